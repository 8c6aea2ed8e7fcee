"""The out-parallel manipulator from a TOML machine file (the built-in machine
reproduced exactly, changed masses as --set of them, bad files refused by key) and
actuator limits checked along the path with the first violation named."""

import numpy as np
import pytest

from kanedyn import KanedynError
from kanedyn.analysis import check_actuator_limits, inverse_study
from kanedyn.cli import main
from kanedyn.models import build, out_parallel_6dof, read_out_parallel_machine

BUILT_IN = """# the built-in out-parallel-6dof
[geometry]
R_b = 0.6
r_p = 0.25
L = 0.6
h = 0.8
gamma_b_deg = 15.0
gamma_p_deg = 45.0

[masses]
m_p = {m_p}
m_s = 2.0
m_c = 5.0

[drive]
lead = 0.01
J_rotor = 2.0e-4
J_coupler = 1.0e-4
J_screw = 3.0e-4
eta = 0.9
eta_back = 0.8
"""


def _machine(tmp_path, text=None, m_p="20.0", name="m.toml"):
    path = tmp_path / name
    path.write_text(BUILT_IN.format(m_p=m_p) if text is None else text)
    return path


@pytest.fixture(scope="module")
def built_in():
    definition = build("out-parallel-6dof")
    model = definition.numeric(definition.derive())
    return definition, model, inverse_study(definition, "sinusoid", points=21, model=model)


def test_a_machine_file_of_the_built_in_machine_gives_its_forces(tmp_path, built_in):
    _, _, ref = built_in
    definition = out_parallel_6dof(read_out_parallel_machine(_machine(tmp_path)))
    got = inverse_study(definition, "sinusoid", points=21)
    assert np.max(np.abs(got.forces - ref.forces)) <= 1e-12 * np.max(np.abs(ref.forces))
    assert np.max(np.abs(got.motors.torque - ref.motors.torque)) <= 1e-12


def test_changed_masses_in_the_file_match_set_of_those_constants(tmp_path, built_in):
    definition, _, _ = built_in
    machine = read_out_parallel_machine(_machine(tmp_path, m_p="12.5"))
    got = inverse_study(out_parallel_6dof(machine), "sinusoid", points=21)
    ref = inverse_study(definition, "sinusoid", points=21, constants={"m_p": 12.5})
    scale = np.max(np.abs(ref.forces))
    assert np.max(np.abs(got.forces - ref.forces)) <= 1e-12 * scale
    # and it is a different machine: 7.5 kg less platform is ~12 N less per carriage
    assert np.max(np.abs(got.forces - built_in[2].forces)) > 5.0


def test_a_changed_geometry_moves_the_home_pose_and_keeps_closed_form_ik(tmp_path):
    text = BUILT_IN.format(m_p=20.0).replace("h = 0.8", "h = 0.75").replace(
        "gamma_b_deg = 15.0", "gamma_b_deg = 20.0")
    definition = out_parallel_6dof(read_out_parallel_machine(_machine(tmp_path, text)))
    study = inverse_study(definition, "quintic", points=11)
    assert study.ik_method == "closed form"
    assert study.pose[0, 2] == 0.75
    # the closed form with the file's geometry satisfies the model's loop closures
    model = study.extra["model"]
    for i in (0, 5, 10):
        y = np.concatenate([study.q[i], study.u[i]])
        assert np.max(np.abs(model.constraint_residuals(study.t[i], y))) < 1e-12
    assert study.power_residual() < 1e-12


