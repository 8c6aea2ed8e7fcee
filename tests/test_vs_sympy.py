"""kanedyn's Kane equations against SymPy's ``KanesMethod``.

What is compared
----------------
For each model the explicit right-hand side of the equations of motion,

.. math::

    \\begin{bmatrix}\\dot q \\\\ \\dot u\\end{bmatrix}
    = M_{full}^{-1} F_{full},

is evaluated at several random states: by kanedyn as ``model.rhs(t, y)``
(its compiled straight-line program, ``M u' = F`` assembled and solved
numerically) and by SymPy as ``solve(km.mass_matrix_full, km.forcing_full)``
of ``sympy.physics.mechanics.KanesMethod`` (or ``System.form_eoms()``).  The
two must agree to 1e-10 relative (``max|a - b| / max|b|``).  The models cover
unconstrained chains (planar and spatial), a specified input, prescribed
motion (a pivot moving as a given function of time), nonholonomic rolling,
a closed holonomic loop, the Whipple bicycle (both kinds of constraints) and
models written with joints in a ``System``.  Auxiliary equations (constraint
forces exposed by auxiliary speeds) are compared with ``km.auxiliary_eqs``,
evaluated at random values of every symbol, and as computed constraint forces.

SymPy's matrices are evaluated with ``lambdify`` in double precision, except
for the Whipple bicycle, whose explicit SymPy equations lose all accuracy in
double precision and are evaluated with 50 digits (see the comment there).

Why the reference is independent
--------------------------------
kanedyn never calls ``KanesMethod``: it derives the equations with its own
engine (named intermediates, partial velocities computed by itself, the
dependent speeds eliminated numerically).  SymPy derives them by explicit
expansion and symbolic elimination.  Every model is built twice, one fresh
copy per tool, because SymPy caches velocities inside ``Point`` objects and
the two tools must not share them.  The only things shared are the model
description (the builders in ``kanedyn.models``) and the symbols' names.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

T = me.dynamicsymbols._t
RTOL = 1e-10
N_STATES = 4


# ------------------------------------------------------------------ helpers
def relative_error(a, b):
    """``max|a - b| / max(max|b|, 1e-12)``; ``b`` is the reference."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-12))


def sympy_kane(args):
    """SymPy's ``KanesMethod`` for a builder's ``kane_args``, equations formed."""
    km = me.KanesMethod(
        args["frame"], q_ind=args["q_ind"], u_ind=args["u_ind"],
        kd_eqs=args["kd_eqs"], q_dependent=args.get("q_dep", []),
        u_dependent=args.get("u_dep", []),
        configuration_constraints=args.get("configuration_constraints", []),
        velocity_constraints=args.get("velocity_constraints", []),
        u_auxiliary=args.get("u_auxiliary", []))
    km.kanes_equations(args["bodies"], args["loads"])
    return km


def check_same_state(eom, q, u):
    """kanedyn's state is ordered as SymPy's ``km.q``, ``km.u``."""
    assert tuple(eom.q) == tuple(q)
    assert tuple(eom.u) == tuple(u)


def replace_specified(expr, specified):
    """Substitute ``{x(t): g(t)}`` into ``expr``, derivatives of ``x`` included."""
    rules = {}
    for x, g in specified.items():
        rules[x] = g
        for order in (1, 2, 3):
            rules[x.diff(T, order)] = sm.diff(g, T, order)
    # xreplace works top-down, so Derivative(x, t) is replaced before x inside it
    return expr.xreplace(rules)


