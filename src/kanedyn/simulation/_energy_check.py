r"""Whether a run's energy balance holds: the stored energy against the work done.

The stored energy :math:`E = T + V` (kinetic plus the model's declared
potential energy; :math:`V = 0` where none is declared) changes along an exact
solution by the work :math:`W` of everything :math:`E` does not hold: the
specified inputs, dissipation, forces given as loads without a declared
potential, and supports moved in time,

.. math:: E(t) - E(t_0) = W(t) = \int_{t_0}^{t} P\,dt, \qquad
          P = \frac{\partial E}{\partial t} + \frac{\partial E}{\partial y} f(t, y).

:math:`P` needs no knowledge of the forces: it is the rate of change of
:math:`E` along the model's own right-hand side :math:`f`, a central
difference at the end of every step the integrator accepts (so output times,
however sparse, do not alias it), and :math:`W` is its integral along the
parabola through the ends of each step and of the one before.  Its error is
estimated by the drift of the trapezoidal rule from it (largest over the run,
:math:`U`).  On the compiled loop the same is computed in C
(``_c_integrator.py``); on ``solve_ivp`` by :class:`WorkTracker`, which the
guarded solver calls after every step.

A run is judged at its output times (at most :data:`_JUDGED_POINTS` of them)
by the energy it stores against the energy the balance allows, both counted
from the lowest potential energy :math:`V_{min}` at those times (the kinetic
energy, never negative, gives them a natural zero), with a margin of
:math:`kU` (:data:`WORK_ERROR_FACTOR`) for the work's error.  It is flagged
when either ratio leaves its side of :math:`F` (:data:`ENERGY_FACTOR`):

.. math:: \frac{E(t) - V_{min} + \bar S}{\max(E(t_0) + W(t) + kU - V_{min}, 0) + \bar S}
          > F, \qquad
          \frac{E(t) - V_{min} + pS}{\max(E(t_0) + W(t) - kU - V_{min}, 0) + pS}
          < \frac1F,

with :math:`S` the largest energy the balance allows during the run,
:math:`\bar S = \max(S, \int |P|\,dt)` (a gain is judged against the energy
that flowed in and out through the work as well: an explicit method at its
stability limit on a stiffly damped model pumps energy into a stiff mode that
the damper burns, which makes the work, not the stored energy, wrong) and
:math:`p` = :data:`PADDING` (a loss is judged where the balance leaves
something to lose).  A flagged run keeps ``success=True``; its message says so
and a :class:`TrustWarning` is issued, whatever the method and its step
options.  So is a successful run whose state is not finite or whose stored
energy overflows (a stored energy that is not defined, ``nan`` where an input
it needs is not given, is not judged).  Where conservative forces are given as
loads without a potential, :math:`W` carries their whole exchange of energy,
its error estimate grows with it, and the check is correspondingly weaker.
"""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["ENERGY_FACTOR", "PADDING", "WORK_ERROR_FACTOR", "TrustWarning", "WorkTracker",
           "balance_ratios", "stored_energy", "with_energy_note"]

#: the factor by which the stored energy may differ from what the energy balance
#: allows before a run is flagged, either way (the evidence: docs/trust.md)
ENERGY_FACTOR = 10.0
#: the padding of both energies where a loss is judged, as a fraction of the
#: largest energy the balance allows during the run
PADDING = 0.05
#: the margin given to the work for its quadrature error, in multiples of the
#: error estimate
WORK_ERROR_FACTOR = 4.0
#: the half width of the central difference of the power, as a fraction of the
#: integrator's step (``KD_POWER_STEP`` of the compiled loop)
_DIFFERENCE = 1e-4
#: at most this many output times are judged (evenly spread, first and last kept)
_JUDGED_POINTS = 2000
_EXPLICIT = ("RK23", "RK45", "DOP853")


class TrustWarning(RuntimeWarning):
    """A run that ended with ``success=True`` whose result should not be trusted."""


def stored_energy(model, t, y):
    """Kinetic plus declared potential energy at ``(t, y)``, J, and the potential."""
    kinetic, potential = model.energies(t, y)
    potential = potential if model.has_potential else 0.0
    return kinetic + potential, potential


def power(model, t, y, f, delta, span):
    """:math:`dE/dt` along the right-hand side ``f`` at ``(t, y)``, W: the central
    difference over ``t -+ delta``, the times kept within ``span`` (inputs may
    be defined on the time span only; at its ends the quotient then holds half
    of the explicit time part of :math:`dE/dt`, for one step)."""
    delta = abs(delta)
    step = delta * np.asarray(f)
    ahead = stored_energy(model, min(t + delta, max(span)), y + step)[0]
    behind = stored_energy(model, max(t - delta, min(span)), y - step)[0]
    return (ahead - behind) / (2 * delta)


