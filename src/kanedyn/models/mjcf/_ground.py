"""Ground contacts of an MJCF model's geoms (``from_mjcf(..., ground=...)``).

Every sphere, capsule and box geom of a moving body that may collide
(``contype`` or ``conaffinity`` not zero) becomes contacts with the ground
plane (see :mod:`kanedyn.modeling._ground`); the model's own planes are not
used: the ground is the one given.
"""

from __future__ import annotations

from ...modeling import CollisionPrimitive, Ground, ground_contacts
from ._xml import MJCFError

__all__ = ["mjcf_ground_contacts"]


def mjcf_ground_contacts(ground, geoms, frame_of, point_of, frame, origin, source):
    """Contacts with ``ground`` of the colliding ``geoms`` (MJCFGeom) of moving bodies.

    ``frame_of`` and ``point_of`` map a kanedyn body name to its frame and origin;
    ``frame`` and ``origin`` are the world's.  A geom named ``""`` is called
    ``<mjcf body>/geom<k>``.
    """
    if not isinstance(ground, Ground):
        raise MJCFError(f"from_mjcf: ground must be a kanedyn.Ground, not {ground!r}")
    primitives, count = [], {}
    for geom in geoms:
        if geom.body == "" or not (geom.contype or geom.conaffinity):
            continue
        k = count[geom.mjcf_body] = count.get(geom.mjcf_body, -1) + 1
        name = geom.name or f"{geom.mjcf_body}/geom{k}"
        primitives.append(CollisionPrimitive(name, geom.type, tuple(geom.size),
                                             frame_of[geom.body], point_of[geom.body],
                                             geom.transform, f"{geom.source}:{geom.line}"))
    contacts = ground_contacts(ground, frame, origin, primitives, source)
    if not contacts:
        raise MJCFError(f"{source}: ground: no colliding sphere, capsule or box geom on a "
                        "moving body")
    return contacts
