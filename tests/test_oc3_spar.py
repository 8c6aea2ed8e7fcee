"""The oc3-spar model: rigid-system frequencies against the published 6 x 6 matrices,
vertical equilibrium with catenary lines, energy in free decay, the flexible tower's
coupled frequency, options and the CLI."""

import numpy as np
import pytest
import scipy.linalg as sl

import kanedyn as kd
from kanedyn._errors import ModelError
from kanedyn.models import _oc3_data as D
from kanedyn.models import oc3_settle, oc3_spar, oc3_static_offsets, oc3_tower


@pytest.fixture(scope="module")
def rigid():
    """Tower rigid, no TMD, still water, linear mooring, no drag, no damping."""
    d = oc3_spar(tower_modes=0, drag=False, linear_damping=False)
    return d, d.numeric(d.derive())


def _frequencies(A):
    ev = np.linalg.eigvals(A)
    return np.sort(np.abs(ev.imag[ev.imag > 0])) / (2 * np.pi)


def _sheet():
    M = D.system_mass_matrix() + D.added_mass_matrix()
    K = D.hydrostatic_matrix() + D.mooring_stiffness_matrix()
    return M, K, np.sort(np.sqrt(sl.eig(K, M, right=False).real)) / (2 * np.pi)


def _jacobians(m, y, h=1e-6):
    """kd's mass matrix and the stiffness (minus the forcing's Jacobian in q) at ``y``."""
    n = m.n_q
    K = np.empty((n, n))
    for j in range(n):
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        K[:, j] = -(m.forcing(0.0, yp) - m.forcing(0.0, ym)) / (2 * h)
    return m.mass_matrix(0.0, y), K


def test_rigid_frequencies_match_the_6x6_eigenproblem(rigid):
    d, m = rigid
    M, K, f_ref = _sheet()
    y = np.zeros(m.n_states)
    # kd's mass matrix and stiffness (Jacobian of the forcing) at the reference state
    Mk, Kk = _jacobians(m, y)
    assert np.allclose(Mk, M, rtol=0, atol=1e-12 * np.abs(M).max())
    f_kd = np.sort(np.sqrt(sl.eig(Kk, Mk, right=False).real)) / (2 * np.pi)
    assert np.allclose(f_kd, f_ref, rtol=1e-6, atol=0)
    # surge/sway, heave, roll/pitch, yaw in the published ranges
    assert f_ref[0] == pytest.approx(f_ref[1], rel=1e-6) and 1 / f_ref[0] > 100
    assert 1 / f_ref[-1] == pytest.approx(8.3, rel=0.05)


def test_rigid_linearization_at_equilibrium_balanced_rna():
    """rna_offset=False: the undisplaced state heaved to balance is an equilibrium;
    kd's full linearize there against scipy's generalized eigenproblem of the same 6x6
    matrices, to 1e-6."""
    d = oc3_spar(tower_modes=0, drag=False, linear_damping=False, rna_offset=False)
    m = d.numeric(d.derive())
    y = oc3_settle(d, m)
    assert np.abs(m.rhs(0.0, y)).max() < 1e-12
    assert np.abs(y[[0, 1, 3, 4, 5]]).max() < 1e-12   # only heave moves
    parts = dict(D._parts(("platform", "tower", "rna")))
    mass, cm, inertia = parts["rna"]
    parts["rna"] = (mass, np.array([0.0, 0.0, cm[2]]), inertia)
    M = sum(D.rigid_body_mass_matrix(*p) for p in parts.values()) + D.added_mass_matrix()
    K = D.hydrostatic_matrix() + D.mooring_stiffness_matrix()
    f_ref = np.sort(np.sqrt(sl.eig(K, M, right=False).real)) / (2 * np.pi)
    f_lin = _frequencies(m.linearize(y)[0])
    assert len(f_lin) == 6
    assert np.allclose(f_lin, f_ref, rtol=1e-6, atol=0)
    heave = np.sqrt((D.HYDRO["C33"].value + D.MOORING["K33"].value) / M[2, 2]) / (2 * np.pi)
    assert M[2, 2] == pytest.approx(D.system_mass_properties()[0] + D.HYDRO["A33"].value,
                                    rel=1e-15)
    assert np.min(np.abs(f_lin / heave - 1)) < 1e-6
    # with the published offset the undisplaced state is not an equilibrium (1.42 MN m)
    dp = oc3_spar(tower_modes=0, drag=False, linear_damping=False)
    mp = dp.numeric(dp.derive())
    moment = mp.forcing(0.0, dp.initial(mp))[4]
    assert moment == pytest.approx(D.RNA["mass"].value * D.ENVIRONMENT["gravity"].value
                                   * D.RNA["cm_x"].value, rel=1e-3)


