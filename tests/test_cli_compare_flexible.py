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


def test_flexible_models_take_their_beam_from_set_and_list_its_units(capsys):
    """The first reduced frequency follows the cantilever's closed form
    (1.8751^2 sqrt(EI / (mu L^4)) / 2 pi) for the length, EI and mass per length given
    on the command line; kanedyn list shows the options with their units."""
    import math

    from kanedyn.cli._options import parse_sets
    from kanedyn.models import build
    for model in ("spin-up-beam", "flexible-robot"):
        options, _ = parse_sets(model, ["length=2.5", "EI=120", "mass_per_length=0.8",
                                        "n_elements=12"])
        member = build(model, **options).symbols["member"]
        closed_form = 1.8751041 ** 2 * math.sqrt(120 / (0.8 * 2.5 ** 4)) / (2 * math.pi)
        assert abs(member.reduced_frequencies[0] / closed_form - 1) < 1e-3
    assert main(["list", "spin-up-beam"]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line.strip()}
    assert rows["EI"][-2:] == ["N", "m^2"] and rows["spin_up_time"][-1] == "s"
    assert rows["mass_per_length"][-1] == "kg/m" and rows["omega_s"][-1] == "rad/s"
