"""Crash-test records in the ISO-MME and NHTSA CSV formats (issue 37, item 2).

No real record can be fetched here: the files are written from kanedyn's synthetic
example pulses (read independently from their own CSV by ``read_pulse_csv``), in
both formats, by hand-made text (a header, numbers one per line) as well as by the
writers, and then broken one line at a time.
"""

import math
import re

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.modeling.vehicle import G0, read_pulse_csv

CODES = {"ax": "10VEHC0000CGACXP", "ay": "10VEHC0000CGACYP", "wz": "10VEHC0000CGAVZP"}


@pytest.fixture(scope="module")
def oblique():
    """The oblique example (accelerations in x and y, a yaw rate), from its CSV."""
    return read_pulse_csv(kd.vehicle.example_pulse("oblique-30deg"))


def _iso_test(folder, series, units=("g", "m/s**2", "deg/s")):
    channels = [(CODES["ax"], "Vehicle CG X acceleration", units[0],
                 series.acceleration[:, 0] / (G0 if units[0] == "g" else 1.0)),
                (CODES["ay"], "Vehicle CG Y acceleration", units[1],
                 series.acceleration[:, 1] / (G0 if units[1] == "g" else 1.0)),
                (CODES["wz"], "Vehicle yaw rate", units[2],
                 np.degrees(series.angular_rate[:, 2]) if units[2] == "deg/s"
                 else series.angular_rate[:, 2])]
    return kd.vehicle.write_iso_mme(folder, "T0001", series.t, channels)


def test_iso_mme_round_trip_by_code_name_and_default(oblique, tmp_path):
    mme = _iso_test(tmp_path / "T0001", oblique)
    by_default = kd.vehicle.read_iso_mme(tmp_path / "T0001")  # the folder
    by_code = kd.vehicle.read_iso_mme(mme, channels=CODES)  # the .mme file
    by_name = kd.vehicle.read_iso_mme(mme, channels={"ax": "vehicle cg x acceleration",
                                                     "ay": "Vehicle CG Y acceleration",
                                                     "wz": "VEHICLE YAW RATE"})
    for got in (by_default, by_code, by_name):
        np.testing.assert_allclose(got.t, oblique.t, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got.acceleration, oblique.acceleration, rtol=1e-14,
                                   atol=1e-12)
        np.testing.assert_allclose(got.angular_rate, oblique.angular_rate, rtol=1e-14,
                                   atol=1e-15)
        assert got.rate_columns == ("wz",)
    assert by_default.notes[0] == f"ax: {CODES['ax']} / Vehicle CG X acceleration (T0001.001)"
    # filtered as today's records are (CFC 60), the motion is the CSV's
    filtered = kd.VehicleMotion.from_series(by_default, filter="CFC60")
    reference = kd.VehicleMotion.from_csv(kd.vehicle.example_pulse("oblique-30deg"),
                                          filter="CFC60")
    t = np.linspace(0.0, 0.15, 301)
    np.testing.assert_allclose(filtered.evaluate("position", 2, t),
                               reference.evaluate("position", 2, t), rtol=0, atol=1e-10)


