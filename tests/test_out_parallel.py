"""The 6-dof out-parallel manipulator: closed-form inverse kinematics, actuators, statics,
singular configurations; actuators and body groups declared on the parallel models."""

import re

import numpy as np
import pytest
from scipy.optimize import brentq

import kanedyn as kd
from kanedyn import ConstraintError
from kanedyn.cli import main
from kanedyn.models import (OUT_PARALLEL_GEOMETRY, OUT_PARALLEL_INERTIA, newton_ik,
                            out_parallel_anchors, out_parallel_ik, quintic_pose,
                            sinusoid_pose)

HOME = np.array([0.0, 0.0, OUT_PARALLEL_GEOMETRY["h"], 0.0, 0.0, 0.0])


@pytest.fixture(scope="module")
def definition():
    return kd.models.build("out-parallel-6dof")


@pytest.fixture(scope="module")
def model(definition):
    return definition.numeric(definition.derive())


def _trajectories():
    t = np.linspace(0.0, 2.0, 41)
    quintic = quintic_pose(t, HOME, HOME + [0.05, -0.04, 0.06, 0.1, -0.08, 0.15], 2.0)
    sinusoid = sinusoid_pose(t, HOME + [0.01, 0.0, -0.02, 0.0, 0.02, 0.0],
                             [0.04, 0.05, 0.03, 0.08, 0.06, 0.2],
                             [0.5, 0.75, 1.0, 0.6, 0.9, 0.4],
                             [0.0, 0.3, 1.0, 0.2, 0.5, 1.3])
    return t, {"quintic": quintic, "sinusoid": sinusoid}


def _jacobian(pose):
    """ds/d(pose rates) from the closed form (six unit rates)."""
    return np.array([out_parallel_ik(pose, np.eye(6)[i])[1][6:12] for i in range(6)]).T


def _state(pose, rate=None):
    q, u, _ = out_parallel_ik(pose, rate)
    return np.concatenate([q, u])


def test_home_configuration_closed_form(definition, model):
    geo = OUT_PARALLEL_GEOMETRY
    across = np.sqrt(geo["R_b"] ** 2 + geo["r_p"] ** 2
                     - 2 * geo["R_b"] * geo["r_p"] * np.cos(geo["gamma_p"] - geo["gamma_b"]))
    s_home = geo["h"] - np.sqrt(geo["L"] ** 2 - across ** 2)
    q, _, _ = out_parallel_ik(HOME)
    np.testing.assert_allclose(q[6:12], s_home, rtol=1e-14)
    y = model.state(definition.initial_state)
    assert np.max(np.abs(model.constraint_residuals(0.0, y))) < 1e-14
    np.testing.assert_allclose(y[6:12], s_home, rtol=1e-14)


@pytest.mark.parametrize("name", ["quintic", "sinusoid"])
def test_ik_satisfies_the_model_constraints_along_trajectory(model, name):
    t, trajs = _trajectories()
    q, u, ud = out_parallel_ik(*trajs[name])
    Y = np.concatenate([q, u], axis=1)
    worst = max(np.max(np.abs(model.constraint_residuals(ti, y))) for ti, y in zip(t, Y))
    assert worst < 1e-13
    # the acceleration constraints K u' + f_a = 0, from the model's own derivation
    p = 6
    for ti, y, a in zip(t[::5], Y[::5], ud[::5]):
        K = model.mass_matrix(ti, y)[p:]
        fa = -model.forcing(ti, y)[p:]
        assert np.max(np.abs(K @ a + fa)) < 1e-11


