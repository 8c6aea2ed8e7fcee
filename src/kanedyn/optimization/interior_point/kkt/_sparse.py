r"""``SparseKKT``: the sparse :math:`LDL^T` factorization of the interior-point
method's KKT matrix, with its inertia.

.. math::

    K = \begin{bmatrix} H + \operatorname{diag}(d_x) & J^T \\
                        J & -\operatorname{diag}(d_c) \end{bmatrix}
      = P^T L D L^T P

with :math:`H` (n x n) the Hessian of the Lagrangian, :math:`J` (m x n) the
constraints' Jacobian, :math:`L` unit lower triangular, :math:`P` the
elimination order (:mod:`._ordering`) and :math:`D` block diagonal: a
2 x 2 block for each pair of a variable and a constraint that the order
made (the constraint's row holds the variable: before fill-in the block is
:math:`\begin{bmatrix} h & j \\ j & -c \end{bmatrix}` with :math:`j \ne 0`,
nonsingular where :math:`h = c = 0`, as for a state without a Hessian or
barrier term when ``diagonal_c = 0``, where a 1 x 1 pivot would be exactly
zero), 1 x 1 elsewhere.  The blocks are fixed by the analysis: no pivoting at run time.
By Sylvester's law of inertia the eigenvalues of :math:`D`'s blocks have
:math:`K`'s inertia, whatever the order, as long as none is zero.

**Analysis, once** (the constructor; again at a zero pivot, below): the
elimination order and its pairs;
the pattern of the permuted upper triangle of :math:`K` (CSC; every diagonal
entry present); the maps of every Hessian entry, Jacobian entry and diagonal
entry to its place there (repeated entries map to the same place and are
summed); the elimination tree and the column counts of :math:`L` (compiled;
the two columns of a pair get the same rows).  The patterns are made in
int32 by the kernel (:mod:`._kernel`), with no int64 copy of the
entries; their indices and the column pointers of K and L are int32 (K and
L of at most 2^31 - 2 entries each).  The analysis is kept for the next
object of the same inputs (:mod:`._analyses`: a problem solved again
makes the same analyses).
The numeric storage (the values of :math:`K`, :math:`L`'s indices and
values, :math:`D`) is made by the first :meth:`~SparseKKT.factor` and held
until :meth:`~SparseKKT.release`; the kernel's scratch by each call.

**Factorization, per call** (:meth:`SparseKKT.factor`, compiled, the GIL
released): the values scattered through the maps, then an up-looking block
:math:`LDL^T`: row :math:`k` of :math:`L` from a sparse triangular solve
:math:`w = L^{-1} K_{0:k,k}` whose pattern the elimination tree gives, then
:math:`D^{-1} w` block by block, then the pivot
:math:`d_k = K_{kk} - \sum_j L_{kj} w_j`.

**Zero pivots.**  Without pivoting, a pivot close to zero would make the
rows below it meaningless.  With :math:`\tau` the constructor's
``zero_pivot`` (default :data:`ZERO_PIVOT`), :math:`a` the largest magnitude
in :math:`K` and :math:`r_k` the largest in row :math:`k` of :math:`K` off
the diagonal, a 1 x 1 pivot :math:`d_k` counts as *zero* when

- it cancelled: :math:`|d_k| \le \tau t_k`, with :math:`t_k = |K_{kk}| +
  \sum_j |L_{kj} w_j|` the sum of the magnitudes of its terms (a singular
  :math:`K`, a constraint row with ``diagonal_c = 0`` dependent on earlier
  ones, an empty row);
- or it would grow the rows below by more than :math:`1/\tau` times
  :math:`K`'s largest entry: :math:`|d_k| \le \tau r_k^2 / a` (a diagonal of
  1e-20 beside entries of 1); for a variable's pivot (an unpaired one) by
  more than :math:`1/\sqrt{\tau}` (1e6): :math:`|d_k| \le \sqrt{\tau}
  r_k^2 / a`.  On the 100-node Hermite-Simpson swing-up a state's diagonal
  of 9.6e-12 beside entries of 1 passed the first bound, made entries of
  L of 1e11, and a later pivot, summed from terms of 2e11, cancelled: zero
  there, not where the growth began.  The constraints' pivots keep the
  first bound: a dependent row regularized by ``diagonal_c = 1e-8`` has a
  pivot of about -1e-8 that is :math:`K`'s own;
- or it is not finite.

A 2 x 2 block :math:`B = \begin{bmatrix} b_1 & e \\ e & b_2 \end{bmatrix}`:
its larger eigenvalue is zero when it is at most :math:`\tau` times the
larger of :math:`t` and the largest magnitude of the block's two rows; the
smaller one (:math:`\det B` over the larger) when the determinant cancelled,
:math:`|b_1 b_2 - e^2| \le \tau (|b_1 b_2| + e^2)`, or by the growth test
above with :math:`r` the largest entry of its two rows off the block.  So a
variable with a barrier term :math:`\Sigma = 10^{12}` paired with its
constraint, :math:`\begin{bmatrix} \Sigma & 1 \\ 1 & 0 \end{bmatrix}`, has
the sound small eigenvalue :math:`-1/\Sigma` (a test: barrier terms up to
1e14).

A zero pivot is replaced by :math:`\pm \max(t_k, a)/\sqrt{\epsilon}`
(:math:`\epsilon` the machine epsilon; at most 1e300): ``+`` in a
variable's row, ``-`` in a constraint's; in a block, the zero eigenvalue
takes that magnitude and the sign opposite to the other one (both zero: one
of each), the eigenvectors kept.  So large, the rows below change about as
little as if that row and column were left out.  The factorization goes on:
:meth:`~SparseKKT.solve` returns finite numbers (the solution with those
pivots changed), and ``n_zero`` counts the replaced ones.  Every other pivot
is counted by its sign, whichever rows it belongs to: a negative pivot among
the variables or a positive one among the constraints is reported as it is
(it is part of :math:`K`'s inertia).

**Zero pivots that the order made.**  The order is made from the
patterns alone, so a factorization can meet a zero pivot that :math:`K`
has not: a pair made through a Jacobian entry of the pattern whose value
is 0 (the pendulum's backward-Euler NLP has such entries: a defect row's
derivative by an input it does not hold), or a variable left unpaired
whose Hessian diagonal is 0 at these values, eliminated before its rows.
So when ``factor`` finds a zero pivot outside the rows already delayed, it
analyses again, up to three times, and factors again with the same values:

1. the pairs made again for these values: a pair only through a Jacobian
   entry above ``zero_pivot`` times the largest of its row, and paired
   first the variables without a Hessian diagonal in the pattern (as the
   constructor's order) and those whose diagonal (Hessian and
   ``diagonal_x``) is at most ``zero_pivot`` times :math:`K`'s largest
   entry here (where either loses no row); not made where these are the
   current order's own inputs (a digest of them is held): that order again;
2. if a pivot is still zero (and the order is ``"pairs"``'s): the band
   swept forward instead (:mod:`._ordering`: neither way suits every
   problem);
3. if a pivot is still zero: its rows (both of a pair) *delayed*,
   eliminated after all others but the dense ones, unpaired; there the
   pivots are the Schur complement of everything before them, zero only
   where :math:`K` without its dense rows is singular or nearly so (or a
   delayed row before them made it so).

The new order is kept for the later factorizations (the delayed rows stay
delayed: each makes its row of :math:`L` as long as the band behind its
first neighbour, so at most :data:`MAX_DELAYED` rows are), at most
:data:`MAX_REANALYSES` analyses in all (``reanalyses`` counts them;
``analysis.n_delayed`` the delayed rows).
The first matrix of the 50-node Hermite-Simpson swing-up (a state with a
zero Hessian diagonal) and of the 501-node backward-Euler one from a random
guess (a pair through a zero entry) take step 1 alone, then eigvalsh's
inertia (``tests/test_kkt_sparse.py``).

So the reported inertia is :math:`K`'s when ``n_zero == 0`` (up to rounding
in pivots that pass the tests).  ``n_zero > 0`` says that :math:`K` is
singular or nearly so, or that a leading block of :math:`PKP^T` is even
after the new order (or the analyses ran out).
The caller regularizes (raises ``diagonal_x`` or ``diagonal_c``) and factors
again; :meth:`~SparseKKT.matvec` multiplies by :math:`K` itself (never by a
replaced pivot), for iterative refinement.
"""

