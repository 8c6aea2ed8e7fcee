"""Time to first use: a built-in model to its first compiled evaluation.

For chain3d (style="positions") at n = 10, 30, 60, 100: cold (a fresh process and
an empty cache directory via XDG_CACHE_HOME, so the model is derived and the
C compiled) and warm (a second fresh process, same model and cache), each the
wall time of ``build -> numeric(backend="c") -> rhs`` inside the process
(``kd.models.build`` with its default options, as a user calls it; the cold and
the warm process's own CPU time to that point too, counted from the interpreter's
start, its compilers' not counted, which a loaded machine inflates less)
(interpreter start-up excluded, ``import kanedyn`` and the SymPy and NumPy it
imports included), and for the warm process also to the end of a first
``kd.simulate`` over 1 s; the cold time is also given after the imports of
NumPy and SymPy (which a script writing its model with SymPy makes first, and
which Pinocchio's figure leaves out too: it is timed after ``import
pinocchio``); Pinocchio's Model + Data construction for the same chain as the
peer when installed.
With TinyCC installed the cold process's first module comes from it (see
``kanedyn.numerics.backends._c_quick``) and the optimized one is built meanwhile:
the table gives the time to the first evaluation, to the optimized module in use
(``kd.numerics.finish_compiling()`` after a 1 s simulation), and, in a cold
process of its own, the first evaluation with the optimizing compiler alone.
The machine is shared: run with ``--repeat`` and read the minima.

The warm process is also timed with ``build(..., lazy=False)`` (the definition's
SymPy objects built, as the default did before), and with ``--user`` users' models
are timed too: a URDF tree read with ``from_urdf`` and chain3d written as a user's
own ``ModelDefinition``, warm from the description's digest against warm derived
again (the compiled module in the cache either way).

``--before SRC`` times only the cold process, of the package in the source folder
``SRC`` (a clone of the repository at the commit before a change) and of this
checkout's, in turns, and gives the minimum and median of each.

    python benchmarks/bench_first_use.py [--sizes 10,30,60,100] [--repeat 1] [--user]
    python benchmarks/bench_first_use.py --sizes 10 --repeat 9 --before ../before/src
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile

# _fresh_process lives next to this script (on sys.path when the script is run directly)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _fresh_process import SRC, byte_compile_package, run_python  # noqa: E402

CHILD = """
import json, time
t0 = time.perf_counter()
import kanedyn as kd
from kanedyn.models._base import DERIVE_STATS
from kanedyn.numerics import COMPILE_STATS
from kanedyn.numerics.backends._c_quick import QUICK_STATS
{imports}
t_imports = time.perf_counter() - t0
d = kd.models.build("chain3d", n={n}, style="positions"{eager})
m = d.numeric(backend="c")
m.rhs(0.0, d.initial(m))
t_rhs = time.perf_counter() - t0
cpu_rhs = time.process_time()
kd.simulate(m, (0.0, 1.0), d.initial(m))
t_run = time.perf_counter() - t0
kd.numerics.finish_compiling()
t_optimized = time.perf_counter() - t0 if QUICK_STATS["quick"] else t_rhs
print(json.dumps([t_rhs, DERIVE_STATS["derivations"], COMPILE_STATS["compiles"],
                  t_run, t_imports, t_optimized, QUICK_STATS["quick"], cpu_rhs]))
"""
#: what a script that writes its model with SymPy imports before it (in the cold
#: process only: the warm one imports neither)
MODEL_IMPORTS = "import numpy, sympy, sympy.physics.mechanics"

PEER = """
import json, time
import numpy as np
import pinocchio as pin
t0 = time.perf_counter()
model = pin.Model()
parent = 0
for i in range({n}):
    axis = pin.JointModelRZ() if i % 2 == 0 else pin.JointModelRX()
    place = pin.SE3(np.eye(3), np.array([0.0, 0.5 if i else 0.0, 0.0]))
    parent = model.addJoint(parent, axis, place, f"j{{i}}")
    inertia = pin.Inertia(1.0, np.array([0.0, 0.25, 0.0]), np.diag([0.025, 0.005, 0.025]))
    model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
data = model.createData()
pin.aba(model, data, np.zeros({n}), np.zeros({n}), np.zeros({n}))
print(json.dumps([time.perf_counter() - t0]))
"""


#: a user's model in a fresh process: the humanoid URDF tree (30 bodies) read with
#: ``from_urdf``, or chain3d written as a user's own ModelDefinition; ``{numeric}``
#: either ``d.numeric(backend="c")`` (the description's digest finds the derivation
#: cache's entry) or ``d.numeric(d.derive(), backend="c")`` (derived again, the
#: compiled module found in the cache: what a warm start did before the digest)
USER = """
import json, sys, time
t0 = time.perf_counter()
import kanedyn as kd
import sympy, sympy.physics.mechanics
from kanedyn.models._base import DERIVE_STATS
from kanedyn.models._fingerprint import description_fingerprint
t_imports = time.perf_counter() - t0
if {urdf!r}:
    d = kd.models.from_urdf({urdf!r}, efforts=False)
else:
    b = kd.models.chain3d(n={n}, style="positions")
    d = kd.models.ModelDefinition(name="my chain", title="a user's chain", kane_args=b.kane_args,
                                  constants=b.constants, initial_state=b.initial_state, t_end=1.0)
