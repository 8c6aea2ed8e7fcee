"""Finite-element members and component mode synthesis against closed forms.

References (``/work/shared/REFERENCES.md``, "Euler–Bernoulli beam frequencies"):
roots beta L of the clamped–free, free–free and pinned–free frequency equations,
omega = (beta L)^2 sqrt(EI / (rho A L^4)); rods: omega = (2n - 1) pi / (2L)
sqrt(EA / rho A) (clamped–free), n pi / L sqrt(EA / rho A) (free–free); the
Rayleigh and Timoshenko simply supported beams in closed form; a tapered
cantilever against a shooting solution of (EI w'')'' = omega^2 rho A w; a
cantilever with a tip mass against its frequency equation.
"""

import numpy as np
import pytest
import scipy.io
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

import kanedyn as kd
from kanedyn import ModelError, OptionError
from kanedyn.modeling.flexible import beam_element_matrices

CLAMPED_FREE = [1.875104068712, 4.694091132974, 7.854757438238]
FREE_FREE = [4.730040744863, 7.853204624096, 10.995607838002]
PINNED_FREE = [3.926602312048, 7.068582745629, 10.210176122813]

L, RHO_A, EI = 1.5, 3.0, 2.0


def _uniform(n, **overrides):
    """A uniform beam along x; bending in x-y (EI_z = EI) far below x-z and the rest."""
    props = dict(mass_per_length=RHO_A, EA=1e9, GJ=1e9, EI_y=1e6 * EI, EI_z=EI,
                 polar_inertia=1e-6)
    props.update(overrides)
    return kd.flexible.BeamMember.uniform("beam", L, n_elements=n, **props)


def _beta(frequency):
    omega = 2 * np.pi * np.asarray(frequency)
    return (omega ** 2 * RHO_A * L ** 4 / EI) ** 0.25


def _orders(errors, ns):
    """Least-squares order over all meshes, and the order of the finest pair."""
    errors, h = np.abs(np.asarray(errors)), 1.0 / np.asarray(ns, float)
    fitted = np.polyfit(np.log(h), np.log(errors), 1)[0]
    last = np.log(errors[-2] / errors[-1]) / np.log(h[-2] / h[-1])
    return fitted, last


# ------------------------------------------------------------------ elements
def test_element_matches_closed_form_matrices():
    length, ei, ra, ri, kga = 2.0, 3.0, 5.0, 0.7, 40.0
    e = beam_element_matrices(length, mass_per_length=ra, EA=11.0, GJ=13.0, EI_y=ei, EI_z=ei,
                              rotary_inertia_y=ri, rotary_inertia_z=ri)
    xy = [1, 5, 7, 11]
    Lh = length
    k = ei / Lh ** 3 * np.array([[12, 6 * Lh, -12, 6 * Lh], [6 * Lh, 4 * Lh ** 2, -6 * Lh,
                                                             2 * Lh ** 2],
                                 [-12, -6 * Lh, 12, -6 * Lh], [6 * Lh, 2 * Lh ** 2, -6 * Lh,
                                                               4 * Lh ** 2]])
    g = 1 / (30 * Lh) * np.array([[36, 3 * Lh, -36, 3 * Lh], [3 * Lh, 4 * Lh ** 2, -3 * Lh,
                                                              -Lh ** 2],
                                  [-36, -3 * Lh, 36, -3 * Lh], [3 * Lh, -Lh ** 2, -3 * Lh,
                                                                4 * Lh ** 2]])
    m = ra * Lh / 420 * np.array([[156, 22 * Lh, 54, -13 * Lh], [22 * Lh, 4 * Lh ** 2, 13 * Lh,
                                                                 -3 * Lh ** 2],
                                  [54, 13 * Lh, 156, -22 * Lh], [-13 * Lh, -3 * Lh ** 2,
                                                                 -22 * Lh, 4 * Lh ** 2]])
    m_rot = ri * g                # rotary inertia: rho I / (30 L) [36 3L ...]
    np.testing.assert_allclose(e.stiffness[np.ix_(xy, xy)], k, atol=1e-12)
    np.testing.assert_allclose(e.mass[np.ix_(xy, xy)], m + m_rot, atol=1e-12)
    np.testing.assert_allclose(e.geometric_stiffness[np.ix_(xy, xy)], g, atol=1e-12)
    xz, flip = [2, 4, 8, 10], np.outer([1, -1, 1, -1], [1, -1, 1, -1])   # theta_y = -w'
    np.testing.assert_allclose(e.stiffness[np.ix_(xz, xz)] * flip, k, atol=1e-12)
    np.testing.assert_allclose(e.stiffness[np.ix_([0, 6], [0, 6])], 11.0 / Lh * np.array(
        [[1, -1], [-1, 1]]))
    np.testing.assert_allclose(e.mass[np.ix_([3, 9], [3, 9])], 2 * ri * Lh / 6 * np.array(
        [[2, 1], [1, 2]]))                           # polar inertia = rho (I_y + I_z)
    # Timoshenko: Przemieniecki's matrices with phi = 12 EI / (kappa G A L^2)
    t = beam_element_matrices(length, mass_per_length=ra, EA=11.0, GJ=13.0, EI_y=ei, EI_z=ei,
                              rotary_inertia_z=ri, rotary_inertia_y=ri, shear_stiffness_y=kga,
                              shear_stiffness_z=kga)
    P = 12 * ei / (kga * Lh ** 2)
    kt = ei / ((1 + P) * Lh ** 3) * np.array(
        [[12, 6 * Lh, -12, 6 * Lh], [6 * Lh, (4 + P) * Lh ** 2, -6 * Lh, (2 - P) * Lh ** 2],
         [-12, -6 * Lh, 12, -6 * Lh], [6 * Lh, (2 - P) * Lh ** 2, -6 * Lh, (4 + P) * Lh ** 2]])
    np.testing.assert_allclose(t.stiffness[np.ix_(xy, xy)], kt, atol=1e-12)
    a = [13 / 35 + 7 * P / 10 + P ** 2 / 3, (11 / 210 + 11 * P / 120 + P ** 2 / 24) * Lh,
         9 / 70 + 3 * P / 10 + P ** 2 / 6, -(13 / 420 + 3 * P / 40 + P ** 2 / 24) * Lh,
         (1 / 105 + P / 60 + P ** 2 / 120) * Lh ** 2, -(1 / 140 + P / 60 + P ** 2 / 120) * Lh ** 2]
    mt = ra * Lh / (1 + P) ** 2 * np.array([[a[0], a[1], a[2], a[3]], [a[1], a[4], -a[3], a[5]],
                                            [a[2], -a[3], a[0], -a[1]],
                                            [a[3], a[5], -a[1], a[4]]])
    r = [6 / 5, (1 / 10 - P / 2) * Lh, (2 / 15 + P / 6 + P ** 2 / 3) * Lh ** 2,
         (-1 / 30 - P / 6 + P ** 2 / 6) * Lh ** 2]
    mr = ri / ((1 + P) ** 2 * Lh) * np.array([[r[0], r[1], -r[0], r[1]], [r[1], r[2], -r[1], r[3]],
                                              [-r[0], -r[1], r[0], -r[1]],
                                              [r[1], r[3], -r[1], r[2]]])
    np.testing.assert_allclose(t.mass[np.ix_(xy, xy)], mt + mr, atol=1e-12)
    assert t.shear_parameters["bending_xy"] == pytest.approx(P)


