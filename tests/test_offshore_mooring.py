"""Spring-dampers, mooring lines and rotor thrust (issue 17, item 1).

References: closed forms (mass-spring frequency, the inextensible catenary with
seabed contact), an independent quadrature of the elastic line's shape, and the
OC3-Hywind figures of the project's data sheet (Jonkman, NREL/TP-500-47535).
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from scipy import integrate
from scipy.spatial.transform import Rotation

import kanedyn as kd
from kanedyn.modeling.offshore import OC3_MOORING, solve_catenary

W_OC3 = 698.094  # N/m, OC3 line weight in water
EA_OC3 = 384.243e6  # N
G, RHO = 9.80665, 1025.0


# ------------------------------------------------------------------ helpers
def free_body(offset=(0.0, 0.0, 0.0)):
    """A free rigid body: q = (x, y, z, body-fixed XYZ angles), u = (v_N, omega_B)."""
    q = me.dynamicsymbols("q1:7")
    u = me.dynamicsymbols("u1:7")
    N, B = me.ReferenceFrame("N"), me.ReferenceFrame("B")
    B.orient_body_fixed(N, q[3:], "XYZ")
    B.set_ang_vel(N, u[3] * B.x + u[4] * B.y + u[5] * B.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    G_ = O.locatenew("G", q[0] * N.x + q[1] * N.y + q[2] * N.z)
    G_.set_vel(N, u[0] * N.x + u[1] * N.y + u[2] * N.z)
    P = G_.locatenew("P", offset[0] * B.x + offset[1] * B.y + offset[2] * B.z)
    P.v2pt_theory(G_, N, B)
    kde = [q[i].diff() - u[i] for i in range(3)]
    kde += list(sm.Matrix(me.kinematic_equations(u[3:], q[3:], "body", "XYZ")))
    return q, u, N, B, O, G_, P, kde


def rigid(B, G_, mass=(3.0, (2.0, 5.0, 7.0))):
    m, (ix, iy, iz) = mass
    return me.RigidBody("body", G_, B, m, (me.inertia(B, ix, iy, iz), G_))


# ------------------------------------------------------------------ springs
@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (0.4, -0.3, 1.1)])
def test_matrix_spring_damper_linearizes_to_K_and_C(offset):
    """About the reference, M dx'' = -J^T K J dx - J^T C J dx' with x_P = J x_G."""
    rng = np.random.default_rng(3)
    K = rng.normal(size=(6, 6)) * 10 + np.eye(6) * 50
    C = rng.normal(size=(6, 6)) + np.eye(6) * 5
    q, u, N, B, O, G_, P, kde = free_body(offset)
    body = rigid(B, G_)
    ref = O.locatenew("Pref", offset[0] * N.x + offset[1] * N.y + offset[2] * N.z)
    element = kd.MatrixSpringDamper("hydro", B, P, N, K, C, reference=ref)
    eom = kd.kane(frame=N, q_ind=q, u_ind=u, kd_eqs=kde, bodies=[body],
                  loads=element.to_loads())
    A, _, _ = eom.numeric(constants={}).linearize(np.zeros(12))
    M = np.diag([3.0, 3.0, 3.0, 2.0, 5.0, 7.0])
    r = np.array(offset)
    J = np.eye(6)
    J[:3, 3:] = -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    np.testing.assert_allclose(A[:6], np.hstack([np.zeros((6, 6)), np.eye(6)]), atol=1e-12)
    np.testing.assert_allclose(M @ A[6:, :6], -J.T @ K @ J, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(M @ A[6:, 6:], -J.T @ C @ J, rtol=1e-10, atol=1e-9)


def test_rotation_vector_is_sine_of_angle_times_axis():
    N, B = me.ReferenceFrame("N"), me.ReferenceFrame("B")
    axis = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    phi = 1.2
    B.orient_axis(N, sm.Float(phi), axis[0] * N.x + axis[1] * N.y + axis[2] * N.z)
    theta = kd.modeling.rotation_vector(B, N)
    comps = [float(sm.N(theta.dot(e))) for e in (N.x, N.y, N.z)]
    np.testing.assert_allclose(comps, np.sin(phi) * axis, atol=1e-12)


def test_spring_damper_on_a_mass_frequency_and_geometric_stiffness():
    """Particle on a spring from the origin: axial k/m, damping c/m; transverse
    stiffness k (l - l0)/l when the spring is stretched to l."""
    x, y, ux, uy = me.dynamicsymbols("x y ux uy")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, ux * N.x + uy * N.y)
    m, k, c, l0 = 2.0, 50.0, 0.8, 1.5
    spring = kd.SpringDamper("s", O, P, k, c, l0, N)
    eom = kd.kane(frame=N, q_ind=[x, y], u_ind=[ux, uy],
                  kd_eqs=[x.diff() - ux, y.diff() - uy],
                  bodies=[me.Particle("p", P, m)], loads=spring.to_loads())
    model = eom.numeric(constants={})
    A, _, _ = model.linearize([l0, 0, 0, 0])
    omega = np.sqrt(np.linalg.eigvals(-A[2:, :2]).max())
    assert omega == pytest.approx(np.sqrt(k / m), rel=1e-12)
    assert -A[2, 2] == pytest.approx(c / m, rel=1e-12)
    l1 = 2.0
    A, _, _ = model.linearize([l1, 0, 0, 0])
    assert -A[3, 1] == pytest.approx(k * (l1 - l0) / l1 / m, rel=1e-12)


