"""Inverse dynamics per point: kanedyn vs Pinocchio's ``rnea``, same run.

The spatial chain ``chain3d`` (n = 5, 10, 30 links; the same chain in
Pinocchio's terms from :func:`_peers.pinocchio_chain`) at random states and
accelerations. Measured:

- kanedyn's compiled ``model.inverse_dynamics(t, q, u, udot)`` called for one
  point from Python (backend ``"c"``);
- the same function given a 1,000-point trajectory in one call, per point;
- ``pinocchio.rnea(model, data, q, v, a)`` for one point;
- the largest difference between the two, N m.

Ratios are between numbers measured in this run (design rule 15).

Usage::

    python benchmarks/bench_inverse.py [--sizes 5 10 30]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import kanedyn as kd  # noqa: E402
from _peers import DEFAULTS, pinocchio_chain  # noqa: E402
from bench_numerics import best_seconds, machine_info  # noqa: E402


def measure(n, points=1000, repeat=5, min_time=0.2):
    """Times per point (s) and the largest difference for the n-link chain."""
    import pinocchio as pin

    model = kd.models.build("chain3d", n=n).numeric(constants=DEFAULTS, backend="c")
    pmodel, pdata = pinocchio_chain(n)
    rng = np.random.default_rng(1)
    q = rng.uniform(-np.pi, np.pi, (n, points))
    u = rng.uniform(-2, 2, (n, points))
    udot = rng.uniform(-5, 5, (n, points))
    t = np.zeros(points)
    tau = model.inverse_dynamics(t, q, u, udot)       # also builds the C function
    ref = np.column_stack([pin.rnea(pmodel, pdata, q[:, i].copy(), u[:, i].copy(),
                                    udot[:, i].copy()) for i in range(points)])
    q0, u0, a0 = q[:, 0].copy(), u[:, 0].copy(), udot[:, 0].copy()
    one = best_seconds(lambda: model.inverse_dynamics(0.0, q0, u0, a0), repeat, min_time)
    batch = best_seconds(lambda: model.inverse_dynamics(t, q, u, udot), repeat,
                         min_time) / points
    peer = best_seconds(lambda: pin.rnea(pmodel, pdata, q0, u0, a0), repeat, min_time)
    return one, batch, peer, float(np.max(np.abs(tau - ref)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[5, 10, 30])
    args = parser.parse_args(argv)
    print(machine_info())
    print(f"{'n':>3}  {'kanedyn C, 1 point':>19}  {'per point of 1,000':>19}  "
          f"{'pinocchio rnea':>15}  {'kanedyn / rnea':>14}  {'max |diff| N m':>14}")
    for n in args.sizes:
        one, batch, peer, diff = measure(n)
        print(f"{n:3d}  {one * 1e6:16.2f} us  {batch * 1e6:16.2f} us  {peer * 1e6:12.2f} us"
              f"  {one / peer:14.2f}  {diff:14.1e}")


if __name__ == "__main__":
    main()
