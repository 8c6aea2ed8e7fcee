"""Generalized-inertia elements: RateInertia, Inerter, AddedMass, drive-train inertia."""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn import ModelError

_TIMES = np.linspace(0.0, 2.0, 41)


def line_masses(with_inerter=True, method="kane"):
    """Two masses on a line joined by a spring k2 and an inerter b; k1 to the ground."""
    x1, x2, u1, u2 = me.dynamicsymbols("x1 x2 u1 u2")
    m1, m2, b, k1, k2 = sm.symbols("m1 m2 b k1 k2", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P1 = O.locatenew("P1", (1 + x1) * N.x)
    P1.set_vel(N, u1 * N.x)
    P2 = O.locatenew("P2", (2 + x2) * N.x)
    P2.set_vel(N, u2 * N.x)
    bodies = [me.Particle("p1", P1, m1), me.Particle("p2", P2, m2)]
    if with_inerter:
        bodies.append(kd.Inerter("inerter", P1, P2, b, N))
    eom = kd.formulate(method=method, frame=N, q_ind=[x1, x2], u_ind=[u1, u2],
                       kd_eqs=[x1.diff() - u1, x2.diff() - u2], bodies=bodies,
                       loads=[(P1, (-k1 * x1 + k2 * (x2 - x1)) * N.x),
                              (P2, -k2 * (x2 - x1) * N.x)],
                       potential_energy=k1 * x1 ** 2 / 2 + k2 * (x2 - x1) ** 2 / 2)
    return eom, (m1, m2, b, k1, k2)


@pytest.mark.parametrize("method", ["kane", "lagrange", "orthogonal-complement"])
def test_two_masses_mass_matrix_exact(method):
    eom, (m1, m2, b, k1, k2) = line_masses(method=method)
    M = sm.simplify(eom.mass_matrix)
    assert sm.simplify(M - sm.Matrix([[m1 + b, -b], [-b, m2 + b]])) == sm.zeros(2, 2)
    # the inerter does no work at rest and brings no velocity terms on a line
    x1, x2 = eom.q
    F = sm.Matrix([-k1 * x1 + k2 * (x2 - x1), -k2 * (x2 - x1)])
    assert sm.simplify(eom.forcing - F) == sm.zeros(2, 1)


def test_two_masses_frequencies_closed_form():
    eom, (m1, m2, b, k1, k2) = line_masses()
    values = {m1: 2.0, m2: 0.7, b: 0.4, k1: 30.0, k2: 11.0}
    model = eom.numeric(constants=values)
    A = model.linearize(np.zeros(4))[0]
    omega = np.sort(np.sqrt(-np.linalg.eigvals(A[2:, :2]).real))
    # det(K - lam M) = 0 with M = [[m1+b, -b], [-b, m2+b]], K = [[k1+k2, -k2], [-k2, k2]]
    M1, M2, B, K1, K2 = (values[s] for s in (m1, m2, b, k1, k2))
    a2 = (M1 + B) * (M2 + B) - B ** 2
    a1 = -((K1 + K2) * (M2 + B) + K2 * (M1 + B) - 2 * K2 * B)
    a0 = (K1 + K2) * K2 - K2 ** 2
    lam = np.sort([(-a1 - s * np.sqrt(a1 ** 2 - 4 * a2 * a0)) / (2 * a2) for s in (1, -1)])
    assert omega == pytest.approx(np.sqrt(lam), rel=1e-10)
    # kinetic energy includes the inerter's: T = (m1 u1^2 + m2 u2^2 + b (u2 - u1)^2) / 2
    y = np.array([0.01, -0.02, 0.3, -0.5])
    T = (M1 * 0.3 ** 2 + M2 * 0.5 ** 2 + B * 0.8 ** 2) / 2
    assert model.kinetic_energy(0.0, y) == pytest.approx(T, rel=1e-13)


def tmd_on_primary(inerter):
    """Primary m (spring k) with a damper mass md (spring kd, damper cd) on top.

    ``inerter``: an inerter b from the damper mass to the ground (a TMDI), or
    ``None`` (a TMD).  Returns the equations and the symbols.
    """
    x, xd, u, ud = me.dynamicsymbols("x xd u ud")
    m, k, md, kd_, cd, b = sm.symbols("m k md kd cd b", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", -1 * N.x)  # the inerter's ground terminal
    G.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, u * N.x)
    D = O.locatenew("D", (1 + xd) * N.x)
    D.set_vel(N, ud * N.x)
    damper_mass = md if inerter else md + b
    bodies = [me.Particle("primary", P, m), me.Particle("damper", D, damper_mass)]
    if inerter:
        bodies.append(kd.Inerter("tmdi", D, G, b, N))
    spring = -kd_ * (xd - x) - cd * (ud - u)
    eom = kd.kane(frame=N, q_ind=[x, xd], u_ind=[u, ud], kd_eqs=[x.diff() - u, xd.diff() - ud],
                  bodies=bodies, loads=[(P, (-k * x - spring) * N.x), (D, spring * N.x)])
    return eom, {m: 5.0, k: 200.0, md: 0.25, kd_: 9.0, cd: 0.4, b: 0.15}


def test_grounded_inerter_is_added_mass():
    """A TMDI with its inerter grounded equals a TMD of mass md + b, exactly."""
    runs = []
    for inerter in (True, False):
        eom, values = tmd_on_primary(inerter)
        model = eom.numeric(constants=values)
        y = np.array([0.02, -0.03, 0.1, 0.4])
        runs.append((model.mass_matrix(0.0, y), model.forcing(0.0, y),
                     kd.simulate(model, (0.0, 2.0), [0.05, 0.0, 0.0, 0.0], t_eval=_TIMES,
                                 rtol=1e-11, atol=1e-12)))
    (Mi, Fi, ri), (Mt, Ft, rt) = runs
    assert np.array_equal(Mi, Mt) and np.allclose(Fi, Ft, rtol=0, atol=1e-15)
    assert ri.success and rt.success
    assert np.max(np.abs(ri.y - rt.y)) < 1e-10
    # a single dof: a mass m + b on a spring k
    eom, values = tmd_on_primary(True)
    lin = eom.numeric(constants=values).linearize(np.zeros(4))[0]
    lin_t = tmd_on_primary(False)[0].numeric(constants=values).linearize(np.zeros(4))[0]
    assert np.sort_complex(np.linalg.eigvals(lin)) == pytest.approx(
        np.sort_complex(np.linalg.eigvals(lin_t)), rel=1e-12)


def free_body(added, method="kane"):
    """A free rigid body; speeds are the body-frame components of v and omega.

    ``added``: a 6x6 matrix as an AddedMass element, or ``(a, J)`` added to the
    body's own mass and central inertia.
    """
    q = me.dynamicsymbols("q1:7")
    u = me.dynamicsymbols("u1:7")
    m, I1, I2, I3 = sm.symbols("m I1 I2 I3", positive=True)
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Body", q[3:], "123")
    B.set_ang_vel(N, u[3] * B.x + u[4] * B.y + u[5] * B.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", q[0] * N.x + q[1] * N.y + q[2] * N.z)
    v = u[0] * B.x + u[1] * B.y + u[2] * B.z
    C.set_vel(N, v)
    vN = v.to_matrix(N)
    kd_eqs = [q[i].diff() - vN[i] for i in range(3)]
    kd_eqs += list(me.kinematic_equations(u[3:], q[3:], "Body", "123"))
    mass, inertia = m, me.inertia(B, I1, I2, I3)
    bodies = []
    if isinstance(added, tuple):
        a, J = added
        mass = m + a
        inertia = inertia + me.inertia(B, *[J[i, j] for i, j in
                                            ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))])
    else:
        bodies.append(kd.AddedMass("fluid", C, B, added, N))
    bodies.insert(0, me.RigidBody("hull", C, B, mass, (inertia, C)))
    eom = kd.formulate(method=method, frame=N, q_ind=q, u_ind=u, kd_eqs=kd_eqs,
                       bodies=bodies, loads=[(C, -9.81 * m * N.z)])
    return eom.numeric(constants={m: 3.0, I1: 0.4, I2: 0.5, I3: 0.3})


