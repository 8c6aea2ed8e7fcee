"""The command line's manners: a mistyped model name gets a suggestion, ``kanedyn
list`` fits 100 columns, every name given is checked before any derivation,
progress written to a file has no carriage returns, and an interrupted sweep
says how to resume it in the command's own syntax."""

import pytest

import kanedyn.models as models
from kanedyn.cli import main
from kanedyn.simulation import _sweep


@pytest.mark.parametrize("argv, suggestion", [
    (["run", "bicycle"], "did you mean whipple-bicycle?"),
    (["derive", "pendlum"], "did you mean pendulum?"),
    (["sweep", "oc3", "--grid", "m=1"], "did you mean oc3-spar?"),
    (["list", "four_bar"], "did you mean four-bar or n-four-bar?"),
    (["compare", "chain-3d"], "did you mean chain3d?"),
])
def test_a_mistyped_model_gets_did_you_mean(argv, suggestion, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and suggestion in err[0] and "unknown model" in err[0], err


def test_no_suggestion_when_nothing_is_close(capsys):
    assert main(["run", "zzzz"]) == 2
    err = capsys.readouterr().err
    assert "unknown model 'zzzz'" in err and "did you mean" not in err


def test_list_fits_100_columns_and_points_to_list_model(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert max(map(len, lines)) <= 100
    for name in models.REGISTRY:
        assert any(line.startswith(name + " ") for line in lines), name
    assert lines[-1] == "options, parameters and states of a model: kanedyn list MODEL"
    assert main(["list", "chain3d"]) == 0
    described = capsys.readouterr().out
    assert "options (--set NAME=VALUE)" in described and "style" in described


@pytest.mark.parametrize("argv, named", [
    (["run", "pendulum", "--set", "n=3"], "--set n: not an option, parameter or state of "
                                          "pendulum; parameters: g, l, m; states: q, u"),
    (["sweep", "pendulum", "--grid", "n=1,2"], "--grid n: not a parameter or state"),
    (["sweep", "pendulum", "--grid", "l=1,2", "--set", "n=3"], "--set n:"),
    (["equilibrium", "pendulum", "--set", "n=3"], "--set n:"),
    (["equilibrium", "pendulum", "--hold", "x"], "--hold x: not a state of pendulum"),
    (["compare", "pendulum", "--set", "n=3"], "--set n:"),
    (["compare", "pendulum", "--set", "q=3"], "--set q: compare takes model options"),
])
def test_every_name_is_checked_before_any_derivation(argv, named, tmp_path, capsys,
                                                     monkeypatch):
    monkeypatch.setattr(models.ModelDefinition, "derive",
                        lambda *a, **k: pytest.fail("derivation started"))
    if argv[0] in ("run", "sweep"):
        argv = [*argv, "--out", str(tmp_path / "out")]
    assert main([*argv, "--quiet"] if argv[0] != "compare" else argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and named in err[0], err


def test_progress_to_a_file_has_no_carriage_returns(tmp_path, capsys):
    assert main(["run", "pendulum", "--t-end", "0.5", "--points", "11", "--backend", "numpy",
                 "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "] deriving simple pendulum" in err and "\r" not in err


def test_interrupted_sweep_says_how_to_resume_in_cli_syntax(tmp_path, capsys, monkeypatch):
    original = _sweep.run_batch

    def interrupted(model, batch, *args, **kwargs):
        if batch[0][0] >= 2:
            raise KeyboardInterrupt
        return original(model, batch, *args, **kwargs)
    monkeypatch.setattr(_sweep, "run_batch", interrupted)
    out = tmp_path / "my sweep"
    argv = ["sweep", "pendulum", "--grid", "l=0.5:2:4", "--out", str(out), "--t-end", "0.2",
            "--scheduler", "serial", "--batch-size", "2", "--quiet", "--backend", "numpy"]
    assert main(argv) == 130
    err = capsys.readouterr().err.strip()
    assert err == (f"kanedyn: sweep interrupted: 2 of 4 runs saved in {out}; run the same "
                   f"command again (with --out '{out}') to finish it: the saved runs are "
                   "skipped")
    monkeypatch.setattr(_sweep, "run_batch", original)
    assert main(argv) == 0  # the same command finishes it
    assert "4 runs, 0 failed" in capsys.readouterr().out
