"""Triangle meshes read from STL (binary or text), OBJ and COLLADA files, for the viewer.

Only geometry is read: vertices and triangles (OBJ polygons are split into
fans; texture coordinates, normals, groups and materials are ignored).  The
result is embedded in the page as base64 little-endian arrays.  COLLADA
(``.dae``) files are read by :mod:`._collada` (trimesh and pycollada).
"""

from __future__ import annotations

import base64
import struct
from pathlib import Path

import numpy as np

from .._errors import ModelError
from ._collada import read_dae

__all__ = ["read_mesh", "read_stl", "read_obj"]


def read_stl(path):
    """``(vertices (n, 3), triangles (m, 3))`` of an STL file (binary or text)."""
    path = Path(path)
    data = path.read_bytes()
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if 84 + 50 * count == len(data):
            rec = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            tri = np.frombuffer(data, dtype=rec, count=count, offset=84)["v"]
            vertices = tri.reshape(-1, 3).astype(float)
            return vertices, np.arange(len(vertices)).reshape(-1, 3)
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError:
        raise ModelError(f"{path}: neither a binary STL (size does not match its triangle "
                         "count) nor a text STL") from None
    vertices = []
    for lineno, line in enumerate(text.splitlines(), 1):
        words = line.split()
        if words[:1] == ["vertex"]:
            if len(words) != 4:
                raise ModelError(f"{path}, line {lineno}: a vertex needs 3 numbers: {line!r}")
            try:
                vertices.append([float(w) for w in words[1:]])
            except ValueError:
                raise ModelError(f"{path}, line {lineno}: not a number in {line!r}") from None
    if not vertices or len(vertices) % 3:
        raise ModelError(f"{path}: a text STL needs facets of 3 vertices; found "
                         f"{len(vertices)} vertices")
    vertices = np.array(vertices)
    return vertices, np.arange(len(vertices)).reshape(-1, 3)


def read_obj(path):
    """``(vertices (n, 3), triangles (m, 3))`` of a Wavefront OBJ file."""
    path = Path(path)
    vertices, faces = [], []
    with path.open(encoding="utf-8", errors="replace") as f:
        for lineno, line in enumerate(f, 1):
            words = line.split()
            if not words:
                continue
            try:
                if words[0] == "v":
                    vertices.append([float(w) for w in words[1:4]])
                    if len(vertices[-1]) != 3:
                        raise ValueError
                elif words[0] == "f":
                    idx = [int(w.split("/")[0]) for w in words[1:]]
                    if len(idx) < 3:
                        raise ValueError
                    idx = [i - 1 if i > 0 else len(vertices) + i for i in idx]
                    faces.extend([idx[0], idx[i], idx[i + 1]] for i in range(1, len(idx) - 1))
            except ValueError:
                raise ModelError(f"{path}, line {lineno}: cannot read {line.strip()!r}") \
                    from None
    if not vertices or not faces:
        raise ModelError(f"{path}: no vertices or no faces (lines 'v x y z', 'f i j k')")
    faces = np.array(faces)
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise ModelError(f"{path}: a face refers to a vertex that does not exist "
                         f"({len(vertices)} vertices)")
    return np.array(vertices), faces


def read_mesh(path):
    """The mesh of an STL, OBJ or COLLADA file as page data (base64 arrays)."""
    path = Path(path)
    reader = {".obj": read_obj, ".dae": read_dae}.get(path.suffix.lower(), read_stl)
    vertices, triangles = reader(path)
    return {"vertices": base64.b64encode(vertices.astype("<f4").tobytes()).decode("ascii"),
            "triangles": base64.b64encode(triangles.astype("<u4").tobytes()).decode("ascii"),
            "n_vertices": int(len(vertices)), "n_triangles": int(len(triangles))}
