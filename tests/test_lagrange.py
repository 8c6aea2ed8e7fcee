"""Lagrange's equations and the augmented (vakonomic) Lagrangean against Kane's method.

Lagrange's formulation uses the coordinates' rates ``w = q'`` as speeds.  Where
a Kane model's speeds are the rates as well, the right-hand sides are compared
entry by entry; elsewhere the physical accelerations ``q''`` are compared: for
the Kane model ``q'' = d/dt q'(q, u)`` is the directional derivative of its
``q'`` along its own state derivative, taken by central differences with one
Richardson step (error about 1e-11 here), for Lagrange's it is ``w'``.
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.engine._symbols import name_of

T = me.dynamicsymbols._t


# ------------------------------------------------------------------ helpers
def kane_qdd(model, t, y, h=1e-4):
    """q'' of a Kane model: derivative of q'(y) along y' (Richardson-extrapolated)."""
    n = model.n_q
    yd = model.rhs(t, y)

    def central(step):
        return (model.rhs(t, y + step * yd)[:n] - model.rhs(t, y - step * yd)[:n]) / (2 * step)

    return (4 * central(h / 2) - central(h)) / 3


def lagrange_state(kane_model, lag_model, t, y):
    """The Lagrange state ``[q, w]`` of the motion at Kane state ``y``."""
    n = kane_model.n_q
    qd = kane_model.rhs(t, y)[:n]
    out = np.zeros(lag_model.n_states)
    for name, q, rate in zip(kane_model.state_names[:n], y[:n], qd):
        out[lag_model.index(name)] = q
        out[lag_model.index(name + "_d")] = rate
    return out


def lagrange_qdd(lag_model, t, y, q_names):
    yd = lag_model.rhs(t, y)
    return np.array([yd[lag_model.index(name + "_d")] for name in q_names])


def rate_names(eom):
    """``{Kane state name: Lagrange state name}`` for models with kd_eqs ``q' - u``."""
    out = {}
    for eq in eom.kd_eqs:
        (qd,) = eq.atoms(sm.Derivative)
        q = qd.expr
        u = sm.expand(qd - eq)
        assert u in eom.u
        out[name_of(q)] = name_of(q)
        out[name_of(u)] = name_of(q) + "_d"
    return out


def knife_edge(vector=True):
    """Chaplygin sleigh written with one speed per coordinate and the knife-edge
    constraint as a velocity constraint (a PointVelocity naming its force R)."""
    x, y, th = me.dynamicsymbols("x y theta")
    ux, uy, w = me.dynamicsymbols("u_x u_y w")
    m, a, I_C = sm.symbols("m a I_C", positive=True)
    N, B = me.ReferenceFrame("N"), me.ReferenceFrame("B")
    B.orient_axis(N, N.z, th)
    B.set_ang_vel(N, w * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, ux * N.x + uy * N.y)
    G = P.locatenew("G", a * B.x)
    G.v2pt_theory(P, N, B)
    body = me.RigidBody("sleigh", G, B, m, (me.inertia(B, 0, 0, I_C), G))
    args = dict(frame=N, q_ind=[x, y, th], u_ind=[ux, w], u_dep=[uy],
                kd_eqs=[x.diff() - ux, y.diff() - uy, th.diff() - w], bodies=[body],
                loads=[])
    if vector:
        args["constraints"] = [kd.PointVelocity(P, B.y, names="R")]
    else:
        args["velocity_constraints"] = [P.vel(N).dot(B.y)]
    return args, {m: 1.0, a: 0.2, I_C: 0.05}


def spring_particle():
    """A particle with z' = y x' pulled towards the z axis by a spring."""
    x, y, z = me.dynamicsymbols("x y z")
    ux, uy, uz = me.dynamicsymbols("u_x u_y u_z")
    m, k = sm.symbols("m k", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y + z * N.z)
    P.set_vel(N, ux * N.x + uy * N.y + uz * N.z)
    args = dict(frame=N, q_ind=[x, y, z], u_ind=[ux, uy], u_dep=[uz],
                kd_eqs=[x.diff() - ux, y.diff() - uy, z.diff() - uz],
                bodies=[me.Particle("p", P, m)], loads=[(P, -k * (x * N.x + y * N.y))],
                velocity_constraints=[uz - y * ux])
    return args, {m: 1.0, k: 4.0}