t_model = time.perf_counter() - t0
description_fingerprint(d)
t_digest = time.perf_counter() - t0 - t_model
m = {numeric}
m.rhs(0.0, d.initial(m))
t_rhs = time.perf_counter() - t0
print(json.dumps([t_rhs, DERIVE_STATS["derivations"], t_imports, t_model, t_digest]))
"""


def user_models(repeat):
    """The table of users' models: cold, warm derived again, warm from the digest."""
    from _peers import humanoid_urdf
    print("\n| user's model | cold s | warm, derived again (the module cached) s | warm, "
          "from the description's digest s | of which imports / building the SymPy objects "
          "/ the digest s | derivations warm again/digest |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        urdf = os.path.join(folder, "humanoid30.urdf")
        with open(urdf, "w") as handle:
            handle.write(humanoid_urdf())
        for label, urdf_path, n in (("chain3d n = 10, a user's ModelDefinition", "", 10),
                                    ("humanoid URDF, 30 bodies", urdf, 0)):
            cold, again, digest = [], [], []
            for _ in range(repeat):
                with tempfile.TemporaryDirectory() as cache:
                    new = USER.format(urdf=urdf_path, n=n, numeric='d.numeric(backend="c")')
                    old = USER.format(urdf=urdf_path, n=n,
                                      numeric='d.numeric(d.derive(), backend="c")')
                    cold.append(child(new, cache))
                    child(old, cache)  # its module (without the cache's M) compiled once
                    for _ in range(2):  # interleaved
                        again.append(child(old, cache))
                        digest.append(child(new, cache))
            best = min(digest, key=lambda row: row[0])
            print(f"| {label} | {min(r[0] for r in cold):.2f} | {min(r[0] for r in again):.2f} "
                  f"| {best[0]:.2f} | {best[2]:.2f} / {best[3] - best[2]:.2f} / {best[4]:.3f} "
                  f"| {again[-1][1]}/{digest[-1][1]} |", flush=True)


def child(code, cache, quick=None, src=SRC):
    proc = run_python(code, cache, quick=quick, src=src)
    if proc.returncode != 0:
        return None
    return json.loads(proc.stdout.strip().splitlines()[-1])


def before_and_after(sizes, repeat, before):
    """The cold process of the code in the source folder ``before`` and of this
    checkout's, in turns (the first by turns), each in an empty cache: the table
    of their minima and medians."""
    byte_compile_package(before)
    print(f"\ncold, the code in {before} (before) and this checkout's (after), "
          f"in turns, {repeat} rounds; minimum (median)")
    print("\n| n | code | cold s | cold, its CPU s | cold after importing NumPy and SymPy s |")
    print("|---|---|---|---|---|")
    for n in sizes:
        rows = {before: [], SRC: []}
        for k in range(repeat):
            for src in ((before, SRC) if k % 2 == 0 else (SRC, before)):
                with tempfile.TemporaryDirectory() as cache:
                    row = child(CHILD.format(n=n, imports=MODEL_IMPORTS, eager=""), cache,
                                src=src)
                if row is None:
                    print(f"(a run of {src} at n = {n} failed: left out)", flush=True)
                else:
                    rows[src].append(row)
        for label, src in (("before", before), ("after", SRC)):
            columns = [[r[0] for r in rows[src]], [r[7] for r in rows[src]],
                       [r[0] - r[4] for r in rows[src]]]
            print(f"| {n} | {label} | " + " | ".join(
                f"{min(c):.3f} ({statistics.median(c):.3f})" for c in columns) + " |",
                flush=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10,30,60,100")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--user", action="store_true",
                        help="also users' models (a URDF tree, a user's ModelDefinition)")
    parser.add_argument("--before", metavar="SRC",
                        help="only the cold process, of the package in the source folder "
                             "SRC (a checkout of the code before a change) and of this "
                             "checkout's, in turns")
    args = parser.parse_args(argv)
    byte_compile_package()
    if args.before:
        before_and_after([int(x) for x in args.sizes.split(",")], args.repeat,
                         os.path.abspath(args.before))
        return
    print("| n | cold s | cold, its CPU s | cold after importing NumPy and SymPy s | cold to "
          "the optimized module s | cold, optimizing compiler only s | warm s | warm to a 1 s "
          "simulation s | warm, its CPU s | warm with build(lazy=False) s "
          "| derivations cold/warm | compiles cold/warm | quick builds cold/warm "
          "| Pinocchio Model+Data s (after its import) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in (int(x) for x in args.sizes.split(",")):
        cold, slow, warm, eager = [], [], [], []
        for k in range(args.repeat):  # the two kinds of cold process in turn, first by turns
            for quick in ((None, False) if k % 2 == 0 else (False, None)):
                with tempfile.TemporaryDirectory() as cache:
                    c = child(CHILD.format(n=n, imports=MODEL_IMPORTS, eager=""), cache, quick)
                    if quick is False:
                        slow.append(c)
                        continue
                    cold.append(c)
                    warm.append(child(CHILD.format(n=n, imports="", eager=""), cache))
                    eager.append(child(CHILD.format(n=n, imports="", eager=", lazy=False"),
                                       cache))
        peer = child(PEER.format(n=n), tempfile.gettempdir())

        def least(rows, k):
            return f"{min(row[k] for row in rows):.3f}"

        print(f"| {n} | {least(cold, 0)} | {least(cold, 7)} | "
              f"{min(c[0] - c[4] for c in cold):.3f} | "
              f"{least(cold, 5)} | {least(slow, 0)} | {least(warm, 0)} | {least(warm, 3)} | "
              f"{least(warm, 7)} | {least(eager, 0)} | "
              f"{cold[-1][1]}/{warm[-1][1]} | {cold[-1][2]}/{warm[-1][2]} | "
              f"{cold[-1][6]}/{warm[-1][6]} | "
              f"{f'{peer[0]:.4f}' if peer else '-'} |", flush=True)
    if args.user:
        user_models(args.repeat)


if __name__ == "__main__":
    main()
