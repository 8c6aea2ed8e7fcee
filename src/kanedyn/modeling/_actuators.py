r"""Actuators, transmissions and external wrenches as modeling objects.

An actuator is described by its *rate*: the speed along which its force or
torque does work (a joint rate, the rate of change of the distance between two
points).  By virtual work, an actuator of force :math:`f` and rate
:math:`\dot s = J u` contributes the generalized forces :math:`J^T f`.  Each
object reduces itself to loads (:meth:`to_loads`) for forward simulation, and a
transmission (:class:`BallScrew`) to an inertial element on its actuator's
rate (:meth:`Actuator.inertia_element`, a :class:`kanedyn.RateInertia` to pass
in ``bodies=[...]``).

``JointActuator``   a force or torque along a joint coordinate or relative rate
``LinearActuator``  a force along the line between two points (a prismatic leg)
``BallScrew``       motor, coupler and screw driving an actuator through a lead
``ExternalWrench``  a force at a body's mass centre and a moment on its frame
``drive_inputs``    actuators driven by specified inputs: their loads and drive trains
"""

import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ._inertial_elements import RateInertia

__all__ = ["Actuator", "JointActuator", "LinearActuator", "BallScrew", "ExternalWrench",
           "drive_inputs"]

_t = me.dynamicsymbols._t


def _check_name(name, what):
    if not isinstance(name, str) or not name:
        raise ModelError(f"{what} needs a non-empty name (a str), got {name!r}")
    return name


class BallScrew:
    r"""A ball-screw drive: motor rotor, coupler and screw turning a nut of lead ``p``.

    The motor angle is :math:`\theta = (2\pi/p)\,s` for a nut travel :math:`s`,
    so a motor torque :math:`\tau` gives the axial force :math:`(2\pi/p)\tau`
    and the rotating inertias appear on the actuator's rate as the mass

    .. math:: m_\text{reflected} = \left(\frac{2\pi}{p}\right)^2
              (J_\text{rotor} + J_\text{coupler} + J_\text{screw}).

    The screw-nut contact loses power: driven forward (the motor doing work
    on the load, :math:`F\dot s \ge 0` for the nut force :math:`F` the load
    needs) the screw needs :math:`\tau = Fp/(2\pi\eta)`; back-driven (the
    load doing work on the motor, :math:`F\dot s < 0`)
    :math:`\tau = \eta' F p/(2\pi)`.  The efficiencies only enter the motor
    torques of an inverse study (:func:`kanedyn.analysis.motor_torques`), not
    the equations of motion.

    Parameters
    ----------
    lead : float or sympy.Expr
        Nut travel per screw revolution ``p``, in m (positive).
    J_rotor, J_coupler, J_screw : float or sympy.Expr
        Moments of inertia about the screw axis, in kg m^2 (non-negative).
    efficiency, back_efficiency : float, optional
        :math:`\eta` (forward-driven) and :math:`\eta'` (back-driven), each in
        (0, 1]; 1 (a lossless screw) when not given.  A self-locking screw
        (:math:`\eta' \le 0`) is not modelled.
    """

    def __init__(self, lead, J_rotor, J_coupler, J_screw, efficiency=1.0,
                 back_efficiency=1.0):
        for name, value in (("efficiency", efficiency), ("back_efficiency", back_efficiency)):
            if (isinstance(value, bool) or not isinstance(value, (int, float))
                    or not 0.0 < value <= 1.0):
                raise ModelError(f"BallScrew {name} must be a number in (0, 1], "
                                 f"got {value!r}")
        self.efficiency, self.back_efficiency = float(efficiency), float(back_efficiency)
        for name, value in (("lead", lead), ("J_rotor", J_rotor), ("J_coupler", J_coupler),
                            ("J_screw", J_screw)):
            if isinstance(value, (int, float)):
                bad = value <= 0 if name == "lead" else value < 0
                if bad:
                    raise ModelError(f"BallScrew {name} must be "
                                     f"{'positive' if name == 'lead' else 'non-negative'}"
                                     f", got {value!r}")
            elif not isinstance(value, sm.Basic):
                raise ModelError(f"BallScrew {name} must be a number or a SymPy "
                                 f"expression, got {type(value).__name__}")
        self.lead, self.J_rotor, self.J_coupler, self.J_screw = (lead, J_rotor, J_coupler,
                                                                  J_screw)

    @property
    def ratio(self):
        """Motor angle per unit of nut travel, :math:`2\\pi/p`, in rad/m."""
        return 2 * sm.pi / self.lead

    @property
    def rotating_inertia(self):
        """:math:`J_\\text{rotor} + J_\\text{coupler} + J_\\text{screw}`, in kg m^2."""
        return self.J_rotor + self.J_coupler + self.J_screw

    @property
    def reflected_inertia(self):
        """The rotating inertia seen on the nut's travel, :math:`(2\\pi/p)^2 J`, in kg."""
        return self.ratio ** 2 * self.rotating_inertia

    def force_from_torque(self, torque):
        """Axial force (N) of a motor torque (N m)."""
        return self.ratio * torque

    def torque_from_force(self, force):
        """Motor torque (N m) giving an axial force (N)."""
        return force / self.ratio

    def __repr__(self):
        return (f"BallScrew(lead={self.lead}, J_rotor={self.J_rotor}, "
                f"J_coupler={self.J_coupler}, J_screw={self.J_screw}, "
                f"efficiency={self.efficiency}, back_efficiency={self.back_efficiency})")


