"""Numerical speed of kanedyn's models: kanedyn vs Pinocchio, same run.

Every ratio printed is between numbers measured in this run, on this machine
(design rule 15). The model is the spatial chain ``chain3d`` (n links, revolute
joints alternating between z and x, gravity), built by kanedyn with
``style="positions"`` and, for Pinocchio, by :func:`_peers.pinocchio_chain`
(the same chain in Pinocchio's own terms).

The script measures

1. right-hand side per call from Python, n = 2, 5, 10, 30, 60: kanedyn's compiled
   ``model.rhs(0.0, y)`` (backend ``"c"``) and, for n <= 10, its numpy
   backend, against ``pinocchio.aba(model, data, q, v, tau)``; the agreement
   of the accelerations; kanedyn's derivation time and the time to generate
   and compile the C extension (the compile cache is a fresh temporary
   directory, so every compile is real);
2. batch evaluation of k = 10000 random states of the n = 10 chain:
   ``model.rhs_batch(0.0, Y)`` against ``model.rhs`` called in a Python loop,
   for both backends, and a loop of ``pinocchio.aba`` for reference;
3. simulation of the n = 5 chain over 10 s at rtol = atol = 1e-8:
   ``kanedyn.simulate`` (compiled RK45 loop) against
   ``scipy.integrate.solve_ivp`` driving ``pinocchio.aba`` and driving
   kanedyn's own compiled right-hand side;
4. large models, each in a fresh subprocess: model-building and derivation
   time, peak memory and operation counts for n = 10 .. 60.

Usage::

    python benchmarks/bench_numerics.py              # full run, a few minutes
    python benchmarks/bench_numerics.py --quick      # fewer repeats, no n = 60, no v2pt
    python benchmarks/bench_numerics.py --markdown   # tables as markdown

Progress goes to stderr, the tables to stdout. Needs Pinocchio
(``pip install pin``, the ``bench`` extra) and a C compiler.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy
from scipy.integrate import solve_ivp

import kanedyn as kd

# _peers lives next to this script (on sys.path when the script is run directly)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _peers import pinocchio_chain
from _timing import interleaved, optimized_modules_only, winner

#: Chains of the right-hand-side comparison (60 not with --quick); the numpy
#: backend only up to 10.
RHS_SIZES = (2, 5, 10, 30, 60)
NUMPY_MAX_N = 10
#: Batch size and chain of the batch comparison.
BATCH_STATES = 10_000
BATCH_N = 10
#: Chain, interval and tolerances of the simulation comparison.
SIM_N = 5
SIM_SPAN = (0.0, 10.0)
SIM_TOL = 1e-8
#: Regular initial state of the simulation (link 2 hanging down).
SIM_Y0 = (0.2, -math.pi / 2 + 0.3, 0.2, -0.2, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0)
#: (style, n) of the large-model measurements, in that order.
LARGE_CASES = (("positions", 10), ("positions", 20), ("positions", 30),
               ("positions", 60), ("v2pt", 30))


def log(message):
    """Progress message on stderr."""
    print(message, file=sys.stderr, flush=True)


# ----------------------------------------------------------------- helpers
def source_revision():
    """Short git hash of the checkout (``-dirty`` if modified), or ``"?"``."""
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty"],
                             cwd=os.path.dirname(os.path.abspath(__file__)),
                             capture_output=True, text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return "?"
    return out.stdout.strip() if out.returncode == 0 and out.stdout.strip() else "?"


def load_average():
    """The 1, 5 and 15 minute load averages as text, or ``"?"``."""
    if not hasattr(os, "getloadavg"):
        return "?"
    return ", ".join(f"{x:.1f}" for x in os.getloadavg())


def cpu_name():
    """The CPU's model name (``/proc/cpuinfo``), else ``platform.processor()`` or "unknown"."""
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine_info():
    """One line describing the machine and the versions measured.

    Returns
    -------
    str
    """
    import pinocchio as pin
    import sympy

    cpu = cpu_name()
    return (f"{datetime.date.today().isoformat()} | {platform.platform()} | CPU {cpu} "
            f"({os.cpu_count()} logical, load {load_average()}) | "
            f"Python {platform.python_version()} | NumPy {np.__version__} | "
            f"SciPy {scipy.__version__} | SymPy {sympy.__version__} | "
            f"pinocchio {pin.__version__} | kanedyn {kd.__version__} "
            f"(git {source_revision()})")


def best_seconds(func, repeat, min_time):
    """Best thread CPU time of one call of ``func()``, in seconds.

    Parameters
    ----------
    func : callable
        Called without arguments.
    repeat : int
        Number of rounds; the fastest is kept (see :mod:`_timing`).
    min_time : float
        Each round calls ``func`` often enough to last at least this long, s.

    Returns
    -------
    float
    """
    return interleaved({"f": func}, rounds=repeat, min_time=min_time)["f"].best


