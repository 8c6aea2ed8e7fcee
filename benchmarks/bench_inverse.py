"""Inverse dynamics per point: kanedyn vs Pinocchio's ``rnea``, same run.

The spatial chain ``chain3d`` (n = 5, 10, 30 links; the same chain in
Pinocchio's terms from :func:`_peers.pinocchio_chain`) at random states and
accelerations. Measured:

- kanedyn's compiled ``model.inverse_dynamics(t, q, u, udot)`` called for one
  point from Python (backend ``"c"``);
- the same function given a 1,000-point trajectory in one call, per point;
- ``pinocchio.rnea(model, data, q, v, a)`` for one point;
- the largest difference between the two, N m.

Then the Stewart platform (``stewart-platform``, 6 independent and 18
dependent coordinates) along a 1,000-point quintic rest-to-rest pose
trajectory, compiled (C): the inverse kinematics in closed form (leg angles
and lengths from :func:`kanedyn.models.stewart_leg_lengths`' geometry,
vectorized over the trajectory) plus ``model.inverse_dynamics`` (dependent
speeds and rates from the constraints), against the same forces obtained
through the forward equations (reduced mass matrix and forcing at every point,
``tau = M[:p] u' - f[:p]`` with the dependent rates from the acceleration
constraint rows). Every contender is timed interleaved in rounds
(:func:`_timing.interleaved`, thread CPU time); minimum, spread
(median / min - 1) and a winner only where the ranges [min, median] do not
overlap (:func:`_timing.winner`) are printed.

Ratios are between numbers measured in this run (design rule 15).

Usage::

    python benchmarks/bench_inverse.py [--sizes 5 10 30] [--rounds 7] [--quick]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import kanedyn as kd  # noqa: E402
from _peers import DEFAULTS, pinocchio_chain  # noqa: E402
from _timing import interleaved, optimized_modules_only, winner  # noqa: E402
from bench_numerics import machine_info  # noqa: E402


def measure(n, points=1000, rounds=7, min_time=0.2):
    """``{name: Timing}`` per point (s) and the largest difference for the n-link chain.

    The three ways (``"one"``: one point per call, ``"batch"``: per point of a
    ``points``-point call, ``"rnea"``) are timed interleaved in ``rounds``
    rounds (:func:`_timing.interleaved`, thread CPU time).
    """
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
    times = interleaved({"one": lambda: model.inverse_dynamics(0.0, q0, u0, a0),
                         "batch": lambda: model.inverse_dynamics(t, q, u, udot),
                         "rnea": lambda: pin.rnea(pmodel, pdata, q0, u0, a0)},
                        rounds=rounds, min_time=min_time)
    times["batch"].times = [x / points for x in times["batch"].times]
    return times, float(np.max(np.abs(tau - ref)))


def stewart_closed_form(P):
    """All coordinates (24, k) of the Stewart platform at poses ``P`` (k, 6)."""
    from kanedyn.models import stewart_anchors
    A, c = stewart_anchors()
    a, b, g = P[:, 3], P[:, 4], P[:, 5]
    ca, sa, cb, sb, cg, sg = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(g), np.sin(g)
    R = np.stack([np.stack([cb * cg, -cb * sg, sb], -1),
                  np.stack([sa * sb * cg + ca * sg, -sa * sb * sg + ca * cg, -sa * cb], -1),
                  np.stack([-ca * sb * cg + sa * sg, ca * sb * sg + sa * cg, ca * cb], -1)],
                 -2)  # body-fixed X-Y-Z, as the model
    tips = P[:, None, :3] + np.einsum("kij,lj->kli", R, c) - A
    s = np.linalg.norm(tips, axis=-1)
    e = tips / s[..., None]
    return np.hstack([P, np.arctan2(-e[..., 1], e[..., 2]), np.arcsin(e[..., 0]), s]).T


def stewart(points=1000, rounds=7):
    """``{name: Timing}`` (thread CPU s per trajectory) of the two ways, largest difference."""
    definition = kd.models.build("stewart-platform")
    model = definition.numeric(backend="c")
    t = np.linspace(0.0, 2.0, points)
    P, V, A = kd.models.quintic_pose(t, [0, 0, 0.4, 0, 0, 0],
                                     [0.05, -0.03, 0.45, 0.1, -0.05, 0.2], 2.0)
    p = model.n_u_ind

    def inverse():
        return model.inverse_dynamics(t, stewart_closed_form(P), V.T, A.T)

    def forward():
        Q = stewart_closed_form(P)
        out = np.empty((p, points))
        y = np.zeros(model.n_states)
        for i in range(points):
            y[:model.n_q] = Q[:, i]
            y[model.n_q:] = 0.0
            y[model.n_q:model.n_q + p] = V[i]
            y = model.consistent_state(t[i], y)
            M, f = model.mass_matrix(t[i], y), model.forcing(t[i], y)
            ud = np.zeros(model.n_u)
            ud[:p] = A[i]
            ud[p:] = np.linalg.solve(M[p:, p:], f[p:] - M[p:, :p] @ ud[:p])
            out[:, i] = M[:p] @ ud - f[:p]
        return out

    diff = float(np.max(np.abs(inverse() - forward())))
    times = interleaved({"inverse": inverse, "forward": forward}, rounds=rounds,
                        min_time=0)
    return times, diff


def main(argv=None):
    optimized_modules_only()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[5, 10, 30])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--quick", action="store_true",
                        help="n = 5 only, 3 rounds of 0.05 s (a smoke run)")
    args = parser.parse_args(argv)
    min_time = 0.2
    if args.quick:
        args.sizes, args.rounds, min_time = [5], 3, 0.05
    print(machine_info())
    print("thread CPU time per point, minimum over interleaved rounds (spread = "
          "median / min - 1)")
    print(f"{'n':>3}  {'kanedyn C, 1 point':>24}  {'per point of 1,000':>24}  "
          f"{'pinocchio rnea':>22}  {'kanedyn / rnea':>14}  {'winner (1 point)':>22}  "
          f"{'max |diff| N m':>14}")
    for n in args.sizes:
        times, diff = measure(n, rounds=args.rounds, min_time=min_time)
        one, batch, peer = times["one"], times["batch"], times["rnea"]
        one.name = "kanedyn"
        clear = winner([one, peer]) or "none (spreads overlap)"
        print(f"{n:3d}  {one.best * 1e6:11.2f} us ({one.spread:4.0%})  "
              f"{batch.best * 1e6:11.2f} us ({batch.spread:4.0%})  "
              f"{peer.best * 1e6:9.2f} us ({peer.spread:4.0%})  "
              f"{one.best / peer.best:14.2f}  {clear:>22}  {diff:14.1e}", flush=True)
    times, diff = stewart(rounds=args.rounds)
    print("\nStewart platform, 1,000-point quintic pose trajectory, C, closed-form IK "
          "included (thread CPU time, min and spread over interleaved rounds):")
    for name, label in (("inverse", "inverse_dynamics"),
                        ("forward", "forward equations (M, f per point)")):
        v = times[name]
        print(f"  {label:36s} {v.best * 1e3:8.1f} ms  (spread {v.spread:.0%})")
    print(f"  ratio forward / inverse {times['forward'].best / times['inverse'].best:.1f}, "
          f"winner: {winner(times) or 'none (spreads overlap)'}, "
          f"max |difference| {diff:.1e} (N or N m)")


if __name__ == "__main__":
    main()
