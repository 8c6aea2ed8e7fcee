"""Actuators with activation dynamics (kd.models.from_mjcf) against MuJoCo.

Each activation is a first-order state of kanedyn's model; at random states,
controls and activations (inside their ranges), its derivative must equal
``mj_forward``'s ``act_dot`` and the speeds' derivatives its ``qacc``
(constraint solver off).  The real model is dm_control's quadruped (twelve
filtered actuators, eight through fixed tendons, a free body).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.models import MJCFError

sys.path.insert(0, str(Path(__file__).parent))
from test_mjcf import numeric_with_controls, random_state, suite_folder  # noqa: E402

mujoco = pytest.importorskip("mujoco", reason="the MJCF tests compare with MuJoCo "
                             "(pip install mujoco)")


@pytest.fixture(autouse=True)
def _mujoco_log_elsewhere(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


ACTIVATIONS = """\
<mujoco model="activations">
  <option timestep="0.01" gravity="0.2 0 -9.81"/>
  <default><general ctrlrange="-2 2"/></default>
  <worldbody>
    <body name="upper"><joint name="j" axis="0 1 0" damping="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
      <body name="lower" pos="0.3 0 0"><joint name="k" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0.05" size="0.03"/>
        <body name="slider" pos="0.25 0 0"><joint name="s" type="slide" axis="1 0 0"/>
          <geom type="box" size="0.03 0.03 0.03"/></body></body></body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="j" coef="1"/><joint joint="k" coef="-0.5"/>
  </fixed></tendon>
  <actuator>
    <general name="integrator" joint="j" dyntype="integrator" gainprm="2"
             actlimited="true" actrange="-1.5 1.5"/>
    <general name="filter" joint="k" dyntype="filter" dynprm="0.3" gainprm="3"
             ctrlrange="-0.5 0.5"/>
    <general name="exact_early" joint="j" dyntype="filterexact" dynprm="0.3" gainprm="3"
             actearly="true"/>
    <intvelocity name="intvelocity" joint="k" kp="5" kv="0.4" actrange="-2 2"/>
    <cylinder name="cylinder" tendon="t" timeconst="0.2" diameter="0.8" bias="1 2 3"/>
    <position name="position" joint="s" kp="7" timeconst="0.4" forcerange="-3 3"/>
    <general name="affine_early" joint="k" dyntype="integrator" gaintype="affine"
             gainprm="2 0.5 0.1" biastype="affine" biasprm="0.1 0.2 0.3" actearly="true"
             actrange="-1 0.5"/>
    <motor name="motor" joint="s" gear="2"/>
  </actuator>