def timed(func):
    """``(result, seconds)`` of one call of ``func()``."""
    start = time.perf_counter()
    result = func()
    return result, time.perf_counter() - start


def random_states(n, count, seed):
    """``count`` random chain states ``[q, u]``, shape ``(count, 2 n)``.

    Angles uniform in (-pi, pi), speeds uniform in (-2, 2) rad/s.
    """
    rng = np.random.default_rng(seed)
    return np.hstack([rng.uniform(-np.pi, np.pi, (count, n)),
                      rng.uniform(-2.0, 2.0, (count, n))])


# ------------------------------------------------------------ the models
def build_chain(n, numpy_backend):
    """kanedyn's and Pinocchio's n-link chain, with build times.

    Parameters
    ----------
    n : int
        Number of links.
    numpy_backend : bool
        Also build kanedyn's numpy-backend model.

    Returns
    -------
    dict
        ``n``, ``definition``, ``eom``, ``derive_s`` (``definition.derive()``),
        ``c`` and ``c_build_s`` (``definition.numeric(eom, backend="c")``:
        C generation and compilation with an empty cache), ``numpy`` and
        ``numpy_build_s`` (or ``None``), ``pin_model``, ``pin_data``.
    """
    definition = kd.models.build("chain3d", n=n, style="positions")
    eom, derive_s = timed(definition.derive)
    model_c, c_build_s = timed(lambda: definition.numeric(eom, backend="c"))
    model_np = numpy_build_s = None
    if numpy_backend:
        model_np, numpy_build_s = timed(lambda: definition.numeric(eom, backend="numpy"))
    pin_model, pin_data = pinocchio_chain(n)
    return {"n": n, "definition": definition, "eom": eom, "derive_s": derive_s,
            "c": model_c, "c_build_s": c_build_s, "numpy": model_np,
            "numpy_build_s": numpy_build_s, "pin_model": pin_model, "pin_data": pin_data}


def acceleration_difference(model, pin_model, pin_data, states):
    """Largest relative difference of kanedyn's u' and ``pinocchio.aba``.

    Parameters
    ----------
    model : NumericModel
        kanedyn's chain.
    pin_model, pin_data
        Pinocchio's chain.
    states : numpy.ndarray
        Shape ``(k, 2 n)``.

    Returns
    -------
    float
        ``max over states of max|u'_kanedyn - u'_aba| / max|u'_aba|``.
    """
    import pinocchio as pin

    n = states.shape[1] // 2
    tau = np.zeros(n)
    worst = 0.0
    for y in states:
        ours = model.rhs(0.0, y)[n:]
        theirs = np.array(pin.aba(pin_model, pin_data, y[:n].copy(), y[n:].copy(), tau))
        worst = max(worst, float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs))))
    return worst


# ------------------------------------------------ 1. right-hand side per call
def measure_rhs(chain, repeat, min_time):
    """Microseconds per right-hand-side call, kanedyn and Pinocchio.

    Parameters
    ----------
    chain : dict
        From :func:`build_chain`.
    repeat, min_time
        See :func:`best_seconds`.

    Returns
    -------
    dict
        One table row: times in µs, ratio, accuracy, build times.
    """
    import pinocchio as pin

    n = chain["n"]
    y = random_states(n, 1, seed=0)[0]
    q, v, tau = y[:n].copy(), y[n:].copy(), np.zeros(n)
    model_c, model_np = chain["c"], chain["numpy"]
    pm, pd = chain["pin_model"], chain["pin_data"]
    row = {"n": n, "derive_s": chain["derive_s"], "c_build_s": chain["c_build_s"],
           "numpy_build_s": chain["numpy_build_s"]}
    contenders = {"c": lambda: model_c.rhs(0.0, y), "pin": lambda: pin.aba(pm, pd, q, v, tau)}
    if model_np is not None:
        contenders["numpy"] = lambda: model_np.rhs(0.0, y)
    timings = interleaved(contenders, rounds=repeat, min_time=min_time)
    row["c_us"] = timings["c"].best * 1e6
    row["pin_us"] = timings["pin"].best * 1e6
    row["spreads"] = {name: t.spread for name, t in timings.items()}
    row["winner"] = winner({k: timings[k] for k in ("c", "pin")})
    row["numpy_us"] = None
    if model_np is not None:
        row["numpy_us"] = timings["numpy"].best * 1e6
    states = random_states(n, 100, seed=1)
    row["diff_c"] = acceleration_difference(model_c, pm, pd, states)
    row["diff_numpy"] = (acceleration_difference(model_np, pm, pd, states)
                         if model_np is not None else None)
    return row


