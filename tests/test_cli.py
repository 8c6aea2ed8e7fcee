"""The kanedyn command line."""

import json
import os
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
    assert "energy balance over the run" in text and "max constraint residual" in text
    assert summary["energy_terms"]["relative_residual"] < 1e-6


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


# ------------------------------------------------------------ bad arguments
BAD_ARGUMENTS = [
    (["run", "pendulum", "--method", "Foo"], "--method"),
    (["compare", "pendulum", "--integrator", "Foo"], "--integrator"),
    (["run", "chain3d", "--set", "n=abc"], "n"),
    (["run", "chain3d", "--set", "n=0"], "n"),
    (["run", "n-link-pendulum-on-cart", "--set", "n=0"], "n"),
    (["run", "snake", "--set", "n=1"], "n"),
    (["run", "n-four-bar", "--set", "n=0"], "n"),
    (["run", "spin-up-beam", "--set", "n_modes=0"], "n_modes"),
    (["run", "flexible-robot", "--set", "n_elements=0"], "n_elements"),
    (["run", "bouncing-ball", "--set", "restitution=2"], "restitution"),
    (["derive", "chain3d", "--set", "n=-1"], "n"),
    (["run", "pendulum", "--set", "m=abc"], "m"),
    (["run", "pendulum", "--set", "m=nan"], "m"),
    (["run", "pendulum", "--t-end", "0"], "--t-end"),
    (["run", "pendulum", "--t-end", "-1"], "--t-end"),
    (["run", "pendulum", "--t-end", "inf"], "--t-end"),
    (["run", "pendulum", "--t-end", "abc"], "--t-end"),
    (["run", "pendulum", "--points", "0"], "--points"),
    (["run", "pendulum", "--points", "1"], "--points"),
    (["run", "pendulum", "--rtol", "0"], "--rtol"),
    (["run", "pendulum", "--rtol", "-1e-8"], "--rtol"),
    (["run", "pendulum", "--atol", "0"], "--atol"),
    (["run", "pendulum", "--atol", "nan"], "--atol"),
    (["compare", "pendulum", "--rtol", "0"], "--rtol"),
    (["compare", "pendulum", "--t-end", "-2"], "--t-end"),
    (["run", "pendulum", "--backend", "fortran"], "--backend"),
    (["list", "bogus"], "bogus"),
]


@pytest.mark.parametrize("argv, named", BAD_ARGUMENTS,
                         ids=[" ".join(a[2:]) or a[1] for a, _ in BAD_ARGUMENTS])
def test_bad_argument_is_one_line_and_exit_code_2(argv, named, tmp_path, capsys,
                                                  monkeypatch):
    monkeypatch.chdir(tmp_path)  # where the default output folder would appear
    code = main([*argv, "--quiet"] if argv[0] in ("run", "derive") else argv)
    captured = capsys.readouterr()
    assert code == 2
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert named in lines[0] and "error" in lines[0] and "Traceback" not in captured.err
    assert not (tmp_path / "kanedyn-out").exists()


def test_bad_arguments_are_refused_before_any_work(monkeypatch):
    """Argument errors come before the derivation (which would take time)."""
    import kanedyn.models as models

    def refuse(*args, **kwargs):
        raise AssertionError("derivation started")
    monkeypatch.setattr(models.ModelDefinition, "derive", refuse)
    for argv in (["run", "pendulum", "--method", "Foo"], ["run", "pendulum", "--t-end", "0"],
                 ["run", "pendulum", "--points", "0"], ["run", "chain3d", "--set", "n=0"]):
        assert main(argv) == 2


def test_output_folder_under_a_file_is_refused_before_the_simulation(tmp_path, capsys,
                                                                    monkeypatch):
    import kanedyn.models as models
    monkeypatch.setattr(models.ModelDefinition, "derive",
                        lambda *a, **k: pytest.fail("derivation started"))
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a folder")
    for argv in (["run", "pendulum", "--out", str(blocker / "out"), "--quiet"],
                 ["run", "pendulum", "--out", str(blocker), "--quiet"],
                 ["compare", "pendulum", "--plot", "--out", str(blocker / "x")],
                 ["demo", "--out", str(blocker), "--quiet"],
                 ["demo", "--out", str(blocker / "out"), "--quiet"],
                 ["sweep", "pendulum", "--grid", "m=1,2", "--out", str(blocker), "--quiet"],
                 ["inverse", "stewart-platform", "--out", str(blocker), "--quiet"],
                 ["study", "seatbelt-regulatory", "--out", str(blocker), "--quiet"],
                 ["derive", "pendulum", "--c", str(blocker / "model.c"), "--quiet"]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and ("--out" in err[0] or "--c" in err[0]), err
        assert f"{blocker} is a file, not a folder" in err[0], err
    assert main(["derive", "pendulum", "--c", str(tmp_path), "--quiet"]) == 2
    assert capsys.readouterr().err == (f"kanedyn: error: --c {tmp_path}: is a folder; give "
                                       "the name of a file\n")


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0,
                    reason="the superuser may write into read-only folders")
