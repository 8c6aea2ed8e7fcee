"""Draw docs/img/solo12_ground.png: Solo12, its joints locked in the standing
posture, dropped tilted onto a rigid ground in kanedyn and in MuJoCo (stiff
contacts): the base's height and angles, and the feet's normal forces.

    python docs/make_ground_figure.py

Needs example-robot-data and mujoco.
"""

import sys
import tempfile
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

import kanedyn as kd  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _solo12 as solo12  # noqa: E402

OUT = Path(__file__).resolve().parent / "img" / "solo12_ground.png"
T_END = 0.45


def main():
    with tempfile.TemporaryDirectory() as folder:
        path = solo12.locked_urdf(solo12.solo12_urdf(), Path(folder) / "locked.urdf")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the meshes, which do not touch the ground
            definition = kd.models.from_urdf(
                path, base="floating", ground=kd.Ground(height=0.0, mu_k=0.8, restitution=0.0),
                ground_points={foot: [(0, 0, 0, solo12.RADIUS)] for foot in solo12.FEET})
        y0 = np.zeros(12)
        y0[2:5] = 0.30, 0.1, 0.15
        t_eval = np.linspace(0.0, T_END, 901)
        res = kd.simulate(definition.numeric(), (0.0, T_END), y0, t_eval=t_eval,
                          max_step=0.01)
        theirs = solo12.mujoco_run(mujoco, solo12.mujoco_model(mujoco, path, 0.8), y0, T_END,
                                   every=5e-4)
    fig, axes = plt.subplots(3, 1, figsize=(8, 8.5), sharex=True)
    ax = axes[0]
    ax.plot(res.t, res.y[2] * 1e3, "k", label="kanedyn (rigid)")
    ax.plot(theirs["t"], theirs["q"][:, 2] * 1e3, "C1--", label="MuJoCo (stiff)")
    ax.set_ylabel("base height, mm")
    ax.legend(loc="upper right")
    ax = axes[1]
    for k, name in ((3, "roll"), (4, "pitch"), (5, "heading")):
        ax.plot(res.t, res.y[k] * 1e3, label=f"{name} (kanedyn)")
        ax.plot(theirs["t"], theirs["q"][:, k] * 1e3, "k:", lw=1)
    ax.set_ylabel("base angles, mrad")
    ax.legend(loc="upper right", title="MuJoCo dotted")
    ax = axes[2]
    for k, foot in enumerate(solo12.FEET):
        ax.plot(res.t, res.contact_forces[f"{foot}/point0"]["normal"], f"C{k}", label=foot)
    ax.set_ylabel("normal force, N")
    ax.set_ylim(0, 30)
    ax.legend(loc="upper right", ncol=2, title="kanedyn")
    for ax in axes:
        for impact in res.impacts:
            ax.axvline(impact.t, color="0.8", lw=0.6, zorder=0)
    axes[-1].set_xlabel("t, s (grey: kanedyn's impacts)")
    fig.suptitle("Solo12, joints locked, dropped from 0.30 m rolled 0.1 rad and pitched "
                 "0.15 rad\n(friction 0.8, plastic impacts; MuJoCo: time constant 0.2 ms, "
                 "0.02 ms steps)")
    fig.tight_layout()
    fig.savefig(OUT, dpi=110)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
