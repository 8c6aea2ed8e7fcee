"""Move a parallel manipulator's platform with the least peak screw force: a min-max by epigraph.

What it shows: a min-max objective in ``kd.OptimalControlProblem`` through an
auxiliary variable.  The built-in out-parallel manipulator driven by its six
carriage forces (``kd.models.build("out-parallel-6dof", force_input=True)``:
a closed loop, 12 independent states of 48, the ball screws' reflected
inertia included) moves its platform between the two poses of today's
quintic (``kanedyn.analysis.inverse_study``: 5 cm and 10 degrees in every axis) in
the same time.  The peak force is the auxiliary variable s, minimized with
the path constraints -s <= F_i(t) <= s at every node and midpoint, the forces
within the drives' limit; the platform is held still before and after, so s
is at least the largest static force in the two poses.  The inverse dynamics
of the optimal path (``inverse_study`` of the collocated poses as a
``kanedyn.analysis.PoseTable``) gives the forces back.  The figure: the carriage
forces, optimal against the quintic.  ``kanedyn optimize out-parallel-6dof``
runs the same study with more checks.

Run it::

    python examples/out_parallel_least_peak_force.py                 # 2 s, 41 nodes
    python examples/out_parallel_least_peak_force.py --duration 1 --plot platform.png
"""

import argparse

import numpy as np
import sympy as sm
from scipy.interpolate import CubicSpline

import kanedyn as kd
from kanedyn.analysis import PoseTable, inverse_study

LIMIT = 200.0                         # N, the ball screws' force limit (assumed rating)
POSE = ("x", "y", "z", "phi_x", "phi_y", "phi_z")
RATES = ("vx", "vy", "vz", "wx", "wy", "wz")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=2.0, help="s")
    parser.add_argument("--nodes", type=int, default=41)
    parser.add_argument("--plot", default="out_parallel_least_peak_force.png")
    args = parser.parse_args(argv)
    T = args.duration

    # today's quintic and its forces; at its ends the platform is at rest.  The
    # inverse model is built once, for the quintic and for the check below (each
    # study would derive it and generate its functions again)
    machine = kd.models.build("out-parallel-6dof")
    inverse = machine.numeric(machine.derive())
    quintic = inverse_study(machine, t_end=T, points=401, model=inverse)
    held = float(np.max(np.abs(quintic.forces[:, [0, -1]])))    # static, held still

    definition = kd.models.build("out-parallel-6dof", force_input=True)
    model = definition.numeric(backend="c")
    forces = definition.symbols["forces"]
    s = sm.Symbol("s")                    # the peak force, N: the auxiliary variable
    at_rest = {name: 0.0 for name in RATES}
    problem = kd.OptimalControlProblem(
        model, nodes=args.nodes, duration=T, method="hermite-simpson",
        mayer=s, lagrange=1e-5 * sum(F ** 2 for F in forces),   # least effort among equals
        auxiliary={s: float(quintic.forces.max())},
        path_constraints=[(F - s, None, 0.0) for F in forces]
        + [(F + s, 0.0, None) for F in forces],
        bounds={s: (held, None), **{F: (-LIMIT, LIMIT) for F in forces}},
        initial={**dict(zip(POSE, quintic.pose[0])), **at_rest},
        final={**dict(zip(POSE, quintic.pose[-1])), **at_rest})
    # the guess: the quintic's forces simulated
    pushes = {F: (lambda t, f=CubicSpline(quintic.t, row): float(f(t)))
              for F, row in zip(forces, quintic.forces)}
    run = kd.simulate(model.with_inputs(pushes), (0.0, T),
                      np.concatenate([quintic.q[0], quintic.u[0]]), dense_output=True,
                      method="Radau", rtol=1e-10, atol=1e-10)
    result = problem.solve(problem.guess_from(run, inputs=pushes))
    peak = result.parameters["s"]
    print(result.message)
    print(f"peak carriage force: optimal {peak:.5g} N, quintic "
          f"{np.max(np.abs(quintic.forces)):.5g} N; held still: {held:.5g} N")

    # the optimal path's inverse dynamics, its poses splined (PoseTable)
    names = list(result.state_names)
    t, y, collocated = result.points()
    table = PoseTable(t, y[[names.index(n) for n in POSE]].T,
                                  "the optimal path", "xyz angles")
    check = inverse_study(machine, poses=table, points=t.size, model=inverse)
    difference = float(np.max(np.abs(check.forces - collocated)))
    print(f"inverse dynamics of the optimal path: peak {np.max(np.abs(check.forces)):.5g} N, "
          f"at most {difference:.3g} N from the collocated forces")

    if args.plot:
        plot(args, result, quintic, check, peak)
        print(f"figure: {args.plot}")
    return {"success": result.success, "result": result, "peak": peak, "held": held,
            "quintic": quintic, "check": check, "difference": difference}


def plot(args, result, quintic, check, peak):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figure, ax = plt.subplots(figsize=(8, 5), constrained_layout=True)
    for i, f in enumerate(result.inputs().values()):
        fine = np.linspace(0.0, result.duration, 801)
        ax.plot(fine, [f(t) for t in fine], color=f"C{i}", label=f"carriage {i + 1}")
        ax.plot(quintic.t, quintic.forces[i], ":", color=f"C{i}")
        ax.plot(check.t, check.forces[i], ".", ms=3, color=f"C{i}")
    ax.axhline(peak, color="k", lw=0.8, label=f"least peak s = {peak:.5g} N")
    ax.axhline(LIMIT, color="r", ls="--", lw=1, label=f"limit {LIMIT:g} N")
    ax.plot([], [], "k:", label="quintic")
    ax.plot([], [], "k.", label="inverse dynamics of the optimal path")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("carriage force [N]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=3, loc="lower center", bbox_to_anchor=(0.5, 1.0),
              frameon=False)
    figure.suptitle(f"Out-parallel manipulator, {args.duration:g} s rest to rest: least peak "
                    f"carriage force (solid) against the quintic (dotted)\n(Hermite-Simpson, "
                    f"{args.nodes} nodes)", fontsize=10)
    figure.savefig(args.plot, dpi=120)
    plt.close(figure)


if __name__ == "__main__":
    main()
