"""Seat-belt sensor studies: the lock map (kd.sweep), the FMVSS 209 check, the CLI.

Independent references: the lock time of a grid point against a run of the
``seatbelt-sensor`` model itself (its pulse from :mod:`kanedyn.modeling.vehicle`,
lock time from ``seatbelt_report`` with ``lock_events``); the static check against
the plumb equilibrium (tilt in the housing = the housing's tilt, 15 deg); the
steady tilt atan(0.7) = 34.99 deg of a 0.7 g deceleration.
"""

import json
import math

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.cli import main
from kanedyn.models import lock_events, seatbelt_report, seatbelt_sensor
from kanedyn.modeling.vehicle import G0, HalfSinePulse, write_pulse_csv

pytest.importorskip("pandas")


@pytest.mark.slow
def test_lock_map_on_a_tiny_grid(tmp_path):
    lock_map = kd.studies.seatbelt_lock_map(peak_g=[0.1, 2.0, 10.0, 20.0], duration=[0.05],
                                            direction=[0.0, 90.0], roll_rate=[0.0], t_end=0.1,
                                            out=tmp_path)
    table = lock_map.table
    assert table.success.all() and len(table) == 8
    frontal = table[table.direction == 0].sort_values("peak_g")
    lateral = table[table.direction == 90].sort_values("peak_g")
    # a tiny pulse (0.1 g: steady tilt 5.7 deg < 20 deg) does not lock
    assert not frontal.locked.iloc[0] and np.isnan(frontal.lock_time.iloc[0])
    # lock time decreases with peak g at fixed duration (measured 27.4, 15.4, 12.1 ms)
    times = frontal.lock_time.to_numpy()[1:]
    assert np.all(np.diff(times) < 0), times
    # a symmetric housing: lateral = frontal
    np.testing.assert_allclose(lateral.lock_time.to_numpy()[1:], times, rtol=1e-6)
    # the study model's closed-form pulse against the model's own pulse and report
    d = seatbelt_sensor(pulse="halfsine", peak_g=20.0, duration=0.05)
    model = d.numeric(backend="c")
    res = kd.simulate(model, (0, 0.03), d.initial(model), events=lock_events(d),
                      rtol=1e-8, atol=1e-8)
    report = seatbelt_report(res, d, events=0)
    assert lock_map.lock_time(20.0, 0.05) == pytest.approx(report.lock_time, rel=1e-6)
    assert (tmp_path / "lock_map.csv").exists() and (tmp_path / "lock_map.png").exists()
    assert "lock_time" in (tmp_path / "lock_map.csv").read_text().splitlines()[0]
    fig = lock_map.figure
    assert "lock time" in fig.axes[-1].get_ylabel()  # the colorbar
    assert {ax.get_title() for ax in fig.axes[:2]} == {"frontal 0°", "lateral 90°"}


def test_study_pulses_match_the_vehicle_pulses():
    """The closed-form displacement of the studies against HalfSinePulse."""
    import sympy as sm

    from kanedyn.analysis._seatbelt_studies import _displacement
    t = sm.Symbol("t", real=True)
    pulse = HalfSinePulse(20.0, 0.08)
    s = sm.lambdify(t, _displacement("halfsine", 20.0 * G0, 0.08, t))
    for tq in (0.01, 0.04, 0.079, 0.1):
        assert s(tq) == pytest.approx(float(pulse.displacement(tq)), rel=1e-12)
    a = sm.lambdify(t, _displacement("ramp", 7.0, 0.05, t).diff(t, 2))
    assert a(0.025) == pytest.approx(3.5) and a(0.2) == pytest.approx(7.0)


@pytest.mark.slow
def test_regulatory_check_passes_defaults_and_fails_a_too_sensitive_sensor():
    check = kd.studies.regulatory_check(directions=(0.0, 90.0))
    assert check.passed, check.text()
    static = [r for r in check.rows if r["case"] == "static"]
    # plumb equilibrium: the tilt in the housing is the housing's, 15 deg
    for r in static:
        assert r["value"] == pytest.approx(15.0, abs=1e-6)
        assert r["margin"] == pytest.approx(5.0, abs=1e-6)
    locks = [r for r in check.rows if r["case"] != "static"]
    assert len(locks) == 4 and all(r["stays_locked"] for r in locks)
    assert check.steady_margin == pytest.approx(math.degrees(math.atan(0.7)) - 20.0)
    # lock angle 10 deg: locks under 0.7 g, but also at the 15 deg static tilt
    bad = kd.studies.regulatory_check(lock_angle=math.radians(10.0), directions=(0.0, 90.0))
    assert not bad.passed
    assert all(not r["passed"] for r in bad.rows if r["case"] == "static")
    assert all(r["passed"] for r in bad.rows if r["case"] != "static")
    assert "FAIL" in bad.text() and "**fail**" in bad.markdown()
    json.dumps(bad.as_dict())
    # lock angle 36 deg (beyond the 30 deg wall and atan(0.7)): never locks at 0.7 g
    dull = kd.studies.regulatory_check(lock_angle=math.radians(36.0), directions=(0.0,))
    assert not dull.passed
    assert all(not r["passed"] for r in dull.rows if r["case"] != "static")


