"""Analytic crash pulses: acceleration, velocity change and displacement in closed form.

A pulse is a scalar acceleration history a(t) >= 0 (m/s^2) that starts at t = 0 and
ends at t = duration; it is zero outside.  Its velocity change dv(t) = int_0^t a and
displacement s(t) = int_0^t dv are exact: each shape is a list of pieces (a SymPy
expression in t on [t_start, t_end)), integrated piece by piece with SymPy and
continued as constant velocity after the end.  Peaks are given in g (standard gravity
g = 9.80665 m/s^2); everything returned is in SI units (m/s^2, m/s, m, s).
:class:`~kanedyn.VehicleMotion` gives the pulse a direction.
"""

from __future__ import annotations

import numpy as np
import sympy as sm

from ..._errors import ModelError
from ..._expressions import as_expression

__all__ = ["G0", "CrashPulse", "HalfSinePulse", "HaversinePulse", "TrapezoidPulse",
           "pulse_from_delta_v"]

#: standard gravity, m/s^2 (the unit of peaks given in g)
G0 = 9.80665

_T = sm.Symbol("t", real=True)


def _positive(value, name, what):
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{what}: {name} must be a number, not {value!r}") from None
    if not (np.isfinite(value) and value > 0):
        raise ModelError(f"{what}: {name} must be positive and finite, not {value!r}")
    return value


class CrashPulse:
    """A pulse a(t) made of pieces, with exact velocity change and displacement.

    Parameters
    ----------
    pieces : sequence of (float, float, sympy.Expr)
        ``(t_start, t_end, a)``: the acceleration on ``[t_start, t_end)``, s and
        m/s^2, as an expression in :attr:`t`; contiguous, the first starting at 0.
    name : str
        Shape name used in messages and ``repr``.

    Attributes
    ----------
    t : sympy.Symbol
        The time symbol of the expressions (real).
    duration : float
        End of the last piece, s.
    """

    t = _T

    def __init__(self, pieces, name="pulse"):
        self.name = name
        pieces = [(float(a), float(b), as_expression(e, f"{name}: piece {k}"))
                  for k, (a, b, e) in enumerate(pieces)]
        if not pieces or pieces[0][0] != 0.0:
            raise ModelError(f"{name}: the pieces must start at t = 0")
        for (a0, b0, _), (a1, _, _) in zip(pieces, pieces[1:]):
            if b0 != a1:
                raise ModelError(f"{name}: pieces [{a0}, {b0}) and [{a1}, ...) do not join")
        self.pieces = tuple(pieces)
        self.duration = pieces[-1][1]
        t = _T
        acc, vel, disp = [], [], []
        v0 = s0 = sm.S.Zero
        for a, b, expr in pieces:
            v = v0 + sm.integrate(expr, (t, a, t))
            s = s0 + sm.integrate(v, (t, a, t))
            acc.append((expr, t < b))
            vel.append((v, t < b))
            disp.append((s, t < b))
            v0, s0 = v.subs(t, b), s.subs(t, b)
        self._dv_total = float(v0)
        end = self.duration
        self.acceleration_expr = sm.Piecewise((0, t < 0), *acc, (0, True))
        self.velocity_expr = sm.Piecewise((0, t < 0), *vel, (v0, True))
        self.displacement_expr = sm.Piecewise((0, t < 0), *disp,
                                              (s0 + v0 * (t - end), True))
        self._num = [sm.lambdify(t, e, "numpy") for e in
                     (self.acceleration_expr, self.velocity_expr, self.displacement_expr)]

    # ------------------------------------------------------------ numbers
    def _eval(self, i, t):
        t = np.asarray(t, dtype=float)
        out = np.asarray(self._num[i](t), dtype=float)
        return np.broadcast_to(out, t.shape).copy() if out.shape != t.shape else out

    def acceleration(self, t):
        """a(t), m/s^2 (array like ``t``)."""
        return self._eval(0, t)

    def velocity_change(self, t=None):
        """dv(t) = int_0^t a, m/s; the whole pulse's when ``t`` is None."""
        return self._dv_total if t is None else self._eval(1, t)

    def displacement(self, t):
        """s(t) = int_0^t dv, m (array like ``t``)."""
        return self._eval(2, t)

    @property
    def delta_v(self):
        """Velocity change of the whole pulse, m/s."""
        return self._dv_total

    @property
    def peak(self):
        """Largest acceleration, m/s^2 (from a dense sampling of the pieces)."""
        t = np.concatenate([np.linspace(a, b, 2001) for a, b, _ in self.pieces])
        return float(np.max(np.abs(self.acceleration(np.minimum(t, self.duration
                                                                 * (1 - 1e-15))))))

    @property
    def peak_g(self):
        """Largest acceleration in g (9.80665 m/s^2)."""
        return self.peak / G0

    def expressions(self):
        """``(a, dv, s)``: SymPy Piecewise expressions in :attr:`t` (SI units)."""
        return self.acceleration_expr, self.velocity_expr, self.displacement_expr

    def __repr__(self):
        return (f"{type(self).__name__}(peak {self.peak_g:.4g} g, duration "
                f"{self.duration:.4g} s, delta_v {self.delta_v:.6g} m/s)")


