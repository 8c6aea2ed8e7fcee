r"""Mesh assets of an MJCF file: their triangles, and their volume, mass centre and
inertia as MuJoCo's compiler infers them.

A ``<mesh>`` gives its vertices and faces inline (``vertex``, ``face``) or in a
file: STL and OBJ (read with trimesh, an optional extra) or MuJoCo's binary
``.msh``.  A file is looked up in the compiler's ``meshdir`` (else ``assetdir``)
relative to the model's folder, and read only when it lies, symbolic links
resolved, below the model's folder or a folder the user allowed
(``from_mjcf(mesh_dirs=...)``).  Vertices are rounded to single precision, as
MuJoCo stores them, then moved by ``refpos``, turned by ``refquat`` and scaled:
:math:`v' = s \odot R^T (v - p)`.

The mesh's ``inertia`` mode says how its mass is distributed (``legacy`` is
MuJoCo's default):

``exact``   the solid the (closed, consistently oriented) surface bounds: the
            signed tetrahedra from any point to each triangle;
``convex``  the solid of the mesh's convex hull;
``legacy``  tetrahedra from a reference point to each triangle, their volumes
            counted positive (a non-convex mesh's volume is over-counted): the
            mass centre from the area-weighted centroid of the triangles, then
            volume and inertia from that mass centre;
``shell``   the surface, of uniform area density (``density`` in kg/m^2).

A tetrahedron with one vertex at the origin and the others :math:`a, b, c`,
of volume :math:`V`, has the second moment
:math:`\int x x^T = \tfrac{V}{20}(a a^T + b b^T + c c^T + s s^T)`,
:math:`s = a + b + c`; a triangle of area :math:`A` has
:math:`\tfrac{A}{12}(a a^T + b b^T + c c^T + s s^T)`; the inertia is
:math:`\operatorname{tr}(S) I - S`.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._errors import ModelError
from ..._input_files import read_bounded_bytes

__all__ = ["Mesh", "MeshLibrary", "mesh_mass_properties", "MESH_INERTIA_MODES",
           "MAX_MESH_BYTES"]

#: ``<mesh inertia=...>`` modes (MuJoCo's default is ``legacy``)
MESH_INERTIA_MODES = ("legacy", "convex", "exact", "shell")

#: the largest mesh file read, bytes
MAX_MESH_BYTES = 256 * 2**20

#: mesh volumes (m^3) or areas (m^2) below this are refused, as MuJoCo does
_TINY = 1e-15


@dataclass(frozen=True)
class Mesh:
    """A ``<mesh>`` asset: ``file`` (as written) or inline ``vertex`` and ``face``
    (flat tuples), ``scale`` (3,), ``refpos`` (3,), ``refquat`` as a rotation
    matrix (3, 3), ``inertia`` mode, ``maxhullvert`` (-1: no limit)."""

    name: str
    file: str | None
    vertex: tuple | None
    face: tuple | None
    scale: tuple
    refpos: tuple
    refrot: np.ndarray
    inertia: str
    maxhullvert: int
    element: object = None


def _trimesh(element):
    try:
        import trimesh
    except ImportError:
        raise element.error("reading a mesh file needs trimesh (not installed): "
                            "pip install 'kanedyn[meshes]'") from None
    return trimesh


def _read_msh(data, element, shown):
    """Vertices and triangles of MuJoCo's binary ``.msh`` (four int32 counts, then
    float32 vertices, normals and texture coordinates, int32 faces)."""
    if len(data) < 16:
        raise element.error(f"{shown}: too short for a .msh file")
    nv, nn, nt, nf = (int(x) for x in np.frombuffer(data[:16], dtype="<i4"))
    if min(nv, nn, nt, nf) < 0 or 16 + 4 * (3 * nv + 3 * nn + 2 * nt + 3 * nf) != len(data):
        raise element.error(f"{shown}: its size ({len(data)} bytes) does not match the "
                            f"counts of its header ({nv} vertices, {nn} normals, {nt} "
                            f"texture coordinates, {nf} faces): not a .msh file")
    vertices = np.frombuffer(data, dtype="<f4", count=3 * nv, offset=16).reshape(-1, 3)
    start = 16 + 4 * (3 * nv + 3 * nn + 2 * nt)
    faces = np.frombuffer(data, dtype="<i4", count=3 * nf, offset=start).reshape(-1, 3)
    return vertices, faces


class MeshLibrary:
    """The meshes of one model, read on first use and their mass properties cached.

    Parameters
    ----------
    meshes : dict
        ``{name: Mesh}``.
    source : str
        The model file (its folder is where mesh files are looked up).
    folder : str or None
        The compiler's ``meshdir`` (else ``assetdir``), relative to the model's folder.
    mesh_dirs : sequence of path-like
        Further folders mesh files may be read from.
    """

    def __init__(self, meshes, source, folder=None, mesh_dirs=()):
        self.meshes, self.source = meshes, source
        self.model_dir = Path(source).resolve().parent
        self.folder = folder
        self.roots = [self.model_dir] + [Path(d).resolve() for d in mesh_dirs]
        self._cache = {}

    def path(self, mesh):
        """The mesh file of ``mesh``, checked to lie below an allowed folder."""
        written = Path(mesh.file)
        base = self.model_dir / self.folder if self.folder else self.model_dir
        target = (written if written.is_absolute() else base / written).resolve()
        if not any(target.is_relative_to(root) for root in self.roots):
            raise mesh.element.error(
                f"file '{mesh.file}' ({target}) is outside the model's folder "
                f"({self.model_dir}): not read; give from_mjcf(..., mesh_dirs=[its "
                "folder]) to read it")
        if not target.is_file():
            raise mesh.element.error(f"file '{mesh.file}' not found (looked for {target})")
        return target

    def triangles(self, mesh):
        """``(vertices (n, 3), faces (m, 3))`` of ``mesh``, in its geom's frame (m)."""
        el = mesh.element
        if mesh.file is None:
            if mesh.vertex is None:
                raise el.error("needs a file or vertex")
            if len(mesh.vertex) % 3 or len(mesh.face or ()) % 3:
                raise el.error("vertex and face need multiples of three numbers")
            vertices = np.array(mesh.vertex, dtype=np.float32).reshape(-1, 3)
            if mesh.face is None:  # MuJoCo's mesh is then the vertices' convex hull
                if len(vertices) < 4:
                    raise el.error("a mesh needs at least four vertices")
                hull = _trimesh(el).convex.convex_hull(vertices.astype(float))
                vertices, faces = np.asarray(hull.vertices), np.asarray(hull.faces)
            else:
                faces = np.array(mesh.face, dtype=float).reshape(-1, 3)
                if np.any(faces != np.round(faces)):
                    raise el.error("face holds numbers that are not vertex indices")
                faces = faces.astype(np.int64)
        else:
            target = self.path(mesh)
            try:
                data = read_bounded_bytes(target, str(target), MAX_MESH_BYTES,
                                          name="the mesh file",
                                          limit=("a mesh", "simplify the mesh"),
                                          wanted="a mesh file (STL, OBJ or .msh)")
            except ModelError as exc:  # a folder, a pipe, too large: named with the element
                raise el.error(str(exc)) from None
            kind = target.suffix.lower()
            if kind == ".msh":
                vertices, faces = _read_msh(data, el, mesh.file)
            elif kind in (".stl", ".obj"):
                trimesh = _trimesh(el)
                try:
                    read = trimesh.load(io.BytesIO(data), file_type=kind[1:], force="mesh",
                                        process=False)
                except Exception as exc:  # trimesh's readers raise many kinds
                    raise el.error(f"file '{mesh.file}' is not a readable {kind[1:].upper()} "
                                   f"mesh: {type(exc).__name__}: {exc}") from None
                vertices, faces = np.asarray(read.vertices), np.asarray(read.faces)
            else:
                raise el.error(f"file '{mesh.file}': a {kind or 'suffix-less'} mesh is not "
                               "read (STL, OBJ and .msh are)")
            vertices = np.asarray(vertices, dtype=np.float32)
            if np.asarray(faces).size == 0:
                raise el.error(f"file '{mesh.file}' holds no triangles: not a readable "
                               f"{kind[1:].upper()} mesh")
        if faces.size == 0 or len(vertices) < 4:
            raise el.error("a mesh needs at least four vertices and one face")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise el.error(f"a face names vertex {int(faces.max())}, but the mesh has "
                           f"{len(vertices)} vertices")
        v = vertices.astype(float) - np.asarray(mesh.refpos)
        v = (v @ mesh.refrot) * np.asarray(mesh.scale)
        return v, np.asarray(faces, dtype=np.int64)

    def properties(self, name):
        """``(volume or area, centre (3,), inertia per unit mass (3, 3))`` of mesh
        ``name`` in its geom's frame."""
        if name not in self._cache:
            mesh = self.meshes[name]
            vertices, faces = self.triangles(mesh)
            self._cache[name] = mesh_mass_properties(vertices, faces, mesh)
        return self._cache[name]


