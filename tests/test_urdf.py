"""URDF import (kd.models.from_urdf) against Pinocchio's URDF loader.

Pinocchio's articulated-body algorithm (``aba``) gives the joint accelerations
and its composite-rigid-body algorithm (``crba``) the joint-space mass matrix
of the same file; kanedyn's Kane equations must give the same numbers at random
states.  The robots are the descriptions shipped by the ``example-robot-data``
package (written by their makers, not by us); the edge cases are small files
written here.  State conventions: kanedyn's ``q_<joint>`` is the joint angle
(or displacement) and ``u_<joint> = q_<joint>'``; Pinocchio's ``q`` holds
``(cos, sin)`` of a continuous joint's angle, its ``v`` the joint rates.
"""

from __future__ import annotations

import errno
import math
import os
import re
import textwrap
from importlib.metadata import PackageNotFoundError, distribution

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.io import scene_data
from kanedyn.models import URDFError

pin = pytest.importorskip("pinocchio", reason="the URDF tests compare with Pinocchio "
                          "(pip install pin)")


def robots_folder():
    """The ``robots`` folder of the example-robot-data package (installed under
    ``cmeel.prefix/share``, not as a Python module)."""
    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        pytest.skip("needs example-robot-data (pip install example-robot-data)")
    return dist.locate_file("cmeel.prefix/share/example-robot-data/robots")


def pinocchio_state(pmodel, definition, q, u, tau=None, base=None):
    """Pinocchio's (q, v, tau) and the v-indices of kanedyn's speeds, in order."""
    qp, vp, tp = np.zeros(pmodel.nq), np.zeros(pmodel.nv), np.zeros(pmodel.nv)
    index = []
    if base is not None:  # free flyer: position, quaternion (x, y, z, w); v local
        from scipy.spatial.transform import Rotation
        qp[:3] = base[0][:3]
        qp[3:7] = Rotation.from_euler("XYZ", base[0][3:]).as_quat()
        vp[:6] = base[1]
        index = list(range(6))
    for k, joint in enumerate(definition.joints):
        jm = pmodel.joints[pmodel.getJointId(joint.name)]
        if jm.nq == 2:  # continuous: (cos, sin)
            qp[jm.idx_q:jm.idx_q + 2] = np.cos(q[k]), np.sin(q[k])
        else:
            qp[jm.idx_q] = q[k]
        vp[jm.idx_v] = u[k]
        if tau is not None:
            tp[jm.idx_v] = tau[k]
        index.append(jm.idx_v)
    return qp, vp, tp, index


def compare_with_pinocchio(definition, pmodel, eom=None, states=4, seed=0, base=False):
    """Max |a - a_pin| / max(1, |a_pin|) and max |M - M_pin| over random states."""
    eom = eom if eom is not None else definition.derive()
    pdata = pmodel.createData()
    rng = np.random.default_rng(seed)
    n = len(definition.joints)
    worst_a = worst_m = 0.0
    tau = np.zeros(n)  # the efforts of the current state, read by the inputs
    spec = {j.effort_input: (lambda t, k=k: float(tau[k]))
            for k, j in enumerate(definition.joints)}
    model = definition.numeric(eom, specified=spec)
    for _ in range(states):
        q, u, tau[:] = rng.uniform(-1.5, 1.5, (3, n))
        if base:
            bq, bu = rng.uniform(-1, 1, (2, 6))
            y = np.concatenate([bq, q, bu, u])
            qp, vp, tp, index = pinocchio_state(pmodel, definition, q, u, tau, (bq, bu))
        else:
            y = np.concatenate([q, u])
            qp, vp, tp, index = pinocchio_state(pmodel, definition, q, u, tau)
        a_pin = pin.aba(pmodel, pdata, qp, vp, tp)[index]
        a = model.rhs(0.0, y)[model.n_q_ind:]
        worst_a = max(worst_a, np.max(np.abs(a - a_pin)) / max(1.0, np.max(np.abs(a_pin))))
        M_pin = pin.crba(pmodel, pdata, qp)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        worst_m = max(worst_m, np.max(np.abs(model.mass_matrix(0.0, y)
                                             - M_pin[np.ix_(index, index)])))
    return worst_a, worst_m


# -- real robots ---------------------------------------------------------------

REAL = {
    # serial arm, fixed joints at base and tool
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    # 7 revolute + 2 prismatic finger joints (one a <mimic>, kept independent
    # as Pinocchio does by default), a fixed hand, inertial origin offsets
    "panda": "panda_description/urdf/panda.urdf",
    # continuous joints, inertial offsets, fixed joints
    "kinova": "kinova_description/robots/kinova.urdf",
}


@pytest.mark.slow
@pytest.mark.parametrize("robot", sorted(REAL))
def test_real_robot_matches_pinocchio(robot):
    path = robots_folder() / REAL[robot]
    definition = kd.models.from_urdf(path)
    pmodel = pin.buildModelFromUrdf(str(path))
    assert len(definition.joints) == pmodel.nv
    worst_a, worst_m = compare_with_pinocchio(definition, pmodel)
    assert worst_a < 1e-10, worst_a
    assert worst_m < 1e-12, worst_m