def test_geometric_stiffness_gives_euler_buckling_load():
    """K - P K_G is singular at the cantilever's buckling load pi^2 EI / (4 L^2)."""
    member = _uniform(16)
    free = np.arange(6, member.stiffness_matrix.shape[0])
    K = member.stiffness_matrix[np.ix_(free, free)]
    KG = member.geometric_stiffness()[np.ix_(free, free)]
    P = sla.eigh(KG, K, eigvals_only=True)[-1]       # largest 1 / P_cr
    assert 1 / P == pytest.approx(np.pi ** 2 * EI / (4 * L ** 2), rel=1e-6)


# ------------------------------------------------- uniform beams: convergence
@pytest.mark.parametrize("supports, roots", [({0: "all"}, CLAMPED_FREE),
                                             ({}, FREE_FREE),
                                             ({0: "translations"}, PINNED_FREE)],
                         ids=["clamped-free", "free-free", "pinned-free"])
def test_bending_frequencies_converge_at_h4(supports, roots):
    ns = [2, 4, 8, 16, 32]
    errors = []
    for n in ns:
        frequencies = _uniform(n).natural_frequencies(3, supports=supports)
        errors.append(_beta(frequencies) / roots - 1)
    errors = np.array(errors)
    assert np.all(errors > 0)                        # consistent mass: upper bounds
    assert np.all(errors[-1] < 2e-5)
    for j in range(3):
        fitted, last = _orders(errors[:, j], ns)
        assert 3.2 < fitted < 4.5 and 3.85 < last < 4.15, (j, fitted, last)


def test_both_bending_planes_axial_and_torsion_modes():
    """All four kinds of mode of a clamped-free beam, mixed in one spectrum."""
    ra, ei_y, ei_z, ea, gj, j = 2.0, 9.0, 1.0, 400.0, 30.0, 0.05
    member = kd.flexible.BeamMember.uniform("mixed", 1.0, mass_per_length=ra, EA=ea, GJ=gj,
                                            EI_y=ei_y, EI_z=ei_z, polar_inertia=j, n_elements=64,
                                            direction=(1.0, 2.0, -0.5), reference_vector=(0, 0, 1))
    w = lambda roots, ei: np.array(roots) ** 2 * np.sqrt(ei / ra)       # noqa: E731
    rod = (2 * np.arange(1, 4) - 1) * np.pi / 2
    expected = {"bending_xy": w(CLAMPED_FREE, ei_z), "bending_xz": w(CLAMPED_FREE, ei_y),
                "axial": rod * np.sqrt(ea / ra), "torsion": rod * np.sqrt(gj / j)}
    reduced = member.craig_bampton(max_frequency=np.sqrt(ea / ra) * 5 / (2 * np.pi))
    computed = {kind: [] for kind in expected}
    freqs = member.natural_frequencies(len(reduced.mode_names), supports={0: "all"})
    for name, f in zip(reduced.mode_names, freqs):
        computed[name.rsplit("_", 1)[0]].append(2 * np.pi * f)
    for kind, values in computed.items():
        k = min(len(values), 3)
        assert k >= 1, kind
        tol = 1e-6 if kind.startswith("bending") else 1e-3      # linear rod elements: h^2
        np.testing.assert_allclose(values[:k], expected[kind][:k], rtol=tol, err_msg=kind)


def test_axial_and_torsion_converge_at_h2():
    ra, ea, gj, j = 2.0, 400.0, 30.0, 0.05
    errors = []
    ns = [4, 8, 16, 32]
    for n in ns:
        member = kd.flexible.BeamMember.uniform("rod", 1.0, mass_per_length=ra, EA=ea, GJ=gj,
                                                EI_y=1e9, EI_z=1e9, polar_inertia=j, n_elements=n)
        f = 2 * np.pi * member.natural_frequencies(4, supports={})
        exact = np.sort(np.r_[np.pi * np.arange(1, 4) * np.sqrt(ea / ra),
                              np.pi * np.arange(1, 4) * np.sqrt(gj / j)])[:4]
        errors.append(f / exact - 1)
    errors = np.array(errors)
    for col in range(4):
        fitted, last = _orders(errors[:, col], ns)
        assert 1.9 < last < 2.1, (col, last)


