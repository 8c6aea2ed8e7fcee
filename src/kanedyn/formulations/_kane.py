r"""Kane's method on a straight-line program.

For generalized speeds :math:`u_1..u_o` (independent then dependent) and every
body :math:`k` with mass centre velocity :math:`v_k`, angular velocity
:math:`\omega_k`, central inertia :math:`I_k` (inertial components):

.. math::

    V_{kr} = \partial v_k/\partial u_r,\quad W_{kr} = \partial\omega_k/\partial u_r

    F_r = \sum_{\text{loads}} F\cdot V_{Pr} + T\cdot W_{Br}

    M_{rs} = \sum_k m_k V_{kr}\cdot V_{ks} + W_{kr}\cdot I_k W_{ks}

    n_r = \sum_k (m_k \bar a_k + \dot m_k v_k)\cdot V_{kr}
          + (I_k\bar\alpha_k + \omega_k\times I_k\omega_k
             + C_k \dot I_k^{B} C_k^T\omega_k)\cdot W_{kr}

where :math:`\bar a_k, \bar\alpha_k` are the accelerations with :math:`\dot u=0`.
Kane's equations :math:`F_r + F_r^* = 0` with :math:`F_r^* = -(M\dot u + n)_r`
are kept *unreduced* (one row per speed); dependent speeds are eliminated
numerically at evaluation time through the constraint Jacobian
:math:`A_r = -B_{dep}^{-1}B_{ind}`, never by symbolic inversion.
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from .._progress import NO_PROGRESS
from ._flexible import BLOCK_BODIES, flexible_bodies, flexible_terms
from ..engine import (SAMPLE_SEEDS, Kinematics, PartialVelocities, Program, SymbolTable, add,
                      composite_equations, cross, dot, fast_eval, inertia_components, matvec,
                      name_of, random_sampler, total_derivative)

__all__ = ["derive_kane", "BodyTerms", "body_kinematics", "load_terms",
           "given_velocity_constraints", "EquationLabel"]


class ContactTerms:
    """Kinematic quantities of one contact (inertial components, named).

    Attributes
    ----------
    contact : Contact
    gap : expression
        The surface's gap function at the contact point (0 in contact).
    grad_norm : expression
        :math:`|\nabla g|` (``gap / grad_norm`` is the distance to first order).
    normal : 3-tuple
        Unit normal into the free side.
    velocity : 3-tuple
        Velocity of the point relative to the surface point it touches.
    jacobian : list of 3-tuples
        Partial velocities of ``velocity``, one per real speed.
    acceleration : 3-tuple
        Time derivative of ``velocity`` with u' = 0.
    normal_rate : expression
        Time derivative of ``normal . velocity`` with u' = 0.
    """

    __slots__ = ("contact", "gap", "grad_norm", "normal", "velocity", "jacobian",
                 "acceleration", "normal_rate")

    def __init__(self, **fields):
        for name in self.__slots__:
            setattr(self, name, fields[name])


def _contact_terms(kin, contact, speeds, aux_zero):
    """The :class:`ContactTerms` of one contact."""
    from ..modeling import SURFACE_COORDINATES

    prog = kin.prog
    surface = contact.surface
    frame, origin = surface.frame, surface.origin
    r = kin.position(contact.point, origin)
    if r is None:
        raise ModelError(
            f"contact {contact.name}: the position of point {contact.point} relative to "
            f"the surface origin {origin} is not defined; locate one from the other "
            "(set_pos/locatenew), directly or through other points")
    C = kin.dcm(frame)
    local = [prog.let(sum(C[i, j] * r[i] for i in range(3)), f"rs_{j}") for j in range(3)]
    where = f"surface {surface.name}"
    coords = dict(zip(SURFACE_COORDINATES, local))
    gap_expr = kin.internal(surface.gap, where)
    gap = prog.let(gap_expr.xreplace(coords), f"gap_{contact.name}")
    grad_local = [kin.internal(surface.gap.diff(x), where).xreplace(coords)
                  for x in SURFACE_COORDINATES]
    grad = [prog.let(sum(C[i, j] * grad_local[j] for j in range(3)), "grad") for i in range(3)]
    grad_norm = prog.let(sm.sqrt(dot(grad, grad)), "gradnorm")
    normal = tuple(prog.let(g / grad_norm, "n") for g in grad)
    v_point = kin.velocity(contact.point)
    v_surface = add(kin.velocity(origin), cross(kin.angular_velocity(frame), r))
    rel = kin.let_vector(tuple(prog.subs(a - b, aux_zero) for a, b in zip(v_point, v_surface)),
                         f"vrel_{contact.name}")
    jacobian = [tuple(prog.diff(c, u) for c in rel) for u in speeds]
    acceleration = kin.let_vector(kin.dt_vector(rel), "arel")
    normal_rate = prog.let(kin.dt(dot(normal, rel)), "vn_dt")
    return ContactTerms(contact=contact, gap=gap, grad_norm=grad_norm, normal=normal,
                        velocity=rel, jacobian=jacobian, acceleration=acceleration,
                        normal_rate=normal_rate)


class BodyTerms:
    """Kinematic quantities of one body or particle (inertial components).

    Attributes
    ----------
    body : RigidBody or Particle
    velocity, omega : tuple of 3 expressions
        Mass-centre velocity and angular velocity (zeros for a particle).
    partial_velocities, partial_angular_velocities : sequence of 3-tuples
        One per speed in ``u + u_aux`` order (:class:`PartialVelocities`:
        formed when first read).
    """

    __slots__ = ("body", "velocity", "omega", "partial_velocities",
                 "partial_angular_velocities")

    def __init__(self, body, velocity, omega, partial_velocities,
                 partial_angular_velocities):
        self.body = body
        self.velocity = velocity
        self.omega = omega
        self.partial_velocities = partial_velocities
        self.partial_angular_velocities = partial_angular_velocities

    def on(self, program):
        """These terms with their partial velocities continued on ``program``
        (an extension of the program they were derived in, e.g. a workspace
        copy): partials formed later go there, not into the equations."""
        def moved(partials):
            return partials.on(program) if isinstance(partials, PartialVelocities) else partials
        return BodyTerms(self.body, self.velocity, self.omega, moved(self.partial_velocities),
                         moved(self.partial_angular_velocities))


def _pivot_rows(K, q):
    """Row order for eliminating ``K`` whose pivots vanish at no sampled point.

    SymPy's LU pivots on the first entry that is not identically zero, which
    may vanish at ordinary configurations (``sin(q)`` at ``q = 0``).  Rows are
    chosen column by column to maximize the smallest pivot over random points
    and the point with every coordinate zero (where such factors vanish).
    """
    n = K.shape[0]
    points = []
    for seed in SAMPLE_SEEDS + (None,):
        sample, memo = random_sampler(seed if seed is not None else 0), {}
        zero = {s: 0.0 for s in q} if seed is None else {}

        def value_of(symbol, sample=sample, zero=zero):
            return zero[symbol] if symbol in zero else sample(symbol)

        points.append(np.array([[fast_eval(e, value_of, memo).real for e in row]
                                for row in K.tolist()]))
    order, rows = [], list(range(n))
    for j in range(n):
        best = max(rows, key=lambda i: min(abs(A[i, j]) for A in points))
        order.append(best)
        rows.remove(best)
        for A in points:
            if A[best, j] != 0:
                for i in rows:
                    A[i] -= A[i, j] / A[best, j] * A[best]
    return order


def _jacobian(eqs, symbols):
    """``eqs.jacobian(symbols)``, differentiating each equation only by the
    symbols it contains (kinematic equations hold a few each: SymPy's
    ``jacobian`` took 1.7 s for the 100 x 100 entries of a 100-body chain),
    and by :func:`total_derivative` (SymPy's rules, without its
    ``Derivative`` objects: 4 against 70 us an entry)."""
    rows = []
    for e in eqs:
        free = e.free_symbols
        rows.append([total_derivative(e, lambda x, s=s: sm.S.One if x == s else sm.S.Zero)
                     if s in free else sm.S.Zero for s in symbols])
    return sm.Matrix(len(rows), len(symbols), [x for row in rows for x in row])


def linear_parts(eqs, rates, speeds, given, name):
    """``(K, Ku, f)`` with ``eqs = K rates + Ku speeds + f`` (kinematic equations).

    ``given`` are the equations as the user wrote them and ``name(symbol)``
    prints a symbol, for the error raised when an equation is nonlinear in
    the rates or the speeds.
    """
    rates, speeds = list(rates), list(speeds)
    K, Ku = _jacobian(eqs, rates), _jacobian(eqs, speeds)
    f = eqs.xreplace({s: 0 for s in rates + speeds})
    bad = set(rates) | set(speeds)
    for i in range(len(eqs)):
        nonlinear = (K.row(i).free_symbols | Ku.row(i).free_symbols) & bad
        if nonlinear:
            names = ", ".join(sorted(name(s) for s in nonlinear))
            raise ModelError(
                f"kinematic differential equation {i} ({given[i]}) is nonlinear in "
                f"{names}; it must be linear in q' and in the generalized speeds")
    return K, Ku, f


class EquationLabel:
    """``kinematic differential equation i (its text)``, the subject of an error
    about equation ``i``, printed when an error names it (printing a SymPy
    expression takes about 0.3 ms: 3 ms of deriving a chain of ten links)."""

    __slots__ = ("index", "equation")

    def __init__(self, index, equation):
        self.index, self.equation = index, equation

    def __str__(self):
        return f"kinematic differential equation {self.index} ({self.equation})"


def _solve_kinematics(spec, table, prog):
    """Solve the kinematic differential equations for q' (named intermediates)."""
    eqs = sm.Matrix([table.internal(e, EquationLabel(i, e))
                     for i, e in enumerate(spec.kd_eqs)])
    eqs = eqs.xreplace({ua: 0 for ua in table.u_aux})
    u = sm.Matrix(table.u)
    K, Ku, f = linear_parts(eqs, table.qdot_raw, table.u, spec.kd_eqs,
                            lambda s: str(table.external(s)))
    rhs = -(Ku * u + f)
    sample, memo = random_sampler(7), {}
    K_num = np.array([[fast_eval(e, sample, memo).real for e in row] for row in K.tolist()])
    if np.all(np.isfinite(K_num)) and np.linalg.matrix_rank(K_num) < K.shape[0]:
        empty = [name_of(spec.q[j]) for j in range(K.shape[1]) if not any(K[:, j])]
        detail = (f"; no equation contains the derivative of {', '.join(empty)}"
                  if empty else "")
        raise ModelError(
            "the kinematic differential equations cannot be solved for q': the matrix "
            f"of coefficients of q' is singular{detail}")
    if K.is_diagonal():
        sol = [rhs[i] / K[i, i] for i in range(K.shape[0])]
    else:
        order = _pivot_rows(K, table.q)
        sol = list(K.extract(order, list(range(K.shape[1]))).LUsolve(rhs.extract(order, [0])))
    qdot = tuple(prog.let(e, f"qd_{name_of(q)}") for e, q in zip(sol, spec.q))
    return qdot, (K, Ku, f)


