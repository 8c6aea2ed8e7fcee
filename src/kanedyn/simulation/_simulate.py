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

import inspect
import numbers

import numpy as np

from ..numerics import (DEFAULT_THRESHOLD, SingularityMonitor, derivatives_built,
                        derivatives_unavailable, diagnose, exact_loop, inputs_follow_state,
                        state_jacobian)
from .._errors import ModelError, OptionError, SimulationInterrupted
from .._progress import as_progress
from .._signals import end_by_signal_if_uncaught
from ._results import SimulationResult
from ._energy_check import Balance, WorkTracker, with_energy_note
from ._events import as_event, listed, python_event
from ._index3 import run_index3
from ._run_guard import (INTERRUPTED, Integrand, RunGuard, guarded_event, guarded_method,
                         scipy_methods, solver_class, time_limit_message)

__all__ = ["simulate", "COMPILED_METHODS", "METHODS",  # noqa: F822  (METHODS: __getattr__)
           "OWN_INTEGRATORS"]


def _drift_event(model, tol):
    def drift(t, y):
        return tol - np.max(np.abs(model.constraint_residuals(t, y)))
    drift.terminal = True
    drift.direction = -1
    return drift


COMPILED_METHODS = ("RK45", "Rosenbrock23")
#: integrators of schemes that bring their own (``Scheme.integrator`` -> function)
OWN_INTEGRATORS = {"index-3 trapezoidal": run_index3}
_COMPILED_OPTIONS = {"max_step", "first_step", "jac"}  # jac: "exact" (Rosenbrock23)
#: options passed on to ``solve_ivp`` (those of its methods)
_SOLVE_IVP_OPTIONS = {"first_step", "max_step", "min_step", "jac", "jac_sparsity",
                      "vectorized", "lband", "uband"}
#: options of the integration of models with contacts
_CONTACT_OPTIONS = {"modes", "stabilization", "rest_speed"}
_MAX_STALLED_PROJECTIONS = 50  # projections in a row without progress in time


