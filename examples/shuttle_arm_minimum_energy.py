"""Move the Shuttle arm's 11-tonne payload with the least effort: optimal control with joint limits.

What it shows: ``kd.OptimalControlProblem`` on the built-in Shuttle arm with
its six joint torques as inputs (``kd.models.build("shuttle-arm",
torque_input=True)``; rigid booms, microgravity).  Between the two poses of
the model's quintic manoeuvre, in the same 150 s, it finds the torques of
least integral of sum tau_i^2 (Hermite-Simpson collocation), with each joint
kept within the range the quintic sweeps plus 10 degrees (state bounds) and
each torque within the largest the quintic needs (input bounds, from
``model.inverse_dynamics`` of the quintic).  The optimal torques are then
replayed with ``kd.simulate`` (Radau): open loop, and with a PD tracking term
on top of them (the model's servo gains acting on the difference from the
collocated path: feedforward plus feedback).  In microgravity nothing pulls
the arm back to a path, so the open-loop replay drifts with the collocation's
error; the tracking term holds it.  The figure: joint angles, torques over
their limits, and how far the end effector of each replay is from the
collocated path.  ``kanedyn optimize shuttle-arm`` runs the same study.

Run it::

    python examples/shuttle_arm_minimum_energy.py            # 101 nodes, 10 deg margin
    python examples/shuttle_arm_minimum_energy.py --nodes 201 --margin 20 --plot arm.png
"""

import argparse

import numpy as np
from scipy.interpolate import CubicSpline

import kanedyn as kd

DURATION = 150.0                      # s, the model's quintic manoeuvre
RADAU = {"method": "Radau", "rtol": 1e-10, "atol": 1e-10}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=101)
    parser.add_argument("--margin", type=float, default=10.0,
                        help="joint-angle margin beyond the quintic's range, deg")
    parser.add_argument("--plot", default="shuttle_arm_minimum_energy.png")
    args = parser.parse_args(argv)

    definition = kd.models.build("shuttle-arm", torque_input=True)
    model = definition.numeric(backend="c")
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    start = np.radians(kd.models.SRMS_START_DEG)
    end = np.radians(kd.models.SRMS_END_DEG)

    # today's quintic: its torques by inverse dynamics set the limits
    t = np.linspace(0.0, DURATION, 1501)
    angles, rates, accelerations = kd.models.quintic_pose(t, start, end, DURATION)
    quintic = model.inverse_dynamics(t, angles.T, rates.T, accelerations.T)
    limit = np.max(np.abs(quintic), axis=1)
    margin = np.radians(args.margin)
    bounds = {}
    for i in range(6):
        bounds[q[i]] = (min(start[i], end[i]) - margin, max(start[i], end[i]) + margin)
        bounds[tau[i]] = (-limit[i], limit[i])
    problem = kd.OptimalControlProblem(
        model, nodes=args.nodes, duration=DURATION, lagrange=sum(x ** 2 for x in tau),
        bounds=bounds, method="hermite-simpson",
        initial={**dict(zip(q, start)), **{x: 0.0 for x in u}},
        final={**dict(zip(q, end)), **{x: 0.0 for x in u}})
    # the guess: the quintic's torques, simulated
    splines = [CubicSpline(t, row) for row in quintic]
    feedforward = {x: (lambda s, f=f: float(f(s))) for x, f in zip(tau, splines)}
    run = kd.simulate(model.with_inputs(feedforward), (0.0, DURATION),
                      np.concatenate([start, np.zeros(6)]), dense_output=True, **RADAU)
    result = problem.solve(problem.guess_from(run, inputs=feedforward))
    effort_quintic = float(np.trapezoid(np.sum(quintic ** 2, axis=0), t))
    print(result.message)
    print(f"integral of sum tau^2: optimal {result.objective:.6g}, quintic "
          f"{effort_quintic:.6g} N^2 m^2 s ({100 * (1 - result.objective / effort_quintic):.1f} "
          "% less)")

    # the replays: the optimal torques alone, and with the servos' PD term on top
    open_loop = result.resimulate(**RADAU).simulation
    points, states, _ = result.points()
    path = CubicSpline(points, states, axis=1)       # the collocated path, nodes and midpoints
    servo = definition.symbols["servo"]
    J = np.asarray(servo["J"])
    kp, kd_ = J * servo["omega_c"] ** 2, 2 * servo["zeta_c"] * J * servo["omega_c"]
    optimal = list(result.inputs().values())

    def tracking(i):
        def torque(s, y):
            ref = path(s)
            return optimal[i](s) + kp[i] * (ref[i] - y[i]) + kd_[i] * (ref[6 + i] - y[6 + i])
        return torque
    tracked = kd.simulate(result.model().with_inputs({tau[i]: tracking(i) for i in range(6)}),
                          (0.0, DURATION), result.y[:, 0], t_eval=result.t, **RADAU)
    drift = {name: float(np.max(np.abs(run.y[:6] - result.y[:6])))
             for name, run in (("open loop", open_loop), ("PD-tracked", tracked))}
    for name, value in drift.items():
        print(f"replayed {name}: joint angles within {value:.2e} rad of the collocated path")

    if args.plot:
        plot(args, result, t, angles, quintic, limit, open_loop, tracked)
        print(f"figure: {args.plot}")
    return {"success": result.success, "result": result, "effort_quintic": effort_quintic,
            "limit": limit, "drift_open_loop": drift["open loop"],
            "drift_tracked": drift["PD-tracked"]}


def plot(args, result, t, angles, quintic, limit, open_loop, tracked):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True, constrained_layout=True)
    torques = np.array([[f(s) for s in t] for f in result.inputs().values()])
    for i in range(6):
        axes[0].plot(result.t, np.degrees(result.y[i]), color=f"C{i}", label=f"q{i + 1}")
        axes[0].plot(t, np.degrees(angles[:, i]), ":", color=f"C{i}")
        axes[1].plot(t, torques[i] / limit[i], color=f"C{i}")
        axes[1].plot(t, quintic[i] / limit[i], ":", color=f"C{i}")
    axes[0].plot([], [], "k:", label="quintic")
    axes[0].set_ylabel("joint angle [deg]")
    axes[0].legend(ncol=7, fontsize=8, loc="lower center", bbox_to_anchor=(0.5, 1.0),
                   frameon=False)
    axes[1].set_ylabel("joint torque / its limit\n(solid optimal, dotted quintic)")
    for run, style, label in ((open_loop, "-", "optimal torques open loop"),
                              (tracked, "--", "with the PD tracking term on top")):
        axes[2].semilogy(run.t[1:], np.max(np.abs(run.y[:6, 1:] - result.y[:6, 1:]), axis=0),
                         style, label=label)
    axes[2].set_ylabel("largest joint angle off the\ncollocated path [rad]")
    axes[2].set_xlabel("t [s]")
    axes[2].legend(fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3)
    figure.suptitle(f"Shuttle arm, 11 t payload, {DURATION:g} s: least integral of sum "
                    f"tau_i^2, joints within the quintic's range +- {args.margin:g} deg\n"
                    f"(Hermite-Simpson, {args.nodes} nodes; replays by Radau)", fontsize=10)
    figure.savefig(args.plot, dpi=120)
    plt.close(figure)


if __name__ == "__main__":
    main()