def _drop_workless(prog, table, fr, loads, fr_aux=()):
    """Remove force magnitudes whose coefficients in ``fr`` vanish identically.

    A constraint force exposed through an auxiliary speed does no work on the
    real motion, so its coefficient in every real generalized active force is
    zero, though usually not visibly so (dot products of rotated unit
    vectors).  Coefficients are tested at random points; symbols that drop out
    are set to zero, so the equations of motion do not ask for their values.
    Only symbols that do work on the auxiliary motion (a nonzero coefficient
    in ``fr_aux``, the auxiliary rows) are candidates: a parameter whose
    effect merely vanishes at the sampled points (the switching time of a
    ``Piecewise`` load) is kept.
    """
    if not fr_aux:
        return fr
    dynamic = set(table.q) | set(table.u) | set(table.u_aux) | {table.t}
    candidates = set()
    for _, vec, _ in loads:
        for c in vec:
            candidates |= prog.deps(c)
    candidates -= dynamic
    candidates = sorted((c for c in candidates if not prog.is_intermediate(c)), key=str)
    candidates = [c for c in candidates
                  if any(prog.diff(e, c) != 0 for e in fr_aux)]
    if not candidates or not fr:
        return fr
    zero = {}
    for sym in candidates:
        coeffs = [prog.diff(e, sym) for e in fr]
        if all(c == 0 for c in coeffs):
            zero[sym] = 0
            continue
        vanishes = True
        for seed in SAMPLE_SEEDS:
            scale = 1.0 + max(abs(v) for v in prog.shadow(fr, seed))
            vals = prog.shadow(coeffs, seed)
            if any(not abs(v) <= 1e-9 * scale for v in vals):
                vanishes = False
                break
        if vanishes:
            zero[sym] = 0
    if not zero:
        return fr
    return [prog.let(prog.subs(e, zero), "Fr") for e in fr]


