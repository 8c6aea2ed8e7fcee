"""The oc3-spar turbine's run figure and the ``oc3-operating`` study (short runs)."""

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.cli import main


@pytest.mark.slow
def test_run_oc3_spar_spinning_writes_the_turbine_figure(tmp_path):
    """kanedyn run oc3-spar with the spinning rotor and the controller writes the story
    figure; the series it draws hold the controller's rated speed and power at 18 m/s."""
    argv = ["run", "oc3-spar", "--set", "rotor=spinning", "--set", "controller=on",
            "--set", "wind_speed=18", "--t-end", "2", "--quiet", "--out", str(tmp_path)]
    assert main(argv) == 0
    assert (tmp_path / "oc3-spar_story.png").stat().st_size > 10_000
    from kanedyn.analysis._oc3_turbine_plot import oc3_turbine_series
    d = kd.models.oc3_spar(rotor="spinning", controller="on", wind_speed=18.0)
    m = d.numeric(backend="c")
    s = oc3_turbine_series(d, m, d.initial(m)[:, None])
    # the operating point of the model card: 12.1 rpm, 14.80 deg, 5.000 MW electrical
    assert s["rotor_speed"][0] == pytest.approx(12.1, rel=1e-3)
    assert s["blade_pitch"][0] == pytest.approx(14.80, abs=0.01)
    assert s["generator_power"][0] == pytest.approx(5.0, rel=1e-3)


@pytest.mark.slow
def test_oc3_operating_study_tabulates_parked_and_operating_runs(tmp_path):
    # the NumPy backend: the study's code is the same on both, and its table is C's to
    # every digit tabulated (measured); on C a cold cache made the run cost 139 s of CPU,
    # 93 s of them gcc's (eight model modules and five derivative modules, each of these
    # used for a few Newton steps or one linearization), against 53 s on NumPy
    result = kd.studies.run_study("oc3-operating", out=tmp_path, wind_speeds="18",
                                  duration=20.0, settle=5.0, backend="numpy")
    columns, rows = result.table("statistics")
    assert [(r[0], r[2]) for r in rows] == [(0.0, k) for k in ("off", "tmd", "tmdi")] + \
        [(18.0, k) for k in ("off", "tmd", "tmdi")]
    assert (tmp_path / "oc3-operating.png").exists()
    operating = rows[3]
    # 5-20 s of the start-up from the upright platform: 11.84 rpm measured (12.1 rpm at
    # the operating point; 12.09 rpm over 100-600 s of the study's run)
    assert operating[columns.index("mean rotor speed [rpm]")] == pytest.approx(12.1, rel=0.05)
    assert rows[0][columns.index("mean rotor speed [rpm]")] == ""   # parked: no rotor speed
    assert all(np.isfinite(r[4]) and r[4] > 0 for r in rows)