def test_panda_data():
    path = robots_folder() / REAL["panda"]
    definition = kd.models.from_urdf(path)
    joints = {j.name: j for j in definition.joints}
    assert [j.type for j in definition.joints].count("prismatic") == 2
    assert joints["panda_joint1"].lower == pytest.approx(-2.8973)
    assert joints["panda_joint1"].effort == pytest.approx(87.0)
    assert definition.limits()["panda_joint4"][:2] == (-3.0718, -0.0698)
    assert joints["panda_finger_joint2"].mimic == ("panda_finger_joint1", 1.0, 0.0)
    # the hand hangs on a fixed joint: merged into link 7's body
    assert definition.link_bodies["panda_hand"][0] == "panda_link7"
    meshes = [v for v in definition.visuals if v.shape == "mesh"]
    assert meshes and all(v.mesh_file().endswith(".dae") for v in meshes)
    hand = next(v for v in meshes if v.link == "panda_hand")
    assert hand.body == "panda_link7"
    T = np.array(hand.transform)
    assert T[2, 3] == pytest.approx(0.107)  # panda_joint8 origin


# -- hand-written edge cases -----------------------------------------------------

EDGE = """\
<?xml version="1.0"?>
<robot name="edge">
  <material name="blue"><color rgba="0 0 0.8 1"/></material>
  <link name="base">
    <inertial><mass value="3.0"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
  </link>
  <link name="gimbal"/>
  <link name="arm">
    <inertial>
      <origin xyz="0.1 0.02 -0.3" rpy="0.3 -0.2 0.5"/>
      <mass value="2.0"/>
      <inertia ixx="0.05" ixy="0.001" ixz="-0.002" iyy="0.04" iyz="0.003" izz="0.02"/>
    </inertial>
    <visual>
      <origin xyz="0 0 -0.2" rpy="0 0 0"/>
      <geometry><cylinder radius="0.02" length="0.4"/></geometry>
      <material name="blue"/>
    </visual>
  </link>
  <link name="tool">
    <inertial>
      <origin xyz="0.05 0 0.01" rpy="0 0.4 0"/>
      <mass value="0.5"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.001"/>
    </inertial>
    <visual><geometry><box size="0.1 0.05 0.02"/></geometry></visual>
  </link>
  <link name="slider">
    <inertial>
      <origin xyz="0 0.03 0" rpy="0 0 0"/>
      <mass value="0.7"/>
      <inertia ixx="0.004" ixy="0.0002" ixz="0" iyy="0.005" iyz="0" izz="0.006"/>
    </inertial>
    <visual><origin xyz="0 0 0.1" rpy="1.5707963 0 0"/>
      <geometry>
        <mesh filename="package://edge_pkg/meshes/slider.stl" scale="0.001 0.001 0.001"/>
      </geometry>
    </visual>
  </link>
  <link name="wheel">
    <inertial>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <mass value="0.3"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.001"/>
    </inertial>
    <visual><geometry><sphere radius="0.05"/></geometry></visual>
  </link>
  <joint name="shoulder" type="revolute">
    <origin xyz="0 0 1" rpy="0.1 0.2 0.3"/>
    <parent link="base"/><child link="gimbal"/>
    <axis xyz="1 1 1"/>
    <limit lower="-1" upper="1.5" effort="30" velocity="2"/>
    <dynamics damping="0.1" friction="0.2"/>
  </joint>
  <joint name="elbow" type="revolute">
    <origin xyz="0.05 0 0" rpy="0 0 0"/>
    <parent link="gimbal"/><child link="arm"/>
    <axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="20" velocity="3"/>
  </joint>
  <joint name="tool_mount" type="fixed">
    <origin xyz="0.2 0 -0.5" rpy="0 0.5 -0.3"/>
    <parent link="arm"/><child link="tool"/>
  </joint>
  <joint name="slide" type="prismatic">
    <origin xyz="0.1 0.1 0" rpy="0.2 0 0"/>
    <parent link="tool"/><child link="slider"/>
    <axis xyz="0.3 0 1"/>
    <limit lower="0" upper="0.2" effort="100" velocity="0.5"/>
  </joint>
  <joint name="spin" type="continuous">
    <origin xyz="0 0.1 0.05" rpy="0 0 0"/>
    <parent link="slider"/><child link="wheel"/>
    <axis xyz="0 -2 0"/>
  </joint>
</robot>
"""


@pytest.fixture(scope="module")
def edge_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("urdf")
    path = folder / "edge.urdf"
    path.write_text(EDGE)
    mesh = folder / "pkgs" / "edge_pkg" / "meshes" / "slider.stl"
    mesh.parent.mkdir(parents=True)
    mesh.write_text("solid slider\nendsolid slider\n")
    return path


@pytest.fixture(scope="module")
def edge(edge_file):
    definition = kd.models.from_urdf(edge_file)
    return definition, definition.derive()


def test_edge_cases_match_pinocchio(edge_file, edge):
    definition, eom = edge
    assert [j.name for j in definition.joints] == ["shoulder", "elbow", "slide", "spin"]
    assert definition.joints[0].axis == pytest.approx((3 ** -0.5,) * 3)
    assert definition.joints[3].axis == pytest.approx((0.0, -1.0, 0.0))
    worst_a, worst_m = compare_with_pinocchio(definition,
                                              pin.buildModelFromUrdf(str(edge_file)), eom)
    assert worst_a < 1e-10 and worst_m < 1e-12, (worst_a, worst_m)


@pytest.mark.slow
def test_gravity_option_matches_pinocchio(edge_file):
    gravity = (1.0, -2.0, -3.0)
    definition = kd.models.from_urdf(edge_file, gravity=gravity, efforts=False)
    assert definition.gravity == gravity
    pmodel = pin.buildModelFromUrdf(str(edge_file))
    pmodel.gravity.linear = np.array(gravity)
    model = definition.numeric()
    q, u = np.array([0.3, -0.4, 0.1, 2.0]), np.array([0.5, 1.0, -0.2, 3.0])
    qp, vp, tp, index = pinocchio_state(pmodel, definition, q, u)
    a_pin = pin.aba(pmodel, pmodel.createData(), qp, vp, tp)[index]
    assert np.allclose(model.rhs(0.0, np.concatenate([q, u]))[4:], a_pin, rtol=0,
                       atol=1e-10)
    # no gravity: a robot at rest stays at rest, and g is not a parameter
    still = kd.models.from_urdf(edge_file, gravity=(0, 0, 0), efforts=False)
    assert "g" not in {str(s) for s in still.constants}
    y = np.concatenate([q, np.zeros(4)])
    assert np.max(np.abs(still.numeric().rhs(0.0, y))) == 0.0


