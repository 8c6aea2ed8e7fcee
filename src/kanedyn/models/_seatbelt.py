r"""The seat-belt inertial sensor: a constrained spherical pendulum on a moving vehicle.

After Allan & Townsend (Shock and Vibration 1995): the vehicle-sensitive element of
an automatic retractor is a small pendulum hanging from a pivot in a housing fixed
in the vehicle.  When the vehicle decelerates or tilts, the pendulum tilts in its
housing; beyond the *lock angle* it lifts the pawl, which engages the ratchet
wheel and locks the belt.  The housing wall limits the tilt.

Coordinates.  The pendulum axis is :math:`e = -B_z`; the pendulum frame B is the
housing frame H turned by :math:`q_1` about :math:`H_x` and then by
:math:`q_2` about the new y axis (a two-axis gimbal; :math:`u_i = \dot q_i`).
Zero tilt is the regular point :math:`q_1 = q_2 = 0` (the singularity of these
angles is at :math:`q_2 = \pm 90°`, far beyond the housing wall), and the tilt
relative to the housing is :math:`\cos\theta = \cos q_1 \cos q_2`.

Body.  Mass ``m``, centre of mass at distance ``L`` from the pivot on the axis,
central inertia ``I`` about every transverse axis and none about the axis itself
(a slender pendulum): its spin about its own axis then carries no energy and the
two gimbal angles describe the spherical pendulum exactly.  Its inertia about the
pivot is :math:`J = I + mL^2` and its equivalent simple-pendulum length
:math:`\ell = J/(mL)`.

Default parameters (assumed, not from a data sheet; plausible for the die-cast
pendulums of retractor sensors, which weigh a few grams and hang some 5-15 mm
below their pivot): m = 5 g, L = 8 mm, I = m (4 mm)^2 = 8e-8 kg m^2, hence
J = 4e-7 kg m^2, :math:`\ell` = 10 mm and a natural frequency of
:math:`\sqrt{g/\ell}/2\pi` = 5.0 Hz.  Lock angle 20 deg: between the 15 deg
static tilt at which FMVSS 209 forbids locking and the 35 deg = atan(0.7) tilt of
a steady 0.7 g deceleration at which it demands it.  Housing wall at 30 deg,
touched by the pendulum's rim at r = 12 mm from the pivot.
"""

from __future__ import annotations

import copy
import functools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..modeling import (ConeLimit, CrashPulse, HalfSinePulse, HaversinePulse, TrapezoidPulse,
                        VehicleMotion, cone_contact, example_pulse, read_iso_mme)
from ._base import ModelDefinition

__all__ = ["seatbelt_sensor", "seatbelt_motion", "lock_events", "seatbelt_tilt",
           "seatbelt_report", "SeatbeltReport", "SEATBELT_DEFAULTS", "G0"]

G0 = 9.80665

#: default sensor parameters (SI units; angles in rad)
SEATBELT_DEFAULTS = {"m": 5e-3, "L": 8e-3, "I": 8e-8, "g": G0,
                     "theta_lock": math.radians(20.0), "theta_lim": math.radians(30.0),
                     "r_c": 12e-3, "k_lim": 5.0, "c_lim": 1.0e-3, "p_lim": 1.0,
                     "e_lim": 0.3, "c_p": 0.0, "tilt_x": 0.0, "tilt_y": 0.0}

_SHAPES = ("halfsine", "haversine", "trapezoid", "step", "none")
_LIMITS = ("penalty", "contact", "none")
_EXAMPLES = ("frontal-48kmh", "oblique-30deg")