def sympy_rhs(M_full, F_full, q, u, constants, specified=None):
    """``f(t, y) = solve(M_full, F_full)`` with SymPy's matrices lambdified.

    ``specified`` maps a function of time to a number or an expression in t.
    """
    if specified:
        M_full = replace_specified(M_full, specified)
        F_full = replace_specified(F_full, specified)
    states = list(q) + list(u)
    consts = list(constants)
    leftover = (M_full.free_symbols | F_full.free_symbols) - set(consts) - {T}
    assert not leftover, f"unvalued symbols in SymPy's matrices: {leftover}"
    leftover = (me.find_dynamicsymbols(M_full) | me.find_dynamicsymbols(F_full)) - set(states)
    assert not leftover, f"unvalued functions of time in SymPy's matrices: {leftover}"
    f = sm.lambdify((T, states, consts), [M_full, F_full], cse=True, modules="numpy")
    p = [constants[c] for c in consts]

    def rhs(t, y):
        M, F = f(t, y, p)
        return np.linalg.solve(np.asarray(M, dtype=float),
                               np.asarray(F, dtype=float).ravel())
    return rhs


def numeric(eom, constants, specified=None):
    """``eom.numeric`` with the values of the constants the equations contain.

    (Not ``ModelDefinition.numeric``: kanedyn rejects constants that dropped
    out of the equations, e.g. ``g`` for the one-link chain turning about the
    vertical.)
    """
    values = {s: constants[s] for s in eom.constants}
    return eom.numeric(constants=values, specified=specified or {})


def compare_rhs(model, reference, states, t=0.0):
    """Largest relative error of ``model.rhs`` against ``reference`` over states."""
    worst = 0.0
    for y in states:
        expected = reference(t, y)
        assert np.all(np.isfinite(expected))
        assert np.max(np.abs(expected)) > 1e-3, "degenerate test state"
        worst = max(worst, relative_error(model.rhs(t, y), expected))
    return worst


def random_states(model, rng, n=N_STATES, q_scale=np.pi, u_scale=2.0):
    """Random unconstrained states ``[q, u]``."""
    return [np.concatenate([rng.uniform(-q_scale, q_scale, model.n_q),
                            rng.uniform(-u_scale, u_scale, model.n_u)])
            for _ in range(n)]


def compare_builtin(name, specified=None, states=None, seed=0, **options):
    """Derive a built-in model with both tools and compare ``rhs`` at states."""
    mine, ref = kd.models.build(name, **options), kd.models.build(name, **options)
    eom = kd.kane(**mine.kane_args)
    model = numeric(eom, mine.constants, specified)
    km = sympy_kane(ref.kane_args)
    check_same_state(eom, km.q, km.u)
    reference = sympy_rhs(km.mass_matrix_full, km.forcing_full, km.q, km.u,
                          ref.constants, specified)
    rng = np.random.default_rng(seed)
    states = states(mine, model, rng) if states else random_states(model, rng)
    return compare_rhs(model, reference, states)


# ---------------------------------------------------- unconstrained models
@pytest.mark.parametrize("n", [1, 2, 3])
def test_n_link_pendulum_on_cart(n):
    d = kd.models.build("n-link-pendulum-on-cart", n=n)
    F = d.symbols["F"]
    err = compare_builtin("n-link-pendulum-on-cart", n=n, specified={F: 0.7})
    assert err <= RTOL


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, pytest.param(6, marks=pytest.mark.slow)])
def test_chain3d(n):
    assert compare_builtin("chain3d", n=n) <= RTOL


# ------------------------------------------------------ constrained models
def consistent(model, y):
    """``model.consistent_state`` plus a check that the constraints hold."""
    y = model.consistent_state(0.0, y)
    assert np.max(np.abs(model.constraint_residuals(0.0, y)), initial=0.0) < 1e-9
    return y


def rolling_disk_states(definition, model, rng):
    """Random leans away from lying flat; contact-point rates made consistent."""
    out = []
    for _ in range(N_STATES):
        y = np.zeros(model.n_states)
        y[:5] = rng.uniform(-np.pi, np.pi, 5)
        y[model.index("q4")] = rng.uniform(-0.8, 0.8)
        y[5:8] = rng.uniform(-5.0, 5.0, 3)
        out.append(consistent(model, y))
    return out


