"""Optimal control against opty, same process, same problem, same IPOPT.

The pendulum swing-up of opty's gallery (10 s, |torque| <= 2 N m, minimum
integral of torque^2; ``_ocp_peers.PENDULUM``) at 100, 1000 and 10000 nodes,
and the cart-pole swing-up (``_ocp_peers.CART_POLE``), posed with kanedyn
(``kd.OptimalControlProblem`` on the built-in model, C backend) and with opty
(equations written independently), both with backward Euler (opty's default),
the same objective sum, bounds, IPOPT options (``_ocp_peers.IPOPT_OPTIONS``:
limited-memory Hessian, MUMPS, ``tol = 1e-10``) and the same initial guess:
opty's gallery's (normal random numbers, seed 0) at its 501 nodes, then the
501-node optimum interpolated for the other sizes.  Both call the same IPOPT
library (cyipopt on Debian's libipopt).

Printed per size: the wall time from the model to the optimum (kanedyn: the
numerical model, the problem, the solve; opty: the problem, whose
construction generates and compiles its code, and the solve), the solve
alone, the iterations, the time per iteration, the objectives and their
relative difference, and the ratios opty / kanedyn.  The C module and opty's
compiled code are built anew in a fresh temporary cache for each run of the
script, so the first size includes compilation for both.

Usage::

    python benchmarks/bench_optimal_control.py [--nodes 100 1000 10000] [--cart-pole 100]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _ocp_peers as peers  # noqa: E402


def run_kanedyn(build, nodes, guess):
    start = time.perf_counter()
    problem, model = build(nodes)
    model.jacobians(0.0, np.zeros(model.n_states), r=np.zeros(len(model.input_names)))
    result = problem.solve(guess, options=peers.IPOPT_OPTIONS)  # derivatives built above
    total = time.perf_counter() - start
    return dict(total=total, solve=result.wall_time, iterations=result.iterations,
                objective=result.objective, status=result.status, x=result.x)


def run_opty(build, nodes, guess, ns, nr):
    start = time.perf_counter()
    problem = build(nodes)
    built = time.perf_counter()
    x, info, iterations = peers.solve_opty(problem, guess, ns, nr)
    end = time.perf_counter()
    return dict(total=end - start, solve=end - built, iterations=iterations,
                objective=float(info["obj_val"]), status=int(info["status"]), x=x)


def compare(label, kanedyn_build, opty_build, nodes, guess, ns, nr):
    k = run_kanedyn(kanedyn_build, nodes, guess)
    o = run_opty(opty_build, nodes, guess, ns, nr)
    rel = abs(k["objective"] - o["objective"]) / abs(o["objective"])
    print(f"{label} N = {nodes}")
    for name, r in (("kanedyn", k), ("opty", o)):
        print(f"  {name:8s} model->optimum {r['total']:8.2f} s  solve {r['solve']:8.2f} s  "
              f"iterations {r['iterations']:5d}  per iteration "
              f"{1e3 * r['solve'] / max(r['iterations'], 1):7.2f} ms  objective "
              f"{r['objective']:.12g}  IPOPT status {r['status']}")
    print(f"  objectives differ by {rel:.1e} (relative); solutions by "
          f"{np.max(np.abs(k['x'] - o['x'])):.1e} at most")
    print(f"  opty / kanedyn: model->optimum {o['total'] / k['total']:.1f}x, per iteration "
          f"{(o['solve'] / max(o['iterations'], 1)) / (k['solve'] / max(k['iterations'], 1)):.2f}x")
    return k, o


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="*", default=[100, 1000, 10000])
    parser.add_argument("--cart-pole", type=int, nargs="*", default=[100])
    args = parser.parse_args()
    os.environ.setdefault("KANEDYN_CACHE_DIR", tempfile.mkdtemp(prefix="kd-bench-ocp-"))
    import cyipopt
    import opty
    print(f"opty {opty.__version__}, cyipopt {cyipopt.__version__} (IPOPT "
          f"{'.'.join(map(str, cyipopt.IPOPT_VERSION))}), kanedyn cache "
          f"{os.environ['KANEDYN_CACHE_DIR']}")
    # opty's gallery problem as published: 501 nodes from its random guess
    gallery = 501
    k, _ = compare("pendulum swing-up (opty's gallery: random guess)", peers.pendulum_kanedyn,
                   peers.pendulum_opty, gallery, np.random.default_rng(0).normal(
                       size=3 * gallery), 2, 1)
    # the other sizes from that solution, interpolated (the random guess fails
    # for both at 100 nodes)
    coarse = k["x"]
    for nodes in args.nodes:
        s_old, s_new = np.linspace(0, 1, gallery), np.linspace(0, 1, nodes)
        Y = coarse[:2 * gallery].reshape(gallery, 2)
        R = coarse[2 * gallery:3 * gallery]
        guess = np.concatenate([
            np.stack([np.interp(s_new, s_old, Y[:, j]) for j in range(2)], axis=1).ravel(),
            np.interp(s_new, s_old, R)])
        compare("pendulum swing-up (guess: the 501-node optimum interpolated)",
                peers.pendulum_kanedyn, peers.pendulum_opty, nodes, guess, 2, 1)
    for nodes in args.cart_pole:
        compare("cart-pole swing-up", peers.cart_pole_kanedyn, peers.cart_pole_opty, nodes,
                peers.cart_pole_guess(nodes), 4, 1)


if __name__ == "__main__":
    main()