def _inertia_remainder(kin, body, m, terms):
    """Inertia force and torque with u' = 0; central inertia and angular momentum.

    Returns ``(force, torque, I_N, H)`` in inertial components; ``I_N`` is
    ``None`` and ``H`` zero for a particle.
    """
    v0, w0 = terms.velocity, terms.omega
    a0 = kin.dt_vector(v0)
    mdot = kin.dt(m)
    force = tuple(m * c for c in a0)
    if mdot != 0:
        force = add(force, tuple(mdot * c for c in v0))
    force = kin.let_vector(force, f"Fi_{body.name}")
    if not isinstance(body, me.RigidBody):
        zero = (sm.S.Zero,) * 3
        return force, zero, None, zero
    I_B, I_N, C = inertia_components(kin, body, f"body {body.name}")
    alpha0 = kin.dt_vector(w0)
    H = kin.let_vector(matvec(I_N, w0), f"H_{body.name}")
    torque = add(matvec(I_N, alpha0), cross(w0, H))
    I_B_dot = I_B.applyfunc(kin.dt)
    if any(I_B_dot):  # inertia changing in the body frame
        torque = add(torque, tuple(C * (I_B_dot * (C.T * sm.Matrix(w0)))))
    return force, kin.let_vector(torque, f"Ti_{body.name}"), I_N, H


