"""kanedyn's OC3-Hywind spar against OpenFAST (issue 36, item 6).

Part 1 reads the OpenFAST deck of tests/data/openfast_oc3 (OpenFAST's r-test
inputs of the OC3-Hywind system, NOTICE.md there) with
``kd.offshore.read_openfast_input`` and compares its numbers with the data the
``oc3-spar`` model is built from.  Part 2 compares kanedyn's free decays with
OpenFAST's, run on that deck (``benchmarks/openfast_oc3.py run`` wrote the
outputs), with the tolerances stated at each assertion and the reasons for the
differences in docs/oc3_model_card.md ("Against OpenFAST").
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.models import _oc3_data as D

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _openfast_oc3 as oc3  # noqa: E402


def _v(group, name):
    return group[name].value


def _deck(name):
    return kd.offshore.read_openfast_input(oc3.DECK / name)


@pytest.fixture(scope="module")
def elastodyn():
    return _deck("NRELOffshrBsline5MW_OC3Hywind_ElastoDyn.dat")


@pytest.fixture(scope="module")
def hydrodyn():
    return _deck("NRELOffshrBsline5MW_OC3Hywind_HydroDyn.dat")


@pytest.fixture(scope="module")
def summary():
    """OpenFAST's own figures of the run (ElastoDyn's masses, MAP++'s line 1)."""
    rows = np.genfromtxt(oc3.OUTPUTS / "summary.csv", delimiter=",", names=True, dtype=None,
                         encoding="utf-8")
    return {str(k): float(v) for k, v in zip(rows["quantity"], rows["value"])}


# ------------------------------------------------------------ part 1: the inputs
def test_platform_and_environment_match_the_model(elastodyn):
    fst = _deck("OC3Hywind.fst")
    assert fst.number("Gravity") == _v(D.ENVIRONMENT, "gravity")
    assert fst.number("WtrDens") == _v(D.ENVIRONMENT, "water_density")
    assert fst.number("WtrDpth") == _v(D.ENVIRONMENT, "water_depth")
    ed = elastodyn
    assert ed.number("PtfmMass") == _v(D.PLATFORM, "mass")
    assert ed.number("PtfmCMzt") == _v(D.PLATFORM, "cm_z")
    assert ed.number("PtfmRefzt") == 0.0      # reference point at the SWL, as kanedyn's P
    for key, name in (("PtfmRIner", "roll_inertia_cm"), ("PtfmPIner", "pitch_inertia_cm"),
                      ("PtfmYIner", "yaw_inertia_cm")):
        assert ed.number(key) == _v(D.PLATFORM, name)
    assert ed.number("TowerBsHt") == _v(D.TOWER, "base_z") == _v(D.PLATFORM, "top_z")
    assert ed.number("TowerHt") == _v(D.TOWER, "top_z")


def test_rotor_nacelle_and_drivetrain_match_the_model(elastodyn, summary):
    ed = elastodyn
    assert ed.number("HubMass") == _v(D.RNA, "hub_mass")
    assert ed.number("NacMass") == _v(D.RNA, "nacelle_mass")
    # ElastoDyn's signs: shaft tilt and precone negative for an upwind rotor tilted up,
    # the overhang negative upwind of the yaw axis
    assert -ed.number("ShftTilt") == _v(D.ROTOR, "shaft_tilt")
    assert -ed.array("PreCone(1)")[0] == _v(D.ROTOR, "precone")
    assert -ed.number("OverHang") == _v(D.ROTOR, "overhang")
    assert 2 * ed.number("TipRad") == _v(D.ROTOR, "diameter")
    assert ed.number("HubRad") == _v(D.ROTOR, "hub_radius")
    assert ed.number("GBRatio") == _v(D.DRIVETRAIN, "gear_ratio")
    assert ed.number("GenIner") == _v(D.DRIVETRAIN, "generator_inertia")
    assert ed.number("DTTorSpr") == _v(D.DRIVETRAIN, "shaft_stiffness")
    assert ed.number("DTTorDmp") == _v(D.DRIVETRAIN, "shaft_damping")
    # the hub height: tower top + shaft height + overhang along the tilted shaft
    hub = (ed.number("TowerHt") + ed.number("Twr2Shft")
           + ed.number("OverHang") * math.sin(math.radians(ed.number("ShftTilt"))))
    assert hub == pytest.approx(_v(D.ROTOR, "hub_height"), abs=1e-3)
    # ElastoDyn integrates the blade file's mass: three blades of 17,536.6 kg where the
    # 5-MW definition (and kanedyn's RNA of 350 t) has 17,740 kg: 0.17 % less RNA mass
    rna = summary["tower_top_mass"]
    assert rna == pytest.approx(ed.number("HubMass") + ed.number("NacMass")
                                + 3 * 17536.614, abs=1e-3)
    assert rna / _v(D.RNA, "mass") - 1 == pytest.approx(-1.743e-3, abs=1e-6)
    # the rotor inertia about the shaft: ElastoDyn's blades and hub against the drivetrain
    # inertia less the generator's, 0.2 % apart
    assert summary["rotor_inertia"] / _v(D.DRIVETRAIN, "rotor_inertia") - 1 == \
        pytest.approx(-2.12e-3, abs=1e-5)


