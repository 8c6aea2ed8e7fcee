r"""Lagrange's equations, and the augmented (vakonomic) Lagrangean.

Both formulations use the rates of the generalized coordinates as generalized
speeds, :math:`w_i = \dot q_i` (new dynamic symbols named ``<q>_d``).  The
model's own speeds :math:`u`, in which its velocities are written, become
functions of :math:`(q, w)` through its kinematic differential equations
:math:`K\dot q + K_u u + f = 0`:

.. math::

    u = -K_u^{-1}(K w + f).

With the kinetic energy :math:`T(q, w, t)` of all bodies and the generalized
forces :math:`Q_j = \sum F\cdot\partial v_P/\partial w_j + T\cdot\partial
\omega_B/\partial w_j` of all loads (gravity included),

A :class:`kanedyn.FlexibleBody` adds its kinetic energy
:math:`\tfrac12 w^TM_b(\eta)w` (body-frame origin velocity, angular velocity
and modal speeds :math:`w`, :math:`M_b` from its inertia invariants) to
:math:`T`, and its gravity, elastic (:math:`-K\eta`) and damping
(:math:`-D\zeta`) forces, projected with :math:`\partial w/\partial w_j`,
to :math:`Q`; its strain energy is part of the reported potential energy.

``method="lagrange"`` (Lagrange's equations with multipliers, i.e. the
Lagrange–d'Alembert principle) gives

.. math::

    M\dot w = Q + \frac{\partial T}{\partial q}
              - \frac{d}{dt}\frac{\partial T}{\partial w}\Big|_{\dot w = 0}
              + B^T\lambda,\qquad
    M = \frac{\partial^2 T}{\partial w\,\partial w},

with the velocity constraints :math:`c(q, w, t) = 0`, :math:`B = \partial
c/\partial w`, in the same unreduced form as Kane's method (one row per
speed; dependent speeds are eliminated numerically).  The dependent speeds
are the rates of the dependent coordinates where those suit the constraints,
completed by the columns of :math:`B` whose block stays farthest from
singular over random configurations.  Where no choice keeps the block
nonsingular everywhere (a knife edge: the lateral constraint's coefficient
of either planar rate vanishes at some heading), the numerical model solves
for the accelerations and the multipliers together instead.

``method="augmented"`` applies the Euler–Lagrange equations to the augmented
Lagrangean :math:`\tilde L = T - V + \sum_i\lambda_i f_i(q, w, t)` (the
vakonomic model; loads, gravity included, enter as :math:`Q`), with the
multipliers :math:`\lambda_i` as further states:

.. math::

    \begin{bmatrix} M + \sum_i\lambda_i H_i & A^T \\ A & 0 \end{bmatrix}
    \begin{bmatrix}\dot w \\ \dot\lambda\end{bmatrix} =
    \begin{bmatrix} Q + \partial T/\partial q
        - \frac{d}{dt}\partial T/\partial w|_{\dot w=0} - G\lambda \\
        -\dot f|_{\dot w = 0}\end{bmatrix},

where :math:`A = \partial f/\partial w`, :math:`H_i = \partial^2 f_i/\partial
w^2` and :math:`G_{ji} = \frac{d}{dt}(\partial f_i/\partial w_j)|_{\dot w=0} -
\partial f_i/\partial q_j`.  For holonomic constraints (given through their
time derivatives) the two formulations agree when :math:`\lambda(0)` is
consistent; for nonholonomic ones they describe different motions.
"""

from __future__ import annotations

import itertools
import math
import random
from dataclasses import replace

import numpy as np
import sympy as sm

from .._errors import ModelError
from ._flexible import BLOCK_BODIES, flexible_block, flexible_bodies, project
from ._kane import (EquationLabel, _contact_terms, _pivot_rows, body_kinematics,
                    given_velocity_constraints, linear_parts, load_terms)
from ..engine import (SAMPLE_SEEDS, Kinematics, Program, SymbolTable, dot, fast_eval, name_of,
                      random_sampler)
from .._progress import NO_PROGRESS

__all__ = ["derive_lagrange", "derive_augmented", "rate_symbols"]