def __getattr__(name):
    """``METHODS``: every method name ``simulate`` accepts, solve_ivp's and the
    compiled loop's (read from SciPy, imported only when asked for: a run on the
    compiled loop needs no SciPy)."""
    if name == "METHODS":
        scipy_names = tuple(scipy_methods())
        return scipy_names + tuple(m for m in COMPILED_METHODS if m not in scipy_names)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def simulate(model, t_span, y0, *, method="RK45", t_eval=None, rtol=1e-8, atol=1e-8,
             events=None, dense_output=False, project=None, projection_tol=None,
             constraint_forces=False, progress=False, backend=None,
             singular_threshold=DEFAULT_THRESHOLD, timeout=None, **options):
    """Integrate a :class:`NumericModel` with SciPy's ``solve_ivp``.

    Parameters
    ----------
    model : NumericModel
    t_span : (float, float)
        Start and end time, s (finite; the end may lie before the start).
    y0 : array_like or dict
        Initial state ``[q, u]``, or ``{symbol or name: value}`` giving at
        least every independent coordinate and speed.  Dependent values are
        starting guesses; they are corrected to satisfy the constraints.
    method : str or OdeSolver
        Any ``solve_ivp`` method (``"RK45"``, ``"DOP853"``, ``"Radau"``,
        ``"BDF"``, ``"LSODA"``, ...).
    t_eval : array_like, optional
        Output times within ``t_span``, ordered in the direction of
        integration; default: the integrator's steps.
    rtol, atol : float
        Integration tolerances (``rtol > 0``; ``atol > 0``, a number or one
        per state).
    events : callable, kd.Event, or a list of them, optional
        ``event(t, y)`` functions returning one number, with optional
        ``terminal`` and ``direction`` attributes, exactly as for
        ``solve_ivp``; or :class:`kanedyn.Event` (a SymPy expression of ``t``
        and the model's states, inputs and constants, evaluated with this
        model's constants; a bare expression is an Event with the defaults),
        which :func:`kanedyn.simulate_many` compiles to C.
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
        Models with contacts are integrated segment by segment between mode
        changes and impacts, the compiled dynamics and contact terms of a
        ``backend="c"`` model driving the segments (``"c"`` requires such a
        model).
    singular_threshold : float or None
        Report the times at which the run passes near a singular
        configuration, where the smallest over the largest singular value of
        the constraint Jacobian (:meth:`NumericModel.constraint_conditioning`)
        has a minimum below this value: in the result's message and by a
        :class:`~kanedyn.SingularConfigurationWarning` (default 1e-3; ``None``:
        do not monitor).  Schemes with their own integrator
        (:class:`kanedyn.schemes.AugmentedLagrangianIndex3`) are run by it.
    timeout : float, optional
        Wall-clock seconds after which the integration stops, checked at every
        step (every 16 steps of the compiled loops): the run then ends with
        ``success=False``, a message naming the limit, and everything computed
        up to then.
    **options
        Passed on to ``solve_ivp``: ``max_step``, ``first_step``, ``min_step``,
        ``jac``, ``jac_sparsity``, ``vectorized``, ``lband``, ``uband`` (other
        names are refused, with the closest known ones).  ``jac="exact"``:
        Radau, BDF and LSODA get the model's exact Jacobian
        (:meth:`NumericModel.jacobians`; inputs that are functions of the
        state differenced), the default for NumPy models of up to
        ``EXACT_JACOBIAN_STATES`` (20) states and for models whose derivatives
        are built (or, on C, compiled and in the cache: a run never waits for
        a compilation it did not ask for); ``jac="differences"`` (otherwise
        the default) leaves them to solve_ivp's differences; a matrix or a
        function ``jac(t, y)`` is passed on.  For
        models with contacts also ``modes`` (initial mode per contact;
        default: found from the state), ``stabilization`` (Baumgarte
        frequency of the contact constraints, rad/s, default 10) and
        ``rest_speed`` (approach speed below which impacts are plastic,
        m/s; default ``max(1e3 atol, 1e-6)`` times the state's scale).

    Returns
    -------
    SimulationResult
        A run that cannot go on (a singular mass matrix, a non-finite
        constant, input or state, a step size that collapses, an input's or
        event's function that raises, the time limit) ends with
        ``success=False``, a message naming the cause, and everything computed
        up to then.  A run whose stored energy differs from what the work done
        on the model allows by more than a factor of 10 (either way), or whose
        state leaves the finite range, keeps ``success=True`` but says so in
        its message (and warns with :class:`TrustWarning`; see
        ``docs/trust.md``).

    Raises
    ------
    OptionError
        An option the integrators cannot honour (tolerances, time span,
        ``t_eval``, ``max_step``, events), naming it.
    SimulationInterrupted
        On Ctrl-C; its ``result`` holds the partial result (``success=False``,
        ``message="interrupted"``).  A subclass of ``KeyboardInterrupt``.
    """
    if not (hasattr(model, "n_states") and callable(getattr(model, "rhs", None))):
        hint = (": make one with .numeric(constants=...)" if hasattr(model, "numeric")
                else "")
        raise TypeError(f"simulate needs a numerical model, got {type(model).__name__}"
                        f"{hint}")
    t0, t1 = _check_span(t_span)
    rtol, atol = _check_tolerances(rtol, atol, model.n_states)
    t_eval = _check_t_eval(t_eval, t0, t1)
    timeout = check_timeout(timeout)
    _check_option_names(options, bool(model.contacts))
    _check_step_options(options, t0, t1)
    options = _with_jacobian(model, method, options)
    if not (isinstance(method, str) and method in COMPILED_METHODS):
        solver_class(method)  # refuse unknown methods before any work
    progress = as_progress(progress)
    y_init = model.state(y0, t0)
    user_events = _check_events(events, t0, y_init, model)
    constrained = (model.n_q_dep + model.n_u_dep) > 0
    scheme = getattr(model, "scheme", None)
    if project is None:
        project = scheme.project if scheme is not None else True
    tol = projection_tol if projection_tol is not None else max(100 * np.max(atol), 1e-10)
    common = dict(model=model, initial_state=y_init, constraint_forces=constraint_forces)
    method_name = method if isinstance(method, str) else getattr(method, "__name__",
                                                                  str(method))
    cause = _initial_failure(model, t0, y_init)
    if cause:
        return SimulationResult.build(
            t=np.array([t0]), y=y_init[:, None].copy(), status=-1,
            message=f"cannot start: {cause}",
            t_events=[np.zeros(0) for _ in user_events],
            y_events=[np.zeros((0, model.n_states)) for _ in user_events],
            dense_segments=None, counters={"nfev": 1, "njev": 0, "nlu": 0}, projections=0,
            method=method_name, **common)
    if model.contacts:
        if dense_output:
            raise ModelError("models with contacts are integrated segment by segment: "
                             "dense_output is not available for them")
        if backend == "c" and getattr(model, "_c", None) is None:
            raise OptionError("backend='c' with contacts needs a model built with "
                              "backend='c' (its compiled dynamics and contact terms drive "
                              "the segments between events)")
        if backend not in (None, "c", "scipy"):
            raise OptionError(f"backend must be None, 'scipy' or 'c', not {backend!r}")
        if t1 < t0:
            raise OptionError(f"models with contacts are integrated forward in time; got "
                              f"t_span ({t0:g}, {t1:g})")
        guard = RunGuard(model, timeout)
        if backend == "scipy":  # the Python reference path for every segment
            options = dict(options, compiled=False)
        with guard.catching_interrupts():
            result = _simulate_with_contacts(model, (t0, t1), y_init, method, t_eval, rtol,
                                             atol, user_events, constraint_forces, progress,
                                             options, guard)
    else:
        monitor = SingularityMonitor(model, singular_threshold,
                                     direction=1.0 if t1 >= t0 else -1.0)
        if getattr(scheme, "integrator", None) is not None:  # a scheme's own integrator
            guard = RunGuard(model, timeout)
            with guard.catching_interrupts():
                result = OWN_INTEGRATORS[scheme.integrator](
                    scheme, model, (t0, t1), y_init, method=method, t_eval=t_eval,
                    events=user_events, dense_output=dense_output,
                    constraint_forces=constraint_forces, monitor=monitor, progress=progress,
                    guard=guard, **options)
        elif _use_compiled(model, method, backend, options):
            progress.stage(f"integrating with the compiled {method} loop")
            guard = RunGuard(model, timeout)
            with guard.catching_interrupts():
                result = _simulate_compiled(model, t0, t1, y_init, method, t_eval, rtol, atol,
                                            user_events, dense_output,
                                            tol if constrained and project else 0.0,
                                            constraint_forces, options, monitor, guard)
        else:
            guard = RunGuard(model, timeout)
            with guard.catching_interrupts():
                result = _simulate_scipy(model, t0, t1, y_init, method, t_eval, rtol, atol,
                                         user_events, dense_output, project and constrained,
                                         tol, progress, guard, options, common, method_name,
                                         monitor)
    progress.done()
    if guard.interrupted or result.message.startswith(INTERRUPTED):
        # a signal after the last step too: the complete result on the exception
        end_by_signal_if_uncaught()
        raise SimulationInterrupted(result, guard.signum)
    return with_energy_note(result, method_name)


