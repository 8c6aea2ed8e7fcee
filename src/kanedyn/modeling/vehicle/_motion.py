"""Prescribed vehicle motion: a moving reference frame driven by a pulse or a record.

The vehicle frame V is placed in the inertial frame N by six specified dynamic
symbols: the origin's position ``x, y, z`` (m, N components) and body-fixed
Z-Y-X angles ``yaw, pitch, roll`` (rad; ``V.orient_body_fixed(N, (yaw, pitch, roll),
"ZYX")``).  kanedyn's kinematics differentiate them (velocity and acceleration of
the origin, angular velocity and acceleration of V); :meth:`VehicleMotion.specified`
gives each symbol and its first two time derivatives as functions of t.

Two sources:

* :meth:`VehicleMotion.from_pulse`: an analytic pulse along a direction fixed in N
  (the vehicle's axes at t = 0), with an optional constant roll rate about the
  vehicle's x axis; everything is in closed form, also as SymPy expressions
  (``specified(exact=True)``).
* :meth:`VehicleMotion.from_csv`: a record of accelerations and angular rates in
  vehicle axes (see :func:`read_pulse_csv`), optionally CFC filtered, interpolated by
  C2 cubic splines (:class:`scipy.interpolate.CubicSpline`, not-a-knot ends).  Without
  rotation the origin's velocity and position are the spline's exact antiderivatives.
  With rotation the angles, the N velocity and the position are integrated together
  (``solve_ivp`` DOP853, rtol 1e-12, steps no longer than the sampling interval,
  dense output): yaw', pitch', roll' are then computed from the angles and the
  interpolated rates (so V's angular velocity equals the record's rates), the angles'
  second derivatives from the spline's derivative, and the origin's acceleration in
  N is R(angles) a_V(t) exactly.  A record is usable on its time span only.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import sympy as sm
from sympy.physics.mechanics import Point, ReferenceFrame, dynamicsymbols

from ..._errors import ModelError
from .._piecewise import PiecewisePolynomial, tabulate
from ._filters import cfc_filter, parse_cfc
from ._pulses import G0, CrashPulse
from ._series import read_pulse_csv

__all__ = ["VehicleMotion", "MotionCheck"]

_NAMES = ("x", "y", "z", "yaw", "pitch", "roll")
#: the motion's parts (kind, order) in the order of its tabulated rows
_KEYS = tuple((kind, order) for kind in ("position", "angles") for order in range(3))
_MAX_ORDER = 2


@lru_cache(maxsize=1)
def _zyx_kinematics():
    """Numeric functions of the Z-Y-X angle kinematics, derived once with SymPy.

    Returns ``(rates, second, dcm)``: angle rates from (angles, body rates), angle
    second derivatives from (angles, body rates, their derivatives), and the matrix
    taking V components to N components.
    """
    t = dynamicsymbols._t
    ang = dynamicsymbols("a0:3")
    A = ReferenceFrame("A")
    B = ReferenceFrame("B")
    B.orient_body_fixed(A, tuple(ang), "ZYX")
    w = B.ang_vel_in(A)
    M = sm.Matrix([[w.dot(e).diff(d) for d in (a.diff(t) for a in ang)]
                   for e in (B.x, B.y, B.z)])  # omega_B = M angles'
    a_s = sm.symbols("a0:3")
    w_s = sm.symbols("w0:3")
    wd_s = sm.symbols("wd0:3")
    rates = sm.simplify(M.inv()) * sm.Matrix(w_s)  # angles' = B(angles) omega
    to_plain = dict(zip(ang, a_s))
    rates = rates.xreplace(to_plain)
    second = (rates.jacobian(a_s) * rates + rates.jacobian(w_s) * sm.Matrix(wd_s))
    dcm = A.dcm(B).xreplace(to_plain)
    f_rates = sm.lambdify([a_s, w_s], rates, "numpy")
    f_second = sm.lambdify([a_s, w_s, wd_s], second, "numpy")
    f_dcm = sm.lambdify([a_s], dcm, "numpy")
    return f_rates, f_second, f_dcm


def _stack(f, *args):
    """Evaluate a lambdified matrix on arrays: (rows, n) for a column, else (rows, cols, n)."""
    n = np.shape(args[0][0])
    out = np.array([[np.broadcast_to(np.asarray(c, float), n) for c in row]
                    for row in f(*args)])
    return out[:, 0] if out.shape[1] == 1 else out


@dataclass(frozen=True)
class MotionCheck:
    """Measured against expected velocity change (m/s) and peak acceleration (g)."""

    delta_v: float
    delta_v_expected: float | None
    peak_g: float
    peak_g_expected: float | None
    rtol: float

    @property
    def passed(self):
        """True when every expected value given is met to ``rtol``."""
        ok = True
        for got, want in ((self.delta_v, self.delta_v_expected),
                          (self.peak_g, self.peak_g_expected)):
            if want is not None:
                ok &= abs(got - want) <= self.rtol * abs(want)
        return bool(ok)


def _names(source, key):
    """Names of the three components of ``(kind, order)`` in messages."""
    kind, order = key
    names = _NAMES[:3] if kind == "position" else _NAMES[3:]
    return [f"{source}: {n}{chr(39) * order}" for n in names]


def _record_tables(splines, v0, t0, source):
    """The inputs of a record without rotation from its splines: position,
    velocity and acceleration (``splines``, :class:`scipy.interpolate.PPoly` of
    shape (3,)) plus the initial velocity ``v0`` (m/s) from ``t0``, as piecewise
    polynomials with the splines' breaks; the angles zero."""
    x = splines[0].x
    tables = {}
    for order, spline in enumerate(splines):
        c = np.moveaxis(np.array(spline.c, float), 0, -1)  # (n, 3, k), highest power first
        if order == 0:  # + v0 (t - t0) = v0 (t - x_i) + v0 (x_i - t0)
            c[..., -2] += v0
            c[..., -1] += v0 * (x[:-1, None] - t0)
        elif order == 1:
            c[..., -1] += v0
        tables["position", order] = [PiecewisePolynomial(x, c[:, j], name)
                                     for j, name in enumerate(
                                         _names(source, ("position", order)))]
        zero = np.zeros((1, 1))
        tables["angles", order] = [PiecewisePolynomial(x[[0, -1]], zero, name)
                                   for name in _names(source, ("angles", order))]
    return tables