def _generic_rows(kin, rows, o, body_terms, masses, inertias, inertial, loads):
    r"""Mass-matrix rows, active and remainder forces as body-by-body sums.

    Row ``r`` (a real or auxiliary speed) of
    :math:`M_{rs} = \sum_k m_k V_{kr}\cdot V_{ks} + W_{kr}\cdot I_k W_{ks}`
    for the real speeds ``s``, and the matching generalized forces.
    """
    rows = list(rows)
    if not rows:
        return [], [], []
    mass = {r: [[] for _ in range(o)] for r in rows}
    for terms, m, I_N in zip(body_terms, masses, inertias):
        V = terms.partial_velocities
        W = terms.partial_angular_velocities
        mV = {s: kin.let_vector(tuple(m * c for c in V[s]), "mV")
              for s in range(o) if any(c != 0 for c in V[s])}
        IW = {s: kin.let_vector(matvec(I_N, W[s]), "IW")
              for s in range(o) if I_N is not None and any(c != 0 for c in W[s])}
        for r in rows:
            # real rows: upper triangle only (mirrored below)
            first = r if r < o else 0
            if any(c != 0 for c in V[r]):
                for s, mv in mV.items():
                    if s >= first:
                        mass[r][s].append(dot(V[r], mv))
            if any(c != 0 for c in W[r]):
                for s, iw in IW.items():
                    if s >= first:
                        mass[r][s].append(dot(W[r], iw))
    out = []
    for r in rows:
        row = [sm.Add(*mass[r][s]) for s in range(o)]
        if r < o:
            for s in range(r):
                row[s] = out[s][r]  # symmetric
        out.append(row)
    active = [sm.Add(*[dot(vec, parts[r]) for _, vec, parts in loads]) for r in rows]
    remainder = [sm.Add(*[dot(f, t.partial_velocities[r]) + dot(tq, t.partial_angular_velocities[r])
                          for t, (f, tq) in zip(body_terms, inertial)]) for r in rows]
    return out, active, remainder