def _simulate_scipy(model, t0, t1, y_init, method, t_eval, rtol, atol, user_events,
                    dense_output, project, tol, progress, guard, options, common,
                    method_name, monitor):
    """The solve_ivp path: segments between drift projections."""
    from scipy.integrate import solve_ivp

    scheme = getattr(model, "scheme", None)
    all_events = [guarded_event(event, k, guard) for k, event in enumerate(user_events)]
    all_events += monitor.events
    drift_index = None
    if project:
        drift_index = len(all_events)
        all_events.append(_drift_event(model, tol))
    direction = 1.0 if t1 >= t0 else -1.0
    integrand = Integrand(model, (t0, t1), progress, guard)
    tracker = WorkTracker(model, (t0, t1))
    guard.on_step = tracker.step
    solver = guarded_method(method, guard)
    ts, ys, segments = [], [], []
    t_events = [[] for _ in user_events]
    y_events = [[] for _ in user_events]
    counters = {"nfev": 0, "njev": 0, "nlu": 0}
    projections = stalled = 0
    t_start, y_start = t0, y_init
    status, message = 0, "the integration reached the end of the interval"
    first = True
    while True:
        seg_eval = None
        if t_eval is not None:
            ahead = direction * (t_eval - t_start)
            seg_eval = t_eval[ahead >= 0] if first else t_eval[ahead > 0]
        guard.last_step = None  # a step of an earlier segment may lie past its end
        sol = solve_ivp(integrand, (t_start, t1), y_start, method=solver,
                        t_eval=seg_eval, events=all_events or None,
                        dense_output=dense_output, rtol=rtol, atol=atol, **options)
        for key in counters:
            counters[key] += getattr(sol, key, 0)
        # solve_ivp gives t and y as empty lists when a segment ends before its
        # first output time
        seg_t = np.asarray(sol.t, dtype=float)
        seg_y = np.asarray(sol.y, dtype=float).reshape(model.n_states, -1)
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
        if sol.status == -1:
            status, message = -1, guard.stop_reason or sol.message
            if t_eval is not None:  # the solver failed: its last step is on the path
                _keep_last_step(ts, ys, guard.last_step, direction)
            break
        if sol.status == 1:
            t_end = _terminal_time(all_events, sol.t_events, direction)
            fired_user = [i for i, ev in enumerate(user_events)
                          if getattr(ev, "terminal", False) and len(sol.t_events[i])
                          and sol.t_events[i][-1] == t_end]
            if fired_user or drift_index is None:
                status, message = 1, "a termination event occurred"
                k = next(i for i, times in enumerate(sol.t_events)
                         if len(times) and times[-1] == t_end)
                tracker.stop(t_end, sol.y_events[k][-1])
                break
            # the drift event: project and restart
            t_drift = float(sol.t_events[drift_index][-1])
            stalled = stalled + 1 if direction * (t_drift - t_start) <= 1e-12 * max(
                abs(t1 - t0), 1e-300) else 0
            if stalled > _MAX_STALLED_PROJECTIONS:
                status = -1
                message = (f"constraint drift returns at once after every projection at "
                           f"t={t_drift:.6g}: the constraints cannot be kept there "
                           "(a singular or ill-conditioned constraint Jacobian?)")
                break
            t_start = t_drift
            y_drift = sol.y_events[drift_index][-1]
            y_start = (scheme.project_state(model, t_start, y_drift) if scheme is not None
                       else model.consistent_state(t_start, y_drift))
            projections += 1
            if t_eval is None:
                ts[-1], ys[-1] = ts[-1][:-1], ys[-1][:, :-1]
                ts.append(np.array([t_start]))
                ys.append(y_start[:, None])
            continue
        break
    t = np.concatenate(ts) if ts else np.zeros(0)
    y = np.concatenate(ys, axis=1) if ys else np.zeros((model.n_states, 0))
    message = monitor.finish(message, t0, y_init, t[-1] if t.size else t0,
                             y[:, -1] if t.size else None)
    return SimulationResult.build(
        t=t, y=y, status=status, message=message,
        t_events=[np.asarray(v) for v in t_events],
        y_events=[np.asarray(v).reshape(-1, model.n_states) for v in y_events],
        dense_segments=segments if dense_output else None, counters=counters,
        projections=projections, method=method_name, balance=tracker.history(), **common)


