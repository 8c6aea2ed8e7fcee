"""Waves, Morison strip loads and hydrostatics of floating structures (issue 17)."""

import math

import numpy as np
import pytest
import sympy.physics.mechanics as me
from scipy.integrate import quad

import kanedyn as kd
from kanedyn import ModelError

RHO, G = 1025.0, 9.80665
SPAR = [(-120.0, 9.4), (-12.0, 9.4), (-4.0, 6.5), (10.0, 6.5)]  # OC3 data sheet


# ------------------------------------------------------------------ waves
def test_dispersion_limits_and_residual():
    w = 0.7
    assert kd.offshore.wave_number(w, np.inf) == pytest.approx(w ** 2 / G, rel=1e-15)
    assert kd.offshore.wave_number(w, 1e4) == pytest.approx(w ** 2 / G, rel=1e-12)
    h, w_small = 1.0, 1e-4
    assert kd.offshore.wave_number(w_small, h) == pytest.approx(w_small / math.sqrt(G * h),
                                                                rel=1e-8)
    ws = np.array([0.05, 0.3, 1.0, 3.0])
    k = kd.offshore.wave_number(ws, 20.0)
    np.testing.assert_allclose(G * k * np.tanh(k * 20.0), ws ** 2, rtol=1e-13)
    with pytest.raises(ModelError, match="omega"):
        kd.offshore.wave_number(-1.0, 10.0)


@pytest.mark.parametrize("depth", [30.0, 320.0, np.inf])
def test_airy_kinematics_satisfy_potential_flow(depth):
    wave = kd.offshore.AiryWave(height=2.0, period=9.0, depth=depth, phase=0.3)
    x, z, t, d = 17.0, -8.0, 2.3, 1e-4
    vel = wave.velocity
    # continuity (Laplace) and irrotationality, central differences
    div = ((vel(x + d, z, t)[0] - vel(x - d, z, t)[0])
           + (vel(x, z + d, t)[2] - vel(x, z - d, t)[2])) / (2 * d)
    curl = ((vel(x, z + d, t)[0] - vel(x, z - d, t)[0])
            - (vel(x + d, z, t)[2] - vel(x - d, z, t)[2])) / (2 * d)
    scale = wave.omega * wave.k * 1.0
    assert abs(div) < 1e-7 * scale and abs(curl) < 1e-7 * scale
    # velocity = grad phi; acceleration = d/dt velocity
    phi = wave.potential
    assert (phi(x + d, z, t) - phi(x - d, z, t)) / (2 * d) == pytest.approx(
        vel(x, z, t)[0], rel=1e-7)
    acc_fd = (vel(x, z, t + d) - vel(x, z, t - d)) / (2 * d)
    np.testing.assert_allclose(wave.acceleration(x, z, t), acc_fd, rtol=1e-7, atol=1e-9)
    # kinematic and dynamic free-surface conditions at z = 0 (linear)
    deta_dt = (wave.elevation(x, t + d) - wave.elevation(x, t - d)) / (2 * d)
    assert deta_dt == pytest.approx(vel(x, 0.0, t)[2], rel=1e-7)
    dphi_dt = (phi(x, 0.0, t + d) - phi(x, 0.0, t - d)) / (2 * d)
    assert dphi_dt + G * wave.elevation(x, t) == pytest.approx(0.0, abs=1e-7)
    if np.isfinite(depth):
        assert abs(vel(x, -depth, t)[2]) < 1e-14  # no flow through the bed


def test_wheeler_stretching():
    h = 50.0
    plain = kd.offshore.AiryWave(4.0, 8.0, h, stretching="none")
    wheeler = kd.offshore.AiryWave(4.0, 8.0, h, stretching="wheeler")
    vertical = kd.offshore.AiryWave(4.0, 8.0, h, stretching="vertical")
    x, t = 3.0, 0.4
    eta = plain.elevation(x, t)
    assert eta > 1.0  # near a crest
    np.testing.assert_allclose(wheeler.velocity(x, eta, t), plain.velocity(x, 0.0, t),
                               rtol=1e-12)
    np.testing.assert_allclose(wheeler.velocity(x, -h, t), plain.velocity(x, -h, t),
                               atol=1e-14)
    z = -10.0
    np.testing.assert_allclose(wheeler.velocity(x, z, t),
                               plain.velocity(x, h * (z - eta) / (h + eta), t), rtol=1e-12)
    np.testing.assert_allclose(vertical.velocity(x, eta / 2, t), plain.velocity(x, 0.0, t))
    assert not np.any(wheeler.velocity(x, eta + 0.01, t))
    assert not np.any(plain.velocity(x, 0.01, t))


