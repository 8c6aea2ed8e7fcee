"""Constraint forces: the tension in a pendulum's rod, two ways.

What it shows: Kane's equations leave out the forces of ideal constraints
(they do no work), so a rod's tension is not in the equations of a pendulum
written with its angle alone.  kanedyn gets it back in two ways:

1. an *auxiliary speed*: let the bob move along the rod at a speed ``u_a``
   that is zero in the motion (``u_auxiliary=[u_a]``) and apply the unknown
   tension ``T`` there; the auxiliary equation gives ``T`` (``res["T"]``);
2. a *vector constraint*: give the bob a radial coordinate ``r`` held at
   ``L`` (a dependent coordinate) and say "the bob has no velocity along the
   rod", ``kd.PointVelocity(P, A.y)``; kanedyn identifies the force along
   ``A.y`` at ``P``, computes its magnitude from the equations, and
   ``kd.check_newton_euler`` confirms that gravity and this force alone
   produce the bob's acceleration.

Both follow the closed form T = m g cos(theta) + m L theta'^2 along a large
swing.

Run it::

    python examples/constraint_forces.py                  # print the checks
    python examples/constraint_forces.py --plot tension.png
"""

import argparse

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

CONSTANTS = {"m": 1.5, "L": 0.8, "g": 9.81}     # kg, m, m/s^2
THETA0, RATE0 = 2.0, 0.0                         # rad, rad/s: released above the pivot


def pendulum_frames():
    """Symbols, the rod's frame ``A`` (``-A.y`` from the pivot to the bob), ``N`` and ``O``."""
    theta, u = me.dynamicsymbols("theta u")
    m, L, g = sm.symbols("m L g", positive=True)
    N = me.ReferenceFrame("N")                       # N.y up
    A = N.orientnew("A", "Axis", (theta, N.z))
    A.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    return (theta, u, m, L, g), N, A, O


def with_auxiliary_speed():
    """The pendulum in its angle alone, the tension exposed by an auxiliary speed."""
    (theta, u, m, L, g), N, A, O = pendulum_frames()
    u_a, T = me.dynamicsymbols("u_a T")              # auxiliary speed, unknown tension
    P = O.locatenew("P", -L * A.y)
    P.set_vel(N, L * u * A.x + u_a * A.y)            # the bob may leave the rod's length
    return kd.kane(frame=N, q_ind=[theta], u_ind=[u], kd_eqs=[theta.diff() - u],
                   u_auxiliary=[u_a], bodies=[me.Particle("bob", P, m)],
                   loads=[(P, -m * g * N.y), (P, T * A.y)],   # the rod pulls towards O
                   potential_energy=-m * g * L * sm.cos(theta))


def with_vector_constraint():
    """The bob at a distance ``r`` along the rod, held there by a vector constraint."""
    (theta, u, m, L, g), N, A, O = pendulum_frames()
    r, u_r = me.dynamicsymbols("r u_r")
    P = O.locatenew("P", -r * A.y)
    P.set_vel(N, r * u * A.x - u_r * A.y)
    rod = kd.PointVelocity(P, A.y, names="T")       # no velocity along the rod: force T A.y
    return kd.kane(frame=N, q_ind=[theta], q_dep=[r], u_ind=[u], u_dep=[u_r],
                   kd_eqs=[theta.diff() - u, r.diff() - u_r],
                   configuration_constraints=[r - L], constraints=[rod],
                   bodies=[me.Particle("bob", P, m)], loads=[(P, -m * g * N.y)],
                   potential_energy=-m * g * r * sm.cos(theta))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=3.0, help="simulated time, s")
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    m, L, g = (CONSTANTS[k] for k in ("m", "L", "g"))
    t_eval = np.linspace(0.0, args.t_end, 601)
    runs, errors = {}, {}
    for label, eom in (("auxiliary speed", with_auxiliary_speed()),
                       ("vector constraint", with_vector_constraint())):
        model = eom.numeric(constants={s: CONSTANTS[s.name] for s in eom.parameters})
        res = kd.simulate(model, (0.0, args.t_end), {"theta": THETA0, "u": RATE0},
                          rtol=1e-10, atol=1e-10, t_eval=t_eval, constraint_forces=True)
        closed = m * g * np.cos(res["theta"]) + m * L * res["u"] ** 2
        errors[label] = float(np.max(np.abs(res["T"] - closed)))
        runs[label] = res
        print(f"{label:>17}: T from {min(res['T']):.4f} to {max(res['T']):.4f} N; "
              f"largest difference from m g cos(theta) + m L theta'^2: "
              f"{errors[label]:.1e} N")

    check = kd.check_newton_euler(runs["vector constraint"])
    print(f"Newton-Euler check of the bob with the identified force: largest residual "
          f"{check.max_force:.1e} N (inertia forces up to {check.inertia_scale:.1f} N)")
    between = float(np.max(np.abs(runs["auxiliary speed"]["T"]
                                  - runs["vector constraint"]["T"])))
    print(f"the two tensions differ by at most {between:.1e} N")

    if args.plot:
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True)
        res = runs["auxiliary speed"]
        axes[0].plot(res.t, np.degrees(res["theta"]))
        axes[0].set_ylabel("rod angle from\nthe downward vertical (deg)")
        axes[1].plot(res.t, m * g * np.cos(res["theta"]) + m * L * res["u"] ** 2,
                     color="0.75", lw=5,
                     label=r"closed form $m g\cos\theta + m L\dot{\theta}{}^{2}$")
        axes[1].plot(res.t, res["T"], label="auxiliary speed, res['T']")
        axes[1].plot(t_eval, runs["vector constraint"]["T"], "k--",
                     label="kd.PointVelocity, res['T']")
        axes[1].set_ylabel("rod tension T (N)")
        axes[1].set_xlabel("t (s)")
        axes[1].set_ylim(top=1.5 * np.max(res["T"]))
        axes[1].legend(loc="upper center", ncol=2, fontsize="small")
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle(f"pendulum released at {THETA0} rad: tension in the rod "
                     "(negative: compression)")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"error_auxiliary": errors["auxiliary speed"],
            "error_vector": errors["vector constraint"],
            "difference": between, "newton_euler_residual": check.max_force,
            "theta": runs["auxiliary speed"]["theta"].tolist(),
            "tension": runs["auxiliary speed"]["T"].tolist()}


if __name__ == "__main__":
    out = main()
    print({key: value for key, value in out.items() if key not in ("theta", "tension")})
