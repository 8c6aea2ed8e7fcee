"""Ground contacts of an imported robot, shared by ``from_urdf`` and ``from_mjcf``.

Each importer hands over the collision shapes of its moving links (URDF) or
bodies (MJCF) as :class:`~kanedyn.modeling.CollisionPrimitive`;
``ground_points`` adds contact points given explicitly in the frame of a link
or body, for those whose collision geometry is a mesh (nothing is guessed from
a mesh), and replaces that link's or body's own shapes.
"""

from __future__ import annotations

import difflib

import numpy as np

from ..modeling import CollisionPrimitive, Ground, ground_contacts

__all__ = ["robot_ground_contacts"]


class _Importer:
    """Who reads the robot, for the messages: ``caller`` (``from_urdf``), ``kind``
    (``link``), ``error`` (its exception class), ``source`` (the file)."""

    def __init__(self, caller, kind, error, source):
        self.caller, self.kind, self.error, self.source = caller, kind, error, source

    def fail(self, text):
        return self.error(f"{self.caller}: {text}")


def _point(who, name, k, value):
    """``(offset (3,), radius)`` of the ``k``-th ground point of ``name``."""
    what = f"ground_points[{name!r}][{k}]"
    try:
        numbers = [float(x) for x in value]
        ok = (len(numbers) in (3, 4) and all(np.isfinite(numbers))
              and not any(isinstance(x, (str, bytes, bool)) for x in value))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise who.fail(f"{what} must be (x, y, z) or (x, y, z, radius), finite numbers in "
                       f"m in the {who.kind}'s frame, not {value!r}")
    if len(numbers) == 4 and numbers[3] < 0:
        raise who.fail(f"{what}: the radius must be >= 0, got {numbers[3]!r}")
    return np.array(numbers[:3]), (numbers[3] if len(numbers) == 4 else 0.0)


def _point_primitives(who, ground_points, places, build):
    """Collision spheres (radius 0: points) of the explicit ground points."""
    if not isinstance(ground_points, dict):
        raise who.fail(f"ground_points must be a dict {{{who.kind} name: [(x, y, z) or "
                       f"(x, y, z, radius), ...]}}, not {ground_points!r}")
    primitives = []
    for name, points in ground_points.items():
        if name not in places:
            close = difflib.get_close_matches(str(name), list(places), n=3, cutoff=0.6)
            hint = f" (did you mean {', '.join(map(repr, close))}?)" if close else ""
            raise who.fail(f"ground_points: {who.source} has no {who.kind} {name!r}{hint}")
        body, T = places[name]
        if body == "":
            raise who.fail(f"ground_points: {who.kind} {name!r} is fixed to the ground: "
                           "its points cannot touch it")
        if isinstance(points, (str, bytes)) or not hasattr(points, "__len__") \
                or len(points) == 0:
            raise who.fail(f"ground_points[{name!r}] must be a non-empty list of points, "
                           f"not {points!r}")
        for k, value in enumerate(points):
            offset, radius = _point(who, name, k, value)
            pose = np.array(T, dtype=float) @ np.block(
                [[np.eye(3), offset[:, None]], [np.zeros((1, 3)), np.ones((1, 1))]])
            primitives.append(CollisionPrimitive(
                f"{name}/point{k}", "sphere", (radius,), build.frame_of[body],
                build.point_of[body], tuple(map(tuple, pose)),
                f"ground_points[{name!r}][{k}]"))
    return primitives


def robot_ground_contacts(ground, ground_points, shapes, places, build, *, caller, kind,
                          error, source, none_usable):
    """The contacts of a robot with ``ground``, or None without a ground.

    Parameters
    ----------
    ground : kanedyn.Ground or None
    ground_points : dict or None
        ``{link or body name: [(x, y, z) or (x, y, z, r), ...]}``, m in its frame.
    shapes : list of (str, CollisionPrimitive)
        The collision shapes of moving links or bodies, each with the name of
        the link or body it belongs to.
    places : dict
        ``{link or body name: (kanedyn body, 4x4 pose in its frame)}``, every one
        of the file; body ``""`` is the ground.
    build : object
        The importer's builder: base frame ``N``, its origin ``O``, and
        ``frame_of``/``point_of``, the frame and origin of each kanedyn body.
    caller, kind : str
        ``"from_urdf"``/``"link"`` or ``"from_mjcf"``/``"body"``, for the messages.
    error : type
        The exception raised for bad input (URDFError, MJCFError).
    source : str
        The file.
    none_usable : str
        The message when nothing can touch the ground.

    Returns
    -------
    list of Contact or None
        One per sphere and explicit point, two per capsule, eight per box (a
        warning names the shapes not used, except those replaced by points).
    """
    who = _Importer(caller, kind, error, source)
    if ground is None:
        if ground_points is not None:
            raise who.fail("ground_points given without a ground (ground=kd.Ground(...))")
        return None
    if not isinstance(ground, Ground):
        raise who.fail(f"ground must be a kanedyn.Ground, not {ground!r}")
    explicit = ([] if ground_points is None
                else _point_primitives(who, ground_points, places, build))
    replaced = set(ground_points or ())
    primitives = [shape for owner, shape in shapes if owner not in replaced]
    contacts = ground_contacts(ground, build.N, build.O, primitives + explicit, source)
    if not contacts:
        raise error(f"{source}: ground: {none_usable}")
    return contacts