def four_bar_states(definition, model, rng):
    """Crank angles where the loop closes near the default assembly."""
    out = []
    for _ in range(N_STATES):
        y = definition.initial(model)  # starting guesses of q2, q3 for Newton
        y[model.index("q1")] = rng.uniform(0.9, 1.5)
        y[model.index("u1")] = rng.uniform(-3.0, 3.0)
        out.append(consistent(model, y))
    return out


def test_rolling_disk():
    assert compare_builtin("rolling-disk", states=rolling_disk_states) <= RTOL


def test_four_bar():
    assert compare_builtin("four-bar", states=four_bar_states) <= RTOL


# ------------------------------------------------------------ the bicycle
# SymPy's explicit bicycle equations are numerically unusable in double
# precision (a documented finding of this project).  KanesMethod eliminates
# the five dependent speeds symbolically (LU of a 5 x 5 symbolic matrix); the
# entries of mass_matrix and forcing become huge trees (millions of
# operations when expanded) whose evaluation suffers catastrophic
# cancellation: evaluated with 53-bit floats at the states of this test,
# SymPy's u' is wrong by 50 % to 400 % relative, and at upright states (zero
# lean and steer) it divides by zero.  This is a property of SymPy's
# expressions, not of the model: evaluated in high precision they agree with
# kanedyn.  So the reference here is SymPy's matrices evaluated exactly as
# written with 50 significant digits (mpmath), at generic states (non-zero
# lean and steer); the test also evaluates them with 60 digits to show that
# 50 are enough.  The trees share their subtrees (about 2,300 distinct
# nodes), so a memoized walk over the distinct nodes takes milliseconds where
# lambdify needs ~35 s just to print the expressions.
_MP_FUNCTIONS = {sm.sin: mpmath.sin, sm.cos: mpmath.cos, sm.tan: mpmath.tan}


def evaluate_mp(exprs, values, dps):
    """Evaluate SymPy expressions with ``dps`` digits, each distinct node once.

    ``values`` maps every symbol and function of time to a number.
    """
    with mpmath.workdps(dps):
        cache = {k: mpmath.mpf(float(v)) for k, v in values.items()}
        stack = list(exprs)
        while stack:
            e = stack[-1]
            if e in cache:
                stack.pop()
                continue
            pending = [a for a in e.args if a not in cache]
            if pending:
                stack.extend(pending)
                continue
            stack.pop()
            if e.is_Number or e.is_NumberSymbol:
                cache[e] = mpmath.mpf(sm.Float(e, dps + 10)._mpf_)
            elif e.is_Add:
                cache[e] = mpmath.fsum(cache[a] for a in e.args)
            elif e.is_Mul:
                cache[e] = mpmath.fprod(cache[a] for a in e.args)
            elif e.is_Pow:
                base, exp = e.args
                cache[e] = (cache[base] ** int(exp) if exp.is_Integer
                            else mpmath.power(cache[base], cache[exp]))
            elif type(e) in _MP_FUNCTIONS:
                cache[e] = _MP_FUNCTIONS[type(e)](cache[e.args[0]])
            else:
                raise TypeError(f"no value or rule for {e!r} ({type(e).__name__})")
        return [cache[e] for e in exprs]


