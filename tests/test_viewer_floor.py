"""The ground grid under everything drawn at every frame, and shapes fixed in the
inertial frame (a robot's fixed base).

A box spins about x while it falls freely (z = -g t^2 / 2): its lowest corner at
each frame is computed here from its 8 corners, and the grid height of the scene
must be the lowest of these over all the frames (not over a sample of them).
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.io import scene_data

LENGTHS = np.array([0.2, 0.4, 1.0])


def _falling_spinning_box(t_end=3.0, spin=7.0, points=301):
    z, th, w, v = me.dynamicsymbols("z th w v")
    g = sm.symbols("g")
    N, A = me.ReferenceFrame("N"), me.ReferenceFrame("A")
    A.orient_axis(N, N.x, th)
    A.set_ang_vel(N, v * N.x)
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", z * N.z)
    G.set_vel(N, w * N.z)
    body = me.RigidBody("box", G, A, 1.0, (me.inertia(A, 1, 1, 1), G))
    eom = kd.kane(frame=N, q_ind=[z, th], u_ind=[w, v],
                  kd_eqs=[z.diff() - w, th.diff() - v], bodies=[body],
                  loads=[(G, -g * N.z)])
    model = eom.numeric(constants={g: 9.81})
    t = np.linspace(0, t_end, points)
    res = kd.simulate(model, (0, t_end), [0.0, 0.0, 0.0, spin], t_eval=t, rtol=1e-10,
                      atol=1e-10)
    assert res.success, res.message
    return res, body, N


def _lowest_corner(z, th):
    corners = np.array([[x, y, c] for x in (-1, 1) for y in (-1, 1) for c in (-1, 1)])
    corners = corners * LENGTHS / 2
    # rotation about x by th: the corner's height is y sin th + c cos th
    heights = np.outer(np.sin(th), corners[:, 1]) + np.outer(np.cos(th), corners[:, 2])
    return z + heights.min(axis=1)


def test_grid_under_the_lowest_corner_over_all_frames():
    res, body, _ = _falling_spinning_box()
    scene = scene_data(res, visuals=[kd.visuals.Box(body, LENGTHS)], up="z")
    expected = _lowest_corner(res["z"], res["th"])
    assert scene["floor"] == pytest.approx(expected.min(), abs=1e-6)
    assert scene["floor"] < -0.5 * 9.81 * 3.0 ** 2  # fell 44 m below its start
    # drawn from fewer frames, the grid is still under the lowest of those frames
    few = scene_data(res, visuals=[kd.visuals.Box(body, LENGTHS)], up="z", max_frames=7)
    kept = np.round(np.linspace(0, len(res.t) - 1, 7)).astype(int)
    assert few["floor"] == pytest.approx(expected[kept].min(), abs=1e-6)


def test_grid_under_a_sphere_and_a_cylinder_exactly():
    """Ellipsoid and cylinder supports: a sphere of radius r is r below its centre;
    a cylinder along the box's y of radius r, length L at angle th reaches
    L/2 |sin th| + r |cos th| below its centre."""
    res, body, _ = _falling_spinning_box(t_end=0.5, spin=2.0, points=51)
    z, th = res["z"], res["th"]
    sphere = scene_data(res, visuals=[kd.visuals.Sphere(body, 0.3)], up="z")
    assert sphere["floor"] == pytest.approx((z - 0.3).min(), abs=1e-6)
    cyl = scene_data(res, visuals=[kd.visuals.Cylinder(body, 0.1, 0.8, axis="y")], up="z")
    reach = 0.4 * np.abs(np.sin(th)) + 0.1 * np.abs(np.cos(th))
    assert cyl["floor"] == pytest.approx((z - reach).min(), abs=1e-6)


def test_shapes_fixed_in_the_inertial_frame():
    res, body, N = _falling_spinning_box(t_end=0.2, points=21)
    base = kd.visuals.Box(N, (2.0, 2.0, 0.5), offset=(0, 0, 5.0), color="#445566")
    scene = scene_data(res, visuals=[base, kd.visuals.Box(body, LENGTHS)], up="z")
    fixed = scene["fixed"]
    assert fixed["name"] == "N (fixed)" and fixed["color"] == "#445566"
    (shape,) = fixed["shapes"]
    assert shape["kind"] == "box" and shape["offset"] == [0.0, 0.0, 5.0]
    assert [b["name"] for b in scene["bodies"]] == ["box"]
    without = scene_data(res, visuals=[kd.visuals.Box(body, LENGTHS)], up="z")
    assert without["fixed"] is None
    # a fixed shape below the model lowers the grid
    low = kd.visuals.Box(N, (1.0, 1.0, 1.0), offset=(0, 0, -10.0))
    assert scene_data(res, visuals=[low], up="z")["floor"] == pytest.approx(-10.5)
    with pytest.raises(kd.ModelError, match="box of body B: B is not the inertial frame N"):
        scene_data(res, visuals=[kd.visuals.Box(me.ReferenceFrame("B"), (1, 1, 1))])


def test_urdf_fixed_base_drawn(tmp_path):
    """A URDF root link's visual (fixed to the ground) is a shape fixed in N, placed
    from the root's origin, in its rgba colour; the legend shows that colour."""
    path = tmp_path / "r.urdf"
    path.write_text("""<robot name="r">
  <material name="slate"><color rgba="0.2 0.4 0.6 1"/></material>
  <link name="base">
    <visual><origin xyz="0 0 -0.05"/><geometry><box size="0.3 0.3 0.1"/></geometry>
      <material name="slate"/></visual>
  </link>
  <link name="arm">
    <inertial><origin xyz="0 0 0.5"/><mass value="1"/>
      <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.01"/></inertial>
    <visual><origin xyz="0 0 0.5"/><geometry><cylinder radius="0.03" length="1"/>
      </geometry></visual>
  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>
""")
    definition = kd.models.from_urdf(path)
    model = definition.numeric()
    y0 = np.array([0.5, 0.0])
    res = kd.simulate(model, (0, 0.3), y0, t_eval=np.linspace(0, 0.3, 11))
    shapes = definition.shapes()
    # the arm's cx is not in its equations (it turns about x): given to the viewer
    scene = scene_data(res, visuals=shapes, inputs=dict(definition.constants))
    fixed = scene["fixed"]
    assert fixed["color"] == "#336699"
    (box,) = fixed["shapes"]
    assert box["kind"] == "box" and box["lengths"] == [0.3, 0.3, 0.1]
    np.testing.assert_allclose(box["offset"], [0, 0, -0.05])
    assert scene["floor"] == pytest.approx(-0.1)  # the base's bottom, the arm above
