"""The elimination order of :class:`~._sparse.SparseKKT`.

The collocation NLP lays its variables out by kind (the states of every node,
then the inputs of every node, then free parameters and the duration, then
interior points) and its constraints by interval, so the KKT matrix in its own
order has no band; ordered by node it has one, a few rows and columns wide,
plus a few dense ones (a free duration or parameter is in every defect row;
instance constraints join the first and the last node).

:func:`elimination_order`:

1. rows whose degree in the graph of K exceeds :func:`dense_threshold` go
   last (a dense row eliminated early would make every row it touches dense,
   and it would spoil the band that step 3 looks for);
2. every other constraint row is paired with a variable of its own, by a
   maximum matching of the Jacobian's pattern (SciPy's
   ``maximum_bipartite_matching``; variables without a diagonal Hessian
   entry matched first where that loses no row): a defect row with one of
   the states it relates;
3. reverse Cuthill-McKee (:func:`reverse_cuthill_mckee`, from a
   pseudo-peripheral node) orders the graph whose nodes are the pairs
   and the unpaired rows (the band, found whatever the layout), in the
   direction that sweeps backward (:func:`_band`): most of the
   other variables of a paired row after its pair;
4. each pair is eliminated variable first, then its constraint; rows that
   a factorization delayed (``delayed``) and the dense rows last.

Step 4 keeps a constraint row from being eliminated before all of its
variables (with ``diagonal_c = 0`` its 1 x 1 pivot would be exactly zero),
and :class:`~._sparse.SparseKKT` eliminates each pair as one 2 x 2
pivot, nonsingular where the variable's diagonal is zero too.

The direction of step 3 matters because nothing pivots at run time: a
defect row paired with the state at the later node of its interval,
eliminated after the earlier node's state and input, carries the Schur
complement of everything before it forward in time, which grows like the
dynamics' unstable modes (forward shooting).  On the 100-node trapezoid
swing-up the constraint rows' pivots so grew by about 2 per interval near
the upright end, to 2e13 beside entries of 21, until one counted as zero
at the 41st factorization of a Newton step (a spurious regularization;
then one iteration more than with ``DenseKKT``).  Swept backward, each pair is
eliminated before the variables its row holds, as the Riccati recursion
eliminates the later stage first: the constraint rows' pivots stay
bounded, and every matrix of that solve has eigvalsh's inertia
(``tests/test_kkt_sparse.py``).  Neither way suits every problem: on the
backward-Euler swing-up from 20,000 nodes, whose final state is fixed, the
backward sweep begins with the last defect rows, paired through an entry
of h (the torque's) where the rate's is 1; the 2 x 2 pivot puts 1/h^2 on the
last free rate, beside which the next pair's pivot counts as zero.
Forward, every matrix of that solve factors with no zero pivot.  So
:class:`~._sparse.SparseKKT` sweeps the other way before it delays rows
(``backward``).  The first order starts from either end of the band; to
run the other way it starts from the far end of the first.

Chosen by measurement (``benchmarks/bench_kkt_factor.py --orders``, the
pendulum swing-up's NLP with a free duration, exact Hessian at random
multipliers, ``diagonal_x = 1e-4``, ``diagonal_c = 0``; 2026-11-29, load
1.7-4.4 on 2 cores; ``docs/benchmarks.md``):

- entries of L below the diagonal at 1,000 / 10,000 nodes, trapezoid: 24,977
  / 249,977 with the pairs by RCM run forward (before the backward sweep),
  26,979 / 269,979 swept backward (from the other end of the band: 8 % more);
  28,963 / 289,963 with the pairs in
  SuperLU's multiple minimum degree order (``ordering="pairs-mmd"``); 20,985
  / 209,985 by RCM on the rows without pairs (``ordering="rcm"``); 19,979 /
  199,979 in SuperLU's minimum degree order on the rows (SciPy's ``splu``,
  ``permc_spec="MMD_AT_PLUS_A"``, no pivoting).  Hermite-Simpson: 73,844 /
  739,796 forward, 70,928 / 709,928 backward; 78,869 / 789,869; 54,951 /
  549,951; 47,275 / 473,385.  With the band started at a pseudo-peripheral
  node (2026-11-30) the same but at 10,000 Hermite-Simpson nodes after the
  first factorization's new pairs: 699,929 swept backward (699,934 before),
  and by the rows' RCM 549,951 until its factorizations delayed rows with
  zero pivots, then 1,103,377 (its orders without those rows).  On the
  backward-Euler swing-up (its fixed initial and final states left out)
  SciPy's RCM had started in the middle of the band: 30.1 entries a node at
  2,000 nodes, 18.0 now (17.8 at 200 nodes both); 16.0 since the earlier
  node's states hold one entry a row of the pattern (27.8 from the middle).  In the NLP's own order
  (the band not found) L had 3.96 times the entries it has with the pairs
  at 41 trapezoid nodes (``tests/test_kkt_sparse.py`` checks more than 3);
- ``factor`` took 0.61x-0.97x the time in the rows' RCM order, 0.87x-1.53x
  with the pairs by minimum degree (100 to 10,000 nodes, both methods,
  three runs):
  the pairs' fill is the two columns of each pair sharing their rows;
- in exchange, no breakdown where a diagonal is zero on both sides of a
  pair: ``K = [[0, Jᵀ], [J, 0]]`` has zero pivots in the rows' RCM order and
  eigvalsh's inertia with the pairs, and so has the free-duration trapezoid
  NLP at 11 nodes with ``diagonal_x = 0`` and ``diagonal_c = 0``
  (``tests/test_kkt_sparse.py``).  An unpaired variable without a Hessian
  or barrier term can still meet a zero pivot, and a pair made through a
  Jacobian entry whose value is 0; ``SparseKKT`` then orders again for the
  values (its module's docstring).
"""