def test_tmd_constants_and_options(rigid):
    d = oc3_spar(tower_modes=0, tmdi="tmdi", drag=False)
    assert {str(s) for s in d.constants} == {"m_d", "k_d", "c_d", "b"}
    md, kd_, cd = (d.constants[d.symbols[k]] for k in ("m_d", "k_d", "c_d"))
    assert kd_ == pytest.approx(md * (2 * np.pi * 0.45) ** 2)
    assert cd == pytest.approx(2 * 0.08 * md * 2 * np.pi * 0.45)
    assert not oc3_spar(tower_modes=0).constants
    for bad in (dict(tmdi="tmdii"), dict(tower_modes=3), dict(mooring="taut"),
                dict(sea="regular", wave_height=0.0), dict(inerter_height=100.0)):
        with pytest.raises(ModelError, match="oc3-spar: option|oc3-spar: sea"):
            oc3_spar(**bad)


def test_vertical_balance_and_catenary_equilibrium():
    g = D.ENVIRONMENT["gravity"].value
    buoyancy = D.ENVIRONMENT["water_density"].value * g * D.PLATFORM["displaced_volume"].value
    weight = (D.PLATFORM["mass"].value + D.TOWER["mass"].value + D.RNA["mass"].value) * g
    from kanedyn.models._oc3_spar import _catenary_vertical
    V0 = _catenary_vertical(0.0)
    assert V0 == pytest.approx(1.607e6, rel=2e-3)
    assert buoyancy - weight == pytest.approx(V0, rel=1e-3)
    options = dict(tmdi="off", mooring="catenary", tmd_mass_ratio=0.02)
    heave = oc3_static_offsets(options)["heave"]
    assert abs(heave) < 0.01
    d = oc3_spar(tower_modes=0, mooring="catenary", drag=False)
    m = d.numeric(d.derive())
    y0 = d.initial(m)
    n = m.n_q
    # the vertical balance leaves no heave acceleration beyond the pitch coupling
    assert abs(m.rhs(0.0, y0)[n + 2]) < 1e-5
    y = oc3_settle(d, m)
    assert np.abs(m.rhs(0.0, y)).max() < 1e-9
    assert abs(y[2] - heave) < 1e-3
    # fairleads carry buoyancy minus weight at rest
    fair = [[float(c.subs({q: v for q, v in zip(d.symbols["q"], y[:n])}))
             for c in p] for p in d.symbols["elements"]["mooring"].fairlead_positions()]
    wrench = d.symbols["elements"]["mooring"].wrench(fair)
    assert -wrench[2] == pytest.approx(buoyancy - weight - D.HYDRO["C33"].value * y[2],
                                       rel=1e-6)