def seatbelt_motion(pulse="halfsine", peak_g=20.0, duration=0.1, direction=0.0,
                    roll_rate=0.0, filter=None):
    """The vehicle motion of the sensor model (see :func:`seatbelt_sensor`).

    Returns
    -------
    (VehicleMotion, float)
        The motion and a default end time, s.
    """
    if not isinstance(pulse, (str, Path)):
        raise ModelError(f"seatbelt-sensor: pulse must be a name or a CSV path, got {pulse!r}")
    name = str(pulse)
    if (isinstance(pulse, Path) or name in _EXAMPLES or name.lower().endswith((".csv", ".mme"))
            or name not in _SHAPES and Path(name).is_dir()):
        if name in _EXAMPLES and isinstance(filter, (type(None), str, int)):
            motion, end = _example_motion(name, filter)
            return copy.copy(motion), end  # its own symbols (moving_frame sets them)
        path = example_pulse(name) if name in _EXAMPLES else Path(name)
        if path.is_dir() or path.suffix.lower() == ".mme":  # an ISO-MME test
            if not path.exists():
                raise ModelError(f"seatbelt-sensor: ISO-MME test {path} does not exist")
            motion = VehicleMotion.from_series(read_iso_mme(path), filter=filter)
        elif not path.is_file():
            raise ModelError(f"seatbelt-sensor: pulse file {path} does not exist")
        else:
            motion = VehicleMotion.from_csv(path, filter=filter)
        return motion, float(motion.t_range[1])
    if name not in _SHAPES:
        raise ModelError(f"seatbelt-sensor: unknown pulse {name!r}; give one of "
                         f"{', '.join(_SHAPES + _EXAMPLES)} or a .csv file")
    if filter is not None:
        raise ModelError("seatbelt-sensor: filter applies to recorded pulses (CSV) only")
    peak_g, duration = float(peak_g), float(duration)
    if not (math.isfinite(duration) and duration > 0):
        raise ModelError(f"seatbelt-sensor: duration must be positive, got {duration}")
    if name != "none" and not (math.isfinite(peak_g) and peak_g > 0):
        raise ModelError(f"seatbelt-sensor: peak_g must be positive, got {peak_g}")
    if name == "halfsine":
        shape = HalfSinePulse(peak_g, duration)
    elif name == "haversine":
        shape = HaversinePulse(peak_g, duration)
    elif name == "trapezoid":  # rise and fall a quarter of the duration each
        shape = TrapezoidPulse(peak_g, duration / 4, duration / 2, duration / 4)
    elif name == "step":  # constant deceleration over the duration
        shape = CrashPulse([(0.0, duration, sm.Float(peak_g * G0))], name="step")
    else:
        shape = CrashPulse([(0.0, duration, sm.S.Zero)], name="none")
    motion = VehicleMotion.from_pulse(shape, direction=float(direction),
                                      roll_rate=float(roll_rate))
    return motion, duration + 0.1


@functools.lru_cache(maxsize=8)
def _example_motion(name, filter):
    """``(motion, end time)`` of the example pulse ``name``, read once per process:
    a record with rotation integrates its angles when read (oblique-30deg: 2 s of
    CPU; a sensor built again, with another limit, read it again), and the file
    is the package's own.  Callers take a shallow copy: the functions of time
    are shared (pure), the attributes a use sets are each copy's own."""
    motion = VehicleMotion.from_csv(example_pulse(name), filter=filter)
    return motion, float(motion.t_range[1])


