"""Turn an elastic robot arm by 90 degrees and stop it without vibration: optimal control.

What it shows: ``kd.OptimalControlProblem`` on the built-in elastic robot
(``kd.models.build("flexible-robot", torque_input=True)``: a hub, a flexible
link reduced to its bending modes, a payload; the motor torque ``tau(t)`` an
input).  The torque of least integral of its square turns the hub by 90
degrees in 1 s and leaves the link at rest and undeformed (every elastic
coordinate and rate zero at the end), by Hermite-Simpson collocation.  Today's
model turns it with a sine pulse that would stop a rigid arm.  Both torques
are simulated with ``kd.simulate`` (Radau), then the link is left free: the
pulse leaves millimetres of tip vibration, the optimal torque a small fraction
of that (what remains is the collocation's error).  The figure shows the hub
angle, the tip deflection, the torque and, on a log scale, the vibration left
after the manoeuvre.  ``kanedyn optimize flexible-robot`` runs the same study.

Run it::

    python examples/flexible_robot_rest_to_rest.py            # two modes, 201 nodes
    python examples/flexible_robot_rest_to_rest.py --modes 4 --nodes 401 --plot arm.png
"""

import argparse

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

DURATION, ANGLE, AFTER = 1.0, np.pi / 2, 2.0     # s, rad, s left free afterwards


def simulate(model, y0, t_end):
    """Radau at 2000 samples per second (the tip's vibration is tens of hertz);
    rtol = atol = 1e-8: the numbers printed are those of 1e-10 to 1e-4 (the
    optimal torque's residual of 3e-5 m, the collocation's error, is 3,000
    times the tolerance), in half the CPU time (measured)."""
    t = np.linspace(0.0, t_end, int(2000 * t_end) + 1)
    return kd.simulate(model, (0.0, t_end), y0, method="Radau", rtol=1e-8, atol=1e-8,
                       t_eval=t)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, default=2, help="bending modes of the link")
    parser.add_argument("--nodes", type=int, default=201)
    parser.add_argument("--plot", default="flexible_robot_rest_to_rest.png")
    args = parser.parse_args(argv)

    # the robot driven by an input torque tau(t)
    definition = kd.models.build("flexible-robot", n_modes=args.modes, torque_input=True)
    model = definition.numeric(backend="c")
    tau = definition.symbols["tau"]
    at_rest = {name: 0.0 for name in model.state_names}      # hub and link at rest
    problem = kd.OptimalControlProblem(
        model, nodes=args.nodes, duration=DURATION, lagrange=tau ** 2,
        initial=at_rest, final=dict(at_rest, theta=ANGLE), method="hermite-simpson")
    result = problem.solve(problem.guess_line(inputs={tau: 0.0}))
    print(result.message)
    print(f"least integral of tau^2: {result.objective:.5f} N^2 m^2 s")

    # the optimal torque simulated, then no torque for AFTER seconds
    first = simulate(result.model(), result.y[:, 0], DURATION)
    rest = simulate(model.with_inputs({tau: 0.0}), first.y[:, -1], AFTER)
    t = np.concatenate([first.t, DURATION + rest.t[1:]])
    y = np.concatenate([first.y, rest.y[:, 1:]], axis=1)
    torque_of = result.inputs()["tau"]
    torque = np.array([torque_of(s) if s <= DURATION else 0.0 for s in t])

    # today's model: the sine pulse (same angle, same duration)
    pulsed = kd.models.build("flexible-robot", n_modes=args.modes)
    pulse_model = pulsed.numeric(backend="c")
    pulse = simulate(pulse_model, np.zeros(pulse_model.n_states), DURATION + AFTER)
    pulse_torque = sm.lambdify(me.dynamicsymbols._t,
                               pulsed.symbols["pulse"].xreplace(pulsed.constants))
    pulse_tau = np.array([float(pulse_torque(s)) for s in pulse.t])

    # the tip's deflection across the link, from the modal coordinates
    link = definition.symbols["link"]
    Phi, _ = link.member.node_modes(link.member.n_nodes - 1)
    etas = [q.func.__name__ for q in link.q]
    index = [model.state_names.index(n) for n in etas]
    tip = Phi[1] @ y[index]
    pulse_tip = Phi[1] @ np.array([pulse[n] for n in etas])
    after, pulse_after = t > DURATION, pulse.t > DURATION
    residual = float(np.max(np.abs(tip[after])))
    pulse_residual = float(np.max(np.abs(pulse_tip[pulse_after])))
    pulse_effort = float(np.trapezoid(pulse_tau ** 2, pulse.t))
    hub = y[model.state_names.index("theta")]
    print(f"pulse: integral of tau^2 {pulse_effort:.5f} N^2 m^2 s, residual tip vibration "
          f"{1e3 * pulse_residual:.3f} mm")
    print(f"optimal, simulated: hub at {np.degrees(hub[-1]):.4f} deg, residual tip "
          f"vibration {1e3 * residual:.4f} mm ({pulse_residual / residual:.0f}x smaller)")

    if args.plot:
        plot(args, result, (t, hub, tip, torque, residual),
             (pulse.t, pulse["theta"], pulse_tip, pulse_tau, pulse_residual))
        print(f"figure: {args.plot}")
    return {"success": result.success, "objective": result.objective, "t": t, "hub": hub,
            "tip": tip, "torque": torque, "residual": residual,
            "pulse_residual": pulse_residual, "pulse_effort": pulse_effort,
            "final_angle": float(hub[-1]), "peak_torque": float(np.max(np.abs(torque)))}


def plot(args, result, optimal, pulse):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(4, 1, figsize=(8, 10), sharex=True, constrained_layout=True)
    for (t, hub, tip, torque, residual), color, style, label, short in (
            (optimal, "C0", "-", f"optimal: least integral of tau^2 (Hermite-Simpson, "
                                 f"{args.nodes} nodes)", "optimal"),
            (pulse, "C3", "--", "sine pulse (today's model)", "pulse")):
        axes[0].plot(t, np.degrees(hub), style, color=color, label=label)
        axes[1].plot(t, 1e3 * tip, style, color=color, lw=0.9)
        axes[2].plot(t, torque, style, color=color)
        late = t > DURATION
        axes[3].semilogy(t[late], np.maximum(1e3 * np.abs(tip[late]), 1e-9), style,
                         color=color, lw=0.6,
                         label=f"{short}: residual {1e3 * residual:.3g} mm")
    for ax in axes:
        ax.axvline(DURATION, color="0.5", ls=":", lw=0.8)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("hub angle [deg]")
    axes[0].legend(fontsize=8, loc="lower right")
    axes[1].set_ylabel("tip deflection [mm]")
    axes[2].set_ylabel("motor torque [N m]")
    axes[3].set_ylabel("|tip deflection| after\nthe manoeuvre [mm]")
    axes[3].set_ylim(1e-3 * 1e3 * optimal[4], 3e3 * pulse[4])
    axes[3].legend(fontsize=8, loc="upper right", ncol=2)
    axes[3].set_xlabel("t [s] (dotted: the end of the manoeuvre; then no torque)")
    figure.suptitle(f"Elastic robot, {args.modes} bending modes, 90 deg in {DURATION:g} s: "
                    f"optimal torque against the sine pulse\n(both simulated with Radau; "
                    f"objective {result.objective:.4f} N^2 m^2 s)", fontsize=10)
    figure.savefig(args.plot, dpi=120)
    plt.close(figure)


if __name__ == "__main__":
    main()