def vakonomic_initial(kane_model, aug_model, y, lam0=0.0):
    """Augmented state ``[q, w, lambda]`` from a Kane state with rate speeds."""
    names = rate_names(kane_model._eom)
    out = np.full(aug_model.n_states, lam0)
    for name, value in zip(kane_model.state_names, y):
        out[aug_model.index(names[name])] = value
    return out


# --------------------------------------------------------- rate-speed models
@pytest.mark.parametrize("name, options", [
    ("pendulum", {}), ("n-link-pendulum-on-cart", {"n": 3}), ("chain3d", {"n": 3}),
    ("four-bar", {})])
def test_rhs_equals_kane_when_speeds_are_rates(name, options):
    """Same state derivative (and multipliers) as Kane's at random consistent states."""
    d = kd.models.build(name, **options)
    kane = d.derive()
    lag = d.derive(method="lagrange")
    assert lag.method == "lagrange"
    names = rate_names(kane)
    assert sorted(lag.state_names) == sorted(names[s] for s in kane.state_names)
    specified = {s: (lambda t: 0.3 + np.sin(t)) for s in kane.specified}
    km = d.numeric(kane, specified=specified)
    lm = d.numeric(lag, specified=specified)
    perm = [lm.index(names[s]) for s in km.state_names]
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(5):
        y = d.initial(km) + rng.uniform(-0.5, 0.5, km.n_states)
        yk = km.state(y)
        yl = np.empty(lm.n_states)
        yl[perm] = yk
        yl = lm.state(yl)  # dependent rates completed from the constraints
        np.testing.assert_allclose(yl[perm], yk, rtol=0, atol=1e-12)
        dk, dl = km.rhs(0.4, yk), lm.rhs(0.4, yl)[perm]
        worst = max(worst, np.max(np.abs(dk - dl)) / (1 + np.max(np.abs(dk))))
        np.testing.assert_allclose(km.kinetic_energy(0.4, yk), lm.kinetic_energy(0.4, yl),
                                   rtol=1e-12)
        mk, ml = km.multipliers(0.4, yk), lm.multipliers(0.4, yl)
        assert list(mk) == list(ml)
        for key in mk:
            assert abs(mk[key] - ml[key]) <= 1e-10 * (1 + abs(mk[key]))
    assert worst < 1e-11


def test_pendulum_explicit_equations():
    """The explicit matrices are Lagrange's textbook equations, equal to Kane's."""
    d = kd.models.build("pendulum")
    kane, lag = d.derive(), d.derive(method="lagrange")
    q, u, m, l, g = (d.symbols[k] for k in ("q", "u", "m", "l", "g"))
    w = me.dynamicsymbols("q_d")
    assert lag.u == (w,)
    assert lag.kd_eqs == (q.diff(T) - w,)
    assert sm.simplify(lag.mass_matrix[0] - m * l**2) == 0
    assert sm.simplify(lag.forcing[0] + m * g * l * sm.sin(q)) == 0
    assert sm.simplify(lag.kinetic_energy - m * l**2 * w**2 / 2) == 0
    assert sm.simplify(lag.forcing_full.xreplace({w: u}) - kane.forcing_full) == sm.zeros(2, 1)
    implicit = kd.formulate(method="lagrange", explicit_kinematics=False, **d.kane_args)
    assert implicit.mass_matrix_kin == sm.eye(1)
    assert implicit.forcing_kin == sm.Matrix([w])


