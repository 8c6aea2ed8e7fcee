"""A MuJoCo model from its MJCF file: dm_control's acrobot falling from upright.

What it shows: ``kd.models.from_mjcf`` turns a MuJoCo model file into a model
definition whose state is MuJoCo's (``qpos``/``qvel``, joint by joint), which
derives, compiles and simulates like any built-in model.  The acrobot is the
one of the ``dm-control`` package's control suite (``pip install dm-control``):
two capsule links on hinges with joint damping, inertias inferred from their
geoms as MuJoCo does, and a motor at the elbow (left at zero control).  It
starts upright, the shoulder turned 0.05 rad, and falls for 3 s.  When the
``mujoco`` package is installed, MuJoCo's own simulation of the same file
(RK4, contacts off) is drawn over kanedyn's.

Run it::

    python examples/mjcf_model.py                       # print the final state
    python examples/mjcf_model.py --plot acrobot.png
    python examples/mjcf_model.py --mjcf my_model.xml   # any other model
"""

import argparse
import time
from pathlib import Path

import numpy as np

import kanedyn as kd


def acrobot_file():
    """The acrobot of dm_control's control suite."""
    try:
        from dm_control import suite
    except ImportError:
        raise SystemExit("this example needs the control suite of dm-control: "
                         "pip install dm-control") from None
    return Path(suite.__file__).parent / "acrobot.xml"


def mujoco_run(path, qpos, t_eval, step=1e-4):
    """MuJoCo's RK4 simulation of ``path`` from ``qpos`` at rest (contacts off):
    ``qpos`` at ``t_eval``, or None without the mujoco package."""
    try:
        import mujoco
    except ImportError:
        return None
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj.opt.timestep, mj.opt.integrator = step, mujoco.mjtIntegrator.mjINT_RK4
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    data = mujoco.MjData(mj)
    data.qpos[:] = qpos
    out = []
    for t in t_eval:
        while data.time < t - step / 2:
            mujoco.mj_step(mj, data)
        out.append(data.qpos.copy())
    return np.array(out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mjcf", help="MJCF file (default: dm_control's acrobot)")
    parser.add_argument("--t-end", type=float, default=3.0, help="simulated time, s")
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    path = args.mjcf or acrobot_file()
    definition = kd.models.from_mjcf(path)      # gravity and joints as the file gives
    print(f"{definition.title}")
    for joint in definition.joints:
        print(f"  {joint.type:6s} {joint.name:12s} damping {joint.damping:g}, "
              f"armature {joint.armature:g}")

    start = time.perf_counter()
    model = definition.numeric(definition.derive())     # controls ctrl_<actuator> zero
    print(f"derived and compiled in {time.perf_counter() - start:.1f} s")

    first = definition.joints[0]
    y0 = definition.initial(model, {str(first.q[0].func): first.ref + 0.05})
    times = np.linspace(0.0, args.t_end, 301)
    res = kd.simulate(model, (0.0, args.t_end), y0, rtol=1e-11, atol=1e-11, t_eval=times)
    print(f"simulation: {res.message}")
    qpos = np.array([definition.mujoco_state(model, y)[0] for y in res.y.T])
    print(f"qpos after {args.t_end:g} s: {np.array2string(qpos[-1], precision=6)}")

    reference = mujoco_run(path, qpos[0], times)
    difference = None
    if reference is not None:
        difference = float(np.max(np.abs(reference - qpos)))
        print(f"MuJoCo (RK4, step 1e-4 s) differs by at most {difference:.2g}")

    if args.plot:
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for k, joint in enumerate(definition.joints[:6]):
            ax.plot(times, qpos[:, joint.qpos_index], color=f"C{k}",
                    label=f"{joint.name} (kanedyn)")
            if reference is not None:
                ax.plot(times[::6], reference[::6, joint.qpos_index], "o", color=f"C{k}",
                        markersize=4, fillstyle="none", label=f"{joint.name} (MuJoCo)")
        ax.set_xlabel("t (s)")
        angles = all(j.type == "hinge" for j in definition.joints)
        ax.set_ylabel("joint angle (rad)" if angles else "qpos (rad or m)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
        ax.set_title(f"{definition.name} from its MJCF file, falling from upright")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"times": times, "qpos": qpos, "mjcf": str(path), "success": bool(res.success),
            "mujoco_difference": difference}


if __name__ == "__main__":
    main()
