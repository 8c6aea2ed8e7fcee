"""Viewer shapes of a URDF robot's ``<visual>`` elements (``URDFDefinition.shapes``).

A :class:`~kanedyn.models.Visual` is posed in the frame of its body's link (origin
at the joint); a viewer shape is placed from the body's mass centre
``G = P + cx b_x + cy b_y + cz b_z`` (the constants ``cx_<body>``...), so its
offset is the visual's translation minus ``(cx, cy, cz)`` and its rotation the
visual's rotation, both in body-frame components.  A visual of a link fixed to
the ground (the fixed base) is a shape fixed in the inertial frame ``N``, placed
from the root link's origin ``O`` in ``N`` components.
"""

from __future__ import annotations

from importlib.util import find_spec
from pathlib import Path

import numpy as np

from ._urdf_meshes import shown_name

__all__ = ["urdf_shapes", "MESH_FORMATS", "colour_of"]

#: mesh file suffixes the viewer reads (.dae with trimesh and pycollada installed)
MESH_FORMATS = (".stl", ".obj", ".dae")

#: the modules that read .dae files (the optional extra "meshes")
_COLLADA_READERS = ("trimesh", "collada")


def _where(vis):
    what = f"mesh '{shown_name(vis.filename)}'" if vis.shape == "mesh" else vis.shape
    return f"{vis.source}:{vis.line}: link '{vis.link}', {what}"


def _not_drawable(vis):
    """Why the viewer cannot draw ``vis`` (None when it can)."""
    if vis.shape != "mesh":
        return None
    if vis.refused:
        return f"not read: {vis.refused}"
    if vis.path is None:
        return "the mesh file was not found (give package_dirs=... to from_urdf)"
    if Path(vis.path).suffix.lower() not in MESH_FORMATS:
        return (f"the viewer reads {', '.join(MESH_FORMATS)} meshes, not "
                f"{Path(vis.path).suffix or 'files without a suffix'}")
    if Path(vis.path).suffix.lower() == ".dae":
        missing = [name for name in _COLLADA_READERS if find_spec(name) is None]
        if missing:
            return (f"reading .dae meshes needs trimesh and pycollada ({', '.join(missing)} "
                    "not installed: pip install 'kanedyn[meshes]')")
    return None


def colour_of(rgba):
    """The viewer's colour and opacity of an RGBA quadruple (each clipped to [0, 1];
    the opacity at least 0.05), ``{}`` for None."""
    if rgba is None:
        return {}
    r, g, b, a = (min(max(float(c), 0.0), 1.0) for c in rgba)
    return {"color": "#{:02x}{:02x}{:02x}".format(*(round(255 * c) for c in (r, g, b))),
            "opacity": max(a, 0.05)}


def _shape(vis, body, centre, rgba):
    from ..modeling import visuals as kv
    T = np.asarray(vis.transform, dtype=float)
    R = T[:3, :3]
    options = dict(offset=T[:3, 3] - centre, **colour_of(rgba))
    if vis.shape == "box":
        return kv.Box(body, vis.size, rotation=R, **options)
    if vis.shape == "cylinder":  # URDF cylinders lie along their own z
        return kv.Cylinder(body, vis.size[0], vis.size[1], axis=R[:, 2], **options)
    if vis.shape == "sphere":
        return kv.Sphere(body, vis.size[0], rotation=R, **options)
    return kv.Mesh(body, vis.path, scale=vis.size, rotation=R, **options)


def _bodies(definition, values):
    """``{body link: (RigidBody, mass centre (3,) in the link frame)}``; the ground,
    ``""``, is the inertial frame with its origin."""
    frames, points = definition.symbols["frames"], definition.symbols["points"]
    rigid = definition.kane_args["bodies"]
    out = {"": (definition.symbols["N"], np.zeros(3))}
    for link, (body, _) in definition.link_bodies.items():
        if body != link:
            continue
        rb = next((b for b in rigid if b.frame is frames[link]), None)
        if rb is None:
            continue
        c = rb.masscenter.pos_from(points[link]).to_matrix(rb.frame)
        out[link] = (rb, np.array([float(ci.xreplace(values)) for ci in c]))
    return out


def urdf_shapes(definition, values):
    """``(shapes, notes)`` of a :class:`URDFDefinition` with constants ``values``.

    Every visual that can be drawn gives one shape.  A link whose visuals include
    one that cannot (an unread mesh format, a missing file) has those replaced by
    its drawable ``<collision>`` geometry, once per link; when it has none, or the
    link is massless, the visual is skipped.  Visuals of links fixed to the ground
    are shapes fixed in the inertial frame.  ``notes`` says
    which visual was replaced or skipped and why.
    """
    bodies = _bodies(definition, values)
    by_link = {}
    for vis in definition.visuals:
        by_link.setdefault(vis.link, ([], []))[0].append(vis)
    for col in definition.collisions:
        if col.link in by_link:
            by_link[col.link][1].append(col)
    shapes, notes = [], []
    for link, (vis_list, col_list) in by_link.items():
        body = vis_list[0].body
        if body not in bodies:
            why = (f"its body '{body}' has no mass, so the viewer has no body to move "
                   "it with")
            notes += [f"skipped {_where(v)}: {why}" for v in vis_list]
            continue
        rb, centre = bodies[body]
        bad = [(v, _not_drawable(v)) for v in vis_list if _not_drawable(v)]
        shapes += [_shape(v, rb, centre, v.rgba) for v in vis_list if not _not_drawable(v)]
        if not bad:
            continue
        usable = [c for c in col_list if not _not_drawable(c)]
        if usable:
            rgba = next((v.rgba for v, _ in bad if v.rgba is not None), None)
            shapes += [_shape(c, rb, centre, c.rgba or rgba) for c in usable]
            notes += [f"replaced {_where(v)} ({why}) by its <collision> geometry: "
                      + ", ".join(_where(c).split(", ", 1)[1] for c in usable)
                      for v, why in bad]
        else:
            notes += [f"skipped {_where(v)}: {why}; no drawable <collision> geometry"
                      for v, why in bad]
    return shapes, notes
