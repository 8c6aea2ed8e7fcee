"""Penalty formulations: penalty, augmented Lagrangian, and its index-3 form."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from ..._errors import ModelError
from ._base import AccelerationSystem, Scheme, al_solve, penalty_weight, stabilization

__all__ = ["Penalty", "AugmentedLagrangian", "AugmentedLagrangianIndex3"]


@dataclass(frozen=True)
class Penalty(Scheme):
    r"""Penalty formulation: the constraint forces are a stiff spring–damper.

    .. math::

        (M + \alpha K^TK)\dot u = f - \alpha K^T(f_a + 2\xi\omega c + \omega^2P^+h)

    Attributes
    ----------
    factor : float
        :math:`\alpha` relative to the scales of :math:`M` and :math:`K^TK`
        (dimensionless).  Larger: smaller constraint error, stiffer system.
    xi, omega : float
        Damping ratio and natural frequency (1/s) of the constraint error.
    """

    name: ClassVar[str] = "penalty"
    factor: float = 1e7
    xi: float = 1.0
    omega: float = 10.0

    def _system(self, model, t, y, mass, K, acc_f):
        """Penalty :math:`\\alpha`, :math:`M + \\alpha K^TK` and :math:`f_a + s`."""
        system = self.acceleration_system()
        s = stabilization(model, t, y, system.velocity_gain, system.position_gain)
        alpha = penalty_weight(mass, K, self.factor)
        return alpha, mass + alpha * K.T @ K, acc_f + s

    def constrained(self, model, t, y, mass, force, K, acc_f):
        alpha, A, target = self._system(model, t, y, mass, K, acc_f)
        return np.linalg.solve(A, force - alpha * K.T @ target)

    def acceleration_system(self):
        return AccelerationSystem(velocity_gain=2.0 * self.xi * self.omega,
                                  position_gain=self.omega ** 2, penalty_factor=self.factor)


@dataclass(frozen=True)
class AugmentedLagrangian(Penalty):
    r"""Augmented Lagrangian: the penalty system with iterated multipliers.

    .. math::

        (M + \alpha K^TK)\dot u_{k+1} = f + K^T\lambda_k - \alpha K^T(f_a + s),
        \qquad \lambda_{k+1} = \lambda_k - \alpha(K\dot u_{k+1} + f_a + s),

    from :math:`\lambda_0 = 0` until the corrections reach round-off (see
    :func:`~kanedyn.numerics.schemes.al_solve`), so a moderate :math:`\alpha`
    suffices.

    Attributes
    ----------
    factor, xi, omega : float
        As for :class:`Penalty` (default factor 1e4).
    max_iterations : int
        Corrections at most per evaluation.
    """

    name: ClassVar[str] = "augmented-lagrangian"
    factor: float = 1e4
    max_iterations: int = 50

    def constrained(self, model, t, y, mass, force, K, acc_f):
        alpha, _, target = self._system(model, t, y, mass, K, acc_f)
        return al_solve(mass, force, K, -target, alpha, max_iterations=self.max_iterations)

    def acceleration_system(self):
        """The converged iteration: the constraints hold (:math:`1/\\alpha = 0`)."""
        return replace(Penalty.acceleration_system(self), penalty_factor=None)


@dataclass(frozen=True)
class AugmentedLagrangianIndex3(Scheme):
    r"""Index-3 augmented Lagrangian with mass-orthogonal projections (Bayo & Ledesma 1996).

    A scheme with its own integrator (:mod:`kanedyn.simulation._index3`):
    :func:`kanedyn.simulate` hands the run to it.  The configuration
    constraints are enforced at every step of the trapezoidal rule by a
    penalty and iterated multipliers, solved by Newton's method; velocities
    and accelerations are then projected onto their constraints in the mass
    metric, regularized by the penalty.  No solve divides by the smallest
    singular value of the constraint Jacobian, so the scheme passes singular
    configurations, and it stays on the branch the motion follows (the
    positions come from the constraints at the next step); redundant
    constraints are allowed.  This is how the reference solutions of the
    IFToMM benchmark problems were computed.

    It needs speeds equal to the coordinate rates and holonomic constraints
    only.  The step is fixed, so ``rtol`` and ``atol`` of
    :func:`kanedyn.simulate` do not apply: the error is second order in
    ``step`` (measured in ``docs/constraints.md``).  Used through
    :meth:`kanedyn.NumericModel.rhs` (e.g. for linearization) it gives the
    augmented-Lagrangian accelerations of :func:`~kanedyn.numerics.schemes.al_solve`,
    without stabilization: at a consistent state, those of the other schemes
    to round-off (``al_solve`` iterates by corrections, so the penalty's
    condition number does not reach them).

    Attributes
    ----------
    step : float
        Time step, s (the largest step not above it that divides the
        interval is used).
    factor : float
        Penalty: :math:`\tfrac{h^2}{4}\alpha\,\|\Phi_q^T\Phi_q\|` is
        ``factor`` times :math:`\|M\|` (largest diagonal entries).
    tol : float
        Newton tolerance on the constraint residual, relative to
        ``1 + max|q|``; the position correction must be below ``100 tol``
        (relative) as well.
    max_iterations : int
        Newton iterations per step before the run stops with a failure.
    projection_iterations : int
        Augmented-Lagrangian corrections at most of each velocity and
        acceleration projection, and of the right-hand side (each stops
        earlier, when its corrections reach round-off).
    """

    name: ClassVar[str] = "augmented-lagrangian-index3"
    project: ClassVar[bool] = True
    integrator: ClassVar[str] = "index-3 trapezoidal"
    c_terms: ClassVar[bool] = True
    step: float = 1e-3
    factor: float = 1e6
    tol: float = 1e-10
    max_iterations: int = 50
    projection_iterations: int = 30

    def __post_init__(self):
        for key in ("step", "factor", "tol"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value > 0):
                raise ModelError(f"{type(self).__name__}: {key} must be positive, "
                                 f"got {value!r}")
        for key in ("max_iterations", "projection_iterations"):
            if int(getattr(self, key)) < 1:
                raise ModelError(f"{type(self).__name__}: {key} must be at least 1")

    def weight(self, mass, C):
        r"""Penalty weight :math:`w` of a projection onto the rows of ``C``."""
        return penalty_weight(mass, C, self.factor)

    def position_penalty(self, mass, J, h):
        r"""Penalty :math:`\alpha` of the configuration constraints for a step ``h``."""
        return 4.0 / (h * h) * penalty_weight(mass, J, self.factor)

    def constrained(self, model, t, y, mass, force, K, acc_f):
        return al_solve(mass, force, K, -acc_f, self.weight(mass, K),
                        max_iterations=self.projection_iterations)

    def acceleration_system(self):
        """The converged iteration, without stabilization: the index-1 system."""
        return AccelerationSystem()

    def project_velocities(self, model, t, y):
        """Speeds projected onto the velocity constraints in the mass metric."""
        y = np.array(y, dtype=float)
        n = model.n_q
        _, _, B, c = model._constraint_terms(t, y)
        mass = model._dynamics(t, y)[1]
        # as a correction: round-off then scales with it, not with the speeds (the
        # penalized system has a condition number of about `factor`)
        y[n:] += al_solve(mass, np.zeros(model.n_u), B, -c, self.weight(mass, B),
                          max_iterations=self.projection_iterations,
                          scale=np.max(np.abs(y[n:])))
        return y

    def project_state(self, model, t, y, max_iterations=50):
        """Coordinates by penalty-regularized Newton steps, then speeds (mass metric)."""
        y = np.array(y, dtype=float)
        n = model.n_q
        for _ in range(max_iterations if model.n_q_dep else 0):
            h, J, _, _ = model._constraint_terms(t, y)
            if np.max(np.abs(h)) <= self.tol * (1.0 + np.max(np.abs(y[:n]))):
                break
            mass = model._dynamics(t, y)[1]
            w = penalty_weight(mass, J, self.factor)
            y[:n] -= np.linalg.solve(mass + w * J.T @ J, w * J.T @ h)
        return self.project_velocities(model, t, y) if model.n_u_dep else y
