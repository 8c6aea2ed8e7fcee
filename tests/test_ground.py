"""A ground plane for robots: ``from_urdf``/``from_mjcf(..., ground=kd.Ground(...))``
turn collision spheres, capsules and boxes into rigid contacts.  Checked against
statics (normal forces carry the weight, shared by symmetry), closed forms (a
sliding box's stopping distance and time, a sphere's rebound height) and, for a
quadruped dropped on its springy legs, MuJoCo's simulation of the same file."""

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _solo12 as solo12  # noqa: E402

G = 9.81

BOX_MJCF = """<mujoco model="box">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="box" pos="0 0 {z}">
      <freejoint/>
      <geom name="box" type="box" size="0.2 0.1 0.05" mass="2"/>
    </body>
  </worldbody>
</mujoco>
"""

BOX_URDF = """<?xml version="1.0"?>
<robot name="block">
  <link name="block">
    <inertial><mass value="3.0"/>
      <inertia ixx="0.01" iyy="0.02" izz="0.025" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.3 0.2 0.1"/></geometry></collision>
    {extra}
  </link>
</robot>
"""

SPHERE_URDF = """<?xml version="1.0"?>
<robot name="ball">
  <link name="ball">
    <inertial><mass value="0.5"/>
      <inertia ixx="0.0008" iyy="0.0008" izz="0.0008" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><sphere radius="0.04"/></geometry></collision>
  </link>
</robot>
"""


def _state(definition, **values):
    """The definition's initial state with some coordinates/speeds set by name."""
    state = dict(definition.initial_state)
    by_name = {str(s).removesuffix("(t)"): s for s in state}
    for name, value in values.items():
        state[by_name[name]] = value
    return state


def _normal_forces(res, k=-1):
    return {name: forces["normal"][k] for name, forces in res.contact_forces.items()}


def test_tilted_box_settles_on_its_four_bottom_corners(tmp_path):
    """An MJCF box dropped tilted lands on an edge and settles flat: the normal
    forces sum to the weight and, the box being symmetric, each bottom corner
    carries a quarter of it; the top corners none."""
    path = tmp_path / "box.xml"
    path.write_text(BOX_MJCF.format(z=0.2))
    ground = kd.Ground(height=0.0, mu_k=0.6, restitution=0.0)
    definition = kd.models.from_mjcf(path, ground=ground)
    names = [c.name for c in definition.kane_args["contacts"]]
    assert names == [f"box#{k}" for k in range(8)]
    res = kd.simulate(definition.numeric(), (0.0, 1.5),
                      _state(definition, phi_joint0=0.3), max_step=0.01)
    assert res.impacts, "the box must land"
    assert res.y[2, -1] == pytest.approx(0.05, abs=1e-8)  # half its height
    assert np.max(np.abs(res.y[6:, -1])) < 1e-6           # at rest
    forces = _normal_forces(res)
    assert sum(forces.values()) == pytest.approx(2.0 * G, rel=1e-8)
    bottom = [f for f in forces.values() if f > 1e-9]
    assert len(bottom) == 4
    assert bottom == pytest.approx([2.0 * G / 4] * 4, rel=1e-6)


def test_sliding_box_stops_at_the_closed_form(tmp_path):
    """A URDF box launched along the ground at v0 slides to rest after
    v0^2 / (2 mu g) in v0 / (mu g): the slip turns to stick then."""
    path = tmp_path / "block.urdf"
    path.write_text(BOX_URDF.format(extra=""))
    mu, v0 = 0.4, 2.0
    definition = kd.models.from_urdf(path, base="floating",
                                     ground=kd.Ground(height=0.0, mu_k=mu, restitution=0.0))
    res = kd.simulate(definition.numeric(), (0.0, 1.0),
                      _state(definition, z=0.05, v_x=v0), rtol=1e-10, atol=1e-10,
                      max_step=0.01)
    assert res.y[0, -1] == pytest.approx(v0 ** 2 / (2 * mu * G), rel=1e-6)
    assert res.y[2, -1] == pytest.approx(0.05, abs=1e-9)
    sticks = [c.t for c in res.mode_history if c.new == "stick"]
    assert sticks and min(sticks) == pytest.approx(v0 / (mu * G), rel=1e-6)
    assert sum(_normal_forces(res, 10).values()) == pytest.approx(3.0 * G, rel=1e-8)