def test_spring_damper_zero_length_is_an_error():
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    with pytest.raises(kd.ModelError, match="'s0'.*coincide"):
        kd.SpringDamper("s0", O, O.locatenew("Q", 0 * N.x), 1.0, 0.0, 0.0, N)


# ------------------------------------------------------------------ catenary
def test_catenary_inextensible_with_seabed_closed_form():
    """Inextensible: suspended length L_s = sqrt(z (z + 2a)), a = H/w,
    x = L - L_s + a asinh(L_s / a), V = w L_s."""
    L, w, H = 902.2, W_OC3, 7.0e5
    a = H / w
    z = 250.0
    Ls = np.sqrt(z * (z + 2 * a))
    x = L - Ls + a * np.arcsinh(Ls / a)
    H1, V1 = solve_catenary(x, z, L, w, 1e18)
    assert H1 == pytest.approx(H, rel=1e-7)
    assert V1 == pytest.approx(w * Ls, rel=1e-7)


def line_shape_by_quadrature(H, V, L, w, EA):
    """Spans of the elastic line by integrating its strained shape over the
    unstretched arc length (seabed part stretched by H/EA)."""
    Ls = V / w
    T = lambda s: np.hypot(H, w * s)  # noqa: E731
    dx = integrate.quad(lambda s: H / T(s) * (1 + T(s) / EA), 0, Ls, epsabs=1e-12)[0]
    dz = integrate.quad(lambda s: w * s / T(s) * (1 + T(s) / EA), 0, Ls, epsabs=1e-12)[0]
    return (L - Ls) * (1 + H / EA) + dx, dz


@pytest.mark.parametrize("EA", [EA_OC3, 2.0e7])
def test_catenary_elastic_matches_quadrature(EA):
    L, w, H, V = 902.2, W_OC3, 6.5e5, 4.8e5
    x, z = line_shape_by_quadrature(H, V, L, w, EA)
    H1, V1 = solve_catenary(x, z, L, w, EA)
    assert H1 == pytest.approx(H, rel=1e-8)
    assert V1 == pytest.approx(V, rel=1e-8)


def test_catenary_line_warm_start_and_bad_span():
    N = me.ReferenceFrame("N")
    line = kd.offshore.CatenaryLine([853.87, 0, -320], me.Point("F"), 902.2, W_OC3, EA_OC3,
                                    name="l1")
    first = line.tensions([5.2, 0, -70])
    again = line.tensions([5.2 + 1e-3, 0, -70])
    assert again[0] == pytest.approx(first[0], rel=1e-3)
    far = line.tensions([-200.0, 0, -70])  # farther than the unstretched line reaches
    assert np.hypot(*far) > 50 * np.hypot(*first)  # held by stretching, EA strain
    with pytest.raises(kd.ModelError, match="'l2'.*length"):
        kd.offshore.CatenaryLine([0, 0, -320], me.Point("F"), -1.0, W_OC3, EA_OC3, name="l2")
    with pytest.raises(kd.ModelError, match="fairlead must be a Point"):
        kd.offshore.CatenaryLine([0, 0, -320], N, 1.0, W_OC3, EA_OC3)


