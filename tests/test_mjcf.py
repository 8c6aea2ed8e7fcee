"""MJCF import (kd.models.from_mjcf) against MuJoCo's own compiler and forward dynamics.

``mujoco.mj_forward`` gives the joint accelerations ``qacc`` of the same file,
with the constraint solver disabled (no contacts, no joint limits: kanedyn
enforces neither) unless a test says otherwise; kanedyn's speeds are MuJoCo's
``qvel`` entry for entry, so its speeds' derivatives must equal ``qacc`` at
random states with random controls.  The models are those the ``dm_control``
package ships (its control suite, written by MuJoCo's makers, not by us); the
edge cases are small files written here.  Quaternions (w-first) of ball and free
joints map to body-fixed x-y-z angles (``MJCFDefinition.state_from_mujoco``).
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.models import MJCFError
from kanedyn.models.mjcf import euler_angles
from kanedyn.models.mjcf._frames import euler_matrix, matrix_quat, quat_matrix

mujoco = pytest.importorskip("mujoco", reason="the MJCF tests compare with MuJoCo "
                             "(pip install mujoco)")


@pytest.fixture(autouse=True)
def _mujoco_log_elsewhere(tmp_path, monkeypatch):
    """MuJoCo writes its warnings (dm_control's cheetah uses the deprecated
    settotalmass) to MUJOCO_LOG.TXT in the working folder: a temporary one."""
    monkeypatch.chdir(tmp_path)


def suite_folder():
    """The folder of dm_control's control-suite MJCF files."""
    suite = pytest.importorskip("dm_control.suite", reason="needs dm-control "
                                "(pip install dm-control)")
    return Path(suite.__file__).parent


def random_state(definition, rng, nv, nu):
    """MuJoCo ``(qpos, qvel, ctrl)`` drawn at random (unit quaternions, |theta| < 90 deg
    is not required: the mapping picks its branch)."""
    qpos = np.zeros(definition.nq)
    for j in definition.joints:
        a = j.qpos_index
        if j.type in ("hinge", "slide"):
            qpos[a] = rng.uniform(-1.5, 1.5)
        else:
            at = a if j.type == "ball" else a + 3
            if j.type == "free":
                qpos[a:a + 3] = rng.uniform(-1, 1, 3)
            quat = rng.normal(size=4)
            qpos[at:at + 4] = quat / np.linalg.norm(quat)
    return qpos, rng.uniform(-1.5, 1.5, nv), rng.uniform(-1.5, 1.5, nu)


def numeric_with_controls(definition):
    """``(model, ctrl)``: the numerical model whose actuator inputs read ``ctrl``."""
    ctrl = np.zeros(len(definition.actuators))
    spec = {a.ctrl: (lambda t, k=k: float(ctrl[k])) for k, a in enumerate(definition.actuators)}
    return definition.numeric(definition.derive(), specified=spec), ctrl


def compare_with_mujoco(path, states=4, seed=0, disable=None, definition=None,
                        model=None, ctrl=None):
    """max |qacc - qacc_mujoco| / max(1, |qacc_mujoco|) over random states."""
    definition = definition or kd.models.from_mjcf(path)
    if model is None:
        model, ctrl = numeric_with_controls(definition)
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj.opt.disableflags |= (mujoco.mjtDisableBit.mjDSBL_CONSTRAINT if disable is None
                            else disable)
    data = mujoco.MjData(mj)
    assert (mj.nq, mj.nv, mj.nu) == (definition.nq, definition.nv, len(ctrl))
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(states):
        qpos, qvel, ctrl[:] = random_state(definition, rng, mj.nv, mj.nu)
        data.qpos[:], data.qvel[:], data.ctrl[:] = qpos, qvel, ctrl
        mujoco.mj_forward(mj, data)
        a = definition.qacc(model, 0.0, definition.state_from_mujoco(model, qpos, qvel))
        worst = max(worst, np.max(np.abs(a - data.qacc)) / max(1.0, np.max(np.abs(data.qacc))))
    return worst


# -- the control suite -----------------------------------------------------------------

SUITE = {
    # slide + hinge, a motor with gear and a control range, a default class
    "cartpole": "cartpole.xml",
    # two hinges, capsules given by fromto, a massless decoration geom
    "acrobot": "acrobot.xml",
    "pendulum": "pendulum.xml",
    "reacher": "reacher.xml",
    "finger": "finger.xml",
    # planar root (slide, slide, hinge), compiler settotalmass, armature, stiffness
    "cheetah": "cheetah.xml",
    "walker": "walker.xml",
    "hopper": "hopper.xml",
    # two slides driven through fixed tendons
    "point_mass": "point_mass.xml",
}


@pytest.mark.parametrize("name", sorted(SUITE))
def test_control_suite_model_matches_mujoco(name):
    worst = compare_with_mujoco(suite_folder() / SUITE[name])
    assert worst < 1e-12, worst


@pytest.mark.slow
def test_humanoid_matches_mujoco():
    """21 hinges under a free joint (27 degrees of freedom)."""
    worst = compare_with_mujoco(suite_folder() / "humanoid.xml", states=3)
    assert worst < 1e-12, worst


