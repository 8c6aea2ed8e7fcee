r"""Constraints written in vector form, and the constraint forces they identify.

A velocity constraint written as a dot product names its own constraint force
(Roithmayr & Hodges 2013): for

.. math::

    ({}^N v^P - {}^N v^{\bar P})\cdot \hat n = 0,

where :math:`\bar P` is the point of body :math:`A` that coincides with
:math:`P` (of body :math:`B`), the partial derivative with respect to a speed
:math:`u_r` is :math:`(v^P_r - v^{\bar P}_r)\cdot\hat n`, which is exactly the
contribution of a force :math:`\lambda\hat n` applied to :math:`B` at
:math:`P` and :math:`-\lambda\hat n` applied to :math:`A` at :math:`\bar P` to
the generalized active force :math:`F_r`.  Kane's equations with the
constraint's dependent speed therefore hold with that force, and the
multiplier :math:`\lambda` is its magnitude along :math:`\hat n`.  Likewise
:math:`({}^N\omega^B - {}^N\omega^A)\cdot\hat n = 0` identifies a torque
:math:`\lambda\hat n` on :math:`B` and :math:`-\lambda\hat n` on :math:`A`,
and the nonlinear :math:`v^P\cdot v^Q = 0` the forces :math:`\lambda v^Q` at
:math:`P` and :math:`\lambda v^P` at :math:`Q`.

Pass these objects to :func:`kanedyn.kane` as ``constraints=[...]``; each
adds its scalar velocity constraints (one per direction) to the model's, and
the equations of motion remember the forces.
"""

from __future__ import annotations

import sympy.physics.mechanics as me

from .._errors import ModelError
from ..engine import add, cross, dot

__all__ = ["VectorConstraint", "PointVelocity", "AngularVelocity", "OrthogonalVelocities",
           "ConstraintAction"]


class ConstraintAction:
    """One force or torque of a constraint, per unit multiplier.

    Attributes
    ----------
    kind : {"force", "torque"}
    location : Point or ReferenceFrame
        Where a force acts (the point) or the frame a torque acts on.
    vector : 3-tuple
        Inertial components (program expressions) of the force or torque for
        a multiplier of 1.
    body : RigidBody, Particle or None
        The body acted on, when the constraint names it; ``None``: the body
        the point is fixed in (found when the forces are checked).
    ground : bool
        The action is on a frame with prescribed motion (no body).
    """

    __slots__ = ("kind", "location", "vector", "body", "ground")

    def __init__(self, kind, location, vector, body=None, ground=False):
        self.kind, self.location, self.vector = kind, location, vector
        self.body, self.ground = body, ground


def _vectors(directions, what):
    if directions is None:
        return None
    if isinstance(directions, me.Vector):
        directions = [directions]
    out = list(directions)
    if not out:
        raise ModelError(f"{what}: give at least one direction")
    for d in out:
        if not isinstance(d, me.Vector):
            raise ModelError(f"{what}: directions must be sympy Vectors, got {d!r}")
    return out


def _names(names, base, count, what):
    if names is None:
        return (base,) if count == 1 else tuple(f"{base}_{i + 1}" for i in range(count))
    if isinstance(names, str):
        names = [names]
    names = tuple(str(n) for n in names)
    if len(names) != count:
        raise ModelError(f"{what}: {count} direction(s) but {len(names)} name(s)")
    return names


def _relative(relative_to, what):
    """``(frame, point fixed in it, body or None)`` of a ``relative_to`` argument."""
    if relative_to is None:
        return None
    if isinstance(relative_to, me.RigidBody):
        return relative_to.frame, relative_to.masscenter, relative_to
    if isinstance(relative_to, me.Particle):
        return None, relative_to.masscenter, relative_to
    if (isinstance(relative_to, tuple) and len(relative_to) == 2
            and isinstance(relative_to[0], me.ReferenceFrame)
            and isinstance(relative_to[1], me.Point)):
        return relative_to[0], relative_to[1], None
    raise ModelError(f"{what}: relative_to must be a RigidBody, a Particle or a "
                     f"(ReferenceFrame, Point fixed in it) pair, got {relative_to!r}")


