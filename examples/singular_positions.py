"""Singular positions: the N four-bar mechanism (IFToMM benchmark A02).

What it shows: a closed chain that passes *singular positions*, where its
constraint Jacobian loses rank.  N four-bar windows in a row (all links
1 m, 1 kg) start with the cranks vertical and turn round and round; twice a
revolution the cranks are horizontal, every link lies on the ground line and,
for an instant, the mechanism has N + 1 degrees of freedom.

* Kane's equations with the default elimination of the dependent speeds
  divide by a vanishing number there.  ``kd.simulate`` watches the
  conditioning of the constraint Jacobian and warns
  (``kd.SingularConfigurationWarning``) with the times it passed near a
  singular position; after one of them the motion has left the physical
  branch, whether or not the integration stops.
* ``kd.formulate(..., method="augmented-lagrangian-index3")`` (Bayo and
  Ledesma's index-3 augmented Lagrangian with the trapezoidal rule, the
  formulation the benchmark's reference solutions were computed with) keeps
  the configuration constraints at the next step, where the Jacobian has its
  full rank again, and stays on the branch.

The reference is the exact branch motion: all cranks at one angle theta,
I theta'' = -G cos(theta) (``kd.models.n_four_bar_exact``), and its singular
times by quadrature (``kd.models.n_four_bar_singular_times``).

Run it::

    python examples/singular_positions.py                    # N = 4, 3 s
    python examples/singular_positions.py --n 10 --t-end 20 --plot a02.png
"""

import argparse
import warnings

import numpy as np

import kanedyn as kd


def simulate_and_catch(model, t_end, y0, **options):
    """``kd.simulate``, returning also the singular-configuration warning (or None)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", kd.SingularConfigurationWarning)
        res = kd.simulate(model, (0.0, t_end), y0, **options)
    found = [w.message for w in caught
             if issubclass(w.category, kd.SingularConfigurationWarning)]
    return res, (found[0] if found else None)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=4, help="number of four-bar windows")
    parser.add_argument("--t-end", type=float, default=3.0, help="simulated time, s")
    parser.add_argument("--step", type=float, default=2e-3,
                        help="fixed step of the index-3 scheme, s")
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    definition = kd.models.build("n-four-bar", n=args.n)
    print(definition.title)
    exact_times = kd.models.n_four_bar_singular_times(args.t_end, n=args.n)
    print("the cranks are horizontal at t = "
          + ", ".join(f"{t:.6f}" for t in exact_times) + " s (quadrature)")
    t_eval = np.linspace(0.0, args.t_end, int(round(50 * args.t_end)) + 1)
    theta_exact, _ = kd.models.n_four_bar_exact(t_eval, n=args.n)

    # Kane's equations, dependent speeds eliminated (the default scheme)
    kane = definition.numeric(definition.derive())
    y0 = definition.initial(kane)
    res_kane, warning = simulate_and_catch(kane, args.t_end, y0, rtol=1e-10, atol=1e-10,
                                           t_eval=t_eval)
    warned = list(warning.times) if warning is not None else []
    print(f"Kane, elimination: {res_kane.message}")

    # the index-3 augmented Lagrangian (fixed step, trapezoidal rule)
    eom = definition.derive(method="augmented-lagrangian-index3")
    index3 = definition.numeric(eom, scheme=kd.schemes.AugmentedLagrangianIndex3(
        step=args.step))
    res_i3, warning_i3 = simulate_and_catch(index3, args.t_end, y0, t_eval=t_eval)
    print(f"index-3 augmented Lagrangian: {res_i3.message}")

    def off_branch(res):
        """Largest |theta0 - exact| (rad) and spread of the crank angles (rad)."""
        k = res.t.size
        cranks = res.y[:args.n + 1]
        return (float(np.max(np.abs(cranks[0] - theta_exact[:k]))),
                float(np.max(np.ptp(cranks, axis=0))))

    error_kane, spread_kane = off_branch(res_kane)
    error_i3, spread_i3 = off_branch(res_i3)
    print(f"Kane, elimination: output up to t = {res_kane.t[-1]:.3f} s; crank 0 off the exact "
          f"motion by up to {error_kane:.2e} rad, cranks spread by {spread_kane:.2e} rad")
    print(f"index-3:           output up to t = {res_i3.t[-1]:.3f} s; crank 0 off the exact "
          f"motion by up to {error_i3:.2e} rad, cranks spread by {spread_i3:.2e} rad")

    if args.plot:
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
        axes[0].plot(t_eval, np.degrees(theta_exact), color="0.75", lw=5,
                     label="exact branch motion")
        axes[0].plot(res_i3.t, np.degrees(res_i3.y[0]), label="index-3 augmented Lagrangian")
        axes[0].plot(res_kane.t, np.degrees(res_kane.y[0]), "--",
                     label="Kane, elimination")
        for t in exact_times:
            for ax in axes:
                ax.axvline(t, color="0.5", lw=0.6, ls=":")
        axes[0].set_ylabel("angle of crank 0 (deg)")
        axes[0].legend(loc="lower left", fontsize="small")
        axes[1].semilogy(res_i3.t, np.maximum(np.ptp(res_i3.y[:args.n + 1], axis=0), 1e-16),
                         label="index-3 augmented Lagrangian")
        axes[1].semilogy(res_kane.t, np.maximum(np.ptp(res_kane.y[:args.n + 1], axis=0),
                                                1e-16), "--", label="Kane, elimination")
        axes[1].set_ylabel("spread of the crank\nangles (rad)")
        axes[1].set_xlabel("t (s); dotted lines: the singular positions of the exact motion")
        axes[1].legend(loc="center right", fontsize="small")
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle(f"IFToMM A02, {args.n} four-bar windows: passing singular positions")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"singular_times": exact_times.tolist(), "kane_warned_at": warned,
            "kane_message": res_kane.message, "kane_t_end": float(res_kane.t[-1]),
            "kane_branch_error": error_kane, "kane_crank_spread": spread_kane,
            "index3_warned_at": list(warning_i3.times) if warning_i3 is not None else [],
            "index3_branch_error": error_i3, "index3_crank_spread": spread_i3,
            "index3_success": bool(res_i3.success)}


if __name__ == "__main__":
    print(main())
