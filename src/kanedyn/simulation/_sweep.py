"""Parameter sweeps on Dask: many simulations of one compiled model.

:func:`sweep` runs :func:`~kanedyn.simulate` once per parameter set (a grid
or random samples of constants and initial values) and returns one tidy
table, one row per run.  The runs go to a Dask distributed cluster (a local
cluster of worker processes by default, or a scheduler address); the model
is pickled once and broadcast to the workers (it carries its generated code,
so nothing is derived again there), and several runs share one task.  With
an output folder, each finished task writes its rows as a Parquet part
file, so an interrupted sweep, or one whose worker died, resumes from the
runs already saved; the folder also gets the combined table.

No sweep waits forever: a scheduler address is checked before use (it must
answer as a Dask scheduler within seconds, :func:`check_scheduler`), and with a
time limit per run (``timeout``) each run's integration stops at it (checked as
it goes) and becomes a failed row; a run stuck in a function of the
model (an input's or an event's) is abandoned on its thread after twice the
limit plus :data:`GRACE` seconds, and its row says so.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import logging
import math
import numbers
import sys
import threading
import time
from pathlib import Path

import numpy as np

from .._errors import ModelError, OptionError
from .._output_files import replacing
from ._simulate import check_timeout, simulate

__all__ = ["sweep", "SweepInterrupted", "SWEEP_OUTPUTS", "check_scheduler", "GRACE"]

#: the quantities a sweep can record per run (besides parameters, success,
#: status and message, always recorded)
SWEEP_OUTPUTS = {
    "final": "final_<state>: the state at the end of the run",
    "max": "max_<state>: the largest value of each state over the run",
    "min": "min_<state>: the smallest value of each state over the run",
    "events": "event<k>_count and event<k>_first: how often event k fired, and when first",
    "energy": "energy_drift: the largest |E(t) - E(0)| over the run, J (where defined)",
    "nfev": "rhs_evaluations: right-hand side evaluations",
    "wall_time": "wall_time: seconds the run took on its worker",
    "t_end": "t_end: the time the run reached, s",
}

_PART = "part-{:07d}.parquet"
_MANIFEST = "sweep.json"
#: seconds a scheduler has to answer as one before a sweep is refused
_CONNECT_SECONDS = 5.0
#: seconds a scheduler without workers is given to get one
_WORKER_WAIT_SECONDS = 10.0
#: seconds beyond twice its time limit after which a run that has not returned
#: (stuck in a function of the model) is abandoned
GRACE = 5.0


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during a sweep; the runs that finished are kept.

    Attributes
    ----------
    table : pandas.DataFrame
        The rows of the finished runs.
    total : int or None
        The number of runs asked for.
    out : Path or None
        The folder the finished runs are saved in (run the same sweep with it
        again to finish), or None.
    """

    def __init__(self, message, table, total=None, out=None):
        super().__init__(message)
        self.table = table
        self.total = total
        self.out = out


def _need(module):
    import importlib
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(f"kd.sweep needs {module}: pip install 'kanedyn[sweep]'") from None


# ----------------------------------------------------------- the runs
def _numbers(name, values):
    values = np.atleast_1d(np.asarray(values, dtype=float)) \
        if not isinstance(values, str) else None
    if values is None or values.ndim != 1 or values.size == 0:
        raise OptionError(f"parameter {name}: give a number or a list of numbers")
    if not np.all(np.isfinite(values)):
        raise OptionError(f"parameter {name}: values must be finite")
    return values