# --------------------------------------------------------- nonholonomic models
def _compare_qdd(d, kane, lag, states, atol):
    km, lm = d.numeric(kane), d.numeric(lag)
    n = km.n_q
    worst = 0.0
    for y in states(km):
        yk = km.consistent_state(0.2, y)
        yl = lagrange_state(km, lm, 0.2, yk)
        assert np.max(np.abs(lm.constraint_residuals(0.2, yl))) < 1e-12
        a = kane_qdd(km, 0.2, yk)
        b = lagrange_qdd(lm, 0.2, yl, km.state_names[:n])
        worst = max(worst, np.max(np.abs(a - b)) / (1 + np.max(np.abs(a))))
        np.testing.assert_allclose(km.total_energy(0.2, yk), lm.total_energy(0.2, yl),
                                   rtol=1e-12)
    assert worst < atol
    return worst


def test_rolling_disk_accelerations_match_kane():
    d = kd.models.build("rolling-disk")
    kane, lag = d.derive(), d.derive(method="lagrange")
    # dependent rates: those of the contact point (nonsingular at every yaw)
    assert lag.u_dep == tuple(me.dynamicsymbols("q1_d q2_d"))
    rng = np.random.default_rng(3)

    def states(km):
        for _ in range(5):
            y = np.zeros(km.n_states)
            y[:5] = rng.uniform(-1.5, 1.5, 5)
            y[5:8] = rng.uniform(-4, 4, 3)
            yield y

    _compare_qdd(d, kane, lag, states, 1e-9)


def test_rolling_disk_motion_matches_kane():
    """Simulated from the default state (zero yaw): same motion as Kane's."""
    d = kd.models.build("rolling-disk")
    km, lm = d.numeric(d.derive()), d.numeric(d.derive(method="lagrange"))
    yk = km.state(d.initial(km))
    yl = lagrange_state(km, lm, 0.0, yk)
    opts = dict(rtol=1e-11, atol=1e-11)
    rk = kd.simulate(km, (0.0, 1.5), yk, **opts)
    rl = kd.simulate(lm, (0.0, 1.5), yl, **opts)
    assert rk.success and rl.success
    np.testing.assert_allclose(rl.y[:5, -1], rk.y[:5, -1], atol=1e-7)
    from kanedyn.numerics.backends._c import compiler_command
    if compiler_command() is not None:  # a fixed partition: the C backend applies
        cm = d.numeric(lm._eom, backend="c")
        np.testing.assert_allclose(cm.rhs(0.3, rl.y[:, 5]), lm.rhs(0.3, rl.y[:, 5]),
                                   rtol=1e-11, atol=1e-11)


def test_bicycle_accelerations_match_kane(bicycle):
    d, kane, km = bicycle
    lag = kd.formulate(method="lagrange", **d.kane_args)
    assert lag.q_dep == kane.q_dep
    assert lag.u_dep[0] == me.dynamicsymbols(name_of(kane.q_dep[0]) + "_d")
    y0 = km.state(d.initial(km))
    rng = np.random.default_rng(5)

    def states(model):
        for _ in range(3):
            y = y0.copy()
            y[:model.n_q] += rng.uniform(-0.2, 0.2, model.n_q)
            y[model.n_q:] += rng.uniform(-1.0, 1.0, model.n_u)
            yield y

    _compare_qdd(d, kane, lag, states, 1e-9)


@pytest.mark.parametrize("vector", [True, False])
def test_knife_edge_matches_chaplygin_sleigh(vector):
    """The sleigh with three rate speeds and a constraint against the built-in
    sleigh whose two speeds satisfy the constraint by construction."""
    args, constants = knife_edge(vector)
    lag = kd.formulate(method="lagrange", **args)
    lm = lag.numeric(constants=constants)
    d = kd.models.build("chaplygin-sleigh")
    sm_model = d.numeric(d.derive())
    rng = np.random.default_rng(11)
    for _ in range(5):
        y = np.concatenate([rng.uniform(-1, 1, 3), rng.uniform(-2, 2, 2)])
        yl = lagrange_state(sm_model, lm, 0.0, y)
        a = kane_qdd(sm_model, 0.0, y)
        b = lagrange_qdd(lm, 0.0, yl, ("x", "y", "theta"))
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * (1 + np.max(np.abs(a))))
    if vector:  # the knife-edge force, as Kane's method identifies it
        km = kd.formulate(method="kane", **args).numeric(constants=constants)
        for _ in range(3):
            yk = km.state({"x": 0.1, "y": -0.3, "theta": rng.uniform(-3, 3),
                           "u_x": rng.uniform(-1, 1), "w": rng.uniform(-2, 2)})
            yl = lagrange_state(km, lm, 0.0, yk)
            fk, fl = km.constraint_forces(0.0, yk), lm.constraint_forces(0.0, yl)
            assert set(fk) == set(fl) == {"R"}
            assert abs(fk["R"] - fl["R"]) < 1e-12 * (1 + abs(fk["R"]))


