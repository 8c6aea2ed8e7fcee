"""The kanedyn command line."""

import json
import re
import subprocess
import sys

import pytest

from kanedyn.cli import main


def test_list(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("pendulum", "chain3d", "rolling-disk", "chaplygin-sleigh", "four-bar",
                 "whipple-bicycle", "n-link-pendulum-on-cart"):
        assert name in out


def test_derive_explicit_prints_explicit_equations(capsys):
    assert main(["derive", "pendulum", "--quiet", "--explicit"]) == 0
    out = capsys.readouterr().out
    assert "mass_matrix[0, 0] = l**2*m" in out and "q' = u" in out
    assert "forcing[0] = -g*l*m*sin(q)" in out and "z0" not in out


def test_derive_prints_compact_text_by_default(capsys):
    """Compact form (named intermediates), plain text, whatever the model's size."""
    for argv in (["derive", "pendulum", "--quiet"],
                 ["derive", "chain3d", "--set", "n=3", "--quiet"]):
        assert main(argv) == 0
        out = capsys.readouterr().out
        assert "\\begin" not in out and "\\frac" not in out  # no LaTeX
        assert re.search(r"^z0 = ", out, re.M) and re.search(r"^mass_matrix\[0, 0\] = ",
                                                              out, re.M)


def test_derive_latex_with_option(capsys):
    assert main(["derive", "chain3d", "--set", "n=3", "--latex", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert r"\begin{aligned}" in out and "z_{" in out  # compact form for this size


def test_run_writes_outputs(tmp_path, capsys):
    out_dir = tmp_path / "run"
    code = main(["run", "four-bar", "--t-end", "0.5", "--out", str(out_dir),
                 "--set", "m_b=1.5", "--set", "u1=1.0", "--quiet"])
    assert code == 0
    for name in ("four-bar.csv", "four-bar.png", "summary.json"):
        assert (out_dir / name).exists()
    summary = json.loads((out_dir / "summary.json").read_text())
    assert summary["success"] and summary["constants"]["m_b"] == 1.5
    assert summary["initial_state"]["u1"] == 1.0
    assert summary["max_constraint_residual"] < 1e-6
    text = capsys.readouterr().out
    assert "energy drift" in text and "max constraint residual" in text


def test_run_with_constraint_forces(tmp_path):
    out_dir = tmp_path / "run"
    assert main(["run", "pendulum", "--set", "tension=true", "--t-end", "0.2",
                 "--out", str(out_dir), "--quiet"]) == 0
    header = (out_dir / "pendulum.csv").read_text().splitlines()[0].split(",")
    assert "T" in header


def test_bad_set_names_the_key(capsys):
    assert main(["run", "pendulum", "--set", "bogus=1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "bogus" in err and "parameters" in err


@pytest.mark.slow
def test_demo(tmp_path):
    """The README's main job, as a console script."""
    proc = subprocess.run(
        [sys.executable, "-m", "kanedyn.cli", "demo", "--out", str(tmp_path), "--t-end", "2",
         "--quiet"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    match = re.search(r"self-stable speed range: ([\d.]+) < v < ([\d.]+)", proc.stdout)
    assert match
    assert abs(float(match.group(1)) - 4.29238253634111) < 1e-9
    assert abs(float(match.group(2)) - 6.02426201538837) < 1e-9
    for name in ("bicycle_eigenvalues.png", "bicycle_ride.png", "bicycle_ride.csv"):
        assert (tmp_path / name).exists()