def test_sphere_rebounds_to_e_squared_of_its_drop(tmp_path):
    """A URDF sphere (offset from its link origin) dropped from h above the
    ground rebounds to e^2 h (Newton's law): its centre is held at the radius
    above the plane, its lowest point touches it."""
    path = tmp_path / "ball.urdf"
    path.write_text(SPHERE_URDF)
    e, h, r = 0.5, 0.3, 0.04
    ground = kd.Ground(height=-0.2, mu_k=0.5, restitution=e, restitution_law="newton")
    definition = kd.models.from_urdf(path, base="floating", ground=ground)
    (contact,) = definition.kane_args["contacts"]
    assert contact.name == "ball/collision0"
    z0 = -0.2 + r + h - 0.1          # the link origin is 0.1 below the centre
    t_land = np.sqrt(2 * h / G)
    res = kd.simulate(definition.numeric(), (0.0, 2 * t_land),
                      _state(definition, z=z0), rtol=1e-10, atol=1e-12, max_step=0.005)
    (impact, *_) = res.impacts
    assert impact.t == pytest.approx(t_land, rel=1e-7)
    after = res.t > impact.t
    assert np.max(res.y[2, after]) - (z0 - h) == pytest.approx(e ** 2 * h, rel=1e-4)


def test_ball_launched_sliding_rolls_at_five_sevenths_of_its_speed(tmp_path):
    """A solid URDF ball (inertia 2/5 m r^2) launched along the ground at v0 without
    spin slides, friction spinning it up, until it rolls at 5 v0 / 7, at
    t = 2 v0 / (7 mu g), 12 v0^2 / (49 mu g) on; then it rolls on without friction
    (the body's point at the bottom of the ball sticks): 2/7 of its kinetic energy
    dissipated."""
    m, r, mu, v0 = 0.5, 0.04, 0.2, 1.0
    path = tmp_path / "ball.urdf"
    path.write_text(SPHERE_URDF.replace('<origin xyz="0 0 0.1"/>', "").replace(
        "0.0008", repr(0.4 * m * r ** 2)))
    definition = kd.models.from_urdf(path, base="floating",
                                     ground=kd.Ground(height=0.0, mu_k=mu, restitution=0.0))
    t_roll = 2 * v0 / (7 * mu * G)
    res = kd.simulate(definition.numeric(), (0.0, 2 * t_roll),
                      _state(definition, z=r, v_x=v0), rtol=1e-10, atol=1e-10)
    (change,) = res.mode_history
    assert (change.old, change.new, change.t) == ("slip", "stick", pytest.approx(t_roll,
                                                                               rel=1e-8))
    after = res.t > t_roll
    from scipy.spatial.transform import Rotation  # the speeds are along the ball's axes
    turned = Rotation.from_euler("XYZ", res.y[3:6, after].T)
    v = turned.apply(res.y[6:9, after].T)
    w = turned.apply(res.y[9:12, after].T)
    assert v[:, 0] == pytest.approx(5 * v0 / 7, rel=1e-8)
    assert w[:, 1] * r == pytest.approx(v[:, 0], rel=1e-8)  # rolling
    x_roll = 12 * v0 ** 2 / (49 * mu * G)
    assert res["x"][-1] == pytest.approx(x_roll + 5 * v0 / 7 * (res.t[-1] - t_roll),
                                         rel=1e-8)
    assert -res.dissipated_work[-1] == pytest.approx(2 / 7 * 0.5 * m * v0 ** 2, rel=1e-8)

def test_capsule_lies_on_the_ground_on_its_end_spheres(tmp_path):
    """A horizontal MJCF capsule falls and rests with its axis at its radius above
    the ground, each end sphere carrying half the weight."""
    path = tmp_path / "capsule.xml"
    path.write_text("""<mujoco><worldbody><body pos="0 0 0.3"><freejoint/>
      <geom name="rod" type="capsule" fromto="-0.2 0 0 0.2 0 0" size="0.03" mass="1.2"/>
      </body></worldbody></mujoco>""")
    definition = kd.models.from_mjcf(path, ground=kd.Ground(height=0.1, mu_k=0.5,
                                                             restitution=0.0))
    assert [c.name for c in definition.kane_args["contacts"]] == ["rod#0", "rod#1"]
    res = kd.simulate(definition.numeric(), (0.0, 0.5), definition.initial_state,
                      max_step=0.01)
    assert res.y[2, -1] == pytest.approx(0.13, abs=1e-9)
    assert list(_normal_forces(res).values()) == pytest.approx([0.6 * G] * 2, rel=1e-8)