def _keep_last_step(ts, ys, last_step, direction):
    """A run that ended early with output times keeps the state the solver
    accepted last when it lies beyond the last output time (a run with sparse
    outputs would otherwise lose everything after the last of them)."""
    if last_step is None or not np.all(np.isfinite(last_step[1])):
        return
    t_last = max((seg[-1] for seg in ts if seg.size), key=lambda t: direction * t,
                 default=None)
    if t_last is None or direction * (last_step[0] - t_last) > 0:
        ts.append(np.array([last_step[0]]))
        ys.append(np.asarray(last_step[1])[:, None])


def _terminal_time(events, t_events, direction):
    """Time at which a terminal event ended a solve_ivp segment."""
    times = [t_events[i][-1] for i, ev in enumerate(events)
             if getattr(ev, "terminal", False) and len(t_events[i])]
    return max(times, key=lambda v: direction * v)


# ----------------------------------------------------------------- checks
def check_timeout(timeout):
    """``timeout`` (s) as a float, or ``None``; anything but a positive finite
    number is refused."""
    if timeout is None:
        return None
    if not isinstance(timeout, numbers.Real) or not 0 < timeout < np.inf:
        raise OptionError(f"timeout must be a positive number of seconds, got {timeout!r}")
    return float(timeout)


def _check_span(t_span):
    try:
        t0, t1 = (float(v) for v in t_span)
    except (TypeError, ValueError):
        raise OptionError(f"t_span must be two numbers (start, end) in s, got "
                          f"{t_span!r}") from None
    if not (np.isfinite(t0) and np.isfinite(t1)):
        raise OptionError(f"t_span must be finite, got ({t0}, {t1})")
    return t0, t1