def test_tower_file_and_elastodyn_tower_mass(summary):
    tower = _deck("NRELOffshrBsline5MW_OC3Hywind_ElastoDyn_Tower.dat")
    table = tower.table("HtFract", rows="NTwInpSt")
    assert np.array_equal(table.column("HtFract"), D.TOWER_STATIONS["fraction"])
    assert np.array_equal(table.column("TMassDen"), D.TOWER_STATIONS["mass_per_length"])
    assert np.array_equal(table.column("TwFAStif"), D.TOWER_STATIONS["EI_fore_aft"])
    assert np.array_equal(table.column("TwSSStif"), D.TOWER_STATIONS["EI_side_side"])
    for key in ("TwrFADmp(1)", "TwrFADmp(2)", "TwrSSDmp(1)", "TwrSSDmp(2)"):
        assert tower.number(key) / 100 == _v(D.TOWER, "damping_ratio")
    # ElastoDyn's integral of the same table (20 nodes) equals kanedyn's exact one
    assert summary["tower_mass"] == pytest.approx(D.tower_rigid_properties()[0], abs=5e-3)
    assert summary["platform_mass"] == _v(D.PLATFORM, "mass")


def test_tower_mode_shapes_are_kanedyns_clamped_modes():
    """The polynomial mode shapes of the tower file reproduce kanedyn's clamped
    tower+RNA modes (the basis of oc3-spar's tower) to 1.5 % of the tip deflection."""
    from kanedyn.models._oc3_tower import oc3_tower
    tower = _deck("NRELOffshrBsline5MW_OC3Hywind_ElastoDyn_Tower.dat")
    fe = oc3_tower(40, 4, rna=True, damping=0.0)
    h = np.linspace(0.0, 1.0, fe.n_nodes)
    shapes = np.array([fe.node_modes(k)[0] for k in range(fe.n_nodes)])
    for j, name in enumerate(fe.mode_names):
        plane, _, k = name.rpartition("_")
        axis, key = (0, "TwFAM") if plane == "fore_aft" else (1, "TwSSM")
        c = [tower.number(f"{key}{k}Sh({p})") for p in range(2, 7)]
        assert sum(c) == pytest.approx(1.0, abs=1e-6)
        poly = sum(ci * h ** p for ci, p in zip(c, range(2, 7)))
        phi = shapes[:, axis, j] / shapes[-1, axis, j]
        assert np.max(np.abs(poly - phi)) < 0.015


def test_hydrodyn_matches_the_model(hydrodyn):
    hd = hydrodyn
    assert hd.number("PtfmVol0") == _v(D.PLATFORM, "displaced_volume")
    assert hd.integer("PotMod") == 1 and hd.integer("RdtnMod") == 0
    # the yaw spring of the delta connection and OC3's additional linear damping
    K = hd.array("AddCLin")
    assert K[5, 5] == _v(D.MOORING, "K66_yaw_spring")
    assert np.count_nonzero(K) == 1
    assert np.array_equal(hd.array("AddBLin"), D.damping_matrix())
    assert not np.any(hd.array("AddF0")) and not np.any(hd.array("AddBQuad"))
    # the spar's geometry: joints on the axis, diameters of the two sections
    z = hd.table("JointID", rows="NJoints").column("Jointzi")
    assert list(z) == [-_v(D.PLATFORM, "draft"), _v(D.PLATFORM, "taper_bottom_z"),
                       _v(D.PLATFORM, "taper_top_z"), _v(D.PLATFORM, "top_z")]
    D_prop = hd.table("PropD", rows="NPropSetsCyl").column("PropD")
    assert list(D_prop) == [_v(D.PLATFORM, "lower_diameter"), _v(D.PLATFORM, "upper_diameter")]
    assert hd.table("SimplCd").column("SimplCd")[0] == _v(D.HYDRO, "drag_coefficient")
    members = hd.table("MJointID1", rows="NMembers")
    assert members.cells("PropPot") == (True, True, True)   # drag only from strip theory


