"""Shapes that draw a body in the 3D viewer: box, cylinder, sphere, mesh file.

A shape is attached to a body (a ``RigidBody``, ``Particle`` or
:class:`~kanedyn.FlexibleBody`) and moves with it, or to the model's inertial
``ReferenceFrame`` (a robot's fixed base), where it stays.  It is placed by an
``offset`` from the body's reference point (a rigid body's or particle's mass
centre, a flexible body's origin) and a ``rotation`` whose columns are the
shape's own x, y, z axes in body-frame components.  All lengths in metres,
numbers only (the viewer draws one set of parameter values).

Only what is declared is drawn this way; a body without a shape is drawn
with the viewer's documented default (:mod:`kanedyn.io`).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import sympy.physics.mechanics as me

from ..._errors import ModelError
from ..flexible import FlexibleBody

__all__ = ["Shape", "Box", "Cylinder", "Sphere", "Mesh"]

_COLOR = re.compile(r"^#[0-9a-fA-F]{6}$")
_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def _body_name(body):
    return getattr(body, "name", repr(body))


def _positive(value, what):
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be a number (m), got {value!r}") from None
    if not np.isfinite(x) or x <= 0:
        raise ModelError(f"{what} must be a positive finite number (m), got {value!r}")
    return x


def _vector(value, what):
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be 3 numbers, got {value!r}") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ModelError(f"{what} must be 3 finite numbers, got {value!r}")
    return v


def _rotation(value, what):
    if value is None:
        return np.eye(3)
    try:
        R = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be a 3 x 3 rotation matrix, got {value!r}") from None
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ModelError(f"{what} must be a 3 x 3 rotation matrix, got shape {R.shape}")
    if np.max(np.abs(R.T @ R - np.eye(3))) > 1e-6 or np.linalg.det(R) < 0:
        raise ModelError(f"{what} is not a proper rotation matrix (orthonormal, det +1)")
    return R


def _axis_rotation(axis, what):
    """Rotation whose y column is ``axis`` (the cylinder's axis, in body components)."""
    if isinstance(axis, str):
        if axis not in _AXES:
            raise ModelError(f"{what} must be 'x', 'y', 'z' or 3 numbers, got {axis!r}")
        axis = _AXES[axis]
    a = _vector(axis, what)
    norm = np.linalg.norm(a)
    if norm == 0:
        raise ModelError(f"{what} must not be the zero vector")
    y = a / norm
    helper = np.array([1.0, 0.0, 0.0]) if abs(y[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    x = np.cross(y, helper)
    x /= np.linalg.norm(x)
    z = np.cross(x, y)
    return np.column_stack([x, y, z])


class Shape:
    """A shape attached to a body; base class of :class:`Box`, :class:`Cylinder`,
    :class:`Sphere` and :class:`Mesh`.

    Parameters
    ----------
    body : RigidBody, Particle, FlexibleBody or ReferenceFrame
        The body the shape moves with, or the model's inertial frame for a
        shape fixed in it (drawn in every frame where it is, as "fixed").
    offset : sequence of 3 float, optional
        Position of the shape's centre from the body's reference point, in
        body-frame components (a particle: inertial axes), m; for a shape fixed
        in the inertial frame, from the point fixed in it that the scene's
        positions start at (the viewer's ``origin``).  Default: none.
    rotation : array_like, shape (3, 3), optional
        The shape's x, y, z axes (columns) in body-frame components.
        Default: aligned with the body frame.
    color : str, optional
        ``"#rrggbb"``; default: the viewer's colour for the body.
    opacity : float
        1 opaque, down to 0.05.
    """

    kind = "shape"

    def __init__(self, body, offset=(0.0, 0.0, 0.0), rotation=None, color=None,
                 opacity=1.0):
        if not isinstance(body, (me.RigidBody, me.Particle, FlexibleBody,
                                 me.ReferenceFrame)):
            raise ModelError(f"a {self.kind} shape belongs to a RigidBody, Particle, "
                             f"FlexibleBody or the inertial ReferenceFrame, got {body!r}")
        where = f"{self.kind} of body {_body_name(body)}"
        self.body = body
        self.offset = _vector(offset, f"{where}: offset")
        self.rotation = _rotation(rotation, f"{where}: rotation")
        if color is not None and not (isinstance(color, str) and _COLOR.match(color)):
            raise ModelError(f"{where}: color must be a string '#rrggbb', got {color!r}")
        self.color = color
        try:
            opacity = float(opacity)
        except (TypeError, ValueError):
            raise ModelError(f"{where}: opacity must be a number, got {opacity!r}") from None
        if not 0.05 <= opacity <= 1.0:
            raise ModelError(f"{where}: opacity must be in [0.05, 1], got {opacity}")
        self.opacity = opacity

    def _where(self):
        return f"{self.kind} of body {_body_name(self.body)}"

    def geometry(self):
        """The shape's own parameters as plain data (for the viewer)."""
        raise NotImplementedError

    def __repr__(self):
        params = ", ".join(f"{k}={v}" for k, v in self.geometry().items() if k != "kind")
        return f"{type(self).__name__}({_body_name(self.body)}, {params})"


class Box(Shape):
    """A box with edge ``lengths`` (m) along the shape's x, y, z axes.

    Examples
    --------
    >>> import sympy.physics.mechanics as me
    >>> import kanedyn as kd
    >>> N = me.ReferenceFrame("N")
    >>> G = me.Point("G")
    >>> body = me.RigidBody("plate", G, N, 1.0, (me.inertia(N, 1, 1, 1), G))
    >>> kd.visuals.Box(body, (0.4, 0.3, 0.02))
    Box(plate, lengths=[0.4, 0.3, 0.02])
    """

    kind = "box"

    def __init__(self, body, lengths, **options):
        super().__init__(body, **options)
        v = _vector(lengths, f"{self._where()}: lengths")
        self.lengths = tuple(_positive(x, f"{self._where()}: lengths") for x in v)

    def geometry(self):
        return {"kind": "box", "lengths": list(self.lengths)}


class Cylinder(Shape):
    """A cylinder of ``radius`` and ``length`` (m) centred on its offset.

    ``axis`` (``"x"``, ``"y"``, ``"z"`` or 3 numbers, in body-frame
    components) is the cylinder's axis; it replaces ``rotation``.
    """

    kind = "cylinder"

    def __init__(self, body, radius, length, axis="z", **options):
        if "rotation" in options:
            raise ModelError(f"a cylinder of body {_body_name(body)} is turned by its axis; "
                             "give axis=..., not rotation")
        where = f"cylinder of body {_body_name(body)}"
        super().__init__(body, rotation=_axis_rotation(axis, f"{where}: axis"), **options)
        self.radius = _positive(radius, f"{where}: radius")
        self.length = _positive(length, f"{where}: length")

    def geometry(self):
        return {"kind": "cylinder", "radius": self.radius, "length": self.length}


class Sphere(Shape):
    """A sphere of ``radius`` (m); ``semi_axes`` (3 numbers) make it an ellipsoid."""

    kind = "sphere"

    def __init__(self, body, radius=None, semi_axes=None, **options):
        super().__init__(body, **options)
        if (radius is None) == (semi_axes is None):
            raise ModelError(f"{self._where()}: give radius or semi_axes (one of them)")
        if radius is not None:
            r = _positive(radius, f"{self._where()}: radius")
            self.semi_axes = (r, r, r)
        else:
            v = _vector(semi_axes, f"{self._where()}: semi_axes")
            self.semi_axes = tuple(_positive(x, f"{self._where()}: semi_axes") for x in v)

    def geometry(self):
        return {"kind": "sphere", "semi_axes": list(self.semi_axes)}


class Mesh(Shape):
    """A triangle mesh read from an STL (binary or text), OBJ or COLLADA file.

    A COLLADA (``.dae``) file is read with trimesh and pycollada
    (``pip install 'kanedyn[meshes]'``), in metres by its ``<unit>`` and turned
    so that its ``<up_axis>`` is the shape's ``+z``; ``scale`` applies after.

    Parameters
    ----------
    body
    path : str or Path
        The file; read when the page is written and embedded in it.
    scale : float or sequence of 3 float
        Factor from the file's units to metres (e.g. 0.001 for millimetres).
    """

    kind = "mesh"

    def __init__(self, body, path, scale=1.0, **options):
        super().__init__(body, **options)
        path = Path(path)
        if path.suffix.lower() not in (".stl", ".obj", ".dae"):
            raise ModelError(f"{self._where()}: {path} is not an .stl, .obj or .dae file")
        if not path.is_file():
            raise ModelError(f"{self._where()}: mesh file {path} does not exist")
        self.path = path
        s = np.broadcast_to(np.asarray(scale, dtype=float), (3,))
        self.scale = tuple(_positive(x, f"{self._where()}: scale") for x in s)

    def geometry(self):
        return {"kind": "mesh", "path": str(self.path), "scale": list(self.scale)}
