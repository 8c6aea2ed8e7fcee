"""Self-stability of the Whipple bicycle: steady motions and their eigenvalues.

What it shows: ``kd.equilibrium`` finds the steady motion of a nonholonomic
model from a rough guess and reports the stability of its linearization.
The bicycle of Meijaard, Papadopoulos, Ruina and Schwab (2007) starts leaning
and steered, with the rear wheel's rate held (the forward speed) and the
position, heading and wheel angles free to move. Newton's method on the exact
derivatives returns it to upright, straight running. Following that steady
motion from 0 to 10 m/s (each speed starting from the last), the eigenvalues
of the lean-and-steer modes give the speed range in which the bicycle steers
itself upright. The published range is 4.292 to 6.024 m/s: the weave mode
turns stable at the lower speed and the capsize mode unstable at the upper.

Run it::

    python examples/bicycle_stability.py
    python examples/bicycle_stability.py --plot bicycle.png
"""

import argparse

import numpy as np
from scipy.optimize import brentq

import kanedyn as kd

#: coordinates that change in steady running: position, heading, wheel angles
MOVING = ["q1", "q2", "q3", "q6", "q8"]


def steady_running(model, speed, guess=None):
    """``kd.equilibrium`` of running at ``speed`` (m/s) from ``guess`` (default:
    upright), the rear wheel's rate held."""
    y = np.zeros(model.n_states) if guess is None else np.array(guess, dtype=float)
    y[model.index("u6")] = -speed / model.constants["rR"]
    return kd.equilibrium(model, y, hold="u6", moving=MOVING)


def lean_steer_eigenvalues(found):
    """The four eigenvalues of lean and steer, sorted by real part: all but the
    smallest ones, which are zero (one per moving coordinate and the held
    speed; the capsize eigenvalue passes zero too, far above their round-off)."""
    ev = found.eigenvalues
    ev = ev[np.argsort(np.abs(ev))[-4:]]
    return ev[np.lexsort((ev.imag, ev.real))]


def max_real(model, speed):
    return float(np.max(lean_steer_eigenvalues(steady_running(model, speed)).real))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)

    definition = kd.models.build("whipple-bicycle")
    model = definition.numeric(backend="numpy")
    guess = np.zeros(model.n_states)
    guess[model.index("q4")], guess[model.index("q7")] = 0.1, -0.05  # lean, steer (rad)
    first = steady_running(model, 5.0, model.consistent_state(0.0, guess))
    print(f"from lean 0.1 rad, steer -0.05 rad at 5 m/s: {first.iterations} Newton steps, "
          f"lean {first.y[model.index('q4')]:.1e} rad, steer {first.y[model.index('q7')]:.1e} "
          f"rad, residual {first.residual:.1e}")

    speeds = np.linspace(0.0, 10.0, 101)
    eigenvalues, state = [], first.y
    for v in speeds:  # each steady motion from the last one
        found = steady_running(model, v, state)
        state = found.y
        eigenvalues.append(lean_steer_eigenvalues(found))
    eigenvalues = np.array(eigenvalues)
    weave = brentq(lambda v: max_real(model, v), 3.0, 5.0, xtol=1e-12)
    capsize = brentq(lambda v: max_real(model, v), 5.0, 8.0, xtol=1e-12)
    at_5 = lean_steer_eigenvalues(steady_running(model, 5.0))
    print(f"self-stable from {weave:.6f} m/s (weave) to {capsize:.6f} m/s (capsize); "
          "published: 4.292383 and 6.024262")
    print("eigenvalues at 5 m/s, 1/s:", ", ".join(f"{e:.6f}" for e in at_5))

    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(8, 5))
        ax.plot(speeds, eigenvalues.real, ".", color="C0", markersize=3)
        ax.plot(speeds, np.abs(eigenvalues.imag), ".", color="C1", markersize=3)
        ax.plot([], [], ".", color="C0", label="real part")
        ax.plot([], [], ".", color="C1", label="imaginary part (magnitude)")
        ax.axvspan(weave, capsize, color="0.85", label="self-stable range")
        ax.axhline(0.0, color="k", linewidth=0.6)
        ax.set_ylim(-10, 10)
        ax.set_xlabel("forward speed, m/s")
        ax.set_ylabel("eigenvalue, 1/s")
        ax.set_title("Whipple bicycle: lean and steer eigenvalues of steady running")
        ax.legend(loc="lower left")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"saved {args.plot}")
    return {"weave": weave, "capsize": capsize, "at_5": at_5, "first": first,
            "speeds": speeds, "eigenvalues": eigenvalues}


if __name__ == "__main__":
    main()