def body_kinematics(kin, bodies, speeds, aux_zero, progress=NO_PROGRESS):
    """Velocities, partial velocities and inertia terms of every body.

    Partial velocities with respect to ``speeds`` (:class:`PartialVelocities`:
    formed when first read), with ``aux_zero`` substituted.

    Returns
    -------
    body_terms : list of BodyTerms
    masses : list of expressions
    inertias : list
        Central inertia matrices in inertial components (``None`` for a
        particle).
    inertial : list of (force, torque)
        Inertia force and torque with u' = 0 (see :func:`_inertia_remainder`).
    momenta : list
        Angular momenta about the mass centres.
    """
    prog = kin.prog
    body_terms, masses, inertias, inertial, hs = [], [], [], [], []
    n_bodies = len(bodies)
    for k, body in enumerate(bodies):
        progress.update(f"kinematics of {body.name} ({k + 1}/{n_bodies})",
                        (k + 1) / n_bodies)
        m = prog.let(kin.internal(body.mass, f"mass of {body.name}"), f"m_{body.name}")
        v = kin.velocity(body.masscenter)
        rigid = isinstance(body, me.RigidBody)
        w = kin.angular_velocity(body.frame) if rigid else (sm.S.Zero,) * 3
        terms = BodyTerms(body, tuple(prog.subs(c, aux_zero) for c in v),
                          tuple(prog.subs(c, aux_zero) for c in w),
                          PartialVelocities(prog, v, speeds, aux_zero),
                          PartialVelocities(prog, w, speeds, aux_zero))
        force, torque, I_N, H = _inertia_remainder(kin, body, m, terms)
        body_terms.append(terms)
        masses.append(m)
        inertias.append(I_N)
        inertial.append((force, torque))
        hs.append(H)
    progress.done()
    return body_terms, masses, inertias, inertial, hs


def load_terms(kin, loads, speeds, aux_zero):
    """``[(location, inertial components, partials of its velocity), ...]``.

    The partials with respect to ``speeds`` (:class:`PartialVelocities`), with
    ``aux_zero`` substituted.
    """
    out = []
    for load in loads:
        loc = load.location
        kind = "T" if isinstance(loc, me.ReferenceFrame) else "F"
        vec = kin.let_vector(kin.vector(load.vector, f"load on {loc}"), f"{kind}_{loc}")
        base = (kin.angular_velocity(loc) if isinstance(loc, me.ReferenceFrame)
                else kin.velocity(loc))
        out.append((loc, vec, PartialVelocities(kin.prog, base, speeds, aux_zero)))
    return out


def vector_constraint_rows(kin, spec, aux_zero):
    """Velocity-constraint expressions and actions of ``spec.vector_constraints``."""
    prog = kin.prog
    exprs, actions, names = [], [], []
    for constraint in spec.vector_constraints:
        for name, (expr, acts) in zip(constraint.names, constraint._rows(kin)):
            exprs.append(prog.subs(expr, aux_zero))
            for a in acts:
                a.vector = tuple(prog.subs(c, aux_zero) for c in a.vector)
            actions.append(tuple(acts))
            names.append(name)
    return exprs, actions, names


def given_velocity_constraints(kin, spec, config, aux_zero):
    """The model's velocity constraints, the forces identified and the names.

    Returns ``(expressions, identified, names)``: explicit velocity
    constraints, then those of vector constraints (when neither is given, the
    time derivatives of the configuration constraints); ``identified`` is
    ``((name, actions), ...)`` of the vector constraints; ``names`` has one
    multiplier name per expression (``lambda_<i>`` for rows without an
    identified force).
    """
    prog = kin.prog
    explicit = spec.velocity_constraints
    if explicit is None and not spec.vector_constraints:
        vel = [kin.dt(c) for c in config]
    else:
        vel = [prog.subs(kin.scalar(c, f"velocity constraint {i}", "vc"), aux_zero)
               for i, c in enumerate(explicit or ())]
    names = [f"lambda_{i}" for i in range(len(vel))]
    exprs, actions, vnames = vector_constraint_rows(kin, spec, aux_zero)
    return vel + exprs, tuple(zip(vnames, actions)), tuple(names + vnames)


