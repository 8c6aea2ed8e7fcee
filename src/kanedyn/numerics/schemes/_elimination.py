"""Kane's elimination of the dependent speeds with a fixed partition."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ._base import AccelerationSystem, Scheme, kkt_solve

__all__ = ["Elimination"]


@dataclass(frozen=True)
class Elimination(Scheme):
    """Dependent speeds eliminated numerically with the model's partition.

    Kane's method as kanedyn evaluates it: the unreduced rows of the
    dependent speeds are folded into the independent ones,
    :math:`\\tilde M = M_i + A_r^T M_d` (:math:`A_r = -B_d^{-1}B_i`), and the
    acceleration constraints complete the square system.  Models whose
    formulation found no partition valid everywhere solve the index-1
    system instead.  Drift is projected away by solving the constraints for
    the dependent coordinates and speeds.
    """

    name: ClassVar[str] = "elimination"
    project: ClassVar[bool] = True
    c_backend: ClassVar[bool] = True

    def accelerations(self, model, t, y, terms):
        _, mass, force, vel_B, acc_K, acc_f = terms
        if model.multiplier_form and model.n_u_dep:
            return kkt_solve(mass, force, acc_K, -acc_f)
        M, f = model._assemble(mass, force, vel_B, acc_K, acc_f)
        if M.shape == (1, 1) and M[0, 0] != 0.0:
            # one speed: LAPACK's LU of a 1 x 1 system divides, to the same bits;
            # np.linalg.solve's checks and dispatch were half of a pendulum's rhs
            # (10 of 21 us); a zero pivot is left to it to raise LinAlgError
            return f / M[0, 0]
        return np.linalg.solve(M, f)

    def acceleration_system(self):
        return AccelerationSystem()