@pytest.mark.slow
def test_fish_matches_mujoco():
    """A free body in a fluid (density 5000 kg/m^3 and viscosity), fins on hinges
    and a ball joint-free tail, actuators through fixed tendons."""
    worst = compare_with_mujoco(suite_folder() / "fish.xml", states=3)
    assert worst < 1e-12, worst


@pytest.mark.slow
def test_manipulator_gripper_coupled_by_a_tendon_equality():
    """dm_control's manipulator: an arm, a gripper whose two fingers a fixed-tendon
    equality couples (a loop closure), and free objects; along kanedyn's motion
    MuJoCo's qacc (its equality made as stiff as it allows, contacts and limits
    off) is the same, the coupling holds.

    The motion is stiff: RK45 took 8308 steps (58078 right-hand sides, 16 s CPU)
    over the 0.2 s, LSODA takes 145 (0.4 s) and ends at RK45's state to 5.8e-12
    (largest entry 1.96; measured), so the comparison runs along LSODA's motion."""
    path = suite_folder() / "manipulator.xml"
    definition = kd.models.from_mjcf(path)
    assert definition.equalities == ("tendon coupling = polynomial of a constant "
                                     "(line 192)",)
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj.eq_solimp[:, :3] = [0.9999, 0.9999, 0.001]
    mj.eq_solref[:] = [1e-4, 1.0]
    residual, worst = _loop_run(path, t_end=0.2, definition=definition, mj=mj,
                                method="LSODA")[1:]
    assert residual < 1e-9, residual
    assert worst < 1e-9, worst


def test_swimmer_with_fluid_forces_matches_mujoco(tmp_path):
    """The six-link swimmer (written by dm_control's swimmer.py from its template):
    a planar root and MuJoCo's inertia-based fluid forces (density 3000)."""
    suite_folder()
    from dm_control.suite import swimmer
    xml, assets = swimmer.get_model_and_assets(6)
    path = tmp_path / "swimmer6.xml"
    path.write_bytes(xml if isinstance(xml, bytes) else xml.encode())
    for name, content in assets.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(content)
    definition = kd.models.from_mjcf(path)
    assert len(definition.joints) == 8
    worst = compare_with_mujoco(path, definition=definition)
    assert worst < 1e-12, worst


def test_cartpole_data():
    cartpole = kd.models.from_mjcf(suite_folder() / "cartpole.xml")
    slider, hinge = cartpole.joints
    assert (slider.name, slider.type, slider.range) == ("slider", "slide", (-1.8, 1.8))
    assert hinge.type == "hinge" and hinge.damping == pytest.approx(2e-6)
    (motor,) = cartpole.actuators
    assert (motor.name, motor.joint, motor.gear, motor.ctrlrange) == \
        ("slide", "slider", 10.0, (-1.0, 1.0))
    assert cartpole.constants[next(s for s in cartpole.constants if str(s) == "m_cart")] \
        == pytest.approx(1.0)
    assert cartpole.gravity == (0.0, 0.0, -9.81)
    assert (cartpole.nq, cartpole.nv) == (2, 2)


def test_acrobot_site_follows_the_arm():
    acrobot = kd.models.from_mjcf(suite_folder() / "acrobot.xml")
    tip = next(s for s in acrobot.sites if s.name == "tip")
    assert tip.body == "lower_arm"
    N, O = acrobot.symbols["N"], acrobot.symbols["O"]
    q1, q2 = acrobot.symbols["q"]
    r = tip.point.pos_from(O).to_matrix(N).subs({q1: 0.3, q2: -0.5})
    mj = mujoco.MjModel.from_xml_path(str(suite_folder() / "acrobot.xml"))
    data = mujoco.MjData(mj)
    data.qpos[:] = [0.3, -0.5]
    mujoco.mj_kinematics(mj, data)
    expected = data.site("tip").xpos
    assert np.allclose(np.array(r, dtype=float).ravel(), expected, atol=1e-14)


# -- hand-written edge cases ---------------------------------------------------------

