"""Motor torques of the out-parallel manipulator's ball screws: efficiency forward and
back-driven, the rotor, coupler and screw inertias as separate terms."""

import numpy as np
import pytest

import kanedyn as kd
from kanedyn import KanedynError, ModelError
from kanedyn.analysis import DRIVE_PARTS, inverse_study, motor_torques
from kanedyn.models import OUT_PARALLEL_INERTIA


def test_motor_torque_hand_calculation_forward_and_back_driven():
    # lead 10 mm, J_r, J_c, J_s = 2e-4, 1e-4, 3e-4 kg m^2, eta = 0.9, eta' = 0.8
    screw = kd.BallScrew(0.01, 2e-4, 1e-4, 3e-4, efficiency=0.9, back_efficiency=0.8)
    force = {"platform": np.array([[300.0, 300.0]]), "struts": np.array([[100.0, 100.0]])}
    rate = np.array([[0.1, -0.1]])       # m/s: forward (F s' > 0), then back-driven
    accel = np.array([[2.0, 2.0]])       # m/s^2
    m = motor_torques(["c1"], [screw], [0.0, 1.0], force, rate, accel)
    # by hand: load 400 N * 0.01 m / (2 pi * 0.9) = 0.707355 N m forward,
    #          400 N * 0.01 m * 0.8 / (2 pi) = 0.509296 N m back-driven;
    # inertia (2e-4 + 1e-4 + 3e-4) kg m^2 * (2 pi / 0.01 m) * 2 m/s^2 = 0.753982 N m
    np.testing.assert_allclose(m.torque[0], [0.707355 + 0.753982, 0.509296 + 0.753982],
                               atol=1e-6)
    np.testing.assert_array_equal(m.back_driven[0], [False, True])
    # rotor 2e-4 * 628.3185 * 2 = 0.251327, coupler half of it, screw 1.5 times
    np.testing.assert_allclose([m.parts[p][0, 0] for p in DRIVE_PARTS],
                               [0.251327, 0.125664, 0.376991], atol=1e-6)
    np.testing.assert_allclose(m.parts["platform"][0], [0.530516, 0.381972], atol=1e-6)
    np.testing.assert_allclose(m.speed[0], [62.831853, -62.831853], atol=1e-6)
    np.testing.assert_allclose(m.power, m.torque * m.speed)


@pytest.mark.parametrize("kwargs, name", [({"efficiency": 0.0}, "efficiency"),
                                          ({"back_efficiency": 1.2}, "back_efficiency"),
                                          ({"efficiency": "0.9"}, "efficiency")])
def test_ball_screw_refuses_efficiencies_outside_0_1(kwargs, name):
    with pytest.raises(ModelError, match=rf"BallScrew {name} must be a number in \(0, 1\]"):
        kd.BallScrew(0.01, 1e-4, 0.0, 0.0, **kwargs)


def test_motor_torques_refuses_missing_screws_and_bad_shapes():
    screw = kd.BallScrew(0.01, 1e-4, 0.0, 0.0)
    with pytest.raises(KanedynError, match="a ball screw for each actuator"):
        motor_torques(["a", "b"], [screw, None], [0.0], {}, np.zeros((2, 1)),
                      np.zeros((2, 1)))
    with pytest.raises(KanedynError, match=r"rates has shape \(1, 2\), expected \(1, 1\)"):
        motor_torques(["a"], [screw], [0.0], {}, np.zeros((1, 2)), np.zeros((1, 1)))


@pytest.fixture(scope="module")
def study():
    return inverse_study("out-parallel-6dof", trajectory="sinusoid", points=41)


