r"""Lowest natural modes of finite-element models, by SciPy's eigensolvers.

All problems are posed as :math:`K x = \omega^2 M x` with :math:`K` positive
definite (the structure held so that it cannot move rigidly) and :math:`M`
positive *semi*definite (massless degrees of freedom, e.g. lumped mass
matrices without rotary inertia, are allowed: their frequencies are infinite
and they never appear among the lowest modes).  Dense problems are solved as
:math:`M x = \mu K x`, :math:`\mu = 1/\omega^2`, by :func:`scipy.linalg.eigh`
(largest :math:`\mu` first); sparse ones by :func:`scipy.sparse.linalg.eigsh`
in shift-invert mode about :math:`\sigma = 0`.

Structures that can move rigidly (free members, pinned members) are reduced
to that form exactly: with :math:`R` the rigid-body modes that the supports
allow, normalized to the identity at a set of *pivot* degrees of freedom
:math:`p`, every elastic mode is :math:`x = T y + R a` with :math:`y` the
displacement relative to the pivots and :math:`R^T M x = 0`, so that

.. math::

    K_{ii}\,y = \omega^2 \bigl(M_{ii} - B C^{-1} B^T\bigr)\,y ,\qquad
    B = T^T M R,\; C = R^T M R,\; a = -C^{-1} B^T y ,

a problem with :math:`K_{ii}` positive definite and an effective mass that
is positive semidefinite (a Schur complement).  No frequency shift is needed
and the rigid-body modes never enter the eigensolver.
"""

from __future__ import annotations

import numpy as np

from ..._errors import ModelError
from ._lazy_scipy import sla, sp, spla

__all__ = ["lowest_modes", "elastic_modes", "rigid_body_modes", "submatrix", "is_sparse",
           "DENSE_LIMIT"]

#: problems with at most this many degrees of freedom are solved densely by ``solver="auto"``
DENSE_LIMIT = 3000
#: modes with 1/omega^2 below this fraction of the largest count as infinite-frequency
_FINITE = 1e-13


def is_sparse(A):
    return sp.issparse(A)


def submatrix(A, rows, cols):
    """``A[rows][:, cols]`` for dense arrays and SciPy sparse arrays (sparse stays CSR)."""
    if sp.issparse(A):
        return sp.csr_array(A)[rows, :][:, cols]
    return np.asarray(A)[np.ix_(rows, cols)]


def _dense(A):
    return A.toarray() if sp.issparse(A) else np.asarray(A, float)


def _use_dense(n, solver):
    if solver == "dense":
        return True
    if solver == "sparse":
        return n <= 2          # eigsh needs k < n; tiny problems go dense anyway
    return n <= DENSE_LIMIT


def rigid_body_modes(nodes, about):
    """Small rigid-body motions of the nodes, shape (6n, 6).

    Columns: unit translations along x, y, z, then unit rotations (rad) about
    x, y, z through the point ``about``.  Dof order per node
    ``ux, uy, uz, rx, ry, rz``.
    """
    nodes = np.asarray(nodes, float)
    R = np.zeros((6 * len(nodes), 6))
    for k, x in enumerate(nodes):
        r = x - np.asarray(about, float)
        R[6 * k:6 * k + 3, :3] = np.eye(3)
        R[6 * k:6 * k + 3, 3:] = np.array([[0.0, r[2], -r[1]],
                                           [-r[2], 0.0, r[0]],
                                           [r[1], -r[0], 0.0]])
        R[6 * k + 3:6 * k + 6, 3:] = np.eye(3)
    return R


