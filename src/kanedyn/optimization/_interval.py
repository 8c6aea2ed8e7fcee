r"""Collocation on points inside each interval that are decision variables:
Hermite-Simpson (separated form) and Legendre-Gauss-Radau (LGR).

Each interval :math:`[t_k, t_{k+1}]`, :math:`h = t_{k+1} - t_k`, holds the
points :math:`g = 0, \dots, m + 1` at :math:`t_k + \sigma_g h`
(:math:`\sigma_0 = 0`, the left node; :math:`\sigma_{m+1} = 1`, the right
node; the :math:`m` points between are variables of the layout, states and
inputs, after everything else in the decision vector).  Every row of the
dynamics is

.. math::

    \sum_g a_{ig}\, y_g + h \sum_g c_{ig}\, f(t_g, y_g, r_g, p) = 0,

with the constant matrices :math:`a, c` of the :class:`IntervalScheme`, and
the objective's integral is :math:`h \sum_k \sum_g w_g L_g`.  Since every
point is a variable, ``model.jacobians`` is called once on all of them and
each Jacobian entry is a value there times a constant.

**Hermite-Simpson** (order 4; Betts, *Practical Methods for Optimal Control*,
2nd ed., sec. 4.6.4): the midpoint :math:`\sigma = \tfrac12`, two rows per
state,

.. math::

    y_{k+1} - y_k - \tfrac{h}{6}\,(f_k + 4\bar f_k + f_{k+1}) = 0
    \quad\text{(Simpson)},\qquad
    \bar y_k - \tfrac12 (y_k + y_{k+1}) - \tfrac{h}{8}\,(f_k - f_{k+1}) = 0
    \quad\text{(Hermite)},

and Simpson's rule for the objective.

**Legendre-Gauss-Radau of degree d** (orthogonal collocation on finite
elements): the state is the polynomial of degree :math:`d` through the left
node and the :math:`d` Radau points :math:`\sigma_1 < \dots < \sigma_d = 1`
(the zeros of :math:`P_d - P_{d-1}` on :math:`[-1, 1]`, mapped to
:math:`[0, 1]`: the Radau points that include the interval's right end), and
it satisfies the dynamics at those :math:`d` points:

.. math::

    \sum_{j=0}^{d} D_{ij}\, y_j - h\, f_i = 0, \quad i = 1, \dots, d,

:math:`D_{ij} = \ell_j'(\sigma_i)` the differentiation matrix of the
Lagrange basis on :math:`\sigma_0, \dots, \sigma_d`.  This is the Radau IIA
Runge-Kutta method in its differential form: states at the nodes of order
:math:`2d - 1`, the objective integrated by the Radau quadrature
(:math:`w_0 = 0`, :math:`w_i = \int_0^1 \prod_{k \ne i} (\sigma -
\sigma_k)/(\sigma_i - \sigma_k)\, d\sigma`, exact to degree :math:`2d - 2`).
Degree 1 is backward Euler.  The inputs are collocated at the Radau points
only: within an interval they are the polynomial of degree :math:`d - 1`
through them.  The input at the first node enters no row of the dynamics;
one more row per input makes it that polynomial's value there, so that it is
what the transcription assumed and no variable is left undetermined.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__ = ["IntervalScheme", "hermite_simpson", "lgr", "radau_points", "IntervalDefects",
           "lagrange_weights"]


def lagrange_weights(points, x):
    """The values at ``x`` of the Lagrange basis on ``points``: shape
    ``(len(x), len(points))``."""
    points = np.asarray(points, dtype=float)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    out = np.ones((x.size, points.size))
    for j, p in enumerate(points):
        for k, q in enumerate(points):
            if k != j:
                out[:, j] *= (x - q) / (p - q)
    return out


@lru_cache(maxsize=None)
def radau_points(degree):
    r"""The ``degree`` Legendre-Gauss-Radau points on :math:`(0, 1]` that
    include 1: the interior ones are the zeros of the Jacobi polynomial
    :math:`P^{(1,0)}_{d-1}` (SciPy's ``roots_jacobi``) mapped from
    :math:`[-1, 1]`."""
    from scipy.special import roots_jacobi
    inner = (roots_jacobi(degree - 1, 1.0, 0.0)[0] + 1.0) / 2.0 if degree > 1 else []
    return tuple(float(v) for v in np.sort(inner)) + (1.0,)


@dataclass(frozen=True)
class IntervalScheme:
    """The constants of a collocation on the points of an interval.

    Attributes
    ----------
    name : str
    positions : tuple of float
        :math:`\\sigma_g`, ``m + 2`` of them: 0, the interior points, 1.
    a, c : ndarray, shape (rows, m + 2)
        Coefficients of the states and of :math:`h f` in each row.
    weights : ndarray, shape (m + 2,)
        The objective's quadrature weights (times h).
    label : str
        What the interior points are called in tables (``"midpoint"``).
    start_inputs : ndarray or None
        When the first node's input enters no row: the coefficients, over the
        points 1..m+1 of the first interval, of the value it is tied to.
    input_positions : tuple of int
        The points whose inputs define the inputs between them (those where
        :math:`f` is collocated).
    """

    name: str
    positions: tuple
    a: np.ndarray
    c: np.ndarray
    weights: np.ndarray
    label: str
    input_positions: tuple
    start_inputs: np.ndarray = None

    @property
    def interior(self):
        """The positions of the interior points (the layout's)."""
        return self.positions[1:-1]

    @property
    def n_rows(self):
        return self.a.shape[0]


def hermite_simpson():
    """The separated Hermite-Simpson scheme (see the module's text)."""
    return IntervalScheme(
        name="hermite-simpson", positions=(0.0, 0.5, 1.0),
        a=np.array([[-1.0, 0.0, 1.0], [-0.5, 1.0, -0.5]]),
        c=np.array([[-1 / 6, -4 / 6, -1 / 6], [-1 / 8, 0.0, 1 / 8]]),
        weights=np.array([1 / 6, 4 / 6, 1 / 6]), label="midpoint",
        input_positions=(0, 1, 2))


@lru_cache(maxsize=None)
def lgr(degree):
    """The Legendre-Gauss-Radau scheme of ``degree`` (see the module's text)."""
    sigma = np.array((0.0,) + radau_points(degree))
    d = degree
    # differentiation matrix of the Lagrange basis on sigma (barycentric form)
    w = np.array([1.0 / np.prod([s - q for q in sigma if q != s]) for s in sigma])
    D = np.zeros((d + 1, d + 1))
    for i in range(d + 1):
        for j in range(d + 1):
            if i != j:
                D[i, j] = w[j] / w[i] / (sigma[i] - sigma[j])
        D[i, i] = -D[i].sum()
    c = np.zeros((d, d + 1))
    c[:, 1:] = -np.eye(d)
    # Radau quadrature: the integral over [0, 1] of the basis on the d Radau
    # points, by Gauss-Legendre with d points (exact to degree 2d - 1)
    x, gw = np.polynomial.legendre.leggauss(d)
    weights = np.concatenate([[0.0], 0.5 * gw @ lagrange_weights(sigma[1:], (x + 1) / 2)])
    return IntervalScheme(
        name="lgr", positions=tuple(float(s) for s in sigma), a=D[1:], c=c,
        weights=weights, label="interior", input_positions=tuple(range(1, d + 1)),
        start_inputs=lagrange_weights(sigma[1:], [0.0])[0])


class IntervalDefects:
    """The dynamics' rows of an :class:`IntervalScheme` on a layout whose
    interior points are the scheme's.

    Rows, interval by interval: each row of the scheme over :attr:`rows` (the
    collocated state entries); then, when the scheme ties the first node's
    input (:attr:`IntervalScheme.start_inputs`), one row per input.
    """

    point_group = 0

    def __init__(self, scheme, layout, rows):
        if tuple(layout.interior) != scheme.interior:
            raise ValueError(f"the layout's interior points are not those of "
                             f"{scheme.name}")
        self.scheme = scheme
        self.layout = layout
        self.rows = np.asarray(rows, dtype=int)
        self.tie_inputs = scheme.start_inputs is not None and layout.n_inputs > 0

    @property
    def n_rows(self):
        """How many rows (the dynamics', then the tied inputs')."""
        L = self.layout
        return (L.nodes - 1) * self.scheme.n_rows * len(self.rows) + \
            (L.n_inputs if self.tie_inputs else 0)

    # the points ----------------------------------------------------------
    def _times(self, t0, h):
        L = self.layout
        N, m = L.nodes, len(L.interior)
        inner = (np.arange(N - 1)[:, None] + np.asarray(L.interior)[None, :]).ravel()
        return t0 + h * np.concatenate([np.arange(N), inner]) if m else t0 + h * np.arange(N)

    def points(self, t0, h, Y, R, Yi, Ri):
        """One evaluation group: the N nodes, then the interior points."""
        return [(self._times(t0, h), np.concatenate([Y, Yi]), np.concatenate([R, Ri]))]

    def _at(self, array):
        """``[array rows of the N - 1 intervals at point g]`` for g = 0..m+1,
        of an array over all points (nodes first, then the interior points
        interval by interval)."""
        N, m = self.layout.nodes, len(self.layout.interior)
        inner = array[N:].reshape((N - 1, m) + array.shape[1:])
        return [array[:N - 1]] + [inner[:, g] for g in range(m)] + [array[1:N]]

    def _positions(self, g):
        """Where point g of every interval lies, as a fraction of the duration."""
        N = self.layout.nodes
        return (np.arange(N - 1) + self.scheme.positions[g]) / (N - 1)

    # values --------------------------------------------------------------
    def values(self, Y, h, evaluated, Yi, R=None, Ri=None):
        rows, a, c = self.rows, self.scheme.a, self.scheme.c
        f = self._at(evaluated[0][0])
        y = self._at(np.concatenate([Y, Yi]))
        out = []
        for i in range(a.shape[0]):
            E = sum(a[i, g] * y[g][:, rows] for g in range(a.shape[1]) if a[i, g])
            out.append(E + h * sum(c[i, g] * f[g][:, rows] for g in range(c.shape[1])
                                   if c[i, g]))
        values = [np.stack(out, axis=1).ravel()]
        if self.tie_inputs:
            first = [v[0] for v in self._at(np.concatenate([R, Ri]))[1:]]
            values.append(R[0] - self.scheme.start_inputs @ np.array(first))
        return np.concatenate(values)

    def _blocks(self, i):
        """The column groups of row kind ``i``: ``("y", g)`` (dense),
        ``("eye", g)`` (the row's own state only), ``("r", g)``, ``"p"``,
        ``"T"``, ``"t0"``."""
        a, c = self.scheme.a[i], self.scheme.c[i]
        L = self.layout
        blocks = []
        for g in range(a.size):
            if c[g]:
                blocks.append(("y", g))
            elif a[g]:
                blocks.append(("eye", g))
        if L.n_inputs:
            blocks += [("r", g) for g in range(c.size) if c[g]]
        return blocks + L.shared_blocks()

    def _point_start(self, g, what):
        """Columns of the first entry of point g in every interval, shape
        (N - 1, 1, 1): ``what`` is ``"y"`` or ``"r"``."""
        L = self.layout
        N, m = L.nodes, len(L.interior)
        k = np.arange(N - 1)[:, None, None]
        size = L.n_states if what == "y" else L.n_inputs
        if 0 < g <= m:
            base = L.interior_start + (0 if what == "y" else (N - 1) * m * L.n_states)
            return base + (k * m + g - 1) * size
        base = 0 if what == "y" else L.input_start
        return base + (k + (g == m + 1)) * size

    def _columns(self, block):
        L = self.layout
        nd = len(self.rows)
        if isinstance(block, str):
            return L.shared_columns(block)
        what, g = block
        if what == "eye":
            return self._point_start(g, "y") + self.rows.reshape(1, nd, 1)
        if what == "y":
            return self._point_start(g, "y") + np.arange(L.n_states)[None, None, :]
        return self._point_start(g, "r") + np.arange(L.n_inputs)[None, None, :]

    def _tie_columns(self):
        """``(rows, columns)`` of the tied inputs' rows (relative rows)."""
        L = self.layout
        nr, m = L.n_inputs, len(L.interior)
        j = np.arange(nr)
        cols = [L.input_start + j]
        for g in range(1, m + 2):
            cols.append(self._point_start(g, "r")[0, 0, 0] + j)
        cols = np.stack(cols, axis=1)
        return np.broadcast_to(j[:, None], cols.shape).ravel(), cols.ravel()

    def pattern(self):
        """``(rows, cols)``: lists of the pieces of the Jacobian pattern, in
        the order of :meth:`jacobian`'s values (made when asked, not kept)."""
        N, nd = self.layout.nodes, len(self.rows)
        n_kinds = self.scheme.n_rows
        k = np.arange(N - 1)[:, None, None]
        i = np.arange(nd)[None, :, None]
        rows, cols = [], []
        for j in range(n_kinds):
            for block in self._blocks(j):
                c = self._columns(block)
                shape = (N - 1, nd, c.shape[2])
                rows.append(np.broadcast_to(k * n_kinds * nd + j * nd + i, shape).ravel())
                cols.append(np.broadcast_to(c, shape).ravel())
        if self.tie_inputs:
            r, c = self._tie_columns()
            rows.append((N - 1) * n_kinds * nd + r)
            cols.append(c)
        return rows, cols

    def jacobian(self, h, T, evaluated, time_rates):
        """Values in the order of :meth:`pattern` (arguments as
        :meth:`._transcription.Defects.jacobian`)."""
        L = self.layout
        N, ns, rows = L.nodes, L.n_states, self.rows
        nd = len(rows)
        f, A, B, Pf = evaluated[0][:4]
        f, A, B = self._at(f), self._at(A), self._at(B)
        Pf = self._at(Pf) if L.n_free else None
        rate = self._at(time_rates[0]) if time_rates else None
        dh = 1.0 / (N - 1)
        eye = np.zeros((nd, ns))
        eye[np.arange(nd), rows] = 1.0
        values = []
        for i in range(self.scheme.n_rows):
            a, c = self.scheme.a[i], self.scheme.c[i]
            active = [g for g in range(c.size) if c[g]]
            for block in self._blocks(i):
                if block == "p":
                    v = sum(h * c[g] * Pf[g][:, rows] for g in active)
                elif block == "T":
                    v = sum(dh * c[g] * f[g][:, rows] for g in active)
                    if rate is not None:
                        v = v + sum(h * c[g] * rate[g][:, rows] * self._positions(g)[:, None]
                                    for g in active)
                    v = v[:, :, None]
                elif block == "t0":
                    v = sum(h * c[g] * rate[g][:, rows] for g in active)[:, :, None]
                elif block[0] == "eye":
                    v = np.full((N - 1, nd, 1), a[block[1]])
                elif block[0] == "y":
                    g = block[1]
                    v = a[g] * eye + h * c[g] * A[g][:, rows]
                else:
                    g = block[1]
                    v = h * c[g] * B[g][:, rows]
                values.append(np.ravel(v))
        if self.tie_inputs:
            tie = np.concatenate([[1.0], -self.scheme.start_inputs])
            values.append(np.tile(tie, L.n_inputs))
        return np.concatenate(values)

    def quadrature(self, h, evaluated_terms):
        """:math:`h \\sum_k \\sum_g w_g L_g` on the points of every interval."""
        value = self._at(evaluated_terms[0][0])
        return h * sum(w * float(np.sum(value[g]))
                       for g, w in enumerate(self.scheme.weights) if w)

    def quadrature_gradient(self, h, evaluated_terms):
        """``(gY, gR, gYi, gRi, gP, gT, gt0)`` of :meth:`quadrature` (the
        nodes', the interior points', the free parameters', the duration's,
        the start time's)."""
        L = self.layout
        N, m = L.nodes, len(L.interior)
        value, d_t, d_y, d_r, d_p, d_T = (self._at(a) for a in evaluated_terms[0])
        gY, gR = np.zeros((N, L.n_states)), np.zeros((N, L.n_inputs))
        gYi, gRi = np.zeros((N - 1, m, L.n_states)), np.zeros((N - 1, m, L.n_inputs))
        gP, gT, gt0 = np.zeros(L.n_free), 0.0, 0.0
        for g, w in enumerate(self.scheme.weights):
            if not w:
                continue
            if 0 < g <= m:
                gYi[:, g - 1] = h * w * d_y[g]
                gRi[:, g - 1] = h * w * d_r[g]
            else:
                o = int(g == m + 1)
                gY[o:o + N - 1] += h * w * d_y[g]
                gR[o:o + N - 1] += h * w * d_r[g]
            gP += h * w * d_p[g].sum(axis=0)
            gT += w / (N - 1) * value[g].sum() + h * w * (np.sum(d_t[g] * self._positions(g))
                                                        + d_T[g].sum())
            gt0 += h * w * np.sum(d_t[g])
        points = (N - 1) * m  # explicit: a model without inputs has no columns to infer
        return (gY, gR, gYi.reshape(points, L.n_states), gRi.reshape(points, L.n_inputs), gP,
                gT, gt0)