def rate_symbols(q):
    """The speeds :math:`w_i = \\dot q_i` of these formulations: ``<q>_d``.

    Parameters
    ----------
    q : sequence of dynamicsymbols
        Generalized coordinates.

    Returns
    -------
    tuple of dynamicsymbols
        ``q1 -> q1_d(t)``, one per coordinate, in the same order.
    """
    from sympy.physics.mechanics import dynamicsymbols
    t = dynamicsymbols._t
    return tuple(sm.Function(f"{name_of(s)}_d")(t) for s in q)


def _check_model(spec, method):
    """Reject what the formulation cannot use, naming the symbols at fault."""
    if spec.u_aux:
        names = ", ".join(name_of(s) for s in spec.u_aux)
        raise ModelError(
            f"the {method!r} formulation does not take auxiliary speeds (u_auxiliary: "
            f"{names}): they are a device of Kane's method for exposing constraint "
            "forces; remove them and the loads they carry, expose the forces with "
            "vector constraints (constraints=[kd.PointVelocity(...)]), or use "
            "method='kane'")
    n, o = len(spec.q), len(spec.u)
    if n != o:
        raise ModelError(
            f"the {method!r} formulation uses the coordinates' rates as speeds, so the "
            f"model must have as many generalized speeds as coordinates; it has {n} "
            f"coordinates ({', '.join(name_of(s) for s in spec.q)}) and {o} speeds "
            f"({', '.join(name_of(s) for s in spec.u)}); give one speed per coordinate "
            "and state nonholonomic constraints as velocity_constraints (or vector "
            "constraints)")
    if method == "augmented" and spec.contacts:
        raise ModelError(
            "the 'augmented' formulation does not support contacts ("
            + ", ".join(c.name for c in spec.contacts) + "); use method='lagrange' or "
            "method='kane'")


def _new_symbols(spec, method):
    """The rate speeds ``w``, checked against the model's names."""
    w = rate_symbols(spec.q)
    taken = {name_of(s): s for s in spec.q + spec.u}
    for s in w:
        if name_of(s) in taken:
            raise ModelError(
                f"the {method!r} formulation names the rate of a coordinate "
                f"{name_of(s)}, which the model already uses for {taken[name_of(s)]}; "
                "rename that symbol")
    return w


def _speeds_from_rates(spec, table, prog, method):
    r"""The model's speeds as expressions in (q, w): :math:`u = -K_u^{-1}(Kw + f)`.

    Must be called before ``table.set_qdot`` (q' is read as a plain symbol).
    """
    tmp = {s: sm.Dummy(name_of(s)) for s in spec.u}
    eqs = sm.Matrix([table.internal(sm.sympify(e, strict=True).xreplace(tmp),
                                    EquationLabel(i, e))
                     for i, e in enumerate(spec.kd_eqs)])
    back = dict(zip(table.qdot_raw, (s.diff(table.t) for s in spec.q)))
    back.update({v: k for k, v in tmp.items()})
    K, Ku, f = linear_parts(eqs, table.qdot_raw, tmp.values(), spec.kd_eqs,
                            lambda s: name_of(back[s]))
    sample, memo = random_sampler(7), {}
    Ku_num = np.array([[fast_eval(e, sample, memo).real for e in row] for row in Ku.tolist()])
    if not np.all(np.isfinite(Ku_num)) or np.linalg.matrix_rank(Ku_num) < Ku.shape[1]:
        empty = [name_of(s) for j, s in enumerate(spec.u) if not any(Ku[:, j])]
        detail = (f"; {', '.join(empty)} appear(s) in none of them" if empty else "")
        raise ModelError(
            f"the {method!r} formulation needs the model's speeds as functions of the "
            "coordinates' rates, but the kinematic differential equations cannot be "
            "solved for the speeds (the matrix of their coefficients is singular"
            f"{detail})")
    rhs = -(K * sm.Matrix(table.u) + f)
    sol = _solve_blocks(Ku, rhs, prog, table.q)
    return tuple(prog.let(e, f"u_{name_of(s)}") for e, s in zip(sol, spec.u))


_ADJUGATE_SIZE = 4  # blocks up to this size are inverted by adjugate and determinant


