"""Actuators, ball-screw transmissions and actuator forces by virtual work."""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn import ModelError


def carriage():
    """A block of mass m sliding along a horizontal rail (coordinate x)."""
    x, v = me.dynamicsymbols("x v")
    m = sm.symbols("m", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, v * N.x)
    block = me.Particle("block", P, m)
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v], bodies=[block],
                  loads=[])
    return eom.numeric(constants={m: 3.5}), x, v, N, O, P


def test_ball_screw_reflected_inertia_closed_form():
    model, x, v, N, O, P = carriage()
    lead, Jr, Jc, Js, mass = 0.005, 2.1e-5, 0.7e-5, 3.3e-5, 3.5
    screw = kd.BallScrew(lead, Jr, Jc, Js)
    drive = kd.JointActuator("screw", x, point=P, axis=N.x, transmission=screw)
    a = 1.7
    out = kd.actuator_forces(model, [drive], 0.0, [0.2, 0.4], [a])
    ratio = 2 * np.pi / lead
    effective = ratio ** 2 * (Jr + Jc + Js) + mass
    assert out.success and not out.redundant
    assert out["screw"] == pytest.approx(effective * a, rel=1e-12)
    assert out.motor_torques["screw"] == pytest.approx(effective * a / ratio, rel=1e-12)
    assert float(screw.reflected_inertia) == pytest.approx(ratio ** 2 * (Jr + Jc + Js))
    # the transmission as an inertial element on the rate x'
    element = drive.inertia_element()
    assert isinstance(element, kd.RateInertia) and element.name == "screw_drive"
    assert float(element.inertia[0, 0]) == pytest.approx(ratio ** 2 * (Jr + Jc + Js))
    assert kd.JointActuator("bare", x).inertia_element() is None


