"""Writing a large model so that SymPy does not multiply it out: a chain of links.

What it shows: the same chain of ``n`` rigid links (revolute joints, each
turning its link about the parent's x axis, gravity along -z) written two
ways with ``sympy.physics.mechanics``:

* **from positions** (recommended for large models): frames by
  ``orient_axis`` and ``set_ang_vel``, points by ``locatenew`` only; no
  ``v2pt_theory``, no ``set_vel`` beyond the fixed pivot.  ``kd.kane`` derives
  every velocity itself, link by link, as named intermediates (one rotation
  per frame), so nothing is multiplied out;
* **as SymPy's documentation writes it**: the same plus ``v2pt_theory`` for
  every point.  SymPy then builds each velocity as an expanded expression
  through the products of all the direction cosines above it, which grows
  with the depth of the chain; ``kd.kane`` recognizes each stored velocity as
  the compact one (two random evaluations) and derives as from positions, but
  SymPy's own writing of the model is the slow part.

For each size it times (process CPU) SymPy's writing of the model and
``kd.kane``, checks that both ways give the same state derivative at a
random state, and plots the times.  ``benchmarks/bench_model_styles.py``
measures the built-in ``chain3d`` the same way in fresh processes, at 10 to
30 links (docs/engine.md, "Writing large models").

Run it::

    python examples/large_chain.py                     # 4, 8, 12 links
    python examples/large_chain.py --sizes 5 10 20 --plot chain_times.png
"""

import argparse
import time

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

CONSTANTS = {"m": 1.0, "l": 0.4, "g": 9.81, "I": 0.02}   # kg, m, m/s^2, kg m^2


def chain(n, v2pt=False):
    """``(kane_args, symbols)`` of the n-link chain; ``v2pt=True`` adds SymPy's
    ``v2pt_theory`` velocities (and nothing else)."""
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    m, l, g, I = sm.symbols("m l g I", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    parent, joint = N, O
    bodies, loads = [], []
    for k in range(n):
        B = me.ReferenceFrame(f"B{k + 1}")
        B.orient_axis(parent, parent.x, q[k])
        B.set_ang_vel(parent, u[k] * parent.x)
        centre = joint.locatenew(f"G{k + 1}", -l / 2 * B.z)
        tip = joint.locatenew(f"P{k + 1}", -l * B.z)
        if v2pt:  # SymPy's way: the velocities written out, expanded
            centre.v2pt_theory(joint, N, B)
            tip.v2pt_theory(joint, N, B)
        inertia = me.inertia(B, I, I, I / 10)
        bodies.append(me.RigidBody(f"link{k + 1}", centre, B, m, (inertia, centre)))
        loads.append((centre, -m * g * N.z))
        parent, joint = B, tip
    kane_args = dict(frame=N, q_ind=list(q), u_ind=list(u),
                     kd_eqs=[qk.diff() - uk for qk, uk in zip(q, u)],
                     bodies=bodies, loads=loads)
    return kane_args, dict(m=m, l=l, g=g, I=I)


def timed(n, v2pt):
    """``(write s, kd.kane s, eom, symbols)``, process CPU time."""
    start = time.process_time()
    kane_args, symbols = chain(n, v2pt)
    written = time.process_time()
    eom = kd.kane(**kane_args)
    return written - start, time.process_time() - written, eom, symbols


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[4, 8, 12],
                        help="numbers of links")
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    rows, rhs, states = [], {}, {}
    rng = np.random.default_rng(3)
    for n in args.sizes:
        row = {"n": n}
        y = states[n] = rng.uniform(-1.0, 1.0, 2 * n)
        for style, v2pt in (("positions", False), ("v2pt", True)):
            write, kane, eom, s = timed(n, v2pt)
            model = eom.numeric(constants={s[k]: v for k, v in CONSTANTS.items()})
            rhs[n, style] = model.rhs(0.0, y)
            row[style] = (write, kane)
        row["difference"] = float(np.max(np.abs(rhs[n, "positions"] - rhs[n, "v2pt"])))
        rows.append(row)
        print(f"n = {n:3d}: from positions: SymPy writes it in {row['positions'][0]:.3f} s, "
              f"kd.kane {row['positions'][1]:.3f} s; with v2pt_theory: "
              f"{row['v2pt'][0]:.3f} s and {row['v2pt'][1]:.3f} s; "
              f"state derivatives differ by {row['difference']:.1e}")

    if args.plot:
        import matplotlib.pyplot as plt
        sizes = [r["n"] for r in rows]
        fig, ax = plt.subplots(figsize=(8, 5))
        for style, label, marker in (("positions", "from positions", "o"),
                                     ("v2pt", "with v2pt_theory", "s")):
            ax.plot(sizes, [r[style][0] for r in rows], marker=marker, ls="-",
                    label=f"SymPy writes the model, {label}")
            ax.plot(sizes, [r[style][1] for r in rows], marker=marker, ls="--",
                    label=f"kd.kane, {label}")
        ax.set_xlabel("links n")
        ax.set_ylabel("process CPU time (s)")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        ax.set_title("a chain of n links written two ways: time to write it and to derive it")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"rows": rows, "states": {n: y.tolist() for n, y in states.items()},
            "rhs": {f"{n} {style}": value.tolist() for (n, style), value in rhs.items()}}


if __name__ == "__main__":
    main()