def _blocks(A):
    """Row and column index sets of the independent diagonal blocks of square ``A``."""
    n = A.shape[0]
    parent = list(range(2 * n))  # union-find over rows 0..n-1 and columns n..2n-1

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(n):
        for j in range(n):
            if A[i, j] != 0:
                parent[find(i)] = find(n + j)
    groups = {}
    for k in range(2 * n):
        groups.setdefault(find(k), []).append(k)
    out = []
    for members in groups.values():
        rows = [k for k in members if k < n]
        cols = [k - n for k in members if k >= n]
        out.append((rows, cols))
    return sorted(out, key=lambda rc: (rc[1] or [n])[0])


def _solve_blocks(A, b, prog, q):
    r"""Solve ``A x = b`` symbolically, block by block, without spurious pivots.

    Small blocks use the adjugate and determinant, which vanish only where
    the block is singular (a rotation block has determinant
    :math:`\cos^2 + \sin^2`; eliminating it divides by a cosine); larger
    ones LU with pivots chosen to vanish at no sampled configuration.
    """
    x = [None] * A.shape[1]
    for rows, cols in _blocks(A):
        block = A.extract(rows, cols)
        rhs = b.extract(rows, [0])
        if len(rows) == 1:
            sol = [rhs[0] / block[0, 0]]
        elif block.is_diagonal():
            sol = [rhs[i] / block[i, i] for i in range(len(rows))]
        elif len(rows) <= _ADJUGATE_SIZE:
            named = block.applyfunc(lambda e: prog.let(e, "Ku"))
            det = prog.let(named.det(method="berkowitz"), "detKu")
            adj = named.adjugate(method="berkowitz")
            sol = [prog.let(e, "Kinv") / det for e in adj * rhs]
        else:
            order = _pivot_rows(block, q)
            named = block.extract(order, list(range(len(cols)))).applyfunc(
                lambda e: prog.let(e, "Ku"))
            sol = list(named.LUsolve(rhs.extract(order, [0])))
        for j, value in zip(cols, sol):
            x[j] = value
    return x


def _acceleration_constraints(spec, table, prog, kin, u_values):
    """Rows ``K_a w' + f_a = 0`` from the user's acceleration constraints (in u')."""
    t = table.t
    tmp = {s.diff(t): sm.Dummy(name_of(s) + "_dot") for s in spec.u}
    values = {}
    for s, value in zip(spec.u, u_values):
        values[tmp[s.diff(t)]] = kin.dt(value) + sm.Add(
            *[prog.diff(value, w) * wd for w, wd in zip(table.u, table.udot)])
    rows = []
    for i, c in enumerate(spec.acceleration_constraints):
        expr = table.internal(sm.sympify(c, strict=True).xreplace(tmp),
                              f"acceleration constraint {i}")
        rows.append(prog.let_tree(expr.xreplace(values), "ac"))
    K = tuple(tuple(prog.let(prog.diff(c, wd), "Ka") for wd in table.udot) for c in rows)
    f = tuple(prog.let(prog.subs(c, {wd: 0 for wd in table.udot}), "fa") for c in rows)
    return K, f


_POINTS = 12  # sample configurations for choosing the dependent speeds
_MAX_SUBSETS = 5000  # beyond this many candidate sets: pivoted QR at one point


def _sample_values(prog, exprs, coordinates, seed):
    """Values of ``exprs`` at a random point; coordinates drawn from [-pi, pi).

    Other leaves (speeds, constants, inputs) are drawn from [0.5, 1.5) as in
    :meth:`Program.shadow`; the wider range for coordinates spreads the
    configurations over whole turns.  ``seed=None``: every coordinate zero
    (where factors such as ``sin(q)`` vanish).
    """
    rng = random.Random(0 if seed is None else seed)
    values = {}

    def value_of(symbol):
        if symbol not in values:
            if symbol in coordinates:
                values[symbol] = (0j if seed is None
                                  else complex(rng.uniform(-math.pi, math.pi)))
            else:
                values[symbol] = complex(rng.uniform(0.5, 1.5))
        return values[symbol]

    for s in prog.needed(exprs):
        values[s] = fast_eval(prog.definition(s), value_of, {})
    return [fast_eval(e, value_of, {}) for e in exprs]


