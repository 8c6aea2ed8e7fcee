"""The Shuttle arm's least-effort manoeuvre on flexible booms: end with the torques at zero.

What it shows: the same payload manoeuvre as
``shuttle_arm_minimum_energy.py`` (150 s, 11 t payload, joint-angle and
torque limits, least integral of sum tau_i^2) for the arm whose two booms
are flexible (``kd.models.build("shuttle-arm", flexible_booms=True,
torque_input=True)``: Craig-Bampton tubes, 4 modal coordinates each, 28
states).  The booms' modes are at 7 to 65 Hz, far faster than the
manoeuvre, so they bend with the joint torques of the moment: the rigid
optimum, whose torques end away from zero, leaves them bent at the end, and
they ring when the torques stop.  The study solves the rigid arm's problem
with every torque starting and ending at zero (instance constraints), and
simulates both optima's torques on the flexible arm with ``kd.simulate``
(Radau), the torques off after 150 s.  It prints the residual deflection of
the end effector each leaves and what the zero-torque ends cost in effort,
and writes the figure.  ``kanedyn optimize shuttle-arm --set booms=flexible``
runs the same study.

Run it::

    python examples/shuttle_arm_flexible_booms.py                 # 101 nodes
    python examples/shuttle_arm_flexible_booms.py --nodes 51 --plot booms.png
"""

import argparse

import kanedyn as kd


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=101)
    parser.add_argument("--plot", default="shuttle_arm_flexible_booms.png")
    args = parser.parse_args(argv)

    study = kd.studies.shuttle_arm_minimum_energy(booms="flexible", nodes=args.nodes)
    d = study.data
    print(study.summary)
    print()
    for name, prefix in (("rigid optimum's torques", "rigid_torques_"),
                         ("torques from and to zero", "ramped_")):
        print(f"{name:26s}: the end effector {1e3 * d[prefix + 'deflection_end']:.3g} mm "
              f"off its straight-boom position at 150 s, up to "
              f"{1e3 * d[prefix + 'ring_peak']:.3g} mm once the torques stop")
    print(f"effort: {d['effort_ramped']:.6g} against {d['effort_rigid']:.6g} N^2 m^2 s "
          f"(+{100 * (d['effort_ratio'] - 1):.2f} %)")
    if args.plot:
        print(f"figure: {study.plot(args.plot)}")
    return {"study": study, "success": study.result.success}


if __name__ == "__main__":
    main()
