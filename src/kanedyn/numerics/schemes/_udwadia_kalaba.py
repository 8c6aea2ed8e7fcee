"""Udwadia–Kalaba's explicit equations."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ._base import AccelerationSystem, Scheme, stabilization

__all__ = ["UdwadiaKalaba"]


@dataclass(frozen=True)
class UdwadiaKalaba(Scheme):
    r"""Udwadia–Kalaba's explicit equations.

    .. math::

        \dot u = a + M^{-1/2}\,(K M^{-1/2})^+\,(b - K a),\qquad a = M^{-1}f,
        \quad b = -f_a - s,

    with the Moore–Penrose inverse (redundant constraints allowed) and an
    optional Baumgarte correction :math:`s` (gains ``alpha``, ``beta`` as
    for :class:`Baumgarte`; default none).
    """

    name: ClassVar[str] = "udwadia-kalaba"
    alpha: float = 0.0
    beta: float = 0.0

    def constrained(self, model, t, y, mass, force, K, acc_f):
        a = np.linalg.solve(mass, force)
        b = -acc_f
        system = self.acceleration_system()
        if system.stabilized:
            b = b - stabilization(model, t, y, system.velocity_gain, system.position_gain)
        w, V = np.linalg.eigh(mass)
        M_inv_half = (V / np.sqrt(w)) @ V.T
        return a + M_inv_half @ np.linalg.pinv(K @ M_inv_half) @ (b - K @ a)

    def acceleration_system(self):
        """That of :class:`Baumgarte` with the same gains: with constraints of full
        rank the accelerations are those of the index-1 system (to round-off)."""
        return AccelerationSystem(velocity_gain=2.0 * self.alpha, position_gain=self.beta ** 2)