def sympy_rhs_mp(km, constants, y, dps):
    """``solve(mass_matrix_full, forcing_full)`` of ``km`` with ``dps`` digits."""
    M, F = km.mass_matrix_full, km.forcing_full
    values = dict(constants)
    values.update(zip(list(km.q) + list(km.u), y))
    entries = evaluate_mp(list(M) + list(F), values, dps)
    n = M.shape[0]
    with mpmath.workdps(dps):
        A = mpmath.matrix(n, n)
        for k, value in enumerate(entries[:n * n]):
            A[k // n, k % n] = value
        x = mpmath.lu_solve(A, mpmath.matrix(entries[n * n:]))
        return np.array([float(v) for v in x])


def bicycle_states(definition, model, rng):
    """Generic riding states: lean, steer, 3-5 m/s; dependent ones made consistent."""
    out = []
    for _ in range(N_STATES):
        y = np.zeros(model.n_states)
        for name in ("q1", "q2", "q3", "q6", "q8"):
            y[model.index(name)] = rng.uniform(-np.pi, np.pi)
        y[model.index("q4")] = rng.choice([-1, 1]) * rng.uniform(0.05, 0.2)  # lean
        y[model.index("q7")] = rng.choice([-1, 1]) * rng.uniform(0.02, 0.1)  # steer
        y[model.index("u4")] = rng.uniform(-0.5, 0.5)  # lean rate
        y[model.index("u7")] = rng.uniform(-0.5, 0.5)  # steer rate
        v = rng.uniform(3.0, 5.0)
        y[model.index("u6")] = -v / 0.3  # rear wheel rate for speed v (rR = 0.3)
        y[model.index("u1")] = v  # guess; u1 is dependent
        out.append(consistent(model, y))
    return out


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:\\s*Velocity of Ho automatically calculated")
def test_whipple_bicycle():
    mine, ref = kd.models.build("whipple-bicycle"), kd.models.build("whipple-bicycle")
    eom = kd.kane(**mine.kane_args)
    model = numeric(eom, mine.constants)
    km = sympy_kane(ref.kane_args)
    check_same_state(eom, km.q, km.u)
    worst = 0.0
    for y in bicycle_states(mine, model, np.random.default_rng(7)):
        expected = sympy_rhs_mp(km, ref.constants, y, dps=50)
        assert relative_error(sympy_rhs_mp(km, ref.constants, y, dps=60), expected) < 1e-14
        assert np.max(np.abs(expected[model.n_q:])) > 1e-3
        worst = max(worst, relative_error(model.rhs(0.0, y), expected))
    assert worst <= RTOL


# ------------------------------------------------- a System built of joints
def spatial_chain_system(n):
    """``n`` links on PinJoints of alternating axes, gravity, a joint spring.

    Built with ``sympy.physics.mechanics.System``: joints, uniform gravity and
    a ``TorqueActuator`` (spring and damper in the first joint).
    """
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    m, l, g, k, c = sm.symbols("m l g k c", positive=True)
    Ixx, Iyy, Izz = sm.symbols("I_xx I_yy I_zz", positive=True)
    ground = me.RigidBody("ground")
    system = me.System.from_newtonian(ground)
    parent = ground
    for i in range(n):
        frame = me.ReferenceFrame(f"B{i + 1}")
        link = me.RigidBody(f"link{i + 1}", frame=frame, mass=m)
        link.central_inertia = me.inertia(frame, Ixx, Iyy, Izz)
        joint = me.PinJoint(
            f"J{i + 1}", parent, link, coordinates=q[i], speeds=u[i],
            parent_point=None if i == 0 else l / 2 * parent.frame.y,
            child_point=-l / 2 * frame.y,
            joint_axis=parent.frame.z if i % 2 == 0 else parent.frame.x)
        system.add_joints(joint)
        parent = link
    first = system.bodies[1]
    system.add_actuators(me.TorqueActuator(-k * q[0] - c * u[0], ground.frame.z,
                                           first.frame, ground.frame))
    system.apply_uniform_gravity(-g * ground.frame.z)
    system.validate_system()
    constants = {m: 1.2, l: 0.7, g: 9.81, k: 3.0, c: 0.4, Ixx: 0.05, Iyy: 0.01,
                 Izz: 0.06}
    return system, constants


@pytest.mark.parametrize("n", [2, 3])
def test_system_with_joints(n):
    mine, constants = spatial_chain_system(n)
    ref, _ = spatial_chain_system(n)
    eom = kd.kane(mine)
    model = numeric(eom, constants)
    ref.form_eoms()
    check_same_state(eom, ref.q, ref.u)
    reference = sympy_rhs(ref.mass_matrix_full, ref.forcing_full, ref.q, ref.u, constants)
    states = random_states(model, np.random.default_rng(n))
    assert compare_rhs(model, reference, states) <= RTOL


# --------------------------------------------------------- prescribed motion
def moving_pivot_pendulum():
    """A compound pendulum whose pivot moves horizontally as ``x(t)``.

    The bob is also held by a spring to the fixed origin (brings in ``x``)
    and damped by air drag on its inertial velocity (brings in ``x'``); the
    pivot acceleration ``x''`` enters through the inertia forces.
    """
    x = me.dynamicsymbols("x")
    q, u = me.dynamicsymbols("q u")
    m, l, g, k, c, I = sm.symbols("m l g k c I", positive=True)
    N = me.ReferenceFrame("N")
    B = me.ReferenceFrame("B")
    B.orient_axis(N, N.z, q)
    B.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    pivot = O.locatenew("S", x * N.x)
    pivot.set_vel(N, x.diff(T) * N.x)
    G = pivot.locatenew("G", -l * B.y)
    G.v2pt_theory(pivot, N, B)
    body = me.RigidBody("rod", G, B, m, (me.inertia(B, 0, 0, I), G))
    loads = [(G, -m * g * N.y - k * G.pos_from(O) - c * G.vel(N))]
    args = dict(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff(T) - u],
                bodies=[body], loads=loads)
    constants = {m: 0.8, l: 0.5, g: 9.81, k: 2.0, c: 0.3, I: 0.02}
    return args, constants, x