def test_ground_input_is_checked(tmp_path):
    """Ground parameters, a ground that is not a Ground, a robot with nothing to
    touch the ground, and collision shapes that cannot: each named."""
    with pytest.raises(kd.ModelError, match="Ground: mu_k must be a finite number >= 0"):
        kd.Ground(height=0.0, mu_k=-0.1, restitution=0.0)
    with pytest.raises(kd.ModelError, match=r"Ground: restitution must be a finite number "
                                            r"in \[0.0, 1.0\], got 1.5"):
        kd.Ground(height=0.0, mu_k=0.5, restitution=1.5)
    with pytest.raises(kd.ModelError, match="Ground: height must be a number, not '0'"):
        kd.Ground(height="0", mu_k=0.5, restitution=0.0)
    with pytest.raises(kd.ModelError, match="Ground: restitution_law must be"):
        kd.Ground(height=0.0, mu_k=0.5, restitution=0.0, restitution_law="hertz")
    with pytest.raises(TypeError, match="mu_k"):
        kd.Ground(height=0.0, restitution=0.0)  # friction has no default
    path = tmp_path / "block.urdf"
    path.write_text(BOX_URDF.format(extra=""))
    with pytest.raises(kd.ModelError, match="from_urdf: ground must be a kanedyn.Ground"):
        kd.models.from_urdf(path, base="floating", ground=True)
    ground = kd.Ground(height=0.0, mu_k=0.5, restitution=0.0)
    path.write_text(BOX_URDF.format(extra="").replace(
        '<box size="0.3 0.2 0.1"/>', '<cylinder radius="0.1" length="0.2"/>'))
    with pytest.raises(kd.models.URDFError, match=r"block\.urdf: ground: no <collision> "
                                                  "sphere or box on a moving link"), \
            pytest.warns(UserWarning, match="a cylinder does not touch the ground"):
        kd.models.from_urdf(path, base="floating", ground=ground)
    path.write_text(BOX_URDF.format(extra='<collision><geometry><cylinder radius="0.1" '
                                          'length="0.2"/></geometry></collision>'))
    with pytest.warns(UserWarning, match=r"1 collision shape\(s\) not in contact with the "
                                         r"ground:\n  .*block\.urdf:7: block/collision1: "
                                         "a cylinder does not touch the ground"):
        definition = kd.models.from_urdf(path, base="floating", ground=ground)
    assert len(definition.kane_args["contacts"]) == 8
    mjcf = tmp_path / "box.xml"
    mjcf.write_text(BOX_MJCF.format(z=0.2))
    with pytest.raises(kd.models.MJCFError, match="from_mjcf: ground must be a "
                                                  "kanedyn.Ground, not 0.5"):
        kd.models.from_mjcf(mjcf, ground=0.5)
    mjcf.write_text(BOX_MJCF.format(z=0.2).replace('name="box" type="box"',
                                                   'name="box" type="box" contype="0" '
                                                   'conaffinity="0"'))
    with pytest.raises(kd.models.MJCFError, match=r"box\.xml: ground: no colliding sphere, "
                                                  "capsule or box geom on a moving body"):
        kd.models.from_mjcf(mjcf, ground=ground)