def test_added_mass_on_free_body():
    rng = np.random.default_rng(7)
    R = rng.normal(size=(6, 6))
    A = R @ R.T  # symmetric positive definite, fully coupled
    model = free_body(A)
    y = rng.normal(size=12)
    rigid = np.diag([3.0, 3.0, 3.0, 0.4, 0.5, 0.3])
    assert model.mass_matrix(0.0, y) == pytest.approx(rigid + A, rel=1e-13, abs=1e-13)
    # isotropic translation and any rotational block: the same as a heavier body
    J = np.array([[0.2, 0.03, -0.01], [0.03, 0.1, 0.02], [-0.01, 0.02, 0.15]])
    A2 = np.zeros((6, 6))
    A2[:3, :3] = 1.7 * np.eye(3)
    A2[3:, 3:] = J
    element, heavier = free_body(A2), free_body((1.7, sm.Matrix(J)))
    for _ in range(3):
        y = rng.normal(size=12)
        assert element.mass_matrix(0.0, y) == pytest.approx(heavier.mass_matrix(0.0, y),
                                                            rel=1e-13, abs=1e-13)
        assert element.forcing(0.0, y) == pytest.approx(heavier.forcing(0.0, y),
                                                        rel=1e-12, abs=1e-12)


def test_added_mass_kane_matches_lagrange():
    """Kirchhoff's velocity terms: Kane's block equals Lagrange's equations of T."""
    rng = np.random.default_rng(11)
    R = rng.normal(size=(6, 6))
    A = R @ R.T
    kane, lagrange = free_body(A), free_body(A, "lagrange")
    y = np.concatenate([0.3 * rng.normal(size=6), rng.normal(size=6)])
    y_rates = np.concatenate([y[:6], kane.rhs(0.0, y)[:6]])  # [q, q'] for Lagrange
    assert lagrange.kinetic_energy(0.0, y_rates) == pytest.approx(
        kane.kinetic_energy(0.0, y), rel=1e-12)
    times = np.linspace(0.0, 0.5, 11)
    rk = kd.simulate(kane, (0.0, 0.5), y, t_eval=times, rtol=1e-11, atol=1e-12)
    rl = kd.simulate(lagrange, (0.0, 0.5), y_rates, t_eval=times, rtol=1e-11, atol=1e-12)
    assert rk.success and rl.success
    assert np.max(np.abs(rk.y[:6] - rl.y[:6])) < 1e-9


