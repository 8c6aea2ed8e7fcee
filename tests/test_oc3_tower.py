"""The OC3-Hywind data and tower: mass, frequencies, reductions, 6 x 6 matrices.

Independent references: the station table integrated by the trapezoid and
Simpson rules; the Euler-Bernoulli eigenproblem with the same interpolated
properties solved by shooting (solve_ivp over each station interval, the
frequency from the root of the tip-condition determinant); a fine FE model.
"""

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.integrate import simpson, solve_ivp
from scipy.optimize import brentq

import kanedyn as kd
from kanedyn.models._oc3_data import (HYDRO, MOORING, PLATFORM, RNA, SOURCES, TOWER,
                                      TOWER_STATIONS, added_mass_matrix, all_figures,
                                      damping_matrix,
                                      hydrostatic_matrix, mooring_stiffness_matrix,
                                      rigid_body_mass_matrix, rna_inertia_about_cm,
                                      system_mass_matrix,
                                      system_mass_properties, tower_rigid_properties,
                                      tower_stations)
from kanedyn.models._oc3_tower import oc3_rna_node_mass, oc3_tower, oc3_tower_member

G = 9.80665
LENGTH = 77.6
FRACTION = np.array(TOWER_STATIONS["fraction"])
MPL = np.array(TOWER_STATIONS["mass_per_length"])
S = FRACTION * LENGTH


# ------------------------------------------------------------------ helpers
def planar_tip(plane):
    """Tip data (mass, first moment, inertia about the top) of the RNA in one bending plane."""
    m, rz = RNA["mass"].value, RNA["cm_z"].value
    J = RNA["Iyy_top"].value if plane == "fore_aft" else RNA["Ixx_top"].value
    return m, m * rz, J


def planar_node_mass(plane):
    """An RNA stand-in with the same in-plane mass, first moment and top inertia, no offset in x.

    It couples neither with axial motion nor with twist, as the shooting solution assumes.
    """
    m, _, J = planar_tip(plane)
    rz = RNA["cm_z"].value
    Jc = J - m * rz ** 2
    inertia = np.diag([Jc, Jc, 1e3])
    return kd.flexible.NodeMass(-1, m, inertia=inertia, offset=(0.0, 0.0, rz))


def shooting_frequency(plane, tip=True, f_start=0.05):
    """First bending frequency (Hz) of the clamped tower by shooting the Euler-Bernoulli ODE.

    State (w, w', EI w'', (EI w'')'); (EI w'')'' = omega^2 m w.  Base: w = w' = 0.
    Tip with a rigid body of mass m, first moment S, inertia J about the top:
    EI w''(L) = omega^2 (S w + J w'), (EI w'')'(L) = -omega^2 (m w + S w').
    """
    EI = np.array(TOWER_STATIONS["EI_fore_aft" if plane == "fore_aft" else "EI_side_side"])
    mt, St, Jt = planar_tip(plane) if tip else (0.0, 0.0, 0.0)
    scale = EI[0] / LENGTH ** 2

    def rhs(x, y, w2):
        ei = np.interp(x, S, EI)
        m = np.interp(x, S, MPL)
        y = y.reshape(4, 2)
        return np.concatenate([y[1], y[2] * scale / ei, y[3], w2 * m * y[0] / scale]).ravel()

    def residual(f):
        w2 = (2 * np.pi * f) ** 2
        y = np.array([[0, 0], [0, 0], [1.0, 0], [0, 1.0 / LENGTH]]).ravel()
        for a, b in zip(S[:-1], S[1:]):
            y = solve_ivp(rhs, (a, b), y, args=(w2,), method="DOP853", rtol=1e-12,
                          atol=1e-14).y[:, -1]
        w, th, M, V = y.reshape(4, 2)
        r1 = M * scale - w2 * (St * w + Jt * th)
        r2 = V * scale + w2 * (mt * w + St * th)
        return r1[0] * r2[1] - r1[1] * r2[0]

    f0, r0 = f_start, residual(f_start)
    while True:
        f1 = f0 + 0.02
        r1 = residual(f1)
        if np.sign(r1) != np.sign(r0):
            return brentq(residual, f0, f1, xtol=1e-12, rtol=1e-12)
        f0, r0 = f1, r1


