r"""Orthogonalized generalized speeds (Lesser 1992).

Kane's equations are the projections of the Newton–Euler equations onto the
partial velocities, the tangent vectors of the configuration manifold.  The
kinetic energy :math:`T = \tfrac12 u^T M(q) u` makes the mass matrix the
metric of that manifold.  With the Cholesky factorization
:math:`M = L L^T` and the new generalized speeds

.. math::

    u^* = L^T u ,

the partial velocities of the new speeds are orthonormal in that metric, so
the mass matrix in :math:`u^*` is the identity and :math:`T = \tfrac12
|u^*|^2` (for kinetic energies quadratic in the speeds).  This module builds a
numerical model whose state is :math:`(q, u^*)`; models with dependent speeds
are orthogonalized on their admissible speeds by
:mod:`kanedyn.numerics._orthogonal_constrained`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .backends._python import compile_python, generate_python
from .._errors import MissingValueError, ModelError
from ._model import StateLayout

__all__ = ["orthogonalize_speeds", "OrthogonalSpeedsModel", "MassMatrices"]


def _frozen(a):
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class MassMatrices:
    r"""The mass matrix in the original and in the orthogonalized speeds.

    Attributes
    ----------
    original : ndarray, shape (o, o)
        :math:`M(q)`, kg, kg m or kg m^2 per entry (as the speeds).
    orthogonalized : ndarray, shape (p, p)
        :math:`M^* = L^{-1} M_r L^{-T}`, dimensionless
        (the identity along the motion, to round-off).
    factor : ndarray, shape (p, p)
        The lower-triangular :math:`L` used (:math:`L L^T = M_r` along the
        motion; the reference factor :math:`L_0` for a fixed one).
    reduced : ndarray, shape (p, p)
        The metric that is factorized: :math:`M_r = C^T M C` on the speeds
        the constraints admit (:math:`u = C u_i` plus a part fixed by the
        constraints); :math:`M` itself (:math:`C = I`, ``p = o``) without
        dependent speeds.
    """

    original: np.ndarray
    orthogonalized: np.ndarray
    factor: np.ndarray
    reduced: np.ndarray

    @property
    def identity_error(self):
        r"""Largest entry of :math:`|M^* - I|`."""
        n = self.orthogonalized.shape[0]
        return float(np.max(np.abs(self.orthogonalized - np.eye(n)), initial=0.0))


def _solve(A, B):
    """``A^-1 B`` for a small triangular ``A``.

    NumPy's LU solve: SciPy's triangular solver on C-ordered right-hand
    sides can take milliseconds in threaded BLAS, which dominates ``rhs``.
    """
    return np.linalg.solve(A, B)


def _congruence(L, M):
    """:math:`L^{-1} M L^{-T}` for a symmetric ``M``."""
    return _solve(L, _solve(L, M).T)


def _phi(X):
    """Strictly lower triangle of ``X`` plus half its diagonal."""
    return np.tril(X, -1) + 0.5 * np.diag(np.diag(X))


class OrthogonalSpeedsModel(StateLayout):
    r"""A numerical model in the orthogonalized speeds :math:`u^* = L^T u`.

    Made by :func:`orthogonalize_speeds`; it has the numerical contract of
    :class:`kanedyn.NumericModel` that :func:`kanedyn.simulate` uses
    (``rhs(t, y)``, ``state``, ``state_names``, energies, ...), with the
    state :math:`y^* = [q, u^*]`.

    Attributes
    ----------
    original : NumericModel
        The model in the original speeds.
    along_motion : bool
        True when :math:`L = L(q)` follows the configuration; False for a
        constant factor :math:`L_0`.
    reference_factor : ndarray or None
        :math:`L_0` (shape (o, o)) for a constant factor, else ``None``.
    state_names : tuple of str
        Coordinates, then the new speeds ``<speed>_star``.
    n_q, n_u : int
        Numbers of coordinates and speeds.
    """

    def __init__(self, original, reference_factor, sources, reference=None, time=None,
                 time_dependent=False):
        self.original = original
        self._at = None if reference is None else _frozen(reference)
        self._at_time = time
        self._time_dependent = time_dependent
        self.reference_factor = None if reference_factor is None else _frozen(reference_factor)
        self.along_motion = reference_factor is None
        self._sources = sources
        self._compile()
        n = original.n_q
        names = original.state_names
        self.state_names = tuple(names[:n]) + tuple(f"{s}_star" for s in names[n:])
        self.n_q, self.n_u = original.n_q, original.n_u
        self.n_q_dep = self.n_u_dep = 0
        for key in ("constants", "aux_names", "input_names", "has_potential",
                    "has_loads", "identified_names"):
            setattr(self, key, getattr(original, key))
        self.contacts = []
        self.multiplier_names = ()
        self.multiplier_form = False
        self._c = None  # no compiled integration loop: simulate uses solve_ivp

    def _compile(self):
        self._fn = {name: compile_python(src, name) for name, src in self._sources.items()}

    def __getstate__(self):
        return {k: v for k, v in self.__dict__.items() if k != "_fn"}

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._compile()

    def __repr__(self):
        kind = "along the motion" if self.along_motion else "constant factor"
        return (f"<OrthogonalSpeedsModel ({kind}): {self.n_q} coordinates, "
                f"{self.n_u} speeds>")

    # ------------------------------------------------------------ basics
    def state(self, values, t=0.0, what="initial value"):
        """A state array ``y*`` from an array or ``{name: value}`` (new names).

        Use :meth:`from_original` to start from a state in the original speeds.
        """
        if isinstance(values, dict):
            y = np.full(self.n_states, np.nan)
            for key, value in values.items():
                y[self.index(key)] = float(value)
            missing = [self.state_names[i] for i in np.flatnonzero(np.isnan(y))]
            if missing:
                raise MissingValueError(f"missing {what}(s) for " + ", ".join(missing))
            return y
        y = self._check_y(values)
        bad = [self.state_names[i] for i in np.flatnonzero(~np.isfinite(y))]
        if bad:
            raise ValueError(f"{what}s are not finite for " + ", ".join(bad))
        return y

    def consistent_state(self, t, y, **_):
        """``y`` itself: the model has no dependent coordinates or speeds."""
        return self._check_y(y)

    # ------------------------------------------------------ factor, maps
    def _args(self):
        return self.original._p

    def _mass(self, t, y):
        """:math:`M(q)` (only ``y[:n_q]`` matters)."""
        return self._fn["ortho_mass"](t, y, self._args(), ())[0]

    def _factor(self, t, y):
        if not self.along_motion:
            return self.reference_factor
        return np.linalg.cholesky(self._mass(t, y))

    def _speeds(self, L, u_star):
        return _solve(L.T, u_star)

    def to_original(self, y_star, t=None):
        r"""The state ``[q, u]`` of a state ``[q, u*]``: :math:`u = L^{-T} u^*`.

        Parameters
        ----------
        y_star : array_like, shape (n_states,) or (n_states, N)
            One state, or one per column (e.g. ``result.y``).
        t : float or array_like, shape (N,), optional
            Time(s), s; required when the mass matrix depends on time.
        """
        return self._map(y_star, t, inverse=True)

    def from_original(self, y, t=None):
        r"""The state ``[q, u*]`` of a state ``[q, u]``: :math:`u^* = L^T u`.

        Parameters
        ----------
        y : array_like, shape (n_states,) or (n_states, N)
        t : float or array_like, shape (N,), optional
            Time(s), s; required when the mass matrix depends on time.
        """
        return self._map(y, t, inverse=False)

    def _map(self, y, t, inverse):
        if t is None:
            if self.along_motion and self._time_dependent:
                raise ValueError("the mass matrix depends on time: give the time(s) t "
                                 "of the state(s)")
            t = 0.0
        y = np.array(y, dtype=float)
        given, wanted = (self, self.original) if inverse else (self.original, self)
        if y.ndim == 2 and y.shape[0] == given.n_states:
            if not y.shape[1]:
                return np.zeros((wanted.n_states, 0))
            ts = np.broadcast_to(np.asarray(t, dtype=float), (y.shape[1],))
            return np.column_stack([self._map(y[:, k], ts[k], inverse)
                                    for k in range(y.shape[1])])
        return self._map_one(given._check_y(y), t, inverse)

    def _map_one(self, y, t, inverse):
        n = self.n_q
        L = self._factor(t, y)
        out = y.copy()
        out[n:] = self._speeds(L, y[n:]) if inverse else L.T @ y[n:]
        return out

    def cholesky_factor(self, t, y):
        r"""The factor :math:`L` and its time derivative :math:`\dot L` at ``y*``.

        Along the motion :math:`\dot L = L\,\Phi(L^{-1}\dot M L^{-T})`, with
        :math:`\Phi` the strictly lower triangle plus half the diagonal and
        :math:`\dot M` exact (generated from the equations); zero for a
        constant factor.

        Returns
        -------
        L, L_dot : ndarray, shape (o, o)
            Lower triangular; units of :math:`\sqrt{M}` and per second.
        """
        y = self._check_y(y)
        L = self._factor(t, y)
        if not self.along_motion:
            return L, np.zeros_like(L)
        u = self._speeds(L, y[self.n_q:])
        yo = np.concatenate([y[:self.n_q], u])
        _, _, M_dot = self._fn["ortho_dynamics"](t, yo, self._args(),
                                                  self.original._r(t, yo))
        return L, self._factor_rate(L, M_dot)

    @staticmethod
    def _factor_rate(L, M_dot):
        X = _congruence(L, M_dot)
        return L @ _phi(0.5 * (X + X.T))

    # ---------------------------------------------------------- dynamics
    def _terms(self, t, y):
        """``L, u, q', M*, f*`` at ``y*`` (see :meth:`forcing`)."""
        y = self._check_y(y)
        n = self.n_q
        if self.along_motion:
            L = np.linalg.cholesky(self._mass(t, y))
            u = self._speeds(L, y[n:])
            yo = np.concatenate([y[:n], u])
            qd, f, M_dot = self._fn["ortho_dynamics"](t, yo, self._args(),
                                                      self.original._r(t, yo))
            f_star = _solve(L, f) + self._factor_rate(L, M_dot).T @ u
            return L, u, qd, None, f_star
        L = self.reference_factor
        u = self._speeds(L, y[n:])
        yo = np.concatenate([y[:n], u])
        qd, M, f = self._fn["ortho_dynamics"](t, yo, self._args(), self.original._r(t, yo))
        return L, u, qd, _congruence(L, M), _solve(L, f)

    def rhs(self, t, y):
        r"""State derivative :math:`[\dot q, \dot u^*]`.

        Along the motion :math:`\dot u^* = L^{-1} f + \dot L^T u`, without a
        linear solve; for a constant factor :math:`M^*\dot u^* = L_0^{-1} f`.
        """
        L, u, qd, M_star, f_star = self._terms(t, y)
        ud = f_star if M_star is None else np.linalg.solve(M_star, f_star)
        return np.concatenate([qd, ud])

    __call__ = rhs

    def mass_matrix(self, t, y):
        r"""Mass matrix in the new speeds, :math:`M^* = L^{-1} M(q) L^{-T}` (o x o).

        Computed from :math:`M(q)` and the factor used, so that it measures
        how far from the identity it is: round-off along the motion, the
        change of configuration for a constant factor.
        """
        return self.mass_matrices(t, y).orthogonalized

    def forcing(self, t, y):
        r"""Forcing :math:`f^*` in the new speeds (o), :math:`M^*\dot u^* = f^*`.

        Along the motion :math:`f^* = L^{-1} f + \dot L^T u` (with
        :math:`M^* = I`); for a constant factor :math:`f^* = L_0^{-1} f`.
        """
        return self._terms(t, y)[4]

    def mass_matrix_full(self, t, y):
        """``[[I, 0], [0, mass_matrix]]``."""
        out = np.eye(self.n_states)
        out[self.n_q:, self.n_q:] = self.mass_matrix(t, y)
        return out

    def forcing_full(self, t, y):
        """``[q', forcing]``."""
        _, _, qd, _, f_star = self._terms(t, y)
        return np.concatenate([qd, f_star])

    def mass_matrices(self, t, y):
        r"""The mass matrix in the original and in the new speeds at ``y*``.

        Parameters
        ----------
        t : float
            Time, s.
        y : array_like, shape (n_states,)
            State ``[q, u*]`` (only ``q`` matters).

        Returns
        -------
        MassMatrices
            ``original`` :math:`M(q)`, ``orthogonalized``
            :math:`L^{-1} M L^{-T}`, ``factor`` :math:`L`; its
            ``identity_error`` is :math:`\max|M^* - I|`.

        Examples
        --------
        >>> import kanedyn as kd
        >>> d = kd.models.build("pendulum")
        >>> ortho = kd.orthogonalize_speeds(d.numeric())
        >>> mm = ortho.mass_matrices(0.0, [0.3, 1.0])
        >>> float(mm.original[0, 0]), float(mm.orthogonalized[0, 0])
        (1.0, 1.0)
        """
        y = self._check_y(y)
        M = self._mass(t, y)
        L = self._factor(t, y)
        return MassMatrices(_frozen(M), _frozen(_congruence(L, M)), _frozen(L), _frozen(M))

    # ------------------------------------------ delegated to the original
    def constraint_residuals(self, t, y):
        """Empty: no dependent coordinates or speeds."""
        return np.zeros(0)

    def energies(self, t, y):
        """``(kinetic, potential)`` energy, J, of the original model at ``y*``."""
        return self.original.energies(t, self.to_original(y, t))

    def kinetic_energy(self, t, y):
        return self.energies(t, y)[0]

    def potential_energy(self, t, y):
        return self.energies(t, y)[1]

    def total_energy(self, t, y):
        return float(sum(self.energies(t, y)))

    @property
    def constraint_force_names(self):
        return self.original.constraint_force_names

    def constraint_forces(self, t, y):
        """Constraint forces (auxiliary speeds) of the original model at ``y*``."""
        return self.original.constraint_forces(t, self.to_original(y, t))

    def multipliers(self, t, y, udot=None):
        return {}

    def with_constants(self, values):
        """The same transformation of the original model with other constants.

        A constant factor is recomputed from the new mass matrix at the same
        reference configuration.
        """
        other = self.original.with_constants(values)
        return orthogonalize_speeds(other, at=None if self.along_motion else self._at,
                                    t=self._at_time)


