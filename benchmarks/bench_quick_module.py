"""What the module from the quick compiler costs at run time, before its swap.

A model's first module comes from TinyCC when it is installed (see
``kanedyn.numerics.backends._c_quick``) and is used until gcc's optimized module
replaces it.  For chain3d (style="positions") at each size, both modules of the
same model in one process: one ``rhs`` call from Python, and the compiled loop
over 1 s of motion (RK45, the model's integrate entry point), interleaved in
rounds, minima of thread CPU time with their spreads; then TinyCC's loop once
its module has adopted gcc's code (as the optimized build makes it do, for a
run under way).

    python benchmarks/bench_quick_module.py [--sizes 3,10,30] [--rounds 7]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile

import numpy as np

# _timing lives next to this script (on sys.path when the script is run directly)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _timing import interleaved, ratio_text  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="3,10,30")
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args(argv)
    os.environ["KANEDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="kanedyn-bench-quick-")
    import kanedyn as kd
    from kanedyn.numerics.backends import _c_build, _c_quick
    if _c_quick.quick_command() is None:
        raise SystemExit("no quick compiler: install TinyCC (apt install tcc)")
    # the quick module alone: no optimized build takes its code over during the timings
    _c_build.optimize_later = lambda module, build: None
    print("| n | rhs, TinyCC µs | rhs, gcc µs | ratio | 1 s on the compiled loop, TinyCC ms "
          "| gcc ms | ratio | TinyCC's loop on gcc's code (adopted) ms | ratio to gcc |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in (int(x) for x in args.sizes.split(",")):
        d = kd.models.build("chain3d", n=n, style="positions")
        eom = d.derive()
        quick_before = _c_quick.QUICK_STATS["quick"]
        quick = d.numeric(eom, backend="c")
        if _c_quick.QUICK_STATS["quick"] != quick_before + 1:
            raise SystemExit(f"n = {n}: the first module did not come from the quick compiler")
        _c_build._LOADED.clear()
        os.environ["KANEDYN_QUICK_CC"] = ""
        optimized = d.numeric(eom, backend="c")
        del os.environ["KANEDYN_QUICK_CC"]
        y = d.initial(quick) + 0.1
        t_eval = np.linspace(0.0, 1.0, 101)
        atol = np.full(quick.n_states, 1e-8)

        def run(c):
            # the compiled loop as kd.simulate calls it for RK45, no events
            return lambda: c.integrate(0.0, 1.0, y, t_eval, 1e-6, atol, np.inf, 0.0, "RK45",
                                       None, 1e-8, False)

        rhs = interleaved({"tcc": lambda: quick._c.rhs(0.0, y),
                           "gcc": lambda: optimized._c.rhs(0.0, y)}, rounds=args.rounds)
        loop = interleaved({"tcc": run(quick._c), "gcc": run(optimized._c)},
                           rounds=args.rounds, min_time=0.2)
        quick._module._adopt(optimized._module._entry)  # what the optimized build does
        adopted = interleaved({"adopted": run(quick._c), "gcc": run(optimized._c)},
                              rounds=args.rounds, min_time=0.2)
        print(f"| {n} | {rhs['tcc'].best * 1e6:.2f} | {rhs['gcc'].best * 1e6:.2f} | "
              f"{ratio_text(rhs['tcc'], rhs['gcc'])} | {loop['tcc'].best * 1e3:.2f} | "
              f"{loop['gcc'].best * 1e3:.2f} | {ratio_text(loop['tcc'], loop['gcc'])} | "
              f"{adopted['adopted'].best * 1e3:.2f} | "
              f"{ratio_text(adopted['adopted'], adopted['gcc'])} |", flush=True)


if __name__ == "__main__":
    main()
