r"""``LowRankKKT``: the Newton system with a limited-memory Hessian
:math:`B = \sigma I - V M^{-1} V^T` (:mod:`.._quasi_newton`).

.. math::

    K = K_0 + U C U^T, \quad
    K_0 = \begin{bmatrix} \operatorname{diag}(d_x + \sigma) & J^T \\
                          J & -\operatorname{diag}(d_c) \end{bmatrix}, \quad
    U = \begin{bmatrix} V \\ 0 \end{bmatrix}, \quad C = -M^{-1}

:math:`K_0` is factored by the sparse or dense KKT object given (with no
Hessian entries); with :math:`Z = K_0^{-1} U` and :math:`G = U^T Z - M`
(2h x 2h), the Sherman-Morrison-Woodbury formula gives

.. math::

    K^{-1} b = K_0^{-1} b - Z G^{-1} U^T K_0^{-1} b ,

and Haynsworth's inertia additivity on :math:`\begin{bmatrix} K_0 & U \\ U^T
& M \end{bmatrix}`, whose Schur complements are :math:`-G` (of :math:`K_0`)
and :math:`K` (of :math:`M`), the inertia
:math:`\operatorname{In}(K) = \operatorname{In}(K_0) + \operatorname{In}(-G)
- \operatorname{In}(M)` from two small symmetric eigenvalue problems, each
of the matrix scaled by its diagonal's square roots on both sides (the same
inertia, Sylvester's law): the pairs' steps may differ in length by many
orders, and so would the eigenvalues of :math:`M` and :math:`G` unscaled,
below one threshold for zero in one and above it in the other.
"""

from __future__ import annotations

import numpy as np

from .._quasi_newton import CompactHessian
from ._diagonal import dense_diagonal

__all__ = ["LowRankKKT"]


class LowRankKKT:
    """The interface of :class:`._dense.DenseKKT` (``factor``, ``solve``,
    ``matvec``, ``release``) for a :class:`~.._quasi_newton.CompactHessian`.

    Parameters
    ----------
    base : DenseKKT or SparseKKT
        Of the n variables and m rows, with an empty Hessian structure.
    """

    def __init__(self, base):
        self.base = base
        self.n, self.m, self.size = base.n, base.m, base.n + base.m
        self.error_reductions = getattr(base, "error_reductions", None)
        self._low_rank = None  # (hessian, Z, G) of the last factorization with h > 0

    def factor(self, hessian, jacobian_values, diagonal_x, diagonal_c, added_x=0.0):
        """Factor K; return its inertia ``(n_positive, n_negative, n_zero)``.

        Parameters
        ----------
        hessian : CompactHessian or ndarray of size 0
            The approximation (an empty array: no Hessian, as the start's
            least-squares multipliers take it).
        jacobian_values, diagonal_x, diagonal_c, added_x
            As the base object takes them.
        """
        self._low_rank = None
        if not isinstance(hessian, CompactHessian):
            return self.base.factor(hessian, jacobian_values, diagonal_x, diagonal_c,
                                    added_x)
        diagonal_x = dense_diagonal(diagonal_x)
        diagonal = np.add(diagonal_x, added_x) if added_x else np.asarray(diagonal_x,
                                                                          dtype=float)
        inertia = self.base.factor(np.zeros(0), jacobian_values, diagonal + hessian.sigma,
                                   diagonal_c)
        V, M = hessian.V, hessian.M
        if not M.size or inertia[2]:
            return inertia
        n, k = self.n, M.shape[0]
        Z = np.empty((self.size, k))
        column = np.zeros(self.size)
        for j in range(k):
            column[:n] = V[:, j]
            Z[:, j] = self.base.solve(column)
        G = V.T @ Z[:n] - M
        G = 0.5 * (G + G.T)
        if not (np.isfinite(Z).all() and np.isfinite(G).all()):
            return (0, 0, self.size)
        self._low_rank = (hessian, Z, G)
        with_g, with_m = _inertia(-G), _inertia(M)
        return tuple(int(a + b - c) for a, b, c in zip(inertia, with_g, with_m))

    def solve(self, rhs, overwrite=False):
        """``K^{-1} rhs`` with the last factorization; shape (n + m,).
        ``overwrite`` is passed to the base object; the correction is
        subtracted in place from its solution (new, or ``rhs`` itself when
        the base took it)."""
        x = self.base.solve(rhs, overwrite=overwrite)
        if self._low_rank is None:
            return x
        hessian, Z, G = self._low_rank
        x -= Z @ np.linalg.solve(G, hessian.V.T @ x[:self.n])
        return x

    def matvec(self, x):
        """``K @ x`` with the last factored values; shape (n + m,)."""
        out = self.base.matvec(x)
        if self._low_rank is None:
            return out
        out[:self.n] -= self._low_rank[0].correction(np.asarray(x, dtype=float)[:self.n])
        return out

    def release(self):
        """Drop the factors until the next :meth:`factor`."""
        self._low_rank = None
        self.base.release()


def _inertia(matrix):
    """``(n_positive, n_negative, n_zero)`` of a small symmetric matrix: the
    eigenvalues of ``D^-1 matrix D^-1`` (``D`` the square roots of its
    diagonal's magnitudes, 1 where zero), one within ``k eps`` of the largest
    magnitude counting as zero."""
    scale = np.sqrt(np.abs(np.diagonal(matrix)))
    scale[scale == 0.0] = 1.0
    eigenvalues = np.linalg.eigvalsh(matrix / np.outer(scale, scale))
    tiny = matrix.shape[0] * np.finfo(float).eps * np.abs(eigenvalues).max(initial=0.0)
    positive = int(np.count_nonzero(eigenvalues > tiny))
    negative = int(np.count_nonzero(eigenvalues < -tiny))
    return positive, negative, matrix.shape[0] - positive - negative