def _choose_dependent(prog, jac, coordinates, preferred, names):
    """Speeds to make dependent: ``(indices, fixed)``, ``len(jac)`` columns of ``jac``.

    ``jac`` is the constraint Jacobian (m x n expressions).  The preferred
    columns (the rates of the model's dependent coordinates) are kept when
    they are independent.  The others are chosen among the remaining columns
    so that the dependent block stays far from singular: the Jacobian is
    evaluated at several random configurations, and the set whose block
    determinant keeps its sign there and whose smallest singular value
    (relative to the Jacobian's norm), minimized over the configurations, is
    largest wins.  A single random point would not do: for the rolling disk
    a column-pivoted QR there picks the rates of one contact coordinate and
    of the spin angle, whose block is singular at zero yaw.  For very many
    candidate sets the choice falls back to a column-pivoted QR factorization
    at one point.

    ``fixed`` is False when the chosen block's determinant changes sign
    between sampled configurations (so that it vanishes somewhere between
    them: the knife edge has no partition of its rates that serves every
    heading) and the block is not that of the model's own dependent
    coordinates; the numerical model then solves for the accelerations and
    multipliers together instead of eliminating the dependent speeds.
    """
    from scipy.linalg import qr

    m = len(jac)
    if m == 0:
        return [], True
    n = len(jac[0])
    flat = [e for row in jac for e in row]
    points = []
    for seed in [SAMPLE_SEEDS[0] + k for k in range(_POINTS)] + [None]:
        vals = np.array(_sample_values(prog, flat, coordinates, seed))
        vals = vals.real.reshape(m, n)
        if np.all(np.isfinite(vals)):
            norm = np.linalg.norm(vals)
            points.append(vals / norm if norm > 0 else vals)
    if not points or all(np.linalg.matrix_rank(B) < m for B in points):
        raise ModelError(
            f"the {m} velocity constraints are not independent: their Jacobian with "
            f"respect to the speeds {', '.join(names)} has rank below {m} at random "
            "points; remove redundant constraints")
    points = [B for B in points if np.linalg.matrix_rank(B) == m]

    def worst(columns):
        return min(np.linalg.svd(B[:, columns], compute_uv=False)[-1] for B in points)

    def keeps_sign(columns):
        signs = {np.sign(np.linalg.det(B[:, columns])) for B in points}
        return len(signs) == 1 and 0 not in signs

    chosen = list(preferred)[:m]
    if chosen and worst(chosen) <= 1e-9 * len(chosen):
        chosen = []
    if len(chosen) == m:
        return chosen, True
    rest = [j for j in range(n) if j not in chosen]
    k = m - len(chosen)
    if math.comb(len(rest), k) <= _MAX_SUBSETS:
        best = max(itertools.combinations(rest, k),
                   key=lambda extra: (keeps_sign(chosen + list(extra)),
                                      worst(chosen + list(extra))))
        chosen = chosen + list(best)
    else:
        B = points[0]
        R = B[:, rest]
        if chosen:
            Qc, _ = np.linalg.qr(B[:, chosen])
            R = R - Qc @ (Qc.T @ R)
        _, _, piv = qr(R, pivoting=True, mode="economic")
        chosen = chosen + sorted(rest[i] for i in piv[:k])
    return chosen, keeps_sign(chosen)