def test_jonswap_spectrum_moments_and_peak():
    Hs, Tp = 6.0, 10.0
    wp = 2 * math.pi / Tp
    for gamma, tol in ((1.0, 1e-9), (3.3, 3e-3)):
        m0 = sum(quad(lambda w: kd.offshore.jonswap_spectrum(w, Hs, Tp, gamma), a, b, limit=200)[0]
                 for a, b in ((0, wp), (wp, 10 * wp), (10 * wp, np.inf)))
        assert m0 == pytest.approx(Hs ** 2 / 16, rel=tol)
    w = np.linspace(0.5 * wp, 2 * wp, 200001)
    assert w[np.argmax(kd.offshore.jonswap_spectrum(w, Hs, Tp, 3.3))] == pytest.approx(wp, rel=1e-4)
    assert kd.offshore.jonswap_gamma(6.0, 8.0) == 5.0
    assert kd.offshore.jonswap_gamma(1.0, 10.0) == 1.0
    with pytest.raises(ModelError, match="gamma"):
        kd.offshore.jonswap_spectrum(1.0, Hs, Tp, 9.0)


def test_irregular_sea_statistics_and_seed():
    Hs, Tp = 6.0, 10.0
    sea = kd.offshore.IrregularSea(Hs, Tp, 3.3, depth=320.0, n_components=200, seed=7)
    t = np.arange(0.0, sea.repeat_period, 0.5)
    eta = np.array([sea.elevation(0.0, ti) for ti in t])
    assert eta.std() == pytest.approx(Hs / 4, rel=0.02)
    assert abs(eta.mean()) < 0.01 * Hs
    same = kd.offshore.IrregularSea(Hs, Tp, 3.3, depth=320.0, n_components=200, seed=7)
    other = kd.offshore.IrregularSea(Hs, Tp, 3.3, depth=320.0, n_components=200, seed=8)
    e_same = np.array([same.elevation(0.0, ti) for ti in t[:50]])
    e_other = np.array([other.elevation(0.0, ti) for ti in t[:50]])
    np.testing.assert_array_equal(e_same, eta[:50])
    assert np.max(np.abs(e_other - eta[:50])) > 0.1


@pytest.mark.parametrize("stretching", ["none", "vertical", "wheeler"])
def test_kinematics_series_and_a_sea_with_another_seed(stretching):
    """The kinematics at many times at once (records for simulate_many) equal those
    time by time; with_seed is the sea of that seed."""
    sea = kd.offshore.IrregularSea(6.0, 10.0, 3.3, depth=320.0, n_components=60, seed=7,
                                   stretching=stretching)
    x, z = np.array([[0.0, 3.0], [-2.0, 1.0]]), np.array([[-30.0, -1.0], [0.5, 2.0]])
    times = np.linspace(0.0, 40.0, 2500)  # more than one block of times
    vel, acc = sea.kinematics_series(x, z, times, 0.5)
    assert vel.shape == acc.shape == (2500, 2, 2, 3)
    for k in (0, 1, 1777, 2499):
        v, a = sea.kinematics(x, z, times[k], 0.5)
        np.testing.assert_allclose(vel[k], v, rtol=0, atol=1e-12)
        np.testing.assert_allclose(acc[k], a, rtol=0, atol=1e-12)
    if stretching == "none":  # 2 m above the still water level: dry
        assert np.all(vel[:, 1, 1] == 0) and np.any(vel[:, 0, 0] != 0)
    eta = sea.elevation_series(np.array([0.0, 5.0]), times[:3])
    assert eta.shape == (3, 2) and eta[2, 1] == sea.elevation(np.array([0.0, 5.0]),
                                                              times[2])[1]
    other = sea.with_seed(8)
    fresh = kd.offshore.IrregularSea(6.0, 10.0, 3.3, depth=320.0, n_components=60, seed=8,
                                     stretching=stretching)
    assert other.seed == 8 and np.array_equal(other.phases, fresh.phases)
    assert np.array_equal(other.omegas, sea.omegas) and other.stretching == stretching