@pytest.mark.slow
def test_floating_base_matches_pinocchio(edge_file):
    definition = kd.models.from_urdf(edge_file, base="floating")
    assert [str(s.func) for s in definition.symbols["q"][:6]] == [
        "x", "y", "z", "phi", "theta", "psi"]
    pmodel = pin.buildModelFromUrdf(str(edge_file), pin.JointModelFreeFlyer())
    worst_a, worst_m = compare_with_pinocchio(definition, pmodel, states=3, base=True)
    assert worst_a < 1e-10 and worst_m < 1e-12, (worst_a, worst_m)


def test_fixed_joint_merges_mass(edge):
    definition, _ = edge
    values = {str(s): v for s, v in definition.constants.items()}
    assert values["m_arm"] == pytest.approx(2.5)  # arm + tool
    assert "m_gimbal" not in values  # massless link: a frame only
    assert definition.link_bodies["tool"][0] == "arm"
    assert definition.link_bodies["base"][0] == ""


def test_pendulum_closed_form(tmp_path):
    """One revolute joint about y, mass centre a distance L below it:
    (I_yy + m L^2) q'' = tau - m g L sin q."""
    m, L, Iyy, g = 1.3, 0.4, 0.02, 9.81
    path = tmp_path / "pendulum.urdf"
    path.write_text(textwrap.dedent(f"""\
        <robot name="p"><link name="world"/>
          <link name="rod"><inertial><origin xyz="0 0 {-L}"/><mass value="{m}"/>
            <inertia ixx="0.03" ixy="0" ixz="0" iyy="{Iyy}" iyz="0" izz="0.01"/>
          </inertial></link>
          <joint name="hinge" type="revolute"><parent link="world"/><child link="rod"/>
            <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="5" velocity="9"/>
          </joint></robot>"""))
    definition = kd.models.from_urdf(path)
    tau = definition.joints[0].effort_input
    model = definition.numeric(specified={tau: 0.7})
    for q in (0.0, 0.4, 2.0):
        expected = (0.7 - m * g * L * math.sin(q)) / (Iyy + m * L ** 2)
        assert model.rhs(0.0, np.array([q, 1.5]))[1] == pytest.approx(expected, rel=1e-13)


def test_visuals_and_meshes(edge_file, edge):
    definition, _ = edge
    by_link = {v.link: v for v in definition.visuals}
    arm = by_link["arm"]
    assert (arm.shape, arm.size, arm.rgba) == ("cylinder", (0.02, 0.4), (0.0, 0.0, 0.8, 1.0))
    assert arm.body == "arm" and np.array(arm.transform)[2, 3] == pytest.approx(-0.2)
    assert (by_link["tool"].shape, by_link["tool"].size) == ("box", (0.1, 0.05, 0.02))
    assert by_link["tool"].body == "arm"  # merged: pose in the arm's frame
    assert np.array(by_link["tool"].transform)[:3, 3] == pytest.approx([0.2, 0, -0.5])
    assert by_link["wheel"].size == (0.05,)
    slider = by_link["slider"]
    assert slider.shape == "mesh" and slider.size == (0.001,) * 3
    assert slider.filename == "package://edge_pkg/meshes/slider.stl"
    with pytest.raises(URDFError, match=r"edge\.urdf:\d+: mesh 'package://edge_pkg.*"
                       "not found"):
        slider.mesh_file()  # not found is an error only when asked for
    found = kd.models.from_urdf(edge_file, package_dirs=[edge_file.parent / "pkgs"])
    mesh = next(v for v in found.visuals if v.shape == "mesh")
    assert mesh.mesh_file().endswith("pkgs/edge_pkg/meshes/slider.stl")


def test_limits_kept_as_data(edge):
    definition, _ = edge
    limits = definition.limits()
    assert limits["shoulder"] == (-1.0, 1.5, 2.0, 30.0)
    assert limits["spin"] == (None, None, None, None)
    shoulder = definition.joints[0]
    assert (shoulder.damping, shoulder.friction) == (0.1, 0.2)


def test_link_breaking_the_triangle_inequality_inside_a_body_is_accepted(tmp_path):
    """A link's own inertia that no solid has (the tool's: 0.0005 + 0.0005 < 0.003,
    as real files have for sensor mounts) merged into a body whose inertia a solid
    has: the dynamics are the body's, as Pinocchio computes them."""
    text = EDGE.replace('ixx="0.002" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.001"',
                        'ixx="0.0005" ixy="0" ixz="0" iyy="0.0005" iyz="0" izz="0.003"')
    path = tmp_path / "tool.urdf"
    path.write_text(text)
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        definition = kd.models.from_urdf(path)
    worst_a, worst_m = compare_with_pinocchio(definition, pin.buildModelFromUrdf(str(path)))
    assert worst_a < 1e-10 and worst_m < 1e-12, (worst_a, worst_m)


