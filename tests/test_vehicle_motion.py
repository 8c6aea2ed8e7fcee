"""Prescribed vehicle motion: pulses, CSV records, CFC filters, the moving frame."""

import os
import re
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import (Particle, Point, ReferenceFrame, dynamicsymbols)

import kanedyn as kd
from kanedyn import ModelError
from kanedyn.modeling.vehicle import G0, cfc_response, write_pulse_csv
from kanedyn.modeling.vehicle._series import MAX_BYTES
from kanedyn.modeling.vehicle._filters import cfc_coefficients


# ------------------------------------------------------------------ pulses
def test_half_sine_48kmh_reference():
    # REFERENCES.md: 48 km/h in 100 ms as a half-sine has a peak of 21.36 g
    p = kd.vehicle.pulse_from_delta_v(48 / 3.6, 0.1)
    assert p.peak_g == pytest.approx(21.36, abs=0.005)
    assert p.delta_v == pytest.approx(48 / 3.6, rel=1e-12)


@pytest.mark.parametrize("pulse, dv, peak", [
    (kd.vehicle.HalfSinePulse(20, 0.08), 2 * 20 * G0 * 0.08 / np.pi, 20),
    (kd.vehicle.HaversinePulse(30, 0.1), 30 * G0 * 0.1 / 2, 30),
    (kd.vehicle.TrapezoidPulse(25, 0.01, 0.04, 0.03), 25 * G0 * (0.005 + 0.04 + 0.015), 25),
    (kd.vehicle.pulse_from_delta_v(10.0, 0.12, "haversine"), 10.0, 2 * 10 / 0.12 / G0),
])
def test_pulse_delta_v_peak_and_displacement(pulse, dv, peak):
    assert pulse.delta_v == pytest.approx(dv, rel=1e-12)
    assert pulse.peak_g == pytest.approx(peak, rel=1e-6)
    # closed forms against numerical quadrature of a(t)
    t = np.linspace(0, pulse.duration * 1.5, 30001)
    a = pulse.acceleration(t)
    v = np.concatenate([[0], np.cumsum((a[1:] + a[:-1]) / 2 * np.diff(t))])
    s = np.concatenate([[0], np.cumsum((v[1:] + v[:-1]) / 2 * np.diff(t))])
    assert np.max(np.abs(pulse.velocity_change(t) - v)) < 1e-5 * dv
    assert np.max(np.abs(pulse.displacement(t) - s)) < 1e-5 * dv * pulse.duration


def test_bad_pulse_parameters_are_named():
    with pytest.raises(ModelError, match="duration"):
        kd.vehicle.HalfSinePulse(20, -0.1)
    with pytest.raises(ModelError, match="shape"):
        kd.vehicle.pulse_from_delta_v(10, 0.1, "square")


# ------------------------------------------------------------------ records
def _sampled(pulse, path, direction=np.array([-1.0, 0, 0]), rate=None, dt=1e-4, end=None):
    end = end or pulse.duration * 1.5
    t = np.arange(0, round(end / dt) + 1) * dt
    acc = direction[None, :] * pulse.acceleration(t)[:, None]
    write_pulse_csv(path, t, acc, rate, acceleration_unit="g")
    return t


def test_csv_round_trip_reproduces_delta_v(tmp_path):
    p = kd.vehicle.HalfSinePulse(20, 0.1)
    path = tmp_path / "halfsine.csv"
    _sampled(p, path)
    m = kd.VehicleMotion.from_csv(path)
    dv = np.linalg.norm(m.velocity_change())
    assert abs(dv - p.delta_v) < 1e-6 * p.delta_v
    check = m.check(delta_v=p.delta_v, peak_g=20, rtol=1e-4)
    assert check.passed, check
    assert not m.check(delta_v=1.1 * p.delta_v).passed


def test_example_pulses_are_as_described():
    front = kd.VehicleMotion.from_csv(kd.vehicle.example_pulse("frontal-48kmh"))
    assert front.velocity_change()[0] == pytest.approx(-48 / 3.6, rel=1e-6)
    assert 30 < front.peak_acceleration() / G0 < 40
    series = kd.vehicle.read_pulse_csv(kd.vehicle.example_pulse("oblique-30deg"))
    assert series.rate_columns == ("wx", "wy", "wz")
    assert np.max(series.angular_rate[:, 2]) == pytest.approx(0.5, rel=1e-12)


