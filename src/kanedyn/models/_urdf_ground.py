"""Ground contacts of a URDF robot (``from_urdf(..., ground=..., ground_points=...)``).

The ``<collision>`` spheres and boxes of moving links become contacts with the
ground (:func:`kanedyn.modeling.ground_contacts`); ``ground_points`` adds
contact points given explicitly in a link's frame, for links whose collision
geometry is a mesh (nothing is guessed from a mesh).
"""

from __future__ import annotations

import difflib

import numpy as np

from .._errors import ModelError
from ..modeling import CollisionPrimitive, Ground, ground_contacts
from ._urdf_parse import URDFError

__all__ = ["urdf_ground_contacts"]


def _point(link, k, value):
    """``(offset (3,), radius)`` of the ``k``-th ground point of ``link``."""
    what = f"from_urdf: ground_points[{link!r}][{k}]"
    try:
        numbers = [float(x) for x in value]
        ok = (len(numbers) in (3, 4) and all(np.isfinite(numbers))
              and not any(isinstance(x, (str, bytes, bool)) for x in value))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ModelError(f"{what} must be (x, y, z) or (x, y, z, radius), finite numbers in "
                         f"m in the link's frame, not {value!r}")
    if len(numbers) == 4 and numbers[3] < 0:
        raise ModelError(f"{what}: the radius must be >= 0, got {numbers[3]!r}")
    return np.array(numbers[:3]), (numbers[3] if len(numbers) == 4 else 0.0)


def _point_primitives(ground_points, robot, build):
    """Collision spheres (radius 0: points) of the explicit ground points."""
    if not isinstance(ground_points, dict):
        raise ModelError("from_urdf: ground_points must be a dict {link name: [(x, y, z) "
                         f"or (x, y, z, radius), ...]}}, not {ground_points!r}")
    primitives = []
    for link, points in ground_points.items():
        if link not in robot.links:
            close = difflib.get_close_matches(str(link), list(robot.links), n=3, cutoff=0.6)
            hint = f" (did you mean {', '.join(map(repr, close))}?)" if close else ""
            raise ModelError(f"from_urdf: ground_points: {robot.source} has no link "
                             f"{link!r}{hint}")
        body, T = build.group[link]
        if body == "":
            raise ModelError(f"from_urdf: ground_points: link {link!r} is fixed to the "
                             "ground: its points cannot touch it")
        if isinstance(points, (str, bytes)) or not hasattr(points, "__len__") \
                or len(points) == 0:
            raise ModelError(f"from_urdf: ground_points[{link!r}] must be a non-empty list "
                             f"of points, not {points!r}")
        for k, value in enumerate(points):
            offset, radius = _point(link, k, value)
            pose = np.array(T, dtype=float) @ np.block(
                [[np.eye(3), offset[:, None]], [np.zeros((1, 3)), np.ones((1, 1))]])
            primitives.append(CollisionPrimitive(
                f"{link}/point{k}", "sphere", (radius,), build.frame_of[body],
                build.point_of[body], tuple(map(tuple, pose)),
                f"ground_points[{link!r}][{k}]"))
    return primitives


def urdf_ground_contacts(ground, ground_points, collisions, robot, build):
    """Contacts with ``ground`` of the ``<collision>`` spheres and boxes of moving
    bodies, and of the explicit ``ground_points`` (a warning names the collision
    elements not used, except those of links given ground points)."""
    if not isinstance(ground, Ground):
        raise ModelError(f"from_urdf: ground must be a kanedyn.Ground, not {ground!r}")
    explicit = ([] if ground_points is None
                else _point_primitives(ground_points, robot, build))
    primitives, count = [], {}
    for vis in collisions:
        if vis.body == "":
            continue  # fixed to the ground
        k = count[vis.link] = count.get(vis.link, -1) + 1
        if ground_points and vis.link in ground_points:
            continue  # the link's explicit points stand for its collision geometry
        size = [s / 2 for s in vis.size] if vis.shape == "box" else vis.size
        primitives.append(CollisionPrimitive(
            f"{vis.link}/collision{k}", vis.shape, tuple(size), build.frame_of[vis.body],
            build.point_of[vis.body], vis.transform, f"{vis.source}:{vis.line}"))
    contacts = ground_contacts(ground, build.N, build.O, primitives + explicit, robot.source)
    if not contacts:
        raise URDFError(f"{robot.source}: ground: no <collision> sphere or box on a moving "
                        "link (meshes and cylinders are not turned into ground contacts; "
                        "give contact points with ground_points={link: [(x, y, z)]})")
    return contacts
