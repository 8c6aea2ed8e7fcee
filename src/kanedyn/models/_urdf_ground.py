"""The collision shapes of a URDF robot that may touch a ground
(``from_urdf(..., ground=...)``; the contacts: :mod:`._robot_ground`)."""

from __future__ import annotations

from ..modeling import CollisionPrimitive

__all__ = ["urdf_collision_shapes", "URDF_NONE_USABLE"]

#: the message when no collision element can touch the ground
URDF_NONE_USABLE = ("no <collision> sphere or box on a moving link (meshes and cylinders "
                    "are not turned into ground contacts; give contact points with "
                    "ground_points={link: [(x, y, z)]})")


def urdf_collision_shapes(collisions, build):
    """``[(link, CollisionPrimitive)]`` of the ``<collision>`` elements of moving
    links (Visual records placed on their bodies), named ``<link>/collision<k>``;
    a box's size is halved to the primitive's half-sizes."""
    shapes, count = [], {}
    for vis in collisions:
        if vis.body == "":
            continue  # fixed to the ground
        k = count[vis.link] = count.get(vis.link, -1) + 1
        size = [s / 2 for s in vis.size] if vis.shape == "box" else vis.size
        shapes.append((vis.link, CollisionPrimitive(
            f"{vis.link}/collision{k}", vis.shape, tuple(size), build.frame_of[vis.body],
            build.point_of[vis.body], vis.transform, f"{vis.source}:{vis.line}")))
    return shapes