EDGE = """\
<mujoco model="edge">
  <compiler angle="radian" eulerseq="zyX"/>
  <option gravity="0.3 -0.5 -9.7" viscosity="0.01" density="1.2" wind="0.2 0 -0.1"/>
  <include file="parts/defaults.xml"/>
  <worldbody>
    <body name="base" pos="0.1 0.2 1.0" euler="0.3 -0.2 0.5" childclass="arm">
      <joint name="swing" type="hinge" pos="0.05 0 0.02" axis="1 1 0" ref="0.3"
             springref="0.5" stiffness="3"/>
      <geom type="box" size="0.1 0.05 0.02" pos="0 0 0.1" euler="0.1 0.2 0.3"/>
      <geom type="ellipsoid" size="0.03 0.05 0.08" pos="0.1 0 0" quat="0.9 0.1 0.3 -0.2"/>
      <body name="slider" pos="0 0.1 0" xyaxes="0 1 0 -1 0 0.2">
        <joint name="slide" type="slide" axis="0 0.3 1" range="-0.2 0.4" damping="0.7"
               armature="0.05"/>
        <geom type="cylinder" fromto="0 0 0 0.2 0.1 -0.3" size="0.03" density="700"/>
        <body name="welded" pos="0.05 0 0" zaxis="1 1 0">
          <geom type="sphere" size="0.04" mass="0.3" pos="0.02 0 0"/>
          <site name="tip" pos="0.1 0 0"/>
        </body>
        <body name="ball" pos="0.1 0.1 -0.2" gravcomp="0.4">
          <joint name="ball" type="ball" pos="0.01 0.02 0.03" damping="0.2" armature="0.01"/>
          <geom type="capsule" fromto="0 0 0 0.1 -0.2 0.1" size="0.02"/>
          <geom type="box" fromto="0 0 0 0 0 -0.2" size="0.03 0.01 0"/>
        </body>
      </body>
      <body name="twohinge" pos="0 -0.1 0" axisangle="0 1 1 0.7">
        <inertial pos="0.02 0.01 -0.03" quat="0.7 0.2 0.1 0.3" mass="0.8"
                  diaginertia="0.004 0.005 0.006"/>
        <joint name="h1" class="stiff" axis="0 0 1"/>
        <joint name="h2" axis="1 0 0" pos="0 0.03 0"/>
        <geom type="sphere" size="0.05"/>
      </body>
      <body name="full" pos="0 -0.2 0.1">
        <inertial pos="0.01 0 -0.02" mass="0.5"
                  fullinertia="0.003 0.004 0.005 0.0002 -0.0001 0.0003"/>
        <joint name="hf" type="slide" axis="1 0 0"/>
      </body>
    </body>
    <body name="flyer" pos="0.5 0 2" quat="0.8 0.2 -0.3 0.1">
      <freejoint name="fly"/>
      <geom type="box" size="0.1 0.2 0.3"/>
      <geom type="capsule" size="0.05 0.1" pos="0.1 0 0" euler="0.3 0 0"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="m_swing" joint="swing" gear="2" ctrlrange="-1 1"/>
    <position name="p_slide" joint="slide" kp="30" kv="2" gear="1.5" forcerange="-5 5"/>
    <velocity name="v_h2" joint="h2" kv="0.3"/>
    <general name="g_h1" joint="h1" gaintype="affine" gainprm="2 0.5 0.1" biastype="affine"
             biasprm="0.1 -1 -0.2"/>
    <damper name="d_hf" joint="hf" kv="0.4" ctrlrange="0 2"/>
  </actuator>
</mujoco>
"""

DEFAULTS = """\
<mujoco>
  <default>
    <geom density="900"/>
    <default class="arm">
      <joint damping="0.1" armature="0.02"/>
      <geom density="1100"/>
      <default class="stiff">
        <joint stiffness="4" springref="-0.2"/>
      </default>
    </default>
  </default>
</mujoco>
"""


@pytest.fixture(scope="module")
def edge(tmp_path_factory):
    """``(path, definition, model, ctrl)`` of the edge-case file."""
    folder = tmp_path_factory.mktemp("edge")
    (folder / "parts").mkdir()
    (folder / "parts" / "defaults.xml").write_text(DEFAULTS)
    path = folder / "edge.xml"
    path.write_text(EDGE)
    definition = kd.models.from_mjcf(path)
    return (path, definition, *numeric_with_controls(definition))


def test_edge_cases_match_mujoco(edge):
    """Every joint type, a joint's anchor and reference, two joints in one body, a
    body welded to its parent (merged), inertias from every shape and both
    <inertial> forms, default classes from an included file, childclass, radians
    and an extrinsic-intrinsic Euler sequence, springs, damping, armature,
    gravity compensation, fluid forces with wind, and every actuator kind with
    control and force ranges."""
    path, definition, model, ctrl = edge
    assert [j.type for j in definition.joints] == ["hinge", "slide", "ball", "hinge",
                                                   "hinge", "slide", "free"]
    assert definition.body_of["welded"][0] == "slider"
    worst = compare_with_mujoco(path, states=6, definition=definition, model=model,
                                ctrl=ctrl)
    assert worst < 1e-12, worst


def test_inertia_from_each_geom_shape(tmp_path):
    """Mass and central inertia inferred from one geom of each shape, with the
    mass given or from the density, against MuJoCo's compiled body inertia."""
    shapes = ['type="sphere" size="0.07"',
              'type="ellipsoid" size="0.03 0.05 0.08" euler="10 20 30"',
              'type="box" size="0.1 0.05 0.02" quat="0.9 0.1 0.3 -0.2"',
              'type="cylinder" size="0.04 0.12" axisangle="1 1 0 40"',
              'type="capsule" size="0.03 0.1" xyaxes="0 1 0 -1 0 0.2" mass="2.5"',
              'type="capsule" fromto="0 0 0 0.1 -0.2 0.1" size="0.02"',
              'type="box" fromto="0.1 0 0 0 0 -0.2" size="0.03" density="300"',
              'type="ellipsoid" fromto="0 0 0 0 0.2 0.2" size="0.03"',
              'type="cylinder" fromto="0 0 0.3 0 0 0" size="0.03" mass="0.7"']
    bodies = "".join(f'<body name="b{k}" pos="{k} 0 0"><joint axis="0 1 0"/><geom {s}'
                     + ('' if 'fromto' in s else ' pos="0.01 0.02 -0.03"') + '/></body>'
                     for k, s in enumerate(shapes))
    path = tmp_path / "shapes.xml"
    path.write_text(f"<mujoco><worldbody>{bodies}</worldbody></mujoco>")
    definition = kd.models.from_mjcf(path)
    mj = mujoco.MjModel.from_xml_path(str(path))
    values = {str(s): v for s, v in definition.constants.items()}
    for k in range(len(shapes)):
        body = mj.body(f"b{k}")
        R = quat_matrix(body.iquat)
        J = R @ np.diag(body.inertia) @ R.T
        assert values[f"m_b{k}"] == pytest.approx(body.mass[0], rel=1e-14)
        assert [values[f"c{a}_b{k}"] for a in "xyz"] == pytest.approx(body.ipos, abs=1e-15)
        mine = np.array([[values[f"I{a}{b}_b{k}" if f"I{a}{b}_b{k}" in values
                                 else f"I{b}{a}_b{k}"] for b in "xyz"] for a in "xyz"],
                        dtype=float)
        assert np.allclose(mine, J, rtol=0, atol=1e-14 * np.abs(J).max()), shapes[k]


