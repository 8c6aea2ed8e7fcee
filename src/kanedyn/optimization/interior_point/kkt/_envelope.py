r"""``EnvelopeKKT``: the :math:`LDL^T` of :class:`~._sparse.SparseKKT`
with :math:`L` stored by its envelope, for less memory.

The same matrix, order, pivots, zero-pivot rules, new orders after a zero
pivot and inertia as :class:`~._sparse.SparseKKT` (its module's
docstring); only the storage and the loops differ:

- **L by rows, its envelope** (profile): row :math:`k` of :math:`L` holds
  every column from its first entry to :math:`k - 1`, values only, with one
  int32 pointer per row.  Without pivoting the fill stays in the envelope of
  :math:`K`'s lower triangle in the order, so that envelope is computed from
  the patterns (one pass over the entries) and no elimination tree, row index
  or count of L is made.  A row that begins at the second column of a pair
  begins at its first (the 2 x 2 pivot mixes the two).  In a band, as the
  collocation's order makes (:mod:`._ordering`), the envelope fills:
  on the backward-Euler pendulum swing-up it has as many entries as the
  sparse :math:`L` (16.0 a node), at 8 bytes each instead of 12.
- **No copy of K**: the values are scattered straight into :math:`L`'s
  storage, which the factorization overwrites row by row
  (:math:`w = L^{-1} K_{f:k,k}` by one dot product per column, then
  :math:`D^{-1} w` block by block and the pivot), and :meth:`matvec`
  multiplies by :math:`K` from the arrays ``factor`` was given, kept by
  reference, not copied: the caller must not change them until the next
  ``factor`` or :meth:`release` (the interior point never does; it keeps
  them to factor again).
- **The 2 x 2 blocks' off-diagonal entries in the envelope**: the second
  row of a pair has no entry of :math:`L` in its own block's column (the
  sparse kernel stores a zero there); that place holds the block's entry.
- **Scratch** of a double and an int32 a row for ``factor`` (each
  column's largest entry of K below the diagonal, each row's own read at
  its step; and the order's inverse, made from the order at each call
  rather than held), for the call's duration (the sparse kernel's is 5
  doubles, and 1 for its ``solve``); ``solve`` works in the right-hand
  side's storage through the order, with none.

Held per row of K: the order and the kinds of the pivots, the
envelope's pointers, :math:`D`, the zero pivots' flags; and the structures
as given (read-only arrays, or :class:`~._periodic.PeriodicIndex` runs,
which the kernel walks in the same entry order: the interior point gives
its patterns so, and then holds no index array of them).  The sums of the
factorization differ in their order from the sparse kernel's (dot
products, not scatters): the same factors up to rounding.  Where the order
has no band (many rows joined to distant ones) the envelope holds zeros
that a sparse :math:`L` leaves out: on the 47 distinct analyses of the
interior-point and optimal-control tests (new orders after zero pivots
included) it held 1.00 to 1.30 times the sparse L's entries
(``docs/benchmarks.md``).

:attr:`~._sparse.SparseKKT.analysis` counts, for this storage:
``nnz_factor`` the envelope's entries; ``bytes_factor`` L's values, the
row pointers and D; ``bytes_maps`` the order, the kinds and the Hessian's
structure; ``bytes_workspace`` the scratch (12 bytes a row) and the zero
pivots' flags.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _sparse
from ._analyses import cached_analysis
from ._periodic import PeriodicIndex, kernel_index
from ._sparse import _INDEX, KKTAnalysis, SparseKKT, _structure

__all__ = ["EnvelopeKKT", "EnvelopeAnalysis"]


@dataclass(frozen=True)
class EnvelopeAnalysis:
    """The arrays of one envelope analysis (read-only once kept), K of order N.

    Attributes
    ----------
    permutation : ndarray of int32, shape (N,)
        ``permutation[k]``: the row of K eliminated ``k``-th.
    n_dense : int
        Rows counted as dense and ordered last.
    kind : ndarray of int8, shape (N,)
        Each pivot's kind (:func:`~._ordering.elimination_order`).
    rowptr : ndarray of int32, shape (N + 1,)
        Row ``k`` of L at ``rowptr[k]:rowptr[k + 1]``, its columns ending at
        ``k - 1``.
    nnz_matrix : int
        K's distinct entries in the upper triangle, diagonal included.
    """

    permutation: np.ndarray
    n_dense: int
    kind: np.ndarray
    rowptr: np.ndarray
    nnz_matrix: int


def _read_only(structure, name, n_rows, n_cols):
    """``(checked, kept)``: ``structure``'s arrays checked, as int32 arrays
    (for the analysis), and what the object keeps of them: a given
    :class:`~._periodic.PeriodicIndex` (its array checked, not kept) or an
    int32 array that cannot be written, the given one when it is so already
    (the interior point's, :mod:`.._reduced`), else a copy.  The
    factorization indexes its storage by them at every call, so they must
    not change after the analysis."""
    arrays = _structure(structure, name, n_rows, n_cols)
    kept = []
    for given, checked in zip(structure, arrays):
        if isinstance(given, PeriodicIndex) or (checked is given
                                                and not checked.flags.writeable):
            kept.append(given)
            continue
        copy = checked.copy()
        copy.flags.writeable = False
        kept.append(copy)
    return tuple(arrays), tuple(kept)


class EnvelopeKKT(SparseKKT):
    """The :math:`LDL^T` of the KKT matrix with L stored by its envelope:
    :class:`~._sparse.SparseKKT`'s parameters, attributes, methods and
    errors (the module's docstring says what differs).  It keeps the
    structures, read-only: arrays that a caller could still write are
    copied."""

    def __init__(self, n, m, hessian_structure, jacobian_structure, **options):
        n, m = _sparse._size(n, "n"), _sparse._size(m, "m")
        hessian, kept_hessian = _read_only(hessian_structure, "hessian_structure", n, n)
        jacobian, kept_jacobian = _read_only(jacobian_structure, "jacobian_structure", m, n)
        self._hessian_structure, self._jacobian_structure = kept_hessian, kept_jacobian
        #: the four index arrays as the kernel takes them (arrays, or runs and table)
        self._indices = tuple(map(kernel_index, kept_hessian + kept_jacobian))
        super().__init__(n, m, hessian, jacobian, **options)

    def _structures(self):
        """The structures as held (arrays, or runs that the new order reads a
        chunk at a time)."""
        return self._hessian_structure, self._jacobian_structure

    def _analyse(self, hessian_structure, jacobian_structure, has_diagonal, pairable):
        """The order (:func:`elimination_order`, ``self._delayed`` last), the
        envelope's pointers (kept for the next object of the same inputs,
        :func:`~._analyses.cached_analysis`) and the storage of the
        factors."""
        n, m, N = self.n, self.m, self.size
        (hr, hc), (jr, jc) = hessian_structure, jacobian_structure
        self._numeric = None  # not held while a new order is made; the next factor
        # makes it again (_storage); nor the last analysis's pointers
        self._rowptr = None
        self._permutation = self._kind = self._zero = self.analysis = None
        symbolic = cached_analysis(
            N, (n, m, self.ordering, self._forward, "envelope"),
            (hr, hc, jr, jc, has_diagonal, pairable, self._delayed),
            lambda: self._symbolic((hr, hc), (jr, jc), has_diagonal, pairable))
        self._permutation, self._kind = symbolic.permutation, symbolic.kind
        self._rowptr = symbolic.rowptr
        self._values = None  # factor's arguments, for matvec
        size = int(self._rowptr[-1])
        self.analysis = KKTAnalysis(
            n, m, self._permutation, symbolic.n_dense, self._n_delayed(),
            symbolic.nnz_matrix, size, 8 * (size + N) + self._rowptr.nbytes,
            sum(a.nbytes for a in (self._permutation, self._kind,
                                   *self._hessian_structure)),
            13 * N)

    def _symbolic(self, hessian_structure, jacobian_structure, has_diagonal, pairable):
        """The :class:`EnvelopeAnalysis` of these inputs (``ValueError`` when
        the envelope has more entries than int32 reaches)."""
        n, N = self.n, self.size
        (hr, hc), (jr, jc) = hessian_structure, jacobian_structure
        permutation, n_dense, kind = self._order((hr, hc), (jr, jc), has_diagonal, pairable)
        inverse = np.empty(N, dtype=_INDEX)
        inverse[permutation] = np.arange(N, dtype=_INDEX)
        rowptr = np.empty(N + 1, dtype=_INDEX)
        indices = (kernel_index(index) for index in (hr, hc, jr, jc))
        total, distinct = self._kernel.envelope(rowptr, inverse, kind, *indices, n)
        if total >= _sparse._LIMIT:
            raise ValueError(f"L's envelope would have {total} entries, too many for 32-bit "
                             "row pointers")
        return EnvelopeAnalysis(permutation, n_dense, kind, rowptr, N + distinct)

    def _storage(self):
        """``(Lx, D)``, made when a factorization first needs them after an
        analysis or :meth:`release`."""
        if self._numeric is None:
            size, N = int(self._rowptr[-1]), self.size
            if 8 * (size + N) >= _sparse.RETURN_FREED_BYTES:
                _sparse._return_freed_memory()
            self._numeric = (np.zeros(size), np.zeros(N))
        return self._numeric

    def release(self):
        """:meth:`~._sparse.SparseKKT.release`, and the values ``factor``
        was given let go."""
        super().release()
        self._values = None

    def _factor(self, hv, jv, diagonals):
        """The kernel's factorization in the current order: its inertia."""
        Lx, D = self._storage()
        self._values = (hv, jv, diagonals)
        zero = self._zero_flags()
        *inertia, self._largest = self._kernel.envelope_factor(
            Lx, self._rowptr, D, self._kind, self._permutation, hv, jv, *diagonals[:3], zero,
            *self._indices, self.zero_pivot, *diagonals[3])
        return self._kept_zero(zero, tuple(inertia))

    def _largest_entry(self):
        return self._largest

    def solve(self, rhs, overwrite=False):
        return self._solved(rhs, overwrite, lambda x, columns: self._kernel.envelope_solve(
            x, self._rowptr, *self._numeric, self._kind, self._permutation, columns))

    def matvec(self, x):
        def product(y, v):
            hv, jv, diagonals = self._values
            self._kernel.structured_matvec(y, v, hv, jv, *diagonals[:3], *self._indices,
                                           *diagonals[3])
        return self._multiplied(x, product)