class _Setup:
    """Program, symbol table and kinematics shared by both formulations."""

    def __init__(self, spec, method):
        _check_model(spec, method)
        self.spec = spec
        self.w_ext = _new_symbols(spec, method)
        table = self.table = SymbolTable(spec.q, self.w_ext)
        prog = self.prog = Program(table.t)
        for s in table.q + table.u + table.udot:
            prog.declare(s)  # w' = 0 inside dt
        table.on_new_specified = prog.declare  # a method: picklable
        self.u_values = _speeds_from_rates(spec, table, prog, method)
        reason = (f"the {method!r} formulation replaces the speed {{}} by an expression "
                  "in the coordinates and their rates, so only the coordinates, the "
                  "speeds and the coordinates' first derivatives may appear there")
        for s, value in zip(spec.u, self.u_values):
            table.substitute(s, value, reason.format(name_of(s)))
        self.w = tuple(table.u)  # internal rates, in the order of q
        self.rate_of = dict(zip(self.w, table.q))
        for q, w in zip(table.q, self.w):
            prog.set_derivative(q, w)
        table.set_qdot(self.w)
        self.kin = Kinematics(prog, table, spec.frame, spec.bodies)

    def constraints(self):
        """Configuration constraints, velocity-constraint residuals, identified, names."""
        kin, prog, spec = self.kin, self.prog, self.spec
        config = tuple(prog.let(kin.scalar(c, f"configuration constraint {i}", "h"), f"h_{i}")
                       for i, c in enumerate(spec.configuration_constraints))
        vel, identified, names = given_velocity_constraints(kin, spec, config, {})
        vel_c = tuple(prog.let(c, "vc") for c in vel)
        return config, vel_c, identified, names

    def dynamics(self, progress):
        """Body terms, loads, kinetic energy and Lagrange's terms for the rates.

        Returns ``(bodies, loads, kinetic, mass, active, remainder)`` with the
        partial velocities taken with respect to all of ``table.u``.
        """
        kin, prog, table = self.kin, self.prog, self.table
        speeds = table.u

        flexible = flexible_bodies(self.spec)
        rigid = [b for b in self.spec.bodies if not isinstance(b, BLOCK_BODIES)]
        body_terms, masses, inertias, inertial, hs = body_kinematics(
            kin, rigid, speeds, {}, progress)
        # flexible bodies: kinetic energy from the inertia invariants; gravity,
        # elastic and damping forces projected on the rates' partial velocities
        blocks = [flexible_block(kin, b, speeds, {}, inertia=False) for b in flexible]
        progress.stage("generalized forces")
        loads = load_terms(kin, self.spec.loads, speeds, {})
        ke = [m * dot(terms.velocity, terms.velocity) / 2 + dot(terms.omega, H) / 2
              for terms, m, H in zip(body_terms, masses, hs)]
        ke.extend(block.kinetic for block in blocks)
        kinetic = prog.let(sm.Add(*ke), "KE")

        progress.stage("derivatives of the kinetic energy")
        rates = [s for s in speeds if s in self.rate_of]
        momenta = [prog.let(prog.diff(kinetic, w), f"p_{w.name}") for w in rates]
        k = len(rates)
        mass = [[None] * k for _ in range(k)]
        for r in range(k):
            for s in range(r, k):
                mass[r][s] = mass[s][r] = prog.let(prog.diff(momenta[r], rates[s]),
                                                   f"M_{r}_{s}")
        index = {s: i for i, s in enumerate(speeds)}
        active = [prog.let(sm.Add(*[dot(vec, parts[index[w]]) for _, vec, parts in loads])
                           + sm.Add(*[project(block.partials[index[w]], block.active)
                                      for block in blocks]), f"Q_{r}")
                  for r, w in enumerate(rates)]
        remainder = [prog.let(kin.dt(p) - prog.diff(kinetic, self.rate_of[w]), f"n_{r}")
                     for r, (p, w) in enumerate(zip(momenta, rates))]
        return body_terms, inertial, loads, kinetic, mass, active, remainder

    def potential(self):
        if self.spec.potential_energy is None:
            return None
        return self.prog.let(self.kin.scalar(self.spec.potential_energy, "potential energy",
                                             "pe"), "PE")

    def kinematic_matrices(self):
        """``(K, Ku, f)`` of the equations ``q' - w = 0`` in the table's speed order."""
        n, o = len(self.table.q), len(self.table.u)
        Ku = sm.zeros(n, o)
        pos = {q: i for i, q in enumerate(self.table.q)}
        for r, s in enumerate(self.table.u):
            if s in self.rate_of:
                Ku[pos[self.rate_of[s]], r] = -1
        return sm.eye(n), Ku, sm.zeros(n, 1)

    def kd_eqs(self):
        t = self.table.t
        return tuple(q.diff(t) - w for q, w in zip(self.spec.q, self.w_ext))