def test_round_off_inertias_are_accepted_with_a_warning(tmp_path):
    """Inertias that miss a solid's by less than 1e-6 of the robot's largest principal
    moment (1 kg m^2, the base's): the tool's (eigenvalue -1e-8, merged into the arm's
    body, which stays a solid's) and the wheel's (a body of its own, eigenvalue -1e-8:
    replaced by the nearest solid's, which changes one principal moment by 1e-8)."""
    tool = ('ixx="0.002" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.001"',
            'ixx="0.002" ixy="0" ixz="0" iyy="0.001" iyz="0.00100001" izz="0.001"')
    wheel = ('ixx="0.001" ixy="0" ixz="0" iyy="0.002"',
             'ixx="0.001" ixy="0" ixz="0.00100001" iyy="0.002"')
    text = EDGE.replace(*tool).replace(*wheel)
    path = tmp_path / "round_off.urdf"
    path.write_text(text)
    with pytest.warns(UserWarning) as record:
        definition = kd.models.from_urdf(path)
    (message,) = [str(w.message) for w in record]
    assert message.startswith(f"{path}: 3 inertia(s) not a solid's by round-off only, up to "
                              "1e-06 kg m^2 (1e-06 of the largest principal moment")
    for link, needle in (("tool", tool[1]), ("wheel", wheel[1])):
        assert (f"{path}:{line_of(text, needle)}: <link name='{link}'>: inertia is not "
                "positive semi-definite by 1e-08 kg m^2") in message
    assert (f"{path}:{line_of(text, wheel[1])}: <link name='wheel'>: the central inertia of "
            "its body is not positive semi-definite by 1e-08 kg m^2") in message
    assert "replaced by the nearest inertia of a solid" in message
    values = {str(s): v for s, v in definition.constants.items()}
    wheel_inertia = np.array([[values[f"I{a}{b}_wheel" if f"I{a}{b}_wheel" in values
                                      else f"I{b}{a}_wheel"] for b in "xyz"] for a in "xyz"])
    moments = np.linalg.eigvalsh(wheel_inertia)
    assert moments == pytest.approx([0.0, 0.002, 0.00200001], abs=1e-15)
    worst_a, worst_m = compare_with_pinocchio(definition, pin.buildModelFromUrdf(str(path)))
    assert worst_a < 1e-7 and worst_m < 2e-8, (worst_a, worst_m)  # the 1e-8 changed


# Robots of example-robot-data that Pinocchio loads and whose files hold inertias that
# are not positive semi-definite by round-off: the head of iCub (+-2.4e-35 kg m^2) and
# others, Tiago's antennas (eigenvalue -3.5e-8 on 1e-6 kg); with the bound on the
# accelerations (Tiago's mass matrix has a condition number of 4.6e6: solving
# kanedyn's M with Pinocchio's forces gives the same difference)
ROUND_OFF = {
    "icub_reduced": ("icub_description/robots/icub_reduced.urdf", "head", 1e-10),
    "tiago_no_hand": ("tiago_description/robots/tiago_no_hand.urdf",
                      "base_antenna_left_link", 1e-9),
}


@pytest.mark.slow
@pytest.mark.parametrize("robot", sorted(ROUND_OFF))
def test_robots_with_round_off_inertias_match_pinocchio(robot):
    relative, link, bound = ROUND_OFF[robot]
    path = robots_folder() / relative
    with pytest.warns(UserWarning, match=rf"round-off only(.|\n)*{path}:\d+: <link "
                      rf"name='{link}'>: inertia is not positive semi-definite"):
        definition = kd.models.from_urdf(path)
    pmodel = pin.buildModelFromUrdf(str(path))
    assert len(definition.joints) == pmodel.nv
    worst_a, worst_m = compare_with_pinocchio(definition, pmodel)
    assert worst_a < bound and worst_m < 1e-12, (worst_a, worst_m)


# -- bad files: file, element and line named --------------------------------------

def line_of(text, needle):
    """The line (1-based) where ``needle`` (possibly several lines) starts."""
    return text[:text.index(needle)].count("\n") + 1


