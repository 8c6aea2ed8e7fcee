"""The exact Hessian of the Lagrangian against IPOPT's limited-memory one on
the problems it reaches beyond a fixed duration: a free duration, a path
constraint, a free parameter, instance constraints, Hermite-Simpson and LGR,
two phases.

Each problem is solved from the same guess with both Hessians (kanedyn
alone, NumPy backend, ``tol = 1e-12``), twice, interleaved; printed: the
objectives and their relative difference, the iterations, the solve's wall
time (``result.wall_time``), and the load average.  The first exact solve of
a model includes generating its second derivatives' code (NumPy, kept by the
model), so the second run of each is the one to compare.

Usage::

    python benchmarks/bench_exact_hessian_kinds.py [--runs 2]
"""

from __future__ import annotations

import argparse
import os

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

TIGHT = {"tol": 1e-12, "max_iter": 1000}


def _pendulum():
    definition = kd.models.build("pendulum", torque=True)
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    return definition.numeric(backend="numpy"), (q, u, tau)


def _cart(masses):
    """A cart pushed by F(t) carrying particles of ``masses`` (kg)."""
    x, v, F = me.dynamicsymbols("x v F")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, v * N.x)
    symbols = sm.symbols(f"m0:{len(masses)}")
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v],
                  bodies=[me.Particle(f"body{k}", P, m) for k, m in enumerate(symbols)],
                  loads=[(P, F * N.x)])
    return eom.numeric(constants=dict(zip(symbols, masses)), specified={F: 0.0},
                       backend="numpy"), (x, v, F)


def problems():
    """``[(label, problem, guess)]``."""
    model, (q, u, tau) = _pendulum()
    T, m = sm.Symbol("T"), sm.Symbol("m")
    out = []
    for method in ("trapezoid", "hermite-simpson"):
        pb = kd.OptimalControlProblem(
            model, nodes=31, duration=T, mayer=T, lagrange=1e-2 * tau ** 2,
            bounds={tau: (-8, 8), T: (0.2, 10)}, initial={q: 0, u: 0},
            final={q: np.pi, u: 0}, method=method)
        out.append((f"pendulum least time, {method}, 31", pb,
                    pb.guess_line(inputs={tau: 0.0}, duration=2.0)))
    pb = kd.OptimalControlProblem(
        model, nodes=31, duration=3.0, lagrange=tau ** 2,
        path_constraints=[(u ** 2 + 0.1 * tau * u, 0, 9.0)], bounds={tau: (-8, 8)},
        initial={q: 0, u: 0}, final={q: np.pi, u: 0}, method="trapezoid")
    out.append(("swing-up, path constraint, trapezoid, 31", pb,
                pb.guess_line(inputs={tau: 0.0})))
    pb = kd.OptimalControlProblem(
        model, nodes=11, duration=3.0, lagrange=tau ** 2 + 0.1 * (m - 1) ** 2, parameters=[m],
        bounds={tau: (-8, 8), m: (0.5, 2)}, initial={q: 0, u: 0}, final={q: np.pi, u: 0},
        method="lgr")
    out.append(("swing-up, free mass, LGR 3, 11", pb, pb.guess_line(inputs={tau: 0.0})))
    pb = kd.OptimalControlProblem(
        model, nodes=31, duration=3.0, lagrange=tau ** 2,
        instance_constraints=[sm.cos(q.func(3.0)) + 1, u.func(3.0), q.func(0),
                              u.func(0) ** 2 + u.func(0)],
        bounds={tau: (-5, 5), q: (-1, 4)}, method="hermite-simpson")
    out.append(("swing-up, instance constraints, Hermite-Simpson, 31", pb,
                pb.guess_line(start={q: 0, u: 0}, end={q: np.pi, u: 0}, inputs={tau: 0.0})))
    loaded, (x, v, F) = _cart([1.0, 1.0])
    alone, _ = _cart([1.0])
    T1, T2 = sm.symbols("T1 T2")
    first = kd.OptimalControlProblem(
        loaded, nodes=21, duration=T1, mayer=T1 + 1e-2 * v ** 2, lagrange=1e-2 * F ** 2,
        bounds={F: (-1, 1), T1: (0.5, 3)}, initial={x: 0, v: 0}, final={x: 0.5},
        method="hermite-simpson")
    second = kd.OptimalControlProblem(
        alone, nodes=21, duration=T2, mayer=T2, lagrange=1e-2 * F ** 2,
        bounds={F: (-1, 1), T2: (0.5, 3)}, final={x: 1, v: 0}, method="hermite-simpson")
    out.append(("payload released, least time, 2 phases, Hermite-Simpson, 21+21",
                kd.MultiphaseProblem([first, second]),
                [first.guess_line(end={v: 0.7}, inputs={F: 1.0}, duration=1.5),
                 second.guess_line(start={x: 0.5, v: 0.7}, inputs={F: 0.0}, duration=1.0)]))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=2)
    args = parser.parse_args()
    print(f"load average at start: {os.getloadavg()[0]:.1f}")
    for label, problem, guess in problems():
        print(label)
        for run in range(args.runs):
            found = {}
            for hessian in ("limited-memory", "exact"):
                r = problem.solve(guess, options=TIGHT, hessian=hessian)
                found[hessian] = r
                print(f"  run {run + 1} {hessian:15s} success {r.success!s:5s} objective "
                      f"{r.objective:.12g}  iterations {r.iterations:4d}  solve "
                      f"{r.wall_time:6.2f} s")
            a, b = found["limited-memory"], found["exact"]
            print(f"  run {run + 1} objectives differ by "
                  f"{abs(a.objective - b.objective) / abs(a.objective):.1e} (relative); "
                  f"load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
