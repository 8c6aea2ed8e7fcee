r"""A variable-speed, collective-pitch wind turbine controller as first-order states.

The baseline controller of the NREL 5-MW turbine (Jonkman et al. 2009,
NREL/TP-500-38060, sec. 7), written in continuous time with three states
that join the model's coordinates (so compiled code integrates them with the
structure):

* the filtered generator speed :math:`\hat\omega` (one-pole low-pass of corner
  :math:`\omega_c`): :math:`\dot{\hat\omega} = \omega_c(\omega_g - \hat\omega)`;
* the integral of the speed error :math:`e_I`, :math:`\dot e_I = \hat\omega -
  \omega_{ref}`, held while the pitch command it feeds sits at its lower or
  upper limit and the error would push it further (anti-windup, as the
  published controller saturates it);
* the blade pitch :math:`\theta` of a first-order actuator with a rate limit:
  :math:`\dot\theta = \mathrm{sat}_{\pm r}((\theta_c - \theta)/\tau)`.

The pitch command is the gain-scheduled PI law
:math:`\theta_c = \mathrm{sat}_{[\theta_{min}, \theta_{max}]}(G_K(K_P e +
K_I e_I))`, :math:`e = \hat\omega - \omega_{ref}`, :math:`G_K = 1/(1 +
\theta/\theta_K)` (the published controller schedules on its last command;
here on the pitch).  The generator torque follows the filtered speed through
regions 1 (none below cut-in), 1½ (a ramp), 2 (:math:`k\hat\omega^2`), 2½ (a
straight line to rated torque at :math:`\omega_{2½}`, the slip line through
the synchronous speed :math:`\omega_{2½}/(1 + s)`) and 3 (rated: constant
power :math:`P/\hat\omega`, or, as OC3 changed it for the floating turbine,
constant torque :math:`P/\omega_{ref}`), region 3 also whenever the pitch is
at least :math:`\theta_3`; limited to :math:`T_{max}`.  The published
torque-rate limit (15 kN m/s) is not modelled.

Region switches and saturations are SymPy ``Piecewise``, ``Min`` and ``Max``,
which the C backend compiles.
"""

from dataclasses import dataclass

import sympy as sm
import sympy.physics.mechanics as me

from ..._errors import ModelError

__all__ = ["BaselineController"]

_t = me.dynamicsymbols._t


def _sat(x, lo, hi):
    return sm.Min(sm.Max(x, lo), hi)


