"""Parallel-manipulator models: the planar 3-RRR, pose trajectories, inverse kinematics."""

import numpy as np
import pytest

import kanedyn as kd
from kanedyn import ConstraintError
from kanedyn.models import (PLANAR_3RRR_GEOMETRY, newton_ik, planar_3rrr_ik, quintic_pose,
                            sinusoid_pose)


@pytest.fixture(scope="module")
def model():
    definition = kd.models.build("3rrr")
    return definition.numeric(definition.derive())


def _trajectories():
    t = np.linspace(0.0, 2.0, 201)
    quintic = quintic_pose(t, [0.0, 0.0, 0.0], [0.08, -0.05, 0.3], 2.0)
    sinusoid = sinusoid_pose(t, [0.01, 0.02, 0.0], [0.06, 0.04, 0.25], [0.5, 1.0, 0.75],
                             [0.0, 0.3, 1.0])
    return t, {"quintic": quintic, "sinusoid": sinusoid}


@pytest.mark.parametrize("name", ["quintic", "sinusoid"])
def test_ik_satisfies_constraints_along_trajectory(model, name):
    t, trajs = _trajectories()
    q, u, ud = planar_3rrr_ik(*trajs[name])
    Y = np.concatenate([q, u], axis=1)
    worst = max(np.max(np.abs(model.constraint_residuals(ti, y))) for ti, y in zip(t, Y))
    assert worst < 1e-12
    # the acceleration constraints K u' + f_a = 0 (the model's own, derived symbolically)
    p = 3
    for ti, y, a in zip(t[::20], Y[::20], ud[::20]):
        K = model.mass_matrix(ti, y)[p:]
        fa = -model.forcing(ti, y)[p:]
        assert np.max(np.abs(K @ a + fa)) < 1e-10


@pytest.mark.parametrize("name", ["quintic", "sinusoid"])
def test_ik_rates_match_finite_differences(name):
    t, trajs = _trajectories()
    pose, rate, accel = trajs[name]
    q, u, ud = planar_3rrr_ik(pose, rate, accel)
    h = 1e-5
    for j in (17, 100, 163):
        plus = [f(t[j:j + 1] + h) for f in (lambda s: _pose(name, s),)][0]
        minus = _pose(name, t[j:j + 1] - h)
        qp, up, _ = planar_3rrr_ik(*plus)
        qm, um, _ = planar_3rrr_ik(*minus)
        np.testing.assert_allclose((qp[0] - qm[0]) / (2 * h), u[j], atol=1e-7)
        np.testing.assert_allclose((up[0] - um[0]) / (2 * h), ud[j], atol=1e-6)


def _pose(name, t):
    if name == "quintic":
        return quintic_pose(t, [0.0, 0.0, 0.0], [0.08, -0.05, 0.3], 2.0)
    return sinusoid_pose(t, [0.01, 0.02, 0.0], [0.06, 0.04, 0.25], [0.5, 1.0, 0.75],
                         [0.0, 0.3, 1.0])


def test_trajectory_rates_match_finite_differences():
    t = np.array([0.3, 0.9, 1.7])
    h = 1e-5
    for f in (lambda s: _pose("quintic", s), lambda s: _pose("sinusoid", s)):
        p, v, a = f(t)
        np.testing.assert_allclose((f(t + h)[0] - f(t - h)[0]) / (2 * h), v, atol=1e-8)
        np.testing.assert_allclose((f(t + h)[1] - f(t - h)[1]) / (2 * h), a, atol=1e-6)
    p, v, a = _pose("quintic", np.array([0.0, 2.0, 3.0]))
    np.testing.assert_allclose(p[0], 0.0)
    np.testing.assert_allclose(p[1:], [[0.08, -0.05, 0.3]] * 2)
    assert np.all(v == 0) and np.allclose(a, 0, atol=1e-15)


def test_newton_ik_matches_closed_form(model):
    t, trajs = _trajectories()
    pose, rate, accel = trajs["sinusoid"]
    q, u, ud = planar_3rrr_ik(pose, rate, accel)
    # warm start from a rough guess of the first point: the elbows stay on the branch
    guess = q[0] + 0.05
    Y, Ud = newton_ik(model, t, pose, rate, accel, guess=guess)
    np.testing.assert_allclose(Y[:, :9], q, atol=1e-10)
    np.testing.assert_allclose(Y[:, 9:], u, atol=1e-10)
    np.testing.assert_allclose(Ud, ud, atol=1e-8)


def test_other_elbow_branch_also_closes_the_loops(model):
    q, u, _ = planar_3rrr_ik([0.03, 0.02, -0.1], [0.1, 0.0, 0.2], elbow=(-1, 1, -1))
    home, _, _ = planar_3rrr_ik([0.03, 0.02, -0.1])
    assert not np.allclose(q[3:], home[3:])
    assert np.max(np.abs(model.constraint_residuals(0.0, np.concatenate([q, u])))) < 1e-12


