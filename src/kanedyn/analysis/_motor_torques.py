r"""Motor torques of ball-screw actuators from the nut forces of an inverse study.

A ball screw of lead :math:`p` turns its motor through :math:`\theta =
(2\pi/p)s` for a nut travel :math:`s`.  The motor drives its rotor, the coupler
and the screw (inertias :math:`J_r, J_c, J_s` about the screw axis) and, through
the screw-nut contact of efficiency :math:`\eta` (forward) or :math:`\eta'`
(back-driven), the nut force :math:`F` the rest of the machine needs:

.. math::

    \tau = \frac{p}{2\pi}\,\epsilon\,F + (J_r + J_c + J_s)\,\frac{2\pi}{p}\,\ddot s,
    \qquad \epsilon = \begin{cases} 1/\eta & F\dot s \ge 0
    \ \text{(forward: power flows from the motor to the load)}\\
    \eta' & F\dot s < 0\ \text{(back-driven: power flows from the load to the motor)}
    \end{cases}

(standstill, :math:`\dot s = 0`, counts as forward).  With :math:`\eta =
\eta' = 1` this is the actuator force of :class:`kanedyn.ActuatorMap` over
:math:`2\pi/p`.  :func:`motor_torques` keeps the terms apart: the nut force
by body group (each scaled by the same :math:`p\epsilon/2\pi`, so the parts sum
to the total) and the rotor's, coupler's and screw's inertia torques.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import KanedynError

__all__ = ["MotorTorques", "motor_torques", "DRIVE_PARTS"]

#: The drive-train parts of a motor torque, motor side of the screw-nut contact.
DRIVE_PARTS = ("rotor", "coupler", "screw")


@dataclass(frozen=True)
class MotorTorques:
    r"""Motor torques, speeds and powers of ball-screw actuators (arrays ``(k, N)``).

    Attributes
    ----------
    names : tuple of str
        The actuators, ``k`` of them.
    t : numpy.ndarray, shape (N,)
        Times, s.
    torque : numpy.ndarray
        Motor torque, N m.
    speed : numpy.ndarray
        Motor speed :math:`2\pi\dot s/p`, rad/s.
    power : numpy.ndarray
        Motor power ``torque * speed``, W.
    nut_force : numpy.ndarray
        Force the screw's nut exerts on the carriage along its rate, N.
    back_driven : numpy.ndarray of bool
        Where :math:`F\dot s < 0` (the back-driving efficiency applies).
    parts : dict
        ``{part: array}``: the nut force's body groups seen at the motor
        (``p\epsilon F_\text{group}/2\pi``), then ``"rotor"``, ``"coupler"``,
        ``"screw"`` (:math:`J\,2\pi\ddot s/p`); they sum to ``torque``.
    """

    names: tuple
    t: np.ndarray
    torque: np.ndarray
    speed: np.ndarray
    power: np.ndarray
    nut_force: np.ndarray
    back_driven: np.ndarray
    parts: dict

    def peak(self, quantity="torque"):
        """``{actuator: largest absolute value}`` of ``torque``, ``speed`` or ``power``."""
        values = getattr(self, quantity)
        return {n: float(np.max(np.abs(v))) for n, v in zip(self.names, values)}


def _screw_numbers(name, screw):
    numbers = {}
    for key in ("lead", "J_rotor", "J_coupler", "J_screw"):
        try:
            numbers[key] = float(getattr(screw, key))
        except TypeError:
            raise KanedynError(f"actuator {name!r}: the ball screw's {key} is symbolic "
                               f"({getattr(screw, key)}); motor torques need numbers") from None
    numbers["efficiency"] = float(screw.efficiency)
    numbers["back_efficiency"] = float(screw.back_efficiency)
    return numbers


def motor_torques(names, screws, t, nut_forces, rates, rate_derivatives):
    r"""Motor torques of ball-screw actuators along a trajectory.

    Parameters
    ----------
    names : sequence of str
        Actuator names, ``k`` of them.
    screws : sequence of BallScrew
        Each actuator's screw (numeric lead, inertias and efficiencies).
    t : array_like, shape (N,)
        Times, s.
    nut_forces : dict
        ``{part: array (k, N)}``: the force along each actuator's rate the
        machine needs from the nut, N, by body group (the inverse study's
        groups without the drive train).
    rates, rate_derivatives : array_like, shape (k, N)
        Nut speed :math:`\dot s` (m/s) and acceleration :math:`\ddot s` (m/s²).

    Returns
    -------
    MotorTorques

    Raises
    ------
    KanedynError
        When a screw is missing or symbolic, or the shapes disagree.
    """
    names = tuple(names)
    k = len(names)
    t = np.asarray(t, float)
    rates = np.asarray(rates, float)
    accels = np.asarray(rate_derivatives, float)
    if len(screws) != k or any(s is None for s in screws):
        raise KanedynError("motor_torques needs a ball screw for each actuator "
                           f"({', '.join(names)})")
    for label, arr in (("rates", rates), ("rate_derivatives", accels),
                       *((f"nut force {g!r}", np.asarray(v)) for g, v in nut_forces.items())):
        if arr.shape != (k, t.size):
            raise KanedynError(f"motor_torques: {label} has shape {arr.shape}, expected "
                               f"({k}, {t.size})")
    numbers = [_screw_numbers(n, s) for n, s in zip(names, screws)]
    lead = np.array([s["lead"] for s in numbers])[:, None]
    eta = np.array([s["efficiency"] for s in numbers])[:, None]
    eta_back = np.array([s["back_efficiency"] for s in numbers])[:, None]
    groups = {g: np.asarray(v, float) for g, v in nut_forces.items()}
    force = sum(groups.values(), np.zeros((k, t.size)))
    back = force * rates < 0
    scale = lead / (2 * np.pi) * np.where(back, eta_back, 1.0 / eta)
    parts = {g: scale * v for g, v in groups.items()}
    ratio = 2 * np.pi / lead
    for part, key in zip(DRIVE_PARTS, ("J_rotor", "J_coupler", "J_screw")):
        inertia = np.array([s[key] for s in numbers])[:, None]
        parts[part] = inertia * ratio * accels
    torque = sum(parts.values(), np.zeros((k, t.size)))
    speed = ratio * rates
    return MotorTorques(names=names, t=t, torque=torque, speed=speed, power=torque * speed,
                        nut_force=force, back_driven=back, parts=parts)