@dataclass(frozen=True)
class BaselineController:
    r"""Gains and limits of a variable-speed, collective-pitch controller (SI units).

    Attributes
    ----------
    cut_in_speed, region2_start_speed, region25_speed, reference_speed : float
        Generator speeds, rad/s: torque starts (region 1½); region 2 starts;
        rated torque is reached (end of 2½; region 3 above); the pitch
        controller's set point :math:`\omega_{ref}`.
    region2_gain : float
        :math:`k`, N m/(rad/s)^2.
    slip : float
        Slip of the region-2½ line, fraction (0.1 for 10 %).
    rated_power : float
        W (mechanical).
    constant_torque : bool
        Region 3: constant torque :math:`P/\omega_{ref}` (True) or constant
        power :math:`P/\hat\omega` (False).
    max_torque : float
        N m.
    region3_pitch : float
        Pitch from which the torque law is in region 3, rad.
    filter_corner : float
        :math:`\omega_c`, rad/s.
    kp, ki : float
        Pitch PI gains at zero pitch: s and dimensionless (rad per rad/s of
        generator speed error, and per rad).
    gain_doubling_pitch : float
        :math:`\theta_K`, rad.
    min_pitch, max_pitch, max_pitch_rate : float
        rad, rad, rad/s.
    actuator_time_constant : float
        :math:`\tau` of the pitch actuator, s.
    """

    cut_in_speed: float
    region2_start_speed: float
    region25_speed: float
    reference_speed: float
    region2_gain: float
    slip: float
    rated_power: float
    constant_torque: bool
    max_torque: float
    region3_pitch: float
    filter_corner: float
    kp: float
    ki: float
    gain_doubling_pitch: float
    min_pitch: float
    max_pitch: float
    max_pitch_rate: float
    actuator_time_constant: float

    def __post_init__(self):
        for key, value in self.__dict__.items():
            if key == "constant_torque":
                continue
            if not isinstance(value, (int, float)) or isinstance(value, bool) \
                    or (value < 0 if key == "min_pitch" else value <= 0):
                raise ModelError(f"BaselineController: {key} must be a positive number, "
                                 f"got {value!r}")
        if not (self.cut_in_speed < self.region2_start_speed < self.region25_speed
                <= self.reference_speed):
            raise ModelError("BaselineController: the generator speeds must increase: "
                             "cut_in < region2_start < region25 <= reference")

    @property
    def rated_torque(self):
        """Generator torque at the end of region 2½, N m."""
        speed = self.reference_speed if self.constant_torque else self.region25_speed
        return self.rated_power / speed

    @property
    def synchronous_speed(self):
        """Where the region-2½ line crosses zero torque, rad/s."""
        return self.region25_speed / (1 + self.slip)

    def states(self):
        """``[filtered generator speed (rad/s), speed-error integral (rad), pitch (rad)]``."""
        return list(me.dynamicsymbols("gen_speed_filtered speed_error_integral blade_pitch"))

    def gain_correction(self, pitch):
        r""":math:`G_K = 1/(1 + \theta/\theta_K)`."""
        return 1 / (1 + pitch / self.gain_doubling_pitch)

    def pitch_command(self, states):
        r""":math:`\theta_c` (rad) of the states."""
        filtered, integral, pitch = states
        gk = self.gain_correction(pitch)
        error = filtered - self.reference_speed
        held = _sat(integral, self.min_pitch / (gk * self.ki), self.max_pitch / (gk * self.ki))
        return _sat(gk * (self.kp * error + self.ki * held), self.min_pitch, self.max_pitch)

    def generator_torque(self, states):
        r""":math:`T_g` (N m, high-speed shaft) of the filtered speed and the pitch."""
        w, _, pitch = states
        rated = self.rated_power / w if not self.constant_torque else self.rated_torque
        k = self.region2_gain
        slope15 = k * self.region2_start_speed ** 2 / (self.region2_start_speed
                                                       - self.cut_in_speed)
        sync = self.synchronous_speed
        slope25 = self.rated_torque / (self.region25_speed - sync)
        # where the region-2 parabola meets the region-2 1/2 line (the lower root)
        transition = (slope25 - (slope25 * (slope25 - 4 * k * sync)) ** 0.5) / (2 * k)
        torque = sm.Piecewise((rated, w >= self.region25_speed),
                              (rated, pitch >= self.region3_pitch),
                              (0, w <= self.cut_in_speed),
                              (slope15 * (w - self.cut_in_speed), w < self.region2_start_speed),
                              (k * w ** 2, w < transition),
                              (slope25 * (w - sync), True))
        return sm.Min(torque, self.max_torque)

    def kinematic_equations(self, states, generator_speed):
        r"""The states' equations :math:`\dot x - f(x, \omega_g) = 0`.

        Parameters
        ----------
        states : list
            From :meth:`states`.
        generator_speed : sympy.Expr
            :math:`\omega_g`, rad/s, of the model's speeds.
        """
        filtered, integral, pitch = states
        gk = self.gain_correction(pitch)
        error = filtered - self.reference_speed
        # anti-windup: the integral stops at the limits of the pitch it commands
        rate = sm.Piecewise((sm.Max(error, 0), gk * self.ki * integral <= self.min_pitch),
                            (sm.Min(error, 0), gk * self.ki * integral >= self.max_pitch),
                            (error, True))
        actuator = _sat((self.pitch_command(states) - pitch) / self.actuator_time_constant,
                        -self.max_pitch_rate, self.max_pitch_rate)
        return [filtered.diff(_t) - self.filter_corner * (generator_speed - filtered),
                integral.diff(_t) - rate,
                pitch.diff(_t) - actuator]

    def steady_integral(self, pitch):
        """The speed-error integral (rad) that holds ``pitch`` (rad) at zero error."""
        return pitch / (self.gain_correction(pitch) * self.ki)
