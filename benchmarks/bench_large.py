"""The compiled right-hand side against Pinocchio's ``aba`` from 2 to 100 bodies.

Usage::

    python benchmarks/bench_large.py [--sizes 2 5 10 30 60 100] [--rounds 15]
                                     [--no-humanoid] [--markdown] [--quick]

Models: the 3D chain (``kd.models.build("chain3d", n=n, style="positions")``
against :func:`_peers.pinocchio_chain`) and a humanoid-like tree of 30 bodies
(:func:`_peers.humanoid_urdf`, read by ``kd.models.from_urdf`` and by
``pinocchio.buildModelFromXML``).  Each round times kanedyn's ``model.rhs`` and
``pin.aba`` one after the other (interleaved, :func:`_timing.interleaved`),
each over enough calls to last about 20 ms of thread CPU time; the tables give
the minimum over rounds of the CPU time per call, the spread (median / minimum
- 1) of each contender and the winner where the ranges [min, median] do not
overlap (:func:`_timing.winner`).
Also printed: the largest relative difference of u' from ``aba`` over 20
random states.  The compile cache is ``$KANEDYN_CACHE_DIR`` (as set by the caller).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile

import numpy as np

import kanedyn as kd

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _peers import humanoid_urdf, pinocchio_chain, pinocchio_urdf  # noqa: E402
from _timing import interleaved, winner  # noqa: E402


def chain_case(n):
    """(label, kanedyn model, pin model, pin data, permutation of u to aba's v)."""
    definition = kd.models.build("chain3d", n=n, style="positions")
    model = definition.numeric(definition.derive(), backend="c")
    pm, pd = pinocchio_chain(n)
    return f"chain n={n}", model, pm, pd, np.arange(n)


def humanoid_case():
    text = humanoid_urdf()
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "humanoid30.urdf")
        with open(path, "w") as handle:
            handle.write(text)
        definition = kd.models.from_urdf(path, efforts=False)
    model = definition.numeric(definition.derive(), backend="c")
    pm, pd = pinocchio_urdf(text)
    names = [j.name for j in definition.joints]
    # kanedyn's coordinate k is Pinocchio's joint names.index(...) - 1 (1 dof each)
    order = np.array([pm.idx_vs[pm.getJointId(name)] for name in names])
    return "humanoid tree, 30 bodies", model, pm, pd, order


def measure(case, rounds):
    import pinocchio as pin

    label, model, pm, pd, order = case
    n = len(order)
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(20):
        y = np.hstack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-2, 2, n)])
        q, v = np.zeros(n), np.zeros(n)
        q[order], v[order] = y[:n], y[n:]
        theirs = np.asarray(pin.aba(pm, pd, q, v, np.zeros(n)))[order]
        ours = model.rhs(0.0, y)[n:]
        worst = max(worst, float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs))))
    q, v = np.zeros(n), np.zeros(n)
    q[order], v[order] = y[:n], y[n:]
    tau = np.zeros(n)
    times = interleaved({"kanedyn": lambda: model.rhs(0.0, y),
                         "aba": lambda: pin.aba(pm, pd, q, v, tau)},
                        rounds=rounds, min_time=0.02)
    return {"label": label, "n": n, "ours": times["kanedyn"], "aba": times["aba"],
            "winner": winner(times) or "none (spreads overlap)", "diff": worst}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2, 5, 10, 30, 60, 100])
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--no-humanoid", action="store_true")
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--quick", action="store_true",
                        help="n = 2 and 5 only, 3 rounds, no humanoid (a smoke run)")
    args = parser.parse_args(argv)
    if args.quick:
        args.sizes, args.rounds, args.no_humanoid = [2, 5], 3, True
    cases = [lambda n=n: chain_case(n) for n in args.sizes]
    if not args.no_humanoid:
        cases.append(humanoid_case)
    bar = "|" if args.markdown else " "
    print(f"{bar} model {bar} kanedyn rhs µs (spread) {bar} pin.aba µs (spread) "
          f"{bar} ratio {bar} winner {bar} max rel. diff u' {bar}")
    if args.markdown:
        print("|---|---:|---:|---:|---|---:|")
    for make in cases:
        row = measure(make(), args.rounds)
        ours, aba = row["ours"], row["aba"]
        print(f"{bar} {row['label']} {bar} {ours.best * 1e6:.2f} ({ours.spread:.0%}) {bar} "
              f"{aba.best * 1e6:.2f} ({aba.spread:.0%}) {bar} {ours.best / aba.best:.2f} "
              f"{bar} {row['winner']} {bar} {row['diff']:.1e} {bar}", flush=True)


if __name__ == "__main__":
    main()