def test_energy_symmetric_linear_mooring():
    """mooring="linear-symmetric": the symmetric part of the published matrix as a
    spring derived from a potential; planar free decay (surge, heave, pitch) with all
    dampers off conserves T + V to the integration tolerance (1e-9 measured; the
    published, unsymmetric "linear" mooring drifts 1.4e-4 on the same motion)."""
    d = oc3_spar(tower_modes=0, drag=False, linear_damping=False, mooring="linear-symmetric")
    m = d.numeric(d.derive(), backend="c")   # a 40-s run at rtol 1e-10
    y0 = oc3_settle(d, m)
    y0[m.index("pitch")] += 0.05
    y0[m.index("surge")] += 5.0
    res = kd.simulate(m, (0.0, 40.0), y0, rtol=1e-10, atol=1e-10,
                      t_eval=np.linspace(0.0, 40.0, 101))
    assert res.success
    E = np.array([m.total_energy(t, y) for t, y in zip(res.t, res.y.T)])
    T = np.array([m.kinetic_energy(t, y) for t, y in zip(res.t, res.y.T)])
    assert T.max() > 1e6
    assert np.abs(E - E[0]).max() < 1e-8 * T.max()
    # linearized, the same matrix as the symmetric part of the published one
    _, Kk = _jacobians(m, oc3_settle(d, m))
    Km = D.mooring_stiffness_matrix()
    K_lin = D.hydrostatic_matrix() + (Km + Km.T) / 2
    assert np.allclose(Kk, K_lin, rtol=0, atol=2e-3 * np.abs(K_lin).max())


@pytest.mark.slow
def test_energy_conserved_in_free_decay():
    """No drag, no linear, aerodynamic or tower damping, undamped TMD with an inerter,
    flexible tower: T + V (gravity, buoyancy, hydrostatic, strain, TMD spring; added mass
    and inerter in T) constant.  Without mooring the declared potential is exact for
    this planar (surge-heave-pitch) motion."""
    d = oc3_spar(tower_modes=2, drag=False, linear_damping=False, tmdi="tmdi",
                 tmd_damping=0.0, mooring="none", tower_damping=0.0)
    # C: the 40-s run at rtol 1e-10 took 15.4 s of CPU on NumPy, 9.4 s with the compiles
    m = d.numeric(d.derive(), backend="c")
    y0 = oc3_settle(d, m)
    y0[m.index("pitch")] += 0.05
    y0[m.index("surge")] += 5.0
    res = kd.simulate(m, (0.0, 40.0), y0, rtol=1e-10, atol=1e-10,
                      t_eval=np.linspace(0.0, 40.0, 201))
    assert res.success
    E = np.array([m.total_energy(t, y) for t, y in zip(res.t, res.y.T)])
    T = np.array([m.kinetic_energy(t, y) for t, y in zip(res.t, res.y.T)])
    assert T.max() > 1e6
    assert np.abs(E - E[0]).max() < 1e-7 * T.max()


def _gravity_stiffness(L, R, V):
    """Independent gravity terms of the 8 x 8 (platform 6 + 2 modes) stiffness at rest:
    the deflected tower's weight under roll/pitch, and the RNA's centre of mass
    (1.967 m above the top, -0.414 m fore-aft) turning with the top node."""
    g = D.ENVIRONMENT["gravity"].value
    ML = np.asarray(L.mass_matrix)
    Kg = np.zeros((8, 8))
    Kg[4, 6:] = Kg[6:, 4] = -g * (R[:, 0] @ ML @ V)
    Kg[3, 6:] = Kg[6:, 3] = g * (R[:, 1] @ ML @ V)
    _, Psi = L.node_modes(L.n_nodes - 1)
    c = np.array([D.RNA["cm_x"].value, 0.0, D.RNA["cm_z"].value])
    H = np.outer([0.0, 0.0, 1.0], c)
    Kg[6:, 6:] = D.RNA["mass"].value * g * (0.5 * Psi.T @ (H + H.T) @ Psi
                                            - c[2] * Psi.T @ Psi)
    return Kg


