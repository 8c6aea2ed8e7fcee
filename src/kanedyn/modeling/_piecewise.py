r"""Specified inputs given as data: piecewise polynomials of time.

A :class:`PiecewisePolynomial` is a function of t held as breakpoints and, per
interval, the coefficients of a polynomial in the time since the interval's start:

.. math:: f(t) = \sum_{j=0}^{k-1} c_{i,j}\,(t - x_i)^{k-1-j},\qquad x_i \le t < x_{i+1}

(highest power first, as :class:`scipy.interpolate.PPoly` per interval).  Given as
a specified input of a C model (``eom.numeric(specified={s: pp}, backend="c")``) it
is evaluated inside the compiled module (Horner's rule), so a run calls no Python
for it; the numpy backend calls it as a function of t.  Both evaluate the same
coefficients the same way.

:func:`tabulate` builds one from a smooth function (a closed-form pulse, the
kinematics of a rotating record) with a checked error: on every interval the
lowest degree up to :data:`MAX_DEGREE` whose interpolant, at points other than its
nodes, is within ``rtol`` times the function's largest magnitude, else the interval
is halved.
"""

from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass

import numpy as np

from .._errors import ModelError

__all__ = ["PiecewisePolynomial", "tabulate", "MAX_DEGREE", "RANGE_TOLERANCE"]

#: highest degree :func:`tabulate` tries on an interval before halving it
MAX_DEGREE = 9
#: a function that does not extrapolate is defined up to this fraction of its span
#: beyond either end (times from a run's arithmetic)
RANGE_TOLERANCE = 1e-9
_DEGREES = (0, 1, 3, 5, 7, MAX_DEGREE)
_MAX_HALVINGS = 40


