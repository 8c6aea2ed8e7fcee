"""Frequency responses of linearized models and the tuning of a TMD / TMDI.

The models are built as a user would: masses on a line with kd.kane,
kd.SpringDamper for the support and the damper, kd.Inerter for the TMDI, a
specified force F(t) on the primary.  References: Den Hartog's fixed-point
tuning (REFERENCES.md); the exact H-infinity optimum of Nishihara & Asami,
J. Vib. Acoust. 124 (2002) 576-582, doi:10.1115/1.1500335; the H2 optimum for
force excitation (Warburton 1982, Asami et al. 2002).
"""

import math

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn import OptionError
from kanedyn.analysis import h2_norm, response_peaks


def primary_with_damper(inerter):
    """Primary m on a spring k, damper mass md on (kd, cd), force F on the primary.

    ``inerter``: an inerter b from the damper mass to a fixed point (a TMDI).
    """
    x, xd, u, ud = me.dynamicsymbols("x xd u ud")
    F = me.dynamicsymbols("F")
    m, k, md, kd_, cd, b = sm.symbols("m k md kd cd b", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", 3 * N.x)  # the inerter's ground terminal
    G.set_vel(N, 0)
    P = O.locatenew("P", (1 + x) * N.x)
    P.set_vel(N, u * N.x)
    D = O.locatenew("D", (2 + xd) * N.x)
    D.set_vel(N, ud * N.x)
    bodies = [me.Particle("primary", P, m), me.Particle("damper", D, md)]
    if inerter:
        bodies.append(kd.Inerter("inerter", D, G, b, N))
    loads = (kd.SpringDamper("support", O, P, k, 0, 1, N).to_loads()
             + kd.SpringDamper("tmd", P, D, kd_, cd, 1, N).to_loads() + [(P, F * N.x)])
    eom = kd.kane(frame=N, q_ind=[x, xd], u_ind=[u, ud],
                  kd_eqs=[x.diff() - u, xd.diff() - ud], bodies=bodies, loads=loads)
    values = {"m": 1.0, "k": 1.0, "md": 0.05, "kd": 0.05, "cd": 0.01}
    if inerter:
        values["b"] = 0.0
    return eom.numeric(constants=values, specified={"F": lambda t, y: 0.0})


@pytest.fixture(scope="module")
def tmdi_model():
    return primary_with_damper(True)


@pytest.fixture(scope="module")
def tmd_model():
    return primary_with_damper(False)


def tune(model, mu, beta=0.0, **options):
    extra = {"inertance": "b", "inertance_ratio": beta} if beta else {}
    return kd.tune_damper(model, np.zeros(4), input="F", output="x", primary_frequency=1.0,
                          primary_mass=1.0, mass_ratio=mu, damper_mass="md", stiffness="kd",
                          damping="cd", **extra, **options)


def nishihara_asami(mu):
    """Exact H-infinity optimum (f, zeta), undamped primary, force excitation."""
    r = math.sqrt(4 + 3 * mu)
    f = 2 / (1 + mu) * math.sqrt(2 * (16 + 23 * mu + 9 * mu ** 2 + 2 * (2 + mu) * r)
                                 / (3 * (64 + 80 * mu + 27 * mu ** 2)))
    zeta = math.sqrt((8 + 9 * mu - 4 * r) / (1 + mu)) / 4
    return f, zeta


def test_den_hartog_formula():
    f, zeta = kd.den_hartog(0.05)
    assert f == pytest.approx(1 / 1.05, rel=1e-15)
    assert zeta == pytest.approx(math.sqrt(0.15 / (8 * 1.05 ** 3)), rel=1e-15)
    with pytest.raises(OptionError, match="mass_ratio"):
        kd.den_hartog(-0.1)


def test_hinf_optimum_recovers_den_hartog(tmd_model):
    """H-infinity tuning of a TMD on an undamped primary, mu = 0.05.

    Compared: f with Den Hartog's 1/(1+mu) to 1e-3 (the exact optimum differs by
    9e-6); the two peaks equal (the min-max optimum); the peak no lower than the
    fixed points' height sqrt(1 + 2/mu) (x_st = F/k = 1) and within 0.1 % of it;
    f and zeta with the exact closed form of Nishihara & Asami to 1e-6.  Den
    Hartog's zeta (the average of the two fixed points' conditions) is below the
    exact optimum by 6.7e-3 at mu = 0.05: not within 1e-3 there (see the mu = 0.01
    case below, where it is).
    """
    mu = 0.05
    res = tune(tmd_model, mu)
    assert res.success, res.message
    f_dh, z_dh = kd.den_hartog(mu)
    assert res.start == (f_dh, z_dh)
    assert abs(res.frequency_ratio - f_dh) < 1e-3
    f_ex, z_ex = nishihara_asami(mu)
    assert res.frequency_ratio == pytest.approx(f_ex, abs=1e-6)
    assert res.damping_ratio == pytest.approx(z_ex, abs=1e-6)
    assert 6e-3 < res.damping_ratio - z_dh < 7e-3
    fixed_point = math.sqrt(1 + 2 / mu)
    assert fixed_point <= res.peak < fixed_point * (1 + 1e-3)
    # equal peaks at the optimum
    A, B, _ = res.model.linearize(np.zeros(4))
    peaks = response_peaks(A, B[:, 0], [1, 0, 0, 0], np.geomspace(0.2, 5, 4001))
    assert peaks.shape[0] == 2
    assert peaks[1, 1] == pytest.approx(peaks[0, 1], rel=1e-6)
    # the undamped primary alone has an unbounded peak; Den Hartog's start is worse
    assert res.peak_without == math.inf and res.peak_reduction == 1.0
    assert res.peak_start > res.peak and 0 < res.peak_reduction_start < 0.01
    # the constants follow from (f, zeta): kd = md (f wp)^2, cd = 2 zeta md f wp
    assert res.constants["kd"] == pytest.approx(mu * res.frequency_ratio ** 2, rel=1e-14)
    assert res.constants["cd"] == pytest.approx(
        2 * res.damping_ratio * mu * res.frequency_ratio, rel=1e-14)


def test_hinf_small_mass_ratio_den_hartog_within_1e3(tmd_model):
    """At mu = 0.01 both of Den Hartog's ratios are within 1e-3 of the optimum."""
    res = tune(tmd_model, 0.01)
    f_dh, z_dh = kd.den_hartog(0.01)
    assert abs(res.frequency_ratio - f_dh) < 1e-3 and abs(res.damping_ratio - z_dh) < 1e-3
    f_ex, z_ex = nishihara_asami(0.01)
    assert res.frequency_ratio == pytest.approx(f_ex, abs=1e-6)
    assert res.damping_ratio == pytest.approx(z_ex, abs=1e-6)


def test_h2_optimum_closed_form(tmd_model):
    """H2 (white-noise force, displacement): f = sqrt(1 + mu/2)/(1 + mu),
    zeta = sqrt(mu (4 + 3 mu) / (8 (1 + mu)(2 + mu)))."""
    mu = 0.05
    res = tune(tmd_model, mu, criterion="h2")
    assert res.success and res.criterion == "h2"
    assert res.frequency_ratio == pytest.approx(math.sqrt(1 + mu / 2) / (1 + mu), abs=1e-6)
    assert res.damping_ratio == pytest.approx(
        math.sqrt(mu * (4 + 3 * mu) / (8 * (1 + mu) * (2 + mu))), abs=1e-6)
    assert res.h2 <= res.h2_start


def test_grounded_tmdi_tunes_as_tmd_of_mass_md_plus_b(tmd_model, tmdi_model):
    """A TMDI (mu = 0.03, beta = 0.02, inerter grounded) = a TMD with mu = 0.05."""
    tmdi = tune(tmdi_model, 0.03, beta=0.02)
    tmd = tune(tmd_model, 0.05)
    assert tmdi.constants["b"] == pytest.approx(0.02) and tmdi.constants["md"] == 0.03
    assert tmdi.frequency_ratio == pytest.approx(tmd.frequency_ratio, abs=1e-8)
    assert tmdi.damping_ratio == pytest.approx(tmd.damping_ratio, abs=1e-8)
    assert tmdi.peak == pytest.approx(tmd.peak, rel=1e-9)
    assert tmdi.h2 == pytest.approx(tmd.h2, rel=1e-9)
    # the same response everywhere, at the optimum
    w = np.geomspace(0.3, 3, 50)
    a = kd.model_frequency_response(tmdi.model, np.zeros(4), w, "F", "x").response
    b = kd.model_frequency_response(tmd.model, np.zeros(4), w, "F", "x").response
    assert np.max(np.abs(a - b) / np.abs(b)) < 1e-8


def test_model_frequency_response_equals_closed_form(tmdi_model):
    """X/F of the kd model = the 2-dof closed form, damper mass md + b, to 1e-10."""
    c = {"m": 2.0, "k": 300.0, "md": 0.1, "b": 0.04, "kd": 4.5, "cd": 0.35}
    model = tmdi_model.with_constants(c)
    w = np.linspace(0.5, 30.0, 400)
    resp = kd.model_frequency_response(model, np.zeros(4), w, "F(t)", ["x", "xd", "u"])
    s = 1j * w
    zd = c["kd"] + c["cd"] * s  # the damper's impedance
    md = c["md"] + c["b"]
    det = (c["k"] + zd + c["m"] * s ** 2) * (zd + md * s ** 2) - zd ** 2
    x = (zd + md * s ** 2) / det
    xd = zd / det
    expected = np.column_stack([x, xd, s * x])
    assert resp.response.shape == (400, 3) and resp.outputs == ("x", "xd", "u")
    assert resp.input == "F"
    assert np.max(np.abs(resp.response - expected) / np.abs(expected)) < 1e-10
    # a row C over the states gives the same as the state's name
    row = kd.model_frequency_response(model, np.zeros(4), w, "F", [[1, 0, 0, 0]])
    assert np.array_equal(row.response[:, 0], resp.response[:, 0])


def test_peak_and_h2_of_a_damped_oscillator():
    """1 dof, k = 4, m = 1, zeta = 0.1: peak 1/(2 zeta sqrt(1 - zeta^2))/k and
    H2^2 = 1/(4 zeta wn^3 m^2) (x per force)."""
    k, m, zeta = 4.0, 1.0, 0.1
    wn = math.sqrt(k / m)
    A = np.array([[0, 1], [-k / m, -2 * zeta * wn]])
    B, C = np.array([0, 1 / m]), np.array([1, 0])
    peaks = response_peaks(A, B, C, np.linspace(0.1, 6, 301))
    assert peaks[0, 1] == pytest.approx(1 / (2 * zeta * math.sqrt(1 - zeta ** 2)) / k,
                                        rel=1e-10)
    assert peaks[0, 0] == pytest.approx(wn * math.sqrt(1 - 2 * zeta ** 2), rel=1e-6)
    assert h2_norm(A, B, C) == pytest.approx(math.sqrt(1 / (4 * zeta * wn ** 3 * m ** 2)),
                                             rel=1e-12)
    assert h2_norm(np.array([[0, 1], [-k, 0]]), B, C) == math.inf


def test_bad_options_name_what_is_wrong(tmd_model):
    with pytest.raises(OptionError, match="'kdd' is not a constant"):
        kd.tune_damper(tmd_model, np.zeros(4), input="F", output="x", primary_frequency=1.0,
                       primary_mass=1.0, mass_ratio=0.05, damper_mass="md", stiffness="kdd",
                       damping="cd")
    with pytest.raises(OptionError, match="criterion"):
        tune(tmd_model, 0.05, criterion="rms")
    with pytest.raises(OptionError, match="output 'y'"):
        kd.model_frequency_response(tmd_model, np.zeros(4), [1.0], "F", "y")
    with pytest.raises(OptionError, match="input 'G'"):
        kd.model_frequency_response(tmd_model, np.zeros(4), [1.0], "G", "x")
    with pytest.raises(OptionError, match="inertance"):
        kd.tune_damper(tmd_model, np.zeros(4), input="F", output="x", primary_frequency=1.0,
                       primary_mass=1.0, mass_ratio=0.05, damper_mass="md", stiffness="kd",
                       damping="cd", inertance_ratio=0.1)
