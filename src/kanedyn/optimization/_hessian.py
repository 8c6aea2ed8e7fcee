r"""The exact Hessian of the NLP's Lagrangian (``solve(hessian="exact")``).

IPOPT's Lagrangian is :math:`\sigma J(z) + \sum_j \lambda_j g_j(z)`.  Every
part of it that is not linear is a sum over points of a function of

.. math::

    u = (x, p, t, T),\qquad x = (y, r) = \sum_o a_o\, x_{k+o},\qquad
    t = t_0 + \tau T,

at each point: a stage point of a one-step method (:math:`a` its
coefficients, two nodes wide for the midpoint rule) or a point of the layout
(a node, or an interior point of Hermite-Simpson and LGR), :math:`\tau` its
position as a fraction of the duration.  The map from the decision
variables :math:`\xi = (x_{k+o}, p, T, t_0)` of a point to :math:`u` is
linear, :math:`u = D\xi`, so a term :math:`h F(u)` (the dynamics' rows and
the objective's quadrature carry the step :math:`h = T/(N-1)`) contributes

.. math::

    h\, D^T F''(u)\, D + \frac{1}{N-1}\bigl(e_T (D^T F')^T + (D^T F') e_T^T\bigr)

(the last part with a free duration only), and a term without :math:`h`
(path constraints, the Mayer term) :math:`D^T F'' D`.  For the dynamics
:math:`F = \omega^T f`, :math:`\omega` the multipliers of the rows through
the method's weights (:math:`-c_s \lambda_k` for a one-step method,
:math:`\sum_i c_{ig} \lambda_{k,i}` for an interval method); its second
derivatives in :math:`(y, r, p, t)` are generated
(:func:`kanedyn.numerics.weighted_hessians`), its first are the NLP's
(:math:`\partial f/\partial t` by differences, as in the constraint
Jacobian).  The objective's, the path constraints' and the instance
constraints' second derivatives are SymPy's.  Entries repeat where blocks
overlap (IPOPT adds them); only the lower triangle is given, and of it only
the entries where some part can be nonzero: where :math:`F''` is not
identically zero (the model's, :func:`kanedyn.numerics.weighted_hessian_pattern`;
the terms', SymPy's) through each point's :math:`D` (a free duration's row
and column whole).  The swing-up's backward-Euler point holds 2 of its 6
(the angle's and the torque's: the model's forces' terms in the rate cancel,
:func:`kanedyn.numerics.weighted_hessian_pattern`).

A phase of a multiphase problem whose start time is a variable has
:math:`t_0` among each point's variables (:math:`\partial t/\partial t_0 =
1`).  A model with constraints (its dependent states and the residual rows)
is refused, naming the feature.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .._errors import ModelError
from ._nlp import INDEX, index_arrays

__all__ = ["LagrangianHessian", "HESSIANS"]

#: the values of ``solve(hessian=...)``
HESSIANS = ("limited-memory", "exact")

#: a map of the points alike (:meth:`_Points.maps`) of at most this many
#: entries, zeros too, is held dense (its product made by BLAS, not SciPy)
DENSE_MAP_SIZE = 1 << 12

#: the points whose second derivatives are evaluated at once: the values'
#: intermediates (arrays of (points, nu, nu)) are bounded by this many
#: points, not by the nodes
CHUNK_POINTS = 4096


def _chunks(K):
    """``[(k0, k1)]``: the points ``0..K-1`` in runs of :data:`CHUNK_POINTS`."""
    return [(k0, min(K, k0 + CHUNK_POINTS)) for k0 in range(0, K, CHUNK_POINTS)]


def _run(arrays, at):
    """The points ``at`` (a slice) of each array of ``arrays`` (``None`` kept)."""
    return tuple(None if a is None else a[at] for a in arrays)


def _row_block(matrix, p0, p1, c0, c1):
    """Rows ``p0:p1`` of the CSR ``matrix`` whose entries all lie in columns
    ``c0:c1``, as a CSR matrix of shape (p1 - p0, c1 - c0) (its values
    shared, the block's column indices shifted: a copy of the block's)."""
    from scipy.sparse import csr_matrix
    if p0 == 0 and p1 == matrix.shape[0] and c0 == 0 and c1 == matrix.shape[1]:
        return matrix
    a, b = matrix.indptr[p0], matrix.indptr[p1]
    return csr_matrix((matrix.data[a:b], matrix.indices[a:b] - c0,
                       matrix.indptr[p0:p1 + 1] - a), shape=(p1 - p0, c1 - c0))


class _Points:
    """Points of one kind: their decision variables ``variables()`` (K, m;
    made when asked, not held), the linear
    map ``D`` (K, nu, m) from them to :math:`u` (a read-only broadcast of one
    point's when it is the same at every point), the mask of each point's
    entries (K, m, m): the lower triangle where ``pattern`` ((nu, nu) bool,
    where :math:`F''` can be nonzero; ``None``: anywhere) through ``D`` can
    be nonzero (a read-only broadcast of one point's when the same at every
    point), the column of a free duration among the m (or ``None``).

    ``alike`` (the number of entries of a point, else ``None``) when every
    point has the same map and the same mask: then :meth:`maps` are one
    point's, applied to every point."""

    def __init__(self, variables, D, duration=None, pattern=None):
        self.variables, self.D, self.duration = variables, D, duration
        V = variables()
        K, m = V.shape
        kept = (np.ones((m, m), dtype=bool) if pattern is None
                else self._point_pattern(D, pattern, duration))
        first = (V[:1, :, None] >= V[:1, None, :]) & kept
        if all((((V[k0:k1, :, None] >= V[k0:k1, None, :]) & kept) == first).all()
               for k0, k1 in _chunks(K)):
            # one point's, broadcast: its entries start at multiples of one count
            self.mask = np.broadcast_to(first, (K, m, m))
            self._count, self._starts = int(np.count_nonzero(first)), None
        else:
            self.mask = (V[:, :, None] >= V[:, None, :]) & kept
            self._count = None
            #: where each point's entries start among the points' (K + 1,): a
            #: point's entries follow the previous point's
            self._starts = np.concatenate([[0], np.cumsum(np.count_nonzero(self.mask,
                                                                           axis=(1, 2)))])
        self.size = self.start(K)
        same_map = D is not None and D.shape[0] > 0 and D.strides[0] == 0
        self.alike = self._count if same_map else None
        self._maps = None
        #: the columns of the flattened F'' that a dense map takes (see maps)
        self.dense_columns = None

    @staticmethod
    def _point_pattern(D, pattern, duration):
        """(m, m) bool: where :math:`D^T F'' D` (and a free duration's part,
        its whole row and column) can be nonzero at any point."""
        used = np.any(D != 0.0, axis=0).astype(int)  # (nu, m)
        kept = (used.T @ pattern.astype(int) @ used) > 0
        if duration is not None:
            kept[duration, :] = kept[:, duration] = True
        return kept

    def start(self, k):
        """Where the entries of point ``k`` start among the points' (``k =
        K``: their number)."""
        return k * self._count if self._starts is None else int(self._starts[k])

    def maps(self, steps):
        r"""``(second, first)``: sparse matrices that take the flattened
        :math:`F''` (K, nu, nu) to :math:`D^T F'' D` and the flattened
        :math:`F'` (K, nu) to the free duration's part
        :math:`(e_T (D^T F')^T + (D^T F') e_T^T) / \mathrm{steps}`, both at the
        entries of :meth:`pattern` (``first`` is ``None`` without a free
        duration); of the first point alone when the points are ``alike``
        (no free duration then), ``second`` then a dense array where it holds
        at most :data:`DENSE_MAP_SIZE` entries, of the columns
        ``dense_columns`` of the flattened :math:`F''` alone.  Made on first
        use: only D's nonzero entries take part."""
        if self._maps is None:
            second, first = self._make_maps(steps)
            if self.alike is not None and second.shape[0] * second.shape[1] <= DENSE_MAP_SIZE:
                # (a dense product is quicker at this size) over the columns
                # it uses: another entry of F'' (not finite, say) takes no part
                self.dense_columns = np.unique(second.indices)
                second = second[:, self.dense_columns].toarray()
            self._maps = second, first
        return self._maps

    def _make_maps(self, steps):
        D = self.D
        K, nu, m = D.shape
        i, a = np.nonzero(np.any(D != 0.0, axis=0))  # D's pattern, shared by the points
        run = max(1, min(CHUNK_POINTS, 2_000_000 // max(1, len(i) ** 2)))

        def second(k0, k1, place):
            k = np.arange(k1 - k0)[:, None, None]
            c = (D[k0 + k, i[None, :, None], a[None, :, None]]
                 * D[k0 + k, i[None, None, :], a[None, None, :]])
            r = place[k, a[None, :, None], a[None, None, :]]
            col = (k * nu + i[None, :, None]) * nu + i[None, None, :]
            keep = (r >= 0) & (c != 0.0)
            return r[keep], col[keep], c[keep]

        def first(k0, k1, place):
            # row j of the point's block gets D^T F' in its columns, column j in its rows
            rows, cols, coefficients = [], [], []
            j = self.duration
            for side in (0, 1):
                k = np.arange(k1 - k0)[:, None]
                other = a[None, :]
                r = place[k, j, other] if side == 0 else place[k, other, j]
                c = np.broadcast_to(D[k0 + k, i[None, :], a[None, :]] / steps, r.shape)
                col = np.broadcast_to(k * nu + i[None, :], r.shape)
                keep = (r >= 0) & (c != 0.0)
                rows.append(r[keep])
                cols.append(col[keep])
                coefficients.append(c[keep])
            return np.concatenate(rows), np.concatenate(cols), np.concatenate(coefficients)

        return (self._by_runs(nu * nu, run, second),
                None if self.duration is None else self._by_runs(nu, run, first))

    def _by_runs(self, width, run, entries):
        """The CSR matrix (size, K * width) whose entries at the points
        ``k0:k1`` are ``entries(k0, k1, place)``: ``(rows, cols, values)``
        relative to those points' (their rows numbered by ``place``, (k1 -
        k0, m, m), -1 off the lower triangle; their columns from ``k0 *
        width``).  Made ``run`` points at a time, each run's rows a block of
        their own: the matrix SciPy makes of all the entries at once (rows
        in order, each row's columns sorted), without every entry's indices
        in 64 bits at once.  Of the first point alone (its entries, its
        columns) when the points are ``alike``."""
        from scipy.sparse import csr_matrix
        K = 1 if self.alike is not None else self.mask.shape[0]
        index = np.int32 if 2 * K * width < np.iinfo(np.int32).max else np.int64
        data, indices, indptr = [], [], [np.zeros(1, dtype=index)]
        for k0 in range(0, K, run):
            k1 = min(K, k0 + run)
            p0, p1 = self.start(k0), self.start(k1)
            place = np.full(self.mask[k0:k1].shape, -1, dtype=np.int64)
            place[self.mask[k0:k1]] = np.arange(p1 - p0)
            rows, cols, values = entries(k0, k1, place)
            block = csr_matrix((values, (rows, cols)), shape=(p1 - p0, (k1 - k0) * width))
            data.append(block.data)
            indices.append(block.indices.astype(index) + k0 * width)
            indptr.append(block.indptr[1:].astype(index) + indptr[-1][-1])
        return csr_matrix((np.concatenate(data), np.concatenate(indices),
                           np.concatenate(indptr)), shape=(self.start(K), K * width))

    def pattern(self):
        """``(rows, cols)`` of its entries of the lower triangle (made when
        asked, not kept)."""
        shape, V = self.mask.shape, self.variables()
        return (np.broadcast_to(V[:, :, None], shape)[self.mask],
                np.broadcast_to(V[:, None, :], shape)[self.mask])


class LagrangianHessian:
    """Pattern and values of the Lagrangian's Hessian of ``nlp`` (a
    :class:`._nlp.CollocationNLP`)."""

    def __init__(self, nlp):
        from ..numerics import hessians_unavailable, weighted_hessian_pattern, weighted_hessians
        pb, L = nlp.problem, nlp.layout
        if pb.n_residuals:
            raise ModelError('hessian="exact" is not available for a model with constraints '
                             '(use hessian="limited-memory")')
        reason = hessians_unavailable(pb.model)
        if reason:
            raise ModelError(f'hessian="exact": {reason}')
        self.nlp = nlp
        self.nx = nx = L.n_states + L.n_inputs
        self.nf = nf = L.n_free
        self.nu = nx + nf + 2
        self.time = L.free_duration or L.free_start_time
        self._weighted_hessians = weighted_hessians  # imported once, not per call
        #: F' is needed (by the free duration's part, :meth:`_Points.maps`) only
        #: with a free duration: without one it is not computed
        self._first = bool(L.free_duration)
        # where the generated Hessian's rows and columns go in u: a leading
        # block (slices) unless the time follows free parameters it lacks
        index = list(range(nx + len(pb.free_columns))) + [nx + nf] * bool(self.time)
        self._h_index = ((slice(0, len(index)),) * 2 if index == list(range(len(index)))
                         else (np.array(index)[:, None], np.array(index)[None, :]))
        self.interval = not hasattr(nlp.defects, "stages")
        # where F'' can be nonzero in u: the dynamics' (the model's structure),
        # with the objective's integrand where it is added
        dynamics = np.zeros((self.nu, self.nu), dtype=bool)
        dynamics[self._h_index] = weighted_hessian_pattern(pb.model, pb.free_columns,
                                                           self.time)
        if pb.lagrange is not None:
            dynamics |= pb.lagrange.hessian_pattern()
        N = L.nodes

        def point_vars():  # (N, nx): each node's states and inputs
            return np.concatenate(L.point_columns(), axis=1)
        self.stages = []
        if not self.interval:
            for s in nlp.defects.stages:
                offsets = [o for o in (0, 1) if s.a[o]]
                self.stages.append(self._points(
                    lambda offsets=offsets: [point_vars()[o:o + N - 1] for o in offsets],
                    [s.a[o] for o in offsets],
                    (np.arange(N - 1) + s.position) / (N - 1), dynamics))
        self.at_points = None
        if self.interval or pb.path or pb.mayer is not None:
            at_points = dynamics.copy() if self.interval else np.zeros_like(dynamics)
            for term in [path.term for path in pb.path] + [pb.mayer] * (pb.mayer is not None):
                at_points |= term.hessian_pattern()
            self.at_points = self._points(lambda: [point_vars()], [1.0], L.positions(),
                                          at_points)
        self.instances = [_Points(lambda c=c: c[None, :], None) for c in nlp._instance_columns]

    def structure(self):
        """``(rows, cols)`` of the lower triangle's entries, :data:`._nlp.INDEX`
        (made when asked, not held: a solver keeps its own)."""
        parts = self.stages + [self.at_points] * (self.at_points is not None) + self.instances
        patterns = [p.pattern() for p in parts]
        return index_arrays([r for r, _ in patterns], [c for _, c in patterns],
                            self.nlp.n, self.nlp.n)

    def _points(self, blocks, a, tau, pattern):
        """:class:`_Points` of the combinations ``sum_b a_b blocks()[b]`` (each
        (K, nx) columns, made when asked) at the positions ``tau`` (K,), where
        :math:`F''` in u can be nonzero ``pattern`` ((nu, nu) bool)."""
        L = self.nlp.layout
        nx, nf, K, nb = self.nx, self.nf, len(tau), len(a)
        shared = list(L.free_start + np.arange(nf))
        if L.free_duration:
            shared.append(L.duration_index)
        if L.free_start_time:
            shared.append(L.start_index)
        shared = np.broadcast_to(np.array(shared, dtype=int), (K, len(shared)))

        def variables():
            return np.concatenate(blocks() + [shared], axis=1, dtype=INDEX, casting="same_kind")
        # the same map at every point but for a free duration's column (tau):
        # one point's, broadcast to all, else one per point
        D = np.zeros((1, self.nu, nb * nx + shared.shape[1]))
        i = np.arange(nx)
        for b in range(nb):
            D[:, i, b * nx + i] = a[b]
        D[:, nx + np.arange(nf), nb * nx + np.arange(nf)] = 1.0
        col = duration = nb * nx + nf
        if L.free_duration:
            D = np.repeat(D, K, axis=0)
            D[:, nx + nf, col] = tau
            D[:, nx + nf + 1, col] = 1.0
            col += 1
        if L.free_start_time:
            D[:, nx + nf, col] = 1.0
        if not L.free_duration:
            D = np.broadcast_to(D, (K,) + D.shape[1:])
        return _Points(variables, D, duration if L.free_duration else None, pattern)

    # ---------------------------------------------------------- the parts
    def _dynamics(self, e, t, Ys, Rs, W, evaluated, rate):
        """``(F'', F')`` in :math:`u` of :math:`F = \\omega^T f` at K points,
        ``W`` (K, n_states) the weights :math:`\\omega` (``F'`` ``None``
        without a free duration, which alone takes it)."""
        pb = self.nlp.problem
        f, A, B, Pf = evaluated
        K, nx, nf = len(t), self.nx, self.nf
        columns = pb.free_columns
        H = self._weighted_hessians(e["model"], t, Ys, Rs, W,
                                    SimpleNamespace(f=f, state=A, inputs=B),
                                    parameters=columns, time=self.time)
        Hu = np.zeros((K, self.nu, self.nu))
        Hu[:, self._h_index[0], self._h_index[1]] = H
        if not self._first:
            return Hu, None
        gu = np.zeros((K, self.nu))
        gu[:, :nx] = np.einsum("ki,kij->kj", W, np.concatenate([A, B], axis=2))
        if nf:
            gu[:, nx:nx + nf] = np.einsum("ki,kij->kj", W, Pf)
        if rate is not None:
            gu[:, nx + nf] = np.sum(W * rate, axis=1)
        return Hu, gu

    def _term(self, term, t, Y, R, P, T):
        """``(F'', F')`` in :math:`u` of a user's term at K points (``F'``
        ``None`` without a free duration, as in :meth:`_dynamics`)."""
        if not self._first:
            return term.hessian(t, Y, R, P, T), None
        _, d_t, d_y, d_r, d_p, d_T = term(t, Y, R, P, T)
        gu = np.concatenate([d_y, d_r, d_p, d_t[:, None], d_T[:, None]], axis=1)
        return term.hessian(t, Y, R, P, T), gu

    def _assemble(self, points, k0, k1, h, out, stepped=None, plain=None):
        """The values of the points ``k0:k1`` of ``points`` into ``out`` (their
        entries, in order): ``stepped = (F'', F')`` of the terms carrying the
        step h, ``plain`` :math:`F''` of the others, both of those points
        (the caller's arrays, overwritten: scaled and summed in place)."""
        second, first = points.maps(self.nlp.layout.nodes - 1)
        if stepped is not None:
            Hu = stepped[0]
            Hu *= h
            if plain is not None:
                Hu += plain
        else:
            Hu = plain
        p0, p1 = points.start(k0), points.start(k1)
        nu = self.nu
        values = out[p0:p1]
        if points.alike is not None:  # one point's map, each point's sums as the whole map's
            flat = Hu.reshape(k1 - k0, nu * nu)
            if points.dense_columns is not None:
                flat = flat[:, points.dense_columns]
            values.reshape(k1 - k0, points.alike)[...] = flat @ second.T
            return
        values[...] = _row_block(second, p0, p1, k0 * nu * nu, k1 * nu * nu) @ Hu.reshape(-1)
        if stepped is not None and first is not None:
            values += _row_block(first, p0, p1, k0 * nu, k1 * nu) @ stepped[1].reshape(-1)

    # ------------------------------------------------------------- values
    def values(self, z, sigma, multipliers):
        """The Hessian's values in the order of :meth:`structure`."""
        nlp = self.nlp
        e = nlp._evaluate(z)
        pb, L = nlp.problem, nlp.layout
        multipliers = np.asarray(multipliers, dtype=float)
        N, ns, K = L.nodes, L.n_states, L.n_points
        h, P, T = e["h"], e["P"], e["T"]
        defects = nlp.defects
        n_defects = defects.n_rows
        kinds = self.stages + [self.at_points] * (self.at_points is not None)
        for points in kinds:
            points.maps(N - 1)  # made on the first call, before the (K, nu, nu) arrays
        out = np.empty(sum(p.size for p in kinds + self.instances))
        offset = 0
        if not self.interval:
            rows = defects.rows
            lam = multipliers[:(N - 1) * len(rows)].reshape(N - 1, len(rows))
            if not isinstance(defects._take, slice):  # not every state, in order
                lam, collocated = np.zeros((N - 1, ns)), lam
                lam[:, rows] = collocated
            stages = defects._stage_values(e["evaluated"])
            rates = (defects._stage_values([(r,) for r in e["rates"]]) if e["rates"]
                     else [None] * len(stages))
            for s, values, rate, points in zip(defects.stages, stages, rates, self.stages):
                for k0, k1 in _chunks(N - 1):
                    at = slice(k0, k1)
                    t = defects.stage_times(s, e["t0"], h, k0, k1)
                    Ys = s.a[0] * e["Y"][k0:k1] + s.a[1] * e["Y"][k0 + 1:k1 + 1]
                    Rs = s.a[0] * e["R"][k0:k1] + s.a[1] * e["R"][k0 + 1:k1 + 1]
                    Hu, gu = self._dynamics(e, t, Ys, Rs, -s.c * lam[at], _run(values, at),
                                            None if rate is None else rate[0][at])
                    if pb.lagrange is not None and sigma:
                        HL, gL = self._term(pb.lagrange, t, Ys, Rs, P, T)
                        HL *= sigma * s.c  # in place: one (K, nu, nu) array less at a time
                        Hu += HL
                        if gu is not None:
                            gu += sigma * s.c * gL
                        del HL
                    self._assemble(points, k0, k1, h, out[offset:], stepped=(Hu, gu))
                offset += points.size
        if self.at_points is not None:
            t_points = nlp._point_times(e)
            weights = (self._interval_weights(multipliers[:n_defects]) if self.interval
                       else None)
            for k0, k1 in _chunks(K):
                at = slice(k0, k1)
                stepped = None
                if self.interval:
                    stepped = self._interval_parts(e, weights, sigma, at)
                plain = np.zeros((k1 - k0, self.nu, self.nu))
                start = n_defects
                for path in pb.path:
                    mu = multipliers[start + k0:start + k1]
                    plain += mu[:, None, None] * path.term.hessian(
                        t_points[at], e["Yp"][at], e["Rp"][at], P, T)
                    start += K
                if pb.mayer is not None and sigma and k0 <= N - 1 < k1:
                    last = slice(N - 1 - k0, N - k0)
                    plain[last] += sigma * pb.mayer.hessian(t_points[N - 1:N], e["Y"][-1:],
                                                            e["R"][-1:], P, T)
                self._assemble(self.at_points, k0, k1, h, out[offset:], stepped=stepped,
                               plain=plain)
            offset += self.at_points.size
        start = n_defects + K * (len(pb.path) + pb.n_residuals)
        for inst, points, mu in zip(pb.instances, self.instances, multipliers[start:]):
            H = np.zeros((1,) + points.mask.shape[1:])
            if inst.hessian is not None:
                full = inst.hessian(nlp._instance_arguments(inst, e))
                n = points.mask.shape[1]
                H[0] = mu * full[:n, :n]  # without T's row and column when T is fixed
            out[offset:offset + points.size] = H[points.mask]
            offset += points.size
        return out

    def _interval_weights(self, lam):
        """``(W, quadrature)`` of an interval method at every point: the
        weights (K, n_states) of the dynamics' rows through the scheme, and
        the objective's quadrature weights (K,)."""
        nlp = self.nlp
        L, defects = nlp.layout, nlp.defects
        scheme, rows = defects.scheme, defects.rows
        N, m, K = L.nodes, len(L.interior), L.n_points
        n_kinds, nd = scheme.n_rows, len(rows)
        lam = lam[:(N - 1) * n_kinds * nd].reshape(N - 1, n_kinds, nd)
        k = np.arange(N - 1)
        where = [k] + [N + k * m + g for g in range(m)] + [k + 1]
        weights = np.zeros((K, nd))
        quadrature = np.zeros(K)
        for g, at in enumerate(where):
            weights[at] += np.einsum("i,kid->kd", scheme.c[:, g], lam)
            quadrature[at] += scheme.weights[g]
        W = np.zeros((K, L.n_states))
        W[:, rows] = weights
        return W, quadrature

    def _interval_parts(self, e, weights, sigma, at):
        """``(F'', F')`` at the points ``at`` (a slice) of an interval method:
        the dynamics' rows through the scheme's ``weights``
        (:meth:`_interval_weights`), and the objective's quadrature."""
        pb = self.nlp.problem
        W, quadrature = weights
        t = self.nlp._point_times(e)[at]
        rate = e["rates"][0][at] if e["rates"] else None
        Hu, gu = self._dynamics(e, t, e["Yp"][at], e["Rp"][at], W[at],
                                _run(e["evaluated"][0], at), rate)
        if pb.lagrange is not None and sigma:
            HL, gL = self._term(pb.lagrange, t, e["Yp"][at], e["Rp"][at], e["P"], e["T"])
            HL *= sigma * quadrature[at, None, None]  # in place, as for the one-step methods
            Hu += HL
            if gu is not None:
                gu += sigma * quadrature[at, None] * gL
        return Hu, gu