def test_iso_mme_hand_written_channel_and_motion(tmp_path):
    """A test written line by line (not by the writer), read into a motion whose
    velocity change is the half-sine's 2 A T / pi."""
    T, A = 0.08, 10.0  # s, g
    t = np.round(np.arange(-50, 1201) * 1e-4, 10)
    a = np.where((t >= 0) & (t <= T), -A * np.sin(np.pi * np.clip(t, 0, T) / T), 0.0)
    channel = tmp_path / "S1" / "Channel"
    channel.mkdir(parents=True)
    (tmp_path / "S1" / "S1.mme").write_text("Data format                 :ISO-MME\n"
                                            "Test number                 :S1\n")
    (channel / "S1.chn").write_text("Number of channels          :1\n"
                                    "Name of channel 001         :10VEHC0000CGACXD / sled\n")
    header = ("Channel code                :10VEHC0000CGACXD\n"
              "Name of the channel         :sled\n"
              "Unit                        :g\n"
              "Sampling interval           :1.000000E-4\n"
              "Time of first sample        :-5.000000E-3\n"
              f"Number of samples           :{t.size}\n")
    (channel / "S1.001").write_text(header + "".join(f"{v:.9E}\n" for v in a))
    series = kd.vehicle.read_iso_mme(tmp_path / "S1")
    assert series.rate_columns == ()
    np.testing.assert_allclose(series.t, t, atol=1e-12)
    motion = kd.VehicleMotion.from_series(series)
    dv = motion.velocity_change()
    assert dv[0] == pytest.approx(-2 * A * G0 * T / np.pi, rel=1e-5)
    assert dv[1] == dv[2] == 0.0