def independent_8x8(elements, mooring=None):
    """The floating system with 2 tower modes assembled independently of kd: mass and
    stiffness (platform 6 + 2 modes, about the undisplaced state, gravity terms
    included) from the FE matrices of the loaded tower (RNA as a node mass) and the
    published 6 x 6 matrices; ``mooring``: a 6 x 6 stiffness instead of the published one.

    Returns
    -------
    (M, K, (L, R, V))
        ``L`` the loaded tower member, ``R`` the rigid-body modes of its nodes about
        P, ``V`` its 2 modes.
    """
    L = oc3_tower(elements, 2, rna=True, damping=0.0)   # the loaded tower, RNA a node mass
    V = L.modes
    # rigid-body modes of the tower nodes about P
    nodes = L.nodes + np.array([0.0, 0.0, D.TOWER["base_z"].value])
    R = np.zeros((6 * len(nodes), 6))
    for k, r in enumerate(nodes):
        R[6 * k:6 * k + 3, :3] = np.eye(3)
        R[6 * k:6 * k + 3, 3:] = [[0, r[2], -r[1]], [-r[2], 0, r[0]], [r[1], -r[0], 0]]
        R[6 * k + 3:6 * k + 6, 3:] = np.eye(3)
    ML = np.asarray(L.mass_matrix)
    Mi = np.zeros((8, 8))
    Mi[:6, :6] = D.system_mass_matrix(("platform",)) + R.T @ ML @ R + D.added_mass_matrix()
    Mi[:6, 6:] = R.T @ ML @ V
    Mi[6:, :6] = Mi[:6, 6:].T
    Mi[6:, 6:] = V.T @ ML @ V
    Ki = np.zeros((8, 8))
    Ki[:6, :6] = D.hydrostatic_matrix() + (D.mooring_stiffness_matrix() if mooring is None
                                           else mooring)
    Ki[6:, 6:] = V.T @ L.stiffness_matrix @ V
    Ki += _gravity_stiffness(L, R, V)
    return Mi, Ki, (L, R, V)


@pytest.mark.slow
def test_flexible_tower_fixed_base_and_coupled_frequencies():
    """The tower's modes are those of the tower with the RNA at its top (the RNA is a
    rigid body, its mass counted once): with the platform held, the model's tower
    frequencies are the fixed-base FE tower+RNA frequencies; floating, the coupled
    frequencies are those of an independently assembled 8 x 8 (6 rigid + 2 modes)."""
    d = oc3_spar(tower_modes=2, tower_elements=10, drag=False, linear_damping=False)
    m = d.numeric(d.derive(), backend="c")
    y = np.zeros(m.n_states)
    Mk, Kk = _jacobians(m, y)
    Mi, Ki, (L, R, V) = independent_8x8(10)
    assert np.abs(Mk - Mi).max() < 1e-12 * np.abs(Mi).max()
    assert np.abs(Kk - Ki).max() < 1e-7 * np.abs(Ki).max()
    # platform held: the tower rows only; without the RNA's gravity terms these are
    # the loaded tower's fixed-base FE frequencies (10 elements), and those agree with
    # 200 elements (0.37095 side-side, 0.37596 fore-aft Hz) to 2e-6
    t = [6, 7]
    Kt = Kk[np.ix_(t, t)] - _gravity_stiffness(L, R, V)[np.ix_(t, t)]
    f_held = np.sort(np.sqrt(sl.eigvals(Kt, Mk[np.ix_(t, t)]).real)) / (2 * np.pi)
    f_fe = np.sort(oc3_tower(200, 2, rna=True).reduced_frequencies)
    assert np.allclose(f_held, f_fe, rtol=1e-5, atol=0)
    assert f_fe == pytest.approx([0.3710, 0.3760], abs=1e-4)
    # floating: the coupled tower frequencies of kd's linearization (0.484 side-side,
    # 0.493 fore-aft Hz measured) against the independent 8 x 8
    f_i = np.sort(np.sqrt(sl.eigvals(Ki, Mi).real)) / (2 * np.pi)
    f_kd = np.sort(np.sqrt(sl.eigvals(Kk, Mk).real)) / (2 * np.pi)
    assert np.allclose(f_kd, f_i, rtol=1e-5, atol=0)   # 3.3e-6 measured (side-side)
    assert 1.25 < f_kd[-1] / f_fe[-1] < 1.35
    # kd's full linearization about the settled state (pitch -1.1e-3 rad): within 1e-5
    f_lin = _frequencies(m.linearize(oc3_settle(d, m))[0])
    assert np.allclose(f_lin[-2:], f_i[-2:], rtol=1e-5, atol=0)