def test_wamit_files_hold_kanedyns_matrices(hydrodyn):
    """The potential-flow files HydroDyn reads carry the published constant added mass
    and hydrostatic matrix, redimensionalized as HydroDyn does (WAMITULEN = 1 m)."""
    rho = _v(D.ENVIRONMENT, "water_density")
    g = _v(D.ENVIRONMENT, "gravity")
    assert hydrodyn.number("WAMITULEN") == 1.0
    root = oc3.DECK / hydrodyn.text("PotFile")
    C = np.zeros((6, 6))
    for i, j, c in np.loadtxt(root.with_suffix(".hst"), ndmin=2):
        C[int(i) - 1, int(j) - 1] = c * rho * g
    assert np.allclose(C, D.hydrostatic_matrix(weight=False), rtol=1e-8, atol=0)
    rows = np.loadtxt(root.with_suffix(".1"), usecols=(0, 1, 2, 3), ndmin=2)
    for period in (-1.0, 0.0, 100.0):
        A = np.zeros((6, 6))
        for _, i, j, a in rows[rows[:, 0] == period]:
            A[int(i) - 1, int(j) - 1] = a * rho
        assert np.allclose(A, D.added_mass_matrix(), rtol=1e-8, atol=0)


def test_map_mooring_matches_the_model_and_its_catenary(summary):
    mp = _deck("NRELOffshrBsline5MW_OC3Hywind_MAP.dat")
    line = mp.table("Diam")
    assert line.column("Diam")[0] == _v(D.MOORING, "line_diameter")
    assert line.column("MassDenInAir")[0] == _v(D.MOORING, "line_mass_per_length")
    assert line.column("EA")[0] == _v(D.MOORING, "line_EA")
    nodes = mp.table("Attachment")
    assert nodes.cells("Attachment") == ("fix", "Vessel")
    assert nodes.cells("Z")[0] == "depth"      # the anchor on the seabed, 320 m
    assert nodes.column("X").tolist() == [_v(D.MOORING, "anchor_radius"),
                                          _v(D.MOORING, "fairlead_radius")]
    assert nodes.cells("Z")[1] == -_v(D.MOORING, "fairlead_depth")
    assert mp.table("UnstrLen").column("UnstrLen")[0] == _v(D.MOORING, "unstretched_length")
    # kanedyn's catenary at the undisplaced fairlead against MAP++'s solution: the same
    # equations, MAP++'s seabed friction (CB = 0.001) aside; measured 6e-7 apart
    from kanedyn.modeling.offshore import solve_catenary
    rho, g = _v(D.ENVIRONMENT, "water_density"), _v(D.ENVIRONMENT, "gravity")
    w = (_v(D.MOORING, "line_mass_per_length")
         - rho * math.pi * _v(D.MOORING, "line_diameter") ** 2 / 4)
    x = _v(D.MOORING, "anchor_radius") - _v(D.MOORING, "fairlead_radius")
    z = _v(D.MOORING, "anchor_depth") - _v(D.MOORING, "fairlead_depth")
    H, V = solve_catenary(x, z, _v(D.MOORING, "unstretched_length"), w * g,
                          _v(D.MOORING, "line_EA"))
    assert H == pytest.approx(summary["fairlead_horizontal"], rel=2e-6)
    assert V == pytest.approx(summary["fairlead_vertical"], rel=2e-6)


def test_regeneration_without_openfast_says_so_and_changes_nothing(monkeypatch, capsys):
    import openfast_oc3
    monkeypatch.delenv("OPENFAST", raising=False)
    monkeypatch.setenv("PATH", "")
    before = {p: p.read_bytes() for p in oc3.DATA.rglob("*") if p.is_file()}
    assert openfast_oc3.main(["run", "--openfast", str(oc3.DATA / "no-such-openfast")]) == 0
    assert "no OpenFAST executable" in capsys.readouterr().out
    assert before == {p: p.read_bytes() for p in oc3.DATA.rglob("*") if p.is_file()}