class VehicleMotion:
    """Prescribed motion of a vehicle frame; build it with a ``from_*`` method.

    Attributes
    ----------
    t_range : (float, float)
        Times where the motion is defined, s (infinite for a pulse).
    source : str
        The pulse or the file it came from.
    symbols : tuple of dynamicsymbols or None
        ``(x, y, z, yaw, pitch, roll)`` of the last :meth:`moving_frame`.
    """

    def __init__(self, funcs, t_range, source, exact=None, pulse=None, breaks=None,
                 tables=None):
        self._funcs = funcs  # (kind, order) -> f(t array) -> (3, n)
        self.t_range = t_range
        self.source = source
        self._exact = exact  # tuple of 6 SymPy expressions in dynamicsymbols._t, or None
        self.pulse = pulse
        self.symbols = None
        # the inputs as piecewise polynomials: given (a record's splines), or
        # tabulated between these breaks when first asked for; breaks: times, or
        # (times, f) with f(t) giving the rows of all _KEYS at once
        self._breaks = breaks
        self._tables = tables

    # --------------------------------------------------------------- builders
    @classmethod
    def from_pulse(cls, pulse, direction=(-1.0, 0.0, 0.0), roll_rate=0.0,
                   initial_velocity=(0.0, 0.0, 0.0)):
        """Motion under an analytic pulse along a direction fixed in N.

        Parameters
        ----------
        pulse : CrashPulse
            E.g. ``kd.vehicle.HalfSinePulse(20, 0.1)`` (peak in g, duration in s).
        direction : float or (3,) array_like
            Direction of the vehicle's acceleration in N (= vehicle axes at t = 0):
            a vector (normalized here), or an angle in degrees: the acceleration
            points along -(cos angle, sin angle, 0), so 0 is a frontal impact
            (deceleration along -x) and 30 an oblique one.
        roll_rate : float
            Constant roll rate about the vehicle's x axis, rad/s (roll = roll_rate t).
        initial_velocity : (3,) array_like
            Velocity of the origin before the pulse, m/s, N components.
        """
        if not isinstance(pulse, CrashPulse):
            raise ModelError(f"from_pulse: {pulse!r} is not a pulse (kd.vehicle.HalfSinePulse, "
                             "kd.vehicle.HaversinePulse, kd.vehicle.TrapezoidPulse, "
                             "kd.vehicle.pulse_from_delta_v)")
        if np.ndim(direction) == 0:
            ang = np.radians(float(direction))
            e = -np.array([np.cos(ang), np.sin(ang), 0.0])
        else:
            e = np.asarray(direction, float).reshape(-1)
            if e.shape != (3,) or not np.all(np.isfinite(e)) or np.linalg.norm(e) == 0:
                raise ModelError(f"from_pulse: direction {direction!r} must be an angle in "
                                 "degrees or a nonzero 3-vector")
            e = e / np.linalg.norm(e)
        v0 = np.asarray(initial_velocity, float).reshape(3)
        p = float(roll_rate)
        col = e[:, None]

        def zeros(t):
            return np.zeros((3,) + np.shape(t))

        funcs = {
            ("position", 0): lambda t: v0[:, None] * np.atleast_1d(t) + col * np.atleast_1d(
                pulse.displacement(t)),
            ("position", 1): lambda t: v0[:, None] + col * np.atleast_1d(
                pulse.velocity_change(t)),
            ("position", 2): lambda t: col * np.atleast_1d(pulse.acceleration(t)),
            ("angles", 0): lambda t: np.array([0 * np.atleast_1d(t), 0 * np.atleast_1d(t),
                                               p * np.atleast_1d(t)]),
            ("angles", 1): lambda t: np.array([0, 0, p])[:, None] + zeros(np.atleast_1d(t)),
            ("angles", 2): lambda t: zeros(np.atleast_1d(t)),
        }
        tt = dynamicsymbols._t
        _, _, s = pulse.expressions()
        s = s.xreplace({pulse.t: tt})
        exact = tuple(sm.Float(v0[i]) * tt + sm.Float(e[i]) * s for i in range(3)) + (
            sm.S.Zero, sm.S.Zero, sm.Float(p) * tt if p else sm.S.Zero)
        # polynomials before the pulse and after it (degree <= 1): extrapolated exactly
        ends = sorted({0.0, pulse.duration} | {b for _, b, _ in pulse.pieces})
        breaks = [-1.0] + ends + [pulse.duration + 1.0]
        motion = cls(funcs, (-np.inf, np.inf), repr(pulse), exact, pulse, breaks=breaks)
        motion._window = (0.0, pulse.duration)
        return motion

    @classmethod
    def from_series(cls, series, filter=None, initial_velocity=(0.0, 0.0, 0.0)):
        """Motion from a :class:`PulseSeries` (see :meth:`from_csv`)."""
        src = series.source
        t = series.t
        acc, rates = series.acceleration, series.angular_rate
        if filter is not None:
            cfc = parse_cfc(filter, f"{src}: filter")
            if not series.uniform:
                raise ModelError(f"{src}: column 't': CFC filtering needs a constant "
                                 "sampling interval; resample the record first")
            acc = cfc_filter(acc, series.dt, cfc, src)
            rates = cfc_filter(rates, series.dt, cfc, src)
        from scipy.interpolate import CubicSpline  # when first needed (start-up time)
        a_sp = CubicSpline(t, acc, axis=0)
        v0 = np.asarray(initial_velocity, float).reshape(3)
        t0 = t[0]
        tables = breaks = None
        if not np.any(rates):
            v_sp = a_sp.antiderivative(1)
            s_sp = a_sp.antiderivative(2)
            tables = _record_tables((s_sp, v_sp, a_sp), v0, t0, src)

            def zeros(tq):
                return np.zeros((3,) + np.shape(np.atleast_1d(tq)))

            funcs = {
                ("position", 0): lambda tq: (v0[:, None] * (np.atleast_1d(tq) - t0)
                                             + s_sp(np.atleast_1d(tq)).T),
                ("position", 1): lambda tq: v0[:, None] + v_sp(np.atleast_1d(tq)).T,
                ("position", 2): lambda tq: a_sp(np.atleast_1d(tq)).T,
                ("angles", 0): zeros, ("angles", 1): zeros, ("angles", 2): zeros,
            }
        else:
            funcs, rows, steps = cls._rotating(series, a_sp, CubicSpline(t, rates, axis=0),
                                               v0)
            breaks = (np.union1d(t, steps), rows)
        motion = cls(funcs, (float(t[0]), float(t[-1])), src, breaks=breaks, tables=tables)
        motion._window = motion.t_range
        motion._samples = len(t)
        return motion

    @classmethod
    def from_csv(cls, path, filter=None, initial_velocity=(0.0, 0.0, 0.0)):
        """Motion from a CSV record of vehicle accelerations and angular rates.

        Parameters
        ----------
        path : str or pathlib.Path
            The file (format: :func:`kanedyn.vehicle.read_pulse_csv`).
        filter : None or str or int
            None (no filtering) or a channel frequency class ``"CFC60"``,
            ``"CFC180"``, ``"CFC600"``, ``"CFC1000"`` (SAE J211/1), applied to all
            channels before interpolation.
        initial_velocity : (3,) array_like
            Velocity of the origin at the record's first time, m/s, N components.
        """
        return cls.from_series(read_pulse_csv(path), filter, initial_velocity)

    @staticmethod
    def _rotating(series, a_sp, w_sp, v0):
        f_rates, f_second, f_dcm = _zyx_kinematics()
        dw_sp = w_sp.derivative()
        t = series.t

        def rhs(tq, y):
            ang = y[:3]
            w = w_sp(tq)
            da = np.asarray(f_rates(ang, w), float).reshape(3)
            acc = np.asarray(f_dcm(ang), float) @ a_sp(tq)
            return np.concatenate([da, acc, y[3:6]])

        y0 = np.concatenate([np.zeros(3), v0, np.zeros(3)])
        from scipy.integrate import solve_ivp
        sol = solve_ivp(rhs, (t[0], t[-1]), y0, method="DOP853", rtol=1e-12,
                        atol=1e-12, max_step=float(np.min(np.diff(t))), dense_output=True)
        if not sol.success:
            raise ModelError(f"{series.source}: integrating the orientation failed "
                             f"({sol.message})")
        pitch = np.max(np.abs(sol.y[1]))
        if pitch > np.radians(85):
            raise ModelError(f"{series.source}: the pitch angle reaches "
                             f"{np.degrees(pitch):.1f} deg; the Z-Y-X angles of the "
                             "vehicle frame are singular at 90 deg")
        dense = sol.sol

        def state(tq):
            return dense(np.atleast_1d(tq))

        def ang(tq):
            return state(tq)[:3]

        def ang_rate(tq):
            tq = np.atleast_1d(tq)
            return _stack(f_rates, ang(tq), w_sp(tq).T)

        def ang_acc(tq):
            tq = np.atleast_1d(tq)
            return _stack(f_second, ang(tq), w_sp(tq).T, dw_sp(tq).T)

        def acc(tq):
            tq = np.atleast_1d(tq)
            R = _stack(f_dcm, ang(tq))  # (3, 3, n)
            return np.einsum("ijn,nj->in", R, a_sp(tq))

        def rows(tq):  # all of them, the dense output evaluated once (tabulation)
            tq = np.atleast_1d(tq)
            y = state(tq)
            a, w = y[:3], w_sp(tq).T
            R = _stack(f_dcm, a)
            return np.concatenate([y[6:9], y[3:6], np.einsum("ijn,nj->in", R, a_sp(tq)),
                                   a, _stack(f_rates, a, w), _stack(f_second, a, w,
                                                                    dw_sp(tq).T)])

        return {("position", 0): lambda tq: state(tq)[6:9],
                ("position", 1): lambda tq: state(tq)[3:6],
                ("position", 2): acc,
                ("angles", 0): ang, ("angles", 1): ang_rate,
                ("angles", 2): ang_acc}, rows, dense.ts

    # ------------------------------------------------------------ evaluation
    def evaluate(self, kind, order, t):
        """Values of ``kind`` ("position" or "angles") differentiated ``order`` times.

        Position: origin in N, m (order 1: m/s, 2: m/s^2).  Angles: yaw, pitch,
        roll, rad (and rad/s, rad/s^2).  Returns shape (3,) for scalar ``t``, else
        (3, n).
        """
        lo, hi = self.t_range
        tq = np.asarray(t, float)
        span = hi - lo if np.isfinite(hi - lo) else 0.0
        if np.any(tq < lo - 1e-9 * span) or np.any(tq > hi + 1e-9 * span):
            raise ModelError(f"{self.source}: the motion is defined for {lo:g} s <= t <= "
                             f"{hi:g} s only (asked at t = {np.min(tq):g} .. "
                             f"{np.max(tq):g} s)")
        out = np.asarray(self._funcs[kind, order](np.clip(tq, lo, hi)), float)
        return out[:, 0] if tq.ndim == 0 else out

    def velocity_change(self):
        """Change of the origin's velocity over the pulse or record, m/s (N, shape (3,))."""
        a, b = self._window
        return self.evaluate("position", 1, b) - self.evaluate("position", 1, a)

    def peak_acceleration(self):
        """Largest magnitude of the origin's acceleration, m/s^2.

        A pulse gives its own peak; a record its spline's on a grid ten times finer
        than the samples.
        """
        if self.pulse is not None:
            return self.pulse.peak
        a, b = self._window
        grid = np.linspace(a, b, min(10 * self._samples + 1, 200001))
        return float(np.max(np.linalg.norm(self.evaluate("position", 2, grid), axis=0)))

    def check(self, delta_v=None, peak_g=None, rtol=1e-3):
        """Compare the velocity change (m/s) and peak (g) with the values expected.

        Returns
        -------
        MotionCheck
            ``.passed`` is True when both given values are met to ``rtol``.
        """
        return MotionCheck(float(np.linalg.norm(self.velocity_change())), delta_v,
                           self.peak_acceleration() / G0, peak_g, float(rtol))

    # ------------------------------------------------------------ the frame
    def moving_frame(self, N, origin, name="V"):
        """The vehicle frame and its origin, written with specified dynamic symbols.

        Parameters
        ----------
        N : sympy.physics.mechanics.ReferenceFrame
            The inertial frame.
        origin : sympy.physics.mechanics.Point
            A point fixed in N: where the vehicle origin is at x = y = z = 0.
        name : str
            Name of the frame; the symbols are ``{name}_x`` ... ``{name}_roll``.

        Returns
        -------
        (ReferenceFrame, Point)
            V oriented by body-fixed Z-Y-X angles (yaw, pitch, roll) and V's origin
            with its velocity in N set.
        """
        if not isinstance(N, ReferenceFrame) or not isinstance(origin, Point):
            raise ModelError("moving_frame(N, origin): N must be a ReferenceFrame and "
                             "origin a Point")
        syms = dynamicsymbols(" ".join(f"{name}_{n}" for n in _NAMES))
        x, y, z, yaw, pitch, roll = syms
        t = dynamicsymbols._t
        V = ReferenceFrame(name)
        V.orient_body_fixed(N, (yaw, pitch, roll), "ZYX")
        O = origin.locatenew(f"{name}_origin", x * N.x + y * N.y + z * N.z)
        O.set_vel(N, x.diff(t) * N.x + y.diff(t) * N.y + z.diff(t) * N.z)
        self.symbols = tuple(syms)
        return V, O

    def specified(self, eom=None, exact=False):
        """Values for ``eom.numeric(specified=...)``.

        Parameters
        ----------
        eom : EquationsOfMotion, optional
            When given, only the inputs these equations need are returned (kanedyn
            refuses inputs a model does not know).
        exact : bool
            Analytic pulses only: SymPy expressions in t for the six symbols (kanedyn
            differentiates them exactly) instead of callables.

        Returns
        -------
        dict
            ``{symbol or Derivative(symbol, (t, k)): callable of t (float) or
            expression}``, k = 1, 2.
        """
        if self.symbols is None:
            raise ModelError("specified(): call moving_frame(N, origin) first; it "
                             "creates the symbols")
        t = dynamicsymbols._t
        needed = None if eom is None else set(eom.specified)
        if needed is not None:
            for key in needed:
                base = key.expr if isinstance(key, sm.Derivative) else key
                order = len(key.variables) if isinstance(key, sm.Derivative) else 0
                if base in self.symbols and order > _MAX_ORDER:
                    raise ModelError(f"the equations need {key}, a derivative of order "
                                     f"{order}; the vehicle motion gives orders up to "
                                     f"{_MAX_ORDER}")
        if exact:
            if self._exact is None:
                raise ModelError(f"specified(exact=True): {self.source} is a record, "
                                 "not an analytic pulse; use callables (exact=False)")
            out = {}
            for s, expr in zip(self.symbols, self._exact):
                keys = [s] + [s.diff(t, k) for k in range(1, _MAX_ORDER + 1)]
                if needed is None or any(k in needed for k in keys):
                    out[s] = expr
            return out
        out = {}
        tables = self.piecewise()
        for i, s in enumerate(self.symbols):
            kind, index = ("position", i) if i < 3 else ("angles", i - 3)
            for order in range(_MAX_ORDER + 1):
                key = s if order == 0 else sm.Derivative(s, (t, order))
                if needed is None or key in needed:
                    out[key] = tables[kind, order][index]
        return out

    def piecewise(self):
        """The motion as piecewise polynomials of t, which a compiled model evaluates
        in C (:class:`~kanedyn.modeling.PiecewisePolynomial`).

        A record without rotation: its splines' own pieces (exact).  A pulse, and a
        record with rotation: tabulated from the closed form, or from the integrated
        angles and the kinematics, within 1e-13 of each component's largest
        magnitude (:func:`~kanedyn.modeling.tabulate`); a pulse's are extrapolated
        (the motion is a polynomial of degree 1 before and after it).

        Returns
        -------
        dict
            ``{(kind, order): [x, y, z] or [yaw, pitch, roll]}``, as
            :meth:`evaluate`'s ``kind`` and ``order``.
        """
        if self._tables is None:
            breaks, rows = (self._breaks if isinstance(self._breaks, tuple) else
                            (self._breaks, None))
            if rows is None:
                def rows(t):
                    return np.concatenate([self._funcs[key](t) for key in _KEYS])
            names = [n for key in _KEYS for n in _names(self.source, key)]
            found = tabulate(rows, breaks, 3 * len(_KEYS), names,
                             extrapolate=self.pulse is not None)
            self._tables = {key: found[3 * i:3 * i + 3] for i, key in enumerate(_KEYS)}
        return self._tables

    def __repr__(self):
        return f"VehicleMotion({self.source}, t in {self.t_range})"
