r"""The exact Hessian of a multiphase NLP's Lagrangian.

The phases share no variable, so their Lagrangians' Hessians
(:class:`._hessian.LagrangianHessian`, each with its own rows' multipliers)
sit on the diagonal at their offsets; the junctions add the second
derivatives of their equations (SymPy's) times their multipliers.  The rows
that tie a start time to the end of the phase before and those of continuity
are linear and add nothing.
"""

from __future__ import annotations

import numpy as np

from ._nlp import index_arrays

__all__ = ["MultiphaseHessian"]


class MultiphaseHessian:
    """Pattern (lower triangle) and values of the Hessian of ``nlp``'s
    Lagrangian (a :class:`._multiphase.MultiphaseNLP` whose phases were
    built with ``hessian="exact"``)."""

    def __init__(self, nlp):
        self.nlp = nlp
        rows, cols = [], []
        for sub, offset in zip(nlp.phase_nlps, nlp.offsets):
            r, c = sub.hessian_structure()
            rows.append(r + offset)
            cols.append(c + offset)
        self._junctions = [(i, row) for i, row in enumerate(nlp.rows) if row.hessian is not None]
        self._masks = []
        for _, row in self._junctions:
            r = np.broadcast_to(row.columns[:, None], (row.columns.size,) * 2)
            c = r.T
            mask = r >= c
            self._masks.append(mask)
            rows.append(r[mask])
            cols.append(c[mask])
        self.structure = index_arrays(rows, cols, nlp.n, nlp.n)

    def values(self, z, sigma, multipliers):
        """The values in the order of :attr:`structure`."""
        nlp = self.nlp
        multipliers = np.asarray(multipliers, dtype=float)
        out = [sub.hessian(x, multipliers[r:r + sub.m], sigma)
               for sub, x, r in zip(nlp.phase_nlps, nlp.parts(z), nlp.row_offsets)]
        first = nlp.m - len(nlp.rows)
        z = np.asarray(z, dtype=float)
        for (i, row), mask in zip(self._junctions, self._masks):
            out.append(multipliers[first + i] * row.hessian(z)[mask])
        return np.concatenate(out)