def test_morison_input_series_equal_its_inputs():
    """input_series (all times at once) against specified()'s functions of t, with the
    cylinder's sea and with another seed's."""
    sea = kd.offshore.IrregularSea(6.0, 10.0, 3.3, depth=320.0, n_components=80, seed=1,
                                   stretching="vertical")
    member, _ = _fixed_member([(-60.0, 9.4), (5.0, 9.4)], rho=RHO, Ca=1.0, Cd=0.6,
                              n_strips=5, waves=sea, z_top=5.0)
    times = np.linspace(0.0, 30.0, 301)
    series = member.input_series(times)
    functions = member.specified()
    assert set(series) == set(functions) and any("wet" in str(k) for k in series)
    for symbol, f in functions.items():
        np.testing.assert_allclose(series[symbol], [f(t) for t in times], rtol=0,
                                   atol=1e-12)
    other, _ = _fixed_member([(-60.0, 9.4), (5.0, 9.4)], rho=RHO, Ca=1.0, Cd=0.6,
                             n_strips=5, waves=sea.with_seed(2), z_top=5.0)
    shifted = member.input_series(times[:20], sea.with_seed(2))
    for symbol, f in other.specified().items():
        name = str(symbol)
        mine = next(v for k, v in shifted.items() if str(k) == name)
        np.testing.assert_allclose(mine, [f(t) for t in times[:20]], rtol=0, atol=1e-12)


# ---------------------------------------------------------------- Morison
def _fixed_member(stations, **kw):
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    return kd.offshore.MorisonCylinder("m", N, O, N.z, stations, N, O, {}, **kw), N


def _total_force(member, N, t, at="origin"):
    values = {sym: f(t) for sym, f in member.specified().items()}
    loads = member.to_loads(at=at)
    force = sum((v for p, v in loads if isinstance(p, me.Point)), me.Vector(0))
    return np.array([float(force.dot(b).xreplace(values)) for b in (N.x, N.y, N.z)])


@pytest.mark.parametrize("depth", [200.0, 320.0])
def test_morison_inertia_matches_depth_integral(depth):
    D, draft, Ca = 9.4, 120.0, 1.0
    wave = kd.offshore.AiryWave(height=0.5, period=12.0, depth=depth)
    member, N = _fixed_member([(-draft, D), (0.0, D)], rho=RHO, Ca=Ca, Cd=0.6,
                              n_strips=6, waves=wave)
    k, w, a, h = wave.k, wave.omega, wave.height / 2, depth
    t = wave.period / 4  # theta = -pi/2 at x = 0: horizontal velocity zero, drag zero
    closed = ((1 + Ca) * RHO * math.pi * D ** 2 / 4 * w ** 2 * a
              * (math.sinh(k * h) - math.sinh(k * (h - draft))) / (k * math.sinh(k * h))
              * math.sin(-w * t))
    F = _total_force(member, N, t)
    assert F[0] == pytest.approx(closed, rel=1e-9)
    assert abs(F[1]) < 1e-9 * abs(closed) and abs(F[2]) < 1e-9 * abs(closed)
    # strips at their points give the same total
    np.testing.assert_allclose(_total_force(member, N, t, at="strips"), F, rtol=1e-12)


def test_morison_drag_in_steady_current():
    D, L, U, Cd = 6.5, 20.0, 1.5, 0.6
    for sign in (1.0, -1.0):
        member, N = _fixed_member([(-L, D), (0.0, D)], rho=RHO, Ca=1.0, Cd=Cd, n_strips=4,
                                  current=(sign * U, 0.0, 0.3))
        F = _total_force(member, N, 0.0)
        expected = 0.5 * RHO * Cd * D * L * U * U * sign  # axial current ignored
        assert F[0] == pytest.approx(expected, rel=1e-12)
        assert F[2] == 0.0


def test_morison_moving_body_relative_velocity_and_added_mass():
    N, B = me.ReferenceFrame("N"), me.ReferenceFrame("B")
    x, th = me.dynamicsymbols("x theta")
    ux, uth = me.dynamicsymbols("u_x u_theta")
    B.orient_axis(N, N.y, th)
    B.set_ang_vel(N, uth * N.y)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, ux * N.x)
    Cd, D, L = 1.0, 2.0, 10.0
    m = kd.offshore.MorisonCylinder("s", B, P, B.z, [(-L, D), (0.0, D)], N, O, {x: 0, th: 0},
                                    rho=RHO, Ca=1.0, Cd=Cd, n_strips=5)
    values = {sym: f(0.0) for sym, f in m.specified().items()}
    (_, F), (_, M) = m.to_loads(at="origin")
    subs = {**values, x: 0, th: 0, ux: 2.0, uth: 0}
    assert float(F.dot(N.x).xreplace(subs)) == pytest.approx(-0.5 * RHO * Cd * D * L * 4.0)
    # added mass: 6x6 about P in B components against the integrals of the section
    A = RHO * math.pi * D ** 2 / 4
    Ma = m.added_mass_matrix()
    assert Ma[0, 0] == pytest.approx(A * L) and Ma[2, 2] == 0.0
    assert Ma[0, 4] == pytest.approx(A * (-L ** 2 / 2))  # surge-pitch: int m z dz
    assert Ma[4, 4] == pytest.approx(A * L ** 3 / 3, rel=1e-12)  # integrated, not lumped
    np.testing.assert_allclose(Ma, Ma.T)
    assert sum(s.mass for s in m.added_mass_terms()) == pytest.approx(A * L)