def test_rotary_inertia_and_timoshenko_against_simply_supported_closed_forms():
    length, ra, ei, ri, kga = 2.0, 7.8, 4.0e3, 0.05, 1.0e5
    k = np.arange(1, 4) * np.pi / length
    supports = {0: "ux uy uz rx", -1: "uy uz"}
    props = dict(mass_per_length=ra, EA=1e12, GJ=1e12, EI_y=100 * ei, EI_z=ei,
                 rotary_inertia_y=ri, rotary_inertia_z=ri)
    # Rayleigh beam: omega^2 = EI k^4 / (rho A + rho I k^2); Hermite elements, h^4
    rayleigh = np.sqrt(ei * k ** 4 / (ra + ri * k ** 2))
    errors = [2 * np.pi * kd.flexible.BeamMember.uniform("r", length, n_elements=n, **props)
              .natural_frequencies(3, supports=supports) / rayleigh - 1 for n in (8, 16, 32)]
    assert np.max(np.abs(errors[-1])) < 1e-5
    assert _orders(np.array(errors)[:, 0], [8, 16, 32])[1] == pytest.approx(4, abs=0.1)
    # Timoshenko: det [[kGA k^2 - rA w^2, -kGA k], [-kGA k, EI k^2 + kGA - rI w^2]] = 0
    a = ra * ri
    b = -(ra * (ei * k ** 2 + kga) + ri * kga * k ** 2)
    c = kga * k ** 2 * (ei * k ** 2 + kga) - kga ** 2 * k ** 2
    timoshenko = np.sqrt((-b - np.sqrt(b * b - 4 * a * c)) / (2 * a))
    member = kd.flexible.BeamMember.uniform("t", length, n_elements=64, shear_stiffness_y=kga,
                                            shear_stiffness_z=100 * kga, **props)
    f = 2 * np.pi * member.natural_frequencies(3, supports=supports)
    np.testing.assert_allclose(f, timoshenko, rtol=5e-4)
    assert np.all(f < 0.97 * rayleigh)               # shear matters for this stubby beam


def test_member_along_any_direction_and_polyline():
    moderate = dict(EA=50.0, GJ=3.0, EI_y=7.0, polar_inertia=0.01)   # rotations mix them
    base = _uniform(8, **moderate)
    tilted = _uniform(8, direction=(1, -2, 2), reference_vector=(0, 0, 1), **moderate)
    f0 = base.natural_frequencies(6, supports={0: "all"})
    np.testing.assert_allclose(tilted.natural_frequencies(6, supports={0: "all"}), f0,
                               rtol=1e-10)
    axis = np.array([1, -2, 2]) / 3
    line = kd.flexible.BeamMember("poly", {"arc": [0, L], "mass_per_length": [RHO_A] * 2,
                                           "EA": [50.0] * 2, "GJ": [3.0] * 2, "EI_y": [7.0] * 2,
                                           "EI_z": [EI] * 2, "polar_inertia": [0.01] * 2},
                                  polyline=np.outer(np.linspace(0, L, 9), axis),
                                  reference_vector=(0, 0, 1))
    np.testing.assert_allclose(line.natural_frequencies(6, supports={0: "all"}), f0, rtol=1e-10)
    np.testing.assert_allclose(line.nodes, tilted.nodes, atol=1e-14)
    # first mode bends in the plane of the axis and the local y axis
    _, modes = tilted.natural_modes(1, supports={0: "all"})
    tip = modes[-6:-3, 0]
    y_local = np.array([0, 0, 1]) - axis[2] * axis
    assert abs(tip @ axis) < 1e-9 * np.linalg.norm(tip)
    assert abs(abs(tip @ y_local) / np.linalg.norm(y_local) - np.linalg.norm(tip)) < 1e-9


# ------------------------------------------------------ component mode synthesis
def _tapered(n=24, **options):
    stations = {"arc": [0.0, 0.9, 1.5, 2.0], "mass_per_length": [5.0, 3.5, 2.0, 1.0],
                "EA": [4e6, 3e6, 2e6, 1e6], "GJ": [4e3, 3e3, 2e3, 1e3],
                "EI_y": [9e3, 5e3, 2e3, 0.8e3], "EI_z": [3e3, 2e3, 1e3, 0.5e3],
                "rotary_inertia_y": [0.02, 0.015, 0.01, 0.005],
                "rotary_inertia_z": [0.01, 0.008, 0.006, 0.004]}
    return kd.flexible.BeamMember("blade", stations, n, **options)


def test_craig_bampton_upper_bounds_decrease_monotonically():
    member = _tapered()
    previous = None
    for k in range(0, 9):
        reduced = member.craig_bampton([12, -1], n_modes=k)
        assert reduced.n_modes == k + 12
        assert np.all(reduced.reduced_frequencies >= reduced.full_frequencies * (1 - 1e-10))
        if previous is not None:
            assert np.all(reduced.reduced_frequencies[:len(previous)]
                          <= previous * (1 + 1e-10))
            assert np.any(reduced.reduced_frequencies[:len(previous)] < previous * (1 - 1e-6))
        previous = reduced.reduced_frequencies
    # normal modes up to a cut-off; all of them: the reduction is exact
    cut = 2 * reduced.full_frequencies[6]
    reduced = member.craig_bampton([-1], max_frequency=cut)
    assert abs(reduced.frequency_comparison()[:4, 2]).max() < 1e-3
    assert reduced.n_modes - 6 == np.sum(
        member.natural_frequencies(30, supports={0: "all", -1: "all"}) <= cut)
    assert np.all(reduced.modes[:6] == 0)
    small = _tapered(6)
    complete = small.craig_bampton([3, -1], n_modes=42 - 6 - 12)
    assert abs(complete.frequency_comparison()[:, 2]).max() < 1e-9


