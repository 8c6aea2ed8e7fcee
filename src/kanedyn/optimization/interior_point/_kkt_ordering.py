"""The elimination order of :class:`~._kkt_sparse.SparseKKT`.

The collocation NLP lays its variables out by kind (the states of every node,
then the inputs of every node, then free parameters and the duration, then
interior points) and its constraints by interval, so the KKT matrix in its own
order has no band; ordered by node it has one, a few rows and columns wide,
plus a few dense ones (a free duration or parameter is in every defect row;
instance constraints join the first and the last node).  :func:`elimination_order`
finds the band with SciPy's reverse Cuthill-McKee on the graph of K without its
dense rows and columns, which go last (a dense row eliminated early would make
every row it touches dense).
"""

from __future__ import annotations

import numpy as np

__all__ = ["elimination_order", "dense_threshold"]


def dense_threshold(size):
    """The degree above which a row of a matrix of ``size`` rows counts as dense
    and is ordered last: ``max(16, 10 sqrt(size))`` (the usual rule of the
    minimum-degree orderings)."""
    return max(16.0, 10.0 * np.sqrt(size))


def elimination_order(size, rows, cols):
    """``(permutation, n_dense)``: the pivot order of a symmetric matrix.

    Parameters
    ----------
    size : int
        The matrix's order N.
    rows, cols : ndarray of int, shape (e,)
        Its off-diagonal pattern, each pair in either or both triangles
        (repeats allowed).

    Returns
    -------
    permutation : ndarray of int32, shape (N,)
        ``permutation[k]``: the row eliminated ``k``-th.
    n_dense : int
        How many rows counted as dense (:func:`dense_threshold`): the last
        ``n_dense`` of the order, in their own order.
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    rows = np.asarray(rows, dtype=np.int64)
    cols = np.asarray(cols, dtype=np.int64)
    both_rows = np.concatenate([rows, cols])
    both_cols = np.concatenate([cols, rows])
    graph = sp.csr_matrix((np.ones(both_rows.size, dtype=np.int8), (both_rows, both_cols)),
                          shape=(size, size))
    graph.sum_duplicates()
    degree = np.diff(graph.indptr)
    dense = degree > dense_threshold(size)
    if dense.any():
        keep = np.flatnonzero(~dense)
        sparse_part = graph[keep][:, keep]
        order = keep[reverse_cuthill_mckee(sparse_part.tocsr(), symmetric_mode=True)]
        order = np.concatenate([order, np.flatnonzero(dense)])
    else:
        order = reverse_cuthill_mckee(graph, symmetric_mode=True)
    return order.astype(np.int32), int(dense.sum())
