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
    """rna_offset=False: the undisplaced state heaved to balance is an equilibrium; kd's full linearize there
    against scipy's generalized eigenproblem of the same 6x6 matrices, to 1e-6."""
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


@pytest.mark.slow
def test_flexible_tower_fore_aft_frequency():
    d = oc3_spar(tower_modes=2, drag=False, linear_damping=False)
    m = d.numeric(d.derive())
    y = oc3_settle(d, m)
    A = m.linearize(y)[0]
    ev, vec = np.linalg.eig(A)
    names = m.state_names[:m.n_q]
    member = d.symbols["tower"].member
    fa = names.index(f"eta_tower_{member.mode_names.index('fore_aft_1') + 1}")
    pick = [i for i in range(len(ev)) if ev[i].imag > 0]
    share = [abs(vec[fa, i]) / np.abs(vec[:m.n_q, i]).max() for i in pick]
    coupled = abs(ev[pick[int(np.argmax(share))]].imag) / (2 * np.pi)
    # fixed base: the tower with the RNA lumped at its top, the same reduction
    fixed = oc3_tower(10, 2, rna=True)
    w2, v = sl.eigh(np.asarray(fixed.modal_stiffness(), float),
                    np.asarray(fixed.modal_mass(), float))
    j = fixed.mode_names.index("fore_aft_1")
    f_fixed = np.sqrt(w2[int(np.argmax(np.abs(v[j])))]) / (2 * np.pi)
    print(f"tower fore-aft: coupled {coupled:.4f} Hz, fixed base {f_fixed:.4f} Hz")
    # measured: coupled 0.515 Hz, fixed base 0.376 Hz: the floating base lets the
    # tower bend against the platform's inertia (higher), and the coupled model's modes
    # are the clamped tower's without the RNA (a Ritz basis: an upper bound)
    assert f_fixed < coupled < 1.5 * f_fixed


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
