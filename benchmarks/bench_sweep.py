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

Overhead per run = (cluster wall time, without start-up) x workers / runs -
(loop time / runs): what a run costs on the cluster beyond its computation.

Run: ``PYTHONPATH=src python benchmarks/bench_sweep.py [--runs 1000] [--t-end 10]``.
"""

from __future__ import annotations

import argparse
import logging
import os
import time

import numpy as np

import kanedyn as kd
# bench_numerics lives next to this script (on sys.path when run directly)
from bench_numerics import cpu_name  # noqa: E402


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--t-end", type=float, default=10.0)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    from distributed import Client, LocalCluster

    d = kd.models.build("chain3d", n=5)
    model = d.numeric(backend="c")
    y0 = d.initial(model)
    params = {"g": (9.0, 10.0), "l": (0.4, 0.6)}
    _, values = kd.simulation._sweep.parameter_runs(model, params, n=args.runs, seed=1)
    span = (0.0, args.t_end)
    print(f"{cpu_name()}, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f}; chain3d n=5, C backend; {args.runs} runs of "
          f"{args.t_end:g} s")

    start = time.perf_counter()
    loop_final = []
    for g, l in values:
        res = kd.simulate(model.with_constants({"g": g, "l": l}), span, y0)
        loop_final.append(res.y[0, -1])
    loop = time.perf_counter() - start
    print(f"loop in one process      {loop:8.2f} s  ({1e3 * loop / args.runs:.2f} ms/run)")

    start = time.perf_counter()
    serial = kd.sweep(model, params, y0, span, n=args.runs, seed=1, scheduler="serial",
                      progress=False)
    serial_time = time.perf_counter() - start
    print(f"kd.sweep serial          {serial_time:8.2f} s")

    start = time.perf_counter()
    table = kd.sweep(model, params, y0, span, n=args.runs, seed=1, n_workers=args.workers,
                     progress=False)
    cluster_time = time.perf_counter() - start
    print(f"kd.sweep local cluster   {cluster_time:8.2f} s  (start-up and shut-down "
          "included)")

    start = time.perf_counter()
    cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    client.run(lambda: __import__("kanedyn"))
    startup = time.perf_counter() - start
    start = time.perf_counter()
    warm = kd.sweep(model, params, y0, span, n=args.runs, seed=1, client=client,
                    progress=False)
    warm_time = time.perf_counter() - start
    client.close()
    cluster.close()
    print(f"cluster start-up         {startup:8.2f} s  (workers importing kanedyn)")
    print(f"kd.sweep, cluster ready  {warm_time:8.2f} s  (speed-up over the loop "
          f"{loop / warm_time:.2f}x)")
    overhead = warm_time * args.workers / args.runs - loop / args.runs
    print(f"overhead per run         {1e3 * overhead:8.2f} ms")
    assert table["success"].all() and warm["success"].all() and serial["success"].all()
    assert np.array_equal(table["final_q1"], warm["final_q1"])
    assert np.array_equal(np.asarray(loop_final), serial["final_q1"])


if __name__ == "__main__":
    main()
