r"""``DenseKKT``: the interior-point step's linear system, factorized dense.

The matrix, of size :math:`(n + m) \times (n + m)`,

.. math::

    K = \begin{bmatrix} H + \operatorname{diag}(d_x) & J^T \\
                        J & -\operatorname{diag}(d_c) \end{bmatrix},

is assembled as a dense array and factorized by LAPACK's symmetric
indefinite :math:`LDL^T` (Bunch-Kaufman, ``dsytrf`` through
:mod:`scipy.linalg.lapack`, what :func:`scipy.linalg.ldl` calls, without
its reconstruction of :math:`L`), solved by ``dsytrs``, after a symmetric
scaling :math:`S K S` that brings each row's largest entry to one.  Its
inertia is Sylvester's: the signs of the eigenvalues of :math:`D`'s 1 x 1
and 2 x 2 blocks, one within :math:`(n + m)\,\epsilon` of zero counted as
zero.  Memory and time grow as :math:`(n + m)^2` and
:math:`(n + m)^3`: the reference for tests and small problems.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg.lapack

from ._diagonal import dense_diagonal

__all__ = ["DenseKKT", "check_structure"]


def check_structure(name, structure, n_rows, n_cols, lower=False):
    """``(rows, cols)`` of a sparse pattern as int64 arrays, checked.

    Parameters
    ----------
    name : str
        The argument's name, for the error.
    structure : (rows, cols)
        Integer sequences of one length.
    n_rows, n_cols : int
        The matrix's shape.
    lower : bool
        Refuse entries above the diagonal (``row < col``).
    """
    rows, cols = (np.asarray(a, dtype=np.int64).ravel() for a in structure)
    if rows.shape != cols.shape:
        raise ValueError(f"{name}: rows ({rows.size}) and cols ({cols.size}) differ in length")
    if rows.size and (rows.min() < 0 or rows.max() >= n_rows or cols.min() < 0
                      or cols.max() >= n_cols):
        raise ValueError(f"{name}: an index outside the {n_rows} x {n_cols} matrix")
    if lower and np.any(rows < cols):
        raise ValueError(f"{name}: an entry above the diagonal (row < col); give the "
                         "lower triangle")
    return rows, cols


class DenseKKT:
    """The KKT matrix assembled dense and factorized by LAPACK's ``dsytrf``.

    Parameters
    ----------
    n, m : int
        Primal variables and constraint rows.
    hessian_structure : (rows, cols)
        The lower triangle (``row >= col``) of the n x n Hessian of the
        Lagrangian; repeated entries are summed.
    jacobian_structure : (rows, cols)
        The m x n constraint Jacobian; repeated entries are summed.
    """

    def __init__(self, n, m, hessian_structure, jacobian_structure):
        self.n, self.m = n, m
        size = self.size = n + m
        hr, hc = check_structure("hessian_structure", hessian_structure, n, n, lower=True)
        jr, jc = check_structure("jacobian_structure", jacobian_structure, m, n)
        off = hr != hc
        # flat positions in K of each value, both triangles
        self._hessian_lower = hr * size + hc
        self._hessian_upper = (hc * size + hr)[off]
        self._hessian_off = off
        self._jacobian_lower = (n + jr) * size + jc
        self._jacobian_upper = jc * size + (n + jr)
        self._positions = np.concatenate([self._hessian_lower, self._hessian_upper,
                                          self._jacobian_lower, self._jacobian_upper])
        self._matrix = None

    def factor(self, hessian_values, jacobian_values, diagonal_x, diagonal_c, added_x=0.0):
        """Factorize K with these values.

        Parameters
        ----------
        hessian_values : ndarray, shape (nnz_H,)
            In the order of ``hessian_structure``.
        jacobian_values : ndarray, shape (nnz_J,)
        diagonal_x : ndarray, shape (n,), float, or DiagonalEntries
            Added to H's diagonal (a number: on every entry).
        diagonal_c : ndarray, shape (m,), or float
            ``>= 0``; :math:`-d_c` is K's lower right diagonal.
        added_x : float
            Added to ``diagonal_x`` where not 0 (the interior point's
            :math:`\\delta_w`).

        Returns
        -------
        (n_positive, n_negative, n_zero) : tuple of int
            K's inertia.
        """
        n, size = self.n, self.size
        diagonal_x = dense_diagonal(diagonal_x)
        h = np.asarray(hessian_values, dtype=float)
        j = np.asarray(jacobian_values, dtype=float)
        weights = np.concatenate([h, h[self._hessian_off], j, j])
        K = np.bincount(self._positions, weights=weights, minlength=size * size)
        K = K.reshape(size, size)
        diagonal = np.einsum("ii->i", K)
        diagonal[:n] += np.add(diagonal_x, added_x) if added_x else diagonal_x
        diagonal[n:] -= diagonal_c
        self._matrix = K
        self._factors = None
        if not np.all(np.isfinite(K)):
            return (0, 0, size)
        # symmetric scaling S K S, rows' largest entries near one: the
        # inertia is K's (Sylvester), a pivot's size relative to its rows
        largest = np.max(np.abs(K), axis=1)
        scale = 1.0 / np.sqrt(np.where(largest > 0, largest, 1.0))
        factor, pivots, info = scipy.linalg.lapack.dsytrf(scale[:, None] * K * scale, lower=1)
        if info < 0:
            raise RuntimeError(f"LAPACK's dsytrf refused argument {-info}")
        self._factors = (factor, pivots, scale)
        return _inertia(factor, pivots)

    def solve(self, rhs, overwrite=False):
        """``K^{-1} rhs`` with the last factorization; shape (n + m,).
        Non-finite entries when K was singular.  ``overwrite`` is ignored
        (the interface's; the scaling makes a new array anyway)."""
        if self._factors is None:
            return np.full(self.size, np.nan)
        factor, pivots, scale = self._factors
        with np.errstate(all="ignore"):
            x, _ = scipy.linalg.lapack.dsytrs(factor, pivots,
                                                 scale * np.asarray(rhs, dtype=float), lower=1)
        return scale * x

    def matvec(self, x):
        """``K @ x`` with the last factored values; shape (n + m,)."""
        return self._matrix @ np.asarray(x, dtype=float)

    def release(self):
        """Drop K and its factors until the next :meth:`factor`."""
        self._matrix = self._factors = None


def _inertia(factor, pivots):
    """``(n_positive, n_negative, n_zero)`` of D in LAPACK's ``dsytrf``
    (lower) of the scaled matrix: a 1 x 1 block where the pivot index is
    positive, a 2 x 2 block on two consecutive negative ones (paired from the
    start of each run); a block's eigenvalue within ``size * eps`` of zero
    counts as zero."""
    size = factor.shape[0]
    diag = np.diagonal(factor).copy()
    sub = np.append(np.diagonal(factor, -1), 0.0)
    negative = pivots < 0
    # position of each entry in its run of negative pivot indices
    run_start = np.maximum.accumulate(np.where(negative & ~np.r_[False, negative[:-1]],
                                               np.arange(size), 0))
    starts = np.flatnonzero(negative & ((np.arange(size) - run_start) % 2 == 0))
    single = ~negative
    a, c, b = diag[starts], diag[starts + 1], sub[starts]
    mean, radius = (a + c) / 2, np.hypot((a - c) / 2, b)
    eigenvalues = np.concatenate([diag[single], mean - radius, mean + radius])
    tiny = np.finfo(float).eps * size
    positive = int(np.count_nonzero(eigenvalues > tiny))
    negative_count = int(np.count_nonzero(eigenvalues < -tiny))
    return positive, negative_count, size - positive - negative_count