def test_state_mapping_round_trip(edge):
    _, definition, model, _ = edge
    rng = np.random.default_rng(3)
    qpos, qvel, _ = random_state(definition, rng, definition.nv, 0)
    y = definition.state_from_mujoco(model, qpos, qvel)
    qpos2, qvel2 = definition.mujoco_state(model, y)
    for j in definition.joints:  # the same rotations (a quaternion or its negative)
        if j.type in ("ball", "free"):
            at = j.qpos_index + (0 if j.type == "ball" else 3)
            assert abs(abs(qpos[at:at + 4] @ qpos2[at:at + 4]) - 1) < 1e-14
            qpos2[at:at + 4] = qpos[at:at + 4]
    assert np.allclose(qpos2, qpos, atol=1e-14) and np.array_equal(qvel2, qvel)


def test_euler_angles_invert_the_rotation():
    rng = np.random.default_rng(0)
    for _ in range(20):
        quat = rng.normal(size=4)
        R = quat_matrix(quat)
        angles = euler_angles(R)
        assert abs(angles[1]) <= math.pi / 2
        assert np.allclose(euler_matrix(angles, "xyz"), R, atol=1e-14)
        assert abs(abs(matrix_quat(R) @ quat / np.linalg.norm(quat)) - 1) < 1e-14


def test_free_body_falls_as_mujoco_integrates(tmp_path):
    """A spinning free box under gravity: kanedyn's simulation against MuJoCo's
    RK4 with a small step over 0.5 s (the box tumbles about its middle axis)."""
    path = tmp_path / "box.xml"
    path.write_text('<mujoco><option timestep="1e-4" integrator="RK4"/><worldbody>'
                    '<body pos="0 0 1" euler="10 20 30"><freejoint name="box"/>'
                    '<geom type="box" size="0.1 0.2 0.3"/></body></worldbody></mujoco>')
    definition = kd.models.from_mjcf(path)
    model = definition.numeric(definition.derive())
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    data = mujoco.MjData(mj)
    data.qvel[:] = [0.5, 0.0, 3.0, 0.1, 5.0, 0.1]
    y0 = definition.state_from_mujoco(model, data.qpos, data.qvel)
    for _ in range(5000):
        mujoco.mj_step(mj, data)
    res = kd.simulate(model, (0.0, 0.5), y0, rtol=1e-11, atol=1e-11)
    qpos, qvel = definition.mujoco_state(model, res.y[:, -1])
    assert np.allclose(qpos[:3], data.qpos[:3], atol=1e-9)
    assert abs(abs(qpos[3:] @ data.qpos[3:]) - 1) < 1e-12
    assert np.allclose(qvel, data.qvel, atol=1e-8)


# -- loop closures -------------------------------------------------------------------

FOUR_BAR = """\
<mujoco model="four-bar">
  <default>
    <joint type="hinge" axis="0 1 0" damping="0.01"/>
    <geom type="capsule" size="0.02" density="1000"/>
  </default>
  <worldbody>
    <body name="crank">
      <joint name="j1"/>
      <geom fromto="0 0 0 0.3 0 0"/>
      <body name="coupler" pos="0.3 0 0">
        <joint name="j2"/>
        <geom fromto="0 0 0 0.4 0 0.6"/>
      </body>
    </body>
    <body name="rocker" pos="0.9 0 0">
      <joint name="j3"/>
      <geom fromto="0 0 0 -0.2 0 0.6"/>
    </body>
  </worldbody>
  <equality>
    <connect body1="coupler" body2="rocker" anchor="0.4 0 0.6"
             solimp="0.9999 0.9999 0.001" solref="0.0001 1"/>
  </equality>
  <actuator><motor name="drive" joint="j1"/></actuator>
</mujoco>
"""


def _stiff_mujoco(path):
    """MuJoCo's model of ``path`` with contacts off and its soft constraints as
    stiff as it allows (no safety clamp of the time constant)."""
    mj = mujoco.MjModel.from_xml_path(str(path))
    return mj, (mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
                | mujoco.mjtDisableBit.mjDSBL_REFSAFE)