from __future__ import annotations

import numpy as np

from ._kernel import kernel
from ._periodic import ENTRIES_CHUNK, entries, kernel_index

__all__ = ["elimination_order", "dense_threshold", "ORDERINGS"]

#: the orders :func:`elimination_order` knows: ``"pairs"`` (the default, above),
#: and for comparison ``"rcm"`` (reverse Cuthill-McKee on the rows themselves, no
#: pairs) and ``"pairs-mmd"`` (the pairs in SuperLU's multiple minimum degree
#: order instead of RCM, :func:`_minimum_degree`)
ORDERINGS = ("pairs", "rcm", "pairs-mmd")


def dense_threshold(degrees):
    """The degree above which a row counts as dense and is ordered last:
    ``max(16, 10 x`` the mean degree ``)``, ``degrees`` the number of
    off-diagonal entries of each row.  Cuthill-McKee numbers a graph by
    levels of a breadth-first search; one row joined to most others puts
    them all in two levels and the band is lost, so the rule is relative to
    the typical row, not to the matrix's order."""
    return max(16.0, 10.0 * float(np.mean(degrees))) if len(degrees) else 16.0


def _minimum_degree(graph):
    """The order of the nodes of ``graph`` (symmetric CSR) by SuperLU's multiple
    minimum degree on A + Aᵀ: SciPy's ``splu`` of a diagonally dominant matrix
    of that pattern (no pivoting off the diagonal), its ``perm_c``."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    size = graph.shape[0]
    if size == 0:
        return np.zeros(0, dtype=np.int64)
    pattern = sp.csc_matrix((-np.ones(graph.nnz), graph.indices, graph.indptr),
                            shape=graph.shape)
    matrix = pattern + sp.diags(np.diff(graph.indptr) + 1.0)
    position = splu(matrix.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                    options={"SymmetricMode": True}).perm_c
    return np.argsort(position)


def _indices(a):
    """``a`` as a C-contiguous int32 array (the kernel's index type; a copy
    only when it is not one)."""
    return np.ascontiguousarray(a, dtype=np.int32)


def _csr(shape, made):
    """The 0/1 pattern (CSR, int8 ones) of the kernel's ``(indptr, indices)``
    buffers ``made``, without a copy."""
    import scipy.sparse as sp
    indptr, indices = (np.frombuffer(b, dtype=np.int32) for b in made)
    return sp.csr_matrix((np.ones(indices.size, dtype=np.int8), indices, indptr),
                         shape=shape)


def _part(rows, cols, row_offset, mask=None):
    """A part of a pattern's entries as the kernel takes it: ``(rows + row_offset,
    cols)`` where ``mask`` (all where ``None``); rows and cols int32 arrays or
    :class:`~._periodic.PeriodicIndex` runs, walked, not made whole."""
    return (kernel_index(rows), kernel_index(cols), int(row_offset),
            None if mask is None else np.ascontiguousarray(mask, dtype=bool))


class _Pattern:
    """A symmetric pattern's CSR arrays alone, ``indptr`` and ``indices``
    (int32, read from the kernel's buffers without a copy), with ``shape``
    and ``nnz``: what the orders read of the compressed graph (no array of
    ones beside them, as SciPy's matrix holds)."""

    def __init__(self, shape, made):
        self.shape = shape
        self.indptr, self.indices = (np.frombuffer(b, dtype=np.int32) for b in made)
        self.nnz = self.indices.size


def _made(shape, parts, symmetric):
    """The 0/1 pattern (CSR, int8 ones, int32 indices) of a ``shape`` matrix
    with the entries of ``parts``, each ``(rows, cols, row_offset[, mask])``
    for the entries ``(rows + row_offset, cols)`` (where ``mask``), and with
    ``symmetric`` their mirror images: repeats merged, each row's columns
    increasing, as SciPy's COO to CSR conversion with ``sum_duplicates`` makes
    them (the kernel's ``csr``, no int64 copy of the entries)."""
    return _csr(shape, kernel().csr(shape[0], shape[1], bool(symmetric),
                                    *(_part(*part) for part in parts)))


def _mask(rows, cols, keep):
    """``keep(rows, cols)`` (a boolean of each entry's row and column) for
    every entry, made a chunk of :data:`~._periodic.ENTRIES_CHUNK` entries at a time (no index
    array made whole)."""
    out = np.empty(len(rows), dtype=bool)
    for start in range(0, out.size, ENTRIES_CHUNK):
        stop = min(out.size, start + ENTRIES_CHUNK)
        out[start:stop] = keep(entries(rows, start, stop), entries(cols, start, stop))
    return out


def _pattern(shape, rows, cols):
    """The 0/1 pattern (CSR) of the entries ``(rows, cols)`` (:func:`_made`)."""
    return _made(shape, [(rows, cols, 0)], False)


def _submatrix(pattern, rows, cols):
    """``pattern[rows][:, cols]`` (CSR) for sorted index arrays ``rows`` (or
    ``None``: all) and ``cols``: the entries kept in their order, renumbered
    (increasingly, so still in :func:`_pattern`'s order).  Only the kept
    rows' entries are read (SciPy's rows); ``pattern`` itself where ``rows``
    and ``cols`` are all of them, and its rows with their columns renumbered
    where no entry lies in a column left out."""
    import scipy.sparse as sp
    m, n = pattern.shape
    if rows is not None and rows.size < m:
        pattern, m = pattern[rows], rows.size
    if cols.size == n:
        return pattern
    col_place = np.full(n, -1, dtype=np.int32)
    col_place[cols] = np.arange(cols.size, dtype=np.int32)
    c = col_place[pattern.indices]
    del col_place
    if (c >= 0).all():  # the same entries: only their columns' numbers change
        return sp.csr_matrix((pattern.data, c, pattern.indptr), shape=(m, cols.size))
    at = np.flatnonzero(c >= 0)
    r = np.searchsorted(pattern.indptr, at, side="right").astype(np.int32) - 1
    c = c[at]
    del at
    return _pattern((m, cols.size), r, c)


def _matching(pattern, preferred, full=None):
    """``partner[i]``: the column matched to row ``i`` of ``pattern`` (m x n,
    CSR), or -1: a maximum matching that matches as many of the ``preferred``
    columns (a boolean mask) as it can first, where that loses no row; with
    ``full`` (a callable that makes a pattern holding ``pattern``, called
    only where ``pattern``'s matching leaves a row unmatched), one of
    ``full``'s when ``pattern`` alone matches fewer rows."""
    from scipy.sparse.csgraph import maximum_bipartite_matching

    partner = np.full(pattern.shape[0], -1, dtype=np.int32)
    cols = np.flatnonzero(preferred)
    if cols.size:
        first = maximum_bipartite_matching(_submatrix(pattern, None, cols),
                                           perm_type="column")
        partner = np.where(first >= 0, cols[np.maximum(first, 0)], -1).astype(np.int32)
        del first
    rows, cols = np.flatnonzero(partner < 0), np.flatnonzero(~preferred)
    if rows.size and cols.size:
        second = maximum_bipartite_matching(_submatrix(pattern, rows, cols),
                                            perm_type="column")
        partner[rows] = np.where(second >= 0, cols[np.maximum(second, 0)], -1)
        del second
    del rows, cols
    matched = int(np.count_nonzero(partner >= 0))
    if matched == pattern.shape[0]:
        return partner  # every row: a maximum matching (``full`` not made)
    best = maximum_bipartite_matching(pattern if full is None else full(),
                                      perm_type="column")
    return partner if matched >= (best >= 0).sum() else best


def _backward_share(order, node, n, block, jr, jc):
    """The share of the paired constraints' other variables that ``order``
    (of the compressed graph's nodes) puts after their pair (1 where there
    are none): at least half, it sweeps backward.

    A band order runs along the collocation's nodes one way or the other.
    With a defect row paired with the state it defines, eliminating the pairs
    before the states and inputs that define them sweeps backward in time,
    as the Riccati recursion does, and the pivots stay bounded; the other way
    is forward shooting, and the constraint rows' pivots grow like the
    dynamics' unstable modes (the pendulum near upright: doubling at each
    interval, to 2e13 beside entries of 21).  ``node``: the node of each row
    of K (-1 for the rows left out); ``block``: the row each row is paired
    into (itself when unpaired)."""
    rank = np.empty(order.size, dtype=np.int32)
    rank[order] = np.arange(order.size, dtype=np.int32)
    row_rank = np.where(node >= 0, rank[np.maximum(node, 0)], -1)  # of each row of K
    del rank
    before = counted = 0
    for start in range(0, len(jr), ENTRIES_CHUNK):  # (the temporaries of a chunk only)
        rows = n + entries(jr, start, start + ENTRIES_CHUNK)
        cols = entries(jc, start, start + ENTRIES_CHUNK)
        partner = block[rows]
        use = (partner != rows) & (cols != partner) & (row_rank[rows] >= 0) & (
            row_rank[cols] >= 0)
        before += int(np.count_nonzero(row_rank[cols[use]] < row_rank[rows[use]]))
        counted += int(np.count_nonzero(use))
    return 1.0 - before / counted if counted else 1.0


def reverse_cuthill_mckee(graph, start=-1):
    """Reverse Cuthill-McKee's order of the nodes of ``graph`` (symmetric
    CSR), each component numbered from a pseudo-peripheral node, or from
    ``start`` (``>= 0``) for its own (the kernel's ``cuthill_mckee``,
    reversed).

    SciPy's ``reverse_cuthill_mckee`` starts each component from a node of
    least degree, which in a collocation's graph may lie anywhere along the
    nodes (most have the same degree): started in the middle, the levels
    hold nodes of both halves and the band is twice as wide (the envelope of
    the backward-Euler swing-up's L had 30.1 entries a node at 2,000 nodes,
    17.8 at 200).  A pseudo-peripheral node is an end of the band."""
    order = np.empty(graph.shape[0], dtype=np.int32)
    kernel().cuthill_mckee(order, _indices(graph.indptr), _indices(graph.indices),
                           int(start))
    return order[::-1].copy()


def _band(graph, node, n, block, jr, jc, backward=True):
    """Reverse Cuthill-McKee's order of ``graph`` (:func:`reverse_cuthill_mckee`)
    that sweeps backward (:func:`_backward_share` at least a half; with
    ``backward=False`` forward, below a half): from a pseudo-peripheral
    node; else from the other end of that order, where that sweeps further
    that way (pairs whose other variables lie at their own node, as the
    interior points' of Hermite-Simpson after the pairs are made again for
    the values, can leave both below a half)."""
    order = reverse_cuthill_mckee(graph)
    share = _backward_share(order, node, n, block, jr, jc)
    if (share >= 0.5) == backward:
        return order
    other = reverse_cuthill_mckee(graph, start=order[0])
    other_share = _backward_share(other, node, n, block, jr, jc)
    return other if (other_share > share) == backward else order


def elimination_order(n, m, hessian, jacobian, ordering="pairs", diagonal=None,
                      pairable=None, delayed=None, backward=True):
    """``(permutation, n_dense, kind)``: the pivot order of the KKT matrix.

    Parameters
    ----------
    n, m : int
        Variables and constraints (K's order is N = n + m; row ``n + i`` of
        K is constraint ``i``).
    hessian : (index, index)
        ``(rows, cols)`` of the Hessian's entries (those on its diagonal
        left out here); each an integer array or a
        :class:`~._periodic.PeriodicIndex`, read a chunk at a time.
    jacobian : (index, index)
        ``(rows, cols)`` of the Jacobian's entries, the same.
    ordering : str
        One of :data:`ORDERINGS`.
    diagonal : ndarray of bool, shape (n,), optional
        The variables whose Hessian has a diagonal entry: the pairing prefers
        the others (a variable without one has a zero pivot of its own when
        ``diagonal_x`` is zero there).
    pairable : ndarray of bool, shape (len(jacobian[0]),), optional
        The Jacobian's entries a pair may be made of (the others only where
        they alone match more rows); default all.
    delayed : ndarray of bool, shape (N,), optional
        Rows eliminated after all others but the dense ones, unpaired, in
        their own order (pivots that a factorization found zero in an
        earlier order, :class:`~._sparse.SparseKKT`).
    backward : bool
        With ``ordering="pairs"``, the band swept backward (step 3), else
        forward (tried after a zero pivot, :class:`~._sparse.SparseKKT`).

    Returns
    -------
    permutation : ndarray of int32, shape (N,)
        ``permutation[k]``: the row of K eliminated ``k``-th.
    n_dense : int
        How many rows counted as dense (:func:`dense_threshold`): the last
        ``n_dense`` of the order, the variables first; the ``delayed`` rows
        (not dense) just before them.
    kind : ndarray of int8, shape (N,)
        Of each pivot in that order: 0 a variable's, 3 a constraint's, 1 and 2
        the variable and the constraint of a pair (consecutive; a 2 x 2 pivot
        of :class:`~._sparse.SparseKKT`).  ``"rcm"`` makes no pairs.
    """
    if ordering not in ORDERINGS:
        raise ValueError(f"ordering must be one of {', '.join(ORDERINGS)}, not {ordering!r}")
    N = n + m
    if N == 0:
        return np.zeros(0, dtype=np.int32), 0, np.zeros(0, dtype=np.int8)
    hr, hc = hessian
    jr, jc = jacobian
    off = _mask(hr, hc, np.not_equal)  # the Hessian's entries off its diagonal
    degrees = np.diff(_made((N, N), [(hr, hc, 0, off), (jr, jc, n)], True).indptr)
    del off
    dense = degrees > dense_threshold(degrees)
    del degrees
    late = dense if delayed is None else dense | delayed
    keep = np.flatnonzero(~late).astype(np.int32)
    block = np.arange(N, dtype=np.int32)  # the node of the compressed graph of each row
    if ordering != "rcm" and m and len(jr):
        inside = _mask(jr, jc, lambda rows, cols: ~late[n + rows] & ~late[cols])

        def pattern_of(taken):  # (the entries walked where taken, not copied)
            return _made((m, n), [(jr, jc, 0, None if taken.all() else taken)], False)
        preferred = np.ones(n, dtype=bool) if diagonal is None else ~diagonal
        if pairable is None:
            partner = _matching(pattern_of(inside), preferred & ~late[:n])
        else:  # (the whole pattern made only where the pairable entries leave a row)
            partner = _matching(pattern_of(inside & pairable), preferred & ~late[:n],
                                lambda: pattern_of(inside))
        paired = np.flatnonzero(partner >= 0)
        block[n + paired] = partner[paired]
        del inside, partner, paired  # (each step's temporaries let go: a new
        # order after a zero pivot is made beside the solver's arrays)
    # the compressed graph on the blocks of the rows that are not dense
    # (numbered in int32 by marks, not np.unique's int64 sort)
    used = np.zeros(N, dtype=bool)
    used[block[keep]] = True
    number = np.cumsum(used, dtype=np.int32) - 1
    del used
    size = int(number[-1]) + 1  # the compressed graph's nodes
    compressed = number[block[keep]]
    del number
    where = np.full(N, -1, dtype=np.int32)  # -1 for a row left out
    where[keep] = compressed
    # (the Hessian's diagonal entries join a block to itself: left out)
    compressed_graph = _Pattern((size,) * 2, kernel().compressed(
        where, size, _part(hr, hc, 0), _part(jr, jc, n)))
    if size == 0:  # every row delayed or dense
        order = np.zeros(0, dtype=np.int64)
    elif ordering == "pairs-mmd":
        order = _minimum_degree(compressed_graph)
    elif ordering == "pairs" and m and len(jr):
        order = _band(compressed_graph, where, n, block, jr, jc, backward)
    else:
        order = reverse_cuthill_mckee(compressed_graph)
    del compressed_graph, where
    # expand: each block's rows in their own order (the variable before its constraint)
    # (keep increases: a stable sort by block keeps each block's rows in order)
    rank = np.empty(size, dtype=np.int32)
    rank[order] = np.arange(size, dtype=np.int32)
    sequence = np.argsort(rank[compressed], kind="stable")
    del rank, compressed
    permutation = np.concatenate([keep[sequence], np.flatnonzero(late & ~dense),
                                  np.flatnonzero(dense)], dtype=np.int32, casting="same_kind")
    del sequence, keep
    # the kind of each pivot: a 1 x 1 of a variable (0) or a constraint (3), the
    # variable (1) and the constraint (2) of a pair
    kind = np.where(permutation < n, 0, 3).astype(np.int8)
    follower = block[permutation[1:]] == block[permutation[:-1]]
    kind[:-1][follower] = 1
    kind[1:][follower] = 2
    return permutation, int(dense.sum()), kind
