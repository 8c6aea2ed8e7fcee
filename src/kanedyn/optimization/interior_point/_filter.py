r"""The filter line search's acceptance test (Waechter & Biegler 2006,
section 2.3), on the constraint violation :math:`\theta = \|c\|_1` and the
barrier function :math:`\varphi_\mu`.

A trial point at step :math:`\alpha` is refused when :math:`\theta >
\theta_{\max}` or the filter holds a pair it does not improve on.  When the
switching condition holds (:math:`\nabla\varphi^T d < 0` and
:math:`\alpha(-\nabla\varphi^T d)^{s_\varphi} > \delta\,\theta^{s_\theta}`)
and :math:`\theta \le \theta_{\min}`, the Armijo condition
:math:`\varphi(\alpha) \le \varphi + \eta_\varphi \alpha \nabla\varphi^T d`
decides; otherwise sufficient decrease in either measure,
:math:`\theta(\alpha) \le (1 - \gamma_\theta)\theta` or
:math:`\varphi(\alpha) \le \varphi - \gamma_\varphi\theta`.  An accepted
step for which the switching and Armijo conditions both hold is "f-type"
and leaves the filter as it is; after any other the filter takes the pair
:math:`((1 - \gamma_\theta)\theta, \varphi - \gamma_\varphi\theta)`.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["Filter"]

GAMMA_THETA = 1e-5
GAMMA_PHI = 1e-8
ETA_PHI = 1e-8
DELTA = 1.0
S_PHI = 2.3
S_THETA = 1.1
#: a relative margin for roundoff in the comparisons (IPOPT's Compare_le)
MARGIN = 10 * np.finfo(float).eps
_EPS = float(np.finfo(float).eps)


class Filter:
    """The filter of one barrier problem, and the acceptance test.

    Parameters
    ----------
    theta_start : float
        :math:`\\theta` at the starting point: :math:`\\theta_{\\max} =
        10^4 \\max(1, \\theta_0)`, :math:`\\theta_{\\min} = 10^{-4} \\max(1, \\theta_0)`.
    theta_max_factor : float
        :math:`10^4` above; the restoration phase's filter takes :math:`10^8`
        (IPOPT's ``resto.theta_max_fact``).
    """

    def __init__(self, theta_start, theta_max_factor=1e4):
        self.theta_max = theta_max_factor * max(1.0, theta_start)
        self.theta_min = 1e-4 * max(1.0, theta_start)
        self.reset()

    def reset(self):
        self._theta = np.empty(0)
        self._phi = np.empty(0)

    def add(self, theta, phi):
        self._theta = np.append(self._theta, (1 - GAMMA_THETA) * theta)
        self._phi = np.append(self._phi, phi - GAMMA_PHI * theta)

    def acceptable(self, theta, phi, reference_phi=None):
        """The pair ``(theta, phi)`` lies below :math:`\\theta_{\\max}` and
        outside the filter's forbidden region (no pair of the filter is
        improved on by neither measure; the roundoff margin relative to
        ``reference_phi``, by default ``phi``)."""
        if not (math.isfinite(theta) and math.isfinite(phi)) or theta > self.theta_max:
            return False
        margin = MARGIN * max(1.0, abs(phi if reference_phi is None else reference_phi))
        return not (self._theta.size and ((theta >= self._theta)
                                          & (phi >= self._phi + margin)).any())

    def smallest_step(self, theta, slope, fraction):
        r""":math:`\alpha_{\min}`: below it the line search gives up
        (``fraction``: IPOPT's ``alpha_min_frac``)."""
        if slope < 0:
            if theta <= self.theta_min:
                bound = min(GAMMA_THETA, GAMMA_PHI * theta / -slope,
                            DELTA * theta ** S_THETA / (-slope) ** S_PHI)
            else:
                bound = min(GAMMA_THETA, GAMMA_PHI * theta / -slope)
        else:
            bound = GAMMA_THETA
        return max(fraction * bound, _EPS)

    def switching(self, theta, slope, alpha):
        return slope < 0 and alpha * (-slope) ** S_PHI > DELTA * theta ** S_THETA

    def accepts(self, theta, phi, slope, alpha, trial_theta, trial_phi):
        """``(accepted, f_type)`` (f_type: the switching and Armijo
        conditions both hold) for the trial point ``(trial_theta, trial_phi)``
        at step ``alpha`` from ``(theta, phi)`` with :math:`\\nabla\\varphi^T d`
        = ``slope``."""
        if not self.acceptable(trial_theta, trial_phi, phi):
            return False, False
        margin = MARGIN * max(1.0, abs(phi))
        switching = self.switching(theta, slope, alpha)
        armijo = trial_phi - phi <= ETA_PHI * alpha * slope + margin
        if theta <= self.theta_min and switching:
            return armijo, True
        return (trial_theta <= (1 - GAMMA_THETA) * theta
                or trial_phi - phi <= -GAMMA_PHI * theta + margin), switching and armijo
