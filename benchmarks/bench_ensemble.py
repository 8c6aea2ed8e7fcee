"""Benchmark (not a test): many runs of one model in C threads against a loop of runs.

``--runs`` runs of two models, C backend, compiled RK45, rtol = atol = 1e-8, each
run with its own random constants and initial angle (seeded), written the way
a user writes them:

* **loop**: ``for`` over the runs, ``model.with_constants`` then ``kd.simulate``
  (each run through Python: checks, the compiled loop, the result object);
* **many, 1 thread / 2 threads**: one ``kd.simulate_many`` call (the same
  RK45 on POSIX threads without Python; the final states are checked equal to
  the loop's, bit for bit);
* **sweep**: ``kd.sweep(..., scheduler="serial")`` (its table; the runs now go
  through ``simulate_many``).

Models: the pendulum, 2 s (the issue's example of a short run), and chain3d
with n = 5, 10 s.  Wall time (threads), minimum of ``--rounds`` interleaved
rounds (:func:`_timing.interleaved`; spread = median / min - 1).

Run: ``PYTHONPATH=src python benchmarks/bench_ensemble.py [--runs 1000] [--rounds 3]
[--quick]``.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

import kanedyn as kd
from _timing import interleaved, optimized_modules_only, ratio_text  # noqa: E402
from bench_numerics import cpu_name  # noqa: E402


def _case(name, t_end, runs, rounds, **options):
    d = kd.models.build(name, **options)
    model = d.numeric(backend="c")
    y0 = np.asarray(d.initial(model), dtype=float)
    rng = np.random.default_rng(1)
    g = rng.uniform(9.0, 10.0, runs)
    length = rng.uniform(0.4, 0.6, runs) if "l" in model.constants else None
    constants = {"g": g} if length is None else {"g": g, "l": length}
    Y0 = np.tile(y0, (runs, 1))
    Y0[:, 0] += rng.uniform(0.0, 0.5, runs)
    span = (0.0, t_end)
    params = {"g": (9.0, 10.0), model.state_names[0]: (0.0, 0.5)}
    out = {}

    def loop():
        out["loop"] = np.array([
            kd.simulate(model.with_constants({k: v[i] for k, v in constants.items()}), span,
                        Y0[i]).y[:, -1] for i in range(runs)])

    def many(threads):
        def run():
            out[f"many{threads}"] = kd.simulate_many(model, Y0, span, constants=constants,
                                                     threads=threads).y_end
        return run

    def sweep():
        out["sweep"] = kd.sweep(model, params, y0, span, n=runs, seed=1, scheduler="serial",
                                progress=False)

    t = interleaved({"loop": loop, "many1": many(1), "many2": many(2), "sweep": sweep},
                    rounds=rounds, min_time=0, clock="wall")
    assert np.array_equal(out["loop"], out["many1"]), "simulate_many differs from the loop"
    assert np.array_equal(out["many1"], out["many2"])
    assert out["sweep"]["success"].all()
    print(f"\n{name} ({model.n_states} states), {runs} runs of {t_end:g} s")
    for key, label in (("loop", "loop of kd.simulate"), ("many1", "simulate_many, 1 thread"),
                       ("many2", "simulate_many, 2 threads"), ("sweep", "kd.sweep serial")):
        note = "" if key == "loop" else f"  {ratio_text(t['loop'], t[key])} faster"
        print(f"  {label:26s} {t[key].best:8.4f} s  {1e3 * t[key].best / runs:7.4f} ms/run"
              f"  spread {t[key].spread:4.0%}{note}")


def main():
    optimized_modules_only()
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="100 runs, 2 rounds")
    args = parser.parse_args()
    if args.quick:
        args.runs, args.rounds = 100, 2
    print(f"{cpu_name()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; "
          "wall time, minimum of interleaved rounds; ratios: the loop's time over each")
    _case("pendulum", 2.0, args.runs, args.rounds)
    _case("chain3d", 10.0, args.runs, args.rounds, n=5)


if __name__ == "__main__":
    main()