RHS_COLUMNS = ("n", "kanedyn C µs", "pin.aba µs", "ratio C/pin", "kanedyn numpy µs",
               "ratio numpy/pin", "max rel. diff of u'", "derive s", "C build s",
               "numpy build s")


def rhs_cells(row):
    """Table cells of one row of :func:`measure_rhs`."""
    numpy_measured = row["numpy_us"] is not None
    diff = f"{row['diff_c']:.1e}"
    if numpy_measured:
        diff += f" / {row['diff_numpy']:.1e}"
    return [str(row["n"]), f"{row['c_us']:.2f}", f"{row['pin_us']:.2f}",
            f"{row['c_us'] / row['pin_us']:.2f}",
            f"{row['numpy_us']:.0f}" if numpy_measured else "-",
            f"{row['numpy_us'] / row['pin_us']:.0f}" if numpy_measured else "-",
            diff, f"{row['derive_s']:.2f}", f"{row['c_build_s']:.2f}",
            f"{row['numpy_build_s']:.2f}" if numpy_measured else "-"]


RHS_NOTES = """\
- One generic random state (angles in (-pi, pi), speeds in (-2, 2) rad/s); best of
  {repeat} timeit runs of at least {min_time:g} s each. kanedyn: model.rhs(0.0, y),
  which returns the whole state derivative [q', u'] (2n values); Pinocchio:
  pin.aba(model, data, q, v, tau) with tau = 0, which returns u' (n values).
  ratio < 1: kanedyn is faster. kanedyn forms the mass matrix and solves
  M u' = F by Cholesky factorization (O(n^3)); Pinocchio's ABA is O(n).
- max rel. diff of u': max over 100 random states of max|u'_kanedyn - u'_aba| /
  max|u'_aba|; C backend / numpy backend.
- derive s: definition.derive() (style="positions"). C build s:
  definition.numeric(eom, backend="c") with an empty compile cache (C code
  generation + compilation + import). numpy build s: the same for backend="numpy"."""


# --------------------------------------------------------- 2. batch evaluation
def measure_batch(chain, count, repeat, min_time):
    """Per-state cost of batch evaluation against a Python loop of ``rhs``.

    All contenders interleaved in rounds (:func:`_timing.interleaved`):
    thread CPU time for single-threaded code; wall time for the C batch on
    every CPU (its threads' CPU time is not what the caller waits for).

    Parameters
    ----------
    chain : dict
        From :func:`build_chain`, with both backends.
    count : int
        Number of random states.
    repeat, min_time
        Rounds, and the least duration of one timing, s.

    Returns
    -------
    list of dict
        One row per way of evaluating: ``label``, ``us`` (per state, minimum),
        ``spread`` (median / min - 1), and for kanedyn's batches ``loop_us``,
        ``loop_spread``, ``ratio`` (loop / batch, minima), ``winner`` (the
        batch, the loop or ``None`` when the spreads overlap) and ``diff``
        (max |batch - loop|).
    """
    import pinocchio as pin

    n = chain["n"]
    Y = random_states(n, count, seed=2)
    mc, mn = chain["c"], chain["numpy"]
    pm, pd, tau = chain["pin_model"], chain["pin_data"], np.zeros(n)
    contenders = {
        "c batch, all CPUs": lambda: mc.rhs_batch(0.0, Y),
        "c batch, 1 thread": lambda: mc.rhs_batch(0.0, Y, threads=1),
        "c batch scalar, 1 thread": lambda: mc.rhs_batch(0.0, Y, threads=1, lanes=False),
        "c loop": lambda: [mc.rhs(0.0, y) for y in Y],
        "numpy batch": lambda: mn.rhs_batch(0.0, Y),
        "numpy loop": lambda: [mn.rhs(0.0, y) for y in Y],
        "pin.aba loop": lambda: [pin.aba(pm, pd, y[:n], y[n:], tau) for y in Y],
    }
    clocks = dict.fromkeys(contenders, "thread")
    clocks["c batch, all CPUs"] = "wall"
    timings = interleaved(contenders, rounds=repeat, min_time=min_time, clock=clocks)
    log("batch: timed")
    rows = []
    for label, loop, model, kwargs in (
            ("c batch, all CPUs", "c loop", mc, {}),
            ("c batch, 1 thread", "c loop", mc, {"threads": 1}),
            ("c batch scalar, 1 thread", "c loop", mc, {"threads": 1, "lanes": False}),
            ("numpy batch", "numpy loop", mn, {})):
        tb, tl = timings[label], timings[loop]
        diff = float(np.max(np.abs(model.rhs_batch(0.0, Y, **kwargs)
                                   - np.array([model.rhs(0.0, y) for y in Y]))))
        rows.append({"label": f"kanedyn {label}", "us": tb.best / count * 1e6,
                     "spread": tb.spread, "loop_us": tl.best / count * 1e6,
                     "loop_spread": tl.spread, "ratio": tl.best / tb.best,
                     "winner": winner([tb, tl]), "diff": diff})
    tp = timings["pin.aba loop"]
    rows.append({"label": "pin.aba", "us": None, "spread": None,
                 "loop_us": tp.best / count * 1e6, "loop_spread": tp.spread,
                 "ratio": None, "winner": None, "diff": None})
    return rows


