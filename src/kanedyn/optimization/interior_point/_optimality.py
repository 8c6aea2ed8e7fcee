r"""The optimality error of an iterate and the safeguard on the bound
multipliers (Waechter & Biegler 2006, sections 2.1 and 2.2), shared by the
iterations on the NLP (:mod:`._solver`) and on its restoration problem
(:mod:`._restoration`).

The scaled error is

.. math::

    E_\mu = \max\Bigl(\frac{\|\nabla L - z_L + z_U\|_\infty}{s_d},\ \|c\|_\infty,\
                      \frac{\|Z (W - W_B) e - \mu e\|_\infty}{s_c}\Bigr),

:math:`s_d = \max(s_{\max}, (\|y\|_1 + \|z\|_1)/(m + n_z))/s_{\max}`,
:math:`s_c = \max(s_{\max}, \|z\|_1/n_z)/s_{\max}`, :math:`s_{\max} = 100`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Errors", "optimality_errors", "numpy_error_reductions", "safeguard_multipliers",
           "next_barrier", "KAPPA_SIGMA", "S_MAX"]

#: the bound multipliers stay within [mu / (KAPPA_SIGMA gap), KAPPA_SIGMA mu / gap]
KAPPA_SIGMA = 1e10
#: s_max of the scaled optimality error
S_MAX = 100.0


@dataclass(frozen=True)
class Errors:
    """An iterate's residuals, all of the scaled problem.

    Attributes
    ----------
    dual_inf, primal_inf, compl : float
        :math:`\\|\\nabla L - z_L + z_U\\|_\\infty`, :math:`\\|c\\|_\\infty`,
        the largest complementarity product.
    error, error_mu : float
        :math:`E_0` and :math:`E_\\mu`.
    """

    dual_inf: float
    primal_inf: float
    compl: float
    error: float
    error_mu: float


def optimality_errors(dual, c, y, z_lower, z_upper, gap_lower, gap_upper, mu,
                      reductions=None):
    """The :class:`Errors` of an iterate.

    Parameters
    ----------
    dual : ndarray, shape (n_w,)
        :math:`\\nabla L - z_L + z_U` in the primal variables (only its
        largest magnitude is taken: an array holding that alone gives the same).
    c : ndarray, shape (m,)
        The rows' residuals.
    y : ndarray, shape (m,)
    z_lower, z_upper, gap_lower, gap_upper : ndarray
        The bound multipliers and their gaps (shapes of the bounds' indices).
    mu : float
        The barrier parameter.
    reductions : callable, optional
        The sums and maxima of :func:`numpy_error_reductions` (the default),
        or a function of the same arguments giving the same numbers (the
        compiled kernel's ``error_reductions``, :mod:`.kkt._kernel`: one call
        in place of NumPy's twenty).  All arrays float64, C-contiguous.
    """
    (y_sum, z_lower_sum, z_upper_sum, dual_inf, primal_inf, compl_lower, compl_upper,
     compl_mu_lower, compl_mu_upper) = (reductions or numpy_error_reductions)(
        dual, c, y, z_lower, z_upper, gap_lower, gap_upper, mu)
    n_z = z_lower.size + z_upper.size
    z_sum = z_lower_sum + z_upper_sum
    s_d = max(S_MAX, (y_sum + z_sum) / max(c.size + n_z, 1)) / S_MAX
    s_c = max(S_MAX, z_sum / max(n_z, 1)) / S_MAX
    dual_inf, primal_inf = float(dual_inf), float(primal_inf)
    compl = float(max(compl_lower, compl_upper))
    compl_mu = max(compl_mu_lower, compl_mu_upper)
    return Errors(dual_inf, primal_inf, compl,
                  error=max(dual_inf / s_d, primal_inf, compl / s_c),
                  error_mu=max(dual_inf / s_d, primal_inf, compl_mu / s_c))


def numpy_error_reductions(dual, c, y, z_lower, z_upper, gap_lower, gap_upper, mu):
    """The sums and maxima :func:`optimality_errors` takes (its arguments):
    :math:`\\|y\\|_1`, :math:`\\|z_L\\|_1`, :math:`\\|z_U\\|_1`,
    :math:`\\|\\text{dual}\\|_\\infty`, :math:`\\|c\\|_\\infty`, the largest
    complementarity products :math:`z_L \\text{gap}_L` and :math:`z_U
    \\text{gap}_U` and their largest distances from ``mu`` (the maxima from
    0.0), as a tuple of nine floats."""
    compl_lower, compl_upper = z_lower * gap_lower, z_upper * gap_upper
    return (np.abs(y).sum(), np.abs(z_lower).sum(), np.abs(z_upper).sum(),
            np.abs(dual).max(initial=0.0), np.abs(c).max(initial=0.0),
            compl_lower.max(initial=0.0), compl_upper.max(initial=0.0),
            np.abs(compl_lower - mu).max(initial=0.0), np.abs(compl_upper - mu).max(initial=0.0))


def safeguard_multipliers(z_lower, z_upper, gap_lower, gap_upper, mu):
    """The bound multipliers clipped to :math:`[\\mu/(\\kappa_\\Sigma\\,
    \\text{gap}), \\kappa_\\Sigma\\mu/\\text{gap}]`: ``(z_lower, z_upper)``."""
    return (z_lower.clip(mu / (KAPPA_SIGMA * gap_lower), KAPPA_SIGMA * mu / gap_lower),
            z_upper.clip(mu / (KAPPA_SIGMA * gap_upper), KAPPA_SIGMA * mu / gap_upper))


def next_barrier(mu, settings):
    r"""The monotone (Fiacco-McCormick) update :math:`\max(\epsilon/(\kappa_\epsilon
    + 1), \min(\kappa_\mu\mu, \mu^{\theta_\mu}))`, :math:`\epsilon =
    \min(` ``tol``, ``compl_inf_tol`` :math:`)`, at least ``mu_min``."""
    s = settings
    floor = max(s.mu_min, min(s.tol, s.compl_inf_tol) / (s.barrier_tol_factor + 1.0))
    return max(floor, min(s.mu_linear_decrease_factor * mu,
                          mu ** s.mu_superlinear_decrease_power))