class WorkTracker:
    r"""The work :math:`W` of the module docstring, step by step on ``solve_ivp``.

    :meth:`step` is the guard's ``on_step``.  Per accepted step it records the
    time, :math:`W` and :math:`P` at its end, and the power over the step,
    :math:`P = P_0 + \beta s + \gamma s^2`: the parabola through the ends of
    this step and of the one before (the line on a piece's first step), along
    which :math:`W` is integrated.  A step that does not start where the last
    one ended (a restart after a drift projection, whose time lies inside the
    last step) starts a new piece there.
    """

    def __init__(self, model, t_span):
        self.model = model
        self.span = t_span
        # per record: time, work and power; the power's coefficients over the
        # step that ends there (from the record before)
        self.t, self.w, self.p, self.beta, self.gamma = [], [], [], [], []
        self.y_end = None
        self.piece = 0  # index of the record that starts the current piece
        self.drift = self.error = self.flow = 0.0
        self.broken = False  # an evaluation failed: no work history

    def step(self, t_a, y_a, f_a, t_b, y_b, f_b):
        """Add the step from ``(t_a, y_a)`` to ``(t_b, y_b)`` (``f``: the
        derivatives there, ``None`` where the solver keeps none)."""
        if self.broken or t_b == t_a:
            return
        h = t_b - t_a
        with np.errstate(all="ignore"):
            try:
                if not self.t or self.t[-1] != t_a or not np.array_equal(self.y_end, y_a):
                    self._restart(t_a, y_a, f_a, h)
                f_b = self.model.rhs(t_b, y_b) if f_b is None else f_b
                p_b = power(self.model, t_b, y_b, f_b, _DIFFERENCE * h, self.span)
            except Exception:  # noqa: BLE001  (the run reports its own failures)
                self.broken = True
                return
            p_a, gamma = self.p[-1], 0.0
            if len(self.t) - 1 > self.piece:  # a step before this one in the piece
                a = self.t[-2] - t_a
                gamma = ((p_b - p_a) / h - (self.p[-2] - p_a) / a) / (h - a)
                self.drift += gamma * h ** 3 / 6  # the trapezoidal rule minus the parabola
                self.error = max(self.error, abs(self.drift))
            beta = (p_b - p_a) / h - gamma * h
        self.w.append(self.w[-1] + h * (p_a + h * (beta / 2 + h * gamma / 3)))
        self.flow += 0.5 * abs(h) * (abs(p_a) + abs(p_b))
        self.t.append(t_b)
        self.p.append(p_b)
        self.beta.append(beta)
        self.gamma.append(gamma)
        self.y_end = y_b

    def _restart(self, t, y, f, h):
        """A new piece at ``(t, y)``; the step that ran past ``t`` ends there (its
        power's coefficients kept for the times before ``t``)."""
        work = beta = gamma = 0.0
        if self.t:
            work = float(self._work_at(np.array([t]))[0])
            keep = int(np.searchsorted(np.sign(h) * np.array(self.t), np.sign(h) * t))
            if keep < len(self.t):
                beta, gamma = self.beta[keep], self.gamma[keep]
            for record in (self.t, self.w, self.p, self.beta, self.gamma):
                del record[keep:]
        f = self.model.rhs(t, y) if f is None else f
        self.piece = len(self.t)
        for record, value in ((self.t, t), (self.w, work), (self.beta, beta), (self.gamma, gamma),
                              (self.p, power(self.model, t, y, f, _DIFFERENCE * h, self.span))):
            record.append(value)

    def _work_at(self, times):
        t, w, p, beta, gamma = (np.array(v) for v in (self.t, self.w, self.p, self.beta,
                                                       self.gamma))
        times = np.asarray(times, dtype=float)
        if t.size < 2:
            return np.full(times.shape, w[0])
        sign = 1.0 if t[-1] >= t[0] else -1.0
        k = np.clip(np.searchsorted(sign * t, sign * times, side="right") - 1, 0, t.size - 2)
        s = times - t[k]
        return w[k] + s * (p[k] + s * (beta[k + 1] / 2 + s * gamma[k + 1] / 3))

    def history(self, times):
        """``(work, error, flow)``: the work at ``times``, its error estimate
        and the work of the power's magnitude over the run, J; ``None`` when an
        evaluation failed."""
        if self.broken or not self.t:
            return None
        return self._work_at(times), self.error, self.flow


