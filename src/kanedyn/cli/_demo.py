"""``kanedyn demo``: the Whipple bicycle's stability against speed and a ride."""

from __future__ import annotations

import time

from .._progress import Progress
from ..models import build
from ._options import check_output_dir, positive_float

__all__ = ["add_parser", "cmd_demo"]


def add_parser(sub):
    """Add the ``demo`` sub-command to ``sub``."""
    p = sub.add_parser("demo", help="the Whipple bicycle: stability against speed "
                                    "and a self-stable ride")
    p.add_argument("--out", default="kanedyn-out", help="output directory")
    p.add_argument("--t-end", type=positive_float, default=5.0, help="ride length [s]")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_demo)


def cmd_demo(args):
    """Derive the Whipple bicycle, map its stability against speed, ride it."""
    import numpy as np

    from ..analysis import PUBLISHED_STABLE_SPEEDS, plot_bicycle_eigenvalues, pyplot
    from ..models import eigenvalues_vs_speed, stability_speeds, upright_state

    out = check_output_dir(args.out)  # before any work, not after it
    progress = Progress(enabled=not args.quiet)
    definition = build("whipple-bicycle")
    progress.stage("deriving the nonlinear Whipple bicycle (Kane's method)")
    t0 = time.perf_counter()
    eom = definition.derive(progress=progress)
    t_derive = time.perf_counter() - t0
    model = definition.numeric(eom)
    print(f"Whipple bicycle: {len(eom.q)} coordinates ({len(eom.q_dep)} dependent), "
          f"{len(eom.u)} speeds ({len(eom.u_dep)} dependent); derived in "
          f"{t_derive:.2f} s")

    progress.stage("linearizing about upright straight running, v = 0..10 m/s")
    speeds = np.linspace(0.0, 10.0, 41)
    eigs = eigenvalues_vs_speed(model, speeds)
    print("\n  v [m/s]   eigenvalues of the lean/steer dynamics [1/s]")
    for v, ev in zip(speeds[::4], eigs[::4]):
        print(f"  {v:6.2f}   " + "  ".join(f"{z.real:9.4f}{z.imag:+9.4f}j" for z in ev))
    weave, capsize = stability_speeds(model)
    print(f"\nself-stable speed range: {weave:.10f} < v < {capsize:.10f} m/s")
    print("published (Meijaard et al. 2007): {!r} < v < {!r}".format(
        *PUBLISHED_STABLE_SPEEDS))

    plt = pyplot()
    fine = np.linspace(0.0, 10.0, 201)
    fig = plot_bicycle_eigenvalues(fine, eigenvalues_vs_speed(model, fine),
                                   stable=(weave, capsize),
                                   path=out / "bicycle_eigenvalues.png")
    plt.close(fig)

    progress.stage("simulating a self-stable ride at 5 m/s after a push (lean rate 0.5 rad/s)")
    from ..simulation import simulate
    y0 = upright_state(model, 5.0)
    y0[model.index("u4")] = 0.5
    y0 = model.consistent_state(0.0, y0)
    t_end = args.t_end
    res = simulate(model, (0.0, t_end), y0, rtol=1e-8, atol=1e-8,
                   t_eval=np.linspace(0.0, t_end, 501), progress=progress)
    res.to_csv(out / "bicycle_ride.csv")
    fig = res.plot(states=["q4", "q7", "u4", "u7"], path=out / "bicycle_ride.png",
                   labels={"q4": "lean q4", "q7": "steer q7", "u4": "lean rate u4",
                           "u7": "steer rate u7"},
                   title="Whipple bicycle: self-stable ride at 5 m/s after a push "
                         "(lean and steer; wheel angles omitted)")
    plt.close(fig)
    lean, steer = res["q4"], res["q7"]
    tail = res.t >= res.t[-1] - 1.0
    print(f"ride: success={res.success}; max |lean| {np.max(np.abs(lean)):.4f} rad; "
          f"|lean| over the last second <= {np.max(np.abs(lean[tail])):.2e} rad, "
          f"|steer| <= {np.max(np.abs(steer[tail])):.2e} rad")
    print(f"energy drift {res.energy_drift():.2e}, max constraint residual "
          f"{np.max(res.constraint_residual):.2e}")
    print(f"wrote {out / 'bicycle_eigenvalues.png'}, {out / 'bicycle_ride.png'}, "
          f"{out / 'bicycle_ride.csv'}")
    return 0 if res.success else 1