def test_study_motor_torques_follow_the_carriage_forces(study):
    """tau = (f - m_refl s'') p eps / (2 pi) + J 2 pi s'' / p, per point, from the
    carriage forces and rates of the study (not from its body groups)."""
    m = study.motors
    p = OUT_PARALLEL_INERTIA["lead"]
    J = OUT_PARALLEL_INERTIA["J_r"] + OUT_PARALLEL_INERTIA["J_cp"] + OUT_PARALLEL_INERTIA["J_sc"]
    ratio = 2 * np.pi / p
    sdd, sd = study.rate_derivatives, study.rates
    nut = study.forces - ratio ** 2 * J * sdd
    back = nut * sd < 0
    assert 0 < back.sum() < back.size        # both regimes occur on this path
    eps = np.where(back, OUT_PARALLEL_INERTIA["eta_back"], 1 / OUT_PARALLEL_INERTIA["eta"])
    expected = nut * p * eps / (2 * np.pi) + J * ratio * sdd
    np.testing.assert_allclose(m.torque, expected, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(sum(m.parts.values()), m.torque, rtol=1e-12, atol=1e-12)
    assert set(m.parts) >= {"platform", "struts", "carriages", *DRIVE_PARTS}


def test_lossless_motor_power_equals_the_power_balance(study):
    """With eta = eta' = 1 the motors' power is the actuators' power of the energy
    balance (dT/dt + dT_drive/dt + dV/dt), computed from the energies."""
    screws = [kd.BallScrew(a.transmission.lead, a.transmission.J_rotor,
                           a.transmission.J_coupler, a.transmission.J_screw)
              for a in study.extra["definition"].actuators]
    nut = {g: v for g, v in study.groups.items() if g != "drive train"}
    m = motor_torques(study.names, screws, study.t, nut, study.rates, study.rate_derivatives)
    pw = study.power
    energy = pw.kinetic_rate + pw.drive_rate + pw.potential_rate - pw.wrench_power
    scale = np.max(np.abs(energy))
    assert np.max(np.abs(m.power.sum(axis=0) - energy)) < 1e-9 * scale


def test_cli_prints_motor_torques_and_writes_their_files(tmp_path, capsys):
    from kanedyn.cli import main
    assert main(["inverse", "out-parallel-6dof", "--points", "21", "--out", str(tmp_path),
                 "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "motors (ball screws; forward efficiency where F·ṡ >= 0" in out
    rows = [line.split() for line in out.splitlines() if line.strip().startswith("carriage")]
    assert len(rows) == 12                 # forces, then motors
    header = (tmp_path / "motors.csv").read_text().splitlines()[0].split(",")
    assert "carriage1:torque [N m]" in header and "carriage6:torque screw [N m]" in header
    data = np.loadtxt(tmp_path / "motors.csv", delimiter=",", skiprows=1)
    col = header.index("carriage1:torque [N m]")
    assert float(rows[6][1]) == pytest.approx(np.max(np.abs(data[:, col])), rel=1e-5)
    assert (tmp_path / "motors.png").stat().st_size > 0
    assert (tmp_path / "motor_decomposition.png").stat().st_size > 0


@pytest.mark.parametrize("model", ["out-parallel-6dof", "stewart-platform"])
def test_a_vertical_platform_wrench_acts_as_extra_platform_weight(model):
    """Fz = -10 kg * g on the platform's mass centre (a specified input) moves the
    actuator forces as 10 kg more platform mass moves their gravity part.

    The model is built once and its definition given to every study (a name
    would build it again each time), and the unloaded and heavier studies share
    one derivation (the heavier one given its constants and that model with
    them), as do the constant and the ramped wrench (the ramp's definition from
    ``with_platform_wrench``, its model the constant one's with the table's
    inputs: the way ``inverse_study`` asks for a wrench with a model)."""
    from kanedyn.analysis import WrenchTable, with_platform_wrench
    g = 9.81
    definition = kd.models.build(model, lazy=False)
    m_p = {str(k): v for k, v in definition.constants.items()}["m_p"]
    unloaded = definition.numeric(definition.derive())
    base = inverse_study(definition, points=11, model=unloaded)
    heavier = inverse_study(definition, points=11, constants={"m_p": m_p + 10.0},
                            model=unloaded.with_constants({"m_p": m_p + 10.0}))
    loaded = inverse_study(definition, points=11, wrench=[0, 0, -10 * g, 0, 0, 0])
    np.testing.assert_allclose(loaded.causes["wrench"],
                               heavier.causes["gravity"] - base.causes["gravity"],
                               rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(loaded.forces - base.forces, loaded.causes["wrench"],
                               atol=1e-9)
    # a table ramping the same force over 0..2 s: half of it at t = 1 s (point 5)
    table = WrenchTable(t=np.array([0.0, 2.0]),
                        values=np.array([[0.0] * 6, [0, 0, -20 * g, 0, 0, 0]]), source="ramp")
    ramped = with_platform_wrench(definition, table)
    ramp = inverse_study(ramped, points=11,
                         model=loaded.extra["model"].with_inputs(ramped.specified))
    np.testing.assert_allclose(ramp.causes["wrench"][:, 5], loaded.causes["wrench"][:, 5],
                               rtol=1e-10)
    # and none of it at the start: the model runs the table's inputs, not the constant's
    np.testing.assert_allclose(ramp.causes["wrench"][:, 0], 0.0, atol=1e-9)
    assert ramp.power_residual() < 1e-12


@pytest.mark.parametrize("text, message", [
    ("t,Fx,Fy,Fz,Mx,My\n0,0,0,0,0,0\n", r"line 1: the header must be t,Fx,Fy,Fz,Mx,My,Mz"),
    ("t,Fx,Fy,Fz,Mx,My,Mz\n0,0,0,0,0,0,0\n0,1,0,0,0,0,0\n",
     r"line 3: t = 0 s is not after the previous row's 0 s"),
    ("t,Fx,Fy,Fz,Mx,My,Mz\n0,0,0,0,0,0,0\n1,nan,0,0,0,0,0\n",
     r"line 3, column Fx: 'nan' is not a finite number"),
    ("t,Fx,Fy,Fz,Mx,My,Mz\n0,0,0,0,0,0,0\n1,0,0,0\n", r"line 3: 4 values, expected 7"),
])
def test_wrench_csv_errors_name_file_line_and_column(tmp_path, text, message):
    from kanedyn.analysis import read_wrench_csv
    path = tmp_path / "w.csv"
    path.write_text(text)
    with pytest.raises(KanedynError, match=message):
        read_wrench_csv(path)


def test_cli_wrench_table_must_cover_the_trajectory(tmp_path, capsys):
    from kanedyn.cli import main
    path = tmp_path / "short.csv"
    path.write_text("t,Fx,Fy,Fz,Mx,My,Mz\n0,0,0,0,0,0,0\n1,0,0,-50,0,0,0\n")
    assert main(["inverse", "out-parallel-6dof", "--quiet", "--wrench", str(path)]) == 2
    err = capsys.readouterr().err
    assert "--wrench: " in err and "covers t = 0 .. 1 s; the trajectory needs 0 .. 2 s" in err