def test_guyan_is_static_condensation():
    member = _tapered(12)
    interface = [6, -1]
    guyan = member.guyan(interface)
    K, M = member.stiffness_matrix, member.mass_matrix
    c = np.r_[36:42, 72:78]
    i = np.setdiff1d(np.arange(6, 78), c)
    Kcc = K[np.ix_(c, c)] - K[np.ix_(c, i)] @ np.linalg.solve(K[np.ix_(i, i)], K[np.ix_(i, c)])
    T = np.zeros((78, 12))
    T[c, np.arange(12)] = 1
    T[i] = -np.linalg.solve(K[np.ix_(i, i)], K[np.ix_(i, c)])
    np.testing.assert_allclose(guyan.modal_stiffness(), Kcc, rtol=1e-9, atol=1e-9 * abs(Kcc).max())
    np.testing.assert_allclose(guyan.modal_mass(), T.T @ M @ T, atol=1e-12)
    f = np.sqrt(1 / sla.eigh(T.T @ M @ T, Kcc, eigvals_only=True)[::-1]) / (2 * np.pi)
    np.testing.assert_allclose(guyan.reduced_frequencies, f, rtol=1e-9)
    zero = member.craig_bampton(interface, n_modes=0)
    np.testing.assert_allclose(zero.modes, guyan.modes)
    assert guyan.mode_names[:2] == ("constraint_6_ux", "constraint_6_uy")
    assert guyan.description.startswith("Guyan")


def test_free_free_basis_spans_the_free_modes():
    member = _uniform(24, polar_inertia=1e-3, EI_y=4 * EI)
    reduced = member.free_free(n_modes=5, reference_node=0)
    assert np.all(reduced.modes[:6] == 0)
    # a floating body: rigid motion of the frame at node 0 plus the modes
    from kanedyn.modeling.flexible._eigen import rigid_body_modes
    basis = np.hstack([rigid_body_modes(member.nodes, member.nodes[0]), reduced.modes])
    K, M = member.stiffness_matrix, member.mass_matrix
    mu = sla.eigh(basis.T @ M @ basis, basis.T @ K @ basis + basis.T @ M @ basis,
                  eigvals_only=True)[::-1]
    omega2 = 1 / mu - 1
    assert np.all(np.abs(omega2[:6]) < 1e-8)
    full = member.natural_frequencies(5, supports={})
    np.testing.assert_allclose(np.sqrt(omega2[6:]) / (2 * np.pi), full, rtol=1e-10)
    np.testing.assert_allclose(_beta(full[[0, 2]]), FREE_FREE[:2], rtol=1e-5)
    assert reduced.mode_names[:3] == ("bending_xy_1", "bending_xz_1", "bending_xy_2")
    # the same modes measured from the other end
    other = member.free_free(n_modes=5, reference_node=-1)
    assert np.all(other.modes[-6:] == 0)
    assert "free–free frequencies" in other.description


def test_degenerate_planes_are_separated_and_named():
    member = _uniform(16, EI_y=EI)                    # round section: EI_y = EI_z
    reduced = member.craig_bampton(n_modes=4)
    assert reduced.mode_names == ("bending_xy_1", "bending_xz_1", "bending_xy_2",
                                  "bending_xz_2")
    tip = reduced.modes[-6:-3]
    np.testing.assert_allclose(tip[:, 0], [0, 1, 0], atol=1e-9)   # scaled: tip deflection 1 m
    np.testing.assert_allclose(tip[:, 1], [0, 0, 1], atol=1e-9)
    K = reduced.modal_stiffness()
    assert abs(K - np.diag(np.diag(K))).max() < 1e-8 * abs(K).max()


def test_sparse_solver_agrees_with_dense():
    member = _tapered(40)
    dense = member.craig_bampton([20, -1], n_modes=6, solver="dense")
    sparse = member.craig_bampton([20, -1], n_modes=6, solver="sparse")
    np.testing.assert_allclose(sparse.modes, dense.modes, atol=1e-8)
    np.testing.assert_allclose(sparse.full_frequencies, dense.full_frequencies, rtol=1e-10)
    by_cut = member.craig_bampton([-1], max_frequency=dense.full_frequencies[5], solver="sparse")
    assert by_cut.n_modes - 6 == np.sum(
        member.natural_frequencies(12, supports={0: "all", -1: "all"})
        <= dense.full_frequencies[5])
    free_d = member.free_free(n_modes=4, solver="dense")
    free_s = member.free_free(n_modes=4, solver="sparse")
    np.testing.assert_allclose(free_s.modes, free_d.modes, atol=1e-8)
    stored = kd.flexible.BeamMember("blade", member.stations, 40, sparse=True)
    assert sp.issparse(stored.mass_matrix)
    np.testing.assert_allclose(stored.craig_bampton([20, -1], n_modes=6).modes, dense.modes,
                               atol=1e-8)


def test_report_lists_full_and_reduced_frequencies():
    reduced = _tapered(12).craig_bampton([-1], n_modes=3)
    text = reduced.report()
    assert "member 'blade'" in text and "Craig–Bampton" in text
    assert "full (Hz)" in text and "reduced (Hz)" in text
    rows = reduced.frequency_comparison()
    assert rows.shape == (9, 3)
    assert f"{rows[0, 0]:.6g}" in text
    assert "constraint_12_rz" in text and "bending_xy_1" in text
    kept = reduced.keep_modes("bending_xy")   # a subset: no full-model frequencies
    text = kept.report()
    assert "full (Hz)" not in text and "no full-model frequencies" in text
    rows = text.splitlines()[3:3 + kept.n_modes]
    assert [float(row.split()[1]) for row in rows] == pytest.approx(kept.reduced_frequencies,
                                                                    rel=1e-5)


# ------------------------------------------------------------- station tables
def _shooting_frequencies(arc, ei, ra, guesses):
    """Clamped-free frequencies (rad/s) of (EI w'')'' = omega^2 rho A w by shooting."""
    def tip(omega2):
        def rhs(x, y):
            e, r = np.interp(x, arc, ei), np.interp(x, arc, ra)
            return [y[1], y[2] / e, y[3], omega2 * r * y[0]]
        ends = []
        for y0 in ([0, 0, 1, 0], [0, 0, 0, 1]):
            y = np.array(y0, float)
            for a, b in zip(arc[:-1], arc[1:]):          # piecewise: kinks at stations
                y = solve_ivp(rhs, (a, b), y, rtol=1e-12, atol=1e-14, method="DOP853").y[:, -1]
            ends.append(y[2:])
        return np.linalg.det(np.array(ends).T)
    return np.array([np.sqrt(brentq(tip, (0.97 * g) ** 2, (1.03 * g) ** 2, xtol=1e-14))
                     for g in guesses])