def lowest_modes(name, K, M, *, count=None, max_omega2=None, low_rank=None, solver="auto",
                 what="modes", allow_fewer=False):
    """Lowest eigenpairs of ``K x = omega^2 (M - B C^-1 B^T) x``.

    Parameters
    ----------
    name : str
        Member name, for messages.
    K : ndarray or sparse, shape (n, n)
        Positive definite stiffness.
    M : ndarray or sparse, shape (n, n)
        Positive semidefinite mass.
    count : int, optional
        Number of modes wanted (exactly one of ``count`` and ``max_omega2``).
    max_omega2 : float, optional
        All modes with ``omega^2 <= max_omega2`` (rad^2/s^2).
    low_rank : (B, C), optional
        ``B`` (n, r) and ``C`` (r, r) of a low-rank correction of the mass.
    solver : {"auto", "dense", "sparse"}
    what : str
        What the modes are, for messages.
    allow_fewer : bool
        Return fewer than ``count`` modes when no more have a finite frequency
        (instead of raising).

    Returns
    -------
    omega2 : ndarray, shape (k,)
        Ascending squared circular frequencies, rad^2/s^2.
    X : ndarray, shape (n, k)
        Eigenvectors normalized to unit (effective) modal mass.
    """
    n = K.shape[0]
    if count is not None and count > n:
        raise ModelError(f"member {name!r}: {count} {what} requested but the model has only "
                         f"{n} degrees of freedom to give them")
    if count == 0 or n == 0:
        return np.zeros(0), np.zeros((n, 0))
    if _use_dense(n, solver):
        omega2, X = _dense_modes(name, K, M, count, max_omega2, low_rank, what)
    else:
        omega2, X = _sparse_modes(name, K, M, count, max_omega2, low_rank, what)
    if count is not None and len(omega2) < count and not allow_fewer:
        raise ModelError(f"member {name!r}: {count} {what} requested but the model has only "
                         f"{len(omega2)} with a finite frequency (the others' degrees of "
                         f"freedom carry no mass)")
    return omega2, X


def _check_stiffness_definite(name, what, exc):
    raise ModelError(f"member {name!r}: the stiffness matrix is singular with the supports of "
                     f"the {what} (the member, or part of it, can move without deforming): "
                     f"{exc}") from None


def _dense_modes(name, K, M, count, max_omega2, low_rank, what):
    Kd = _dense(K)
    Md = _dense(M)
    if low_rank is not None:
        B, C = low_rank
        Md = Md - B @ np.linalg.solve(C, B.T)
    Md = 0.5 * (Md + Md.T)
    n = Kd.shape[0]
    try:
        if count is not None:
            mu, V = sla.eigh(Md, Kd, subset_by_index=[n - count, n - 1])
        else:
            mu, V = sla.eigh(Md, Kd, subset_by_value=[1.0 / max_omega2, np.inf])
    except np.linalg.LinAlgError as exc:
        _check_stiffness_definite(name, what, exc)
    order = np.argsort(mu)[::-1]
    mu, V = mu[order], V[:, order]
    if len(mu) == 0:
        return np.zeros(0), np.zeros((n, 0))
    scale = max(mu[0], float(np.max(np.abs(np.diag(Md)) / np.diag(Kd))))
    keep = mu > _FINITE * scale
    mu, V = mu[keep], V[:, keep]
    # eigh normalizes V^T K V = I, so V^T M V = diag(mu)
    return 1.0 / mu, V / np.sqrt(mu)


def _sparse_modes(name, K, M, count, max_omega2, low_rank, what):
    n = K.shape[0]
    Ks = sp.csc_array(K)
    if low_rank is None:
        Mop = sp.csr_array(M)
    else:
        B, C = low_rank
        Ms = sp.csr_array(M)
        CinvBt = np.linalg.solve(C, B.T)
        Mop = spla.LinearOperator((n, n), matvec=lambda x: Ms @ x - B @ (CinvBt @ x),
                                  dtype=float)
    try:
        lu = spla.splu(Ks)
    except RuntimeError as exc:
        _check_stiffness_definite(name, what, exc)
    Kinv = spla.LinearOperator((n, n), matvec=lu.solve, dtype=float)
    k = count if count is not None else min(n - 2, 12)
    while True:
        if k >= n - 1:      # ARPACK cannot return that many: solve densely
            return _dense_modes(name, K, M, count, max_omega2, low_rank, what)
        lam, V = spla.eigsh(Ks, k=k, M=Mop, sigma=0.0, which="LM", OPinv=Kinv)
        order = np.argsort(lam)
        lam, V = lam[order], V[:, order]
        keep = (lam > 0) & (lam < lam[0] / _FINITE)
        lam, V = lam[keep], V[:, keep]
        if count is not None or (len(lam) and lam[-1] > max_omega2) or len(lam) < k:
            break
        k = min(2 * k, n - 1)
    if max_omega2 is not None:
        sel = lam <= max_omega2
        lam, V = lam[sel], V[:, sel]
    MV = Mop @ V
    V = V / np.sqrt(np.einsum("ij,ij->j", V, MV))
    return lam, V


