r"""Contacts: a point of a body touching a surface, with Coulomb friction.

A :class:`Contact` joins a material point ``P`` (of a particle or rigid body)
and a :class:`Surface` fixed in a frame ``E`` (a body of the system, or a frame
in prescribed motion) with origin ``O``.  The surface is the zero set of a gap
function :math:`g(x, y, z)` of the coordinates of ``P`` relative to ``O`` in
``E``; :math:`g > 0` where the point may be, so that the unit normal
:math:`n = \nabla g / |\nabla g|` points into the free side, the way the
normal force pushes.

Contacts reduce themselves to a constraint direction and a force law
(DESIGN rule 7): the formulation receives the gap, the normal, the relative
velocity of ``P`` with respect to the surface point it touches and that
velocity's partial velocities; the friction law and the modes (separated,
sliding, sticking) are handled numerically.
"""

from __future__ import annotations

import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from .._expressions import as_expression

__all__ = ["Surface", "Plane", "Sphere", "Ellipsoid", "ImplicitSurface", "Contact",
           "SURFACE_COORDINATES"]

#: Symbols standing for the coordinates of the contact point in the surface frame.
SURFACE_COORDINATES = sm.symbols("x_s y_s z_s", real=True)


class Surface:
    """A surface fixed in ``frame``, as the zero set of a gap function.

    Parameters
    ----------
    frame : ReferenceFrame
        The frame the surface is fixed in.
    origin : Point
        A point fixed in ``frame``; coordinates are measured from it.
    gap : sympy expression
        :math:`g(x_s, y_s, z_s)` in :data:`SURFACE_COORDINATES`, positive on
        the side where the contact point may be.
    name : str
    """

    def __init__(self, frame, origin, gap, name="surface"):
        if not isinstance(frame, me.ReferenceFrame):
            raise ModelError(f"surface {name}: frame must be a ReferenceFrame, got {frame!r}")
        if not isinstance(origin, me.Point):
            raise ModelError(f"surface {name}: origin must be a Point, got {origin!r}")
        gap = as_expression(gap, f"surface {name}: the gap function")
        if not gap.free_symbols & set(SURFACE_COORDINATES):
            raise ModelError(f"surface {name}: the gap function {gap} does not depend on "
                             "the coordinates x_s, y_s, z_s")
        self.frame = frame
        self.origin = origin
        self.gap = gap
        self.name = name

    def __repr__(self):
        return f"<{type(self).__name__} {self.name} in {self.frame}>"


class Plane(Surface):
    """The plane through ``origin`` with unit ``normal`` (a Vector fixed in ``frame``).

    The free side is the one ``normal`` points to.
    """

    def __init__(self, frame, origin, normal, name="plane"):
        comps = [normal.dot(frame.x), normal.dot(frame.y), normal.dot(frame.z)]
        length = sm.sqrt(sum(c ** 2 for c in comps))
        x = SURFACE_COORDINATES
        super().__init__(frame, origin, sum(c * xi for c, xi in zip(comps, x)) / length,
                         name)


class Sphere(Surface):
    """A sphere of ``radius`` centred at ``origin``.

    ``inside=True``: the point moves inside (a tank wall); else outside.
    """

    def __init__(self, frame, origin, radius, inside=True, name="sphere"):
        radius = _check_coefficient(radius, f"surface {name}: radius", positive=True)
        r = sm.sqrt(sum(c ** 2 for c in SURFACE_COORDINATES))
        super().__init__(frame, origin, radius - r if inside else r - radius, name)
        self.radius = radius
        self.inside = inside


class Ellipsoid(Surface):
    """An ellipsoid with semi-axes ``a, b, c`` along ``frame``'s axes, centred at ``origin``.

    ``inside=True``: the point moves inside (the tank of the slug example).
    """

    def __init__(self, frame, origin, a, b, c, inside=True, name="ellipsoid"):
        a, b, c = (_check_coefficient(value, f"surface {name}: semi-axis {axis}", positive=True)
                   for value, axis in zip((a, b, c), "abc"))
        x, y, z = SURFACE_COORDINATES
        level = (x / a) ** 2 + (y / b) ** 2 + (z / c) ** 2 - 1
        super().__init__(frame, origin, -level if inside else level, name)
        self.axes = (a, b, c)
        self.inside = inside


