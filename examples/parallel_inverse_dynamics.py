"""Inverse dynamics of a parallel robot: the 3-RRR's motor torques along a planned motion.

The planar 3-RRR manipulator's platform moves rest to rest from its home pose by a
quintic in each of x, y and its angle.  kanedyn solves the closed chains' inverse
kinematics, then the torques the three base motors need (Kane's equations with
the loop constraints, mapped to the actuators by virtual work), and checks them by
the power balance: the motors' power against the rate of the kinetic energy,
computed independently from the energy expression.

    python examples/parallel_inverse_dynamics.py
    python examples/parallel_inverse_dynamics.py --plot 3rrr.png
"""

import argparse

import numpy as np

from kanedyn.analysis import inverse_study


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    study = inverse_study("3rrr", trajectory="quintic", points=201)
    power = study.power
    scale = float(np.max(np.abs(power.actuator)))
    residual = float(np.max(np.abs(power.residual))) / scale
    print(f"3-RRR, {study.trajectory} rest-to-rest motion over {study.t[-1]:g} s "
          f"(inverse kinematics: {study.ik_method})")
    for name, unit, force in zip(study.names, study.units, study.forces):
        print(f"  {name}: largest |torque| {np.max(np.abs(force)):.4g} {unit}")
    print(f"  power balance: largest residual {residual:.2e} of the largest motor power "
          f"({scale:.4g} W)")

    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        for name, unit, force in zip(study.names, study.units, study.forces):
            ax1.plot(study.t, force, label=name)
        ax1.set_ylabel(f"motor torque [{study.units[0]}]")
        ax1.set_title("3-RRR: motor torques of a quintic rest-to-rest motion")
        ax1.legend()
        ax2.plot(study.t, power.actuator, "k", lw=2, label="motors' power")
        ax2.plot(study.t, power.kinetic_rate + power.drive_rate + power.potential_rate
                 - power.wrench_power, "C1--", label="rate of the energies")
        ax2.set_xlabel("time [s]")
        ax2.set_ylabel("power [W]")
        ax2.set_title(f"power balance (largest residual {residual:.1e} of the peak)")
        ax2.legend()
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"plot: {args.plot}")
    return {"study": study, "power_residual": residual}


if __name__ == "__main__":
    main()
