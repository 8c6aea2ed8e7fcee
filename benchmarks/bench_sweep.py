"""Benchmark (not a test): a parameter sweep on a local Dask cluster against a plain loop.

The 3D chain of 5 links (``chain3d``, n = 5, C backend), ``--runs`` runs of
``--t-end`` s each with random g and l (seeded), compiled RK45 loop
(``kd.simulate`` default for C models), rtol = atol = 1e-8:

* **loop**: ``for`` over the runs in this process, ``model.with_constants`` then
  ``kd.simulate`` (what a user writes without kanedyn's sweep);
* **serial**: ``kd.sweep(..., scheduler="serial")`` (the same, with the table);
* **cluster**: ``kd.sweep`` on a ``LocalCluster`` of ``--workers`` processes,
  started by the sweep (its start-up, the model's broadcast and shut-down
  included), and the same on a cluster started beforehand (``client=``).

The four are timed interleaved in ``--rounds`` rounds (:func:`_timing.interleaved`,
wall time since the cluster works in other processes; minimum and spread
median / min - 1; a winner only where the ranges [min, median] do not overlap).

Overhead per run = (cluster wall time, without start-up) x workers / runs -
(loop time / runs): what a run costs on the cluster beyond its computation.

Run: ``PYTHONPATH=src python benchmarks/bench_sweep.py [--runs 1000] [--t-end 10]
[--rounds 3] [--quick]``.
"""

from __future__ import annotations

import argparse
import logging
import os
import time

import numpy as np

import kanedyn as kd
from kanedyn.simulation._sweep import parameter_runs
# bench_numerics lives next to this script (on sys.path when run directly)
from _timing import interleaved, optimized_modules_only, ratio_text, winner  # noqa: E402
from bench_numerics import cpu_name  # noqa: E402


def main():
    optimized_modules_only()
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--t-end", type=float, default=10.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=3,
                        help="interleaved rounds (minimum and spread of the wall times)")
    parser.add_argument("--quick", action="store_true",
                        help="20 runs of 1 s, 2 rounds (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.runs, args.t_end, args.rounds = 20, 1.0, 2
    from distributed import Client, LocalCluster

    d = kd.models.build("chain3d", n=5)
    model = d.numeric(backend="c")
    y0 = d.initial(model)
    params = {"g": (9.0, 10.0), "l": (0.4, 0.6)}
    _, values = parameter_runs(model, params, n=args.runs, seed=1)
    span = (0.0, args.t_end)
    print(f"{cpu_name()}, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f}; chain3d n=5, C backend; {args.runs} runs of "
          f"{args.t_end:g} s; wall time, minimum of {args.rounds} interleaved rounds "
          "(spread = median / min - 1)")

    start = time.perf_counter()
    cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    client.run(lambda: __import__("kanedyn"))
    startup = time.perf_counter() - start
    out = {}

    def loop():
        out["loop"] = [kd.simulate(model.with_constants({"g": g, "l": l}), span, y0).y[0, -1]
                       for g, l in values]

    def serial():
        out["serial"] = kd.sweep(model, params, y0, span, n=args.runs, seed=1,
                                 scheduler="serial", progress=False)

    def cold():
        out["cold"] = kd.sweep(model, params, y0, span, n=args.runs, seed=1,
                               n_workers=args.workers, progress=False)

    def ready():
        out["ready"] = kd.sweep(model, params, y0, span, n=args.runs, seed=1,
                                client=client, progress=False)

    # wall time: the cluster's work is done in other processes
    try:
        t = interleaved({"loop": loop, "serial": serial, "cold": cold, "ready": ready},
                        rounds=args.rounds, min_time=0, clock="wall")
    finally:
        client.close()
        cluster.close()
    rows = (("loop", "loop in one process"), ("serial", "kd.sweep serial"),
            ("cold", "kd.sweep local cluster"), ("ready", "kd.sweep, cluster ready"))
    notes = {"loop": f"({1e3 * t['loop'].best / args.runs:.2f} ms/run)",
             "cold": "(start-up and shut-down included)",
             "ready": f"(speed-up over the loop {ratio_text(t['loop'], t['ready'])})"}
    for key, label in rows:
        print(f"{label:24s} {t[key].best:8.2f} s  spread {t[key].spread:4.0%}  "
              f"{notes.get(key, '')}")
    print(f"cluster start-up         {startup:8.2f} s  (workers importing kanedyn; once)")
    print(f"fastest: {winner(t) or 'none stated (spreads overlap)'}")
    overhead = t["ready"].best * args.workers / args.runs - t["loop"].best / args.runs
    print(f"overhead per run         {1e3 * overhead:8.2f} ms")
    table, warm, serial_table = out["cold"], out["ready"], out["serial"]
    assert table["success"].all() and warm["success"].all() and serial_table["success"].all()
    assert np.array_equal(table["final_q1"], warm["final_q1"])
    assert np.array_equal(np.asarray(out["loop"]), serial_table["final_q1"])


if __name__ == "__main__":
    main()