def two_link_arm():
    """Planar arm of uniform rods under gravity, in absolute angles th1, th2."""
    th1, th2, w1, w2 = me.dynamicsymbols("th1 th2 w1 w2")
    m1, m2, l1, l2, g = sm.symbols("m1 m2 l1 l2 g", positive=True)
    N = me.ReferenceFrame("N")
    A, B = N.orientnew("A", "Axis", (th1, N.z)), N.orientnew("B", "Axis", (th2, N.z))
    A.set_ang_vel(N, w1 * N.z)
    B.set_ang_vel(N, w2 * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    E = O.locatenew("E", l1 * A.x)
    E.v2pt_theory(O, N, A)
    H = E.locatenew("H", l2 * B.x)
    H.v2pt_theory(E, N, B)
    G1 = O.locatenew("G1", l1 / 2 * A.x)
    G1.v2pt_theory(O, N, A)
    G2 = E.locatenew("G2", l2 / 2 * B.x)
    G2.v2pt_theory(E, N, B)
    b1 = me.RigidBody("upper", G1, A, m1, (me.inertia(A, 0, 0, m1 * l1 ** 2 / 12), G1))
    b2 = me.RigidBody("fore", G2, B, m2, (me.inertia(B, 0, 0, m2 * l2 ** 2 / 12), G2))
    eom = kd.kane(frame=N, q_ind=[th1, th2], u_ind=[w1, w2],
                  kd_eqs=[th1.diff() - w1, th2.diff() - w2], bodies=[b1, b2],
                  loads=[(G1, -m1 * g * N.y), (G2, -m2 * g * N.y)])
    values = {m1: 1.3, m2: 0.9, l1: 0.7, l2: 0.5, g: 9.81}
    return eom.numeric(constants=values), (th1, th2), (N, A, B, O, E, H), values


def arm_torques_closed_form(q1, q2, u1, u2, a1, a2, m1=1.3, m2=0.9, l1=0.7, l2=0.5,
                            g=9.81):
    """Textbook joint torques of a two-link arm in relative angles (q2 at the elbow)."""
    c1, c2 = l1 / 2, l2 / 2
    I1, I2 = m1 * l1 ** 2 / 12, m2 * l2 ** 2 / 12
    M11 = I1 + I2 + m1 * c1 ** 2 + m2 * (l1 ** 2 + c2 ** 2 + 2 * l1 * c2 * np.cos(q2))
    M12 = I2 + m2 * (c2 ** 2 + l1 * c2 * np.cos(q2))
    M22 = I2 + m2 * c2 ** 2
    h = m2 * l1 * c2 * np.sin(q2)
    g1 = (m1 * c1 + m2 * l1) * g * np.cos(q1) + m2 * c2 * g * np.cos(q1 + q2)
    g2 = m2 * c2 * g * np.cos(q1 + q2)
    return np.array([M11 * a1 + M12 * a2 - h * (2 * u1 * u2 + u2 ** 2) + g1,
                     M12 * a1 + M22 * a2 + h * u1 ** 2 + g2])


def test_two_link_arm_joint_torques():
    model, (th1, th2), (N, A, B, *_), _ = two_link_arm()
    shoulder = kd.JointActuator("shoulder", th1, frame=A, reaction_frame=N, axis=N.z)
    elbow = kd.JointActuator("elbow", th2 - th1, frame=B, reaction_frame=A, axis=N.z)
    amap = kd.ActuatorMap(model, [shoulder, elbow])
    rng = np.random.default_rng(3)
    for _ in range(5):
        y = rng.uniform(-2, 2, 4)
        udot = rng.uniform(-3, 3, 2)
        out = amap.forces(0.0, y, udot)
        q1, q2 = y[0], y[1] - y[0]
        u1, u2 = y[2], y[3] - y[2]
        expected = arm_torques_closed_form(q1, q2, u1, u2, udot[0], udot[1] - udot[0])
        np.testing.assert_allclose(out.forces, expected, rtol=1e-11, atol=1e-11)
        assert out.success and out.condition < 10
        # and J^T f equals M u' - F of the forward equations
        tau = model.mass_matrix(0.0, y) @ udot - model.forcing(0.0, y)
        np.testing.assert_allclose(out.jacobian.T @ out.forces, tau, atol=1e-11)


def four_bar():
    d = kd.models.build("four-bar")
    return d, d.numeric()


def _energy_rate(model, y, udot_full, h=1e-6):
    ydot = np.concatenate([model.rhs(0.0, y)[:model.n_q], udot_full])
    return (model.total_energy(0.0, y + h * ydot)
            - model.total_energy(0.0, y - h * ydot)) / (2 * h)


@pytest.mark.parametrize("kind", ["joint", "linear", "screw"])
def test_four_bar_power_balance(kind):
    d, model = four_bar()
    q1 = d.symbols["q"][0]
    N = d.symbols["N"]
    if kind == "joint":
        act = kd.JointActuator("crank", q1)
    else:
        # a leg from a ground pivot below O to the crank tip
        la = sm.Symbol("l_a", positive=True)
        A = N.orientnew("A_leg", "Axis", (q1, N.z))
        O = me.Point("O_leg")
        base = O.locatenew("base", -0.4 * N.y + 0.1 * N.x)
        tip = O.locatenew("tip", la * A.x)
        screw = kd.BallScrew(0.01, 3e-5, 1e-5, 2e-5) if kind == "screw" else None
        act = kd.LinearActuator("leg", base, tip, N, transmission=screw)
    amap = kd.ActuatorMap(model, [act])
    rng = np.random.default_rng(11)
    y0 = model.state(d.initial_state)
    checked = 0
    for _ in range(6):
        y = y0.copy()
        y[0] = rng.uniform(0.5, 2.0)
        y[3] = rng.uniform(-2, 2)
        y = model.consistent_state(0.0, y)
        out = amap.forces(0.0, y, [rng.uniform(-3, 3)])
        assert out.success, out.message
        udot_full = _udot_full(model, y, out)
        power = float(out.forces[0] * out.rates[0])
        dE = _energy_rate(model, y, udot_full)
        if kind != "joint":  # the leg's acceleration against a difference in time
            h = 1e-6
            ydot = np.concatenate([model.rhs(0.0, y)[:model.n_q], udot_full])
            ahead, behind = (amap.forces(0.0, y + s * h * ydot, udot_full).rates[0]
                             for s in (1, -1))
            assert out.rate_derivatives[0] == pytest.approx((ahead - behind) / (2 * h),
                                                            rel=1e-6, abs=1e-8)
        if kind == "screw":  # the drive train's kinetic energy m_r s'^2 / 2 changes too
            m_r = (2 * np.pi / 0.01) ** 2 * 6e-5
            dE += m_r * out.rates[0] * out.rate_derivatives[0]
        assert power == pytest.approx(dE, rel=1e-7, abs=1e-8)
        checked += 1
    assert checked == 6


def _udot_full(model, y, out):
    """Accelerations of all speeds reproduced by forward dynamics under tau."""
    M, F = model.mass_matrix(0.0, y), model.forcing(0.0, y)
    p = model.n_u_ind
    F = F.copy()
    F[:p] += out.generalized_forces
    return np.linalg.solve(M, F)


def test_redundant_actuators_least_norm():
    model, x, v, N, O, P = carriage()
    left = kd.JointActuator("left", x)
    right = kd.JointActuator("right", 2 * v)  # a speed expression: twice the travel rate
    with pytest.raises(ModelError, match="redundant=True"):  # not said: refused
        kd.ActuatorMap(model, [left, right])
    out = kd.actuator_forces(model, [left, right], 0.0, [0.0, 0.0], [2.0], redundant=True)
    # least norm of f1 + 2 f2 = m a = 7: f = (7/5, 14/5)
    np.testing.assert_allclose(out.forces, [7 / 5, 14 / 5], rtol=1e-12)
    assert out.redundant and out.success
    assert "redundant" in out.message and "least-norm" in out.message


def test_singular_configuration_reports_condition():
    model, (th1, th2), (N, A, B, O, E, H), _ = two_link_arm()
    base = O.locatenew("base", -0.3 * N.y)
    legs = [kd.LinearActuator("to_elbow", base, E, N), kd.LinearActuator("to_hand", O, H, N)]
    amap = kd.ActuatorMap(model, legs)
    # arm straight: the distance O-H is at its maximum, its rate vanishes
    out = amap.forces(0.0, [0.3, 0.3 + 1e-10, 0.0, 0.0], [0.0, 0.0])
    assert not out.success
    assert out.condition > 1e8
    assert "singular" in out.message and "condition number" in out.message
    assert np.all(np.isfinite(out.forces))
    bent = amap.forces(0.0, [0.3, 1.2, 0.0, 0.0], [0.0, 0.0])
    assert bent.success and bent.condition < 100


def test_bad_input():
    model, x, v, N, O, P = carriage()
    arm, *_ = two_link_arm()
    with pytest.raises(ModelError, match="cannot drive"):
        kd.ActuatorMap(arm, [kd.JointActuator("one", me.dynamicsymbols("th1"))])
    with pytest.raises(ModelError, match="named 'a'"):
        kd.ActuatorMap(model, [kd.JointActuator("a", x), kd.JointActuator("a", x)])
    with pytest.raises(ModelError, match="lead must be positive"):
        kd.BallScrew(0.0, 1e-5, 0, 0)
    with pytest.raises(ModelError, match="no value"):
        kd.ActuatorMap(model, [kd.JointActuator("k", sm.Symbol("k") * x)])


def test_loads():
    model, x, v, N, O, P = carriage()
    leg = kd.LinearActuator("leg", O, P, N)
    F = sm.Symbol("F")
    (pa, fa), (pb, fb) = leg.to_loads(F)
    assert pa is O and pb is P
    assert sm.simplify((fb + fa).magnitude()) == 0
    body = me.RigidBody("b", P, N, 1, (me.inertia(N, 1, 1, 1), P))
    wrench = kd.ExternalWrench(body, force=3 * N.x, moment=2 * N.z)
    assert wrench.to_loads() == [(P, 3 * N.x), (N, 2 * N.z)]


def test_ball_screw_equals_a_modelled_rotor():
    """The transmission's reflected inertia equals a rotor body turning (2 pi/p) x."""
    lead, J = 0.004, 5.1e-5
    x, v = me.dynamicsymbols("x v")
    m = sm.symbols("m", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, v * N.x)
    ratio = 2 * sm.pi / lead
    R = N.orientnew("R", "Axis", (ratio * x, N.x))
    R.set_ang_vel(N, ratio * v * N.x)
    rotor = me.RigidBody("rotor", O, R, 1.0, (me.inertia(R, J, 0, 0), O))
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v],
                  bodies=[me.Particle("block", P, m), rotor], loads=[])
    with_rotor = eom.numeric(constants={m: 3.5})
    plain, *_ = carriage()
    modelled = kd.actuator_forces(with_rotor, [kd.JointActuator("s", x)], 0.0, [0.1, 0.3],
                                  [2.5])
    reflected = kd.actuator_forces(plain, [kd.JointActuator(
        "s", x, transmission=kd.BallScrew(lead, J, 0.0, 0.0))], 0.0, [0.1, 0.3], [2.5])
    assert reflected["s"] == pytest.approx(modelled["s"], rel=1e-12)


