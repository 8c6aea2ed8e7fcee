"""``kanedyn study oc3-campbell``: its CSV and PNG, and its frequencies are kd.campbell's."""

import csv
import math

import numpy as np
import pytest

import kanedyn as kd
from kanedyn._errors import KanedynError
from kanedyn.cli import main


@pytest.mark.slow
def test_oc3_campbell_study_writes_its_table_and_figure_with_campbells_frequencies(tmp_path):
    code = main(["study", "oc3-campbell", "--set", "n_speeds=3", "--set", "max_rpm=12.1",
                 "--set", "drivetrain=rigid", "--out", str(tmp_path), "--quiet"])
    assert code == 0
    table, figure = tmp_path / "oc3-campbell_modes.csv", tmp_path / "oc3-campbell.png"
    assert figure.stat().st_size > 10_000
    with table.open() as handle:
        rows = list(csv.reader(handle))
    header, values = rows[0], np.array(rows[1:], dtype=object)
    assert header[0] == "rotor speed [rpm]" and len(values) == 3
    np.testing.assert_allclose(values[:, 0].astype(float), [0.0, 6.05, 12.1])
    # the same model and speeds through kd.campbell directly
    from kanedyn.models import oc3_spar
    d = oc3_spar(rotor="spinning", controller="off", drivetrain="rigid", tower_modes=2)
    m = d.numeric(backend="c")
    diagram = kd.campbell(m, np.array([0.0, 6.05, 12.1]) * math.pi / 30, d.initial(m),
                          speed="rotor_speed", azimuth="azimuth")
    for j, label in enumerate(diagram.labels):
        column = header.index(f"{label} frequency [Hz]")
        np.testing.assert_allclose(values[:, column].astype(float),
                                   diagram.frequencies[:, j], rtol=1e-9)
    # rigid drivetrain: no shaft mode; the platform's and the tower's modes only
    assert not any("shaft" in name for name in header)


def test_oc3_campbell_study_refuses_bad_speeds():
    with pytest.raises(KanedynError, match="n_speeds"):
        kd.studies.run_study("oc3-campbell", n_speeds=1)
    with pytest.raises(KanedynError, match="max_rpm"):
        kd.studies.run_study("oc3-campbell", max_rpm=-1.0)