def _check_tolerances(rtol, atol, n):
    try:
        rtol = float(rtol)
    except (TypeError, ValueError):
        raise OptionError(f"rtol must be a number, got {rtol!r}") from None
    if not (np.isfinite(rtol) and rtol > 0):
        raise OptionError(f"rtol must be a positive number, got {rtol}")
    atol_arr = np.asarray(atol, dtype=float)
    if atol_arr.ndim > 1 or (atol_arr.ndim == 1 and atol_arr.shape != (n,)):
        raise OptionError(f"atol must be a number or one per state ({n}), got shape "
                          f"{atol_arr.shape}")
    if not np.all(np.isfinite(atol_arr)) or np.any(atol_arr <= 0):
        raise OptionError(f"atol must be positive and finite, got {atol}")
    return rtol, (float(atol_arr) if atol_arr.ndim == 0 else atol_arr)


def _check_t_eval(t_eval, t0, t1):
    if t_eval is None:
        return None
    t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))
    if t_eval.ndim != 1:
        raise OptionError(f"t_eval must be one-dimensional, got shape {t_eval.shape}")
    if not np.all(np.isfinite(t_eval)):
        raise OptionError("t_eval contains values that are not finite")
    lo, hi = min(t0, t1), max(t0, t1)
    outside = t_eval[(t_eval < lo) | (t_eval > hi)]
    if outside.size:
        raise OptionError(f"{outside.size} of the {t_eval.size} t_eval points lie outside "
                          f"t_span ({t0:g}, {t1:g}), e.g. {outside[0]:g}; give output "
                          "times within the span")
    steps = np.diff(t_eval) * (1.0 if t1 >= t0 else -1.0)
    if np.any(steps <= 0):
        order = "increasing" if t1 >= t0 else "decreasing (integration runs backward)"
        raise OptionError(f"t_eval must be strictly {order} for t_span ({t0:g}, {t1:g})")
    return t_eval


def _check_option_names(options, has_contacts):
    """Refuse options nothing reads (``rtoll=``), with the closest known names."""
    import difflib
    import inspect
    known = _SOLVE_IVP_OPTIONS | (_CONTACT_OPTIONS if has_contacts else set())
    for name in sorted(set(options) - known):
        if name in _CONTACT_OPTIONS:
            raise OptionError(f"option {name!r} applies to models with contacts only")
        keywords = set(inspect.signature(simulate).parameters) - {"model", "t_span", "y0",
                                                                   "options"}
        close = difflib.get_close_matches(name, sorted(known | keywords), n=2)
        hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
        raise OptionError(f"unknown option {name!r} of simulate{hint}")


#: the methods of solve_ivp that use the Jacobian of the right-hand side
_JACOBIAN_METHODS = ("Radau", "BDF", "LSODA")

#: NumPy models of up to this many states get the exact Jacobian without asking
#: (its first build grows fast with size: chain3d at 20 states 3 s, at 60 states
#: 23 s); larger ones, and C models (a compilation: 5 s at 20 states, 51 s at
#: 60), once their derivatives are built or in the compile cache
EXACT_JACOBIAN_STATES = 20


