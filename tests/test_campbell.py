"""Campbell diagrams (kd.campbell): the rotating cantilever against Wright, Smith,
Thresher & Wang (1982) (REFERENCES.md); the multiblade transformation on a lag-hinged
rotor against the closed form on a fixed hub and against Floquet multipliers on a
flexible support; the OC3 spar's modes against its rigid-body frequencies and the
drivetrain's closed form; bad input named."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import linear_sum_assignment

import kanedyn as kd
from kanedyn._errors import ModelError
from kanedyn.analysis._mbc import multiblade_basis

#: Wright et al. (1982), flapwise frequencies (rad/s) at Omega = 0, 2, ..., 12 rad/s
WRIGHT_FLAP = np.array([(3.516, 22.035, 61.697), (4.137, 22.615, 62.273),
                        (5.585, 24.273, 63.967), (7.360, 26.809, 66.684),
                        (9.257, 29.995, 70.293), (11.202, 33.640, 74.649),
                        (13.170, 37.603, 79.615)])
BLADES = [["zeta_1"], ["zeta_2"], ["zeta_3"]]


@pytest.fixture(scope="module")
def lag_rotor():
    definition = kd.models.lag_rotor()
    return definition, definition.derive()


def test_rotating_cantilever_campbell_curve_matches_wright_table():
    """The first three flap frequencies over Omega = 0..12 rad/s: the steady motion with
    the hub speed held, the exact linearization, the azimuth removed (single blade: no
    multiblade transformation, frequencies in the rotating frame).  20 elements and 5
    kept modes: at most 0.06, 0.13 and 0.09 % above the table (measured, at 12 rad/s; the
    FE stiffening converges as h^2, tests/test_fe_members.py), so 0.2 %."""
    model = kd.models.rotating_cantilever(n_elements=20, n_modes=5).numeric(backend="c")
    diagram = kd.campbell(model, np.arange(0.0, 13.0, 2.0), np.zeros(model.n_states),
                          speed="Omega", azimuth="psi", n_modes=3)
    assert diagram.converged.all() and diagram.labels == ("eta_blade_1", "eta_blade_2",
                                                          "eta_blade_3")
    error = diagram.frequencies * 2 * np.pi / WRIGHT_FLAP - 1
    assert np.abs(error).max() < 2e-3, np.round(error, 5)
    assert np.abs(error[0]).max() < 5e-5          # at rest: the table's rounding only
    assert diagram.mac.min() > 0.99 and np.all(diagram.periodicity < 1e-12)
    assert np.allclose(diagram.damping_ratios, 0.0, atol=1e-9)


def test_multiblade_basis_derivatives_and_orthogonality():
    """T' and T'' against differences; T^T T = diag(N, N/2, ..., N) for 3, 4 and 5 blades."""
    for n in (3, 4, 5):
        T, dT, ddT = multiblade_basis(n, 0.7)
        h = 1e-6
        Tp, Tm = multiblade_basis(n, 0.7 + h)[0], multiblade_basis(n, 0.7 - h)[0]
        assert np.allclose((Tp - Tm) / (2 * h), dT, atol=1e-8)
        assert np.allclose((Tp - 2 * T + Tm) / h ** 2, ddT, atol=1e-3)
        gram = T.T @ T
        expected = np.full(n, n / 2)
        expected[0] = n
        if n % 2 == 0:
            expected[-1] = n
        assert np.allclose(gram, np.diag(expected), atol=1e-12)


def test_lag_rotor_on_a_fixed_hub_splits_into_collective_and_whirl(lag_rotor):
    """Hub springs 1e11 N/m (a fixed hub) and the rotor driven at constant speed: the lag
    frequency in the rotating frame is w^2 = k/(m l^2) + Omega^2 e/l; in multiblade
    coordinates the collective stays at w, the cyclic modes are the forward whirl at
    w + Omega and the backward whirl at w - Omega (non-rotating frame)."""
    definition, eom = lag_rotor
    model = definition.numeric(eom, constants={definition.symbols["k_h"]: 1e11})
    speeds = np.linspace(0.0, 4.0, 9)
    diagram = kd.campbell(model, speeds, np.zeros(model.n_states), speed="Omega",
                          azimuth="psi", rotating=BLADES, constant_speed=True, n_modes=3)
    omega = np.sqrt(640.0 / (10.0 * 2.0 ** 2) + speeds ** 2 * 0.5 / 2.0)
    rad = diagram.frequencies * 2 * np.pi
    # the hub's residual flexibility (53,000 rad/s) shifts the cyclic modes by ~1e-8
    np.testing.assert_allclose(rad[:, diagram.mode("zeta_1 collective")], omega, rtol=1e-9)
    np.testing.assert_allclose(rad[:, diagram.mode("zeta_1 forward")], omega + speeds,
                               rtol=1e-7)
    np.testing.assert_allclose(rad[:, diagram.mode("zeta_1 backward")], omega - speeds,
                               rtol=1e-7)
    assert diagram.coordinate_names[2:5] == ("zeta_1 collective", "zeta_1 cos", "zeta_1 sin")


