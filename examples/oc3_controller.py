"""The OC3-Hywind floating turbine, its rotor spinning under the baseline controller, in gusts.

The rotor turns on its tilted shaft and drives the generator through the
97:1 gearbox; the baseline controller with the OC3 gains (variable-speed
torque below rated, gain-scheduled pitch above, constant torque in region 3)
holds the rotor near 12.1 rpm and the power near 5 MW while the spar pitches.
The model, the controller's three states included, is compiled (C backend).

    python examples/oc3_controller.py                          # 18 m/s, 10 % turbulence
    python examples/oc3_controller.py --wind 14 --turbulence 0.15
    python examples/oc3_controller.py --plot oc3_controller.png
"""

import argparse
import math

import numpy as np
import sympy as sm

import kanedyn as kd


def run(wind, turbulence, duration, backend):
    definition = kd.models.oc3_spar(tower_modes=0, rotor="spinning", controller="on",
                                    wind_speed=wind, turbulence=turbulence, seed=3)
    model = definition.numeric(definition.derive(), backend=backend)
    times = np.linspace(0.0, duration, int(duration * 4) + 1)
    res = kd.simulate(model, (0.0, duration), definition.initial(model), t_eval=times,
                      rtol=1e-6, atol=1e-6)
    rotor = definition.symbols["rotor"]
    states = [s for s in definition.kane_args["q_ind"] + definition.kane_args["u_ind"]]
    power = sm.lambdify(states, rotor["electrical_power"], "numpy")
    wind_input = definition.specified[next(k for k in definition.specified
                                           if k.func.__name__ == "V_wind")]
    return definition, dict(
        t=res.t, success=res.success, rotor_rpm=res["rotor_speed"] * 30 / math.pi,
        pitch_deg=np.degrees(res["blade_pitch"]),
        power=np.array([power(*y) for y in res.y.T]),
        platform_pitch_deg=np.degrees(res["pitch"]),
        wind=np.array([wind_input(x) for x in res.t]))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wind", type=float, default=18.0, help="mean wind, m/s (12-25)")
    parser.add_argument("--turbulence", type=float, default=0.1, help="intensity (0.1: 10 %%)")
    parser.add_argument("--duration", type=float, default=300.0, help="s")
    parser.add_argument("--backend", default="c", choices=["c", "numpy"])
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    definition, out = run(args.wind, args.turbulence, args.duration, args.backend)
    late = out["t"] >= args.duration / 2
    out.update({f"mean_{k}": float(np.mean(out[k][late]))
                for k in ("rotor_rpm", "pitch_deg", "power", "platform_pitch_deg", "wind")})
    print(definition.title)
    print(f"  second half: wind {out['mean_wind']:.2f} m/s, rotor {out['mean_rotor_rpm']:.2f} "
          f"rpm (published rated 12.1), pitch {out['mean_pitch_deg']:.2f} deg, electrical "
          f"power {out['mean_power'] / 1e6:.3f} MW (rated 5), platform pitch "
          f"{out['mean_platform_pitch_deg']:.2f} deg")

    if args.plot:
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            raise SystemExit("--plot needs matplotlib: pip install matplotlib") from None
        fig, axes = plt.subplots(5, 1, figsize=(9, 10), sharex=True)
        rows = [("wind", "hub-height wind (m/s)"), ("rotor_rpm", "rotor speed (rpm)"),
                ("pitch_deg", "blade pitch (deg)"), ("power", "electrical power (MW)"),
                ("platform_pitch_deg", "platform pitch (deg)")]
        for ax, (key, label) in zip(axes, rows):
            ax.plot(out["t"], out[key] / (1e6 if key == "power" else 1), lw=0.9)
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        axes[1].axhline(12.1, color="k", ls="--", lw=0.8, label="rated 12.1 rpm")
        axes[3].axhline(5.0, color="k", ls="--", lw=0.8, label="rated 5 MW")
        for ax in (axes[1], axes[3]):
            ax.legend(loc="lower right")
        axes[-1].set_xlabel("time (s)")
        fig.suptitle(f"OC3-Hywind, spinning rotor and baseline controller (OC3 gains): "
                     f"{args.wind:g} m/s, {100 * args.turbulence:g} % turbulence")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)
        print(f"  plot written to {args.plot}")
    return out


if __name__ == "__main__":
    main()