def seatbelt_sensor(limit="penalty", pulse="halfsine", peak_g=20.0, duration=0.1,
                    direction=0.0, roll_rate=0.0, filter=None, pivot_force=False):
    """The ``seatbelt-sensor`` model: a constrained spherical pendulum in a vehicle.

    Parameters
    ----------
    limit : {"penalty", "contact", "none"}
        How the housing limits the tilt to ``theta_lim``: a :class:`~kanedyn.ConeLimit`
        penalty torque (constants ``k_lim`` N m/rad^p, ``c_lim`` N m s/rad, ``p_lim``),
        a unilateral contact with restitution ``e_lim`` of the pendulum's rim (at
        ``r_c`` from the pivot) on a cone of the housing (:func:`~kanedyn.cone_contact`),
        or no limit.
    pulse : str or path
        ``"halfsine"``, ``"haversine"``, ``"trapezoid"`` (rise and fall a quarter of
        the duration), ``"step"`` (constant deceleration for ``duration``), ``"none"``
        (vehicle at rest), an example pulse (``"frontal-48kmh"``, ``"oblique-30deg"``)
        a CSV record (:func:`kanedyn.vehicle.read_pulse_csv`) or an ISO-MME test (its
        folder or ``.mme`` file; the vehicle's channels, :func:`kanedyn.vehicle.read_iso_mme`).
    peak_g : float
        Peak deceleration, g (analytic pulses).
    duration : float
        Pulse duration, s (analytic pulses).
    direction : float
        Direction of the deceleration, deg: along -(cos, sin, 0) in vehicle axes
        (0 frontal, 90 lateral).
    roll_rate : float
        Constant roll rate of the vehicle about its x axis, rad/s (analytic pulses).
    filter : str, optional
        CFC filter of a CSV record, e.g. ``"CFC60"``.
    pivot_force : bool
        Expose the pivot force (N, inertial components ``R_x, R_y, R_z``) through
        auxiliary speeds (``model.auxiliary(t, y)``).

    Returns
    -------
    ModelDefinition
        ``symbols`` holds the frames, points, coordinates, the ``motion``
        (:class:`~kanedyn.VehicleMotion`), the ``limit_element`` (ConeLimit or
        Contact or None) and ``tilt`` (expression, rad).
    """
    if limit not in _LIMITS:
        raise ModelError(f"seatbelt-sensor: limit must be one of {', '.join(_LIMITS)}, "
                         f"got {limit!r}")
    motion, t_end = seatbelt_motion(pulse, peak_g, duration, direction, roll_rate, filter)
    sy = {n: sm.Symbol(n, real=True) for n in SEATBELT_DEFAULTS}
    m, L, I, g = sy["m"], sy["L"], sy["I"], sy["g"]
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    V, VO = motion.moving_frame(N, O)
    H = V.orientnew("H", "Body", (sy["tilt_x"], sy["tilt_y"], 0), "XYZ")  # housing
    P = VO.locatenew("P", 0)  # pivot, at the vehicle origin
    P.set_vel(N, VO.vel(N))
    B1 = H.orientnew("B1", "Axis", (q1, H.x))
    B = B1.orientnew("B", "Axis", (q2, B1.y))
    B.set_ang_vel(H, u1 * H.x + u2 * B1.y)
    loads = []
    kane_args = dict(frame=N, q_ind=[q1, q2], u_ind=[u1, u2],
                     kd_eqs=[q1.diff() - u1, q2.diff() - u2])
    extra = {}
    if pivot_force:
        ua = me.dynamicsymbols("ua_x ua_y ua_z")
        R = me.dynamicsymbols("R_x R_y R_z")
        P.set_vel(N, VO.vel(N) + ua[0] * N.x + ua[1] * N.y + ua[2] * N.z)
        loads.append((P, R[0] * N.x + R[1] * N.y + R[2] * N.z))
        kane_args["u_auxiliary"] = list(ua)
        extra.update(ua=tuple(ua), R=tuple(R))
    G = P.locatenew("G", -L * B.z)
    G.v2pt_theory(P, N, B)
    pendulum = me.RigidBody("pendulum", G, B, m,
                            (me.inertia(B, I, I, 0), G))
    pendulum.potential_energy = m * g * G.pos_from(O).dot(N.z)
    loads.append((G, -m * g * N.z))
    # viscous pivot friction on the axis' relative turning rate (transverse part of
    # the relative angular velocity: no torque about the axis, which has no inertia)
    w_rel = B.ang_vel_in(H)
    loads.append((B, -sy["c_p"] * (w_rel - w_rel.dot(B.z) * B.z)))
    tilt = sm.acos(sm.cos(q1) * sm.cos(q2))
    element, contacts = None, []
    if limit == "penalty":
        element = ConeLimit(B, H, -B.z, -H.z, sy["theta_lim"], sy["k_lim"], sy["c_lim"],
                            sy["p_lim"], name="housing")
        loads.extend(element.to_loads()[:1])  # the housing's motion is prescribed
    elif limit == "contact":
        rim = P.locatenew("rim", -sy["r_c"] * B.z)
        rim.v2pt_theory(P, N, B)
        element = cone_contact(rim, H, P, -H.z, sy["theta_lim"], sy["r_c"],
                               restitution=sy["e_lim"], name="housing")
        contacts.append(element)
    # the housing: a body without mass or inertia fixed in H at the pivot, so that
    # the viewer draws it (it adds nothing to the equations)
    housing = me.RigidBody("housing", P, H, 0, (me.inertia(H, 0, 0, 0), P))
    kane_args.update(bodies=[pendulum, housing], loads=loads,
                     potential_energy=pendulum.potential_energy)
    if contacts:
        kane_args["contacts"] = contacts
    used = {"m", "L", "I", "g", "c_p", "tilt_x", "tilt_y"}
    used |= {"penalty": {"theta_lim", "k_lim", "c_lim", "p_lim"},
             "contact": {"theta_lim", "r_c", "e_lim"}, "none": set()}[limit]
    constants = {sy[n]: SEATBELT_DEFAULTS[n] for n in SEATBELT_DEFAULTS if n in used}
    units = {"m": "kg", "L": "m", "I": "kg m^2", "g": "m/s^2", "theta_lock": "rad",
             "theta_lim": "rad", "r_c": "m", "k_lim": "N m/rad^p", "c_lim": "N m s/rad",
             "p_lim": "1", "e_lim": "1", "c_p": "N m s/rad", "tilt_x": "rad",
             "tilt_y": "rad"}
    symbols = dict(q1=q1, q2=q2, u1=u1, u2=u2, N=N, V=V, H=H, B=B, P=P, G=G, O=O,
                   motion=motion, limit_element=element, tilt=tilt, limit=limit,
                   lock_angle=SEATBELT_DEFAULTS["theta_lock"], **sy,
                   **extra)
    specified = _needed_inputs(motion, pivot_force)
    shapes = _shapes(pendulum, housing, {n: sy[n] if n in used else SEATBELT_DEFAULTS[n]
                                         for n in ("L", "r_c", "theta_lim")})
    # the housing's place needs the vehicle's displacement, which no equation does
    displacement = {s: v for s, v in motion.specified().items() if s in motion.symbols[:3]}
    return ModelDefinition(
        name="seatbelt-sensor",
        title="seat-belt inertial sensor: spherical pendulum in a housing on a moving "
              "vehicle",
        kane_args=kane_args, constants=constants,
        constant_units={sy[n]: units[n] for n in used},
        initial_state={q1: 0.0, q2: 0.0, u1: 0.0, u2: 0.0}, t_end=t_end,
        specified=specified, symbols=symbols,
        description="After Allan & Townsend (1995). The pendulum tilts in its housing "
                    "under the vehicle's deceleration; tilt beyond theta_lock locks the "
                    f"belt (seatbelt_report). Pulse: {motion.source}; limit: {limit}.",
        units={q1: "rad", q2: "rad", u1: "rad/s", u2: "rad/s"},
        report=_run_report, animation_inputs=displacement, shape_specs=shapes)


