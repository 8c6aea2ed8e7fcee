"""Benchmark (not a test): contact simulations, before and after.

Three runs with modes, events and impacts (``_contact_cases.py``):
``falling-rod`` (t_end 2 s, 40 impacts, 13 of both ends at once),
``slug-ellipsoid`` (8 s, 36 impacts, slip and flight) and ``ball-3d`` (a
spinning ball on a rough floor, 1.5 s, 20 impacts then rolling), all with
``kd.simulate`` at its default tolerances (rtol = atol = 1e-8).

Contenders, each a worker process importing kanedyn from its own source
tree (``--before``, by default the main checkout, against this tree):

* ``before numpy`` / ``after numpy``: models built with ``backend="numpy"``;
* ``after c``: models built with ``backend="c"``, ``simulate(backend="c")``
  (the segments in the compiled contact loop, ``contact_segment``);
* ``after c-py``: the same models with ``simulate(backend="scipy")`` (every
  segment by ``solve_ivp`` on the Python per-mode solve, the reference path).

The original "before" of issue 18 (the tree before the first contact work,
commit ``02f89bf``) is run with ``--before`` pointing at its ``src``, e.g.
``git archive 02f89bf src | tar -x -C /tmp/before`` then ``--before
/tmp/before/src``.

The workers build every model once, run each simulation once to warm up,
then the rounds interleave the contenders (round-robin, order rotated each
round); each measurement is the thread CPU time of one ``kd.simulate``.
Reported (:mod:`_timing`): the minimum over rounds and the spread
(median / min - 1), the speed-up of each contender over ``before numpy`` as a
ratio of minima with both spreads, and the fastest contender only where the
ranges [min, median] do not overlap (:func:`_timing.winner`).  The
workers also report the mode history and impact count, which must agree.

Run: ``PYTHONPATH=src python benchmarks/bench_contacts.py [--rounds 7]
[--before /work/main/src] [--cases ball-3d ...] [--quick]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

_WORKER = r"""
import json, sys, time, warnings
sys.path.insert(0, {here!r})
warnings.simplefilter("ignore")
import kanedyn as kd
from _contact_cases import CASES, build
backend = {backend!r}
built = {{name: build(name, backend) for name in {cases!r}}}
options = {{"backend": {run!r}}} if {run!r} else {{}}
for name, (model, y0, t_end) in built.items():
    kd.simulate(model, (0, t_end), y0, **options)
print("ready", flush=True)
for line in sys.stdin:
    name = line.strip()
    model, y0, t_end = built[name]
    start = time.thread_time()
    res = kd.simulate(model, (0, t_end), y0, **options)
    cpu = time.thread_time() - start
    history = [[round(c.t, 9), c.contact, c.old, c.new] for c in res.mode_history]
    print(json.dumps({{"cpu": cpu, "impacts": len(res.impacts), "history": history,
                      "ok": bool(res.success)}}), flush=True)
"""


def _worker(src, backend, run, cases):
    env = dict(os.environ, PYTHONPATH=str(src))
    code = _WORKER.format(here=str(HERE), backend=backend, run=run, cases=list(cases))
    proc = subprocess.Popen([sys.executable, "-c", code],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            env=env)
    line = proc.stdout.readline()
    if line.strip() != "ready":
        raise RuntimeError(f"the worker on {src} ({backend}) did not start")
    return proc


def _ask(proc, name):
    proc.stdin.write(name + "\n")
    proc.stdin.flush()
    return json.loads(proc.stdout.readline())


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--before", default="/work/main/src")
    parser.add_argument("--cases", nargs="+", help="cases to run (default: all)")
    parser.add_argument("--quick", action="store_true",
                        help="ball-3d only, 2 rounds (a smoke run)")
    args = parser.parse_args()
    sys.path.insert(0, str(HERE))
    from _contact_cases import CASES
    from _timing import Timing, optimized_modules_only, ratio_text, winner
    optimized_modules_only()
    if args.quick:
        args.cases, args.rounds = args.cases or ["ball-3d"], 2
    cases = args.cases or list(CASES)
    unknown = sorted(set(cases) - set(CASES))
    if unknown:
        parser.error(f"unknown case(s) {', '.join(unknown)}; known: {', '.join(CASES)}")
    after = HERE.parent / "src"
    contenders = {"before numpy": (args.before, "numpy", None),
                  "after numpy": (after, "numpy", None), "after c": (after, "c", "c"),
                  "after c-py": (after, "c", "scipy")}
    workers = {label: _worker(*spec, cases) for label, spec in contenders.items()}
    times = {(label, name): [] for label in contenders for name in cases}
    outcome = {}
    labels = list(contenders)
    try:
        for r in range(args.rounds):
            order = labels[r % len(labels):] + labels[:r % len(labels)]
            for name in cases:
                for label in order:
                    answer = _ask(workers[label], name)
                    times[label, name].append(answer["cpu"])
                    outcome[label, name] = (answer["impacts"], answer["history"],
                                            answer["ok"])
    finally:
        for proc in workers.values():
            proc.stdin.close()
            proc.wait()
    print(f"thread CPU s per run, minimum of {args.rounds} interleaved rounds "
          "(spread = median / min - 1); speed-up over before numpy with both spreads")
    for name in cases:
        timings = {label: Timing(label, times[label, name]) for label in labels}
        base = timings["before numpy"]
        for label in labels:
            t = timings[label]
            same = outcome[label, name][:2] == outcome["before numpy", name][:2]
            print(f"{name:15s} {label:13s} {t.best:8.4f} s  spread {t.spread:4.0%}  "
                  f"speed-up {ratio_text(base, t):>24s}"
                  f"  impacts {outcome[label, name][0]:3d}  same modes/impacts: {same}")
        print(f"{name:15s} fastest: {winner(timings) or 'none stated (spreads overlap)'}")


if __name__ == "__main__":
    main()
