"""Benchmark of the ``oc3-spar`` model on the compiled backend (issue 17).

1. Irregular sea (JONSWAP, Hs, Tp, seed) with a steady wind: CPU seconds per
   simulated second (``--duration`` s of sea, default 600 s; the hour figure is
   the measured rate times 3600 s, said so in the output).
2. A ``--points``-period linear RAO sweep (``oc3-rao``'s linear model) plus its
   build, reported separately.

Build and compile times are reported apart from the run times.  Run:
``python benchmarks/bench_oc3.py [--duration 600] [--points 20]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=600.0, help="simulated sea, s")
    p.add_argument("--points", type=int, default=20, help="wave periods of the RAO sweep")
    p.add_argument("--Hs", type=float, default=6.0, help="significant wave height, m")
    p.add_argument("--Tp", type=float, default=10.0, help="peak period, s")
    p.add_argument("--wind", type=float, default=0.0,
                   help="steady wind speed, m/s (0: parked rotor)")
    p.add_argument("--tower-modes", type=int, default=2, help="tower bending modes")
    a = p.parse_args(argv)
    from kanedyn.analysis._oc3_studies import _linear, _model, linear_rao, oc3_outputs
    from kanedyn.analysis._oc3_studies import wave_input_phasor
    from kanedyn.simulation import simulate

    t0 = time.perf_counter()
    opts = dict(tower_modes=a.tower_modes, drag=True, sea="irregular", wave_height=a.Hs,
                wave_period=a.Tp, seed=1, wind_speed=a.wind)
    d, _, model, y_eq = _model("c", **opts)
    build = time.perf_counter() - t0
    t0 = time.process_time()
    res = simulate(model, (0.0, a.duration), y_eq, rtol=1e-6, atol=1e-6,
                   t_eval=np.arange(0.0, a.duration + 1e-9, 0.25))
    cpu = time.process_time() - t0
    print(f"irregular sea Hs {a.Hs:g} m, Tp {a.Tp:g} s, wind {a.wind:g} m/s: build "
          f"{build:.1f} s (derive + compile + settle)")
    print(f"  {a.duration:g} s simulated in {cpu:.2f} CPU s: {a.duration / cpu:.0f}x faster "
          f"than real time (success {res.success}); an hour at this rate: "
          f"{3600 * cpu / a.duration:.1f} CPU s (scaled)" if a.duration != 3600 else
          f"  3600 s simulated in {cpu:.2f} CPU s: {3600 / cpu:.0f}x faster than real time")
    top = oc3_outputs(d, model)["top_displacement"][0]
    print(f"  std of tower-top displacement {np.std(top @ res.y):.3f} m")

    t0 = time.perf_counter()
    dl, ml, yl, A, B, r = _linear("c", tower_modes=2, drag=True)
    build = time.perf_counter() - t0
    C = np.array([oc3_outputs(dl, ml)[k][0] for k in ("surge", "pitch", "top_displacement")])
    t0 = time.process_time()
    linear_rao(A, B, lambda T: wave_input_phasor(dl, r, T), C,
               np.linspace(4.0, 40.0, a.points))
    cpu = time.process_time() - t0
    print(f"linear RAO sweep, {a.points} periods: {cpu:.3f} CPU s (linear model build "
          f"{build:.1f} s)")


if __name__ == "__main__":
    main()