def parameter_runs(model, parameters, n=None, seed=None):
    """The runs of a sweep: parameter names and one row of values per run.

    Parameters
    ----------
    model : NumericModel
    parameters : dict
        ``{name or symbol: values}``: a grid (a number or a sequence of
        numbers per name; the Cartesian product), or, with ``n``, random
        samples (``(low, high)`` for a uniform distribution, or a
        ``scipy.stats`` distribution, anything with ``rvs``).  Names are
        the model's constants or its state names (initial values).
    n : int, optional
        Number of random samples.
    seed : int, optional
        Seed of the random samples (``numpy.random.default_rng``).

    Returns
    -------
    names : list of str
    values : ndarray, shape (n_runs, n_names)
    """
    if not isinstance(parameters, dict) or not parameters:
        raise OptionError("parameters must be a non-empty dict {name: values}")
    if not all(isinstance(k, str) for k in parameters):  # dynamic symbols: SymPy loaded
        from ..engine import name_of
    names = [k if isinstance(k, str) else name_of(k) for k in parameters]
    known = set(model.constants) | set(model.state_names)
    unknown = [k for k in names if k not in known]
    if unknown:
        raise ModelError(f"{', '.join(unknown)}: not constant(s) or state(s) of this model; "
                         f"its constants are {', '.join(model.constants) or '(none)'} and "
                         f"its states {', '.join(model.state_names)}")
    if len(set(names)) != len(names):
        raise OptionError(f"a parameter is given twice: {names}")
    specs = list(parameters.values())
    if n is None:
        axes = [_numbers(name, v) for name, v in zip(names, specs)]
        values = np.array(list(itertools.product(*axes)), dtype=float)
        return names, values.reshape(-1, len(names))
    if not isinstance(n, numbers.Integral) or n < 1:
        raise OptionError(f"n (the number of random samples) must be a positive integer, "
                          f"got {n!r}")
    rng = np.random.default_rng(seed)
    columns = []
    for name, spec in zip(names, specs):
        if hasattr(spec, "rvs"):
            column = np.asarray(spec.rvs(size=n, random_state=rng), dtype=float)
        else:
            bounds = _numbers(name, spec)
            if bounds.size != 2 or not bounds[0] < bounds[1]:
                raise OptionError(f"parameter {name}: random samples need (low, high) with "
                                  "low < high, or a scipy.stats distribution")
            column = rng.uniform(bounds[0], bounds[1], n)
        columns.append(column)
    return names, np.column_stack(columns)


def _run_one(model, run, names, values, y0, t_span, outputs, options):
    """One row: the run's parameters, success and message, and its outputs."""
    row = _parameters_row(run, names, values)
    start = time.perf_counter()
    try:
        constants = {k: v for k, v in zip(names, values) if k in model.constants}
        m = model.with_constants(constants) if constants else model
        y = np.array(y0, dtype=float)
        initial = {k: v for k, v in zip(names, values) if k not in model.constants}
        for k, v in initial.items():
            y[model.index(k)] = v
        if initial and model.n_q_dep + model.n_u_dep:
            y = m.consistent_state(t_span[0], y)
        res = simulate(m, t_span, y, **options)
        row.update(success=bool(res.success), status=int(res.status), message=str(res.message))
        _outputs(row, res, outputs, m)
    except Exception as exc:  # a failed run is a row, never a lost sweep
        row.update(success=False, status=-1, message=f"{type(exc).__name__}: {exc}")
    if "wall_time" in outputs:
        row["wall_time"] = time.perf_counter() - start
    return row


def _outputs(row, res, outputs, model):
    """The ``outputs`` of the run ``res`` into ``row`` (``nan`` where a run that
    stopped before its first output time has no value; its message says why)."""
    names = res.state_names
    states = res.y if res.t.size else np.full((len(names), 1), np.nan)
    if "final" in outputs:
        row.update((f"final_{s}", float(v)) for s, v in zip(names, states[:, -1]))
    if "max" in outputs:
        row.update((f"max_{s}", float(v)) for s, v in zip(names, states.max(axis=1)))
    if "min" in outputs:
        row.update((f"min_{s}", float(v)) for s, v in zip(names, states.min(axis=1)))
    if "events" in outputs:
        for k, times in enumerate(res.t_events or ()):
            row[f"event{k}_count"] = int(len(times))
            row[f"event{k}_first"] = float(times[0]) if len(times) else float("nan")
    if "energy" in outputs:
        energy = res.energy
        row["energy_drift"] = (float(np.max(np.abs(energy - energy[0])))
                               if energy is not None and len(energy) else float("nan"))
    if "nfev" in outputs:
        row["rhs_evaluations"] = int(res.nfev)
    if "t_end" in outputs:
        row["t_end"] = float(res.t[-1]) if res.t.size else float("nan")


#: the options of ``simulate`` a sweep's runs may have to be integrated together
_ENSEMBLE_OPTIONS = {"method", "rtol", "atol", "t_eval", "max_step", "first_step", "project",
                     "projection_tol", "events"}


def _expression_events(events):
    """Whether ``events`` (``simulate``'s option) are all expressions
    (:class:`~._events.Event`), which :func:`simulate_many` compiles."""
    from ._events import as_event, listed
    return all(as_event(event) is not None for event in listed(events))


