r"""Simulation on SciPy's ``solve_ivp`` with constraint handling.

* Initial conditions are made consistent: dependent coordinates by Newton's
  method, dependent speeds from the velocity constraints.
* Constraint drift is projected away: a terminal event fires when the largest
  constraint residual exceeds ``projection_tol``; the state is projected back
  (same partition as above) and integration restarts from there.
* A failure (non-finite derivative, singular matrix, step-size collapse) ends
  the run with ``success=False`` and a message; everything computed up to that
  point is returned.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from ._errors import ModelError
from ._progress import as_progress
from ._results import SimulationResult
from ._singular import DEFAULT_THRESHOLD, SingularityMonitor

__all__ = ["simulate"]


class _Integrand:
    """``rhs`` wrapper: counts, progress, and non-finite results as data."""

    def __init__(self, model, t_span, progress):
        self.model = model
        self.failure = None
        self.progress = progress
        self.t0, self.t1 = t_span
        self.n = model.n_states

    def __call__(self, t, y):
        try:
            out = self.model.rhs(t, y)
        except np.linalg.LinAlgError as exc:
            if self.failure is None:
                self.failure = f"singular system at t={t:.6g} ({exc})"
            return np.full(self.n, np.nan)
        if not np.all(np.isfinite(out)):
            if self.failure is None:
                bad = [self.model.state_names[i] for i in np.flatnonzero(~np.isfinite(out))]
                self.failure = (f"non-finite derivative of {', '.join(bad)} at "
                                f"t={t:.6g}")
        if self.progress.enabled and self.t1 != self.t0:
            self.progress.update("simulating", (t - self.t0) / (self.t1 - self.t0))
        return out


def _drift_event(model, tol):
    def drift(t, y):
        return tol - np.max(np.abs(model.constraint_residuals(t, y)))
    drift.terminal = True
    drift.direction = -1
    return drift


COMPILED_METHODS = ("RK45", "Rosenbrock23")
_COMPILED_OPTIONS = {"max_step", "first_step"}


def simulate(model, t_span, y0, *, method="RK45", t_eval=None, rtol=1e-8, atol=1e-8,
             events=None, dense_output=False, project=None, projection_tol=None,
             constraint_forces=False, progress=False, backend=None,
             singular_threshold=DEFAULT_THRESHOLD, **options):
    """Integrate a :class:`NumericModel` with SciPy's ``solve_ivp``.

    Parameters
    ----------
    model : NumericModel
    t_span : (float, float)
        Start and end time, s.
    y0 : array_like or dict
        Initial state ``[q, u]``, or ``{symbol or name: value}`` giving at
        least every independent coordinate and speed.  Dependent values are
        starting guesses; they are corrected to satisfy the constraints.
    method : str or OdeSolver
        Any ``solve_ivp`` method (``"RK45"``, ``"DOP853"``, ``"Radau"``,
        ``"BDF"``, ``"LSODA"``, ...).
    t_eval : array_like, optional
        Output times; default: the integrator's steps.
    rtol, atol : float
        Integration tolerances.
    events : callable or list of callables, optional
        ``event(t, y)`` functions with optional ``terminal`` and ``direction``
        attributes, exactly as for ``solve_ivp``.
    dense_output : bool
        Keep a continuous solution (``result.sol(t)``).
    project : bool, optional
        Project constraint drift back onto the constraint manifold (systems
        with dependent coordinates or speeds), as the model's constraint
        scheme does it (:meth:`kanedyn.schemes.Scheme.project_state`).
        Default: the scheme's choice (Kane's elimination, projection and
        coordinate partitioning project; index-1, Baumgarte, penalty,
        augmented-Lagrangian, Udwadia–Kalaba and null-space schemes do not).
    projection_tol : float, optional
        Residual that triggers a projection; default ``max(100 * atol, 1e-10)``.
    constraint_forces : bool
        Evaluate the constraint forces at every output time (``result["T"]``
        etc.): those exposed by auxiliary speeds and those identified by
        vector constraints (see :meth:`NumericModel.constraint_forces`).
    progress : bool
        Show progress on stderr.
    backend : {None, "scipy", "c"}
        ``"c"``: the compiled integration loop of a ``backend="c"`` model
        (methods ``"RK45"``, the same algorithm as SciPy's, and
        ``"Rosenbrock23"``, for stiff problems); ``"scipy"``: ``solve_ivp``.
        Default: the compiled loop where it applies, else ``solve_ivp``.
    singular_threshold : float or None
        Report the times at which the run passes near a singular
        configuration, where the smallest over the largest singular value of
        the constraint Jacobian (:meth:`NumericModel.constraint_conditioning`)
        has a minimum below this value: in the result's message and by a
        :class:`~kanedyn.SingularConfigurationWarning` (default 1e-3; ``None``:
        do not monitor).  Schemes with their own integrator
        (:class:`kanedyn.schemes.AugmentedLagrangianIndex3`) are run by it.
    **options
        Passed on to ``solve_ivp`` (``max_step``, ``first_step``, ...).  For
        models with contacts also ``modes`` (initial mode per contact;
        default: found from the state), ``stabilization`` (Baumgarte
        frequency of the contact constraints, rad/s, default 10) and
        ``rest_speed`` (approach speed below which impacts are plastic,
        m/s; default ``max(1e3 atol, 1e-6)`` times the state's scale).

    Returns
    -------
    SimulationResult
    """
    t0, t1 = (float(v) for v in t_span)
    progress = as_progress(progress)
    y_init = model.state(y0, t0)
    user_events = [] if events is None else (
        list(events) if isinstance(events, (list, tuple)) else [events])
    constrained = (model.n_q_dep + model.n_u_dep) > 0
    scheme = getattr(model, "scheme", None)
    if project is None:
        project = scheme.project if scheme is not None else True
    tol = projection_tol if projection_tol is not None else max(100 * np.max(atol), 1e-10)
    t_eval = None if t_eval is None else np.asarray(t_eval, dtype=float)
    if model.contacts:
        if backend == "c" or dense_output:
            raise ModelError("models with contacts are integrated segment by segment on "
                             "solve_ivp: backend='c' and dense_output are not available "
                             "for them")
        return _simulate_with_contacts(model, (t0, t1), y_init, method, t_eval, rtol, atol,
                                       user_events, constraint_forces, progress, options)
    monitor = SingularityMonitor(model, singular_threshold)
    if getattr(scheme, "integrate", None) is not None:  # a scheme with its own integrator
        return scheme.integrate(model, (t0, t1), y_init, method=method, t_eval=t_eval,
                                events=user_events, dense_output=dense_output,
                                constraint_forces=constraint_forces, monitor=monitor,
                                progress=progress, **options)
    if _use_compiled(model, method, backend, options):
        progress.stage(f"integrating with the compiled {method} loop")
        return _simulate_compiled(model, t0, t1, y_init, method, t_eval, rtol, atol,
                                  user_events, dense_output, tol if constrained and project
                                  else 0.0, constraint_forces, options, monitor)
    all_events = list(user_events) + monitor.events
    if constrained and project:
        all_events.append(_drift_event(model, tol))

    integrand = _Integrand(model, (t0, t1), progress)
    ts, ys, segments = [], [], []
    t_events = [[] for _ in user_events]
    y_events = [[] for _ in user_events]
    counters = {"nfev": 0, "njev": 0, "nlu": 0}
    projections = 0
    t_start, y_start = t0, y_init
    status, message = 0, "the integration reached the end of the interval"
    first = True
    while True:
        seg_eval = None
        if t_eval is not None:
            keep = (t_eval >= t_start) if first else (t_eval > t_start)
            seg_eval = t_eval[keep & (t_eval <= t1)]
        sol = solve_ivp(integrand, (t_start, t1), y_start, method=method,
                        t_eval=seg_eval, events=all_events or None,
                        dense_output=dense_output, rtol=rtol, atol=atol, **options)
        for key in counters:
            counters[key] += getattr(sol, key, 0)
        # solve_ivp gives y of shape (0,) when an event ends a segment before
        # its first output time
        seg_t, seg_y = sol.t, np.asarray(sol.y).reshape(model.n_states, -1)
        if not first and t_eval is None and seg_t.size and seg_t[0] == t_start:
            seg_t, seg_y = seg_t[1:], seg_y[:, 1:]
        ts.append(seg_t)
        ys.append(seg_y)
        if dense_output and sol.sol is not None:
            segments.append(sol.sol)
        for i in range(len(user_events)):
            if sol.t_events is not None and len(sol.t_events[i]):
                t_events[i].extend(sol.t_events[i])
                y_events[i].extend(sol.y_events[i])
        if monitor.active and sol.t_events is not None:
            monitor.collect(sol.t_events[len(user_events)], sol.y_events[len(user_events)])
        first = False
        if sol.status == -1 or integrand.failure is not None:
            status = -1
            message = integrand.failure or sol.message
            if integrand.failure and sol.status != -1:
                message += " (the integrator continued; results after it are unreliable)"
            break
        if sol.status == 1:
            fired_user = [i for i, ev in enumerate(user_events)
                          if getattr(ev, "terminal", False) and len(sol.t_events[i])
                          and sol.t_events[i][-1] == sol.t[-1]]
            if fired_user or not (constrained and project):
                status = 1
                message = "a termination event occurred"
                break
            # drift event: project and restart
            t_start = float(sol.t_events[-1][-1])
            y_drift = sol.y_events[-1][-1]
            y_start = (scheme.project_state(model, t_start, y_drift) if scheme is not None
                       else model.consistent_state(t_start, y_drift))
            projections += 1
            if t_eval is None:
                ts[-1], ys[-1] = ts[-1][:-1], ys[-1][:, :-1]
                ts.append(np.array([t_start]))
                ys.append(y_start[:, None])
            continue
        break
    progress.done()
    t = np.concatenate(ts) if ts else np.zeros(0)
    y = np.concatenate(ys, axis=1) if ys else np.zeros((model.n_states, 0))
    message = monitor.finish(message, t0, y_init, t[-1] if t.size else t0,
                             y[:, -1] if t.size else None)
    return SimulationResult.build(
        model=model, t=t, y=y, status=status, message=message,
        t_events=[np.asarray(v) for v in t_events],
        y_events=[np.asarray(v).reshape(-1, model.n_states) for v in y_events],
        dense_segments=segments if dense_output else None, counters=counters,
        projections=projections, initial_state=y_init,
        constraint_forces=constraint_forces,
        method=method if isinstance(method, str) else getattr(method, "__name__", str(method)))


def _use_compiled(model, method, backend, options):
    """Whether to run the compiled loop (raises if asked for and impossible)."""
    compiled = getattr(model, "_c", None) is not None
    reasons = []
    if not compiled:
        reasons.append("the model was not built with backend='c'")
    if method not in COMPILED_METHODS:
        reasons.append(f"method {method!r} is not one of {', '.join(COMPILED_METHODS)}")
    unsupported = set(options) - _COMPILED_OPTIONS
    if unsupported:
        reasons.append(f"option(s) {', '.join(sorted(unsupported))} are solve_ivp-only")
    if backend == "c" and reasons:
        raise ValueError("the compiled integration loop cannot be used: " + "; ".join(reasons))
    if backend == "scipy":
        if method == "Rosenbrock23":
            raise ValueError("method 'Rosenbrock23' is only available in the compiled "
                             "loop (a model with backend='c' and backend='c' here)")
        return False
    if backend not in (None, "c", "scipy"):
        raise ValueError(f"backend must be None, 'scipy' or 'c', not {backend!r}")
    if method == "Rosenbrock23" and reasons:
        raise ValueError("method 'Rosenbrock23' needs the compiled loop: " + "; ".join(reasons))
    return not reasons


class _CompiledDense:
    """Continuous solution of the compiled loop (one polynomial per step)."""

    def __init__(self, th, y_old, q, method):
        self.t_old = th[:, 0]
        self.h = th[:, 1]
        self.y_old = y_old
        self.q = q.reshape(len(th), -1, 4)
        self.method = method

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        scalar = t.ndim == 0
        t = np.atleast_1d(t)
        forward = self.h[0] >= 0 if len(self.h) else True
        if forward:
            k = np.clip(np.searchsorted(self.t_old, t, side="right") - 1, 0, len(self.h) - 1)
        else:
            k = np.clip(np.searchsorted(-self.t_old, -t, side="right") - 1, 0, len(self.h) - 1)
        x = (t - self.t_old[k]) / self.h[k]
        q = self.q[k]  # (m, n, 4)
        if self.method == "RK45":
            powers = np.stack([x, x ** 2, x ** 3, x ** 4], axis=-1)  # (m, 4)
            delta = np.einsum("mnj,mj->mn", q, powers)
        else:
            d = 1.0 / (2.0 + np.sqrt(2.0))
            a = x * (1 - x) / (1 - 2 * d)
            b = x * (x - 2 * d) / (1 - 2 * d)
            delta = q[:, :, 0] * a[:, None] + q[:, :, 1] * b[:, None]
        y = (self.y_old[k] + self.h[k][:, None] * delta).T
        return y[:, 0] if scalar else y


def _simulate_compiled(model, t0, t1, y_init, method, t_eval, rtol, atol, events, dense,
                       project_tol, constraint_forces, options, monitor):
    # the monitor scans the steps afterwards (a Python event call per step would
    # cost more than the compiled step itself)
    want_dense = dense or monitor.active
    atol_vec = np.broadcast_to(np.asarray(atol, dtype=float), (model.n_states,)).copy()
    out = model._c.integrate(t0, t1, y_init, t_eval, float(rtol), atol_vec,
                             float(options.get("max_step", np.inf)),
                             float(options.get("first_step") or 0.0), method,
                             events if events else None, float(project_tol),
                             bool(want_dense))
    status = out["status"]
    dense_sol = None
    if want_dense and len(out["dense_th"]):
        dense_sol = _CompiledDense(out["dense_th"], out["dense_y"], out["dense_q"], method)
        th = out["dense_th"]
        ends = np.append(th[:, 0], th[-1, 0] + th[-1, 1])
        monitor.scan(ends, np.vstack([out["dense_y"], dense_sol(ends[-1])]), dense_sol)
    message = monitor.finish(out["message"], t0, y_init, out["t"][-1] if len(out["t"]) else t0,
                             out["y"][-1] if len(out["t"]) else None, stacklevel=4)
    dense_sol = dense_sol if dense else None
    counters = {"nfev": out["nfev"], "njev": out["njev"], "nlu": out["nlu"]}
    return SimulationResult.build(
        model=model, t=out["t"], y=out["y"].T.copy(), status=status, message=message,
        t_events=list(out["t_events"]), y_events=list(out["y_events"]),
        dense_segments=dense_sol, counters=counters, projections=out["projections"],
        initial_state=y_init, constraint_forces=constraint_forces,
        method=f"{method} (compiled)")


def _simulate_with_contacts(model, t_span, y_init, method, t_eval, rtol, atol, events,
                            constraint_forces, progress, options):
    from ._hybrid import simulate_contacts
    progress.stage("integrating with contacts (modes, events, impacts)")
    extra = {k: options.pop(k) for k in ("modes", "stabilization", "rest_speed")
             if k in options}
    t, y, status, message, extras = simulate_contacts(
        model, t_span, y_init, method=method, t_eval=t_eval, rtol=rtol, atol=atol,
        events=events, **extra, **options)
    return SimulationResult.build(
        model=model, t=t, y=y, status=status, message=message,
        t_events=extras["t_events"], y_events=extras["y_events"], dense_segments=None,
        counters=extras["counters"], projections=0, initial_state=y_init,
        constraint_forces=constraint_forces, method=method, contacts=extras)