@pytest.mark.slow
def test_tapered_cantilever_against_shooting_solution():
    st = _tapered(2).stations.columns
    # shooting has no rotary inertia: compare the member without it
    kept = {k: v for k, v in st.items()
            if not k.endswith("inertia") and not k.startswith("rotary")}
    plain = kd.flexible.BeamMember("plain", kept, 32)
    reduced = plain.craig_bampton(n_modes=6)
    omega = 2 * np.pi * reduced.full_frequencies[:6]
    names = reduced.mode_names
    for plane, ei in (("bending_xy", st["EI_z"]), ("bending_xz", st["EI_y"])):
        fe = np.array([w for w, n in zip(omega, names) if n.startswith(plane)])
        exact = _shooting_frequencies(st["arc"], ei, st["mass_per_length"], fe)
        np.testing.assert_allclose(fe, exact, rtol=5e-6, err_msg=plane)
        assert np.all(fe >= exact * (1 - 1e-12))


def test_station_interpolation_and_rigid_body_inertia():
    member = _tapered(7)                               # nodes fall between stations
    st = member.stations.columns
    props = member.properties_at([0.45, 1.2, 2.0])
    np.testing.assert_allclose(props["EI_z"], [2.5e3, 1.5e3, 0.5e3])
    np.testing.assert_allclose(props["mass_per_length"], [4.25, 2.75, 1.0])
    np.testing.assert_allclose(props["polar_inertia"], [0.0265, 0.0195, 0.009])
    # the consistent mass integrates the piecewise-linear mass exactly:
    # total mass, first and second moments about the root
    from kanedyn.modeling.flexible._eigen import rigid_body_modes
    R = rigid_body_modes(member.nodes, member.nodes[0])
    rigid = R.T @ member.mass_matrix @ R
    x = np.linspace(0, 2, 200001)
    ra = np.interp(x, st["arc"], st["mass_per_length"])
    mass = np.trapezoid(ra, x)
    first = np.trapezoid(ra * x, x)
    second = np.trapezoid(ra * x * x, x)
    assert rigid[0, 0] == pytest.approx(mass, rel=1e-9)
    assert rigid[1, 5] == pytest.approx(first, rel=1e-8)
    rot_z = np.trapezoid(np.interp(x, st["arc"], st["rotary_inertia_z"]), x)
    assert rigid[5, 5] == pytest.approx(second + rot_z, rel=1e-8)


def test_structural_twist_turns_the_principal_planes():
    """A constant twist a turns the section, not the beam's frequencies: the softer
    plane's first mode deflects along local y = cos a body y + sin a body z."""
    a = 0.4
    plain = _uniform(12, EI_y=4 * EI)
    columns = dict(plain.stations.columns, twist=np.full(2, a))
    twisted = kd.flexible.BeamMember("twisted", columns, n_elements=12)
    assert "structural twist" in twisted.summary
    f0, _ = plain.natural_modes(4, supports={0: "all"})
    f1, modes = twisted.natural_modes(4, supports={0: "all"})
    np.testing.assert_allclose(f1, f0, rtol=1e-10)
    tip = modes[-6:-3, 0] / np.linalg.norm(modes[-6:-3, 0])
    np.testing.assert_allclose(np.abs(tip), [0.0, np.cos(a), np.sin(a)], atol=1e-9)
    assert tip[1] * tip[2] > 0          # turned right-handed about the member's axis


def _pretwisted_ritz(length, mass_per_length, EI_y, EI_z, twist, n=14):
    """Lowest frequencies (Hz) of a clamped-free beam whose principal axes turn linearly
    by ``twist`` along it: Rayleigh-Ritz on the continuous beam, deflections v (body y)
    and w (body z) in the polynomials x^2 P_k, the curvature's principal components
    cos t v'' + sin t w'' (against EI_z) and -sin t v'' + cos t w'' (against EI_y)."""
    xg, wg = np.polynomial.legendre.leggauss(60)
    x, wq = (xg + 1) / 2 * length, wg * length / 2
    P, D = [], []
    for k in range(n):
        p = (np.polynomial.Legendre.basis(k, domain=[0, length])
             .convert(kind=np.polynomial.Polynomial) * np.polynomial.Polynomial([0, 0, 1]))
        P.append(p(x))
        D.append(p.deriv(2)(x))
    P, D = np.array(P), np.array(D)
    c, s = np.cos(twist * x / length), np.sin(twist * x / length)
    K = np.block([[(D * (EI_z * c * c + EI_y * s * s) * wq) @ D.T,
                   (D * ((EI_z - EI_y) * s * c) * wq) @ D.T],
                  [(D * ((EI_z - EI_y) * s * c) * wq) @ D.T,
                   (D * (EI_z * s * s + EI_y * c * c) * wq) @ D.T]])
    Mq = (P * mass_per_length * wq) @ P.T
    M = np.block([[Mq, 0 * Mq], [0 * Mq, Mq]])
    return np.sqrt(sla.eigh(K, M, eigvals_only=True)[:4]) / (2 * np.pi)


def test_pretwisted_cantilever_against_a_ritz_solution():
    """Uniform, principal stiffnesses 1:8, twisted by 90 deg from root to tip: the
    coupled flap-edge frequencies against the continuous beam's (each element takes its
    mean twist: the error falls as h^2)."""
    table = {"arc": [0.0, L], "mass_per_length": [RHO_A] * 2, "EA": [1e9] * 2,
             "GJ": [1e9] * 2, "EI_y": [EI] * 2, "EI_z": [8 * EI] * 2, "twist": [0.0, np.pi / 2]}
    exact = _pretwisted_ritz(L, RHO_A, EI, 8 * EI, np.pi / 2)
    errors = [kd.flexible.BeamMember("b", table, n_elements=n).natural_frequencies(
        4, supports={0: "all"}) / exact - 1 for n in (32, 64)]
    assert np.max(np.abs(errors[1])) < 2e-4
    np.testing.assert_allclose(np.log2(np.abs(errors[0] / errors[1])), 2.0, atol=0.05)


