r"""The frozen result of a formulation: :class:`EquationsOfMotion`.

Internally the equations live in a straight-line program (named intermediates).
The SymPy-convention matrices (``mass_matrix``, ``forcing``, ``*_full``) are
explicit expressions in the model's own symbols, built on first access and
cached: a compatibility view for code written for SymPy's ``KanesMethod``
(``sm.lambdify``, ``me.msubs``, ``.subs``, ``.xreplace`` work on them).
Building them costs time linear in the number of intermediates (0.1 to 1 s for
a 3D chain of 8 bodies, against some 30 s for SymPy's own derivation);
their expression *trees* can be larger than SymPy's (equal subtrees are
shared objects), so tree-walking tools such as ``sm.lambdify`` (use
``cse=True``) or ``count_ops`` take seconds for large systems.  The numerical
path (:meth:`EquationsOfMotion.numeric`) never builds them.

Conventions (identical to SymPy's ``KanesMethod``)::

    mass_matrix_full * [q'; u'] = forcing_full

    mass_matrix = [k_d; k_dnh]          (o x o)
    forcing     = [f_r~ - n_r~; -f_dnh] (o)

with :math:`k_d = M_{ind} + A_r^T M_{dep}`, :math:`A_r = -B_{dep}^{-1} B_{ind}`
from the velocity constraints :math:`B u + b = 0` and the acceleration
constraints :math:`k_{dnh}\,\dot u + f_{dnh} = 0`.
"""

from __future__ import annotations

from functools import cached_property

import sympy as sm

from ..modeling import constraint_units, description_symbols, state_units
from ..engine import SAMPLE_SEEDS, name_of

__all__ = ["EquationsOfMotion"]

_SIMPLIFY_NODES = 40  # explicit expressions up to this many nodes are trigsimp'ed


def _same(a, b, rtol=1e-9):
    """Equal complex values (both finite) to a relative tolerance."""
    return a == a and b == b and abs(a - b) <= rtol * max(1.0, abs(a), abs(b))