def _shapes(pendulum, housing, size):
    """The sensor at its size (m): the pendulum a rod from the pivot to its rim (r_c)
    with a 2.5 mm ball at its mass centre (L below the pivot); the housing a
    translucent cylinder reaching the rim where it touches the wall (radius
    r_c sin theta_lim, depth r_c cos theta_lim below the pivot)."""
    L, r_c, wall = size["L"], size["r_c"], size["theta_lim"]
    depth = r_c * sm.cos(wall)
    return (("Cylinder", pendulum, {"radius": 0.6e-3, "length": r_c, "axis": "z",
                                    "offset": (0.0, 0.0, L - r_c / 2), "color": "#4a5a6a"}),
            ("Sphere", pendulum, {"radius": 2.5e-3, "color": "#c0392b"}),
            ("Cylinder", housing, {"radius": r_c * sm.sin(wall), "length": depth,
                                   "axis": "z", "offset": (0.0, 0.0, -depth / 2),
                                   "color": "#d5dbdb", "opacity": 0.12}))


def _run_report(result, definition):
    """The ``report`` hook of the model (``kanedyn run``): lock times from the
    output points."""
    return seatbelt_report(result, definition)


def _needed_inputs(motion, pivot_force):
    """The vehicle inputs the sensor's equations and energies use (eom.numeric
    refuses others)."""
    t = me.dynamicsymbols._t
    x, y, z, yaw, pitch, roll = motion.symbols
    keys = [sm.Derivative(s, (t, k)) for s in (x, y, z) for k in (1, 2)]
    keys += [s for s in (yaw, pitch, roll)]
    keys += [sm.Derivative(s, (t, k)) for s in (yaw, pitch, roll) for k in (1, 2)]
    keys.append(z)  # in the potential energy (the energies need x', y', z' too)
    allv = motion.specified()
    return {k: allv[k] for k in keys if k in allv}


