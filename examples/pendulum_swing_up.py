"""Swing a pendulum up with the least torque: optimal control by direct collocation.

What it shows: ``kd.OptimalControlProblem`` on the built-in pendulum driven
by a torque at its pivot (``kd.models.build("pendulum", torque=True)``):
from hanging at rest to upright at rest in 10 s, the torque limited to
2 N m, minimizing the integral of the torque squared (opty's gallery
problem).  The problem is first solved on 101 nodes from a guess that
rotates the pendulum steadily, then on 401 nodes from that solution; the
optimal torque is then simulated with ``kd.simulate`` and the simulated
states are compared with the collocated ones: they agree while the pendulum
swings, and part once it nears the top, where it is unstable (an open-loop
torque replays the optimum only as well as the collocation's error, which
the instability amplifies).  The figure shows the angle,
the rate and the torque with its limits.

Run it::

    python examples/pendulum_swing_up.py                 # writes pendulum_swing_up.png
    python examples/pendulum_swing_up.py --plot swing.png --nodes 801
"""

import argparse

import numpy as np

import kanedyn as kd

DURATION, LIMIT = 10.0, 2.0       # s, N m


def solve(nodes):
    """The swing-up on ``nodes`` nodes (trapezoid), from a coarse solution."""
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend="c")          # m = 1 kg, l = 1 m, g = 9.81 m/s^2
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))

    def problem(n):
        return kd.OptimalControlProblem(
            model, nodes=n, duration=DURATION, lagrange=tau ** 2,
            bounds={tau: (-LIMIT, LIMIT)}, initial={q: 0.0, u: 0.0},
            final={q: np.pi, u: 0.0}, method="trapezoid")

    coarse = problem(101)
    # a guess: turn steadily to the top, pushing gently back and forth
    guess = coarse.guess_line(start={u: np.pi / DURATION}, end={u: np.pi / DURATION},
                              inputs={tau: lambda t: np.sin(2 * np.pi * t / DURATION)})
    first = coarse.solve(guess)
    print(f"101 nodes: {first.message}")
    fine = problem(nodes)
    return fine.solve(first)                         # interpolated onto the finer grid


def plot(result, path):
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(3, 1, sharex=True, figsize=(7, 7), constrained_layout=True)
    axes[0].plot(result.t, result["q"], label="angle q")
    axes[0].axhline(np.pi, color="0.6", ls="--", lw=0.8, label="upright (pi)")
    axes[0].set_ylabel("q [rad]")
    axes[1].plot(result.t, result["u"], label="rate u")
    axes[1].set_ylabel("u [rad/s]")
    axes[2].plot(result.t, result["tau"], label="torque tau")
    for bound, label in ((-LIMIT, f"limits +-{LIMIT:g} N m"), (LIMIT, None)):
        axes[2].axhline(bound, color="0.6", ls="--", lw=0.8, label=label)
    axes[2].set_ylabel("tau [N m]")
    axes[2].set_ylim(-1.5 * LIMIT, 1.6 * LIMIT)  # room for the legend above the limits
    axes[2].set_xlabel("t [s]")
    for ax in axes:
        ax.legend(loc="upper right" if ax is axes[2] else "upper left", fontsize=8)
        ax.grid(alpha=0.3)
    figure.suptitle(f"Pendulum swing-up of least integral of torque^2\n{result.t.size} "
                    f"nodes, {result.method}: objective {result.objective:.4f} N^2 m^2 s",
                    fontsize=11)
    figure.savefig(path, dpi=110)
    return path


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=401)
    parser.add_argument("--plot", default="pendulum_swing_up.png")
    args = parser.parse_args(argv)
    result = solve(args.nodes)
    print(f"{args.nodes} nodes: {result.message}")
    print(f"objective {result.objective:.6f} N^2 m^2 s, largest constraint violation "
          f"{result.constraint_violation:.1e}, {result.iterations} iterations in "
          f"{result.wall_time:.2f} s")
    check = result.resimulate()
    run = check.simulation
    units = result.problem.model.state_units                # q: rad, u: rad/s
    difference = np.abs(run.y - result.y[:, :run.t.size])   # per state, at the nodes
    early = run.t <= 5.0

    def per_state(values):
        return ", ".join(f"{name} {value:.1e} {units[name]}"
                         for name, value in zip(result.state_names, values))
    angle = difference[result.state_names.index("q")]
    apart = np.flatnonzero(angle > 0.1)                      # rad
    print(f"the optimal torque simulated stays within "
          f"{per_state(np.max(difference[:, early], axis=1))} of the collocated states over "
          f"the first 5 s; largest difference {per_state(check.defect.values())}")
    if apart.size:
        k = apart[0]
        print(f"its angle is more than 0.1 rad from the collocated one from t = {run.t[k]:.2f} s, "
              f"where the collocated angle is {result['q'][k]:.3f} rad (upright: pi): there the "
              "pendulum is unstable and an open-loop torque cannot hold it")
    print(f"figure: {plot(result, args.plot)}")
    return {"t": result.t, "q": result["q"], "u": result["u"], "tau": result["tau"],
            "objective": result.objective, "success": result.success}


if __name__ == "__main__":
    main()