class Actuator:
    """Base of actuators: a name, a rate and an optional transmission."""

    kind = "actuator"

    def __init__(self, name, transmission=None):
        self.name = _check_name(name, type(self).__name__)
        if transmission is not None and not isinstance(transmission, BallScrew):
            raise ModelError(f"actuator {name!r}: transmission must be a BallScrew, got "
                             f"{type(transmission).__name__}")
        self.transmission = transmission

    def _time_expression(self):
        raise NotImplementedError

    def rate(self, speeds, kindiffdict):
        """The actuator's rate as an expression linear in the speeds.

        Parameters
        ----------
        speeds : sequence of sympy.Function
            The generalized speeds ``u`` of the equations of motion.
        kindiffdict : dict
            ``{q': f(q, u)}`` (``eom.kindiffdict()``).

        Returns
        -------
        sympy.Expr
            In m/s (linear actuators) or rad/s (joint rotations).
        """
        expr = self._time_expression()
        if expr.atoms(sm.Derivative) or set(speeds) & me.find_dynamicsymbols(expr):
            rate = expr
        else:
            rate = expr.diff(_t)
        rate = rate.xreplace(kindiffdict)
        left = [s for s in rate.atoms(sm.Derivative)]
        if left:
            raise ModelError(f"actuator {self.name!r}: its rate contains {left}, which the "
                             "kinematic differential equations do not give in terms of "
                             "the speeds")
        return rate

    @property
    def reflected_inertia(self):
        """Mass (or inertia) of the transmission on the rate; 0 without one."""
        return 0 if self.transmission is None else self.transmission.reflected_inertia

    def inertia_element(self):
        r"""The transmission's drive-train inertia as an inertial element.

        A :class:`kanedyn.RateInertia` of the reflected inertia on the
        actuator's rate :math:`\dot s` (kinetic energy
        :math:`\tfrac12 m_\text{reflected}\dot s^2`), to pass in
        ``bodies=[...]`` of :func:`kanedyn.kane`; ``None`` without a
        transmission.

        Returns
        -------
        RateInertia or None
            Named ``"<actuator name>_drive"``.
        """
        if self.transmission is None:
            return None
        return _ActuatorRate(f"{self.name}_drive", [self._time_expression()],
                             self.transmission.reflected_inertia)


class _ActuatorRate(RateInertia):
    """A RateInertia on an actuator's rate.

    Its one expression is the actuator's: a speed expression (the rate
    itself) or a coordinate expression (the rate is its time derivative),
    told apart in the model's symbols when the equations are derived.
    """

    def _rates(self, kin):
        prog, table = kin.prog, kin.table
        expr = kin.scalar(self.rates[0], f"{self._where}: rate", f"s_{self.name}")
        if any(prog.diff(expr, s) != 0 for s in table.u + table.u_aux):
            return [expr]
        return [kin.dt(expr)]


class JointActuator(Actuator):
    """A force or torque acting along a joint coordinate or a relative joint rate.

    Parameters
    ----------
    name : str
    expression : sympy.Expr
        A coordinate expression (``q2 - q1``: the actuator's rate is its time
        derivative) or a speed expression (containing speeds: it *is* the rate).
    frame, reaction_frame : sympy.physics.mechanics.ReferenceFrame, optional
        For :meth:`to_loads` of a rotary actuator: the torque acts on ``frame``
        about ``axis`` and its reaction on ``reaction_frame``.
    point, reaction_point : sympy.physics.mechanics.Point, optional
        For :meth:`to_loads` of a linear joint: the force acts at ``point`` along
        ``axis`` and its reaction at ``reaction_point``.
    axis : sympy.physics.vector.Vector, optional
        Unit vector of the joint.
    transmission : BallScrew, optional
    """

    kind = "joint"

    def __init__(self, name, expression, frame=None, reaction_frame=None, point=None,
                 reaction_point=None, axis=None, transmission=None):
        super().__init__(name, transmission)
        if not isinstance(expression, sm.Basic):
            raise ModelError(f"JointActuator {name!r}: the expression must be a SymPy "
                             f"expression of coordinates or speeds, got "
                             f"{type(expression).__name__}")
        self.expression = expression
        self.frame, self.reaction_frame = frame, reaction_frame
        self.point, self.reaction_point, self.axis = point, reaction_point, axis

    def _time_expression(self):
        return self.expression

    def to_loads(self, magnitude):
        """Loads of a torque or force ``magnitude`` (a symbol or expression)."""
        if self.axis is None or (self.frame is None and self.point is None):
            raise ModelError(f"JointActuator {self.name!r}: to_loads needs axis= and "
                             "frame= (a torque) or point= (a force)")
        if self.frame is not None:
            loads = [(self.frame, magnitude * self.axis)]
            if self.reaction_frame is not None:
                loads.append((self.reaction_frame, -magnitude * self.axis))
        else:
            loads = [(self.point, magnitude * self.axis)]
            if self.reaction_point is not None:
                loads.append((self.reaction_point, -magnitude * self.axis))
        return loads

    def __repr__(self):
        return f"JointActuator({self.name!r}, {self.expression})"


