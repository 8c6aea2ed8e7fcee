"""Mesh geoms whose mass is inferred (kd.models.from_mjcf) against MuJoCo's compiler.

For each ``<mesh inertia=...>`` mode (MuJoCo's default ``legacy``, ``convex``,
``exact``, ``shell``), meshes from STL, OBJ and MuJoCo's ``.msh`` files and
inline vertices, scaled, moved by ``refpos``/``refquat`` and placed by their
geoms: kanedyn's body mass, mass centre and inertia against MuJoCo's compiled
``body_mass``, ``body_ipos`` and ``body_inertia``/``body_iquat``, and its
accelerations against ``mj_forward``'s ``qacc`` at random states.  The real
model is dm_control's Kinova Jaco arm (meshes with given masses, inertias from
their triangles).
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.models import MJCFError
from kanedyn.models.mjcf._frames import quat_matrix

sys.path.insert(0, str(Path(__file__).parent))
from test_mjcf import compare_with_mujoco  # noqa: E402

mujoco = pytest.importorskip("mujoco", reason="the MJCF tests compare with MuJoCo "
                             "(pip install mujoco)")
trimesh = pytest.importorskip("trimesh", reason="STL and OBJ meshes are read with trimesh")


@pytest.fixture(autouse=True)
def _mujoco_log_elsewhere(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


def dented_box():
    """A box (0.2 x 0.3 x 0.1 m) whose top is pushed in to a point 0.09 m below
    it: a closed, outward-oriented, non-convex mesh (its hull is the box)."""
    box = trimesh.creation.box(extents=[0.2, 0.3, 0.1])
    vertices = np.vstack([box.vertices, [[0.0, 0.0, -0.04]]]) + [0.03, -0.02, 0.05]
    top = sorted((i for i, v in enumerate(box.vertices) if v[2] > 0),
                 key=lambda i: np.arctan2(box.vertices[i][1], box.vertices[i][0]))
    faces = [f for f in box.faces if not all(box.vertices[i][2] > 0 for i in f)]
    faces += [[top[k], top[(k + 1) % 4], 8] for k in range(4)]
    return trimesh.Trimesh(vertices, np.array(faces), process=False)


def _inline(mesh):
    return (f'vertex="{" ".join(f"{x:.17g}" for x in mesh.vertices.ravel())}" '
            f'face="{" ".join(str(i) for i in mesh.faces.ravel())}"')


def mesh_model(folder):
    """An MJCF file whose bodies each carry one mesh geom (one an extra box)."""
    dent = dented_box()
    (folder / "meshes").mkdir()
    dent.export(folder / "meshes" / "dent.stl")
    trimesh.creation.icosphere(subdivisions=1, radius=0.05).export(
        folder / "meshes" / "ball.obj")
    shutil.copy(Path(mujoco.__file__).parent / "testdata" / "abdomen_1_body.msh",
                folder / "meshes")
    text = f"""\
    <mujoco model="meshes">
      <compiler meshdir="meshes"/>
      <option gravity="0.3 -0.5 -9.81"/>
      <default>
        <mesh scale="1 1 1"/>
        <default class="big"><mesh scale="1.5 0.8 1.2"/></default>
      </default>
      <asset>
        <mesh file="dent.stl"/>
        <mesh name="dent_exact" file="dent.stl" inertia="exact"/>
        <mesh name="dent_convex" file="dent.stl" inertia="convex" class="big"/>
        <mesh name="dent_shell" file="dent.stl" inertia="shell" refpos="0.01 0.02 0.03"
              refquat="0.9 0.1 -0.3 0.2"/>
        <mesh name="ball" file="ball.obj" scale="0.7 1.1 1.3"/>
        <mesh name="abdomen" file="abdomen_1_body.msh"/>
        <mesh name="inline" {_inline(dent)} inertia="exact" scale="0.5 0.5 0.5"/>
        <mesh name="hull" vertex="0 0 0 0.1 0 0 0 0.2 0 0 0 0.3 0.05 0.05 0.05"/>
      </asset>
      <worldbody>
        <body name="legacy"><joint axis="0 1 0"/>
          <geom type="mesh" mesh="dent" pos="0.1 0 0" euler="10 20 30"/></body>
        <body name="exact" pos="0.5 0 0"><joint axis="1 0 0"/>
          <geom type="mesh" mesh="dent_exact" density="700"/></body>
        <body name="convex" pos="1 0 0"><joint axis="0 0 1"/><joint axis="1 0 0"/>
          <geom type="mesh" mesh="dent_convex" mass="2"/>
          <geom type="box" size="0.05 0.02 0.01" pos="0 0.2 0"/></body>
        <body name="shell" pos="1.5 0 0"><joint type="ball"/>
          <geom type="mesh" mesh="dent_shell" density="3"/></body>
        <body name="obj" pos="2 0 0"><joint type="slide" axis="0 0 1"/>
          <joint axis="0 1 0" pos="0.1 0 0"/>
          <geom type="mesh" mesh="ball" quat="0.8 0.2 0.1 0.3"/></body>
        <body name="msh" pos="2.5 0 0"><joint axis="1 1 0"/>
          <geom type="mesh" mesh="abdomen" pos="0 0 -0.1"/></body>
        <body name="inline" pos="3 0 0"><freejoint/>
          <geom type="mesh" mesh="inline"/></body>
        <body name="hull" pos="3.5 0 0"><joint axis="0 1 1"/>
          <geom type="mesh" mesh="hull"/></body>
      </worldbody>
    </mujoco>
    """
    path = folder / "meshes.xml"
    path.write_text(text)
    return path


def _values(definition):
    return {str(s): v for s, v in definition.constants.items()}


def assert_bodies_match(definition, mj, names):
    """Mass (1e-13), mass centre (1e-13 m), principal moments (1e-12) and the
    inertia tensor (1e-7: the principal axes MuJoCo compiles for a mesh, ``body_iquat``,
    carry its eigen-solver's tolerance, up to 6e-8 here) against MuJoCo's compiled
    bodies."""
    values = _values(definition)
    for name in names:
        body = mj.body(name)
        R = quat_matrix(body.iquat)
        J = R @ np.diag(body.inertia) @ R.T
        mine = np.array([[values.get(f"I{a}{b}_{name}", values.get(f"I{b}{a}_{name}"))
                          for b in "xyz"] for a in "xyz"], dtype=float)
        assert values[f"m_{name}"] == pytest.approx(body.mass[0], rel=1e-13), name
        assert [values[f"c{a}_{name}"] for a in "xyz"] == pytest.approx(body.ipos,
                                                                         abs=1e-13), name
        assert np.sort(np.linalg.eigvalsh(mine)) == pytest.approx(
            np.sort(body.inertia), rel=1e-12), name
        assert np.abs(mine - J).max() <= 1e-7 * np.abs(J).max(), name


def test_mesh_inertia_in_every_mode_matches_mujoco(tmp_path):
    path = mesh_model(tmp_path)
    definition = kd.models.from_mjcf(path)
    mj = mujoco.MjModel.from_xml_path(str(path))
    assert_bodies_match(definition, mj, ["legacy", "exact", "convex", "shell", "obj",
                                         "msh", "inline", "hull"])
    # legacy over-counts the dent: more mass than the exact solid, less than the hull
    values = _values(definition)
    assert values["m_exact"] / 700 < values["m_legacy"] / 1000 < mj.body("convex").mass[0]
    # MuJoCo's dynamics use its compiled axes, off by up to 6e-8 (above): qacc agrees
    # to that (5.4e-8 over 20 states)
    worst = compare_with_mujoco(path, states=4, definition=definition)
    assert worst < 2e-7, worst


def test_jaco_arm_meshes_match_mujoco():
    """dm_control's Kinova Jaco arm: six mesh links with their masses given and
    inertias from their STL files (legacy mode), a second top-level <default>."""
    kinova = pytest.importorskip("dm_control").__file__
    path = Path(kinova).parent / "third_party" / "kinova" / "jaco_arm.xml"
    definition = kd.models.from_mjcf(path)
    mj = mujoco.MjModel.from_xml_path(str(path))
    assert_bodies_match(definition, mj, [f"b_{k}" for k in range(1, 6)])
    worst = compare_with_mujoco(path, states=3, definition=definition)
    assert worst < 1e-9, worst


def test_two_top_level_defaults_merge_as_mujoco_does(tmp_path):
    """A second top-level <default> adds to the top class; a class it declares
    starts from the top class as it is then, one declared before does not."""
    path = tmp_path / "defaults.xml"
    path.write_text("""<mujoco>
      <default><joint damping="2"/><default class="a"><joint armature="1"/></default>
      </default>
      <default><joint stiffness="3"/><default class="b"><joint armature="5"/></default>
      </default>
      <worldbody><body><joint name="j"/><geom size="0.1"/></body>
        <body><joint name="k" class="b"/><geom size="0.1"/></body>
        <body><joint name="l" class="a"/><geom size="0.1"/></body></worldbody>
    </mujoco>""")
    joints = {j.name: j for j in kd.models.from_mjcf(path).joints}
    mj = mujoco.MjModel.from_xml_path(str(path))
    for name, joint in joints.items():
        dof = mj.joint(name).dofadr[0]
        assert (joint.damping, joint.stiffness, joint.armature) == (
            mj.dof_damping[dof], mj.jnt_stiffness[mj.joint(name).id], mj.dof_armature[dof])


BAD_MESHES = {
    "outside the model's folder": (
        '<mesh file="../outside.stl"/>', '<geom type="mesh" mesh="outside"/>',
        r"meshes\.xml:\d+: <mesh>: file '\.\./outside\.stl' .* is outside the model's "
        r"folder .* give from_mjcf\(\.\.\., mesh_dirs=\[its folder\]\)"),
    "missing file": (
        '<mesh file="gone.stl"/>', '<geom type="mesh" mesh="gone"/>',
        r"meshes\.xml:\d+: <mesh>: file 'gone\.stl' not found"),
    "unknown mesh": (
        '<mesh file="dent.stl"/>', '<geom type="mesh" mesh="dnet"/>',
        r"meshes\.xml:\d+: <geom>: mesh='dnet': no mesh asset of that name"),
    "primitive fitted to a mesh": (
        '<mesh file="dent.stl"/>', '<geom type="box" mesh="dent"/>',
        r"meshes\.xml:\d+: <geom>: mesh='dent': a box fitted to a mesh is not supported"),
    "exact of an open mesh": (
        '<mesh name="open" vertex="0 0 0 1 0 0 0 1 0 0 0 1" face="0 2 1 0 1 3 0 3 2" '
        'inertia="exact"/>', '<geom type="mesh" mesh="open"/>',
        r"meshes\.xml:\d+: <mesh name='open'>: inertia='exact' needs a closed, "
        "consistently oriented mesh"),
    "unknown inertia mode": (
        '<mesh file="dent.stl" inertia="solid"/>', '<geom type="mesh" mesh="dent"/>',
        r"meshes\.xml:\d+: <mesh>: inertia='solid': 'solid' is not one of legacy, "
        "convex, exact, shell"),
    "a text file as a mesh": (
        '<mesh file="notes.stl"/>', '<geom type="mesh" mesh="notes"/>',
        r"meshes\.xml:\d+: <mesh>: file 'notes\.stl' .*not a readable STL mesh"),
}


@pytest.mark.parametrize("case", sorted(BAD_MESHES))
def test_bad_meshes_name_file_element_and_line(case, tmp_path):
    asset, geom, pattern = BAD_MESHES[case]
    folder = tmp_path / "model"
    folder.mkdir()
    dented_box().export(folder / "dent.stl")
    dented_box().export(tmp_path / "outside.stl")
    (folder / "notes.stl").write_text("not a mesh\n")
    path = folder / "meshes.xml"
    path.write_text(f"<mujoco><asset>\n{asset}\n</asset><worldbody><body><joint/>\n"
                    f"{geom}</body></worldbody></mujoco>")
    with pytest.raises(MJCFError, match=pattern):
        kd.models.from_mjcf(path)


def test_mesh_dirs_allow_a_folder_outside_the_model(tmp_path):
    folder = tmp_path / "model"
    folder.mkdir()
    (tmp_path / "shared").mkdir()
    dented_box().export(tmp_path / "shared" / "dent.stl")
    path = folder / "m.xml"
    path.write_text('<mujoco><compiler meshdir="../shared"/><asset><mesh file="dent.stl"/>'
                    '</asset><worldbody><body name="b"><joint/><geom type="mesh" '
                    'mesh="dent"/></body></worldbody></mujoco>')
    with pytest.raises(MJCFError, match="outside the model's folder"):
        kd.models.from_mjcf(path)
    definition = kd.models.from_mjcf(path, mesh_dirs=[tmp_path / "shared"])
    assert_bodies_match(definition, mujoco.MjModel.from_xml_path(str(path)), ["b"])


def test_fluid_forces_take_a_mesh_geoms_principal_axes(tmp_path):
    """MuJoCo's inertia-box fluid model orients a body's box by its only geom's
    frame, which for a mesh geom is the mesh's principal axes (not the frame of
    the mesh file: that gives 0.15 here); agreement to MuJoCo's axes (6.6e-8)."""
    path = mesh_model(tmp_path)
    path.write_text(path.read_text().replace(
        '<option gravity="0.3 -0.5 -9.81"/>',
        '<option gravity="0.3 -0.5 -9.81" density="1000" viscosity="0.5" wind="0.3 0 0.1"/>'))
    worst = compare_with_mujoco(path, states=3)
    assert worst < 2e-7, worst