from __future__ import annotations

import functools
import math
import numbers
from dataclasses import dataclass

import numpy as np

from ._analyses import SymbolicAnalysis, _digest, cached_analysis
from ._diagonal import DiagonalEntries
from ._kernel import kernel
from ._ordering import ORDERINGS, elimination_order
from ._periodic import ENTRIES_CHUNK, entries

__all__ = ["SparseKKT", "KKTAnalysis", "ZERO_PIVOT", "MAX_REANALYSES", "MAX_DELAYED",
           "pairable_entries"]

#: default relative threshold of a zero pivot (see the module's docstring)
ZERO_PIVOT = 1e-12

#: at most this many analyses after the constructor's, over an object's life
#: (the module's docstring, *Zero pivots that the order made*)
MAX_REANALYSES = 4

#: at most this many rows delayed (the module's docstring, *Zero pivots that
#: the order made*): each makes its row of L as long as the band behind it
MAX_DELAYED = 64

_INDEX = np.int32
_LIMIT = np.iinfo(_INDEX).max

#: numeric storage of at least this many bytes is made after the process's
#: freed memory is handed back to the system (:func:`_return_freed_memory`)
RETURN_FREED_BYTES = 16 * 2 ** 20

#: the names of ``factor``'s arguments, in their order
_FACTOR_ARGUMENTS = ("hessian_values", "jacobian_values", "diagonal_x", "diagonal_c")


