r"""Linear spring-dampers: between two points, and in six degrees of freedom.

``SpringDamper``        a force along the line between two points,
                        :math:`f = k\,(\ell - \ell_0) + c\,\dot\ell`
``MatrixSpringDamper``  a 6x6 stiffness and damping about a reference point and
                        orientation (hydrostatic and mooring matrices)
``rotation_vector``     the rotation measure the 6x6 element uses

Both reduce themselves to loads (:meth:`to_loads`) that every formulation and
backend sees.
"""

import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError

__all__ = ["SpringDamper", "MatrixSpringDamper", "rotation_vector"]


def _check_name(name, what):
    if not isinstance(name, str) or not name:
        raise ModelError(f"{what} needs a non-empty name (a str), got {name!r}")
    return name


def _check_type(value, kind, what):
    if not isinstance(value, kind):
        raise ModelError(f"{what} must be a {kind.__name__}, got {type(value).__name__}")
    return value


def _check_coefficient(value, what):
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if value < 0:
            raise ModelError(f"{what} must not be negative, got {value!r}")
        return sm.sympify(value, strict=True)
    if isinstance(value, sm.Basic):
        return value
    raise ModelError(f"{what} must be a number or a SymPy expression, got "
                     f"{type(value).__name__}")


class SpringDamper:
    r"""A linear spring and a viscous damper between two points.

    The tension :math:`f = k\,(\ell - \ell_0) + c\,\dot\ell` with
    :math:`\ell = |r_{AB}|` pulls the points together when positive: the load
    on ``point_a`` is :math:`+f\,e` and on ``point_b`` :math:`-f\,e`, with
    :math:`e = r_{AB}/\ell` the unit vector from A to B.

    Parameters
    ----------
    name : str
    point_a, point_b : sympy.physics.mechanics.Point
    stiffness : float or sympy.Expr
        :math:`k`, N/m (non-negative).
    damping : float or sympy.Expr
        :math:`c`, N s/m (non-negative).
    free_length : float or sympy.Expr
        :math:`\ell_0`, the unstretched length, m.
    frame : sympy.physics.mechanics.ReferenceFrame
        The frame in which :math:`\dot\ell` is taken (any frame gives the same
        rate; the inertial frame is customary).

    Raises
    ------
    ModelError
        If the points coincide identically (the line has no direction).
    """

    def __init__(self, name, point_a, point_b, stiffness, damping, free_length, frame):
        self.name = _check_name(name, "SpringDamper")
        what = f"SpringDamper {name!r}"
        self.point_a = _check_type(point_a, me.Point, f"{what}: point_a")
        self.point_b = _check_type(point_b, me.Point, f"{what}: point_b")
        self.frame = _check_type(frame, me.ReferenceFrame, f"{what}: frame")
        self.stiffness = _check_coefficient(stiffness, f"{what}: stiffness")
        self.damping = _check_coefficient(damping, f"{what}: damping")
        self.free_length = _check_coefficient(free_length, f"{what}: free_length")
        r = self.point_b.pos_from(self.point_a)
        if r == me.Vector(0) or sm.simplify(r.magnitude()) == 0:
            raise ModelError(f"{what}: point_a {point_a.name} and point_b {point_b.name} "
                             "coincide; a spring needs a line of non-zero length")

    @property
    def length(self):
        """:math:`\\ell`, the distance between the points (m)."""
        r = self.point_b.pos_from(self.point_a)
        return sm.sqrt(r.dot(r))

    @property
    def length_rate(self):
        """:math:`\\dot\\ell` (m/s)."""
        r = self.point_b.pos_from(self.point_a)
        return r.dt(self.frame).dot(r) / self.length

    @property
    def tension(self):
        """:math:`f = k(\\ell - \\ell_0) + c\\dot\\ell` (N), positive when stretched."""
        return (self.stiffness * (self.length - self.free_length)
                + self.damping * self.length_rate)

    def to_loads(self):
        """``[(point_a, f e), (point_b, -f e)]``."""
        r = self.point_b.pos_from(self.point_a)
        force = self.tension / self.length * r
        return [(self.point_a, force), (self.point_b, -force)]

    def __repr__(self):
        return (f"SpringDamper({self.name!r}, {self.point_a.name}, {self.point_b.name}, "
                f"k={self.stiffness}, c={self.damping}, l0={self.free_length})")


def rotation_vector(body_frame, reference_frame):
    r"""The rotation measure of ``body_frame`` relative to ``reference_frame``.

    .. math:: \theta = \tfrac12 \sum_{i=1}^{3} r_i \times b_i
              = \operatorname{vee}\!\left(\tfrac12 (R - R^T)\right)
              = \sin\varphi\; n

    with :math:`r_i`, :math:`b_i` the unit vectors of the two frames and
    :math:`R` the rotation taking one to the other, of angle :math:`\varphi`
    about the unit axis :math:`n`.  It is the vector part of the rotation
    matrix's skew part: equal to the rotation vector :math:`\varphi n` to third
    order in the angle (:math:`\sin\varphi = \varphi - \varphi^3/6`), smooth
    everywhere, and its first variation about the reference is exactly the
    small rotation, :math:`\delta\theta = \delta\varphi\,n`.  At large angles
    it saturates (its magnitude peaks at 90 degrees and returns to zero at 180
    degrees): a 6x6 matrix about a reference is meant for small rotations.

    Returns
    -------
    sympy.physics.vector.Vector
        Dimensionless (rad to first order).
    """
    refs = (reference_frame.x, reference_frame.y, reference_frame.z)
    bodies = (body_frame.x, body_frame.y, body_frame.z)
    return sum((r.cross(b) for r, b in zip(refs, bodies)), me.Vector(0)) / 2


