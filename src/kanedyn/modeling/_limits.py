r"""Constraint torque functions: a body's tilt limited by a cone of its housing.

The *tilt* :math:`\theta` is the angle between an axis fixed in the body (unit
:math:`e`) and an axis fixed in the housing (unit :math:`a`), both through a
common pivot.  A housing lets the body tilt up to a limit angle
:math:`\theta_l` (a cone of half-angle :math:`\theta_l` about :math:`a`).  Two
ways to keep the body inside:

``ConeLimit``     a penalty law: beyond the limit a stiff, damped, one-sided
                  restoring torque :math:`T = \max(0,\ k\,\delta^p + c\,\dot\theta)`,
                  :math:`\delta = \theta - \theta_l > 0`, about
                  :math:`n = a \times e / |a \times e|`, reduced to loads;
``cone_contact``  the same limit as a unilateral contact with restitution
                  (:class:`~kanedyn.Contact`): a point of the body on the body
                  axis at distance ``r`` from the pivot touches the cone of
                  half-angle :math:`\theta_l` fixed in the housing, apex at the
                  pivot (:func:`cone_surface`).

The tilt is computed as :math:`\theta = \operatorname{atan2}(|a\times e|,\ a\cdot e)`,
accurate at every angle, and its rate as
:math:`\dot\theta = \omega_{B/H}\cdot(a\times e)/|a\times e|`; the penalty torque
and these rates only act for :math:`\theta > \theta_l`, where
:math:`|a \times e| \ge \sin\theta_l > 0`, so nothing divides by zero at zero
tilt.  With a stiff enough penalty the two agree: see ``tests/test_seatbelt.py``
and ``docs/seatbelt.md``.
"""

from __future__ import annotations

import math

import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from .._expressions import as_expression
from ._contacts import SURFACE_COORDINATES, Contact, ImplicitSurface

__all__ = ["ConeLimit", "cone_surface", "cone_contact", "tilt_angle",
           "penalty_damping_for_restitution"]


def _frame_of(obj, what):
    if isinstance(obj, me.ReferenceFrame):
        return obj
    frame = getattr(obj, "frame", None)
    if isinstance(frame, me.ReferenceFrame):
        return frame
    raise ModelError(f"{what} must be a ReferenceFrame or a RigidBody, got {obj!r}")


def _unit(vector, frame, what):
    if not isinstance(vector, me.Vector):
        raise ModelError(f"{what} must be a sympy.physics.mechanics Vector, got {vector!r}")
    comps = [vector.dot(frame.x), vector.dot(frame.y), vector.dot(frame.z)]
    length = sm.sqrt(sum(c ** 2 for c in comps))
    if length.is_number and float(length) == 0.0:
        raise ModelError(f"{what} is the zero vector")
    return vector / length if not (length.is_number and float(length) == 1.0) else vector


def _check_angle(value, what):
    value = as_expression(value, what)
    if value.is_number and not 0.0 < float(value) < math.pi / 2:
        raise ModelError(f"{what} must lie strictly between 0 and pi/2 rad, got {float(value)}")
    return value


def tilt_angle(body_axis, housing_axis):
    r"""Tilt between two unit vectors, :math:`\operatorname{atan2}(|a\times e|, a\cdot e)`.

    Returns
    -------
    (theta, cross, sin_theta) : sympy expressions / Vector
        The angle (rad), :math:`a\times e` and its length.
    """
    cross = housing_axis.cross(body_axis)
    s = sm.sqrt(cross.dot(cross))
    return sm.atan2(s, housing_axis.dot(body_axis)), cross, s