def test_ball_screw_carriage_effective_mass_and_energy():
    x, v = me.dynamicsymbols("x v")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, v * N.x)
    mass, k, lead, Jr, Jc, Js = 3.5, 40.0, 0.005, 2.1e-5, 0.7e-5, 3.3e-5
    screw = kd.BallScrew(lead, Jr, Jc, Js)
    for actuator in (kd.JointActuator("screw", x, point=P, axis=N.x, transmission=screw),
                     kd.JointActuator("screw", v, point=P, axis=N.x, transmission=screw),
                     kd.LinearActuator("screw", O, P, N, transmission=screw)):
        start = 0.3 if isinstance(actuator, kd.LinearActuator) else 0.0
        eom = kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v],
                      bodies=[me.Particle("carriage", P, mass), actuator.inertia_element()],
                      loads=[(P, -k * (x - start) * N.x)],
                      potential_energy=k * (x - start) ** 2 / 2)
        model = eom.numeric()
        effective = mass + (2 * np.pi / lead) ** 2 * (Jr + Jc + Js)
        y0 = [start + 0.01, 0.2]
        assert model.mass_matrix(0.0, y0)[0, 0] == pytest.approx(effective, rel=1e-13)
        res = kd.simulate(model, (0.0, 2.0), y0, t_eval=_TIMES, rtol=1e-10, atol=1e-12)
        assert res.success
        E0 = effective * 0.2 ** 2 / 2 + k * 0.01 ** 2 / 2
        assert res.energy == pytest.approx(np.full(_TIMES.size, E0), rel=1e-7)
        # the period of m_eff on k
        omega = np.sqrt(k / effective)
        expected = start + 0.01 * np.cos(omega * _TIMES) + 0.2 / omega * np.sin(omega * _TIMES)
        assert res.y[0] == pytest.approx(expected, abs=1e-8)