BAD = [
    # (name, old, new, element named, line needle, message)
    ("missing mass", '<mass value="2.0"/>', "", "<link name='arm'>",
     '<inertial>\n      <origin xyz="0.1',
     "has no <mass>"),
    ("two masses", '<mass value="2.0"/>', '<mass value="2.0"/><mass value="3.5"/>',
     "<link name='arm'>", '<mass value="3.5"/>', "<inertial> has 2 <mass> elements"),
    ("negative inertia", 'ixx="0.05"', 'ixx="-0.05"', "<link name='arm'>", 'ixx="-0.05"',
     "not positive semi-definite"),
    ("indefinite inertia", 'ixy="0.0002"', 'ixy="0.5"', "<link name='slider'>", 'ixy="0.5"',
     "not positive semi-definite"),
    ("unknown joint type", 'name="slide" type="prismatic"', 'name="slide" type="screw"',
     "<joint name='slide'>", 'type="screw"', "unknown joint type 'screw'"),
    ("planar joint", 'name="slide" type="prismatic"', 'name="slide" type="planar"',
     "<joint name='slide'>", 'type="planar"', "joint type 'planar' is not supported"),
    ("floating joint", 'name="spin" type="continuous"', 'name="spin" type="floating"',
     "<joint name='spin'>", 'type="floating"', "not supported"),
    ("missing child link", '<child link="wheel"/>', '<child link="whee1"/>',
     "<joint name='spin'>", 'name="spin"', "child link 'whee1' does not exist"),
    ("malformed number", 'xyz="0.2 0 -0.5"', 'xyz="0.2 1.0.2 -0.5"',
     "<joint name='tool_mount'>", "1.0.2",
     "<origin xyz='0.2 1.0.2 -0.5'>: '1.0.2' is not a number"),
    ("Arabic-Indic digits", '<mass value="2.0"/>', '<mass value="\u0662.\u0660"/>',
     "<link name='arm'>", '\u0662', "<mass value='\u0662.\u0660'>: is not a number"),
    ("full-width digits", 'xyz="0.2 0 -0.5"', 'xyz="0.2 \uff10 -0.5"',
     "<joint name='tool_mount'>", "\uff10", "'\uff10' is not a number"),
    ("a non-ASCII space between numbers", 'xyz="0.2 0 -0.5"', 'xyz="0.2\u20030 -0.5"',
     "<joint name='tool_mount'>", "\u2003", "needs 3 numbers, found 2"),
    ("zero axis", '<axis xyz="0 -2 0"/>', '<axis xyz="0 0 0"/>', "<joint name='spin'>",
     '<axis xyz="0 0 0"/>', "joint axis is zero"),
    ("two parents", '<parent link="slider"/><child link="wheel"/>',
     '<parent link="slider"/><child link="arm"/>', "<joint name='spin'>", 'name="spin"',
     "link 'arm' already has a parent joint 'elbow'"),
    ("three numbers", 'rpy="0.1 0.2 0.3"', 'rpy="0.1 0.2"', "<joint name='shoulder'>",
     'rpy="0.1 0.2"', "needs 3 numbers"),
    ("massless leaf", '<mass value="0.3"/>', '<mass value="0"/>', "<joint name='spin'>",
     'name="spin"', "moves only massless links"),
    ("number out of range", '<mass value="2.0"/>', '<mass value="1e999"/>',
     "<link name='arm'>", '<mass value="1e999"/>',
     "<mass value='1e999'>: '1e999' is beyond the range of floating point"),
    ("inertia out of range", 'ixx="0.05" ixy="0.001" ixz="-0.002" iyy="0.04"',
     'ixx="1e308" ixy="1e308" ixz="-0.002" iyy="1e308"',
     "<link name='arm'>", 'ixx="1e308"', "inertia beyond the range of floating point "
     "(principal moments"),
    ("triangle inequality", 'ixx="0.001" ixy="0" ixz="0" iyy="0.002"',
     'ixx="0.001" ixy="0" ixz="0" iyy="0.007"', "<link name='wheel'>", 'iyy="0.007"',
     "the central inertia of its body violates the triangle inequality I1 + I2 >= I3 by "
     "0.005 kg m^2 (principal moments 0.001, 0.001, 0.007 kg m^2): more than round-off, "
     "which is up to 1e-06 kg m^2 (1e-06 of the largest principal moment"),
    ("indefinite beyond round-off", 'ixx="0.001" ixy="0" ixz="0" iyy="0.002"',
     'ixx="0.001" ixy="0" ixz="0.0010011" iyy="0.002"', "<link name='wheel'>",
     'ixz="0.0010011"', "inertia is not positive semi-definite by 1.1e-06 kg m^2"),
]


@pytest.mark.parametrize("case", BAD, ids=[c[0] for c in BAD])
def test_bad_file_names_file_element_line(tmp_path, case):
    _, old, new, element, needle, message = case
    assert old in EDGE
    text = EDGE.replace(old, new, 1)
    if "massless" in case[0]:
        text = text.replace('ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.001"',
                            'ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"')
    path = tmp_path / "bad.urdf"
    path.write_text(text)
    line = line_of(text, needle)
    with pytest.raises(URDFError) as info:
        kd.models.from_urdf(path)
    text_of_error = str(info.value)
    assert f"{path}:{line}: " in text_of_error, text_of_error
    assert element in text_of_error and message in text_of_error, text_of_error


def test_cycle(tmp_path):
    text = EDGE.replace('<parent link="base"/><child link="gimbal"/>',
                        '<parent link="wheel"/><child link="gimbal"/>')
    path = tmp_path / "cycle.urdf"
    path.write_text(text)
    line = line_of(text, '<joint name="shoulder"')
    with pytest.raises(URDFError, match=rf"cycle\.urdf:{line}: <joint name='shoulder'>: "
                       "joints form a cycle through link 'gimbal'"):
        kd.models.from_urdf(path)
    text = text.replace("</robot>", '<joint name="loop" type="fixed"><parent link="arm"/>'
                        '<child link="base"/></joint></robot>')
    path.write_text(text)
    with pytest.raises(URDFError, match=r"cycle\.urdf: the joints form a cycle"):
        kd.models.from_urdf(path)


def test_two_roots(tmp_path):
    text = EDGE.replace('<link name="gimbal"/>', '<link name="gimbal"/>\n  <link name="stray"/>')
    path = tmp_path / "roots.urdf"
    path.write_text(text)
    with pytest.raises(URDFError, match=r"roots\.urdf: 2 root links \('base' line 4, "
                       r"'stray' line 9\)"):
        kd.models.from_urdf(path)


def test_not_xml_and_not_urdf(tmp_path):
    path = tmp_path / "junk.urdf"
    path.write_text("<robot name='x'>\n  <link name='a'>\n</robot>\n")
    with pytest.raises(URDFError, match=r"junk\.urdf:3: not a well-formed XML file"):
        kd.models.from_urdf(path)
    path.write_text("just text\n")
    with pytest.raises(URDFError, match=r"junk\.urdf:1: not a well-formed XML file"):
        kd.models.from_urdf(path)
    path.write_text("<sdf version='1.6'/>\n")
    with pytest.raises(URDFError, match="root element is <sdf>, not <robot>"):
        kd.models.from_urdf(path)
    with pytest.raises(URDFError, match="cannot read the URDF file"):
        kd.models.from_urdf(tmp_path / "missing.urdf")


# -- viewer shapes of the visuals --------------------------------------------------

