"""A diagonal that is zero but at some entries: the barrier's :math:`\\Sigma`
(nonzero only where a variable is bounded), given to the factorizations
without an array of every variable's."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["DiagonalEntries", "dense_diagonal"]


class DiagonalEntries(NamedTuple):
    """A diagonal of ``size`` entries, ``values`` at the increasing entries
    ``index`` (int32, each below ``size``) and 0 elsewhere."""

    index: np.ndarray
    values: np.ndarray
    size: int

    def dense(self):
        """The (size,) array of every entry."""
        out = np.zeros(self.size)
        out[self.index] = self.values
        return out

    def split(self, n):
        """``(first, rest)``: the entries below ``n``, a :class:`DiagonalEntries`
        of size ``n`` (views of these arrays), and those from ``n`` on, an array
        of ``size - n``."""
        k = int(np.searchsorted(self.index, n))
        rest = np.zeros(self.size - n)
        rest[self.index[k:] - n] = self.values[k:]
        return DiagonalEntries(self.index[:k], self.values[:k], n), rest


def dense_diagonal(diagonal):
    """``diagonal`` (an array, a number or :class:`DiagonalEntries`) with a
    :class:`DiagonalEntries` made dense: what a factorization of dense
    arrays takes."""
    return diagonal.dense() if isinstance(diagonal, DiagonalEntries) else diagonal
