r"""``DenseKKT``: the interior-point step's linear system, factorized dense.

The matrix, of size :math:`(n + m) \times (n + m)`,

.. math::

    K = \begin{bmatrix} H + \operatorname{diag}(d_x) & J^T \\
                        J & -\operatorname{diag}(d_c) \end{bmatrix},

is assembled as a dense array and factorized by SciPy's symmetric
indefinite :math:`LDL^T` (Bunch-Kaufman, :func:`scipy.linalg.ldl`).  Its
inertia is Sylvester's: the signs of the eigenvalues of :math:`D`'s
1 x 1 and 2 x 2 blocks.  Memory and time grow as :math:`(n + m)^2` and
:math:`(n + m)^3`: the reference for tests and small problems.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

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
    """The KKT matrix assembled dense and factorized by SciPy's ``ldl``.

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

    def factor(self, hessian_values, jacobian_values, diagonal_x, diagonal_c):
        """Factorize K with these values.

        Parameters
        ----------
        hessian_values : ndarray, shape (nnz_H,)
            In the order of ``hessian_structure``.
        jacobian_values : ndarray, shape (nnz_J,)
        diagonal_x : ndarray, shape (n,)
            Added to H's diagonal.
        diagonal_c : ndarray, shape (m,)
            ``>= 0``; :math:`-d_c` is K's lower right diagonal.

        Returns
        -------
        (n_positive, n_negative, n_zero) : tuple of int
            K's inertia.
        """
        n, size = self.n, self.size
        h = np.asarray(hessian_values, dtype=float)
        j = np.asarray(jacobian_values, dtype=float)
        weights = np.concatenate([h, h[self._hessian_off], j, j])
        K = np.bincount(self._positions, weights=weights, minlength=size * size)
        K = K.reshape(size, size)
        diagonal = np.einsum("ii->i", K)
        diagonal[:n] += diagonal_x
        diagonal[n:] -= diagonal_c
        self._matrix = K
        if not np.all(np.isfinite(K)):
            self._factors = None
            return (0, 0, size)
        lu, d, perm = scipy.linalg.ldl(K, lower=True, hermitian=True)
        self._factors = (lu[perm], perm)
        return self._blocks(d, np.max(np.abs(K), initial=0.0))

    def _blocks(self, d, scale):
        """Inertia from D's blocks; D's inverse kept as its blocks' inverses."""
        size = self.size
        diag = np.diag(d).copy()
        sub = np.diag(d, -1)
        starts = np.flatnonzero(sub != 0.0)
        single = np.ones(size, dtype=bool)
        single[starts] = single[starts + 1] = False
        a, c, b = diag[starts], diag[starts + 1], sub[starts]
        mean, radius = (a + c) / 2, np.hypot((a - c) / 2, b)
        eigenvalues = np.concatenate([diag[single], mean - radius, mean + radius])
        tiny = np.finfo(float).eps * size * scale
        positive = int(np.count_nonzero(eigenvalues > tiny))
        negative = int(np.count_nonzero(eigenvalues < -tiny))
        with np.errstate(divide="ignore", invalid="ignore"):
            inverse_single = np.where(single, 1.0 / np.where(single, diag, 1.0), 0.0)
            det = a * c - b * b
            self._block_inverse = (starts, c / det, a / det, -b / det)
        self._inverse_single = inverse_single
        return positive, negative, size - positive - negative

    def solve(self, rhs):
        """``K^{-1} rhs`` with the last factorization; shape (n + m,).
        Non-finite entries when K was singular."""
        if self._factors is None:
            return np.full(self.size, np.nan)
        lower, perm = self._factors
        rhs = np.asarray(rhs, dtype=float)
        first = scipy.linalg.solve_triangular(lower, rhs[perm], lower=True,
                                              unit_diagonal=True, check_finite=False)
        starts, ia, ic, ib = self._block_inverse
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            middle = self._inverse_single * first
            middle[starts] = ia * first[starts] + ib * first[starts + 1]
            middle[starts + 1] = ib * first[starts] + ic * first[starts + 1]
        last = scipy.linalg.solve_triangular(lower, middle, lower=True, trans="T",
                                             unit_diagonal=True, check_finite=False)
        out = np.empty(self.size)
        out[perm] = last
        return out

    def matvec(self, x):
        """``K @ x`` with the last factored values; shape (n + m,)."""
        return self._matrix @ np.asarray(x, dtype=float)