def _reference_state(model, at):
    """State array of ``at`` (array, or ``{name: value}`` giving all coordinates)."""
    names = model.state_names
    n = model.n_q
    if isinstance(at, dict):
        y = np.zeros(model.n_states)
        given = set()
        for key, value in at.items():
            i = model.index(key)
            y[i] = float(value)
            given.add(i)
        missing = [names[i] for i in range(n) if i not in given]
        if missing:
            raise MissingValueError("at: missing value(s) of the coordinate(s) "
                                    + ", ".join(missing))
        return y
    y = np.array(at, dtype=float)
    if y.shape not in ((model.n_states,), (n,)):
        raise ValueError(f"at must have {model.n_states} entries ({', '.join(names)}) "
                         f"or {n} coordinates, got shape {y.shape}")
    y = np.concatenate([y, np.zeros(model.n_states - n)]) if y.shape == (n,) else y
    bad = [names[i] for i in np.flatnonzero(~np.isfinite(y[:n]))]
    if bad:
        raise ValueError("at: values are not finite for " + ", ".join(bad))
    return y


def orthogonalize_speeds(model, at=None, t=None):
    r"""A model in generalized speeds whose mass matrix is the identity.

    With the Cholesky factorization :math:`M(q) = L L^T` of the mass matrix
    the new speeds are :math:`u^* = L^T u` (Lesser 1992): their partial
    velocities are orthonormal in the kinetic-energy metric, so Kane's
    equations become :math:`\dot u^* = f^*` and, for kinetic energies
    quadratic in the speeds, :math:`T = \tfrac12 |u^*|^2`.

    Along the motion (``at=None``), :math:`L = L(q)`.  Substituting
    :math:`u = L^{-T} u^*` and
    :math:`\dot u = L^{-T}\dot u^* - L^{-T}\dot L^T L^{-T} u^*` into
    :math:`M\dot u = f` gives :math:`L\dot u^* - L\dot L^T u = f`, i.e.

    .. math::

        \dot u^* = L^{-1} f + \dot L^T u, \qquad
        \dot L = L\,\Phi\!\left(L^{-1}\dot M L^{-T}\right),

    where :math:`\Phi(X)` is the strictly lower triangle of :math:`X` plus
    half its diagonal (from :math:`\dot M = \dot L L^T + L \dot L^T`, the
    lower-triangular :math:`L^{-1}\dot L` is :math:`\Phi` of the symmetric
    :math:`L^{-1}\dot M L^{-T}`), and
    :math:`\dot M = \sum_k \partial M/\partial q_k\,\dot q_k +
    \partial M/\partial t` is generated exactly from the equations' program.

    With a reference state (``at=y_ref``) the factor is constant,
    :math:`u^* = L_0^T u` with :math:`M(q_\mathrm{ref}) = L_0 L_0^T`: the mass
    matrix :math:`L_0^{-1} M(q) L_0^{-T}` is the identity at the reference
    configuration only, the kinematic equations become
    :math:`\dot q = \dot q(q, L_0^{-T} u^*)` and
    :math:`\dot u^* = L_0^T M^{-1} f`.

    With dependent speeds (velocity constraints :math:`B u + b = 0`,
    nonholonomic or the rates of configuration constraints) the new speeds
    are orthonormal on the speeds the constraints admit,
    :math:`u = C u_i + u_p` with :math:`C = [I;\ -B_d^{-1}B_i]`: with
    :math:`C^T M C = L L^T`, :math:`v^* = L^T u_i` and the state is
    :math:`[q, v^*]`; see :class:`ConstrainedOrthogonalSpeedsModel`.

    Parameters
    ----------
    model : NumericModel
        Made by ``eom.numeric(...)`` (either backend) in this session: its
        equations are needed.  No contacts; dependent speeds only with
        velocity constraints linear in the speeds.
    at : None, array_like or dict, optional
        ``None``: factor along the motion.  Otherwise the reference state
        (``n_states`` or ``n_q`` entries, or ``{name: value}`` giving every
        coordinate; speeds are not used).
    t : float, optional
        Time of the reference state, s; required (and used) only when the
        mass matrix depends on time (prescribed motion).

    Returns
    -------
    OrthogonalSpeedsModel
        State ``[q, u*]`` with the speeds named ``<speed>_star`` (one per
        independent speed, a :class:`ConstrainedOrthogonalSpeedsModel`, with
        dependent speeds); works with
        :func:`kanedyn.simulate`; :meth:`~OrthogonalSpeedsModel.to_original`
        and :meth:`~OrthogonalSpeedsModel.from_original` map states.

    Raises
    ------
    ModelError
        For contacts, constraints in the multiplier form, dependent
        coordinates without dependent speeds, a mass matrix or
        velocity-constraint matrix that depends on speeds or on a specified
        input given as a number or callable (its rate would not be exact:
        give a SymPy expression in t), or a mass matrix that is not positive
        definite at ``at``.
    ValueError
        For an ``at`` of the wrong length or with non-finite values.

    Notes
    -----
    Specified inputs given as callables ``f(t, y)`` receive the original
    state ``[q, u]``.  The Cholesky factorization costs what the linear solve
    it replaces costs; the point is the form of the equations.

    References
    ----------
    D. Lesser, "A geometric interpretation of Kane's equations", Proc. R. Soc.
    Lond. A 436 (1992) 69-87.

    Examples
    --------
    >>> import numpy as np, kanedyn as kd
    >>> d = kd.models.build("chain3d", n=2)
    >>> ortho = kd.orthogonalize_speeds(d.numeric())
    >>> ortho.state_names
    ('q1', 'q2', 'u1_star', 'u2_star')
    >>> y = ortho.from_original([0.3, -0.2, 1.0, 0.5])
    >>> bool(np.allclose(ortho.mass_matrix(0.0, y), np.eye(2), atol=1e-12))
    True
    """
    eom, functions = _equations_of(model)
    names = model.state_names
    n, o = model.n_q, model.n_u
    if model.n_q_dep and not model.n_u_dep:
        raise ModelError(
            "orthogonalize_speeds: the model has dependent coordinates ("
            + ", ".join(names[n - model.n_q_dep:n]) + ") but no dependent speeds; "
            "give the velocity constraints (the rates of the configuration "
            "constraints) with dependent speeds")
    if model.multiplier_form:
        raise ModelError("orthogonalize_speeds does not support constraints in the "
                         "multiplier form (all speeds in the state); give dependent speeds")
    if model.contacts:
        raise ModelError("orthogonalize_speeds does not support contacts ("
                         + ", ".join(c["name"] for c in model.contacts) + ")")
    prog = eom._program
    args, outputs = functions["dynamics"]
    qdot_out, mass_out, force_out = outputs[0], outputs[1], outputs[2]
    if (qdot_out[0], mass_out[0], force_out[0]) != ((n,), (o, o), (o,)):
        raise ModelError("orthogonalize_speeds: unexpected layout of the model's dynamics "
                         "function (expected q', mass matrix, forcing first)")
    mass = mass_out[1]
    refuse_speed_dependence(eom, args, mass, "the mass matrix")
    if model.n_u_dep:
        from ._orthogonal_constrained import orthogonalize_constrained
        return orthogonalize_constrained(model, at, t)
    mass_args = {"y": args["y"], "p": args["p"], "r": []}
    sources = {"ortho_mass": generate_python(prog, "ortho_mass", mass_args, [mass_out])}
    if at is None:
        mass_dot = ((o, o), [prog.dt(e) for e in mass])
        dyn = [qdot_out, force_out, mass_dot]
    else:
        dyn = [qdot_out, mass_out, force_out]
    sources["ortho_dynamics"] = generate_python(prog, "ortho_dynamics", args, dyn)
    time_dependent = depends_on_time(eom, mass)
    factor = y_ref = None
    if at is not None:
        y_ref, t = reference_of(model, at, t, time_dependent)
        M0 = compile_python(sources["ortho_mass"], "ortho_mass")(t, y_ref, model._p, ())[0]
        factor = reference_factor(M0, model, y_ref)
    return OrthogonalSpeedsModel(model, factor, sources, reference=y_ref, time=t,
                                 time_dependent=time_dependent)


