r"""The OC3 turbine's spinning rotor, drivetrain and baseline controller (``rotor="spinning"``).

Parts of the ``oc3-spar`` builder:

* :func:`spinning_rotor`: the rotor azimuth (and, with a flexible drivetrain,
  the low-speed shaft's twist) as degrees of freedom
  (:class:`~kanedyn.offshore.Drivetrain` with the published inertias, gearbox
  and shaft, :data:`DRIVETRAIN`), the quasi-steady rotor thrust and torque of
  the NREL 5-MW performance table (:class:`~kanedyn.offshore.RotorAerodynamics`)
  and the generator torque and blade pitch of the baseline controller with the
  OC3 gains (:class:`~kanedyn.offshore.BaselineController`, three
  first-order states) or, with ``controller="off"``, held at their steady
  values for the mean wind (specified inputs, replaceable);
* :func:`oc3_operating_point`: the steady operating point of that rotor,
  drivetrain and controller on a fixed hub in a steady wind;
* with ``aero="bem"`` the rotor's loads come instead from blade-element
  momentum theory on the NREL 5-MW blade
  (:class:`~kanedyn.offshore.BladeElementRotor` of
  :func:`~kanedyn.models._nrel5mw_blade.nrel5mw_bem`): the force and moment
  of the annuli solved, at every state, at the relative wind each blade
  element sees (rotor speed, azimuth, the hub's velocity and the nacelle's
  rotation);
* with ``blades="flexible"`` the blades are flexible bodies
  (:mod:`kanedyn.models._oc3_blades`): the drivetrain's rotor is then the hub
  alone, the pitch turns the blades at their roots, and the aerodynamic loads
  act on the blades' nodes (:class:`~kanedyn.offshore.FlexibleBladeElementRotor`
  with ``aero="bem"``);
* :func:`rna_inertia_pieces`: the RNA's inertia less the spinning parts'.

Precone (2.5 deg) is not modelled: the blades sit in the plane normal to the
shaft (with rigid blades the published rotor inertia, which includes it, is
used).
The pitch actuator is first order with :data:`PITCH_ACTUATOR_TIME_CONSTANT`
(not published: the published controller commands the pitch directly, rate
limited) and the 8 deg/s rate limit.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..modeling import (BaselineController, BladeElementRotor, Drivetrain,
                        FlexibleBladeElementRotor, PerformanceSurface, RotorAerodynamics)
from ._oc3_blades import blade_annulus_nodes, blade_thrust_loads, flexible_blades
from ._nrel5mw_blade import nrel5mw_bem
from ._nrel5mw_performance import (PITCH_DEGREES, POWER_COEFFICIENT, THRUST_COEFFICIENT,
                                   TIP_SPEED_RATIOS)
from ._oc3_data import CONTROLLER, DRIVETRAIN, ENVIRONMENT, ROTOR, rna_inertia_about_cm

__all__ = ["spinning_rotor", "oc3_operating_point", "OperatingPoint", "oc3_controller",
           "oc3_performance_surface", "rna_inertia_pieces", "PITCH_ACTUATOR_TIME_CONSTANT",
           "AERO_MODELS"]

#: the ``aero`` option's choices: the performance table's fit, blade-element momentum
AERO_MODELS = ("thrust", "bem")

#: s, time constant of the first-order pitch actuator (our choice: fast against the
#: pitch controller's 0.2 rad/s, slow enough for explicit integrators)
PITCH_ACTUATOR_TIME_CONSTANT = 0.1


def _v(group, key):
    return group[key].value


@functools.lru_cache(maxsize=1)
def oc3_performance_surface():
    """The NREL 5-MW rotor's :class:`~kanedyn.offshore.PerformanceSurface` (degree-8 fit)."""
    return PerformanceSurface(TIP_SPEED_RATIOS, PITCH_DEGREES, POWER_COEFFICIENT,
                              THRUST_COEFFICIENT, degree=10)


def oc3_controller():
    """The baseline controller with the OC3 gains and region-3 constant torque."""
    c = {key: figure.value for key, figure in CONTROLLER.items()}
    return BaselineController(constant_torque=True,
                              actuator_time_constant=PITCH_ACTUATOR_TIME_CONSTANT, **c)


def _radius():
    return _v(ROTOR, "diameter") / 2


