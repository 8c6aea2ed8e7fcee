"""Stiff runs with the exact Jacobian against solve_ivp's finite differences, same run.

``kd.simulate(..., method=M, jac="exact")`` (the default for Radau, BDF and
LSODA where the model has exact derivatives) against ``jac="differences"``
(solve_ivp differences the right-hand side, one evaluation per state), on:

- a stiff spring chain written as users write it (``kd.kane``: 30 particles on
  a line, springs of 1e6 N/m and dampers of 10 N s/m between them, the first
  one tied to the ground, pulled by a constant force on the last);
- the spin-up beam and the flexible robot (built-in flexible models);
- the OC3 spar (built-in, its catenary mooring).

With ``--loop``, the same runs in the compiled integration loop (C backend,
``method="Rosenbrock23"``, which evaluates a Jacobian at every step): the
derivative module's exact Jacobian against the loop's forward differences.

Measured: CPU time of the run (process time, the minimum of ``--rounds``
interleaved rounds), the right-hand-side evaluations (counted by wrapping
``model.rhs``, solve_ivp's ``nfev`` leaves out those of its differences; the
compiled loop counts its own), the Jacobians evaluated, and the largest
difference between the two end states.

Usage::

    python benchmarks/bench_stiff_jacobians.py [--rounds 3] [--backend numpy] [--loop]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

sys.path.insert(0, str(Path(__file__).resolve().parent))

import kanedyn as kd  # noqa: E402
from bench_numerics import machine_info  # noqa: E402


def spring_chain(n=30, stiffness=1e6, damping=10.0, backend="numpy"):
    """The chain of ``n`` particles, its model and initial state (at rest)."""
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    k, c, F = sm.symbols("k c F")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    points, loads = [], []
    for i in range(n):
        P = O.locatenew(f"P{i + 1}", q[i] * N.x)
        P.set_vel(N, u[i] * N.x)
        points.append(P)
    for i in range(n):
        stretch = q[i] - (q[i - 1] if i else 0)
        rate = u[i] - (u[i - 1] if i else 0)
        tension = -k * stretch - c * rate
        loads.append((points[i], tension * N.x))
        if i:
            loads.append((points[i - 1], -tension * N.x))
    loads.append((points[-1], F * N.x))
    eom = kd.kane(frame=N, q_ind=q, u_ind=u, kd_eqs=[a.diff() - b for a, b in zip(q, u)],
                  bodies=[me.Particle(f"p{i + 1}", points[i], 1.0) for i in range(n)],
                  loads=loads)
    model = eom.numeric(constants={k: stiffness, c: damping, F: 100.0}, backend=backend)
    return model, np.zeros(2 * n)


def cases(backend, loop=False):
    """``(title, model, y0, method, t_end)`` of each run (``loop``: every run
    with the compiled Rosenbrock23 loop)."""
    model, y0 = spring_chain(backend=backend)
    runs = [("spring chain n = 30", model, y0, "BDF", 1.0)]
    for name, method, t_end in [("spin-up-beam", "Radau", 5.0),
                                ("flexible-robot", "BDF", 1.0),
                                ("oc3-spar", "BDF", 60.0)]:
        definition = kd.models.build(name)
        model = definition.numeric(backend=backend)
        runs.append((name, model, definition.initial(model), method, t_end))
    for name, model, y0, method, t_end in runs:
        method = "Rosenbrock23" if loop else method
        yield f"{name}, {method}, {t_end:g} s", model, y0, method, t_end


class Counted:
    """``model.rhs`` wrapped to count its calls."""

    def __init__(self, model):
        self.model, self.calls = model, 0
        self.rhs = model.rhs

    def __enter__(self):
        def counting(t, y):
            self.calls += 1
            return self.rhs(t, y)
        self.model.rhs = counting
        return self

    def __exit__(self, *exc):
        self.model.rhs = self.rhs


def run(model, y0, method, t_end, jac):
    with Counted(model) as counter:
        start = time.process_time()
        result = kd.simulate(model, (0.0, t_end), y0, method=method, jac=jac,
                             rtol=1e-6, atol=1e-8)
        cpu = time.process_time() - start
    # the compiled loop calls the right-hand side in C: its own count
    return cpu, result.nfev if method == "Rosenbrock23" else counter.calls, result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--backend", default="numpy")
    parser.add_argument("--loop", action="store_true",
                        help="the compiled Rosenbrock23 loop (C backend)")
    args = parser.parse_args()
    backend = "c" if args.loop else args.backend
    print(machine_info())
    print("\n| run | Jacobian | CPU, s | rhs evaluations | Jacobians | CPU differences / "
          "exact | end states differ by |")
    print("|---|---|---|---|---|---|---|")
    for title, model, y0, method, t_end in cases(backend, args.loop):
        run(model, y0, method, min(t_end, 1e-3), "exact")  # generates the derivative code
        best = {}
        for _ in range(args.rounds):
            for jac in ("exact", "differences"):
                found = run(model, y0, method, t_end, jac)
                if jac not in best or found[0] < best[jac][0]:
                    best[jac] = found
        gap = np.max(np.abs(best["exact"][2].y[:, -1] - best["differences"][2].y[:, -1]))
        for jac in ("differences", "exact"):
            cpu, calls, result = best[jac]
            ratio = f"{best['differences'][0] / best['exact'][0]:.2f}" if jac == "exact" else ""
            print(f"| {title} | {jac} | {cpu:.3f} | {calls} | {result.njev} | {ratio} | "
                  f"{gap:.1e} |" + ("" if result.success else f" ({result.message})"))


if __name__ == "__main__":
    main()