def test_body_frame_speeds():
    """Speeds mixing the rates through the heading (K_u not diagonal): the
    sleigh with the velocity of P in body axes, checked at headings 0, pi/2
    (where an unpivoted elimination divides by cos(theta) = 0) and random."""
    x, y, th = me.dynamicsymbols("x y theta")
    ux, uy, w = me.dynamicsymbols("u_x u_y w")
    m, a, I_C = sm.symbols("m a I_C", positive=True)
    N, B = me.ReferenceFrame("N"), me.ReferenceFrame("B")
    B.orient_axis(N, N.z, th)
    B.set_ang_vel(N, w * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, ux * B.x + uy * B.y)
    G = P.locatenew("G", a * B.x)
    G.v2pt_theory(P, N, B)
    body = me.RigidBody("sleigh", G, B, m, (me.inertia(B, 0, 0, I_C), G))
    args = dict(frame=N, q_ind=[x, y, th], u_ind=[ux, w], u_dep=[uy],
                kd_eqs=[x.diff() - ux * sm.cos(th) + uy * sm.sin(th),
                        y.diff() - ux * sm.sin(th) - uy * sm.cos(th), th.diff() - w],
                velocity_constraints=[uy], bodies=[body],
                loads=[(P, -sm.Symbol("c") * P.vel(N))])  # viscous drag
    constants = {m: 1.3, a: 0.2, I_C: 0.05, sm.Symbol("c"): 0.4}
    km = kd.formulate(method="kane", **args).numeric(constants=constants)
    lm = kd.formulate(method="lagrange", **args).numeric(constants=constants)
    rng = np.random.default_rng(4)
    for heading in (0.0, np.pi / 2, rng.uniform(-3, 3)):
        yk = km.state({"x": 0.3, "y": -0.2, "theta": heading, "u_x": -0.7, "w": 1.1})
        yl = lagrange_state(km, lm, 0.0, yk)
        a = kane_qdd(km, 0.0, yk)
        b = lagrange_qdd(lm, 0.0, yl, ("x", "y", "theta"))
        assert np.all(np.isfinite(b))
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * (1 + np.max(np.abs(a))))


def test_knife_edge_without_fixed_partition():
    """No choice of dependent rate serves every heading (the x_d or y_d column of
    the constraint vanishes at some heading): the equations are solved for
    accelerations and multiplier together, through headings 0 and pi/2."""
    args, constants = knife_edge()
    lag = kd.formulate(method="lagrange", **args)
    assert lag._multiplier_form
    lm = lag.numeric(constants=constants)
    d = kd.models.build("chaplygin-sleigh")
    sleigh = d.numeric(d.derive())
    y = np.array([0.0, 0.0, 0.0, -0.5, 1.0])  # heading 0, turning
    yl = lagrange_state(sleigh, lm, 0.0, y)
    opts = dict(rtol=1e-11, atol=1e-11, t_eval=np.linspace(0.0, 4.0, 41))
    rs = kd.simulate(sleigh, (0.0, 4.0), y, **opts)
    rl = kd.simulate(lm, (0.0, 4.0), yl, **opts)
    assert rs.success and rl.success
    assert rs["theta"][-1] > np.pi  # past every heading where a partition fails
    for name in ("x", "y", "theta"):
        np.testing.assert_allclose(rl[name], rs[name], atol=1e-8)