@dataclass(frozen=True)
class KKTAnalysis:
    """What the symbolic analysis found.

    Attributes
    ----------
    n, m : int
        The primal variables and the constraints (K is (n + m) x (n + m)).
    permutation : ndarray of int32, shape (n + m,)
        ``permutation[k]``: the row of K eliminated ``k``-th.
    n_dense : int
        Rows counted as dense and ordered last.
    n_delayed : int
        Rows whose pivot a factorization found zero, ordered just before the
        dense ones (0 until then).
    nnz_matrix : int
        Entries of K's upper triangle after repeats are summed, diagonal included.
    nnz_factor : int
        Entries of L below the diagonal.
    bytes_factor : int
        Bytes of L (values, row indices, column pointers) and of D's blocks
        (L's values and row indices and D held from a ``factor`` to the next
        ``release``).
    bytes_maps : int
        Bytes of the maps of the values into K's storage, of K's pattern and
        values (held as L's values are), of the elimination tree and of the
        order.
    bytes_workspace : int
        Bytes of the scratch of ``factor`` and ``solve`` (48 per row of K,
        allocated by each call for its duration) and of the zero pivots' flags
        (1 per row, made for each factorization, held only when a pivot was
        zero).
    """

    n: int
    m: int
    permutation: np.ndarray
    n_dense: int
    n_delayed: int
    nnz_matrix: int
    nnz_factor: int
    bytes_factor: int
    bytes_maps: int
    bytes_workspace: int


def _size(value, name):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        raise ValueError(f"{name} must be a non-negative integer, not {value!r}")
    return int(value)


def _structure(structure, name, n_rows, n_cols):
    """``(rows, cols)`` of ``structure`` as int32 arrays (the kernel's index
    type; no copy of arrays that are int32 already), checked against the shape."""
    try:
        rows, cols = structure
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (rows, cols) of integer arrays") from None
    arrays = []
    for label, value, bound in (("rows", rows, n_rows), ("cols", cols, n_cols)):
        a = np.asarray(value)
        if a.ndim != 1:
            raise ValueError(f"{name}: {label} must be one-dimensional, not of shape "
                             f"{a.shape}")
        if a.size and not np.issubdtype(a.dtype, np.integer):
            raise ValueError(f"{name}: {label} must hold integers, not {a.dtype}")
        bad = np.flatnonzero((a < 0) | (a >= bound))
        if bad.size:
            raise ValueError(f"{name}: {label}[{bad[0]}] = {a[bad[0]]} is outside "
                             f"0..{bound - 1}")
        arrays.append(np.ascontiguousarray(a, dtype=_INDEX))
    if arrays[0].shape != arrays[1].shape:
        raise ValueError(f"{name}: rows and cols differ in length ({arrays[0].size} and "
                         f"{arrays[1].size})")
    return arrays


def _values(value, size, name):
    """``value`` as a C-contiguous float64 array of shape ``(size,)`` (its
    values checked by :func:`_check_values`)."""
    a = np.ascontiguousarray(value, dtype=float)
    if a.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},), not {a.shape}")
    return a


_NO_ENTRIES = np.zeros(0)
_NO_ENTRIES.flags.writeable = False
_NO_INDEX = np.zeros(0, dtype=_INDEX)
_NO_INDEX.flags.writeable = False


def _number(value, name):
    """``value`` (a real number, a 0-d array too) as a finite float."""
    if type(value) is float and math.isfinite(value):  # (the usual case, at once)
        return value
    try:
        number = (float(value) if np.ndim(value) == 0
                  and not isinstance(value, (bool, np.bool_, str)) else None)
    except (TypeError, ValueError):
        number = None
    if number is None or not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number, not {value!r}")
    return number


def _diagonal(value, size, name):
    """``(array, constant)`` of a diagonal given as an array of shape
    ``(size,)`` (its values checked by :func:`_check_values`; the constant
    0.0) or as one number for every entry (no entries; the number,
    :func:`_number`)."""
    if type(value) is not float and np.ndim(value) != 0:
        return _values(value, size, name), 0.0
    return _NO_ENTRIES, _number(value, name)


def _diagonals(n, m, diagonal_x, diagonal_c, added_x):
    """The kernel's diagonals of n variables and m rows (:func:`_diagonal`;
    ``diagonal_x`` also a :class:`~._diagonal.DiagonalEntries`, its index
    the kernel's to check; ``added_x`` a finite number, a constant
    ``diagonal_c`` not negative): ``(dx, dx_index, dc, (n, x_constant,
    added_x, c_constant))`` (``dx_index`` without entries unless
    ``diagonal_x`` has an index)."""
    if isinstance(diagonal_x, DiagonalEntries):
        if diagonal_x.size != n:
            raise ValueError(f"diagonal_x must have {n} entries, not {diagonal_x.size}")
        dx_index = np.ascontiguousarray(diagonal_x.index, dtype=_INDEX)
        dx, x_constant = _values(diagonal_x.values, dx_index.size, "diagonal_x"), 0.0
    else:
        (dx, x_constant), dx_index = _diagonal(diagonal_x, n, "diagonal_x"), _NO_INDEX
    dc, c_constant = _diagonal(diagonal_c, m, "diagonal_c")
    if c_constant < 0.0:
        raise ValueError(f"diagonal_c = {c_constant!r} is negative")
    return dx, dx_index, dc, (n, x_constant, _number(added_x, "added_x"), c_constant)