BATCH_COLUMNS = ("backend", "rhs_batch µs/state", "rhs loop µs/state",
                 "loop/batch", "clear winner", "max |batch - loop|")


def batch_cells(row):
    """Table cells of one row of :func:`measure_batch`."""
    loop = f"{row['loop_us']:.2f} (+{row['loop_spread']:.0%})"
    if row["us"] is None:
        return [row["label"] + " (loop, reference)", "-", loop, "-", "-", "-"]
    return [row["label"], f"{row['us']:.3f} (+{row['spread']:.0%})", loop,
            f"{row['ratio']:.1f}x", row["winner"] or "none (spreads overlap)",
            f"{row['diff']:.1e}"]


BATCH_NOTES = """\
- n = {n} chain, k = {count} random states Y (shape (k, {states})); per-state time =
  minimum over {repeat} interleaved rounds / k (spread: median / min - 1, in
  brackets). Thread CPU time, except the C batch on all CPUs (wall time).
  batch: model.rhs_batch(0.0, Y[, threads=1]) (C: 4 states per SIMD op, "scalar":
  lanes=False, one state at a time); loop: [model.rhs(0.0, y) for y in Y];
  pin.aba: [pin.aba(model, data, y[:n], y[n:], tau) for y in Y] (accelerations only).
- Targets: numpy batch >= 20x faster per state than its rhs loop; C batch >= 3x
  faster per state than its rhs loop (all CPUs: rows in blocks over threads)."""


# ------------------------------------------------------- 3. compiled simulation
def measure_simulation(chain, repeat, min_time):
    """Wall time and agreement of four ways to integrate the chain.

    Parameters
    ----------
    chain : dict
        From :func:`build_chain` (n = :data:`SIM_N`).
    repeat, min_time
        See :func:`best_seconds`.

    Returns
    -------
    rows : list of dict
        ``label``, ``seconds``, ``nfev``, ``diff`` (max |y(10) - y_pin(10)|),
        ``error`` (max |y(10) - y_ref(10)|, reference: DOP853 at 1e-12).
    info : dict
        ``method`` of the kanedyn result, ``chaotic_diff`` (the same
        comparison from the model's default, chaotic initial state) and
        ``steps`` (output points of kd.simulate).
    """
    import pinocchio as pin

    n, model = chain["n"], chain["c"]
    pm, pd, tau = chain["pin_model"], chain["pin_data"], np.zeros(n)
    y0 = np.array(SIM_Y0, dtype=float)
    atol = np.full(2 * n, SIM_TOL)

    def pin_fun(t, y):
        return np.concatenate([y[n:], pin.aba(pm, pd, y[:n], y[n:], tau)])

    def with_pinocchio(y_start=y0, method="RK45", tol=SIM_TOL):
        res = solve_ivp(pin_fun, SIM_SPAN, y_start, method=method, rtol=tol, atol=tol)
        return res.y[:, -1], res.nfev

    def compiled(y_start=y0):
        res = kd.simulate(model, SIM_SPAN, y_start, rtol=SIM_TOL, atol=SIM_TOL)
        return res

    def integrate_only():
        out = model._c.integrate(SIM_SPAN[0], SIM_SPAN[1], y0, None, SIM_TOL, atol,
                                 np.inf, 0.0, "RK45", None, 0.0, False)
        return out["y"][-1], out["nfev"]

    def with_kanedyn_rhs():
        res = solve_ivp(model.rhs, SIM_SPAN, y0, method="RK45", rtol=SIM_TOL, atol=SIM_TOL)
        return res.y[:, -1], res.nfev

    reference, _ = with_pinocchio(method="DOP853", tol=1e-12)
    result = compiled()
    runs = [("kd.simulate (compiled RK45)", compiled,
             lambda: (result.y[:, -1], result.nfev)),
            ("model._c.integrate (compiled RK45, integration only)", integrate_only,
             integrate_only),
            (PIN_RUN, with_pinocchio, with_pinocchio),
            ("solve_ivp RK45 + kanedyn C rhs", with_kanedyn_rhs, with_kanedyn_rhs)]
    rows = []
    for label, func, final in runs:
        y_end, nfev = final()
        rows.append({"label": label, "seconds": best_seconds(func, repeat, min_time),
                     "nfev": int(nfev), "y_end": y_end,
                     "error": float(np.max(np.abs(y_end - reference)))})
        log(f"simulation: {label} done")
    y_pin = next(row["y_end"] for row in rows if row["label"] == PIN_RUN)
    for row in rows:
        row["diff"] = float(np.max(np.abs(row["y_end"] - y_pin)))

    y_default = chain["definition"].initial(model)
    chaotic_ours = compiled(y_default).y[:, -1]
    chaotic_pin, _ = with_pinocchio(y_default)
    info = {"method": result.method, "steps": result.t.size,
            "chaotic_diff": float(np.max(np.abs(chaotic_ours - chaotic_pin))),
            "y_default": y_default}
    return rows, info


