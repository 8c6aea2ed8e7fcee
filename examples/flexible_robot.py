"""The elastic one-dof robot: a motor turns a flexible link with a payload, rest to rest.

Finite elements give the link's elastic coordinates, Craig–Bampton reduces them,
Kane's method gives the equations (Meghdari & Fahimi's recipe).  A torque pulse
that would turn a rigid robot by 90 degrees in 1 s and stop it leaves the
flexible one vibrating; the motor's work equals the change of kinetic plus strain
energy.

    python examples/flexible_robot.py                   # print the manoeuvre
    python examples/flexible_robot.py --modes 2         # fewer modes
    python examples/flexible_robot.py --plot robot.png  # hub angle, tip, energies
"""

import argparse

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import cumulative_simpson

import kanedyn as kd


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, default=4, help="bending modes of the link")
    parser.add_argument("--backend", default="c", choices=["c", "numpy"])
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    definition = kd.models.build("flexible-robot", n_modes=args.modes)
    print(definition.title)
    print(definition.symbols["member"].report())
    model = definition.numeric(backend=args.backend)
    t_end = definition.t_end
    res = kd.simulate(model, (0.0, t_end), definition.initial(model),
                      t_eval=np.linspace(0.0, t_end, 3001), rtol=1e-10, atol=1e-10)

    link = definition.symbols["link"]
    Phi, _ = link.member.node_modes(link.member.n_nodes - 1)
    eta = np.array([res[q.func.__name__] for q in link.q])
    tip = Phi[1] @ eta                                     # m, across the link
    strain = 0.5 * np.einsum("ik,ij,jk->k", eta, link.modal_stiffness, eta)
    torque = sm.lambdify(me.dynamicsymbols._t,
                         definition.symbols["torque"].xreplace(definition.constants))
    tau = np.array([float(torque(x)) for x in res.t])
    work = np.concatenate([[0.0], cumulative_simpson(tau * res["omega"], x=res.t)])
    energy = res.energy - res.energy[0]
    balance = float(np.max(np.abs(energy - work)) / np.max(np.abs(energy)))
    print(f"  {res.message}")
    print(f"  hub angle at {t_end:g} s: {np.degrees(res['theta'][-1]):.2f} deg "
          f"(a rigid robot: 90), hub rate {res['omega'][-1]:+.3f} rad/s")
    print(f"  largest tip deflection {1e3 * np.max(np.abs(tip)):.1f} mm; strain energy up to "
          f"{1e3 * strain.max():.2f} mJ; motor work {1e3 * work[-1]:.3f} mJ; energy balance "
          f"{balance:.1e} (relative)")

    if args.plot:
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            raise SystemExit("--plot needs matplotlib: pip install matplotlib") from None
        fig, axes = plt.subplots(4, 1, figsize=(8, 10), sharex=True)
        axes[0].plot(res.t, np.degrees(res["theta"]), label="hub angle (deg)")
        axes[0].plot(res.t, 20 * tau, "--", label="motor torque x 20 (N m)")
        axes[0].set_ylabel("hub angle (deg)\ntorque x 20 (N m)")
        axes[0].legend(fontsize="small")
        axes[1].plot(res.t, 1e3 * tip)
        axes[1].set_ylabel("tip deflection (mm)")
        axes[2].plot(res.t, 1e3 * strain)
        axes[2].set_ylabel("strain energy (mJ)")
        axes[3].plot(res.t, energy, label="change of kinetic + strain energy")
        axes[3].plot(res.t, work, ":", color="k", label="motor work")
        axes[3].set_ylabel("energy (J)")
        axes[3].set_xlabel("t (s)")
        axes[3].legend(fontsize="small", title=f"largest difference {balance:.0e} (relative)",
                       title_fontsize="small")
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle(f"Elastic one-dof robot, {args.modes} bending modes: "
                     "rest-to-rest torque pulse")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"success": res.success, "t": res.t, "theta": res["theta"],
            "omega": res["omega"], "tau": tau, "energy": res.energy, "tip": tip,
            "energy_balance": balance}


if __name__ == "__main__":
    out = main()
    print({key: value for key, value in out.items() if np.ndim(value) == 0})