def _second_moment(weights, a, b, c, divisor):
    s = a + b + c
    S = sum(np.einsum("i,ij,ik->jk", weights, p, p) for p in (a, b, c, s))
    return S / divisor


def _inertia(S):
    return np.trace(S) * np.eye(3) - S


def _solid(vertices, faces, apex, absolute):
    tri = vertices[faces] - apex
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6
    return (np.abs(vol) if absolute else vol), a, b, c


def mesh_mass_properties(vertices, faces, mesh):
    """``(volume or area, centre (3,), inertia per unit mass (3, 3))`` of a mesh.

    Parameters
    ----------
    vertices : ndarray, shape (n, 3)
        m, in the geom's frame.
    faces : ndarray of int, shape (m, 3)
    mesh : Mesh
        Its ``inertia`` mode and ``maxhullvert``; its element for errors.

    Returns
    -------
    size : float
        The volume (m^3), or the area (m^2) for ``shell``.
    centre : ndarray, shape (3,)
        m.
    inertia : ndarray, shape (3, 3)
        About the centre, per unit mass (m^2).
    """
    el, mode = mesh.element, mesh.inertia
    if mode == "convex":
        if mesh.maxhullvert != -1:
            raise el.error("maxhullvert with inertia='convex': a hull cut short is not "
                           "computed here; remove maxhullvert or give the body an "
                           "<inertial>")
        hull = _trimesh(el).convex.convex_hull(vertices)
        vertices, faces = np.asarray(hull.vertices), np.asarray(hull.faces)
    tri = vertices[faces]
    areas = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                           axis=1) / 2
    if mode == "shell":
        area = areas.sum()
        if area < _TINY:
            raise el.error(f"the mesh's area ({area:.3g} m^2) is too small")
        centre = (areas[:, None] * tri.mean(axis=1)).sum(axis=0) / area
        p = tri - centre
        S = _second_moment(areas, p[:, 0], p[:, 1], p[:, 2], 12)
        return area, centre, _inertia(S) / area
    if mode == "exact":
        trimesh = _trimesh(el)
        check = trimesh.Trimesh(vertices, faces, process=True)
        if not (check.is_watertight and check.is_winding_consistent):
            raise el.error("inertia='exact' needs a closed, consistently oriented mesh, "
                           "and this one is not (give inertia='convex' or 'shell')")
    absolute = mode == "legacy"
    if absolute:  # the mass centre from the area-weighted centroid of the triangles
        apex = (areas[:, None] * tri.mean(axis=1)).sum(axis=0) / max(areas.sum(), _TINY)
    else:
        apex = vertices.mean(axis=0)
    vol, a, b, c = _solid(vertices, faces, apex, absolute)
    if vol.sum() < _TINY:
        raise el.error(f"the mesh's volume ({vol.sum():.3g} m^3) is not positive"
                       + (" (are its faces oriented inwards?)" if not absolute else ""))
    centre = apex + (vol[:, None] * (a + b + c)).sum(axis=0) / (4 * vol.sum())
    vol, a, b, c = _solid(vertices, faces, centre, absolute)
    volume = vol.sum()
    S = _second_moment(vol, a, b, c, 20)
    return volume, centre, _inertia(S) / volume