class VectorConstraint:
    """Base class: velocity constraints with identified constraint forces.

    Attributes
    ----------
    names : tuple of str
        One per scalar constraint: the names of the multipliers (the
        constraint-force magnitudes).
    """

    names = ()

    def __len__(self):
        return len(self.names)

    def _rows(self, kin):  # pragma: no cover - abstract
        """``[(velocity-constraint expression, [ConstraintAction, ...]), ...]``."""
        raise NotImplementedError


class PointVelocity(VectorConstraint):
    r"""The velocity of a point has no component along given directions.

    :math:`({}^N v^P - {}^N v^{\bar P})\cdot\hat n_i = 0` where :math:`\bar P`
    is the point of ``relative_to`` coinciding with ``P`` (or a fixed point
    when ``relative_to`` is ``None``).  Identified force: :math:`\lambda_i
    \hat n_i` on the body of ``P`` at ``P``; the reaction :math:`-\lambda_i
    \hat n_i` on ``relative_to`` at :math:`\bar P`.

    Parameters
    ----------
    point : Point
        The constrained point (with its velocity defined in the model: for a
        rolling contact, the contact point as a point of the rolling body).
    directions : Vector or sequence of Vector, optional
        The directions :math:`\hat n_i` (need not be unit vectors; the
        multiplier is then the force divided by their length).  Default:
        the three axes of the frame of ``relative_to`` (or of the inertial
        frame): the relative velocity vanishes.
    relative_to : RigidBody, Particle or (ReferenceFrame, Point), optional
        The other body (or a frame with prescribed motion and a point fixed
        in it).  Default: the inertial frame.
    body : RigidBody or Particle, optional
        The body ``point`` belongs to (default: found from its velocity).
    names : str or sequence of str, optional
        Multiplier names, one per direction (default ``F_<point>_<i>``).

    Examples
    --------
    A pin ``P`` of body ``B`` in a slot of body ``A`` along ``A.x``:
    ``PointVelocity(P, A.y, relative_to=A)``; a disk rolling on the ground
    at contact point ``C``: ``PointVelocity(C, [N.x, N.y])``.
    """

    def __init__(self, point, directions=None, relative_to=None, body=None, names=None):
        what = f"PointVelocity({getattr(point, 'name', point)})"
        if not isinstance(point, me.Point):
            raise ModelError(f"{what}: point must be a sympy Point, got {point!r}")
        self.point = point
        self.directions = _vectors(directions, what)
        self.relative_to = relative_to
        self._relative = _relative(relative_to, what)
        if body is not None and not isinstance(body, (me.RigidBody, me.Particle)):
            raise ModelError(f"{what}: body must be a RigidBody or Particle, got {body!r}")
        self.body = body
        count = 3 if self.directions is None else len(self.directions)
        self.names = _names(names, f"F_{point.name}", count, what)
        self._what = what

    def __repr__(self):
        return f"<PointVelocity {self.point.name}: {', '.join(self.names)}>"

    def _rows(self, kin):
        what = self._what
        v = kin.velocity(self.point)
        reaction = None
        frame = kin.N
        if self._relative is not None:
            rel_frame, origin, rel_body = self._relative
            r = kin.position(self.point, origin)
            if r is None:
                raise ModelError(
                    f"{what}: the position of {self.point.name} relative to {origin.name} "
                    "is not defined; locate one from the other (set_pos/locatenew)")
            v_bar = kin.velocity(origin)
            if rel_frame is not None:
                v_bar = add(v_bar, cross(kin.angular_velocity(rel_frame), r))
                frame = rel_frame
            v = tuple(a - b for a, b in zip(v, v_bar))
            reaction = rel_body
        directions = self.directions or [frame.x, frame.y, frame.z]
        rows = []
        for i, d in enumerate(directions):
            n = kin.let_vector(kin.vector(d, f"{what} direction {i + 1}"), "nvc")
            actions = [ConstraintAction("force", self.point, n, self.body)]
            if self._relative is not None:
                actions.append(ConstraintAction(
                    "force", self.point, tuple(-c for c in n), reaction,
                    ground=reaction is None))
            rows.append((dot(v, n), actions))
        return rows