def rna_inertia_pieces(rest=None):
    r"""The RNA's inertia about its centre of mass without the spinning parts, kg m^2.

    The published RNA inertia less the rotor's about the tilted shaft,
    :math:`I_{RNA} - I_{rotor}\,s s^T` (``A`` components).  That remainder is
    positive definite but its principal moments (3.06e6, 22.1e6, 25.9e6)
    miss the triangle inequality of a solid's: the published RNA inertia and
    the published rotor inertia do not quite belong to one solid.  It is
    returned as two matrices that a body can each carry: the remainder
    without its smallest principal part, and that part.

    Parameters
    ----------
    rest : ndarray, shape (3, 3), optional
        Another remainder to split so (the RNA less flexible blades and the
        hub, :func:`~kanedyn.models._oc3_blades.rna_without_blades`).

    Returns
    -------
    (ndarray, ndarray)
        Shape (3, 3) each; their sum is the remainder.
    """
    if rest is None:
        tilt = math.radians(_v(ROTOR, "shaft_tilt"))
        s = np.array([math.cos(tilt), 0.0, -math.sin(tilt)])
        rest = rna_inertia_about_cm() - _v(DRIVETRAIN, "rotor_inertia") * np.outer(s, s)
    w, V = np.linalg.eigh(rest)
    axial = w[0] * np.outer(V[:, 0], V[:, 0])
    return rest - axial, axial


@dataclass(frozen=True)
class OperatingPoint:
    """A steady operating point of the rotor, drivetrain and controller in a steady wind.

    Attributes
    ----------
    wind_speed : float
        m/s.
    rotor_speed : float
        rad/s.
    pitch : float
        rad.
    generator_torque : float
        N m (high-speed shaft).
    aerodynamic_power : float
        W (rotor torque times rotor speed).
    electrical_power : float
        W (generator torque times speed times the efficiency).
    thrust : float
        N.
    """

    wind_speed: float
    rotor_speed: float
    pitch: float
    generator_torque: float
    aerodynamic_power: float
    electrical_power: float
    thrust: float

    @property
    def rotor_rpm(self):
        """Rotor speed, rpm."""
        return self.rotor_speed * 30 / math.pi


def _torque_law(controller):
    w, e, p = sm.symbols("w e p")
    return sm.lambdify((w, p), controller.generator_torque([w, e, p]), "math")


def _aerodynamics(aero, wind_speed):
    """``(thrust(speed, pitch), torque(speed, pitch))`` of the rotor on a still hub, N, N m."""
    R, rho = _radius(), _v(ROTOR, "air_density")
    if aero == "bem":
        # the wind along the tilted shaft (the in-plane part's effect is second order)
        axial = wind_speed * math.cos(math.radians(_v(ROTOR, "shaft_tilt")))
        bem = nrel5mw_bem()
        return (lambda speed, pitch: float(bem.steady_loads(axial, speed, pitch)[0]),
                lambda speed, pitch: float(bem.steady_loads(axial, speed, pitch)[1]))
    surface = oc3_performance_surface()
    q = 0.5 * rho * math.pi * R ** 2 * wind_speed ** 2
    return (lambda speed, pitch: q * float(surface.coefficients(speed * R / wind_speed,
                                                                pitch)[1]),
            lambda speed, pitch: q * R * float(surface.torque_coefficient(
                speed * R / wind_speed, pitch)))


def oc3_operating_point(wind_speed, aero="thrust"):
    r"""The steady operating point of the OC3 rotor, drivetrain and controller at a wind speed.

    With the hub held still: below rated the pitch is at its minimum and the
    rotor speed balances the aerodynamic torque against :math:`N_g T_g` of the
    torque law; once the generator would exceed the set point the speed is the
    set point and the pitch balances the torques (SciPy's ``brentq``).

    Parameters
    ----------
    wind_speed : float
        m/s, from 3 to 25 (cut-in to cut-out).
    aero : {"thrust", "bem"}
        The rotor's aerodynamics: the performance table's fit, or
        blade-element momentum theory with the wind's component along the
        tilted shaft (as the ``oc3-spar`` option ``aero``).

    Returns
    -------
    OperatingPoint
    """
    from scipy.optimize import brentq
    if not (isinstance(wind_speed, (int, float)) and 3 <= wind_speed <= 25):
        raise ModelError(f"oc3_operating_point: wind_speed must be from 3 to 25 m/s, got "
                         f"{wind_speed!r}")
    if aero not in AERO_MODELS:
        raise ModelError(f"oc3_operating_point: aero must be one of {', '.join(AERO_MODELS)}, "
                         f"got {aero!r}")
    controller = oc3_controller()
    ratio = _v(DRIVETRAIN, "gear_ratio")
    law = _torque_law(controller)
    aero_thrust, aero_torque = _aerodynamics(aero, wind_speed)

    def balance(speed, pitch=0.0):
        return aero_torque(speed, pitch) - ratio * law(ratio * speed, pitch)

    top = controller.reference_speed / ratio
    pitch = controller.min_pitch
    lo = 0.5 * controller.cut_in_speed / ratio
    if balance(top) > 0:    # the torque law cannot hold the rotor below the set point
        speed = top
        pitch = brentq(lambda p: balance(top, p), controller.min_pitch, math.radians(30),
                       xtol=1e-12)
    else:
        speed = brentq(balance, lo, top, xtol=1e-12)
    torque = law(ratio * speed, pitch)
    return OperatingPoint(wind_speed, speed, pitch, torque, aero_torque(speed, pitch) * speed,
                          _v(DRIVETRAIN, "generator_efficiency") * torque * ratio * speed,
                          aero_thrust(speed, pitch))


