"""Exact derivatives of the dynamics: kanedyn's ``model.jacobians`` vs Pinocchio's
``computeABADerivatives``, same run.

The spatial chain ``chain3d`` (the same chain in Pinocchio's terms from
:func:`_peers.pinocchio_chain`) at n = 7, 12, 30 (and 100 with ``--large``),
compiled (backend ``"c"``), at a random state:

- ``model.jacobians(0.0, y)``: the full :math:`\\partial f/\\partial y` (kinematic
  rows included), called for one state from Python, and for 1000 states in
  one call (per state);
- ``pinocchio.computeABADerivatives(model, data, q, v, tau)`` from Python:
  :math:`\\partial\\ddot q/\\partial(q, v, \\tau)`;
- the largest difference of :math:`\\partial\\dot u/\\partial(q, u)` between them;
- the size of the generated derivative code (its operations, after common
  subexpressions) and the exponent of its growth with n;
- the time of the first call (generation and compilation: the quick compiler's
  module, gcc's built in the background) against that of the first right-hand
  side (derivation, generation, the first module), in a fresh process with a
  fresh cache.

Timings interleaved in rounds (:func:`_timing.interleaved`, thread CPU time);
minimum and spread (median / min - 1).  Ratios are between numbers measured in
this run.

Usage::

    python benchmarks/bench_jacobians.py [--sizes 7 12 30] [--large] [--rounds 7]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import kanedyn as kd  # noqa: E402
from _fresh_process import byte_compile_package, run_python  # noqa: E402
from _peers import DEFAULTS, pinocchio_chain  # noqa: E402
from _timing import interleaved  # noqa: E402
from bench_numerics import machine_info  # noqa: E402


_FIRST_USE = """
import time, json, numpy as np, kanedyn as kd
from _peers import DEFAULTS
start = time.perf_counter()
model = kd.models.build("chain3d", n={n}).numeric(constants=DEFAULTS, backend="c")
model.rhs(0.0, np.zeros({x}))
rhs = time.perf_counter() - start
start = time.perf_counter()
model.jacobians(0.0, np.zeros({x}))
print(json.dumps([rhs, time.perf_counter() - start]))
"""


def first_use(n):
    """Seconds of the first rhs (derivation, generation and the first module
    included) and then of the first jacobians call, in a fresh process with a
    fresh cache."""
    with tempfile.TemporaryDirectory() as cache:
        code = f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})\n" \
            + _FIRST_USE.format(n=n, x=2 * n)
        done = run_python(code, cache)
        if done.returncode:
            raise RuntimeError(done.stderr[-2000:])
        return json.loads(done.stdout.strip().splitlines()[-1])


def operations(n):
    """Operations of the generated derivative code (after common subexpressions)."""
    from kanedyn.numerics._jacobians import _specification
    model = kd.models.build("chain3d", n=n).numeric(constants=DEFAULTS, backend="numpy")
    prog, _, outputs = _specification(model, False)
    return prog.count_ops([e for _, exprs in outputs for e in exprs], cse=True)


def measure(n, rounds):
    import pinocchio as pin

    model = kd.models.build("chain3d", n=n).numeric(constants=DEFAULTS, backend="c")
    pmodel, pdata = pinocchio_chain(n)
    rng = np.random.default_rng(2)
    q, u = rng.uniform(-1.5, 1.5, (2, n))
    tau = np.zeros(n)
    y = np.concatenate([q, u])
    J = model.jacobians(0.0, y)
    # the derivative module comes from the quick compiler first: gcc's code is timed
    kd.numerics.finish_compiling()
    dq, dv, _ = pin.computeABADerivatives(pmodel, pdata, q, u, tau)
    error = max(np.max(np.abs(J.state[n:, :n] - dq)), np.max(np.abs(J.state[n:, n:] - dv)))
    states = rng.uniform(-1.5, 1.5, (1000, 2 * n))
    times = interleaved({
        "kanedyn": lambda: model.jacobians(0.0, y),
        "batch": lambda: model.jacobians(np.zeros(len(states)), states),
        "pinocchio": lambda: pin.computeABADerivatives(pmodel, pdata, q, u, tau)},
        rounds=rounds)
    times["batch"].times = [x / len(states) for x in times["batch"].times]
    return times, float(error)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[7, 12, 30])
    parser.add_argument("--large", action="store_true", help="also n = 100")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--no-first-use", action="store_true",
                        help="only the timings per call (not the fresh-process builds)")
    args = parser.parse_args()
    sizes = args.sizes + ([100] if args.large else [])
    print(machine_info())
    print("\n| chain3d n | kanedyn jacobians, us | the same, 1000 states in one call, us "
          "per state | Pinocchio computeABADerivatives, us | kanedyn / Pinocchio (one; "
          "batch) | largest difference |")
    print("|---|---|---|---|---|---|")
    for n in sizes:
        times, error = measure(n, args.rounds)
        a, c, b = times["kanedyn"], times["batch"], times["pinocchio"]
        print(f"| {n} | {1e6 * a.best:.1f} (spread {a.spread:.0%}) | {1e6 * c.best:.1f} "
              f"(spread {c.spread:.0%}) | {1e6 * b.best:.1f} (spread {b.spread:.0%}) | "
              f"{a.best / b.best:.2f}; {c.best / b.best:.2f} | {error:.1e} |")
    if args.no_first_use:
        return
    print("\n| chain3d n | operations of the derivative code | first rhs, s | "
          "first jacobians, s | jacobians / rhs |")
    print("|---|---|---|---|---|")
    ops, builds = [], []
    byte_compile_package()
    for n in sizes:
        count = operations(n)
        ops.append(count)
        rhs, jac = first_use(n)
        builds.append(jac)
        print(f"| {n} | {count} | {rhs:.2f} | {jac:.2f} | {jac / rhs:.2f} |")
    if len(sizes) > 1:
        for what, values in (("operations of the derivative code", ops),
                             ("first jacobians call", builds)):
            slope = np.polyfit(np.log(sizes), np.log(values), 1)[0]
            print(f"\ngrowth of the {what}: ~ n^{slope:.2f}")


if __name__ == "__main__":
    main()
