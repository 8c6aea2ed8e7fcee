r"""The bounds of the primal vector :math:`w = (x, s)` (free variables, then
the inequality rows' slacks) and what the barrier makes of them.

The barrier function of the scaled problem, with :math:`\mu` the barrier
parameter and :math:`\kappa_d` IPOPT's damping of the variables bounded on
one side only,

.. math::

    \varphi_\mu(w) = f(x) - \mu \sum_{i \in L} \ln(w_i - w_{L,i})
                          - \mu \sum_{i \in U} \ln(w_{U,i} - w_i)
                   + \kappa_d \mu \Bigl(\sum_{i \in L \setminus U} (w_i - w_{L,i})
                                       + \sum_{i \in U \setminus L} (w_{U,i} - w_i)\Bigr).
"""

from __future__ import annotations

import numpy as np

from ._reduced import compact_index_type
from .kkt._diagonal import DiagonalEntries

__all__ = ["PrimalBounds", "fraction_to_boundary"]


class PrimalBounds:
    """Bounds of ``w`` (length ``size``), infinite where absent, relaxed by
    ``relax`` (IPOPT's ``bound_relax_factor``: each finite bound moved out
    by ``relax * max(1, |bound|)``).

    Attributes
    ----------
    lower_index, upper_index : ndarray of int
        The entries with a finite lower / upper bound (``int32`` where
        ``size`` allows).
    lower, upper : ndarray
        Those bounds (relaxed), shapes as the index arrays (a read-only
        broadcast of one number where every entry has the same).
    """

    def __init__(self, lower, upper, relax, kappa_d):
        lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
        self.size = lower.size
        has_lower, has_upper = np.isfinite(lower), np.isfinite(upper)
        index = compact_index_type(self.size)
        self.lower_index = np.flatnonzero(has_lower).astype(index)
        self.upper_index = np.flatnonzero(has_upper).astype(index)
        if np.array_equal(self.upper_index, self.lower_index):  # (one array, read only)
            self.upper_index = self.lower_index
            self._bounded = None  # the entries bounded on either side: lower_index
        else:  # those entries, and where each bound's are among them
            self._bounded = np.union1d(self.lower_index, self.upper_index).astype(index)
            self._lower_at = np.searchsorted(self._bounded, self.lower_index).astype(index)
            self._upper_at = np.searchsorted(self._bounded, self.upper_index).astype(index)
        lo, up = lower[has_lower], upper[has_upper]
        self.lower = _held(lo - relax * np.maximum(1.0, np.abs(lo)))
        self.upper = _held(up + relax * np.maximum(1.0, np.abs(up)))
        self.kappa_d = kappa_d
        # the damped entries (bounded on one side only), in w and among the bounds'
        lower_only, upper_only = has_lower & ~has_upper, has_upper & ~has_lower
        self._damped_lower = np.flatnonzero(lower_only)
        self._damped_upper = np.flatnonzero(upper_only)
        self._one_sided_lower = np.flatnonzero(lower_only[self.lower_index])
        self._one_sided_upper = np.flatnonzero(upper_only[self.upper_index])

    def gaps(self, w):
        """``(w - w_L, w_U - w)`` on the bounded entries."""
        return w[self.lower_index] - self.lower, self.upper - w[self.upper_index]

    def barrier(self, objective, gap_lower, gap_upper, mu):
        r""":math:`\varphi_\mu` from the objective and the gaps (a gap that is not
        positive gives NaN or infinity: the solver runs under
        ``np.errstate(all="ignore")`` and tests for them)."""
        logs = np.log(gap_lower).sum() + np.log(gap_upper).sum()
        if self._one_sided_lower.size or self._one_sided_upper.size:
            damping = self.kappa_d * (gap_lower[self._one_sided_lower].sum()
                                      + gap_upper[self._one_sided_upper].sum())
        else:  # the same: both sums would be 0.0
            damping = self.kappa_d * 0.0
        return objective - mu * logs + mu * damping

    def barrier_gradient(self, gradient_w, gap_lower, gap_upper, mu):
        r""":math:`\nabla \varphi_\mu` from the objective's gradient in ``w``
        (zero in the slacks)."""
        # + mu kappa_d on the lower-only entries, - on the upper-only ones, + 0.0
        # elsewhere (the sums of a full damping vector's, a zero's sign too)
        out = gradient_w + 0.0
        damping = mu * self.kappa_d
        out[self._damped_lower] += damping
        out[self._damped_upper] -= damping
        out[self.lower_index] -= mu / gap_lower
        out[self.upper_index] += mu / gap_upper
        return out

    def sigma(self, z_lower, z_upper, gap_lower, gap_upper):
        r""":math:`\Sigma = Z_L (W - W_L)^{-1} + Z_U (W_U - W)^{-1}` of the
        ``size`` entries, a :class:`~.kkt._diagonal.DiagonalEntries` (its
        values at the bounded entries alone: the sums of an array of every
        entry, without it)."""
        if self._bounded is None:
            values = z_lower / gap_lower
            values += z_upper / gap_upper
            return DiagonalEntries(self.lower_index, values, self.size)
        values = np.zeros(self._bounded.size)
        values[self._lower_at] = z_lower / gap_lower
        values[self._upper_at] += z_upper / gap_upper
        return DiagonalEntries(self._bounded, values, self.size)

    def step_lengths(self, z_lower, z_upper, gap_lower, gap_upper, dw, mu, tau):
        r"""The bound multipliers' Newton steps of :math:`z\,\text{gap} = \mu`
        along the primal step ``dw`` and the fractions to the boundary:
        ``(dz_lower, dz_upper, alpha_primal_max, alpha_dual)``."""
        dw_lower, dw_upper = dw[self.lower_index], dw[self.upper_index]
        dz_lower = (mu - z_lower * gap_lower - z_lower * dw_lower) / gap_lower
        dz_upper = (mu - z_upper * gap_upper + z_upper * dw_upper) / gap_upper
        alpha_max = min(fraction_to_boundary(gap_lower, dw_lower, tau),
                        fraction_to_boundary(gap_upper, -dw_upper, tau))
        alpha_z = min(fraction_to_boundary(z_lower, dz_lower, tau),
                      fraction_to_boundary(z_upper, dz_upper, tau))
        return dz_lower, dz_upper, alpha_max, alpha_z

    def dense(self, start=0):
        """``(lower, upper)`` of the entries from ``start`` on, relaxed,
        infinite where absent, shapes (size - start,)."""
        lower = np.full(self.size - start, -np.inf)
        upper = np.full(self.size - start, np.inf)
        for out, index, values in ((lower, self.lower_index, self.lower),
                                   (upper, self.upper_index, self.upper)):
            at = index >= start
            out[index[at] - start] = values[at]
        return lower, upper

    def push(self, w, push, frac):
        """``w`` moved into the bounds' interior (IPOPT's ``bound_push`` and
        ``bound_frac``: at least ``min(push * max(1, |bound|), frac * (upper -
        lower))`` from each bound), computed on the bounded entries alone."""
        w = np.array(w, dtype=float)
        i, j = self.lower_index, self.upper_index
        # the width of each bounded entry (infinite where it has one bound)
        upper_at_i = _values_at(i, j, self.upper, np.inf)
        lower_at_j = _values_at(j, i, self.lower, -np.inf)
        with np.errstate(invalid="ignore"):
            p_lower = np.minimum(push * np.maximum(1.0, np.abs(self.lower)),
                                 frac * (upper_at_i - self.lower))
            p_upper = np.minimum(push * np.maximum(1.0, np.abs(self.upper)),
                                 frac * (self.upper - lower_at_j))
        w[i] = np.maximum(w[i], self.lower + p_lower)
        w[j] = np.minimum(w[j], self.upper - p_upper)
        return w


def _held(values):
    """``values``, or a read-only broadcast of their one value when they are
    all the same to the bit (a bound on an input at every node: no array of
    it)."""
    bits = values.view(np.int64)
    if values.size > 1 and (bits == bits[0]).all():
        return np.broadcast_to(values[:1].copy(), values.shape)
    return values


def _values_at(index, other_index, other_values, absent):
    """``other_values`` (of the entries ``other_index``) at the entries
    ``index``, ``absent`` where ``other_index`` lacks one (both sorted)."""
    place = np.searchsorted(other_index, index)
    found = place < other_index.size
    found[found] = other_index[place[found]] == index[found]
    out = np.full(index.size, absent)
    out[found] = other_values[place[found]]
    return out


def fraction_to_boundary(values, steps, tau):
    r"""The largest :math:`\alpha \in (0, 1]` with :math:`v + \alpha\,\Delta v
    \ge (1 - \tau) v` for positive ``values`` :math:`v` and ``steps``
    :math:`\Delta v` (called under the solver's ``np.errstate``)."""
    if not steps.size:
        return 1.0
    fastest = float((steps / values).min())
    return 1.0 if not fastest < -tau else -tau / fastest
