"""``kanedyn inverse``: in-process runs of the command."""

import csv

import numpy as np
import pytest

from kanedyn.cli import main


def test_inverse_3rrr_table_files_and_check(tmp_path, capsys):
    out = tmp_path / "inv"
    code = main(["inverse", "3rrr", "--trajectory", "sinusoid", "--points", "41",
                 "--out", str(out), "--check", "--quiet"])
    assert code == 0
    text = capsys.readouterr().out
    for name in ("base1", "base2", "base3", "power-balance residual", "closed form",
                 "forward check"):
        assert name in text
    for name in ("forces.csv", "causes.csv", "groups.csv", "power.csv", "forces.png",
                 "decomposition.png", "power.png"):
        assert (out / name).stat().st_size > 0
    rows = list(csv.reader(open(out / "forces.csv")))
    assert rows[0][:4] == ["t [s]", "x", "y", "phi"] and "base1 [N m]" in rows[0]
    assert len(rows) == 42
    # the printed peaks are those of the CSV
    data = np.array(rows[1:], float)
    peak = np.max(np.abs(data[:, rows[0].index("base2 [N m]")]))
    assert f"{peak:.6g} N m" in text
    error = float(text.split("largest pose error")[1].split()[0])
    assert error < 1e-7
    # the causes add up to the forces
    causes = list(csv.reader(open(out / "causes.csv")))
    head, values = causes[0], np.array(causes[1:], float)
    cols = [i for i, h in enumerate(head) if h.startswith("base1:")]
    total = data[:, rows[0].index("base1 [N m]")]
    assert np.allclose(values[:, cols].sum(axis=1), total, rtol=0, atol=1e-12 * peak + 1e-15)


def test_inverse_model_without_actuators_is_one_line_exit_2(capsys):
    assert main(["inverse", "pendulum", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "declares no actuators" in err


@pytest.mark.parametrize("argv, what", [
    (["inverse", "3rrr", "--trajectory", "circle"], "--trajectory"),
    (["inverse", "3rrr", "--points", "1"], "--points"),
    (["inverse", "3rrr", "--t-end", "-1"], "--t-end"),
    (["inverse", "3rrr", "--set", "nosuch=1", "--quiet"], "nosuch"),
])
def test_inverse_bad_arguments_are_one_line(argv, what, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and what in err


def test_inverse_unwritable_out_is_refused_before_the_model_is_built(tmp_path, capsys,
                                                                     monkeypatch):
    """``--out`` through a file: one line naming ``--out``, before the model's
    build (the Stewart platform's takes seconds)."""
    import kanedyn.cli._inverse as inverse

    def not_built(*args, **kwargs):
        raise AssertionError("the model was built before --out was checked")

    monkeypatch.setattr(inverse, "build", not_built)
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    assert main(["inverse", "stewart-platform", "--out", str(blocker / "sub"),
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out" in err and "is a file" in err


def test_inverse_set_changes_the_forces(capsys):
    """A heavier platform: the closed form still applies (masses are no geometry)."""
    assert main(["inverse", "3rrr", "--points", "11", "--quiet"]) == 0
    light = capsys.readouterr().out
    assert main(["inverse", "3rrr", "--points", "11", "--set", "m_p=3.0", "--quiet"]) == 0
    heavy = capsys.readouterr().out
    assert "closed form" in heavy and light != heavy
