r"""The limited-memory BFGS approximation of the Lagrangian's Hessian
(``hessian_approximation="limited-memory"``, IPOPT's option of that name).

From the last :math:`h` pairs (``limited_memory_max_history``)

.. math::

    s_k = x_{k+1} - x_k, \qquad
    y_k = \nabla_x L(x_{k+1}, \lambda_{k+1}) - \nabla_x L(x_k, \lambda_{k+1})

(:math:`\nabla_x L = \sigma_f \nabla f + J^T \lambda`, the multipliers of
the newer point in both terms, the bounds' multipliers cancelling), the
compact representation of Byrd, Nocedal & Schnabel ("Representations of
quasi-Newton matrices and their use in limited memory methods", Math.
Program. 63, 1994, eq. (2.17)):

.. math::

    B = \sigma I - V M^{-1} V^T, \qquad V = [\sigma S \;\; Y], \qquad
    M = \begin{bmatrix} \sigma S^T S & L \\ L^T & -D \end{bmatrix}

with :math:`S, Y` the pairs as columns, :math:`L_{ij} = s_i^T y_j` for
:math:`i > j` (else 0) and :math:`D = \operatorname{diag}(s_i^T y_i)`.
:math:`\sigma` is IPOPT's ``scalar1`` initialization, :math:`s^T y / s^T s`
of the newest pair within ``[limited_memory_init_val_min,
limited_memory_init_val_max]``; ``limited_memory_init_val`` before the
first pair.  A pair with :math:`s^T y \le \sqrt{\epsilon}\,\|s\|\,\|y\|` is
skipped (:math:`B` stays positive definite); more than
``limited_memory_max_skipping`` skipped in a row empty the memory.  That is
IPOPT's rule (``limited_memory_update_type="bfgs"``).  By default
(``"damped-bfgs"``) a pair of too little curvature is damped first
(Powell's rule, Nocedal & Wright, *Numerical Optimization*, 2nd ed.,
procedure 18.2): where :math:`s^T y < 0.2\, s^T B s`, :math:`y` becomes
:math:`\theta y + (1 - \theta) B s` with :math:`\theta = 0.8\, s^T B s /
(s^T B s - s^T y)`, so that :math:`s^T y = 0.2\, s^T B s > 0`.  Where the
Lagrangian is not convex the memory then keeps curvature that skipping
throws away: with skipping, the steps of opty's least-time double pendulum
shrink to gradient steps of :math:`B = I` (the memory emptied again and
again) and the iterations stall short of the optimum; damped, they converge
to a local optimum (``docs/benchmarks.md``).  On the pendulum swing-ups that
are infeasible with 40 nodes the damped iterations end in local
infeasibility (status 2) as IPOPT's with the exact Hessian do; with
skipping they run to ``max_iter``.

:class:`.kkt._low_rank.LowRankKKT` factors the Newton system with
:math:`\sigma I` on the diagonal and adds :math:`-V M^{-1} V^T` by the
Sherman-Morrison-Woodbury formula.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CompactHessian", "LimitedMemoryBFGS"]

_SKIP = np.sqrt(np.finfo(float).eps)


@dataclass(frozen=True)
class CompactHessian:
    r""":math:`B = \sigma I - V M^{-1} V^T` (the module's notation).

    Attributes
    ----------
    sigma : float
        > 0.
    V : ndarray, shape (n, 2 h)
        :math:`[\sigma S \;\; Y]`; ``h = 0``: :math:`B = \sigma I`.
    M : ndarray, shape (2 h, 2 h)
        Symmetric, nonsingular.
    """

    sigma: float
    V: np.ndarray
    M: np.ndarray

    def correction(self, v):
        r""":math:`V M^{-1} V^T v`, shape (n,): :math:`\sigma v - B v`."""
        if not self.M.size:
            return np.zeros(self.V.shape[0])
        return self.V @ np.linalg.solve(self.M, self.V.T @ v)

    def times(self, v):
        """:math:`B v`, shape (n,)."""
        return self.sigma * np.asarray(v, dtype=float) - self.correction(v)

    def dense(self):
        """:math:`B` as an (n, n) array (for checks; n small)."""
        n = self.V.shape[0]
        out = self.sigma * np.eye(n)
        if self.M.size:
            out -= self.V @ np.linalg.solve(self.M, self.V.T)
        return out


class LimitedMemoryBFGS:
    """The memory of pairs of one problem (the NLP's, or the restoration
    phase's, which keeps its own).

    Parameters
    ----------
    settings : namespace
        The solver's options (``limited_memory_*``).
    """

    def __init__(self, settings):
        self.settings = settings
        self.reset()

    def reset(self):
        """Forget every pair and the last point."""
        self.S = self.Y = None  # (h, n) each: the pairs as rows, oldest first
        self.sigma = float(self.settings.limited_memory_init_val)
        self.skipped = 0
        #: ``(x, gradient, jacobian_values)`` of the last point, or ``None``
        self.last = None
        self._compact = None  # compact()'s, until the pairs or sigma change

    def update(self, s, y):
        """Add the pair ``(s, y)`` (or skip it, see the module)."""
        st = self.settings
        sy = float(s @ y)
        if st.limited_memory_update_type == "damped-bfgs":
            Bs = self.compact(s.size).times(s)
            sBs = float(s @ Bs)
            if sBs > 0 and sy < 0.2 * sBs:
                theta = 0.8 * sBs / (sBs - sy)
                y = theta * y + (1.0 - theta) * Bs
                sy = float(s @ y)
        if not (np.isfinite(sy) and sy > _SKIP * np.linalg.norm(s) * np.linalg.norm(y)):
            self.skipped += 1
            if self.skipped > st.limited_memory_max_skipping:
                self.reset()
            return
        self.skipped = 0
        self._compact = None
        keep = int(st.limited_memory_max_history)
        if keep:  # the newest ``keep`` pairs
            s_row, y_row = np.array(s, dtype=float)[None, :], np.array(y, dtype=float)[None, :]
            self.S = s_row if self.S is None else _newest(self.S, s_row, keep)
            self.Y = y_row if self.Y is None else _newest(self.Y, y_row, keep)
        self.sigma = float(np.clip(sy / float(s @ s), st.limited_memory_init_val_min,
                                   st.limited_memory_init_val_max))

    def compact(self, n):
        """The :class:`CompactHessian` of the pairs held (``n`` variables),
        made once per change of the pairs (the damping asks for it before an
        update, the step after it)."""
        if self._compact is None:
            self._compact = self._made(n)
        return self._compact

    def _made(self, n):
        sigma = self.sigma
        if self.S is None:
            return CompactHessian(sigma, np.zeros((n, 0)), np.zeros((0, 0)))
        S, Y = self.S, self.Y
        SY = S @ Y.T  # (h, h): s_i . y_j
        h = S.shape[0]
        M = np.empty((2 * h, 2 * h))
        M[:h, :h] = sigma * (S @ S.T)
        L = np.tril(SY, -1)
        M[:h, h:] = L
        M[h:, :h] = L.T
        M[h:, h:] = -np.diag(np.diag(SY))
        return CompactHessian(sigma, np.concatenate([sigma * S, Y]).T, M)


def _newest(rows, row, keep):
    """``rows`` (h, n) with ``row`` (1, n) after them, the newest ``keep``
    kept: a new array of at most ``keep`` rows (a slice of a longer one would
    hold all its rows)."""
    return np.concatenate([rows[max(len(rows) - keep + 1, 0):], row])
