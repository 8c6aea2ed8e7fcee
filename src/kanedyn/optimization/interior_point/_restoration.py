r"""The feasibility restoration phase (Waechter & Biegler 2006, section 3.3).

When the filter line search finds no acceptable step at :math:`\bar w =
(\bar x, \bar s)`, the iterations turn to the restoration problem

.. math::

    \min_{w, p, n}\ \rho \sum_j (p_j + n_j)
        + \frac{\zeta}{2} \|D_R (x - \bar x)\|_2^2
    \quad\text{s.t.}\quad c(w) - p + n = 0,\ w_L \le w \le w_U,\ p, n \ge 0

(:math:`c` the scaled rows' residuals of :mod:`._solver`, :math:`\rho =
1000`, :math:`\zeta = \sqrt{\mu}` at the restoration's barrier parameter
:math:`\mu`, :math:`D_R = \operatorname{diag}(\min(1, 1/|\bar x_i|))`),
solved by the same primal-dual iterations: barrier parameter from
:math:`\max(\mu, \|c(\bar w)\|_\infty)`, falling by the monotone rule;
:math:`p, n` started at the barrier problem's minimizers for fixed
:math:`x` (the paper's (33)), their bound multipliers :math:`\mu/p,
\mu/n`, those of :math:`w` the NLP's capped at :math:`\rho`, :math:`y =
0`; a filter line search of its own (:math:`\theta_{\max}` factor
:math:`10^8`).  Its Newton system has the NLP's structure: :math:`p` and
:math:`n` are eliminated like the inequality rows' slacks, each adding
:math:`(\Sigma_p + \delta_w)^{-1} + (\Sigma_n + \delta_w)^{-1}` to its
row's diagonal, the proximity term :math:`\zeta D_R^2` adds to
:math:`\Sigma_x`, and the Hessian is the rows' part of the Lagrangian's, so
the NLP's KKT object factors it (:class:`._step.StepSolver` with the
eliminated variables' rows and signs).

After each accepted step, the point :math:`w` returns to the NLP when its
violation :math:`\theta = \|c(w)\|_1` fell below :math:`\kappa_{resto}
\bar\theta` (:math:`\kappa_{resto} = 0.9`, IPOPT's
``required_infeasibility_reduction``) and the NLP's filter (which took
:math:`(\bar\theta, \bar\varphi)` on entering) accepts :math:`(\theta,
\varphi_\mu(w))`; the bound multipliers of :math:`w` then take a
primal-dual step from their values on entering (all reset to 1 when one
exceeds 1000, IPOPT's ``bound_mult_reset_threshold``) and :math:`y` is
zero (IPOPT's default ``constr_mult_reset_threshold = 0``).  When the
restoration problem converges (its optimality error below ``tol``, or
``acceptable_iter`` iterates within ``acceptable_tol``) at a point
violating the rows beyond ``constr_viol_tol`` (unscaled), the NLP is
locally infeasible: status 2.

Simplified against IPOPT: no second-order corrections in the restoration's
line search; when that line search fails, status -2 (IPOPT would first try
to reset :math:`p, n` for the current :math:`x`); no ``expect_infeasible_problem``.
"""

from __future__ import annotations

import time

import numpy as np

from ._bounds import PrimalBounds, fraction_to_boundary
from ._filter import Filter
from ._optimality import next_barrier, optimality_errors, safeguard_multipliers
from ._quasi_newton import LimitedMemoryBFGS
from ._step import StepSolver

__all__ = ["Restoration", "Restored", "PENALTY", "REQUIRED_REDUCTION",
           "BOUND_MULTIPLIER_RESET"]

#: rho, IPOPT's resto_penalty_parameter
PENALTY = 1000.0
#: kappa_resto, IPOPT's required_infeasibility_reduction
REQUIRED_REDUCTION = 0.9
#: a bound multiplier above this after the restoration resets them all to 1
BOUND_MULTIPLIER_RESET = 1000.0
#: the restoration filter's theta_max factor (IPOPT's resto.theta_max_fact)
THETA_MAX_FACTOR = 1e8