class EquationsOfMotion:
    """Equations of motion of a multibody system; immutable.

    Created by :func:`kanedyn.kane` (or another formulation); do not construct
    directly.

    Attributes
    ----------
    frame : sympy.physics.mechanics.ReferenceFrame
        The inertial frame.
    q_ind, q_dep, u_ind, u_dep, u_aux : tuple of sympy dynamic symbols
        Independent and dependent generalized coordinates and speeds, and
        auxiliary speeds.
    method : str
        Name of the formulation that produced the equations (``"kane"``).
    bodies, loads : tuple
        The SymPy bodies and loads the equations were derived from.
    contacts : tuple of Contact
        Contacts (their forces are found at evaluation time, see
        :meth:`NumericModel.contact_dynamics`).
    name, title : str or None
        The model's name and one-line description where a model definition
        gave them (:meth:`kanedyn.models.ModelDefinition.derive`); plots use
        them.
    """

    name = None
    title = None
    _declared_units = None
    _declared_gravity = None

    _FIELDS = ("spec", "program", "table", "kinematics", "explicit_kinematics",
               "qdot", "kinematic_matrices", "mass", "active", "remainder",
               "vel_B", "vel_c", "acc_K", "acc_f", "config", "aux_K", "aux_f",
               "kinetic", "potential", "body_terms", "inertial", "load_vectors",
               "identified", "multiplier_names", "contact_terms", "method")

    def __init__(self):
        raise TypeError("EquationsOfMotion is created by kanedyn.kane(...)")

    @classmethod
    def _from_derivation(cls, **fields):
        missing = set(cls._FIELDS) - set(fields)
        if missing:
            raise TypeError(f"missing fields {sorted(missing)}")
        self = object.__new__(cls)
        for name in cls._FIELDS:
            object.__setattr__(self, "_" + name, fields[name])
        spec = fields["spec"]
        for name in ("frame", "q_ind", "q_dep", "u_ind", "u_dep", "u_aux", "bodies",
                     "loads", "contacts"):
            object.__setattr__(self, name, getattr(spec, name))
        object.__setattr__(self, "method", fields["method"])
        # the description's own symbols, read now: the SymPy objects may change later
        object.__setattr__(self, "_description_symbols", description_symbols(spec))
        return self

    def _label(self, name=None, title=None, units=None, gravity=None):
        """Set the model's name, title, declared units and gravity (3 numbers,
        inertial components, m/s^2; once, by a model definition that derived
        the equations); returns ``self``."""
        for key, value in (("name", name), ("title", title), ("_declared_units", units),
                           ("_declared_gravity", gravity)):
            if value is not None:
                object.__setattr__(self, key, value)
        return self

    def __setattr__(self, name, value):
        raise AttributeError("EquationsOfMotion is immutable")

    def __getstate__(self):
        """Pickled without the cached views (explicit matrices, linearization
        terms): they are rebuilt on first use."""
        cls = type(self)
        return {k: v for k, v in self.__dict__.items()
                if k != "_linearization_cache"
                and not isinstance(getattr(cls, k, None), cached_property)}

    def __setstate__(self, state):
        self.__dict__.update(state)

    def __delattr__(self, name):
        raise AttributeError("EquationsOfMotion is immutable")

    def __repr__(self):
        return (f"<EquationsOfMotion ({self.method}): {len(self.q)} coordinates "
                f"({len(self.q_dep)} dependent), {len(self.u)} speeds "
                f"({len(self.u_dep)} dependent), {len(self.u_aux)} auxiliary, "
                f"{len(self._program)} intermediates>")

    # ------------------------------------------------------------- symbols
    @property
    def q(self):
        """Generalized coordinates, independent then dependent."""
        return self.q_ind + self.q_dep

    @property
    def u(self):
        """Generalized speeds, independent then dependent."""
        return self.u_ind + self.u_dep

    @property
    def state(self):
        """The state vector ``[q, u]`` (as dynamic symbols)."""
        return self.q + self.u

    @property
    def state_names(self):
        return tuple(name_of(s) for s in self.state)

    @cached_property
    def state_units(self):
        """``{state name: unit or None}``: rad, m, rad/s, m/s as the kinematics
        tell (:func:`kanedyn.modeling.state_units`), declared units first;
        ``None`` where they do not tell."""
        return state_units(self._spec, self._declared_units)

    @cached_property
    def constraint_units(self):
        """Units of the configuration and velocity constraints, ``(list, list)``
        (``None`` where unknown)."""
        return constraint_units(self._spec, self.state_units)

    @property
    def kd_eqs(self):
        """The kinematic differential equations as given."""
        return self._spec.kd_eqs

    def _all_outputs(self):
        out = list(self._qdot)
        for row in self._mass:
            out.extend(row)
        out.extend(self._active)
        out.extend(self._remainder)
        for row in self._vel_B:
            out.extend(row)
        out.extend(self._vel_c)
        for row in self._acc_K:
            out.extend(row)
        out.extend(self._acc_f)
        out.extend(self._config)
        for c in self._contact_terms:
            out.extend([c.gap, c.grad_norm, c.normal_rate, *c.normal, *c.velocity,
                        *c.acceleration])
            out.extend(e for row in c.jacobian for e in row)
        return out

    def _leaf_symbols(self, exprs):
        prog = self._program
        found = set()
        for e in exprs:
            found |= prog.deps(e)
        return found

    @cached_property
    def constants(self):
        """Constant symbols the equations of motion depend on, sorted by name.

        Includes the symbols of contact friction and restitution coefficients.
        """
        leaves = self._leaf_symbols(self._all_outputs())
        for contact in self.contacts:
            for value in contact.coefficients.values():
                leaves |= sm.sympify(value, strict=True).free_symbols
        table = self._table
        consts = [s for s in leaves if not table.is_dynamic(s) and s != table.t
                  and s not in table.qdot_raw]
        return tuple(sorted(consts, key=str))

    @cached_property
    def parameters(self):
        """Every constant symbol of the model description, sorted by name.

        The symbols of the bodies (masses, inertia dyadics, mass-centre
        positions), of every point position and velocity and frame
        orientation reachable from the bodies and loads, of the loads,
        kinematic differential equations, constraints, potential energy,
        contacts and vector constraints, and of the equations themselves.
        :attr:`constants` is the subset the equations of motion need; a
        parameter can drop out (the length of a link beyond the last body,
        ``g`` for a link turning about the vertical).
        :meth:`numeric` accepts a value for every parameter and requires one
        for every constant.
        """
        found = set(self._description_symbols) | set(self.constants)
        return tuple(sorted(found, key=str))

    @cached_property
    def specified(self):
        """Specified inputs (functions of time, and derivatives) the equations need."""
        leaves = self._leaf_symbols(self._all_outputs())
        table = self._table
        return tuple(ext for ext, int_ in table.specified.items() if int_ in leaves)

    # ---------------------------------------------------- explicit views
    @cached_property
    def _explicit_memo(self):
        """Explicit values of intermediates, in the model's dynamic symbols."""
        return dict(self._table._ext)

    @cached_property
    def _raw_memo(self):
        """The same, built without SymPy's automatic simplification."""
        return dict(self._table._ext)

    @cached_property
    def _size_memo(self):
        return {}

    def _explicit(self, expr):
        """Explicit expression in the model's symbols.

        Every intermediate is expanded once, from its parents' explicit
        values, and the base symbols are mapped back to the model's dynamic
        symbols on the way (cost linear in the number of intermediates).  The
        size of the result is known beforehand: results of at most
        ``_SIMPLIFY_NODES`` tree nodes are built by SymPy's evaluating
        constructors and, if they contain squares of sines or cosines, passed
        through ``trigsimp`` (inertial components leave ``sin**2 + cos**2``
        patterns that it removes cheaply); larger
        ones are built unevaluated (``evaluate=False``: sums, products and
        powers as the program writes them, several times faster; any
        substitution or ``doit()`` evaluates them).
        """
        prog = self._program
        if prog.tree_size(expr, memo=self._size_memo) > _SIMPLIFY_NODES:
            return prog.expand(expr, memo=self._raw_memo, evaluate=False)
        value = prog.expand(expr, memo=self._explicit_memo)
        if any(isinstance(p.base, (sm.sin, sm.cos)) and p.exp.is_even
               for p in value.atoms(sm.Pow)):
            value = sm.trigsimp(value)
        return value

    def _explicit_matrix(self, rows, reduce=False):
        """Explicit matrix of compact ``rows``; ``reduce``: see
        :meth:`_without_spurious_coordinates`."""
        rows = [list(r) for r in rows]
        if not rows:
            return sm.Matrix()
        flat = [e for row in rows for e in row]
        if reduce:
            flat = self._without_spurious_coordinates(flat)
        return sm.Matrix(len(rows), len(rows[0]), [self._explicit(e) for e in flat])

    def _without_spurious_coordinates(self, exprs):
        """``exprs`` with the coordinates they do not depend on set to zero.

        The compact equations are written in the inertial frame, so an entry
        such as a link's own mass-matrix term formally contains every
        rotation of the chain above it, which cancel.  Coordinates an entry
        does not depend on (complex-step derivatives at two random points)
        are set to zero, and the result is kept where its values at the
        random points equal the original's: explicit entries then are about
        as small as those of a derivation in body frames.
        """
        prog = self._program
        q = set(self._table.q)
        found = prog.insensitive(exprs, q)
        out = []
        for e, drop in zip(exprs, found):
            if drop:
                reduced = e  # one coordinate at a time: shared between entries
                for x in (s for s in self._table.q if s in drop):
                    reduced = prog.subs(reduced, {x: 0})
                if all(_same(a, b) for seed in SAMPLE_SEEDS
                       for a, b in zip(prog.shadow([e], seed), prog.shadow([reduced], seed))):
                    e = reduced
            out.append(e)
        return out

    def kindiffdict(self):
        """Mapping ``{q': expression in u}`` (as SymPy's ``kindiffdict``)."""
        t = self._table.t
        return {q.diff(t): self._explicit(e) for q, e in zip(self.q, self._qdot)}

    @cached_property
    def _ars(self):
        """Compact :math:`A_r = -B_{dep}^{-1} B_{ind}` (m x p)."""
        p = len(self.u_ind)
        if not self.u_dep:
            return sm.Matrix(0, p, [])
        B = sm.Matrix(self._vel_B)
        sol = -B[:, p:].LUsolve(B[:, :p])
        return sol.applyfunc(lambda e: self._program.let(e, "Ar"))

    def _reduced(self, rows):
        """``rows[ind] + A_r^T rows[dep]`` for an o-row matrix."""
        rows = sm.Matrix(rows)
        p = len(self.u_ind)
        if not self.u_dep:
            return rows
        return rows[:p, :] + self._ars.T * rows[p:, :]

    @cached_property
    def _compact_mass_matrix(self):
        k_d = self._reduced([list(r) for r in self._mass])
        if self.u_dep:
            k_d = k_d.col_join(sm.Matrix(self._acc_K))
        return k_d

    @cached_property
    def _compact_forcing(self):
        f = sm.Matrix([a - n for a, n in zip(self._active, self._remainder)])
        f = self._reduced(f)
        if self.u_dep:
            f = f.col_join(-sm.Matrix(self._acc_f))
        return f

    @cached_property
    def mass_matrix(self):
        """Mass matrix of the dynamic (and acceleration-constraint) equations, o x o.

        Explicit (SymPy's ``KanesMethod.mass_matrix``), built on first access
        and cached; see the module notes for the cost.  Entries larger than a
        few dozen nodes are built unevaluated (``evaluate=False``); their
        values are the same, and any substitution evaluates them.
        """
        return self._explicit_matrix(self._compact_mass_matrix.tolist(), reduce=True)

    @cached_property
    def forcing(self):
        """Forcing vector matching :attr:`mass_matrix`, o x 1 (explicit, as
        :attr:`mass_matrix`)."""
        return self._explicit_matrix(self._compact_forcing.tolist())

    @cached_property
    def mass_matrix_kin(self):
        """Coefficient matrix of q' in the kinematic equations (identity if explicit)."""
        n = len(self.q)
        if self._explicit_kinematics:
            return sm.eye(n)
        K, _, _ = self._kinematic_matrices
        return self._table.external_matrix(K)

    @cached_property
    def forcing_kin(self):
        """Right-hand side of the kinematic equations."""
        if self._explicit_kinematics:
            return sm.Matrix([self._explicit(e) for e in self._qdot])
        _, Ku, f = self._kinematic_matrices
        return self._table.external_matrix(-(Ku * sm.Matrix(self._table.u) + f))

    @cached_property
    def mass_matrix_full(self):
        """Block-diagonal ``[[mass_matrix_kin, 0], [0, mass_matrix]]``, (n + o) x (n + o).

        As SymPy's ``KanesMethod.mass_matrix_full`` (explicit; built on first
        access, in time linear in the number of intermediates, and cached).
        For numbers use :meth:`numeric`, or ``sm.lambdify(..., cse=True)``.
        """
        n, o = len(self.q), len(self.u)
        return self.mass_matrix_kin.row_join(sm.zeros(n, o)).col_join(
            sm.zeros(o, n).row_join(self.mass_matrix))

    @cached_property
    def forcing_full(self):
        """``[forcing_kin; forcing]``, (n + o) x 1, as SymPy's ``forcing_full``."""
        return self.forcing_kin.col_join(self.forcing)

    @cached_property
    def generalized_active_forces(self):
        r"""Generalized active forces :math:`\tilde F_r` (reduced as SymPy's ``fr``)."""
        return self._explicit_matrix(self._reduced(
            sm.Matrix(self._active)).tolist())

    @cached_property
    def generalized_inertia_forces(self):
        r"""Generalized inertia forces :math:`\tilde F^*_r` (SymPy's ``frstar``)."""
        udot = sm.Matrix(self._table.udot)
        frstar = -(sm.Matrix([list(r) for r in self._mass]) * udot
                   + sm.Matrix(self._remainder))
        return self._explicit_matrix(self._reduced(frstar).tolist())

    def inverse_dynamics(self):
        r"""Generalized forces needed on the independent speeds, symbolically.

        :math:`\tau = -(\tilde F_r + \tilde F^*_r)`, the forces that, added to
        the generalized active forces of the independent speeds, make
        Kane's equations hold for given :math:`q, u, \dot u`: linear in
        :math:`\dot u` (for closed chains the dependent rates appear; they
        follow from the acceleration constraints).  Explicit expressions, as
        :attr:`generalized_inertia_forces`: for large systems evaluate them
        numerically, without expanding, with
        ``eom.numeric(...).inverse_dynamics(t, q, u, udot)``
        (:meth:`kanedyn.NumericModel.inverse_dynamics`).

        Returns
        -------
        sympy.Matrix, shape (len(u_ind), 1)
        """
        return -(self.generalized_active_forces + self.generalized_inertia_forces)

    @cached_property
    def auxiliary_equations(self):
        r"""Auxiliary equations :math:`F_a + F^*_a = 0`, one per auxiliary speed.

        They contain the accelerations :math:`\dot u` and the constraint-force
        symbols the auxiliary speeds expose.
        """
        if not self.u_aux:
            raise ValueError("no auxiliary speeds (u_auxiliary) were given, so there "
                             "are no auxiliary equations")
        udot = sm.Matrix(self._table.udot)
        rows = sm.Matrix(self._aux_K) * udot + sm.Matrix(self._aux_f)
        return self._explicit_matrix(rows.tolist())

    @cached_property
    def partial_velocities(self):
        """Partial velocities and angular velocities, per body.

        Returns
        -------
        dict
            ``{body name: (velocities, angular_velocities)}``, each a list of
            SymPy ``Vector`` in the inertial frame, one per speed of
            ``u + u_aux``.
        """
        out = {}
        for terms in self._body_terms:
            vs = [self._as_vector(v) for v in terms.partial_velocities]
            ws = [self._as_vector(w) for w in terms.partial_angular_velocities]
            out[terms.body.name] = (vs, ws)
        return out

    @property
    def multiplier_names(self):
        """Names of the velocity constraints' multipliers, one per constraint.

        Constraints in vector form give them their own names (the identified
        force's); others are ``lambda_<i>``.
        """
        return self._multiplier_names

    @cached_property
    def identified_forces(self):
        """Constraint forces and torques identified by vector constraints.

        Returns
        -------
        dict
            ``{name: [(kind, location, vector, body), ...]}``: ``kind`` is
            "force" (``location`` the point it acts at) or "torque"
            (``location`` the frame); ``vector`` the force or torque per unit
            multiplier as a SymPy ``Vector`` in the inertial frame; ``body``
            the body acted on when the constraint names it, else ``None``.
            Reactions on frames with prescribed motion are omitted.
        """
        return {name: [(a.kind, a.location, self._as_vector(a.vector), a.body)
                       for a in actions if not a.ground]
                for name, actions in self._identified}

    def _as_vector(self, comps):
        N = self.frame
        x, y, z = (self._explicit(c) for c in comps)
        return x * N.x + y * N.y + z * N.z

    @cached_property
    def kinetic_energy(self):
        """Kinetic energy, explicit."""
        return self._explicit(self._kinetic)

    @cached_property
    def potential_energy(self):
        """Potential energy if the model declared one, else ``None``."""
        return None if self._potential is None else self._explicit(self._potential)

    @property
    def scheme(self):
        """The constraint scheme its numerical models use by default.

        A :class:`kanedyn.schemes.Scheme`: how the accelerations are found
        from the mass matrix, forcing and constraints, and what is done about
        constraint drift; :meth:`numeric` takes ``scheme=`` to choose another.
        """
        from ..numerics.schemes import as_scheme  # a facade of the numerics layer
        return as_scheme(getattr(self, "_scheme", None) or "elimination")

    # --------------------------------------------------------- inspection
    def operation_counts(self):
        """Operation counts of the compact (shared-intermediate) equations.

        Returns
        -------
        dict
            ``mass_matrix``, ``forcing`` (generalized active and inertia
            forces, kinematic equations), ``both`` (the two counted jointly,
            shared intermediates once), ``constraints`` (constraint matrices
            and residual terms), ``all`` (everything the right-hand side
            evaluates, jointly), ``all_cse`` (``all`` after the joint common
            subexpression elimination the code generators apply) and
            ``intermediates`` (of ``all``), and ``kinds``: the operations of
            ``all_cse`` by kind (``multiplications``, ``additions``,
            ``powers``, ``functions``).
        """
        prog = self._program
        M = [e for row in self._mass for e in row]
        F = list(self._active) + list(self._remainder) + list(self._qdot)
        C = ([e for row in self._vel_B for e in row] + list(self._vel_c)
             + [e for row in self._acc_K for e in row] + list(self._acc_f))
        everything = M + F + C
        memo = {}  # the intermediates the counts share, counted once
        kinds = prog.operation_kinds(everything, cse=True)
        return {"mass_matrix": prog.count_ops(M, memo=memo),
                "forcing": prog.count_ops(F, memo=memo),
                "both": prog.count_ops(M + F, memo=memo),
                "constraints": prog.count_ops(C, memo=memo),
                "all": prog.count_ops(everything, memo=memo),
                "all_cse": sum(kinds.values()), "kinds": kinds,
                "intermediates": len(prog.needed(everything))}

    def to_latex(self, explicit=None, max_ops=400):
        r"""LaTeX of the kinematic and dynamic equations.

        Parameters
        ----------
        explicit : bool, optional
            Print explicit expressions (default when they are small) or the
            compact form with its intermediates listed.
        max_ops : int
            Size above which ``explicit=None`` chooses the compact form.
        """
        from ._latex import equations_latex
        return equations_latex(self, explicit=explicit, max_ops=max_ops)

    def to_text(self, explicit=False):
        """Plain text of the kinematic and dynamic equations, one per line.

        Parameters
        ----------
        explicit : bool
            Explicit expressions in the model's symbols instead of the compact
            form (intermediates ``z0, z1, ...`` listed once, the equations in
            terms of them).
        """
        from ._text import equations_text
        return equations_text(self, explicit=explicit)

    def _repr_html_(self):
        """Notebook display: sizes, constants, operation count; equations of small models.

        The equations are included as LaTeX (:meth:`to_latex`, typeset by the
        notebook) when that is short (at most 4000 characters); for larger
        models the display names :meth:`to_latex` and :meth:`to_text`.
        """
        import html as _html
        from .._html import box, names, table
        prog = self._program
        terms = ([e for row in self._mass for e in row] + list(self._active)
                 + list(self._remainder) + list(self._qdot)
                 + [e for row in self._vel_B for e in row] + list(self._vel_c)
                 + [e for row in self._acc_K for e in row] + list(self._acc_f))
        rows = [("formulation", self.method),
                ("coordinates q", f"{len(self.q)} ({len(self.q_dep)} dependent)"),
                ("speeds u", f"{len(self.u)} ({len(self.u_dep)} dependent)"),
                ("auxiliary speeds", len(self.u_aux)),
                ("configuration constraints", len(self._config)),
                ("velocity constraints", len(self._vel_c)),
                ("constants", names(self.constants)),
                ("specified inputs", names(self.specified)),
                ("bodies", names(getattr(b, "name", b) for b in self.bodies)),
                ("intermediates (right-hand side)", len(prog.needed(terms))),
                ("operations (right-hand side)", prog.count_ops(terms))]
        if self.contacts:
            rows.append(("contacts", len(self.contacts)))
        outputs = list(self._qdot) + list(self._compact_mass_matrix) + list(
            self._compact_forcing)
        latex = None
        if len(prog.needed(outputs)) <= 200:  # else: no LaTeX built at all
            latex = self.to_latex()
        if latex is not None and len(latex) <= 4000:
            equations = "$$" + _html.escape(latex, quote=False) + "$$"
        else:
            equations = ("<p>large equations: <code>eom.to_latex()</code> or "
                         "<code>eom.to_text()</code> shows them in compact form</p>")
        return box(table(rows, caption="equations of motion"), equations,
                   title=f"EquationsOfMotion ({self.method}): {', '.join(self.state_names)}"
                   if len(self.state_names) <= 12 else f"EquationsOfMotion ({self.method})")

    def _repr_latex_(self):
        return "$\\displaystyle " + self.to_latex() + "$"

    # ------------------------------------------------------------ numerics
    def numeric(self, constants=None, specified=None, backend="numpy", **options):
        """Numerical model: ``rhs(t, y)``, mass matrix, constraints, energies.

        Parameters
        ----------
        constants : dict
            ``{symbol or name: value}`` for every symbol in :attr:`constants`;
            values for the other :attr:`parameters` (symbols of the
            description the equations do not need) are accepted and unused
            (they do not appear in the model's ``constants``).  A name is
            matched against the symbols' names only; a key that is no
            parameter raises :class:`~kanedyn.ModelError` with the closest
            names.
        specified : dict, optional
            Values of the specified inputs in :attr:`specified`: a number, a
            SymPy expression in ``t`` (substituted exactly, derivatives included),
            a callable ``f(t)`` or a callable ``f(t, y)``.
        backend : {"numpy", "c"}
            Code generator: interpreted NumPy code, or C compiled into an
            extension module on first use and cached on disk (falls back to
            "numpy" with a warning when no C compiler is available).
        cse : bool, optional
            Eliminate common subexpressions of the generated code jointly
            (default: on for "c" except in the articulated-body pass of a
            tree, where it gains nothing; off for "numpy").
        scheme : str or Scheme, optional
            Constraint scheme (:mod:`kanedyn.schemes`); default :attr:`scheme`.

        Returns
        -------
        NumericModel
        """
        from ..numerics import build_numeric_model
        return build_numeric_model(self, constants or {}, specified or {}, backend,
                                   **options)

    def save(self, path):
        """Write these equations to a file that :func:`kanedyn.load` reads back.

        A zip archive of JSON (format described in :mod:`kanedyn.io._saved`):
        SymPy expressions are stored as trees of allow-listed classes, so
        loading evaluates no text and runs no code from the file.  Numerical
        models are not saved (they are rebuilt by :meth:`numeric`; pickle
        them to ship them between processes).

        Parameters
        ----------
        path : str or os.PathLike
            The file to write (conventionally ``*.kdeom``).

        Returns
        -------
        pathlib.Path
        """
        from ..io import save_equations  # a facade of the io layer
        return save_equations(self, path)

    def linearize(self, op_point=None, A_and_B=True, constants=None, specified=None,
                  t=0.0, simplify=False, linear_solver="LU"):
        r"""Linearize about an operating point, as SymPy's ``KanesMethod.linearize``.

        Parameters
        ----------
        op_point : dict or iterable of dicts, optional
            Values of coordinates, speeds, inputs and optionally the speeds'
            time derivatives :math:`\dot u` (used as given, as SymPy does;
            computed from the equations of motion when absent).
        A_and_B : bool
            ``True`` (kanedyn's default): ``(A, B, r)`` of
            :math:`\delta\dot x_i = A\,\delta x_i + B\,\delta r`, with
            :math:`x_i = [q_{ind}; u_{ind}]`.  ``False`` (SymPy's default):
            ``(M, A, B, r)`` of the implicit form
            :math:`M[\delta\dot q;\delta\dot u] = A\,\delta x_i + B\,\delta r`,
            the matrices SymPy returns.
        constants, specified : dict, optional
            With ``constants`` the result is numerical (NumPy arrays).
        t : float
            Time of the operating point (numerical path).
        simplify, linear_solver
            SymPy's options (symbolic path).

        Returns
        -------
        tuple
            ``(A, B, r)``, or ``(M, A, B, r)`` with ``A_and_B=False``: SymPy
            matrices and ``r`` a column matrix of the inputs (symbolic path), or
            NumPy arrays and ``r`` a list of the inputs' names (with
            ``constants``).  Dependent coordinates and speeds are eliminated:
            ``A`` is square of size ``n_q - n_q_dep + n_u - n_u_dep``.

        See Also
        --------
        kanedyn.NumericModel.linearize : the same about a numerical state.

        Notes
        -----
        The operating point, the elimination of dependent coordinates and speeds
        and the comparison with SymPy's ``Linearizer`` are described on the
        documentation's linearization page (``docs/linearization.md``).
        """
        from ..numerics import linearize_symbolic
        return linearize_symbolic(self, op_point=op_point, A_and_B=A_and_B,
                                  constants=constants, specified=specified, t=t,
                                  simplify=simplify, linear_solver=linear_solver)
