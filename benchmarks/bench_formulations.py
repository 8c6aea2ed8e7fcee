"""Formulations side by side on the wheeled snake robot, n = 3 .. 10 links.

The structure of the comparison of Kane's method with Lagrange-based methods on
a snake robot (operation counts, constraint error, energy error, CPU time),
measured in one run on this machine for every formulation of the registry that
describes the nonholonomic motion:

1. operations of the generated equations after joint common subexpression
   elimination (multiplications, additions, function calls) and the
   derivation time;
2. velocity-level constraint error (the wheels' lateral velocity, m/s): the
   largest residual of a driven run (serpenoid torques, t = 0..T) at
   ``rtol = 1e-6``;
3. energy error on a conservative run (no torques, no joint damping): the
   largest ``|E - E(0)| / E(0)`` at ``rtol = 1e-6``;
4. CPU seconds per simulated second at equal accuracy: runs at several
   tolerances against a reference (Kane's method, DOP853 at ``rtol = 1e-12``),
   interpolated to the target error of the coordinates (m, rad).

All formulations run on the numpy backend and on SciPy's RK45 (the natural
orthogonal complement also on BDF, as its authors integrate it).

Usage::

    python benchmarks/bench_formulations.py                 # n = 3 .. 10, a few minutes
    python benchmarks/bench_formulations.py --n 3 5 --t-end 2
    python benchmarks/bench_formulations.py --markdown

Progress goes to stderr, the tables to stdout.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

import kanedyn as kd
from kanedyn.analysis._compare import compare_formulations, work_precision

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _timing import Timing, winner  # noqa: E402

METHODS = ("kane", "lagrange", "lagrange-index1", "lagrange-baumgarte",
           "lagrange-projection", "penalty", "augmented-lagrangian", "udwadia-kalaba",
           "partitioning", "maggi", "orthogonal-complement")


def _derivation_times(n, methods):
    out = {}
    for m in methods:
        start = time.process_time()
        kd.models.build("snake", n=n).derive(method=m)
        out[m] = time.process_time() - start
    return out


def measure(n, methods, t_end, target, tolerances, rounds=3):
    """All figures of one snake size; ``{method: {metric: value}}``.

    The work-precision runs are repeated ``rounds`` times (each round runs
    every formulation in turn, so the contenders are interleaved); the CPU
    time at the target is the minimum over the rounds, with its spread
    (median / min - 1) and the :class:`_timing.Timing` in ``"cpu_timing"``.
    """
    methods = [m for m in methods if m in kd.FORMULATIONS]
    print(f"n = {n}: derivations", file=sys.stderr, flush=True)
    derivation = _derivation_times(n, methods)
    print(f"n = {n}: driven run", file=sys.stderr, flush=True)
    driven = compare_formulations("snake", methods, t_end=t_end, rtol=1e-6, atol=1e-8,
                                  n_points=101, n=n)
    print(f"n = {n}: conservative run", file=sys.stderr, flush=True)
    free = compare_formulations("snake", methods, t_end=t_end, rtol=1e-6, atol=1e-8,
                                n_points=101, constants={"A": 0.0, "c": 0.0}, n=n)
    print(f"n = {n}: work-precision", file=sys.stderr, flush=True)
    per_round = {m: [] for m in methods}
    for r in range(rounds):
        wp = work_precision("snake", methods, tolerances=tolerances, t_end=t_end,
                            target=target, n=n)
        for m in methods:
            per_round[m].append(wp.at_target[m])
        print(f"n = {n}: work-precision round {r + 1}/{rounds}", file=sys.stderr, flush=True)
    timings = {m: Timing(m, v) for m, v in per_round.items() if np.all(np.isfinite(v))}
    energy0 = _initial_energy(n)
    rows = {}
    for m in methods:
        ops = driven.operations[m]
        e = free.energy_error[m]
        rows[m] = {
            "mul": ops["multiplications"], "add": ops["additions"], "fun": ops["functions"],
            "ops": ops["total"], "derive": derivation[m],
            "constraint": driven.constraint_residual[m],
            "energy": float(np.max(np.abs(e))) / energy0 if e is not None else float("nan"),
            "cpu_equal": timings[m].best if m in timings else float("nan"),
            "cpu_spread": timings[m].spread if m in timings else float("nan"),
            "cpu_timing": timings.get(m),
            "message": driven.messages[m],
        }
    return rows


def _initial_energy(n):
    definition = kd.models.build("snake", n=n)
    model = definition.numeric(definition.derive(), constants={"A": 0.0, "c": 0.0})
    return model.total_energy(0.0, model.state(definition.initial(model)))


def _winner(results, metric, methods):
    values = {m: results[m][metric] for m in methods if np.isfinite(results[m][metric])}
    return min(values, key=values.get) if values else "-"


def report(all_results, methods, markdown, target):
    sizes = sorted(all_results)
    columns = [("ops", "operations (after CSE)", "{:.0f}"),
               ("derive", "derivation CPU [s]", "{:.2f}"),
               ("constraint", "max |lateral wheel velocity| [m/s], rtol 1e-6", "{:.1e}"),
               ("energy", "max |E - E0| / E0, conservative run, rtol 1e-6", "{:.1e}"),
               ("cpu_equal", f"CPU s per simulated s at error {target:g}", "{:.3f}")]
    out = []
    for key, title, fmt in columns:
        if markdown:
            out.append(f"\n**{title}**\n")
            out.append("| method | " + " | ".join(f"n={n}" for n in sizes) + " |")
            out.append("|---|" + "---:|" * len(sizes))
        else:
            out.append(f"\n{title}")
            out.append(f"{'method':<22}" + "".join(f"{'n=' + str(n):>10}" for n in sizes))
        for m in methods:
            cells = [fmt.format(all_results[n][m][key]) if m in all_results[n] else "-"
                     for n in sizes]
            if markdown:
                out.append(f"| {m} | " + " | ".join(cells) + " |")
            else:
                out.append(f"{m:<22}" + "".join(f"{c:>10}" for c in cells))
        winners = [_winner(all_results[n], key, [m for m in methods if m in all_results[n]])
                   for n in sizes]
        out.append(("\n" if markdown else "") + "lowest: " + ", ".join(
            f"n={n} {w}" for n, w in zip(sizes, winners)))
        if key == "cpu_equal":
            out.append("spread (median / min - 1 over the rounds): " + "; ".join(
                f"n={n} " + ", ".join(f"{m} {all_results[n][m]['cpu_spread']:.0%}"
                                      for m in methods if m in all_results[n])
                for n in sizes))
            clear = [winner([r["cpu_timing"] for r in all_results[n].values()
                             if r["cpu_timing"] is not None]) for n in sizes]
            out.append("clear winner (spreads do not overlap): " + ", ".join(
                f"n={n} {w or 'none'}" for n, w in zip(sizes, clear)))
    mults = {n: all_results[n] for n in sizes}
    detail = ["\nmultiplications / additions / function calls"]
    for m in methods:
        detail.append(f"{m:<22}" + "".join(
            f"  {mults[n][m]['mul']}/{mults[n][m]['add']}/{mults[n][m]['fun']}"
            for n in sizes if m in mults[n]))
    out.extend(detail)
    failed = [f"n={n} {m}: {r['message']}" for n in sizes
              for m, r in all_results[n].items() if "reached the end" not in r["message"]]
    if failed:
        out.append("\ndid not finish: " + "; ".join(failed))
    return "\n".join(out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=list(range(3, 11)))
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--t-end", type=float, default=3.0)
    parser.add_argument("--target", type=float, default=1e-6,
                        help="coordinate error at which CPU times are compared")
    parser.add_argument("--rounds", type=int, default=3,
                        help="interleaved work-precision rounds (minimum and spread)")
    parser.add_argument("--markdown", action="store_true")
    args = parser.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    results = {n: measure(n, methods, args.t_end, args.target, (1e-6, 1e-8, 1e-10),
                       args.rounds)
               for n in args.n}
    print(f"Snake robot on passive wheels, t = 0..{args.t_end:g} s, numpy backend, RK45.")
    print(report(results, methods, args.markdown, args.target))
    return 0


if __name__ == "__main__":
    sys.exit(main())