def test_arm_round_trip_through_loads():
    """Forward dynamics under the computed torques (as loads) gives back u'."""
    th1, th2, w1, w2 = me.dynamicsymbols("th1 th2 w1 w2")
    model, _, (N, A, B, O, E, H), values = two_link_arm()
    eom0 = model._eom
    T1, T2 = sm.symbols("T1 T2")
    shoulder = kd.JointActuator("shoulder", th1, frame=A, reaction_frame=N, axis=N.z)
    elbow = kd.JointActuator("elbow", th2 - th1, frame=B, reaction_frame=A, axis=N.z)
    loads = list(eom0.loads) + shoulder.to_loads(T1) + elbow.to_loads(T2)
    driven = kd.kane(frame=N, q_ind=[th1, th2], u_ind=[w1, w2],
                     kd_eqs=[th1.diff() - w1, th2.diff() - w2], bodies=list(eom0.bodies),
                     loads=loads)
    y, udot = np.array([0.4, -0.9, 1.1, -0.3]), np.array([0.8, -1.6])
    out = kd.actuator_forces(model, [shoulder, elbow], 0.0, y, udot)
    forward = driven.numeric(constants=values | {T1: out.forces[0], T2: out.forces[1]})
    np.testing.assert_allclose(forward.rhs(0.0, y)[2:], udot, rtol=1e-10, atol=1e-12)


def test_four_bar_rocker_dead_centre():
    """Crank and coupler in line: the rocker stops moving, a rocker drive is singular."""
    d, model = four_bar()
    q1, q2, q3 = d.symbols["q"]
    la, lb, lc, ld = 0.3, 1.0, 0.8, 0.9
    a = np.arccos(((la + lb) ** 2 + ld ** 2 - lc ** 2) / (2 * (la + lb) * ld))
    y = model.state(d.initial_state)
    y[:3] = [a, a + 1e-3, 1.0]
    y[3] = 1.0
    amap = kd.ActuatorMap(model, [kd.JointActuator("rocker", q3)])
    y = model.consistent_state(0.0, y)
    y[0] = y[1] = a  # exactly in line (q2 = q1 solves the loop at this crank angle)
    y = model.consistent_state(0.0, y)
    out = amap.forces(0.0, y, [0.5])
    assert not out.success and out.condition > 1e8, (out.condition, y[:3] - a)
    assert "condition number" in out.message
    away = y.copy()
    away[0] = a + 0.6
    away = model.consistent_state(0.0, away)
    fine = amap.forces(0.0, away, [0.5])
    assert fine.success and fine.condition < 1e3
