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

The exact derivatives of :math:`f` come from ``model.jacobians`` at all
stage points in one call; the constraint Jacobian is assembled from them in
dense blocks per interval (its pattern is fixed once).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["METHODS", "COLLOCATION_METHODS", "ORDERS", "Stage", "Layout", "Defects"]


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


#: method -> stages
METHODS = {
    "backward-euler": (Stage((0.0, 1.0), 1.0),),
    "trapezoid": (Stage((1.0, 0.0), 0.5), Stage((0.0, 1.0), 0.5)),
    "midpoint": (Stage((0.5, 0.5), 1.0),),
}

#: the names of the collocation methods (``method=``)
COLLOCATION_METHODS = tuple(METHODS)

#: the order of accuracy of each method's states
ORDERS = {"backward-euler": 1, "trapezoid": 2, "midpoint": 2}


@dataclass(frozen=True)
class Layout:
    """Where each unknown lives in the decision vector.

    Attributes
    ----------
    nodes : int
        N.
    n_states, n_inputs, n_free : int
    free_duration : bool
    """

    nodes: int
    n_states: int
    n_inputs: int
    n_free: int
    free_duration: bool

    @property
    def n_variables(self):
        return (self.nodes * (self.n_states + self.n_inputs) + self.n_free
                + int(self.free_duration))

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

    def join(self, Y, R, P, T):
        parts = [np.ravel(Y), np.ravel(R), np.ravel(P)]
        if self.free_duration:
            parts.append([T])
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

    # the stage points ---------------------------------------------------
    def points(self, t0, h, Y, R):
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
    def values(self, Y, h, evaluated):
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
        """:math:`h \\sum_k \\sum_s c_s L_s` and its parts, from the terms
        evaluated on the groups of :meth:`points` (each ``(value, d_t, d_y,
        d_r, d_p, d_T)``): ``(value, [(stage, weight c, term arrays)])``."""
        stages = self._stage_values(evaluated_terms)
        total = sum(h * s.c * float(np.sum(term[0])) for s, term in zip(self.stages, stages))
        return total, list(zip(self.stages, stages))
