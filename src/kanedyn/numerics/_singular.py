r"""Singular configurations: where the constraint Jacobian loses rank, and a run's monitor.

A closed chain is *singular* where the Jacobian of its constraints loses rank:
the mechanism gains degrees of freedom for an instant (a four-bar linkage
folded flat, the cranks of a parallelogram linkage lying along the ground),
branches of its motion meet, and every scheme that solves the constraints for
dependent speeds or for multipliers divides by a vanishing number.  kanedyn
measures the distance to such a position by the ratio

.. math::

    \rho(t, y) = \sigma_{\min}/\sigma_{\max}

of the smallest to the largest singular value of the velocity-constraint
matrix :math:`B = \partial c/\partial u`, which holds the holonomic
constraints as the derivatives of the configuration constraints
(:meth:`kanedyn.NumericModel.constraint_conditioning`).  :math:`\rho = 0` at a
singular position; :math:`1/\rho` is the condition number of the constraints.

:class:`SingularityMonitor` finds, during :func:`kanedyn.simulate`, the times of
closest approach: an event function is the rate of change of :math:`\rho`
along the motion (a central difference along :math:`\dot q`), and a root where
it turns from negative to positive is a local minimum of :math:`\rho`, however
narrow the dip and however long the integrator's step.  The compiled
integration loop does the same in C as it goes (its steps cost less than a
Python event call): it screens each step with a bound on :math:`\rho` from the
constraint matrix at its ends, and examines only the steps that may dip below
the threshold, so that a run keeps only the minima it found.  Minima below the
threshold are reported in the result's message and by a
:class:`~kanedyn.SingularConfigurationWarning`.
"""

from __future__ import annotations

import bisect
import warnings

import numpy as np

from .._errors import SingularConfigurationWarning

__all__ = ["conditioning", "SingularityMonitor", "DEFAULT_THRESHOLD"]

#: Default threshold of :math:`\sigma_{\min}/\sigma_{\max}` below which a run is
#: said to pass near a singular configuration (a condition number above 1000).
DEFAULT_THRESHOLD = 1e-3

_LISTED = 8  # passages named one by one in the message
# a change of the ratio over the central difference below this is round-off, not an
# approach (a rigid motion keeps the ratio constant: its rate is noise of either sign,
# which would make event roots appear and vanish between a step and its interpolant)
_NOISE = 1e-12

#: What the note of a run that passed near a singular configuration recommends.
ADVICE = ("the constraints lose rank there, so the motion may have jumped to another "
          "branch or stopped; a scheme that passes such positions on the branch the "
          "motion follows: kanedyn.schemes.AugmentedLagrangianIndex3 "
          "(method='augmented-lagrangian-index3')")