class Restored:
    """The restoration's outcome.

    Attributes
    ----------
    status : int or None
        ``None``: back to the NLP at ``point``; else the solve's status
        (2 locally infeasible, -2 the restoration's line search failed, -3,
        -13, -1, -4, 5 as in :mod:`._status`).
    point : tuple
        ``(w, y, z_lower, z_upper, evaluation)`` of the NLP.
    """

    def __init__(self, status, point):
        self.status, self.point = status, point


def starting_pairs(c, mu, rho=PENALTY):
    r"""``(p, n)`` minimizing :math:`\rho(p + n) - \mu(\ln p + \ln n)`
    subject to :math:`c - p + n = 0`, row by row (the paper's (33))."""
    a = (mu - rho * c) / (2 * rho)
    n = a + np.sqrt(a * a + mu * c / (2 * rho))
    return c + n, n


def multiplier_step(z, gap_before, gap_after, mu, tau):
    """Bound multipliers after a primal move from ``gap_before`` to
    ``gap_after``: a primal-dual step of :math:`z\\,\\text{gap} = \\mu`,
    cut by the fraction to the boundary ``tau``."""
    dz = (mu - z * gap_after) / gap_before
    return z + fraction_to_boundary(z, dz, tau) * dz


class Restoration:
    """The restoration phase of one solve (``run``: the solver's ``_Run``,
    whose problem, bounds, KKT object, callbacks and counters it uses)."""

    def __init__(self, run):
        self.run = run
        n, m, size = run.n, run.m, run.bounds.size
        self.size = size
        rows = np.arange(m)
        self.stepper = StepSolver(
            run.kkt, n, m, np.concatenate([run.inequality, rows, rows]), run.s,
            signs=np.concatenate([np.full(size - n + m, -1.0), np.ones(m)]))
        B = run.bounds
        lower, upper = np.full(size + 2 * m, -np.inf), np.full(size + 2 * m, np.inf)
        lower[B.lower_index], upper[B.upper_index] = B.lower, B.upper
        lower[size:] = 0.0
        self.bounds = PrimalBounds(lower, upper, 0.0, run.s.kappa_d)

    # ------------------------------------------------------------ the problem
    def _split(self, w):
        """``(w of the NLP, p, n)``."""
        size, m = self.size, self.run.m
        return w[:size], w[size:size + m], w[size + m:]

    def _objective(self, w, zeta):
        x = w[:self.run.n]
        _, p, n = self._split(w)
        return PENALTY * (p.sum() + n.sum()) + 0.5 * zeta * (
            self.scale2 * (x - self.reference) ** 2).sum()

    def _gradient(self, w, zeta):
        g = np.full(w.size, PENALTY)
        g[:self.size] = 0.0
        g[:self.run.n] = zeta * self.scale2 * (w[:self.run.n] - self.reference)
        return g

    def _residuals(self, e, w):
        """The restoration rows :math:`c(w) - p + n` and the NLP's :math:`c(w)`."""
        w_nlp, p, n = self._split(w)
        c = self.run._row_residuals(e.rows, w_nlp)
        return c - p + n, c

    def _trial(self, w, mu, zeta):
        """``(evaluation, w, theta, phi, gaps, residuals)`` at a trial point
        (``gaps`` of the bounds, ``residuals`` :meth:`_residuals`'), or ``None``."""
        e = self.run._evaluate(w[:self.run.n])
        if not e.finite():
            return None
        gaps = self.bounds.gaps(w)
        residuals = self._residuals(e, w)
        theta = float(np.abs(residuals[0]).sum())
        phi = self.bounds.barrier(self._objective(w, zeta), *gaps, mu)
        return e, w, theta, phi, gaps, residuals

    # -------------------------------------------------------------- the phase
    def solve(self, w, z_lower, z_upper, e, mu, line_filter, print_row):
        """Restore from the NLP's iterate ``(w, z_lower, z_upper, e)`` at
        barrier parameter ``mu``, the NLP's filter ``line_filter`` already
        holding this point: a :class:`Restored`."""
        run, s, B, BR = self.run, self.run.s, self.run.bounds, self.bounds
        n, m, size = run.n, run.m, self.size
        run.jacobian_at(e)  # (let go by the NLP's line search)
        c_start = run._row_residuals(e.rows, w)
        theta_start = float(np.abs(c_start).sum())
        entry = (z_lower, z_upper, B.gaps(w))
        self.reference = w[:n].copy()
        self.scale2 = np.minimum(1.0, 1.0 / np.maximum(np.abs(self.reference), 1e-300)) ** 2
        mu_r = max(mu, float(np.abs(c_start).max(initial=0.0)))
        p, nn = starting_pairs(c_start, mu_r)
        wr = np.concatenate([w, p, nn])
        zl = np.concatenate([np.minimum(PENALTY, z_lower), mu_r / p, mu_r / nn])
        zu = np.minimum(PENALTY, z_upper)
        y = np.zeros(m)
        resto_filter = Filter(theta_start, THETA_MAX_FACTOR)
        tau = max(s.tau_min, 1.0 - mu_r)
        acceptable_count = 0
        largest_start = float(np.abs(c_start).max(initial=0.0))
        first, reprint = True, False
        row = dict(alpha_dual=0.0, alpha_primal=0.0, step=0.0, delta_w=0.0, trials=0, kind=" ")
        (gap_lower, gap_upper), (c_r, c) = BR.gaps(wr), self._residuals(e, wr)
        last = None  # (mu, theta, phi) of the last accepted trial point
        # the limited-memory approximation of the rows' part, its own pairs
        quasi_newton = None if run.quasi_newton is None else LimitedMemoryBFGS(s)
        while True:
            zeta = np.sqrt(mu_r)
            gradient = self._gradient(wr, zeta)
            lagrangian = gradient.copy()
            lagrangian[:n] += run.reduced.transpose_times(e.jacobian, y)
            if size > n:
                lagrangian[n:size] -= y[run.inequality]
            lagrangian[size:size + m] -= y
            lagrangian[size + m:] += y
            dual = lagrangian.copy()
            dual[BR.lower_index] -= zl
            dual[BR.upper_index] += zu
            errors = optimality_errors(dual, c_r, y, zl, zu, gap_lower, gap_upper, mu_r,
                                       run.error_reductions)
            violation = run.unscaled_violation(e.rows, c)
            if print_row is not None and not reprint:
                print_row(f"{run.iteration}r", e.objective / run.reduced.objective_scale,
                          violation, errors.dual_inf, mu_r, row)
            if not first and not reprint:
                # back to the NLP: the rows' largest residual cut by kappa_resto
                # and the point acceptable to the NLP's filter
                if (float(np.abs(c).max(initial=0.0)) <= REQUIRED_REDUCTION * largest_start
                        and self._acceptable(line_filter, e, wr, c, mu)):
                    return Restored(None, self._back(entry, wr[:size], e, mu))
            first = reprint = False
            acceptable_count = acceptable_count + 1 if errors.error <= s.acceptable_tol else 0
            if errors.error <= s.tol or (s.acceptable_iter
                                         and acceptable_count >= s.acceptable_iter):
                # the restoration problem converged: feasible (then back to
                # the NLP, if its filter accepts the point) or locally infeasible
                if violation > s.constr_viol_tol:
                    return self._failed(2, wr, y, zl, zu, e)
                if self._acceptable(line_filter, e, wr, c, mu):
                    return Restored(None, self._back(entry, wr[:size], e, mu))
                return self._failed(-2, wr, y, zl, zu, e)
            status = run.stopping_status()
            if status is not None:
                return self._failed(status, wr, y, zl, zu, e)
            # the barrier parameter (monotone)
            if errors.error_mu <= s.barrier_tol_factor * mu_r:
                new_mu = next_barrier(mu_r, s)
                if new_mu < mu_r:
                    mu_r = new_mu
                    tau = max(s.tau_min, 1.0 - mu_r)
                    resto_filter.reset()
                    reprint = True
                    continue
            # the Newton step
            hessian = run.hessian_values(e, y, 0.0, quasi_newton)  # the rows' part only
            if hessian is None:
                return self._failed(-13, wr, y, zl, zu, e)
            sigma = BR.sigma(zl, zu, gap_lower, gap_upper).dense()
            sigma[:n] += zeta * self.scale2
            barrier_gradient = BR.barrier_gradient(gradient, gap_lower, gap_upper, mu_r)
            residual_w = barrier_gradient + (lagrangian - gradient)
            direction = run.direction(self.stepper, BR, hessian, e.jacobian, sigma, residual_w,
                                      c_r, zl, zu, lambda: (gap_lower, gap_upper), mu_r, tau)
            del hessian, sigma  # (the factors let go by direction) not held further
            if direction is None:
                return self._failed(-3, wr, y, zl, zu, e)
            step, dz_lower, dz_upper, alpha_max, alpha_z = direction
            dw, dy = step.primal, step.rows
            # the line search (backtracking, no second-order correction)
            t = time.perf_counter()
            if last is not None and last[0] == mu_r:  # as the line search found them
                theta, phi = last[1:]
            else:
                theta = float(np.abs(c_r).sum())
                phi = BR.barrier(self._objective(wr, zeta), gap_lower, gap_upper, mu_r)
            slope = float(barrier_gradient @ dw)
            alpha_min = resto_filter.smallest_step(theta, slope, s.alpha_min_frac)
            alpha, found, trials = alpha_max, None, 0
            while alpha >= alpha_min and found is None:
                trials += 1
                trial = self._trial(wr + alpha * dw, mu_r, zeta)
                if trial is not None:
                    accepted, f_type = resto_filter.accepts(theta, phi, slope, alpha,
                                                            trial[2], trial[3])
                    if accepted:
                        found = trial
                        break
                alpha /= 2
            run.timings["line_search"] += time.perf_counter() - t
            if found is None:
                return self._failed(-2, wr, y, zl, zu, e)
            if not f_type:
                resto_filter.add(theta, phi)
            e, wr, theta, phi, (gap_lower, gap_upper), (c_r, c) = found
            last = (mu_r, theta, phi)
            y = y + alpha * dy
            zl = zl + alpha_z * dz_lower
            zu = zu + alpha_z * dz_upper
            run.iteration += 1
            if not run._derivatives(e):
                return self._failed(-13, wr, y, zl, zu, e)
            zl, zu = safeguard_multipliers(zl, zu, gap_lower, gap_upper, mu_r)
            if print_row is not None:  # the printed row's columns
                row = dict(alpha_dual=alpha_z, alpha_primal=alpha,
                           step=float(np.abs(dw).max(initial=0.0)), delta_w=step.delta_w,
                           trials=trials, kind="f" if f_type else "h")

    def _acceptable(self, line_filter, e, w, c, mu):
        """The NLP's filter accepts the NLP's part of ``w`` (rows' residuals ``c``)."""
        B, size = self.run.bounds, self.size
        return line_filter.acceptable(float(np.abs(c).sum()),
                                      B.barrier(e.objective, *B.gaps(w[:size]), mu))

    def _back(self, entry, w, e, mu):
        """The NLP's ``(w, y, z_lower, z_upper, e)`` at the restored ``w``."""
        run = self.run
        z_lower, z_upper, (gap_lower, gap_upper) = entry
        new_lower, new_upper = run.bounds.gaps(w)
        tau = max(run.s.tau_min, 1.0 - mu)
        z_lower = multiplier_step(z_lower, gap_lower, new_lower, mu, tau)
        z_upper = multiplier_step(z_upper, gap_upper, new_upper, mu, tau)
        if max(z_lower.max(initial=0.0), z_upper.max(initial=0.0)) \
                > BOUND_MULTIPLIER_RESET:
            z_lower, z_upper = np.ones_like(z_lower), np.ones_like(z_upper)
        return w.copy(), np.zeros(run.m), z_lower, z_upper, e

    def _failed(self, status, w, y, z_lower, z_upper, e):
        """A status with the NLP's part of the restoration's iterate and
        multipliers (those of the rows, of the bounds of ``w``)."""
        size, n_lower = self.size, self.run.bounds.lower_index.size
        return Restored(status, (w[:size].copy(), y.copy(), z_lower[:n_lower].copy(),
                                 z_upper.copy(), e))