def test_unreachable_pose_names_the_leg_and_the_excess():
    geo = PLANAR_3RRR_GEOMETRY
    # push the platform straight away from leg 1's base joint (at 90 degrees)
    y = -0.5
    d = np.hypot(0.0, y + geo["r_p"] - geo["R_b"])          # anchor 1 to base joint 1
    excess = d - (geo["l_1"] + geo["l_2"])
    assert excess > 0
    with pytest.raises(ConstraintError, match=r"leg 1") as info:
        planar_3rrr_ik([[0.0, 0.0, 0.0], [0.0, y, 0.0]])
    assert f"{excess:.6g} m beyond" in str(info.value)
    assert "point 1" in str(info.value)


def test_gravity_option_derives_and_falls():
    definition = kd.models.build("3rrr", gravity=True)
    model = definition.numeric(definition.derive())
    y = model.state(definition.initial_state)
    accel = model.rhs(0.0, y)[9:]
    # released at rest under gravity along -N.y: the platform accelerates downward
    assert accel[1] < 0
    # (all elbows on the same side: the mechanism is chiral, so x and phi move too)
    assert model.potential_energy(0.0, y) != 0.0


def test_bad_options():
    with pytest.raises(kd.ModelError, match="gravity"):
        kd.models.build("3rrr", gravity=1)
    with pytest.raises(ValueError, match="elbow"):
        planar_3rrr_ik([0, 0, 0], elbow=(1, 0, 1))
    with pytest.raises(kd.ModelError, match="l_3"):
        planar_3rrr_ik([0, 0, 0], geometry={"l_3": 1.0})


# ------------------------------------------------------------ Stewart platform
from kanedyn.models import STEWART_GEOMETRY, stewart_anchors, stewart_leg_lengths  # noqa: E402


def test_stewart_home_leg_lengths_closed_form():
    geo = STEWART_GEOMETRY
    # at the home pose, base anchor at angle beta and platform anchor at beta -+ 2 gamma_b
    chord2 = (geo["R_b"] ** 2 + geo["r_p"] ** 2
              - 2 * geo["R_b"] * geo["r_p"] * np.cos(2 * geo["gamma_b"]))
    expected = np.sqrt(chord2 + geo["h"] ** 2)
    home = [0, 0, geo["h"], 0, 0, 0]
    np.testing.assert_allclose(stewart_leg_lengths(home), np.full(6, expected), rtol=1e-14)
    definition = kd.models.build("stewart-platform")
    model = definition.numeric(definition.derive())
    y = model.state(definition.initial_state)
    names = model.state_names
    s = y[[names.index(f"s{j}") for j in range(1, 7)]]
    np.testing.assert_allclose(s, expected, rtol=1e-14)
    # the model's loop closures hold at a rotated pose completed by Newton, with the
    # closed-form leg lengths
    pose = np.array([0.02, -0.01, 0.43, 0.05, -0.04, 0.1])
    y2 = y.copy()
    y2[:6] = pose
    y2 = model.consistent_state(0.0, y2)
    s2 = y2[[names.index(f"s{j}") for j in range(1, 7)]]
    np.testing.assert_allclose(s2, stewart_leg_lengths(pose), rtol=1e-12)


def test_stewart_statics_equal_leg_forces():
    geo = STEWART_GEOMETRY
    definition = kd.models.build("stewart-platform")
    model = definition.numeric(definition.derive(), constants={"m_c": 0.0, "m_r": 0.0})
    y = model.state(definition.initial_state)
    W = 10.0 * 9.81                                      # m_p g
    # reference from the geometry alone: force and moment balance of the platform
    A, c = stewart_anchors()
    tips = np.array([0, 0, geo["h"]]) + c
    e = (tips - A) / np.linalg.norm(tips - A, axis=1)[:, None]
    balance = np.vstack([e.T, np.cross(c, e).T])         # 6 x 6: leg forces -> wrench
    reference = np.linalg.solve(balance, [0, 0, W, 0, 0, 0])
    cos_gamma = e[0, 2]
    np.testing.assert_allclose(reference, W / (6 * cos_gamma), rtol=1e-12)
    # kanedyn: generalized forces needed at rest, M u' - F = -F in the pose speeds,
    # mapped to the legs by virtual work: J^T tau = Q with J = ds/dpose
    Q = -model.forcing(0.0, y)[:6]
    h = 1e-6
    pose = y[:6]
    J = np.empty((6, 6))
    for k in range(6):
        dp = np.zeros(6)
        dp[k] = h
        J[:, k] = (stewart_leg_lengths(pose + dp) - stewart_leg_lengths(pose - dp)) / (2 * h)
    tau = np.linalg.solve(J.T, Q)
    np.testing.assert_allclose(tau, reference, rtol=1e-7)
    # the same by kd.ActuatorMap with a force actuator on each leg length: the
    # rate Jacobian of the legs comes from the model's constraints (no differences)
    legs = [kd.JointActuator(f"leg{j + 1}", s) for j, s in enumerate(definition.symbols["s"])]
    statics = kd.ActuatorMap(model, legs).forces(0.0, y, np.zeros(6))
    assert statics.success and not statics.redundant
    np.testing.assert_allclose(statics.forces, reference, rtol=1e-10)
