"""Contacts: a block thrown onto a rough floor bounces, slides and stops.

What it shows: a unilateral contact between a point and a plane
(``kd.Contact(point, kd.Plane(...), mu_k=..., restitution=...)``) with
Coulomb friction whose normal force is the one the equations compute.  A
small block (a particle: it cannot tip) is thrown horizontally at 5 m/s from
1 m above the floor.  Each impact reverses the normal speed times the
restitution coefficient e and takes mu (1 + e) times the approach speed off
the horizontal speed; the bounces shrink geometrically (the last, slower
than about 1e-6 m/s, is made plastic), then the block slides at the
deceleration mu g and sticks.  The script prints the impacts, the contact
mode history (separated, slip, stick) and the energy balance: the energy
lost equals the friction work plus the impacts' losses.

Run it::

    python examples/friction_and_impacts.py                  # print the story
    python examples/friction_and_impacts.py --plot block.png
"""

import argparse

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

#: mass (kg), gravity (m/s^2), friction coefficient, restitution coefficient
CONSTANTS = {"m": 0.5, "g": 9.81, "mu": 0.2, "e": 0.5}
#: thrown from 1 m at 5 m/s horizontally (m, m/s)
START = {"x": 0.0, "z": 1.0, "u_x": 5.0, "u_z": 0.0}


def build():
    """Kane's equations of the block with its floor contact; returns ``(eom, symbols)``.

    Coordinates ``x`` (along the floor) and ``z`` (height) of the block, m;
    speeds their rates, m/s.  ``N.z`` is up; the floor is the plane z = 0.
    """
    x, z, ux, uz = me.dynamicsymbols("x z u_x u_z")
    m, g, mu, e = sm.symbols("m g mu e", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + z * N.z)
    P.set_vel(N, ux * N.x + uz * N.z)
    block = me.Particle("block", P, m)

    floor = kd.Contact(P, kd.Plane(N, O, N.z), mu_k=mu, restitution=e, name="floor")
    eom = kd.kane(frame=N, q_ind=[x, z], u_ind=[ux, uz],
                  kd_eqs=[x.diff() - ux, z.diff() - uz], bodies=[block],
                  loads=[(P, -m * g * N.z)], potential_energy=m * g * z,
                  contacts=[floor])
    return eom, dict(zip("x z u_x u_z m g mu e".split(), (x, z, ux, uz, m, g, mu, e)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=3.0, help="simulated time, s")
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    eom, s = build()
    model = eom.numeric(constants={s[k]: v for k, v in CONSTANTS.items()})
    res = kd.simulate(model, (0.0, args.t_end), {s[k]: v for k, v in START.items()},
                      rtol=1e-10, atol=1e-10, t_eval=np.linspace(0.0, args.t_end, 3001))
    print(f"simulation: {res.message}")

    print(f"{len(res.impacts)} impacts; the first five:")
    for impact in res.impacts[:5]:
        print(f"  t = {impact.t:.9f} s: approach {impact.approach_speeds[0]:.6f} m/s, "
              f"separation {impact.separation_speeds[0]:.6f} m/s; impulse: normal "
              f"{impact.normal_impulses[0]:.6f}, friction {impact.impulses[0][0]:.6f} N s; "
              f"energy lost {impact.energy_loss:.6f} J")
    print("mode changes (a bounce that leaves the floor again changes no mode):")
    for change in res.mode_history:
        print(f"  t = {change.t:.9f} s: {change.contact} {change.old} -> {change.new} "
                  f"({change.reason})")
    stop = res.mode_history[-1].t
    print(f"the block stops at t = {stop:.6f} s, x = {res['x'][-1]:.6f} m")

    impact_loss = sum(impact.energy_loss for impact in res.impacts)
    friction_work = float(res.dissipated_work[-1])
    lost = float(res.energy[0] - res.energy[-1])
    balance = float(np.max(np.abs(res.energy_balance())))
    print(f"energy lost {lost:.9f} J = impacts {impact_loss:.9f} J + sliding friction "
          f"{-friction_work:.9f} J; largest energy-balance error {balance:.1e} J")

    if args.plot:
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(3, 1, figsize=(8, 9))
        axes[0].plot(res["x"], res["z"])
        axes[0].set_xlabel("x (m)")
        axes[0].set_ylabel("height z (m)")
        axes[0].set_title("path of the block", fontsize="medium")
        axes[1].plot(res.t, res["u_x"], label="horizontal speed")
        for k, impact in enumerate(res.impacts):
            axes[1].axvline(impact.t, color="0.6", lw=0.6, ls=":",
                            label="impacts" if k == 0 else None)
        axes[1].set_ylabel("horizontal speed (m/s)")
        twin = axes[1].twinx()
        twin.plot(res.t, res.contact_forces["floor"]["normal"], color="C1",
                  label="normal force")
        twin.set_ylabel("normal force (N)")
        axes[1].legend(handles=axes[1].lines[:2] + twin.lines, loc="center right")
        jumps = np.array([sum(i.energy_loss for i in res.impacts if i.t < t) for t in res.t])
        axes[2].plot(res.t, res.energy, label="energy of the block")
        axes[2].plot(res.t, jumps, label="lost in impacts")
        axes[2].plot(res.t, -res.dissipated_work, label="lost to sliding friction")
        axes[2].set_ylabel("energy (J)")
        axes[2].legend(loc="center right")
        for ax in axes[1:]:
            ax.set_xlabel("t (s)")
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle(f"block thrown onto a rough floor (mu = {CONSTANTS['mu']}, "
                     f"e = {CONSTANTS['e']})")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"impact_times": [i.t for i in res.impacts],
            "approach_speeds": [float(i.approach_speeds[0]) for i in res.impacts],
            "friction_impulses": [float(i.impulses[0][0]) for i in res.impacts],
            "stop_time": stop, "final_x": float(res["x"][-1]),
            "energy_lost": lost, "impact_loss": impact_loss,
            "friction_work": friction_work, "energy_balance": balance,
            "modes": [(c.t, c.old, c.new) for c in res.mode_history],
            "success": bool(res.success)}


if __name__ == "__main__":
    print(main())
