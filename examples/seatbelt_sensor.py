"""The seat-belt inertial sensor under a crash pulse: its tilt and its energy balance.

The sensor's pendulum hangs in a housing fixed in a vehicle that decelerates by a
20 g half-sine pulse of 100 ms.  It tilts past the lock angle (20 deg), which
locks the belt, and reaches the housing's wall (30 deg, a stiff damped limit).
The energy balance accounts for every joule: the pendulum's stored energy changes
by the work of the forces that drive the housing's prescribed motion and of the
wall's limit torque, to the integration's tolerance.

    python examples/seatbelt_sensor.py
    python examples/seatbelt_sensor.py --plot seatbelt.png
"""

import argparse

import numpy as np

import kanedyn as kd
from kanedyn.analysis import energy_balance


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="c", choices=["c", "numpy"])
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    definition = kd.models.build("seatbelt-sensor")
    model = definition.numeric(backend=args.backend)
    t_end = 0.12
    res = kd.simulate(model, (0.0, t_end), definition.initial(model),
                      t_eval=np.linspace(0.0, t_end, 601), rtol=1e-10, atol=1e-10,
                      dense_output=True)
    tilt = np.degrees(np.arccos(np.cos(res["q1"]) * np.cos(res["q2"])))
    lock = np.degrees(definition.symbols["lock_angle"])
    locked = res.t[np.argmax(tilt > lock)] if np.any(tilt > lock) else None
    balance = energy_balance(res)
    print(definition.title)
    print(f"  largest tilt {np.max(tilt):.2f} deg; lock angle {lock:g} deg reached at "
          + (f"t = {1e3 * locked:.2f} ms" if locked is not None else "no time"))
    print("  energy balance:")
    print("\n".join(balance.lines()))

    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        ax1.plot(1e3 * res.t, tilt, label="tilt of the pendulum")
        ax1.axhline(lock, color="C3", ls="--", label=f"lock angle ({lock:g} deg)")
        ax1.set_ylabel("tilt in the housing [deg]")
        ax1.set_title("seat-belt sensor, 20 g half-sine pulse of 100 ms")
        ax1.legend(loc="lower right")
        ax2.plot(1e3 * res.t, 1e3 * balance.energy_change, "k", lw=2,
                 label="change of stored energy")
        for name, work in balance.terms.items():
            if np.any(work):
                ax2.plot(1e3 * res.t, 1e3 * work, ls="--", label=f"work: {name}")
        ax2.set_xlabel("time [ms]")
        ax2.set_ylabel("energy [mJ]")
        ax2.set_title(f"energy balance (largest residual {balance.relative_residual:.1e} "
                      "of the energy exchanged)")
        ax2.legend(loc="upper left", fontsize=8)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"plot: {args.plot}")
    return {"success": res.success, "t": res.t, "tilt": tilt, "lock_time": locked,
            "balance": balance}


if __name__ == "__main__":
    main()
