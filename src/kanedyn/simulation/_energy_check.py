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
difference at states the integrator accepted (so output times, however
sparse, do not alias it), whose two energies give :math:`E` and :math:`V`
there as well (their mean).  These samples are taken where a panel of
:data:`_PANEL_STEPS` accepted steps ends (a piece of the solution starts
with a panel of one step; a drift projection, a terminal event and the end
of the run end a piece), and :math:`W` is integrated along the parabola
through the ends of each panel and of the one before.  Its error is
estimated by the drift of the trapezoidal rule from it (largest over the
run, :math:`U`).  The panels make the check cost a quarter of what a sample
at every step did (``docs/benchmarks.md``); the work's quadrature error
grows with the panel's length cubed, to about 1e-4 to 1e-2 of the energy
exchanged at the default tolerance, well inside the factor judged.  On the
compiled loop the same is computed in C (``_c_integrator.py``), which keeps
at most :data:`_KEPT_SAMPLES` samples (every second one dropped when full,
the last kept); on ``solve_ivp`` by :class:`WorkTracker`, which the guarded
solver calls after every step.

A run is judged at these samples (at most :data:`_KEPT_SAMPLES` of them,
evenly spread) by the energy it stores against the energy the balance
allows, both counted from the lowest potential energy :math:`V_{min}` there
(the kinetic energy, never negative, gives them a natural zero), with a
margin of :math:`kU` (:data:`WORK_ERROR_FACTOR`) for the work's error.  It
is flagged when either ratio leaves its side of :math:`F`
(:data:`ENERGY_FACTOR`):

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

import bisect
import warnings
from dataclasses import dataclass

import numpy as np

__all__ = ["ENERGY_FACTOR", "PADDING", "WORK_ERROR_FACTOR", "Balance", "TrustWarning",
           "WorkTracker", "balance_ratios", "stored_energy", "with_energy_note"]

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
#: accepted steps in a panel, at whose ends the balance is sampled (a piece's
#: first panel: one step; ``KD_WORK_PANEL`` of the compiled loop)
_PANEL_STEPS = 4
#: at most this many samples are judged (``KD_KEPT_SAMPLES`` of the compiled loop)
_KEPT_SAMPLES = 2048
_EXPLICIT = ("RK23", "RK45", "DOP853")


class TrustWarning(RuntimeWarning):
    """A run that ended with ``success=True`` whose result should not be trusted."""


@dataclass(frozen=True)
class Balance:
    """The energy balance of a run, sampled as the module's text says.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Times of the samples, s (the first: the start of the run).
    energy, potential : ndarray, shape (n,)
        Stored energy and potential energy there (0 where none is declared), J.
    work : ndarray, shape (n,)
        The work done on the model up to there, J.
    error : float
        The work's error estimate, J.
    flow : float
        The work of the power's magnitude over the run, J.
    """

    t: np.ndarray
    energy: np.ndarray
    potential: np.ndarray
    work: np.ndarray
    error: float
    flow: float


def stored_energy(model, t, y):
    """Kinetic plus declared potential energy at ``(t, y)``, J, and the potential."""
    kinetic, potential = model.energies(t, y)
    potential = potential if model.has_potential else 0.0
    return kinetic + potential, potential


def sample(model, t, y, f, delta, span):
    """``(P, E, V)`` at ``(t, y)``, derivative ``f`` there: :math:`dE/dt` along
    ``f``, W, the central difference over ``t -+ delta``, the times kept within
    ``span`` (inputs may be defined on the time span only; at its ends the
    quotient then holds half of the explicit time part of :math:`dE/dt`, for
    one step); the stored and the potential energy there, J, the means of the
    two (to ``delta`` squared)."""
    delta = abs(delta)
    step = delta * np.asarray(f)
    ahead, ahead_v = stored_energy(model, min(t + delta, max(span)), y + step)
    behind, behind_v = stored_energy(model, max(t - delta, min(span)), y - step)
    return (ahead - behind) / (2 * delta), 0.5 * (ahead + behind), 0.5 * (ahead_v + behind_v)