def spinning_rotor(A, hub, N, wind, options, wind_symbol=None, wind_series=None, origin=None):
    r"""The spinning rotor part of the ``oc3-spar`` builder.

    Parameters
    ----------
    A : ReferenceFrame
        The nacelle frame.
    hub : Point
        The hub centre, its velocity in ``N`` known in the speeds.
    N : ReferenceFrame
    wind : float
        Mean wind speed, m/s (0: no aerodynamic loads).
    options : dict
        The builder's options (``controller``, ``drivetrain``, ``aero``,
        ``blades``).
    wind_symbol : sympy.Function, optional
        The specified input of a turbulent wind (otherwise the mean wind).
    wind_series : callable, optional
        The turbulent wind as a function of time (m/s), for ``aero="bem"``.
    origin : Point, optional
        A point fixed in ``N``: the flexible blades' gravitational energy is
        taken from it (needed with ``blades="flexible"``).

    Returns
    -------
    dict
        ``q``, ``u``, ``kd_eqs``, ``bodies``, ``loads``, ``load_names``
        (``{index: energy-balance term}``), ``held`` (the indices of the loads
        whose work ``potential`` holds), ``potential`` (SymPy), ``specified``
        (``{symbol: value}``; with ``aero="bem"`` the rotor's inputs are not
        among them: they need the model's whole state,
        ``symbols["aerodynamics"].specified(states)``), ``initial``
        (``{symbol: value}``), ``units`` (of the states), ``symbols``
        (``drivetrain``, ``controller``, ``aerodynamics``, ``generator_torque``,
        ``pitch``, ``electrical_power``, all SymPy in the states; with flexible
        blades ``blades``, the three FlexibleBody).
    """
    controlled = options["controller"] == "on"
    bem = options["aero"] == "bem"
    flexible_blades_on = options.get("blades", "rigid") == "flexible"
    controller = oc3_controller()
    point = oc3_operating_point(wind, options["aero"]) if wind > 0 else None
    states = controller.states() if controlled else []
    pitch_rate = 0
    if controlled:
        torque, pitch = controller.generator_torque(states), states[2]
        specified = {}
    else:
        torque, pitch = me.dynamicsymbols("T_generator pitch_input")
        specified = {torque: point.generator_torque if point else 0.0}
        if flexible_blades_on or (point and bem):
            # the blades' orientation and the BEM's loads take the held pitch
            pitch = point.pitch if point else 0.0
        elif point:     # without wind nothing depends on the pitch
            specified[pitch] = point.pitch
    flexible = options["drivetrain"] == "flexible"
    # flexible blades carry their own inertia: the drivetrain's rotor is the hub
    rotor_inertia = _v(DRIVETRAIN, "hub_inertia" if flexible_blades_on else "rotor_inertia")
    drive = Drivetrain(A, hub, math.radians(_v(ROTOR, "shaft_tilt")),
                       rotor_inertia, _v(DRIVETRAIN, "generator_inertia"),
                       _v(DRIVETRAIN, "gear_ratio"), torque,
                       stiffness=_v(DRIVETRAIN, "shaft_stiffness") if flexible else None,
                       damping=_v(DRIVETRAIN, "shaft_damping") if flexible else None)
    q, u, kd_eqs = list(drive.q), list(drive.u), list(drive.kd_eqs)
    loads, bodies, potential, units = list(drive.loads), list(drive.bodies), [], {}
    # load index -> energy-balance term (the blades' node loads one per blade)
    names = {0: "generator torque", 1: "generator torque's reaction on the nacelle"}
    if flexible:     # the shaft's spring torques (2-4) are held by its potential
        names.update(dict.fromkeys((5, 6, 7), "low-speed shaft damping"))
    if controlled:
        q += states
        kd_eqs += controller.kinematic_equations(states, drive.generator_speed)
        pitch_rate = states[2].diff(me.dynamicsymbols._t) - kd_eqs[-1]
    blades = None
    if flexible_blades_on:
        blades = flexible_blades(drive, hub, N, origin, pitch, pitch_rate,
                                 _v(ENVIRONMENT, "gravity"))
        q, u, kd_eqs = q + blades["q"], u + blades["u"], kd_eqs + blades["kd_eqs"]
        bodies += blades["bodies"]
        potential.append(blades["potential"])
        units.update(blades["units"])
    aero = None
    if wind > 0 and bem and blades:
        bem_rotor = nrel5mw_bem()
        aero = FlexibleBladeElementRotor(
            "rotor", bem_rotor, blades["bodies"],
            blade_annulus_nodes(blades["bodies"][0].member, bem_rotor), hub,
            drive.shaft_frame, blades["radial"], N, pitch,
            wind_series if wind_series is not None else wind)
        loads += aero.to_loads()
        names.update(_blade_load_names(len(loads), aero.to_loads()))
    elif wind > 0 and bem:
        aero = BladeElementRotor("rotor", nrel5mw_bem(), hub, drive.shaft_frame,
                                 drive.rotor_frame, N, drive.q[0], drive.rotor_speed, pitch,
                                 wind_series if wind_series is not None else wind)
        loads += aero.to_loads()
    elif wind > 0 and blades:
        blade_loads, thrusts, torques = blade_thrust_loads(
            blades["bodies"], blades["radial"], drive.shaft, N, oc3_performance_surface(),
            drive.rotor_speed, pitch, wind_symbol if wind_symbol is not None else wind)
        names.update(_blade_load_names(len(loads) + len(blade_loads), blade_loads))
        loads += blade_loads
        aero = BladeThrust(thrusts, torques)
    elif wind > 0:
        aero = RotorAerodynamics("rotor", oc3_performance_surface(), _radius(),
                                 _v(ROTOR, "air_density"), hub, drive.shaft, N,
                                 drive.rotor_frame, drive.rotor_speed, pitch,
                                 wind_symbol if wind_symbol is not None else wind)
        loads += aero.to_loads()
    speed = point.rotor_speed if point else 0.0
    initial = {drive.u[0]: speed}
    if flexible and point:   # the twist that carries the steady torque
        initial[drive.q[1]] = (_v(DRIVETRAIN, "gear_ratio") * point.generator_torque
                               / _v(DRIVETRAIN, "shaft_stiffness"))
    if controlled:
        p0 = point.pitch if point else 0.0
        initial.update({states[0]: _v(DRIVETRAIN, "gear_ratio") * speed, states[1]:
                        controller.steady_integral(p0), states[2]: p0})
    power = _v(DRIVETRAIN, "generator_efficiency") * torque * drive.generator_speed
    units.update({**dict.fromkeys(drive.q, "rad"), **dict.fromkeys(drive.u, "rad/s")})
    if controlled:
        units.update({states[0]: "rad/s", states[1]: "rad", states[2]: "rad"})
    return dict(q=q, u=u, kd_eqs=kd_eqs, bodies=bodies, loads=loads, load_names=names,
                held=drive.potential_loads,
                potential=sm.Add(drive.potential_energy, *potential), specified=specified,
                initial=initial, units=units,
                symbols=dict(drivetrain=drive, controller=controller if controlled else None,
                             aerodynamics=aero, generator_torque=torque, pitch=pitch,
                             electrical_power=power,
                             blades=blades["bodies"] if blades else None))


def _blade_load_names(end, blade_loads):
    """``{index: "aerodynamic forces on <blade>"}`` of the last ``len(blade_loads)`` of
    ``end`` loads (each acting at a node point named ``<blade>_node<k>``)."""
    start = end - len(blade_loads)
    return {start + i: "aerodynamic forces on " + point.name.rpartition("_node")[0]
            for i, (point, _) in enumerate(blade_loads)}


@dataclass(frozen=True)
class BladeThrust:
    """The performance table's loads on flexible blades: each blade's thrust and torque.

    Attributes
    ----------
    thrusts, torques : list of sympy.Expr
        Per blade, N and N m (a third of the rotor's at the blade's relative wind).
    """

    thrusts: list
    torques: list

    @property
    def thrust(self):
        """The rotor's thrust, N."""
        return sm.Add(*self.thrusts)

    @property
    def torque(self):
        """The rotor's aerodynamic torque, N m."""
        return sm.Add(*self.torques)