def test_prescribed_pivot_motion():
    args, constants, x = moving_pivot_pendulum()
    ref_args, _, _ = moving_pivot_pendulum()
    A, w = sm.symbols("A w", positive=True)
    motion = {x: A * sm.sin(w * T)}
    values = {**constants, A: 0.2, w: 3.0}
    eom = kd.kane(**args)
    model = eom.numeric(constants=values, specified=motion)
    km = sympy_kane(ref_args)
    check_same_state(eom, km.q, km.u)
    used = me.find_dynamicsymbols(km.mass_matrix_full) | me.find_dynamicsymbols(km.forcing_full)
    assert {x, x.diff(T), x.diff(T, 2)} <= used  # position, velocity, acceleration
    reference = sympy_rhs(km.mass_matrix_full, km.forcing_full, km.q, km.u, values, motion)
    rng = np.random.default_rng(11)
    worst = 0.0
    for y in random_states(model, rng):
        t = rng.uniform(0.0, 5.0)
        worst = max(worst, compare_rhs(model, reference, [y], t=t))
    assert worst <= RTOL


# ------------------------------------------------------ auxiliary equations
def as_plain_symbols(exprs):
    """Replace u'(t), u(t), F(t) by plain symbols: ``(exprs, symbols)``."""
    rules = {}
    for e in exprs:
        for d in e.atoms(sm.Derivative):
            rules.setdefault(d, sm.Dummy(str(d)))
        for f in me.find_dynamicsymbols(e):
            rules.setdefault(f, sm.Dummy(str(f)))
    # xreplace works top-down: Derivative(u(t), t) is replaced before u(t)
    return [e.xreplace(rules) for e in exprs], rules


@pytest.mark.parametrize("name, option, force", [("pendulum", "tension", "T"),
                                                 ("rolling-disk", "normal_force", "N_c")])
def test_auxiliary_equations(name, option, force):
    mine, ref = kd.models.build(name, **{option: True}), kd.models.build(name, **{option: True})
    eom = kd.kane(**mine.kane_args)
    km = sympy_kane(ref.kane_args)
    ours, theirs = sm.Matrix(eom.auxiliary_equations), sm.Matrix(km.auxiliary_eqs)
    assert ours.shape == theirs.shape == (1, 1)
    exprs, rules = as_plain_symbols([ours[0], theirs[0]])
    F = mine.symbols[force]
    assert F in rules and all(rules[F] in e.free_symbols for e in exprs)
    symbols = sorted(set(rules.values()) | set(ref.constants), key=str)
    assert exprs[0].free_symbols | exprs[1].free_symbols <= set(symbols)
    f = sm.lambdify(symbols, exprs)
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(N_STATES):
        values = rng.uniform(-2.0, 2.0, len(symbols))
        a, b = f(*values)
        assert abs(b) > 1e-3
        worst = max(worst, relative_error(a, b))
    assert worst <= RTOL


