"""The seat-belt sensor's run with its vehicle motion evaluated in Python and in C.

``seatbelt-sensor`` (2 degrees of freedom, penalty wall, C backend, compiled RK45
loop, rtol = atol = 1e-8, 501 output points: what ``kanedyn run seatbelt-sensor``
does) under three pulses (``--pulses``): the example records ``frontal-48kmh``
(0.15 s, no rotation) and ``oblique-30deg`` (0.17 s, yawing) and the analytic
``halfsine`` (20 g, 0.1 s; run 0.2 s).  Two contenders per pulse:

* **python inputs**: the 16 vehicle inputs as Python callables of t, each
  evaluating the motion (``motion.evaluate``), called from the compiled loop at
  every right-hand side (the path of every run before issue 37);
* **compiled inputs**: the model as built (``definition.numeric(backend="c")``),
  whose inputs are piecewise polynomials evaluated inside the compiled module.

Timings interleaved in rounds (:func:`_timing.interleaved`, thread CPU time,
minimum and spread median / min - 1).  The largest state difference of the two
runs is printed too, and the wall time of building the definition (the motion, its
tables) and the model (its module from the cache after the first run).
``--lock-map N`` also times ``kd.studies.seatbelt_lock_map`` over about N half-sine
pulses (wall time, serial, one run).

Run: ``PYTHONPATH=src python benchmarks/bench_seatbelt.py [--rounds 3]
[--pulses frontal-48kmh oblique-30deg halfsine] [--lock-map 1000]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import kanedyn as kd  # noqa: E402
from _timing import interleaved, optimized_modules_only, ratio_text  # noqa: E402
from kanedyn.models import build  # noqa: E402


def _python_inputs(definition):
    """The definition's inputs as Python callables evaluating the motion."""
    motion = definition.symbols["motion"]
    out = {}
    for key in definition.specified:
        base = key.expr if hasattr(key, "expr") else key
        order = len(key.variables) if hasattr(key, "variables") else 0
        i = motion.symbols.index(base)
        kind, index = ("position", i) if i < 3 else ("angles", i - 3)
        out[key] = (lambda tq, kind=kind, order=order, index=index:
                    float(motion.evaluate(kind, order, tq)[index]))
    return out


def _runner(model, definition):
    y0 = definition.initial(model)
    t_end = definition.t_end
    t_eval = np.linspace(0.0, t_end, 501)

    def run():
        return kd.simulate(model, (0.0, t_end), y0, rtol=1e-8, atol=1e-8, t_eval=t_eval)
    return run


def main():
    optimized_modules_only()
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--pulses", nargs="+",
                        default=["frontal-48kmh", "oblique-30deg", "halfsine"])
    parser.add_argument("--lock-map", type=int, default=0, metavar="N",
                        help="also time the lock map over about N half-sine pulses")
    args = parser.parse_args()
    for pulse in args.pulses:
        start = time.perf_counter()
        definition = build("seatbelt-sensor", pulse=pulse)  # the motion and its tables
        compiled = definition.numeric(backend="c")
        setup = time.perf_counter() - start
        python = definition.numeric(backend="c", specified=_python_inputs(definition))
        runs = {"python inputs": _runner(python, definition),
                "compiled inputs": _runner(compiled, definition)}
        a, b = (run() for run in runs.values())
        diff = float(np.max(np.abs(a.y - b.y))) if a.y.shape == b.y.shape else float("nan")
        timings = interleaved(runs, rounds=args.rounds, min_time=0.0)
        slow, fast = timings["python inputs"], timings["compiled inputs"]
        print(f"{pulse} ({definition.t_end:g} s, {a.nfev} rhs calls): python inputs "
              f"{slow.best * 1e3:.1f} ms, compiled inputs {fast.best * 1e3:.1f} ms: "
              f"{ratio_text(slow, fast)}; largest state difference {diff:.2e}; building "
              f"the definition and the model {setup:.2f} s wall (module from the cache)")
    if args.lock_map:
        side = max(1, round(args.lock_map ** (1 / 3)))
        grid = dict(peak_g=np.linspace(1.0, 30.0, side), duration=np.linspace(0.03, 0.15, side),
                    direction=np.linspace(0.0, 90.0, side))
        kd.studies.seatbelt_lock_map(peak_g=[5.0], duration=[0.05], direction=[0.0])  # build
        start = time.perf_counter()
        result = kd.studies.seatbelt_lock_map(**grid)
        wall = time.perf_counter() - start
        n = len(result.table)
        print(f"lock map: {n} half-sine pulses, {result.table.locked.sum()} lock, "
              f"{wall:.2f} s wall ({wall / n * 1e3:.1f} ms per run, serial, "
              f"t_end {result.t_end:g} s)")


if __name__ == "__main__":
    main()
