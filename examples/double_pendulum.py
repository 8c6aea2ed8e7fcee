"""From SymPy objects to a simulation: a double pendulum of two uniform rods.

What it shows: a model written with ``sympy.physics.mechanics`` (frames,
points, rigid bodies, gravity loads and the potential energy) turned into
Kane's equations with ``kd.kane``, into a numerical model with
``eom.numeric`` and into a motion with ``kd.simulate``; then two checks a
user can trust:

* the total energy of the undamped motion stays constant (relative drift at
  the integration tolerance);
* the small-oscillation frequencies from the eigenvalues of
  ``eom.linearize`` about the hanging position equal the closed form of two
  equal uniform rods, omega^2 = (3 -+ 6/sqrt(7)) g/l.

Run it::

    python examples/double_pendulum.py                   # print the checks
    python examples/double_pendulum.py --plot pendulum.png
"""

import argparse

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

CONSTANTS = {"m": 1.0, "l": 0.5, "g": 9.81}      # kg, m, m/s^2


def build():
    """Kane's equations of the double pendulum; returns ``(eom, symbols)``.

    Angles ``q1, q2`` are absolute, from the downward vertical (rad); speeds
    ``u1 = q1'``, ``u2 = q2'`` (rad/s).  Both rods have mass ``m`` and length
    ``l``; ``N.y`` points up.
    """
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    m, l, g = sm.symbols("m l g", positive=True)

    N = me.ReferenceFrame("N")
    A = me.ReferenceFrame("A")
    B = me.ReferenceFrame("B")
    A.orient_axis(N, N.z, q1)
    B.orient_axis(N, N.z, q2)
    A.set_ang_vel(N, u1 * N.z)
    B.set_ang_vel(N, u2 * N.z)

    O = me.Point("O")                       # the fixed pivot
    O.set_vel(N, 0)
    Ao = O.locatenew("Ao", -l / 2 * A.y)    # centre of rod A
    P = O.locatenew("P", -l * A.y)          # the hinge between the rods
    Bo = P.locatenew("Bo", -l / 2 * B.y)    # centre of rod B
    for point, base, frame in ((Ao, O, A), (P, O, A), (Bo, P, B)):
        point.v2pt_theory(base, N, frame)

    I_rod = m * l ** 2 / 12                 # about the centre, across the rod
    rod_a = me.RigidBody("rod_a", Ao, A, m, (me.inertia(A, I_rod, 0, I_rod), Ao))
    rod_b = me.RigidBody("rod_b", Bo, B, m, (me.inertia(B, I_rod, 0, I_rod), Bo))

    eom = kd.kane(frame=N, q_ind=[q1, q2], u_ind=[u1, u2],
                  kd_eqs=[q1.diff() - u1, q2.diff() - u2],
                  bodies=[rod_a, rod_b],
                  loads=[(Ao, -m * g * N.y), (Bo, -m * g * N.y)],
                  potential_energy=m * g * (Ao.pos_from(O) + Bo.pos_from(O)).dot(N.y))
    return eom, dict(q1=q1, q2=q2, u1=u1, u2=u2, m=m, l=l, g=g)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=10.0, help="simulated time, s")
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    eom, s = build()
    constants = {s[name]: value for name, value in CONSTANTS.items()}
    print(f"Kane's equations: mass matrix {eom.mass_matrix.shape}, "
          f"{eom.operation_counts()['all_cse']} operations after CSE")

    # -- simulate a large swing from both rods horizontal, and watch the energy
    model = eom.numeric(constants=constants)
    y0 = {s["q1"]: np.pi / 2, s["q2"]: np.pi / 2, s["u1"]: 0.0, s["u2"]: 0.0}
    res = kd.simulate(model, (0.0, args.t_end), y0, rtol=1e-10, atol=1e-10,
                      t_eval=np.linspace(0.0, args.t_end, 1001))
    drift = res.energy_drift()
    print(f"simulation: {res.message}; {res.nfev} evaluations")
    print(f"relative energy drift over {args.t_end:g} s: {drift:.1e}")

    # -- linearize about the hanging position; the eigenvalues are +-i omega
    A, _, _ = eom.linearize(op_point={s["q1"]: 0.0, s["q2"]: 0.0, s["u1"]: 0.0,
                                      s["u2"]: 0.0}, constants=constants)
    omegas = np.sort(np.abs(np.linalg.eigvals(A).imag))[::2]   # one of each pair
    l, g = CONSTANTS["l"], CONSTANTS["g"]
    closed = np.sqrt(np.array([3 - 6 / np.sqrt(7), 3 + 6 / np.sqrt(7)]) * g / l)
    for k, (w, w_exact) in enumerate(zip(omegas, closed), start=1):
        print(f"mode {k}: omega = {w:.12f} rad/s from eom.linearize, "
              f"{w_exact:.12f} rad/s closed form")

    if args.plot:
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        axes[0].plot(res.t, np.degrees(res["q1"]), label="q1 (upper rod)")
        axes[0].plot(res.t, np.degrees(res["q2"]), label="q2 (lower rod)")
        axes[0].set_ylabel("angle from the vertical (deg)")
        axes[0].legend(loc="lower left")
        axes[1].plot(res.t, res.energy - res.energy[0])
        axes[1].set_ylabel("energy change (J)")
        axes[1].set_xlabel("t (s)")
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle("double pendulum of two uniform rods, released horizontal")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"energy_drift": drift, "omega": omegas.tolist(),
            "success": bool(res.success)}


if __name__ == "__main__":
    print(main())
