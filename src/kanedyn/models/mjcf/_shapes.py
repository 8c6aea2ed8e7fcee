"""Viewer shapes of an MJCF model's geoms (``MJCFDefinition.shapes``).

A geom's pose is kept in the frame of the kanedyn body that carries it (origin
at that body's origin); a viewer shape is placed from the body's mass centre
(the constants ``cx_<body>``...), so its offset is the geom's position less the
mass centre, its rotation the geom's.  Spheres, ellipsoids, boxes and
cylinders are drawn as themselves, a capsule as a cylinder with a sphere at
each end; planes, height fields, meshes and SDFs are not drawn (named in the
notes), nor are geoms of the ground or of massless bodies.
"""

from __future__ import annotations

import numpy as np

from .._urdf_shapes import colour_of

__all__ = ["mjcf_shapes", "VISIBLE_GROUPS"]

#: the geom groups MuJoCo's viewer shows by default
VISIBLE_GROUPS = (0, 1, 2)


def _bodies(definition, values):
    """``{kanedyn body name: (RigidBody, mass centre (3,) in its frame)}``."""
    points = definition.symbols["points"]
    out = {}
    for name, body in definition.symbols["bodies"].items():
        c = body.masscenter.pos_from(points[name]).to_matrix(body.frame)
        out[name] = (body, np.array([float(ci.xreplace(values)) for ci in c]))
    return out


def mjcf_shapes(definition, values, groups=VISIBLE_GROUPS):
    """``(shapes, notes)`` of an :class:`MJCFDefinition` with constants ``values``."""
    from ...modeling import visuals as kv
    bodies = _bodies(definition, values)
    shapes, notes = [], []
    for geom in definition.geoms:
        if geom.group not in groups:
            continue
        where = f"{geom.source}:{geom.line}: {geom.type} geom '{geom.name}'"
        if geom.body not in bodies:
            if geom.body != "":
                notes.append(f"skipped {where}: its body has no mass")
            continue
        if geom.type not in ("sphere", "ellipsoid", "box", "cylinder", "capsule"):
            notes.append(f"skipped {where}: the viewer draws no {geom.type}")
            continue
        rgba = geom.rgba if geom.rgba is None or geom.rgba[3] > 0 else None
        if geom.rgba is not None and geom.rgba[3] == 0:
            continue  # invisible in MuJoCo too
        rb, centre = bodies[geom.body]
        T = np.asarray(geom.transform, dtype=float)
        R, offset = T[:3, :3], T[:3, 3] - centre
        options = colour_of(rgba)
        size = geom.size
        if geom.type == "sphere":
            shapes.append(kv.Sphere(rb, size[0], offset=offset, **options))
        elif geom.type == "ellipsoid":
            shapes.append(kv.Sphere(rb, semi_axes=size, offset=offset, rotation=R, **options))
        elif geom.type == "box":
            shapes.append(kv.Box(rb, [2 * x for x in size], offset=offset, rotation=R,
                                 **options))
        else:
            shapes.append(kv.Cylinder(rb, size[0], 2 * size[1], axis=R[:, 2], offset=offset,
                                      **options))
            if geom.type == "capsule":
                for end in (-1, 1):
                    shapes.append(kv.Sphere(rb, size[0], offset=offset
                                            + end * size[1] * R[:, 2], **options))
    return shapes, notes
