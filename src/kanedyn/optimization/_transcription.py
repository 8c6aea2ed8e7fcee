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

``hermite-simpson`` and ``lgr`` (Legendre-Gauss-Radau of a chosen degree)
collocate on points inside each interval that are decision variables too:
see :mod:`._interval`.

The exact derivatives of :math:`f` come from ``model.jacobians`` at all
stage points in one call; the constraint Jacobian is assembled from them in
dense blocks per interval (its pattern is fixed once).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._terms import identically_zero

__all__ = ["METHODS", "COLLOCATION_METHODS", "ORDERS", "Stage", "Layout", "Defects",
           "defects_for", "INTERVAL_METHODS", "interval_scheme"]


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

#: methods whose points inside each interval are decision variables
#: (:mod:`._interval`); ``lgr`` takes a degree
INTERVAL_METHODS = ("hermite-simpson", "lgr")

#: the names of the collocation methods (``method=``)
COLLOCATION_METHODS = tuple(METHODS) + INTERVAL_METHODS

#: the order of accuracy of each method's states at the nodes (``lgr``:
#: 2 degree - 1)
ORDERS = {"backward-euler": 1, "trapezoid": 2, "midpoint": 2, "hermite-simpson": 4}


def interval_scheme(method, degree=None):
    """The :class:`._interval.IntervalScheme` of an interval method, else ``None``."""
    from ._interval import hermite_simpson, lgr
    if method == "hermite-simpson":
        return hermite_simpson()
    if method == "lgr":
        return lgr(degree)
    return None