def test_catenary_warm_newton_equals_the_cold_scipy_solve():
    """The warm-started Newton path (analytic Jacobian) against SciPy's hybr from Peyrot
    and Goulois's guess, at 200 random OC3 spans (horizontal -40 to +25 m, vertical
    +-15 m about the anchor-fairlead spans, both branches), each warm-started from the
    tensions of another span (up to ~3 sigma of 2 m, 1 m away): H and V agree to
    1e-11 relative (measured 3.4e-14).  The Jacobian equals central differences of
    the spans to 1e-6 relative on both branches."""
    from kanedyn.modeling.offshore._catenary import _newton, catenary_jacobian
    from kanedyn.modeling.offshore._catenary import catenary_spans
    d = OC3_MOORING
    L, w, EA = d["length"], d["weight_in_water"], d["EA"]
    x0, z0 = d["anchor_radius"] - d["fairlead_radius"], d["anchor_depth"] - d["fairlead_depth"]
    rng = np.random.default_rng(0)
    for x, z in zip(x0 + rng.uniform(-40, 25, 200), z0 + rng.uniform(-15, 15, 200)):
        H, V = solve_catenary(x, z, L, w, EA)
        guess = solve_catenary(x + rng.normal(0, 2), z + rng.normal(0, 1), L, w, EA)
        found = _newton(x, z, L, w, EA, True, *guess)
        assert found is not None
        assert found == pytest.approx((H, V), rel=1e-11)
        assert solve_catenary(x, z, L, w, EA, guess=guess) == pytest.approx((H, V),
                                                                            rel=1e-11)
    for H, V in ((6.5e5, 4.8e5), (6.5e5, 1.2 * w * L)):     # on the seabed, suspended
        J = np.array(catenary_jacobian(H, V, L, w, EA))
        dH, dV = 1e-5 * H, 1e-5 * V
        numeric = np.column_stack([
            (np.array(catenary_spans(H + dH, V, L, w, EA))
             - np.array(catenary_spans(H - dH, V, L, w, EA))) / (2 * dH),
            (np.array(catenary_spans(H, V + dV, L, w, EA))
             - np.array(catenary_spans(H, V - dV, L, w, EA))) / (2 * dV)])
        np.testing.assert_allclose(J, numeric, rtol=1e-6)


def oc3_mooring():
    N, O = me.ReferenceFrame("N"), me.Point("O")
    d = OC3_MOORING
    lines, fairleads = [], []
    for i, a in enumerate(np.radians([180.0, 60.0, -60.0])):
        c, s = np.cos(a), np.sin(a)
        lines.append(kd.offshore.CatenaryLine([d["anchor_radius"] * c, d["anchor_radius"] * s,
                                               -d["anchor_depth"]], me.Point(f"F{i}"), d["length"],
                                              d["weight_in_water"], d["EA"]))
        fairleads.append([d["fairlead_radius"] * c, d["fairlead_radius"] * s,
                          -d["fairlead_depth"]])
    return kd.offshore.CatenaryMooring("oc3", lines, N, O), np.array(fairleads)


def test_oc3_line_weight_and_vertical_load():
    """Wet weight from the sheet's mass and diameter; vertical load = buoyancy - weight."""
    d = OC3_MOORING
    wet = d["mass_per_length"] * G - RHO * G * np.pi * d["diameter"] ** 2 / 4
    assert wet == pytest.approx(W_OC3, rel=1e-4)
    mooring, P = oc3_mooring()
    wrench = mooring.wrench(P)
    buoyancy = RHO * G * 8029.21
    weight = (7_466_330 + 249_718 + 350_000) * G
    assert -wrench[2] == pytest.approx(buoyancy - weight, rel=0.01)  # about 1.607 MN
    assert -wrench[2] == pytest.approx(1.6e6, rel=0.01)
    np.testing.assert_allclose(wrench[[0, 1, 3, 4, 5]], 0, atol=1e-3)


