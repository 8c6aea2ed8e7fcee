"""Checks of mass and stiffness matrices brought from elsewhere, and Matrix Market files."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..._errors import ModelError
from ._lazy_scipy import sio, sp, spla

__all__ = ["check_matrix", "read_matrix"]

#: matrices up to this size get a dense eigenvalue check of semidefiniteness; larger
#: ones an inertia count from a sparse factorization
_DENSE_CHECK = 1000


def read_matrix(member, what, path):
    """Read a Matrix Market file (:func:`scipy.io.mmread`); errors name the member and file."""
    path = Path(path)
    try:
        A = sio.mmread(str(path))
    except (OSError, ValueError) as exc:
        raise ModelError(f"member {member!r}: cannot read the {what} matrix from {str(path)!r} "
                         f"as a Matrix Market file: {exc}") from None
    return sp.csr_array(A) if sp.issparse(A) else np.asarray(A)


def check_matrix(member, what, A, n_nodes, tolerance):
    """Validate a mass or stiffness matrix; return it as float ndarray or CSR array.

    Checks: two-dimensional, square, ``6 * n_nodes`` rows, finite, symmetric
    (largest ``|A - A^T|`` at most ``tolerance`` times the largest ``|A|``) and
    positive semidefinite (smallest eigenvalue at least ``-tolerance`` times
    the largest).
    """
    where = f"member {member!r}: the {what} matrix"
    if sp.issparse(A):
        A = sp.csr_array(A, dtype=float)
    else:
        try:
            A = np.asarray(A, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ModelError(f"{where} is not an array of numbers ({exc})") from None
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ModelError(f"{where} must be square, got shape {A.shape}")
    N = 6 * n_nodes
    if A.shape[0] != N:
        raise ModelError(f"{where} is {A.shape[0]} x {A.shape[1]} but {n_nodes} nodes have {N} "
                         f"degrees of freedom (6 per node: ux, uy, uz, rx, ry, rz)")
    values = A.data if sp.issparse(A) else A
    if not np.all(np.isfinite(values)):
        raise ModelError(f"{where} has entries that are not finite numbers")
    scale = float(np.max(np.abs(values))) if values.size else 0.0
    if scale == 0.0:
        raise ModelError(f"{where} is zero")
    diff = A - A.T
    if sp.issparse(diff):
        diff = diff.tocoo()
        worst = int(np.argmax(np.abs(diff.data))) if diff.nnz else None
        asym = float(abs(diff.data[worst])) if worst is not None else 0.0
        where_ij = (int(diff.row[worst]), int(diff.col[worst])) if worst is not None else (0, 0)
    else:
        flat = int(np.argmax(np.abs(diff)))
        asym = float(np.abs(diff).flat[flat])
        where_ij = np.unravel_index(flat, diff.shape)
    if asym > tolerance * scale:
        i, j = (int(v) for v in where_ij)
        raise ModelError(f"{where} is not symmetric: entries ({i}, {j}) and ({j}, {i}) differ by "
                         f"{asym:.3g} ({asym / scale:.3g} of its largest entry)")
    if A.shape[0] <= _DENSE_CHECK:
        dense = A.toarray() if sp.issparse(A) else A
        eig = np.linalg.eigvalsh(0.5 * (dense + dense.T))
        lo, hi = float(eig[0]), float(eig[-1])
        if lo < -tolerance * max(hi, 0.0):
            raise ModelError(f"{where} is not positive semidefinite: its smallest eigenvalue is "
                             f"{lo:.3g} ({lo / hi:.3g} of its largest, {hi:.3g})")
    else:
        _check_sparse_semidefinite(where, A, tolerance)
    return A


def _eigenvalues_below(S, sigma):
    """How many eigenvalues of the symmetric ``S`` lie below ``sigma`` (Sylvester's law of
    inertia: the negative pivots of an LDL^T factorization of ``S - sigma I`` with symmetric
    diagonal pivoting); ``None`` if the factorization needed off-diagonal pivots."""
    shifted = sp.csc_array(S - sigma * sp.eye_array(S.shape[0], format="csc"))
    try:
        lu = spla.splu(shifted, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
    except RuntimeError:                        # exactly singular: sigma is an eigenvalue
        return None
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    return int(np.sum(lu.U.diagonal() < 0))


def _check_sparse_semidefinite(where, A, tolerance):
    """Semidefiniteness of a large sparse matrix by inertia counts (no eigensolver).

    With ``g`` the Gershgorin bound of the largest eigenvalue, ``A`` passes if
    no eigenvalue lies below ``-tolerance * g``; otherwise the smallest
    eigenvalue is bracketed by bisection on the shift to report by how much.
    """
    S = sp.csc_array(0.5 * (A + A.T))
    bound = float(np.max(np.abs(S).sum(axis=1)))
    delta = tolerance * bound
    count = _eigenvalues_below(S, -delta)
    if count is None:
        warnings.warn(f"{where}: could not confirm that it is positive semidefinite (the "
                      f"factorization needed off-diagonal pivots)", stacklevel=5)
        return
    if count == 0:
        return
    low, high = bound, delta                    # the smallest eigenvalue is in [-low, -high]
    while low > 1.01 * high:
        mid = np.sqrt(low * high)
        below = _eigenvalues_below(S, -mid)
        if below is None:
            break
        low, high = (low, mid) if below else (mid, high)
    raise ModelError(f"{where} is not positive semidefinite: its smallest eigenvalue is about "
                     f"{-np.sqrt(low * high):.3g} ({-np.sqrt(low * high) / bound:.3g} of the "
                     f"bound {bound:.3g} of its largest); {count} eigenvalue(s) below "
                     f"{-delta:.3g}")
