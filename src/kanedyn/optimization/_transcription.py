r"""Direct collocation: the decision variables and the dynamics' defects.

The duration :math:`T` is cut into :math:`N - 1` equal intervals,
:math:`h = T/(N-1)`, nodes :math:`t_k = t_0 + k h`.  The decision vector is

.. math::

    z = [\,y_0, \dots, y_{N-1},\; r_0, \dots, r_{N-1},\; p,\; T\,]

(states then inputs node by node, the free parameters, and the duration when
it is free).  On each interval the states obey

.. math::

    y_{k+1} - y_k - h \sum_s c_s\, f(t_s, y_s, r_s, p) = 0,

with the stages :math:`s` of the method, each a point :math:`y_s = \sum_o
a_{s,o}\, y_{k+o}` (:math:`o \in \{0, 1\}`, the same for :math:`r` and
:math:`t`):

================  ==========================================  ==============
method            stages :math:`(a_{s,0}, a_{s,1};\ c_s)`      order
================  ==========================================  ==============
backward-euler    :math:`(0, 1;\ 1)`                           1
trapezoid         :math:`(1, 0;\ \tfrac12)`, :math:`(0, 1;\ \tfrac12)`   2
midpoint          :math:`(\tfrac12, \tfrac12;\ 1)`             2
================  ==========================================  ==============

The integral of the objective is the same sum (backward Euler: the
rectangles at the right ends; trapezoid; midpoint), so the discrete problem
is consistent.  ``midpoint`` is opty's ``"midpoint"``, ``backward-euler``
its ``"backward euler"``.

``hermite-simpson`` (order 4) is the separated form (Betts, *Practical
Methods for Optimal Control*, 2nd ed., sec. 4.6.4): the states and inputs at
the midpoint of each interval, :math:`\bar y_k, \bar r_k`, are decision
variables too (after everything else in :math:`z`), and each interval has
two groups of rows,

.. math::

    y_{k+1} - y_k - \tfrac{h}{6}\,(f_k + 4\bar f_k + f_{k+1}) = 0
    \quad\text{(Simpson)},\qquad
    \bar y_k - \tfrac12 (y_k + y_{k+1}) - \tfrac{h}{8}\,(f_k - f_{k+1}) = 0
    \quad\text{(Hermite)},

with :math:`\bar f_k = f(t_k + h/2, \bar y_k, \bar r_k, p)`.  Every point
(nodes and midpoints) is independent of the others, so ``model.jacobians``
is called once on all 2N - 1 of them and each row's derivatives are those
values times constants: no products of Jacobians, as the compressed form
(midpoints eliminated, :math:`\bar y` a function of both nodes) needs.
The objective's integral is Simpson's rule on the same points.

The exact derivatives of :math:`f` come from ``model.jacobians`` at all
stage points in one call; the constraint Jacobian is assembled from them in
dense blocks per interval (its pattern is fixed once).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["METHODS", "COLLOCATION_METHODS", "ORDERS", "Stage", "Layout", "Defects",
           "HermiteSimpsonDefects", "defects_for", "MIDPOINT_METHODS"]


@dataclass(frozen=True)
class Stage:
    """A stage point :math:`\\sum_o a_o\\, x_{k+o}` and its weight ``c``."""

    a: tuple
    c: float

    @property
    def position(self):
        """Its time within the interval, in units of h."""
        return self.a[1]

    @property
    def node(self):
        """The node offset (0 or 1) when the stage is a node, else ``None``."""
        if self.a == (1.0, 0.0):
            return 0
        if self.a == (0.0, 1.0):
            return 1
        return None


#: one-step method -> its stages (:class:`Defects`)
METHODS = {
    "backward-euler": (Stage((0.0, 1.0), 1.0),),
    "trapezoid": (Stage((1.0, 0.0), 0.5), Stage((0.0, 1.0), 0.5)),
    "midpoint": (Stage((0.5, 0.5), 1.0),),
}

#: methods whose midpoint states and inputs are decision variables
#: (:class:`HermiteSimpsonDefects`)
MIDPOINT_METHODS = ("hermite-simpson",)

#: the names of the collocation methods (``method=``)
COLLOCATION_METHODS = tuple(METHODS) + MIDPOINT_METHODS

#: the order of accuracy of each method's states
ORDERS = {"backward-euler": 1, "trapezoid": 2, "midpoint": 2, "hermite-simpson": 4}


def defects_for(method, layout, rows):
    """The defect rows of ``method`` on ``layout`` (see :class:`Defects`)."""
    if method in MIDPOINT_METHODS:
        return HermiteSimpsonDefects(layout, rows)
    return Defects(method, layout, rows)


@dataclass(frozen=True)
class Layout:
    """Where each unknown lives in the decision vector.

    Attributes
    ----------
    nodes : int
        N.
    n_states, n_inputs, n_free : int
    free_duration : bool
    midpoints : bool
        The states and inputs at the N - 1 midpoints are variables too
        (Hermite-Simpson), after the duration: ``[..., T, ybar_0, ...,
        ybar_{N-2}, rbar_0, ..., rbar_{N-2}]``.
    """

    nodes: int
    n_states: int
    n_inputs: int
    n_free: int
    free_duration: bool
    midpoints: bool = False

    @classmethod
    def of(cls, problem):
        """The layout of an :class:`OptimalControlProblem`."""
        s = problem.symbols
        return cls(problem.nodes, len(s.states), len(s.inputs), len(s.free),
                   problem.free_duration, problem.method in MIDPOINT_METHODS)

    @property
    def n_points(self):
        """Points that carry states and inputs: the nodes, then the midpoints."""
        return 2 * self.nodes - 1 if self.midpoints else self.nodes

    @property
    def mid_start(self):
        """Index of the first midpoint state (the end of the vector without them)."""
        return self.free_start + self.n_free + int(self.free_duration)

    @property
    def n_variables(self):
        return self.n_points * (self.n_states + self.n_inputs) + self.n_free \
            + int(self.free_duration)

    def point_columns(self):
        """``(state columns (n_points, n_states), input columns (n_points,
        n_inputs))`` of every point, nodes first."""
        N, ns, nr = self.nodes, self.n_states, self.n_inputs
        node = np.arange(N)[:, None]
        ys = [node * ns + np.arange(ns)]
        rs = [self.input_start + node * nr + np.arange(nr)]
        if self.midpoints:
            mid = np.arange(N - 1)[:, None]
            ys.append(self.mid_start + mid * ns + np.arange(ns))
            rs.append(self.mid_start + (N - 1) * ns + mid * nr + np.arange(nr))
        return np.concatenate(ys), np.concatenate(rs)

    @property
    def input_start(self):
        return self.nodes * self.n_states

    @property
    def free_start(self):
        return self.nodes * (self.n_states + self.n_inputs)

    @property
    def duration_index(self):
        return self.free_start + self.n_free if self.free_duration else None

    def state_index(self, k, j):
        return k * self.n_states + j

    def input_index(self, k, j):
        return self.input_start + k * self.n_inputs + j

    def split(self, z, duration):
        """``(Y (N, n_states), R (N, n_inputs), P (n_free,), T)``."""
        N, ns, nr = self.nodes, self.n_states, self.n_inputs
        Y = z[:N * ns].reshape(N, ns)
        R = z[N * ns:N * (ns + nr)].reshape(N, nr)
        P = z[self.free_start:self.free_start + self.n_free]
        T = z[self.duration_index] if self.free_duration else duration
        return Y, R, P, T

    def split_midpoints(self, z):
        """``(Ybar (N - 1, n_states), Rbar (N - 1, n_inputs))``, or ``(None, None)``."""
        if not self.midpoints:
            return None, None
        N, ns, nr = self.nodes, self.n_states, self.n_inputs
        start = self.mid_start
        Ym = z[start:start + (N - 1) * ns].reshape(N - 1, ns)
        Rm = z[start + (N - 1) * ns:start + (N - 1) * (ns + nr)].reshape(N - 1, nr)
        return Ym, Rm

    def join(self, Y, R, P, T, Ym=None, Rm=None):
        """The decision vector; the midpoints (when the layout has them) are
        required."""
        parts = [np.ravel(Y), np.ravel(R), np.ravel(P)]
        if self.free_duration:
            parts.append([T])
        if self.midpoints:
            if Ym is None or Rm is None:
                raise ValueError("this layout needs the midpoint states and inputs")
            parts += [np.ravel(Ym), np.ravel(Rm)]
        return np.concatenate(parts).astype(float)


class Defects:
    """The dynamics' defect rows of one method on one layout.

    ``rows``: the state entries whose defects are imposed (all states, or the
    independent ones of a model with constraints, whose dependent entries
    follow from the constraints at every node).
    """

    def __init__(self, method, layout, rows):
        self.stages = METHODS[method]
        self.layout = layout
        self.rows = np.asarray(rows, dtype=int)
        self.structure = self._structure()

    @property
    def point_group(self):
        """The index of the evaluation group that holds every point of the
        layout (its nodes), or ``None``."""
        return 0 if any(s.node is not None for s in self.stages) else None

    # the stage points ---------------------------------------------------
    def points(self, t0, h, Y, R, Ym=None, Rm=None):
        """``[(t, Y, R)]`` of the distinct evaluation groups: all nodes (when
        some stage is a node), then each interior stage's points."""
        groups = []
        N = self.layout.nodes
        if any(s.node is not None for s in self.stages):
            groups.append((t0 + h * np.arange(N), Y, R))
        for s in self.stages:
            if s.node is None:
                a0, a1 = s.a
                groups.append((t0 + h * (np.arange(N - 1) + s.position),
                               a0 * Y[:-1] + a1 * Y[1:], a0 * R[:-1] + a1 * R[1:]))
        return groups

    def _stage_values(self, evaluated):
        """Per stage, the arrays of its N - 1 points from the evaluated groups
        (each a tuple of arrays with a first axis over the group's points)."""
        out = []
        interior = 1 if any(s.node is not None for s in self.stages) else 0
        for s in self.stages:
            if s.node is not None:
                sl = slice(s.node, s.node + self.layout.nodes - 1)
                out.append(tuple(None if a is None else a[sl] for a in evaluated[0]))
            else:
                out.append(evaluated[interior])
                interior += 1
        return out

    # values ------------------------------------------------------------
    def values(self, Y, h, evaluated, Ym=None):
        """Defects, shape ((N - 1) * n_rows,)."""
        rows = self.rows
        E = Y[1:, rows] - Y[:-1, rows]
        for s, (f, *_) in zip(self.stages, self._stage_values(evaluated)):
            E = E - h * s.c * f[:, rows]
        return E.ravel()

    def _blocks(self):
        """The column groups of each interval's rows: ``("y", o)``, ``("r",
        o)``, ``"p"``, ``"T"``."""
        L = self.layout
        offsets = sorted({o for s in self.stages for o in (0, 1) if s.a[o]} | {0, 1})
        blocks = [("y", o) for o in offsets]
        if L.n_inputs:
            blocks += [("r", o) for o in offsets if any(s.a[o] for s in self.stages)]
        if L.n_free:
            blocks.append("p")
        if L.free_duration:
            blocks.append("T")
        return blocks

    def _structure(self):
        L = self.layout
        N, nd = L.nodes, len(self.rows)
        k = np.arange(N - 1)[:, None, None]
        i = np.arange(nd)[None, :, None]
        rows, cols = [], []
        for block in self._blocks():
            if block == "p":
                c = L.free_start + np.arange(L.n_free)[None, None, :]
            elif block == "T":
                c = np.full((1, 1, 1), L.duration_index)
            elif block[0] == "y":
                c = (k + block[1]) * L.n_states + np.arange(L.n_states)[None, None, :]
            else:
                c = L.input_start + (k + block[1]) * L.n_inputs + np.arange(
                    L.n_inputs)[None, None, :]
            shape = (N - 1, nd, c.shape[2])
            rows.append(np.broadcast_to(k * nd + i, shape).ravel())
            cols.append(np.broadcast_to(c, shape).ravel())
        return np.concatenate(rows), np.concatenate(cols)

    def jacobian(self, h, T, evaluated, time_rates):
        """Values in the order of :attr:`structure`.

        ``evaluated``: per group ``(f, A, B, Pf)`` (Pf: the free parameters'
        columns, or None); ``time_rates``: per group :math:`\\partial
        f/\\partial t` (free duration) or ``None``.
        """
        L = self.layout
        N, rows = L.nodes, self.rows
        nd = len(rows)
        stages = self._stage_values(evaluated)
        rates = self._stage_values([(r,) for r in time_rates]) if time_rates else None
        values = []
        eye = np.zeros((nd, L.n_states))
        eye[np.arange(nd), rows] = 1.0
        for block in self._blocks():
            if block == "p":
                v = sum(-h * s.c * Pf[:, rows] for s, (_, _, _, Pf) in zip(self.stages, stages))
            elif block == "T":
                dh = 1.0 / (N - 1)
                v = 0.0
                for j, (s, (f, *_)) in enumerate(zip(self.stages, stages)):
                    v = v - dh * s.c * f[:, rows]
                    if rates is not None:
                        position = (np.arange(N - 1) + s.position) * dh
                        v = v - h * s.c * rates[j][0][:, rows] * position[:, None]
                v = v[:, :, None]
            elif block[0] == "y":
                o = block[1]
                v = np.broadcast_to((1.0 if o == 1 else -1.0) * eye, (N - 1, nd, L.n_states))
                for s, (_, A, _, _) in zip(self.stages, stages):
                    if s.a[o]:
                        v = v - h * s.c * s.a[o] * A[:, rows]
            else:
                o = block[1]
                v = 0.0
                for s, (_, _, B, _) in zip(self.stages, stages):
                    if s.a[o]:
                        v = v - h * s.c * s.a[o] * B[:, rows]
            values.append(np.ravel(v))
        return np.concatenate(values)

    def quadrature(self, h, evaluated_terms):
        """:math:`h \\sum_k \\sum_s c_s L_s`, from the terms evaluated on the
        groups of :meth:`points` (each ``(value, d_t, d_y, d_r, d_p, d_T)``)."""
        stages = self._stage_values(evaluated_terms)
        return sum(h * s.c * float(np.sum(term[0])) for s, term in zip(self.stages, stages))

    def quadrature_gradient(self, h, evaluated_terms):
        """The gradient of :meth:`quadrature`: ``(gY, gR, gYbar, gRbar, gP,
        gT)`` (no midpoints here: ``gYbar = gRbar = None``)."""
        L = self.layout
        N = L.nodes
        gY, gR = np.zeros((N, L.n_states)), np.zeros((N, L.n_inputs))
        gP, gT = np.zeros(L.n_free), 0.0
        for stage, (value, d_t, d_y, d_r, d_p, d_T) in zip(
                self.stages, self._stage_values(evaluated_terms)):
            w = h * stage.c
            for o in (0, 1):
                a = stage.a[o]
                if a:
                    gY[o:o + N - 1] += w * a * d_y
                    gR[o:o + N - 1] += w * a * d_r
            gP += w * d_p.sum(axis=0)
            position = (np.arange(N - 1) + stage.position) / (N - 1)
            gT += stage.c / (N - 1) * value.sum() + w * np.sum(d_t * position) + w * d_T.sum()
        return gY, gR, None, None, gP, gT