def _ensemble_rows(model, batch, names, y0, t_span, outputs, options, threads):
    """The rows of ``batch`` from one :func:`simulate_many`, or ``None`` where
    ``simulate`` would integrate the runs otherwise than the ensemble does (a
    NumPy model, contacts, a scheme's own integrator, a method other than the
    compiled RK45, events that are Python functions or other options) or the
    outputs need what the ensemble does not keep (every step's state without
    ``t_eval``, energies, each run's wall time).  The numbers are those of
    ``simulate``'s compiled loop.  Where a run's values are refused (a negative
    mass), the batch goes run by run (:func:`_run_one`), whose rows say which
    failed."""
    from ._ensemble import simulate_many
    kept = {"final", "nfev", "t_end", "events"} \
        | ({"max", "min"} if "t_eval" in options else set())
    if (getattr(model, "_c", None) is None or model.contacts or not set(outputs) <= kept
            or getattr(getattr(model, "scheme", None), "integrator", None) is not None
            or not set(options) <= _ENSEMBLE_OPTIONS
            or options.get("method", "RK45") != "RK45"
            or options.get("events") is not None and not _expression_events(options["events"])):
        return None
    values = np.array([v for _, v in batch], dtype=float).reshape(len(batch), len(names))
    constants = {k: values[:, j] for j, k in enumerate(names) if k in model.constants}
    Y0 = np.tile(np.asarray(y0, dtype=float), (len(batch), 1))
    for j, k in enumerate(names):
        if k not in model.constants:
            Y0[:, model.index(k)] = values[:, j]
    try:
        ensemble = simulate_many(model, Y0, t_span, constants=constants or None,
                                 threads=threads,
                                 **{k: v for k, v in options.items() if k != "method"})
    except (ModelError, OptionError):  # a run's values: the runs one by one, failed rows
        return None
    rows = []
    for i, (run, values) in enumerate(batch):
        row = _parameters_row(run, names, values)
        row.update(success=bool(ensemble.status[i] >= 0), status=int(ensemble.status[i]),
                   message=ensemble.message[i])
        _ensemble_outputs(row, ensemble, i, outputs, "t_eval" not in options)
        rows.append(row)
    return rows


def _ensemble_outputs(row, ensemble, i, outputs, every_step):
    """:func:`_outputs` of run ``i`` of an ensemble: its output times reached, and
    the state accepted last where a run that ended early got beyond them (as
    ``simulate`` keeps it), or that a terminal event ended where ``simulate`` would
    have given ``every_step`` (no ``t_eval``)."""
    y = ensemble.y[i]
    reached = np.all(np.isfinite(y), axis=1)
    t, states = ensemble.t[reached], y[reached]
    ended = ensemble.status[i] < 0 or ensemble.status[i] == 1 and every_step
    if ended and (not t.size or ensemble.t_end[i] > t[-1]) \
            and np.all(np.isfinite(ensemble.y_end[i])) and ensemble.t_end[i] != ensemble.t[0]:
        t = np.append(t, ensemble.t_end[i])
        states = np.vstack([states, ensemble.y_end[i]])
    if not t.size:
        t, states = np.array([np.nan]), np.full((1, y.shape[1]), np.nan)
    names = ensemble.state_names
    if "final" in outputs:
        row.update((f"final_{s}", float(v)) for s, v in zip(names, states[-1]))
    if "max" in outputs:
        row.update((f"max_{s}", float(v)) for s, v in zip(names, states.max(axis=0)))
    if "min" in outputs:
        row.update((f"min_{s}", float(v)) for s, v in zip(names, states.min(axis=0)))
    if "events" in outputs:
        for k, times in enumerate(ensemble.t_events[i] if ensemble.t_events else ()):
            row[f"event{k}_count"] = int(len(times))
            row[f"event{k}_first"] = float(times[0]) if len(times) else float("nan")
    if "nfev" in outputs:
        row["rhs_evaluations"] = int(ensemble.nfev[i])
    if "t_end" in outputs:
        row["t_end"] = float(t[-1])


def _parameters_row(run, names, values):
    return dict({"run": int(run)}, **{name: float(v) for name, v in zip(names, values)})