# ------------------------------------------------------------------ bad files
def _write(path, text):
    path.write_text(text)
    return path


GOOD = "t [s],ax [g],ay [g],az [g]\n" + "".join(
    f"{i * 1e-3},{-5 * np.sin(i / 3)},0,0\n" for i in range(10))


@pytest.mark.parametrize("text, column, what", [
    (GOOD.replace("ay [g],", ""), "ay", "missing column"),
    (GOOD.replace("0.003,", "0.001,", 1), "t", "does not increase"),
    (GOOD.replace(",0,0\n", ",nan,0\n", 1), "ay", "not a finite number"),
    (GOOD.replace(",0,0\n", ",,0\n", 1), "ay", "empty cell"),
    (GOOD.replace("\n0.005,-", "\n0.005,-10000"), "ax", "above"),
    (GOOD.replace("az [g]", "az"), "az", "no unit"),
    (GOOD.replace("az [g]", "az [furlong]"), "az", "unknown unit"),
    ("t [s],ax [g],ay [g],az [g]\n0,0,0,0\n", "", "samples"),
    (GOOD.replace(",0,0\n", ",0,0,7\n", 1), "", "line 2 has 5 cells, the header (line 1) "
                                                  "names 4 columns"),
])
def test_bad_csv_names_file_and_column(tmp_path, text, column, what):
    path = _write(tmp_path / "bad_pulse.csv", text)
    with pytest.raises(ModelError) as err:
        kd.vehicle.read_pulse_csv(path)
    msg = str(err.value)
    assert "bad_pulse.csv" in msg and what in msg
    assert f"'{column}'" in msg or not column


@pytest.mark.parametrize("encoding", ["latin-1", "utf-16"])
def test_csv_not_utf8_is_named(tmp_path, encoding):
    """A spreadsheet's export in another encoding (a Latin-1 unit, UTF-16)."""
    path = tmp_path / "bad_pulse.csv"
    path.write_text(GOOD.replace("ax [g]", "ax [m/s\u00b2]"), encoding=encoding)
    with pytest.raises(ModelError, match=r"bad_pulse\.csv: not UTF-8 text \(byte 0x"):
        kd.vehicle.read_pulse_csv(path)


def test_byte_order_mark_of_a_spreadsheet_is_skipped(tmp_path):
    """Spreadsheet programs save "CSV UTF-8" with a byte-order mark before the header."""
    path = tmp_path / "excel.csv"
    path.write_text(GOOD, encoding="utf-8-sig")
    assert path.read_bytes().startswith(b"\xef\xbb\xbf")
    series = kd.vehicle.read_pulse_csv(path)
    plain = kd.vehicle.read_pulse_csv(_write(tmp_path / "plain.csv", GOOD))
    np.testing.assert_array_equal(series.t, plain.t)
    np.testing.assert_array_equal(series.acceleration, plain.acceleration)


def test_huge_cell_is_named_with_its_line(tmp_path):
    """A cell over the csv module's field limit (131,072 characters)."""
    lines = GOOD.splitlines()
    lines.insert(3, '"' + "9" * 140_000 + '",0,0,0')
    path = _write(tmp_path / "huge.csv", "\n".join(lines) + "\n")
    with pytest.raises(ModelError, match=r"huge\.csv: line 4: a cell longer than 131072 "
                                         "characters"):
        kd.vehicle.read_pulse_csv(path)


@pytest.mark.timeout(30)  # a reader that waits for a writer of the pipe fails, not hangs
@pytest.mark.parametrize("kind", ["a folder", "a named pipe", "a character device"])
def test_files_that_are_not_regular_are_refused(tmp_path, kind):
    """A folder, a named pipe (no writer: opening it must not wait for one) and
    /dev/zero (endless) are refused before anything is read."""
    if kind == "a folder":
        path = tmp_path
    elif kind == "a named pipe":
        if not hasattr(os, "mkfifo"):
            pytest.skip("no named pipes here")
        path = tmp_path / "pulse.csv"
        os.mkfifo(path)
    else:
        path = Path("/dev/zero")
        if not path.exists():
            pytest.skip("no /dev/zero here")
    with pytest.raises(ModelError, match=rf"^{re.escape(str(path))}: {kind}, not a regular "
                                         "file; give a CSV file$"):
        kd.vehicle.read_pulse_csv(path)