def _loop_run(path, t_end=1.5, specified=None, definition=None, mj=None, method="RK45"):
    definition = definition or kd.models.from_mjcf(path)
    model = definition.numeric(definition.derive(), specified=specified)
    res = kd.simulate(model, (0.0, t_end), definition.initial(model), rtol=1e-11,
                      atol=1e-11, method=method)
    assert res.success, res.message
    step = max(1, len(res.t) // 40)  # about 40 states along the motion, and the last
    residual = max(np.max(np.abs(model.constraint_residuals(t, y)))
                   for t, y in zip(list(res.t[::step]) + [res.t[-1]],
                                   list(res.y.T[::step]) + [res.y[:, -1]]))
    stiff, flags = _stiff_mujoco(path)
    mj = mj or stiff
    mj.opt.disableflags |= flags
    data = mujoco.MjData(mj)
    worst = 0.0
    for y in res.y.T[::max(1, len(res.t) // 12)]:
        data.qpos[:], data.qvel[:] = definition.mujoco_state(model, y)
        mujoco.mj_forward(mj, data)
        a = definition.qacc(model, 0.0, y)
        worst = max(worst, np.max(np.abs(a - data.qacc)) / max(1, np.max(np.abs(data.qacc))))
    return definition, residual, worst


def test_connect_closes_a_four_bar(tmp_path):
    """The loop's constraint holds along a simulation; MuJoCo's soft constraint
    (impedance 0.9999, its largest) gives the same accelerations to 1e-3."""
    path = tmp_path / "fourbar.xml"
    path.write_text(FOUR_BAR)
    definition, residual, worst = _loop_run(path)
    assert definition.equalities == ("connect coupler-rocker (line 21)",)
    assert len(definition.kane_args["q_dep"]) == 2  # the third row is redundant (planar)
    assert residual < 1e-9, residual
    assert worst < 1e-3, worst


WELD = """\
<mujoco model="weld">
  <compiler angle="radian"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="a" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.03"/>
    </body>
    <body name="carriage" pos="0.5 0 1">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <joint name="b" axis="0 1 0"/>
      <geom type="box" size="0.05 0.05 0.05"/>
    </body>
  </worldbody>
  <equality>
    <weld body1="arm" body2="carriage" solimp="0.9999 0.9999 0.001" solref="0.0001 1"/>
    <joint joint1="z" polycoef="0 0 0 0 0" active="false"/>
  </equality>
</mujoco>
"""


def test_weld_to_a_swinging_arm(tmp_path):
    """A carriage on two slides and a hinge, welded to the tip of a swinging arm:
    one degree of freedom left."""
    path = tmp_path / "weld.xml"
    path.write_text(WELD)
    definition, residual, worst = _loop_run(path, t_end=1.0)
    assert len(definition.kane_args["q_ind"]) == 1
    assert residual < 1e-9, residual
    assert worst < 1e-3, worst


SITES = """\
<mujoco model="site loop">
  <compiler angle="radian"/>
  <default><joint type="hinge" axis="0 1 0"/><geom type="capsule" size="0.02"/></default>
  <worldbody>
    <body name="crank"><joint name="j1"/><geom fromto="0 0 0 0.3 0 0"/>
      <body name="coupler" pos="0.3 0 0"><joint name="j2"/><geom fromto="0 0 0 0.4 0 0.6"/>
        <site name="tip" pos="0.4 0 0.6"/></body></body>
    <body name="rocker" pos="0.9 0 0"><joint name="j3"/><geom fromto="0 0 0 -0.2 0 0.6"/>
      <site name="top" pos="-0.2 0 0.6"/></body>
    <body name="arm" pos="0 0 1"><joint name="a"/><geom fromto="0 0 0 0.5 0 0"/>
      <site name="hand" pos="0.5 0 0" euler="0 0.3 0"/></body>
    <body name="carriage" pos="0.5 0 1"><joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/><joint name="b"/>
      <geom type="box" size="0.05 0.05 0.05"/><site name="grip" euler="0 0.3 0"/></body>
  </worldbody>
  <equality>
    <connect site1="tip" site2="top" solimp="0.9999 0.9999 0.001" solref="0.0001 1"/>
    <weld site1="hand" site2="grip" solimp="0.9999 0.9999 0.001" solref="0.0001 1"/>
  </equality>
</mujoco>
"""


def test_connect_and_weld_between_sites(tmp_path):
    """A four-bar closed by two coinciding sites and a carriage whose site frame
    is welded to a turned site of an arm."""
    path = _write(tmp_path, SITES)
    definition, residual, worst = _loop_run(path, t_end=1.0)
    assert definition.equalities == ("connect of sites tip-top (line 17)",
                                     "weld of sites hand-grip (line 18)")
    assert residual < 1e-9, residual
    assert worst < 1e-3, worst


COUPLED = """<mujoco><compiler angle="radian"/><worldbody>
  <body name="a"><joint name="j1" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/></body>
  <body name="b" pos="1 0 0"><joint name="j2" axis="0 1 0" ref="0.2"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.03"/></body>
  </worldbody><equality>
  <joint joint1="j1" joint2="j2" polycoef="0 0.5 {a2} 0 0"
         solimp="0.9999 0.9999 0.001" solref="0.0001 1"/>
  </equality></mujoco>"""


@pytest.mark.parametrize("a2", [0.0, 0.3])
def test_joint_equality_couples_two_hinges(a2, tmp_path):
    """``<equality joint>``: q1 - ref1 = c0 + c1 (q2 - ref2) + c2 (q2 - ref2)^2.
    MuJoCo's constraint acceleration leaves out the term 2 c2 q2'^2 (its soft
    constraint stabilises the drift), so the motions are compared for a linear
    coupling only; kanedyn holds the constraint either way."""
    path = tmp_path / "coupled.xml"
    path.write_text(COUPLED.format(a2=a2))
    definition, residual, worst = _loop_run(path, t_end=1.0)
    assert residual < 1e-9, residual
    if a2 == 0.0:
        assert worst < 1e-3, worst


TENDONS = """\
<mujoco model="tendons">
  <compiler angle="radian"/>
  <default><tendon damping="0.2"/></default>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="j1" axis="0 1 0" stiffness="2 0.5 0.3" damping="0.1 0.2 0.05"
             springref="0.2"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>
      <body name="b" pos="0.4 0 0">
        <joint name="j2" axis="0 1 0"/>
        <joint name="s2" type="slide" axis="1 0 0" stiffness="5" springref="0.1"/>
        <geom type="box" size="0.1 0.03 0.02"/>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="t1" stiffness="3 0.4" springlength="0.1 0.3" armature="0.02">
      <joint joint="j1" coef="1"/><joint joint="j2" coef="-0.5"/>
    </fixed>
    <fixed name="t2" stiffness="1" damping="0.3 0.1 0.02">
      <joint joint="s2" coef="2"/><joint joint="j1" coef="0.3"/>
    </fixed>
  </tendon>
  <actuator>
    <position name="p" tendon="t1" kp="5" kv="0.5" gear="1.5"/>
    <motor name="m" tendon="t2" gear="0.7" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
"""


def test_fixed_tendons_and_polynomial_springs(tmp_path):
    """Fixed tendons with polynomial springs (one with a dead band, one at the
    length of the joints' spring references), polynomial damping from a default
    class, armature, and actuators through them; joints with polynomial springs
    and damping."""
    path = _write(tmp_path, TENDONS)
    worst = compare_with_mujoco(path, states=6)
    assert worst < 1e-12, worst


# -- refused files -------------------------------------------------------------------

def _write(tmp_path, text, name="model.xml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


BAD = {
    "billion laughs": (
        '<?xml version="1.0"?>\n<!DOCTYPE mujoco [\n<!ENTITY a "aaaaaaaaaa">\n'
        '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">\n]>\n<mujoco>&b;</mujoco>\n',
        r"model\.xml:3: entity declarations are not accepted in an MJCF file"),
    "external entity": (
        '<?xml version="1.0"?>\n<!DOCTYPE mujoco [\n'
        '<!ENTITY secret SYSTEM "file:///etc/passwd">\n]>\n<mujoco>&secret;</mujoco>\n',
        r"model\.xml:3: entity declarations are not accepted"),
    "not XML": ("<mujoco><worldbody></mujoco>",
                r"model\.xml:1: not a well-formed XML file \(mismatched tag\)"),
    "not MJCF": ("<robot name='r'/>",
                 r"model\.xml:1: the root element is <robot>, not <mujoco>"),
    "malformed number": (
        "<mujoco>\n<worldbody>\n<body>\n<joint axis='0 1.0.2 0'/>\n"
        "<geom size='0.1'/></body></worldbody></mujoco>",
        r"model\.xml:4: <joint>: axis='0 1\.0\.2 0': '1\.0\.2' is not a number"),
    "number from a default class": (
        "<mujoco>\n<default>\n<joint damping='lots'/>\n</default>\n<worldbody><body>"
        "<joint name='j'/><geom size='0.1'/></body></worldbody></mujoco>",
        r"model\.xml:3: <joint> \(a default\): damping='lots': 'lots' is not a number"),
    "unknown class": (
        "<mujoco><worldbody><body>\n<joint class='stiff'/><geom size='0.1'/>"
        "</body></worldbody></mujoco>",
        r"model\.xml:2: <joint>: class 'stiff' is not a default class of this model"),
    "zero axis": (
        "<mujoco><worldbody><body>\n<joint name='j' axis='0 0 0'/><geom size='0.1'/>"
        "</body></worldbody></mujoco>",
        r"model\.xml:2: <joint name='j'>: axis='0 0 0': a zero joint axis"),
    "unknown joint type": (
        "<mujoco><worldbody><body>\n<joint type='hing'/><geom size='0.1'/>"
        "</body></worldbody></mujoco>",
        r"model\.xml:2: <joint>: type='hing': 'hing' is not one of hinge, slide, ball, free"),
    "free joint below a body": (
        "<mujoco><worldbody><body><joint/><geom size='0.1'/><body>\n<freejoint/>"
        "<geom size='0.1'/></body></body></worldbody></mujoco>",
        r"model\.xml:2: <freejoint>: a free joint must be the only joint of a body whose "
        "parent is the world"),
    "massless moving body": (
        "<mujoco><worldbody><body>\n<joint name='j'/></body></worldbody></mujoco>",
        r"model\.xml:2: <joint name='j'>: moves only massless bodies"),
    "shell inertia": (
        "<mujoco><worldbody><body><joint/>\n<geom type='box' size='0.1 0.1 0.1' "
        "shellinertia='true'/></body></worldbody></mujoco>",
        r"model\.xml:2: <geom>: shellinertia cannot be inferred here .* give the body an "
        "<inertial>"),
    "spatial tendon of one site": (
        "<mujoco><worldbody><body><joint name='j'/><geom size='0.1'/><site name='s'/>"
        "</body></worldbody><tendon>\n<spatial name='t'><site site='s'/></spatial>"
        "</tendon></mujoco>",
        r"model\.xml:2: <spatial name='t'>: a spatial tendon \(and each branch after a "
        r"pulley\) needs at least two sites"),
    "actuator of a missing joint": (
        "<mujoco><worldbody><body><joint name='j'/><geom size='0.1'/></body></worldbody>"
        "<actuator>\n<motor name='m' joint='k'/></actuator></mujoco>",
        r"model\.xml:2: <motor name='m'>: joint='k': no joint of that name"),
    "muscle activation dynamics": (
        "<mujoco><worldbody><body><joint name='j'/><geom size='0.1'/></body></worldbody>"
        "<actuator>\n<general joint='j' dyntype='muscle'/></actuator></mujoco>",
        r"model\.xml:2: <general>: dyntype='muscle': 'muscle' activation dynamics are not "
        "supported"),
    "equality of a missing body": (
        "<mujoco><worldbody><body name='a'><joint/><geom size='0.1'/></body></worldbody>"
        "<equality>\n<connect body1='a' body2='b' anchor='0 0 0'/></equality></mujoco>",
        r"model\.xml:2: <connect>: body2='b': no body of that name"),
    "fromto and pos": (
        "<mujoco><worldbody><body><joint/>\n<geom type='capsule' size='0.1' pos='0 0 1' "
        "fromto='0 0 0 1 0 0'/></body></worldbody></mujoco>",
        r"model\.xml:2: <geom>: gives fromto and pos: give one"),
    "alignfree": (
        "<mujoco>\n<compiler alignfree='true'/><worldbody><body><freejoint/>"
        "<geom size='0.1'/></body></worldbody></mujoco>",
        r"model\.xml:2: <compiler>: alignfree='true': free bodies moved to their inertial "
        "frames are not supported"),
    "two orientations": (
        "<mujoco><worldbody>\n<body euler='0 0 1' quat='1 0 0 0'><joint/>"
        "<geom size='0.1'/></body></worldbody></mujoco>",
        r"model\.xml:2: <body>: gives quat and euler: give one orientation"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_file_names_file_element_and_line(case, tmp_path):
    text, pattern = BAD[case]
    with pytest.raises(MJCFError, match=pattern):
        kd.models.from_mjcf(_write(tmp_path, text))


def test_includes_are_read_from_the_model_folder_only(tmp_path):
    (tmp_path / "secret.xml").write_text("<mujoco><worldbody/></mujoco>")
    folder = tmp_path / "model"
    folder.mkdir()
    path = _write(folder, "<mujoco>\n<include file='../secret.xml'/></mujoco>")
    with pytest.raises(MJCFError, match=r"model\.xml:2: <include>: file '\.\./secret\.xml' "
                                        r"is outside the folder of the main file"):
        kd.models.from_mjcf(path)
    _write(folder, "<mujoco>\n<include file='b.xml'/></mujoco>", "a.xml")
    _write(folder, "<mujoco>\n<include file='a.xml'/></mujoco>", "b.xml")
    path = _write(folder, "<mujoco>\n<include file='a.xml'/></mujoco>")
    with pytest.raises(MJCFError, match=r"b\.xml:2: <include>: file 'a\.xml' is included "
                                        r"a second time \(first by .*model\.xml:2\)"):
        kd.models.from_mjcf(path)
    path = _write(folder, "<mujoco>\n<include file='gone.xml'/></mujoco>")
    with pytest.raises(MJCFError, match=r"model\.xml:2: <include>: file 'gone\.xml' not "
                                        "found"):
        kd.models.from_mjcf(path)


def test_mujoco_own_test_model_is_refused_at_its_first_unsupported_element():
    """The model MuJoCo's wheel ships for its tests (meshes, tendons, actuators with
    activation, fluid ellipsoids) is refused, naming what and where."""
    path = Path(mujoco.__file__).parent / "testdata" / "model.xml"
    if not path.exists():
        pytest.skip("this mujoco wheel ships no testdata/model.xml")
    with pytest.raises(MJCFError, match=r"model\.xml:\d+: <\w+.*>: .*not supported"):
        kd.models.from_mjcf(path)


def test_docs_example_runs(tmp_path, monkeypatch):
    """docs/mjcf.md's python block, on a copy of dm_control's cart-pole."""
    import shutil

    from test_readme import run_python_blocks
    shutil.copy(suite_folder() / "cartpole.xml", tmp_path)
    shutil.copytree(suite_folder() / "common", tmp_path / "common")
    text = (Path(__file__).resolve().parents[1] / "docs" / "mjcf.md").read_text()
    (ns,) = run_python_blocks(text, "docs/mjcf.md", tmp_path, monkeypatch)
    assert ns["res"].success
    assert ns["qpos"].shape == (2,) and ns["qvel"].shape == (2,)


def test_clamped_controls_compile_with_their_derivatives():
    """Control and force ranges are written with absolute values: the C backend
    evaluates them and their exact derivatives (``model.jacobians``) like NumPy."""
    from kanedyn.numerics import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    cartpole = kd.models.from_mjcf(suite_folder() / "cartpole.xml")
    eom = cartpole.derive()
    spec = {cartpole.symbols["ctrl"]["slide"]: 3.0}      # beyond ctrlrange (-1, 1)
    models = [cartpole.numeric(eom, backend=b, specified=spec) for b in ("numpy", "c")]
    y = cartpole.initial(models[0], {"q_hinge_1": 0.4, "u_slider": 0.3})
    a = [m.rhs(0.0, y) for m in models]
    assert np.allclose(a[0], a[1], rtol=1e-13, atol=1e-13)
    jac = [m.jacobians(0.0, y) for m in models]
    for part in ("state", "inputs"):
        assert np.allclose(getattr(jac[0], part), getattr(jac[1], part), rtol=1e-12,
                           atol=1e-12), part
    assert np.all(jac[0].inputs == 0)  # the control is clamped: no effect at the margin


FRAMES = """\
<mujoco model="frames">
  <compiler eulerseq="XYZ"/>
  <default>
    <default class="c"><joint axis="1 0 0" damping="0.3"/><geom density="500"/></default>
  </default>
  <worldbody>
    <frame pos="0.1 0 0.2" euler="30 0 45" childclass="c">
      <body name="a" pos="0 0.1 0" euler="10 20 30">
        <joint name="ja" range="-30 60" ref="10" springref="20" stiffness="2"/>
        <geom type="box" size="0.1 0.05 0.02"/>
        <frame pos="0 0 0.1" axisangle="0 0 1 90">
          <geom type="sphere" size="0.03" pos="0.05 0 0"/>
          <site name="s" fromto="0 0 0 0.1 0.2 0" type="capsule" size="0.01"/>
          <body name="b" pos="0.1 0 0">
            <joint name="jb" type="ball" pos="0 0 0.02"/>
            <geom type="capsule" size="0.02 0.1"/>
          </body>
        </frame>
      </body>
    </frame>
    <body name="m" mocap="true" pos="1 0 0"><geom type="box" size="0.1 0.1 0.1"/></body>
  </worldbody>
</mujoco>
"""


def test_frames_degrees_and_fixed_axis_euler(tmp_path):
    """``<frame>`` with a childclass, MuJoCo's default degrees (orientations, hinge
    range, ref and springref), a fixed-axis Euler sequence, a site given by
    fromto, a mocap body (fixed here, as mj_forward leaves it)."""
    path = _write(tmp_path, FRAMES)
    definition = kd.models.from_mjcf(path)
    ja = definition.joints[0]
    assert ja.range == pytest.approx((-math.pi / 6, math.pi / 3))
    assert (ja.ref, ja.springref) == pytest.approx((math.radians(10), math.radians(20)))
    assert (ja.damping, ja.stiffness) == (0.3, 2.0)
    model, ctrl = numeric_with_controls(definition)
    assert compare_with_mujoco(path, definition=definition, model=model, ctrl=ctrl) < 1e-12
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    data.qpos[:] = [0.4, 0.9, 0.1, -0.3, 0.2]
    mujoco.mj_kinematics(mj, data)
    y = definition.state_from_mujoco(model, data.qpos, np.zeros(mj.nv))
    site = next(s for s in definition.sites if s.name == "s")
    values = {q: y[model.index(str(q.func))] for q in definition.symbols["q"]}
    r = site.point.pos_from(definition.symbols["O"]).to_matrix(definition.symbols["N"])
    assert np.allclose(np.array(r.xreplace(values), dtype=float).ravel(),
                       data.site("s").xpos, atol=1e-14)


def test_geoms_and_shapes_are_where_mujoco_puts_them(edge):
    """Every geom's pose (``MJCFGeom.transform`` in its kanedyn body's frame) at a
    random state equals MuJoCo's ``geom_xpos`` and ``geom_xmat``; the viewer gets
    one shape per sphere, ellipsoid, box and cylinder and three per capsule."""
    path, definition, model, _ = edge
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    qpos, qvel, _ = random_state(definition, np.random.default_rng(5), mj.nv, 0)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(mj, data)
    y = definition.state_from_mujoco(model, qpos, qvel)
    values = {q: y[model.index(str(q.func))] for q in definition.symbols["q"]}
    N, O = definition.symbols["N"], definition.symbols["O"]
    assert len(definition.geoms) == mj.ngeom
    for k, geom in enumerate(definition.geoms):
        frame = definition.symbols["frames"][geom.mjcf_body]
        point = definition.symbols["points"][geom.mjcf_body]
        R = np.array(frame.dcm(N).T.xreplace(values), dtype=float)
        p = np.array(point.pos_from(O).to_matrix(N).xreplace(values), dtype=float).ravel()
        T = np.array(geom.transform)
        assert np.allclose(p + R @ T[:3, 3], data.geom_xpos[k], atol=1e-14), geom.name
        assert np.allclose(R @ T[:3, :3], data.geom_xmat[k].reshape(3, 3), atol=1e-14)
    kinds = [g.type for g in definition.geoms]
    shapes, notes = definition.visual_shapes()
    assert len(shapes) == len(kinds) + 2 * kinds.count("capsule") and not notes
