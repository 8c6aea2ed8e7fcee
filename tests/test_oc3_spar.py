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
    m = d.numeric(d.derive())
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
    """No drag, no linear or aerodynamic damping, undamped TMD with an inerter, flexible
    tower: T + V (gravity, buoyancy, hydrostatic, strain, TMD spring; added mass and
    inerter in T) constant.  Without mooring the declared potential is exact for this
    planar (surge-heave-pitch) motion."""
    d = oc3_spar(tower_modes=2, drag=False, linear_damping=False, tmdi="tmdi",
                 tmd_damping=0.0, mooring="none")
    m = d.numeric(d.derive())
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


@pytest.mark.slow
def test_flexible_tower_fixed_base_and_coupled_frequencies():
    """The tower's modes are those of the tower with the RNA at its top (the RNA is a
    rigid body, its mass counted once): with the platform held, the model's tower
    frequencies are the fixed-base FE tower+RNA frequencies; floating, the coupled
    frequencies are those of an independently assembled 8 x 8 (6 rigid + 2 modes)."""
    d = oc3_spar(tower_modes=2, tower_elements=10, drag=False, linear_damping=False)
    m = d.numeric(d.derive())
    y = np.zeros(m.n_states)
    Mk, Kk = _jacobians(m, y)
    L = oc3_tower(10, 2, rna=True)        # the loaded tower, RNA as a node mass
    V = L.modes
    # independent assembly: rigid-body modes of the tower nodes about P
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
    Ki[:6, :6] = D.hydrostatic_matrix() + D.mooring_stiffness_matrix()
    Ki[6:, 6:] = V.T @ L.stiffness_matrix @ V
    Ki += _gravity_stiffness(L, R, V)
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
