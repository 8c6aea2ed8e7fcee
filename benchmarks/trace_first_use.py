"""Where a cold first use goes: a timeline of one fresh process.

The same path as ``bench_first_use.py`` (chain3d, style="positions", an empty
cache directory, build -> ``numeric(backend="c")`` -> first ``rhs``), with the
clock read at every stage (the imports of NumPy, SymPy and
``sympy.physics.mechanics``, the model's definition, the derivation, each
translation unit as the code generation hands it over, the optimized module
taking the quick one's place) and every compiler run's start and end (the quick
compiler's: the generic runtime's alone while the model is derived, then the
module's; without it the optimizing compiler's prefetched generic runtime's; a
run's end is when the build first sees it ended).  Seconds from before
``import numpy``, wall time and the process's own CPU time (which a loaded
machine inflates far less; the compilers' CPU is not in it).  The machine is
shared: compare traces of one hour only.

    python benchmarks/trace_first_use.py [--n 10] [--repeat 1] [--no-quick]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile

# _fresh_process lives next to this script (on sys.path when the script is run directly)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _fresh_process import byte_compile_package, run_python  # noqa: E402

CHILD = """
import json, subprocess, time
from pathlib import Path
t0 = time.perf_counter()
marks, runs, cpu = [], [], []
c0 = time.process_time()
def mark(what):
    marks.append((time.perf_counter() - t0, what))
    cpu.append(time.process_time() - c0)
import numpy
mark("import numpy")
import sympy
mark("import sympy")
import kanedyn as kd
import sympy.physics.mechanics
mark("import kanedyn, sympy.physics.mechanics")
from kanedyn.numerics.backends import _c, _c_build
from kanedyn.numerics.backends._c_quick import quick_command

class Run(subprocess.Popen):
    # a compiler run: its start, and its end when the build first sees it ended
    def __init__(self, cmd, *args, **kwargs):
        super().__init__(cmd, *args, **kwargs)
        sources = [part for part in cmd if part.endswith(".c")]
        flags = [part for part in cmd if part in ("-O0", "-O1", "-O2")]
        what = "link" if not sources else (
            f"quick compiler ({{Path(cmd[0]).name}}), prefetched: {{Path(sources[0]).name}}"
            if cmd[0] == (quick_command() or [None])[0] and "-c" in cmd else
            f"quick compiler ({{Path(cmd[0]).name}}): {{len(sources)}} units"
            if cmd[0] == (quick_command() or [None])[0] else
            ("prefetched " if "prefetch-" in sources[0] else "")
            + Path(sources[0]).name + " " + " ".join(flags))
        self.record = [time.perf_counter() - t0, None, what]
        runs.append(self.record)
    def poll(self):
        code = super().poll()
        if code is not None and self.record[1] is None:
            self.record[1] = time.perf_counter() - t0
        return code
    def wait(self, *args, **kwargs):
        code = super().wait(*args, **kwargs)
        if self.record[1] is None:
            self.record[1] = time.perf_counter() - t0
        return code

subprocess.Popen = Run
d = kd.models.build("chain3d", n={n}, style="positions")
mark("model defined")
derive = type(d).derive
def timed_derive(self, *args, **kwargs):
    mark("derivation starts")
    try:
        return derive(self, *args, **kwargs)
    finally:
        mark("derivation ends")
type(d).derive = timed_derive
units = _c.generate_c_units
def timed_units(*args, **kwargs):
    mark("code generation starts")
    for k, unit in enumerate(units(*args, **kwargs)):
        level = _c_build.unit_flags(unit)[0]
        defined = [line.split("(")[0].split()[-1].lstrip("*") for line in unit.splitlines()
                   if line.startswith(("KD_GEN", "static")) and line.rstrip().endswith("{{")
                   and "kd_powi" not in line and "kd_sign" not in line]
        mark(f"unit{{k}} generated: {{len(unit)}} characters, {{level}}, "
             f"defines {{', '.join(defined[:2])}}{{', ...' if len(defined) > 2 else ''}}")
        yield unit
    mark("code generation ends")
_c.generate_c_units = timed_units
m = d.numeric(backend="c")
mark("module loaded")
m.rhs(0.0, d.initial(m))
mark("first rhs")
first = m._module
kd.numerics.finish_compiling()
if m._module is not first:
    mark("optimized module in use")
print(json.dumps([marks, runs, cpu]))
"""


def trace(n, quick=None, cpu=False):
    """``(marks, runs)`` of one cold process: ``(s, stage)`` and
    ``[start s, end s, unit]`` per compiler run; ``quick=False``: without the
    quick compiler (see :func:`_fresh_process.run_python`); ``cpu=True``: also
    the process's CPU time at each mark, s (its compilers' not counted)."""
    with tempfile.TemporaryDirectory() as cache:
        proc = run_python(CHILD.format(n=n), cache, quick=quick)
    if proc.returncode != 0:
        raise SystemExit(proc.stderr[-3000:])
    marks, runs, used = json.loads(proc.stdout.strip().splitlines()[-1])
    return (marks, runs, used) if cpu else (marks, runs)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--no-quick", action="store_true",
                        help="without the quick compiler (KANEDYN_QUICK_CC empty)")
    args = parser.parse_args(argv)
    byte_compile_package()
    for k in range(args.repeat):
        marks, runs, used = trace(args.n, quick=False if args.no_quick else None, cpu=True)
        print(f"chain3d n = {args.n}, cold, trace {k + 1} (wall s, this process's CPU s)")
        for (at, stage), cpu in zip(marks, used):
            print(f"  {at:6.3f} s  {cpu:6.3f} s  {stage}")
        busy = 0.0
        for start, end, what in sorted(runs):
            end = end if end is not None else float("nan")
            busy += end - start
            print(f"  {start:6.3f} -> {end:6.3f} s  ({end - start:5.3f} s)  compiler: {what}")
        print(f"  compiler runs: {len(runs)}, {busy:.2f} s in all (two at a time at most)")


if __name__ == "__main__":
    main()
