"""Inverse-dynamics and actuator forces by cause and by body group; the power balance."""

import numpy as np
import pytest
import sympy as sm

import kanedyn as kd
from kanedyn.models import quintic_pose


def _rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


# ------------------------------------------------------------------ open chain
@pytest.fixture(scope="module")
def chain():
    definition = kd.models.build("chain3d")
    eom = definition.derive()
    g = next(s for s in eom.constants if str(s) == "g")
    model = definition.numeric(eom)
    rng = np.random.default_rng(3)
    q, u, ud = rng.normal(size=(3, model.n_q, 5))
    return model, g, q, u, ud


def test_open_chain_parts_sum_and_vanish(chain):
    model, g, q, u, ud = chain
    parts = model.inverse_parts(0.0, q, u, ud, gravity=g)
    tau = model.inverse_dynamics(0.0, q, u, ud)
    assert _rel(parts.total, tau) < 1e-12
    causes = parts.by_cause()
    assert _rel(sum(causes.values()), tau) < 1e-12
    assert np.max(np.abs(parts.other)) < 1e-12 * np.max(np.abs(tau))
    assert not parts.wrench.any()  # no load but the weights
    # the acceleration part is M u' (the model's mass matrix, an independent route)
    Mu = np.column_stack([model.mass_matrix(0.0, np.concatenate([q[:, i], u[:, i]]))
                          @ ud[:, i] for i in range(q.shape[1])])
    assert _rel(parts.acceleration, Mu) < 1e-12
    # each part vanishes when its cause is switched off
    assert np.max(np.abs(model.inverse_parts(0.0, q, u, 0 * ud, gravity=g).acceleration)) \
        == 0.0
    assert np.max(np.abs(model.inverse_parts(0.0, q, 0 * u, ud, gravity=g).velocity)) \
        < 1e-14
    weightless = model.with_constants({"g": 0.0})
    assert np.max(np.abs(weightless.inverse_parts(0.0, q, u, ud, gravity=g).gravity)) == 0.0
    # without the gravity symbol the weights count as applied loads
    plain = model.inverse_parts(0.0, q, u, ud)
    np.testing.assert_allclose(plain.wrench, parts.gravity, rtol=1e-13, atol=1e-13)


def test_open_chain_groups(chain):
    model, g, q, u, ud = chain
    groups = {"inner": ["link1", "link2"], "tip": ["link5"]}
    parts = model.inverse_parts(0.0, q[:, 0], u[:, 0], ud[:, 0], groups=groups, gravity=g)
    assert parts.total.shape == (model.n_u,)
    assert list(parts.groups) == ["inner", "tip", "other", "loads", "unassigned"]
    assert _rel(sum(parts.groups.values()), parts.total) < 1e-12
    np.testing.assert_allclose(parts.groups["other"],
                               parts.bodies["link3"] + parts.bodies["link4"], rtol=1e-14)
    assert not parts.groups["loads"].any()  # the weights belong to the bodies
    with pytest.raises(kd.ModelError, match="no body 'link9'"):
        model.inverse_parts(0.0, q, u, ud, groups={"x": ["link9"]})
    with pytest.raises(kd.ModelError, match="in groups"):
        model.inverse_parts(0.0, q, u, ud, groups={"a": ["link1"], "b": ["link1"]})
    with pytest.raises(kd.ModelError, match="not a constant"):
        model.inverse_parts(0.0, q, u, ud, gravity=sm.Symbol("gee"))


# ------------------------------------------------------------ Stewart platform
@pytest.fixture(scope="module")
def stewart():
    definition = kd.models.build("stewart-platform")
    sym = definition.symbols
    N, platform = sym["N"], definition.kane_args["bodies"][0]
    Fw = sm.Symbol("F_w")
    wrench = kd.ExternalWrench(platform, force=Fw * (3 * N.x - 2 * N.y + 5 * N.z),
                               moment=Fw * (0.4 * N.x + 0.7 * N.z))
    args = dict(definition.kane_args)
    args["loads"] = list(args["loads"]) + wrench.to_loads()
    eom = kd.kane(**args)
    model = eom.numeric(constants={**{str(k): v for k, v in definition.constants.items()},
                                   "F_w": 20.0})
    legs = [kd.JointActuator(f"leg{j + 1}", s,
                             transmission=kd.BallScrew(0.01, 2e-5, 1e-5, 3e-5))
            for j, s in enumerate(sym["s"])]
    t = np.linspace(0.0, 1.0, 21)
    pose, rate, accel = quintic_pose(t, [0, 0, 0.4, 0, 0, 0], [0.05, -0.03, 0.45, 0.1,
                                                                -0.05, 0.2], 1.0)
    home = model.state(definition.initial_state)
    q = np.tile(home[:model.n_q, None], (1, t.size))
    q[:6] = pose.T
    struts = [f"{kind}{j}" for j in range(1, 7) for kind in ("cylinder", "piston")]
    return dict(model=model, amap=kd.ActuatorMap(model, legs), g=sym["g"], t=t, q=q,
                u=rate.T, ud=accel.T, groups={"platform": ["platform"], "struts": struts})