def _with_jacobian(model, method, options):
    """``options`` with ``jac`` the model's exact Jacobian where the method uses
    one (``jac="exact"``; without asking, for models of up to
    :data:`EXACT_JACOBIAN_STATES` states or whose derivatives are built) or
    without it (``jac="differences"``: solve_ivp's own differences)."""
    asked = "jac" in options
    jac = options.get("jac", "exact")
    if not isinstance(jac, str):
        if method == "Rosenbrock23":
            raise OptionError("the compiled Rosenbrock23 loop takes jac='exact' or "
                              "'differences', not a matrix or a function")
        return options  # the user's matrix or function, to solve_ivp
    if jac not in ("exact", "differences"):
        raise OptionError(f"jac must be 'exact', 'differences', a matrix or a function "
                          f"jac(t, y), not {jac!r}")
    options = {k: v for k, v in options.items() if k != "jac"}
    loop = method == "Rosenbrock23"  # the compiled loop's: "exact" kept, for it
    if jac == "differences" or not (loop or method in _JACOBIAN_METHODS):
        return options
    contacts = bool(model.contacts)  # exact within each segment's contact modes
    reason = derivatives_unavailable(model, modes_given=contacts)
    if reason is None and loop and inputs_follow_state(model):
        reason = (f"the inputs {', '.join(inputs_follow_state(model))} are functions of "
                  "the state, whose derivatives the compiled loop does not take: use "
                  "method='Radau' or 'BDF' (their Jacobian includes them)")
    if reason is not None:
        if asked:
            raise OptionError(f"jac='exact': {reason}")
        return options
    small = model.n_states <= EXACT_JACOBIAN_STATES and model.backend == "numpy"
    if asked or small or derivatives_built(model):
        options["jac"] = "exact" if loop or contacts else state_jacobian(model)
    return options


def _check_step_options(options, t0, t1):
    for key in ("max_step", "first_step", "min_step"):
        if key not in options or options[key] is None:
            continue
        value = options[key]
        if not isinstance(value, numbers.Real) or np.isnan(value):
            raise OptionError(f"{key} must be a number, got {value!r}")
        if key == "min_step" and value < 0 or key != "min_step" and value <= 0:
            raise OptionError(f"{key} must be positive, got {value}")
    first = options.get("first_step")
    if first is not None and first > abs(t1 - t0) > 0:
        raise OptionError(f"first_step {first} is longer than t_span ({t0:g}, {t1:g})")


def _check_events(events, t0, y0, model):
    """Events as a list of functions (an :class:`~._events.Event` as one of
    ``model``), each checked once at the initial state."""
    events = listed(events)
    for k, event in enumerate(events):
        expression = as_event(event)
        if expression is not None:
            events[k] = event = python_event(model, expression)
        name = getattr(event, "__name__", None) or f"events[{k}]"
        if not callable(event):
            raise OptionError(f"events[{k}] is not callable: {event!r}")
        try:
            inspect.signature(event).bind(t0, y0)
        except TypeError:
            raise OptionError(f"event {name} must take (t, y), as for solve_ivp; its "
                              f"signature is {inspect.signature(event)}") from None
        except ValueError:  # builtins without a signature: try them
            pass
        try:
            value = event(t0, y0.copy())
        except Exception as exc:
            raise ModelError(f"event {name} raised {type(exc).__name__} at the initial state "
                             f"(t={t0:g}): {exc}") from exc
        if np.ndim(value) != 0:
            raise OptionError(f"event {name} returned an array of shape {np.shape(value)} "
                              "at the initial state; an event returns one number (give "
                              "one event function per component)")
        try:
            float(value)
        except (TypeError, ValueError):
            raise OptionError(f"event {name} returned {value!r}, not a number") from None
        direction = getattr(event, "direction", 0)
        if not isinstance(direction, numbers.Real) or np.isnan(direction):
            raise OptionError(f"event {name}: direction must be a number (-1, 0, 1), got "
                              f"{direction!r}")
    return events


def _initial_failure(model, t0, y):
    """Why the derivative at the initial state is not finite, or ``""``."""
    try:
        f = model.rhs(t0, y)
    except np.linalg.LinAlgError:
        f = None
    except ModelError as exc:  # e.g. an input's function raised: its message
        return str(exc)
    if f is not None and np.all(np.isfinite(f)):
        return ""
    return diagnose(model, t0, y) or (
        "the state derivative at the initial state is not finite (" + ", ".join(
            name for name, v in zip(model.state_names, f) if not np.isfinite(v)) + ")"
        if f is not None else "the equations are singular at the initial state")


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
        raise OptionError("the compiled integration loop cannot be used: " + "; ".join(reasons))
    if backend == "scipy":
        if method == "Rosenbrock23":
            raise OptionError("method 'Rosenbrock23' is only available in the compiled "
                             "loop (a model with backend='c' and backend='c' here)")
        return False
    if backend not in (None, "c", "scipy"):
        raise OptionError(f"backend must be None, 'scipy' or 'c', not {backend!r}")
    if method == "Rosenbrock23" and reasons:
        raise OptionError("method 'Rosenbrock23' needs the compiled loop: " + "; ".join(reasons))
    return not reasons