def derive_lagrange(spec, progress=NO_PROGRESS, explicit_kinematics=True):
    r"""Lagrange's equations with multipliers for a :class:`ModelSpec`.

    Generalized speeds are the coordinates' rates :math:`w = \dot q` (named
    ``<q>_d``), independent then dependent; see the module docstring for the
    equations.  The result has the structure of Kane's (unreduced rows, one
    per speed; velocity constraints :math:`B w + b = 0` eliminated
    numerically), so every numerical tool applies unchanged.

    When no partition of the rates into independent and dependent ones is
    nonsingular at every sampled configuration (and the dependent ones are
    not simply the rates of the model's dependent coordinates), the result is
    marked for the multiplier form of the acceleration solve,
    :math:`[M, -B^T; B, 0]`, which the numpy backend evaluates (the C
    backend does not yet).

    Parameters
    ----------
    spec : ModelSpec
        The model, with as many speeds as coordinates and no auxiliary speeds.
    progress : Progress
    explicit_kinematics : bool
        As for Kane's method (the kinematic equations are :math:`\dot q = w`
        either way).

    Returns
    -------
    EquationsOfMotion
        ``method == "lagrange"``; ``u_ind``/``u_dep`` are the rates,
        ``multiplier_names`` and the identified forces as for Kane's method.

    Raises
    ------
    ModelError
        Auxiliary speeds given; numbers of coordinates and speeds differ; the
        kinematic differential equations cannot be solved for the speeds;
        dependent velocity constraints.
    """
    from ._eom import EquationsOfMotion

    progress.stage("kinematic differential equations")
    setup = _Setup(spec, "lagrange")
    table, prog, kin = setup.table, setup.prog, setup.kin

    progress.stage("constraints")
    config, vel_c, identified, names = setup.constraints()
    jac = [[prog.diff(c, w) for w in table.u] for c in vel_c]
    q_pos = {q: i for i, q in enumerate(spec.q)}
    preferred = [q_pos[q] for q in spec.q_dep]
    dep, fixed = _choose_dependent(prog, jac, set(table.q), preferred,
                                   [name_of(s) for s in setup.w_ext])
    ind = [j for j in range(len(table.u)) if j not in dep]
    table.reorder_speeds(ind + dep)
    vel_B = tuple(tuple(prog.let(prog.diff(c, w), "B") for w in table.u) for c in vel_c)
    if spec.acceleration_constraints is not None:
        acc_K, acc_f = _acceleration_constraints(spec, table, prog, kin, setup.u_values)
    else:
        acc_K = vel_B
        acc_f = tuple(prog.let(kin.dt(c), "fa") for c in vel_c)

    body_terms, inertial, loads, kinetic, mass, active, remainder = setup.dynamics(progress)
    contacts = tuple(_contact_terms(kin, c, table.u, {}) for c in spec.contacts)

    new_spec = replace(spec, u_ind=tuple(setup.w_ext[j] for j in ind),
                       u_dep=tuple(setup.w_ext[j] for j in dep), u_aux=(),
                       kd_eqs=setup.kd_eqs())
    progress.stage(f"done: {len(prog)} intermediates")
    eom = EquationsOfMotion._from_derivation(
        spec=new_spec, program=prog, table=table, kinematics=kin,
        explicit_kinematics=explicit_kinematics,
        qdot=setup.w, kinematic_matrices=setup.kinematic_matrices(),
        mass=tuple(tuple(row) for row in mass), active=tuple(active),
        remainder=tuple(remainder), vel_B=vel_B, vel_c=vel_c, acc_K=acc_K, acc_f=acc_f,
        config=config, aux_K=(), aux_f=(), kinetic=kinetic, potential=setup.potential(),
        body_terms=tuple(body_terms), inertial=tuple(inertial),
        load_vectors=tuple((loc, vec) for loc, vec, _ in loads),
        identified=identified, multiplier_names=names,
        contact_terms=contacts, method="lagrange")
    # no partition of the rates serves every configuration: the numerical model
    # solves M w' = f + K^T mu, K w' = -f_a for w' and mu together
    object.__setattr__(eom, "_multiplier_form", not fixed)
    return eom


