"""The standalone C export against the compiled module and Pinocchio's ``aba``, same run.

``chain3d`` (the spatial chain; Pinocchio's twin from :func:`_peers.pinocchio_chain`)
at n = 10, 30 and 100 (``--sizes``), at a random state, built with ``style="positions"``
(as ``bench_large.py`` and ``bench_numerics.py`` build it: the same equations; the
default ``"v2pt"`` has SymPy multiply out direction cosines while the model is built,
which did not finish in 25 minutes at n = 100):

- the standalone file of ``model.c_source()`` (what ``kanedyn derive MODEL
  --c`` writes), compiled with ``cc -O2 -shared -fPIC`` and the instruction
  flags kanedyn builds its own modules with (``-mavx`` on an x86-64 CPU with
  AVX, as its header advises), called from C in a loop of 1000 calls (so no
  Python in the time);
- the compiled module's ``model.rhs`` (from Python);
- ``pinocchio.aba`` (from Python);
- ``pinocchio::aba`` called from a C++ loop on the same model at the same
  state (:mod:`_pinocchio_cpp`: compiled once per run against the pin wheel's
  headers, its algorithms compiled there with -O3 and the instruction flags
  above, or with ``--pinocchio-cpp wheel`` the wheel's compiled ones; timed in
  its own rounds after the others; its largest difference from the Python
  binding's accelerations is printed).  Without pinocchio, or where the program
  does not compile, its column says "n/a" and the reason is printed once.

Timings interleaved in rounds (:func:`_timing.interleaved`, thread CPU time);
minimum and spread (median / min - 1).  The largest difference of the state
derivatives is printed too.

Usage::

    python benchmarks/bench_c_export.py [--sizes 10 30 100] [--rounds 7]
        [--pinocchio-cpp here|wheel]
"""

from __future__ import annotations

import argparse
import ctypes
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import kanedyn as kd  # noqa: E402
from _peers import DEFAULTS, pinocchio_chain  # noqa: E402
from _pinocchio_cpp import add_option, announced  # noqa: E402
from _timing import interleaved, optimized_modules_only  # noqa: E402
from kanedyn.numerics.backends._c_build import _VEX  # noqa: E402
from bench_numerics import machine_info  # noqa: E402

#: appended to the exported file: the calls timed in C
_LOOP = r"""
int kanedyn_bench(int calls, const double *y, const double *p, double *ydot) {
    int status = 0;
    for (int k = 0; k < calls; ++k) status |= kanedyn_rhs(0.0, y, p, NULL, ydot);
    return status;
}
"""
CALLS = 1000


def exported(model, folder):
    """The model's standalone file compiled as a library (ctypes)."""
    source = Path(folder) / "model.c"
    source.write_text(model.c_source() + _LOOP)
    library = Path(folder) / "libmodel.so"
    cc = shutil.which("cc") or shutil.which("gcc")
    subprocess.run([cc, "-O2", *_VEX, "-shared", "-fPIC", "-std=c99", str(source), "-o",
                    str(library), "-lm"], check=True)
    lib = ctypes.CDLL(str(library))
    vec = ctypes.POINTER(ctypes.c_double)
    lib.kanedyn_bench.argtypes = [ctypes.c_int, vec, vec, vec]
    lib.kanedyn_bench.restype = ctypes.c_int
    return lib, vec


def measure(n, rounds, folder, cpp=None):
    Path(folder).mkdir()
    import pinocchio as pin

    model = kd.models.build("chain3d", n=n, style="positions").numeric(constants=DEFAULTS,
                                                                        backend="c")
    pmodel, pdata = pinocchio_chain(n)
    rng = np.random.default_rng(2)
    y = rng.uniform(-1.5, 1.5, 2 * n)
    q, u, tau = y[:n], y[n:], np.zeros(n)
    p = np.array(list(model.constants.values()), dtype=float)
    lib, vec = exported(model, folder)
    out = np.zeros(2 * n)

    def export():
        return lib.kanedyn_bench(CALLS, y.ctypes.data_as(vec), p.ctypes.data_as(vec),
                                 out.ctypes.data_as(vec))
    assert export() == 0
    difference = float(np.max(np.abs(out - model.rhs(0.0, y))))
    times = interleaved({"export": export, "module": lambda: model.rhs(0.0, y),
                         "pinocchio": lambda: pin.aba(pmodel, pdata, q, u, tau)},
                        rounds=rounds)
    times["export"].times = [t / CALLS for t in times["export"].times]
    in_cpp = None if cpp is None else cpp.run(pmodel, q, u, tau, rounds)
    return times, difference, in_cpp


def main():
    optimized_modules_only()  # the module timed is gcc's, not TinyCC's first one
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 30, 100])
    parser.add_argument("--rounds", type=int, default=7)
    add_option(parser)
    args = parser.parse_args()
    print(machine_info())
    with tempfile.TemporaryDirectory() as folder:
        cpp = announced(folder, args.pinocchio_cpp)
        print("\n| chain3d n | standalone export (C loop), us | compiled module rhs, us | "
              "Pinocchio aba (Python), us | Pinocchio aba in C++, us | export / module | "
              "export / Pinocchio (Python) | export / Pinocchio C++ | largest difference "
              "(export - module; C++ - Python aba) |")
        print("|---|---|---|---|---|---|---|---|---|")
        for n in args.sizes:
            times, difference, in_cpp = measure(n, args.rounds, Path(folder) / str(n), cpp)
            e, m, b = times["export"], times["module"], times["pinocchio"]
            if in_cpp is None:
                c_text, c_ratio, c_difference = "n/a", "n/a", "n/a"
            else:
                c = in_cpp.aba
                c_text = f"{1e6 * c.best:.2f} (spread {c.spread:.0%})"
                c_ratio = f"{e.best / c.best:.2f}"
                c_difference = f"{in_cpp.difference:.1e}"
            print(f"| {n} | {1e6 * e.best:.2f} (spread {e.spread:.0%}) | {1e6 * m.best:.2f} "
                  f"(spread {m.spread:.0%}) | {1e6 * b.best:.2f} (spread {b.spread:.0%}) | "
                  f"{c_text} | {e.best / m.best:.2f} | {e.best / b.best:.2f} | {c_ratio} | "
                  f"{difference:.1e}; {c_difference} |")


if __name__ == "__main__":
    main()
