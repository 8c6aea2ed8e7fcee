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

With ``--repeat K`` each tool then solves its problem again K times from the
same guess, the tools in turn (kanedyn's solvers, opty, and again), and the
time per iteration is also printed as the minimum over those solves (wall
time of the solve over its iterations; kanedyn's interior point with its
phases from the fastest solve): the cost of an iteration without what a
first solve does once (the first calls into each module, kanedyn's
Hessian terms differentiated on first use, the KKT analysis, warming the
caches), and less of the machine's other work.

Printed per size: the wall time from the model to the optimum (kanedyn: the
numerical model, the problem, the solve; opty: the problem, whose
construction generates and compiles its code, and the solve), the solve
alone, the iterations, the time per iteration, the objectives and their
relative difference, and the ratios opty / kanedyn.  The C module and opty's
compiled code are built anew in a fresh temporary cache for each run of the
script, so the first size includes compilation for both (in model->optimum;
kanedyn's derivatives, its Hessian's module and SparseKKT's are built before
its solve is timed, as opty's code is compiled before its solve).

A problem of opty's gallery with six states (``--gallery``): "Upright a
double pendulum" (a cart and two rods from hanging to upright in the least
time, ``_ocp_peers.DOUBLE_PENDULUM_CART``), posed as the gallery poses it
(300 nodes, backward Euler, its own initial guess), opty's equations by
SymPy's KanesMethod, kanedyn's by ``kd.kane`` on the same SymPy objects.
Each is also restarted from the other's optimum, to check that both
discrete problems have the same optima.  With ``--solvers ... interior-point``
kanedyn's interior point solves it too, with its limited-memory Hessian
(the exact one stalls there, and IPOPT's exact one ends infeasible): IPOPT's
update and Powell's damped one, each from the gallery's guess and from
opty's optimum.

Nodes against memory and time (``--scan``): the pendulum swing-up solved
in a fresh child process per run, from the 501-node optimum interpolated,
at growing node counts, by each of ``CONTENDERS``: kanedyn and opty as
their users run them (kanedyn's defaults ask MUMPS for 100 % workspace over
its estimate, opty leaves IPOPT's 1000 %), and each with the other's
``mumps_mem_percent``, which tells the option's part of a difference.  Per
run: the child's peak resident memory from ``os.wait4`` (``ru_maxrss``),
its peak address space (``VmPeak``, which a cap such as ``ulimit -v``
counts), its wall time from the model to the optimum.  A contender stops at
the first node count whose run exceeds the memory budget
(``--memory-budget``, GiB of peak resident memory) or the time budget
(``--time-budget``, s; the child is then killed), or that IPOPT does not
solve.  ``--scan-max-iter`` caps IPOPT's iterations (the same for all; the
memory grows over the first ten or so, as the limited-memory Hessian fills
its history, then hardly).  Then, per budget of ``--budgets`` (GiB), the
most nodes each ran within it and where the line through its two largest
runs reaches it, and kanedyn's count over opty's (the issue's goal: 10x).
``--address-cap`` (GiB) caps each child's address space (``RLIMIT_AS``); by
default there is no cap: with IPOPT's 1000 % MUMPS reserves far more
address space than it touches, and with a cap of 8 or 12 GiB it failed to
allocate its workspace at 10^6 nodes with 3.1 GiB resident.

``--hessian exact``: kanedyn with the exact Hessian of the Lagrangian
(``solve(hessian="exact")``), opty with IPOPT's limited-memory one as always
(opty gives no Hessian).

``--solvers ipopt interior-point``: kanedyn's NLP solvers, each a row per
size beside opty's: IPOPT (with ``--hessian``'s Hessian) and kanedyn's own
interior-point method (``solve(solver="interior-point")``, the exact Hessian
in these rows, ``tol = 1e-10`` as IPOPT's; ``--linear-solver`` picks its
factorization: by default the solver's own choice (``"auto"``, the
envelope since 2026-11-30; the sparse one in the figures recorded before),
``sparse``, ``envelope``, or ``dense`` only for small sizes).  The
interior-point rows also print where its time went per iteration: the
callbacks (objective, constraints, their derivatives, trial points
included), the Hessian's values, the factorizations and solves, and the
rest (the algorithm's own work in Python).  The scan's contenders include
``kanedyn, interior-point`` (the solver's defaults), ``kanedyn,
interior-point, sparse`` and ``kanedyn, interior-point, NumPy's allocator``
(``large_arrays="numpy"``: NumPy's large arrays not in mappings of their
own).

Usage::

    python benchmarks/bench_optimal_control.py [--nodes 100 1000 10000] [--cart-pole 100] \
        [--hessian exact] [--solvers ipopt interior-point] [--linear-solver dense] \
        [--repeat 5]
    python benchmarks/bench_optimal_control.py --nodes --cart-pole --gallery 300 \
        [--solvers ipopt interior-point]
    python benchmarks/bench_optimal_control.py --nodes --cart-pole --scan \
        [--scan-nodes 1000 3000 ...] [--memory-budget 4] [--time-budget 600] \
        [--address-cap 12] [--scan-max-iter 15] [--budgets 1 2] [--contenders ...]
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _ocp_peers as peers  # noqa: E402


#: kanedyn's Hessian of the Lagrangian (``--hessian``): IPOPT's limited-memory
#: approximation (as opty) or the exact one
HESSIAN = {"kind": "limited-memory"}

#: kanedyn's NLP solvers compared (``--solvers``) and the interior-point
#: method's factorization (``--linear-solver``)
SOLVERS = {"kanedyn": ["ipopt"], "linear_solver": "auto"}

#: repeated solves of each built problem (``--repeat``)
REPEAT = {"solves": 0}


def interior_point_options():
    """The interior-point solver's options: IPOPT_OPTIONS' tolerance and
    iteration limit (the others are IPOPT's own), the factorization."""
    return {"tol": peers.IPOPT_OPTIONS["tol"], "max_iter": peers.IPOPT_OPTIONS["max_iter"],
            "linear_solver": SOLVERS["linear_solver"]}


def kanedyn_options():
    """IPOPT's options and ``solve``'s ``hessian`` for kanedyn."""
    if HESSIAN["kind"] == "exact":
        options = {k: v for k, v in peers.IPOPT_OPTIONS.items() if k != "hessian_approximation"}
        return options, "exact"
    return peers.IPOPT_OPTIONS, "limited-memory"


def run_kanedyn(build, nodes, guess, solver="ipopt"):
    start = time.perf_counter()
    problem, model = build(nodes)
    model.jacobians(0.0, np.zeros(model.n_states), r=np.zeros(len(model.input_names)))
    if HESSIAN["kind"] == "exact" or solver == "interior-point":
        from kanedyn.numerics import weighted_hessians  # the Hessian's module too
        weighted_hessians(model, np.zeros(1), np.zeros((1, model.n_states)),
                          np.zeros((1, len(model.input_names))), np.zeros((1, model.n_states)))
    if solver == "interior-point":
        from kanedyn.optimization.interior_point import SparseKKT
        SparseKKT(1, 0, ([0], [0]), ([], []))  # its module built beforehand, as the
                                                # derivatives' above

    def solve():
        """``(result, timings)`` of one solve from ``guess``."""
        if solver == "interior-point":
            from kanedyn.optimization.interior_point import InteriorPoint
            chosen = InteriorPoint()
            result = problem.solve(guess, solver=chosen, hessian="exact",
                                   options=interior_point_options())
            return result, chosen.timings
        options, hessian = kanedyn_options()
        return problem.solve(guess, options=options, hessian=hessian), None
    result, timings = solve()  # derivatives built above
    total = time.perf_counter() - start

    def again():
        result, timings = solve()
        return result.wall_time, result.iterations, timings
    return dict(total=total, solve=result.wall_time, iterations=result.iterations,
                objective=result.objective, status=result.status, x=result.x,
                timings=timings, again=again)


def _phases(timings, iterations):
    """The interior-point solve's time per iteration by phase, ms."""
    per = {k: 1e3 * v / max(iterations, 1) for k, v in timings.items()}
    own = per["total"] - per["callbacks"] - per["hessian"] - per["factor_solve"]
    return (f"callbacks {per['callbacks']:.3f}, Hessian {per['hessian']:.3f}, factor and "
            f"solve {per['factor_solve']:.3f}, the rest {own:.3f} ms")


def run_opty(build, nodes, guess, ns, nr):
    start = time.perf_counter()
    problem = build(nodes)
    built = time.perf_counter()
    x, info, iterations = peers.solve_opty(problem, guess, ns, nr)
    end = time.perf_counter()

    def again():
        problem.obj_value.clear()  # opty appends each iteration's objective there
        begin = time.perf_counter()
        _, _, count = peers.solve_opty(problem, guess, ns, nr)
        return time.perf_counter() - begin, count, None
    return dict(total=end - start, solve=end - built, iterations=iterations,
                objective=float(info["obj_val"]), status=int(info["status"]), x=x,
                again=again)


def repeated(runs, rounds):
    """Per run (``{name: run}`` of :func:`run_kanedyn` / :func:`run_opty`): the
    least seconds per iteration over ``rounds`` more solves, the runs in
    turn, and the timings of that solve (``(per iteration, iterations,
    timings)``)."""
    best = {}
    for _ in range(rounds):
        for name, run in runs.items():
            seconds, iterations, timings = run["again"]()
            per = seconds / max(iterations, 1)
            if name not in best or per < best[name][0]:
                best[name] = (per, iterations, timings)
    return best


def compare(label, kanedyn_build, opty_build, nodes, guess, ns, nr):
    ours = {solver: run_kanedyn(kanedyn_build, nodes, guess, solver)
            for solver in SOLVERS["kanedyn"]}
    o = run_opty(opty_build, nodes, guess, ns, nr)
    print(f"{label} N = {nodes} (load {os.getloadavg()[0]:.1f})")
    names = {"ipopt": "kanedyn+IPOPT", "interior-point": "kanedyn+IP"}
    for name, r in [(names[s], r) for s, r in ours.items()] + [("opty+IPOPT", o)]:
        print(f"  {name:13s} model->optimum {r['total']:8.2f} s  solve {r['solve']:8.2f} s  "
              f"iterations {r['iterations']:5d}  per iteration "
              f"{1e3 * r['solve'] / max(r['iterations'], 1):7.2f} ms  objective "
              f"{r['objective']:.12g}  status {r['status']}")
        if r.get("timings"):
            print(f"  {'':13s} per iteration: {_phases(r['timings'], r['iterations'])}")
    per_o = o["solve"] / max(o["iterations"], 1)
    for solver, k in ours.items():
        rel = abs(k["objective"] - o["objective"]) / abs(o["objective"])
        print(f"  {names[solver]}: objectives differ from opty's by {rel:.1e} (relative); "
              f"solutions by {np.max(np.abs(k['x'] - o['x'])):.1e} at most")
        print(f"  opty / {names[solver]}: model->optimum {o['total'] / k['total']:.1f}x, "
              f"per iteration {per_o / (k['solve'] / max(k['iterations'], 1)):.2f}x")
    if REPEAT["solves"]:
        # the repeated solves time the optimized modules: builds whose quick
        # module's use did not pay for them during the first solve start now
        from kanedyn.numerics import finish_compiling
        finish_compiling()
        best = repeated({**{names[s]: r for s, r in ours.items()}, "opty+IPOPT": o},
                        REPEAT["solves"])
        print(f"  per iteration, least of {REPEAT['solves']} more solves each, in turn "
              f"(load {os.getloadavg()[0]:.1f}):")
        for name, (per, iterations, timings) in best.items():
            print(f"  {name:13s} {1e3 * per:7.3f} ms ({iterations} iterations)")
            if timings:
                print(f"  {'':13s} {_phases(timings, iterations)}")
        for name in best:
            if name != "opty+IPOPT":
                print(f"  opty / {name}: per iteration "
                      f"{best['opty+IPOPT'][0] / best[name][0]:.2f}x")
    return ours[SOLVERS["kanedyn"][0]], o


def double_pendulum_gallery(nodes):
    """opty's "Upright a double pendulum", 6 states, least time, as the gallery
    poses it; then each tool restarted from the other's optimum."""
    N = nodes
    guess = peers.double_pendulum_cart_guess(N)
    start = time.perf_counter()
    problem, _ = peers.double_pendulum_cart_kanedyn(N)
    k_build = time.perf_counter() - start
    ours = problem.solve(guess, options=peers.IPOPT_OPTIONS)
    k_total = time.perf_counter() - start
    start = time.perf_counter()
    opty_problem = peers.double_pendulum_cart_opty(N)
    built = time.perf_counter()
    for key, value in peers.IPOPT_OPTIONS.items():
        opty_problem.add_option(key, value)
    w, info = opty_problem.solve(peers.duration_to_opty(guess, N, 6, 1))
    o_total, o_solve = time.perf_counter() - start, time.perf_counter() - built
    o_iterations = len(opty_problem.obj_value) - 1
    print(f"double pendulum on a cart (opty's gallery, its guess), N = {N}")
    for name, total, solve, iterations, h, status in (
            ("kanedyn", k_total, ours.wall_time, ours.iterations, ours.objective,
             ours.status),
            ("opty", o_total, o_solve, o_iterations, float(info["obj_val"]),
             int(info["status"]))):
        print(f"  {name:8s} model->optimum {total:8.2f} s  solve {solve:8.2f} s  iterations "
              f"{iterations:5d}  per iteration {1e3 * solve / max(iterations, 1):7.2f} ms  "
              f"h {h:.10g} s (duration {h * (N - 1):.6g} s)  IPOPT status {status}")
    print(f"  opty / kanedyn: model->optimum {o_total / k_total:.2f}x, per iteration "
          f"{(o_solve / max(o_iterations, 1)) / (ours.wall_time / max(ours.iterations, 1)):.2f}x")
    # each from the other's optimum, IPOPT's "acceptable" stop turned off (it
    # ends least-time runs early): the same discrete problem has both optima
    strict = dict(peers.IPOPT_OPTIONS, acceptable_iter=0)
    theirs = peers.duration_from_opty(np.asarray(w), N, 6, 1)
    again = problem.solve(theirs, options=strict)
    opty_problem.add_option("acceptable_iter", 0)
    before = len(opty_problem.obj_value)  # opty appends to it across solves
    w2, info2 = opty_problem.solve(peers.duration_to_opty(ours.x, N, 6, 1))
    print(f"  kanedyn from opty's optimum (acceptable_iter=0): h {again.objective:.10g} "
          f"(opty's {float(info['obj_val']):.10g}, relative difference "
          f"{abs(again.objective / float(info['obj_val']) - 1):.1e}) in {again.iterations} "
          f"iterations, status {again.status}")
    print(f"  opty from kanedyn's point (acceptable_iter=0): h {float(info2['obj_val']):.10g} "
          f"(kanedyn's {ours.objective:.10g}), status {int(info2['status'])}, "
          f"{len(opty_problem.obj_value) - before - 1} iterations")
    ours_strict = problem.solve(guess, options=strict)
    print(f"  kanedyn from the gallery's guess (acceptable_iter=0): h "
          f"{ours_strict.objective:.10g} in {ours_strict.iterations} iterations "
          f"({ours_strict.wall_time:.1f} s), status {ours_strict.status}")
    if "interior-point" in SOLVERS["kanedyn"]:
        _gallery_interior_point(problem, guess, theirs, k_build, o_total, o_solve,
                                o_iterations, float(info["obj_val"]))


def _gallery_interior_point(problem, guess, theirs, build, o_total, o_solve, o_iterations,
                            o_h):
    """The gallery problem by kanedyn's interior point with its limited-memory
    Hessian, IPOPT's update (skipping pairs of negative curvature) and
    Powell's damped one: from the gallery's guess (the acceptable stop, then
    without it) and from opty's optimum ``theirs`` (as a start at an
    optimum is given to a monotone barrier: ``mu_init``, ``bound_push`` and
    ``bound_frac`` 1e-8, so that the first barrier problems do not pull the
    bang-bang force off its bounds).  Model -> optimum is the first build's
    time (``build``, the cold one, before IPOPT's solve) plus the solve."""
    N = problem.nodes
    for update in ("bfgs", "damped-bfgs"):
        options = dict(interior_point_options(), limited_memory_update_type=update)
        found = problem.solve(guess, solver="interior-point", options=options)
        per = found.wall_time / max(found.iterations, 1)
        total = build + found.wall_time
        print(f"  interior point, limited memory ({update}): model->optimum {total:6.2f} s  "
              f"solve {found.wall_time:6.2f} s  iterations {found.iterations:5d}  per "
              f"iteration {1e3 * per:6.2f} ms  h {found.objective:.10g} s (duration "
              f"{found.objective * (N - 1):.6g} s)  status {found.status}")
        print(f"    opty / interior point: model->optimum {o_total / total:.2f}x, per "
              f"iteration {(o_solve / max(o_iterations, 1)) / per:.2f}x; h "
              f"{abs(found.objective / o_h - 1):.1e} from opty's")
        strict = dict(options, acceptable_iter=0)
        at_optimum = dict(strict, mu_init=1e-8, bound_push=1e-8, bound_frac=1e-8)
        for name, start, chosen in (("the gallery's guess", guess, strict),
                                    ("opty's optimum, mu_init 1e-8", theirs, at_optimum)):
            again = problem.solve(start, solver="interior-point", options=chosen)
            print(f"    from {name} (acceptable_iter=0): h {again.objective:.10g} "
                  f"({abs(again.objective / o_h - 1):.1e} from opty's) in "
                  f"{again.iterations} iterations ({again.wall_time:.2f} s), status "
                  f"{again.status}")


# -------------------------------------------------- nodes against memory and time
_CHILD = """
import json, os, resource, sys, time
import numpy as np
sys.path.insert(0, {bench!r})
import _ocp_peers as peers
tool, nodes, path, extra = {tool!r}, {nodes}, {path!r}, {extra!r}
options = dict(peers.IPOPT_OPTIONS, **extra)
guess = peers.pendulum_interpolated(np.load(path), nodes)
start = time.perf_counter()
if tool == "kanedyn":
    problem, model = peers.pendulum_kanedyn(nodes)
    result = problem.solve(guess, options=options)
    out = dict(objective=result.objective, status=result.status,
               iterations=result.iterations, solve=result.wall_time)
elif tool == "kanedyn-ip":
    problem, model = peers.pendulum_kanedyn(nodes)
    result = problem.solve(guess, solver="interior-point", hessian="exact", options=dict(
        dict(tol=peers.IPOPT_OPTIONS["tol"], max_iter=peers.IPOPT_OPTIONS["max_iter"]),
        **extra))
    out = dict(objective=result.objective, status=result.status,
               iterations=result.iterations, solve=result.wall_time)
else:
    problem = peers.pendulum_opty(nodes)
    built = time.perf_counter()
    x, info, iterations = peers.solve_opty(problem, guess, 2, 1, options)
    out = dict(objective=float(info["obj_val"]), status=int(info["status"]),
               iterations=iterations, solve=time.perf_counter() - built)
out["total"] = time.perf_counter() - start
with open("/proc/self/status") as status:
    out.update({{k: int(v.split()[0]) / 2 ** 20 for k, v in
                (line.split(":", 1) for line in status) if k == "VmPeak"}})
print("RESULT " + json.dumps(out))
"""

#: who runs in the scan: label -> (tool, IPOPT options over ``IPOPT_OPTIONS``).
#: Each as its user runs it (kanedyn with its own defaults, among them
#: ``mumps_mem_percent = 100``; opty with IPOPT's 1000 %), and each with the
#: other's MUMPS workspace, to tell the option's part of a difference
CONTENDERS = {
    "kanedyn": ("kanedyn", {}),
    "kanedyn, mumps_mem_percent=1000": ("kanedyn", {"mumps_mem_percent": 1000}),
    "opty": ("opty", {}),
    "opty, mumps_mem_percent=100": ("opty", {"mumps_mem_percent": 100}),
    "kanedyn, interior-point": ("kanedyn-ip", {}),
    "kanedyn, interior-point, sparse": ("kanedyn-ip", {"linear_solver": "sparse"}),
    "kanedyn, interior-point, NumPy's allocator": ("kanedyn-ip", {"large_arrays": "numpy"}),
}


def _limit_memory(cap_gib):
    if not cap_gib:
        return None
    limit = int(cap_gib * 2 ** 30)

    def apply():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    return apply


def scan(nodes_list, memory_gib, time_s, address_cap=0.0, max_iter=0, budgets=(1.0, 2.0),
         contenders=tuple(CONTENDERS)):
    """The pendulum swing-up at growing node counts, each run in a fresh
    process; then, per memory budget, the most nodes each contender ran within
    it (peak resident memory and peak address space)."""
    tmp = Path(tempfile.mkdtemp(prefix="kd-bench-ocp-scan-"))
    np.save(tmp / "guess.npy", peers.pendulum_gallery_optimum())
    env = dict(os.environ)
    extra = {"max_iter": max_iter} if max_iter else {}
    print(f"nodes against memory and time: pendulum swing-up, budgets {memory_gib:g} GiB "
          f"peak resident memory, {time_s:g} s model->optimum; each run a fresh process "
          + (f"(address space capped at {address_cap:g} GiB)" if address_cap
             else "(address space not capped)")
          + (f"; at most {max_iter} iterations, the peaks over those" if max_iter else ""))
    print(f"  {'contender':34s} {'nodes':>8s} {'peak GiB':>9s} {'VmPeak':>7s} {'wall s':>8s} "
          f"{'solve s':>8s} {'iter':>5s} {'status':>6s}  objective  (load)")
    rows = []
    for label in contenders:
        tool, options = CONTENDERS[label]
        for nodes in nodes_list:
            row = _measured(tool, nodes, tmp / "guess.npy", time_s, env, address_cap,
                            dict(options, **extra))
            row["label"] = label
            rows.append(row)
            print(f"  {label:34s} {nodes:8d} {row['peak_gib']:9.3f} "
                  f"{row.get('VmPeak', float('nan')):7.3f} {row['wall']:8.1f} "
                  f"{row.get('solve', float('nan')):8.1f} {row.get('iterations', -1):5d} "
                  f"{row.get('status', -999):6d}  {row.get('objective', float('nan')):.10g}"
                  f"  ({os.getloadavg()[0]:.1f})"
                  + (f"  FAILED: {row['failed']}" if "failed" in row else ""), flush=True)
            solved = (0, 1, -1) if max_iter else (0, 1)
            if ("failed" in row or row["peak_gib"] > memory_gib or row["wall"] > time_s
                    or row.get("status") not in solved):
                print(f"  {label}: out of budget (or not solved) at {nodes} nodes")
                break
    _within_budgets(rows, budgets, contenders)


def _within_budgets(rows, budgets, contenders):
    """Per budget (GiB) and contender, the most nodes of a run that ended
    without failing and stayed within it, by peak resident memory and by
    peak address space (``VmPeak``: what a cap such as ``ulimit -v``
    counts); the node count where the line through the two largest runs
    reaches the budget (memory grows linearly in the nodes here); and
    kanedyn's counts over opty's."""
    print("  nodes within a memory budget, resident / address space: the most run within "
          "it; in brackets where the line through the two largest runs reaches it")
    most = {}
    for budget in budgets:
        for label in contenders:
            ok = sorted((r for r in rows if r["label"] == label and "failed" not in r),
                        key=lambda r: r["nodes"])
            counts = []
            for key in ("peak_gib", "VmPeak"):
                run = max((r["nodes"] for r in ok if r.get(key, np.inf) <= budget), default=0)
                line = np.nan
                if len(ok) >= 2:
                    (n0, m0), (n1, m1) = [(r["nodes"], r.get(key, np.nan)) for r in ok[-2:]]
                    if m1 > m0:  # else the memory did not grow: no line
                        line = n0 + (budget - m0) * (n1 - n0) / (m1 - m0)
                counts.append((run, line))
            most[budget, label] = counts
            print(f"    {budget:g} GiB  {label:34s} " + " / ".join(
                f"{run:8d} [{line:9.0f}]" if np.isfinite(line) else f"{run:8d} [  no line]"
                for run, line in counts))
        for ours in ("kanedyn", "kanedyn, interior-point", "kanedyn, interior-point, sparse"):
            if {ours, "opty"} <= set(contenders):
                k, o = most[budget, ours], most[budget, "opty"]
                ratio = [f"{a[1] / b[1]:.2f}x" if np.isfinite(a[1] / b[1]) else "n/a"
                         for a, b in zip(k, o)]
                print(f"    {budget:g} GiB  {ours} / opty by the lines: {ratio[0]} resident, "
                      f"{ratio[1]} address space (goal: 10x)")


def _measured(tool, nodes, guess_path, time_s, env, address_cap, options):
    """The child's run with its own peak resident memory, read by
    ``os.wait4`` on the process (``ru_maxrss``, KiB on Linux), and its peak
    address space (``VmPeak``, which the child reports)."""
    code = _CHILD.format(bench=str(Path(__file__).resolve().parent), tool=tool,
                         nodes=nodes, path=str(guess_path), extra=options)
    start = time.perf_counter()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen([sys.executable, "-c", code], stdout=out, stderr=err,
                                text=True, env=env,
                                preexec_fn=_limit_memory(address_cap))
        deadline = start + time_s
        killed = False
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() > deadline:
                proc.send_signal(signal.SIGKILL)
                killed = True
                pid, status, usage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.05)
        proc.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - start
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    row = dict(tool=tool, nodes=nodes, wall=wall, peak_gib=usage.ru_maxrss / 2 ** 20)
    line = next((x for x in stdout.splitlines() if x.startswith("RESULT ")), None)
    if line:
        row.update(json.loads(line[7:]))
    if killed:
        row["failed"] = f"killed at the time budget ({time_s:g} s)"
    elif line is None:
        tail = (stderr.strip().splitlines() or ["no output"])[-1]
        row["failed"] = f"exit {proc.returncode}: {tail[:160]}"
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="*", default=[100, 1000, 10000])
    parser.add_argument("--cart-pole", type=int, nargs="*", default=[100])
    parser.add_argument("--gallery", type=int, nargs="*", default=[],
                        help="opty's double pendulum on a cart at these node counts "
                             "(the gallery's: 300)")
    parser.add_argument("--hessian", choices=("limited-memory", "exact"),
                        default="limited-memory",
                        help="kanedyn's Hessian of the Lagrangian (opty: limited-memory)")
    parser.add_argument("--solvers", nargs="+", choices=("ipopt", "interior-point"),
                        default=["ipopt"], help="kanedyn's NLP solvers compared with opty")
    parser.add_argument("--linear-solver", choices=("auto", "sparse", "envelope", "dense"),
                        default="auto",
                        help="the interior-point solver's factorization")
    parser.add_argument("--method", choices=("backward-euler", "midpoint"),
                        default="backward-euler",
                        help="the pendulum's collocation for both tools (not the scan's): "
                             "backward Euler is opty's default; at 100 and 200 nodes the "
                             "swing-up is infeasible with it, and with the midpoint rule not")
    parser.add_argument("--repeat", type=int, default=0,
                        help="solve each built problem this many more times, the tools in "
                             "turn, and print the least time per iteration")
    parser.add_argument("--scan", action="store_true",
                        help="nodes against memory and time, one process per run")
    parser.add_argument("--scan-nodes", type=int, nargs="*",
                        default=[1000, 3000, 10000, 30000, 100000, 300000, 1000000])
    parser.add_argument("--memory-budget", type=float, default=4.0, help="GiB")
    parser.add_argument("--time-budget", type=float, default=600.0, help="s")
    parser.add_argument("--address-cap", type=float, default=0.0,
                        help="GiB of address space per child (0: no cap)")
    parser.add_argument("--scan-max-iter", type=int, default=0,
                        help="IPOPT's max_iter in the scan (0: to convergence)")
    parser.add_argument("--budgets", type=float, nargs="*", default=[1.0, 2.0],
                        help="GiB: the most nodes within each, printed after the scan")
    parser.add_argument("--contenders", nargs="*", default=list(CONTENDERS)[:4],
                        choices=list(CONTENDERS))
    args = parser.parse_args()
    HESSIAN["kind"] = args.hessian
    SOLVERS["kanedyn"] = args.solvers
    SOLVERS["linear_solver"] = args.linear_solver
    REPEAT["solves"] = args.repeat
    pendulum_kanedyn = functools.partial(peers.pendulum_kanedyn, method=args.method)
    pendulum_opty = functools.partial(peers.pendulum_opty, method=args.method)
    os.environ.setdefault("KANEDYN_CACHE_DIR", tempfile.mkdtemp(prefix="kd-bench-ocp-"))
    import cyipopt
    import opty
    print(f"kanedyn's Hessian: {args.hessian}; the pendulum's collocation: {args.method}; "
          f"load average {os.getloadavg()[0]:.1f}")
    print(f"opty {opty.__version__}, cyipopt {cyipopt.__version__} (IPOPT "
          f"{'.'.join(map(str, cyipopt.IPOPT_VERSION))}), kanedyn cache "
          f"{os.environ['KANEDYN_CACHE_DIR']}")
    if not args.nodes:
        for nodes in args.cart_pole:
            compare("cart-pole swing-up", peers.cart_pole_kanedyn, peers.cart_pole_opty,
                    nodes, peers.cart_pole_guess(nodes), 4, 1)
        for nodes in args.gallery:
            double_pendulum_gallery(nodes)
        if args.scan:
            scan(args.scan_nodes, args.memory_budget, args.time_budget, args.address_cap,
                 args.scan_max_iter, args.budgets, args.contenders)
        return
    # opty's gallery problem as published: 501 nodes from its random guess
    gallery = peers.GALLERY_NODES
    k, _ = compare("pendulum swing-up (opty's gallery: random guess)", pendulum_kanedyn,
                   pendulum_opty, gallery, np.random.default_rng(0).normal(
                       size=3 * gallery), 2, 1)
    # the other sizes from that solution, interpolated (the random guess fails
    # for both at 100 nodes)
    for nodes in args.nodes:
        guess = peers.pendulum_interpolated(k["x"], nodes)
        compare("pendulum swing-up (guess: the 501-node optimum interpolated)",
                pendulum_kanedyn, pendulum_opty, nodes, guess, 2, 1)
    for nodes in args.cart_pole:
        compare("cart-pole swing-up", peers.cart_pole_kanedyn, peers.cart_pole_opty, nodes,
                peers.cart_pole_guess(nodes), 4, 1)
    for nodes in args.gallery:
        double_pendulum_gallery(nodes)
    if args.scan:
        scan(args.scan_nodes, args.memory_budget, args.time_budget, args.address_cap,
             args.scan_max_iter, args.budgets, args.contenders)


if __name__ == "__main__":
    main()