class ConeLimit:
    r"""Penalty law keeping a body's axis within a cone of its housing.

    Beyond the limit angle the body feels the torque :math:`-T\,n` and the
    housing :math:`+T\,n`, with

    .. math::
        T = \max\bigl(0,\ k\,\delta^p + c\,\dot\theta\bigr), \quad
        \delta = \theta - \theta_l > 0, \qquad T = 0 \text{ otherwise},

    :math:`n = a\times e/|a\times e|` the axis about which the tilt grows and
    :math:`\dot\theta = \omega_{B/H}\cdot n` the tilt rate.  The ``max`` keeps
    the torque one-sided: the wall pushes, it never pulls.

    Parameters
    ----------
    body : ReferenceFrame or RigidBody
        The tilting body (its frame).
    housing : ReferenceFrame or RigidBody
        The housing (a body of the system or a frame in prescribed motion).
    body_axis : Vector
        Axis fixed in the body through the pivot (normalised here).
    housing_axis : Vector
        Axis of the cone, fixed in the housing (normalised here).
    limit : number or Symbol
        Half-angle of the cone :math:`\theta_l`, rad, in (0, pi/2).
    stiffness : number or Symbol
        :math:`k`, N m / rad^p (> 0).
    damping : number or Symbol
        :math:`c`, N m s / rad (>= 0); see :func:`penalty_damping_for_restitution`.
    exponent : number or Symbol
        :math:`p` (>= 1; 1: linear, 1.5: Hertz-like).
    name : str

    Attributes
    ----------
    tilt, tilt_rate, penetration, magnitude : sympy expressions
        :math:`\theta` (rad), :math:`\dot\theta` (rad/s; exact where the limit is
        active), :math:`\max(\delta, 0)` (rad) and :math:`T` (N m): outputs.
    torque : Vector
        The torque on the body.
    """

    def __init__(self, body, housing, body_axis, housing_axis, limit, stiffness,
                 damping=0, exponent=1, name="cone limit"):
        if not isinstance(name, str) or not name:
            raise ModelError(f"ConeLimit needs a non-empty name, got {name!r}")
        self.name = name
        self.body = _frame_of(body, f"ConeLimit {name}: body")
        self.housing = _frame_of(housing, f"ConeLimit {name}: housing")
        self.body_axis = _unit(body_axis, self.body, f"ConeLimit {name}: body_axis")
        self.housing_axis = _unit(housing_axis, self.housing,
                                  f"ConeLimit {name}: housing_axis")
        self.limit = _check_angle(limit, f"ConeLimit {name}: limit")
        self.stiffness = as_expression(stiffness, f"ConeLimit {name}: stiffness")
        self.damping = as_expression(damping, f"ConeLimit {name}: damping")
        self.exponent = as_expression(exponent, f"ConeLimit {name}: exponent")
        for value, what, lower, strict in ((self.stiffness, "stiffness", 0.0, True),
                                           (self.damping, "damping", 0.0, False),
                                           (self.exponent, "exponent", 1.0, False)):
            if value.is_number:
                v = float(value)
                if not math.isfinite(v) or v < lower or (strict and v == lower):
                    op = ">" if strict else ">="
                    raise ModelError(f"ConeLimit {name}: {what} must be {op} {lower}, got {v}")
        theta, cross, s = tilt_angle(self.body_axis, self.housing_axis)
        # where the limit is active |a x e| >= sin(limit): the floor only guards
        # the (discarded) inactive branch against 0/0 at zero tilt
        s_safe = sm.Max(s, sm.sin(self.limit) / 2)
        self.normal = cross / s_safe
        w_rel = self.body.ang_vel_in(self.housing)
        self.tilt = theta
        self.tilt_rate = w_rel.dot(cross) / s_safe
        delta = theta - self.limit
        self.penetration = sm.Max(delta, 0)
        law = self.stiffness * self.penetration ** self.exponent + self.damping * self.tilt_rate
        self.magnitude = sm.Piecewise((sm.Max(law, 0), delta > 0), (0, True))
        self.torque = -self.magnitude * self.normal

    def to_loads(self):
        """``[(body frame, torque), (housing frame, -torque)]`` for ``kd.kane(loads=...)``."""
        return [(self.body, self.torque), (self.housing, -self.torque)]

    def __repr__(self):
        return (f"<ConeLimit {self.name}: limit {self.limit}, k={self.stiffness}, "
                f"c={self.damping}, p={self.exponent}>")