@pytest.mark.parametrize("name, option, force, states", [
    ("pendulum", "tension", "T", None),
    ("rolling-disk", "normal_force", "N_c", rolling_disk_states)])
def test_constraint_force_values(name, option, force, states):
    """``model.auxiliary`` against SymPy's auxiliary equation solved for the force.

    SymPy's accelerations come from its own ``solve(M_full, F_full)``.
    """
    mine, ref = kd.models.build(name, **{option: True}), kd.models.build(name, **{option: True})
    eom = kd.kane(**mine.kane_args)
    model = numeric(eom, mine.constants)
    km = sympy_kane(ref.kane_args)
    check_same_state(eom, km.q, km.u)
    reference = sympy_rhs(km.mass_matrix_full, km.forcing_full, km.q, km.u, ref.constants)
    F = mine.symbols[force]
    udots = [u.diff(T) for u in km.u]
    consts = list(ref.constants)
    plain = {s: sm.Dummy() for s in [*udots, *km.q, *km.u, F]}  # xreplace: top-down
    equation = km.auxiliary_eqs[0].xreplace(plain)
    aux = sm.lambdify(([plain[s] for s in [*km.q, *km.u]], [plain[s] for s in udots],
                       plain[F], consts), equation)
    p = [ref.constants[c] for c in consts]
    rng = np.random.default_rng(5)
    states = states(mine, model, rng) if states else random_states(model, rng)
    worst = 0.0
    for y in states:
        ud = reference(0.0, y)[model.n_q:]
        at0, at1 = aux(y, ud, 0.0, p), aux(y, ud, 1.0, p)
        expected = -at0 / (at1 - at0)  # the equation is linear in the force
        assert abs(expected) > 1e-3
        worst = max(worst, relative_error(model.auxiliary(0.0, y)[force], expected))
    assert worst <= RTOL


# ------------------------------------- generalized forces, partial velocities
def test_generalized_forces_and_partial_velocities():
    """fr, frstar (reduced with the dependent speeds) and partial velocities.

    Evaluated at a consistent four-bar state, with random values for u'.
    """
    ours = kd.models.build("four-bar")
    theirs = kd.models.build("four-bar")
    eom = ours.derive()
    km = sympy_kane(theirs.kane_args)
    model = ours.numeric(eom)
    y = model.consistent_state(0.0, ours.initial(model))
    rng = np.random.default_rng(5)
    values = dict(zip(list(km.q) + list(km.u), y))
    values.update({u.diff(T): v for u, v in zip(km.u, rng.normal(size=len(km.u)))})
    values.update(ours.constants)

    def num(matrix):
        return np.array([float(sm.sympify(e).xreplace(values)) for e in matrix])

    fr, frstar = km.kanes_equations(theirs.kane_args["bodies"], theirs.kane_args["loads"])
    assert relative_error(num(eom.generalized_active_forces), num(fr)) < RTOL
    assert relative_error(num(eom.generalized_inertia_forces), num(frstar)) < RTOL

    N = ours.kane_args["frame"]
    for body_ours, body_theirs in zip(ours.kane_args["bodies"], theirs.kane_args["bodies"]):
        vs, ws = eom.partial_velocities[body_ours.name]
        ref_v = me.partial_velocity([body_theirs.masscenter.vel(theirs.kane_args["frame"])],
                                    km.u, theirs.kane_args["frame"])[0]
        for ours_v, ref in zip(vs, ref_v):
            ref_n = [ref.dot(theirs.kane_args["frame"].x), ref.dot(theirs.kane_args["frame"].y)]
            got = [ours_v.dot(N.x), ours_v.dot(N.y)]
            assert relative_error(num(got), num(ref_n)) < RTOL
        assert len(ws) == len(km.u)