class WorkTracker:
    r"""The energy balance of the module's text, panel by panel on ``solve_ivp``.

    :meth:`step` is the guard's ``on_step``.  A panel ends after
    :data:`_PANEL_STEPS` accepted steps (one on a piece's first), or where the
    piece ends: the next step starts elsewhere (a restart after a drift
    projection), a terminal event (:meth:`stop`), the end of the run
    (:meth:`history`).  There the balance is sampled, and a record kept of
    the time, :math:`W`, :math:`P`, :math:`E`, :math:`V` and of the power over
    the panel, :math:`P = P_0 + \beta s + \gamma s^2`: the parabola through
    the ends of this panel and of the one before (the line on a piece's first
    panel), along which :math:`W` is integrated.  A restart whose time lies
    inside the last panel (the drift event's) cuts it there.
    """

    def __init__(self, model, t_span):
        self.model = model
        self.span = t_span
        # per record: time, work, power, stored and potential energy; the
        # power's coefficients over the panel that ends there
        self.t, self.w, self.p, self.e, self.v, self.beta, self.gamma = ([] for _ in range(7))
        self.y_record = None  # the state at the last record's time
        self.end = None  # (t, y, f, h) of the last step: the open panel's end
        self.steps = 0  # steps in the open panel
        self.piece = 0  # index of the record that starts the current piece
        self.drift = self.error = self.flow = 0.0
        self.broken = False  # an evaluation failed: no balance

    def _records(self):
        return self.t, self.w, self.p, self.e, self.v, self.beta, self.gamma

    def _safely(self, work, *args):
        """``work(*args)``; an evaluation that fails leaves the run without a
        balance (the run reports its own failures)."""
        with np.errstate(all="ignore"):
            try:
                work(*args)
            except Exception:  # noqa: BLE001
                self.broken = True

    def step(self, t_a, y_a, f_a, t_b, y_b, f_b):
        """Add the step from ``(t_a, y_a)`` to ``(t_b, y_b)`` (``f``: the
        derivatives there, ``None`` where the solver keeps none)."""
        if not self.broken and t_b != t_a:
            self._safely(self._step, t_a, y_a, f_a, t_b, y_b, f_b)

    def _step(self, t_a, y_a, f_a, t_b, y_b, f_b):
        last = self.end or ((self.t[-1], self.y_record) if self.t else None)
        if last is None or last[0] != t_a or not np.array_equal(last[1], y_a):
            self._end_panel()
            self._start(t_a, y_a, f_a, t_b - t_a)
        self.end = (t_b, y_b, f_b, t_b - t_a)
        self.steps += 1
        if self.steps >= (_PANEL_STEPS if len(self.t) - 1 > self.piece else 1):
            self._end_panel()

    def stop(self, t, y):
        """The run ends at ``(t, y)``, inside the last step (a terminal event)."""
        if not self.broken and self.t:
            self._safely(self._stop, t, y)

    def _stop(self, t, y):
        h = self.end[3] if self.end else t - self.t[-1]
        self._end_panel()
        if t != self.t[-1]:
            self._start(t, y, None, h)

    def _end_panel(self):
        """End the open panel at the last step's end (nothing if none is open)."""
        if not self.steps:
            return
        t_b, y_b, f_b, step = self.end
        f_b = self.model.rhs(t_b, y_b) if f_b is None else f_b
        p_b, e_b, v_b = sample(self.model, t_b, y_b, f_b, _DIFFERENCE * step, self.span)
        t_a, p_a, h = self.t[-1], self.p[-1], t_b - self.t[-1]
        gamma = 0.0
        if len(self.t) - 1 > self.piece:  # a panel before this one in the piece
            a = self.t[-2] - t_a
            gamma = ((p_b - p_a) / h - (self.p[-2] - p_a) / a) / (h - a)
            self.drift += gamma * h ** 3 / 6  # the trapezoidal rule minus the parabola
            self.error = max(self.error, abs(self.drift))
        beta = (p_b - p_a) / h - gamma * h
        self.flow += 0.5 * abs(h) * (abs(p_a) + abs(p_b))
        w_b = self.w[-1] + h * (p_a + h * (beta / 2 + h * gamma / 3))
        for record, value in zip(self._records(), (t_b, w_b, p_b, e_b, v_b, beta, gamma)):
            record.append(value)
        self.y_record, self.end, self.steps = y_b, None, 0

    def _start(self, t, y, f, h):
        """A new piece at ``(t, y)``; the panel that ran past ``t`` ends there
        (its power's coefficients kept for the times before ``t``)."""
        work = beta = gamma = 0.0
        if self.t:
            work = self._work_at(t)
            direction = float(np.sign(h))
            keep = bisect.bisect_left(self.t, direction * t, key=lambda v: direction * v)
            if keep < len(self.t):
                beta, gamma = self.beta[keep], self.gamma[keep]
            for record in self._records():
                del record[keep:]
        f = self.model.rhs(t, y) if f is None else f
        p, e, v = sample(self.model, t, y, f, _DIFFERENCE * h, self.span)
        self.piece, self.y_record = len(self.t), y
        for record, value in zip(self._records(), (t, work, p, e, v, beta, gamma)):
            record.append(value)

    def _work_at(self, time):
        """The work done up to ``time``, from the power polynomial of the panel that
        holds it (the records searched, not copied: a restart costs O(log n))."""
        t = self.t
        if len(t) < 2:
            return float(self.w[0])
        sign = 1.0 if t[-1] >= t[0] else -1.0
        k = bisect.bisect_right(t, sign * time, key=lambda v: sign * v) - 1
        k = min(max(k, 0), len(t) - 2)
        s = time - t[k]
        return float(self.w[k] + s * (self.p[k] + s * (self.beta[k + 1] / 2
                                                        + s * self.gamma[k + 1] / 3)))

    def history(self):
        """The run's :class:`Balance` (its open panel ended at the last step),
        or ``None`` when an evaluation failed."""
        if not self.broken:
            self._safely(self._end_panel)
        if self.broken or not self.t:
            return None
        return Balance(np.array(self.t), np.array(self.e), np.array(self.v), np.array(self.w),
                       self.error, self.flow)


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
    if not np.isfinite(y).all():
        k = int(np.argmin(np.all(np.isfinite(y), axis=0)))
        bad = [f"{name} = {v}" for name, v in zip(result.state_names, y[:, k])
               if not np.isfinite(v)]
        return (f"the state left the finite range at t={t[k]:.6g} s ({', '.join(bad)})"
                f"{_advice(method)}")
    balance = getattr(result, "_balance", None)
    if balance is None or balance.t.size < 2:
        return ""
    times, energy, potential, values = (balance.t, balance.energy, balance.potential,
                                        balance.work)
    if times.size > _KEPT_SAMPLES:  # evenly spread, the first and the last kept
        columns = np.linspace(0, times.size - 1, _KEPT_SAMPLES).astype(int)
        times, energy, potential, values = (a[columns] for a in (times, energy, potential,
                                                                 values))
    error, flow = float(balance.error), float(balance.flow)
    if np.any(np.isinf(energy)):
        k = int(np.argmax(np.isinf(energy)))
        return (f"the stored energy left the finite range at t={times[k]:.6g} s "
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
    return (f"the energy balance fails: at t={times[k]:.6g} s the model stores "
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
    name = method.split()[0] if isinstance(method, str) and method.strip() else ""
    if name in _EXPLICIT:
        return (f": the explicit method {name} did not resolve the dynamics (a stiff "
                "system?); use method='Radau' or 'BDF' (or 'Rosenbrock23' on a C model), "
                "or a tighter rtol")
    return ": the steps did not resolve the dynamics; use a tighter rtol and atol"