def test_nhtsa_csv_round_trip(oblique, tmp_path):
    path = tmp_path / "v12345.csv"
    kd.vehicle.write_nhtsa_csv(path, oblique.t, [
        ("VEHICLE CG X ACCELERATION", "G", oblique.acceleration[:, 0] / G0),
        ("VEHICLE CG Y ACCELERATION", "G", oblique.acceleration[:, 1] / G0),
        ("YAW RATE", "deg/s", np.degrees(oblique.angular_rate[:, 2]))])
    got = kd.vehicle.read_nhtsa_csv(path, {"ax": "Vehicle CG X Acceleration", "ay": 2,
                                           "wz": "yaw  rate"})
    np.testing.assert_allclose(got.t, oblique.t, atol=1e-15)
    np.testing.assert_allclose(got.acceleration, oblique.acceleration, rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(got.angular_rate, oblique.angular_rate, rtol=1e-14, atol=1e-15)


def test_nhtsa_csv_without_units_is_g_and_seconds(tmp_path):
    path = tmp_path / "plain.csv"
    rows = "".join(f"{k * 1e-3},{-2.0 * k}\n" for k in range(6))
    path.write_text("Time,SLED ACCELERATION\n" + rows)
    got = kd.vehicle.read_nhtsa_csv(path, {"ax": "sled acceleration"})
    np.testing.assert_allclose(got.t, np.arange(6) * 1e-3)
    np.testing.assert_allclose(got.acceleration[:, 0], -2.0 * G0 * np.arange(6))
    path.write_text("Time (ms),SLED ACCELERATION (m/s^2)\n" + rows)
    got = kd.vehicle.read_nhtsa_csv(path, {"ax": 1})
    np.testing.assert_allclose(got.t, np.arange(6) * 1e-6)
    np.testing.assert_allclose(got.acceleration[:, 0], -2.0 * np.arange(6))


def _break(path, line, text):
    """Replace line ``line`` (1-based) of ``path`` by ``text``."""
    lines = path.read_text().splitlines(keepends=True)
    lines[line - 1] = text
    path.write_text("".join(lines))


# channel file T0001.001: header lines 1-10 (Unit 6, Sampling interval 7, Number of
# samples 9), samples from line 11
ISO_CASES = {
    "text sample": (lambda d: _break(d / "Channel" / "T0001.001", 40, "1.2.3\n"),
                    r"T0001\.001: channel 10VEHC0000CGACXP \(ax\), line 40: sample '1\.2\.3' "
                    r"is not a finite number"),
    "NaN sample": (lambda d: _break(d / "Channel" / "T0001.002", 12, "nan\n"),
                   r"T0001\.002: channel 10VEHC0000CGACYP \(ay\), line 12: sample 'nan'"),
    "count mismatch": (lambda d: _break(d / "Channel" / "T0001.001", 9,
                                        "Number of samples           :1900\n"),
                       r"T0001\.001: channel 10VEHC0000CGACXP \(ax\): 1801 samples \(lines "
                       r"11-1811\), the header \(line 9\) says 1900"),
    "unknown unit": (lambda d: _break(d / "Channel" / "T0001.001", 6,
                                      "Unit                        :ft/s**2\n"),
                     r"T0001\.001: channel 10VEHC0000CGACXP \(ax\), line 6: unknown unit "
                     r"'ft/s\*\*2' for an acceleration"),
    "rate in g": (lambda d: _break(d / "Channel" / "T0001.003", 6,
                                   "Unit                        :g\n"),
                  r"T0001\.003: channel 10VEHC0000CGAVZP \(wz\), line 6: unknown unit 'g' "
                  r"for an angular rate"),
    "missing key": (lambda d: _break(d / "Channel" / "T0001.002", 7, "Filter  :none\n"),
                    r"T0001\.002: channel 10VEHC0000CGACYP \(ay\): the header \(lines 1-10\) "
                    r"has no 'Sampling interval' value"),
    "NOVALUE interval": (lambda d: _break(d / "Channel" / "T0001.002", 7,
                                          "Sampling interval           :NOVALUE\n"),
                         r"has no 'Sampling interval' value"),
    "zero interval": (lambda d: _break(d / "Channel" / "T0001.001", 7,
                                       "Sampling interval           :0\n"),
                      r"T0001\.001: channel 10VEHC0000CGACXP \(ax\), line 7: sampling "
                      r"interval 0 s must be positive"),
    "other time axis": (lambda d: _break(d / "Channel" / "T0001.003", 8,
                                         "Time of first sample        :-0.02\n"),
                        r"T0001\.003: channel 10VEHC0000CGAVZP \(wz\): its time axis .* "
                        r"differs from T0001\.001's"),
    "channel file missing": (lambda d: (d / "Channel" / "T0001.002").unlink(),
                             r"T0001\.chn: channel 002 \(10VEHC0000CGACYP, for ay\) has no "
                             r"file T0001\.002"),
    "list count wrong": (lambda d: _break(d / "Channel" / "T0001.chn", 2,
                                          "Number of channels          :4\n"),
                         r"T0001\.chn: 'Number of channels' says 4, the list names 3"),
    "code differs from list": (lambda d: _break(d / "Channel" / "T0001.001", 1,
                                                "Channel code                :10VEHC0000CGACZP\n"),
                               r"T0001\.001: channel 10VEHC0000CGACXP \(ax\), line 1: the "
                               r"file's channel code is 10VEHC0000CGACZP"),
    "no Channel folder": (lambda d: (d / "Channel").rename(d / "Elsewhere"),
                          r"T0001\.mme: no 'Channel' folder beside it"),
    "g in place of m/s**2 (1000 g)": (
        lambda d: _break(d / "Channel" / "T0001.002", 6, "Unit                        :g\n"),
        r"T0001\.002: channel 10VEHC0000CGACYP \(ay\): peak .* g is above 1000 g"),
}


@pytest.mark.parametrize("case", list(ISO_CASES))
def test_malformed_iso_mme(case, oblique, tmp_path):
    folder = tmp_path / "T0001"
    _iso_test(folder, oblique)
    spoil, pattern = ISO_CASES[case]
    if case == "g in place of m/s**2 (1000 g)":  # ay of 50 times the pulse, in m/s^2
        _iso_test(folder, oblique.__class__(oblique.t, 50 * oblique.acceleration,
                                            oblique.angular_rate), ("g", "m/s**2", "deg/s"))
    spoil(folder)
    with pytest.raises(kd.ModelError, match=pattern):
        kd.vehicle.read_iso_mme(folder)


def test_iso_mme_channel_choice_refused(oblique, tmp_path):
    folder = tmp_path / "T0001"
    _iso_test(folder, oblique)
    with pytest.raises(kd.ModelError, match=r"T0001\.chn: no channel with code or name "
                                            r"'HEAD X' \(for ax\); channels: 10VEHC"):
        kd.vehicle.read_iso_mme(folder, channels={"ax": "HEAD X"})
    with pytest.raises(kd.ModelError, match=r"channels: unknown key\(s\) \['bx'\]"):
        kd.vehicle.read_iso_mme(folder, channels={"bx": CODES["ax"]})
    _break(folder / "Channel" / "T0001.chn", 4,
           "Name of channel 002         :10VEHC0000CGACXP / second x\n")
    with pytest.raises(kd.ModelError, match=r"T0001\.chn: 2 vehicle channels for ax "
                                            r"\(10VEHC0000CGACXP, 10VEHC0000CGACXP\)"):
        kd.vehicle.read_iso_mme(folder)


NHTSA_CASES = {
    "text cell": (5, "0.0003,abc,0\n", r"bad\.csv: column 'X ACC \(G\)', line 5: 'abc' is "
                                       r"not a finite number"),
    "empty cell": (3, "0.0001,,0\n", r"bad\.csv: column 'X ACC \(G\)', line 3: 'an empty "
                                     r"cell'"),
    "time back": (6, "0.0001,1,0\n", r"bad\.csv: column 'Time \(s\)': time does not "
                                     r"increase at line 6"),
    "unknown unit": (1, "Time (s),X ACC (furlongs),YAW (deg/s)\n",
                     r"bad\.csv: column 'X ACC \(furlongs\)' \(for ax\): unknown unit "
                     r"'furlongs' for an acceleration"),
    "no time column": (1, "X ACC (G),YAW (deg/s)\n",
                       r"bad\.csv: line 1: the first column is 'X ACC \(G\)'"),
    "channel absent": (1, "Time (s),Y ACC (G),YAW (deg/s)\n",
                       r"bad\.csv: no column 'x acc' \(for ax\) in the header \(line 1\)"),
}


@pytest.mark.parametrize("case", list(NHTSA_CASES))
def test_malformed_nhtsa_csv(case, tmp_path):
    path = tmp_path / "bad.csv"
    kd.vehicle.write_nhtsa_csv(path, np.arange(8) * 1e-4,
                               [("X ACC", "G", -np.arange(8.0)), ("YAW", "deg/s", np.zeros(8))])
    line, text, pattern = NHTSA_CASES[case]
    _break(path, line, text)
    with pytest.raises(kd.ModelError, match=pattern):
        kd.vehicle.read_nhtsa_csv(path, {"ax": "x acc", "wz": "YAW"})


def test_nhtsa_channels_required(tmp_path):
    with pytest.raises(kd.ModelError, match=re.escape("channels must be a dict with at least "
                                                      "'ax'")):
        kd.vehicle.read_nhtsa_csv(tmp_path / "x.csv", {"ay": 1})


def test_seatbelt_runs_an_iso_mme_test_as_its_csv(tmp_path):
    """The sensor driven by an ISO-MME copy of the frontal example locks as with the CSV."""
    series = read_pulse_csv(kd.vehicle.example_pulse("frontal-48kmh"))
    folder = tmp_path / "F1"
    kd.vehicle.write_iso_mme(folder, "F1", series.t, [
        ("10VEHC0000CGACXP", "Vehicle CG X", "g", series.acceleration[:, 0] / G0)])
    from_iso = kd.models.seatbelt_sensor(pulse=str(folder))
    from_csv = kd.models.seatbelt_sensor(pulse="frontal-48kmh")
    reports = []
    for d in (from_iso, from_csv):
        model = d.numeric(backend="c")
        res = kd.simulate(model, (0.0, d.t_end), d.initial(model), rtol=1e-8, atol=1e-8,
                          events=kd.models.lock_events(d))
        reports.append(kd.models.seatbelt_report(res, d, events=0))
    assert reports[0].locked and reports[1].locked
    assert math.isclose(reports[0].lock_time, reports[1].lock_time, rel_tol=1e-6)