def test_file_size_is_bounded(tmp_path):
    """A file above MAX_BYTES (a sparse one: nothing is read) is refused with the
    way to raise the limit; max_bytes sets it either way."""
    big = tmp_path / "big.csv"
    with big.open("wb") as handle:
        handle.truncate(MAX_BYTES + 1)
    with pytest.raises(ModelError, match=rf"big\.csv: {MAX_BYTES + 1} bytes, more than the "
                       rf"{MAX_BYTES} a pulse record may have \(give read_pulse_csv\(\.\.\., "
                       r"max_bytes=\.\.\.\) to read a larger one\)"):
        kd.vehicle.read_pulse_csv(big)
    path = _write(tmp_path / "pulse.csv", GOOD)
    size = path.stat().st_size
    with pytest.raises(ModelError, match=rf"{size} bytes, more than the {size - 1} "):
        kd.vehicle.read_pulse_csv(path, max_bytes=size - 1)
    assert len(kd.vehicle.read_pulse_csv(path, max_bytes=size).t) == 10


def test_memory_of_reading_is_proportional_to_the_data(tmp_path):
    """Reading 20,000 rows allocates at its peak less than twice the file's size and
    three times the arrays returned (0.45 of that); a Python object per cell took
    4.6 times it (51.7 MB for a file of 0.87 MB)."""
    rows = 20_000
    t = np.arange(rows) * 1e-5
    acc = np.column_stack([-5 * np.sin(t * 300), np.zeros(rows), np.zeros(rows)])
    path = tmp_path / "long.csv"
    write_pulse_csv(path, t, acc, acceleration_unit="g")
    size = path.stat().st_size
    tracemalloc.start()
    try:
        series = kd.vehicle.read_pulse_csv(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_allclose(series.acceleration, acc, rtol=1e-15, atol=1e-300)
    arrays = series.t.nbytes + series.acceleration.nbytes + series.angular_rate.nbytes
    assert peak < 2 * size + 3 * arrays, (peak, size, arrays)


def _half_sine_text(time_unit, scale, dt=1e-4, duration=0.1, peak_g=20.0):
    """A half-sine pulse sampled every ``dt`` s, times written in s * ``scale``."""
    t = np.arange(round(duration / dt) + 1) * dt
    a = -peak_g * np.sin(np.pi * t / duration)
    return f"t [{time_unit}],ax [g],ay [g],az [g]\n" + "".join(
        f"{float(ti * scale)!r},{float(ai)!r},0,0\n" for ti, ai in zip(t, a))


def test_times_in_milliseconds_labelled_seconds_are_warned_of(tmp_path):
    """A 49 ms pulse written in ms under 't [s]' lasts 49 s: its speed change, 1000
    times the real one, is far above any vehicle test's; the same record labelled
    correctly, and the example pulses, give no warning."""
    wrong = _write(tmp_path / "wrong.csv", _half_sine_text("s", 1e3, duration=0.049))
    with pytest.warns(UserWarning, match=r"wrong\.csv: the accelerations imply a speed "
                      r"change of 6\d{3} m/s .* over 49 s, above 100 m/s; if the times are "
                      r"in milliseconds, write 't \[ms\]' \(the speed change is then 6\.\d+"):
        series = kd.vehicle.read_pulse_csv(wrong)
    assert series.t[-1] == pytest.approx(49.0)  # read as written, only warned of
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for text in (_half_sine_text("ms", 1e3, duration=0.049),  # 6.1 m/s
                     _half_sine_text("s", 1.0, duration=0.15, peak_g=45)):  # 42 m/s
            kd.vehicle.read_pulse_csv(_write(tmp_path / "right.csv", text))
        for name in ("frontal-48kmh", "oblique-30deg"):
            kd.vehicle.read_pulse_csv(kd.vehicle.example_pulse(name))


def test_absent_rates_mean_no_rotation_and_partial_rates_are_read(tmp_path):
    series = kd.vehicle.read_pulse_csv(_write(tmp_path / "a.csv", GOOD))
    assert series.rate_columns == () and not np.any(series.angular_rate)
    text = GOOD.replace("az [g]\n", "az [g],wz [deg/s]\n").replace(",0,0\n", ",0,0,90\n")
    series = kd.vehicle.read_pulse_csv(_write(tmp_path / "b.csv", text))
    assert series.rate_columns == ("wz",)
    assert np.allclose(series.angular_rate[:, 2], np.pi / 2)


# ------------------------------------------------------------------ CFC filters
@pytest.mark.parametrize("cfc", [60, 180, 600, 1000])
def test_cfc_response_in_j211_corridor(cfc):
    dt = 1 / (100 * cfc)
    fn = 5 / 3 * cfc  # F_N: nominal -3 dB frequency
    # DC gain exactly 1
    b, a = cfc_coefficients(cfc, dt)
    assert np.sum(b) / np.sum(a) == pytest.approx(1, abs=1e-13)
    # pass band up to the class frequency: +0.5 / -1 dB
    f = np.linspace(0.1, cfc, 50)
    db = cfc_response(f, dt, cfc)
    assert np.all(db <= 0.5) and np.all(db >= -1)
    # -3 dB at F_N (corridor +0.5 / -4 dB); this filter: within 0.05 dB of -3
    assert cfc_response(fn, dt, cfc)[0] == pytest.approx(-3.0, abs=0.05)
    # beyond F_N: below a -9 dB/octave line from F_N, and 30 dB down by 4 F_N
    for k in (2, 4):
        assert cfc_response(k * fn, dt, cfc)[0] <= 0.5 - 9 * np.log2(k)
    assert cfc_response(4 * fn, dt, cfc)[0] <= -30


def test_cfc_filter_is_phaseless_and_keeps_constants():
    dt = 1e-4
    t = np.arange(0, 0.4, dt)
    x = np.sin(2 * np.pi * 20 * t) * np.exp(-((t - 0.2) / 0.05) ** 2)
    y = kd.vehicle.cfc_filter(x, dt, "CFC180")
    # symmetric input about 0.2 s stays symmetric (no phase lag): peak time unchanged
    assert abs(np.argmax(y) - np.argmax(x)) <= 1
    # a time-reversed record gives the time-reversed result (up to the start-up
    # transients of the two passes, 1e-9 of the amplitude for this record)
    assert np.allclose(kd.vehicle.cfc_filter(x[::-1], dt, 180)[::-1], y, atol=1e-8)
    # and a one-pass filter would not: it lags by about a millisecond
    from scipy.signal import lfilter
    one = lfilter(*cfc_coefficients(180, dt), x)
    assert np.argmax(one) - np.argmax(x) >= 5
    assert np.allclose(kd.vehicle.cfc_filter(np.full(500, 3.0), dt, 60), 3.0, atol=1e-12)
    with pytest.raises(ModelError, match="CFC60"):
        kd.vehicle.cfc_filter(x, 1 / 300, 60)
    with pytest.raises(ModelError, match="CFC90"):
        kd.vehicle.cfc_filter(x, dt, "CFC90")


def test_filtered_example_removes_ringing_keeps_delta_v():
    path = kd.vehicle.example_pulse("frontal-48kmh")
    raw = kd.VehicleMotion.from_csv(path)
    filtered = kd.VehicleMotion.from_csv(path, filter="CFC60")
    assert filtered.peak_acceleration() < raw.peak_acceleration()
    assert filtered.velocity_change()[0] == pytest.approx(-48 / 3.6, rel=1e-5)


# ------------------------------------------------------------------ the moving frame
def test_point_fixed_in_vehicle_follows_the_pulse():
    p = kd.vehicle.HalfSinePulse(20, 0.1)
    motion = kd.VehicleMotion.from_pulse(p, direction=30, roll_rate=2.0)
    N, O = ReferenceFrame("N"), Point("O")
    V, VO = motion.moving_frame(N, O)
    P = VO.locatenew("P", 0.3 * V.y + 0.5 * V.z)
    t = dynamicsymbols._t
    exact = motion.specified(exact=True)
    r = P.pos_from(O).to_matrix(N).xreplace(exact)
    e = -np.array([np.cos(np.pi / 6), np.sin(np.pi / 6), 0])
    for tk in (0.03, 0.1, 0.14):
        roll = 2.0 * tk
        body = np.array([0, 0.3 * np.cos(roll) - 0.5 * np.sin(roll),
                         0.3 * np.sin(roll) + 0.5 * np.cos(roll)])
        want = e * p.displacement(tk) + body
        got = np.array(r.subs(t, tk).evalf(), float).ravel()
        assert np.allclose(got, want, atol=1e-12)
        # the callables give the same values
        calls = motion.specified()
        x = [calls[s](tk) for s in motion.symbols]
        assert np.allclose(x[:3], e * p.displacement(tk), atol=1e-14)
        assert x[5] == pytest.approx(roll)


def test_record_with_yaw_rate_gives_the_records_angular_velocity():
    motion = kd.VehicleMotion.from_csv(kd.vehicle.example_pulse("oblique-30deg"))
    N, O = ReferenceFrame("N"), Point("O")
    V, _ = motion.moving_frame(N, O)
    values = motion.specified()
    w = V.ang_vel_in(N).to_matrix(V)
    series = kd.vehicle.read_pulse_csv(kd.vehicle.example_pulse("oblique-30deg"))
    for k in (200, 900, 1500):
        tk = series.t[k]
        subs = {key: f(tk) for key, f in values.items()}
        got = np.array(w.xreplace(subs), float).ravel()
        assert np.allclose(got, series.angular_rate[k], atol=1e-12)


def _pendulum(motion, g=9.81):
    """Pendulum of length 0.2 m hinged at the vehicle origin about V.y."""
    q, u = dynamicsymbols("q u")
    N, O = ReferenceFrame("N"), Point("O")
    V, VO = motion.moving_frame(N, O)
    B = V.orientnew("B", "Axis", (q, V.y))
    B.set_ang_vel(V, u * V.y)
    P = VO.locatenew("P", -0.2 * B.z)
    P.v2pt_theory(VO, N, B)
    bob = Particle("bob", P, 0.5)
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u], bodies=[bob],
                  loads=[(P, -0.5 * g * N.z)])
    return eom


