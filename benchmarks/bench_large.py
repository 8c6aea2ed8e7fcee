"""The compiled right-hand side against Pinocchio's ``aba`` from 2 to 100 bodies.

Usage::

    python benchmarks/bench_large.py [--sizes 2 5 10 30 60 100] [--rounds 15]
                                     [--no-humanoid] [--markdown] [--quick]
                                     [--straight-line]

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

``--straight-line``: also time, in the same rounds, the model compiled with the
mass matrix evaluated by its straight-line code and factored (the path before
the articulated-body pass; ``TREE_MIN_SPEEDS`` raised for that build), and give
the largest relative difference of its u' from the default model's.
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
from _timing import interleaved, optimized_modules_only, winner  # noqa: E402


def compiled(definition, straight):
    """The C model of ``definition`` and, if ``straight``, the straight-line one."""
    from kanedyn.numerics.backends import _c
    eom = definition.derive()
    model = definition.numeric(eom, backend="c")
    if not straight:
        return model, None
    default = _c.TREE_MIN_SPEEDS
    _c.TREE_MIN_SPEEDS = 10**9
    try:
        return model, definition.numeric(eom, backend="c")
    finally:
        _c.TREE_MIN_SPEEDS = default


def chain_case(n, straight=False):
    """(label, kanedyn models, pin model, pin data, permutation of u to aba's v)."""
    definition = kd.models.build("chain3d", n=n, style="positions")
    models = compiled(definition, straight)
    pm, pd = pinocchio_chain(n)
    return f"chain n={n}", models, pm, pd, np.arange(n)


def humanoid_case(straight=False):
    text = humanoid_urdf()
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "humanoid30.urdf")
        with open(path, "w") as handle:
            handle.write(text)
        definition = kd.models.from_urdf(path, efforts=False)
    models = compiled(definition, straight)
    pm, pd = pinocchio_urdf(text)
    names = [j.name for j in definition.joints]
    # kanedyn's coordinate k is Pinocchio's joint names.index(...) - 1 (1 dof each)
    order = np.array([pm.idx_vs[pm.getJointId(name)] for name in names])
    return "humanoid tree, 30 bodies", models, pm, pd, order


def measure(case, rounds):
    import pinocchio as pin

    label, (model, straight), pm, pd, order = case
    n = len(order)
    rng = np.random.default_rng(0)
    worst = worst_straight = 0.0
    for _ in range(20):
        y = np.hstack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-2, 2, n)])
        q, v = np.zeros(n), np.zeros(n)
        q[order], v[order] = y[:n], y[n:]
        theirs = np.asarray(pin.aba(pm, pd, q, v, np.zeros(n)))[order]
        ours = model.rhs(0.0, y)[n:]
        worst = max(worst, float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs))))
        if straight is not None:
            before = straight.rhs(0.0, y)[n:]
            worst_straight = max(worst_straight, float(np.max(np.abs(ours - before))
                                                       / np.max(np.abs(before))))
    q, v = np.zeros(n), np.zeros(n)
    q[order], v[order] = y[:n], y[n:]
    tau = np.zeros(n)
    contenders = {"kanedyn": lambda: model.rhs(0.0, y),
                  "aba": lambda: pin.aba(pm, pd, q, v, tau)}
    if straight is not None:
        contenders["straight"] = lambda: straight.rhs(0.0, y)
    times = interleaved(contenders, rounds=rounds, min_time=0.02)
    pair = {"kanedyn": times["kanedyn"], "aba": times["aba"]}
    return {"label": label, "n": n, "ours": times["kanedyn"], "aba": times["aba"],
            "straight": times.get("straight"), "diff": worst,
            "winner": winner(pair) or "none (spreads overlap)",
            "diff_straight": worst_straight}


def main(argv=None):
    optimized_modules_only()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2, 5, 10, 30, 60, 100])
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--no-humanoid", action="store_true")
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--quick", action="store_true",
                        help="n = 2 and 5 only, 3 rounds, no humanoid (a smoke run)")
    parser.add_argument("--straight-line", action="store_true",
                        help="also time the straight-line mass matrix path")
    args = parser.parse_args(argv)
    if args.quick:
        args.sizes, args.rounds, args.no_humanoid = [2, 5], 3, True
    straight = args.straight_line
    cases = [lambda n=n: chain_case(n, straight) for n in args.sizes]
    if not args.no_humanoid:
        cases.append(lambda: humanoid_case(straight))
    bar = "|" if args.markdown else " "
    extra = (f" straight-line µs (spread) {bar} ratio {bar} max rel. diff u' "
             f"from straight-line {bar}" if straight else "")
    print(f"{bar} model {bar} kanedyn rhs µs (spread) {bar} pin.aba µs (spread) "
          f"{bar} ratio {bar} winner {bar} max rel. diff u' {bar}{extra}")
    if args.markdown:
        print("|---|---:|---:|---:|---|---:|" + ("---:|---:|---:|" if straight else ""))
    for make in cases:
        row = measure(make(), args.rounds)
        ours, aba = row["ours"], row["aba"]
        text = (f"{bar} {row['label']} {bar} {ours.best * 1e6:.2f} ({ours.spread:.0%}) {bar} "
                f"{aba.best * 1e6:.2f} ({aba.spread:.0%}) {bar} {ours.best / aba.best:.2f} "
                f"{bar} {row['winner']} {bar} {row['diff']:.1e} {bar}")
        if straight:
            before = row["straight"]
            text += (f" {before.best * 1e6:.2f} ({before.spread:.0%}) {bar} "
                     f"{before.best / aba.best:.2f} {bar} {row['diff_straight']:.1e} {bar}")
        print(text, flush=True)


if __name__ == "__main__":
    main()