# ------------------------------------------------------------ hydrostatics
def _spar(form, stations=SPAR):
    N, B = me.ReferenceFrame("N"), me.ReferenceFrame("B")
    z, th = me.dynamicsymbols("z theta")
    B.orient_axis(N, N.y, th)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", z * N.z)
    hs = kd.offshore.Hydrostatics("spar", B, P, B.z, stations, N, O, {z: 0, th: 0}, rho=RHO,
                                  form=form)
    return hs, N, z, th


def _wrench(hs, N, subs):
    (_, F), (_, M) = hs.to_loads()
    return float(F.dot(N.z).xreplace(subs)), float(M.dot(N.y).xreplace(subs))


def test_oc3_hydrostatic_coefficients():
    hs, *_ = _spar("linear")
    V = math.pi / 4 * (9.4 ** 2 * 108 + (6.5 ** 2 + 6.5 * 9.4 + 9.4 ** 2) / 3 * 8
                       + 6.5 ** 2 * 4)
    assert hs.volume == pytest.approx(V, rel=1e-12)
    assert hs.volume == pytest.approx(8029.21, rel=1e-5)  # data sheet
    assert hs.buoyancy == pytest.approx(RHO * G * V, rel=1e-12)
    C = hs.stiffness_matrix()
    assert C[2, 2] == pytest.approx(RHO * G * math.pi * 6.5 ** 2 / 4, rel=1e-12)
    assert C[2, 2] == pytest.approx(332941.0, rel=2e-3)  # sheet: 0.18 % lower
    assert C[3, 3] == pytest.approx(-4_999_184_000.0, rel=2e-3)


def test_large_angle_tends_to_linear_and_exact_volume():
    lin, N, z, th = _spar("linear")
    big, N_b, z_b, th_b = _spar("large_angle")
    C55 = lin.stiffness_matrix()[4, 4]
    for angle in (1e-4, -1e-4):
        Fz, My = _wrench(big, N_b, {z_b: 0, th_b: angle})
        assert My / angle == pytest.approx(-C55, rel=1e-6)
        Fz_l, My_l = _wrench(lin, N, {z: 0, th: angle})
        assert My_l / angle == pytest.approx(-C55, rel=1e-8)  # sin(angle)/angle
    Fz, _ = _wrench(big, N_b, {z_b: 0.2, th_b: 0})
    assert Fz == pytest.approx(lin.buoyancy - 0.2 * lin.stiffness_matrix()[2, 2], rel=1e-12)
    # volume of the tilted member: slices of the section at the SWL (circular segments)
    alpha, zO = 0.3, -0.5
    c, s_ = math.cos(alpha), math.sin(alpha)
    R, s_a, s_b = 3.25, -4.0, 10.0

    def wet_area(s):  # disk at s: submerged where z_O + s c + x sin(alpha) < 0
        xc = -(zO + s * c) / s_
        if xc >= R:
            return math.pi * R ** 2
        if xc <= -R:
            return 0.0
        return math.pi * R ** 2 - (R ** 2 * math.acos(xc / R) - xc * math.sqrt(R ** 2 - xc ** 2))

    V_sec = quad(wet_area, s_a, s_b, limit=200, epsabs=1e-12)[0]
    M_sec = quad(lambda s: s * wet_area(s), s_a, s_b, limit=200, epsabs=1e-12)[0]
    V_low, M_low, _ = big.geometry.integrals(-120.0, -4.0)
    V, M = big.submerged(zO, c)
    assert V == pytest.approx(V_low + V_sec, rel=1e-9)
    assert M == pytest.approx(M_low + M_sec, rel=1e-9)
    with pytest.raises(ModelError, match="leaves the section"):
        big.submerged(0.0, math.cos(1.2))