@pytest.mark.slow
def test_pendulum_driven_by_pulse_and_by_its_csv_agree(tmp_path):
    p = kd.vehicle.HalfSinePulse(5, 0.1)
    path = tmp_path / "p.csv"
    _sampled(p, path, end=0.2)
    results = []
    for motion in (kd.VehicleMotion.from_pulse(p, direction=0),
                   kd.VehicleMotion.from_csv(path)):
        eom = _pendulum(motion)
        model = eom.numeric(specified=motion.specified(eom))
        res = kd.simulate(model, (0, 0.2), [0.0, 0.0], rtol=1e-11, atol=1e-12)
        assert res.success
        results.append(res)
    # under 5 g the pendulum swings to about -1.9 rad.  The spline through the
    # samples (h = 0.1 ms) departs from the sine only near the kinks of a(t) at 0 and T,
    # by O(h a') ~ 1e-4 of the peak over a few samples, whose velocity error is
    # O(h^2 a') ~ 5e-6 m/s: q agrees to ~1e-6 rad (measured 4.7e-7 rad)
    qa, qb = results[0]["q"][-1], results[1]["q"][-1]
    assert abs(qa) > 0.5
    assert qa == pytest.approx(qb, abs=1e-6)
    # and the exact (SymPy) inputs give the same as the callables
    motion = kd.VehicleMotion.from_pulse(p, direction=0)
    eom = _pendulum(motion)
    model = eom.numeric(specified=motion.specified(eom, exact=True))
    res = kd.simulate(model, (0, 0.2), [0.0, 0.0], rtol=1e-11, atol=1e-12)
    assert res["q"][-1] == pytest.approx(qa, abs=1e-8)


def test_specified_needs_the_frame_and_exact_needs_a_pulse(tmp_path):
    motion = kd.VehicleMotion.from_csv(kd.vehicle.example_pulse("frontal-48kmh"))
    with pytest.raises(ModelError, match="moving_frame"):
        motion.specified()
    motion.moving_frame(ReferenceFrame("N"), Point("O"))
    with pytest.raises(ModelError, match="not an analytic pulse"):
        motion.specified(exact=True)
    with pytest.raises(ModelError, match="defined for"):
        motion.specified()[motion.symbols[0]](1.0)
    assert sm.Derivative(motion.symbols[0], (dynamicsymbols._t, 2)) in motion.specified()
