r"""Index arrays held as periodic runs: a collocation pattern without its
index arrays.

A transcription's Jacobian and Hessian repeat one stage's entries at every
node, their rows and columns moved on by fixed steps: in the pattern's
entry order, ``rows[e + P] - rows[e]`` repeats with period ``P`` over long
stretches (``P`` the entries of a stage, or of one block of them; the steps
differ where a stage's entries lie in parts of the vector that are laid out
differently, a state's and an input's).  Such a stretch is a *run*: ``P``
base indices and their ``P`` steps, repeated ``K`` times, the ``s``-th
repeat's entry ``j`` at ``base[j] + s * step[j]``.  :class:`PeriodicIndex` holds an int32
array as its runs, in entry order (stretches that do not repeat as runs of
one repeat that hold their indices), so that the interior point does not
hold the patterns' 8 bytes an entry (about 96 bytes a node on the pendulum
swing-up, an eighth of its peak) while it iterates; the compiled kernel
(:mod:`._kernel`) walks the runs where it walked the arrays, in the same
entry order, so every sum it makes is the same.

:func:`periodic` finds the runs: the period at the middle of a stretch
(the least ``P`` up to :data:`MAX_PERIOD` over which the steps of a window
of :data:`PROBE_ENTRIES` entries repeat), the longest stretch around it
with that period and those steps, then the parts before and after it in
turn.  Arrays
of fewer than :data:`PERIODIC_ENTRIES` entries, or whose runs would hold more
than half their bytes, are kept as they are.  Where an array is needed
(an analysis's order, a SciPy product) ``numpy.asarray`` makes it from the
runs.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PeriodicIndex", "periodic", "kernel_index", "entries",
           "PERIODIC_ENTRIES", "MAX_PERIOD", "PROBE_ENTRIES", "ENTRIES_CHUNK"]

#: arrays of fewer entries are kept as they are (their bytes matter little,
#: and the interior point's small problems keep the arrays' own code paths)
PERIODIC_ENTRIES = 1 << 16

#: the longest period looked for (entries of a stage, or of a block of them)
MAX_PERIOD = 64

#: the window in which a period is looked for, and the fewest entries a run
#: of more than one repeat covers
PROBE_ENTRIES = 512

#: the entries read at a time (:func:`entries`) where a pass over a pattern in
#: NumPy makes temporaries of its entries
ENTRIES_CHUNK = 1 << 16

_INDEX = np.int32


class PeriodicIndex:
    """A one-dimensional int32 index array held as runs (the module's
    docstring), read-only.

    Parameters
    ----------
    runs : ndarray of int64, shape (R, 3)
        Each run's ``(period, repeats, first)``, the runs in entry order.
        A run of one repeat holds its entries at ``table[first:first +
        period]``; a run of more holds its bases there and their steps next,
        at ``table[first + period:first + 2 * period]``: its entry ``s *
        period + j`` is ``base[j] + s * step[j]``.
    table : ndarray of int32
        The runs' bases and steps.

    Attributes
    ----------
    size : int
        The array's entries.
    nbytes : int
        The bytes held (runs and table).

    Notes
    -----
    ``numpy.asarray`` makes the array (int32, a new one at each call).
    Comparisons, arithmetic and indexing are refused (``TypeError``): they
    would be made on the object, not on the array it stands for.
    """

    __slots__ = ("runs", "table", "size")
    __hash__ = None
    dtype = np.dtype(_INDEX)
    ndim = 1

    def __init__(self, runs, table):
        runs = np.array(runs, dtype=np.int64).reshape(-1, 3)
        table = np.array(table, dtype=_INDEX).ravel()
        period, repeats, first = runs.T
        held = np.where(repeats > 1, 2 * period, period)
        limit = np.iinfo(_INDEX).max  # (an int32 array's entries, so no product overflows)
        if runs.size and ((period <= 0).any() or (repeats <= 0).any() or (first < 0).any()
                          or (period > limit).any() or (repeats > limit).any()
                          or (first + held > table.size).any()
                          or float((period.astype(float) * repeats).sum()) > limit):
            raise ValueError("PeriodicIndex: runs whose periods, repeats or places do not "
                             f"fit a table of {table.size}, or more entries than int32 "
                             "indexes")
        runs.flags.writeable = table.flags.writeable = False
        self.runs, self.table = runs, table
        self.size = int((period * repeats).sum())

    @property
    def shape(self):
        return (self.size,)

    @property
    def nbytes(self):
        return self.runs.nbytes + self.table.nbytes

    def __len__(self):
        return self.size

    def __array__(self, dtype=None, copy=None):
        if copy is False:
            raise ValueError("a PeriodicIndex is made into an array by a copy")
        out = self.take(0, self.size)
        return out if dtype is None else out.astype(dtype, copy=False)

    def take(self, start, stop):
        """The entries ``start:stop`` (``0 <= start <= stop <= size``), a new
        int32 array made from the runs that hold them."""
        out = np.empty(stop - start, dtype=_INDEX)
        at = 0  # the first entry of the run
        for period, repeats, first in self.runs.tolist():
            length = period * repeats
            lo, hi = max(start, at), min(stop, at + length)
            if lo < hi and repeats == 1:  # its entries as they are
                out[lo - start:hi - start] = self.table[first + lo - at:first + hi - at]
            elif lo < hi:
                # the run's entries lo - at .. hi - at, by whole repeats
                s0, s1 = (lo - at) // period, (hi - at - 1) // period + 1
                bases = self.table[first:first + period].astype(np.int64)
                steps = self.table[first + period:first + 2 * period].astype(np.int64)
                block = bases + np.multiply.outer(np.arange(s0, s1, dtype=np.int64), steps)
                skip = lo - at - s0 * period
                out[lo - start:hi - start] = block.ravel()[skip:skip + hi - lo]
            at += length
            if at >= stop:
                break
        return out

    def _refused(self, *_args):
        raise TypeError("a PeriodicIndex is not an array: compare, compute or index with "
                        "numpy.asarray(index)")

    __eq__ = __ne__ = __lt__ = __le__ = __gt__ = __ge__ = _refused
    __add__ = __radd__ = __sub__ = __rsub__ = __mul__ = __rmul__ = _refused
    __getitem__ = _refused

    def __repr__(self):
        return (f"PeriodicIndex({self.size} entries in {len(self.runs)} runs, "
                f"{self.nbytes} bytes)")


def periodic(index):
    """``index`` (one-dimensional, integers) as a :class:`PeriodicIndex`
    where that holds at most half its bytes, else as it is (a
    :class:`PeriodicIndex` too is returned as it is).  Only int32 arrays of at
    least :data:`PERIODIC_ENTRIES` entries are looked at."""
    if isinstance(index, PeriodicIndex):
        return index
    a = np.asarray(index)
    if a.dtype != _INDEX or a.ndim != 1 or a.size < PERIODIC_ENTRIES:
        return index
    runs, pieces, first = [], [], 0
    for start, period, repeats in _runs(a, 0, a.size):
        runs.append((period, repeats, first))
        pieces.append(a[start:start + period])
        if repeats > 1:
            pieces.append(a[start + period:start + 2 * period] - a[start:start + period])
        first += period if repeats == 1 else 2 * period
    if 8 * 3 * len(runs) + 4 * first > a.nbytes // 2:
        return index
    return PeriodicIndex(runs, np.concatenate(pieces))


def _runs(a, start, stop):
    """``[(start, period, repeats)]``: the runs of ``a[start:stop]`` in order
    (a stretch without a period: one repeat of its whole length)."""
    found, todo = [], [("part", start, stop)]
    while todo:  # a part's runs take its place: the part before, the run, the part after
        item = todo.pop()
        if item[0] == "run":
            found.append(item[1])
            continue
        _, start, stop = item
        n = stop - start
        period = _period(a, start, stop) if n >= 4 * PROBE_ENTRIES else None
        if period is None:
            found.append((start, n, 1))
            continue
        # the stretch around the middle whose steps a[e + period] - a[e] repeat
        # with the period, for e in [r0, r1): entries r0 to r1 + 2 period (it
        # holds the period's window)
        steps = a[start + period:stop].astype(np.int64)
        steps -= a[start:stop - period]
        other = steps[period:] != steps[:-period]
        del steps
        middle = n // 2
        before = np.flatnonzero(other[:middle])
        after = np.flatnonzero(other[middle:])
        r0 = int(before[-1]) + 1 if before.size else 0
        r1 = middle + int(after[0]) if after.size else other.size
        repeats = (r1 - r0 + 2 * period) // period
        s0 = start + r0
        todo += [("part", s0 + repeats * period, stop), ("run", (s0, period, repeats)),
                 ("part", start, s0)]
    return _merged([run for run in found if run[1] * run[2] > 0])


def _period(a, start, stop):
    """The least period up to :data:`MAX_PERIOD` with which the steps of the
    window of :data:`PROBE_ENTRIES` entries at the middle of ``a[start:stop]``
    repeat, else ``None``."""
    middle = (start + stop) // 2
    window = a[middle - PROBE_ENTRIES // 2:middle + PROBE_ENTRIES // 2].astype(np.int64)
    for period in range(1, MAX_PERIOD + 1):
        if not (window[2 * period:] - 2 * window[period:-period] + window[:-2 * period]).any():
            return period
    return None


def _merged(runs):
    """``runs`` with neighbouring single repeats joined (one stretch)."""
    out = []
    for run in runs:
        if out and run[2] == 1 and out[-1][2] == 1:
            start, length, _ = out[-1]
            out[-1] = (start, length + run[1], 1)
        else:
            out.append(run)
    return out


def entries(index, start, stop):
    """The entries ``start:stop`` of ``index`` (an array, a slice of it; a
    :class:`PeriodicIndex`, made from its runs): the chunks in which the
    analysis reads an index without making it whole."""
    if isinstance(index, PeriodicIndex):
        return index.take(start, min(stop, index.size))
    return np.asarray(index)[start:stop]


def kernel_index(index):
    """``index`` as the kernel takes an index argument: a
    :class:`PeriodicIndex` as ``(runs, table)``, else a C-contiguous int32
    array (a copy only where it is not one)."""
    if isinstance(index, PeriodicIndex):
        return index.runs, index.table
    return np.ascontiguousarray(index, dtype=_INDEX)