def first_by_plane(K, M, modes, top):
    """First fore-aft (top ux) and side-side (top uy) frequencies (Hz) of the Ritz basis."""
    K = np.asarray(modes.T @ (K @ modes))
    M = np.asarray(modes.T @ (M @ modes))
    w2, X = sla.eigh(K, M)
    out = {}
    for j in np.argsort(w2):
        u = modes[6 * top:6 * top + 2] @ X[:, j]
        plane = "fore_aft" if abs(u[0]) > abs(u[1]) else "side_side"
        out.setdefault(plane, np.sqrt(w2[j]) / (2 * np.pi))
    return out


def full_first(member):
    _, X = member.natural_modes(8, supports={0: "all"})
    return first_by_plane(member.stiffness_matrix, member.mass_matrix, X, member.n_nodes - 1)


# ------------------------------------------------------------------- tower mass
def test_tower_mass_from_the_table():
    member = oc3_tower_member(20, rna=False)
    M = np.asarray(member.mass_matrix)
    ez = np.zeros(M.shape[0])
    ez[2::6] = 1.0
    trapezoid = np.trapezoid(MPL, S)
    assert ez @ M @ ez == pytest.approx(trapezoid, rel=1e-12)
    # the published 249,718 kg: the table's linear interpolation gives it to 0.003 kg
    assert trapezoid == pytest.approx(TOWER["mass"].value, rel=1e-7)
    assert tower_rigid_properties()[0] == pytest.approx(trapezoid, rel=1e-12)
    # Simpson on the 11 stations (quadratic pieces, closer to the tube) gives 72.5 kg (0.03 %) less
    assert simpson(MPL, x=S) - trapezoid == pytest.approx(-72.47, abs=0.01)


def test_tower_mass_moment_about_the_base():
    member = oc3_tower_member(20, rna=False)
    M = np.asarray(member.mass_matrix)
    z = member.nodes[:, 2]
    ex = np.zeros(M.shape[0])
    ex[0::6] = 1.0
    ry = np.zeros(M.shape[0])   # rigid rotation about y: u_x = z theta, theta_y = theta
    ry[0::6] = z
    ry[4::6] = 1.0
    # Simpson with the midpoints of linearly interpolated mass is exact for (m s) and (m s^2)
    fine = np.linspace(0, LENGTH, 2 * (len(S) - 1) + 1)
    mfine = np.interp(fine, S, MPL)
    first = simpson(mfine * fine, x=fine)
    second = simpson(mfine * fine ** 2, x=fine)
    assert ex @ M @ ry == pytest.approx(first, rel=1e-12)
    assert ry @ M @ ry == pytest.approx(second, rel=1e-12)   # no bending rotary inertia
    mass, cm, inertia = tower_rigid_properties(section_inertia=False)
    assert cm[2] == pytest.approx(TOWER["base_z"].value + first / mass, rel=1e-12)
    assert inertia[0, 0] == pytest.approx(second - first ** 2 / mass, rel=1e-10)


def test_tower_sections_reproduce_the_mass_per_length_at_the_ends():
    # the tube geometry is a second source for the end stations' mass per length
    for D, t, m in ((TOWER["base_diameter"], TOWER["base_thickness"], MPL[0]),
                    (TOWER["top_diameter"], TOWER["top_thickness"], MPL[-1])):
        tube = TOWER["density"].value * np.pi * (D.value - t.value) * t.value
        assert tube == pytest.approx(m, rel=1e-4)
    assert tower_stations()["polar_inertia"][0] > 0


# ---------------------------------------------------------------- frequencies
@pytest.mark.slow
@pytest.mark.parametrize("plane", ["fore_aft", "side_side"])
@pytest.mark.parametrize("tip", [False, True])
def test_first_bending_frequency_against_shooting(plane, tip):
    reference = shooting_frequency(plane, tip)
    nm = (planar_node_mass(plane),) if tip else ()
    member = kd.flexible.BeamMember("tower", tower_stations(), n_elements=40, direction=(0, 0, 1),
                                    node_masses=nm)
    fe = full_first(member)[plane]
    assert fe == pytest.approx(reference, rel=1e-6)
    if tip:   # the real RNA (x offset, product of inertia) changes it by less than 0.1 %
        assert full_first(oc3_tower_member(40))[plane] == pytest.approx(reference, rel=1e-3)