def test_floating_spar_through_kane_equilibrium_and_restoring():
    """Hydrostatics + Morison loads through kd.kane: a freely floating spar at rest."""
    N, B = me.ReferenceFrame("N"), me.ReferenceFrame("B")
    z, th = me.dynamicsymbols("z theta")
    uz, uth = me.dynamicsymbols("u_z u_theta")
    B.orient_axis(N, N.y, th)
    B.set_ang_vel(N, uth * N.y)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", z * N.z)
    P.set_vel(N, uz * N.z)
    hs = kd.offshore.Hydrostatics("spar", B, P, B.z, SPAR, N, O, {z: 0, th: 0}, rho=RHO,
                                  form="large_angle")
    mor = kd.offshore.MorisonCylinder("spar", B, P, B.z, SPAR, N, O, {z: 0, th: 0}, rho=RHO,
                                      Ca=1.0, Cd=0.6, n_strips=4)
    mass, zG, Iyy = hs.volume * RHO, -89.9155, 4.22923e9
    G_pt = P.locatenew("G", zG * B.z)
    G_pt.v2pt_theory(P, N, B)
    body = me.RigidBody("platform", G_pt, B, mass, (me.inertia(B, Iyy, Iyy, 1.0), G_pt))
    loads = hs.to_loads() + mor.to_loads(at="origin") + [(G_pt, -mass * G * N.z)]
    eom = kd.kane(frame=N, q_ind=[z, th], u_ind=[uz, uth], kd_eqs=[z.diff() - uz,
                  th.diff() - uth], bodies=[body], loads=loads)
    model = eom.numeric(specified=mor.specified())
    assert np.allclose(model.rhs(0.0, np.zeros(4)), 0.0, atol=1e-9)
    # small pitch: restoring moment C55 - m g zG (weight term from gravity)
    C55 = hs.stiffness_matrix()[4, 4] - mass * G * zG
    ydot = model.rhs(0.0, np.array([0.0, 1e-5, 0.0, 0.0]))
    Iyy_P = Iyy + mass * zG ** 2
    # surge is not a coordinate: pitch about P with the mass centre below
    assert ydot[3] == pytest.approx(-C55 * 1e-5 / Iyy_P, rel=1e-4)


def test_morison_added_mass_enters_the_mass_matrix():
    """``inertia_elements()`` puts the strips' added mass into Kane's mass matrix."""
    N, B = me.ReferenceFrame("N"), me.ReferenceFrame("B")
    z, th = me.dynamicsymbols("z theta")
    uz, uth = me.dynamicsymbols("u_z u_theta")
    B.orient_axis(N, N.y, th)
    B.set_ang_vel(N, uth * N.y)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", z * N.z)
    P.set_vel(N, uz * N.z)
    mor = kd.offshore.MorisonCylinder("spar", B, P, B.z, SPAR, N, O, {z: 0, th: 0}, rho=RHO,
                                      Ca=1.0, Cd=0.6, n_strips=4)
    mass, Iyy = 7.46633e6, 4.22923e9
    body = me.RigidBody("platform", P, B, mass, (me.inertia(B, Iyy, Iyy, 1.0), P))
    eom = kd.kane(frame=N, q_ind=[z, th], u_ind=[uz, uth],
                  kd_eqs=[z.diff() - uz, th.diff() - uth],
                  bodies=[body, *mor.inertia_elements()], loads=mor.to_loads(at="origin"))
    model = eom.numeric(specified=mor.specified())
    M = model.mass_matrix(0.0, np.zeros(4))
    # pitch about P: the strips' C_a rho A s^2 integrated over the wetted length
    s = np.linspace(-120.0, 0.0, 24001)
    D = np.interp(s, [p[0] for p in SPAR], [p[1] for p in SPAR])
    A55 = np.trapezoid(RHO * np.pi * D ** 2 / 4 * s ** 2, s)
    assert M[0, 0] == pytest.approx(mass, rel=1e-12)  # no heave added mass in strip theory
    assert M[1, 1] == pytest.approx(Iyy + A55, rel=1e-6)
    assert M[0, 1] == pytest.approx(0.0, abs=1e-6 * mass)
    assert kd.offshore.MorisonCylinder("dry", B, P, B.z, SPAR, N, O, {z: 0, th: 0}, rho=RHO,
                                       Ca=0.0, Cd=0.6, n_strips=2).inertia_elements() == []
