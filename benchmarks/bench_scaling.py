"""Benchmark (not a test): how ensembles scale past one core, and what a GPU would give.

Three measurements behind ``docs/scaling.md``:

1. **Threads.** ``kd.simulate_many`` on ``chain3d`` (n = 5, 10 s, rtol = atol =
   1e-8, random g and initial angle, seeded) with 1 and 2 POSIX threads, wall
   time interleaved in ``--rounds`` rounds. The speed-up S2 gives Amdahl's
   parallel fraction p = 2 (1 - 1/S2), from which S(k) = 1 / ((1 - p) + p/k) is
   extrapolated to k threads.
2. **Dask.** ``kd.sweep`` of the same runs on a running local cluster of 2
   worker processes at several ``batch_size`` values. With t_run the runs' own
   time (from 1.), the wall times W(b) fit
   ``W * workers = N (t_run + o_run) + (N / b) o_chunk`` by least squares:
   ``o_run`` is what a run costs beyond its computation, ``o_chunk`` what a
   task (chunk) costs.
3. **Operation counts.** The generated right-hand side's operations
   (``Program.count_ops`` after common subexpressions, the mass matrix,
   forcing and kinematics) plus a dense LDLᵀ solve (n³/3 + 2n² operations, an
   upper bound: the compiled module factors along the tree), for chain3d at
   n = 5, 10, 27, 30, and the RK45 evaluations per simulated second measured
   in 1. Multiplied out against a GPU's published double-precision peak they
   give the estimate of ``docs/scaling.md`` (the efficiency assumed is stated
   there, not measured: this machine has no GPU).

Run: ``PYTHONPATH=src python benchmarks/bench_scaling.py [--runs 400] [--rounds 3]
[--quick]``.
"""

from __future__ import annotations

import argparse
import logging
import os
import time

import numpy as np

import kanedyn as kd
from _timing import interleaved, optimized_modules_only  # noqa: E402
from bench_numerics import cpu_name  # noqa: E402

T_END = 10.0
TOL = dict(rtol=1e-8, atol=1e-8)


def chain(n):
    definition = kd.models.build("chain3d", n=n)
    model = definition.numeric(backend="c")
    return model, np.asarray(definition.initial(model), dtype=float)


def runs(model, y0, count):
    rng = np.random.default_rng(1)
    Y0 = np.tile(y0, (count, 1))
    Y0[:, 0] += rng.uniform(0.0, 0.5, count)
    return Y0, {"g": rng.uniform(9.0, 10.0, count)}


def threads(model, y0, count, rounds):
    """Wall times of simulate_many with 1 and 2 threads, and the counts of run 0."""
    Y0, constants = runs(model, y0, count)
    out = {}

    def many(k):
        def run():
            out[k] = kd.simulate_many(model, Y0, (0.0, T_END), constants=constants,
                                      threads=k, **TOL)
        return run

    t = interleaved({1: many(1), 2: many(2)}, rounds=rounds, min_time=0, clock="wall")
    assert np.array_equal(out[1].y_end, out[2].y_end)
    return t, out[1]


def dask_overheads(model, y0, count, t_run, batches, rounds):
    """``(o_run, o_chunk, rows)``: the fit of the cluster's wall times."""
    from distributed import Client, LocalCluster
    logging.getLogger("distributed").setLevel(logging.ERROR)
    params = {"g": (9.0, 10.0), model.state_names[0]: (0.0, 0.5)}
    workers = 2
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        kd.sweep(model, params, y0, (0.0, T_END), n=2 * workers, seed=1, client=client,
                 progress=False, **TOL)  # the workers import kanedyn and the model
        timed = {}
        for b in batches:
            def run(b=b):
                kd.sweep(model, params, y0, (0.0, T_END), n=count, seed=1, client=client,
                         batch_size=b, progress=False, **TOL)
            timed[b] = run
        t = interleaved(timed, rounds=rounds, min_time=0, clock="wall")
    rows = [(b, t[b].best) for b in batches]
    A = np.array([[count, count / b] for b, _ in rows])
    rhs = np.array([w * workers - count * t_run for _, w in rows])
    (o_run, o_chunk), *_ = np.linalg.lstsq(A, rhs, rcond=None)
    return o_run, o_chunk, rows


def operations(n):
    """``(rhs operations after CSE, dense solve operations)`` of chain3d with n links."""
    definition = kd.models.build("chain3d", n=n)
    model = definition.numeric(backend="numpy")
    from kanedyn.numerics._inverse import _workspace
    prog, _ = _workspace(model)
    _, outputs = model._functions["dynamics"]
    exprs = [e for _, part in outputs for e in np.ravel(np.asarray(part, dtype=object))]
    return prog.count_ops(exprs, cse=True), n ** 3 // 3 + 2 * n ** 2


def main():
    optimized_modules_only()
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=400)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    count, rounds = (40, 1) if args.quick else (args.runs, args.rounds)
    print(f"{cpu_name()}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")

    model, y0 = chain(5)
    t, first = threads(model, y0, count, rounds)
    s2 = t[1].best / t[2].best
    p = 2.0 * (1.0 - 1.0 / s2)
    t_run = t[1].best / count
    nfev = float(np.mean(first.nfev))
    print(f"\n1. threads: chain3d n = 5, {count} runs of {T_END:g} s, "
          f"{nfev:.0f} rhs evaluations per run (mean)")
    for k in (1, 2):
        print(f"  {k} thread(s): {t[k].best:.3f} s ({1e3 * t[k].best / count:.2f} ms/run, "
              f"spread {t[k].spread:.0%})")
    print(f"  speed-up S2 = {s2:.2f}, parallel fraction p = {p:.3f}")
    for k in (4, 8, 16, 64):
        print(f"  Amdahl, {k:2d} threads: {1.0 / ((1.0 - p) + p / k):5.1f}x")
    print(f"  rhs evaluations per second per core: {nfev / t_run:,.0f}")

    batches = (4, 16, 64) if args.quick else (4, 8, 16, 32, 64, 128)
    started = time.perf_counter()
    o_run, o_chunk, rows = dask_overheads(model, y0, count, t_run, batches, rounds)
    print(f"\n2. Dask: {count} runs on a running local cluster of 2 workers "
          f"({time.perf_counter() - started:.0f} s in all)")
    for b, w in rows:
        print(f"  batch_size {b:4d}: {w:.3f} s wall ({1e3 * w / count:.2f} ms/run)")
    print(f"  fit: {1e3 * o_run:.3f} ms per run beyond its computation "
          f"({1e3 * t_run:.2f} ms), {1e3 * o_chunk:.2f} ms per chunk")

    print("\n3. operations per right-hand side (generated, after CSE, + dense solve)")
    for n in (5,) if args.quick else (5, 10, 27, 30):
        ops, solve = operations(n)
        print(f"  chain3d n = {n:3d}: {ops:7d} + {solve:6d} = {ops + solve:7d}")


if __name__ == "__main__":
    main()