def test_oc3_catenary_stiffness_matches_linearized_matrix():
    """Finite differences of the quasi-static loads (moments about the displaced
    reference point at the SWL) against OC3's K11, K33, K44, K55, K66, K15, K51."""
    mooring, P = oc3_mooring()

    def wrench(x):
        R = Rotation.from_rotvec(x[3:]).as_matrix()
        return mooring.wrench(P @ R.T + x[:3], about=x[:3])
    K = np.zeros((6, 6))
    steps = [0.01] * 3 + [1e-4] * 3
    for j, h in enumerate(steps):
        e = np.zeros(6)
        e[j] = h
        K[:, j] = -(wrench(e) - wrench(-e)) / (2 * h)
    d = OC3_MOORING
    assert K[0, 0] == pytest.approx(d["K11"], rel=0.02)
    assert K[1, 1] == pytest.approx(d["K11"], rel=0.02)
    assert K[2, 2] == pytest.approx(d["K33"], rel=0.02)
    assert K[3, 3] == pytest.approx(d["K44"], rel=0.02)
    assert K[4, 4] == pytest.approx(d["K44"], rel=0.02)
    assert K[5, 5] == pytest.approx(11_560_000.0, rel=0.02)  # without the delta's spring
    assert K[0, 4] == pytest.approx(d["K15"], rel=0.02)
    assert K[4, 0] == pytest.approx(d["K51"], rel=0.02)
    assert K[1, 3] == pytest.approx(-d["K15"], rel=0.02)


def test_catenary_mooring_as_runtime_inputs_and_linear_mooring():
    """The runtime fairlead forces reach the equations: heave acceleration
    -V/m at the undisplaced state; LinearMooring.oc3 gives the same mean load."""
    q, u, N, B, O, G_, P, kde = free_body()
    d = OC3_MOORING
    lines = []
    for i, a in enumerate(np.radians([180.0, 60.0, -60.0])):
        c, s = np.cos(a), np.sin(a)
        F = P.locatenew(f"F{i}", d["fairlead_radius"] * (c * B.x + s * B.y)
                        - d["fairlead_depth"] * B.z)
        F.v2pt_theory(P, N, B)
        lines.append(kd.offshore.CatenaryLine([d["anchor_radius"] * c, d["anchor_radius"] * s,
                                               -d["anchor_depth"]], F, d["length"],
                                              d["weight_in_water"], d["EA"]))
    mooring = kd.offshore.CatenaryMooring("oc3", lines, N, O)
    mass = 8.0e6
    body = rigid(B, G_, (mass, (4e9, 4e9, 2e8)))
    eom = kd.kane(frame=N, q_ind=q, u_ind=u, kd_eqs=kde, bodies=[body],
                  loads=mooring.to_loads())
    model = eom.numeric(constants={}, specified=mooring.specified(eom))
    y = np.zeros(12)
    _, fairleads = oc3_mooring()
    vertical = mooring.wrench(fairleads)[2]
    assert model.rhs(0.0, y)[8] == pytest.approx(vertical / mass, rel=1e-9)
    y[0] = 5.0  # surge: the lines pull back
    assert model.rhs(0.0, y)[6] < 0
    linear = kd.offshore.LinearMooring.oc3(B, P, N, reference=O)
    assert float(linear.vertical_load) == pytest.approx(-vertical, rel=1e-9)


# ------------------------------------------------------------------ rotor and wind
def test_thrust_curve_rated_and_interpolation():
    curve = kd.offshore.NREL5MW_THRUST
    assert curve(11.4) == pytest.approx(800e3, rel=0.02)
    area = np.pi * 63.0 ** 2
    assert curve(7.5) == pytest.approx(0.5 * 1.225 * area * 0.8 * 7.5 ** 2, rel=0.01)
    assert curve(8.0) > curve(7.0) and curve(15.0) < curve(11.4)
    assert curve.slope(8.0) > 0 > curve.slope(15.0)


