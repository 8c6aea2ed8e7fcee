r"""The primal-dual Newton step, its linear system regularized until its
inertia is right (Waechter & Biegler 2006, section 3.1).

Unknowns :math:`(\Delta x, \Delta s, \Delta y)`; the slacks' rows
:math:`(\Sigma_s + \delta_w)\,\Delta s - \Delta y_I = -r_s` are eliminated,
which leaves, with :math:`D_c = \delta_c` on the equality rows and
:math:`(\Sigma_s + \delta_w)^{-1} + \delta_c` on the inequality rows,

.. math::

    \begin{bmatrix} W + \Sigma_x + \delta_w I & J^T \\ J & -D_c \end{bmatrix}
    \begin{bmatrix} \Delta x \\ \Delta y \end{bmatrix} =
    -\begin{bmatrix} r_x \\ c - [0;\ (\Sigma_s + \delta_w)^{-1} r_s] \end{bmatrix}

(:math:`r = \nabla\varphi_\mu + (J^T y, -y_I)`, :math:`c` the rows'
residuals :math:`g_E - g_L` and :math:`g_I - s`).  The matrix must have n
positive and m negative eigenvalues; else :math:`\delta_c = \bar\delta_c
\mu^{\kappa_c}` when it is singular, and :math:`\delta_w` grows from its
last value (IPOPT's rules).  When the first :data:`DEGENERATE_ITERATIONS`
iterations all found K singular (and, for the Hessian, still singular with
:math:`\delta_c`), every later first factorization starts with
:math:`\delta_c` (and :math:`\kappa_w^- \delta_w^{last}`) instead of zero;
one iteration without settles the question the other way (IPOPT's
``degen_iters_max``; wrong inertia without a zero eigenvalue is negative
curvature, not degeneracy).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._finite import all_finite
from .kkt._diagonal import DiagonalEntries

__all__ = ["NewtonStep", "StepSolver", "DEGENERATE_ITERATIONS"]

#: after this many consecutive iterations that needed a regularization, the
#: first factorization of an iteration starts with it (IPOPT's degen_iters_max)
DEGENERATE_ITERATIONS = 3

#: the entries of the right-hand side made at a time in the refinement
_CHUNK = 1 << 16


@dataclass(frozen=True)
class NewtonStep:
    """A search direction.

    Attributes
    ----------
    primal : ndarray, shape (n + n_slacks,)
        :math:`\\Delta w = (\\Delta x, \\Delta s)`.
    rows : ndarray, shape (m,)
        :math:`\\Delta y`.
    delta_w, delta_c : float
        The regularization it took.
    """

    primal: np.ndarray
    rows: np.ndarray
    delta_w: float
    delta_c: float


class StepSolver:
    """Newton steps through a KKT factorization (``kkt``: the interface of
    :mod:`.kkt._dense`), remembering the last Hessian regularization.

    Parameters
    ----------
    kkt : DenseKKT or SparseKKT
        Of n variables and m rows.
    n, m : int
    inequality : ndarray of int, shape (n_slacks,)
        The row of each eliminated variable :math:`w_{n+k}` (the inequality
        rows' slacks; the restoration phase's :math:`p, n` too, so a row may
        repeat).
    settings : namespace
        The solver's options.
    signs : ndarray, shape (n_slacks,), optional
        Each eliminated variable's coefficient in its row: -1 (a slack, the
        default) or +1.
    """

    def __init__(self, kkt, n, m, inequality, settings, signs=None):
        self.kkt, self.n, self.m = kkt, n, m
        self.inequality = np.asarray(inequality, dtype=np.int64)
        self.signs = (np.full(self.inequality.size, -1.0) if signs is None
                      else np.asarray(signs, dtype=float))
        self.settings = settings
        self.last_delta_w = 0.0
        #: whether every step takes delta_w > 0 / delta_c > 0 at once
        #: (None: not decided yet, see _degenerate)
        self.hessian_degenerate = self.jacobian_degenerate = None
        self._counts = {"regularized": 0, "singular": 0}
        self.factorizations = 0
        self._state = None
        #: the last matrix's inputs while its factors are released to be made
        #: again (:meth:`release`), else ``None``
        self._again = None

    def _factor(self, hessian_values, jacobian_values, sigma, delta_w, delta_c):
        n = self.n
        if isinstance(sigma, DiagonalEntries):  # the variables' entries, the slacks'
            sigma_x, sigma_s = sigma.split(n)
        else:
            sigma_x, sigma_s = sigma[:n], sigma[n:]
        slack_diagonal = sigma_s + delta_w
        if self.inequality.size:
            diagonal_c = delta_c + np.bincount(self.inequality, weights=1.0 / slack_diagonal,
                                               minlength=self.m)
        else:  # delta_c + 0.0, as the sum above, on every row: a number, no array
            diagonal_c = delta_c + 0.0
        self.factorizations += 1
        # sigma's own entries (views, which the KKT may hold for its products),
        # delta_w added by the KKT (the same sums, no array of them)
        inertia = self.kkt.factor(hessian_values, jacobian_values, sigma_x, diagonal_c,
                                  delta_w)
        self._state = (slack_diagonal, delta_w, delta_c)
        self._again = None
        return int(inertia[0]), int(inertia[1]), int(inertia[2])

    def release(self, again=None):
        """Drop the factors (the KKT's ``release``).  ``again``: a callable
        that makes the last matrix's ``(hessian_values, jacobian_values,
        sigma)`` again (the same numbers), kept so that :meth:`solve` factors
        it again when asked: the line search holds neither the factors nor
        the matrix's values through its trial points for its rare
        second-order corrections."""
        self.kkt.release()
        self._again = again

    def compute(self, hessian_values, jacobian_values, sigma, residual_w, residual_c, mu):
        """The regularized Newton step, or ``None`` when no regularization up
        to ``max_hessian_perturbation`` gave the right inertia.

        Parameters
        ----------
        sigma : ndarray, shape (n + n_slacks,), or DiagonalEntries of that size
            :math:`\\Sigma` of the bounds.
        residual_w : ndarray, shape (n + n_slacks,)
            :math:`\\nabla\\varphi_\\mu + (J^T y, -y_I)`.
        residual_c : ndarray, shape (m,)
            The rows' residuals.
        """
        s = self.settings
        right = (self.n, self.m, 0)
        jacobian_delta = s.jacobian_regularization_value * mu ** s.jacobian_regularization_exponent
        delta_c = jacobian_delta if self.jacobian_degenerate else 0.0
        delta_w = 0.0
        if self.hessian_degenerate and self.last_delta_w > 0:
            delta_w = max(s.min_hessian_perturbation, s.perturb_dec_fact * self.last_delta_w)
        inertia = self._factor(hessian_values, jacobian_values, sigma, delta_w, delta_c)
        step = self.solve(residual_w, residual_c) if inertia == right else None
        # singular even with delta_c: evidence that the Hessian is degenerate
        still_singular = False
        if delta_c == 0.0:
            singular = step is None and (inertia[2] > 0 or inertia == right)
            self.jacobian_degenerate = self._degenerate("singular", singular,
                                                        self.jacobian_degenerate)
            if singular:
                delta_c = jacobian_delta
                inertia = self._factor(hessian_values, jacobian_values, sigma, delta_w, delta_c)
                if inertia == right:
                    step = self.solve(residual_w, residual_c)
                still_singular = step is None and inertia[2] > 0
        if self.hessian_degenerate is None and delta_w == 0.0:
            # only a matrix singular without delta_w counts; wrong inertia
            # (negative curvature) decides "not degenerate", as in IPOPT
            self.hessian_degenerate = self._degenerate("regularized", still_singular, None)
        if step is None:
            if delta_w == 0.0:
                delta_w = (s.first_hessian_perturbation if self.last_delta_w == 0.0 else
                           max(s.min_hessian_perturbation,
                               s.perturb_dec_fact * self.last_delta_w))
            else:
                delta_w *= s.perturb_inc_fact
            while step is None and delta_w <= s.max_hessian_perturbation:
                if self._factor(hessian_values, jacobian_values, sigma, delta_w,
                                delta_c) == right:
                    step = self.solve(residual_w, residual_c)
                if step is None:
                    delta_w *= (s.perturb_inc_fact_first if self.last_delta_w == 0.0
                                else s.perturb_inc_fact)
            if step is None:
                return None
        if step.delta_w > 0:
            self.last_delta_w = step.delta_w
        return step

    def _degenerate(self, kind, happened, decided):
        """IPOPT's rule: ``None`` (undecided) until the first iteration
        without the regularization (``False`` from then on) or the
        :data:`DEGENERATE_ITERATIONS`-th with it (``True``)."""
        if decided is not None:
            return decided
        if not happened:
            return False
        self._counts[kind] += 1
        return True if self._counts[kind] >= DEGENERATE_ITERATIONS else None

    def _refined(self, solution, rhs_part, scale):
        """``solution`` of K x = rhs after iterative refinement (in place),
        ``rhs_part(k0, k1)`` the entries ``k0:k1`` of rhs (made again, so
        that rhs is not held beside the solution and K's product), ``scale``
        :math:`\\max(1, \\|rhs\\|_\\infty)`."""
        if not self.settings.max_refinement_steps:
            return solution
        size = solution.size
        for _ in range(int(self.settings.max_refinement_steps)):
            if not all_finite(solution):
                break
            error = self.kkt.matvec(solution)  # a new array: ours to overwrite
            for k0 in range(0, size, _CHUNK):  # rhs - K x, rhs a chunk at a time
                k1 = min(size, k0 + _CHUNK)
                np.subtract(rhs_part(k0, k1), error[k0:k1], out=error[k0:k1])
            # the largest |error| without an array of them (NaN either way)
            largest = max(error.max(initial=0.0), -error.min(initial=0.0))
            if not largest > self.settings.residual_ratio_max * scale:
                break
            # the correction solved in error's storage, then added in place;
            # error not held through the next matvec's new array
            solution += self.kkt.solve(error, overwrite=True)
            del error
        return solution

    def solve(self, residual_w, residual_c, release=False):
        """The step with the last factorization for these residuals (also the
        second-order correction's), refined iteratively; ``None`` if not finite.
        ``release``: factors made again for this solve (:meth:`release`) are
        let go again after it, kept to be made again."""
        n = self.n
        slack_diagonal, delta_w, delta_c = self._state
        again = self._again
        if again is not None:  # released: the same matrix factored again
            self._factor(*again(), delta_w, delta_c)
        residual_s = residual_w[n:]
        # the inequality rows' part of rhs (held: rhs is made again in parts)
        slacks = (np.bincount(self.inequality, weights=self.signs * residual_s / slack_diagonal,
                              minlength=self.m) if self.inequality.size else None)

        def rhs_part(k0, k1):
            """Entries ``k0:k1`` of rhs, a new array."""
            out = np.empty(k1 - k0)
            a, b = min(k0, n), min(k1, n)  # the primal part's, then the rows'
            r0, r1 = max(k0, n) - n, max(k1, n) - n
            np.negative(residual_w[a:b], out=out[:b - a])
            rows = out[b - a:]
            if slacks is not None:
                rows[...] = -residual_c[r0:r1]
                rows += slacks[r0:r1]
            else:  # -residual_c + 0.0 (as the sum above, a zero's sign too)
                np.subtract(0.0, residual_c[r0:r1], out=rows)
            return out

        rhs = rhs_part(0, n + self.m)
        if not all_finite(rhs):
            return None
        scale = max(1.0, float(rhs.max(initial=0.0)), -float(rhs.min(initial=0.0)))  # |rhs|
        # solved in rhs's own storage: rhs is made again in parts where needed
        solution = self._refined(self.kkt.solve(rhs, overwrite=True), rhs_part, scale)
        del rhs
        if release and again is not None:
            self.release(again)
        if not all_finite(solution):
            return None
        dx, dy = solution[:n], solution[n:]
        if not self.inequality.size:  # both views of the solution: no copy
            return NewtonStep(dx, dy, delta_w, delta_c)
        ds = (-self.signs * dy[self.inequality] - residual_s) / slack_diagonal
        return NewtonStep(np.concatenate([dx, ds]), dy, delta_w, delta_c)