def _equations_of(model):
    """The equations and generated functions behind ``model`` (refused if lost)."""
    eom = getattr(model, "_eom", None)
    functions = getattr(model, "_functions", None)
    if eom is None or functions is None:
        raise ModelError("orthogonalize_speeds needs a model made by eom.numeric(...) in "
                         "this session (an unpickled model has lost its equations)")
    return eom, functions


def refuse_speed_dependence(eom, args, exprs, what):
    """Raise unless ``exprs`` depend only on coordinates, time and constants.

    Their rate along the motion is generated exactly (``Program.dt``), which
    needs them free of speeds and of inputs known only numerically.
    """
    prog, table = eom._program, eom._table
    allowed = set(table.q) | {table.t} | set(args["p"])
    foreign = set()
    for e in exprs:
        foreign |= prog.deps(e) - allowed
    if foreign:
        names = sorted(str(table.external(s)) for s in foreign)
        raise ModelError(
            f"{what} depends on " + ", ".join(names) + ", not only on the "
            "coordinates, time and constants; its rate is needed exactly, so give "
            "specified inputs that enter it as SymPy expressions in t")


def depends_on_time(eom, exprs):
    """Whether any of ``exprs`` depends on time explicitly."""
    prog, t = eom._program, eom._table.t
    return any(t in prog.deps(e) for e in exprs)


def reference_of(model, at, t, time_dependent):
    """``(y_ref, t_ref)``: the reference state and its time (0 when time does not matter)."""
    y_ref = _reference_state(model, at)
    if t is None and time_dependent:
        raise ValueError("the mass matrix depends on time: give the time t of the "
                         "reference state")
    return y_ref, 0.0 if t is None else float(t)


def reference_factor(metric, model, y_ref):
    """Cholesky factor of the metric at the reference state, or a ModelError naming it."""
    try:
        return np.linalg.cholesky(metric)
    except np.linalg.LinAlgError:
        names = model.state_names
        raise ModelError("the mass matrix is not positive definite at the reference "
                         "configuration " + ", ".join(
                             f"{names[i]}={y_ref[i]:.6g}" for i in range(model.n_q))) from None
