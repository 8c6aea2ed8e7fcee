"""COLLADA (.dae) meshes: read with trimesh and pycollada, in metres, z up.

The files are written here: a box 2 x 4 x 6 file units whose corners are known,
in a document whose ``<unit>`` and ``<up_axis>`` vary, placed by a node that
translates it by (10, 0, 0) file units.
"""

import base64

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.io._collada import read_dae
from kanedyn.io._meshes import read_mesh

pytest.importorskip("trimesh")
pytest.importorskip("collada")

#: the box's corners in file units (x in +-1, y in +-2, z in +-3)
CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-2, 2) for z in (-3, 3)], float)
#: the 12 triangles of the box, as indices into CORNERS
FACES = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]


def _dae(unit="0.01", up="Y_UP", asset=True):
    floats = " ".join(f"{v:g}" for v in CORNERS.ravel())
    indices = " ".join(str(i) for face in FACES for i in face)
    head = "<asset>"
    if unit is not None:
        head += f'<unit name="centimeter" meter="{unit}"/>'
    if up is not None:
        head += f"<up_axis>{up}</up_axis>"
    head += "</asset>"
    return f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  {head if asset else ""}
  <library_geometries>
    <geometry id="box-mesh" name="box">
      <mesh>
        <source id="box-positions">
          <float_array id="box-positions-array" count="{CORNERS.size}">{floats}</float_array>
          <technique_common>
            <accessor source="#box-positions-array" count="{len(CORNERS)}" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/>
              <param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="box-vertices">
          <input semantic="POSITION" source="#box-positions"/>
        </vertices>
        <triangles count="{len(FACES)}">
          <input semantic="VERTEX" source="#box-vertices" offset="0"/>
          <p>{indices}</p>
        </triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="scene">
      <node id="box-node" name="box">
        <translate>10 0 0</translate>
        <instance_geometry url="#box-mesh"/>
      </node>
    </visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
"""


def _sorted(points):
    points = np.round(np.asarray(points, float), 9)
    return points[np.lexsort(points.T[::-1])]


def _expected(unit, to_z):
    return _sorted((CORNERS + [10, 0, 0]) * unit @ to_z)


def test_y_up_centimetres_become_metres_z_up(tmp_path):
    """unit 0.01 and Y_UP: (x, y, z) cm -> (x, -z, y) / 100 m."""
    path = tmp_path / "box.dae"
    path.write_text(_dae())
    vertices, triangles = read_dae(path)
    y_up = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], float)
    np.testing.assert_allclose(_sorted(np.unique(vertices, axis=0)), _expected(0.01, y_up),
                               atol=1e-12)
    # the file's +y (2 cm) is now +z: the box is 4 cm tall along z, 6 cm deep along y
    np.testing.assert_allclose(np.ptp(vertices, axis=0), [0.02, 0.06, 0.04])
    assert triangles.shape == (12, 3)


def test_z_up_metres_kept(tmp_path):
    path = tmp_path / "box.dae"
    path.write_text(_dae(unit="1", up="Z_UP"))
    vertices, _ = read_dae(path)
    np.testing.assert_allclose(_sorted(np.unique(vertices, axis=0)),
                               _expected(1.0, np.eye(3)), atol=1e-12)


def test_x_up_and_the_specification_defaults(tmp_path):
    """X_UP: +x becomes +z, -y becomes +x; no <unit>, no <up_axis>: 1 m, Y_UP."""
    path = tmp_path / "box.dae"
    path.write_text(_dae(unit=None, up="X_UP"))
    vertices, _ = read_dae(path)
    x_up = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], float)
    np.testing.assert_allclose(_sorted(np.unique(vertices, axis=0)), _expected(1.0, x_up),
                               atol=1e-12)
    assert np.isclose(vertices[:, 2].min(), 9.0)  # the translated x, now up
    path.write_text(_dae(unit=None, up=None))
    vertices, _ = read_dae(path)
    np.testing.assert_allclose(np.ptp(vertices, axis=0), [2, 6, 4])  # Y_UP turned


def test_page_data_of_a_dae(tmp_path):
    path = tmp_path / "box.DAE"
    path.write_text(_dae())
    data = read_mesh(path)
    assert data["n_triangles"] == 12
    vertices = np.frombuffer(base64.b64decode(data["vertices"]), "<f4").reshape(-1, 3)
    np.testing.assert_allclose(vertices[:, 0].min(), 0.09, rtol=1e-6)


@pytest.mark.parametrize("text, message", [
    ("<COLLADA><unclosed>", ":1: not a well-formed XML file"),
    ("not xml at all", ":1: not a well-formed XML file"),
    ("<?xml version='1.0'?><notcollada/>", "not a readable COLLADA file"),
    # an entity naming a file of this machine, and an expansion bomb's first step
    (_dae().replace("<COLLADA", '<!DOCTYPE COLLADA [<!ENTITY up SYSTEM '
                    '"file:///etc/hostname">]>\n<COLLADA', 1).replace("Y_UP", "&up;"),
     ":2: entity declarations are not accepted in a COLLADA file"),
    (_dae().replace("<COLLADA", '<!DOCTYPE COLLADA [<!ENTITY a "aaaaaaaaaa">'
                    '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>\n<COLLADA', 1),
     ":2: entity declarations are not accepted in a COLLADA file"),
    (_dae(unit="centimetre"), "<unit meter='centimetre'> is not a positive number"),
    (_dae(unit="-1"), "<unit meter='-1'> is not a positive number"),
    (_dae(up="W_UP"), "<up_axis>W_UP</up_axis> is not X_UP, Y_UP or Z_UP"),
    (_dae().replace('<instance_geometry url="#box-mesh"/>', ""), "holds no triangles"),
])
def test_malformed_dae_named_with_its_fault(tmp_path, text, message):
    path = tmp_path / "bad.dae"
    path.write_text(text)
    with pytest.raises(kd.ModelError) as info:
        read_dae(path)
    assert str(path) in str(info.value) and message in str(info.value)


def test_dae_larger_than_the_limit_refused(tmp_path, monkeypatch):
    import kanedyn.io._collada as collada_reader
    path = tmp_path / "box.dae"
    path.write_text(_dae())
    monkeypatch.setattr(collada_reader, "MAX_DAE_BYTES", 100)
    with pytest.raises(kd.ModelError, match=r"box.dae: \d+ bytes, more than the 100 a "
                                            r"COLLADA mesh may have"):
        read_dae(path)


def test_missing_libraries_named(tmp_path, monkeypatch):
    import sys
    path = tmp_path / "box.dae"
    path.write_text(_dae())
    monkeypatch.setitem(sys.modules, "trimesh", None)  # import fails as if absent
    with pytest.raises(kd.ModelError, match=r"needs trimesh and pycollada.*kanedyn\[meshes\]"):
        read_dae(path)