def derive_augmented(spec, progress=NO_PROGRESS, explicit_kinematics=True):
    r"""Euler–Lagrange equations of the augmented (vakonomic) Lagrangean.

    The multipliers :math:`\lambda_i` (named ``lam_<multiplier name>``, one
    per velocity constraint) are further generalized speeds without
    coordinates: the state is ``[q, w, lambda]`` and the mass matrix the
    symmetric indefinite

    .. math::

        \begin{bmatrix} M + \sum_i\lambda_i H_i & A^T \\ A & 0\end{bmatrix}

    (see the module docstring).  There are no dependent coordinates or
    speeds: the constraints hold because their time derivatives are among
    the equations, so the initial state must satisfy them (configuration
    and velocity constraints), and nothing projects the motion back onto
    them.  :math:`\lambda(0)` must be given (``lambda(0) = 0`` is the
    common choice); it selects one of the vakonomic motions, which in
    general differ from the nonholonomic one of Kane's or Lagrange's method.

    Parameters
    ----------
    spec : ModelSpec
        The model, with as many speeds as coordinates, no auxiliary speeds
        and no contacts.
    progress : Progress
    explicit_kinematics : bool
        As for Kane's method.

    Returns
    -------
    EquationsOfMotion
        ``method == "augmented"``; ``u_ind`` is the rates then the
        multipliers; ``q_dep``, ``u_dep`` and ``multiplier_names`` are empty
        (the multipliers are states, not solved for).  The forces identified
        by vector constraints are kept, so that
        :func:`kanedyn.check_newton_euler` fits them to the motion (and shows
        where no such force explains it).

    Raises
    ------
    ModelError
        As :func:`derive_lagrange`, and for contacts.
    """
    from ._eom import EquationsOfMotion

    progress.stage("kinematic differential equations")
    setup = _Setup(spec, "augmented")
    table, prog, kin = setup.table, setup.prog, setup.kin
    n = len(table.q)

    progress.stage("constraints")
    _, vel_c, identified, names = setup.constraints()
    m = len(vel_c)
    lam_ext = tuple(sm.Function(f"lam_{name}")(table.t) for name in names)
    taken = {name_of(s) for s in spec.q + spec.u + setup.w_ext}
    for s in lam_ext:
        if name_of(s) in taken:
            raise ModelError(f"the 'augmented' formulation names a multiplier {name_of(s)}, "
                             "which the model already uses; rename that symbol")
    lam = table.add_speeds(lam_ext)
    for s in lam + table.udot[n:]:
        prog.declare(s)  # lambda' = 0 inside dt
    w = setup.w
    A = [[prog.let(prog.diff(c, wj), "A") for wj in w] for c in vel_c]
    if spec.acceleration_constraints is not None:
        acc_K, acc_f = _acceleration_constraints(spec, table, prog, kin, setup.u_values)
        acc_K = [row[:n] for row in acc_K]
    else:
        acc_K = A
        acc_f = tuple(prog.let(kin.dt(c), "fa") for c in vel_c)

    body_terms, inertial, loads, kinetic, mass, active, remainder = setup.dynamics(progress)

    progress.stage("multiplier terms")
    o = n + m
    rows = [[sm.S.Zero] * o for _ in range(o)]
    for j in range(n):
        for k in range(n):
            curv = sm.Add(*[lam[i] * prog.diff(A[i][j], w[k]) for i in range(m)])
            rows[j][k] = prog.let(mass[j][k] + curv, f"M_{j}_{k}") if curv != 0 else mass[j][k]
        for i in range(m):
            rows[j][n + i] = A[i][j]
    for i in range(m):
        for k in range(n):
            rows[n + i][k] = acc_K[i][k]
    rem = []
    for j in range(n):
        G = [kin.dt(A[i][j]) - prog.diff(vel_c[i], setup.rate_of[w[j]]) for i in range(m)]
        extra = sm.Add(*[lam[i] * G[i] for i in range(m)])
        rem.append(prog.let(remainder[j] + extra, f"n_{j}") if extra != 0 else remainder[j])
    rem.extend(acc_f)
    act = list(active) + [sm.S.Zero] * m

    new_spec = replace(spec, q_ind=spec.q, q_dep=(), u_ind=setup.w_ext + lam_ext, u_dep=(),
                       u_aux=(), kd_eqs=setup.kd_eqs(), configuration_constraints=(),
                       velocity_constraints=None, acceleration_constraints=None,
                       vector_constraints=())
    progress.stage(f"done: {len(prog)} intermediates")
    return EquationsOfMotion._from_derivation(
        spec=new_spec, program=prog, table=table, kinematics=kin,
        explicit_kinematics=explicit_kinematics,
        qdot=w, kinematic_matrices=setup.kinematic_matrices(),
        mass=tuple(tuple(row) for row in rows), active=tuple(act), remainder=tuple(rem),
        vel_B=(), vel_c=(), acc_K=(), acc_f=(), config=(), aux_K=(), aux_f=(),
        kinetic=kinetic, potential=setup.potential(),
        body_terms=tuple(body_terms), inertial=tuple(inertial),
        load_vectors=tuple((loc, vec) for loc, vec, _ in loads),
        identified=identified, multiplier_names=(), contact_terms=(), method="augmented")