def cart_pendulum(method):
    """A cart (x) with a pendulum (th); an inerter from the bob to a ground point."""
    x, th, u, w = me.dynamicsymbols("x th u w")
    M, m, l, b, g = sm.symbols("M m l b g", positive=True)
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (th, N.z))
    A.set_ang_vel(N, w * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", x * N.x)
    C.set_vel(N, u * N.x)
    P = C.locatenew("P", -l * A.y)
    P.v2pt_theory(C, N, A)
    G = O.locatenew("G", 0.7 * N.x + 0.4 * N.y)
    G.set_vel(N, 0)
    bodies = [me.Particle("cart", C, M), me.Particle("bob", P, m),
              kd.Inerter("inerter", P, G, b, N)]
    eom = kd.formulate(method=method, frame=N, q_ind=[x, th], u_ind=[u, w],
                       kd_eqs=[x.diff() - u, th.diff() - w], bodies=bodies,
                       loads=[(P, -m * g * N.y), (C, -3.0 * x * N.x)],
                       potential_energy=-m * g * l * sm.cos(th) + 1.5 * x ** 2)
    return eom, {M: 1.2, m: 0.5, l: 0.8, b: 0.3, g: 9.81}


def test_formulations_and_backends_agree():
    rng = np.random.default_rng(3)
    states = [rng.normal(size=4) for _ in range(4)]
    models = {}
    for method in ("kane", "lagrange", "orthogonal-complement"):
        eom, values = cart_pendulum(method)
        models[method] = eom.numeric(constants=values)
    ref = models["kane"]
    for method, model in models.items():
        for y in states:
            assert model.rhs(0.0, y) == pytest.approx(ref.rhs(0.0, y), rel=1e-11, abs=1e-11)
            assert model.kinetic_energy(0.0, y) == pytest.approx(ref.kinetic_energy(0.0, y),
                                                                 rel=1e-12)
    # the inerter's energy is in the kinetic energy: b/2 (d|PG|/dt)^2
    eom, values = cart_pendulum("kane")
    no_inerter = eom.numeric(constants={**values, sm.Symbol("b", positive=True): 0.0})
    y = states[0]
    xv, thv, uv, wv = y
    P = np.array([xv + 0.8 * np.sin(thv), -0.8 * np.cos(thv)])
    vP = np.array([uv + 0.8 * np.cos(thv) * wv, 0.8 * np.sin(thv) * wv])
    r = P - np.array([0.7, 0.4])
    rate = r @ vP / np.linalg.norm(r)
    assert ref.kinetic_energy(0.0, y) - no_inerter.kinetic_energy(0.0, y) == pytest.approx(
        0.3 * rate ** 2 / 2, rel=1e-12)
    c_model = eom.numeric(constants=values, backend="c")
    for y in states:
        assert c_model.rhs(0.0, y) == pytest.approx(ref.rhs(0.0, y), rel=1e-12, abs=1e-12)
    # inverse dynamics: M u' - F of the forward equations
    udot = rng.normal(size=2)
    y = states[1]
    tau = ref.inverse_dynamics(0.0, y[:2], y[2:], udot)
    expected = ref.mass_matrix(0.0, y) @ udot - ref.forcing(0.0, y)
    assert np.ravel(tau) == pytest.approx(np.ravel(expected), rel=1e-11, abs=1e-11)
    # energy conservation in the free motion (gravity and the cart's spring)
    res = kd.simulate(ref, (0.0, 2.0), states[2], t_eval=_TIMES, rtol=1e-10, atol=1e-12)
    assert res.success
    assert np.max(np.abs(res.energy - res.energy[0])) < 1e-7 * abs(res.energy[0])


def test_bad_input_names_the_element():
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    x, v = me.dynamicsymbols("x v")
    with pytest.raises(ModelError, match="'mw'.*symmetric"):
        kd.RateInertia("mw", [v, 2 * v], [[1.0, 0.2], [0.3, 1.0]])
    with pytest.raises(ModelError, match="'mw'.*2 x 2"):
        kd.RateInertia("mw", [v, 2 * v], [[1.0, 0.2, 0.0]])
    with pytest.raises(ModelError, match="'neg'.*semi-definite"):
        kd.RateInertia("neg", [v], -2.0)
    with pytest.raises(ModelError, match="'fluid'.*6 x 6"):
        kd.AddedMass("fluid", O, N, np.eye(3), N)
    with pytest.raises(ModelError, match="'same'.*coincide"):
        kd.Inerter("same", O, O.locatenew("O2", 0 * N.x), 1.0, N)
    with pytest.raises(ModelError, match="'bad'.*constant"):
        kd.RateInertia("bad", [v], x)
    # a rate that is not linear in the speeds
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, v * N.x)
    with pytest.raises(ModelError, match="'square'.*not linear"):
        kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v],
                bodies=[me.Particle("p", P, 1.0), kd.RateInertia("square", [v ** 2], 1.0)],
                loads=[])