def kane_setup(spec, progress=NO_PROGRESS):
    """Symbol table, program, kinematic equations and kinematics of a model.

    Shared by the formulations in the model's own speeds (Kane's method, the
    natural orthogonal complement).

    Returns
    -------
    table : SymbolTable
    prog : Program
    kin : Kinematics
    qdot : tuple
        :math:`\\dot q` in terms of the speeds.
    kin_matrices : tuple
        The linear parts of the kinematic differential equations.
    """
    table = SymbolTable(spec.q, spec.u, spec.u_aux)
    prog = Program(table.t)
    for s in table.q:
        prog.declare(s)
    for s in table.u + table.u_aux + table.udot:
        prog.declare(s)
    table.on_new_specified = prog.declare  # a method: picklable

    progress.stage("kinematic differential equations")
    qdot, kin_matrices = _solve_kinematics(spec, table, prog)
    for s, value in zip(table.q, qdot):
        prog.set_derivative(s, value)
    table.set_qdot(qdot)
    return table, prog, Kinematics(prog, table, spec.frame, spec.bodies), qdot, kin_matrices


def constraint_terms(kin, spec, aux_zero):
    """Configuration, velocity and acceleration constraints in the model's speeds.

    Returns
    -------
    config, vel_c, vel_B, acc_K, acc_f : tuples of intermediates
        Residuals :math:`h`, :math:`c` (may be nonlinear in u), :math:`B =
        \\partial c/\\partial u` and :math:`K\\dot u + f_a = 0`.
    identified, names
        As :func:`given_velocity_constraints`.
    """
    prog, table = kin.prog, kin.table
    config = tuple(prog.let(kin.scalar(c, f"configuration constraint {i}", "h"), f"h_{i}")
                   for i, c in enumerate(spec.configuration_constraints))
    vel, identified, names = given_velocity_constraints(kin, spec, config, aux_zero)
    vel_c = tuple(prog.let(c, "vc") for c in vel)  # residuals; may be nonlinear in u
    vel_B = tuple(tuple(prog.let(prog.diff(c, us), "B") for us in table.u) for c in vel_c)
    if spec.acceleration_constraints is not None:
        acc = [prog.subs(prog.let_tree(table.internal(
                   c, f"acceleration constraint {i}", allow_udot=True), "ac"), aux_zero)
               for i, c in enumerate(spec.acceleration_constraints)]
        acc_K = tuple(tuple(prog.let(prog.diff(c, ud), "Ka") for ud in table.udot)
                      for c in acc)
        acc_f = tuple(prog.let(prog.subs(c, {ud: 0 for ud in table.udot}), "fa")
                      for c in acc)
    else:
        acc_K = vel_B
        acc_f = tuple(prog.let(kin.dt(c), "fa") for c in vel)
    return config, vel_c, vel_B, acc_K, acc_f, identified, names


def kinetic_term(prog, body_terms, masses, momenta, flexible):
    """The kinetic energy of rigid and flexible bodies as an intermediate.

    ``m v.v / 2 + omega.H / 2`` per rigid body (``momenta``: the angular
    momenta ``H``), plus each flexible block's ``kinetic``.
    """
    ke = [m * dot(terms.velocity, terms.velocity) / 2 + dot(terms.omega, H) / 2
          for terms, m, H in zip(body_terms, masses, momenta)]
    ke.extend(block.kinetic for block in flexible)
    return prog.let(sm.Add(*ke), "KE")


def potential_term(kin, spec):
    """The declared potential energy as an intermediate, or ``None``."""
    if spec.potential_energy is None:
        return None
    return kin.prog.let(kin.scalar(spec.potential_energy, "potential energy", "pe"), "PE")