def seatbelt_tilt(y):
    """Tilt of the pendulum relative to its housing, rad, from states ``[q1, q2, ...]``."""
    y = np.asarray(y, float)
    c = np.cos(y[0]) * np.cos(y[1])
    s = np.hypot(np.sin(y[0]) * np.cos(y[1]), np.sin(y[1]))
    return np.arctan2(s, c)


def _lock_angle(definition, lock_angle):
    if lock_angle is not None:
        return float(lock_angle)
    return float(definition.symbols["lock_angle"])


def lock_events(definition, lock_angle=None):
    """Events for ``kd.simulate``: the tilt crossing the lock angle (both ways).

    Returns
    -------
    list of callables
        ``[crossing]``: ``crossing(t, y) = tilt - lock angle`` (direction 0); pass it
        as the first event and give ``seatbelt_report(..., events=0)``.
    """
    angle = _lock_angle(definition, lock_angle)

    def crossing(t, y):
        return float(seatbelt_tilt(y[:2])) - angle

    crossing.terminal = False
    crossing.direction = 0
    return [crossing]


@dataclass(frozen=True)
class SeatbeltReport:
    """Locking of the sensor over a run (times in s, angles in rad).

    Attributes
    ----------
    locked : bool
        The tilt exceeded the lock angle at some time.
    lock_time : float or None
        First time the tilt reached the lock angle.
    lock_duration : float
        Total time spent beyond the lock angle (an interval still open at the end
        counts up to the end of the run).
    intervals : tuple of (float, float)
        Locked intervals.
    releases : tuple of float
        Unintended releases: times the tilt fell back below the lock angle while
        the vehicle's acceleration still exceeded ``release_g``.
    max_tilt : float
    lock_angle : float
    release_g : float
    complete : bool
        The run reached its end (or a terminal event); ``False`` for a run that
        stopped early (interrupted, failed): the report covers it up to
        :attr:`reached` only.
    reached : float or None
        The last time the run computed, s.
    lock_between : tuple of (float, float) or None
        Where the output points do not resolve the first lock (the tilt changes
        by more than a quarter of the lock angle between the two around it),
        those two times, and :attr:`lock_time` is ``None``: the tilt crossed the
        lock angle somewhere between them.
    stopped : str
        Why a run that is not complete stopped (its message).
    """

    locked: bool
    lock_time: float | None
    lock_duration: float
    intervals: tuple
    releases: tuple
    max_tilt: float
    lock_angle: float
    release_g: float
    complete: bool = True
    reached: float | None = None
    lock_between: tuple | None = None
    stopped: str = ""

    def text(self):
        """One line: lock time, lock duration, releases (ms) and the largest tilt (deg)."""
        return self.summary()

    def as_dict(self):
        """JSON-ready values (s and rad, like the attributes; None when not locked)."""
        return {"locked": self.locked, "lock_time": self.lock_time,
                "lock_duration": self.lock_duration,
                "intervals": [list(map(float, iv)) for iv in self.intervals],
                "releases": [float(t) for t in self.releases],
                "max_tilt": self.max_tilt, "lock_angle": self.lock_angle,
                "release_g": self.release_g, "complete": self.complete,
                "reached": self.reached,
                "lock_between": None if self.lock_between is None else list(self.lock_between),
                "stopped": self.stopped}

    def summary(self):
        partial = ("" if self.complete else
                   f"partial run (stopped at t = {1e3 * self.reached:.2f} ms: {self.stopped}): ")
        if not self.locked:
            return (f"{partial}no lock: max tilt {math.degrees(self.max_tilt):.2f} deg < lock "
                    f"angle {math.degrees(self.lock_angle):.2f} deg")
        open_end = self.intervals[-1][1] >= self.reached
        if self.lock_between is not None:
            a, b = self.lock_between
            text = (f"locks between t = {1e3 * a:.2f} and {1e3 * b:.2f} ms (the output points "
                    "do not resolve it; give more of them, or lock_events)")
        else:
            duration = ("at least " if open_end and not self.complete else "") \
                + f"{1e3 * self.lock_duration:.2f} ms"
            text = f"locks at t = {1e3 * self.lock_time:.2f} ms, locked for {duration}"
        text = f"{partial}{text}, max tilt {math.degrees(self.max_tilt):.2f} deg"
        if not self.complete and open_end:
            text += ", still locked when the run stopped"
        if self.releases:
            text += ("; unintended release at t = "
                     + ", ".join(f"{1e3 * t:.2f}" for t in self.releases) + " ms")
        else:
            text += "; no unintended release"
        return text


