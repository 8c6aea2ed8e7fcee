"""Validation against closed-form solutions (see ../shared/REFERENCES.md).

Each reference below is derived by hand (Newton-Euler or energy), not from
kanedyn's equations.
"""

import numpy as np
import pytest
import sympy as sm
from scipy.optimize import brentq
from scipy.special import ellipk

import kanedyn as kd

TIGHT = dict(rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------ pendulum
def test_pendulum_period_from_elliptic_integral():
    d = kd.models.build("pendulum")
    model = d.numeric(constants={"l": 0.8, "g": 9.81})
    q = d.symbols["q"]

    def upward_crossing(t, y):
        return y[1]
    upward_crossing.direction = 1.0

    res = kd.simulate(model, (0, 6), {q: np.pi / 2, d.symbols["u"]: 0.0},
                      events=[upward_crossing], **TIGHT)
    periods = np.diff(res.t_events[0])
    exact = 4 * ellipk(np.sin(np.pi / 4) ** 2) * np.sqrt(0.8 / 9.81)
    assert len(periods) >= 2
    np.testing.assert_allclose(periods, exact, rtol=1e-9)


def test_pendulum_rod_tension():
    """T = m (g cos q + l u^2) along a large swing."""
    d = kd.models.build("pendulum", tension=True)
    m, l, g = 1.7, 0.9, 9.81
    model = d.numeric(constants={"m": m, "l": l, "g": g})
    res = kd.simulate(model, (0, 3), {d.symbols["q"]: 2.5, d.symbols["u"]: 0.4},
                      t_eval=np.linspace(0, 3, 61), constraint_forces=True, **TIGHT)
    q, u = res["q"], res["u"]
    np.testing.assert_allclose(res["T"], m * (g * np.cos(q) + l * u ** 2), rtol=1e-10,
                               atol=1e-10)


# --------------------------------------------------------------- the sleigh
def test_chaplygin_sleigh_closed_form():
    d = kd.models.build("chaplygin-sleigh", lateral_force=True)
    m, a, I_C = 1.3, 0.25, 0.07
    u0, w0 = -0.8, 1.5
    model = d.numeric(constants={"m": m, "a": a, "I_C": I_C})
    t = np.linspace(0, 15, 151)
    s = d.symbols
    res = kd.simulate(model, (0, 15), {s["x"]: 0, s["y"]: 0, s["theta"]: 0.3,
                                       s["u"]: u0, s["w"]: w0},
                      t_eval=t, constraint_forces=True, **TIGHT)
    J = I_C + m * a ** 2
    U = np.sqrt(u0 ** 2 + J / m * w0 ** 2)
    lam = a * m * U / J
    u_exact = U * np.tanh(lam * t + np.arctanh(u0 / U))
    np.testing.assert_allclose(res["u"], u_exact, rtol=0, atol=1e-9)
    # |w| from energy conservation, the lateral knife-edge force from Newton-Euler
    w = res["w"]
    np.testing.assert_allclose(w ** 2, m / J * (U ** 2 - u_exact ** 2), atol=1e-9)
    np.testing.assert_allclose(res["R"], m * res["u"] * w * (1 - m * a ** 2 / J),
                               atol=1e-9)


# ------------------------------------------------------------- rolling disk
def _upright_rolling(model, spin):
    names = model.state_names
    y = np.zeros(model.n_states)
    y[names.index("u2")] = spin
    return model.consistent_state(0.0, y)


def _max_real_part(model, spin):
    A, _, _ = model.linearize(_upright_rolling(model, spin))
    return np.max(np.linalg.eigvals(A).real)


def test_rolling_disk_stability_threshold():
    """Upright rolling of a thin disk is stable iff Omega^2 > g / (3 r)."""
    d = kd.models.build("rolling-disk")
    r, g = 0.3, 9.81
    model = d.numeric(constants={"r": r, "g": g, "m": 2.0})
    critical = np.sqrt(g / (3 * r))
    assert _max_real_part(model, 1.02 * critical) < 1e-9  # marginal: imaginary pairs
    assert _max_real_part(model, 0.98 * critical) > 1e-3
    # the transition, located by bisection on "has an unstable eigenvalue"
    found = brentq(lambda s: _max_real_part(model, s) - 1e-4, 0.9 * critical, critical,
                   xtol=1e-12)
    assert found < critical
    assert critical - found < 1e-6 * critical


def _steady_turn_state(model, theta, yaw_rate, r, g):
    """State of a thin disk in a steady turn (hand-derived Newton-Euler balance).

    With lean theta and yaw rate psi', the spin component along the axle
    Omega satisfies (r/4) psi'^2 sin(th) cos(th) - (3/2) r Omega psi' cos(th)
    - g sin(th) = 0.
    """
    omega = ((r / 4) * yaw_rate ** 2 * np.sin(theta) * np.cos(theta)
             - g * np.sin(theta)) / (1.5 * r * yaw_rate * np.cos(theta))
    names = model.state_names
    y = np.zeros(model.n_states)
    y[names.index("q4")] = theta
    y[names.index("u2")] = omega
    y[names.index("u3")] = yaw_rate * np.cos(theta)
    return model.consistent_state(0.0, y)


def test_rolling_disk_steady_turn():
    d = kd.models.build("rolling-disk", normal_force=True)
    r, g, m = 0.3, 9.81, 2.0
    model = d.numeric(constants={"r": r, "g": g, "m": m})
    y = _steady_turn_state(model, theta=0.3, yaw_rate=2.0, r=r, g=g)
    udot = model.rhs(0.0, y)[model.n_q:]
    assert np.max(np.abs(udot[:3])) < 1e-10
    # in a steady turn the normal force carries the weight exactly
    assert abs(model.auxiliary(0.0, y)["N_c"] - m * g) < 1e-10
    # and the motion stays steady: lean and rates do not change
    res = kd.simulate(model, (0, 2), y, **TIGHT)
    assert np.max(np.abs(res["q4"] - 0.3)) < 1e-8
    assert np.max(np.abs(res["u2"] - y[model.index("u2")])) < 1e-8


def test_rolling_disk_normal_force_upright():
    d = kd.models.build("rolling-disk", normal_force=True)
    m, g = 2.0, 9.81
    model = d.numeric(constants={"m": m, "g": g, "r": 0.3})
    y = _upright_rolling(model, 7.0)
    assert abs(model.auxiliary(0.0, y)["N_c"] - m * g) < 1e-10


# --------------------------------------------------------------- four-bar
def test_four_bar_energy_and_constraints():
    """Closed loop under gravity: energy conserved, loop stays closed."""
    d = kd.models.build("four-bar")
    model = d.numeric()
    res = kd.simulate(model, (0, 3), d.initial(model), rtol=1e-10, atol=1e-10)
    assert res.success
    assert res.energy_drift() < 1e-7
    assert np.max(res.constraint_residual) < 1e-7


@pytest.mark.parametrize("name", ["chain3d", "n-link-pendulum-on-cart", "whipple-bicycle"])
def test_conservative_models_conserve_energy(name, bicycle):
    if name == "whipple-bicycle":
        d, _, model = bicycle
    else:
        d = kd.models.build(name)
        model = d.numeric()
    y0 = d.initial(model)
    if model.n_q_dep or model.n_u_dep:
        y0 = model.consistent_state(0.0, y0)
    res = kd.simulate(model, (0, 1.5), y0, rtol=1e-10, atol=1e-10)
    assert res.success
    assert res.energy_drift() < 1e-7


def test_energy_expression_is_the_models():
    """Kinetic energy from the compact program equals the explicit SymPy one."""
    d = kd.models.build("chain3d", n=2)
    eom = d.derive()
    model = d.numeric(eom)
    y = np.array([0.3, -0.7, 0.5, 1.1])
    subs = dict(zip(eom.state, y))
    subs.update(d.constants)
    explicit = float(eom.kinetic_energy.xreplace(subs))
    assert abs(explicit - model.kinetic_energy(0.0, y)) < 1e-12
    assert sm.sympify(eom.potential_energy).free_symbols


def test_pendulum_of_prescribed_length_with_its_rate_in_a_velocity():
    """A bob on a string of prescribed length l(t), its velocity written as the
    time derivative of its position (so l' appears after l is known):
    d/dt(m l^2 u) = -m g l sin q."""
    import sympy.physics.mechanics as me
    q, u, l = me.dynamicsymbols("q u l")
    t = me.dynamicsymbols._t
    m, g = sm.symbols("m g", positive=True)
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (q, N.z))
    A.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", -l * A.y)
    P.set_vel(N, P.pos_from(O).dt(N))
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("bob", P, m)], loads=[(P, -m * g * N.y)])
    length = 1 + sm.sin(3 * t) / 10
    model = eom.numeric(constants={m: 1.0, g: 9.81}, specified={l: length})
    for tt, qq, uu in ((0.3, 0.1, 0.2), (1.1, -0.7, 1.5)):
        lv = float(length.subs(t, tt))
        ld = float(length.diff(t).subs(t, tt))
        expected = (-9.81 * lv * np.sin(qq) - 2 * ld * lv * uu) / lv**2
        assert model.rhs(tt, [qq, uu])[1] == pytest.approx(expected, rel=1e-13)