def _pose(xyz, rpy):
    """4x4 pose of a URDF <origin>, written out (fixed-axis roll, pitch, yaw)."""
    from scipy.spatial.transform import Rotation
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    T[:3, 3] = xyz
    return T


def _turn(axis, angle):
    from scipy.spatial.transform import Rotation
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(angle * np.asarray(axis) / np.linalg.norm(axis)).as_matrix()
    return T


def test_box_visual_placed_where_the_urdf_says(tmp_path):
    """The box of link 'tool' (fixed to 'arm', whose mass centre is off its joint),
    with its own origin offset and rpy, drawn by the viewer at the pose that the
    URDF's forward kinematics gives, at nonzero joint angles."""
    box_origin = ((0.03, -0.02, 0.04), (0.3, 0.2, -0.4))
    text = EDGE.replace('<visual><geometry><box size="0.1 0.05 0.02"/>',
                        '<visual><origin xyz="0.03 -0.02 0.04" rpy="0.3 0.2 -0.4"/>'
                        '<geometry><box size="0.1 0.05 0.02"/>', 1)
    path = tmp_path / "edge_box.urdf"
    path.write_text(text)
    definition = kd.models.from_urdf(path)
    shapes, notes = definition.visual_shapes()
    # the slider's mesh is not found (no package_dirs): skipped, named, warned
    assert [n for n in notes if "slider" in n] == [n for n in notes if n.startswith("skipped")]
    assert len(notes) == 1 and "slider.stl" in notes[0] and "not found" in notes[0]
    with pytest.warns(UserWarning, match="slider.stl"):
        assert len(definition.shapes()) == len(shapes) == 3  # arm, tool, wheel
    box = next(s for s in shapes if isinstance(s, kd.visuals.Box))
    assert box.body.name == "arm" and box.lengths == (0.1, 0.05, 0.02)
    arm_c = [definition.constants[sm_] for sm_ in definition.constants
             if str(sm_) in ("cx_arm", "cy_arm", "cz_arm")]
    assert np.linalg.norm(arm_c) > 0.1  # the mass centre is well off the joint

    model = definition.numeric()
    y0 = definition.initial(model)
    y0[:4] = (0.7, -0.9, 0.05, 0.3)
    y0[4:8] = (0.5, -1.0, 0.1, 2.0)
    res = kd.simulate(model, (0.0, 0.2), y0, t_eval=[0.0, 0.1, 0.2])
    assert res.success
    scene = scene_data(res, visuals=shapes)
    arm = next(b for b in scene["bodies"] if b["name"] == "arm")
    drawn = next(s for s in arm["shapes"] if s["kind"] == "box")
    from scipy.spatial.transform import Rotation
    for k in range(3):
        q1, q2 = res.y[0, k], res.y[1, k]
        assert abs(q1) > 0.3 and abs(q2) > 0.3
        expected = (_pose((0, 0, 1), (0.1, 0.2, 0.3)) @ _turn((1, 1, 1), q1)
                    @ _pose((0.05, 0, 0), (0, 0, 0)) @ _turn((0, 1, 0), q2)
                    @ _pose((0.2, 0, -0.5), (0, 0.5, -0.3)) @ _pose(*box_origin))
        p = np.array(arm["position"]).reshape(-1, 3)[k]
        R = Rotation.from_quat(np.array(arm["quaternion"]).reshape(-1, 4)[k]).as_matrix()
        centre = p + R @ np.array(drawn["offset"])
        axes = R @ Rotation.from_quat(drawn["quaternion"]).as_matrix()
        np.testing.assert_allclose(centre, expected[:3, 3], atol=2e-6)
        np.testing.assert_allclose(axes, expected[:3, :3], atol=2e-6)


ONE_LINK = """<robot name="one">
  <link name="base"/>
  <link name="arm">
    <inertial><origin xyz="0.5 0.2 0"/><mass value="1"/>
      <inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0.5 0 0"/><geometry><box size="1 0.1 0.1"/></geometry></visual>
  </link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>
"""


def test_one_link_drawn_where_its_mass_centre_is_off_the_axis(tmp_path):
    """The arm turns about y and its mass centre is 0.2 m along y: the equations
    do not use cy_arm (nor some inertias), the numerical model keeps its value
    aside and the viewer places the box with it."""
    path = tmp_path / "one.urdf"
    path.write_text(ONE_LINK)
    definition = kd.models.from_urdf(path)
    model = definition.numeric()
    assert model._data["unused_constants"]["cy_arm"] == pytest.approx(0.2)
    res = kd.simulate(model, (0.0, 0.3), [0.4, 0.0], t_eval=[0.0, 0.15, 0.3])
    shapes = definition.shapes()
    scene = scene_data(res, visuals=shapes)
    arm = next(b for b in scene["bodies"] if b["name"] == "arm")
    drawn = next(s for s in arm["shapes"] if s["kind"] == "box")
    from scipy.spatial.transform import Rotation
    for k in range(3):
        expected = _turn((0, 1, 0), res.y[0, k]) @ _pose((0.5, 0, 0), (0, 0, 0))
        p = np.array(arm["position"]).reshape(-1, 3)[k]
        R = Rotation.from_quat(np.array(arm["quaternion"]).reshape(-1, 4)[k]).as_matrix()
        np.testing.assert_allclose(p + R @ np.array(drawn["offset"]), expected[:3, 3],
                                   atol=2e-6)  # the page rounds to 6 digits