#: a crossing between two output points is located by interpolation where the tilt
#: changes between them by at most this fraction of the lock angle
_RESOLVED_TILT_STEP = 0.25


def seatbelt_report(result, definition, events=None, lock_angle=None, release_g=0.7):
    """Lock time, duration and unintended releases of a ``seatbelt-sensor`` run.

    Parameters
    ----------
    result : SimulationResult
    definition : ModelDefinition
        The definition the run's model came from (its motion gives the vehicle
        acceleration).
    events : int, optional
        Index in ``result.t_events`` of the :func:`lock_events` crossing; the crossing
        times are then the event times.  Without it they are interpolated
        linearly between the output times.
    lock_angle : float, optional
        rad; default: the definition's ``theta_lock``.
    release_g : float
        A fall below the lock angle while the vehicle's acceleration magnitude
        exceeds this many g is an unintended release.

    Returns
    -------
    SeatbeltReport
        Of what the run computed: a run that stopped early (``success`` false)
        gives a report marked partial.  A first lock between output points so
        far apart that the tilt changes by more than a quarter of the lock angle
        between them is given as those two times (``lock_between``), not as a
        time interpolated across them.
    """
    angle = _lock_angle(definition, lock_angle)
    t = np.asarray(result.t, float)
    if t.size == 0:
        raise ModelError(f"the run has no output point (it stopped: {result.message}): "
                         "there is nothing to report on the sensor's locking")
    tilt = seatbelt_tilt(result.y[:2])
    over = tilt > angle
    if events is not None:
        times = np.asarray(result.t_events[events], float)
        order = np.argsort(times, kind="stable")
        times = times[order]
        q1, q2, u1, u2 = np.asarray(result.y_events[events], float).reshape(
            times.size, result.y.shape[0])[order, :4].T
        # the side after each crossing: where the tilt goes (cos(tilt) = cos q1 cos q2)
        sides = np.sin(q1) * np.cos(q2) * u1 + np.cos(q1) * np.sin(q2) * u2 > 0
    else:
        idx = np.nonzero(over[1:] != over[:-1])[0]
        f = tilt - angle
        times = t[idx] - f[idx] * (t[idx + 1] - t[idx]) / (f[idx + 1] - f[idx])
        sides = over[idx + 1]
    state = bool(over[0])
    starts, ends = ([t[0]] if state else []), []
    lock_between = None
    for k, (tc, after) in enumerate(zip(times, sides)):
        if after == state:  # a crossing found twice (at the end of a segment and the next)
            continue
        if after and not starts and events is None:
            i = idx[k]
            if abs(tilt[i + 1] - tilt[i]) > _RESOLVED_TILT_STEP * angle:
                lock_between = (float(t[i]), float(t[i + 1]))
        (starts if after else ends).append(float(tc))
        state = bool(after)
    if state:
        ends.append(float(t[-1]))
    intervals = tuple(zip(starts, ends))
    motion = definition.symbols["motion"]
    releases = []
    for t_end in ends[:len(starts)]:
        if t_end >= t[-1]:
            continue
        tq = np.clip(t_end, *motion.t_range)
        acc = np.linalg.norm(motion.evaluate("position", 2, np.atleast_1d(tq))[:, 0])
        if acc > release_g * G0:
            releases.append(t_end)
    return SeatbeltReport(
        locked=bool(intervals),
        lock_time=intervals[0][0] if intervals and lock_between is None else None,
        lock_duration=float(sum(b - a for a, b in intervals)), intervals=intervals,
        releases=tuple(releases), max_tilt=float(np.max(tilt)), lock_angle=angle,
        release_g=float(release_g), complete=bool(result.success), reached=float(t[-1]),
        lock_between=lock_between, stopped="" if result.success else result.message)
