"""Triangle meshes read from COLLADA (``.dae``) files, for the viewer.

The file is read whole (at most ``MAX_DAE_BYTES``), checked to be well-formed XML
that declares no entities, and its bytes parsed by pycollada (an XML reader:
nothing in the file is run; given bytes, it opens no other file the document
names) and its scene flattened into one triangle mesh by trimesh, the node
transforms applied.  Both are optional (``pip install 'kanedyn[meshes]'``) and imported
only when a ``.dae`` file is read.

The document's ``<asset>`` gives the length unit (``<unit meter="0.01"/>``: one
file unit is 0.01 m) and the up axis (``<up_axis>``: ``X_UP``, ``Y_UP`` or
``Z_UP``); the defaults of the COLLADA specification, 1 m and ``Y_UP``, hold when
they are absent.  The vertices returned are in metres with ``+z`` up, as a URDF
mesh is: a ``Y_UP`` file is turned by +90 degrees about x (its ``+y`` becomes
``+z``, its ``+z`` becomes ``-y``); an ``X_UP`` file, whose right is ``-y`` and
inward ``+z`` (the specification's axes), has its ``+x`` made ``+z``, ``-y``
made ``+x`` and ``+z`` made ``-y``.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from .._errors import ModelError
from .._input_files import read_bounded_bytes, refuse_xml_entities

__all__ = ["read_dae", "UP_AXIS_TO_Z", "MAX_DAE_BYTES"]

#: the largest COLLADA file read, bytes (a robot's meshes are a few MB)
MAX_DAE_BYTES = 256 * 2**20

#: rows: the file's x, y, z axes in z-up components (vertices @ this matrix)
UP_AXIS_TO_Z = {
    "Z_UP": np.eye(3),
    "Y_UP": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
    "X_UP": np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]),
}


def _libraries(path):
    try:
        import collada
        import trimesh
    except ImportError as exc:
        raise ModelError(f"{path}: reading COLLADA (.dae) meshes needs trimesh and "
                         f"pycollada ({exc.name} is not installed): "
                         "pip install 'kanedyn[meshes]'") from None
    return collada, trimesh


def _asset(path, doc):
    """``(metres per file unit, up axis)`` of the document's ``<asset>``."""
    node = getattr(doc.assetInfo, "xmlnode", None)
    unit_node = None if node is None else node.find(doc.tag("unit"))
    up_node = None if node is None else node.find(doc.tag("up_axis"))
    unit = 1.0
    if unit_node is not None:
        written = unit_node.get("meter")
        try:
            unit = float(written)
        except (TypeError, ValueError):
            unit = float("nan")
        if not (np.isfinite(unit) and unit > 0):
            raise ModelError(f"{path}: <unit meter={written!r}> is not a positive number "
                             "of metres per unit")
    up = "Y_UP"
    if up_node is not None:
        up = (up_node.text or "").strip()
        if up not in UP_AXIS_TO_Z:
            raise ModelError(f"{path}: <up_axis>{up_node.text}</up_axis> is not X_UP, Y_UP "
                             "or Z_UP")
    return unit, up


def read_dae(path):
    """``(vertices (n, 3), triangles (m, 3))`` of a COLLADA file, in metres, z up.

    Parameters
    ----------
    path : str or Path

    Raises
    ------
    ModelError
        trimesh or pycollada is missing, the file is larger than ``MAX_DAE_BYTES``,
        not well-formed XML, declares entities, is not COLLADA, its unit or up axis
        is malformed, or its scene holds no triangles.
    """
    path = Path(path)
    collada, trimesh = _libraries(path)
    data = read_bounded_bytes(path, str(path), MAX_DAE_BYTES, name="the mesh file",
                              limit=("a COLLADA mesh", "simplify the mesh"),
                              wanted="a COLLADA (.dae) file")
    refuse_xml_entities(data, str(path), "a COLLADA file")
    try:
        # textures and unsupported effects are not drawn: not being able to read
        # them is no reason to refuse the geometry
        doc = collada.Collada(io.BytesIO(data), ignore=[collada.common.DaeUnsupportedError,
                                                 collada.common.DaeBrokenRefError])
    except Exception as exc:  # lxml syntax errors, pycollada's DaeError family
        raise ModelError(f"{path}: not a readable COLLADA file: "
                         f"{type(exc).__name__}: {exc}") from None
    root = doc.xmlnode.getroot().tag
    if root.rpartition("}")[2] != "COLLADA":
        raise ModelError(f"{path}: not a readable COLLADA file: its root element is "
                         f"<{root.rpartition('}')[2]}>, not <COLLADA>")
    unit, up = _asset(path, doc)
    try:
        scene = trimesh.load_scene(io.BytesIO(data), file_type="dae")
        mesh = scene.to_geometry() if len(scene.geometry) else None
    except Exception as exc:
        raise ModelError(f"{path}: trimesh cannot build its scene: "
                         f"{type(exc).__name__}: {exc}") from None
    if mesh is None or len(getattr(mesh, "faces", ())) == 0:
        raise ModelError(f"{path}: the COLLADA scene holds no triangles (no "
                         "<instance_geometry> of a mesh with <triangles> or <polylist>)")
    vertices = np.asarray(mesh.vertices, dtype=float) * unit @ UP_AXIS_TO_Z[up]
    return vertices, np.asarray(mesh.faces, dtype=np.int64)