@pytest.mark.slow
@pytest.mark.parametrize("plane", ["fore_aft", "side_side"])
def test_element_convergence_is_fourth_order(plane):
    # meshes aligned with the stations (10, 20, 40 elements); the RNA stand-in in the plane
    # (the real RNA's x offset couples side-side with twist, whose linear elements converge
    # as h^2 and spoil the rate below 1e-7)
    reference = shooting_frequency(plane)
    errors = []
    for n in (10, 20, 40):
        member = kd.flexible.BeamMember("tower", tower_stations(), n_elements=n,
                                        direction=(0, 0, 1),
                                        node_masses=(planar_node_mass(plane),))
        errors.append(full_first(member)[plane] / reference - 1)
    errors = np.array(errors)
    assert np.all(errors > 0)                                   # consistent mass: upper bounds
    ratios = errors[:-1] / errors[1:]
    assert np.all((ratios > 14) & (ratios < 18)), ratios        # h^4: 16 per halving
    fine = full_first(oc3_tower_member(200))
    coarse = full_first(oc3_tower_member(20))
    for p in ("fore_aft", "side_side"):                         # the real RNA, 20 elements
        assert 0 < coarse[p] / fine[p] - 1 < 2e-7


def test_craig_bampton_converges_from_above():
    member = oc3_tower_member(40)
    exact = full_first(member)
    top = member.n_nodes - 1
    previous = None
    for n in (0, 2, 4, 8, 16):
        reduced = member.craig_bampton((top,), n_modes=n)
        f = first_by_plane(member.stiffness_matrix, member.mass_matrix, reduced.modes, top)
        now = np.array([f["fore_aft"], f["side_side"]])
        truth = np.array([exact["fore_aft"], exact["side_side"]])
        assert np.all(now >= truth * (1 - 1e-10))                 # upper bounds
        if previous is not None:
            assert np.all(now <= previous * (1 + 1e-12))          # monotone
        previous = now
    assert np.all(previous / truth - 1 < 1e-6)


def test_oc3_tower_reduced_modes():
    reduced = oc3_tower(20, 4)
    assert set(reduced.mode_names) == {"fore_aft_1", "side_side_1", "fore_aft_2",
                                       "side_side_2"}
    exact = full_first(oc3_tower_member(20))
    f = dict(zip(reduced.mode_names, reduced.reduced_frequencies))
    # keeping normal modes of the clamped member: the first ones are exact
    assert np.sort(reduced.reduced_frequencies)[:2] == pytest.approx(
        sorted(exact.values()), rel=1e-8)
    assert "fore_aft_1" in reduced.report()
    assert min(f, key=f.get) == "side_side_1"     # the RNA's roll inertia exceeds its pitch one
    with pytest.raises(kd.ModelError, match="modes"):
        oc3_tower(20, 0)


# -------------------------------------------------------------- 6 x 6 matrices
def test_system_mass_and_centre_of_mass():
    mass, cm = system_mass_properties()
    tower_mass, tower_cm, _ = tower_rigid_properties()
    parts = [(PLATFORM["mass"].value, PLATFORM["cm_z"].value), (tower_mass, tower_cm[2]),
             (RNA["mass"].value, TOWER["top_z"].value + RNA["cm_z"].value)]
    assert mass == pytest.approx(sum(m for m, _ in parts), rel=1e-14)
    assert mass == pytest.approx(7_466_330 + 249_718 + 350_000, abs=0.01)
    assert cm[2] == pytest.approx(sum(m * z for m, z in parts) / mass, rel=1e-12)
    assert cm[0] == pytest.approx(RNA["mass"].value * RNA["cm_x"].value / mass, rel=1e-12)
    M = system_mass_matrix()
    assert np.allclose(M, M.T, rtol=0, atol=1e-12 * np.abs(M).max())
    assert np.all(np.linalg.eigvalsh(M) > 0)
    assert np.allclose(M[:3, :3], mass * np.eye(3), rtol=1e-14)
    assert M[0, 4] == pytest.approx(mass * cm[2], rel=1e-12)     # m z_G couples surge-pitch
    assert M[1, 3] == pytest.approx(-mass * cm[2], rel=1e-12)
    parts_sum = sum(system_mass_matrix([p]) for p in ("platform", "tower", "rna"))
    assert np.allclose(parts_sum, M, rtol=1e-14)
    # pitch inertia about SWL: parallel axes, checked by hand for the platform
    Mp = system_mass_matrix(["platform"])
    assert Mp[4, 4] == pytest.approx(PLATFORM["pitch_inertia_cm"].value
                                     + PLATFORM["mass"].value * PLATFORM["cm_z"].value ** 2)


