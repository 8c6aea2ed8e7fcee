"""Spatial tendons through sites (kd.models.from_mjcf) against MuJoCo.

A spatial tendon's length is the sum of its straight segments between
consecutive sites, a pulley dividing the branch after it; its spring, damping
and actuators act along the segments.  kanedyn's length expression must equal
MuJoCo's ``ten_length``, and its accelerations ``mj_forward``'s ``qacc``
(constraint solver off), at random states and controls.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.engine import name_of
from kanedyn.models import MJCFError

sys.path.insert(0, str(Path(__file__).parent))
from test_mjcf import (compare_with_mujoco, numeric_with_controls, random_state,  # noqa: E402
                       suite_folder)

mujoco = pytest.importorskip("mujoco", reason="the MJCF tests compare with MuJoCo "
                             "(pip install mujoco)")


@pytest.fixture(autouse=True)
def _mujoco_log_elsewhere(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


SPATIAL = """\
<mujoco model="spatial">
  <option gravity="0.3 0 -9.81"/>
  <default><tendon damping="0.2"/></default>
  <worldbody>
    <site name="anchor" pos="0.1 0.05 0.3"/>
    <site name="anchor2" pos="-0.2 0 0.2"/>
    <body name="upper"><joint name="j" axis="0 1 0" damping="0.05" springref="10"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
      <site name="s1" pos="0.1 0.02 0.04"/>
      <site name="s2" pos="0.28 0 0.03"/>
      <body name="lower" pos="0.3 0 0"><joint name="k" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0.05" size="0.03"/>
        <site name="s3" pos="0.2 0.01 -0.02"/>
        <body name="ballbody" pos="0.25 0 0.05"><joint name="b" type="ball"/>
          <geom type="box" size="0.05 0.02 0.03" pos="0.05 0 0"/>
          <site name="s4" pos="0.1 0.02 0"/></body></body></body>
    <body name="free" pos="0.5 0.3 0.5"><freejoint/>
      <geom type="sphere" size="0.05"/><site name="s5" pos="0 0.05 0"/></body>
  </worldbody>
  <tendon>
    <spatial name="cable" stiffness="20" damping="0.3 0.1" limited="true" range="0 2"
             armature="0.05">
      <site site="anchor"/><site site="s1"/><site site="s2"/><site site="s3"/>
      <site site="s4"/>
    </spatial>
    <spatial name="pulley" stiffness="5" springlength="0.4">
      <site site="anchor2"/><site site="s1"/>
      <pulley divisor="2"/>
      <site site="s3"/><site site="s5"/>
    </spatial>
    <spatial name="band" stiffness="8 0 3" springlength="0.2 0.3">
      <site site="s2"/><site site="s5"/>
    </spatial>
  </tendon>
  <actuator>
    <motor name="pull" tendon="cable" gear="2" ctrlrange="-1 1"/>
    <position name="hold" tendon="pulley" kp="3" kv="0.5"/>
    <general name="filtered" tendon="band" dyntype="filter" dynprm="0.2" gainprm="4"/>
  </actuator>