def derive_kane(spec, progress=NO_PROGRESS, explicit_kinematics=True):
    """Kane's equations for a :class:`ModelSpec`; returns an EquationsOfMotion."""
    from ._eom import EquationsOfMotion

    table, prog, kin, qdot, kin_matrices = kane_setup(spec, progress)
    speeds = table.u + table.u_aux
    o, s_aux = len(table.u), len(table.u_aux)
    aux_zero = {ua: 0 for ua in table.u_aux}

    rigid = [b for b in spec.bodies if not isinstance(b, BLOCK_BODIES)]
    body_terms, masses, inertias, inertial, hs = body_kinematics(
        kin, rigid, speeds, aux_zero, progress)
    flexible = [flexible_terms(kin, b, speeds, o, aux_zero) for b in flexible_bodies(spec)]
    progress.stage("generalized active forces")
    loads = load_terms(kin, spec.loads, speeds, aux_zero)

    # ------------------------------------------- mass matrix, remainder
    progress.stage("mass matrix and forcing")
    speed_tree = []
    structured = composite_equations(kin, rigid, body_terms, masses, inertias,
                                     inertial, loads, o, tree=speed_tree)
    if structured is not None:
        mass, active, remainder = structured
        rows = range(o, o + s_aux)  # auxiliary rows: body by body
    else:
        mass, active, remainder = [], [], []
        rows = range(o + s_aux)
    g_mass, g_active, g_remainder = _generic_rows(
        kin, rows, o, body_terms, masses, inertias, inertial, loads)
    mass, active, remainder = (list(mass) + g_mass, list(active) + g_active,
                               list(remainder) + g_remainder)
    for terms in flexible:  # flexible bodies add their own terms to every row
        mass = [[a + b for a, b in zip(row, extra)] for row, extra in zip(mass, terms.mass)]
        active = [a + b for a, b in zip(active, terms.active)]
        remainder = [a + b for a, b in zip(remainder, terms.remainder)]
    mass_rows = [[prog.let(e, f"M_{r}_{s}") for s, e in enumerate(row)]
                 for r, row in enumerate(mass)]
    fr = [prog.let(prog.subs(e, aux_zero), f"Fr_{r}") for r, e in enumerate(active)]
    fr[:o] = _drop_workless(prog, table, fr[:o], loads, fr[o:])
    nonmm = [prog.let(prog.subs(e, aux_zero), f"n_{r}") for r, e in enumerate(remainder)]

    # ----------------------------------------------------- constraints
    progress.stage("constraints")
    config, vel_c, vel_B, acc_K, acc_f, identified, names = constraint_terms(
        kin, spec, aux_zero)

    # ------------------------------------------------------- energies
    kinetic = kinetic_term(prog, body_terms, masses, hs, flexible)
    potential = potential_term(kin, spec)

    # ------------------------------------------------------ auxiliary
    contacts = tuple(_contact_terms(kin, c, table.u, aux_zero) for c in spec.contacts)

    aux_K = tuple(tuple(-mass_rows[o + a][s] for s in range(o)) for a in range(s_aux))
    aux_f = tuple(prog.let(fr[o + a] - nonmm[o + a], f"aux_{a}") for a in range(s_aux))

    progress.stage(f"done: {len(prog)} intermediates")
    eom = EquationsOfMotion._from_derivation(
        spec=spec, program=prog, table=table, kinematics=kin,
        explicit_kinematics=explicit_kinematics,
        qdot=qdot, kinematic_matrices=kin_matrices,
        mass=tuple(tuple(row) for row in mass_rows[:o]),
        active=tuple(fr[:o]), remainder=tuple(nonmm[:o]),
        vel_B=vel_B, vel_c=vel_c, acc_K=acc_K, acc_f=acc_f, config=config,
        aux_K=aux_K, aux_f=aux_f, kinetic=kinetic, potential=potential,
        body_terms=tuple(body_terms), inertial=tuple(inertial),
        load_vectors=tuple((loc, vec) for loc, vec, _ in loads),
        identified=identified, multiplier_names=names,
        contact_terms=contacts, method="kane")
    # the mass matrix as a tree of speeds (an O(n) solve in the C backend);
    # flexible bodies add terms outside that structure
    tree = speed_tree[0] if speed_tree and len(rigid) == len(spec.bodies) else None
    object.__setattr__(eom, "_speed_tree", tree)
    # the flexible bodies' and inertial elements' blocks (the power of prescribed motion)
    object.__setattr__(eom, "_flexible_blocks", tuple(terms.block for terms in flexible))
    return eom
