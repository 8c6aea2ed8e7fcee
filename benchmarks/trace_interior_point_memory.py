"""Where the interior point's memory goes at its peak: one traced solve.

The pendulum swing-up of ``bench_optimal_control.py``'s scan (backward Euler,
opty's problem; the straight-line guess of ``_ocp_peers.pendulum_guess``, or
with ``--guess gallery`` the scan's own, the 501-node optimum interpolated)
solved by ``solve(solver="interior-point", hessian="exact")`` with at most
``--max-iter`` iterations, traced by ``tracemalloc`` from after the problem
is built.  Prints the highest traced memory of the solve in bytes per node
(NumPy's arrays included; the C kernel's own scratch and the allocator's
overhead not), where it was reached (the call stack at the highest traced
memory seen on a function's return; ``--at NAME`` looks only at returns of
functions named so), the allocations alive then by source line, and the
process's ``VmHWM`` and ``VmPeak``; with ``--resident`` also the highest
resident memory read on a return (``/proc/self/statm``), the traced memory
then, and where.  Bytes per node of one node count
include the fixed part (imports made during the solve): compare two counts
for a slope.  ``docs/benchmarks.md`` ("A fourth round: what the iterations
hold") gives its figures.

    python benchmarks/trace_interior_point_memory.py [--nodes 100000] [--max-iter 15]
        [--at NAME] [--lines 30] [--limited-memory] [--linear-solver sparse]
        [--guess gallery] [--resident]
"""

from __future__ import annotations

import argparse
import linecache
import os
import sys
import tracemalloc

# _ocp_peers lives next to this script (on sys.path when the script is run directly)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _ocp_peers as peers  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=100_000)
    parser.add_argument("--max-iter", type=int, default=15)
    parser.add_argument("--at", default=None,
                        help="look only at returns of functions of this name (e.g. _factor)")
    parser.add_argument("--lines", type=int, default=30, help="allocations listed")
    parser.add_argument("--limited-memory", action="store_true",
                        help="the limited-memory Hessian (the solver's default) instead of "
                             "the exact one")
    parser.add_argument("--guess", default="line", choices=("line", "gallery"),
                        help="the straight line (_ocp_peers.pendulum_guess) or, as "
                             "bench_optimal_control.py's scan starts, the 501-node optimum "
                             "interpolated")
    parser.add_argument("--resident", action="store_true",
                        help="also read the resident memory (/proc/self/statm) at each "
                             "return: its highest, the traced memory then, and where "
                             "(tracemalloc's own memory included)")
    parser.add_argument("--linear-solver", default="auto",
                        choices=("auto", "sparse", "envelope", "dense"),
                        help="the interior point's factorization (its option linear_solver)")
    args = parser.parse_args()
    nodes = args.nodes
    problem, _ = peers.pendulum_kanedyn(nodes)
    guess = (peers.pendulum_guess(nodes) if args.guess == "line" else
             peers.pendulum_interpolated(peers.pendulum_gallery_optimum(), nodes))
    highest = {"bytes": -1, "snapshot": None, "stack": ""}
    # with --resident: the highest resident memory seen on a return, the
    # traced memory then, and where
    statm = os.open("/proc/self/statm", os.O_RDONLY) if args.resident else None
    resident = {"bytes": -1, "traced": 0, "stack": ""}

    def resident_bytes():
        return int(os.pread(statm, 64, 0).split()[1]) * os.sysconf("SC_PAGE_SIZE")

    def stack_of(frame):
        names, f = [], frame
        while f is not None and len(names) < 6:
            names.append(f.f_code.co_name)
            f = f.f_back
        return " < ".join(names)

    def on_return(frame, event, _arg):
        if event != "return" or "kanedyn" not in frame.f_code.co_filename:
            return
        if args.at and frame.f_code.co_name != args.at:
            return
        now = tracemalloc.get_traced_memory()[0]
        if statm is not None:
            rss = resident_bytes()
            if rss > resident["bytes"]:
                resident.update(bytes=rss, traced=now, stack=stack_of(frame))
        if now > highest["bytes"] * 1.01:
            highest.update(bytes=now, snapshot=tracemalloc.take_snapshot(),
                           stack=stack_of(frame))

    options = dict(max_iter=args.max_iter, tol=1e-10, linear_solver=args.linear_solver)
    hessian = "limited-memory" if args.limited_memory else "exact"
    tracemalloc.start(1)
    start = tracemalloc.get_traced_memory()[0]
    if statm is not None:
        start_rss = resident_bytes()
    sys.setprofile(on_return)
    try:
        result = problem.solve(guess, solver="interior-point", hessian=hessian,
                               options=options)
    finally:
        sys.setprofile(None)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    print(f"pendulum swing-up, {nodes} nodes, backward Euler, {hessian} Hessian, "
          f"{args.linear_solver} factorization: status "
          f"{result.status} after {result.iterations} iterations, objective "
          f"{result.objective:.10g}")
    print(f"highest traced memory of the solve: {(peak - start) / nodes:.0f} B a node; the "
          f"highest seen on a return{f' of {args.at}' if args.at else ''}: "
          f"{(highest['bytes'] - start) / nodes:.0f} B a node, in {highest['stack']}")
    if statm is not None:
        above = (resident["bytes"] - start_rss) / nodes
        print(f"highest resident memory seen on a return: {above:.0f} B a node above the "
              f"start's (traced then: {(resident['traced'] - start) / nodes:.0f}), in "
              f"{resident['stack']}")
    print("alive then, B a node, by the line that allocated it:")
    for stat in highest["snapshot"].statistics("lineno")[:args.lines]:
        frame = stat.traceback[0]
        code = linecache.getline(frame.filename, frame.lineno).strip()
        print(f"  {stat.size / nodes:7.0f}  {os.path.basename(frame.filename)}:{frame.lineno}"
              f"  {code[:80]}")
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(("VmHWM", "VmPeak")):
                print(line.strip())


if __name__ == "__main__":
    main()