</mujoco>
"""


def tendon_lengths(definition, model, y):
    values = {s: y[model.index(name_of(s))] for s in definition.symbols["q"]}
    return np.array([float(L.xreplace(values))
                     for L in definition.symbols["tendons"].values()])


def test_spatial_tendons_match_mujoco(tmp_path):
    """Sites on the world, on hinged bodies, on a ball joint's body and on a free
    body; a pulley; springs about the length at the spring references (default),
    a length and a dead band (cubic); linear and quadratic damping from a default
    class and its own; armature (of a tendon within one kinematic tree); a
    motor, a position servo and a filtered actuator on tendons."""
    path = tmp_path / "spatial.xml"
    path.write_text(SPATIAL)
    definition = kd.models.from_mjcf(path)
    model, ctrl = numeric_with_controls(definition)
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    data = mujoco.MjData(mj)
    rng = np.random.default_rng(2)
    worst_length = worst_qacc = 0.0
    for _ in range(4):
        qpos, qvel, ctrl[:] = random_state(definition, rng, mj.nv, mj.nu)
        act = rng.uniform(-1, 1, mj.na)
        data.qpos[:], data.qvel[:], data.ctrl[:], data.act[:] = qpos, qvel, ctrl, act
        mujoco.mj_forward(mj, data)
        y = definition.state_from_mujoco(model, qpos, qvel, act)
        worst_length = max(worst_length, np.max(np.abs(tendon_lengths(definition, model, y)
                                                       - data.ten_length)))
        qacc = definition.qacc(model, 0.0, y)
        worst_qacc = max(worst_qacc, np.max(np.abs(qacc - data.qacc))
                         / max(1.0, np.max(np.abs(data.qacc))))
    assert worst_length < 1e-14, worst_length
    assert worst_qacc < 1e-12, worst_qacc


def test_ball_in_cup_matches_mujoco():
    """dm_control's ball-in-cup, refused before for its spatial tendon (a string
    between two sites, whose length limit is not applied)."""
    path = suite_folder() / "ball_in_cup.xml"
    definition = kd.models.from_mjcf(path)
    assert list(definition.symbols["tendons"]) == ["string"]
    assert compare_with_mujoco(path, states=3, definition=definition) < 1e-12


REFUSED = {
    "wrapping": ("<spatial><site site='a'/><geom geom='g'/><site site='b'/></spatial>",
                 r"<geom>: a spatial tendon wrapping around a geom is not supported"),
    "one site": ("<spatial><site site='a'/></spatial>",
                 r"<spatial>: a spatial tendon \(and each branch after a pulley\) needs "
                 "at least two sites"),
    "unknown site": ("<spatial><site site='a'/><site site='c'/></spatial>",
                     r"<site>: site='c': no site of that name"),
    "pulley without a divisor": (
        "<spatial><site site='a'/><site site='b'/><pulley/><site site='a'/>"
        "<site site='b'/></spatial>", r"<pulley>: a pulley needs a positive divisor"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_refused_spatial_tendons_name_file_element_and_line(case, tmp_path):
    tendon, pattern = REFUSED[case]
    path = tmp_path / "model.xml"
    path.write_text("<mujoco><worldbody><site name='a'/><body><joint/><geom name='g' "
                    "size='0.1'/><site name='b' pos='0.2 0 0'/></body></worldbody>"
                    f"<tendon>\n{tendon}</tendon></mujoco>")
    with pytest.raises(MJCFError, match=r"model\.xml:2: " + pattern):
        kd.models.from_mjcf(path)


TWO_TREES = """\
<mujoco><worldbody>
  <body name="arm"><joint name="j" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/><site name="a" pos="0.3 0 0"/>
    <body pos="0.3 0 0"><joint name="k" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/></body></body>
  <body name="cart" pos="0 0.5 0"><joint name="s" type="slide" axis="1 0 0"/>
    <geom type="box" size="0.05 0.05 0.05"/><site name="b"/></body>
</worldbody>
<tendon>
  <fixed name="t" armature="0.3" stiffness="2"><joint joint="j" coef="1"/>
    <joint joint="k" coef="0.5"/><joint joint="s" coef="-2"/></fixed>
  SPATIAL
</tendon>
<actuator><motor tendon="t"/></actuator></mujoco>
"""


def test_tendon_armature_across_kinematic_trees(tmp_path):
    """A fixed tendon with armature coupling an arm and a separate cart: MuJoCo
    adds the armature within each kinematic tree only (no inertia coupling the
    arm and the cart), and so does kanedyn; a spatial tendon with armature
    across the two trees is refused (MuJoCo's velocity term then is not that of
    the trees' parts)."""
    path = tmp_path / "trees.xml"
    path.write_text(TWO_TREES.replace("SPATIAL", ""))
    assert compare_with_mujoco(path, states=4) < 1e-12
    path.write_text(TWO_TREES.replace("SPATIAL", "<spatial armature='0.1'><site site='a'/>"
                                      "<site site='b'/></spatial>"))
    with pytest.raises(MJCFError, match=r"trees\.xml:12: <spatial>: armature of a spatial "
                                        r"tendon spanning several kinematic trees \(below "
                                        r"bodies arm, cart\) is not supported"):
        kd.models.from_mjcf(path)
