"""The seat-belt sensor: a constrained spherical pendulum on a moving vehicle.

Closed forms for a spherical pendulum whose body has inertia J = I + m L^2 about
the pivot (none about its own axis) and equivalent length l = J / (m L):

- steady conical motion at tilt theta: Omega^2 = g / (l cos theta);
- small oscillation of the tilt about it: w^2 = Omega^2 (1 + 3 cos^2 theta)
  (from the effective potential h^2/(2 J sin^2) - m g L cos theta: the
  stiffness at the steady tilt is (g/l)(1 + 3 cos^2 theta)/cos theta);
- under a constant horizontal acceleration a: tan theta = a / g, and the small
  oscillation about it w^2 = sqrt(g^2 + a^2) / l (l = L for a point mass).
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import kanedyn as kd
from kanedyn._errors import ModelError
from kanedyn.models import (SEATBELT_DEFAULTS, lock_events, seatbelt_report, seatbelt_sensor,
                            seatbelt_tilt)
from kanedyn.modeling.vehicle import write_pulse_csv

G = SEATBELT_DEFAULTS["g"]


def _model(constants=None, **options):
    d = seatbelt_sensor(**options)
    return d, d.numeric(constants=constants or {})


def _length(m=5e-3, L=8e-3, I=8e-8):
    return (I + m * L ** 2) / (m * L)


def _state(e, rates=(0.0, 0.0)):
    """Gimbal angles putting the pendulum axis along the unit vector e (housing axes)."""
    e = np.asarray(e, float) / np.linalg.norm(e)
    return [math.atan2(e[1], -e[2]), math.asin(-e[0]), *rates]


def _frequency(t, x):
    """Mean angular frequency from the crossings of x through its mid-value."""
    mid = 0.5 * (x.max() + x.min())
    f = x - mid
    i = np.nonzero(np.sign(f[1:]) != np.sign(f[:-1]))[0]
    tc = t[i] - f[i] * (t[i + 1] - t[i]) / (f[i + 1] - f[i])
    return math.pi * (len(tc) - 1) / (tc[-1] - tc[0])


@pytest.mark.slow
def test_steady_conical_motion_and_its_small_oscillation():
    d, model = _model(limit="none", pulse="none", duration=1.0)
    ell = _length()
    th = math.radians(25.0)
    Om = math.sqrt(G / (ell * math.cos(th)))
    # axis e = (-sin th, 0, -cos th) turning about the vertical at Omega:
    # q1 = 0, q2 = th, u1 = -Omega tan th, u2 = 0
    y0 = [0.0, th, -Om * math.tan(th), 0.0]
    t = np.linspace(0, 0.6, 6001)
    res = kd.simulate(model, (0, 0.6), y0, t_eval=t, rtol=1e-11, atol=1e-12)
    assert res.success
    tilt = seatbelt_tilt(res.y[:2])
    assert np.max(np.abs(tilt - th)) < 1e-8            # steady (measured ~1e-10)
    az = np.unwrap(np.arctan2(-np.sin(res.y[0]) * np.cos(res.y[1]), -np.sin(res.y[1])))
    assert abs((az[-1] - az[0]) / 0.6) == pytest.approx(Om, rel=1e-8)
    # a wrong rate (5 % off) is not steady: the test can fail
    y_bad = [0.0, th, -1.05 * Om * math.tan(th), 0.0]
    bad = kd.simulate(model, (0, 0.2), y_bad, rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(seatbelt_tilt(bad.y[:2]) - th)) > 1e-3
    # small oscillation: perturb the tilt rate
    eps = 1e-3
    res = kd.simulate(model, (0, 0.6), [0.0, th, -Om * math.tan(th), eps], t_eval=t,
                      rtol=1e-11, atol=1e-12)
    w = _frequency(t, seatbelt_tilt(res.y[:2]))
    expected = Om * math.sqrt(1 + 3 * math.cos(th) ** 2)
    assert w == pytest.approx(expected, rel=2e-5)


@pytest.mark.parametrize("direction", [0.0, 30.0])
def test_tilted_equilibrium_under_constant_acceleration(direction):
    a_g = 0.5
    # a point mass: I = 0, L = l = 10 mm
    d, model = _model(constants={"I": 0.0, "L": 0.01}, limit="none", pulse="step",
                      peak_g=a_g, duration=5.0, direction=direction)
    ang = math.radians(direction)
    # the vehicle accelerates along -(cos, sin, 0): the pendulum hangs along g_eff
    e = np.array([a_g * math.cos(ang), a_g * math.sin(ang), -1.0])
    y0 = _state(e)
    res = kd.simulate(model, (0, 0.3), y0, rtol=1e-11, atol=1e-12)
    tilt = seatbelt_tilt(res.y[:2])
    assert tilt[0] == pytest.approx(math.atan(a_g), abs=1e-14)
    assert np.max(np.abs(tilt - math.atan(a_g))) < 1e-9
    # small oscillation in the plane of the tilt
    e2 = np.array([math.tan(math.atan(a_g) + 1e-3) * math.cos(ang),
                   math.tan(math.atan(a_g) + 1e-3) * math.sin(ang), -1.0])
    t = np.linspace(0, 1.0, 10001)
    res = kd.simulate(model, (0, 1.0), _state(e2), t_eval=t, rtol=1e-11, atol=1e-12)
    w = _frequency(t, seatbelt_tilt(res.y[:2]))
    assert w == pytest.approx(math.sqrt(math.hypot(G, a_g * G) / 0.01), rel=1e-5)


def test_energy_change_equals_pivot_work():
    d, model = _model(limit="none", pulse="halfsine", peak_g=3.0, duration=0.1,
                      direction=30.0, pivot_force=True)
    motion = d.symbols["motion"]
    y0 = np.array(_state([0.2, -0.1, -1.0], rates=(3.0, -2.0)))

    def rhs(t, z):
        y = z[:-1]
        f = model.auxiliary(t, y)
        force = np.array([f[k] for k in sorted(f)])  # R_x, R_y, R_z
        return np.append(model.rhs(t, y), force @ motion.evaluate("position", 1, t))

    sol = solve_ivp(rhs, (0, 0.15), np.append(y0, 0.0), method="DOP853", rtol=1e-12,
                    atol=1e-14)
    assert sol.success
    y1, work = sol.y[:-1, -1], sol.y[-1, -1]
    e0 = sum(model.energies(0.0, y0))
    e1 = sum(model.energies(0.15, y1))
    # the pulse brings the pendulum (and its 3 g decelerating pivot) ~ 1e-3 J
    assert abs(work) > 1e-4
    print("energy change", e1 - e0, "pivot work", work, "rel", (e1 - e0) / work - 1)
    assert (e1 - e0) == pytest.approx(work, rel=1e-8)


@pytest.mark.slow
def test_csv_sampled_pulse_agrees_with_analytic(tmp_path):
    pulse = kd.vehicle.HalfSinePulse(3.0, 0.1)
    t = np.arange(0, 2001) * 1e-4
    acc = np.array([-1.0, 0.0, 0.0])[None, :] * pulse.acceleration(t)[:, None]
    path = tmp_path / "halfsine.csv"
    write_pulse_csv(path, t, acc, acceleration_unit="g")
    finals = []
    for source in ("halfsine", str(path)):
        d, model = _model(limit="none", pulse=source, peak_g=3.0, duration=0.1)
        res = kd.simulate(model, (0, 0.15), _state([0.05, 0.02, -1.0]), rtol=1e-10,
                          atol=1e-12)
        assert res.success
        finals.append(res.y[:, -1])
    assert abs(finals[0][1]) > 0.2  # a large swing
    # spline error near the kinks of a(t) at 0 and T: ~1e-6 rad (see test_vehicle_motion)
    np.testing.assert_allclose(finals[0][:2], finals[1][:2], atol=5e-6)


@pytest.mark.slow
def test_penalty_limit_converges_to_contact():
    options = dict(pulse="halfsine", peak_g=2.0, duration=0.1, direction=30.0)
    t_end = 0.12
    t = np.linspace(0, t_end, 241)
    y0 = _state([0.0, 0.0, -1.0])
    d, model = _model(constants={"e_lim": 1.0}, limit="contact", **options)
    ref = kd.simulate(model, (0, t_end), y0, t_eval=t, rtol=1e-10, atol=1e-12)
    assert ref.success and len(ref.impacts) >= 1
    # on the output grid the wall is touched only between samples
    lim = SEATBELT_DEFAULTS["theta_lim"]
    assert lim - 0.02 < np.max(seatbelt_tilt(ref.y[:2])) < lim + 1e-6
    errors = []
    for k in (5.0, 50.0, 500.0):
        d, model = _model(constants={"k_lim": k, "c_lim": 0.0}, limit="penalty", **options)
        res = kd.simulate(model, (0, t_end), y0, t_eval=t, rtol=1e-10, atol=1e-12)
        assert res.success
        errors.append(np.max(np.abs(seatbelt_tilt(res.y[:2]) - seatbelt_tilt(ref.y[:2]))))
    print("penalty vs contact, max tilt error (rad):", errors)
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.2 * errors[0]


def test_lock_at_07g_and_no_lock_at_15_degree_static_tilt():
    d, model = _model(limit="penalty", pulse="step", peak_g=0.7, duration=1.0)
    res = kd.simulate(model, (0, 0.15), d.initial(model), rtol=1e-9, atol=1e-12,
                      events=lock_events(d))
    report = seatbelt_report(res, d, events=0)
    assert report.locked and 0 < report.lock_time < 0.1
    assert report.releases == ()
    # static: the housing tilted 15 deg, the pendulum hanging plumb, at rest
    tilt = math.radians(15.0)
    d, model = _model(constants={"tilt_y": tilt}, limit="penalty", pulse="none",
                      duration=1.0)
    y0 = _state([math.sin(tilt), 0.0, -math.cos(tilt)])  # N's down, in housing axes
    res = kd.simulate(model, (0, 0.3), y0, rtol=1e-10, atol=1e-12, events=lock_events(d))
    report = seatbelt_report(res, d, events=0)
    assert not report.locked and report.lock_time is None
    assert report.max_tilt == pytest.approx(tilt, abs=1e-8)


def test_report_finds_intervals_and_unintended_release():
    d = seatbelt_sensor(limit="none", pulse="step", peak_g=1.0, duration=0.1)
    lock = d.symbols["lock_angle"]
    t = np.linspace(0, 0.2, 201)
    # over on (5.5, 45.5) ms, (85.5, 125.5) ms and from 165.5 ms to the end
    tilt = lock + 0.1 * np.sin(2 * np.pi * (t - 0.0055) / 0.08)
    y = np.vstack([np.zeros_like(t), -tilt, 0 * t, 0 * t])
    rep = seatbelt_report(SimpleNamespace(t=t, y=y, success=True, message=""), d)
    assert rep.locked and rep.lock_time == pytest.approx(0.0055, abs=1e-5)
    assert np.array(rep.intervals) == pytest.approx(
        np.array([[0.0055, 0.0455], [0.0855, 0.1255], [0.1655, 0.2]]), abs=1e-5)
    # a release at 45.5 ms (the 1 g step still on), none at 125.5 ms (it ended at 100)
    assert rep.releases == pytest.approx((0.0455,), abs=1e-5)
    assert rep.lock_duration == pytest.approx(0.1145, abs=1e-4)


@pytest.fixture(scope="module")
def default_sensor():
    d = kd.models.build("seatbelt-sensor")
    return d, d.numeric(backend="numpy")


@pytest.mark.usefixtures("terminal_signals")
def test_the_report_of_an_interrupted_run_says_so_and_interpolates_nothing(default_sensor):
    """Ctrl-C at t = 0.1 s of a run whose output points are 20 s apart: the result
    holds t = 0 and the state reached.  The report says the run is partial, and
    that the lock lies between those two times (it said "locks at t = 66.69 ms",
    interpolated across them; the lock is at 15.18 ms, which the 501 points of
    the default run resolve)."""
    import signal
    d, model = default_sensor

    def ctrl_c_at(t, y):  # under the run's guard (Ctrl-C taken over)
        if t > 0.1 and signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
            signal.raise_signal(signal.SIGINT)
        return 1.0
    with pytest.raises(kd.SimulationInterrupted) as stop:
        kd.simulate(model, (0.0, 1e4), d.initial(model), t_eval=np.linspace(0, 1e4, 501),
                    events=[ctrl_c_at])
    res = stop.value.result
    assert res.t.size == 2 and 0.1 < res.t[-1] < 0.11
    report = seatbelt_report(res, d)
    assert not report.complete and report.stopped == "interrupted"
    assert report.locked and report.lock_time is None
    assert report.lock_between == (0.0, res.t[-1])
    reached = f"{1e3 * res.t[-1]:.2f}"
    assert report.summary().startswith(
        f"partial run (stopped at t = {reached} ms: interrupted): locks between t = 0.00 "
        f"and {reached} ms (the output points do not resolve it")
    assert report.as_dict()["complete"] is False
    full = kd.simulate(model, (0.0, d.t_end), d.initial(model),
                       t_eval=np.linspace(0.0, d.t_end, 501))
    report = seatbelt_report(full, d)
    assert report.complete and report.lock_between is None
    assert report.lock_time == pytest.approx(0.015176, abs=1e-6)


def test_lock_times_from_output_points_far_apart(default_sensor):
    """A complete run with 51 output points: the lock lies between two of them 13 deg
    of tilt apart; the report gives those times, not an interpolation (15.00 ms,
    the events' time being 15.18 ms).  With the lock events the times are the
    events' at any number of points, and so is the time locked (it read the side
    of each crossing from the next output point: 184.82 ms with 3 points, 137.59
    with 501)."""
    d, model = default_sensor
    reports = {}
    for n in (3, 51, 501):
        res = kd.simulate(model, (0.0, d.t_end), d.initial(model), events=lock_events(d),
                          t_eval=np.linspace(0.0, d.t_end, n))
        reports[n] = seatbelt_report(res, d), seatbelt_report(res, d, events=0)
    coarse = reports[51][0]
    assert coarse.lock_time is None and coarse.lock_between == pytest.approx((0.012, 0.016))
    assert "locks between t = 12.00 and 16.00 ms" in coarse.summary()
    assert reports[501][0].lock_time == pytest.approx(0.015176, abs=1e-6)
    for n in (3, 51):
        exact = reports[n][1]
        assert exact.lock_between is None
        assert exact.lock_time == pytest.approx(reports[501][1].lock_time, rel=1e-9)
        assert exact.lock_duration == pytest.approx(reports[501][1].lock_duration, rel=1e-9)


def test_options_are_checked():
    with pytest.raises(ModelError, match="limit"):
        seatbelt_sensor(limit="soft")
    with pytest.raises(ModelError, match="unknown pulse"):
        seatbelt_sensor(pulse="sawtooth")
    with pytest.raises(ModelError, match="does not exist"):
        seatbelt_sensor(pulse="/nonexistent/crash.csv")
    with pytest.raises(ModelError, match="peak_g"):
        seatbelt_sensor(peak_g=-1)
    p = kd.models.build("pendulum").symbols
    with pytest.raises(ModelError, match="limit must lie"):
        kd.ConeLimit(p["A"], p["N"], p["A"].y, p["N"].y, 2.0, 1.0)
    with pytest.raises(ModelError, match="stiffness"):
        kd.ConeLimit(p["A"], p["N"], p["A"].y, p["N"].y, 0.5, 0.0)
    assert "seatbelt-sensor" in kd.models.REGISTRY
    d = kd.models.build("seatbelt-sensor", pulse="frontal-48kmh")
    assert d.t_end == pytest.approx(0.15)


def test_penalty_damping_gives_restitution():
    c = kd.penalty_damping_for_restitution(0.3, 5.0, 4e-7)
    zeta = c / (2 * math.sqrt(5.0 * 4e-7))
    assert math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2)) == pytest.approx(0.3)
    assert kd.penalty_damping_for_restitution(1.0, 5.0, 4e-7) == 0.0