# ------------------------------------------------------------ part 2: the responses
def _both(name):
    """OpenFAST's committed response and kanedyn's, ``((t, channels), (t, channels))``."""
    case = oc3.CASES[name]
    return oc3.read_output_csv(oc3.OUTPUTS / f"{name}.csv"), oc3.kanedyn_response(case)


#: case -> (relative period tolerance, damping-ratio tolerance (absolute), relative
#: tolerance of the double amplitudes, cycles compared); measured differences and their
#: causes in docs/oc3_model_card.md ("Against OpenFAST")
#: (surge is not compared: OpenFAST's loosely coupled surge decay is damped less than its
#: linear damping matrix alone would damp it; the card's "OpenFAST's coupling")
DECAY_TOLERANCES = {
    # measured: period 1e-5, damping 1e-5; double amplitudes 1.8 % larger in kanedyn,
    # as OpenFAST's balance is 1.7 cm higher (its lighter RNA), 1.7 % of the release
    "heave": (0.002, 0.001, 0.025, 4),
    # measured: period -0.04 %, damping -0.0011, double amplitudes up to +1.6 %
    "pitch": (0.003, 0.002, 0.025, 3),
    # measured: period +0.52 %, damping -0.0002, double amplitudes up to +0.4 %
    "yaw": (0.008, 0.001, 0.01, 4),
    # measured: period -0.003 %, damping +0.0001, double amplitudes within 0.5 %
    "tower": (0.002, 0.0005, 0.01, 10),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(DECAY_TOLERANCES))
def test_free_decay_against_openfast(name):
    """Period, damping ratio (logarithmic decrement of the double amplitudes) and the
    amplitude envelope of each free decay, kanedyn against OpenFAST on the same inputs
    (released from the same displacement of the undisplaced platform)."""
    (t_of, of), (t_kd, kd) = _both(name)
    channel = oc3.CASES[name].channel
    period_tol, damping_tol, amplitude_tol, cycles = DECAY_TOLERANCES[name]
    a = oc3.decay_measures(t_of, of[channel], count=cycles)
    b = oc3.decay_measures(t_kd, kd[channel], count=cycles)
    assert len(a.times) == len(b.times) == cycles
    assert abs(b.period / a.period - 1) < period_tol
    assert abs(b.damping - a.damping) < damping_tol
    assert np.max(np.abs(b.double_amplitudes / a.double_amplitudes - 1)) < amplitude_tol


@pytest.mark.slow
def test_offsets_released_undisplaced_against_openfast(summary):
    """Released from the undisplaced position, both settle (a damped cosine fitted from
    40 s) to the tower deflection of the RNA's overhanging weight within 5 % (measured
    1.4 %); OpenFAST floats higher by its lighter RNA's buoyancy surplus,
    Δm g / (C33 + K33) = 1.74 cm, measured 1.71 cm, within 5 %.  (The settled pitch is
    not compared: OpenFAST's loosely coupled surge swings by a metre in this record,
    docs/oc3_model_card.md, "OpenFAST's coupling".)"""
    (t_of, of), (t_kd, kd) = _both("still")
    top = [oc3.settled_offset(t, s["TTDspFA"], 29.5) for t, s in ((t_of, of), (t_kd, kd))]
    assert top[1] < 0 and abs(top[1] / top[0] - 1) < 0.05
    heave = [oc3.settled_offset(t, s["PtfmHeave"], 30.9) for t, s in ((t_of, of), (t_kd, kd))]
    mass = D.system_mass_properties()[0] - summary["total_mass"]
    stiffness = _v(D.HYDRO, "C33") + _v(D.MOORING, "K33")
    expected = mass * _v(D.ENVIRONMENT, "gravity") / stiffness
    assert expected == pytest.approx(0.0174, abs=1e-4)
    assert heave[0] - heave[1] == pytest.approx(expected, rel=0.05)
    assert abs(heave[1]) < 1e-3        # kanedyn starts within 0.15 mm of its balance


#: channel -> (relative amplitude tolerance, phase tolerance (rad)) of the response at
#: the wave period, from 60 s on; measured (kanedyn against OpenFAST): surge -0.65 %,
#: pitch -1.0 %, tower-top deflection -0.8 %, phases within 0.0032 rad.  Heave is not
#: compared: neither code has a first-order heave excitation here (no axial terms), its
#: 5 to 11 mm at the wave period are second-order effects (docs/oc3_model_card.md)
WAVE_TOLERANCES = {
    "PtfmSurge": (0.02, 0.01),
    "PtfmPitch": (0.025, 0.01),
    "TTDspFA": (0.02, 0.01),
}