def test_stewart_parts_sum_and_vanish(stewart):
    model, g, t, q, u, ud = (stewart[k] for k in ("model", "g", "t", "q", "u", "ud"))
    parts = model.inverse_parts(t, q, u, ud, groups=stewart["groups"], gravity=g)
    tau = model.inverse_dynamics(t, q, u, ud)
    assert _rel(parts.total, tau) < 1e-12
    assert _rel(sum(parts.by_cause().values()), tau) < 1e-12
    assert np.max(np.abs(parts.other)) < 1e-12 * np.max(np.abs(tau))
    assert _rel(sum(parts.groups.values()), tau) < 1e-12
    assert set(parts.groups) == {"platform", "struts", "other", "loads", "unassigned"}
    assert not parts.groups["other"].any()
    assert _rel(parts.groups["loads"], parts.wrench) < 1e-14  # the wrench alone
    scale = np.max(np.abs(tau))
    assert np.max(np.abs(model.inverse_parts(t, q, u, 0 * ud, gravity=g).acceleration)) \
        < 1e-13 * scale
    assert np.max(np.abs(model.inverse_parts(t, q, 0 * u, ud, gravity=g).velocity)) \
        < 1e-13 * scale
    assert np.max(np.abs(model.with_constants({"g": 0.0}).inverse_parts(
        t, q, u, ud, gravity=g).gravity)) < 1e-13 * scale
    assert np.max(np.abs(model.with_constants({"F_w": 0.0}).inverse_parts(
        t, q, u, ud, gravity=g).wrench)) < 1e-13 * scale
    # at rest the needed forces are gravity's and the wrench's alone
    rest = model.inverse_parts(0.0, q[:, 0], 0 * u[:, 0], 0 * ud[:, 0], gravity=g)
    assert np.max(np.abs(rest.acceleration)) + np.max(np.abs(rest.velocity)) == 0.0


def test_stewart_actuator_parts_sum_to_forces(stewart):
    amap, g, t, q, u, ud = (stewart[k] for k in ("amap", "g", "t", "q", "u", "ud"))
    parts = amap.parts(t, q, u, ud, groups=stewart["groups"], gravity=g)
    states = parts.generalized.states
    forces = np.column_stack([amap.forces(t[i], states[:, i], ud[:, i]).forces
                              for i in range(t.size)])
    assert _rel(parts.total, forces) < 1e-12
    assert _rel(sum(parts.causes.values()), forces) < 1e-12
    assert _rel(sum(parts.groups.values()), forces) < 1e-12
    drive = parts.groups["drive train"]
    assert np.max(np.abs(drive)) > 0
    np.testing.assert_allclose(parts.drive_acceleration + parts.drive_velocity, drive)
    still = amap.parts(t, q, 0 * u, 0 * ud, gravity=g)
    assert not still.drive_velocity.any() and not still.drive_acceleration.any()


def test_stewart_power_balance(stewart):
    amap, g, t, q, u, ud = (stewart[k] for k in ("amap", "g", "t", "q", "u", "ud"))
    balance = amap.power_balance(t, q, u, ud, gravity=g)
    scale = np.max(np.abs(balance.actuator))
    assert scale > 1.0 and np.max(np.abs(balance.wrench_power)) > 0.1
    assert np.max(np.abs(balance.residual)) < 1e-9 * scale
    # the declared potential is that of the weights
    np.testing.assert_allclose(balance.potential_rate, -balance.gravity_power,
                               atol=1e-12 * scale)