def test_tip_mass_against_frequency_equation():
    ratio = 0.7
    member = _uniform(32, node_masses=[kd.flexible.NodeMass(-1, ratio * RHO_A * L)])

    def equation(b):
        return (1 + np.cos(b) * np.cosh(b)
                + ratio * b * (np.cos(b) * np.sinh(b) - np.sin(b) * np.cosh(b)))
    grid = np.linspace(0.5, 12, 2000)
    values = equation(grid)
    roots = [brentq(equation, grid[i], grid[i + 1]) for i in range(len(grid) - 1)
             if values[i] * values[i + 1] < 0][:3]
    reduced = member.craig_bampton(n_modes=3)
    assert reduced.mode_names == ("bending_xy_1", "bending_xy_2", "bending_xy_3")
    np.testing.assert_allclose(_beta(reduced.full_frequencies[:3]), roots, rtol=2e-6)
    assert roots[0] < CLAMPED_FREE[0]
    # an offset mass couples translation and rotation: its inertia about the node
    offset = kd.flexible.NodeMass(0, 2.0, inertia=(0.1, 0.2, 0.3), offset=(0.0, 0.5, 0.0)).matrix()
    assert offset[5, 5] == pytest.approx(0.3 + 2.0 * 0.25)
    assert offset[0, 5] == pytest.approx(-2.0 * 0.5)  # u_x of the mass = u_x - 0.5 theta_z


# --------------------------------------------------- second-order displacement
def _exact_foreshortening(beta_l, length):
    """1/2 int_0^L w'^2 dx for the clamped-free mode normalized to w(L) = 1."""
    b = beta_l / length
    s = (np.cosh(beta_l) + np.cos(beta_l)) / (np.sinh(beta_l) + np.sin(beta_l))
    w = lambda x: np.cosh(b * x) - np.cos(b * x) - s * (np.sinh(b * x) - np.sin(b * x))  # noqa
    dw = lambda x: b * (np.sinh(b * x) + np.sin(b * x) - s * (np.cosh(b * x) - np.cos(b * x)))  # noqa
    return 0.5 * quad(lambda x: dw(x) ** 2, 0, length, epsabs=1e-14)[0] / w(length) ** 2


def test_second_order_tip_foreshortening_of_first_mode():
    axis = np.array([2.0, -1.0, 2.0]) / 3
    member = _uniform(32, direction=axis)
    reduced = member.craig_bampton(n_modes=2)
    assert reduced.mode_names[0] == "bending_xy_1"
    exact = _exact_foreshortening(CLAMPED_FREE[0], L)
    G = reduced.second_order
    assert G.shape == (33, 3, 2, 2)
    np.testing.assert_allclose(0.5 * G[-1, :, 0, 0], -exact * axis, rtol=1e-6)
    np.testing.assert_allclose(reduced.node_modes(32)[0][:, 0] @ axis, 0, atol=1e-12)
    assert np.all(G[0] == 0)
    assert np.allclose(G, G.transpose(0, 1, 3, 2))
    # decreasing foreshortening toward the root, along the axis only
    along = np.einsum("kx,x->k", G[:, :, 0, 0], axis)
    assert np.all(np.diff(along) < 0)
    np.testing.assert_allclose(G[:, :, 0, 0], np.outer(along, axis), atol=1e-14)
    # clamped at the other end, node 0 moves toward the last node: along +axis
    flipped = member.craig_bampton(n_modes=1, reference_node=-1)
    np.testing.assert_allclose(0.5 * flipped.second_order[0, :, 0, 0], exact * axis, rtol=1e-6)
    # second mode: the exact shape with beta_2
    assert reduced.mode_names[1] == "bending_xy_2"
    np.testing.assert_allclose(0.5 * reduced.second_order[-1, :, 1, 1] @ axis,
                               -_exact_foreshortening(CLAMPED_FREE[1], L), rtol=1e-5)


WRIGHT_FLAP = {0: (3.516, 22.035, 61.697), 2: (4.137, 22.615, 62.273), 4: (5.585, 24.273, 63.967),
               6: (7.360, 26.809, 66.684), 8: (9.257, 29.995, 70.293),
               10: (11.202, 33.640, 74.649), 12: (13.170, 37.603, 79.615)}


def _rotating_flap(n_elements):
    """Flap frequencies (rad/s) of a spinning cantilever from G, shape (7 speeds, 3 modes).

    Spinning about body z, the beam along x carries the centrifugal loads
    f = Omega^2 M r (r: node positions); their work through the foreshortening
    gives the stiffness S = -sum_k f_k . G_k, and flap (along z) feels no
    centrifugal softening.
    """
    member = kd.flexible.BeamMember.uniform("blade", 31.623, mass_per_length=100.0, EA=1e12, GJ=1e5,
                                            EI_y=1e8, EI_z=1e9, polar_inertia=1e-3,
                                            n_elements=n_elements)
    reduced = member.craig_bampton(max_frequency=200.0)
    flap = [j for j, name in enumerate(reduced.mode_names) if name.startswith("bending_xz")]
    Phi = reduced.modes[:, flap]
    G = reduced.second_order[:, :, flap][:, :, :, flap]
    r = np.zeros(len(Phi))
    r[0::6] = reduced.nodes[:, 0]
    f = (member.mass_matrix @ r).reshape(-1, 6)[:, :3]
    S = -np.einsum("kx,kxij->ij", f, G)
    K, M = Phi.T @ member.stiffness_matrix @ Phi, Phi.T @ member.mass_matrix @ Phi
    return np.array([np.sqrt(sla.eigh(K + omega ** 2 * S, M, eigvals_only=True)[:3])
                     for omega in WRIGHT_FLAP])