def test_read_only_output_folder_is_refused(tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        assert main(["run", "pendulum", "--out", str(locked / "out"), "--quiet"]) == 2
    finally:
        locked.chmod(0o755)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out" in err[0]


def test_read_only_output_folder_is_refused_as_superuser_too(tmp_path, capsys, monkeypatch):
    """The write probe's failure (as on a read-only file system) is reported."""
    import tempfile

    def read_only(*args, **kwargs):
        raise OSError(30, "Read-only file system")
    monkeypatch.setattr(tempfile, "TemporaryFile", read_only)
    assert main(["run", "pendulum", "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out" in err[0] and "Read-only" in err[0]


def test_help_and_version_exit_code_0(capsys):
    assert main(["--version"]) == 0
    assert main(["run", "--help"]) == 0
    out = capsys.readouterr().out
    assert "--backend {auto,numpy,c}" in out


def test_list_model_shows_options_parameters_and_states(capsys):
    assert main(["list", "n-link-pendulum-on-cart"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^n\s+int\s+3\s*$", out, re.M)  # option, type, default
    assert re.search(r"^m_c\s+2\s+kg\s*$", out, re.M)  # parameter, default, unit
    assert re.search(r"^g\s+9\.81\s+m/s\^2\s*$", out, re.M)
    assert re.search(r"^q1\s+0\.4\s+rad\s*$", out, re.M)  # state, initial value, unit
    assert re.search(r"^q0\s+0\s+m\s*$", out, re.M)        # the cart's position
    assert re.search(r"^u3\s+0\s+rad/s\s*$", out, re.M)


def test_list_model_marks_dependent_states(capsys):
    assert main(["list", "four-bar"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^q2\s+0\.3\s+rad\s+dependent", out, re.M)
    assert re.search(r"^q1\s+1\.2\s+rad\s*$", out, re.M)


def test_compare_quiet_prints_only_the_table(capsys):
    assert main(["compare", "pendulum", "--methods", "kane,lagrange", "--t-end", "0.2",
                 "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "Each formulation starts" not in out
    assert "kane" in out and "lagrange" in out


def test_run_with_the_c_backend_matches_numpy(tmp_path):
    from kanedyn.numerics.backends import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    summaries = {}
    for backend in ("numpy", "c"):
        out = tmp_path / backend
        assert main(["run", "four-bar", "--t-end", "0.3", "--backend", backend, "--out",
                     str(out), "--quiet", "--rtol", "1e-10", "--atol", "1e-10"]) == 0
        summaries[backend] = (out / "four-bar.csv").read_text().splitlines()
    last = [[float(x) for x in summaries[b][-1].split(",")] for b in ("numpy", "c")]
    assert last[0] == pytest.approx(last[1], rel=1e-7, abs=1e-9)


# ------------------------------------------------------------ --backend auto
def test_backend_auto_is_c_with_a_compiler_and_numpy_without(tmp_path, capsys, monkeypatch):
    from kanedyn.numerics.backends import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler on this machine (auto is numpy; tested below)")
    assert main(["run", "pendulum", "--t-end", "0.2", "--out", str(tmp_path / "a"),
                 "--quiet"]) == 0
    assert json.loads((tmp_path / "a" / "summary.json").read_text())["backend"] == "c"
    assert "backend: c" in capsys.readouterr().out
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    assert main(["run", "pendulum", "--t-end", "0.2", "--out", str(tmp_path / "b"),
                 "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "backend: numpy (" in printed and "no-such-compiler" in printed
    assert json.loads((tmp_path / "b" / "summary.json").read_text())["backend"] == "numpy"
    # asked for by name, a missing compiler is an error naming the option
    assert main(["run", "pendulum", "--backend", "c", "--out", str(tmp_path / "c"),
                 "--quiet"]) == 2
    assert "--backend c:" in capsys.readouterr().err
    assert main(["run", "pendulum", "--backend", "numpy", "--t-end", "0.2",
                 "--out", str(tmp_path / "d"), "--quiet"]) == 0
    assert json.loads((tmp_path / "d" / "summary.json").read_text())["backend"] == "numpy"


def test_backend_auto_runs_on_numpy_what_c_cannot_build(tmp_path, capsys, monkeypatch):
    """A model the C backend cannot generate runs on numpy under auto, with a note."""
    from kanedyn.models import ModelDefinition
    from kanedyn.numerics.backends import CodegenError, compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler: auto is numpy without trying C")
    numeric = ModelDefinition.numeric

    def no_c(self, eom=None, backend="numpy", **options):
        if backend == "c":
            raise CodegenError("the C backend cannot generate code for f(x) (a test)")
        return numeric(self, eom, backend=backend, **options)

    monkeypatch.setattr(ModelDefinition, "numeric", no_c)
    assert main(["run", "pendulum", "--t-end", "0.2", "--out", str(tmp_path / "a"),
                 "--quiet"]) == 0
    assert "backend: numpy (the C backend cannot build this model: the C backend " \
           "cannot generate code for f(x)" in capsys.readouterr().out
    assert main(["run", "pendulum", "--backend", "c", "--t-end", "0.2",
                 "--out", str(tmp_path / "b"), "--quiet"]) == 2  # asked for: an error
    assert "f(x)" in capsys.readouterr().err