def test_piecewise_load_keeps_its_switching_time():
    """A servo tracking a quintic profile that ends at T: the profile's
    parameter T must survive the derivation (it vanishes from the equations
    at sampled times beyond T, which is no reason to drop it)."""
    import sympy.physics.mechanics as me
    q, u = me.dynamicsymbols("q u")
    t = me.dynamicsymbols._t
    m, l, T = sm.symbols("m l T", positive=True)
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (q, N.z))
    A.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", l * A.x)
    P.v2pt_theory(O, N, A)
    s = t / T
    profile = sm.Piecewise((0, t < 0), (10 * s**3 - 15 * s**4 + 6 * s**5, t < T), (1, True))
    torque = -4 * (q - profile) - 2 * (u - profile.diff(t))
    for method in ("kane", "orthogonal-complement"):
        eom = kd.formulate(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                           bodies=[me.Particle("bob", P, m)], loads=[(A, torque * N.z)],
                           method=method)
        assert T in eom.constants, method
        model = eom.numeric(constants={m: 1.0, l: 1.0, T: 2.0})
        for tt in (0.5, 1.5, 2.5):
            ref = float(torque.subs({t: tt, T: 2.0, q: 0.1, u: 0.2}).doit())
            assert model.rhs(tt, [0.1, 0.2])[1] == pytest.approx(ref, rel=1e-13), method