def test_cli_run_tmdi(tmp_path):
    from kanedyn.cli import main
    from kanedyn.cli._options import parse_sets
    options, rest = parse_sets("oc3-spar", ["tmdi=tmd", "wave_height=4", "sea=regular",
                                            "k_d=1e5"])
    assert options == {"tmdi": "tmd", "wave_height": 4.0, "sea": "regular"}
    assert rest == {"k_d": 1e5}
    assert main(["run", "oc3-spar", "--set", "tmdi=tmdi", "--t-end", "20", "--out",
                 str(tmp_path), "--quiet"]) == 0
    assert (tmp_path / "oc3-spar.csv").exists()


# ------------------------------------------------------------------ coverage (issue 17)
_TILT = np.radians(D.ROTOR["shaft_tilt"].value)


def test_thrust_along_the_tilted_shaft_at_the_hub(rigid):
    """Wind 8 m/s (below rated: T = 1/2 rho A C_T V^2 with C_T = 0.8), undisplaced: the
    thrust's generalized forces are T cos5 (surge), -T sin5 (heave) and the pitch moment
    about the SWL point T (z_hub cos5 - x_overhang sin5), the hub 5.0191 m upwind and 90 m
    up; the aerodynamic damping is dT/dV on the hub's velocity along the shaft."""
    d0, m0 = rigid
    d = oc3_spar(tower_modes=0, drag=False, linear_damping=False, wind_speed=8.0)
    m = d.numeric(d.derive())
    y = np.zeros(m.n_states)
    f = m.forcing(0.0, y) - m0.forcing(0.0, y)
    T = 0.5 * 1.225 * np.pi * 63.0 ** 2 * 0.80 * 8.0 ** 2
    c, s = np.cos(_TILT), np.sin(_TILT)
    lever = D.ROTOR["hub_height"].value * c - D.ROTOR["overhang"].value * s   # 89.22 m
    assert f[4] == pytest.approx(T * lever, rel=1e-12)
    assert f[[0, 2]] == pytest.approx([T * c, -T * s], rel=1e-12)
    assert np.abs(f[[1, 3, 5]]).max() < 1e-9 * T
    # pitch rate w: hub velocity along the shaft w * lever, thrust -dT/dV w lever
    w = 1e-6
    y[m.n_q + 4] = w
    df = m.forcing(0.0, y) - m0.forcing(0.0, y) - f
    slope = d.symbols["elements"]["rotor"].damping(8.0)   # the PCHIP curve's dT/dV
    assert slope == pytest.approx(2 * T / 8.0, rel=5e-3)  # 0.4 % from the quadratic
    assert df[4] == pytest.approx(-slope * w * lever ** 2, rel=1e-4)


def _buoyancy_part():
    """Volume, centre of buoyancy and waterplane of the spar stations, integrated here."""
    from scipy.integrate import quad
    from kanedyn.models._oc3_spar import spar_geometry
    s, D_ = np.array(spar_geometry()).T

    def area(z):
        return np.pi * np.interp(z, s, D_) ** 2 / 4
    V = sum(quad(area, a, b)[0] for a, b in zip(s[:2], [s[1], s[2]])) + quad(area, s[2], 0)[0]
    M1 = sum(quad(lambda z: z * area(z), a, b)[0]
             for a, b in ((s[0], s[1]), (s[1], s[2]), (s[2], 0.0)))
    D0 = np.interp(0.0, s, D_)
    return V, M1 / V, np.pi * D0 ** 2 / 4, np.pi * D0 ** 4 / 64