def pairable_entries(m, jacobian_rows, jacobian_values, zero_pivot=ZERO_PIVOT):
    """The Jacobian's entries a 2 x 2 pivot may be made of at these values:
    those above ``zero_pivot`` times the largest magnitude of their row
    (boolean, shape ``(len(jacobian_rows),)``; a zero row has none).  An
    entry of the pattern that is zero here (a structural zero: the
    collocation's Jacobian holds each defect row's derivative by every state
    and input of its node) would make a pair whose pivot is zero where the
    variable's diagonal is.  (Made a chunk of :data:`~._periodic.ENTRIES_CHUNK` entries
    at a time: no array of the entries' magnitudes beside the solver's;
    ``jacobian_rows`` may be a :class:`~._periodic.PeriodicIndex`.)"""
    values = np.asarray(jacobian_values)
    row_largest = np.zeros(m)
    for k0 in range(0, values.size, ENTRIES_CHUNK):
        k1 = k0 + ENTRIES_CHUNK
        np.maximum.at(row_largest, entries(jacobian_rows, k0, k1), np.abs(values[k0:k1]))
    out = np.empty(values.size, dtype=bool)
    for k0 in range(0, values.size, ENTRIES_CHUNK):
        k1 = k0 + ENTRIES_CHUNK
        np.greater(np.abs(values[k0:k1]),
                   zero_pivot * row_largest[entries(jacobian_rows, k0, k1)], out=out[k0:k1])
    return out


def _check_values(kernel, arrays, names, nonnegative=None):
    """Raise ``ValueError`` at the first entry of ``arrays`` (float64,
    C-contiguous) that is not finite, else at the most negative of the array
    named ``nonnegative`` (the kernel's ``invalid``: one call, not NumPy's
    three per array)."""
    last = len(arrays) if nonnegative is None else names.index(nonnegative)
    found = kernel.invalid(*arrays, last)
    if found is None:
        return
    which, entry = found
    a, name = arrays[which], names[which]
    if not np.isfinite(a[entry]):
        raise ValueError(f"{name}[{entry}] is not finite")
    raise ValueError(f"{name}[{int(np.argmin(a))}] = {float(a.min())!r} is negative")


def _permuted_pattern(n, permutation, hessian, jacobian):
    """K's upper triangle in the elimination order, and where each value goes
    (the kernel's ``permuted``).

    Returns
    -------
    Ap : ndarray of int32, shape (N + 1,)
        Column pointers (CSC) of the permuted upper triangle, every diagonal
        entry present.
    Ai : ndarray of int32
        Its row indices, sorted within each column.
    hessian_map, jacobian_map : ndarray of int32
        The place in ``Ai`` (and in the values) of each Hessian and Jacobian
        entry, in the order of their structures (repeats share a place).
    diagonal_map : ndarray of int32, shape (N,)
        The place of K's diagonal entry of each row, in K's own order.

    Raises
    ------
    ValueError
        More entries than 32-bit indices reach.
    """
    (hr, hc), (jr, jc) = hessian, jacobian
    N = permutation.size
    inverse = np.empty(N, dtype=_INDEX)
    inverse[permutation] = np.arange(N, dtype=_INDEX)
    Ap = np.empty(N + 1, dtype=_INDEX)
    maps = (np.empty(hr.size, dtype=_INDEX), np.empty(jr.size, dtype=_INDEX),
            np.empty(N, dtype=_INDEX))
    rows = kernel().permuted(Ap, *maps, inverse,
                             *(np.ascontiguousarray(a, dtype=_INDEX) for a in (hr, hc, jr, jc)),
                             n)
    return (Ap, np.frombuffer(rows, dtype=_INDEX)) + maps


