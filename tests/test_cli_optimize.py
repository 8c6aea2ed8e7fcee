"""``kanedyn optimize``: in-process runs of the command (named problems, their
options, files, exit codes)."""

import csv

import numpy as np
import pytest

from kanedyn.cli import main

pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (the test extra)")


def test_optimize_lists_the_problems(capsys):
    assert main(["optimize"]) == 0
    text = capsys.readouterr().out
    for name in ("pendulum:", "swing-up", "flexible-robot:", "rest-to-rest", "minimum-time",
                 "whipple-bicycle:", "lane-change", "offset=3.0", "shuttle-arm:",
                 "minimum-energy", "margin=10.0", "out-parallel-6dof:", "least-peak-force",
                 "force_limit=200.0"):
        assert name in text


def test_optimize_pendulum_bound_files_and_the_printed_objective(tmp_path, capsys):
    """The swing-up with the torque bound replaced: the CSV holds the nodes,
    the bound holds at each and is the one the printed ratio is to, the ends
    are those asked for, and the printed objective is the trapezoid rule of
    the CSV's torque squared (what the trapezoidal collocation minimizes),
    computed here.  (Which local optimum IPOPT reaches depends on the BLAS
    kernels: one with the bound active, 18.12, and one below it, 9.50, with
    a peak of 1.488, were both seen.)"""
    out, figure = tmp_path / "swing.csv", tmp_path / "swing.png"
    code = main(["optimize", "pendulum", "--nodes", "101", "--bound", "tau=-1.8:1.8",
                 "--output", str(out), "--plot", str(figure), "--quiet", "--backend",
                 "numpy"])
    text = capsys.readouterr().out
    assert code == 0, text
    rows = list(csv.reader(open(out)))
    assert rows[0] == ["t", "point", "q", "u", "tau"]
    assert len(rows) == 102 and {r[1] for r in rows[1:]} == {"node"}
    t, q, u, tau = (np.array([float(r[k]) for r in rows[1:]]) for k in (0, 2, 3, 4))
    assert np.max(np.abs(tau)) <= 1.8 + 1e-7
    ratio = float(text.split("(where the NLP bounds it) ")[1].split()[0].rstrip(";"))
    assert abs(ratio - np.max(np.abs(tau)) / 1.8) < 1e-5
    np.testing.assert_allclose([q[0], u[0], q[-1], u[-1]], [0, 0, np.pi, 0], atol=1e-7)
    printed = float(text.split("objective ")[1].split()[0].rstrip(";"))
    assert abs(printed - np.trapezoid(tau ** 2, t)) < 1e-6 * printed
    assert figure.stat().st_size > 0
    assert "follows the collocated angle" in text


def test_optimize_hermite_simpson_csv_has_the_midpoints(tmp_path, capsys):
    out = tmp_path / "hs.csv"
    code = main(["optimize", "pendulum", "--nodes", "41", "--method", "hermite-simpson",
                 "--output", str(out), "--quiet", "--backend", "numpy"])
    assert code == 0, capsys.readouterr().out
    rows = list(csv.reader(open(out)))[1:]
    assert len(rows) == 81
    assert [r[1] for r in rows[:3]] == ["node", "midpoint", "node"]
    t = np.array([float(r[0]) for r in rows])
    assert np.all(np.diff(t) > 0)


