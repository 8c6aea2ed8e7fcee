r"""Studies of the seat-belt sensor (``seatbelt-sensor``): lock map and regulatory check.

Both studies run one compiled model whose vehicle motion is written in closed
form with four extra constants, so that :func:`kanedyn.sweep` varies the pulse
like any parameter (no derivation or build per run), and whose lock is an event
given as an expression of the angles, so that the sweep integrates the lock map's
runs together in C threads (:func:`kanedyn.simulate_many`; for a C model with the
``penalty`` or ``none`` limit: the ``contact`` limit's modes and impacts are followed
in Python, so its runs go one :func:`kanedyn.simulate` each):

* ``peak_g`` (g) and ``duration`` (s) of the pulse,
* ``direction`` (rad): the deceleration points along -(cos, sin, 0) in vehicle
  axes (0 frontal, pi/2 lateral),
* ``roll_rate`` (rad/s): constant roll of the vehicle about its x axis.

Pulse shapes (the vehicle origin's displacement s(t) along the direction, with
A = peak_g g0): ``halfsine`` a = A sin(pi t/T) on [0, T]; ``haversine``
a = A (1 - cos(2 pi t/T))/2 on [0, T]; ``ramp`` a = A t/T up to T, then held at A;
``step`` a = A from t = 0 on (T unused).  The displacements are integrated in closed
form here and differentiated exactly by kanedyn; they agree with the pulses of
:mod:`kanedyn.modeling.vehicle` (tested).

The regulatory check follows FMVSS 209 (S4.3(j)) as far as the sensor alone allows:
the retractor must lock before 25 mm of webbing is withdrawn when subjected to an
acceleration of 0.7 g reached within 50 ms, and a vehicle-sensitive retractor must
not lock at tilts of the vehicle up to 15 deg.  The sensor alone has no webbing, so
the 25 mm cannot be checked; it is read here as a time budget: the pendulum must
reach its lock angle no later than ``time_limit`` (default 50 ms) after the
deceleration has reached 0.7 g, and stay locked while it is held.  Two inputs are
checked: a step to 0.7 g and a linear ramp to 0.7 g over 50 ms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from .._output_files import replacing, save_figure
from ._studies import StudyOption, register_study

__all__ = ["seatbelt_study_model", "seatbelt_lock_map", "SeatbeltLockMap",
           "regulatory_check", "RegulatoryCheck", "PULSE_SHAPES", "DIRECTION_NAMES"]

#: standard gravity, m/s^2
_G0 = 9.80665

#: closed-form pulse shapes of the studies
PULSE_SHAPES = ("halfsine", "haversine", "ramp", "step")

#: names of the directions the figures label, deg -> name
DIRECTION_NAMES = {0.0: "frontal", 30.0: "oblique", 45.0: "oblique", 90.0: "lateral",
                   180.0: "rear"}


def _displacement(shape, A, T, t):
    """s(t), m: displacement of the vehicle origin along the pulse direction."""
    pi = sm.pi
    if shape == "halfsine":
        inside = A * T / pi * (t - T / pi * sm.sin(pi * t / T))
        after = A * T ** 2 / pi + 2 * A * T / pi * (t - T)
    elif shape == "haversine":
        inside = A / 2 * (t ** 2 / 2 + T ** 2 / (4 * pi ** 2) * (sm.cos(2 * pi * t / T) - 1))
        after = A * T ** 2 / 4 + A * T / 2 * (t - T)
    elif shape == "ramp":
        inside = A * t ** 3 / (6 * T)
        after = A * T ** 2 / 6 + A * T / 2 * (t - T) + A / 2 * (t - T) ** 2
    elif shape == "step":
        return sm.Piecewise((0, t < 0), (A * t ** 2 / 2, True))
    else:
        raise ModelError(f"seatbelt study: unknown pulse shape {shape!r}; give one of "
                         f"{', '.join(PULSE_SHAPES)}")
    return sm.Piecewise((0, t < 0), (inside, t < T), (after, True))


def seatbelt_study_model(shape="halfsine", limit="penalty", constants=None, backend="c"):
    """The sensor with a closed-form pulse whose size, direction and roll are constants.

    Parameters
    ----------
    shape : {"halfsine", "haversine", "ramp", "step"}
    limit : {"penalty", "contact", "none"}
        The housing limit (:func:`kanedyn.models.seatbelt_sensor`).
    constants : dict, optional
        Sensor parameters by name (``m``, ``L``, ``I``, ``theta_lim``, ``k_lim``,
        ``tilt_x``, ...), SI units.
    backend : {"c", "numpy"}

    Returns
    -------
    (ModelDefinition, NumericModel)
        The model has the constants ``peak_g`` (g), ``duration`` (s), ``direction``
        (rad) and ``roll_rate`` (rad/s) besides the sensor's, all runtime values
        (``model.with_constants``, :func:`kanedyn.sweep`).
    """
    from ..models import build
    if shape not in PULSE_SHAPES:
        raise ModelError(f"seatbelt study: unknown pulse shape {shape!r}; give one of "
                         f"{', '.join(PULSE_SHAPES)}")
    definition = build("seatbelt-sensor", limit=limit, pulse="none")
    eom = definition.derive()
    t = me.dynamicsymbols._t
    A, T, phi, p = sm.symbols("peak_g duration direction roll_rate", real=True)
    s = _displacement(shape, A * _G0, T, t)
    x, y, z, yaw, pitch, roll = definition.symbols["motion"].symbols
    zero = sm.S.Zero
    specified = {x: -sm.cos(phi) * s, y: -sm.sin(phi) * s, z: zero, yaw: zero,
                 pitch: zero, roll: p * t}
    values = dict(definition.constants)
    values.update(definition._constant_overrides(constants or {}))
    start = {A: 1.0, T: 0.1, phi: 0.0, p: 0.0}
    if shape == "step":  # no duration
        del start[T]
    values.update(start)
    model = eom.numeric(constants=values, specified=specified, backend=backend)
    return definition, model


def _lock_event(lock_angle):
    """The tilt of the pendulum in its housing crossing the lock angle (both ways), as
    an expression (:class:`kanedyn.Event`): ``kd.sweep`` integrates the lock map's runs
    together in C with it (``simulate_many``), and ``kd.simulate`` takes it too.  The
    tilt is that of :func:`kanedyn.models.seatbelt_tilt`."""
    from ..simulation import Event
    q1, q2 = me.dynamicsymbols("q1 q2")
    c = sm.cos(q1) * sm.cos(q2)
    s = sm.sqrt((sm.sin(q1) * sm.cos(q2)) ** 2 + sm.sin(q2) ** 2)
    return Event(sm.atan2(s, c) - lock_angle, name="lock")


def _lock_angle(lock_angle):
    from ..models import SEATBELT_DEFAULTS
    value = SEATBELT_DEFAULTS["theta_lock"] if lock_angle is None else float(lock_angle)
    if not (math.isfinite(value) and 0 < value < math.pi / 2):
        raise ModelError(f"seatbelt study: lock_angle must be between 0 and pi/2 rad, got "
                         f"{lock_angle!r}")
    return value


# ----------------------------------------------------------------- lock map
@dataclass(frozen=True)
class SeatbeltLockMap:
    """Lock time of the sensor over pulse severity, direction and roll rate.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per run: ``peak_g`` (g), ``duration`` (s), ``direction`` (deg),
        ``roll_rate`` (rad/s), ``locked`` (bool), ``lock_time`` (s, NaN: no lock),
        ``lock_crossings`` (times the tilt crossed the lock angle), ``success``,
        ``message``.
    figure : matplotlib.figure.Figure
        Lock time (ms) over peak g and duration, one panel per direction (columns)
        and roll rate (rows); runs without lock marked "no lock".
    shape : str
    lock_angle : float
        rad.
    t_end : float
        Length of every run, s.
    """

    table: object
    figure: object
    shape: str
    lock_angle: float
    t_end: float
    sensor: dict = field(default_factory=dict)

    def to_csv(self, path):
        """Write :attr:`table` as CSV; returns the path."""
        with replacing(path, newline="") as handle:
            self.table.to_csv(handle, index=False)
        return path

    def save_figure(self, path, dpi=120):
        """Write :attr:`figure` (PNG, SVG, PDF by the suffix); returns the path."""
        return save_figure(self.figure, path, dpi=dpi, bbox_inches="tight")

    def lock_time(self, peak_g, duration, direction=0.0, roll_rate=0.0):
        """Lock time of one grid point, s (NaN: no lock)."""
        t = self.table
        row = t[np.isclose(t.peak_g, peak_g) & np.isclose(t.duration, duration)
                & np.isclose(t.direction, direction) & np.isclose(t.roll_rate, roll_rate)]
        if row.empty:
            raise ModelError(f"lock map: no run at peak_g={peak_g}, duration={duration}, "
                             f"direction={direction}, roll_rate={roll_rate}")
        return float(row.lock_time.iloc[0])


def _values(name, values, positive=True):
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
        raise ModelError(f"seatbelt_lock_map: {name} must be finite numbers, got {values!r}")
    if positive and np.any(arr <= 0):
        raise ModelError(f"seatbelt_lock_map: {name} must be positive, got {values!r}")
    return arr


def seatbelt_lock_map(peak_g=(2.0, 5.0, 10.0, 20.0, 30.0),
                      duration=(0.04, 0.06, 0.08, 0.1, 0.12),
                      direction=(0.0, 30.0, 45.0, 90.0), roll_rate=(0.0,), shape="halfsine",
                      limit="penalty", constants=None, lock_angle=None, t_end=None,
                      backend="c", rtol=1e-8, atol=1e-8, out=None, scheduler="serial",
                      progress=False, **sweep_options):
    """Lock time of the sensor over a grid of pulses (:func:`kanedyn.sweep`).

    Parameters
    ----------
    peak_g : sequence of float
        Peak decelerations, g.
    duration : sequence of float
        Pulse durations, s (the rise time of a ``ramp``).
    direction : sequence of float
        Directions of the deceleration, deg (0 frontal, 30 and 45 oblique, 90 lateral).
    roll_rate : sequence of float
        Roll rates of the vehicle about its x axis, rad/s (rollover).
    shape : {"halfsine", "haversine", "ramp", "step"}
    limit : {"penalty", "contact", "none"}
    constants : dict, optional
        Sensor parameters by name (SI units).
    lock_angle : float, optional
        rad; default the model's 20 deg.
    t_end : float, optional
        Length of every run, s; default the longest duration + 0.1 s.
    backend, rtol, atol
        Of the model and :func:`kanedyn.simulate`.
    out : path, optional
        Folder of the sweep (resumable); it also gets ``lock_map.csv`` and
        ``lock_map.png``.
    scheduler : str or None
        :func:`kanedyn.sweep`'s: ``"serial"`` (default: the runs are short) or None
        (a local Dask cluster) or a scheduler address.
    **sweep_options
        Further keywords of :func:`kanedyn.sweep` (``n_workers``, ``client``).

    Returns
    -------
    SeatbeltLockMap
    """
    from ..simulation import sweep
    peak_g = _values("peak_g", peak_g)
    duration = _values("duration", duration)
    direction = _values("direction", direction, positive=False)
    roll_rate = _values("roll_rate", roll_rate, positive=False)
    angle = _lock_angle(lock_angle)
    t_end = float(duration.max() + 0.1) if t_end is None else float(t_end)
    definition, model = seatbelt_study_model(shape, limit, constants, backend)
    y0 = definition.initial(model)
    parameters = {"peak_g": peak_g, "duration": duration,
                  "direction": np.radians(direction), "roll_rate": roll_rate}
    raw = sweep(model, parameters, y0, (0.0, t_end), outputs=("events",),
                events=[_lock_event(angle)], rtol=rtol, atol=atol, scheduler=scheduler,
                progress=progress, out=None if out is None else f"{out}/sweep",
                **sweep_options)
    table = raw[["peak_g", "duration", "direction", "roll_rate", "success",
                 "message"]].copy()
    table["direction"] = np.round(np.degrees(raw["direction"].to_numpy()), 9)
    table["lock_time"] = raw["event0_first"].astype(float)
    table["locked"] = np.isfinite(table["lock_time"]) & table["success"]
    table["lock_crossings"] = raw["event0_count"]
    table = table[["peak_g", "duration", "direction", "roll_rate", "locked", "lock_time",
                   "lock_crossings", "success", "message"]]
    figure = _plot_map(table, shape, angle)
    result = SeatbeltLockMap(table=table, figure=figure, shape=shape, lock_angle=angle,
                             t_end=t_end, sensor=dict(constants or {}))
    if out is not None:
        result.to_csv(f"{out}/lock_map.csv")
        result.save_figure(f"{out}/lock_map.png")
    return result


def _direction_title(deg):
    name = DIRECTION_NAMES.get(float(deg) % 360.0)
    text = f"{deg:g}°"
    return f"{name} {text}" if name else f"direction {text}"


def _plot_map(table, shape, lock_angle):
    """Heat maps of the lock time, one per direction and roll rate."""
    from matplotlib.colors import Normalize

    from ._plotting import pyplot
    plt = pyplot()
    directions = sorted(table.direction.unique())
    rates = sorted(table.roll_rate.unique())
    gs = sorted(table.peak_g.unique())
    ds = sorted(table.duration.unique())
    times = table.lock_time.to_numpy() * 1e3
    finite = times[np.isfinite(times)]
    norm = Normalize(vmin=float(finite.min()) if finite.size else 0.0,
                     vmax=float(finite.max()) if finite.size else 1.0)
    ncol, nrow = len(directions), len(rates)
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol + 1.2, 2.9 * nrow + 0.8),
                             squeeze=False, sharex=True, sharey=True)
    cmap = plt.get_cmap("viridis_r").with_extremes(bad="0.85")
    image = None
    for i, rate in enumerate(rates):
        for j, deg in enumerate(directions):
            ax = axes[i, j]
            grid = np.full((len(ds), len(gs)), np.nan)
            failed = np.zeros(grid.shape, dtype=bool)  # no answer: not "no lock"
            part = table[(table.direction == deg) & (table.roll_rate == rate)]
            for _, row in part.iterrows():
                cell = ds.index(row.duration), gs.index(row.peak_g)
                grid[cell] = row.lock_time * 1e3 if row.locked else np.nan
                failed[cell] = not row.success
            image = ax.imshow(np.ma.masked_invalid(grid), origin="lower", aspect="auto",
                              cmap=cmap, norm=norm)
            small = len(gs) * len(ds) <= 64
            for a in range(len(ds)):
                for b in range(len(gs)):
                    if failed[a, b]:
                        ax.text(b, a, "run\nfailed", ha="center", va="center", fontsize=7,
                                color="tab:red")
                    elif not np.isfinite(grid[a, b]):
                        ax.text(b, a, "no\nlock", ha="center", va="center", fontsize=7,
                                color="0.3")
                    elif small:
                        ax.text(b, a, f"{grid[a, b]:.0f}", ha="center", va="center",
                                fontsize=7, color="w" if norm(grid[a, b]) > 0.5 else "k")
            title = _direction_title(deg)
            if len(rates) > 1 or rate != 0:
                title += f", roll {rate:g} rad/s"
            ax.set_title(title, fontsize=9)
            ax.set_xticks(range(len(gs)), [f"{g:g}" for g in gs], fontsize=8)
            ax.set_yticks(range(len(ds)), [f"{1e3 * d:g}" for d in ds], fontsize=8)
            if i == nrow - 1:
                ax.set_xlabel("peak deceleration [g]")
            if j == 0:
                ax.set_ylabel("pulse duration [ms]")
    bar = fig.colorbar(image, ax=axes.ravel().tolist(), shrink=0.9)
    bar.set_label("lock time [ms] (grey: no lock, or the run failed)")
    fig.suptitle(f"Seat-belt sensor: lock time under {shape} pulses "
                 f"(lock angle {math.degrees(lock_angle):g}°)", fontsize=10)
    plt.close(fig)
    return fig


# ------------------------------------------------------------ regulatory check
@dataclass(frozen=True)
class RegulatoryCheck:
    """Pass/fail of the sensor against the FMVSS 209 sensitivity requirements.

    Attributes
    ----------
    rows : tuple of dict
        One per case: ``requirement`` (text), ``case``, ``direction`` (deg),
        ``value`` and ``limit`` (with ``unit``), ``margin`` (limit side positive:
        passes when > 0 — for lock-time rows ``limit - value``, ms; for the static
        rows ``lock angle - max tilt``, deg), ``passed``.
    passed : bool
        All rows passed.
    lock_angle : float
        rad.
    steady_margin : float
        atan(0.7) - lock angle, deg: the tilt a steady 0.7 g gives beyond the lock
        angle (the quasi-static margin of the locking requirement; the wall at
        ``theta_lim`` stops the pendulum before it, which still locks when
        ``theta_lim`` > lock angle).
    interpretation : str
    """

    rows: tuple
    passed: bool
    lock_angle: float
    steady_margin: float
    interpretation: str

    def text(self):
        """The table as lines of text, then PASS or FAIL."""
        lines = [f"{'requirement':<34} {'case':<16} {'dir':>5} {'value':>9} {'limit':>9} "
                 f"{'margin':>9}  result"]
        for r in self.rows:
            lines.append(f"{r['requirement']:<34} {r['case']:<16} {r['direction']:>5g} "
                         f"{_num(r['value']):>9} {_num(r['limit']):>9} "
                         f"{_num(r['margin']):>9} {r['unit']:<4} "
                         f"{'pass' if r['passed'] else 'FAIL'}")
        lines.append(f"steady 0.7 g tilt atan(0.7) = 34.99 deg; lock angle "
                     f"{math.degrees(self.lock_angle):.2f} deg; margin "
                     f"{self.steady_margin:.2f} deg")
        lines.append("overall: " + ("PASS" if self.passed else "FAIL"))
        return "\n".join(lines)

    def as_dict(self):
        """JSON-ready values."""
        return {"passed": self.passed, "lock_angle": self.lock_angle,
                "steady_margin_deg": self.steady_margin, "rows": [dict(r) for r in self.rows],
                "interpretation": self.interpretation}

    def markdown(self):
        """The table in Markdown (docs)."""
        lines = ["| requirement | case | direction [deg] | value | limit | margin | result |",
                 "|---|---|---|---|---|---|---|"]
        for r in self.rows:
            lines.append(f"| {r['requirement']} | {r['case']} | {r['direction']:g} | "
                         f"{_num(r['value'])} {r['unit']} | {_num(r['limit'])} {r['unit']} | "
                         f"{_num(r['margin'])} {r['unit']} | "
                         f"{'pass' if r['passed'] else '**fail**'} |")
        return "\n".join(lines)


def _num(x):
    return "none" if x is None or not np.isfinite(x) else f"{x:.2f}"


_INTERPRETATION = (
    "FMVSS 209 S4.3(j): lock before 25 mm of webbing is withdrawn at 0.7 g reached within "
    "50 ms; no lock at vehicle tilts up to 15 deg. The sensor alone has no webbing: the "
    "25 mm is read as a time budget, the pendulum's tilt must reach the lock angle at most "
    "time_limit after the deceleration reaches 0.7 g (a step at t = 0, or a linear ramp "
    "over 50 ms) and stay beyond it while the deceleration is held. Static: the vehicle "
    "(the housing) tilted by 15 deg in each direction, the pendulum at rest hanging "
    "plumb, simulated: its tilt in the housing must stay below the lock angle.")


def _housing_tilt(tilt, direction):
    """``tilt_x, tilt_y`` (rad) turning the housing axis by ``tilt`` towards
    ``direction`` (rad) in vehicle axes, and the gimbal state hanging plumb."""
    sb = math.sin(tilt) * math.cos(direction)
    b = math.asin(sb)
    a = math.asin(-math.sin(tilt) * math.sin(direction) / math.cos(b))
    # gravity direction (pendulum axis, plumb) in housing axes: Ry(b)^T Rx(a)^T (0,0,-1)
    ca, sa, cb = math.cos(a), math.sin(a), math.cos(b)
    e_x1 = np.array([0.0, -sa, -ca])          # Rx(a)^T (0, 0, -1)
    e = np.array([cb * e_x1[0] - sb * e_x1[2], e_x1[1], sb * e_x1[0] + cb * e_x1[2]])
    q1 = math.atan2(e[1], -e[2])
    q2 = math.asin(max(-1.0, min(1.0, -e[0])))
    return a, b, [q1, q2, 0.0, 0.0]


def regulatory_check(constants=None, lock_angle=None, limit="penalty", decel_g=0.7,
                     rise_time=0.05, time_limit=0.05, hold=0.25, static_tilt=15.0,
                     directions=(0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0),
                     static_time=0.5, backend="c", rtol=1e-8, atol=1e-8):
    """Check the sensor against the FMVSS 209 sensitivity requirements.

    Parameters
    ----------
    constants : dict, optional
        Sensor parameters by name (SI units): ``m``, ``L``, ``I``, ``theta_lim``, ...
    lock_angle : float, optional
        rad; default the model's 20 deg.
    limit : {"penalty", "contact", "none"}
    decel_g : float
        Deceleration that must lock the retractor, g (0.7).
    rise_time : float
        Rise time of the ramped deceleration, s (0.05).
    time_limit : float
        Longest time from reaching ``decel_g`` to the lock, s (see the module text).
    hold : float
        How long ``decel_g`` is held after it is reached, s.
    static_tilt : float
        Static tilt that must not lock, deg (15).
    directions : sequence of float
        Directions of the decelerations and of the static tilts, deg.
    static_time : float
        Length of each static run, s.

    Returns
    -------
    RegulatoryCheck
    """
    from ..models import seatbelt_tilt
    from ..simulation import simulate
    angle = _lock_angle(lock_angle)
    event = _lock_event(angle)
    rows = []
    for shape, rise in (("step", 0.0), ("ramp", float(rise_time))):
        definition, model = seatbelt_study_model(shape, limit, constants, backend)
        y0 = definition.initial(model)
        for deg in directions:
            pulse = {"peak_g": float(decel_g), "direction": math.radians(deg)}
            if rise > 0:
                pulse["duration"] = rise
            m = model.with_constants(pulse)
            t_end = rise + hold
            res = simulate(m, (0.0, t_end), y0, events=[event], rtol=rtol, atol=atol)
            crossings = np.asarray(res.t_events[0], float)
            lock = float(crossings[0]) if crossings.size and res.success else math.nan
            after = (seatbelt_tilt(res.y[:2])[res.t >= (lock if np.isfinite(lock) else
                                                        t_end)])
            stays = bool(np.isfinite(lock) and crossings.size == 1 and np.all(after > angle
                                                                               - 1e-9))
            value = (lock - rise) * 1e3 if np.isfinite(lock) else math.nan
            margin = time_limit * 1e3 - value if np.isfinite(value) else math.nan
            case = "step" if rise == 0 else f"ramp {rise * 1e3:g} ms"
            rows.append(dict(requirement=f"lock at {decel_g:g} g (time after reaching it)",
                             case=case, direction=float(deg), value=value,
                             limit=time_limit * 1e3, unit="ms", margin=margin,
                             passed=bool(np.isfinite(margin) and margin >= 0 and stays),
                             stays_locked=stays))
    definition, model = seatbelt_study_model("step", limit, constants, backend)
    for deg in directions:
        a, b, y0 = _housing_tilt(math.radians(static_tilt), math.radians(deg))
        m = model.with_constants({"peak_g": 0.0, "tilt_x": a, "tilt_y": b})
        res = simulate(m, (0.0, static_time), y0, events=[event], rtol=rtol, atol=atol)
        tilt = float(np.max(seatbelt_tilt(res.y[:2]))) if res.success else math.nan
        margin = math.degrees(angle - tilt)
        rows.append(dict(requirement=f"no lock at a static tilt of {static_tilt:g} deg",
                         case="static", direction=float(deg), value=math.degrees(tilt),
                         limit=math.degrees(angle), unit="deg", margin=margin,
                         passed=bool(res.success and margin > 0
                                     and len(res.t_events[0]) == 0),
                         stays_locked=None))
    return RegulatoryCheck(rows=tuple(rows), passed=all(r["passed"] for r in rows),
                           lock_angle=angle,
                           steady_margin=math.degrees(math.atan(decel_g) - angle),
                           interpretation=_INTERPRETATION)


# ------------------------------------------------------------ study registry
def _numbers(study, name, text):
    """A comma-separated list of numbers from the command line (converted, not evaluated)."""
    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise ModelError(f"study {study}: option {name} must be numbers separated by "
                         f"commas, got {text!r}") from None
    if not values:
        raise ModelError(f"study {study}: option {name} needs at least one number")
    return values


def _lock_map_study(out, quiet, peak_g, duration, direction, roll_rate, shape, limit,
                    backend):
    grid = {name: _numbers("seatbelt-map", name, text)
            for name, text in (("peak_g", peak_g), ("duration", duration),
                               ("direction", direction), ("roll_rate", roll_rate))}
    result = seatbelt_lock_map(**grid, shape=shape, limit=limit, backend=backend,
                               progress=not quiet)
    table = result.table
    columns = ("peak [g]", "duration [s]", "direction [deg]", "roll rate [rad/s]",
               "locked", "lock time [s]", "run")
    rows = tuple((float(r.peak_g), float(r.duration), float(r.direction),
                  float(r.roll_rate), bool(r.locked),
                  float(r.lock_time) if r.locked else None,
                  "ok" if r.success else f"failed: {r.message}") for r in table.itertuples())
    figures = []
    if out is not None:
        figures.append(result.save_figure(out / "seatbelt-map.png"))
    locked = [r for r in rows if r[4]]
    summary = (f"{len(locked)} of {len(rows)} pulses lock the sensor (lock angle "
               f"{math.degrees(result.lock_angle):.1f} deg)")
    if locked:
        first = min(locked, key=lambda r: r[5])
        summary += (f"; earliest lock {1e3 * first[5]:.2f} ms at {first[0]:g} g, "
                    f"{1e3 * first[1]:g} ms, {first[2]:g} deg")
    failed = table[~table.success]
    if len(failed):
        summary += (f"; {len(failed)} of {len(rows)} runs failed and say nothing about "
                    f"locking (first: {failed.message.iloc[0]})")
    return dict(tables={"lock_map": (columns, rows)}, figures=figures, summary=summary,
                data={"lock_times": {r[:4]: r[5] for r in rows}})


def _regulatory_study(out, quiet, lock_angle_deg, limit, backend):
    check = regulatory_check(lock_angle=math.radians(lock_angle_deg), limit=limit,
                             backend=backend)
    columns = ("requirement", "case", "direction [deg]", "value", "limit", "margin", "unit",
               "passed")
    rows = tuple((r["requirement"], r["case"], r["direction"], r["value"], r["limit"],
                  r["margin"], r["unit"], r["passed"]) for r in check.rows)
    return dict(tables={"regulatory": (columns, rows)}, figures=[], summary=check.text(),
                data={"passed": check.passed})


register_study("seatbelt-map", _lock_map_study, {
    "peak_g": StudyOption(str, "2,5,10,20,30", "pulse peaks, g (comma list)"),
    "duration": StudyOption(str, "0.04,0.06,0.08,0.1,0.12", "pulse durations, s"),
    "direction": StudyOption(str, "0,30,45,90", "pulse directions from the vehicle's x, deg"),
    "roll_rate": StudyOption(str, "0", "roll rates (rollover), rad/s"),
    "shape": StudyOption(str, "halfsine", "pulse shape", PULSE_SHAPES),
    "limit": StudyOption(str, "penalty", "housing limit law", ("penalty", "contact", "none")),
    "backend": StudyOption(str, "c", "numerical backend", ("numpy", "c")),
}, "lock time of the seat-belt sensor over pulse peak, duration, direction and roll rate")

register_study("seatbelt-regulatory", _regulatory_study, {
    "lock_angle_deg": StudyOption(float, round(math.degrees(_lock_angle(None)), 6),
                                  "tilt at which the pawl engages, deg"),
    "limit": StudyOption(str, "penalty", "housing limit law", ("penalty", "contact", "none")),
    "backend": StudyOption(str, "c", "numerical backend", ("numpy", "c")),
}, "FMVSS 209 sensitivity: lock at 0.7 g within 50 ms, no lock at a static 15 deg tilt")