class HermiteSimpsonDefects:
    r"""The separated Hermite-Simpson rows (see the module's text), on a
    layout with midpoints.

    Rows, interval by interval: the Simpson rows, then the Hermite rows, each
    over :attr:`rows`.  Each is :math:`\sum_g a_g\, x_g + h \sum_g c_g\,
    f(x_g)` over the interval's three points :math:`g` (left node, midpoint,
    right node), with the coefficients of :data:`KINDS`.
    """

    #: (name, {point: coefficient of the state}, {point: coefficient of h f})
    KINDS = (("simpson", {"left": -1.0, "mid": 0.0, "right": 1.0},
              {"left": -1 / 6, "mid": -4 / 6, "right": -1 / 6}),
             ("hermite", {"left": -0.5, "mid": 1.0, "right": -0.5},
              {"left": -1 / 8, "mid": 0.0, "right": 1 / 8}))
    #: Simpson's weights of the objective's integral, times h
    WEIGHTS = {"left": 1 / 6, "mid": 4 / 6, "right": 1 / 6}
    #: where each point lies in its interval, in units of h
    POSITION = {"left": 0.0, "mid": 0.5, "right": 1.0}

    point_group = 0

    def __init__(self, layout, rows):
        if not layout.midpoints:
            raise ValueError("Hermite-Simpson needs a layout with midpoints")
        self.layout = layout
        self.rows = np.asarray(rows, dtype=int)
        self.structure = self._structure()

    def points(self, t0, h, Y, R, Ym, Rm):
        """One evaluation group: the N nodes, then the N - 1 midpoints."""
        N = self.layout.nodes
        t = np.concatenate([t0 + h * np.arange(N), t0 + h * (np.arange(N - 1) + 0.5)])
        return [(t, np.concatenate([Y, Ym]), np.concatenate([R, Rm]))]

    def _at(self, array):
        """``{point: array rows of the N - 1 intervals}`` of an array over all points."""
        N = self.layout.nodes
        return {"left": array[:N - 1], "mid": array[N:], "right": array[1:N]}

    def values(self, Y, h, evaluated, Ym):
        rows = self.rows
        f = self._at(evaluated[0][0])
        y = {"left": Y[:-1], "mid": Ym, "right": Y[1:]}
        out = []
        for _, a, c in self.KINDS:
            E = sum(a[g] * y[g][:, rows] for g in a if a[g])
            out.append(E + h * sum(c[g] * f[g][:, rows] for g in c if c[g]))
        return np.stack(out, axis=1).ravel()

    def _blocks(self, kind):
        """The column groups of one kind of rows: ``("y", point)`` (dense),
        ``("eye", point)`` (the row's own state only), ``("r", point)``, ``"p"``,
        ``"T"``."""
        _, a, c = kind
        L = self.layout
        blocks = []
        for g in ("left", "mid", "right"):
            if c[g]:
                blocks.append(("y", g))
            elif a[g]:
                blocks.append(("eye", g))
        if L.n_inputs:
            blocks += [("r", g) for g in ("left", "mid", "right") if c[g]]
        if L.n_free:
            blocks.append("p")
        if L.free_duration:
            blocks.append("T")
        return blocks

    def _columns(self, block):
        L = self.layout
        N, ns, nr, nd = L.nodes, L.n_states, L.n_inputs, len(self.rows)
        k = np.arange(N - 1)[:, None, None]
        if block == "p":
            return L.free_start + np.arange(L.n_free)[None, None, :]
        if block == "T":
            return np.full((1, 1, 1), L.duration_index)
        what, g = block
        if what == "eye":
            start = (L.mid_start + k * ns if g == "mid"
                     else (k + (g == "right")) * ns)
            return start + self.rows.reshape(1, nd, 1)
        if what == "y":
            if g == "mid":
                return L.mid_start + k * ns + np.arange(ns)[None, None, :]
            return (k + (g == "right")) * ns + np.arange(ns)[None, None, :]
        if g == "mid":
            return L.mid_start + (N - 1) * ns + k * nr + np.arange(nr)[None, None, :]
        return L.input_start + (k + (g == "right")) * nr + np.arange(nr)[None, None, :]

    def _structure(self):
        N, nd = self.layout.nodes, len(self.rows)
        k = np.arange(N - 1)[:, None, None]
        i = np.arange(nd)[None, :, None]
        rows, cols = [], []
        for j, kind in enumerate(self.KINDS):
            for block in self._blocks(kind):
                c = self._columns(block)
                shape = (N - 1, nd, c.shape[2])
                rows.append(np.broadcast_to(k * 2 * nd + j * nd + i, shape).ravel())
                cols.append(np.broadcast_to(c, shape).ravel())
        return np.concatenate(rows), np.concatenate(cols)

    def jacobian(self, h, T, evaluated, time_rates):
        """Values in the order of :attr:`structure` (arguments as
        :meth:`Defects.jacobian`)."""
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
        for kind in self.KINDS:
            _, a, c = kind
            for block in self._blocks(kind):
                if block == "p":
                    v = sum(h * c[g] * Pf[g][:, rows] for g in c if c[g])
                elif block == "T":
                    v = 0.0
                    for g in c:
                        if c[g]:
                            v = v + dh * c[g] * f[g][:, rows]
                            if rate is not None:
                                position = (np.arange(N - 1) + self.POSITION[g]) * dh
                                v = v + h * c[g] * rate[g][:, rows] * position[:, None]
                    v = v[:, :, None]
                elif block[0] == "eye":
                    v = np.full((N - 1, nd, 1), a[block[1]])
                elif block[0] == "y":
                    g = block[1]
                    v = a[g] * eye + h * c[g] * A[g][:, rows]
                else:
                    g = block[1]
                    v = h * c[g] * B[g][:, rows]
                values.append(np.ravel(v))
        return np.concatenate(values)

    def quadrature(self, h, evaluated_terms):
        """Simpson's rule, :math:`\\tfrac{h}{6} \\sum_k (L_k + 4\\bar L_k + L_{k+1})`."""
        value = self._at(evaluated_terms[0][0])
        return h * sum(w * float(np.sum(value[g])) for g, w in self.WEIGHTS.items())

    def quadrature_gradient(self, h, evaluated_terms):
        """``(gY, gR, gYbar, gRbar, gP, gT)`` of :meth:`quadrature`."""
        L = self.layout
        N = L.nodes
        value, d_t, d_y, d_r, d_p, d_T = (self._at(a) for a in evaluated_terms[0])
        gY, gR = np.zeros((N, L.n_states)), np.zeros((N, L.n_inputs))
        gP, gT = np.zeros(L.n_free), 0.0
        for g, w in self.WEIGHTS.items():
            if g == "mid":
                gYm, gRm = h * w * d_y[g], h * w * d_r[g]
            else:
                o = int(g == "right")
                gY[o:o + N - 1] += h * w * d_y[g]
                gR[o:o + N - 1] += h * w * d_r[g]
            gP += h * w * d_p[g].sum(axis=0)
            position = (np.arange(N - 1) + self.POSITION[g]) / (N - 1)
            gT += w / (N - 1) * value[g].sum() + h * w * (np.sum(d_t[g] * position)
                                                        + d_T[g].sum())
        return gY, gR, gYm, gRm, gP, gT
