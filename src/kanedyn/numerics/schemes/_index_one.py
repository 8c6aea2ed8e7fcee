"""Lagrange's equations with multipliers as an index-1 DAE: plain, Baumgarte, projection."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ._base import AccelerationSystem, Scheme, kkt_solve, stabilization

__all__ = ["IndexOne", "Baumgarte", "Projection"]


@dataclass(frozen=True)
class IndexOne(Scheme):
    """Lagrange's equations with multipliers as an index-1 DAE, no stabilization."""

    name: ClassVar[str] = "index-1"

    def constrained(self, model, t, y, mass, force, K, acc_f):
        return kkt_solve(mass, force, K, -acc_f)

    def acceleration_system(self):
        return AccelerationSystem()


@dataclass(frozen=True)
class Baumgarte(IndexOne):
    r"""Index 1 with Baumgarte stabilization :math:`\ddot h + 2\alpha\dot h + \beta^2h = 0`.

    Attributes
    ----------
    alpha, beta : float
        Damping rate and natural frequency of the constraint error, 1/s.
    """

    name: ClassVar[str] = "baumgarte"
    alpha: float = 10.0
    beta: float = 10.0

    def constrained(self, model, t, y, mass, force, K, acc_f):
        system = self.acceleration_system()
        s = stabilization(model, t, y, system.velocity_gain, system.position_gain)
        return kkt_solve(mass, force, K, -acc_f - s)

    def acceleration_system(self):
        return AccelerationSystem(velocity_gain=2.0 * self.alpha, position_gain=self.beta ** 2)


@dataclass(frozen=True)
class Projection(IndexOne):
    """Index 1; after drift the state is projected onto the constraints.

    Coordinates: the least (Euclidean) change of all coordinates that
    satisfies the configuration constraints (Gauss–Newton, minimum norm);
    speeds: the least change in the kinetic-energy metric,
    :math:`\\Delta u = -M^{-1}B^T(BM^{-1}B^T)^{-1}c`.
    """

    name: ClassVar[str] = "projection"
    project: ClassVar[bool] = True

    def project_state(self, model, t, y, tol=1e-12, max_iterations=50):
        y = np.array(y, dtype=float)
        n = model.n_q
        for _ in range(max_iterations if model.n_q_dep else 0):
            h, J, _, _ = model._constraint_terms(t, y)
            if np.max(np.abs(h)) <= tol:
                break
            y[:n] -= np.linalg.lstsq(J, h, rcond=None)[0]
        for _ in range(max_iterations if model.n_u_dep else 0):
            _, _, B, c = model._constraint_terms(t, y)
            if np.max(np.abs(c)) <= tol * (1.0 + np.max(np.abs(y[n:]))):
                break
            mass = model._dynamics(t, y)[1]
            MiBt = np.linalg.solve(mass, B.T)
            y[n:] -= MiBt @ np.linalg.solve(B @ MiBt, c)
        return y