def _matrix6(value, what):
    try:
        m = sm.Matrix(value)
    except Exception:
        raise ModelError(f"{what} must be a 6x6 matrix (nested lists, numpy array or "
                         f"sympy.Matrix), got {type(value).__name__}") from None
    if m.shape != (6, 6):
        raise ModelError(f"{what} must be 6x6, got shape {m.shape}")
    return m


class MatrixSpringDamper:
    r"""A 6x6 stiffness and damping of a body about a reference point and orientation.

    The generalized displacement and velocity are

    .. math:: x = \begin{bmatrix} d \\ \theta \end{bmatrix},\qquad
              v = \begin{bmatrix} \dot d \\ \omega \end{bmatrix}

    with :math:`d` the displacement of ``point`` from the reference point,
    :math:`\theta` the rotation of ``body_frame`` relative to the reference
    orientation (:func:`rotation_vector`: :math:`\sin\varphi\,n`, the small
    rotation vector to third order), :math:`\dot d` the velocity of ``point``
    and :math:`\omega` the angular velocity of ``body_frame``, all in
    ``frame`` components.  The element applies

    .. math:: \begin{bmatrix} F \\ M \end{bmatrix} = -K x - C v

    as a force :math:`F` at ``point`` and a torque :math:`M` on ``body_frame``
    (``frame`` components).  Linearized about the reference (``point`` at the
    reference point, the frames aligned, at rest), the generalized forces are
    exactly :math:`-K\,\delta x - C\,\delta v`: the matrices as hydrostatic and
    mooring data give them.

    Parameters
    ----------
    name : str
    body_frame : sympy.physics.mechanics.ReferenceFrame
        The frame of the body the element acts on.
    point : sympy.physics.mechanics.Point
        The body's reference point (e.g. the platform's point on the still
        water line), fixed in the body.
    frame : sympy.physics.mechanics.ReferenceFrame
        The (inertial) frame in which the matrices are given.
    K : 6x6 array_like
        Stiffness: N/m, N/rad, N m/m, N m/rad blocks.
    C : 6x6 array_like
        Damping: N s/m, N s/rad, N m s/m, N m s/rad blocks.
    reference : sympy.physics.mechanics.Point or (Point, ReferenceFrame)
        The reference position of ``point`` (a point fixed in ``frame``) and,
        optionally, the reference orientation (a frame fixed in ``frame``;
        ``frame`` itself when not given).
    """

    def __init__(self, name, body_frame, point, frame, K, C, reference):
        self.name = _check_name(name, "MatrixSpringDamper")
        what = f"MatrixSpringDamper {name!r}"
        self.body_frame = _check_type(body_frame, me.ReferenceFrame, f"{what}: body_frame")
        self.point = _check_type(point, me.Point, f"{what}: point")
        self.frame = _check_type(frame, me.ReferenceFrame, f"{what}: frame")
        self.K = _matrix6(K, f"{what}: K")
        self.C = _matrix6(C, f"{what}: C")
        if isinstance(reference, me.Point):
            ref_point, ref_frame = reference, frame
        elif (isinstance(reference, (tuple, list)) and len(reference) == 2
              and isinstance(reference[0], me.Point)
              and isinstance(reference[1], me.ReferenceFrame)):
            ref_point, ref_frame = reference
        else:
            raise ModelError(f"{what}: reference must be a Point fixed in {frame.name} "
                             "or a (Point, ReferenceFrame) pair, got "
                             f"{type(reference).__name__}")
        self.reference_point, self.reference_frame = ref_point, ref_frame

    def _components(self, vector):
        return [vector.dot(e) for e in (self.frame.x, self.frame.y, self.frame.z)]

    @property
    def displacement(self):
        """:math:`x = [d, \\theta]` (6 SymPy expressions, m and rad)."""
        d = self.point.pos_from(self.reference_point)
        theta = rotation_vector(self.body_frame, self.reference_frame)
        return sm.Matrix(self._components(d) + self._components(theta))

    @property
    def velocity(self):
        """:math:`v = [\\dot d, \\omega]` (6 SymPy expressions, m/s and rad/s)."""
        v = self.point.vel(self.frame)
        w = self.body_frame.ang_vel_in(self.frame)
        return sm.Matrix(self._components(v) + self._components(w))

    def generalized_load(self):
        """:math:`[F, M] = -K x - C v` (6 expressions, N and N m, ``frame`` components)."""
        return -self.K * self.displacement - self.C * self.velocity

    def to_loads(self):
        """``[(point, F), (body_frame, M)]``."""
        f = self.generalized_load()
        e = (self.frame.x, self.frame.y, self.frame.z)
        force = sum((f[i] * e[i] for i in range(3)), me.Vector(0))
        torque = sum((f[3 + i] * e[i] for i in range(3)), me.Vector(0))
        return [(self.point, force), (self.body_frame, torque)]

    def __repr__(self):
        return (f"MatrixSpringDamper({self.name!r}, {self.body_frame.name}, "
                f"{self.point.name}, {self.frame.name})")