def test_ground_points_input_is_checked(tmp_path):
    """Explicit ground points: an unknown link (with the close names), a link fixed
    to the ground, a malformed point, a negative radius, points without a ground:
    each named; a link given points has its collision elements replaced, not warned
    about."""
    path = tmp_path / "block.urdf"
    path.write_text(BOX_URDF.format(extra="").replace(
        '<box size="0.3 0.2 0.1"/>', '<mesh filename="block.stl"/>'))
    ground = kd.Ground(height=0.0, mu_k=0.5, restitution=0.0)

    def load(points, base="floating", given=ground):
        return kd.models.from_urdf(path, base=base, ground=given, ground_points=points)

    with pytest.raises(kd.ModelError, match=r"ground_points: .*block\.urdf has no link "
                                            r"'blok' \(did you mean 'block'\?\)"):
        load({"blok": [(0, 0, 0)]})
    with pytest.raises(kd.ModelError, match="link 'block' is fixed to the ground"):
        load({"block": [(0, 0, 0)]}, base="fixed")
    with pytest.raises(kd.ModelError, match=r"ground_points\['block'\]\[1\] must be "
                                            r"\(x, y, z\) or \(x, y, z, radius\)"):
        load({"block": [(0, 0, 0), (0, 0)]})
    with pytest.raises(kd.ModelError, match=r"ground_points\['block'\]\[0\]: the radius "
                                            "must be >= 0, got -0.01"):
        load({"block": [(0, 0, 0, -0.01)]})
    with pytest.raises(kd.ModelError, match=r"ground_points\['block'\] must be a non-empty"):
        load({"block": []})
    with pytest.raises(kd.ModelError, match="ground_points given without a ground"):
        load({"block": [(0, 0, 0)]}, given=None)
    with pytest.raises(kd.models.URDFError, match="give contact points with ground_points"), \
            pytest.warns(UserWarning, match="a mesh does not touch the ground"):
        load(None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the block's mesh is replaced by its points
        definition = load({"block": [(x, y, -0.05) for x in (-0.15, 0.15)
                                     for y in (-0.1, 0.1)]})
    res = kd.simulate(definition.numeric(), (0.0, 0.5), _state(definition, z=0.1),
                      max_step=0.01)
    assert [c.name for c in definition.kane_args["contacts"]] == [
        f"block/point{k}" for k in range(4)]
    assert res.y[2, -1] == pytest.approx(0.05, abs=1e-9)  # resting on its four points
    assert list(_normal_forces(res).values()) == pytest.approx([3.0 * G / 4] * 4, rel=1e-8)


DRUM_MJCF = """<mujoco model="drum">
  <worldbody>
    <body name="stand" pos="1 0 0"><geom type="box" size="0.1 0.1 0.1"/></body>
    <body name="drum" pos="0 0 0.3"><freejoint/>
      <geom name="shell" type="cylinder" size="0.1 0.05" mass="2" contype="0"
            conaffinity="0"/>
      <body name="rim" pos="0 0 -0.05" euler="90 0 0"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_mjcf_ground_points(tmp_path):
    """``from_mjcf(ground_points=...)``: points in the frame of a body welded to the
    moving one (``rim``, turned 90 deg about x: its point (x, y, z) is (x, -z, y - 0.05)
    in the drum's frame), three at 120 deg on a circle 20 mm below the rim: the drum
    rests on them at 0.07 m, each carrying a third of its weight.  Bad input is named
    as for ``from_urdf`` (the same code): an unknown body with the close names, a body
    welded to the world, a malformed point, points without a ground."""
    path = tmp_path / "drum.xml"
    path.write_text(DRUM_MJCF)
    ground = kd.Ground(height=0.0, mu_k=0.5, restitution=0.0)
    points = [(0.1 * np.cos(a), -0.02, 0.1 * np.sin(a)) for a in np.arange(3) * 2 * np.pi / 3]
    with pytest.raises(kd.models.MJCFError, match=r"drum\.xml: ground: no colliding sphere, "
                                                  r"capsule or box geom on a moving body "
                                                  r"\(give contact points with ground_points"):
        kd.models.from_mjcf(path, ground=ground)
    definition = kd.models.from_mjcf(path, ground=ground, ground_points={"rim": points})
    assert [c.name for c in definition.kane_args["contacts"]] == [
        f"rim/point{k}" for k in range(3)]
    res = kd.simulate(definition.numeric(), (0.0, 0.5), definition.initial_state,
                      max_step=0.01)
    assert res.y[2, -1] == pytest.approx(0.07, abs=1e-9)
    assert res.y[3:6, -1] == pytest.approx([0.0] * 3, abs=1e-9)  # level
    assert list(_normal_forces(res).values()) == pytest.approx([2.0 * G / 3] * 3, rel=1e-8)

    def load(points, given=ground):
        return kd.models.from_mjcf(path, ground=given, ground_points=points)

    with pytest.raises(kd.models.MJCFError, match=r"from_mjcf: ground_points: .*drum\.xml has "
                                                  r"no body 'rims' \(did you mean 'rim'\?\)"):
        load({"rims": points})
    with pytest.raises(kd.models.MJCFError, match="from_mjcf: ground_points: body 'stand' is "
                                                  "fixed to the ground"):
        load({"stand": points})
    with pytest.raises(kd.models.MJCFError, match=r"from_mjcf: ground_points\['rim'\]\[2\] "
                                                  r"must be \(x, y, z\) or \(x, y, z, radius\), "
                                                  "finite numbers in m in the body's frame"):
        load({"rim": points[:2] + [(0.0, "a", 0.0)]})
    with pytest.raises(kd.models.MJCFError, match=r"ground_points\['rim'\]\[0\]: the radius "
                                                  "must be >= 0"):
        load({"rim": [(0, 0, 0, -1)]})
    with pytest.raises(kd.models.MJCFError, match="from_mjcf: ground_points must be a dict "
                                                  r"\{body name"):
        load([points])
    with pytest.raises(kd.models.MJCFError, match="from_mjcf: ground_points given without a "
                                                  "ground"):
        load({"rim": points}, given=None)

QUADRUPED_MJCF = """<mujoco model="quadruped">
  <option gravity="0 0 -9.81" timestep="0.0005"/>
  <default>
    <joint type="hinge" axis="0 1 0" stiffness="40" damping="0.4"/>
    <geom type="capsule" size="0.015" mass="0.15" friction="0.8"/>
  </default>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="base" pos="0 0 0.45">
      <freejoint/>
      <geom name="base" type="box" size="0.2 0.1 0.03" mass="1.5"/>
      <body name="fl" pos="0.18 0.12 0"><joint name="fl"/>
        <geom name="fl" fromto="0 0 0 0.05 0 -0.22"/></body>
      <body name="fr" pos="0.18 -0.12 0"><joint name="fr"/>
        <geom name="fr" fromto="0 0 0 0.05 0 -0.22"/></body>
      <body name="hl" pos="-0.18 0.12 0"><joint name="hl"/>
        <geom name="hl" fromto="0 0 0 -0.05 0 -0.22"/></body>
      <body name="hr" pos="-0.18 -0.12 0"><joint name="hr"/>
        <geom name="hr" fromto="0 0 0 -0.05 0 -0.22"/></body>
    </body>
  </worldbody>
</mujoco>
"""


def _mujoco_drop(path, t_end):
    """MuJoCo's times (n,), base height (n,), the summed normal contact force at
    the end (N) and the final hip angles (4,), rad."""
    mujoco = pytest.importorskip("mujoco")
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    t, z = [], []
    while data.time < t_end:
        mujoco.mj_step(model, data)
        t.append(data.time)
        z.append(data.qpos[2])
    wrench = np.zeros(6)
    total = 0.0
    for i in range(data.ncon):
        mujoco.mj_contactForce(model, data, i, wrench)
        total += wrench[0]  # along the contact normal
    return np.array(t), np.array(z), total, data.qpos[7:].copy()


def _settled_after(t, z, tol=1e-3):
    """The last time the height is farther than ``tol`` (m) from its final value."""
    return t[np.nonzero(np.abs(z - z[-1]) > tol)[0][-1]]


@pytest.mark.slow
def test_quadruped_drop_compared_with_mujoco(tmp_path):
    """A quadruped (box base, four capsule legs on spring-damper hips, MJCF)
    dropped 0.215 m onto the ground, in kanedyn (rigid contacts, plastic impacts,
    Coulomb friction 0.8) and in MuJoCo (its soft contacts, same friction, the
    file's own floor plane).  Both land at the free-fall time; the base rests
    0.235 m high in kanedyn (legs undeflected: the sticking feet take the
    horizontal load) and 0.3 to 1 mm lower in MuJoCo (its feet sink in and
    creep, the hips deflect by about 0.006 rad); MuJoCo's base dips 10 to 20 mm
    at landing and rings down within 0.15 s, kanedyn's stops at the impact; in
    both the normal forces carry the weight."""
    path = tmp_path / "quadruped.xml"
    path.write_text(QUADRUPED_MJCF)
    definition = kd.models.from_mjcf(path, ground=kd.Ground(height=0.0, mu_k=0.8,
                                                             restitution=0.0))
    assert len(definition.kane_args["contacts"]) == 8 + 4 * 2
    t_end, weight = 1.0, (1.5 + 4 * 0.15) * G
    res = kd.simulate(definition.numeric(), (0.0, t_end), definition.initial_state,
                      max_step=0.01)
    t_mj, z_mj, normal_mj, hips_mj = _mujoco_drop(path, t_end)
    t_fall = np.sqrt(2 * (0.45 - 0.22 - 0.015) / G)
    assert res.impacts[0].t == pytest.approx(t_fall, rel=1e-6)
    assert t_mj[np.argmax(z_mj < 0.235)] == pytest.approx(t_fall, abs=2e-3)
    assert res.y[2, -1] == pytest.approx(0.235, abs=1e-9)
    assert 0.3e-3 < res.y[2, -1] - z_mj[-1] < 1e-3         # MuJoCo's feet sink, creep
    assert 0.010 < 0.235 - np.min(z_mj) < 0.020                # and its dip at landing
    assert np.abs(hips_mj) == pytest.approx([0.006] * 4, abs=1e-3)
    assert np.max(np.abs(res.y[6:10, -1])) < 1e-9              # kanedyn's hips undeflected
    n_q = len(definition.kane_args["q_ind"])
    assert np.max(np.abs(res.y[n_q:, -1])) < 1e-6   # the speeds: at rest
    assert np.all(np.abs(res.y[2, res.t > res.impacts[-1].t] - 0.235) < 1e-6)
    assert 0.0 < _settled_after(t_mj, z_mj) - t_fall < 0.15
    assert sum(_normal_forces(res).values()) == pytest.approx(weight, rel=1e-8)
    assert normal_mj == pytest.approx(weight, rel=1e-3)


SOLO_FEET, SOLO_RADIUS = solo12.FEET, solo12.RADIUS


def _solo12():
    """Solo12's URDF (example-robot-data) and Pinocchio, or skip."""
    from importlib.metadata import PackageNotFoundError
    pin = pytest.importorskip("pinocchio")
    try:
        return solo12.solo12_urdf(), pin
    except PackageNotFoundError:
        pytest.skip("needs example-robot-data")


def _pinocchio_q(pin, pmodel, names, y):
    """Pinocchio's configuration of kanedyn's coordinates ``y[:len(names)]``."""
    from scipy.spatial.transform import Rotation
    q = np.zeros(pmodel.nq)
    q[:3] = y[:3]
    q[3:7] = Rotation.from_euler("XYZ", y[3:6]).as_quat()
    for k, name in enumerate(names[6:], start=6):
        q[pmodel.joints[pmodel.getJointId(name.removeprefix("q_"))].idx_q] = y[k]
    return q


def test_solo12_stands_on_its_feet():
    """Solo12 (mesh collisions only: its feet given as ``ground_points``, spheres of
    the foot mesh's 16 mm radius) dropped level from 0.30 m with PD joint springs
    holding the straight-standing posture: it lands at the free-fall time of its
    lowest feet (from Pinocchio's forward kinematics), settles, and at rest (i) the
    normal forces sum to its weight (its masses summed from the URDF file), (ii)
    the feet rest on the ground and (iii) Pinocchio's generalized gravity equals
    the spring torques plus the contact forces through the Jacobians of the balls'
    bottoms."""
    import xml.etree.ElementTree as ET
    path, pin = _solo12()
    radius, kp, kd_ = SOLO_RADIUS, 20.0, 0.5
    ground = kd.Ground(height=0.0, mu_k=0.8, restitution=0.0)
    with pytest.warns(UserWarning, match="13 collision shape"):  # the base's, legs' meshes
        definition = kd.models.from_urdf(path, base="floating", ground=ground, ground_points={
            foot: [(0.0, 0.0, 0.0, radius)] for foot in SOLO_FEET})
    assert [c.name for c in definition.kane_args["contacts"]] == [
        f"{foot}/point0" for foot in SOLO_FEET]
    names = [str(s).removesuffix("(t)") for s in definition.kane_args["q_ind"]]
    n = len(names)

    def pd(i, target):
        return lambda t, y: -kp * (y[i] - target) - kd_ * y[n + i]

    specified = {}
    for s in definition.specified:
        joint = str(s).removesuffix("(t)").removeprefix("tau_")
        specified[s] = pd(names.index("q_" + joint), solo12.posture(joint))
    model = definition.numeric(specified=specified, backend="c")
    y0 = np.zeros(2 * n)
    y0[2] = 0.30
    y0[6:n] = [solo12.posture(name.removeprefix("q_")) for name in names[6:]]
    res = kd.simulate(model, (0.0, 2.0), y0, max_step=0.01)

    pmodel = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    data = pmodel.createData()
    feet = [pmodel.getFrameId(foot) for foot in SOLO_FEET]

    def foot_heights(y):
        pin.framesForwardKinematics(pmodel, data, _pinocchio_q(pin, pmodel, names, y))
        return np.array([data.oMf[f].translation[2] for f in feet])

    t_fall = np.sqrt(2 * (np.min(foot_heights(y0)) - radius) / G)
    assert res.impacts[0].t == pytest.approx(t_fall, rel=1e-6)
    y = res.y[:, -1]
    assert np.max(np.abs(y[n:])) < 1e-8                                # at rest
    assert foot_heights(y) == pytest.approx([radius] * 4, abs=1e-9)   # on the ground
    masses = [float(m.get("value")) for m in ET.parse(path).iter("mass")]
    normal = _normal_forces(res)
    assert sum(normal.values()) == pytest.approx(sum(masses) * G, rel=1e-6)
    assert y[2] == pytest.approx(0.236, abs=1e-3)  # the soft PD springs give under load

    # statics with Pinocchio: g(q) = tau + sum_feet J_foot^T f_foot
    q = _pinocchio_q(pin, pmodel, names, y)
    gravity = pin.computeGeneralizedGravity(pmodel, data, q)
    pin.computeJointJacobians(pmodel, data, q)
    pin.framesForwardKinematics(pmodel, data, q)
    tau = np.zeros(pmodel.nv)
    for k, name in enumerate(names[6:], start=6):
        joint = name.removeprefix("q_")
        tau[pmodel.joints[pmodel.getJointId(joint)].idx_v] = -kp * (y[k] - solo12.posture(joint))
    for foot, frame in zip(SOLO_FEET, feet):
        forces = res.contact_forces[f"{foot}/point0"]
        f = forces["friction"][-1] + np.array([0.0, 0.0, forces["normal"][-1]])
        J = pin.getFrameJacobian(pmodel, data, frame, pin.LOCAL_WORLD_ALIGNED)
        # the force acts at the bottom of the ball, r = (0, 0, -radius) from the foot
        r_cross = np.array([[0.0, radius, 0.0], [-radius, 0.0, 0.0], [0.0, 0.0, 0.0]])
        tau += (J[:3] - r_cross @ J[3:]).T @ f
    assert tau == pytest.approx(gravity, abs=1e-8 * np.max(np.abs(gravity)))


def _with_gravity_potential(definition):
    """The definition with its gravity potential ``sum m g z`` declared (from_urdf
    gives gravity as loads): ``res.energy`` and ``res.energy_balance()``."""
    from dataclasses import replace
    N, O, g = definition.kane_args["frame"], definition.symbols["O"], definition.symbols["g"]
    V = sum(b.mass * g * b.masscenter.pos_from(O).dot(N.z)
            for b in definition.kane_args["bodies"])
    return replace(definition, kane_args={**definition.kane_args, "potential_energy": V})


@pytest.fixture(scope="module")
def locked_solo12(tmp_path_factory):
    """Solo12 with its joints locked: the URDF file, Pinocchio's model of it, its
    foot frames and weight (N), and kanedyn's model on a ground of a friction."""
    from types import SimpleNamespace
    path, pin = _solo12()
    locked = solo12.locked_urdf(path, tmp_path_factory.mktemp("solo12") / "locked.urdf")
    pmodel = pin.buildModelFromUrdf(str(locked), pin.JointModelFreeFlyer())

    def model(mu):
        ground = kd.Ground(height=0.0, mu_k=mu, restitution=0.0)
        with pytest.warns(UserWarning, match="collision shape"):  # the meshes
            definition = kd.models.from_urdf(locked, base="floating", ground=ground,
                                             ground_points={foot: [(0, 0, 0, SOLO_RADIUS)]
                                                            for foot in SOLO_FEET})
        return _with_gravity_potential(definition).numeric()

    return SimpleNamespace(path=locked, pin=pin, pmodel=pmodel, model=model,
                           frames=[pmodel.getFrameId(foot) for foot in SOLO_FEET],
                           weight=sum(i.mass for i in pmodel.inertias) * G)


def _foot_points(solo, y):
    """The feet's centres (4, 3) in the world at the locked robot's state ``y``."""
    from scipy.spatial.transform import Rotation
    data = solo.pmodel.createData()
    q = np.concatenate([y[:3], Rotation.from_euler("XYZ", y[3:6]).as_quat()])
    solo.pin.framesForwardKinematics(solo.pmodel, data, q)
    return np.array([data.oMf[f].translation for f in solo.frames])


#: the tilted drop: base height (m), roll and pitch (rad), friction
SOLO_DROP = (0.30, 0.1, 0.15, 0.8)
#: the slide: friction, launch speed (m/s)
SOLO_SLIDE = (0.1, 1.0)


@pytest.fixture(scope="module")
def locked_drop(locked_solo12):
    """The locked Solo12 dropped tilted: its initial state and the result."""
    z, roll, pitch, mu = SOLO_DROP
    y0 = np.zeros(12)
    y0[2:5] = z, roll, pitch
    return y0, kd.simulate(locked_solo12.model(mu), (0.0, 0.5), y0, max_step=0.01)


@pytest.fixture(scope="module")
def locked_slide(locked_solo12):
    """The locked Solo12 launched forwards on its feet: its initial state and result."""
    mu, v0 = SOLO_SLIDE
    y0 = np.zeros(12)
    y0[2] = SOLO_RADIUS - _foot_points(locked_solo12, y0)[0, 2]  # feet on the ground
    y0[6] = v0
    return y0, kd.simulate(locked_solo12.model(mu), (0.0, 1.2 * v0 / (mu * G)), y0,
                           max_step=0.01, rtol=1e-10, atol=1e-10)


def _touchdowns(res):
    """The first time each foot touches the ground (s)."""
    return {foot: min(c.t for c in res.mode_history if c.contact == f"{foot}/point0")
            for foot in SOLO_FEET}


def _check_energy(res):
    """Dissipation is never negative and the energy balance closes: the energy lost
    is what friction and the impacts dissipated."""
    assert np.max(np.abs(res.energy_balance())) < 1e-8 * res.energy[0]
    assert all(impact.energy_loss >= 0 for impact in res.impacts)
    # the friction work (<= 0) never grows but by the work on the residual slip of
    # sticking feet (up to the stick speed)
    assert np.all(np.diff(res.dissipated_work) <= 1e-8 * abs(res.dissipated_work[-1]))
    lost = res.energy[0] - res.energy[-1]  # the rest: normal forces on the contact drift
    assert lost == pytest.approx(-res.dissipated_work[-1]
                                 + sum(i.energy_loss for i in res.impacts), rel=1e-6)


def test_solo12_locked_dropped_tilted_rocks_to_rest(locked_solo12, locked_drop):
    """Solo12 with its joints locked in the standing posture, dropped from a base
    height of 0.30 m rolled 0.1 rad and pitched 0.15 rad (friction 0.8, plastic
    impacts): the front right foot lands first, at its free-fall time (Pinocchio's
    kinematics of the tilted robot); the others follow as it rolls on that foot's
    ball and rocks from foot pair to foot pair until it rests on its four feet,
    each carrying a quarter of its weight; the energy lost is what the impacts
    and friction dissipated, to the integration's tolerance."""
    y0, res = locked_drop
    assert res.success, res.message
    heights = _foot_points(locked_solo12, y0)[:, 2] - SOLO_RADIUS
    first = res.impacts[0]
    assert first.contacts == ("FR_FOOT/point0",)
    assert np.argmin(heights) == 1
    assert first.t == pytest.approx(np.sqrt(2 * np.min(heights) / G), rel=1e-8)
    touchdown = _touchdowns(res)
    assert sorted(touchdown, key=touchdown.get) == ["FR_FOOT", "FL_FOOT", "HL_FOOT", "HR_FOOT"]
    y = res.y[:, -1]
    assert np.max(np.abs(y[6:])) < 1e-6  # at rest, to the stick speed 100 atol
    assert _foot_points(locked_solo12, y)[:, 2] == pytest.approx(  # to the drift
        [SOLO_RADIUS] * 4, abs=1e-7)
    weight = locked_solo12.weight
    assert list(_normal_forces(res).values()) == pytest.approx([weight / 4] * 4, rel=1e-6)
    _check_energy(res)


def test_solo12_locked_slides_to_the_closed_form(locked_solo12, locked_slide):
    """The locked Solo12 standing on a ground of friction 0.1, launched forwards at
    1 m/s: all four feet slide, the robot translates without turning and stops after
    v0^2 / (2 mu g) in v0 / (mu g), every sliding foot at once.  While it slides
    the normal forces carry its weight and the front feet carry more than the hind
    ones: their moment about the mass centre balances the friction's at the ground
    (``sum N_i (x_i - x_G) = mu m g z_G``); the kinetic energy is what friction
    dissipates."""
    from scipy.spatial.transform import Rotation
    mu, v0 = SOLO_SLIDE
    y0, res = locked_slide
    assert res.success, res.message
    t_stop = v0 / (mu * G)
    assert res.y[0, -1] == pytest.approx(v0 ** 2 / (2 * mu * G), rel=1e-9)
    assert np.max(np.abs(res.y[[1, 3, 4, 5], :])) < 1e-9      # no sideways, no turning
    stops = [c for c in res.mode_history if (c.old, c.new) == ("slip", "stick")]
    assert stops and {c.t for c in stops} == {stops[0].t}
    assert stops[0].t == pytest.approx(t_stop, rel=1e-9)
    weight = locked_solo12.weight
    normal = np.array([res.contact_forces[f"{foot}/point0"]["normal"] for foot in SOLO_FEET])
    sliding = res.t < t_stop
    assert normal[:, sliding].sum(axis=0) == pytest.approx(weight, rel=1e-9)
    k = np.searchsorted(res.t, t_stop / 2)
    y = res.y[:, k]
    pin, pmodel = locked_solo12.pin, locked_solo12.pmodel
    q = np.concatenate([y[:3], Rotation.from_euler("XYZ", y[3:6]).as_quat()])
    centre = pin.centerOfMass(pmodel, pmodel.createData(), q)
    feet = _foot_points(locked_solo12, y)
    assert normal[:, k] @ (feet[:, 0] - centre[0]) == pytest.approx(mu * weight * centre[2],
                                                                    rel=1e-8)
    assert normal[0, k] + normal[1, k] > normal[2, k] + normal[3, k]  # front over hind
    assert -res.dissipated_work[-1] == pytest.approx(res.kinetic_energy[0], rel=1e-9)
    _check_energy(res)


def test_solo12_locked_compared_with_mujoco(locked_solo12, locked_drop, locked_slide):
    """The tilted drop and the slide of the locked Solo12 in MuJoCo (its own URDF
    reader gives the same mass matrix as kanedyn's, to rounding).  The model
    differences: MuJoCo's contacts are soft (the feet sink in by a fraction of a
    micrometre at rest, impacts last a few steps, friction is regularized) and it
    steps at 0.02 ms; kanedyn's are rigid, impacts instantaneous and plastic.  The
    feet touch down in the same order, each within 0.1 ms (MuJoCo sees a touch at
    the step after it); after 25 impacts in kanedyn both rest within 0.1 mm and
    0.5 mrad of heading of each other, the base at the same height to 1
    micrometre, the normal forces carrying the weight; MuJoCo's slide stops 0.45 mm
    (0.09 %) beyond v0^2 / (2 mu g), where kanedyn's stops."""
    mujoco = pytest.importorskip("mujoco")
    solo = locked_solo12
    y0, res = locked_drop
    model = solo12.mujoco_model(mujoco, solo.path, SOLO_DROP[3])
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)  # the level pose: MuJoCo's speeds are kanedyn's
    M = np.zeros((6, 6))
    mujoco.mj_fullM(model, data, M)
    assert M == pytest.approx(res.model.mass_matrix(0.0, np.zeros(12)), abs=1e-12)
    theirs = solo12.mujoco_run(mujoco, model, y0, 0.5)
    touchdown, ours = theirs["touchdown"], _touchdowns(res)
    assert sorted(touchdown, key=touchdown.get) == sorted(ours, key=ours.get)
    later = np.array([touchdown[f] - ours[f] for f in SOLO_FEET])
    assert np.all((later >= 0) & (later < 1e-4))
    y = res.y[:, -1]
    assert theirs["position"] == pytest.approx(y[:3], abs=1e-4)
    assert theirs["position"][2] == pytest.approx(y[2], abs=1e-6)
    assert theirs["angles"][2] == pytest.approx(y[5], abs=5e-4)
    assert np.max(np.abs(theirs["qvel"])) < 1e-6
    assert theirs["normal"] == pytest.approx(solo.weight, rel=1e-6)
    mu, v0 = SOLO_SLIDE
    y0, res = locked_slide
    theirs = solo12.mujoco_run(mujoco, solo12.mujoco_model(mujoco, solo.path, mu), y0,
                               res.t[-1])
    assert 0 < theirs["position"][0] - v0 ** 2 / (2 * mu * G) < 1e-3
    assert np.max(np.abs(theirs["qvel"])) < 1e-6