def elastic_modes(name, K, M, nodes, fixed, *, count=None, max_omega2=None, pivots=None,
                  solver="auto", what="modes"):
    """Lowest elastic modes of a member held at the degrees of freedom ``fixed``.

    The rigid-body motions the supports leave free are removed exactly (see
    the module docstring): the result contains only modes of nonzero frequency.

    Parameters
    ----------
    name : str
        Member name, for messages.
    K, M : ndarray or sparse, shape (N, N)
        Stiffness and mass of the whole member, N = 6 n.
    nodes : ndarray, shape (n, 3)
        Node positions, m (rigid-body motions are built from them).
    fixed : sequence of int
        Degrees of freedom held at zero.
    count, max_omega2 : see :func:`lowest_modes`
    pivots : sequence of int, optional
        Degrees of freedom at which the rigid-body motion left free is measured
        (default: chosen by pivoted QR).  The relative modes are zero there.
    solver : {"auto", "dense", "sparse"}
    what : str
        For messages.

    Returns
    -------
    omega2 : ndarray, shape (k,)
        rad^2/s^2, ascending.
    X : ndarray, shape (N, k)
        The modes (zero at ``fixed``), unit modal mass, orthogonal in mass to
        the free rigid-body motions.
    Y : ndarray, shape (N, k)
        The same modes minus their rigid-body part: zero at ``fixed`` and at
        the pivots.
    """
    N = K.shape[0]
    fixed = np.asarray(sorted(set(int(i) for i in fixed)), int)
    free = np.setdiff1d(np.arange(N), fixed)
    R = rigid_body_modes(nodes, nodes[0])
    if len(fixed):
        null = sla.null_space(R[fixed], rcond=1e-10)
        R = R @ null
    if R.shape[1] == 0:
        omega2, V = lowest_modes(name, submatrix(K, free, free), submatrix(M, free, free),
                                 count=count, max_omega2=max_omega2, solver=solver, what=what)
        X = np.zeros((N, V.shape[1]))
        X[free] = V
        return omega2, X, X.copy()
    r = R.shape[1]
    if pivots is None:
        _, _, perm = sla.qr(R[free].T, pivoting=True, mode="economic")
        pivots = free[perm[:r]]
    pivots = np.asarray(pivots, int)
    if len(pivots) != r or abs(np.linalg.det(R[pivots])) < 1e-12:
        raise ModelError(f"member {name!r}: the pivot degrees of freedom do not determine the "
                         f"{r} rigid-body motion(s) the supports leave free")
    R = R @ np.linalg.inv(R[pivots])
    Kd_R = K @ R
    k_scale = max(float(np.max(np.abs(_diag(K)))), 1e-300)
    leak = float(np.max(np.abs(Kd_R))) / (k_scale * float(np.max(np.abs(R))))
    if leak > 1e-6:
        raise ModelError(f"member {name!r}: the stiffness matrix does not leave rigid-body "
                         f"motion free of strain (|K R| / |K| = {leak:.2g}): the degrees of "
                         f"freedom must be ux, uy, uz, rx, ry, rz of each node in body axes, "
                         f"at the node positions given")
    inner = np.setdiff1d(free, pivots)
    MR = np.asarray(M @ R)
    C = R.T @ MR
    C = 0.5 * (C + C.T)
    c_eig = np.linalg.eigvalsh(C)
    if c_eig[0] <= 1e-12 * max(c_eig[-1], 0.0):
        raise ModelError(f"member {name!r}: a rigid-body motion left free by the supports "
                         f"carries no mass (the inertia of the free member is singular; "
                         f"give rotary or polar inertia, or node masses)")
    B = MR[inner]
    omega2, Yi = lowest_modes(name, submatrix(K, inner, inner), submatrix(M, inner, inner),
                              count=count, max_omega2=max_omega2, low_rank=(B, C),
                              solver=solver, what=what)
    Y = np.zeros((N, Yi.shape[1]))
    Y[inner] = Yi
    a = -np.linalg.solve(C, B.T @ Yi)
    return omega2, Y + R @ a, Y


def _diag(A):
    return A.diagonal() if sp.issparse(A) else np.diag(np.asarray(A))