@pytest.mark.parametrize("robot", ["ur5", "panda"])
def test_robot_shapes_one_per_moving_link(robot):
    """The arms' visual meshes are COLLADA (.dae): each moving link is drawn by its
    own visual meshes (read with trimesh), and so is the base, fixed in the
    inertial frame."""
    pytest.importorskip("trimesh")
    pytest.importorskip("collada")
    definition = kd.models.from_urdf(robots_folder() / REAL[robot])
    shapes, notes = definition.visual_shapes()
    moving = {b.name for b in definition.kane_args["bodies"]}
    N = definition.symbols["N"]
    assert {s.body.name for s in shapes} == moving | {N.name}
    assert all(s.path.suffix == ".dae" for s in shapes if isinstance(s, kd.visuals.Mesh))
    base = [s for s in shapes if s.body is N]
    assert len(base) == 1 and base[0].path.stem in ("base", "link0")
    assert notes == []
    if robot == "ur5":
        assert len(shapes) == 7 and all(isinstance(s, kd.visuals.Mesh) for s in shapes)


def _mesh_robot(path, filenames):
    """One moving link 'arm' with a visual mesh per file name; the lines of the visuals."""
    visuals = "".join(f'    <visual><geometry><mesh filename="{name}"/></geometry></visual>\n'
                      for name in filenames)
    text = f"""<robot name="r">
  <link name="base"/>
  <link name="arm">
    <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
{visuals}  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/></joint>
</robot>
"""
    path.write_text(text)
    return {name: line_of(text, f'filename="{name}"') for name in filenames}


def test_meshes_outside_the_allowed_folders_are_not_read(tmp_path):
    """A URDF file names meshes by '..', an absolute path, a file:// URI, a symbolic
    link and a package:// URI that climbs out of its package: none is read (so none
    reaches the viewer's page) unless the user names a folder that holds it."""
    secret = tmp_path / "secret.obj"  # another file of the user's
    secret.write_text("v 0 0 0\nv 7 0 0\nv 7 7 0\nf 1 2 3\n")
    robot = tmp_path / "robot"
    (robot / "meshes").mkdir(parents=True)
    (robot / "pkgs" / "pkg").mkdir(parents=True)
    (robot / "meshes" / "ok.obj").write_text(secret.read_text())
    (robot / "link.obj").symlink_to(secret)
    outside = ["../secret.obj", str(secret), f"file://{secret}", "link.obj",
               "package://pkg/../../../secret.obj"]
    path = robot / "r.urdf"
    lines = _mesh_robot(path, ["meshes/ok.obj", *outside])
    definition = kd.models.from_urdf(path, package_dirs=[robot / "pkgs"])
    by_name = {v.filename: v for v in definition.visuals}
    assert by_name["meshes/ok.obj"].mesh_file() == str(robot / "meshes" / "ok.obj")
    for name in outside:
        vis = by_name[name]
        assert vis.path is None and f"{secret} is outside the folders" in vis.refused
        with pytest.raises(URDFError, match=rf"r\.urdf:{lines[name]}: mesh '{re.escape(name)}' "
                           r"of link 'arm' is not read: .* give mesh_dirs="):
            vis.mesh_file()
    with pytest.warns(UserWarning, match=r"5 visual\(s\) not drawn") as record:
        shapes = definition.shapes()
    assert [s.path for s in shapes] == [robot / "meshes" / "ok.obj"]
    assert str(record[0].message).count("not read: ") == 5

    allowed = kd.models.from_urdf(path, package_dirs=[robot / "pkgs"], mesh_dirs=[tmp_path])
    assert {v.filename for v in allowed.visuals if v.path == str(secret)} == set(outside)


