r"""``InteriorPoint``: kanedyn's primal-dual interior-point NLP solver.

The method of IPOPT (Waechter & Biegler, "On the implementation of an
interior-point filter line-search algorithm for large-scale nonlinear
programming", Math. Program. 106(1), 2006) on the scaled, reduced problem
of :mod:`._reduced` (equality rows :math:`c_E(x) = 0`, inequality rows
:math:`g_I(x) - s = 0` with bounded slacks :math:`s`):

1. the barrier problem :math:`\min \varphi_\mu(x, s)` (:mod:`._bounds`) for a
   falling :math:`\mu` (monotone, Fiacco-McCormick: :math:`\mu \leftarrow
   \max(\epsilon/(\kappa_\epsilon + 1), \min(\kappa_\mu\mu, \mu^{\theta_\mu}))`
   once the barrier problem's optimality error is below
   :math:`\kappa_\epsilon\mu`);
2. per iteration one Newton step of the primal-dual equations with the
   exact Hessian of the Lagrangian or its limited-memory BFGS approximation
   (``hessian_approximation="limited-memory"``, :mod:`._quasi_newton`,
   factored through :mod:`.kkt._low_rank`), its linear system regularized
   to the right inertia (:mod:`._step`);
3. fraction to the boundary (:math:`\tau = \max(\tau_{\min}, 1 - \mu)`) for
   the primal variables and, separately, the bound multipliers;
4. the filter line search with the switching and Armijo conditions and up
   to ``max_soc`` second-order corrections (:mod:`._filter`); the bound
   multipliers are then kept within :math:`[\mu/(\kappa_\Sigma\,
   \text{gap}), \kappa_\Sigma\mu/\text{gap}]`, :math:`\kappa_\Sigma = 10^{10}`;
5. when the line search finds no step, IPOPT's soft restoration phase:
   primal and dual variables along the step by one step length
   :math:`\min(\alpha^{\max}, \alpha_z^{\max})` (IPOPT, after a step the
   filter accepts, moves the bound multipliers by their own fraction to the
   boundary and :math:`y` by the line search's last step), taken while the filter
   accepts the point or the primal-dual system error
   (:math:`\|\nabla L - z_L + z_U\|_1 + \|c\|_1 + \|Z\,\text{gap} -
   \mu\|_1`) falls by the factor :data:`SOFT_REDUCTION`, for at most
   :data:`SOFT_ITERATIONS` iterations after the first; else (the point not acceptable,
   status 1, nor almost feasible, :data:`ALMOST_FEASIBLE`) the feasibility
   restoration phase (:mod:`._restoration`): back with a less infeasible
   point the filter accepts, or status 2 (locally infeasible) or -2 (the
   restoration failed; status 1 at the last acceptable iterate, as IPOPT
   returns it, when there was one);
6. the scaled optimality error :math:`E_0` against ``tol`` (with IPOPT's
   unscaled checks ``dual_inf_tol``, ``constr_viol_tol``,
   ``compl_inf_tol``), and ``acceptable_iter`` consecutive iterates within
   the ``acceptable_`` tolerances.

What it lacks against IPOPT: the watchdog, the adaptive barrier
strategies, the SR1 update; the restoration phase's simplifications are
listed in :mod:`._restoration` (with the limited-memory Hessian it keeps a
memory of its own, of the rows' part, emptied on entering; the NLP's is
emptied as it begins).
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from ..._errors import OptionError
from ._bounds import PrimalBounds, fraction_to_boundary
from ._filter import Filter
from ._finite import all_finite
from ._mapped import mapped_large_arrays
from .kkt._low_rank import LowRankKKT
from .kkt._sparse import SparseKKT, pairable_entries
from ._optimality import next_barrier, optimality_errors, safeguard_multipliers
from ._options import settings as checked_settings
from ._quasi_newton import LimitedMemoryBFGS
from ._reduced import ReducedNLP
from ._restoration import Restoration
from ._start import least_squares_multipliers, primal_start, warm_multipliers
from ._status import ADVICE, STATUS
from ._step import StepSolver

__all__ = ["InteriorPoint", "kkt_class"]

#: a step below this relative to its variables is tiny (IPOPT's 10 eps)
_TINY_STEP = 10 * float(np.finfo(float).eps)
#: the soft restoration phase: a step is taken when it cuts the primal-dual
#: system error to this fraction (IPOPT's soft_resto_pderror_reduction_factor),
#: for at most this many iterations after its first (IPOPT's max_soft_resto_iters)
SOFT_REDUCTION = 0.9999
SOFT_ITERATIONS = 10
#: below this violation times ``tol`` the restoration phase is not entered
#: (IPOPT's almost feasible point)
ALMOST_FEASIBLE = 1e-2
#: with the exact Hessian, an objective's gradient of this many bytes or more
#: is not held through the Newton step (the solve's peak) but evaluated again
#: after it, the same numbers: one gradient evaluation an iteration (6-8 % of
#: an iteration at 100 and 10,000 swing-up nodes, so only for large problems)
#: for 8 bytes a variable at the peak
GRADIENT_AGAIN_BYTES = 1 << 22
#: with a primal vector of this many bytes or more, a second-order
#: correction's factors, made again for it, are let go once it is solved
#: (not held through its trial point's evaluation) and made again for a
#: further correction; below, one factorization serves them all
CORRECTION_AGAIN_BYTES = 1 << 22


def kkt_class(choice):
    """``(KKT class, note)`` for the option ``linear_solver``: ``"envelope"``
    (``EnvelopeKKT``), ``"sparse"`` (``SparseKKT``), ``"dense"``
    (``DenseKKT``), ``"auto"`` (envelope when the C kernel builds or is
    cached, else dense, the note saying why).  The envelope's L held 1.00 to
    1.30 times the sparse L's entries in the analyses of the solver's tests,
    at 8 bytes an entry against 12, and no copy of K
    (``docs/benchmarks.md``)."""
    from .kkt._dense import DenseKKT
    if choice == "dense":
        return DenseKKT, None
    from ...numerics import CompilerError
    try:
        from .kkt._kernel import kernel
        if choice == "sparse":
            from .kkt._sparse import SparseKKT as chosen
        else:
            from .kkt._envelope import EnvelopeKKT as chosen
        kernel()  # compiled (or taken from the cache) here: no compiler, neither class
    except (ImportError, CompilerError) as exc:
        if choice != "auto":
            raise type(exc)(f"interior-point option linear_solver={choice!r}: the compiled "
                            f"factorization is not available ({exc}); use "
                            "linear_solver='dense'") from exc
        return DenseKKT, f"EnvelopeKKT is not available ({exc}): DenseKKT used"
    return chosen, None


class _Evaluation:
    """The scaled NLP's values at one point: ``x`` its free variables (the
    caller's array, not a copy; the full vector is made again when a
    callback needs it: not held)."""

    __slots__ = ("x", "objective", "rows", "gradient", "jacobian", "fixed_jacobian")

    def __init__(self, x, objective, rows):
        self.x, self.objective, self.rows = x, objective, rows
        #: with the Jacobian: the NLP's entries in the fixed variables' columns
        #: (:attr:`._reduced.ReducedNLP.fixed_jacobian`), kept when it is let go
        self.gradient = self.jacobian = self.fixed_jacobian = None

    def finite(self):
        return math.isfinite(self.objective) and all_finite(self.rows)


class InteriorPoint:
    """kanedyn's interior-point NLP solver (``solve(solver="interior-point")``:
    with ``hessian="exact"`` the exact Hessian of the Lagrangian, else its
    limited-memory BFGS approximation).

    Options are IPOPT's names where IPOPT has them
    (:data:`._options.DEFAULTS`), plus ``linear_solver``: ``"envelope"``,
    ``"sparse"``, ``"dense"`` or ``"auto"``.  After a solve, :attr:`timings` holds the
    seconds spent per phase and :attr:`note` what the solver chose.
    """

    name = "interior-point"

    def __init__(self):
        self.timings = {}
        self.note = None

    @staticmethod
    def available():
        """``None``: the solver needs NumPy and SciPy only."""
        return None

    @staticmethod
    def arrays(options=None):
        """The context in which an NLP for these options is best built,
        solved and its result made: NumPy's large arrays each in a mapping of
        their own (:mod:`._mapped`) unless the option ``large_arrays`` is
        ``"numpy"`` (:meth:`solve` opens it too, around the iterations)."""
        from ._options import DEFAULTS
        choice = (options or {}).get("large_arrays", DEFAULTS["large_arrays"])
        return mapped_large_arrays(choice == "mapped")

    def solve(self, nlp, x0, options=None, warm=None, stop=lambda: False):
        """Solve ``nlp`` from ``x0``: an :class:`~kanedyn.optimization.NLPSolution`.

        Parameters
        ----------
        nlp : object
            The NLP interface of :mod:`kanedyn.optimization._solvers`: with an
            exact Hessian (``nlp.exact_hessian`` not ``None``, as
            ``solve(hessian="exact")`` makes it) that Hessian is used, else
            the limited-memory approximation; the option
            ``hessian_approximation``, when given, must agree.
        x0 : ndarray, shape (nlp.n,)
        options : dict, optional
            See :data:`._options.DEFAULTS`; an unknown name raises ``ValueError``.
        warm : dict, optional
            IPOPT's multipliers ``{"g", "x_lower", "x_upper"}`` of an earlier solve.
        stop : callable
            Asked once per iteration; ``True`` ends the solve (status 5).
        """
        s = checked_settings(options)
        has_exact = getattr(nlp, "exact_hessian", None) is not None
        if s.hessian_approximation == "exact" and not has_exact:
            raise OptionError("interior-point option hessian_approximation='exact': this NLP "
                             'has no exact Hessian; pass hessian="exact" to solve()')
        if s.hessian_approximation == "limited-memory" and has_exact:
            raise OptionError('hessian="exact" and the interior-point option '
                             "hessian_approximation='limited-memory' contradict each other; "
                             "give one")
        if s.hessian_approximation is None:
            s.hessian_approximation = "exact" if has_exact else "limited-memory"
        run = _Run(nlp, x0, s, warm, stop)
        # the callbacks and the iterations meet infinities and NaNs (a trial
        # point outside the model's domain, log of a zero gap): they are
        # tested for, not warned about (one context for the whole solve);
        # the large arrays in mappings of their own (._mapped)
        with np.errstate(all="ignore"), self.arrays(options):
            solution = run.solve()
        self.timings, self.note = run.timings, run.note
        return solution


class _Run:
    """One solve: the iterates and the algorithm's state."""

    def __init__(self, nlp, x0, settings, warm, stop):
        self.nlp, self.s, self.warm, self.stop = nlp, settings, warm, stop
        self.x0 = np.asarray(x0, dtype=float).reshape(int(nlp.n))  # read, never written
        self.timings = dict(callbacks=0.0, hessian=0.0, factor_solve=0.0, line_search=0.0,
                            total=0.0)
        self.note = None
        self.iteration = 0
        self.restoration = None
        self.start_wall = time.perf_counter()
        self.start_cpu = time.process_time()

    # ------------------------------------------------------------ helpers
    def _evaluate(self, x):
        """Objective and rows at the free variables ``x`` (scaled)."""
        t = time.perf_counter()
        R = self.reduced
        x_full = R.full(x)
        e = _Evaluation(x, R.objective(x_full), R.constraints(x_full))
        self.timings["callbacks"] += time.perf_counter() - t
        return e

    def _derivatives(self, e):
        """The gradient and the Jacobian at a new point ``e``: whether they
        are finite.  The last step's factors are dropped first (the new point
        needs new ones): not held while the derivatives and the next Hessian
        are made."""
        self.stepper.release()
        t = time.perf_counter()
        x_full = self.reduced.full(e.x)
        e.gradient = self.reduced.gradient(x_full)
        e.jacobian = self.reduced.jacobian(x_full)
        e.fixed_jacobian = self.reduced.fixed_jacobian
        self.timings["callbacks"] += time.perf_counter() - t
        return all_finite(e.gradient) and all_finite(e.jacobian)

    def jacobian_at(self, e):
        """The Jacobian at ``e``: evaluated again where the line search let
        it go (the same numbers), the NLP's evaluation behind it then dropped."""
        if e.jacobian is None:
            t = time.perf_counter()
            e.jacobian = self.reduced.jacobian(self.reduced.full(e.x))
            e.fixed_jacobian = self.reduced.fixed_jacobian
            self._drop_nlp_evaluation()
            self.timings["callbacks"] += time.perf_counter() - t
        return e.jacobian

    def _row_residuals(self, rows, w):
        """:math:`c`: equality rows minus their value, inequality rows minus
        their slacks (scaled); ``rows`` itself where nothing is subtracted
        (neither is written)."""
        if self.row_target is None and not self.inequality.size:
            return rows
        c = rows - self.row_target if self.row_target is not None else rows.copy()
        if self.inequality.size:
            c[self.inequality] = rows[self.inequality] - w[self.n:]
        return c

    def _in_w(self, v):
        """A vector ``v`` of the variables (n,) as one of ``w`` (zeros in the
        slacks; ``v`` itself when there are none, not to be written)."""
        if not self.inequality.size:
            return v
        out = np.zeros(self.bounds.size)
        out[:self.n] = v
        return out

    def _result(self, status, w, y, z_lower, z_upper, e):
        from .._solvers import NLPSolution
        R, n = self.reduced, self.n
        if w is None:
            x_full = self.x0.copy()
            multipliers = {"g": np.zeros(R.m_full), "x_lower": np.zeros(R.n_full),
                           "x_upper": np.zeros(R.n_full)}
            objective = float("nan") if e is None else e.objective / R.objective_scale
        else:
            if e is not None:  # the run ends: its derivatives not held with the NLP's last
                e.gradient = e.jacobian = None
            # nor its KKT system (the order, the structures): the multipliers of
            # the fixed variables take the Jacobian's entries in their columns,
            # the last evaluation's where it was made at this point (bit for
            # bit), else the NLP's Jacobian evaluated
            self.stepper = self.kkt = self.restoration = self.error_reductions = None
            x_full = R.full(w[:n])
            fixed = None if e is None else e.fixed_jacobian
            if fixed is not None and not np.array_equal(
                    np.asarray(e.x).view(np.uint64), w[:n].view(np.uint64)):
                fixed = None
            # the variables' bound multipliers (of w's entries below n)
            lo, up = self.bounds.lower_index, self.bounds.upper_index
            in_lower, in_upper = lo < n, up < n
            with np.errstate(all="ignore"):
                multipliers = R.multipliers_full(
                    x_full, y, (lo[in_lower], z_lower[in_lower]),
                    (up[in_upper], z_upper[in_upper]), fixed)
            objective = e.objective / R.objective_scale
        self.timings["total"] = time.perf_counter() - self.start_wall
        return NLPSolution(
            x=x_full, objective=float(objective), status=status, status_text=STATUS[status],
            advice=ADVICE.get(status),
            iterations=self.iteration, wall_time=self.timings["total"],
            multipliers=multipliers, solver=InteriorPoint.name,
            hessian=self.s.hessian_approximation)

    # ------------------------------------------------------------- start
    def _setup(self):
        s = self.s
        exact = s.hessian_approximation == "exact"
        self.reduced = R = ReducedNLP(self.nlp, self.x0, s, exact_hessian=exact)
        self.n, self.m = n, m = R.n, R.m
        self.inequality = R.inequality
        # (each in a method of its own: what it computes from is not held
        # while the KKT system is set up)
        if not self._scale():
            return False
        self._set_bounds()
        kkt_type, self.note = kkt_class(s.linear_solver)
        paired = {}
        if issubclass(kkt_type, SparseKKT):
            # the kernel is there: the patterns held as runs where they repeat;
            # no pair through an entry that is zero at the start (a structural
            # zero): the first factorization would meet its zero pivot
            R.hold_periodic()
            paired = {"pairable": self.pairable}
        self.kkt = kkt_type(n, m, R.hessian_structure(), R.jacobian_structure, **paired)
        self.pairable = None
        #: the NLP's limited-memory approximation, or ``None`` (exact)
        self.quasi_newton = None
        if not exact:
            self.kkt = LowRankKKT(self.kkt)
            self.quasi_newton = LimitedMemoryBFGS(s)
        #: the optimality errors' sums and maxima: SparseKKT's, one call (the
        #: same numbers as NumPy's, which DenseKKT's solves take)
        self.error_reductions = getattr(self.kkt, "error_reductions", None)
        self.stepper = StepSolver(self.kkt, n, m, self.inequality, s)
        return True

    def _scale(self):
        """The reduced NLP's scaling from the derivatives at the start point
        (:meth:`._reduced.ReducedNLP.scale_at`); ``False`` when one is not
        finite.  The NLP's evaluation there is then dropped (the start point
        evaluates again)."""
        R = self.reduced
        x_full = R.start_full()
        t = time.perf_counter()
        with np.errstate(all="ignore"):
            gradient = np.asarray(self.nlp.gradient(x_full), dtype=float)
            jacobian = np.asarray(self.nlp.jacobian(x_full), dtype=float)
        self.timings["callbacks"] += time.perf_counter() - t
        if not (all_finite(gradient) and all_finite(jacobian)):
            return False
        R.scale_at(x_full, gradient, jacobian)
        #: the Jacobian's entries that are not (relatively) zero at the start,
        #: those the sparse factorizations' order may pair (until it is made)
        self.pairable = pairable_entries(R.m, R.jacobian_structure[0],
                                         R.kept_jacobian(jacobian))
        self._drop_nlp_evaluation()
        return True

    def _drop_nlp_evaluation(self):
        """The NLP's last evaluation dropped, where it keeps one
        (``forget_evaluation``: the model's derivatives at every point), when
        the point's callbacks are done: not held through a factorization."""
        forget = getattr(self.nlp, "forget_evaluation", None)
        if forget is not None:
            forget()

    def _set_bounds(self):
        """The primal bounds (:class:`._bounds.PrimalBounds`), the rows'
        targets and the slacks' bounds, scaled."""
        R, s = self.reduced, self.s
        x_lower, x_upper = R.variable_bounds()
        g_lower, g_upper = R.row_bounds()
        ineq = self.inequality
        #: the rows' targets (equality rows' values), ``None`` where all are
        #: +0.0 (``rows - 0.0`` is ``rows``, bit for bit)
        self.row_target = np.where(R.equality, g_lower, 0.0)
        if not (self.row_target.any() or np.signbit(self.row_target).any()):
            self.row_target = None
        self.bounds = PrimalBounds(np.concatenate([x_lower, g_lower[ineq]]),
                                   np.concatenate([x_upper, g_upper[ineq]]),
                                   s.bound_relax_factor, s.kappa_d)
        self.slack_bounds = self.bounds.dense(start=self.n)

    def _start(self):
        """``(w, y, z_lower, z_upper, evaluation)`` or ``None`` (not finite)."""
        s, n, R = self.s, self.n, self.reduced
        warm = self.warm is not None
        x = self.bounds.push(np.concatenate([self.x0[R.free], np.zeros(len(self.inequality))]),
                             s.warm_start_bound_push if warm else s.bound_push,
                             s.warm_start_bound_frac if warm else s.bound_frac)[:n]
        e = self._evaluate(x)
        if not (e.finite() and self._derivatives(e)):
            return None
        w = primal_start(self.bounds, n, x, e.rows, self.inequality, s, warm)
        if np.array_equal(w[:n].view(np.uint64), x.view(np.uint64)):
            e.x = w[:n]  # the same numbers: the pushed start not held beside w
        del x
        if warm:
            y, zl_x, zu_x = R.scaled_multipliers(self.warm)
            z_lower, z_upper = warm_multipliers(self.bounds, n, y[self.inequality], zl_x, zu_x,
                                                s.warm_start_mult_bound_push)
            return w, y, z_lower, z_upper, e
        z_lower = np.full(self.bounds.lower_index.size, s.bound_mult_init_val)
        z_upper = np.full(self.bounds.upper_index.size, s.bound_mult_init_val)

        def gradient_w():  # (made once the matrix is factored: not held through it)
            out = np.concatenate([e.gradient, np.zeros(len(self.inequality))])
            out[self.bounds.lower_index] -= z_lower
            out[self.bounds.upper_index] += z_upper
            return out
        self._drop_nlp_evaluation()  # before each factorization (the Hessian evaluates again)
        t = time.perf_counter()
        y = least_squares_multipliers(self.kkt, n, self.m, self.inequality, e.jacobian,
                                      R.hessian_size, gradient_w,
                                      s.constr_mult_init_max)
        self.kkt.release()  # its factors not held through the first Hessian
        self.timings["factor_solve"] += time.perf_counter() - t
        return w, y, z_lower, z_upper, e

    # ------------------------------------------------------------- solve
    def solve(self):
        if not self._setup():
            return self._result(-13, None, None, None, None, None)
        R = self.reduced
        if np.count_nonzero(R.equality) > self.n:
            return self._result(-10, None, None, None, None, None)
        return self._iterate()

    def _measures(self, w, y, z_lower, z_upper, e, mu, gaps=None, c=None):
        """Residuals and optimality errors at the current iterate (``gaps``
        and the rows' residuals ``c`` at ``w`` when the caller has them)."""
        n, B, R = self.n, self.bounds, self.reduced
        gap_lower, gap_upper = B.gaps(w) if gaps is None else gaps
        lagrangian = R.transpose_times(e.jacobian, y)
        lagrangian += e.gradient  # grad of f + y^T c (summed in place), then in w
        lagrangian = self._in_w(lagrangian)
        if self.inequality.size:
            lagrangian[n:] = -y[self.inequality]
        dual = lagrangian.copy()
        dual[B.lower_index] -= z_lower
        dual[B.upper_index] += z_upper
        np.abs(dual, out=dual)
        if c is None:
            c = self._row_residuals(e.rows, w)
        # of the dual residual only its largest magnitude (as a one-entry array:
        # the errors take its maximum) and its sum (the system error) are held
        m = dict(gap_lower=gap_lower, gap_upper=gap_upper, lagrangian=lagrangian,
                 c=c, dual_largest=np.array([dual.max(initial=0.0)]), dual_sum=dual.sum(),
                 violation=self.unscaled_violation(e.rows, c))
        del dual
        return self._errors(m, y, z_lower, z_upper, mu)

    def _errors(self, m, y, z_lower, z_upper, mu):
        """``m`` of :meth:`_measures` with the optimality errors at the barrier
        parameter ``mu`` (after a new ``mu`` only these change)."""
        errors = optimality_errors(m["dual_largest"], m["c"], y, z_lower, z_upper,
                                   m["gap_lower"], m["gap_upper"], mu, self.error_reductions)
        sf = self.reduced.objective_scale
        m.update(dual_inf=errors.dual_inf, primal_inf=errors.primal_inf, error=errors.error,
                 error_mu=errors.error_mu,
                 unscaled=(errors.dual_inf / sf, m["violation"], errors.compl / sf))
        return m

    def unscaled_violation(self, rows, c):
        """IPOPT's unscaled violation :math:`\\|\\cdot\\|_\\infty`: the
        equality rows' residuals ``c``, the inequality rows (values ``rows``)
        against their (relaxed) bounds."""
        violation = c
        if self.inequality.size:
            violation = c.copy()
            values = rows[self.inequality]
            violation[self.inequality] = values - np.clip(values, *self.slack_bounds)
        return float((np.abs(violation) / self.reduced.row_scale).max(initial=0.0))

    def hessian_values(self, e, y, objective_factor, quasi_newton=None):
        """The scaled Lagrangian's Hessian at ``e`` with the rows'
        multipliers ``y`` and the objective times ``objective_factor``, or
        ``None`` when a value is not finite; with ``quasi_newton`` (a
        :class:`._quasi_newton.LimitedMemoryBFGS`) its approximation after
        the pair from the last point it saw to ``e``."""
        t = time.perf_counter()
        if quasi_newton is None:
            hessian = self.reduced.hessian(self.reduced.full(e.x), y, objective_factor)
            self._drop_nlp_evaluation()  # the point's last callback
            finite = all_finite(hessian)
        else:
            x = e.x
            if quasi_newton.last is not None:
                x_last, gradient_last, jacobian_last = quasi_newton.last
                change = self.reduced.transpose_times(e.jacobian - jacobian_last, y)
                if objective_factor:
                    change += objective_factor * (e.gradient - gradient_last)
                quasi_newton.update(x - x_last, change)
            quasi_newton.last = (x, e.gradient, e.jacobian)
            hessian = quasi_newton.compact(self.n)
            finite = all_finite(hessian.V)
        self.timings["hessian"] += time.perf_counter() - t
        return hessian if finite else None

    def _matrix_again(self, e, y, hessian, z_lower, z_upper, gap_lower, gap_upper):
        """A callable that makes the Newton step's ``(hessian, jacobian,
        sigma)`` at ``e`` again (:meth:`._step.StepSolver.release`): the exact
        Hessian evaluated again (the same numbers), a limited-memory one
        held (its next update must not run twice)."""
        held = None if self.quasi_newton is None else hessian

        def again():
            made = held if held is not None else self.hessian_values(e, y, 1.0)
            jacobian = self.jacobian_at(e)
            if held is None:  # (exact) not held by the point through the correction's trial
                e.jacobian = None
            return made, jacobian, self.bounds.sigma(z_lower, z_upper, gap_lower, gap_upper)
        return again

    def direction(self, stepper, bounds, hessian, jacobian, sigma, residual_w, c, z_lower,
                  z_upper, gaps, mu, tau):
        """The Newton step (:meth:`._step.StepSolver.compute`) and the bound
        multipliers' steps and step lengths
        (:meth:`._bounds.PrimalBounds.step_lengths`): ``(step, dz_lower,
        dz_upper, alpha_primal_max, alpha_dual)``, or ``None`` when no
        regularization gave the right inertia.  The point's callbacks are
        done (the Hessian made): the NLP's evaluation is dropped first; the
        factors once the step is solved (not held through the step lengths
        and the line search).  ``gaps()`` gives ``(gap_lower, gap_upper)``
        after the step is solved (the caller's to make again, not held
        through it)."""
        self._drop_nlp_evaluation()
        t = time.perf_counter()
        step = stepper.compute(hessian, jacobian, sigma, residual_w, c, mu)
        stepper.release()
        self.timings["factor_solve"] += time.perf_counter() - t
        if step is None:
            return None
        return (step,) + bounds.step_lengths(z_lower, z_upper, *gaps(), step.primal, mu, tau)

    def stopping_status(self):
        """-1 (``max_iter``), -4 (``max_cpu_time``), 5 (a stop request) or ``None``."""
        s = self.s
        if self.iteration >= s.max_iter:
            return -1
        if s.max_cpu_time < 1e20 and time.process_time() - self.start_cpu > s.max_cpu_time:
            return -4
        if self.stop():
            return 5
        return None

    def _converged(self, m, acceptable):
        s = self.s
        dual, primal, compl = m["unscaled"]
        if acceptable:
            return (m["error"] <= s.acceptable_tol and dual <= s.acceptable_dual_inf_tol
                    and primal <= s.acceptable_constr_viol_tol
                    and compl <= s.acceptable_compl_inf_tol)
        return (m["error"] <= s.tol and dual <= s.dual_inf_tol and primal <= s.constr_viol_tol
                and compl <= s.compl_inf_tol)

    def _iterate(self):
        """The iterations from :meth:`_start`'s point (held by no other frame:
        not kept past the first step)."""
        started = self._start()
        if started is None:
            return self._result(-13, None, None, None, None, None)
        w, y, z_lower, z_upper, e = started
        del started
        s, n, B = self.s, self.n, self.bounds
        mu = s.mu_init
        tau = max(s.tau_min, 1.0 - mu)
        m = self._measures(w, y, z_lower, z_upper, e, mu)
        theta = float(np.abs(m["c"]).sum())
        line_filter = Filter(theta)
        acceptable_count = 0
        force_barrier = restored_row = False
        #: iterations in the soft restoration phase after its first (None: not
        #: in it); the last iterate within the acceptable tolerances, or None
        soft, last_acceptable = None, None
        row = dict(alpha_dual=0.0, alpha_primal=0.0, step=0.0, delta_w=0.0, trials=0, kind=" ")
        if s.print_level:
            if self.note:
                print(f"interior point: {self.note}", file=sys.stdout)
            _print_header()
        while True:
            if s.print_level and not restored_row:  # a restored point was printed
                _print_row(self.iteration, e.objective / self.reduced.objective_scale,
                           m["unscaled"][1], m["dual_inf"], mu, row)
            restored_row = False
            if self._converged(m, acceptable=False):
                return self._result(0, w, y, z_lower, z_upper, e)
            acceptable = self._converged(m, acceptable=True)
            acceptable_count = acceptable_count + 1 if acceptable else 0
            if acceptable:  # (its values without the derivatives: not held)
                last_acceptable = (w, y, z_lower, z_upper,
                                   _Evaluation(e.x, e.objective, e.rows))
            if s.acceptable_iter and acceptable_count >= s.acceptable_iter:
                return self._result(1, w, y, z_lower, z_upper, e)
            if np.abs(w[:n]).max(initial=0.0) > s.diverging_iterates_tol:
                return self._result(4, w, y, z_lower, z_upper, e)
            stopping = self.stopping_status()
            if stopping is not None:
                return self._result(stopping, w, y, z_lower, z_upper, e)
            # the barrier parameter (monotone)
            while force_barrier or m["error_mu"] <= s.barrier_tol_factor * mu:
                force_barrier = False
                new_mu = next_barrier(mu, s)
                if new_mu >= mu:
                    break
                mu = new_mu
                tau = max(s.tau_min, 1.0 - mu)
                line_filter.reset()
                soft = None
                m = self._errors(m, y, z_lower, z_upper, mu)
            # the Newton step
            hessian = self.hessian_values(e, y, 1.0, self.quasi_newton)
            if hessian is None:
                return self._result(-13, w, y, z_lower, z_upper, e)
            # (the gaps are w's, B.gaps(w): not held through the step but made
            # again after it, the same numbers)
            gap_lower, gap_upper = m.pop("gap_lower"), m.pop("gap_upper")
            sigma = B.sigma(z_lower, z_upper, gap_lower, gap_upper)
            gradient_w = self._in_w(e.gradient)
            # (the Lagrangian's gradient and the barrier's not held through the
            # step: only this needs the first, the slope below the second, made
            # again from the same numbers)
            residual_w = B.barrier_gradient(gradient_w, gap_lower, gap_upper, mu) \
                + (m.pop("lagrangian") - gradient_w)
            del gap_lower, gap_upper

            def gaps():  # made again after the step, kept in m
                m["gap_lower"], m["gap_upper"] = B.gaps(w)
                return m["gap_lower"], m["gap_upper"]
            again = self.quasi_newton is None and e.gradient.nbytes >= GRADIENT_AGAIN_BYTES
            if again:  # not held through the step (GRADIENT_AGAIN_BYTES)
                e.gradient = gradient_w = None
            direction = self.direction(self.stepper, B, hessian, e.jacobian, sigma, residual_w,
                                       m["c"], z_lower, z_upper, gaps, mu, tau)
            if direction is None:
                return self._result(-3, w, y, z_lower, z_upper, e)
            gap_lower, gap_upper = m["gap_lower"], m["gap_upper"]
            if again:
                t = time.perf_counter()
                e.gradient = self.reduced.gradient(self.reduced.full(e.x))
                gradient_w = self._in_w(e.gradient)
                self.timings["callbacks"] += time.perf_counter() - t
            # the factors are not held through the line search (direction let
            # them go), nor the Hessian and sigma, nor (with the exact Hessian)
            # the Jacobian, while the trial points are evaluated: a
            # second-order correction or the restoration phase makes them
            # again (the same numbers); the limited-memory update holds the
            # Jacobian for its next pair anyway
            self.stepper.release(again=self._matrix_again(e, y, hessian, z_lower, z_upper,
                                                          gap_lower, gap_upper))
            del hessian, sigma
            if self.quasi_newton is None:
                e.jacobian = None
            step, dz_lower, dz_upper, alpha_max, alpha_z = direction
            dw, dy = step.primal, step.rows
            # the line search
            t = time.perf_counter()
            # theta and phi of an accepted trial point (phi at the same mu) as
            # the line search found them, else computed here
            theta = m["theta"] if "theta" in m else float(np.abs(m["c"]).sum())
            phi = m["phi"][1] if "phi" in m and m["phi"][0] == mu else \
                B.barrier(e.objective, gap_lower, gap_upper, mu)
            barrier_gradient = B.barrier_gradient(gradient_w, gap_lower, gap_upper, mu)
            slope = float(barrier_gradient @ dw)
            del barrier_gradient
            tiny = ((np.abs(dw) / (1.0 + np.abs(w))).max(initial=0.0)
                    < _TINY_STEP
                    and (np.abs(dy) / (1.0 + np.abs(y))).max(initial=0.0) < 1e-2)
            in_filter = soft is not None  # the soft phase's first point is in it
            soft_kind = None  # a soft restoration step: "s", or "S" the filter's
            if tiny:
                found = self._trial(w + alpha_max * dw, mu)
                accepted = found is not None
                if accepted:
                    found = (found, alpha_max, step, True, 1)
                force_barrier = True
            else:
                found = None
                if soft is None:
                    found = self._line_search(w, dw, step, alpha_max, theta, phi, slope, mu,
                                              tau, line_filter, residual_w, m)
                    if found is None:  # the soft restoration phase, the point in the filter
                        line_filter.add(theta, phi)
                        in_filter, soft = True, -1
                if found is None and soft < SOFT_ITERATIONS:
                    soft += 1
                    found, soft_kind = self._soft_step(w, y, z_lower, z_upper, m, step,
                                                       dz_lower, dz_upper, alpha_max, alpha_z,
                                                       theta, phi, mu, line_filter)
                if soft_kind != "s":  # the filter accepts, or no step: the soft phase ends
                    soft = None
            self.timings["line_search"] += time.perf_counter() - t
            if found is None:
                soft = None
                if self._converged(m, acceptable=True):
                    return self._result(1, w, y, z_lower, z_upper, e)
                # the feasibility restoration phase, the point in the filter
                if not in_filter:
                    line_filter.add(theta, phi)
                if theta <= ALMOST_FEASIBLE * s.tol:  # almost feasible: not restored
                    self.iteration += 1
                    if last_acceptable is not None:
                        return self._result(1, *last_acceptable)
                    return self._result(-2, w, y, z_lower, z_upper, e)
                if self.restoration is None:
                    self.restoration = Restoration(self)
                if self.quasi_newton is not None:  # no pair across the restoration
                    self.quasi_newton.reset()
                self.iteration += 1  # IPOPT counts the entry as an iteration
                restored = self.restoration.solve(w, z_lower, z_upper, e, mu, line_filter,
                                                  _print_row if s.print_level else None)
                if restored.status == -2 and last_acceptable is not None:
                    return self._result(1, *last_acceptable)
                if restored.status is not None:
                    return self._result(restored.status, *restored.point)
                w, y, z_lower, z_upper, e = restored.point
                m = self._measures(w, y, z_lower, z_upper, e, mu)
                restored_row = True
                continue
            (trial, w_trial, theta_trial, phi_trial, gaps, c), alpha, step_used, f_type, \
                trials = found
            corrected = step_used is not step
            if corrected:
                # a second-order correction: the bound multipliers step along it
                dz_lower, dz_upper, _, alpha_z = B.step_lengths(
                    z_lower, z_upper, gap_lower, gap_upper, step_used.primal, mu, tau)
            if soft_kind is not None:  # one step length for all, the filter as it is
                alpha_z = alpha
            elif not f_type and not tiny:
                line_filter.add(theta, phi)
            # the new iterate
            w = w_trial
            y = y + alpha * step_used.rows
            z_lower = z_lower + alpha_z * dz_lower
            z_upper = z_upper + alpha_z * dz_upper
            e = trial
            if s.print_level:  # the printed row's columns
                row = dict(alpha_dual=alpha_z, alpha_primal=alpha,
                           step=float(np.abs(dw).max(initial=0.0)), delta_w=step.delta_w,
                           trials=trials, kind=soft_kind or (("F" if f_type else "H")
                                                            if corrected
                                                            else ("f" if f_type else "h")))
            # this step's arrays are not held into the new point's derivatives,
            # measures, Hessian and factorization, nor its matrix's inputs
            del gradient_w, residual_w, direction, step, step_used, found, \
                dw, dy, dz_lower, dz_upper
            self.stepper.release()
            if e.gradient is None and not self._derivatives(e):  # (a soft step's has them)
                self.iteration += 1
                return self._result(-13, w, y, z_lower, z_upper, e)
            z_lower, z_upper = safeguard_multipliers(z_lower, z_upper, *gaps, mu)
            self.iteration += 1
            m = self._measures(w, y, z_lower, z_upper, e, mu, gaps, c)
            m.update(theta=theta_trial, phi=(mu, phi_trial))

    def _trial(self, w_trial, mu):
        """``(evaluation, w, theta, phi, gaps, c)`` at a trial point (``gaps``
        of the bounds, ``c`` the rows' residuals), or ``None`` when a value is
        not finite."""
        e = self._evaluate(w_trial[:self.n])
        if not e.finite():
            return None
        gaps = self.bounds.gaps(w_trial)
        c = self._row_residuals(e.rows, w_trial)
        theta = float(np.abs(c).sum())
        phi = self.bounds.barrier(e.objective, *gaps, mu)
        return e, w_trial, theta, phi, gaps, c

    def _soft_step(self, w, y, z_lower, z_upper, m, step, dz_lower, dz_upper, alpha_max,
                   alpha_z, theta, phi, mu, line_filter):
        """A step of the soft restoration phase (the module's item 5): ``(found,
        kind)`` with ``found`` as :meth:`_line_search` gives it and ``kind``
        ``"S"`` (the filter accepts the point) or ``"s"`` (the primal-dual
        system error fell), or ``(None, None)``; ``m`` the current iterate's
        :meth:`_measures`."""
        alpha = min(alpha_max, alpha_z)
        trial = self._trial(w + alpha * step.primal, mu)
        if trial is None:
            return None, None
        e, w_trial, trial_theta, trial_phi, gaps, c = trial
        if line_filter.accepts(theta, phi, 0.0, 0.0, trial_theta, trial_phi)[0]:
            return (trial, alpha, step, False, 1), "S"
        if not self._derivatives(e):
            return None, None
        trial_lower, trial_upper = z_lower + alpha * dz_lower, z_upper + alpha * dz_upper
        trial_m = self._measures(w_trial, y + alpha * step.rows, trial_lower, trial_upper, e,
                                 mu, gaps, c)
        if _system_error(trial_m, trial_lower, trial_upper, mu) \
                <= SOFT_REDUCTION * _system_error(m, z_lower, z_upper, mu):
            return (trial, alpha, step, False, 1), "s"
        return None, None

    def _line_search(self, w, dw, step, alpha_max, theta, phi, slope, mu, tau, line_filter,
                     residual_w, m):
        """Backtracking from ``alpha_max`` (halving), a second-order correction
        after a first trial that raised the violation:
        ``(trial, alpha, step, f_type, trials)`` (``step`` the corrected one
        after a second-order correction) or ``None``; ``m`` the current
        iterate's :meth:`_measures`."""
        s = self.s
        alpha_min = line_filter.smallest_step(theta, slope, s.alpha_min_frac)
        alpha = alpha_max
        trials = 0
        while alpha >= alpha_min or not trials:  # the first step always tried (IPOPT)
            trials += 1
            trial = self._trial(w + alpha * dw, mu)
            if trial is not None:
                accepted, f_type = line_filter.accepts(theta, phi, slope, alpha, trial[2],
                                                       trial[3])
                if accepted:
                    return trial, alpha, step, f_type, trials
                if trials == 1 and trial[2] >= theta and s.max_soc:
                    # of the rejected point only its violation is held through the
                    # corrections (and the first correction's rows)
                    theta_trial, c_soc = trial[2], alpha * m["c"] + trial[5]
                    trial = None
                    corrected = self._second_order(w, alpha, theta_trial, c_soc, theta, phi,
                                                   slope, mu, tau, line_filter, residual_w, m)
                    if corrected is not None:
                        return corrected + (trials,)
            alpha /= 2
        return None

    def _second_order(self, w, alpha, theta_trial, c_soc, theta, phi, slope, mu, tau,
                      line_filter, residual_w, m):
        """Second-order corrections of a rejected full step (its violation
        ``theta_trial``; ``c_soc`` the first correction's rows, the step
        length times the current point's residuals plus the rejected
        point's; up to ``max_soc``, while each cuts the violation by
        ``kappa_soc``)."""
        s, B = self.s, self.bounds
        theta_old = theta_trial
        gap_lower, gap_upper = m["gap_lower"], m["gap_upper"]
        lo, up = B.lower_index, B.upper_index
        again = w.nbytes >= CORRECTION_AGAIN_BYTES
        try:
            for _ in range(int(s.max_soc)):
                # the rejected point's evaluation is not held through the factorization
                self._drop_nlp_evaluation()
                t = time.perf_counter()
                corrected = self.stepper.solve(residual_w, c_soc, release=again)
                self.timings["factor_solve"] += time.perf_counter() - t
                if corrected is None:
                    return None
                dw = corrected.primal
                alpha_soc = min(fraction_to_boundary(gap_lower, dw[lo], tau),
                                fraction_to_boundary(gap_upper, -dw[up], tau))
                soc_trial = self._trial(w + alpha_soc * dw, mu)
                if soc_trial is None:
                    return None
                accepted, f_type = line_filter.accepts(theta, phi, slope, alpha, soc_trial[2],
                                                       soc_trial[3])
                if accepted:
                    return soc_trial, alpha_soc, corrected, f_type
                if soc_trial[2] > s.kappa_soc * theta_old:
                    return None
                theta_old = soc_trial[2]
                c_soc = alpha_soc * c_soc + soc_trial[5]
            return None
        finally:  # the factors made again (for all the corrections) not held past them
            self.stepper.release()