def run_batch(model, batch, names, y0, t_span, outputs, options, timeout=None, threads=1):
    """Rows of a batch of runs ``[(run id, values), ...]`` (one Dask task);
    ``timeout``: the time limit of each run, s (see :func:`sweep`).  Runs
    :func:`~kanedyn.simulation._ensemble.simulate_many` integrates as
    ``simulate`` would are integrated together in C, on ``threads`` threads
    (None: every CPU; see :func:`_ensemble_rows`)."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a worker has no one to warn; messages are rows
        if timeout is None:
            rows = _ensemble_rows(model, batch, names, y0, t_span, outputs, options, threads)
            if rows is not None:
                return rows
            return [_run_one(model, run, names, values, y0, t_span, outputs, options)
                    for run, values in batch]
        options = dict(options, timeout=timeout)
        return [_run_limited(model, run, names, values, y0, t_span, outputs, options,
                             timeout) for run, values in batch]


def _run_limited(model, run, names, values, y0, t_span, outputs, options, timeout):
    """:func:`_run_one` on a thread of its own, abandoned (and asked to stop) when
    it has not returned after twice its time limit plus :data:`GRACE` s: its
    integration stops at the limit, so only a function of the model that does
    not return (an input's, an event's) holds it."""
    box = {}

    def target():
        try:
            box["row"] = _run_one(model, run, names, values, y0, t_span, outputs, options)
        except _Abandoned:  # _ask_to_stop reached it
            pass
    thread = threading.Thread(target=target, daemon=True, name=f"kanedyn sweep run {run}")
    start = time.perf_counter()
    thread.start()
    thread.join(2 * timeout + GRACE)
    if "row" in box:
        return box["row"]
    _ask_to_stop(thread)
    row = _parameters_row(run, names, values)
    row.update(success=False, status=-1, message=(
        f"the time limit of {timeout:g} s was reached and the run did not return within "
        f"{timeout + GRACE:g} s more (stuck in a function of the model, an input's or an "
        "event's?); it was abandoned"))
    if "wall_time" in outputs:
        row["wall_time"] = time.perf_counter() - start
    return row


class _Abandoned(BaseException):
    """Raised in the thread of an abandoned run (not an ``Exception``: a run
    catches those)."""


def _ask_to_stop(thread):
    """Raise :class:`_Abandoned` in ``thread`` when it next runs Python code (a
    loop in Python stops; a call that blocks in C keeps the thread until it
    returns).  Best effort, through CPython's ``PyThreadState_SetAsyncExc``."""
    import ctypes
    set_exception = getattr(getattr(ctypes, "pythonapi", None), "PyThreadState_SetAsyncExc",
                            None)
    if set_exception is not None and thread.ident is not None:
        set_exception(ctypes.c_ulong(thread.ident), ctypes.py_object(_Abandoned))


# ------------------------------------------------------------- storage
def _fingerprint(model, names, values, y0, t_span, outputs, options):
    """What identifies a sweep, for resuming it in the same folder."""
    digest = hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest()
    return {"parameters": names, "runs": int(len(values)), "values_sha256": digest,
            "y0": [float(v) for v in y0], "t_span": [float(t) for t in t_span],
            "outputs": sorted(outputs), "options": {k: _describe(v) for k, v in
                                                    sorted(options.items())},
            "states": list(model.state_names), "constants": dict(model.constants),
            "backend": model._data["backend"]}


def _describe(value):
    """Text identifying an option (functions by name: their repr has an address)."""
    if isinstance(value, (list, tuple)):
        return [_describe(v) for v in value]
    if callable(value):
        return f"{getattr(value, '__module__', '')}.{getattr(value, '__qualname__', '')}"
    return repr(value)


def _open_folder(out, fingerprint):
    """Create or check the output folder; the run ids already saved."""
    pd = _need("pandas")
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptionError(f"cannot create the output folder {out}: "
                          f"{exc.strerror or exc}") from None
    manifest = out / _MANIFEST
    if manifest.exists():
        try:
            saved = json.loads(manifest.read_text())
        except ValueError:
            raise OptionError(f"{manifest} is not a sweep description (JSON); "
                              "use another folder") from None
        differ = sorted(k for k in set(saved) | set(fingerprint)
                        if saved.get(k) != fingerprint.get(k))
        if differ:
            raise OptionError(f"the folder {out} holds another sweep (its "
                              f"{', '.join(differ)} differ); use another folder, or "
                              "delete it to start again")
    else:
        with replacing(manifest) as handle:
            handle.write(json.dumps(fingerprint, indent=1))
    done = set()
    for part in sorted(out.glob("part-*.parquet")):
        done.update(int(r) for r in pd.read_parquet(part, columns=["run"])["run"])
    return out, done