class ImplicitSurface(Surface):
    """Any surface :math:`g(x_s, y_s, z_s) = 0` (see :class:`Surface`)."""


def _check_coefficient(value, name, lower=0.0, upper=None, positive=False):
    """Numbers are checked now (``positive``: above ``lower``, not equal to it);
    symbols when their values are given."""
    if value is None:
        return None
    value = as_expression(value, name)
    if value.is_number:
        v = float(value)
        if v < lower or (positive and v == lower) or (upper is not None and v > upper):
            bound = (f"in [{lower}, {upper}]" if upper is not None
                     else f"> {lower}" if positive else f">= {lower}")
            raise ModelError(f"{name} must be {bound}, got {v}")
    return value


class Contact:
    r"""A point of a body in contact with a surface, with Coulomb friction.

    Parameters
    ----------
    point : Point
        The material point that touches the surface (a particle's point, or a
        point fixed in a rigid body: a corner, the end of a rod).
    surface : Surface
    mu_k, mu_s : number or Symbol, optional
        Kinetic and static friction coefficients (``mu_s`` defaults to
        ``mu_k``); zero for a smooth surface.
    viscous : number or Symbol, optional
        Viscous friction coefficient, N s/m: an extra tangential force
        :math:`-c\,v_t`.
    kind : {"unilateral", "bilateral"}
        Unilateral contacts may separate (the normal force cannot pull);
        bilateral ones stay in contact.
    restitution : number or Symbol, optional
        Coefficient of restitution for impacts, in [0, 1].
    restitution_law : {"newton", "poisson"}
        Newton: normal separation speed ``e`` times the approach speed;
        Poisson: restitution impulse ``e`` times the compression impulse.
    name : str, optional
    """

    def __init__(self, point, surface, mu_k=0, mu_s=None, viscous=0, kind="unilateral",
                 restitution=None, restitution_law="poisson", name=None):
        if not isinstance(point, me.Point):
            raise ModelError(f"contact point must be a Point, got {point!r}")
        if not isinstance(surface, Surface):
            raise ModelError(f"contact surface must be a kanedyn Surface, got {surface!r}")
        if kind not in ("unilateral", "bilateral"):
            raise ModelError(f"contact kind must be 'unilateral' or 'bilateral', not {kind!r}")
        if restitution_law not in ("newton", "poisson"):
            raise ModelError("restitution_law must be 'newton' or 'poisson', not "
                             f"{restitution_law!r}")
        self.name = name or f"{point.name}/{surface.name}"
        self.point = point
        self.surface = surface
        self.mu_k = _check_coefficient(mu_k, f"contact {self.name}: mu_k")
        self.mu_s = _check_coefficient(mu_k if mu_s is None else mu_s,
                                       f"contact {self.name}: mu_s")
        self.viscous = _check_coefficient(viscous, f"contact {self.name}: viscous")
        self.restitution = _check_coefficient(restitution, f"contact {self.name}: "
                                              "restitution", 0.0, 1.0)
        self.kind = kind
        self.restitution_law = restitution_law

    @property
    def coefficients(self):
        """The coefficients that may be symbols: ``{name: value}``."""
        out = {"mu_k": self.mu_k, "mu_s": self.mu_s, "viscous": self.viscous}
        if self.restitution is not None:
            out["restitution"] = self.restitution
        return out

    def __repr__(self):
        return f"<Contact {self.name} ({self.kind}, mu_k={self.mu_k}, mu_s={self.mu_s})>"


def coefficient_value(value, constants, what):
    """Numerical value of a coefficient given the model's constants."""
    value = as_expression(value, what)
    if not value.is_number:
        value = sm.sympify(value.xreplace(
            {s: constants[s] for s in value.free_symbols if s in constants}), strict=True)
    if not value.is_number:
        missing = ", ".join(sorted(map(str, value.free_symbols)))
        raise ModelError(f"{what} needs values for {missing}")
    v = float(value)
    if v != v:
        raise ModelError(f"{what} is not a number")
    return v