def test_newton_euler_check_of_lagrange_motion():
    """Each body obeys Newton-Euler with the identified force (equations' multipliers)."""
    args, constants = knife_edge()
    lm = kd.formulate(method="lagrange", **args).numeric(constants=constants)
    y0 = lm.state({"x": 0, "y": 0, "theta": 0.3, "theta_d": 1.0,
                   lm.state_names[3]: -0.4})
    res = kd.simulate(lm, (0.0, 2.0), y0, rtol=1e-10, atol=1e-10)
    check = kd.check_newton_euler(lm, res.t[::10], res.y[:, ::10])
    assert check.source == "equations"
    assert np.max(np.abs(check.force_residual)) < 1e-12
    assert np.max(np.abs(check.moment_residual)) < 1e-12


def test_energy_conserved_four_bar():
    """Closed loop, dependent coordinates: total energy constant along the motion."""
    d = kd.models.build("four-bar")
    lm = d.numeric(d.derive(method="lagrange"))
    y0 = lm.state({"q1": 1.2, "q1_d": 2.0, "q2": 0.3, "q3": 1.6})
    res = kd.simulate(lm, (0.0, 3.0), y0, rtol=1e-11, atol=1e-11)
    assert res.success
    energy = np.array([lm.total_energy(t, y) for t, y in zip(res.t, res.y.T)])
    kinetic = np.array([lm.kinetic_energy(t, y) for t, y in zip(res.t, res.y.T)])
    assert np.ptp(kinetic) > 1.0  # energy is exchanged
    assert np.ptp(energy) < 1e-8 * np.max(np.abs(energy))


def test_given_acceleration_constraints_are_converted():
    """Acceleration constraints in u' (rolling disk: u not the rates) give the same
    equations as the time derivatives of the velocity constraints."""
    d = kd.models.build("rolling-disk")
    args = dict(d.kane_args)
    q = d.symbols["q"]
    kdd = sm.solve(args["kd_eqs"], [qi.diff(T) for qi in q], dict=True)[0]
    vel = [sm.sympify(c).xreplace(kdd) for c in args["velocity_constraints"]]
    args["acceleration_constraints"] = [c.diff(T).xreplace(kdd) for c in vel]
    plain = d.numeric(d.derive(method="lagrange"))
    given = d.numeric(kd.formulate(method="lagrange", **args))
    km = d.numeric(d.derive())
    rng = np.random.default_rng(2)
    for _ in range(3):
        y = np.zeros(km.n_states)
        y[:5] = rng.uniform(-1, 1, 5)
        y[5:8] = rng.uniform(-3, 3, 3)
        yl = lagrange_state(km, plain, 0.0, km.consistent_state(0.0, y))
        a, b = plain.rhs(0.0, yl), given.rhs(0.0, yl)
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-11 * (1 + np.max(np.abs(a))))


@pytest.mark.parametrize("name", ["ladder", "bouncing-ball"])
def test_contact_models_match_kane(name):
    """Contacts (friction, separation, impacts) run on Lagrange's equations too."""
    d = kd.models.build(name)
    kane = d.derive()
    names = rate_names(kane)
    km, lm = d.numeric(kane), d.numeric(d.derive(method="lagrange"))
    yk = km.state(d.initial(km))
    yl = np.empty(lm.n_states)
    yl[[lm.index(names[s]) for s in km.state_names]] = yk
    t_end = min(d.t_end, 2.0)
    rk = kd.simulate(km, (0.0, t_end), yk, rtol=1e-10, atol=1e-10)
    rl = kd.simulate(lm, (0.0, t_end), yl, rtol=1e-10, atol=1e-10)
    assert rk.success and rl.success
    np.testing.assert_allclose(rl.y[:km.n_q, -1], rk.y[:km.n_q, -1], atol=1e-7)