def _write_part(out, rows):
    pd = _need("pandas")
    first = min(r["run"] for r in rows)
    with replacing(out / _PART.format(first), "wb") as handle:  # all of it or nothing
        pd.DataFrame(rows).to_parquet(handle, index=False)


def _table(rows, out, names):
    """All rows, sorted by run; from the part files when there is a folder."""
    pd = _need("pandas")
    if out is not None:
        parts = sorted(out.glob("part-*.parquet"))
        frames = [pd.read_parquet(p) for p in parts]
        table = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    else:
        table = pd.DataFrame(rows)
    if table.empty:
        return pd.DataFrame(columns=["run", *names, "success", "status", "message"])
    first = ["run", *names, "success", "status", "message"]
    table = table[first + [c for c in table.columns if c not in first]]
    return table.sort_values("run", kind="stable").reset_index(drop=True)


# --------------------------------------------------------------- sweep
def sweep(model, parameters, y0, t_span, outputs=("final",), *, n=None, seed=None,
          out=None, table_format="parquet", scheduler=None, client=None, n_workers=2,
          batch_size=None, progress=True, timeout=None, **options):
    """Simulate ``model`` over a grid or random samples of its parameters.

    Parameters
    ----------
    model : NumericModel
        The compiled model (either backend); pickled once and broadcast to
        the workers.  Its specified inputs must be picklable (numbers, SymPy
        expressions, or functions defined at module level).
    parameters : dict
        ``{name or symbol: values}`` of constants (``model.constants``) and
        initial values (state names, e.g. ``"q1"``).  A grid: a number or a
        sequence of numbers each, all combinations run.  With ``n``: random
        samples, ``(low, high)`` (uniform) or a ``scipy.stats`` distribution
        each.
    y0 : array_like or dict
        The initial state, shape ``(n_states,)`` (or ``{name: value}``, see
        :meth:`NumericModel.state`); swept initial values replace entries.
    t_span : (float, float)
        Start and end time of every run, s.
    outputs : sequence of str
        Quantities recorded per run besides ``run`` (the run id), the
        parameters, ``success``, ``status`` and ``message``: any of
        :data:`SWEEP_OUTPUTS` (``"final"``, ``"max"``, ``"min"``, ``"events"``,
        ``"energy"``, ``"nfev"``, ``"wall_time"``, ``"t_end"``).
    n : int, optional
        Number of random samples (then ``parameters`` gives distributions).
    seed : int, optional
        Seed of the random samples.
    out : str or os.PathLike, optional
        Output folder.  Each finished batch is written there at once as
        ``part-<first run>.parquet``, then the whole table as
        ``results.parquet`` (or ``results.csv``).  Running the same sweep
        with the same folder again skips the runs already saved (resume
        after Ctrl-C or a crash); a folder of another sweep is refused.
    table_format : {"parquet", "csv"}
        Format of the combined table in ``out``.
    scheduler : str, optional
        Address of a Dask scheduler (``"tcp://host:8786"``), checked before
        use (:func:`check_scheduler`).  Default: a local cluster of
        ``n_workers`` processes, closed at the end; ``"serial"``: no Dask, the
        runs one after another in this process.
    client : distributed.Client, optional
        An existing Dask client to use (then ``scheduler`` is ignored).
    n_workers : int
        Worker processes of the local cluster.
    batch_size : int, optional
        Runs per task (default: about eight tasks per worker, at most 64
        runs each).
    progress : bool
        Show a progress bar (tqdm) on stderr.
    timeout : float, optional
        Time limit of each run, s: its integration stops there (checked as
        it goes, :func:`kanedyn.simulate`'s ``timeout``) and the run is a
        row with ``success=False``, a message naming the limit and the
        outputs of what it computed.  A run that does not return (stuck in a
        function of the model) is abandoned after twice the limit plus
        :data:`GRACE` s: a row with that message.  Default: no limit.
    **options
        Passed on to :func:`kanedyn.simulate` (``rtol``, ``atol``,
        ``method``, ``events``, ``backend``, ``max_step``, ...).

    Returns
    -------
    pandas.DataFrame
        One row per run, sorted by ``run``.  A run that raised or did not
        succeed is a row with ``success=False`` and its message.

    Raises
    ------
    ModelError
        A parameter name that is neither a constant nor a state of the model.
    OptionError
        Bad options, an output folder that holds another sweep, or a
        scheduler that does not answer as one.
    SweepInterrupted
        On Ctrl-C; the finished runs are saved (with ``out``) and in its
        ``table``; the message says how to resume.
    """
    _need("pandas")  # before any work: the table needs it
    names, values = parameter_runs(model, parameters, n=n, seed=seed)
    outputs = (outputs,) if isinstance(outputs, str) else tuple(outputs)
    bad = [o for o in outputs if o not in SWEEP_OUTPUTS]
    if bad:
        raise OptionError(f"unknown output(s) {', '.join(map(repr, bad))}; available: "
                          f"{', '.join(SWEEP_OUTPUTS)}")
    if table_format not in ("parquet", "csv"):
        raise OptionError(f"table_format must be 'parquet' or 'csv', not {table_format!r}")
    timeout = check_timeout(timeout)
    y0 = model.state(y0, t_span[0]) if isinstance(y0, dict) else np.array(y0, dtype=float)
    if y0.shape != (model.n_states,):
        raise OptionError(f"y0 must have {model.n_states} entries "
                          f"({', '.join(model.state_names)}), got shape {y0.shape}")
    t_span = tuple(float(t) for t in t_span)
    if len(t_span) != 2:
        raise OptionError("t_span must be (start, end)")
    if client is None:
        scheduler = check_scheduler(scheduler)
    fingerprint = _fingerprint(model, names, values, y0, t_span, outputs, options)
    done = set()
    if out is not None:
        out, done = _open_folder(out, fingerprint)
    todo = [(run, values[run]) for run in range(len(values)) if run not in done]
    workers = 1 if scheduler == "serial" else max(1, int(n_workers))
    size = batch_size or max(1, min(64, math.ceil(len(todo) / (8 * workers)) or 1))
    batches = [todo[i:i + size] for i in range(0, len(todo), size)]
    rows = []
    tqdm = _need("tqdm").tqdm
    bar = tqdm(total=len(values), initial=len(done), unit="run", disable=not progress,
               desc="sweep", file=sys.stderr)
    args = (names, y0, t_span, outputs, options, timeout)

    def finished(batch_rows):
        if out is not None:
            _write_part(out, batch_rows)
        else:
            rows.extend(batch_rows)
        bar.update(len(batch_rows))

    try:
        if scheduler == "serial" and client is None:
            for batch in batches:
                finished(run_batch(model, batch, *args, threads=None))
        elif batches:
            _on_dask(model, batches, args, finished, scheduler, client, workers)
    except KeyboardInterrupt:
        bar.close()
        table = _table(rows, out, names)
        where = (f"saved in {out}; run the same sweep again with out={str(out)!r} to finish "
                 "it (saved runs are skipped)" if out is not None else
                 "kept in this exception's table (give out=... to make sweeps resumable)")
        raise SweepInterrupted(f"sweep interrupted: {len(table)} of {len(values)} runs "
                               f"{where}", table, total=len(values), out=out) from None
    bar.close()
    table = _table(rows, out, names)
    if out is not None:
        with replacing(out / f"results.{table_format}",
                       "w" if table_format == "csv" else "wb", newline="") as handle:
            if table_format == "csv":
                table.to_csv(handle, index=False)
            else:
                table.to_parquet(handle, index=False)
    return table