class LinearActuator(Actuator):
    """A force along the line between two points; positive pushes them apart.

    Its rate is the rate of change of the distance between ``point_a`` and
    ``point_b`` (m/s): the extension rate of a prismatic leg.

    Parameters
    ----------
    name : str
    point_a, point_b : sympy.physics.mechanics.Point
    frame : sympy.physics.mechanics.ReferenceFrame
        The frame in which the distance is differentiated (any: a distance is
        the same in all frames; the inertial frame is customary).
    transmission : BallScrew, optional
    """

    kind = "linear"

    def __init__(self, name, point_a, point_b, frame, transmission=None):
        super().__init__(name, transmission)
        for label, p in (("point_a", point_a), ("point_b", point_b)):
            if not isinstance(p, me.Point):
                raise ModelError(f"LinearActuator {name!r}: {label} must be a Point, got "
                                 f"{type(p).__name__}")
        if not isinstance(frame, me.ReferenceFrame):
            raise ModelError(f"LinearActuator {name!r}: frame must be a ReferenceFrame")
        self.point_a, self.point_b, self.frame = point_a, point_b, frame

    def _time_expression(self):
        return self.length

    @property
    def length(self):
        """Distance between the points (m), a SymPy expression."""
        r = self.point_b.pos_from(self.point_a)
        return sm.sqrt(r.dot(r))

    def to_loads(self, magnitude):
        """Loads of an axial force ``magnitude`` (N), pushing the points apart."""
        r = self.point_b.pos_from(self.point_a)
        e = r / self.length
        return [(self.point_a, -magnitude * e), (self.point_b, magnitude * e)]

    def __repr__(self):
        return f"LinearActuator({self.name!r}, {self.point_a}, {self.point_b})"


class ExternalWrench:
    """A force at a body's mass centre and a moment on its frame.

    Parameters
    ----------
    body : sympy.physics.mechanics.RigidBody or Particle
    force : sympy.physics.vector.Vector, optional
        In N; zero when omitted.
    moment : sympy.physics.vector.Vector, optional
        In N m; a particle takes none.
    """

    def __init__(self, body, force=None, moment=None):
        if not hasattr(body, "masscenter"):
            raise ModelError(f"ExternalWrench needs a RigidBody or Particle, got "
                             f"{type(body).__name__}")
        if moment is not None and not hasattr(body, "frame"):
            raise ModelError(f"ExternalWrench on particle {body.name!r}: a particle "
                             "takes no moment")
        if force is None and moment is None:
            raise ModelError(f"ExternalWrench on {body.name!r}: give force= or moment=")
        self.body, self.force, self.moment = body, force, moment

    def to_loads(self):
        """``[(masscenter, force), (frame, moment)]`` (those given)."""
        loads = []
        if self.force is not None:
            loads.append((self.body.masscenter, self.force))
        if self.moment is not None:
            loads.append((self.body.frame, self.moment))
        return loads

    def __repr__(self):
        return f"ExternalWrench({self.body.name!r}, force={self.force}, moment={self.moment})"


def drive_inputs(actuators):
    """Actuators driven by specified inputs, for a forward model.

    Each actuator's force or torque becomes the dynamic symbol
    ``F_<name>(t)`` (N or N m) applied through :meth:`~JointActuator.to_loads`,
    and its transmission's drive train (:meth:`Actuator.inertia_element`)
    becomes an inertial element, so that the input is the force or torque
    on the actuator's rate with the reflected inertia included (what
    ``ActuatorMap.forces`` computes).

    Parameters
    ----------
    actuators : sequence of Actuator

    Returns
    -------
    inputs : list of sympy.Function
        ``F_<name>(t)``, one per actuator, in order.
    loads : list
        Their loads, for ``loads=[...]``.
    elements : list of RateInertia
        The drive trains, for ``bodies=[...]`` (none for an actuator without
        a transmission).
    """
    inputs, loads, elements = [], [], []
    for actuator in actuators:
        F = me.dynamicsymbols(f"F_{actuator.name}")
        inputs.append(F)
        loads += actuator.to_loads(F)
        element = actuator.inertia_element()
        if element is not None:
            elements.append(element)
    return inputs, loads, elements