def test_optimize_lgr_csv_has_the_interior_points(tmp_path, capsys):
    """--method lgr --degree 3: each interval's two interior Radau points in
    the CSV between its nodes, at the Radau positions; --degree without
    lgr is refused (exit code 2), naming the method."""
    out = tmp_path / "lgr.csv"
    code = main(["optimize", "pendulum", "--nodes", "21", "--method", "lgr", "--degree", "3",
                 "--output", str(out), "--quiet", "--backend", "numpy"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "21 nodes, lgr of degree 3" in text
    rows = list(csv.reader(open(out)))[1:]
    assert len(rows) == 21 + 20 * 2
    assert [r[1] for r in rows[:4]] == ["node", "interior", "interior", "node"]
    t = np.array([float(r[0]) for r in rows[:4]])
    np.testing.assert_allclose((t[1:3] - t[0]) / (t[3] - t[0]),
                               [(4 - np.sqrt(6)) / 10, (4 + np.sqrt(6)) / 10], rtol=1e-12)
    assert main(["optimize", "pendulum", "--degree", "3", "--quiet"]) == 2
    assert "--degree is for --method lgr (the problem's method is trapezoid)" in \
        capsys.readouterr().err


def test_optimize_exit_1_when_ipopt_fails(capsys):
    """The iteration limit reached: exit code 1, the summary says so."""
    code = main(["optimize", "pendulum", "--nodes", "51", "--max-iter", "3", "--quiet",
                 "--backend", "numpy"])
    text = capsys.readouterr().out
    assert code == 1
    assert "NOT solved" in text and "maximum number of iterations" in text
    # the last iterate is not called optimal anywhere in the summary
    assert "optimal" not in text and "last-iterate (not solved) torque simulated" in text


@pytest.mark.slow
def test_optimize_unsolved_flexible_robot_table_is_not_optimal(tmp_path, capsys):
    """``--max-iter 3`` on the minimum-time rotation (few nodes): the table's
    column is the last iterate's, and no line calls it optimal."""
    code = main(["optimize", "flexible-robot", "--problem", "minimum-time", "--nodes", "21",
                 "--max-iter", "3", "--set", "n_modes=1", "--set", "after=0.2", "--quiet",
                 "--plot", str(tmp_path / "robot.png")])
    text = capsys.readouterr().out
    assert code == 1, text
    assert "optimal" not in text, text
    header = next(line for line in text.splitlines() if "sine pulse" in line)
    assert "last-iterate (not solved)" in header
    assert (tmp_path / "robot.png").stat().st_size > 0


@pytest.mark.parametrize("method", ["trapezoid", "hermite-simpson"])
def test_optimize_exact_hessian_reaches_the_same_optimum(method, capsys):
    """--hessian exact: the same swing-up optimum as IPOPT's limited-memory
    Hessian (to 1e-6 of the objective), in fewer iterations; Hermite-Simpson
    (interior points) too."""
    found = {}
    for hessian in ("limited-memory", "exact"):
        assert main(["optimize", "pendulum", "--nodes", "101", "--hessian", hessian,
                     "--method", method, "--quiet", "--backend", "numpy"]) == 0
        text = capsys.readouterr().out
        objective = float(text.split("objective ")[1].split()[0].rstrip(";"))
        iterations = int(text.split(" iterations in ")[0].rsplit(" ", 1)[1])
        found[hessian] = objective, iterations
    assert found["exact"][0] == pytest.approx(found["limited-memory"][0], rel=1e-6)
    assert found["exact"][1] < found["limited-memory"][1]


@pytest.mark.parametrize("argv, what", [
    (["optimize", "four-bar"], "no optimal-control problem is defined on 'four-bar'"),
    (["optimize", "pendulum", "--problem", "cartwheel"], "cartwheel"),
    (["optimize", "pendulum", "--bound", "tau=2:1"], "lower bound 2 is above"),
    (["optimize", "pendulum", "--bound", "tau2"], "NAME=LOW:HIGH"),
    (["optimize", "pendulum", "--bound", "zz=-1:1", "--quiet"], "zz"),
    (["optimize", "pendulum", "--set", "zz=1", "--quiet"], "--set zz"),
    (["optimize", "pendulum", "--method", "rk4"], "rk4"),
    (["optimize", "pendulum", "--nodes", "1"], "--nodes"),
    (["optimize", "pendulum", "--hessian", "bfgs"], "--hessian"),
    (["optimize", "whipple-bicycle", "--hessian", "exact", "--quiet", "--backend", "numpy"],
     'hessian="exact" is not available for a model with constraints'),
    (["optimize", "flexible-robot", "--set", "torque_input=false", "--quiet"],
     "torque_input"),
    (["optimize", "pendulum", "--set", "limit=-1", "--quiet"],
     "option limit must be a positive number, not -1"),
    (["optimize", "flexible-robot", "--problem", "minimum-time", "--set",
      "pulse_duration=0", "--quiet"], "option pulse_duration must be a positive number, not 0"),
    (["optimize", "out-parallel-6dof", "--set", "force_limit=-200", "--quiet"],
     "option force_limit must be a positive number, not -200"),
])
def test_optimize_bad_arguments_are_one_line_exit_2(argv, what, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and what in err, err


@pytest.mark.slow
def test_optimize_flexible_robot_against_the_pulse(flexible_robot_least_effort, monkeypatch,
                                                   tmp_path, capsys):
    """The elastic robot's rest-to-rest rotation from the command line, two
    modes: the residual vibration of the optimal torque simulated is far
    below the pulse's (the table's row).  The link is left free 0.5 s after
    (``--set after=0.5``, default 2 s): the largest deflections come within
    0.05 s, the residuals are those of the 2-s run to the last digit
    (measured).  The command's call of the problem's function is checked
    argument by argument; the study it returns is the session's (conftest's
    ``flexible_robot_least_effort``, the same function with the same
    arguments, the command's empty bounds, constants and IPOPT options being
    the function's defaults, its backend "auto" the C backend where a compiler
    is found), not solved a second time: the command's own path through the
    study is ``test_optimize_unsolved_flexible_robot_table_is_not_optimal``'s."""
    import dataclasses

    from kanedyn.analysis import OPTIMAL_PROBLEMS, available_problems
    available_problems()
    problem = OPTIMAL_PROBLEMS["flexible-robot"]["rest-to-rest"]
    calls = []

    def shared(**kwargs):
        from kanedyn.numerics.backends import compiler_command
        calls.append(kwargs)
        if compiler_command() is None:  # backend "auto" is NumPy here: solved anew
            return problem.function(**kwargs)
        return flexible_robot_least_effort  # "auto" is C here, as the session's
    monkeypatch.setitem(OPTIMAL_PROBLEMS["flexible-robot"], "rest-to-rest",
                        dataclasses.replace(problem, function=shared))
    code = main(["optimize", "flexible-robot", "--set", "n_modes=2", "--set", "after=0.5",
                 "--quiet", "--plot", str(tmp_path / "robot.png")])
    assert calls == [dict(nodes=None, method=None, duration=None, bounds={}, constants={},
                          model_options={"n_modes": 2}, backend="auto", ipopt={}, after=0.5)]
    text = capsys.readouterr().out
    assert code == 0, text
    row = next(line for line in text.splitlines() if "residual tip" in line)
    optimal, pulse = map(float, row.split()[-2:])
    assert optimal < pulse / 100
    assert (tmp_path / "robot.png").stat().st_size > 0


@pytest.mark.slow
def test_optimize_bicycle_problem_option(capsys):
    """--set offset=1 (a problem option) and --duration: the simulated run
    ends 1 m aside."""
    code = main(["optimize", "whipple-bicycle", "--set", "offset=1", "--nodes", "31",
                 "--duration", "3", "--quiet"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "lane change of 1 m at 5 m/s in 3 s" in text
    aside = float(text.split("ends ")[1].split(" m aside")[0])
    assert abs(aside - 1.0) < 1e-2


@pytest.mark.slow
def test_the_problems_are_studies_too(tmp_path, capsys):
    """``kanedyn study whipple-bicycle-lane-change``: the problem's options and
    the model's, the trajectory and numbers as CSV, the figure."""
    code = main(["study", "whipple-bicycle-lane-change", "--set", "offset=1", "--set",
                 "nodes=31", "--out", str(tmp_path), "--quiet"])
    text = capsys.readouterr().out
    assert code == 0, text
    rows = list(csv.reader(open(tmp_path / "whipple-bicycle-lane-change_trajectory.csv")))
    assert rows[0][:3] == ["t", "point", "q1"] and rows[0][-1] == "T_delta"
    assert len(rows) == 1 + 61  # 31 nodes and 30 midpoints
    numbers = dict(csv.reader(open(tmp_path / "whipple-bicycle-lane-change_numbers.csv")))
    assert abs(float(numbers["lateral"]) - 1.0) < 1e-2
    assert (tmp_path / "whipple-bicycle-lane-change.png").stat().st_size > 0


@pytest.mark.slow
def test_optimize_out_parallel_in_one_second_within_a_limit(tmp_path, capsys):
    """``--duration 1 --set force_limit=180``: the quintic needs 262.5 N, the
    least peak (176.6 N) fits under 180 N; the CSV's forces, nodes and
    midpoints, keep the limit."""
    out = tmp_path / "platform.csv"
    code = main(["optimize", "out-parallel-6dof", "--nodes", "21", "--duration", "1",
                 "--set", "force_limit=180", "--output", str(out), "--plot",
                 str(tmp_path / "platform.png"), "--quiet"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "quintic 262.509" in text and "within +-180 N" in text
    rows = list(csv.DictReader(open(out)))
    assert len(rows) == 41
    forces = np.array([[float(row[f"F_carriage{j}"]) for j in range(1, 7)] for row in rows])
    assert 176.0 < np.max(np.abs(forces)) <= 180.0
    assert (tmp_path / "platform.png").stat().st_size > 0


def test_optimize_passes_a_text_option_as_written(monkeypatch, capsys):
    """``--set booms=flexible`` reaches the problem's function as the text
    ``"flexible"`` (not parsed as a number), next to a numeric option and a
    model option; the problem is replaced by a recorder (the real study is
    ``tests/test_optimal_studies.py``'s)."""
    import dataclasses
    import types

    from kanedyn.analysis import OPTIMAL_PROBLEMS, available_problems
    available_problems()
    seen = {}

    def record(**kwargs):
        seen.update(kwargs)
        return types.SimpleNamespace(summary="recorded",
                                     result=types.SimpleNamespace(success=True))
    problem = OPTIMAL_PROBLEMS["shuttle-arm"]["minimum-energy"]
    monkeypatch.setitem(OPTIMAL_PROBLEMS["shuttle-arm"], "minimum-energy",
                        dataclasses.replace(problem, function=record))
    assert main(["optimize", "shuttle-arm", "--set", "booms=flexible", "--set",
                 "margin=20", "--set", "payload=false", "--quiet"]) == 0
    assert seen["booms"] == "flexible" and seen["margin"] == 20.0
    assert seen["model_options"] == {"payload": False}
    assert "recorded" in capsys.readouterr().out