def test_tower_block_matches_the_finite_element_rigid_motion():
    member = oc3_tower_member(20)
    M = np.asarray(member.mass_matrix)
    nodes = member.nodes
    R = np.zeros((M.shape[0], 6))      # rigid motions of the base point: u = v + w x r
    for k, r in enumerate(nodes):
        R[6 * k:6 * k + 3, :3] = np.eye(3)
        R[6 * k:6 * k + 3, 3:] = -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]],
                                            [-r[1], r[0], 0]])
        R[6 * k + 3:6 * k + 6, 3:] = np.eye(3)
    fe = R.T @ M @ R
    base = np.array([0, 0, TOWER["base_z"].value])
    mt, ct, It = tower_rigid_properties(section_inertia=False)
    It[2, 2] = tower_rigid_properties()[2][2, 2]         # the FE has polar, no bending rotary
    ref = (rigid_body_mass_matrix(mt, ct - base, It)
           + rigid_body_mass_matrix(
               RNA["mass"].value, [RNA["cm_x"].value, 0, LENGTH + RNA["cm_z"].value],
               rna_inertia_about_cm()))
    assert np.allclose(fe, ref, rtol=0, atol=2e-4 * np.abs(ref).max())
    assert fe[5, 5] == pytest.approx(ref[5, 5], rel=2e-3)     # yaw: polar inertia interpolated


def test_hydrostatic_added_mass_damping_and_mooring_matrices():
    C = hydrostatic_matrix()
    mass, cm = system_mass_properties()
    assert np.allclose(C, C.T)
    assert C[4, 4] - HYDRO["C55_buoyancy"].value == pytest.approx(-mass * G * cm[2])
    assert C[4, 4] > 0 and C[3, 3] > 0                          # stable in roll and pitch
    assert np.allclose(hydrostatic_matrix(weight=False)[3:5, 3:5],
                       np.diag([HYDRO["C44_buoyancy"].value] * 2))
    A = added_mass_matrix()
    assert np.allclose(A, A.T) and A[0, 4] == -A[1, 3]
    assert np.all(np.linalg.eigvalsh(A[:5, :5]) > 0)
    B = damping_matrix()
    assert np.allclose(B, np.diag(np.diag(B)))
    K = mooring_stiffness_matrix()
    asym = np.abs(K - K.T).max() / np.abs(K[0, 4])
    assert 0 < asym < 2e-3                                     # as published: 0.18 %
    assert K[5, 5] == MOORING["K66"].value + MOORING["K66_yaw_spring"].value
    assert K[0, 4] == -K[1, 3] and K[4, 0] == -K[3, 1]
    # fairleads 70 m below SWL: the coupling is about -70 m times the surge stiffness
    assert K[4, 0] / K[0, 0] == pytest.approx(-70, rel=0.05)


def test_rigid_system_heave_frequency_closed_form():
    M, A = system_mass_matrix(), added_mass_matrix()
    C, K = hydrostatic_matrix(), mooring_stiffness_matrix()
    w2 = np.sort(sla.eigvals(C + K, M + A).real)
    heave = np.sqrt((HYDRO["C33"].value + MOORING["K33"].value)
                    / (system_mass_properties()[0] + HYDRO["A33"].value))
    # the RNA's x offset couples heave with pitch a little (4e-7 here)
    assert np.min(np.abs(np.sqrt(w2) - heave)) < 1e-5 * heave


def test_every_figure_has_a_known_source_and_is_in_the_model_card():
    from pathlib import Path
    card = (Path(__file__).parents[1] / "docs" / "oc3_model_card.md").read_text()
    for group, name, figure in all_figures():
        assert figure.source in SOURCES
        assert f"`{group}.{name}`" in card, (group, name)
    assert np.all(np.linalg.eigvalsh(rna_inertia_about_cm()) > 0)
    assert oc3_rna_node_mass().matrix().shape == (6, 6)