def _ratios(B):
    """``sigma_min / sigma_max`` of each matrix of a stack, shape (k, m, o) -> (k,)."""
    s = np.linalg.svd(B, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(s[..., 0] > 0, s[..., -1] / s[..., 0], 0.0)


def _velocity_matrix(model, t, y):
    """The velocity-constraint matrix :math:`B = \\partial c/\\partial u`, shape (m, o)."""
    B = model._constraint_terms(t, y)[2]
    return np.asarray(B, dtype=float).reshape(model.n_u_dep, model.n_u)


def conditioning(model, t, y):
    r""":math:`\sigma_{\min}/\sigma_{\max}` of the constraint Jacobian at a state.

    The matrix is the velocity-constraint matrix :math:`B = \partial
    c/\partial u` (m x o): it holds every constraint, holonomic ones as the
    time derivatives of the configuration constraints (:math:`B =
    \partial h/\partial q\;\partial\dot q/\partial u`), so it loses rank
    where the configuration-constraint Jacobian does.

    Parameters
    ----------
    model : NumericModel
    t : float
    y : ndarray, shape (n_states,)

    Returns
    -------
    float
        0 where the constraints have lost rank; ``nan`` when :math:`B` is not
        finite.

    Raises
    ------
    ValueError
        When the model has no velocity constraints.
    """
    if not model.n_u_dep:
        raise ValueError("the model has no constraints, hence no constraint Jacobian")
    B = _velocity_matrix(model, t, y)
    if not np.isfinite(B.sum()):
        return float("nan")
    return float(_ratios(B))


class SingularityMonitor:
    """Times at which a run passes near singular configurations.

    Parameters
    ----------
    model : NumericModel
    threshold : float or None
        Report minima of :math:`\\sigma_{\\min}/\\sigma_{\\max}` below this
        value (0 < threshold < 1); ``None`` switches the monitor off.
    displacement : float
        Largest change of a coordinate in the central difference that gives
        the rate of the ratio (rad or m).
    direction : {1.0, -1.0}
        The direction of integration in time: a minimum is where the rate
        turns from negative to positive forward in time, from positive to
        negative backward.

    Attributes
    ----------
    events : list of callable
        The event function to add to the integrator's events (empty when the
        monitor is off or the model has no constraints).
    passages : list of (float, float)
        ``(t, ratio)`` of every minimum found below the threshold, in time order.
    """

    def __init__(self, model, threshold=DEFAULT_THRESHOLD, displacement=1e-7, direction=1.0):
        if threshold is not None and not 0.0 < float(threshold) < 1.0:
            raise ValueError(f"singular_threshold must be between 0 and 1 (a ratio of "
                             f"singular values) or None, got {threshold!r}")
        self.model = model
        self.threshold = None if threshold is None else float(threshold)
        self.displacement = float(displacement)
        self.passages = []
        active = (self.threshold is not None and hasattr(model, "_constraint_terms")
                  and model.n_u_dep > 0)

        def approach(t, y):
            return self._rate(t, y)
        # the ratio stops falling and starts rising: a minimum (events see the
        # function's values in the order of integration)
        approach.direction = 1.0 if direction >= 0 else -1.0
        approach.terminal = False
        self.events = [approach] if active else []

    @property
    def active(self):
        return bool(self.events)

    def ratio(self, t, y):
        """:func:`conditioning` at a state."""
        return conditioning(self.model, t, y)

    def _rate(self, t, y):
        """Rate of change of the ratio along the motion (1/s), never exactly zero."""
        model = self.model
        y = np.array(y, dtype=float)
        n = model.n_q
        qdot = y[n:] if getattr(model, "rates_are_speeds", False) else model._dynamics(t, y)[0]
        speed = np.abs(qdot).max() if np.isfinite(qdot).all() else 0.0
        if not speed > 0.0:
            return 1.0  # at rest: not approaching anything
        dt = self.displacement / speed
        ahead, behind = y.copy(), y.copy()
        ahead[:n] += dt * qdot
        behind[:n] -= dt * qdot
        pair = np.stack([_velocity_matrix(model, t + dt, ahead),
                         _velocity_matrix(model, t - dt, behind)])
        if not np.isfinite(pair.sum()):
            return 1.0
        r_ahead, r_behind = _ratios(pair)
        if abs(r_ahead - r_behind) <= _NOISE:  # the ratio does not change: no approach
            return 1.0
        return (r_ahead - r_behind) / (2.0 * dt)

    def collect(self, t_events, y_events):
        """Record the minima among event roots ``t_events`` (states ``y_events``)."""
        t_events = np.atleast_1d(np.asarray(t_events, dtype=float))
        if not t_events.size:
            return
        y_events = np.asarray(y_events, dtype=float).reshape(t_events.size, -1)
        for t, y in zip(t_events, y_events):
            self._record(float(t), y)

    def _record(self, t, y):
        """Keep a minimum below the threshold; minima within 1e-6 s (relative) merge."""
        r = self.ratio(t, y)
        if not (np.isfinite(r) and r < self.threshold):
            return
        k = bisect.bisect_left(self.passages, t, key=lambda passage: passage[0])
        for near in (k - 1, k):  # the neighbours in time
            if 0 <= near < len(self.passages):
                s, r_s = self.passages[near]
                if abs(t - s) <= 1e-6 * max(1.0, abs(t)):
                    if r < r_s:
                        self.passages[near] = (t, r)
                    return
        self.passages.insert(k, (t, r))

    def finish(self, message, t0, y0, t_end, y_end, stacklevel=3, advice=None):
        """The run's message with the passages added; warns when there are any.

        The first and last states count as well when the ratio there is below
        the threshold (a run that starts at, or stops near, a singular
        position); ``y0`` or ``y_end`` ``None``: not counted (the compiled
        loop counts them itself).  ``stacklevel`` as for :func:`warnings.warn`,
        counted from this method (3: the caller of the function that calls
        it); ``advice`` replaces the closing sentence of the note (what to do
        about it).

        Returns
        -------
        str
        """
        if not self.active:
            return message
        if y0 is not None:
            self._record(float(t0), np.asarray(y0, dtype=float))
        if y_end is not None and np.all(np.isfinite(y_end)):
            self._record(float(t_end), np.asarray(y_end, dtype=float))
        if not self.passages:
            return message
        times = [t for t, _ in self.passages]
        ratios = [r for _, r in self.passages]
        more = len(times) - _LISTED
        note = ("passed near a singular configuration at t = "
                + ", ".join(_distinct_text(times[:_LISTED]))
                + (f" and {more} more time(s)" if more > 0 else "") + " s "
                "(smallest/largest singular value of the constraint Jacobian "
                + ", ".join(f"{r:.2g}" for r in ratios[:_LISTED])
                + f", below {self.threshold:g}): " + (advice or ADVICE))
        warnings.warn(SingularConfigurationWarning(note, times, ratios),
                      stacklevel=stacklevel)
        return f"{message.rstrip('.')}; {note}"


def _distinct_text(times):
    """``times`` printed with 6 significant digits, or as many more (up to 15) as
    it takes for distinct times to read differently (two minima microseconds
    apart)."""
    for digits in range(6, 16):
        texts = [f"{t:.{digits}g}" for t in times]
        if len(set(texts)) == len(set(times)):
            break
    return texts
