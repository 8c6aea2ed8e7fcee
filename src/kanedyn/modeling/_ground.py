"""A ground plane for robots: their collision primitives as contact points.

Importers (``from_urdf(..., ground=...)``, ``from_mjcf(..., ground=...)``)
describe each collision primitive as a :class:`CollisionPrimitive` (its shape,
size and pose in a body's frame); :func:`ground_contacts` turns them into
:class:`~kanedyn.modeling.Contact` objects against the plane ``z = height`` of
the base frame, normal ``+z``:

- a sphere of radius ``r``: the point of its body at the bottom of the ball,
  its centre less ``r`` along the normal, exact for a sphere on a plane
  whatever the body's orientation; its velocity is the body's at that point
  (the centre's plus the body's rotation about it), so a ball that rolls has
  its contact point at rest, and the forces act there;
- a capsule (radius ``r``, half-length ``h`` along its own ``z``): its two end
  spheres, each as above, exact for a capsule on a plane (a capsule touches a
  plane with an end sphere, or lies on it with both);
- a box: its eight vertices against the plane ``z = height``, exact for a box
  on a plane (a convex polyhedron touches a plane with its vertices).

Other shapes (cylinders, ellipsoids, meshes, planes) are not turned into
contacts; :func:`ground_contacts` names each in its notes.
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ._contacts import Contact, Plane

__all__ = ["Ground", "CollisionPrimitive", "ground_contacts", "GROUND_SHAPES"]

#: the primitive shapes that become ground contacts
GROUND_SHAPES = ("sphere", "capsule", "box")


def _number(value, what, lower=0.0, upper=None):
    if isinstance(value, (str, bytes, bool)) or not isinstance(value, (int, float, np.number)):
        raise ModelError(f"Ground: {what} must be a number, not {value!r}")
    v = float(value)
    if not np.isfinite(v) or v < lower or (upper is not None and v > upper):
        bound = f"in [{lower}, {upper}]" if upper is not None else f">= {lower}"
        raise ModelError(f"Ground: {what} must be a finite number {bound}, got {value!r}")
    return v


@dataclass(frozen=True)
class Ground:
    """A rigid ground plane ``z = height`` of the base frame (normal ``+z``).

    Every parameter but ``mu_s`` is required: the friction and restitution of a
    ground are properties of the materials, with no default.

    Parameters
    ----------
    height : float
        Height of the plane above the base frame's origin along its ``z``, m.
    mu_k : float
        Kinetic Coulomb friction coefficient (>= 0).
    restitution : float
        Coefficient of restitution of impacts, in [0, 1] (0: plastic).
    mu_s : float or None, optional
        Static friction coefficient; None: equal to ``mu_k`` (as in
        :class:`~kanedyn.modeling.Contact`).
    restitution_law : {"poisson", "newton"}, optional
        As in :class:`~kanedyn.modeling.Contact`.
    """

    height: float
    mu_k: float
    restitution: float
    mu_s: float | None = None
    restitution_law: str = "poisson"

    def __post_init__(self):
        for name, lower, upper in (("height", -np.inf, None), ("mu_k", 0.0, None),
                                   ("restitution", 0.0, 1.0)):
            object.__setattr__(self, name, _number(getattr(self, name), name, lower, upper))
        if self.mu_s is not None:
            object.__setattr__(self, "mu_s", _number(self.mu_s, "mu_s"))
        if self.restitution_law not in ("poisson", "newton"):
            raise ModelError("Ground: restitution_law must be 'poisson' or 'newton', not "
                             f"{self.restitution_law!r}")


@dataclass(frozen=True)
class CollisionPrimitive:
    """A collision shape fixed in a body, as an importer hands it to
    :func:`ground_contacts`.

    Attributes
    ----------
    name : str
        Names its contacts (``"<name>"`` or ``"<name>#<k>"``) and its notes
        (file, line, body).
    shape : str
        ``"sphere"``, ``"capsule"``, ``"box"``, or another (noted, not used).
    size : tuple of float
        Sphere ``(r,)``; capsule ``(r, half_length)`` along its own ``z``; box
        half-sizes ``(a, b, c)``; m.
    frame : ReferenceFrame
        The body's frame.
    origin : Point
        A point fixed in the body (its velocity in the base frame known or
        derivable), the origin of ``transform``.
    transform : tuple
        Pose (4x4 nested tuples) of the shape in ``frame`` from ``origin``.
    where : str, optional
        Where it is described (file and line), for the notes.
    """

    name: str
    shape: str
    size: tuple
    frame: object
    origin: object
    transform: tuple
    where: str = ""


def _body_points(primitive):
    """``[(suffix, centre (3,) in the body frame, its radius m)]``: the balls (radius
    0: points) whose bottoms touch the ground."""
    T = np.asarray(primitive.transform, dtype=float)
    R, p = T[:3, :3], T[:3, 3]
    size = [float(s) for s in primitive.size]
    if primitive.shape == "sphere":
        return [("", p, size[0])]
    if primitive.shape == "capsule":
        r, h = size[:2]
        return [(f"#{k}", p + end * h * R[:, 2], r) for k, end in enumerate((-1, 1))]
    half = np.array(size[:3])
    return [(f"#{k}", p + R @ (half * np.array(signs)), 0.0)
            for k, signs in enumerate(itertools.product((-1, 1), repeat=3))]


def ground_contacts(ground, frame, origin, primitives, source):
    """Contacts of collision primitives with a ground plane.

    Parameters
    ----------
    ground : Ground
    frame : ReferenceFrame
        The base (inertial) frame; the plane is ``z = ground.height`` in it.
    origin : Point
        The base frame's origin (fixed in ``frame``).
    primitives : iterable of CollisionPrimitive
    source : str
        The model file, for the warning.

    Returns
    -------
    list of Contact
        One per sphere, two per capsule, eight per box.

    Warns
    -----
    UserWarning
        Naming the primitives of other shapes, not in contact with the ground.
    """
    if not isinstance(ground, Ground):
        raise ModelError(f"ground must be a kanedyn.Ground, not {ground!r}")
    contacts, notes = [], []
    O_plane = origin.locatenew("ground", sm.Float(ground.height) * frame.z)
    O_plane.set_vel(frame, 0)
    plane = Plane(frame, O_plane, frame.z, name=f"ground z={ground.height:g}")
    for prim in primitives:
        if prim.shape not in GROUND_SHAPES:
            where = f"{prim.where}: " if prim.where else ""
            notes.append(f"{where}{prim.name}: a {prim.shape} does not touch the ground "
                         f"(only {', '.join(GROUND_SHAPES)} do)")
            continue
        for suffix, offset, radius in _body_points(prim):
            name = f"{prim.name}{suffix}"
            point = prim.origin.locatenew(name if not radius else f"{name} centre", sum(
                (sm.Float(float(c)) * e for c, e in zip(offset, (prim.frame.x, prim.frame.y,
                                                                  prim.frame.z)) if c != 0),
                me.Vector(0)))
            point.v2pt_theory(prim.origin, frame, prim.frame)
            if radius:  # the body's point at the bottom of the ball, moving with the body
                bottom = point.locatenew(name, -sm.Float(radius) * frame.z)
                bottom.v2pt_theory(point, frame, prim.frame)
                point = bottom
            contacts.append(Contact(point, plane, mu_k=ground.mu_k, mu_s=ground.mu_s,
                                    restitution=ground.restitution,
                                    restitution_law=ground.restitution_law,
                                    name=name))
    if notes:
        warnings.warn(f"{source}: {len(notes)} collision shape(s) not in contact with the "
                      "ground:\n  " + "\n  ".join(notes), UserWarning, stacklevel=4)
    return contacts