def test_ik_matches_newton_ik(definition, model):
    t, trajs = _trajectories()
    pose, rate, accel = trajs["sinusoid"]
    q, u, ud = out_parallel_ik(pose, rate, accel)
    guess = model.state(definition.initial_state)[:24] + 0.01   # a rough start, same branch
    Y, Ud = newton_ik(model, t, pose, rate, accel, guess=guess)
    np.testing.assert_allclose(Y[:, :24], q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(Y[:, 24:], u, rtol=0, atol=1e-10)
    np.testing.assert_allclose(Ud, ud, rtol=0, atol=1e-10)


def test_ik_rates_match_finite_differences():
    def at(s):
        return quintic_pose(np.atleast_1d(s), HOME, HOME + [0.05, -0.04, 0.06, 0.1, -0.08,
                                                             0.15], 2.0)
    h = 1e-5
    for tj in (0.4, 1.1, 1.7):
        q, u, ud = out_parallel_ik(*at(tj))
        qp, up, _ = out_parallel_ik(*at(tj + h))
        qm, um, _ = out_parallel_ik(*at(tj - h))
        np.testing.assert_allclose((qp - qm)[0] / (2 * h), u[0], atol=1e-8)
        np.testing.assert_allclose((up - um)[0] / (2 * h), ud[0], atol=1e-6)


def test_home_statics_by_virtual_work(definition, model):
    """Holding still at home: the carriage forces balance gravity in virtual work."""
    values = {str(k): v for k, v in definition.constants.items()}
    g, L = values["g"], values["L"]
    mp, ms, mc = values["m_p"], values["m_s"], values["m_c"]
    amap = kd.ActuatorMap(model, definition.actuators)
    out = amap.forces(0.0, _state(HOME), np.zeros(6))
    assert out.success and not out.redundant
    f = out.forces
    # by the D3 symmetry of the design, six equal forces; each leg (carriage and strut)
    # carries its own weight and a sixth of the platform's along its vertical rail
    np.testing.assert_allclose(f, g * (mc + ms + mp / 6), rtol=1e-12)
    rng = np.random.default_rng(5)
    for _ in range(4):
        v = rng.normal(size=6)
        q, u, _ = out_parallel_ik(HOME, v)
        sd, a, b, da, db = u[6:12], q[12:18], q[18:24], u[12:18], u[18:24]
        # strut axis height rate: l_z = cos a cos b
        lz_rate = -np.sin(a) * np.cos(b) * da - np.cos(a) * np.sin(b) * db
        gravity_power = -g * (mp * v[2] + np.sum(mc * sd + ms * (sd + L / 2 * lz_rate)))
        assert np.dot(f, sd) == pytest.approx(-gravity_power, rel=1e-10, abs=1e-10)


def test_ball_screw_reflected_inertia(definition, model):
    lead, Jr, Jc, Js = (OUT_PARALLEL_INERTIA[k] for k in ("lead", "J_r", "J_cp", "J_sc"))
    closed = (2 * np.pi / lead) ** 2 * (Jr + Jc + Js)
    assert closed == pytest.approx(236.8705056, rel=1e-9)
    for actuator in definition.actuators:
        assert float(actuator.reflected_inertia) == pytest.approx(closed, rel=1e-14)
    # the drive trains add (2 pi/p)^2 J s'' to each carriage force, s'' from the closed form
    bare = [kd.JointActuator(a.name, a.expression, point=a.point, axis=a.axis)
            for a in definition.actuators]
    _, trajs = _trajectories()
    pose, rate, accel = (x[13] for x in trajs["sinusoid"])
    q, u, ud = out_parallel_ik(pose, rate, accel)
    y = np.concatenate([q, u])
    driven = kd.ActuatorMap(model, definition.actuators).forces(0.0, y, accel)
    alone = kd.ActuatorMap(model, bare).forces(0.0, y, accel)
    np.testing.assert_allclose(driven.rate_derivatives, ud[6:12], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(driven.forces - alone.forces, closed * ud[6:12],
                               rtol=1e-9, atol=1e-8)
    for j, name in enumerate(driven.names):
        assert driven.motor_torques[name] == pytest.approx(
            driven.forces[j] * lead / (2 * np.pi), rel=1e-12)


def test_unreachable_pose_names_the_leg_and_the_shortfall():
    A0, e, c = out_parallel_anchors()
    pose = HOME + [0.34, 0.0, 0.0, 0.0, 0.0, 0.0]
    # rails are vertical: an anchor's distance from its rail is the horizontal distance
    across = np.hypot(*(pose[:2] + c[:, :2] - A0[:, :2]).T)
    short = across - OUT_PARALLEL_GEOMETRY["L"]
    leg = int(np.flatnonzero(short > 0)[0])
    with pytest.raises(ConstraintError, match=rf"leg {leg + 1} cannot reach") as info:
        out_parallel_ik(np.vstack([HOME, pose]))
    assert f"the strut is {short[leg]:.6g} m too short" in str(info.value)
    assert "point 1" in str(info.value)
    with pytest.raises(ValueError, match="pose"):
        out_parallel_ik([0.0, 0.0, 0.8])
    with pytest.raises(kd.ModelError, match="L_2"):
        out_parallel_ik(HOME, geometry={"L_2": 1.0})


def test_singular_configuration_is_reported_not_divided_by(definition, model):
    """Tilted about x by about 60 degrees the strut lines become dependent: with the
    carriages held, the platform can still move (det ds/dpose changes sign)."""
    def det(angle):
        return np.linalg.det(_jacobian(HOME + [0, 0, 0, angle, 0, 0]))

    assert det(1.0) * det(1.1) < 0
    angle = brentq(det, 1.0, 1.1, xtol=1e-15)
    pose = HOME + [0, 0, 0, angle, 0, 0]
    sv = np.linalg.svd(_jacobian(pose), compute_uv=False)
    assert sv[-1] < 1e-12 * sv[0]
    amap = kd.ActuatorMap(model, definition.actuators)
    out = amap.forces(0.0, _state(pose), np.zeros(6))
    assert not out.success
    assert np.isfinite(out.condition) and out.condition > 1e8
    assert np.all(np.isfinite(out.forces))
    assert "singular configuration" in out.message
    near = amap.forces(0.0, _state(HOME + [0, 0, 0, 0.9, 0, 0]), np.zeros(6))
    assert near.success and near.condition < 1e4


def test_actuators_and_body_groups_on_parallel_models():
    expected = {"out-parallel-6dof": ({}, [f"carriage{j}" for j in range(1, 7)],
                                      {"platform", "struts", "carriages"}),
                "stewart-platform": ({}, [f"leg{j}" for j in range(1, 7)],
                                     {"platform", "legs"}),
                "3rrr": ({"gravity": True}, ["base1", "base2", "base3"],
                         {"platform", "proximal", "distal"})}
    for name, (options, actuators, groups) in expected.items():
        definition = kd.models.build(name, **options)
        assert [a.name for a in definition.actuators] == actuators
        assert set(definition.body_groups) == groups
        grouped = [b for names in definition.body_groups.values() for b in names]
        bodies = [b.name for b in definition.kane_args["bodies"]]
        assert sorted(grouped) == sorted(bodies)            # each body in one group
    # other models declare none
    plain = kd.models.build("pendulum")
    assert plain.actuators == () and plain.body_groups == {}


@pytest.mark.slow
def test_stewart_and_3rrr_actuators_hold_the_home_pose():
    stewart = kd.models.build("stewart-platform")
    model = stewart.numeric(stewart.derive())
    y = model.state(stewart.initial_state)
    out = kd.ActuatorMap(model, stewart.actuators).forces(0.0, y, np.zeros(6))
    assert out.success
    np.testing.assert_allclose(out.forces, out.forces[0], rtol=1e-12)   # symmetric design
    assert out.forces[0] > 0                                         # legs push up
    planar = kd.models.build("3rrr", gravity=True)
    model = planar.numeric(planar.derive())
    y = model.state(planar.initial_state)
    out = kd.ActuatorMap(model, planar.actuators).forces(0.0, y, np.zeros(3))
    assert out.success and out.forces.shape == (3,)
    # virtual work against gravity for a motion of the platform: sum f theta' = dV/dt
    q, u, _ = kd.models.planar_3rrr_ik(np.zeros(3), [0.1, -0.2, 0.3])
    y = np.concatenate([q, u])
    h = 1e-6
    qp, _, _ = kd.models.planar_3rrr_ik(h * np.array([0.1, -0.2, 0.3]))
    qm, _, _ = kd.models.planar_3rrr_ik(-h * np.array([0.1, -0.2, 0.3]))
    dV = (model.potential_energy(0.0, np.concatenate([qp, u]))
          - model.potential_energy(0.0, np.concatenate([qm, u]))) / (2 * h)
    assert np.dot(out.forces, u[3:6]) == pytest.approx(dV, rel=1e-7)


@pytest.mark.slow
def test_cli_lists_the_model_with_its_actuators(capsys):
    assert main(["list", "out-parallel-6dof"]) == 0
    out = capsys.readouterr().out
    assert "out-parallel" in out
    assert re.search(r"^m_p\s+20\s+kg\s*$", out, re.M)
    assert re.search(r"^s3\s+0\.35\d*\s+m\s+dependent", out, re.M)
    assert re.search(r"^carriage6\s+joint\s+ball screw, lead 0\.01 m", out, re.M)
    assert "reflected 236.871 kg" in out
    assert re.search(r"^struts\s+strut1, strut2", out, re.M)