#: Label of the reference run of the simulation table.
PIN_RUN = "solve_ivp RK45 + pin.aba"

SIM_COLUMNS = ("integration", "wall ms", "pin+solve_ivp / this", "nfev",
               "max |y(10) - y_pin(10)|", "max |y(10) - y_ref(10)|")


def simulation_cells(row, pin_seconds):
    """Table cells of one row of :func:`measure_simulation`."""
    return [row["label"], f"{row['seconds'] * 1e3:.2f}",
            f"{pin_seconds / row['seconds']:.1f}x", str(row["nfev"]),
            f"{row['diff']:.1e}", f"{row['error']:.1e}"]


SIM_NOTES = """\
- n = {n} chain over t = 0 .. 10 s, rtol = atol = {tol:g}, from the regular state
  y0 = [0.2, -pi/2 + 0.3, 0.2, -0.2, 0.1, 0, 0, 0, 0, 0] (link 2 hanging down).
  Wall time: best of {repeat} runs of at least {min_time:g} s each.
- kd.simulate(model, (0, 10), y0, rtol=1e-8, atol=1e-8) with a backend="c"
  model (result.method = {method!r}); after integrating it also computes
  the energy and constraint-residual histories at its {steps} output points.
  model._c.integrate(...) is the private compiled entry point kd.simulate
  calls, timed alone to separate the integration (private API; fine for a
  benchmark, not for users).
- solve_ivp RK45 + pin.aba: fun = lambda t, y: np.concatenate([y[n:], pin.aba(model,
  data, y[:n], y[n:], tau)]). solve_ivp RK45 + kanedyn C rhs: fun = model.rhs.
- y_pin: solve_ivp + pin.aba's final state; y_ref: solve_ivp DOP853 + pin.aba at
  rtol = atol = 1e-12 (the error of each integration, not just their agreement).
- From the model's default initial state, y0 = {y_default}, the
  chain falls and is chaotic: the compiled loop and solve_ivp + pin.aba, both
  correct to their tolerance, end {chaotic:.2g} apart (max abs. over the state)
  at t = 10 s, so agreement cannot be measured there; hence the regular state."""


# ----------------------------------------------------------- 4. large models
def peak_memory_mb():
    """Peak resident memory of this process so far, MiB.

    ``VmHWM`` of ``/proc/self/status`` where it exists (Linux): the high-water
    mark of this program's memory, which starts afresh at ``exec``. Otherwise
    ``resource.getrusage(RUSAGE_SELF).ru_maxrss``, which on Linux would also
    count the parent process's memory at the time it started this one.
    """
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024  # kB
    except OSError:
        pass
    scale = 1024 * 1024 if sys.platform == "darwin" else 1024  # bytes on macOS, else KiB
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / scale


def child_measurement(style, n):
    """Build and derive one chain; print a JSON line (runs in a subprocess).

    Prints ``build_s`` (``kd.models.build``), ``derive_s``
    (``definition.derive()``), ``counts`` (``eom.operation_counts()``) and its
    time ``counts_s``, ``rss_imports_mb`` (peak resident memory after the
    imports) and ``peak_mb`` (peak resident memory after the derivation), both
    from :func:`peak_memory_mb`.
    """
    rss_imports = peak_memory_mb()
    definition, build_s = timed(lambda: kd.models.build("chain3d", n=n, style=style))
    eom, derive_s = timed(definition.derive)
    peak = peak_memory_mb()
    counts, counts_s = timed(eom.operation_counts)
    print(json.dumps({"style": style, "n": n, "build_s": build_s, "derive_s": derive_s,
                      "counts": counts, "counts_s": counts_s,
                      "rss_imports_mb": rss_imports, "peak_mb": peak}))