@functools.lru_cache(maxsize=1)
def _malloc_trim():
    """glibc's ``malloc_trim(pad)``, or ``None`` under another C library."""
    import ctypes
    try:
        trim = ctypes.CDLL(None).malloc_trim  # the process's own C library
    except (OSError, AttributeError):
        return None
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def _return_freed_memory():
    """Hand the pages of memory freed on the heap back to the system (glibc's
    ``malloc_trim(0)``; nothing under another C library).

    The interior point frees and makes arrays of a few MB at every
    iteration; glibc serves them from its heap once its mmap threshold has
    risen past them, and the freed ones stay resident.  The factors, made
    anew at every point, would then come on top: handed back first, the
    process's peak resident memory on the 300,000-node swing-up fell from
    0.69 to 0.57 GiB (``docs/benchmarks.md``).  No number changes."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


class SparseKKT:
    """The sparse :math:`LDL^T` of the KKT matrix, its pattern analysed once.

    Parameters
    ----------
    n, m : int
        Primal variables and constraints.
    hessian_structure : (ndarray of int, ndarray of int)
        ``(rows, cols)`` of the lower triangle (``row >= col``) of the n x n
        Hessian of the Lagrangian; repeated entries are summed.
    jacobian_structure : (ndarray of int, ndarray of int)
        ``(rows, cols)`` of the m x n constraint Jacobian; repeated entries
        are summed.
    zero_pivot : float
        The relative threshold :math:`\\tau` below which a pivot counts as
        zero (the module's docstring); default :data:`ZERO_PIVOT`.
    ordering : str
        The elimination order, one of
        :data:`~._ordering.ORDERINGS` (:mod:`._ordering`).
    pairable : ndarray of bool, shape (len(jacobian_structure[0]),), optional
        The Jacobian's entries the order may make a 2 x 2 pivot of (the
        others only where they alone match more rows); default all.  The
        interior point gives :func:`pairable_entries` at its start point,
        so that no pair is made through a structural zero (which the first
        ``factor`` would meet as a zero pivot, and analyse again).

    Attributes
    ----------
    analysis : KKTAnalysis
        The order, the sizes of K and L and the bytes held (the last
        analysis's).
    reanalyses : int
        The analyses made after the constructor's, for zero pivots that the
        order made (the module's docstring), at most :data:`MAX_REANALYSES`.
    inertia : (int, int, int) or None
        What the last ``factor`` returned; ``None`` before the first.
    error_reductions : callable
        The kernel's sums and maxima of the interior point's optimality error
        (:mod:`._kernel`), the numbers of
        :func:`~.._optimality.numpy_error_reductions` in one call.

    Raises
    ------
    ValueError
        A size that is not a non-negative integer, a structure that is not a
        pair of equal-length integer arrays, an index out of range, an entry
        of the Hessian above the diagonal (each naming the argument); K or L
        with more entries than 32-bit indices and column pointers reach.
    CompilerError
        No C compiler (the kernel is compiled once, then cached).

    Notes
    -----
    ``factor`` and ``solve`` release the GIL while they compute, and they
    write the object's storage: one call at a time per
    object (another object of the same structure may work meanwhile).
    """

    def __init__(self, n, m, hessian_structure, jacobian_structure, *,
                 zero_pivot=ZERO_PIVOT, ordering="pairs", pairable=None):
        n, m = _size(n, "n"), _size(m, "m")
        hr, hc = _structure(hessian_structure, "hessian_structure", n, n)
        upper = np.flatnonzero(hr < hc)
        if upper.size:
            e = upper[0]
            raise ValueError(f"hessian_structure: entry {e} (row {hr[e]}, col {hc[e]}) is "
                             "above the diagonal; give the lower triangle (row >= col)")
        jr, jc = _structure(jacobian_structure, "jacobian_structure", m, n)
        if not (isinstance(zero_pivot, numbers.Real) and 0.0 <= zero_pivot < 1.0):
            raise ValueError(f"zero_pivot must be a number in [0, 1), not {zero_pivot!r}")
        if ordering not in ORDERINGS:
            raise ValueError(f"ordering must be one of {', '.join(ORDERINGS)}, not "
                             f"{ordering!r}")
        if pairable is not None:
            pairable = np.asarray(pairable)
            if pairable.dtype != bool or pairable.shape != jr.shape:
                raise ValueError(f"pairable must be a boolean array of shape {jr.shape} (one "
                                 f"for each Jacobian entry), not {pairable.dtype} of shape "
                                 f"{pairable.shape}")
        N = n + m
        if N >= _LIMIT:
            raise ValueError(f"n + m = {N} is too large for 32-bit indices")
        self._kernel = kernel()
        self.error_reductions = self._kernel.error_reductions
        self.n, self.m, self.size = n, m, N
        self.zero_pivot = float(zero_pivot)
        self.ordering = ordering
        #: the rows delayed to the end of the order (a mask), ``None`` while none is
        self._delayed = None
        self._forward = False  # the band swept forward (after a zero pivot)
        self.reanalyses = 0
        self._entries = (hr.size, jr.size)  # of the Hessian and the Jacobian
        has_diagonal = np.zeros(n, dtype=bool)
        has_diagonal[hr[hr == hc]] = True
        self._analyse((hr, hc), (jr, jc), has_diagonal, pairable)
        self._order_key = self._order_inputs(has_diagonal, pairable)
        self.inertia = None

    def _order_inputs(self, has_diagonal, pairable):
        """A digest of what the order is made of beside the structures (the
        same digest: the same order)."""
        return _digest((self._forward,), (has_diagonal, pairable, self._delayed))

    def _structures(self):
        """``((hr, hc), (jr, jc))``, the constructor's structures, from the
        maps (not kept: an analysis again is rare)."""
        column = np.repeat(np.arange(self.size, dtype=_INDEX), np.diff(self._Ap))
        first = self._permutation[self._Ai]
        second = self._permutation[column]
        del column
        high = np.maximum(first, second)
        np.minimum(first, second, out=first)
        del second
        h, j = self._hessian_map, self._jacobian_map
        return (high[h], first[h]), (high[j] - _INDEX(self.n), first[j])

    def _analyse(self, hessian_structure, jacobian_structure, has_diagonal, pairable):
        """The order (pairs by :func:`elimination_order`, ``self._delayed``
        last), K's permuted pattern and maps, the elimination tree (those
        kept for the next object of the same inputs,
        :func:`~._analyses.cached_analysis`) and the storage of the
        factors; ``has_diagonal`` and ``pairable`` as
        :func:`elimination_order` takes them."""
        n, m, N = self.n, self.m, self.size
        (hr, hc), (jr, jc) = hessian_structure, jacobian_structure
        self._numeric = None  # not held while a new order is made; the next factor
        # makes it again (_storage); nor the last analysis's arrays
        self._Ap = self._Ai = self._hessian_map = self._jacobian_map = None
        self._diagonal_map = self._parent = None
        self._permutation = self._kind = self._zero = self.analysis = None
        symbolic = cached_analysis(
            N, (n, m, self.ordering, self._forward),
            (hr, hc, jr, jc, has_diagonal, pairable, self._delayed),
            lambda: self._symbolic((hr, hc), (jr, jc), has_diagonal, pairable))
        self._permutation, self._kind = symbolic.permutation, symbolic.kind
        self._Ap, self._Ai, self._Lp = symbolic.Ap, symbolic.Ai, symbolic.Lp
        self._hessian_map, self._jacobian_map = symbolic.hessian_map, symbolic.jacobian_map
        self._diagonal_map, self._parent = symbolic.diagonal_map, symbolic.parent
        nnz = int(self._Lp[-1])
        factor_bytes = 12 * nnz + self._Lp.nbytes + 16 * N  # Li, Lx, Lp, D, E
        map_bytes = 8 * self._Ai.size + sum(  # Ax and the maps
            a.nbytes for a in (self._hessian_map, self._jacobian_map, self._diagonal_map,
                               self._Ap, self._Ai, self._parent, self._kind,
                               self._permutation))
        self.analysis = KKTAnalysis(n, m, self._permutation, symbolic.n_dense,
                                    self._n_delayed(), int(self._Ai.size), nnz,
                                    factor_bytes, map_bytes, 49 * N)

    def _order(self, hessian_structure, jacobian_structure, has_diagonal, pairable):
        """``(permutation, n_dense, kind)`` of :func:`elimination_order` for
        these structures (``self._delayed`` last)."""
        return elimination_order(self.n, self.m, hessian_structure, jacobian_structure,
                                 self.ordering, has_diagonal, pairable, self._delayed,
                                 not self._forward)

    def _symbolic(self, hessian_structure, jacobian_structure, has_diagonal, pairable):
        """The :class:`~._analyses.SymbolicAnalysis` of these inputs: the
        order, K's permuted pattern and maps, the elimination tree and L's
        column pointers (``ValueError`` when K or L has more entries than
        int32 reaches)."""
        n, N = self.n, self.size
        (hr, hc), (jr, jc) = hessian_structure, jacobian_structure
        permutation, n_dense, kind = self._order((hr, hc), (jr, jc), has_diagonal, pairable)
        Ap, Ai, hessian_map, jacobian_map, diagonal_map = _permuted_pattern(
            n, permutation, (hr, hc), (jr, jc))
        # elimination tree and the pattern's size, then L's column pointers
        parent = np.empty(N, dtype=_INDEX)
        counts = np.empty(N, dtype=_INDEX)  # each below N
        self._kernel.symbolic(parent, counts, Ap, Ai, kind)
        nnz = int(counts.sum(dtype=np.int64))
        if nnz >= _LIMIT:
            raise ValueError(f"L would have {nnz} entries, too many for 32-bit column "
                             "pointers")
        Lp = np.zeros(N + 1, dtype=_INDEX)
        np.cumsum(counts, dtype=_INDEX, out=Lp[1:])
        return SymbolicAnalysis(permutation, n_dense, kind, Ap, Ai, hessian_map, jacobian_map,
                                diagonal_map, parent, Lp)

    def factor(self, hessian_values, jacobian_values, diagonal_x, diagonal_c, added_x=0.0):
        """Factor K with these values; return its inertia.

        Parameters
        ----------
        hessian_values : array_like, shape (len(hessian_structure[0]),)
            The Hessian's entries, in the order of its structure.
        jacobian_values : array_like, shape (len(jacobian_structure[0]),)
            The Jacobian's entries, in the order of its structure.
        diagonal_x : array_like, shape (n,), float, or DiagonalEntries
            Added to H's diagonal (a number: the same on every entry, no
            array made; :class:`~._diagonal.DiagonalEntries`: its values at
            its entries, 0 elsewhere, no array of every entry).
        diagonal_c : array_like, shape (m,), or float
            Its negative is the constraints' diagonal block; >= 0, may be 0
            (a number: the same on every row).
        added_x : float
            Added to each entry of ``diagonal_x`` where not 0 (the interior
            point's :math:`\\delta_w`: the same sums as ``diagonal_x +
            added_x``, without their array).

        Returns
        -------
        (int, int, int)
            ``(n_positive, n_negative, n_zero)``: the pivots by sign, the zero
            ones as the module's docstring defines them (after the new order
            that a zero pivot may bring, *Zero pivots that the order made*).

        Raises
        ------
        ValueError
            A shape that does not match, a value that is not finite, a
            negative ``diagonal_c`` (naming the argument); a new order after
            a zero pivot whose L has more entries than int32 reaches.
        """
        hv = _values(hessian_values, self._entries[0], "hessian_values")
        jv = _values(jacobian_values, self._entries[1], "jacobian_values")
        diagonals = _diagonals(self.n, self.m, diagonal_x, diagonal_c, added_x)
        _check_values(self._kernel, (hv, jv, diagonals[0], diagonals[2]), _FACTOR_ARGUMENTS,
                      "diagonal_c")
        self.inertia = None  # no factors while the kernel overwrites them
        inertia = self._factor(hv, jv, diagonals)
        if inertia[2] and self.reanalyses < MAX_REANALYSES:
            inertia = self._reanalyse(hv, jv, diagonals, inertia)
        self.inertia = inertia
        return inertia

    def _storage(self):
        """``(Ax, Li, Lx, D, E)``: K's values and the storage of L and D,
        made when a factorization first needs them after an analysis or
        :meth:`release`."""
        if self._numeric is None:
            nnz, N = int(self._Lp[-1]), self.size
            if 8 * self._Ai.size + 12 * nnz + 16 * N >= RETURN_FREED_BYTES:
                _return_freed_memory()
            self._numeric = (np.zeros(self._Ai.size), np.zeros(nnz, dtype=_INDEX),
                             np.zeros(nnz), np.zeros(N), np.zeros(N))
        return self._numeric

    def release(self):
        """Drop K's values and the factors (``bytes_factor`` and K's values
        of :attr:`analysis`) until the next :meth:`factor`, which makes them
        again; :meth:`solve` and :meth:`matvec` refuse until then.  The
        interior point calls it at each new point, so that the last step's
        factors are not held while the derivatives and the next Hessian are
        evaluated."""
        self._numeric = None
        self.inertia = None

    def _factor(self, hv, jv, diagonals):
        """The kernel's factorization in the current order (``diagonals`` of
        :func:`_diagonals`): its inertia."""
        Ax, Li, Lx, D, E = self._storage()
        zero = self._zero_flags()
        return self._kept_zero(zero, self._kernel.factor(
            Ax, self._Lp, Li, Lx, D, E, self._Ap, self._Ai, self._parent, self._kind,
            self._hessian_map, hv, self._jacobian_map, jv, self._diagonal_map, *diagonals[:3],
            zero, self.zero_pivot, *diagonals[3]))

    def _zero_flags(self):
        """(N,) int8 for a factorization to flag its zero pivots in (made for
        each: held only when one was zero, :meth:`_kept_zero`)."""
        self._zero = None
        return np.zeros(self.size, dtype=np.int8)

    def _kept_zero(self, zero, result):
        """``result`` (the kernel's, its third entry the zero pivots), ``zero``
        kept for :meth:`_zero_rows` when a pivot was zero."""
        self._zero = zero if result[2] else None
        return result

    def _n_delayed(self):
        return 0 if self._delayed is None else int(np.count_nonzero(self._delayed))

    def _delayed_mask(self):
        """(N,) bool: the rows delayed to the end of the order."""
        return np.zeros(self.size, dtype=bool) if self._delayed is None else self._delayed

    def _largest_entry(self):
        """The largest magnitude in K's last factored values."""
        return float(np.abs(self._numeric[0]).max(initial=0.0))

    def _zero_rows(self):
        """Which rows of K (its own order, a mask) had a zero pivot in the
        last factorization."""
        failed = np.zeros(self.size, dtype=bool)
        if self._zero is not None:
            failed[self._permutation[self._zero.astype(bool)]] = True
        return failed

    def _reanalyse(self, hv, jv, diagonals, inertia):
        """The inertia after the order is made again for these values (the
        module's docstring, *Zero pivots that the order made*), or
        ``inertia`` when there is nothing new to try."""
        m = self.m
        failed = self._zero_rows()
        if not (failed & ~self._delayed_mask()).any():
            return inertia  # zero where it was already delayed: K's own
        largest = max(self._largest_entry(), 1e-300)
        self._numeric = None  # (made again by the next factor) not held meanwhile
        (hr, hc), (jr, _) = self._structures()
        dx, dx_index, _, (_, x_constant, added_x, _) = diagonals
        if dx_index.size:
            diagonal = DiagonalEntries(dx_index, dx, self.n).dense()
        else:
            diagonal = dx.copy() if dx.size else np.full(self.n, x_constant)
        if added_x:
            diagonal += added_x
        # a Hessian diagonal in the pattern, not zero at these values (the
        # others have a zero diagonal at least where diagonal_x is zero); the
        # structures read a chunk at a time (runs are not made whole)
        has_diagonal = np.zeros(self.n, dtype=bool)
        for k0 in range(0, len(hr), ENTRIES_CHUNK):
            k1 = k0 + ENTRIES_CHUNK
            rows = entries(hr, k0, k1)
            on = rows == entries(hc, k0, k1)
            np.add.at(diagonal, rows[on], hv[k0:k1][on])
            has_diagonal[rows[on]] = True
        has_diagonal &= np.abs(diagonal) > self.zero_pivot * largest
        pairable = pairable_entries(m, jr, jv, self.zero_pivot)
        # the structures asked again for each new order: not held through the
        # factorizations between them
        del diagonal, hr, hc, jr
        # first the pairs made again; then the band swept the other way; then
        # what still fails, delayed to the end
        found = inertia
        for step in ("pairs", "forward", "delay"):
            if step == "forward":  # (no band of pairs without constraints)
                if self._forward or self.ordering != "pairs" or not self._entries[1]:
                    continue
                self._forward = True
            if step == "delay":
                delayed = self._delayed_mask() | failed
                if np.count_nonzero(delayed) > MAX_DELAYED:
                    return found  # each makes a long row of L: not for many
                self._delayed = delayed
            key = self._order_inputs(has_diagonal, pairable)
            if step == "pairs" and key == self._order_key:
                continue  # the same pairs again: the same order (not made)
            self.reanalyses += 1
            self._analyse(*self._structures(), has_diagonal, pairable)
            self._order_key = key
            found = self._factor(hv, jv, diagonals)
            if not found[2] or self.reanalyses >= MAX_REANALYSES:
                return found
            failed = self._zero_rows()
            if not (failed & ~self._delayed_mask()).any():
                return found
        return found

    def _factored(self, what):
        if self.inertia is None:
            raise ValueError(f"{what}: nothing is factored yet; call factor first")

    def solve(self, rhs, overwrite=False):
        """The solution of K x = rhs with the last factors.

        Parameters
        ----------
        rhs : array_like, shape (n + m,) or (n + m, k)
        overwrite : bool
            Solve in ``rhs``'s own storage and return it, when ``rhs`` is a
            writeable C-contiguous float64 ndarray of shape (n + m,) (else,
            or by default, in a copy; the same numbers either way).

        Returns
        -------
        ndarray, the shape of ``rhs``
            (Where pivots were replaced, the solution of that changed K.)
        """
        return self._solved(rhs, overwrite, lambda x, columns: self._kernel.solve(
            x, self._Lp, *self._numeric[1:], self._kind, self._permutation, columns))

    def _solved(self, rhs, overwrite, kernel_solve):
        """:meth:`solve` with ``kernel_solve(x, columns)``, which overwrites
        ``x`` (``columns`` rows of length n + m) with the solutions."""
        self._factored("solve")
        b = np.asarray(rhs, dtype=float)
        N = self.size
        if b.ndim not in (1, 2) or b.shape[0] != N:
            raise ValueError(f"rhs must have shape ({N},) or ({N}, k), not {b.shape}")
        in_place = (overwrite and b is rhs and b.ndim == 1 and b.flags.c_contiguous
                    and b.flags.writeable)
        # rhs's own storage, or a copy: (k, N) or (N,)
        x = b if in_place else np.array(b.T, dtype=float, order="C")
        if self._kernel.invalid(x, 1) is not None:  # (1: no array to be >= 0)
            raise ValueError("rhs holds a value that is not finite")
        kernel_solve(x, 1 if b.ndim == 1 else b.shape[1])
        return x.T if b.ndim == 2 else x

    def matvec(self, x):
        """K x with the last factored values (the caller's diagonals, no
        replaced pivot).

        Parameters
        ----------
        x : array_like, shape (n + m,)

        Returns
        -------
        ndarray, shape (n + m,)
        """
        return self._multiplied(x, lambda y, v: self._kernel.matvec(
            y, v, self._Ap, self._Ai, self._numeric[0], self._permutation))

    def _multiplied(self, x, kernel_matvec):
        """:meth:`matvec` with ``kernel_matvec(y, x)``, which writes K x in ``y``."""
        self._factored("matvec")
        v = np.ascontiguousarray(x, dtype=float)
        if v.shape != (self.size,):
            raise ValueError(f"x must have shape ({self.size},), not {v.shape}")
        y = np.empty(self.size)
        kernel_matvec(y, v)
        return y