# ------------------------------------------------------------------ augmented
@pytest.mark.parametrize("build", [knife_edge, spring_particle])
def test_augmented_differs_from_nonholonomic(build):
    """lambda(0) = 0: the vakonomic motion keeps the constraint but is not the
    nonholonomic one (Kane's), and no constraint force explains it."""
    args, constants = build()
    km = kd.formulate(method="kane", **args).numeric(constants=constants)
    aug = kd.formulate(method="augmented", **args)
    am = aug.numeric(constants=constants)
    assert aug.method == "augmented" and not aug.u_dep and not aug.q_dep
    assert am.state_names[-1].startswith("lam_") and am.multiplier_names == ()
    start = {km.state_names[0]: 0.2, km.state_names[1]: 0.0, km.state_names[2]: 0.3,
             km.state_names[3]: -0.5, km.state_names[4]: 1.0}
    yk = km.state(start)
    ya = vakonomic_initial(km, am, yk, lam0=0.0)
    # with lambda = 0 the accelerations agree at the start
    names = rate_names(km._eom)
    perm = [am.index(names[s]) for s in km.state_names]
    np.testing.assert_allclose(am.rhs(0.0, ya)[perm], km.rhs(0.0, yk), atol=1e-12)
    opts = dict(rtol=1e-10, atol=1e-10)
    rk = kd.simulate(km, (0.0, 2.0), yk, **opts)
    ra = kd.simulate(am, (0.0, 2.0), ya, **opts)
    assert rk.success and ra.success
    difference = np.max(np.abs(ra.y[perm, -1] - rk.y[:, -1]))
    assert difference > 1e-2  # >> the integration tolerance
    # the constraint f(q, w) still holds along the vakonomic motion: evaluate it
    # with the Lagrange model (same q and w names)
    lm = kd.formulate(method="lagrange", **args).numeric(constants=constants)
    to_lag = [am.index(s) for s in lm.state_names]
    residual = max(np.max(np.abs(lm.constraint_residuals(t, y[to_lag])))
                   for t, y in zip(ra.t, ra.y.T))
    assert residual < 1e-7
    if build is knife_edge:
        check = kd.check_newton_euler(am, ra.t[::10], ra.y[:, ::10])
        assert check.source == "fit"
        assert np.max(np.abs(check.force_residual)) > 1e-2


@pytest.mark.parametrize("lam0", [0.0, 1.7])
def test_augmented_holonomic_four_bar_agrees(lam0):
    """For holonomic constraints only lambda' enters: any lambda(0) gives the
    constrained motion."""
    d = kd.models.build("four-bar")
    lm = d.numeric(d.derive(method="lagrange"))
    am = d.numeric(d.derive(method="augmented"))
    assert am.state_names == ("q1", "q2", "q3", "q1_d", "q2_d", "q3_d",
                              "lam_lambda_0", "lam_lambda_1")
    yl = lm.state({"q1": 1.2, "q1_d": 2.0, "q2": 0.3, "q3": 1.6})
    ya = np.full(am.n_states, lam0)
    ya[[am.index(s) for s in lm.state_names]] = yl
    # lambda' is minus Lagrange's multiplier
    mult = lm.multipliers(0.0, yl)
    np.testing.assert_allclose(am.rhs(0.0, ya)[-2:], [-mult["lambda_0"], -mult["lambda_1"]],
                               rtol=1e-10)
    opts = dict(rtol=1e-11, atol=1e-11)
    rl = kd.simulate(lm, (0.0, 2.0), yl, **opts)
    ra = kd.simulate(am, (0.0, 2.0), ya, **opts)
    idx = [am.index(s) for s in lm.state_names]
    np.testing.assert_allclose(ra.y[idx, -1], rl.y[:, -1], atol=1e-7)