def with_energy_note(result, method):
    """``result``, its message extended (and a :class:`TrustWarning` issued) when
    a successful run fails the energy balance or leaves the finite range."""
    note = energy_note(result, method)
    if note:
        warnings.warn(note, TrustWarning, stacklevel=3)
        result.__dict__["message"] = f"{result.message}; warning: {note}"
    return result


def energy_note(result, method):
    """Why a successful run cannot be trusted, or ``""`` (see the module docstring)."""
    t, y = result.t, result.y
    if not result.success or t.size == 0:
        return ""
    finite = np.all(np.isfinite(y), axis=0)
    if not finite.all():
        k = int(np.argmin(finite))
        bad = [f"{name} = {v}" for name, v in zip(result.state_names, y[:, k])
               if not np.isfinite(v)]
        return (f"the state left the finite range at t={t[k]:.6g} s ({', '.join(bad)})"
                f"{_advice(method)}")
    work = getattr(result, "_work", None)
    if t.size < 2 or work is None:
        return ""
    columns = np.unique(np.linspace(0, t.size - 1, min(t.size, _JUDGED_POINTS)).astype(int))
    energy, potential = np.empty(columns.size), np.empty(columns.size)
    with np.errstate(all="ignore"):
        for j, k in enumerate(columns):
            energy[j], potential[j] = stored_energy(result.model, t[k], y[:, k])
    values = np.asarray(work[0], dtype=float)[columns]
    error, flow = float(work[1]), float(work[2])
    if np.any(np.isinf(energy)):
        k = int(np.argmax(np.isinf(energy)))
        return (f"the stored energy left the finite range at t={t[columns[k]]:.6g} s "
                f"({energy[k]} J){_advice(method)}")
    if not np.all(np.isfinite(energy)):  # not defined (an input it needs is not given)
        return ""
    if not (np.all(np.isfinite(values)) and np.isfinite(error) and np.isfinite(flow)):
        return ""
    high, low = balance_ratios(energy, potential, values, error, flow)
    k_high, k_low = int(np.argmax(high)), int(np.argmin(low))
    if high[k_high] > ENERGY_FACTOR:
        k = k_high
    elif low[k_low] < 1 / ENERGY_FACTOR:
        k = k_low
    else:
        return ""
    return (f"the energy balance fails: at t={t[columns[k]]:.6g} s the model stores "
            f"{energy[k]:.6g} J, where its initial energy ({energy[0]:.6g} J) and the work "
            f"done on it ({values[k]:+.6g} J) give {energy[0] + values[k]:.6g} J: off by "
            f"more than a factor of {ENERGY_FACTOR:g} (docs/trust.md){_advice(method)}")


def balance_ratios(energy, potential, work, error, flow):
    """The two ratios of the module docstring at each judged point.

    Parameters
    ----------
    energy, potential, work : ndarray, shape (n,)
        Stored energy, potential energy and the work done on the model up to
        each judged point (the first: the start of the run), J.
    error : float
        The work's error estimate, J.
    flow : float
        The work of the power's magnitude over the run, J.

    Returns
    -------
    high, low : ndarray, shape (n,)
        The stored energy over the most and over the least the balance allows
        (a run is flagged where ``high > ENERGY_FACTOR`` or
        ``low < 1 / ENERGY_FACTOR``).
    """
    floor = np.min(potential)
    stored = energy - floor
    allowed = energy[0] + work - floor
    margin = WORK_ERROR_FACTOR * error
    scale = max(np.max(allowed), stored[0], 1e-9 * np.max(np.abs(energy)), 1e-300)
    above = max(scale, flow)
    high = (stored + above) / (np.maximum(allowed + margin, 0.0) + above)
    pad = PADDING * scale
    low = (stored + pad) / (np.maximum(allowed - margin, 0.0) + pad)
    return high, low


def _advice(method):
    """What to do about it, for ``method`` (a name, perhaps with " (compiled)")."""
    name = (method or "").split()[0] if isinstance(method, str) else ""
    if name in _EXPLICIT:
        return (f": the explicit method {name} did not resolve the dynamics (a stiff "
                "system?); use method='Radau' or 'BDF' (or 'Rosenbrock23' on a C model), "
                "or a tighter rtol")
    return ": the steps did not resolve the dynamics; use a tighter rtol and atol"