class _CompiledDense:
    """Continuous solution of the compiled loop (one polynomial per step)."""

    def __init__(self, th, y_old, q, method):
        self.t_old = th[:, 0]
        self.h = th[:, 1]
        self.y_old = y_old
        self.q = q.reshape(len(th), -1, 4)
        self.method = method

    @property
    def ts(self):
        """The steps' ends, s (as ``OdeSolution.ts``)."""
        return np.concatenate([self.t_old, self.t_old[-1:] + self.h[-1:]])

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
                       project_tol, constraint_forces, options, monitor, guard):
    atol_vec = np.broadcast_to(np.asarray(atol, dtype=float), (model.n_states,)).copy()
    events = [guarded_event(event, k) for k, event in enumerate(events or ())]
    # the loop looks for singular configurations as it goes (memory: the minima found)
    loop = exact_loop(model) if options.get("jac") == "exact" else model._c
    out = loop.integrate(t0, t1, y_init, t_eval, float(rtol), atol_vec,
                             float(options.get("max_step", np.inf)),
                             float(options.get("first_step") or 0.0), method,
                             events or None, float(project_tol), bool(dense),
                             monitor.threshold if monitor.active else 0.0,
                             monitor.displacement, guard.stop_flag, guard.seconds_left())
    status = out["status"]
    message = "a termination event occurred" if status == 1 else out["message"]
    if out["interrupted"]:
        message = INTERRUPTED
    elif out["timed_out"]:
        message = time_limit_message(guard.timeout, out["t"][-1] if len(out["t"]) else np.nan)
    elif status == -1 and "t_bad" in out:
        message = diagnose(model, out["t_bad"], out["y_bad"]) or message
    monitor.collect(out["singular_t"], out["singular_y"])  # the first and last state too
    message = monitor.finish(message, t0, None, t1, None, stacklevel=4)
    dense_sol = None
    if dense and len(out["dense_th"]):
        dense_sol = _CompiledDense(out["dense_th"], out["dense_y"], out["dense_q"], method)
    counters = {"nfev": out["nfev"], "njev": out["njev"], "nlu": out["nlu"]}
    return SimulationResult.build(
        model=model, t=out["t"], y=out["y"].T.copy(), status=status, message=message,
        t_events=list(out["t_events"]), y_events=list(out["y_events"]),
        dense_segments=dense_sol, counters=counters, projections=out["projections"],
        initial_state=y_init, constraint_forces=constraint_forces,
        method=f"{method} (compiled)", balance=_compiled_balance(out))


def _compiled_balance(out):
    """The energy balance the compiled loop sampled (rows: t, P, E, V, W)."""
    b = out["balance"]
    if not len(b):
        return None
    return Balance(b[:, 0], b[:, 2], b[:, 3], b[:, 4], out["work_error"], out["work_flow"])


def _simulate_with_contacts(model, t_span, y_init, method, t_eval, rtol, atol, events,
                            constraint_forces, progress, options, guard):
    from ._hybrid import simulate_contacts
    progress.stage("integrating with contacts (modes, events, impacts)")
    extra = {k: options.pop(k) for k in ("modes", "stabilization", "rest_speed")
             if k in options}
    t, y, status, message, extras = simulate_contacts(
        model, t_span, y_init, method=method, t_eval=t_eval, rtol=rtol, atol=atol,
        events=events, guard=guard, **extra, **options)
    return SimulationResult.build(
        model=model, t=t, y=y, status=status, message=message,
        t_events=extras["t_events"], y_events=extras["y_events"], dense_segments=None,
        counters=extras["counters"], projections=0, initial_state=y_init,
        constraint_forces=constraint_forces, method=method, contacts=extras)