def test_aerodynamic_damping_sign_and_runtime_thrust():
    """A hub moving downwind feels less thrust (below rated): dT/dV > 0."""
    x, ux = me.dynamicsymbols("x ux")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    hub = O.locatenew("hub", x * N.x)
    hub.set_vel(N, ux * N.x)
    rotor = kd.offshore.RotorThrust("r", hub, N.x, N, kd.offshore.NREL5MW_THRUST, wind=8.0)
    thrust = rotor.specified([x, ux])[rotor.symbol]
    at_rest = thrust(0.0, [0.0, 0.0])
    assert at_rest == pytest.approx(kd.offshore.NREL5MW_THRUST(8.0))
    assert thrust(0.0, [0.0, 0.5]) < at_rest < thrust(0.0, [0.0, -0.5])
    dv = 1e-4
    slope = (thrust(0.0, [0.0, -dv]) - thrust(0.0, [0.0, dv])) / (2 * dv)
    assert slope == pytest.approx(rotor.damping(8.0), rel=1e-4)
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[ux], kd_eqs=[x.diff() - ux],
                  bodies=[me.Particle("m", hub, 1e6)], loads=rotor.to_loads())
    model = eom.numeric(constants={}, specified=rotor.specified(eom))
    assert model.rhs(0.0, np.zeros(2))[1] == pytest.approx(at_rest / 1e6)


def test_thrust_as_an_expression_is_the_curve():
    """ThrustCurve.expression: the same PCHIP pieces (held at the ends); a rotor's thrust
    under a steady wind as an expression of the state gives the model the same
    derivative as its Python function of (t, y)."""
    import sympy as sm
    curve = kd.offshore.NREL5MW_THRUST
    V = sm.Symbol("V")
    f = sm.lambdify(V, curve.expression(V), "math")
    speeds = np.linspace(0.0, 30.0, 3001)
    np.testing.assert_allclose([f(v) for v in speeds], curve(speeds), rtol=1e-14, atol=1e-9)
    x, ux = me.dynamicsymbols("x ux")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    hub = O.locatenew("hub", x * N.x)
    hub.set_vel(N, ux * N.x)
    rotor = kd.offshore.RotorThrust("r", hub, N.x, N, curve, wind=9.0)
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[ux], kd_eqs=[x.diff() - ux],
                  bodies=[me.Particle("m", hub, 1e6)], loads=rotor.to_loads())
    python = eom.numeric(constants={}, specified=rotor.specified(eom))
    compiled = eom.numeric(constants={}, specified={rotor.symbol: rotor.expression()})
    assert compiled.input_names == ()
    for u in (-4.0, -0.3, 0.0, 0.7, 12.0):
        assert compiled.rhs(0.0, [0.0, u])[1] == pytest.approx(python.rhs(0.0, [0.0, u])[1],
                                                               rel=1e-14)
    gusty = kd.offshore.RotorThrust("g", hub, N.x, N, curve, wind=lambda t: 9.0 + t)
    with pytest.raises(kd.ModelError, match="the wind varies in time"):
        gusty.expression()


def test_kaimal_wind_mean_intensity_and_seed():
    t, v = kd.offshore.kaimal_wind(11.4, 0.15, duration=3600.0, dt=0.25, seed=7)
    assert v.mean() == pytest.approx(11.4, rel=0.01)
    assert v.std() / v.mean() == pytest.approx(0.15, rel=0.03)
    _, v2 = kd.offshore.kaimal_wind(11.4, 0.15, duration=3600.0, dt=0.25, seed=7)
    _, v3 = kd.offshore.kaimal_wind(11.4, 0.15, duration=3600.0, dt=0.25, seed=8)
    np.testing.assert_array_equal(v, v2)
    assert not np.allclose(v, v3)
    assert t[1] - t[0] == 0.25 and t.size == 14400
