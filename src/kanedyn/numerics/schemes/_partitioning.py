"""Generalized coordinate partitioning (Wehage & Haug) and Maggi's null-space equations."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ._base import AccelerationSystem, Scheme, complement_solve

__all__ = ["Partitioning", "NullSpace"]


def _pivoted_partition(A, m):
    """Column indices (dependent, independent) by QR with column pivoting."""
    import scipy.linalg as sla  # imported when first needed
    piv = sla.qr(A, mode="r", pivoting=True)[1]
    return np.sort(piv[:m]), np.sort(piv[m:])


@dataclass(frozen=True)
class Partitioning(Scheme):
    """Generalized coordinate partitioning (Wehage & Haug 1982).

    At every evaluation the dependent speeds are the columns of the
    acceleration-constraint matrix chosen by QR with column pivoting (the
    best-conditioned block), eliminated as in :class:`Elimination`; after
    drift the dependent coordinates (pivoted columns of the configuration
    Jacobian) and speeds are solved from the independent ones by Newton's
    method.
    """

    name: ClassVar[str] = "partitioning"
    project: ClassVar[bool] = True

    def constrained(self, model, t, y, mass, force, K, acc_f):
        return complement_solve(mass, force, K, acc_f, _pivoted_partition(K, K.shape[0])[0])

    def acceleration_system(self):
        return AccelerationSystem()

    def project_state(self, model, t, y, tol=1e-12, max_iterations=50):
        y = np.array(y, dtype=float)
        n = model.n_q
        if model.n_q_dep:
            dep = _pivoted_partition(model._constraint_terms(t, y)[1], model.n_q_dep)[0]
            for _ in range(max_iterations):
                h, J, _, _ = model._constraint_terms(t, y)
                if np.max(np.abs(h)) <= tol:
                    break
                y[dep] -= np.linalg.solve(J[:, dep], h)
        if model.n_u_dep:
            _, _, B, c = model._constraint_terms(t, y)
            dep = _pivoted_partition(B, model.n_u_dep)[0]
            for _ in range(max_iterations):
                _, _, B, c = model._constraint_terms(t, y)
                if np.max(np.abs(c)) <= tol * (1.0 + np.max(np.abs(y[n:]))):
                    break
                y[n + dep] -= np.linalg.solve(B[:, dep], c)
        return y


@dataclass(frozen=True)
class NullSpace(Scheme):
    r"""Maggi's equations: projection onto the null space of the constraints.

    With an orthonormal basis :math:`N` of :math:`\ker K` (from the SVD) and
    the least-norm particular solution :math:`\dot u_p = -K^+f_a`,

    .. math::

        \dot u = \dot u_p + N z,\qquad N^TMN\,z = N^T(f - M\dot u_p),

    solved by Cholesky's factorization; no stabilization.
    """

    name: ClassVar[str] = "null-space"

    def constrained(self, model, t, y, mass, force, K, acc_f):
        import scipy.linalg as sla  # imported when first needed
        N = sla.null_space(K)
        particular = -np.linalg.lstsq(K, acc_f, rcond=None)[0]
        z = sla.cho_solve(sla.cho_factor(N.T @ mass @ N), N.T @ (force - mass @ particular))
        return particular + N @ z

    def acceleration_system(self):
        return AccelerationSystem()
