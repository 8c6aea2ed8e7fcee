r"""A rotor spinning on a tilted shaft in the nacelle, and its generator behind a gearbox.

The shaft frame ``S`` is the nacelle frame turned about its lateral axis by
the tilt, so :math:`S_x = \cos\gamma\,A_x - \sin\gamma\,A_z` points downwind
and down (the hub upwind and higher).  The rotor turns about :math:`S_x` by
its azimuth :math:`\psi` at the speed :math:`\Omega` (relative to the nacelle);
the generator turns :math:`N_g` times as fast.  With a rigid low-speed shaft
the generator's angle is :math:`N_g\psi`; with a flexible one it is
:math:`N_g(\psi - \delta)`, :math:`\delta` the shaft's twist, loaded by
:math:`M = k\delta + c\dot\delta` (rotor side :math:`-M`, generator side
:math:`+M/N_g`, the gearbox reaction :math:`M(1 - 1/N_g)` on the nacelle).
The generator torque :math:`T_g` (high-speed shaft) brakes the generator and
turns the nacelle (its stator) the other way.

The rotating parts carry only their inertia about the shaft (the rotor's
and the generator's polar moments): for an axisymmetric rotor the rest of its
inertia and its mass do not change as it turns and stay with the nacelle's.
"""

import sympy as sm
import sympy.physics.mechanics as me

from ..._errors import ModelError

__all__ = ["Drivetrain"]

_t = me.dynamicsymbols._t


class Drivetrain:
    r"""The rotor azimuth degree of freedom, the generator, and optionally the shaft's twist.

    Parameters
    ----------
    nacelle : sympy.physics.mechanics.ReferenceFrame
        The frame the shaft bearings are fixed in (``A``).
    hub : sympy.physics.mechanics.Point
        The hub centre on the shaft axis.
    tilt : float
        Shaft tilt :math:`\gamma`, rad.
    rotor_inertia : float
        The rotor's (hub and blades) moment of inertia about the shaft, kg m^2.
    generator_inertia : float
        The generator's about the high-speed shaft, kg m^2.
    gear_ratio : float
        :math:`N_g`, high-speed to low-speed shaft.
    generator_torque : sympy.Expr
        :math:`T_g`, N m on the high-speed shaft (an expression of the states
        or a specified input).
    stiffness, damping : float, optional
        The low-speed shaft's torsional stiffness (N m/rad) and damping
        (N m s/rad); given both, the shaft's twist is a degree of freedom.

    Attributes
    ----------
    q, u : list
        ``azimuth`` (rad) [and ``shaft_twist``, rad]; ``rotor_speed`` (rad/s)
        [and ``shaft_twist_rate``].
    kd_eqs : list
    shaft_frame, rotor_frame, generator_frame : ReferenceFrame
    shaft : Vector
        :math:`S_x`.
    generator_speed : sympy.Expr
        The generator's speed relative to the nacelle, rad/s (high-speed shaft).
    loads : list
        The generator's torque and its reaction on the nacelle; with a flexible
        shaft, the shaft spring's three torques, then its damper's.
    potential_energy : sympy.Expr
        The shaft spring's :math:`\tfrac12 k\,\text{twist}^2`, J (0 when rigid).
    potential_loads : tuple of int
        The indices in ``loads`` of the spring's torques, whose work
        ``potential_energy`` holds.
    """

    def __init__(self, nacelle, hub, tilt, rotor_inertia, generator_inertia, gear_ratio,
                 generator_torque, stiffness=None, damping=None):
        for key, value in (("rotor_inertia", rotor_inertia),
                           ("generator_inertia", generator_inertia),
                           ("gear_ratio", gear_ratio)):
            if not (isinstance(value, (int, float)) and value > 0):
                raise ModelError(f"Drivetrain: {key} must be a positive number, got {value!r}")
        if (stiffness is None) != (damping is None):
            raise ModelError("Drivetrain: a flexible shaft needs both stiffness and damping")
        self.nacelle, self.hub, self.gear_ratio = nacelle, hub, gear_ratio
        S = me.ReferenceFrame("S")
        S.orient_axis(nacelle, nacelle.y, tilt)
        S.set_ang_vel(nacelle, 0)
        self.shaft_frame, self.shaft = S, S.x
        azimuth, speed = me.dynamicsymbols("azimuth rotor_speed")
        self.q, self.u = [azimuth], [speed]
        self.kd_eqs = [azimuth.diff(_t) - speed]
        gen_angle, gen_rate = azimuth, speed
        self.flexible = stiffness is not None
        if self.flexible:
            twist, twist_rate = me.dynamicsymbols("shaft_twist shaft_twist_rate")
            self.q.append(twist)
            self.u.append(twist_rate)
            self.kd_eqs.append(twist.diff(_t) - twist_rate)
            gen_angle, gen_rate = azimuth - twist, speed - twist_rate
        R = me.ReferenceFrame("R")
        R.orient_axis(S, S.x, azimuth)
        R.set_ang_vel(S, speed * S.x)
        G = me.ReferenceFrame("G")
        G.orient_axis(S, S.x, gear_ratio * gen_angle)
        G.set_ang_vel(S, gear_ratio * gen_rate * S.x)
        self.rotor_frame, self.generator_frame = R, G
        self.rotor_speed = speed
        self.generator_speed = gear_ratio * gen_rate
        self.bodies = [me.RigidBody("rotor", hub, R, 0, (me.inertia(R, rotor_inertia, 0, 0),
                                                          hub)),
                       me.RigidBody("generator", hub, G, 0,
                                    (me.inertia(G, generator_inertia, 0, 0), hub))]
        self.loads = [(G, -generator_torque * S.x), (nacelle, generator_torque * S.x)]
        self.potential_energy = sm.S.Zero
        self.potential_loads = ()
        if self.flexible:
            # the shaft's spring (its work held by the potential energy), then its damper
            for moment in (stiffness * twist, damping * twist_rate):
                self.loads += [(R, -moment * S.x), (G, moment / gear_ratio * S.x),
                               (nacelle, moment * (1 - 1 / sm.Float(gear_ratio)) * S.x)]
            self.potential_energy = stiffness * twist ** 2 / 2
            self.potential_loads = (2, 3, 4)

    def __repr__(self):
        return (f"Drivetrain(gear_ratio={self.gear_ratio}, "
                f"{'flexible' if self.flexible else 'rigid'} shaft)")
