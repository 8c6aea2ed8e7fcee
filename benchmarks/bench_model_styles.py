"""A chain written the way SymPy's documentation writes it against the same chain
written from positions: SymPy's model building and ``kd.kane``, same run.

``chain3d`` at n = 10, 20, 30 links (``--sizes``) in its two styles:

- ``style="v2pt"``: every mass centre's and joint's velocity by SymPy's
  ``v2pt_theory`` (which multiplies out the direction cosines of the chain as it
  builds the model) and an explicit potential energy, as SymPy users write it;
- ``style="positions"``: positions only (``locatenew``), the velocities left to
  kanedyn, which derives them in compact form.

Each case runs in a fresh Python process (no SymPy cache shared between cases):
the time to write the model (``kd.models.chain3d``: SymPy's frames, points,
``v2pt_theory``), then ``kd.kane(**definition.kane_args)`` (kanedyn's
derivation, which for the v2pt style recognizes each stored velocity as the
compact one of its recursive kinematics before using it), process CPU time
of each.  The two styles' equations are compared at a random state (the mass
matrix and forcing evaluated by ``eom.numeric(backend="numpy")``).  Cases
interleaved by round (``--rounds``); minima.

Usage::

    python benchmarks/bench_model_styles.py [--sizes 10 20 30] [--rounds 2]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _fresh_process import byte_compile_package, run_python  # noqa: E402
from bench_numerics import machine_info  # noqa: E402

CHILD = """
import json, time
import numpy as np
import kanedyn as kd
c0 = time.process_time()
definition = kd.models.chain3d(n={n}, style={style!r})
c1 = time.process_time()
eom = kd.kane(**definition.kane_args)
c2 = time.process_time()
model = eom.numeric(constants=definition.constants, backend="numpy")
y = np.random.default_rng(7).uniform(-1.0, 1.0, model.n_states)
print(json.dumps([c1 - c0, c2 - c1, model.rhs(0.0, y).tolist()]))
"""


def case(n, style, cache):
    """``(build s, kd.kane s, rhs at the random state)`` of one fresh process."""
    run = run_python(CHILD.format(n=n, style=style), cache)
    if run.returncode:
        raise RuntimeError(f"chain3d n = {n} {style}: {run.stderr[-2000:]}")
    return json.loads(run.stdout.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[10, 20, 30])
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args(argv)
    byte_compile_package()
    print(machine_info())
    print("\n| n | v2pt: SymPy builds, s | v2pt: kd.kane, s | positions: builds, s | "
          "positions: kd.kane, s | kd.kane v2pt / positions | largest difference of y' |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as cache:
        for n in args.sizes:
            runs = {"v2pt": [], "positions": []}
            for k in range(args.rounds):
                for style in (("v2pt", "positions") if k % 2 == 0 else ("positions", "v2pt")):
                    runs[style].append(case(n, style, cache))
            build = {s: min(r[0] for r in runs[s]) for s in runs}
            kane = {s: min(r[1] for r in runs[s]) for s in runs}
            difference = max(abs(a - b) for a, b in zip(runs["v2pt"][0][2],
                                                        runs["positions"][0][2]))
            print(f"| {n} | {build['v2pt']:.2f} | {kane['v2pt']:.2f} | "
                  f"{build['positions']:.2f} | {kane['positions']:.2f} | "
                  f"{kane['v2pt'] / kane['positions']:.2f} | {difference:.1e} |", flush=True)


if __name__ == "__main__":
    main()
