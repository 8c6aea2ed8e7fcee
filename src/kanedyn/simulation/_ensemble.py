"""``simulate_many``: many trajectories of one compiled model at once, in C.

Each trajectory has its own initial state, constants and inputs (values, or a
record sampled on a time grid shared by all and interpolated linearly); all
run the compiled loop's RK45 (``Model.integrate_many`` of the C module: the
same steps and numbers as ``kd.simulate(..., method="RK45")`` on the compiled
loop) on POSIX threads, Python's lock released, and the outputs at ``t_eval``
come back as one array.  Events are SymPy expressions (:class:`~._events.Event`),
compiled into one C function the threads evaluate, located as the compiled loop
locates them.  What a run of ``kd.simulate`` does in Python per step (events and
inputs that are Python functions, the energy sampling, the search for singular
configurations) is not available here: the checks say so.
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._errors import ModelError, OptionError, SimulationInterrupted
from .._output_files import replacing
from .._signals import end_by_signal_if_uncaught
from ._events import as_event, compiled_event_table, listed
from ._run_guard import INTERRUPTED, RunGuard, time_limit_message

__all__ = ["simulate_many", "EnsembleResult"]

#: outcome codes of the C ensemble (KD_ENS_...)
_DONE, _SMALL_STEP, _PROJECTION, _STOPPED, _TIMED_OUT, _TERMINAL, _NO_MEMORY = range(7)


@dataclass(frozen=True)
class EnsembleResult:
    """Trajectories of one model from :func:`simulate_many`.

    Attributes
    ----------
    t : ndarray, shape (m,)
        Output times, s.
    y : ndarray, shape (N, m, n_states)
        States at the output times; ``nan`` past where a run ended early.
    status : ndarray of int, shape (N,)
        0: reached the end; 1: a terminal event ended it; -1: ended early
        (``message`` says why).
    message : tuple of str
        One per run.
    t_end : ndarray, shape (N,)
        Time of each run's last accepted state, s (a terminal event's time).
    y_end : ndarray, shape (N, n_states)
        That state (the end state of a complete run).
    t_events : tuple
        Per run, a tuple of one array per event: the times it occurred, s (as
        ``SimulationResult.t_events``).
    y_events : tuple
        Per run, a tuple of one array per event, shape (k, n_states): the states
        there.
    nfev, steps, projections : ndarray of int, shape (N,)
        Right-hand sides evaluated, steps accepted, projections onto the
        constraints, per run.
    constants : ndarray, shape (N, n_constants)
        Each run's constants, columns ``constant_names``.
    inputs : ndarray, shape (N, k, n_inputs)
        Each run's inputs at ``input_times`` (``k = 1``: constant inputs).
    input_times : ndarray, shape (k,), or None
    state_names, constant_names, input_names : tuple of str
    model : NumericModel
    method : str
    """

    t: np.ndarray
    y: np.ndarray
    status: np.ndarray
    message: tuple
    t_end: np.ndarray
    y_end: np.ndarray
    nfev: np.ndarray
    steps: np.ndarray
    projections: np.ndarray
    constants: np.ndarray
    inputs: np.ndarray
    input_times: np.ndarray | None
    state_names: tuple
    constant_names: tuple
    input_names: tuple
    model: object
    method: str = "RK45 (compiled ensemble)"
    t_events: tuple = ()
    y_events: tuple = ()

    def __len__(self):
        return len(self.status)

    @property
    def success(self):
        """Whether each run reached the end, shape (N,)."""
        return self.status >= 0

    def __getitem__(self, name):
        """The history of the state ``name`` in every run, shape (N, m)."""
        if name not in self.state_names:
            raise KeyError(f"{name!r} is not a state of this model; its states are "
                           f"{', '.join(self.state_names)}")
        return self.y[:, :, self.state_names.index(name)]

    def run(self, i):
        """Run ``i`` as a :class:`SimulationResult` (its output times reached and
        its events), on the model with its constants (inputs held at their first
        sample)."""
        from ._results import SimulationResult
        i = int(i)
        model = self.model.with_constants(list(self.constants[i]))
        reached = np.all(np.isfinite(self.y[i]), axis=1)
        return SimulationResult.build(
            model=model, t=self.t[reached], y=self.y[i][reached].T.copy(),
            status=int(self.status[i]), message=self.message[i],
            t_events=list(self.t_events[i]) if self.t_events else [],
            y_events=list(self.y_events[i]) if self.y_events else [],
            dense_segments=None, counters={"nfev": int(self.nfev[i]), "njev": 0, "nlu": 0},
            projections=int(self.projections[i]), initial_state=self.y[i][0].copy(),
            constraint_forces=False, method=self.method)

    def to_csv(self, path):
        """Write one table: run, time and states per row (the rows reached);
        returns the path."""
        path = Path(path)
        with replacing(path, newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(["run", "t", *self.state_names])
            for i in range(len(self)):
                for t, row in zip(self.t, self.y[i]):
                    if np.all(np.isfinite(row)):
                        writer.writerow([i, repr(float(t)), *(repr(float(v)) for v in row)])
        return path


def _count(*sizes):
    """The number of runs the arguments agree on (1 broadcasts)."""
    found = {s for s in sizes if s != 1}
    if len(found) > 1:
        raise OptionError(f"simulate_many: the initial states, constants and inputs give "
                          f"different numbers of runs ({', '.join(map(str, sorted(found)))})")
    return found.pop() if found else 1


def _constants(model, constants):
    """``(P (n or 1, n_p), runs)`` from ``{name: value or values}`` (None: the model's)."""
    names = list(model.constants)
    if constants is None:
        return np.asarray(model._p, dtype=float)[None, :], 1
    if not isinstance(constants, dict):
        raise OptionError("simulate_many: constants must be {name: value or one value per "
                          "run}")
    unknown = sorted(set(constants) - set(names))
    if unknown:
        raise ModelError(f"simulate_many: {', '.join(unknown)} are not constants of this "
                         f"model; its constants are {', '.join(names)}")
    columns = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in constants.items()}
    for k, v in columns.items():
        if v.ndim != 1:
            raise OptionError(f"simulate_many: constant {k} must be a number or one value "
                              f"per run, got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ModelError(f"simulate_many: constant {k} has values that are not finite")
    n = _count(*(len(v) for v in columns.values()))
    P = np.tile(np.asarray(model._p, dtype=float), (n, 1))
    for k, v in columns.items():
        P[:, names.index(k)] = v
    _check_bodies(model, P, set(columns))
    return P, n


def _check_bodies(model, P, given):
    """The plausibility checks of ``model.with_constants`` (masses, inertias) on
    each run's constants where the ``given`` ones enter the bodies."""
    from ..modeling import body_values
    parameters = model._body_parameters()
    symbols = {s for _, _, mass, inertia in parameters
               for s in mass.free_symbols | (inertia.free_symbols if inertia is not None
                                             else set())}
    if not {str(s) for s in symbols} & given:
        return
    names = list(model.constants)
    for i, row in enumerate(P):
        current = dict(zip(names, row))
        try:
            body_values(parameters, {s: current[str(s)] for s in symbols if str(s) in current})
        except ModelError as exc:
            raise ModelError(f"simulate_many: run {i}: {exc}") from None


def _inputs(model, inputs, input_times, t0, t1):
    """``(R (n or 1, k, n_r), times or None, runs)``."""
    names = [name.removesuffix("(t)") for name in model.input_names]
    if not names:
        if inputs:
            raise ModelError("simulate_many: this model has no inputs")
        return np.zeros((1, 1, 0)), None, 1
    if inputs is not None and not isinstance(inputs, dict):
        raise OptionError("simulate_many: inputs must be {name: values}")
    given = {(k if isinstance(k, str) else str(k)).removesuffix("(t)"): v
             for k, v in (inputs or {}).items()}
    missing = [k for k in names if k not in given]
    unknown = sorted(set(given) - set(names))
    if unknown or missing:
        raise ModelError(
            "simulate_many runs without Python, so every input is given as values: "
            + (f"{', '.join(unknown)} are not inputs of this model; " if unknown else "")
            + (f"give inputs={{{', '.join(repr(k) + ': ...' for k in missing)}}} "
               if missing else "")
            + f"(its inputs: {', '.join(names)}; a number, one per run, or one row of "
            "samples at input_times per run)")
    times = None
    if input_times is not None:
        times = np.asarray(input_times, dtype=float)
        if times.ndim != 1 or times.size < 2 or not np.all(np.isfinite(times)) \
                or np.any(np.diff(times) <= 0):
            raise OptionError("simulate_many: input_times must be at least 2 finite, "
                              "strictly increasing times, s")
        if times[0] > min(t0, t1) or times[-1] < max(t0, t1):
            raise OptionError(f"simulate_many: the input record ({times[0]:g} to "
                              f"{times[-1]:g} s) must cover t_span ({t0:g}, {t1:g})")
    k = 1 if times is None else times.size
    columns = []
    for name in names:
        v = np.asarray(given[name], dtype=float)
        if times is None:
            if v.ndim > 1:
                raise OptionError(f"simulate_many: input {name} must be a number or one "
                                  "value per run (or give input_times for records)")
            v = np.atleast_1d(v)[:, None]
        else:
            if v.ndim == 1 and v.size == k:
                v = v[None, :]
            if v.ndim != 2 or v.shape[1] != k:
                raise OptionError(f"simulate_many: input {name} must have {k} samples (the "
                                  f"input_times) per run, got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ModelError(f"simulate_many: input {name} has values that are not finite")
        columns.append(v)
    n = _count(*(len(v) for v in columns))
    R = np.stack([np.broadcast_to(v, (n, k)) for v in columns], axis=2)
    return np.ascontiguousarray(R), times, n


def _check_model(model):
    if getattr(model, "_c", None) is None:
        raise ModelError("simulate_many integrates in the model's compiled code: build the "
                         "model with backend='c'")
    if model.contacts:
        raise ModelError(f"simulate_many does not integrate models with contacts "
                         f"({', '.join(c['name'] for c in model.contacts)}): their modes, "
                         "events and impacts are followed in Python; use kd.sweep")
    scheme = getattr(model, "scheme", None)
    if getattr(scheme, "integrator", None) is not None:
        raise ModelError(f"the constraint scheme {scheme.name!r} brings its own integrator; "
                         "simulate_many runs the compiled RK45: use kd.sweep")


def _initial_states(model, y0, P, n, t0):
    """``(n, n_states)`` initial states, the dependent ones completed per run."""
    Y = np.atleast_2d(np.asarray(y0, dtype=float))
    if Y.ndim != 2 or Y.shape[1] != model.n_states:
        raise OptionError(f"simulate_many: y0 must have {model.n_states} entries "
                          f"({', '.join(model.state_names)}) per run, got shape "
                          f"{np.shape(y0)}")
    n = _count(len(Y), n)
    Y = np.array(np.broadcast_to(Y, (n, model.n_states)))
    if model.n_q_dep + model.n_u_dep:
        P = np.broadcast_to(P, (n, P.shape[1]))
        same = np.all(P == np.asarray(model._p))
        for i in range(n):
            m = model if same else model.with_constants(list(P[i]))
            Y[i] = m.state(Y[i], t0)
    elif not np.all(np.isfinite(Y)):
        raise ModelError("simulate_many: y0 has values that are not finite")
    return Y, n


def _events(events):
    """``events`` of :func:`simulate_many` as a list of :class:`Event`."""
    found = []
    for k, event in enumerate(listed(events)):
        as_expression = as_event(event)
        if as_expression is not None:
            found.append(as_expression)
            continue
        name = getattr(event, "__name__", None) or f"events[{k}]"
        if callable(event):
            raise OptionError(
                f"simulate_many: event {name} is a Python function, which cannot run in "
                "the C threads that integrate the runs; give it as a SymPy expression of "
                "t and the model's states, inputs and constants, kd.Event(expression, "
                "terminal=..., direction=...) (kd.simulate takes the same Event)")
        raise OptionError(f"simulate_many: events[{k}] is not a SymPy expression or a "
                          f"kd.Event: {event!r}")
    return found


def _events_by_run(out, n, n_events):
    """``(t_events, y_events)`` of :class:`EnsembleResult` from the C ensemble's
    events (in run order, each run's in the order met)."""
    if not n_events:
        return (), ()
    run, which, t, y = out["event_run"], out["event_which"], out["event_t"], out["event_y"]
    bounds = np.searchsorted(run, np.arange(n + 1))
    t_events, y_events = [], []
    for i in range(n):
        part = slice(bounds[i], bounds[i + 1])
        kinds = which[part]
        t_events.append(tuple(t[part][kinds == k] for k in range(n_events)))
        y_events.append(tuple(y[part][kinds == k] for k in range(n_events)))
    return tuple(t_events), tuple(y_events)


def simulate_many(model, y0, t_span, *, constants=None, inputs=None, input_times=None,
                  t_eval=None, events=None, rtol=1e-8, atol=1e-8, max_step=np.inf,
                  first_step=None, project=None, projection_tol=None, threads=None,
                  timeout=None):
    """Integrate many runs of one compiled model at once, in C.

    Parameters
    ----------
    model : NumericModel
        Built with ``backend="c"``; no contacts, no scheme with its own
        integrator.
    y0 : array_like, shape (n_states,) or (N, n_states)
        Initial states (one for all runs, or one per run); dependent
        coordinates and speeds are completed per run, as ``kd.simulate`` does.
    t_span : (float, float)
        Start and end time, s.
    constants : dict, optional
        ``{name: value or (N,) values}``; the others keep the model's values.
    inputs : dict, optional
        ``{name: values}`` for every specified input of the model: a number or
        (N,) values (held constant), or with ``input_times`` (k,) samples per
        run, shape (k,) or (N, k), interpolated linearly.
    input_times : array_like, shape (k,), optional
        Times of the input samples, s, covering ``t_span``.
    t_eval : array_like, optional
        Output times within ``t_span`` (default: its two ends).
    events : kd.Event, SymPy expression, or a list of them, optional
        Zero crossings of expressions of ``t`` and the model's states, inputs and
        constants (each run's), compiled into C and located as ``kd.simulate``'s
        compiled loop locates its events (Brent's method on each step's
        continuous extension); a terminal one ends its run there (status 1).
        Python functions cannot run in the threads and are refused.
    rtol, atol, max_step, first_step
        As :func:`kanedyn.simulate` with ``method="RK45"`` on the compiled loop.
    project, projection_tol
        As :func:`kanedyn.simulate`: constraint drift projected after any step
        whose largest residual exceeds ``projection_tol`` (default
        ``max(100 atol, 1e-10)``).
    threads : int, optional
        POSIX threads (default: the CPUs this process may use).
    timeout : float, optional
        Seconds of computing for the whole ensemble; the runs then end where
        they are, with what they computed.

    Returns
    -------
    EnsembleResult

    Raises
    ------
    OptionError
        An event that is a Python function (or not an expression).
    ModelError
        An event naming a symbol that is not the model's, or that C cannot
        evaluate.
    SimulationInterrupted
        On Ctrl-C; its ``result`` is the :class:`EnsembleResult` of what was
        computed.
    """
    from ._simulate import (_check_span, _check_t_eval, _check_tolerances, _initial_failure,
                            check_timeout)
    _check_model(model)
    events = _events(events)
    t0, t1 = _check_span(t_span)
    rtol, atol = _check_tolerances(rtol, atol, model.n_states)
    t_eval = _check_t_eval(t_eval, t0, t1)
    t_eval = np.array([t0, t1]) if t_eval is None else t_eval
    timeout = check_timeout(timeout)
    max_step = float(max_step)
    if not max_step > 0:
        raise OptionError(f"max_step must be positive, got {max_step}")
    P, n_p = _constants(model, constants)
    R, times, n_r = _inputs(model, inputs, input_times, t0, t1)
    Y0, n = _initial_states(model, y0, P, _count(n_p, n_r), t0)
    P = np.ascontiguousarray(np.broadcast_to(P, (n, P.shape[1])))
    R = np.ascontiguousarray(np.broadcast_to(R, (n,) + R.shape[1:]))
    if threads is None:
        threads = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") \
            else (os.cpu_count() or 1)
    if int(threads) != threads or threads < 1:
        raise OptionError(f"threads must be a positive whole number, got {threads!r}")
    constrained = model.n_q_dep + model.n_u_dep > 0
    scheme = getattr(model, "scheme", None)
    if project is None:
        project = scheme.project if scheme is not None else True
    tol = projection_tol if projection_tol is not None else max(100 * np.max(atol), 1e-10)
    atol_vec = np.broadcast_to(np.asarray(atol, dtype=float), (model.n_states,)).copy()
    table = compiled_event_table(model, events) if events else (None, None, None)
    guard = RunGuard(model, timeout)
    with guard.catching_interrupts():
        out = model._c.integrate_many(
            t0, t1, Y0, P, times, R, t_eval, float(rtol), atol_vec, max_step,
            float(first_step or 0.0), float(tol) if constrained and project else 0.0,
            int(threads), guard.stop_flag, guard.seconds_left(), *table)
    t_events, y_events = _events_by_run(out, n, len(events))
    messages = [_message(code, t_end, t_bad, timeout) for code, t_end, t_bad in
                zip(out["outcome"], out["t_end"], out["t_singular"])]
    for i in np.flatnonzero(out["t_singular"] == t0):  # as kd.simulate: why it cannot start
        cause = _initial_failure(model.with_constants(list(P[i])), t0, Y0[i])
        messages[i] = f"cannot start: {cause}" if cause else messages[i]
    status = np.where(out["outcome"] == _DONE, 0, np.where(out["outcome"] == _TERMINAL, 1, -1))
    result = EnsembleResult(
        t=t_eval.copy(), y=out["y"], status=status,
        message=tuple(messages),
        t_end=out["t_end"], y_end=out["y_end"], nfev=out["nfev"], steps=out["steps"],
        projections=out["projections"], constants=P, inputs=R, input_times=times,
        state_names=tuple(model.state_names), constant_names=tuple(model.constants),
        input_names=tuple(model.input_names), model=model, t_events=t_events,
        y_events=y_events)
    if guard.interrupted or out["interrupted"]:
        end_by_signal_if_uncaught()
        raise SimulationInterrupted(result, guard.signum)
    return result


def _message(code, t_end, t_bad, timeout):
    if code == _DONE:
        return "the integration reached the end of the interval"
    if code == _SMALL_STEP:
        if np.isfinite(t_bad):
            return (f"singular equations of motion at t={t_bad:.6g} (the integrator could "
                    "not step past it)")
        return "Required step size is less than spacing between numbers."
    if code == _PROJECTION:
        return ("the constraints could not be satisfied by projection (singular constraint "
                "Jacobian)")
    if code == _STOPPED:
        return INTERRUPTED
    if code == _TERMINAL:
        return "a termination event occurred"
    if code == _NO_MEMORY:
        return "no memory was left for the events found"
    return time_limit_message(timeout, t_end)
