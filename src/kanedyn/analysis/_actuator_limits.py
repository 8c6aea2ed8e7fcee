"""Actuator limits checked along an inverse study's path; the first violation named.

Quantities (absolute values compared with positive limits): ``force`` (the
actuator force, N or N m), ``speed`` (its rate, m/s or rad/s), ``torque``
(the motor torque of a ball-screw drive, N m) and ``motor_speed`` (rad/s).
The first violation is the earliest time at which any quantity of any
actuator exceeds its limit (ties: the lowest actuator number, then the order
above).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._errors import KanedynError

__all__ = ["LIMIT_QUANTITIES", "LimitViolation", "LimitCheck", "check_actuator_limits"]

#: The quantities a limit may be set on, in the order ties are broken.
LIMIT_QUANTITIES = ("force", "speed", "torque", "motor_speed")


@dataclass(frozen=True)
class LimitViolation:
    """Where a quantity first exceeds its limit.

    Attributes
    ----------
    time : float
        s.
    point : int
        Index of the trajectory point.
    actuator : str
        Its name; ``number`` is its 1-based position among the actuators.
    number : int
    quantity : str
        One of :data:`LIMIT_QUANTITIES`.
    value, limit : float
        The value there (signed) and the limit on its absolute value, in ``unit``.
    unit : str
    """

    time: float
    point: int
    actuator: str
    number: int
    quantity: str
    value: float
    limit: float
    unit: str

    def describe(self):
        """One line: time, actuator, quantity, value against the limit."""
        return (f"t = {self.time:.6g} s, actuator {self.number} ({self.actuator}): "
                f"{self.quantity} {self.value:.6g} {self.unit}, |{self.quantity}| > "
                f"limit {self.limit:.6g} {self.unit}")


@dataclass(frozen=True)
class LimitCheck:
    """Actuator limits against the path.

    Attributes
    ----------
    limits : dict
        ``{quantity: limit}`` checked.
    units : dict
        ``{quantity: unit}``.
    peaks : dict
        ``{quantity: largest absolute value over actuators and points}``.
    first : LimitViolation or None
        The first violation along the path; None when all are within limits.
    violations : dict
        ``{quantity: number of (point, actuator) pairs over the limit}``.
    """

    limits: dict
    units: dict
    peaks: dict
    first: LimitViolation | None
    violations: dict

    @property
    def ok(self):
        """True when no quantity exceeds its limit anywhere."""
        return self.first is None


def _limit_value(quantity, value):
    if quantity not in LIMIT_QUANTITIES:
        raise KanedynError(f"unknown actuator limit {quantity!r}; known: "
                           f"{', '.join(LIMIT_QUANTITIES)}")
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) \
            or not (math.isfinite(value) and value > 0):
        raise KanedynError(f"actuator limit {quantity} must be a finite number > 0, "
                           f"got {value!r}")
    return float(value)


def check_actuator_limits(t, names, values, units, limits):
    """Check ``|values[q]| <= limits[q]`` at every point; name the first violation.

    Parameters
    ----------
    t : array_like, shape (N,)
        Times, s.
    names : sequence of str
        The ``k`` actuators.
    values : dict
        ``{quantity: array (k, N)}``: the quantities available (a quantity
        without values cannot be limited: ``torque`` and ``motor_speed`` need
        ball-screw drives).
    units : dict
        ``{quantity: unit}``.
    limits : dict
        ``{quantity: positive limit}``, a subset of :data:`LIMIT_QUANTITIES`.

    Returns
    -------
    LimitCheck
    """
    t = np.asarray(t, float)
    checked = {q: _limit_value(q, v) for q, v in limits.items()}
    first, peaks, counts = None, {}, {}
    for quantity in LIMIT_QUANTITIES:
        if quantity not in checked:
            continue
        if values.get(quantity) is None:
            raise KanedynError(f"actuator limit {quantity}: this model's actuators have no "
                               f"{quantity.replace('_', ' ')} (motor torques and speeds "
                               "need a ball screw on every actuator)")
        arr = np.asarray(values[quantity], float)
        over = np.abs(arr) > checked[quantity]
        peaks[quantity] = float(np.max(np.abs(arr)))
        counts[quantity] = int(np.count_nonzero(over))
        if not over.any():
            continue
        actuators, points = np.nonzero(over)
        j = int(np.lexsort((actuators, points))[0])
        point, actuator = int(points[j]), int(actuators[j])
        key = (point, actuator, LIMIT_QUANTITIES.index(quantity))
        if first is None or key < first[0]:
            first = (key, LimitViolation(
                time=float(t[point]), point=point, actuator=str(names[actuator]),
                number=actuator + 1, quantity=quantity,
                value=float(arr[actuator, point]), limit=checked[quantity],
                unit=units[quantity]))
    return LimitCheck(limits=checked, units={q: units[q] for q in checked}, peaks=peaks,
                      first=None if first is None else first[1], violations=counts)