def test_large_angle_hydrostatics_is_linear_for_small_motion(rigid):
    """Heave 0.1 m, pitch and roll 0.01 rad from rest: the large-angle model's right side
    minus the linear one's is exactly the difference of the restoring coefficients,
    geometric (C33 = rho g A_wp, C55 = rho g (I_wp + V z_B), integrated here) minus
    published (C33 and C55_buoyancy of OC3), to 1e-4 of the linear restoring: the
    large-angle terms are of second order (1.8e-5 measured at 0.01 rad).  The geometric
    coefficients exceed the published ones by 0.18 % (heave and pitch buoyancy part; the
    figures' rho g, presumably), 0.78 % of the whole pitch restoring with the weight."""
    d_lin, m_lin = rigid
    d = oc3_spar(tower_modes=0, drag=False, linear_damping=False, hydrostatics="large_angle")
    m = d.numeric(d.derive())
    g, rho = D.ENVIRONMENT["gravity"].value, D.ENVIRONMENT["water_density"].value
    V, zb, Awp, Iwp = _buoyancy_part()
    assert V == pytest.approx(D.PLATFORM["displaced_volume"].value, rel=2e-5)
    C33, C55 = rho * g * Awp, rho * g * (Iwp + V * zb)
    C33_pub, C55_pub = D.HYDRO["C33"].value, D.HYDRO["C55_buoyancy"].value
    assert C33 / C33_pub - 1 == pytest.approx(0.0018, abs=1e-4)
    assert C55 / C55_pub - 1 == pytest.approx(0.0018, abs=1e-4)
    y0 = np.zeros(m.n_states)
    # at rest both have the buoyancy of the displaced volume (geometric vs published)
    r0 = m.forcing(0.0, y0) - m_lin.forcing(0.0, y0)
    assert r0[2] == pytest.approx(rho * g * (V - D.PLATFORM["displaced_volume"].value),
                                  abs=1e-6 * rho * g * V)
    for i, eps, c_geo, c_pub in ((2, 0.1, C33, C33_pub), (4, 0.01, C55, C55_pub),
                                 (3, 0.01, C55, C55_pub)):
        y = y0.copy()
        y[i] = eps
        lin = m_lin.forcing(0.0, y) - m_lin.forcing(0.0, y0)
        large = m.forcing(0.0, y) - m.forcing(0.0, y0)
        # the linear model's hydrostatic moment is -C sin(eps) (MatrixSpringDamper)
        step = eps if i == 2 else np.sin(eps)
        expected = lin[i] - (c_geo * eps - c_pub * step)
        assert large[i] == pytest.approx(expected, rel=1e-4, abs=0), (i, large[i], expected)
        others = [k for k in range(6) if k != i]
        assert np.abs(large[others] - lin[others]).max() < 1e-4 * abs(lin[i])