def defects_for(method, layout, rows, degree=None):
    """The defect rows of ``method`` on ``layout`` (see :class:`Defects` and
    :class:`._interval.IntervalDefects`)."""
    scheme = interval_scheme(method, degree)
    if scheme is not None:
        from ._interval import IntervalDefects
        return IntervalDefects(scheme, layout, rows)
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
    interior : tuple of float
        Positions (fractions of an interval) of the m points inside every
        interval whose states and inputs are variables too (Hermite-Simpson's
        midpoint, LGR's interior Radau points), after the duration:
        ``[..., T, ybar_(0,1), ..., ybar_(0,m), ybar_(1,1), ..., rbar_(0,1),
        ...]``, interval by interval.
    free_start_time : bool
        The start time is a variable, the vector's last entry (a phase that
        follows a free duration, :mod:`._multiphase`).
    """

    nodes: int
    n_states: int
    n_inputs: int
    n_free: int
    free_duration: bool
    interior: tuple = ()
    free_start_time: bool = False

    @classmethod
    def of(cls, problem, free_start_time=False):
        """The layout of an :class:`OptimalControlProblem`."""
        s = problem.symbols
        scheme = interval_scheme(problem.method, problem.degree)
        return cls(problem.nodes, len(s.states), len(s.inputs), len(s.free),
                   problem.free_duration, scheme.interior if scheme else (),
                   free_start_time)

    @property
    def n_interior(self):
        """Interior points in all: (N - 1) m."""
        return (self.nodes - 1) * len(self.interior)

    @property
    def n_points(self):
        """Points that carry states and inputs: the nodes, then the interior points."""
        return self.nodes + self.n_interior

    @property
    def interior_start(self):
        """Index of the first interior state."""
        return self.free_start + self.n_free + int(self.free_duration)

    @property
    def start_index(self):
        """Index of the start time when it is a variable (the last entry)."""
        return self.n_variables - 1 if self.free_start_time else None

    @property
    def n_variables(self):
        return self.n_points * (self.n_states + self.n_inputs) + self.n_free \
            + int(self.free_duration) + int(self.free_start_time)

    def positions(self):
        """Where each point lies, as a fraction of the duration: the nodes,
        then the interior points (a read-only array, made when asked: not
        held)."""
        return _positions(self.nodes, self.interior)

    def point_columns(self):
        """``(state columns (n_points, n_states), input columns (n_points,
        n_inputs))`` of every point, nodes first."""
        N, ns, nr = self.nodes, self.n_states, self.n_inputs
        node = np.arange(N)[:, None]
        inner = np.arange(self.n_interior)[:, None]
        ys = [node * ns + np.arange(ns), self.interior_start + inner * ns + np.arange(ns)]
        rs = [self.input_start + node * nr + np.arange(nr),
              self.interior_start + self.n_interior * ns + inner * nr + np.arange(nr)]
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

    def shared_blocks(self):
        """The column groups every row of the dynamics may depend on besides
        its points: ``"p"`` (the free parameters), ``"T"`` (a free
        duration), ``"t0"`` (a start time that is a variable)."""
        return [block for block, present in (("p", self.n_free), ("T", self.free_duration),
                                             ("t0", self.free_start_time)) if present]

    def shared_columns(self, block):
        """The columns of a :meth:`shared_blocks` group, shape (1, 1, k)."""
        if block == "p":
            return self.free_start + np.arange(self.n_free)[None, None, :]
        return np.full((1, 1, 1), self.duration_index if block == "T" else self.start_index)

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

    def split_interior(self, z):
        """``(Yi ((N - 1) m, n_states), Ri ((N - 1) m, n_inputs))`` (empty
        without interior points)."""
        K, ns, nr = self.n_interior, self.n_states, self.n_inputs
        start = self.interior_start
        Yi = z[start:start + K * ns].reshape(K, ns)
        Ri = z[start + K * ns:start + K * (ns + nr)].reshape(K, nr)
        return Yi, Ri

    def start_time(self, z, fixed):
        """The start time: the variable when the layout has it, else ``fixed``."""
        return z[self.start_index] if self.free_start_time else fixed

    def join(self, Y, R, P, T, Yi=None, Ri=None, t0=None):
        """The decision vector; the interior points (when the layout has
        them) and the start time (when it is a variable) are required."""
        parts = [np.ravel(Y), np.ravel(R), np.ravel(P)]
        if self.free_duration:
            parts.append([T])
        if self.n_interior:
            if Yi is None or Ri is None:
                raise ValueError("this layout needs the interior points' states and inputs")
            parts += [np.ravel(Yi), np.ravel(Ri)]
        if self.free_start_time:
            if t0 is None:
                raise ValueError("this layout needs the start time")
            parts.append([t0])
        return np.concatenate(parts).astype(float, copy=False)


def _positions(nodes, interior):
    """:meth:`Layout.positions` of ``nodes`` and ``interior``, read-only."""
    inner = (np.arange(nodes - 1)[:, None] + np.asarray(interior)[None, :]).ravel()
    out = np.concatenate([np.arange(nodes), inner]) / (nodes - 1)
    out.flags.writeable = False
    return out


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
        N, nd = layout.nodes, len(self.rows)
        #: how the rows are taken from a (..., n_states) array: a slice when
        #: they are all the states in order (a view, not a copy by fancy index)
        self._take = (slice(None) if np.array_equal(self.rows, np.arange(layout.n_states))
                      else self.rows)
        # where each stage's points are among the evaluated groups: a slice of
        # the nodes' group, or a group of its own (see points)
        interior = 1 if any(s.node is not None for s in self.stages) else 0
        self._block_list = None  # see _blocks
        #: whether the nodes are a group of their own (some stage is a node)
        self._node_group = bool(interior)
        self._stage_groups = []
        for s in self.stages:
            if s.node is not None:
                self._stage_groups.append((0, slice(s.node, s.node + N - 1)))
            else:
                self._stage_groups.append((interior, None))
                interior += 1
        eye = np.zeros((nd, layout.n_states))
        eye[np.arange(nd), self.rows] = 1.0
        #: d(defect)/d(y_k) and d(defect)/d(y_(k+1)) of the difference alone
        self._difference = {o: np.broadcast_to((1.0 if o == 1 else -1.0) * eye,
                                               (N - 1, nd, layout.n_states)) for o in (0, 1)}

    # (made when asked, not held: arrays of the nodes' length)
    def stage_times(self, stage, t0, h, k0=0, k1=None):
        """The times of ``stage``'s points in the intervals ``k0`` to ``k1``
        (all by default), s, shape (k1 - k0,)."""
        k1 = self.layout.nodes - 1 if k1 is None else k1
        return t0 + h * (np.arange(k0, k1) + stage.position)

    def _stage_positions(self, stage):
        """``stage``'s point positions, fractions of the duration, (N - 1,)."""
        N = self.layout.nodes
        return (np.arange(N - 1) + stage.position) / (N - 1)

    @property
    def n_rows(self):
        return (self.layout.nodes - 1) * len(self.rows)

    @property
    def point_group(self):
        """The index of the evaluation group that holds every point of the
        layout (its nodes), or ``None``."""
        return 0 if any(s.node is not None for s in self.stages) else None

    # the stage points ---------------------------------------------------
    def points(self, t0, h, Y, R, Yi=None, Ri=None):
        """``[(t, Y, R)]`` of the distinct evaluation groups: all nodes (when
        some stage is a node), then each interior stage's points."""
        groups = []
        if self._node_group:
            groups.append((t0 + h * np.arange(self.layout.nodes), Y, R))
        for s in self.stages:
            if s.node is None:
                a0, a1 = s.a
                groups.append((self.stage_times(s, t0, h), a0 * Y[:-1] + a1 * Y[1:],
                               a0 * R[:-1] + a1 * R[1:]))
        return groups

    def _stage_values(self, evaluated):
        """Per stage, the arrays of its N - 1 points from the evaluated groups
        (each a tuple of arrays with a first axis over the group's points)."""
        return [evaluated[g] if sl is None else
                tuple(None if a is None else a[sl] for a in evaluated[g])
                for g, sl in self._stage_groups]

    # values ------------------------------------------------------------
    def values(self, Y, h, evaluated, Yi=None, R=None, Ri=None):
        """Defects, shape ((N - 1) * len(rows),)."""
        rows = self._take
        E = Y[1:, rows] - Y[:-1, rows]
        for s, (f, *_) in zip(self.stages, self._stage_values(evaluated)):
            E = E - h * s.c * f[:, rows]
        return E.ravel()

    def _blocks(self):
        """``(block, width)`` of the column groups of each interval's rows:
        ``("y", o)``, ``("r", o)``, ``"p"``, ``"T"``, ``"t0"``, and their
        columns in each row (:meth:`_block_width`) (made once: the layout is
        fixed)."""
        if self._block_list is None:
            L = self.layout
            offsets = sorted({o for s in self.stages for o in (0, 1) if s.a[o]} | {0, 1})
            blocks = [("y", o) for o in offsets]
            if L.n_inputs:
                blocks += [("r", o) for o in offsets if any(s.a[o] for s in self.stages)]
            self._block_list = tuple((b, self._block_width(b))
                                     for b in blocks + L.shared_blocks())
        return self._block_list

    def pattern(self):
        """``(rows, cols)``: lists of the pieces of the defect rows' Jacobian
        pattern, in the order of :meth:`jacobian`'s values (made when asked,
        not kept: the NLP joins them into its own pattern)."""
        L = self.layout
        N, nd = L.nodes, len(self.rows)
        k = np.arange(N - 1)[:, None, None]
        i = np.arange(nd)[None, :, None]
        rows, cols = [], []
        for block, _ in self._blocks():
            if isinstance(block, str):
                c = L.shared_columns(block)
            elif block[0] == "y" and self._difference_only(block[1]):
                c = (k + block[1]) * L.n_states + np.asarray(self.rows)[None, :, None]
            elif block[0] == "y":
                c = (k + block[1]) * L.n_states + np.arange(L.n_states)[None, None, :]
            else:
                c = L.input_start + (k + block[1]) * L.n_inputs + np.arange(
                    L.n_inputs)[None, None, :]
            shape = (N - 1, nd, c.shape[2])
            rows.append(np.broadcast_to(k * nd + i, shape).ravel())
            cols.append(np.broadcast_to(c, shape).ravel())
        return rows, cols

    def jacobian(self, h, T, evaluated, time_rates):
        """Values in the order of :meth:`pattern`.

        ``evaluated``: per group ``(f, A, B, Pf)`` (Pf: the free parameters'
        columns, or None); ``time_rates``: per group :math:`\\partial
        f/\\partial t` (free duration or start time) or ``None``.
        """
        L = self.layout
        N, rows = L.nodes, self._take
        stages = self._stage_values(evaluated)
        rates = self._stage_values([(r,) for r in time_rates]) if time_rates else None
        shape = (N - 1, len(self.rows))  # each block's values: shape + (its width,)
        size = shape[0] * shape[1]
        values = np.empty(size * sum(width for _, width in self._blocks()))
        start = 0
        for block, width in self._blocks():
            # each block written in place: the blocks not joined
            out = values[start:start + size * width].reshape(shape + (width,))
            start += size * width
            if block == "p":
                out[...] = sum(-h * s.c * Pf[:, rows]
                               for s, (_, _, _, Pf) in zip(self.stages, stages))
            elif block == "T":
                dh = 1.0 / (N - 1)
                v = 0.0
                for j, (s, (f, *_)) in enumerate(zip(self.stages, stages)):
                    v = v - dh * s.c * f[:, rows]
                    if rates is not None:
                        position = self._stage_positions(s)
                        v = v - h * s.c * rates[j][0][:, rows] * position[:, None]
                out[...] = v[:, :, None]
            elif block == "t0":
                out[...] = sum(-h * s.c * rates[j][0][:, rows]
                               for j, s in enumerate(self.stages))[:, :, None]
            elif block[0] == "y" and self._difference_only(block[1]):
                out[...] = 1.0 if block[1] == 1 else -1.0  # each row's own state
            else:  # the states' (A) or the inputs' (B) block, summed where it is written
                o, which = block[1], 1 if block[0] == "y" else 2
                out[...] = self._difference[o] if which == 1 else 0.0
                for s, parts in zip(self.stages, stages):
                    if s.a[o]:
                        out -= h * s.c * s.a[o] * parts[which][:, rows]
        return values

    def _difference_only(self, o):
        """Whether the states at offset ``o`` of an interval enter its rows
        through the difference alone (no stage there: backward Euler's
        earlier node): their block is then each row's own state, one entry a
        row (the pattern holds no structural zeros there)."""
        return not any(s.a[o] for s in self.stages)

    def _block_width(self, block):
        """The columns of a :meth:`_blocks` group in each row."""
        L = self.layout
        if isinstance(block, str):
            return L.shared_columns(block).shape[2]
        if block[0] == "y":
            return 1 if self._difference_only(block[1]) else L.n_states
        return L.n_inputs

    def quadrature(self, h, evaluated_terms):
        """:math:`h \\sum_k \\sum_s c_s L_s`, from the terms evaluated on the
        groups of :meth:`points` (each ``(value, d_t, d_y, d_r, d_p, d_T)``)."""
        stages = self._stage_values(evaluated_terms)
        return sum(h * s.c * float(term[0].sum()) for s, term in zip(self.stages, stages))

    def quadrature_gradient(self, h, evaluated_terms):
        """The gradient of :meth:`quadrature`: ``(gY, gR, gYi, gRi, gP, gT,
        gt0)`` (no interior points here: ``gYi = gRi = None``; ``gt0`` the
        start time's).  ``gT`` and ``gt0`` are left 0.0 where the layout has
        no free duration or start time (no variable takes them)."""
        L = self.layout
        N = L.nodes
        gY, gR = np.zeros((N, L.n_states)), np.zeros((N, L.n_inputs))
        gP, gT, gt0 = np.zeros(L.n_free), 0.0, 0.0
        for stage, (value, d_t, d_y, d_r, d_p, d_T) in zip(
                self.stages, self._stage_values(evaluated_terms)):
            w = h * stage.c
            for o in (0, 1):
                a = stage.a[o]
                # (a part identically zero adds nothing: the sums from 0.0 are
                # never -0.0, so the same numbers without its array of zeros)
                if a and not identically_zero(d_y):
                    gY[o:o + N - 1] += w * a * d_y
                if a and not identically_zero(d_r):
                    gR[o:o + N - 1] += w * a * d_r
            if L.n_free:
                gP += w * d_p.sum(axis=0)
            if L.free_duration:
                gT += stage.c / (N - 1) * value.sum() \
                    + w * np.sum(d_t * self._stage_positions(stage)) + w * d_T.sum()
            if L.free_start_time:
                gt0 += w * np.sum(d_t)
        return gY, gR, None, None, gP, gT, gt0