def test_augmented_mass_matrix_and_backends():
    """Symmetric indefinite system; the C backend (LU fallback) agrees with numpy."""
    args, constants = knife_edge()
    aug = kd.formulate(method="augmented", **args)
    am = aug.numeric(constants=constants)
    y = np.array([0.1, -0.2, 0.7, 0.3, 0.5, -1.1, 0.4])
    M = am.mass_matrix(0.0, y)
    np.testing.assert_allclose(M, M.T, atol=1e-14)
    eig = np.linalg.eigvalsh(M)
    assert eig.min() < 0 < eig.max()
    assert M[-1, -1] == 0.0
    # no dependent speeds, so nothing to project; energies still available
    assert am.n_u_dep == 0 and am.n_q_dep == 0
    assert np.isfinite(am.kinetic_energy(0.0, y))
    from kanedyn.numerics.backends._c import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    cm = aug.numeric(constants=constants, backend="c")
    np.testing.assert_allclose(cm.rhs(0.3, y), am.rhs(0.3, y), rtol=1e-12, atol=1e-13)


def test_augmented_quadratic_constraint_curvature():
    """A constraint nonlinear in the speeds puts lambda H into the mass matrix."""
    x, y = me.dynamicsymbols("x y")
    ux, uy = me.dynamicsymbols("u_x u_y")
    m, c = sm.symbols("m c", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, ux * N.x + uy * N.y)
    # speed fixed in magnitude: ux^2 + uy^2 = c^2
    aug = kd.formulate(method="augmented", frame=N, q_ind=[x, y], u_ind=[ux], u_dep=[uy],
                       kd_eqs=[x.diff() - ux, y.diff() - uy],
                       velocity_constraints=[ux**2 + uy**2 - c**2],
                       bodies=[me.Particle("p", P, m)], loads=[(P, -m * N.y)])
    am = aug.numeric(constants={m: 2.0})  # c enters only through f = 0 itself
    state = np.array([0.0, 0.0, 0.6, 0.8, 0.25])  # lambda = 0.25
    M = am.mass_matrix(0.0, state)
    # d2T/dw2 = m I, H = 2 I: M + lambda H = (2 + 0.5) I; A = 2 w
    np.testing.assert_allclose(M, [[2.5, 0, 1.2], [0, 2.5, 1.6], [1.2, 1.6, 0]],
                               atol=1e-14)
    np.testing.assert_allclose(am.forcing(0.0, state), [0.0, -2.0, 0.0], atol=1e-14)


# ---------------------------------------------------------------- bad input
def test_auxiliary_speeds_rejected():
    d = kd.models.build("pendulum", tension=True)
    for method in ("lagrange", "augmented"):
        with pytest.raises(kd.ModelError, match=r"auxiliary speeds \(u_auxiliary: u_a\)"):
            d.derive(method=method)


def test_fewer_speeds_than_coordinates_rejected():
    d = kd.models.build("chaplygin-sleigh")
    for method in ("lagrange", "augmented"):
        with pytest.raises(kd.ModelError, match=r"3 coordinates \(x, y, theta\) and 2 "
                                                r"speeds \(u, w\)"):
            d.derive(method=method)


def test_speed_derivative_rejected():
    d = kd.models.build("pendulum")
    P, A, m, u = (d.symbols[k] for k in ("P", "A", "m", "u"))
    args = dict(d.kane_args)
    args["loads"] = list(args["loads"]) + [(P, -m * u.diff(T) * A.x)]
    with pytest.raises(kd.ModelError, match=r"load on P contains .*a derivative of u; "
                                            r"the 'lagrange' formulation replaces"):
        kd.formulate(method="lagrange", **args)


def test_speeds_not_solvable_rejected():
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q1 * N.x + q2 * N.y)
    P.set_vel(N, (u1 + u2) * N.x + (u1 + u2) * N.y)
    args = dict(frame=N, q_ind=[q1, q2], u_ind=[u1, u2],
                kd_eqs=[q1.diff() - u1 - u2, q2.diff() - u1 - u2],
                bodies=[me.Particle("p", P, sm.Symbol("m"))])
    with pytest.raises(kd.ModelError, match="cannot be solved for the speeds"):
        kd.formulate(method="lagrange", **args)


def test_registered():
    assert {"kane", "lagrange", "augmented"} <= set(kd.FORMULATIONS)
    with pytest.raises(kd.ModelError, match="augmented.*kane.*lagrange"):
        kd.formulate(method="hamilton", **kd.models.build("pendulum").kane_args)