class HalfSinePulse(CrashPulse):
    """a(t) = A sin(pi t / T) on [0, T]; dv = 2 A T / pi.

    Parameters
    ----------
    peak_g : float
        A in g (9.80665 m/s^2).
    duration : float
        T, s.
    """

    def __init__(self, peak_g, duration):
        A = _positive(peak_g, "peak_g", "half-sine pulse") * G0
        T = _positive(duration, "duration", "half-sine pulse")
        super().__init__([(0.0, T, A * sm.sin(sm.pi * _T / T))], "half-sine")


class HaversinePulse(CrashPulse):
    """a(t) = A (1 - cos(2 pi t / T)) / 2 on [0, T]; dv = A T / 2.

    Parameters
    ----------
    peak_g : float
        A in g (9.80665 m/s^2).
    duration : float
        T, s.
    """

    def __init__(self, peak_g, duration):
        A = _positive(peak_g, "peak_g", "haversine pulse") * G0
        T = _positive(duration, "duration", "haversine pulse")
        super().__init__([(0.0, T, A * (1 - sm.cos(2 * sm.pi * _T / T)) / 2)], "haversine")


class TrapezoidPulse(CrashPulse):
    """Linear rise to A, hold, linear fall; dv = A (rise/2 + hold + fall/2).

    Parameters
    ----------
    peak_g : float
        A in g (9.80665 m/s^2).
    rise, hold, fall : float
        Durations of the three parts, s (``hold`` may be 0).
    """

    def __init__(self, peak_g, rise, hold, fall):
        what = "trapezoid pulse"
        A = _positive(peak_g, "peak_g", what) * G0
        r = _positive(rise, "rise", what)
        f = _positive(fall, "fall", what)
        h = float(hold)
        if not (np.isfinite(h) and h >= 0):
            raise ModelError(f"{what}: hold must be >= 0 and finite, not {hold!r}")
        t = _T
        pieces = [(0.0, r, A * t / r)]
        if h > 0:
            pieces.append((r, r + h, sm.Float(A)))
        pieces.append((r + h, r + h + f, A * (r + h + f - t) / f))
        super().__init__(pieces, "trapezoid")


def pulse_from_delta_v(delta_v, duration, shape="half-sine"):
    """The pulse of the given shape with velocity change ``delta_v`` over ``duration``.

    Parameters
    ----------
    delta_v : float
        Velocity change, m/s (e.g. 48 km/h = 13.333 m/s).
    duration : float
        T, s.
    shape : {"half-sine", "haversine"}
        Half-sine: peak A = pi dv / (2 T); haversine: A = 2 dv / T.

    Returns
    -------
    CrashPulse
    """
    dv = _positive(delta_v, "delta_v", "pulse from delta_v")
    T = _positive(duration, "duration", "pulse from delta_v")
    if shape == "half-sine":
        return HalfSinePulse(np.pi * dv / (2 * T) / G0, T)
    if shape == "haversine":
        return HaversinePulse(2 * dv / T / G0, T)
    raise ModelError(f"pulse from delta_v: unknown shape {shape!r}; use 'half-sine' "
                     "or 'haversine'")