def measure_large(style, n, timeout=3600):
    """Run :func:`child_measurement` in a fresh Python process.

    A fresh process gives each case its own peak-memory figure and an empty
    SymPy cache.

    Returns
    -------
    dict
        The child's JSON result.
    """
    command = [sys.executable, os.path.abspath(__file__), "--child", style, str(n)]
    out = subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                         check=False)
    if out.returncode != 0:
        raise RuntimeError(f"measurement of chain3d n={n} style={style} failed:\n"
                           f"{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


LARGE_COLUMNS = ("style", "n", "build s", "derive s", "build+derive s", "peak MB",
                 "after imports MB", "ops M", "ops F", "ops M+F (joint)",
                 "intermediates", "operation_counts s")


def large_cells(row):
    """Table cells of one row of :func:`measure_large`."""
    counts = row["counts"]
    return [row["style"], str(row["n"]), f"{row['build_s']:.2f}", f"{row['derive_s']:.2f}",
            f"{row['build_s'] + row['derive_s']:.2f}", f"{row['peak_mb']:.0f}",
            f"{row['rss_imports_mb']:.0f}", f"{counts['mass_matrix']:,}",
            f"{counts['forcing']:,}", f"{counts['both']:,}", f"{counts['intermediates']:,}",
            f"{row['counts_s']:.2f}"]


def growth_exponent(rows, key, style="positions", sizes=(30, 60)):
    """Exponent p of ``value ~ n**p`` between two chain sizes, or ``None``.

    Parameters
    ----------
    rows : list of dict
        From :func:`measure_large`.
    key : callable
        ``key(row) -> value``.
    style : str
        Which chains.
    sizes : (int, int)
        The two sizes.
    """
    by_n = {row["n"]: key(row) for row in rows if row["style"] == style}
    if not all(n in by_n for n in sizes):
        return None
    (a, b), (va, vb) = sizes, (by_n[sizes[0]], by_n[sizes[1]])
    return math.log(vb / va) / math.log(b / a)


LARGE_NOTES = """\
- Each row in a fresh Python process. build s: kd.models.build("chain3d", n=n,
  style=style) (SymPy model building: frames, points, velocities); derive s:
  definition.derive(); peak MB: the process's peak resident memory (VmHWM of
  /proc/self/status) at the end of the derivation, whole process, including
  the ~{imports:.0f} MB that importing kanedyn, SymPy and NumPy takes ("after imports").
- style "positions" builds body positions and lets kanedyn differentiate them;
  "v2pt" writes velocities with SymPy's v2pt_theory, as SymPy users do (its
  building is SymPy's own work and is slow for long chains).
- ops: eom.operation_counts(), compact form: mass matrix M, forcing F, each with the
  intermediates it needs; M+F counted jointly (shared intermediates once)."""


# ------------------------------------------------------------------ output
def format_table(columns, rows, markdown, left=1):
    """A plain-text or markdown table.

    Parameters
    ----------
    columns : sequence of str
        Titles.
    rows : list of list of str
        Cells.
    markdown : bool
        Markdown instead of aligned text (``|`` in cells is escaped).
    left : int
        Number of leading (left-aligned) columns; the rest align right.

    Returns
    -------
    str
    """
    if markdown:
        columns = [title.replace("|", "\\|") for title in columns]
        rows = [[cell.replace("|", "\\|") for cell in cells] for cells in rows]
        lines = ["| " + " | ".join(columns) + " |",
                 "|" + "|".join("---" if i < left else "--:" for i in range(len(columns)))
                 + "|"]
        return "\n".join(lines + ["| " + " | ".join(cells) + " |" for cells in rows])
    widths = [max([len(title)] + [len(cells[i]) for cells in rows])
              for i, title in enumerate(columns)]

    def line(cells):
        return "  ".join(cell.ljust(w) if i < left else cell.rjust(w)
                         for i, (cell, w) in enumerate(zip(cells, widths)))
    return "\n".join([line(columns), line(["-" * w for w in widths])]
                     + [line(cells) for cells in rows])


def section(title, table, notes, markdown):
    """A titled table with its notes, as text."""
    heading = f"**{title}**" if markdown else f"{title}\n{'=' * len(title)}"
    return f"{heading}\n\n{table}\n\nNotes:\n{notes}\n"


def verdict(ok):
    """``"met"`` or ``"NOT met"``."""
    return "met" if ok else "NOT met"


def batch_targets(batch_rows):
    """Lines of the two batch targets (ratio of minima, with the spreads)."""
    lines = []
    for label, goal in (("kanedyn numpy batch", 20), ("kanedyn c batch, all CPUs", 3)):
        row = next(r for r in batch_rows if r["label"] == label)
        lines.append(f"- {label[8:]} >= {goal}x faster per state than an rhs loop "
                     f"({row['ratio']:.1f}x; spreads batch {row['spread']:.0%}, loop "
                     f"{row['loop_spread']:.0%}): {verdict(row['ratio'] >= goal)}")
    return lines


def targets_summary(rhs_rows, batch_rows, sim_rows, large_rows):
    """The project's numerical targets and whether this run meets them.

    Returns
    -------
    str
    """
    lines = []
    small = [r for r in rhs_rows if r["n"] <= 10]
    big = [r for r in rhs_rows if r["n"] == 30]
    ratios = ", ".join(f"n={r['n']}: {r['c_us'] / r['pin_us']:.2f}" for r in small)
    lines.append(f"- C rhs / pin.aba <= 1 at n <= 10 ({ratios}): "
                 f"{verdict(all(r['c_us'] <= r['pin_us'] for r in small))}")
    if big:
        r = big[0]
        lines.append(f"- C rhs / pin.aba <= 1.5 at n = 30 ({r['c_us'] / r['pin_us']:.2f}): "
                     f"{verdict(r['c_us'] <= 1.5 * r['pin_us'])}")
    for r in rhs_rows:
        if r["n"] > 30:
            lines.append(f"- (no target) C rhs / pin.aba at n = {r['n']}: "
                         f"{r['c_us'] / r['pin_us']:.2f}")
    lines.extend(batch_targets(batch_rows))
    sim_ours = sim_rows[0]
    sim_pin = next(r for r in sim_rows if r["label"] == PIN_RUN)
    speed = sim_pin["seconds"] / sim_ours["seconds"]
    lines.append(f"- kd.simulate >= 5x faster than solve_ivp + pin.aba ({speed:.1f}x): "
                 f"{verdict(speed >= 5)}")
    lines.append(f"- final states agree to 1e-6 ({sim_ours['diff']:.1e}): "
                 f"{verdict(sim_ours['diff'] <= 1e-6)}")
    limits = {30: 30.0, 60: 300.0}
    for row in large_rows:
        if row["style"] == "positions" and row["n"] in limits:
            lines.append(f"- derivation n = {row['n']} < {limits[row['n']]:.0f} s "
                         f"({row['derive_s']:.1f} s): "
                         f"{verdict(row['derive_s'] < limits[row['n']])}")
    v2pt = [r for r in large_rows if r["style"] == "v2pt"]
    for row in v2pt:
        lines.append(f"- v2pt n = {row['n']}: derivation < 30 s ({row['derive_s']:.1f} s): "
                     f"{verdict(row['derive_s'] < 30)}; model building + derivation "
                     f"{row['build_s'] + row['derive_s']:.1f} s")
    if large_rows:
        peak = max(r["peak_mb"] for r in large_rows)
        lines.append(f"- peak memory < 2 GB (largest {peak:.0f} MB): {verdict(peak < 2048)}")
    exponent = growth_exponent(large_rows, lambda r: r["counts"]["mass_matrix"])
    if exponent is not None:
        lines.append(f"- mass-matrix operation count no faster than O(n^2) "
                     f"(n^{exponent:.2f} between n = 30 and 60): {verdict(exponent <= 2.05)}")
    return "\n".join(lines)


# -------------------------------------------------------------------- main
def run(args):
    """All four measurements; prints the report to stdout."""
    repeat, min_time = (3, 0.05) if args.quick else (7, 0.2)
    header = "kanedyn vs Pinocchio, numerics: " + machine_info()  # before the load changes
    log(f"compile cache: {os.environ['KANEDYN_CACHE_DIR']} (fresh)")

    if args.batch_only:
        chain = build_chain(BATCH_N, numpy_backend=True)
        batch_rows = measure_batch(chain, BATCH_STATES, repeat, min_time)
        print(header)
        print(f"load average at the end: {load_average()}")
        print()
        print(section(f"2. Batch evaluation, chain3d n = {BATCH_N}, k = {BATCH_STATES} states",
                      format_table(BATCH_COLUMNS, [batch_cells(r) for r in batch_rows],
                                   args.markdown),
                      BATCH_NOTES.format(n=BATCH_N, count=BATCH_STATES, states=2 * BATCH_N,
                                         repeat=repeat), args.markdown))
        print("\n".join(batch_targets(batch_rows)))
        return
    rhs_sizes = [n for n in RHS_SIZES if not (args.quick and n > 30)]
    chains = {}
    for n in sorted(set(rhs_sizes) | {BATCH_N, SIM_N}):
        chains[n] = build_chain(n, numpy_backend=n <= NUMPY_MAX_N)
        log(f"n={n}: derived in {chains[n]['derive_s']:.2f} s, "
            f"C built in {chains[n]['c_build_s']:.2f} s")

    rhs_rows = []
    for n in rhs_sizes:
        rhs_rows.append(measure_rhs(chains[n], repeat, min_time))
        log(f"rhs n={n} done")
    batch_rows = measure_batch(chains[BATCH_N], BATCH_STATES, repeat, min_time)
    sim_rows, sim_info = measure_simulation(chains[SIM_N], repeat, min_time)
    if sim_info["method"] != "RK45 (compiled)":
        raise RuntimeError(f"kd.simulate did not use the compiled loop: {sim_info['method']}")

    large_rows = []
    for style, n in LARGE_CASES:
        if args.quick and (n > 30 or style != "positions"):
            continue
        large_rows.append(measure_large(style, n))
        log(f"large: {style} n={n} derived in {large_rows[-1]['derive_s']:.1f} s")

    md = args.markdown
    print(header)
    print(f"load average at the end: {load_average()}")
    print()
    print(section("1. Right-hand side per call, chain3d",
                  format_table(RHS_COLUMNS, [rhs_cells(r) for r in rhs_rows], md),
                  RHS_NOTES.format(repeat=repeat, min_time=min_time), md))
    print(section(f"2. Batch evaluation, chain3d n = {BATCH_N}, k = {BATCH_STATES} states",
                  format_table(BATCH_COLUMNS, [batch_cells(r) for r in batch_rows], md),
                  BATCH_NOTES.format(n=BATCH_N, count=BATCH_STATES, states=2 * BATCH_N,
                                     repeat=repeat), md))
    pin_seconds = next(r["seconds"] for r in sim_rows if r["label"] == PIN_RUN)
    y_default = "[" + ", ".join(f"{v:g}" for v in sim_info["y_default"]) + "]"
    print(section(f"3. Simulation, chain3d n = {SIM_N}, 10 s",
                  format_table(SIM_COLUMNS,
                               [simulation_cells(r, pin_seconds) for r in sim_rows], md),
                  SIM_NOTES.format(n=SIM_N, tol=SIM_TOL, repeat=repeat, min_time=min_time,
                                   method=sim_info["method"], steps=sim_info["steps"],
                                   y_default=y_default, chaotic=sim_info["chaotic_diff"]),
                  md))
    exponents = []
    for label, key in (("mass matrix ops", lambda r: r["counts"]["mass_matrix"]),
                       ("forcing ops", lambda r: r["counts"]["forcing"]),
                       ("derivation time", lambda r: r["derive_s"])):
        p = growth_exponent(large_rows, key)
        if p is not None:
            exponents.append(f"{label} ~ n^{p:.2f}")
    notes = LARGE_NOTES.format(imports=min(r["rss_imports_mb"] for r in large_rows))
    if exponents:
        notes += "\n- Growth between n = 30 and 60 (positions): " + ", ".join(exponents) + "."
    if args.quick:
        notes += "\n- --quick: n = 60 (here and in table 1) and the v2pt chain were skipped."
    print(section("4. Large models: derivation and memory",
                  format_table(LARGE_COLUMNS, [large_cells(r) for r in large_rows], md),
                  notes, md))
    print("**Targets**" if md else "Targets\n=======")
    print()
    print(targets_summary(rhs_rows, batch_rows, sim_rows, large_rows))


def main(argv=None):
    """Parse the command line and run the benchmark.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default ``sys.argv[1:]``).
    """
    optimized_modules_only()
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="3 timing runs of >= 0.05 s instead of 7 of >= 0.2 s; "
                             "skip n = 60 and the v2pt chain")
    parser.add_argument("--markdown", action="store_true", help="print markdown tables")
    parser.add_argument("--batch-only", action="store_true",
                        help="only the batch evaluation (table 2) and its targets")
    parser.add_argument("--child", nargs=2, metavar=("STYLE", "N"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        child_measurement(args.child[0], int(args.child[1]))
        return

    # A fresh compile cache, so that the C build times include compilation.
    previous = os.environ.get("KANEDYN_CACHE_DIR")
    cache = tempfile.mkdtemp(prefix="kanedyn-bench-cache-")
    os.environ["KANEDYN_CACHE_DIR"] = cache
    try:
        run(args)
    finally:
        shutil.rmtree(cache, ignore_errors=True)
        if previous is None:
            os.environ.pop("KANEDYN_CACHE_DIR", None)
        else:
            os.environ["KANEDYN_CACHE_DIR"] = previous


if __name__ == "__main__":
    main()
