"""kanedyn's interior point with the exact Hessian and with its limited-memory
BFGS approximation (IPOPT's update, which skips pairs of negative curvature,
and Powell's damped one, the default), against IPOPT with the exact Hessian.

The pendulum and cart-pole swing-ups of ``_ocp_peers`` (opty's gallery
problems), each collocation method at 40 and 200 nodes, from the straight
line with the input at 0.1 (pendulum) or 0 (cart-pole), ``tol = 1e-10``.
Some are infeasible with so few nodes (IPOPT: status 2).  Per solver and
problem: iterations, status, the objective ("same" within 1e-6 relative of
IPOPT's when IPOPT solved it) and the time per iteration.  Not a test: a
table of how each Hessian fares, for docs/benchmarks.md.

Usage::

    python benchmarks/bench_interior_point_hessians.py [--nodes 40 200]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _ocp_peers as peers  # noqa: E402

METHODS = ("trapezoid", "hermite-simpson", "backward-euler", "midpoint")

#: column -> (solver, hessian, extra options)
SOLVERS = {
    "IPOPT exact": ("ipopt", "exact", {"print_level": 0}),
    "IP exact": ("interior-point", "exact", {}),
    "IP L-BFGS (IPOPT's)": ("interior-point", "limited-memory",
                            {"limited_memory_update_type": "bfgs"}),
    "IP L-BFGS damped": ("interior-point", "limited-memory",
                         {"limited_memory_update_type": "damped-bfgs"}),
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="+", default=[40, 200])
    args = parser.parse_args()
    os.environ.setdefault("KANEDYN_CACHE_DIR", tempfile.mkdtemp(prefix="kd-bench-iph-"))
    print(f"load average {os.getloadavg()[0]:.1f}; cells: iterations, status, objective "
          "('same': within 1e-6 of IPOPT's), ms per iteration")
    print("| problem | " + " | ".join(SOLVERS) + " |")
    print("|---" * (len(SOLVERS) + 1) + "|")
    tally = {name: {"same": 0, "infeasible": 0} for name in SOLVERS}
    for peer, start in (("pendulum", 0.1), ("cart_pole", 0.0)):
        for method in METHODS:
            for nodes in args.nodes:
                problem, _ = getattr(peers, f"{peer}_kanedyn")(nodes, method)
                guess = problem.guess_line(inputs={problem.symbols.inputs[0]: start})
                cells, reference = [], None
                for name, (solver, hessian, extra) in SOLVERS.items():
                    found = problem.solve(guess, solver=solver, hessian=hessian,
                                          options=dict({"tol": 1e-10}, **extra))
                    if reference is None:
                        reference = found
                    solved = reference.status in (0, 1)
                    same = (solved and found.status in (0, 1) and abs(
                        found.objective - reference.objective)
                        <= 1e-6 * max(1.0, abs(reference.objective)))
                    tally[name]["same"] += same
                    tally[name]["infeasible"] += (not solved and found.status == 2)
                    shown = "same" if same and name != "IPOPT exact" else \
                        f"{found.objective:.8g}"
                    per = 1e3 * found.wall_time / max(found.iterations, 1)
                    cells.append(f"{found.iterations}, {found.status}, {shown}, {per:.2f}")
                print(f"| {peer.replace('_', '-')}, {method}, {nodes} | " + " | ".join(cells)
                      + " |", flush=True)
    for name, counts in tally.items():
        print(f"{name}: IPOPT's optimum {counts['same']}, infeasibility found (status 2) "
              f"where IPOPT found it {counts['infeasible']}")


if __name__ == "__main__":
    main()