@pytest.mark.slow
def test_cli_pulse_and_pulse_file(tmp_path, capsys):
    out = tmp_path / "a"
    assert main(["run", "seatbelt-sensor", "--pulse", "halfsine", "--set", "peak_g=20",
                 "--set", "duration=0.1", "--t-end", "0.03", "--backend", "c",
                 "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "report: locks at t = 15.18 ms" in text and "no unintended release" in text
    report = json.loads((out / "summary.json").read_text())["report"]
    assert report["locked"] and report["lock_time"] == pytest.approx(0.015175, abs=2e-5)
    # the same pulse as a CSV record
    t = np.linspace(0.0, 0.1, 2001)
    acc = np.zeros((t.size, 3))
    acc[:, 0] = -HalfSinePulse(20.0, 0.1).acceleration(t)
    path = tmp_path / "crash.csv"
    write_pulse_csv(path, t, acc)
    out = tmp_path / "b"
    assert main(["run", "seatbelt-sensor", "--pulse-file", str(path), "--t-end", "0.03",
                 "--backend", "c", "--out", str(out), "--quiet"]) == 0
    from_file = json.loads((out / "summary.json").read_text())["report"]
    assert from_file["lock_time"] == pytest.approx(report["lock_time"], abs=1e-5)


def _one_line_error(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for word in words:
        assert word in err
    return err


def test_cli_pulse_errors(tmp_path, capsys):
    _one_line_error(capsys, ["run", "seatbelt-sensor", "--pulse", "bogus", "--quiet"],
                    "bogus", "halfsine")
    _one_line_error(capsys, ["run", "pendulum", "--pulse", "halfsine", "--quiet"],
                    "pendulum", "no pulse option")
    _one_line_error(capsys, ["run", "seatbelt-sensor", "--pulse-file",
                             str(tmp_path / "missing.csv"), "--quiet"], "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("t [s],ax [g],ay [g]\n0,0,0\n0.001,1,0\n0.002,2,0\n")
    _one_line_error(capsys, ["run", "seatbelt-sensor", "--pulse-file", str(bad),
                             "--quiet"], "bad.csv", "az")
    _one_line_error(capsys, ["run", "seatbelt-sensor", "--pulse", "step", "--set",
                             "pulse=none", "--quiet"], "once")


@pytest.mark.slow
def test_studies_from_the_command_line(tmp_path, capsys):
    """``kanedyn study seatbelt-regulatory`` / ``seatbelt-map`` give the Python results."""
    assert main(["study", "seatbelt-regulatory", "--quiet", "--out", str(tmp_path / "a")]) == 0
    assert "overall: PASS" in capsys.readouterr().out
    assert main(["study", "seatbelt-regulatory", "--quiet", "--set", "lock_angle_deg=10",
                 "--out", str(tmp_path / "b")]) == 0
    assert "overall: FAIL" in capsys.readouterr().out  # the 15 deg static tilt locks
    assert main(["study", "seatbelt-map", "--quiet", "--set", "peak_g=0.1,10",
                 "--set", "duration=0.05", "--set", "direction=0",
                 "--out", str(tmp_path / "m")]) == 0
    lines = (tmp_path / "m" / "seatbelt-map_lock_map.csv").read_text().splitlines()
    assert len(lines) == 3
    small, large = (line.split(",") for line in lines[1:])
    assert small[4] == "False" and large[4] == "True"
    python = kd.studies.seatbelt_lock_map(peak_g=[10.0], duration=[0.05], direction=[0.0])
    assert float(large[5]) == pytest.approx(python.lock_time(10.0, 0.05), rel=1e-9)
    assert (tmp_path / "m" / "seatbelt-map.png").stat().st_size > 10_000
    assert main(["study", "seatbelt-map", "--set", "peak_g=ten"]) == 2
    assert "peak_g" in capsys.readouterr().err