</mujoco>
"""


def compare_activations(path, definition, states, seed=0):
    """``(max rel. difference of act_dot, of qacc)`` against ``mj_forward``."""
    model, ctrl = numeric_with_controls(definition)
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    data = mujoco.MjData(mj)
    assert (mj.na, mj.nu) == (definition.na, len(definition.actuators))
    rng = np.random.default_rng(seed)
    worst_act = worst_qacc = 0.0
    for _ in range(states):
        qpos, qvel, ctrl[:] = random_state(definition, rng, mj.nv, mj.nu)
        act = np.array([rng.uniform(*(a.actrange or (-1.5, 1.5)))
                        for a in definition.actuators if a.act is not None])
        data.qpos[:], data.qvel[:], data.ctrl[:], data.act[:] = qpos, qvel, ctrl, act
        mujoco.mj_forward(mj, data)
        y = definition.state_from_mujoco(model, qpos, qvel, act)
        assert definition.mujoco_act(model, y) == pytest.approx(act, abs=0)
        a_dot = definition.act_dot(model, 0.0, y)
        qacc = definition.qacc(model, 0.0, y)
        worst_act = max(worst_act, np.max(np.abs(a_dot - data.act_dot))
                        / max(1.0, np.max(np.abs(data.act_dot))))
        worst_qacc = max(worst_qacc, np.max(np.abs(qacc - data.qacc))
                         / max(1.0, np.max(np.abs(data.qacc))))
    return worst_act, worst_qacc


def test_every_activation_kind_matches_mujoco(tmp_path):
    """integrator with a range, filter, filterexact acting early, intvelocity,
    cylinder through a fixed tendon, position with a time constant and a force
    range, an affine integrator acting early within its range, and a motor."""
    path = tmp_path / "activations.xml"
    path.write_text(ACTIVATIONS)
    definition = kd.models.from_mjcf(path)
    kinds = {a.name: a.dyntype for a in definition.actuators}
    assert kinds == {"integrator": "integrator", "filter": "filter",
                     "exact_early": "filterexact", "intvelocity": "integrator",
                     "cylinder": "filter", "position": "filterexact",
                     "affine_early": "integrator", "motor": "none"}
    assert [a.act_index for a in definition.actuators] == [0, 1, 2, 3, 4, 5, 6, None]
    worst_act, worst_qacc = compare_activations(path, definition, states=6)
    assert worst_act < 1e-12, worst_act
    assert worst_qacc < 1e-12, worst_qacc


def test_an_integrator_stops_at_the_end_of_its_range(tmp_path):
    """A constant control drives an integrator's activation up its range, where
    it stays: MuJoCo's own steps (which clamp the activation) against
    kanedyn's simulation, whose rate stops at the range's end."""
    path = tmp_path / "ramp.xml"
    path.write_text("""<mujoco><option timestep="0.001"/><worldbody><body>
      <joint name="j" axis="0 1 0"/><geom size="0.1" pos="0.2 0 0"/></body></worldbody>
      <actuator><general name="a" joint="j" dyntype="integrator" actrange="-1 0.3"/>
      </actuator></mujoco>""")
    definition = kd.models.from_mjcf(path)
    model = definition.numeric(definition.derive(),
                               specified={definition.symbols["ctrl"]["a"]: 0.5})
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    data.ctrl[:] = 0.5
    times, mine = [0.3, 0.6, 0.9], []
    res = kd.simulate(model, (0, 0.9), definition.state_from_mujoco(
        model, data.qpos, data.qvel, data.act), t_eval=times, rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    for k, t in enumerate(times):
        while data.time < t - 1e-9:
            mujoco.mj_step(mj, data)
        mine.append(res["act_a"][k])
        assert mine[-1] == pytest.approx(data.act[0], abs=1e-6), t
    assert mine == pytest.approx([0.15, 0.3, 0.3], abs=1e-6)


def test_quadruped_matches_mujoco(tmp_path):
    """dm_control's quadruped, refused before for its activations: twelve
    filtered actuators (eight through fixed tendons) and a free body.  Its four
    soft tendon couplings (equalities) are taken out of a copy: kanedyn holds
    them rigidly, MuJoCo's constraint solver (off here) softly."""
    import shutil
    text = (suite_folder() / "quadruped.xml").read_text()
    start, end = text.index("<equality>"), text.index("</equality>") + len("</equality>")
    shutil.copytree(suite_folder() / "common", tmp_path / "common")
    path = tmp_path / "quadruped.xml"
    path.write_text(text[:start] + text[end:])
    definition = kd.models.from_mjcf(path)
    assert definition.na == 12
    worst_act, worst_qacc = compare_activations(path, definition, states=3)
    assert worst_act < 1e-12, worst_act
    assert worst_qacc < 1e-9, worst_qacc