@dataclass(frozen=True, eq=False)
class PiecewisePolynomial:
    """A function of time held as polynomial pieces (see the module text).

    Parameters
    ----------
    breaks : array_like, shape (n + 1,)
        Strictly increasing times, s.
    coefficients : array_like, shape (n, k)
        Row i: the coefficients of piece i in powers of ``t - breaks[i]``, highest
        first (units of the value per s^power).
    name : str
        What it is (used in messages): e.g. ``"crash.csv: x''"``.
    extrapolate : bool
        Outside ``[breaks[0], breaks[-1]]`` continue the end pieces (True) or
        refuse the time (False: a record is defined on its time span only).
    """

    breaks: np.ndarray
    coefficients: np.ndarray
    name: str = "piecewise polynomial"
    extrapolate: bool = False

    def __post_init__(self):
        x = np.array(self.breaks, dtype=float).reshape(-1)
        c = np.array(self.coefficients, dtype=float)
        if c.ndim == 1:
            c = c[:, None]
        if x.size < 2 or c.ndim != 2 or c.shape[0] != x.size - 1 or c.shape[1] < 1:
            raise ModelError(f"{self.name}: a piecewise polynomial needs n + 1 breaks and "
                             f"(n, k) coefficients, got {x.size} breaks and coefficients "
                             f"of shape {c.shape}")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(c))):
            raise ModelError(f"{self.name}: breaks and coefficients must be finite")
        if np.any(np.diff(x) <= 0):
            raise ModelError(f"{self.name}: the breaks must increase strictly")
        x.setflags(write=False)
        c.setflags(write=False)
        object.__setattr__(self, "breaks", x)
        object.__setattr__(self, "coefficients", c)
        object.__setattr__(self, "extrapolate", bool(self.extrapolate))
        # one time at a time (a run of the numpy backend asks for one per step):
        # Python floats, without NumPy's per-call cost on scalars
        object.__setattr__(self, "_scalar", (x.tolist(), c.tolist(), self.limits()))

    @property
    def t_range(self):
        """``(first, last)`` break, s."""
        return float(self.breaks[0]), float(self.breaks[-1])

    def limits(self):
        """``(lo, hi)``: the times accepted, s (infinite when it extrapolates)."""
        if self.extrapolate:
            return -math.inf, math.inf
        lo, hi = self.t_range
        margin = RANGE_TOLERANCE * (hi - lo)
        return lo - margin, hi + margin

    def __call__(self, t):
        """Value at ``t`` (float for a scalar, else an array of the shape of ``t``)."""
        if isinstance(t, (float, int, np.floating, np.integer)):
            return self._at(float(t))
        tq = np.asarray(t, dtype=float)
        lo, hi = self.limits()
        if np.any(tq < lo) or np.any(tq > hi) or np.any(np.isnan(tq)):
            self._refuse(np.min(tq), np.max(tq))
        x, c = self.breaks, self.coefficients
        i = np.clip(np.searchsorted(x, tq, side="right") - 1, 0, x.size - 2)
        s = tq - x[i]
        value = c[i, 0]
        for j in range(1, c.shape[1]):
            value = value * s + c[i, j]
        return float(value) if np.ndim(value) == 0 else value

    def _at(self, t):
        """:meth:`__call__` at one time ``t`` (float): the same operations in the
        same order on Python floats (the same value, bit for bit)."""
        breaks, rows, (lo, hi) = self._scalar
        if not lo <= t <= hi:  # NaN too
            self._refuse(t, t)
        i = min(max(bisect.bisect_right(breaks, t) - 1, 0), len(breaks) - 2)
        row, s = rows[i], t - breaks[i]
        value = row[0]
        for coefficient in row[1:]:
            value = value * s + coefficient
        return value

    def _refuse(self, first, last):
        a, b = self.t_range
        raise ModelError(f"{self.name}: defined for {a:g} s <= t <= {b:g} s only "
                         f"(asked at t = {first:g} .. {last:g} s)")

    def packed(self):
        """The data the compiled module reads: ``[n, k, lo, hi, breaks, coefficients]``
        (``lo, hi`` from :meth:`limits`), float64."""
        lo, hi = self.limits()
        n, k = self.coefficients.shape
        return np.concatenate([[n, k, lo, hi], self.breaks, self.coefficients.ravel()])

    def __repr__(self):
        a, b = self.t_range
        n, k = self.coefficients.shape
        return (f"PiecewisePolynomial({self.name}, {n} pieces of degree {k - 1}, "
                f"t in [{a:g}, {b:g}]{', extrapolated' if self.extrapolate else ''})")


@functools.lru_cache(maxsize=None)
def _interpolation(degree):
    """``(z, to_chebyshev, to_powers)`` of degree ``degree`` on [0, 1]: the
    Chebyshev points of the first kind (inside the interval: a function that
    jumps at a break is sampled on one side only), the matrix taking values there
    to Chebyshev coefficients (well conditioned), and the one taking those to
    coefficients of powers of z (integers, exact)."""
    from numpy.polynomial import Chebyshev, Polynomial
    k = np.arange(degree + 1)
    u = np.cos(np.pi * (k + 0.5) / (degree + 1))
    to_chebyshev = np.cos(np.outer(k, np.arccos(u))) * (2.0 / (degree + 1))
    to_chebyshev[0] *= 0.5
    to_powers = np.zeros((degree + 1, degree + 1))
    for j in k:
        power = Chebyshev.basis(j, domain=[0, 1]).convert(kind=Polynomial, domain=[0, 1],
                                                         window=[0, 1]).coef
        to_powers[:power.size, j] = power
    return (u + 1) / 2, to_chebyshev, to_powers


#: where the fits are checked, on [0, 1]: none of them a node of the degrees tried
_CHECK = (np.arange(24) + 0.5) / 24 + 0.01


