"""Nonholonomic rolling: when does an upright rolling disk stay upright?

What it shows: a thin disk rolling without slip on a horizontal plane.
Rolling is a constraint on velocities that cannot be integrated into one on
positions (the disk can reach any place with any heading), so the
coordinates stay independent while the contact point's rates become
dependent speeds (``u_dep``) fixed by two velocity constraints
(``velocity_constraints``).  The eigenvalues of ``eom.linearize`` about
upright rolling at spin rate Omega show the closed-form stability threshold
of the thin disk, Omega^2 > g/(3 r): below it a real pair (the disk falls
over), above it an imaginary pair (it wobbles and stays up).  Two short
simulations from a small lean show the same.

Run it::

    python examples/rolling_disk.py                    # print the checks
    python examples/rolling_disk.py --plot disk.png
"""

import argparse

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

CONSTANTS = {"m": 2.0, "r": 0.3, "g": 9.81}      # kg, m, m/s^2


def build():
    """Kane's equations of the rolling disk; returns ``(eom, symbols)``.

    Coordinates: contact point ``x, y`` (m), heading ``psi``, lean from the
    vertical ``theta`` and spin ``phi`` (rad); speeds are their rates, those
    of ``psi, theta, phi`` independent, ``x', y'`` dependent.  ``N.z`` is up.
    """
    x, y, psi, theta, phi = me.dynamicsymbols("x y psi theta phi")
    ux, uy, dpsi, dtheta, dphi = me.dynamicsymbols("u_x u_y dpsi dtheta dphi")
    m, r, g = sm.symbols("m r g", positive=True)

    N = me.ReferenceFrame("N")
    heading = N.orientnew("Y", "Axis", (psi, N.z))
    lean = heading.orientnew("L", "Axis", (theta, heading.x))   # L.y is the axle
    disk_frame = lean.orientnew("R", "Axis", (phi, lean.y))
    heading.set_ang_vel(N, dpsi * N.z)
    lean.set_ang_vel(heading, dtheta * heading.x)
    disk_frame.set_ang_vel(lean, dphi * lean.y)

    O = me.Point("O")
    O.set_vel(N, 0)
    contact = O.locatenew("C", x * N.x + y * N.y)
    contact.set_vel(N, ux * N.x + uy * N.y)
    centre = contact.locatenew("G", r * lean.z)
    centre.v2pt_theory(contact, N, lean)

    # no slip: the disk's material point at the contact has no velocity
    slip = centre.vel(N) + disk_frame.ang_vel_in(N).cross(contact.pos_from(centre))
    I_diameter = m * r ** 2 / 4                        # thin disk
    disk = me.RigidBody("disk", centre, disk_frame, m,
                        (me.inertia(lean, I_diameter, 2 * I_diameter, I_diameter), centre))

    q = [x, y, psi, theta, phi]
    u = [ux, uy, dpsi, dtheta, dphi]
    eom = kd.kane(frame=N, q_ind=q, u_ind=[dpsi, dtheta, dphi], u_dep=[ux, uy],
                  kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)],
                  velocity_constraints=[slip.dot(heading.x), slip.dot(heading.y)],
                  bodies=[disk], loads=[(centre, -m * g * N.z)],
                  potential_energy=m * g * r * sm.cos(theta))
    names = "x y psi theta phi u_x u_y dpsi dtheta dphi m r g".split()
    return eom, dict(zip(names, q + u + [m, r, g]))


def upright(s, spin):
    """The state of upright rolling along ``N.x`` at spin rate ``spin`` (rad/s)."""
    state = {s[name]: 0.0 for name in ("x", "y", "psi", "theta", "phi", "dpsi", "dtheta",
                                        "u_y")}
    state.update({s["dphi"]: spin, s["u_x"]: CONSTANTS["r"] * spin})
    return state


def eigenvalues(eom, s, spin):
    """Eigenvalues of the linearized equations about upright rolling, 1/s."""
    A, _, _ = eom.linearize(op_point=upright(s, spin),
                            constants={s[k]: v for k, v in CONSTANTS.items()})
    return np.linalg.eigvals(A)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=4.0, help="simulated time, s")
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    eom, s = build()
    r, g = CONSTANTS["r"], CONSTANTS["g"]
    critical = np.sqrt(g / (3 * r))
    print(f"closed form: upright rolling is stable for spin rates above "
          f"sqrt(g/(3r)) = {critical:.6f} rad/s")
    spins = {"below": 0.7 * critical, "above": 1.5 * critical}
    largest_real, lean_eigenvalues = {}, {}
    for case, spin in spins.items():
        lam = eigenvalues(eom, s, spin)
        lean_eigenvalues[case] = lam[np.argsort(-np.abs(lam))[:2]]   # the nonzero pair
        largest_real[case] = float(np.max(lam.real))
        print(f"spin {spin:.4f} rad/s ({case} the threshold): lean eigenvalues "
              + ", ".join(f"{v:.6f}" for v in lean_eigenvalues[case])
              + f"; largest real part {largest_real[case]:.2e} 1/s")

    # simulate from a small lean: stays up above the threshold, falls below it
    model = eom.numeric(constants={s[k]: v for k, v in CONSTANTS.items()})

    def fallen(t, y):
        """An event: the lean reaches 0.5 rad, the disk is falling over."""
        return abs(y[model.index("theta")]) - 0.5
    fallen.terminal = True

    runs = {}
    for case, spin in spins.items():
        start = upright(s, spin)
        start[s["theta"]] = 0.05
        runs[case] = kd.simulate(model, (0.0, args.t_end), start, rtol=1e-10, atol=1e-10,
                                 events=[fallen], max_step=0.01)
        lean = runs[case]["theta"]
        print(f"from a lean of 0.05 rad, {case} the threshold: largest lean "
              f"{np.max(np.abs(lean)):.4f} rad; {runs[case].message}")
    stable = runs["above"]

    if args.plot:
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
        for case, res in runs.items():
            axes[0].plot(res.t, np.degrees(res["theta"]),
                         label=f"spin {spins[case]:.2f} rad/s ({case} threshold)")
        axes[0].set_xlabel("t (s)")
        axes[0].set_ylabel("lean from the vertical (deg)")
        axes[0].legend(loc="upper right")  # the falling disk leaves at the top left
        axes[1].plot(stable["x"], stable["y"])
        axes[1].set_xlabel("contact point x (m)")
        axes[1].set_ylabel("contact point y (m)")
        axes[1].set_aspect("equal", adjustable="datalim")
        axes[1].set_title(f"path on the ground, spin {spins['above']:.2f} rad/s",
                          fontsize="medium")
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle(f"thin disk rolling without slip (r = {r} m): stable iff "
                     f"spin > sqrt(g/3r) = {critical:.2f} rad/s")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"spin": {case: float(v) for case, v in spins.items()},
            "largest_real_part": largest_real,
            "lean_eigenvalues": {case: [complex(v) for v in lam]
                                 for case, lam in lean_eigenvalues.items()},
            "max_lean_above": float(np.max(np.abs(stable["theta"]))),
            "fell_below": bool(runs["below"].status == 1),
            "success": bool(stable.success)}


if __name__ == "__main__":
    print(main())