@pytest.mark.slow
def test_regular_waves_against_openfast():
    """In the same regular wave (H 6 m, T 10 s, a crest at the origin at t = 0 in both)
    the responses at the wave period (fitted from 60 s on, with a cubic for the slow
    transient) agree in amplitude and phase within the stated tolerances; the two wave
    elevations first agree with the wave asked for, to 1e-4 of the amplitude."""
    (t_of, of), (t_kd, kd) = _both("waves")
    period, start = oc3.WAVE_PERIOD, oc3.WAVE_START
    waves = [oc3.wave_harmonic(t, s["Wave1Elev"], period, start) for t, s in
             ((t_of, of), (t_kd, kd))]
    for h in waves:
        assert h.amplitude == pytest.approx(oc3.WAVE_HEIGHT / 2, rel=1e-4)
        assert abs(h.phase) < 1e-4
    for channel, (amplitude_tol, phase_tol) in WAVE_TOLERANCES.items():
        a, b = (oc3.wave_harmonic(t, s[channel], period, start) for t, s in
                ((t_of, of), (t_kd, kd)))
        assert abs(b.amplitude / a.amplitude - 1) < amplitude_tol, channel
        assert abs(math.remainder(b.phase - a.phase, 2 * math.pi)) < phase_tol, channel




#: the steady-wind case (18 m/s, rotor turning, baseline controller, still water):
#: channel -> relative tolerance of kanedyn's mean against OpenFAST's, means from
#: oc3.WIND_START (100 s) to 400 s; measured (kanedyn against OpenFAST): rotor speed and
#: electrical power +0.009 %, blade pitch +0.21 %, aerodynamic thrust +2.94 %, platform
#: pitch +1.99 %, tower-top deflection +0.41 %.  OpenFAST's rotor speed, power and pitch
#: swing (by 0.22 %, 0.22 % and 0.37 %) with its undamped surge oscillation, and the
#: window is not a whole number of those swings; causes in docs/oc3_model_card.md
#: ("Against OpenFAST")
WIND_TOLERANCES = {
    "RotSpeed": 0.002,
    "GenPwr": 0.002,
    "BlPitch1": 0.006,
    "RtAeroFxh": 0.035,
    "PtfmPitch": 0.025,
    "TTDspFA": 0.01,
}


@pytest.mark.slow
def test_steady_wind_against_openfast():
    """In a steady uniform 18 m/s wind with the rotor turning and the baseline
    controller (OC3 gains, region-3 constant torque) on, both codes started from the
    same state (kanedyn's settled one), the means from 100 s of rotor speed, electrical
    power, blade pitch, aerodynamic thrust, platform pitch and tower-top deflection
    agree within the stated tolerances; kanedyn's larger thrust is the one difference
    beyond 0.5 % in the rotor.  (Surge and heave are not compared: OpenFAST's loosely
    coupled surge swings by a metre about a mean 1 m further downwind, undamped, and
    its heave with it; docs/oc3_model_card.md, "OpenFAST's coupling".)  kanedyn's
    record is steady from 100 s and is run to 125 s only: its means over 100-200 s
    equal those over OpenFAST's 100-400 s window to 5 digits (measured on a 400 s run),
    and its means over 100-125 s equal those over 100-200 s within 1.6e-5 relative
    (measured on a 200 s run; the largest, platform pitch, 1.5e-5), below 1 % of every
    channel's margin to its tolerance."""
    case = oc3.CASES["wind"]
    t_of, of = oc3.read_output_csv(oc3.OUTPUTS / "wind.csv")
    end = oc3.WIND_START + 25.0
    t_kd, kd = oc3.kanedyn_response(case, duration=end)
    assert t_of[-1] == case.duration and t_kd[-1] == end
    for channel, tol in WIND_TOLERANCES.items():
        a, b = (oc3.wind_mean(t, s, channel) for t, s in ((t_of, of), (t_kd, kd)))
        assert abs(b / a - 1) < tol, (channel, a, b)
    thrust = [oc3.wind_mean(t, s, "RtAeroFxh") for t, s in ((t_of, of), (t_kd, kd))]
    assert thrust[1] / thrust[0] - 1 > 0.02      # the known difference, not yet explained