def penalty_damping_for_restitution(restitution, stiffness, inertia):
    r"""Damping of a linear (p = 1) penalty that gives a coefficient of restitution.

    For a linear spring-dashpot acting on an inertia :math:`J` the rebound
    speed over the approach speed is :math:`e = \exp(-\zeta\pi/\sqrt{1-\zeta^2})`,
    :math:`\zeta = c / (2\sqrt{kJ})`; hence
    :math:`\zeta = -\ln e / \sqrt{\pi^2 + \ln^2 e}` and :math:`c = 2\zeta\sqrt{kJ}`
    (the one-sided ``max`` lets the body leave slightly early, so the
    restitution realised is slightly larger for large damping).

    Parameters
    ----------
    restitution : float
        In (0, 1].
    stiffness : float
        N m / rad.
    inertia : float
        Moment of inertia about the pivot for the tilt, kg m^2.

    Returns
    -------
    float
        :math:`c`, N m s / rad.
    """
    e, k, J = float(restitution), float(stiffness), float(inertia)
    if not 0.0 < e <= 1.0:
        raise ModelError(f"penalty_damping_for_restitution: restitution must be in (0, 1], "
                         f"got {e}")
    if k <= 0 or J <= 0:
        raise ModelError("penalty_damping_for_restitution: stiffness and inertia must be "
                         f"positive, got {k}, {J}")
    le = math.log(e)
    zeta = -le / math.sqrt(math.pi ** 2 + le ** 2)
    return 2.0 * zeta * math.sqrt(k * J)


def cone_surface(housing, apex, axis, limit, radius, name="cone"):
    r"""A circular cone fixed in ``housing``: apex at ``apex``, axis ``axis``, half-angle ``limit``.

    The gap function is
    :math:`g = (\zeta^2\sin^2\theta_l - \rho^2\cos^2\theta_l)/(r\sin 2\theta_l)`
    (:math:`\zeta` the coordinate along the axis, :math:`\rho` the distance from
    it, ``r = radius`` the distance from the apex at which the contact point
    moves): positive inside the cone, and on its surface at that distance
    :math:`\nabla g` is the inward unit normal, so :math:`g` is the distance to
    the wall to first order.  Written without square roots, it is smooth on
    the axis (zero tilt).  Only the nappe around ``+axis`` is meant (the other
    one is also "inside").

    Parameters
    ----------
    housing : ReferenceFrame
    apex : Point
        Fixed in ``housing`` (the pivot).
    axis : Vector
        Fixed in ``housing``; normalised here.
    limit : number or Symbol
        Half-angle, rad, in (0, pi/2).
    radius : number or Symbol
        Distance of the contact point from the apex, m (> 0).
    """
    frame = _frame_of(housing, f"cone {name}: housing")
    axis = _unit(axis, frame, f"cone {name}: axis")
    limit = _check_angle(limit, f"cone {name}: limit")
    radius = as_expression(radius, f"cone {name}: radius")
    if radius.is_number and float(radius) <= 0:
        raise ModelError(f"cone {name}: radius must be positive, got {float(radius)}")
    x = SURFACE_COORDINATES
    a = [axis.dot(frame.x), axis.dot(frame.y), axis.dot(frame.z)]
    zeta = sum(ai * xi for ai, xi in zip(a, x))
    rho2 = sum(xi ** 2 for xi in x) - zeta ** 2
    gap = ((zeta * sm.sin(limit)) ** 2 - rho2 * sm.cos(limit) ** 2) / (
        radius * sm.sin(2 * limit))
    surface = ImplicitSurface(frame, apex, gap, name=name)
    surface.axis, surface.limit, surface.radius = axis, limit, radius
    return surface


def cone_contact(point, housing, apex, axis, limit, radius, restitution=None,
                 restitution_law="newton", mu_k=0, name="cone"):
    """The tilt limit as a unilateral :class:`~kanedyn.Contact` of ``point`` on a cone.

    ``point`` is fixed in the tilting body on its axis at distance ``radius``
    from the pivot ``apex``; the contact's normal force times ``radius`` is the
    limit torque (the cone's normal is perpendicular to the body axis where it
    touches).  Parameters as :func:`cone_surface` and :class:`~kanedyn.Contact`.
    """
    surface = cone_surface(housing, apex, axis, limit, radius, name=f"{name} wall")
    return Contact(point, surface, mu_k=mu_k, restitution=restitution,
                   restitution_law=restitution_law, name=name)