def check_scheduler(scheduler):
    """``scheduler`` of :func:`sweep`, checked before use.

    ``None`` (a local cluster), ``"serial"`` and Dask cluster objects are
    returned as they are; an address must be well formed and answer, within
    a few seconds, as a Dask scheduler.

    Raises
    ------
    OptionError
        One line naming the address and what is wrong with it: malformed (no
        port, an unknown scheme), nothing listening, no answer (something
        other than Dask listens there), or a Dask server that is not a
        scheduler.
    """
    if scheduler is None or scheduler == "serial":
        return scheduler
    if not isinstance(scheduler, str):
        if hasattr(scheduler, "scheduler_address"):  # a Dask cluster object
            return scheduler
        raise OptionError(f"scheduler must be an address ('tcp://host:8786'), 'serial' or "
                          f"a Dask cluster, not {type(scheduler).__name__}")
    _need("distributed")
    from distributed.comm import parse_address, parse_host_port
    from distributed.comm.registry import backends
    address = scheduler.strip()
    try:
        scheme, location = parse_address(address)
        if scheme not in backends:
            raise ValueError(f"unknown scheme {scheme!r}; known: {', '.join(sorted(backends))}")
        if scheme != "inproc":
            parse_host_port(location)
    except ValueError as exc:
        raise OptionError(f"scheduler {scheduler!r} is not a Dask scheduler address ({exc}); "
                          "give tcp://host:port, or 'serial'") from None
    reply, error = _identity(address, _CONNECT_SECONDS)
    if error is not None:
        why = ("it accepted the connection but did not answer: is something other than "
               "a Dask scheduler listening there?" if isinstance(error, TimeoutError)
               else f"{type(error).__name__}: {error}".rstrip(": "))
        raise OptionError(f"scheduler {address}: no Dask scheduler answered within "
                          f"{_CONNECT_SECONDS:g} s ({why})")
    kind = reply.get("type") if isinstance(reply, dict) else None
    if kind != "Scheduler":
        raise OptionError(f"scheduler {address}: the Dask server there is a {kind or 'server'}, "
                          "not a scheduler")
    return address