def test_morison_added_mass_against_strips_and_the_sheet(rigid):
    """added_mass="morison" (Ca = 1, 10 strips): surge and sway rho V, roll and pitch
    rho int A s^2, their coupling rho int A s (closed-form integrals of the stations);
    against the potential-flow sheet: surge +6.1 %, pitch +8.0 %, coupling +5.7 %
    (measured), and no heave or yaw added mass."""
    from scipy.integrate import quad
    from kanedyn.models._oc3_spar import spar_geometry
    d0, m0 = rigid
    d = oc3_spar(tower_modes=0, drag=False, linear_damping=False, added_mass="morison")
    m = d.numeric(d.derive())
    y = np.zeros(m.n_states)
    A_sheet = D.added_mass_matrix()
    A = m.mass_matrix(0.0, y) - (m0.mass_matrix(0.0, y) - A_sheet)
    rho = D.ENVIRONMENT["water_density"].value
    s, D_ = np.array(spar_geometry()).T
    pieces = ((s[0], s[1]), (s[1], s[2]), (s[2], 0.0))

    def moment(k):
        return rho * sum(quad(lambda z: z ** k * np.pi * np.interp(z, s, D_) ** 2 / 4,
                              a, b)[0] for a, b in pieces)
    assert A[0, 0] == pytest.approx(moment(0), rel=1e-6)
    assert A[1, 1] == pytest.approx(moment(0), rel=1e-6)
    assert A[0, 4] == pytest.approx(moment(1), rel=5e-3)
    assert A[1, 3] == pytest.approx(-moment(1), rel=5e-3)
    assert A[4, 4] == pytest.approx(moment(2), rel=5e-3)
    assert A[3, 3] == pytest.approx(moment(2), rel=5e-3)
    assert A[2, 2] == 0.0 and A[5, 5] == 0.0
    excess = {k: A[k] / A_sheet[k] - 1 for k in ((0, 0), (4, 4), (0, 4))}
    assert 0.060 < excess[(0, 0)] < 0.062
    assert 0.079 < excess[(4, 4)] < 0.081
    assert 0.056 < excess[(0, 4)] < 0.058


@pytest.mark.slow
def test_irregular_sea_seeded():
    """sea="irregular" (Hs 6 m, Tp 10 s): the same seed, on a new definition, gives the
    same 30 s response bitwise; seed 2 a different one (metres apart)."""
    opts = dict(tower_modes=0, sea="irregular", wave_height=6.0, wave_period=10.0)
    d1 = oc3_spar(seed=1, **opts)
    eom = d1.derive()
    t = np.linspace(0.0, 30.0, 31)
    runs = []
    for seed in (1, 1, 2):
        d = d1 if not runs else oc3_spar(seed=seed, **opts)
        m = d.numeric(eom, backend="c")   # one module (the same equations) for the three
        res = kd.simulate(m, (0.0, 30.0), d.initial(m), rtol=1e-8, atol=1e-8, t_eval=t)
        assert res.success
        runs.append(res.y)
    assert np.array_equal(runs[0], runs[1])
    assert np.abs(runs[0][0]).max() > 1.0                # the sea moves the spar
    assert np.abs(runs[2] - runs[0]).max() > 0.5


@pytest.mark.slow
def test_turbulent_wind_thrust_scales_with_intensity():
    """Wind 8 m/s, Kaimal turbulence 5 % and 10 % (same seed: the same series shape):
    the thrust varies, its standard deviation over 60 s about doubles, and it is of the
    order of the quasi-steady dT/dV sigma_V."""
    opts = dict(tower_modes=0, wind_speed=8.0, drag=False)
    d5 = oc3_spar(turbulence=0.05, **opts)
    eom = d5.derive()
    t = np.linspace(0.0, 60.0, 241)
    stds = []
    for ti in (0.05, 0.10):
        d = d5 if ti == 0.05 else oc3_spar(turbulence=ti, **opts)
        m = d.numeric(eom)
        y0 = oc3_settle(d, m)
        res = kd.simulate(m, (0.0, 60.0), y0, rtol=1e-6, atol=1e-6, t_eval=t)
        assert res.success
        rotor = d.symbols["elements"]["rotor"]
        (thrust,) = rotor.specified([*d.symbols["q"], *d.symbols["u"]]).values()
        T = np.array([thrust(ti_, yi) for ti_, yi in zip(res.t, res.y.T)])
        stds.append(T.std())
    slope = 2 * 0.5 * 1.225 * np.pi * 63.0 ** 2 * 0.80 * 8.0
    assert stds[0] > 0
    assert 1.8 < stds[1] / stds[0] < 2.2
    assert 0.3 < stds[0] / (slope * 0.05 * 8.0) < 1.5