@pytest.mark.slow
def test_second_order_gives_centrifugal_stiffening_of_rotating_cantilever():
    """Wright, Smith, Thresher & Wang (1982), tabulated in Bir (2009): flap, Omega 0..12."""
    coarse, fine, finer = (_rotating_flap(n) for n in (20, 40, 80))
    table = np.array(list(WRIGHT_FLAP.values()))
    assert np.abs(fine / table - 1).max() < 3e-4
    assert np.abs(finer / table - 1).max() < 1e-4
    # the stiffening converges as h^2 (tension piecewise constant between nodes)
    order = np.log2((fine - coarse)[-1] / (finer - fine)[-1])
    assert np.all((order > 1.8) & (order < 2.2)), order


def test_second_order_of_constraint_modes_and_matrix_members():
    member = _uniform(8)
    reduced = member.craig_bampton([-1], n_modes=1)
    G = reduced.second_order
    # a unit tip translation uy bends the beam statically: w(x) = x^2 (3L - x) / (2 L^3)
    j = reduced.mode_names.index("constraint_8_uy")
    exact = 0.5 * quad(lambda x: (3 * x * (2 * L - x) / (2 * L ** 3)) ** 2, 0, L)[0]
    assert 0.5 * G[-1, 0, j, j] == pytest.approx(-exact, rel=1e-12)   # cubic: exact
    k = reduced.mode_names.index("constraint_8_ux")
    assert np.all(G[:, :, k, :] == 0)                  # axial stretch does not foreshorten
    imported = kd.flexible.FEMember.from_matrices("imported", member.mass_matrix,
                                                  member.stiffness_matrix, member.nodes)
    assert imported.craig_bampton([-1], n_modes=1).second_order is None


# ---------------------------------------------------------------- from_matrices
def test_from_matrices_dense_sparse_and_matrix_market(tmp_path):
    member = _tapered(10)
    direct = member.craig_bampton([5, -1], n_modes=4)
    M, K = member.mass_matrix, member.stiffness_matrix
    scipy.io.mmwrite(tmp_path / "m.mtx", sp.coo_array(M), symmetry="symmetric")
    scipy.io.mmwrite(tmp_path / "k.mtx", sp.coo_array(K), symmetry="symmetric")
    sources = {"dense": (M, K), "sparse": (sp.csr_array(M), sp.csc_matrix(K)),
               "file": (tmp_path / "m.mtx", str(tmp_path / "k.mtx"))}
    for label, (m, k) in sources.items():
        imported = kd.flexible.FEMember.from_matrices(label, m, k, member.nodes)
        reduced = imported.craig_bampton([5, -1], n_modes=4)
        np.testing.assert_allclose(reduced.modes, direct.modes, atol=1e-10, err_msg=label)
        np.testing.assert_allclose(reduced.full_frequencies, direct.full_frequencies,
                                   rtol=1e-10)
        np.testing.assert_allclose(reduced.reduced_frequencies, direct.reduced_frequencies,
                                   rtol=1e-10)
        assert reduced.mode_names[:4] == ("normal_1", "normal_2", "normal_3", "normal_4")
        assert reduced.mode_names[4:] == direct.mode_names[4:]
        assert reduced.second_order is None
        np.testing.assert_allclose(imported.free_free(n_modes=3).modes,
                                   member.free_free(n_modes=3).modes, atol=1e-10)


def test_lumped_mass_matrix_without_rotary_inertia():
    """A lumped (diagonal) mass matrix with massless rotations: infinite modes never appear."""
    member = _uniform(40, polar_inertia=0)
    lumped = np.zeros(member.mass_matrix.shape)
    for k in range(41):
        share = RHO_A * L / 40 * (0.5 if k in (0, 40) else 1)
        lumped[6 * k:6 * k + 3, 6 * k:6 * k + 3] = share * np.eye(3)
    imported = kd.flexible.FEMember.from_matrices("lumped", lumped, member.stiffness_matrix,
                                                  member.nodes)
    f = imported.natural_frequencies(3, supports={0: "all"})
    np.testing.assert_allclose(_beta(f), CLAMPED_FREE, rtol=2e-3)
    with pytest.raises(ModelError, match="'lumped'.*only 120 with a finite frequency"):
        imported.craig_bampton(n_modes=121)


# ------------------------------------------------------------------ bad input
def _stations(**changes):
    table = {"arc": [0.0, 1.0, 2.0], "mass_per_length": [2.0, 2.0, 2.0], "EA": [1e6] * 3,
             "GJ": [1e3] * 3, "EI_y": [1e3] * 3, "EI_z": [1e3] * 3}
    table.update(changes)
    return table


@pytest.mark.parametrize("changes, message", [
    (dict(arc=[0.0, 2.0, 1.0]), r"'tower': station 2 \(arc 1 m\) is not after station 1"),
    (dict(EI_y=[1e3, -5.0, 1e3]), r"'tower': station 1 \(arc 1 m\): EI_y = -5 N m\^2 must be"),
    (dict(mass_per_length=[2.0, 2.0, -1.0]), r"'tower': station 2 .*mass_per_length = -1.*neg"),
    (dict(EA=[1e6, np.nan, 1e6]), r"'tower': station 1 \(arc 1 m\) has no value for 'EA'"),
    (dict(GJ=None), r"'tower': the station table has no column 'GJ'"),
    (dict(EI_x=[1.0] * 3), r"'tower': unknown station column\(s\) \['EI_x'\]"),
    (dict(EA=[1e6, 1e6]), r"'tower': station column 'EA' has 2 values, 'arc' has 3"),
])
def test_bad_station_tables(changes, message):
    table = _stations(**changes)
    table = {k: v for k, v in table.items() if v is not None}
    with pytest.raises(ModelError, match=message):
        kd.flexible.BeamMember("tower", table, 4)


