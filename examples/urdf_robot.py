"""A robot from its URDF description: the UR5 arm falling under gravity.

What it shows: ``kd.models.from_urdf`` turns a robot description file into a
model definition (one coordinate per revolute, continuous or prismatic joint;
fixed joints merged into their parent body), which derives, compiles and
simulates like any built-in model.  The UR5 description comes from the
``example-robot-data`` package (``pip install example-robot-data``); the arm
starts stretched out at rest with no joint torques and falls for 1 s.

Run it::

    python examples/urdf_robot.py                        # print the joint angles
    python examples/urdf_robot.py --plot ur5.png
    python examples/urdf_robot.py --urdf my_robot.urdf   # any other robot
"""

import argparse
import time
from importlib.metadata import PackageNotFoundError, distribution

import numpy as np

import kanedyn as kd


def ur5_file():
    """The UR5 file shipped by example-robot-data (under ``cmeel.prefix/share``)."""
    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        raise SystemExit("this example needs the robots of example-robot-data: "
                         "pip install example-robot-data") from None
    return dist.locate_file("cmeel.prefix/share/example-robot-data/robots/"
                            "ur_description/urdf/ur5_robot.urdf")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--urdf", help="URDF file (default: the UR5 of example-robot-data)")
    parser.add_argument("--t-end", type=float, default=1.0, help="simulated time, s")
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    parser.add_argument("--animate", metavar="FILE.html",
                        help="write a 3D animation drawn with the robot's own geometry")
    args = parser.parse_args(argv)

    path = args.urdf or ur5_file()
    robot = kd.models.from_urdf(path)           # gravity (0, 0, -9.81) m/s^2, fixed base
    print(f"{robot.name}: {len(robot.joints)} joints from {path}")
    for joint in robot.joints:
        print(f"  {joint.type:10s} {joint.name:22s} limits {joint.lower} .. {joint.upper}")

    start = time.perf_counter()
    eom = robot.derive()
    model = robot.numeric(eom)                  # joint torques tau_<joint> are zero
    print(f"derived and compiled in {time.perf_counter() - start:.1f} s")

    y0 = robot.initial(model)                   # all joint angles and rates zero
    times = np.linspace(0.0, args.t_end, 201)
    res = kd.simulate(model, (0.0, args.t_end), y0, rtol=1e-10, atol=1e-10, t_eval=times)
    print(f"simulation: {res.message}")
    final = {j.name: float(res[str(j.q.func)][-1]) for j in robot.joints}
    print(f"joint angles after {args.t_end:g} s (rad):")
    for name, angle in final.items():
        print(f"  {name:22s} {angle:+.6f}")

    if args.plot:
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for k, joint in enumerate(robot.joints):    # styles tell overlapping curves apart
            ax.plot(res.t, np.degrees(res[str(joint.q.func)]), label=joint.name,
                    linestyle=("-", "--", ":")[k // 3 % 3])
        ax.set_xlabel("t (s)")
        ax.set_ylabel("joint angle (deg)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8)
        ax.set_title(f"{robot.name}: falling under gravity from rest, no joint torques")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    if args.animate:                            # visuals; .dae meshes -> collision STL
        page = res.animate(args.animate, visuals=robot.shapes(), title=robot.title)
        print(f"animation saved to {page}")

    return {"final": final, "t_end": args.t_end, "urdf": str(path),
            "success": bool(res.success)}


if __name__ == "__main__":
    main()
