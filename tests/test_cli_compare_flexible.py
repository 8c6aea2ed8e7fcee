"""kanedyn compare on a model with flexible bodies: Radau by default, said at the start;
the Newton-Euler columns left out with the reason, the comparison complete."""

from kanedyn.cli import main


def test_flexible_shuttle_arm_compares_without_the_newton_euler_columns(capsys):
    code = main(["compare", "shuttle-arm", "--methods", "kane,lagrange", "--set",
                 "flexible_booms=true", "--t-end", "0.05", "--quiet"])
    out = capsys.readouterr().out
    assert code == 0
    assert "integrator: Radau for every formulation (shuttle-arm has flexible bodies" in out
    assert "N-E columns n/a: the Newton-Euler check covers rigid bodies" in out
    rows = [line.split() for line in out.splitlines() if line.startswith(("kane ", "lagrange "))]
    assert len(rows) == 2 and all(row[5:8] == ["n/a"] * 3 for row in rows)
    # the two formulations agree on the motion
    assert float(rows[1][4]) < 1e-8


def test_a_rigid_model_keeps_rk45_and_its_newton_euler_columns(capsys):
    code = main(["compare", "four-bar", "--methods", "kane", "--t-end", "0.05", "--quiet"])
    out = capsys.readouterr().out
    assert code == 0 and "RK45" in out and "n/a" not in out and "integrator: Radau" not in out
