"""fatrop (a structure-exploiting interior point method) through CasADi on the
pendulum swing-up: does it keep less memory per node than IPOPT with MUMPS?

opty's gallery swing-up (10 s, |torque| <= 2 N m, least sum of h torque^2,
``_ocp_peers.PENDULUM``) posed with ``casadi.Opti`` for fatrop, which takes
its dynamics as explicit stage maps x_{k+1} = F(x_k, u_k): forward Euler
here, so not the discrete problem of kanedyn's and opty's backward Euler
(the memory per node is what is compared).  The variables are declared
stage by stage, x_0, u_0, x_1, ..., and each stage's constraints in order,
which fatrop's structure detection needs.  The guess: the angle on a line
from 0 to pi, the rate of that line, no torque.

Each node count runs in a fresh process (``--child``); printed: the time to
build the ``Opti`` problem and to solve, fatrop's iterations and status,
the objective, the peak resident memory (``VmHWM``) and address space
(``VmPeak``) after building and after solving.  Run kanedyn's side with
``bench_optimal_control.py --scan`` for the same node counts.

Usage::

    python benchmarks/bench_ocp_fatrop.py [--nodes 1000 10000]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _ocp_peers as peers  # noqa: E402


def _memory():
    """``VmHWM`` and ``VmPeak`` of this process, GiB."""
    with open("/proc/self/status") as status:
        values = {k: int(v.split()[0]) / 2 ** 20 for k, v in
                  (line.split(":", 1) for line in status) if k in ("VmHWM", "VmPeak")}
    return f"resident {values['VmHWM']:.3f} GiB, address space {values['VmPeak']:.3f} GiB"


def solve(nodes):
    """The swing-up on ``nodes`` nodes with fatrop; prints its figures."""
    import casadi as ca
    p = peers.PENDULUM
    duration, limit = p["duration"], p["torque"]
    inertia, weight = p["m"] * p["l"] ** 2, p["m"] * p["g"] * p["l"]
    h = duration / (nodes - 1)
    start = time.perf_counter()
    opti = ca.Opti()
    X, U = [], []
    for k in range(nodes):
        X.append(opti.variable(2))
        if k < nodes - 1:
            U.append(opti.variable())
    objective = 0
    for k in range(nodes - 1):
        angle, rate = X[k][0], X[k][1]
        opti.subject_to(X[k + 1] == X[k] + h * ca.vertcat(
            rate, (U[k] - weight * ca.sin(angle)) / inertia))
        if k == 0:
            opti.subject_to(X[0] == ca.vertcat(0, 0))
        opti.subject_to(opti.bounded(-limit, U[k], limit))
        objective += h * U[k] ** 2
    opti.subject_to(X[-1] == ca.vertcat(np.pi, 0))
    opti.minimize(objective)
    s = np.linspace(0.0, 1.0, nodes)
    for k in range(nodes):
        opti.set_initial(X[k], [np.pi * s[k], np.pi / duration])
    opti.solver("fatrop", {"structure_detection": "auto", "expand": True,
                           "print_time": False, "fatrop.print_level": 0,
                           "fatrop.tol": 1e-8})
    built = time.perf_counter()
    print(f"fatrop, {nodes} nodes: Opti problem built in {built - start:.1f} s; "
          f"{_memory()}", flush=True)
    try:
        solution = opti.solve()
        stats, value = solution.stats(), solution.value(objective)
    except RuntimeError as exc:
        stats, value = opti.debug.stats(), float("nan")
        print(f"  not solved: {str(exc).splitlines()[-1][:160]}")
    print(f"  solved in {time.perf_counter() - built:.1f} s, {stats.get('iter_count')} "
          f"iterations, status {stats.get('return_status')}, objective {value:.10g}; "
          f"{_memory()}", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="*", default=[1000, 10000])
    parser.add_argument("--child", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        solve(args.child)
        return
    import casadi
    print(f"CasADi {casadi.__version__}; load average {os.getloadavg()[0]:.1f}")
    for nodes in args.nodes:
        subprocess.run([sys.executable, __file__, "--child", str(nodes)], check=False)


if __name__ == "__main__":
    main()