class AngularVelocity(VectorConstraint):
    r"""The angular velocity of a body has no component along given directions.

    :math:`({}^N\omega^B - {}^N\omega^A)\cdot\hat n_i = 0`; identified torque
    :math:`\lambda_i\hat n_i` on ``B`` and :math:`-\lambda_i\hat n_i` on ``A``.

    Parameters
    ----------
    body : RigidBody or ReferenceFrame
    directions : Vector or sequence of Vector, optional
        Default: the three axes of the frame of ``relative_to`` (or of the
        inertial frame).
    relative_to : RigidBody or ReferenceFrame, optional
        Default: the inertial frame.
    names : str or sequence of str, optional
        Default ``T_<body>_<i>``.
    """

    def __init__(self, body, directions=None, relative_to=None, names=None):
        what = f"AngularVelocity({getattr(body, 'name', body)})"
        self.frame, self.body = self._frame_and_body(body, what)
        self.relative_frame, self.relative_body = (
            (None, None) if relative_to is None else self._frame_and_body(relative_to, what))
        self.directions = _vectors(directions, what)
        count = 3 if self.directions is None else len(self.directions)
        self.names = _names(names, f"T_{getattr(body, 'name', body)}", count, what)
        self._what = what

    @staticmethod
    def _frame_and_body(obj, what):
        if isinstance(obj, me.RigidBody):
            return obj.frame, obj
        if isinstance(obj, me.ReferenceFrame):
            return obj, None
        raise ModelError(f"{what}: expected a RigidBody or ReferenceFrame, got {obj!r}")

    def __repr__(self):
        return f"<AngularVelocity {self.frame}: {', '.join(self.names)}>"

    def _rows(self, kin):
        w = kin.angular_velocity(self.frame)
        frame = kin.N
        if self.relative_frame is not None:
            w = tuple(a - b for a, b in zip(w, kin.angular_velocity(self.relative_frame)))
            frame = self.relative_frame
        directions = self.directions or [frame.x, frame.y, frame.z]
        rows = []
        for i, d in enumerate(directions):
            n = kin.let_vector(kin.vector(d, f"{self._what} direction {i + 1}"), "nvc")
            actions = [ConstraintAction("torque", self.frame, n, self.body)]
            if self.relative_frame is not None:
                actions.append(ConstraintAction(
                    "torque", self.relative_frame, tuple(-c for c in n), self.relative_body,
                    ground=self.relative_body is None))
            rows.append((dot(w, n), actions))
        return rows


class OrthogonalVelocities(VectorConstraint):
    r"""The velocities of two points are perpendicular: :math:`v^P\cdot v^Q = 0`.

    A constraint nonlinear in the speeds.  Its partial derivatives
    :math:`v^P_r\cdot v^Q + v^P\cdot v^Q_r` identify the forces
    :math:`\lambda v^Q` at ``P`` and :math:`\lambda v^P` at ``Q``.

    Parameters
    ----------
    point_p, point_q : Point
    bodies : pair of RigidBody or Particle, optional
        The bodies the points belong to (default: found from the velocities).
    name : str, optional
        Default ``F_<P>_<Q>``.
    """

    def __init__(self, point_p, point_q, bodies=(None, None), name=None):
        what = f"OrthogonalVelocities({getattr(point_p, 'name', point_p)}, " \
               f"{getattr(point_q, 'name', point_q)})"
        for p in (point_p, point_q):
            if not isinstance(p, me.Point):
                raise ModelError(f"{what}: expected sympy Points, got {p!r}")
        self.points = (point_p, point_q)
        self.bodies = tuple(bodies)
        self.names = _names(name, f"F_{point_p.name}_{point_q.name}", 1, what)

    def __repr__(self):
        return f"<OrthogonalVelocities {self.points[0].name}, {self.points[1].name}>"

    def _rows(self, kin):
        P, Q = self.points
        vp = kin.let_vector(kin.velocity(P), "vP")
        vq = kin.let_vector(kin.velocity(Q), "vQ")
        actions = [ConstraintAction("force", P, vq, self.bodies[0]),
                   ConstraintAction("force", Q, vp, self.bodies[1])]
        return [(dot(vp, vq), actions)]
