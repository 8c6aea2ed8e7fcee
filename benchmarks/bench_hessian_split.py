"""Where an iteration of the exact-Hessian solve goes: IPOPT's own timing.

The pendulum swing-up of ``bench_optimal_control.py`` (``_ocp_peers.PENDULUM``,
backward Euler, C backend, ``solve(hessian="exact")``, the line guess of
``_ocp_peers.pendulum_guess``), solved ``--rounds`` times per node count
after one solve that builds everything (the generated modules' optimized
builds awaited), each with IPOPT's ``print_timing_statistics`` written to a
file and read back.  Printed per node count: the iterations, then per
iteration (ms) the wall time of the solve, IPOPT's own work (its overall
algorithm less the function evaluations), the function evaluations, of
them the Lagrangian's Hessian and the constraint Jacobian; the minimum and
the spread ``median / min - 1`` over the rounds.

Run it with the kanedyn to measure first on ``PYTHONPATH`` (a checkout of an
older commit measures that commit with this script), interleaving runs of
two checkouts by hand::

    python benchmarks/bench_hessian_split.py [--nodes 100 10000] [--rounds 5]
"""

import argparse
import os
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _ocp_peers as peers  # noqa: E402

#: the lines of IPOPT's timing statistics read (CPU seconds, then "(sys: ... wall: ...)")
PARTS = {"overall": "OverallAlgorithm", "functions": "Function Evaluations",
         "hessian": "Lagrangian Hessian", "jacobian": "Equality constraint Jacobian"}


def _wall(text, label):
    """The wall seconds of IPOPT's timing line ``label`` in ``text``."""
    found = re.search(re.escape(label) + r"\.*:\s*[-\d.e+]+\s*\(sys:\s*[-\d.e+]+\s*wall:\s*"
                      r"([-\d.e+]+)\)", text)
    if found is None:
        raise RuntimeError(f"IPOPT's timing statistics have no line {label!r}")
    return float(found.group(1))


def solve_timed(problem, guess, folder):
    """``(iterations, {part: ms per iteration})`` of one exact-Hessian solve."""
    path = os.path.join(folder, "ipopt.txt")
    options = {k: v for k, v in peers.IPOPT_OPTIONS.items() if k != "hessian_approximation"}
    options.update(print_timing_statistics="yes", output_file=path, file_print_level=3)
    start = time.perf_counter()
    result = problem.solve(guess, options=options, hessian="exact")
    wall = time.perf_counter() - start
    text = Path(path).read_text()
    n = max(result.iterations, 1)
    parts = {k: _wall(text, label) for k, label in PARTS.items()}
    per = {"solve": wall, "ipopt": parts["overall"] - parts["functions"],
           "functions": parts["functions"], "hessian": parts["hessian"],
           "jacobian": parts["jacobian"]}
    return result.iterations, {k: 1e3 * v / n for k, v in per.items()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="*", default=[100, 10000])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    import kanedyn as kd
    from kanedyn.numerics.backends._c_quick import finish_compiling
    print(f"kanedyn from {Path(kd.__file__).parent}, load average {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as folder:
        for nodes in args.nodes:
            problem, _ = peers.pendulum_kanedyn(nodes)
            guess = peers.pendulum_guess(nodes)
            solve_timed(problem, guess, folder)  # builds the generated code
            finish_compiling()
            rounds = [solve_timed(problem, guess, folder) for _ in range(args.rounds)]
            iterations = {i for i, _ in rounds}
            print(f"N = {nodes}: iterations {sorted(iterations)}; per iteration, ms "
                  "(min, spread median/min - 1):")
            for part in rounds[0][1]:
                values = np.array([r[1][part] for r in rounds])
                spread = np.median(values) / values.min() - 1
                print(f"  {part:10s} {values.min():9.3f}  {spread:5.0%}")


if __name__ == "__main__":
    main()