def _identity(address, seconds):
    """``(reply, error)`` of the Dask server at ``address`` asked who it is,
    within ``seconds``: an ``OSError`` when no connection was made in 80 % of
    them, a ``TimeoutError`` when a connection made got no answer (on a thread
    of its own with its own event loop, so that this works where an event loop
    runs already, as in a notebook)."""
    from distributed.core import rpc
    import asyncio
    box = {}

    async def ask():
        server = rpc(address, timeout=0.8 * seconds)
        try:
            return await server.identity()
        finally:
            await server.close_rpc()

    def run():
        try:
            box["reply"] = asyncio.run(asyncio.wait_for(ask(), seconds))
        except Exception as exc:  # noqa: BLE001  (reported as the reason)
            box["error"] = exc

    thread = threading.Thread(target=run, daemon=True, name="kanedyn scheduler check")
    thread.start()
    thread.join(seconds + 2.0)
    if thread.is_alive():
        return None, TimeoutError()
    return box.get("reply"), box.get("error")


def _wait_for_a_worker(client, scheduler):
    """A scheduler without workers would keep the sweep waiting: give it
    :data:`_WORKER_WAIT_SECONDS` to get one, then refuse."""
    try:
        client.wait_for_workers(1, timeout=_WORKER_WAIT_SECONDS)
    except TimeoutError:
        client.close()
        raise OptionError(f"the Dask scheduler {scheduler} has no workers (none joined within "
                          f"{_WORKER_WAIT_SECONDS:g} s); start some with `dask worker "
                          f"{scheduler}`") from None


def _on_dask(model, batches, args, finished, scheduler, client, n_workers):
    """Submit the batches to a Dask cluster; ``finished(rows)`` for each result.

    A batch whose task fails for a reason outside the runs (a worker lost
    more often than the scheduler allows) is resubmitted twice, then
    recorded as failed runs.
    """
    distributed = _need("distributed")
    own_cluster = own_client = None
    if client is None:
        if scheduler is None:
            own_cluster = distributed.LocalCluster(
                n_workers=n_workers, threads_per_worker=1, processes=True,
                dashboard_address=None, silence_logs=logging.ERROR)
            scheduler = own_cluster
        try:
            client = own_client = distributed.Client(scheduler, timeout=_CONNECT_SECONDS)
        except OSError as exc:
            if own_cluster is not None:
                own_cluster.close()
            raise OptionError(f"cannot reach the Dask scheduler {scheduler}: {exc}") from None
        if own_cluster is None:
            _wait_for_a_worker(client, scheduler)
    futures = {}
    try:
        shipped = client.scatter(model, broadcast=True, hash=False)

        def submit(batch, attempt):
            future = client.submit(run_batch, shipped, batch, *args, pure=False,
                                   retries=1)
            futures[future] = (batch, attempt)
            return future

        pending = distributed.as_completed([submit(b, 0) for b in batches])
        for future in pending:
            batch, attempt = futures.pop(future)
            try:
                rows = future.result()
            except Exception as exc:
                if attempt < 2:
                    if shipped.status != "finished":
                        shipped = client.scatter(model, broadcast=True, hash=False)
                    pending.add(submit(batch, attempt + 1))
                    continue
                rows = [dict(_parameters_row(run, args[0], values), success=False,
                             status=-1, message=f"task failed: {type(exc).__name__}: {exc}")
                        for run, values in batch]
            finished(rows)
    finally:
        for future in list(futures):
            future.cancel()
        if own_client is not None:
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()