def _system_error(m, z_lower, z_upper, mu):
    r"""The primal-dual system error of :meth:`_Run._measures`' ``m``:
    :math:`\|\nabla L - z_L + z_U\|_1 + \|c\|_1 + \|Z\,\text{gap} - \mu\|_1`
    (IPOPT's, whose division by the entries' count does not change its
    comparisons)."""
    return float(m["dual_sum"] + np.abs(m["c"]).sum()
                 + np.abs(z_lower * m["gap_lower"] - mu).sum()
                 + np.abs(z_upper * m["gap_upper"] - mu).sum())


def _print_header():
    print("iter    objective    inf_pr   inf_du lg(mu)  ||d||  lg(rg) alpha_du alpha_pr  ls",
          file=sys.stdout)


def _print_row(iteration, objective, violation, dual_inf, mu, row):
    """IPOPT's columns: ``iteration`` (a restoration iteration's ends in
    ``r``), inf_pr the unscaled violation, inf_du the scaled dual
    infeasibility."""
    rg = f"{np.log10(row['delta_w']):6.1f}" if row["delta_w"] > 0 else "     -"
    print(f"{str(iteration):>4} {objective:14.7e} {violation:8.2e} {dual_inf:8.2e} "
          f"{np.log10(mu):5.1f} {row['step']:8.2e} {rg} {row['alpha_dual']:8.2e} "
          f"{row['alpha_primal']:8.2e}{row['kind']} {row['trials']:2d}", file=sys.stdout,
          flush=True)
