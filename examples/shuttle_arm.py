"""The Shuttle arm (SRMS) moving a Hubble-class payload: natural orthogonal
complement with Gear's BDF method against Kane's method.

Cyril, Angeles & Misra (1991) derived the arm's equations with the natural
orthogonal complement, solved them by Cholesky's factorization and
integrated them with Gear's stiff method.  This script does the same with
``kd.formulate(..., method="orthogonal-complement")`` and ``method="BDF"``,
and compares with Kane's equations integrated with DOP853 (explicit) and BDF.

    python examples/shuttle_arm.py                 # print the comparison
    python examples/shuttle_arm.py --plot arm.png  # and save a plot
    python examples/shuttle_arm.py --no-payload    # the empty arm
    python examples/shuttle_arm.py --t-end 20      # the first 20 s of the manoeuvre
"""

import argparse
import time

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    parser.add_argument("--no-payload", action="store_true", help="move the empty arm")
    parser.add_argument("--rtol", type=float, default=1e-10, help="integrator rtol")
    parser.add_argument("--atol", type=float, default=1e-11, help="integrator atol")
    parser.add_argument("--t-end", type=float, default=None,
                        help="simulated time, s (default: the whole manoeuvre, 200 s)")
    args = parser.parse_args(argv)

    definition = kd.models.build("shuttle-arm", payload=not args.no_payload)
    print(definition.title)
    timings = {}
    eoms = {}
    for method in ("orthogonal-complement", "kane"):
        start = time.process_time()
        eoms[method] = definition.derive(method=method)
        timings[method] = time.process_time() - start
    models = {method: definition.numeric(eom) for method, eom in eoms.items()}
    for method, eom in eoms.items():
        counts = eom.operation_counts()
        print(f"  {method:<22} derived in {timings[method]:.2f} s CPU; operations "
              f"M {counts['mass_matrix']}, f {counts['forcing']}, jointly with CSE "
              f"{counts['all_cse']}; scheme {type(eom.scheme).__name__}")

    t_end = definition.t_end if args.t_end is None else args.t_end
    t_eval = np.linspace(0.0, t_end, 401)
    y0 = definition.initial(models["kane"])
    runs = {}
    for label, method, integrator in (("NOC + BDF", "orthogonal-complement", "BDF"),
                                      ("Kane + BDF", "kane", "BDF"),
                                      ("Kane + DOP853", "kane", "DOP853")):
        start = time.process_time()
        res = kd.simulate(models[method], (0.0, t_end), y0, method=integrator,
                          rtol=args.rtol, atol=args.atol, t_eval=t_eval)
        cpu = time.process_time() - start
        runs[label] = res
        print(f"  {label:<14} {res.message}; {res.nfev:6d} evaluations, {cpu:6.2f} s CPU")

    noc, kane = runs["NOC + BDF"], runs["Kane + DOP853"]
    differences = {"angles": float(np.max(np.abs(noc.y[:6] - kane.y[:6]))),
                   "rates": float(np.max(np.abs(noc.y[6:] - kane.y[6:]))),
                   "kane_bdf": float(np.max(np.abs(noc.y - runs["Kane + BDF"].y)))}
    print("largest difference, NOC + BDF vs Kane + DOP853: "
          f"angles {differences['angles']:.2e} rad, rates {differences['rates']:.2e} rad/s")
    print(f"largest difference, NOC + BDF vs Kane + BDF:    {differences['kane_bdf']:.2e}")

    # end-effector tracking and drive torques
    sy, constants = definition.symbols, definition.constants
    t = sm.Symbol("t")

    def numeric(expr, variables):
        expr = sm.sympify(expr).xreplace(constants).xreplace({me.dynamicsymbols._t: t})
        return sm.lambdify(variables, expr, "numpy")

    tip = numeric(sy["tip_position"], list(sy["q"]))
    reference = numeric(sm.Matrix(sy["q_ref"]), [t])
    torques = numeric(sm.Matrix(sy["torques"]), [t] + list(sy["q"]) + list(sy["u"]))
    tip_actual = np.array([np.ravel(tip(*noc.y[:6, k])) for k in range(noc.t.size)])
    tip_ref = np.array([np.ravel(tip(*np.ravel(reference(tk)))) for tk in noc.t])
    error = np.linalg.norm(tip_actual - tip_ref, axis=1)
    tau = np.array([np.ravel(torques(tk, *noc.y[:, k])) for k, tk in enumerate(noc.t)])
    print(f"end effector: travels {np.linalg.norm(tip_ref[-1] - tip_ref[0]):.2f} m, "
          f"largest tracking error {1e3 * error.max():.2f} mm, at {t_end:g} s "
          f"{1e3 * error[-1]:.2e} mm; peak joint torques "
          + ", ".join(f"{v:.0f}" for v in np.max(np.abs(tau), axis=0)) + " N m")

    if args.plot:
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            raise SystemExit("--plot needs matplotlib: pip install matplotlib") from None
        fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
        refs = np.array([np.ravel(reference(tk)) for tk in noc.t])
        for i in range(6):
            axes[0].plot(noc.t, np.degrees(noc.y[i]), label=f"q{i + 1}")
            axes[0].plot(noc.t, np.degrees(refs[:, i]), "k:", lw=0.8,
                         label="reference" if i == 5 else None)
        axes[0].set_ylabel("joint angle (deg)")
        axes[0].legend(ncol=7, fontsize="small", loc="lower center", bbox_to_anchor=(0.5, 1.0),
                       frameon=False)  # above the axes: the curves fill them
        axes[1].plot(noc.t, 1e3 * error)
        axes[1].set_ylabel("tip tracking error (mm)")
        axes[2].plot(noc.t, tau)
        axes[2].set_ylabel("joint torque (N m),\njoints as above")
        axes[2].set_xlabel("t (s)")
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle(definition.title, fontsize="small")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"noc_vs_kane_dop853_angles": differences["angles"],
            "noc_vs_kane_dop853_rates": differences["rates"],
            "noc_vs_kane_bdf": differences["kane_bdf"],
            "tracking_error_max": float(error.max()),
            "success": all(res.success for res in runs.values())}


if __name__ == "__main__":
    print(main())