def _fit(f, a, b, degree, rows):
    """Interpolants of degree ``degree`` of ``f`` on the intervals ``[a, b]``:
    coefficients (rows, n, degree + 1) in powers of ``t - a``, highest first, and
    the largest error of each row and interval at the check points (rows, n)."""
    z, to_chebyshev, to_powers = _interpolation(degree)
    h = b - a
    samples = np.asarray(f((a[:, None] + h[:, None] * z).ravel()), float)
    samples = samples.reshape(rows, a.size, z.size)
    ascending = (samples @ to_chebyshev.T) @ to_powers.T  # in powers of (t - a)/h
    ascending = ascending / h[None, :, None] ** np.arange(degree + 1)
    coefficients = ascending[..., ::-1]
    s = h[:, None] * _CHECK
    exact = np.asarray(f((a[:, None] + s).ravel()), float).reshape(rows, a.size, _CHECK.size)
    value = np.broadcast_to(coefficients[..., :1], exact.shape).copy()
    for j in range(1, degree + 1):
        value = value * s + coefficients[..., j:j + 1]
    return coefficients, np.max(np.abs(value - exact), axis=-1)


def tabulate(f, breaks, rows, names, rtol=1e-13, extrapolate=False):
    """Piecewise polynomials of a smooth function, each within ``rtol`` of it.

    Parameters
    ----------
    f : callable
        ``f(t)`` for an array t of shape (m,) returns shape (rows, m); smooth
        between consecutive ``breaks``.
    breaks : array_like, shape (n + 1,)
        Times where ``f`` or its derivatives may jump (kept as breaks), s.
    rows : int
    names : sequence of str
        One per row (the :attr:`PiecewisePolynomial.name`).
    rtol : float
        Largest error at the check points, relative to the row's largest
        magnitude at the points sampled.
    extrapolate : bool
        Of the results; the end pieces are then the interpolants of the end
        intervals (exact where ``f`` is a polynomial of degree <= 9 there).

    Returns
    -------
    list of PiecewisePolynomial
        One per row.
    """
    x = np.unique(np.asarray(breaks, float))
    if x.size < 2:
        raise ModelError(f"tabulate: {names[0]}: need at least two distinct breaks")
    todo_a, todo_b = x[:-1], x[1:]
    scale = np.max(np.abs(np.asarray(f(x), float).reshape(rows, -1)), axis=1)
    pieces = []  # (a, b, coefficients (rows, k))
    for _ in range(_MAX_HALVINGS):
        for degree in _DEGREES:
            if todo_a.size == 0:
                break
            coefficients, error = _fit(f, todo_a, todo_b, degree, rows)
            scale = np.maximum(scale, np.max(np.abs(coefficients[..., -1]), axis=1))
            good = np.all(error <= rtol * scale[:, None], axis=0)
            pieces += [(a, b, c) for a, b, c in zip(todo_a[good], todo_b[good],
                                                    np.moveaxis(coefficients[:, good], 1, 0))]
            todo_a, todo_b = todo_a[~good], todo_b[~good]
        if todo_a.size == 0:
            break
        middle = 0.5 * (todo_a + todo_b)
        todo_a, todo_b = (np.concatenate([todo_a, middle]),
                          np.concatenate([middle, todo_b]))
    else:
        _, error = _fit(f, todo_a[:1], todo_b[:1], MAX_DEGREE, rows)
        row = int(np.argmax(error[:, 0] / np.maximum(scale, 1e-300)))
        raise ModelError(f"tabulate: {names[row]}: not within {rtol:g} of its largest "
                         f"magnitude near t = {todo_a[0]:g} s after {_MAX_HALVINGS} "
                         "halvings (is it smooth between the breaks?)")
    pieces.sort(key=lambda piece: piece[0])
    width = max(c.shape[1] for _, _, c in pieces)
    table = np.zeros((rows, len(pieces), width))
    for i, (_, _, c) in enumerate(pieces):
        table[:, i, width - c.shape[1]:] = c
    edges = np.array([a for a, _, _ in pieces] + [pieces[-1][1]])
    return [PiecewisePolynomial(edges, table[r], names[r], extrapolate) for r in range(rows)]