def test_bad_matrices():
    member = _uniform(4)
    M, K, nodes = member.mass_matrix.copy(), member.stiffness_matrix.copy(), member.nodes
    bad = M.copy()
    bad[3, 10] += 1e-3
    with pytest.raises(ModelError, match=r"'imp': the mass matrix is not symmetric: entries "
                                         r"\(3, 10\) and \(10, 3\) differ by 0.001"):
        kd.flexible.FEMember.from_matrices("imp", bad, K, nodes)
    indefinite = K - 1e-3 * np.abs(K).max() * np.eye(30)
    with pytest.raises(ModelError, match=r"'imp': the stiffness matrix is not positive "
                                         r"semidefinite: its smallest eigenvalue is -"):
        kd.flexible.FEMember.from_matrices("imp", M, indefinite, nodes)
    with pytest.raises(ModelError, match=r"'imp': the mass matrix is not positive semidef"):
        kd.flexible.FEMember.from_matrices("imp", sp.csr_array(M - 0.1 * np.eye(30)), K, nodes)
    with pytest.raises(ModelError, match=r"'imp': the mass matrix is 30 x 30 but 6 nodes have "
                                         r"36 degrees of freedom"):
        kd.flexible.FEMember.from_matrices("imp", M, K, np.vstack([nodes, [[9, 9, 9]]]))
    with pytest.raises(ModelError, match=r"'imp': the stiffness matrix must be square"):
        kd.flexible.FEMember.from_matrices("imp", M, K[:, :-1], nodes)
    with pytest.raises(ModelError, match=r"'imp': cannot read the mass matrix from 'nope.mtx'"):
        kd.flexible.FEMember.from_matrices("imp", "nope.mtx", K, nodes)
    with pytest.raises(ModelError, match=r"'imp': .*rigid-body motion free of strain"):
        kd.flexible.FEMember.from_matrices("imp", M, K, nodes * 2).free_free(n_modes=2)


def test_large_matrices_checked_by_inertia(monkeypatch):
    """Beyond the dense limit, semidefiniteness comes from the pivots of a factorization."""
    from kanedyn.modeling.flexible import _matrices
    monkeypatch.setattr(_matrices, "_DENSE_CHECK", 10)
    member = _uniform(6)
    M, K, nodes = member.mass_matrix, member.stiffness_matrix, member.nodes
    kd.flexible.FEMember.from_matrices("big", sp.csr_array(M), K, nodes)      # singular K passes
    lowest = np.linalg.eigvalsh(M)[0]
    shifted = M - (lowest + 0.01) * np.eye(42)                      # smallest eigenvalue -0.01
    with pytest.raises(ModelError, match=r"'big': the mass matrix is not positive semidefinite:"
                                         r" its smallest eigenvalue is about -0.0(099|1)[ 0-9]"):
        kd.flexible.FEMember.from_matrices("big", shifted, K, nodes)


def test_bad_reduction_options():
    member = _uniform(4)
    with pytest.raises(ModelError, match=r"'beam': interface node 99 does not exist \(nodes "
                                         r"0..4\)"):
        member.craig_bampton([99], n_modes=1)
    with pytest.raises(ModelError, match=r"'beam': reference node -9 does not exist"):
        member.craig_bampton(n_modes=1, reference_node=-9)
    with pytest.raises(ModelError, match=r"'beam': 50 fixed-interface normal modes requested "
                                         r"but the model has only 24 degrees of freedom"):
        member.craig_bampton(n_modes=50)
    with pytest.raises(ModelError, match=r"'beam': 30 free–free modes requested"):
        member.free_free(n_modes=30)
    with pytest.raises(OptionError, match=r"'beam': Craig–Bampton needs exactly one of n_modes"):
        member.craig_bampton(n_modes=2, max_frequency=10.0)
    with pytest.raises(OptionError, match=r"'beam': Craig–Bampton needs exactly one of n_modes"):
        member.craig_bampton()
    with pytest.raises(OptionError, match=r"'beam': n_modes must be a non-negative integer"):
        member.craig_bampton(n_modes=2.5)
    with pytest.raises(ModelError, match=r"'beam': the reduction has no modes"):
        member.guyan([0])
    with pytest.raises(ModelError, match=r"'beam': interface nodes \(4, -1\) name a node twice"):
        member.guyan([4, -1])
    with pytest.raises(OptionError, match=r"'beam': unknown reduction method 'modal'"):
        member.reduce("modal", n_modes=2)
    with pytest.raises(ModelError, match=r"'beam': .*carries no mass"):
        _uniform(4, polar_inertia=0).free_free(n_modes=2)
    with pytest.raises(ModelError, match=r"'beam': no node at arc 0.7 m"):
        member.node_at(0.7)
    with pytest.raises(ModelError, match=r"member 'beam': the node mass at node -1 has mass -2"):
        _uniform(4, node_masses=[kd.flexible.NodeMass(-1, -2.0)])
    with pytest.raises(OptionError, match=r"'beam': give exactly one of n_elements, node_arcs"):
        kd.flexible.BeamMember("beam", _stations(), 4, node_arcs=[0, 1, 2])
    reduced = member.reduce("guyan", interface_nodes=[-1])
    assert reduced.n_modes == 6 and member.node_at(0.75) == 2


def test_docs_example_runs_and_prints_its_report():
    from pathlib import Path
    import re
    text = (Path(__file__).resolve().parents[1] / "docs" / "flexible.md").read_text()
    block = re.findall(r"```python\n(.*?)```", text, re.S)[0]
    namespace = {}
    exec(compile(block, "docs/flexible.md", "exec"), namespace)
    report = namespace["reduced"].report()
    printed = re.findall(r"```\n(member 'blade'.*?)```", text, re.S)[0]
    for line in printed.splitlines():
        if line.strip() and "..." not in line:
            assert line in report.splitlines(), line