@pytest.mark.parametrize("omega", [1.5, 3.0])
def test_lag_rotor_on_springs_against_floquet_multipliers(lag_rotor, omega):
    """With the hub on its springs the rotating-frame system is periodic; its monodromy
    matrix over one revolution (integrating x' = A(Omega t) x, no multiblade
    coordinates) has the multipliers exp(lambda T) of the multiblade eigenvalues, and
    one multiplier 1 (the free rotor's speed)."""
    definition, eom = lag_rotor
    model = definition.numeric(eom)
    diagram = kd.campbell(model, [omega], np.zeros(model.n_states), speed="Omega",
                          azimuth="psi", rotating=BLADES)
    assert diagram.frequencies.shape == (1, 5) and diagram.periodicity[0] < 1e-12
    names = model.state_names
    psi, speed = names.index("psi"), names.index("Omega")
    keep = [i for i in range(model.n_states) if i != psi]

    def state_matrix(angle):
        y = np.zeros(model.n_states)
        y[speed], y[psi] = omega, angle
        return model.linearize(y)[0][np.ix_(keep, keep)]

    n, period = len(keep), 2 * math.pi / omega
    run = solve_ivp(lambda t, x: (state_matrix(omega * t) @ x.reshape(n, n)).ravel(),
                    (0.0, period), np.eye(n).ravel(), method="DOP853", rtol=1e-11, atol=1e-12)
    multipliers = np.linalg.eigvals(run.y[:, -1].reshape(n, n))
    lam = diagram.eigenvalues[0]
    expected = np.exp(np.concatenate([lam, lam.conj(), [0.0]]) * period)
    distance = np.abs(expected[:, None] - multipliers[None, :])
    rows, cols = linear_sum_assignment(distance)
    assert distance[rows, cols].max() < 1e-7
    # in the blades' own coordinates the state matrix is periodic: the result says so
    plain = kd.campbell(model, [omega], np.zeros(model.n_states), speed="Omega",
                        azimuth="psi")
    assert plain.periodicity[0] > 1e-3


def test_plot_and_bad_input(lag_rotor, tmp_path):
    definition, eom = lag_rotor
    model = definition.numeric(eom)
    y0 = np.zeros(model.n_states)
    diagram = kd.campbell(model, [0.0, 1.0, 2.0], y0, speed="Omega", azimuth="psi",
                          rotating=BLADES)
    fig = diagram.plot(tmp_path / "campbell.png")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "rotor speed [rpm]" and ax.get_ylabel() == "frequency [Hz]"
    assert {t.get_text() for t in ax.texts} >= {"1P", "3P"}
    assert (tmp_path / "campbell.png").stat().st_size > 0
    with pytest.raises(kd.OptionError, match="speed_unit"):
        diagram.plot(speed_unit="Hz")
    with pytest.raises(KeyError, match="no mode labelled 'flap'"):
        diagram.mode("flap")
    bad = [(dict(speed="Omegaa"), "Omegaa"), (dict(speed="psi"), "not an independent speed"),
           (dict(azimuth="w_1"), "not an independent coordinate"),
           (dict(rotating=[["zeta_1"], ["zeta_2"]]), "2 blade"),
           (dict(rotating=[["zeta_1"], ["zeta_2"], ["zeta_3", "x"]]), "same"),
           (dict(rotating=[["zeta_1"], ["zeta_2"], ["psi"]]), "psi"),
           (dict(rotating=[["zeta_1"], ["zeta_2"], ["zeta_2"]]), "twice")]
    for change, message in bad:
        kwargs = dict(speed="Omega", azimuth="psi") | change
        with pytest.raises(ModelError, match=message):
            kd.campbell(model, [1.0], y0, **kwargs)
    with pytest.raises(ModelError, match="finite"):
        kd.campbell(model, [0.0, np.nan], y0, speed="Omega", azimuth="psi")


@pytest.mark.slow
def test_oc3_spar_campbell_against_rigid_body_and_drivetrain_frequencies():
    """oc3-spar, spinning rotor (rigid blades, no wind, controller off), flexible
    drivetrain, two tower modes, 0 to 12.1 rpm.  At rest the platform modes are those of
    the model card's 6 x 6 problem (surge/sway 0.0081, heave 0.0324, roll/pitch 0.0343,
    yaw 0.121 Hz; published full-system pitch about 0.034 Hz), the coupled tower modes
    0.484 / 0.493 Hz (tests/test_oc3_spar.py), the drivetrain torsion the closed form
    sqrt(k (1/I_rotor + 1/(97^2 J_g))) / 2 pi = 2.223 Hz (rigid blades: the published
    5-MW drivetrain mode, 0.62 Hz, includes the blades' edgewise flexibility).  The
    rotor's gyroscopic coupling changes them by less than 0.5 % up to rated speed."""
    from kanedyn.models import oc3_spar
    d = oc3_spar(tower_modes=2, rotor="spinning", controller="off", drivetrain="flexible")
    m = d.numeric(backend="c")
    rpm = np.linspace(0.0, 12.1, 12)
    diagram = kd.campbell(m, rpm * np.pi / 30, d.initial(m), speed="rotor_speed",
                          azimuth="azimuth")
    assert diagram.converged.all() and np.all(diagram.periodicity < 1e-9)
    f0 = np.sort(diagram.frequencies[0])
    np.testing.assert_allclose(f0[:6], [0.0081, 0.0081, 0.0324, 0.0343, 0.0343, 0.121],
                               rtol=0.015)
    assert f0[3] == pytest.approx(0.034, abs=0.001)
    k, I_r, J_g = 867_637_000.0, 38_759_227.0, 534.116
    closed = math.sqrt(k * (1 / I_r + 1 / (97 ** 2 * J_g))) / (2 * math.pi)
    # 0.33 % above it measured: the nacelle turns with the reaction (the spar rolls; the
    # same 0.3 % as tests/test_oc3_rotor.py), and the shaft damping (5 %)
    np.testing.assert_allclose(diagram.frequencies[:, diagram.mode("shaft_twist")], closed,
                               rtol=5e-3)
    assert np.abs(diagram.frequencies / diagram.frequencies[0] - 1).max() < 5e-3
    assert diagram.mac.min() > 0.9
