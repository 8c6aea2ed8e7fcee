"""The geoms of an MJCF model that may touch a ground (``from_mjcf(..., ground=...)``;
the contacts: :mod:`kanedyn.models._robot_ground`).

Every sphere, capsule and box geom of a moving body that may collide
(``contype`` or ``conaffinity`` not zero) becomes contacts with the ground
plane (see :mod:`kanedyn.modeling._ground`); the model's own planes are not
used: the ground is the one given.
"""

from __future__ import annotations

from ...modeling import CollisionPrimitive

__all__ = ["mjcf_collision_shapes", "MJCF_NONE_USABLE"]

#: the message when no geom can touch the ground
MJCF_NONE_USABLE = ("no colliding sphere, capsule or box geom on a moving body (give "
                    "contact points with ground_points={body: [(x, y, z)]})")


def mjcf_collision_shapes(geoms, frame_of, point_of):
    """``[(MJCF body, CollisionPrimitive)]`` of the colliding ``geoms`` (MJCFGeom)
    of moving bodies; ``frame_of`` and ``point_of`` map a kanedyn body name to its
    frame and origin.  A geom named ``""`` is called ``<mjcf body>/geom<k>``."""
    shapes, count = [], {}
    for geom in geoms:
        if geom.body == "" or not (geom.contype or geom.conaffinity):
            continue
        k = count[geom.mjcf_body] = count.get(geom.mjcf_body, -1) + 1
        name = geom.name or f"{geom.mjcf_body}/geom{k}"
        shapes.append((geom.mjcf_body, CollisionPrimitive(
            name, geom.type, tuple(geom.size), frame_of[geom.body], point_of[geom.body],
            geom.transform, f"{geom.source}:{geom.line}")))
    return shapes
