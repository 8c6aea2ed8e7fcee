"""The symbolic analyses of :class:`~._sparse.SparseKKT`, kept for the
next object of the same structure.

An analysis (the elimination order of :mod:`._ordering`, K's permuted
pattern and the maps of the values into it, the elimination tree and the
column pointers of L) depends on the patterns, the order's name and, after a
zero pivot, on which Jacobian entries may pair, which variables have a
diagonal and which rows are delayed: never on values.  Every interior-point
solve makes a new ``SparseKKT``; a problem solved again (a warm start, a
sweep of parameters, a benchmark's repeats) asks for the same analyses in
the same sequence.  On the 100-node pendulum swing-up an analysis took
1.5–1.8 ms and a solve made four (the constructor's and three after zero
pivots), an eighth of its time; a kept one is found by a digest of those
inputs in a few microseconds, and it holds the same arrays, so the
factorizations are the same to the last bit.

Only analyses of K of order at most :data:`CACHED_ROWS` are kept (beyond, an
analysis is a small part of a solve and its arrays are large), the
:data:`CACHED_ANALYSES` used last (two problems solved in turn, as the
pendulum's four and the cart-pole's three).  The arrays kept are read-only: the
objects share them.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

__all__ = ["SymbolicAnalysis", "cached_analysis", "CACHED_ROWS", "CACHED_ANALYSES"]

#: analyses of K of order (n + m) at most this are kept (about 3 MB each at
#: this order for the pendulum's collocation NLP, 10,000 nodes)
CACHED_ROWS = 50_000

#: at most this many analyses are kept, the ones used last
CACHED_ANALYSES = 8

_KEPT = OrderedDict()
_LOCK = threading.Lock()


@dataclass(frozen=True)
class SymbolicAnalysis:
    """The arrays of one analysis (read-only), of K of order N.

    Attributes
    ----------
    permutation : ndarray of int32, shape (N,)
        ``permutation[k]``: the row of K eliminated ``k``-th.
    n_dense : int
        Rows counted as dense and ordered last.
    kind : ndarray of int8, shape (N,)
        Each pivot's kind (:func:`~._ordering.elimination_order`).
    Ap : ndarray of int32, shape (N + 1,)
        Column pointers of K's permuted upper triangle (CSC).
    Ai : ndarray of int32
        Its row indices.
    hessian_map, jacobian_map, diagonal_map : ndarray of int32
        The place in ``Ai`` of each Hessian entry, Jacobian entry and
        diagonal entry.
    parent : ndarray of int32, shape (N,)
        The elimination tree.
    Lp : ndarray of int32, shape (N + 1,)
        Column pointers of L.
    """

    permutation: np.ndarray
    n_dense: int
    kind: np.ndarray
    Ap: np.ndarray
    Ai: np.ndarray
    hessian_map: np.ndarray
    jacobian_map: np.ndarray
    diagonal_map: np.ndarray
    parent: np.ndarray
    Lp: np.ndarray


def _digest(settings, arrays):
    """A digest of ``settings`` (a tuple of numbers and strings) and of the
    dtype, shape and bytes of each array of ``arrays`` (``None`` allowed)."""
    h = hashlib.blake2b(repr(settings).encode(), digest_size=32)
    for a in arrays:
        if a is None:
            h.update(b"None;")
            continue
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape};".encode())
        h.update(a.data)
    return h.digest()


def cached_analysis(size, settings, arrays, make):
    """The analysis of these inputs: a kept one, else ``make()`` (a
    :class:`SymbolicAnalysis`), kept when K's order ``size`` is at most
    :data:`CACHED_ROWS`.

    Parameters
    ----------
    size : int
        K's order, n + m.
    settings : tuple
        The analysis's numbers and names (n, m, the order's name).
    arrays : sequence of ndarray or None
        Its array inputs (the patterns, and what a zero pivot made of them).
    make : callable
        Makes the analysis when none is kept.
    """
    if size > CACHED_ROWS:
        return make()
    key = _digest(settings, arrays)
    with _LOCK:
        kept = _KEPT.get(key)
        if kept is not None:
            _KEPT.move_to_end(key)
            return kept
    made = make()
    for value in vars(made).values():
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
    with _LOCK:
        _KEPT[key] = made
        while len(_KEPT) > CACHED_ANALYSES:
            _KEPT.popitem(last=False)
    return made