def test_quadruped_with_its_couplings_along_its_motion():
    """The quadruped as shipped: its four tendon couplings held rigidly by
    kanedyn (residuals below 1e-9 along 0.2 s driven by constant controls);
    MuJoCo with the couplings as stiff as it allows (impedance 0.9999, time
    constant 1e-4 s) gives the same act_dot, and qacc to 1e-3 (its constraint
    force is 0.9999 of the rigid one)."""
    definition = kd.models.from_mjcf(suite_folder() / "quadruped.xml")
    assert len(definition.equalities) == 4 and definition.na == 12
    ctrl = {a.ctrl: 0.3 * np.cos(k) for k, a in enumerate(definition.actuators)}
    model = definition.numeric(definition.derive(), specified=ctrl)
    res = kd.simulate(model, (0.0, 0.2), definition.initial(model), rtol=1e-11,
                      atol=1e-11)
    assert res.success, res.message
    mj = mujoco.MjModel.from_xml_path(str(suite_folder() / "quadruped.xml"))
    mj.eq_solimp[:, :3] = [0.9999, 0.9999, 0.001]
    mj.eq_solref[:] = [1e-4, 1.0]
    mj.opt.disableflags |= (mujoco.mjtDisableBit.mjDSBL_CONTACT
                            | mujoco.mjtDisableBit.mjDSBL_LIMIT
                            | mujoco.mjtDisableBit.mjDSBL_REFSAFE)
    data = mujoco.MjData(mj)
    data.ctrl[:] = [ctrl[a.ctrl] for a in definition.actuators]
    step = max(1, len(res.t) // 8)
    worst_qacc = worst_act = residual = 0.0
    for t, y in zip(res.t[::step], res.y.T[::step]):
        data.qpos[:], data.qvel[:] = definition.mujoco_state(model, y)
        data.act[:] = definition.mujoco_act(model, y)
        mujoco.mj_forward(mj, data)
        qacc = definition.qacc(model, t, y)
        worst_qacc = max(worst_qacc, np.max(np.abs(qacc - data.qacc))
                         / max(1.0, np.max(np.abs(data.qacc))))
        worst_act = max(worst_act, np.max(np.abs(definition.act_dot(model, t, y)
                                                 - data.act_dot)))
        residual = max(residual, np.max(np.abs(model.constraint_residuals(t, y))))
    assert residual < 1e-9, residual
    assert worst_act < 1e-12, worst_act
    assert worst_qacc < 1e-3, worst_qacc


REFUSED = {
    "muscle": ("<muscle joint='j'/>", r"<muscle>: <muscle> actuators are not supported"),
    "user dynamics": ("<general joint='j' dyntype='user'/>",
                      r"<general>: dyntype='user': 'user' activation dynamics are not "
                      "supported"),
    "zero time constant": ("<general joint='j' dyntype='filter' dynprm='0'/>",
                           r"<general>: dynprm='0': the time constant of a filter must "
                           "be positive"),
    "two activations": ("<general joint='j' dyntype='integrator' actdim='2'/>",
                        r"<general>: actdim='2': one activation per actuator"),
    "reversed range": ("<general joint='j' dyntype='integrator' actrange='1 -1'/>",
                       r"<general>: actrange='1 -1': the lower limit is above the upper"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_refused_activations_name_file_element_and_line(case, tmp_path):
    actuator, pattern = REFUSED[case]
    path = tmp_path / "model.xml"
    path.write_text("<mujoco><worldbody><body><joint name='j'/><geom size='0.1'/></body>"
                    f"</worldbody><actuator>\n{actuator}</actuator></mujoco>")
    with pytest.raises(MJCFError, match=r"model\.xml:2: " + pattern):
        kd.models.from_mjcf(path)


def test_a_state_from_mujoco_needs_the_activations(tmp_path):
    path = tmp_path / "activations.xml"
    path.write_text(ACTIVATIONS)
    definition = kd.models.from_mjcf(path)
    model = numeric_with_controls(definition)[0]
    with pytest.raises(ValueError, match="7 activations: give act"):
        definition.state_from_mujoco(model, np.zeros(3), np.zeros(3))
    without = kd.models.from_mjcf(path, inputs=False)
    assert without.na == 0 and all(a.act is None for a in without.actuators)