@pytest.mark.parametrize("edit, message", [
    (("m_c = 5.0", "m_c = 5.0\nm_x = 1.0"), r"m.toml: \[masses\] unknown key 'm_x'; known: "
                                            r"m_p, m_s, m_c"),
    (("m_s = 2.0\n", ""), r"m.toml: \[masses\] missing key 'm_s' \(kg\)"),
    (("eta = 0.9", "eta = 1.5"), r"m.toml: \[drive\] eta: must be a finite number in "
                                 r"\(0, 1\], got 1.5"),
    (("L = 0.6", 'L = "0.6"'), r"m.toml: \[geometry\] L: must be a number \(m\), got str"),
    (("L = 0.6", "L = true"), r"m.toml: \[geometry\] L: must be a number \(m\), got bool"),
    (("r_p = 0.25", "r_p = -0.25"), r"m.toml: \[geometry\] r_p: must be a finite number > 0"),
    (("[drive]", "[drives]"), r"m.toml: unknown section \[drives\]"),
    (("h = 0.8", "h = = 0.8"), r"m.toml: not a valid TOML file: .*line 6, column"),
    (("J_screw = 3.0e-4", "J_screw = -1e-4"), r"\[drive\] J_screw: must be a finite "
                                              r"number >= 0 \(kg m\^2\)"),
])
def test_bad_machine_files_are_refused_naming_the_key(tmp_path, edit, message):
    text = BUILT_IN.format(m_p=20.0).replace(*edit)
    with pytest.raises(KanedynError, match=message):
        read_out_parallel_machine(_machine(tmp_path, text))


def test_a_limit_just_below_the_peak_names_the_peak_as_first_violation(built_in):
    definition, model, ref = built_in
    peak = np.max(np.abs(ref.forces))
    j, i = np.unravel_index(np.argmax(np.abs(ref.forces)), ref.forces.shape)
    study = inverse_study(definition, "sinusoid", points=21, model=model,
                          limits={"force": peak * (1 - 1e-9), "torque": 10.0})
    check = study.limit_check
    # only the peak point is over the limit, so it is the first violation
    assert check.violations == {"force": 1, "torque": 0}
    v = check.first
    assert (v.point, v.number, v.actuator, v.quantity) == (i, j + 1, ref.names[j], "force")
    assert v.time == ref.t[i] and abs(v.value) == peak and v.unit == "N"
    ok = inverse_study(definition, "sinusoid", points=21, model=model,
                       limits={"force": peak * (1 + 1e-9)}).limit_check
    assert ok.ok and ok.peaks["force"] == peak


def test_the_first_violation_is_the_earliest_over_actuators_and_quantities():
    t = np.array([0.0, 1.0, 2.0])
    values = {"force": np.array([[0.0, 0.0, 9.0], [0.0, 5.0, 0.0]]),
              "speed": np.array([[0.0, 3.0, 0.0], [0.0, 0.0, 0.0]])}
    units = {"force": "N", "speed": "m/s"}
    check = check_actuator_limits(t, ["a", "b"], values, units, {"force": 4, "speed": 2})
    v = check.first
    assert (v.time, v.actuator, v.number, v.quantity, v.value) == (1.0, "a", 1, "speed", 3.0)
    assert v.describe() == ("t = 1 s, actuator 1 (a): speed 3 m/s, |speed| > limit 2 m/s")
    assert check.violations == {"force": 2, "speed": 1}
    with pytest.raises(KanedynError, match="actuator limit torque: this model's actuators"):
        check_actuator_limits(t, ["a", "b"], values, units, {"torque": 1.0})
    with pytest.raises(KanedynError, match="actuator limit force must be a finite number > 0"):
        check_actuator_limits(t, ["a", "b"], values, units, {"force": -1.0})


def test_cli_machine_file_limits_print_the_first_violation(tmp_path, capsys):
    path = _machine(tmp_path, BUILT_IN.format(m_p=20.0) + "\n[limits]\nforce = 150.0\n")
    assert main(["inverse", "out-parallel-6dof", "--machine", str(path), "--points", "21",
                 "--quiet", "--limit", "speed=1.0"]) == 0
    out = capsys.readouterr().out
    assert "actuator limits: force 150 N" in out and "speed 1 m/s" in out
    assert "LIMIT EXCEEDED, first at t = " in out and "|force| > limit 150 N" in out