def test_package_uri_found_in_the_ros_package_above_the_urdf(tmp_path):
    """package://PKG/... is looked for in a folder PKG above the URDF only when that
    folder is a ROS package (holds a package.xml)."""
    urdf = tmp_path / "mypkg" / "urdf"
    (tmp_path / "mypkg" / "meshes").mkdir(parents=True)
    urdf.mkdir()
    (tmp_path / "mypkg" / "meshes" / "arm.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    path = urdf / "r.urdf"
    _mesh_robot(path, ["package://mypkg/meshes/arm.obj"])
    (vis,) = kd.models.from_urdf(path).visuals
    assert vis.path is None and vis.refused == ""  # not a package: not looked in
    (tmp_path / "mypkg" / "package.xml").write_text("<package/>")
    (vis,) = kd.models.from_urdf(path).visuals
    assert vis.mesh_file() == str(tmp_path / "mypkg" / "meshes" / "arm.obj")


def test_mesh_uris_are_decoded(tmp_path):
    """file: URIs (RFC 8089: file:///path, file://localhost/path, file:/path) and
    package:// URIs are percent-decoded (RFC 3986); what they name is still read only
    from inside the allowed folders, and a file: URI of another host is not read."""
    robot = tmp_path / "robot"
    (robot / "pkgs" / "pkg" / "meshes").mkdir(parents=True)
    mesh = robot / "pkgs" / "pkg" / "meshes" / "arm part#1.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "secret.obj").write_text(mesh.read_text())
    encoded = str(mesh.parent).replace("/pkgs/", "/%70kgs/") + "/arm%20part%231.obj"
    read = [f"file://{encoded}", f"file://localhost{encoded}", f"FILE://LocalHost{encoded}",
            f"file:{encoded}", "package://pkg/meshes/arm%20part%231.obj",
            "package://%70kg/meshes/arm part%231.obj"]
    refused = {f"file://{robot}/%2E%2E/secret.obj": f"{tmp_path / 'secret.obj'} is outside",
               "package://pkg/%2E%2E/%2E%2E/%2E%2E/secret.obj": "secret.obj is outside",
               f"file://otherhost{mesh}": "names a file on the host 'otherhost'; only local",
               "file:meshes/a.obj": "needs an absolute path",
               "file:///meshes/a%00.obj": "holds a NUL character",
               "package:///meshes/a.obj": "names a package: package://PKG/path",
               "file://[oops/a.obj": "not a valid URI"}
    path = robot / "r.urdf"
    _mesh_robot(path, [*read, *refused])
    by_name = {v.filename: v for v in
               kd.models.from_urdf(path, package_dirs=[robot / "pkgs"]).visuals}
    for name in read:
        assert by_name[name].mesh_file() == str(mesh), name
    for name, why in refused.items():
        assert by_name[name].path is None and why in by_name[name].refused, name


@pytest.mark.parametrize("kind", ["too long", "too long a folder chain", "symbolic link loop",
                                  "folder not searchable"])
def test_mesh_names_the_file_system_refuses(tmp_path, kind, monkeypatch):
    """A mesh name that the file system refuses to look up loads the robot; the mesh
    is then not read, and asking for it names the file, the line and the cause."""
    robot = tmp_path / "robot"
    robot.mkdir()
    name, cause = {"too long": ("a" * 5000 + ".obj", "File name too long"),
                   "too long a folder chain": ("x/" * 3000 + "y.obj", "File name too long"),
                   "symbolic link loop": ("loop/a.obj", "Too many levels of symbolic links"),
                   "folder not searchable": ("locked/a.obj", "Permission denied")}[kind]
    (robot / "loop").symlink_to(robot / "loop")
    if kind == "folder not searchable":  # as root no folder is: the refusal stat() gives
        real_stat = os.stat

        def stat(path, *args, **kwargs):
            if "locked" in str(path):
                raise PermissionError(errno.EACCES, "Permission denied", str(path))
            return real_stat(path, *args, **kwargs)
        monkeypatch.setattr(os, "stat", stat)
    path = robot / "r.urdf"
    lines = _mesh_robot(path, ["ok.obj", name])
    (robot / "ok.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    definition = kd.models.from_urdf(path)
    vis = next(v for v in definition.visuals if v.filename == name)
    assert vis.path is None and vis.refused == f"its name cannot be looked up: {cause}"
    shown = re.escape(name[:50]) + r"\.\.\.\(\d+ characters\)" if len(name) > 100 else name
    with pytest.raises(URDFError, match=rf"^{re.escape(str(path))}:{lines[name]}: mesh "
                       rf"'{shown}' of link 'arm' is not read: its name cannot be looked up: "
                       rf"{cause}$"):
        vis.mesh_file()
    with pytest.warns(UserWarning, match=rf"r\.urdf:{lines[name]}: link 'arm', mesh '{shown}'"
                      rf": not read: its name cannot be looked up: {cause}"):
        assert len(definition.shapes()) == 1


def test_built_in_model_shapes():
    ball = kd.models.bouncing_ball()
    (sphere,) = ball.shapes()
    assert sphere.semi_axes == (0.05,) * 3
    assert ball.shapes({"r": 0.2})[0].semi_axes == (0.2,) * 3
    bike = kd.models.whipple_bicycle()
    rear, front = bike.shapes()
    assert (rear.body.name, rear.radius) == ("rear_wheel", 0.3)
    assert (front.body.name, front.radius) == ("front_wheel", 0.35)
    np.testing.assert_allclose(rear.rotation[:, 1], [0, 1, 0])  # the spin axis
    assert kd.models.pendulum().shapes() == []


_NEAR_INTEGERS = """<robot name="near">
  <link name="base"/>
  <link name="a"><inertial><origin xyz="0.1 0.02 -0.03" rpy="0.2 0 0.1"/><mass value="1.2"/>
    <inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0" izz="0.025"/></inertial></link>
  <link name="b"><inertial><origin xyz="0 0.3 0" rpy="0 0 0"/><mass value="0.7"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.01"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/>
    <origin xyz="0.5 1e-10 5.000000000000001" rpy="1.5707963267948966 0 0"/>
    <axis xyz="0 0 1"/><limit effort="1" velocity="1" lower="-3" upper="3"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0 0.4 -0.9999999999999999" rpy="0 -1.5707963267948966 3.141592653589793"/>
    <axis xyz="1 0 0"/><limit effort="1" velocity="1" lower="-3" upper="3"/></joint>
</robot>
"""


def test_entries_within_round_off_of_an_integer_are_that_integer(tmp_path):
    """A rotation by pi/2 written in radians, an offset 1 ulp from an integer:
    the URDF reader takes the integers (within 1e-15; 0.5 and 1e-10 are kept),
    and the model still matches Pinocchio's, which reads the floats."""
    import sympy as sm

    from kanedyn.models._urdf import _number
    for text, expected in (("6.123233995736766e-17", 0), ("1.0000000000000002", 1),
                           ("-0.9999999999999999", -1), ("5.000000000000001", 5)):
        value = _number(text)
        assert isinstance(value, sm.Integer) and value == expected, text
    for text in ("0.5", "1e-10", "1e-14", "8.000000000000002"):
        value = _number(text)
        assert isinstance(value, sm.Float) and float(value) == float(text), text
    path = tmp_path / "near.urdf"
    path.write_text(_NEAR_INTEGERS)
    definition = kd.models.from_urdf(path)
    numbers = {a for e in definition.derive().mass_matrix for a in e.atoms(sm.Float)}
    assert not any(abs(float(a)) < 1e-12 for a in numbers)  # no cos(pi/2) left as a float
    worst_a, worst_m = compare_with_pinocchio(definition, pin.buildModelFromUrdf(str(path)))
    assert worst_a < 1e-13 and worst_m < 1e-14, (worst_a, worst_m)
