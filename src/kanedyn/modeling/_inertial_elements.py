r"""Generalized-inertia elements: kinetic energy on rates linear in the speeds.

An inertial element carries the kinetic energy

.. math:: T = \tfrac12 w^TM_ww,

with :math:`w` a vector of :math:`k` *rates*, linear in the generalized
speeds (:math:`w = W u + w_t`, :math:`W` and :math:`w_t` functions of the
coordinates and time), and :math:`M_w` a constant symmetric :math:`k\times k`
matrix.  Its generalized inertia forces are :math:`F^*_r = -(\partial
w/\partial u_r)^TM_w\dot w`: it adds :math:`W^TM_wW` to the mass matrix and
:math:`-W^TM_w\dot w|_{\dot u = 0}` to the forcing.  The formulations treat it
as a block of the kind a flexible body reduces to (see
:mod:`kanedyn.formulations._flexible`), with no velocity terms of its own
(:math:`M_w` is constant) and no applied forces.  Elements are passed in
``bodies=[...]`` of :func:`kanedyn.kane`.

``RateInertia``  any rates and an inertia matrix on them
``Inerter``      the two-terminal inerter: :math:`w = d|AB|/dt`, :math:`M_w = b`
``AddedMass``    a 6 x 6 added-mass matrix on a point's velocity and a frame's
                 angular velocity, in body components
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError

__all__ = ["InertialElement", "RateInertia", "Inerter", "AddedMass"]

_RTOL = 1e-9  # relative tolerance of the symmetry and definiteness checks


def _check_name(name, what):
    if not isinstance(name, str) or not name:
        raise ModelError(f"{what} needs a non-empty name (a str), got {name!r}")
    return name


def _inertia_matrix(value, k, where):
    """``value`` as a constant symmetric, positive semi-definite k x k matrix."""
    if isinstance(value, (int, float, np.integer, np.floating)) or (
            isinstance(value, sm.Basic) and not isinstance(value, sm.MatrixBase)):
        if k != 1:
            raise ModelError(f"{where}: a scalar inertia needs exactly one rate, got {k} "
                             "(give a k x k matrix)")
        value = [[value]]
    try:
        M = sm.ImmutableMatrix(np.asarray(value, dtype=object).tolist()
                               if not isinstance(value, sm.MatrixBase) else value)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{where}: cannot read the inertia matrix: {exc}") from None
    M = M.applyfunc(sm.sympify)
    if M.shape != (k, k):
        raise ModelError(f"{where}: the inertia matrix must be {k} x {k} (one row and column "
                         f"per rate), got {M.shape[0]} x {M.shape[1]}")
    moving = set().union(*(me.find_dynamicsymbols(e) for e in M))
    if moving:
        raise ModelError(f"{where}: the inertia matrix must be constant; it contains "
                         f"{', '.join(sorted(map(str, moving)))}")
    numeric = all(e.is_number for e in M)
    if numeric:
        A = np.array(M.tolist(), dtype=float)
        scale = max(np.max(np.abs(A)), 1e-300)
        if np.max(np.abs(A - A.T)) > _RTOL * scale:
            raise ModelError(f"{where}: the inertia matrix is not symmetric "
                             f"(largest |M - M^T| = {np.max(np.abs(A - A.T)):.3g})")
        lowest = np.linalg.eigvalsh((A + A.T) / 2)[0]
        if lowest < -_RTOL * scale:
            raise ModelError(f"{where}: the inertia matrix must be positive semi-definite "
                             f"(kinetic energy never negative); its smallest eigenvalue is "
                             f"{lowest:.6g}")
    else:
        if any(sm.simplify(M[i, j] - M[j, i]) != 0 for i in range(k) for j in range(i)):
            raise ModelError(f"{where}: the inertia matrix is not symmetric")
        for i in range(k):
            d = M[i, i]
            if d.is_number and float(d) < 0 or d.is_negative:
                raise ModelError(f"{where}: diagonal entry {i} of the inertia matrix is "
                                 f"negative ({d})")
    return M


class InertialElement:
    r"""Base of the generalized-inertia elements.

    Attributes
    ----------
    name : str
    inertia : sympy.ImmutableMatrix
        :math:`M_w`, shape (k, k), constant and symmetric (units: kg for rates
        in m/s, kg m^2 for rates in rad/s).
    """

    kind = "inertial element"

    def __init__(self, name, inertia, k):
        self.name = _check_name(name, type(self).__name__)
        self.inertia = _inertia_matrix(inertia, k, self._where)

    @property
    def _where(self):
        return f"{type(self).__name__} {self.name!r}"

    @property
    def size(self):
        """Number of rates :math:`k`."""
        return self.inertia.shape[0]

    def _bias(self, w, p, cross):
        """Velocity terms :math:`\\beta` of the block (zero: the rates are time
        derivatives and :math:`M_w` is constant)."""
        return [0] * len(w)

    def _rates(self, kin):
        """The rates :math:`w` in the program's internal symbols (k expressions).

        ``kin`` is the formulation's :class:`kanedyn.engine.Kinematics`.
        """
        raise NotImplementedError

    def __repr__(self):
        return f"{type(self).__name__}({self.name!r})"


class RateInertia(InertialElement):
    r"""Kinetic energy :math:`\tfrac12 w^TM_ww` on given rates.

    Parameters
    ----------
    name : str
    rates : sequence of sympy.Expr, or one expression
        The :math:`k` rates (m/s or rad/s): expressions in the coordinates,
        speeds, coordinate derivatives and time that are linear in the
        generalized speeds once the kinematic differential equations are used.
        Rates that are time derivatives of functions of the coordinates and
        time (a distance, a joint angle, inertial velocity components) give
        the same equations in every formulation; for components in a
        rotating frame use :class:`AddedMass`, which adds the velocity terms
        such rates need.
    inertia : array_like or scalar
        :math:`M_w`, a constant symmetric positive semi-definite (k, k)
        matrix, or a scalar for one rate; SymPy symbols allowed.

    Raises
    ------
    ModelError
        Naming the element: a rate that is not an expression, an inertia of
        the wrong shape, not symmetric, not constant or with a negative
        eigenvalue.  A rate not linear in the speeds is refused when the
        equations are derived.
    """

    kind = "rates"

    def __init__(self, name, rates, inertia):
        if isinstance(rates, sm.Basic) and not isinstance(rates, sm.MatrixBase):
            rates = [rates]
        rates = tuple(rates)
        _check_name(name, "RateInertia")
        if not rates:
            raise ModelError(f"RateInertia {name!r}: give at least one rate")
        for i, r in enumerate(rates):
            if isinstance(r, me.Vector) or not isinstance(r, (sm.Basic, int, float)):
                raise ModelError(f"RateInertia {name!r}: rate {i} must be a scalar SymPy "
                                 f"expression, got {type(r).__name__}")
        self.rates = tuple(sm.sympify(r, strict=True) for r in rates)
        super().__init__(name, inertia, len(rates))

    def _rates(self, kin):
        return [kin.scalar(r, f"{self._where}: rate {i}", f"w_{self.name}")
                for i, r in enumerate(self.rates)]


class Inerter(InertialElement):
    r"""A two-terminal inerter of inertance ``b`` between two points.

    Its force is :math:`b\,\ddot\ell`, with :math:`\ell = |AB|` the distance
    of its terminals, along their line: pulling the terminals together when
    they separate faster and faster.  It is the element of kinetic energy
    :math:`\tfrac12 b\dot\ell^2`, so it adds :math:`b\,\ell_u^T\ell_u` to the
    mass matrix (:math:`\ell_u = \partial\dot\ell/\partial u`) and
    :math:`-b\,\ell_u^T\dot\ell_u u` to the forcing; see
    ``docs/inertial_elements.md``.

    Parameters
    ----------
    name : str
    point_a, point_b : sympy.physics.mechanics.Point
        The terminals; their positions must be connected (``set_pos`` /
        ``locatenew``) and their velocities known in the model's frame.
    inertance : float or sympy.Expr
        :math:`b`, in kg (non-negative).
    frame : sympy.physics.mechanics.ReferenceFrame
        The frame in which the distance is differentiated (a distance rate is
        the same in every frame; the inertial frame is customary).

    Raises
    ------
    ModelError
        Naming the inerter: terminals that are not points, the same point or
        with no connecting positions, a negative inertance.
    """

    kind = "inerter"

    def __init__(self, name, point_a, point_b, inertance, frame):
        _check_name(name, "Inerter")
        for label, p in (("point_a", point_a), ("point_b", point_b)):
            if not isinstance(p, me.Point):
                raise ModelError(f"Inerter {name!r}: {label} must be a Point, got "
                                 f"{type(p).__name__}")
        if not isinstance(frame, me.ReferenceFrame):
            raise ModelError(f"Inerter {name!r}: frame must be a ReferenceFrame, got "
                             f"{type(frame).__name__}")
        try:
            r = point_b.pos_from(point_a)
        except ValueError:
            raise ModelError(f"Inerter {name!r}: no position connects {point_a.name} and "
                             f"{point_b.name}; locate one from the other") from None
        if r == me.Vector(0) or point_a is point_b:
            raise ModelError(f"Inerter {name!r}: its terminals {point_a.name} and "
                             f"{point_b.name} coincide (zero-length line: no direction)")
        self.point_a, self.point_b, self.frame = point_a, point_b, frame
        super().__init__(name, inertance, 1)

    @property
    def inertance(self):
        """:math:`b`, in kg."""
        return self.inertia[0, 0]

    @property
    def length(self):
        """Distance between the terminals (m), a SymPy expression."""
        r = self.point_b.pos_from(self.point_a)
        return sm.sqrt(r.dot(r))

    def _rates(self, kin):
        where = self._where
        r = kin.position(self.point_b, self.point_a)
        if r is None:
            r = kin.vector(self.point_b.pos_from(self.point_a), f"{where}: line")
        if all(c == 0 for c in r):
            raise ModelError(f"{where}: its terminals coincide (zero-length line)")
        r = kin.let_vector(r, f"r_{self.name}")
        va, vb = kin.velocity(self.point_a), kin.velocity(self.point_b)
        prog = kin.prog
        length = prog.let(sm.sqrt(sm.Add(*[c ** 2 for c in r])), f"len_{self.name}")
        return [sm.Add(*[c * (b - a) for c, a, b in zip(r, va, vb)]) / length]


class AddedMass(InertialElement):
    r"""A 6 x 6 added-mass matrix on a body's motion in a frame.

    The rates are the velocity of ``point`` and the angular velocity of
    ``body_frame``, both in ``frame`` and in ``body_frame`` components,
    :math:`w = (v_x, v_y, v_z, \omega_x, \omega_y, \omega_z)`, and
    :math:`M_w` the added-mass matrix about ``point`` in that order (as the
    added mass of a floating body is given: surge, sway, heave, roll, pitch,
    yaw).  :math:`T = \tfrac12 w^TM_ww` is the fluid's kinetic energy; the
    element adds :math:`T_b^TM_wT_b` to the mass matrix and, since the rates
    are components in the rotating body frame, Kirchhoff's velocity terms
    :math:`\omega\times p_v` and :math:`\omega\times p_\omega + v\times
    p_v` (:math:`p = M_ww`; the last one is Munk's moment) to the forcing, as
    Lagrange's equations in quasi-coordinates give them.

    Parameters
    ----------
    name : str
    point : sympy.physics.mechanics.Point
        Reference point of the matrix (fixed in ``body_frame``).
    body_frame : sympy.physics.mechanics.ReferenceFrame
    matrix : array_like, shape (6, 6)
        Constant, symmetric, positive semi-definite (kg, kg m, kg m^2 blocks).
    frame : sympy.physics.mechanics.ReferenceFrame
        The model's inertial frame.

    Raises
    ------
    ModelError
        Naming the element: wrong types, a matrix not 6 x 6, not symmetric or
        with a negative eigenvalue, a frame other than the model's.
    """

    kind = "added mass"

    def __init__(self, name, point, body_frame, matrix, frame):
        _check_name(name, "AddedMass")
        if not isinstance(point, me.Point):
            raise ModelError(f"AddedMass {name!r}: point must be a Point, got "
                             f"{type(point).__name__}")
        for label, f in (("body_frame", body_frame), ("frame", frame)):
            if not isinstance(f, me.ReferenceFrame):
                raise ModelError(f"AddedMass {name!r}: {label} must be a ReferenceFrame, "
                                 f"got {type(f).__name__}")
        self.point, self.body_frame, self.frame = point, body_frame, frame
        super().__init__(name, matrix, 6)

    @property
    def matrix(self):
        """The 6 x 6 added-mass matrix."""
        return self.inertia

    def _bias(self, w, p, cross):
        """Kirchhoff's terms: :math:`(\\omega\\times p_v,\\ \\omega\\times p_\\omega +
        v\\times p_v)` (the rates are components in a rotating frame)."""
        v, om, pv, pw = w[:3], w[3:], p[:3], p[3:]
        return list(cross(om, pv)) + [a + b for a, b in zip(cross(om, pw), cross(v, pv))]

    def _rates(self, kin):
        if self.frame is not kin.N:
            raise ModelError(f"{self._where}: its frame {self.frame.name} must be the "
                             f"model's frame {kin.N.name}")
        C = kin.dcm(self.body_frame)
        v, om = kin.velocity(self.point), kin.angular_velocity(self.body_frame)
        return [sum(C[i, a] * vec[i] for i in range(3)) for vec in (v, om) for a in range(3)]
