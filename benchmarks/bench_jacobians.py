"""Exact derivatives of the dynamics: kanedyn's ``model.jacobians`` vs Pinocchio's
``computeABADerivatives``, same run.

Robots of ``example-robot-data`` (fixed base, both read from the same URDF
text): the Panda arm with its two finger joints made fixed (n = 7) and Solo12
(n = 12), the joint torques ``tau`` their inputs on both sides; and the
spatial chain ``chain3d`` (the same chain in Pinocchio's terms from
:func:`_peers.pinocchio_chain`) at n = 7, 12, 30 (and 100 with ``--large``),
without inputs on kanedyn's side.  Compiled (backend ``"c"``), at a random
state:

- ``model.jacobians(0.0, y, r=tau)`` (the robots) or ``model.jacobians(0.0,
  y)`` (the chain): the full :math:`\\partial f/\\partial y` (kinematic rows
  included) and :math:`\\partial f/\\partial\\tau`, called for one state from
  Python, and for 1000 states in one call (per state);
- the same derivatives from the standalone C file of
  ``model.c_source(jacobians=True)`` (what ``kanedyn derive MODEL --c FILE
  --jacobians`` writes: ``kanedyn_jacobians``, no Python), compiled with the
  flags kanedyn compiles its own modules with (``-O2``, ``-mavx`` on an x86-64
  CPU with AVX, ``-fno-math-errno -ffp-contract=off``) and called in a C loop
  of 1000 calls: the call to set beside Pinocchio's from C++;
- ``pinocchio.computeABADerivatives(model, data, q, v, tau)`` from Python:
  :math:`\\partial\\ddot q/\\partial(q, v, \\tau)`;
- ``pinocchio::computeABADerivatives`` called from a C++ loop on the same
  Pinocchio model at the same state (:mod:`_pinocchio_cpp`: compiled once per
  run against the pin wheel's headers, its algorithms compiled there with -O3
  and the instruction flags of kanedyn's modules, or with ``--pinocchio-cpp
  wheel`` the wheel's compiled ones; the model passed across as numbers; timed
  in its own rounds after the others; its largest difference from the Python
  binding's is printed).  Without pinocchio, or where the program does not
  compile, its column says "n/a" and the reason is printed once.  kanedyn's
  figure is a call from Python; this one is a call from C++;
- the largest difference of :math:`\\partial\\dot u/\\partial(q, u)` between them;
- the size of the generated derivative code (its operations, after common
  subexpressions) and the exponent of its growth with n;
- the time of the first call (generation and compilation: the quick compiler's
  module, gcc's built in the background) against that of the first right-hand
  side (derivation, generation, the first module), in a fresh process with a
  fresh cache, with the CPU time of each (the process's, and its compiler
  children's) and the load average before the run.

Timings interleaved in rounds (:func:`_timing.interleaved`, thread CPU time);
minimum, median and spread (median / min - 1).  Ratios are between numbers
measured in this run (of the minima, and of the medians).

Usage::

    python benchmarks/bench_jacobians.py [--sizes 7 12 30] [--large] [--rounds 7]
        [--style v2pt|positions]
        [--no-robots] [--no-first-use | --first-use-only] [--pinocchio-cpp here|wheel]
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import kanedyn as kd  # noqa: E402
from _fresh_process import byte_compile_package, run_python  # noqa: E402
from _peers import DEFAULTS, pinocchio_chain  # noqa: E402
from _pinocchio_cpp import add_option, announced  # noqa: E402
from _timing import interleaved  # noqa: E402
from bench_numerics import machine_info  # noqa: E402
from kanedyn.numerics.backends._c_build import _VEX  # noqa: E402

#: appended to the exported file: the calls timed in C
_LOOP = r"""
int kanedyn_bench(int calls, const double *y, const double *p, const double *r,
                  double *ydot, double *jacobian) {
    int status = 0;
    for (int k = 0; k < calls; ++k)
        status |= kanedyn_jacobians(0.0, y, p, r, ydot, jacobian, NULL);
    return status;
}
"""
CALLS = 1000


def exported(model, folder):
    """``kanedyn_bench`` of the model's standalone file with the exact derivatives,
    compiled as a library (ctypes) with the flags of kanedyn's own modules."""
    folder = Path(tempfile.mkdtemp(dir=folder))
    source = folder / "model.c"
    source.write_text(model.c_source(jacobians=True) + _LOOP)
    library = folder / "libmodel.so"
    cc = shutil.which("cc") or shutil.which("gcc")
    subprocess.run([cc, "-O2", *_VEX, "-fno-math-errno", "-ffp-contract=off", "-shared",
                    "-fPIC", "-std=c99", str(source), "-o", str(library), "-lm"], check=True)
    lib = ctypes.CDLL(str(library))
    vec = ctypes.POINTER(ctypes.c_double)
    lib.kanedyn_bench.argtypes = [ctypes.c_int, vec, vec, vec, vec, vec]
    lib.kanedyn_bench.restype = ctypes.c_int
    return lib, vec


_FIRST_USE = """
import time, json, resource, numpy as np, kanedyn as kd
from _peers import DEFAULTS
def cpu():
    return [sum(getattr(resource.getrusage(who), f) for f in ("ru_utime", "ru_stime"))
            for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
start, before = time.perf_counter(), cpu()
model = kd.models.build("chain3d", n={n}, style={style!r}).numeric(constants=DEFAULTS,
                                                                  backend="c")
model.rhs(0.0, np.zeros({x}))
rhs, middle = time.perf_counter() - start, cpu()
if {after_build}:
    kd.numerics.finish_compiling()
    middle = cpu()
start = time.perf_counter()
model.jacobians(0.0, np.zeros({x}))
jac, after = time.perf_counter() - start, cpu()
print(json.dumps([rhs, jac, [b - a for a, b in zip(before, middle)],
                  [b - a for a, b in zip(middle, after)]]))
"""


def first_use(n, style="v2pt", after_build=False):
    """Seconds of the first rhs (derivation, generation and the first module
    included) and then of the first jacobians call, in a fresh process with a
    fresh cache; then the CPU seconds of each, ``[process, compiler children
    it waited for]`` (the optimized build of the rhs runs in the background
    meanwhile: its gcc counts in the children of the jacobians call).  With
    ``after_build`` the jacobians call waits for that build to end first
    (``kd.numerics.finish_compiling()``, not timed), so that it does not share
    the CPU with the rhs's gcc."""
    with tempfile.TemporaryDirectory() as cache:
        code = f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})\n" \
            + _FIRST_USE.format(n=n, x=2 * n, style=style, after_build=after_build)
        done = run_python(code, cache)
        if done.returncode:
            raise RuntimeError(done.stderr[-2000:])
        return json.loads(done.stdout.strip().splitlines()[-1])


def operations(n, style="v2pt"):
    """Operations of the generated derivative code (after common subexpressions)."""
    from kanedyn.numerics._jacobians import _specification
    model = kd.models.build("chain3d", n=n, style=style).numeric(constants=DEFAULTS,
                                                                backend="numpy")
    prog, _, outputs = _specification(model, False)
    return prog.count_ops([e for _, exprs in outputs for e in exprs], cse=True)


#: the robots of example-robot-data: URDF file, joints made fixed
ROBOTS = {"Panda": ("panda_description/urdf/panda.urdf",
                    ("panda_finger_joint1", "panda_finger_joint2")),
          "Solo12": ("solo_description/robots/solo12.urdf", ())}


def robot_text(name):
    """The URDF text of a robot of :data:`ROBOTS` with its listed joints made
    fixed (their ``mimic`` elements dropped), or ``None`` without
    example-robot-data."""
    import xml.etree.ElementTree as ET
    from importlib.metadata import PackageNotFoundError, distribution
    try:
        robots = distribution("example-robot-data").locate_file(
            "cmeel.prefix/share/example-robot-data/robots")
    except PackageNotFoundError:
        return None
    relative, fixed = ROBOTS[name]
    root = ET.parse(Path(robots) / relative).getroot()
    for joint in root.iter("joint"):
        if joint.get("name") in fixed:
            joint.set("type", "fixed")
            for mimic in joint.findall("mimic"):
                joint.remove(mimic)
    return ET.tostring(root, encoding="unicode")


def robot_models(name, folder):
    """``(model, pinocchio model, data, speeds, efforts)`` of a robot: kanedyn's
    model (C), Pinocchio's from the same text, the Pinocchio speed index of each
    of kanedyn's joints and the input index of each joint's torque."""
    from _peers import pinocchio_urdf
    text = robot_text(name)
    path = Path(folder) / f"{name}.urdf"
    path.write_text(text)
    definition = kd.models.from_urdf(path)
    model = definition.numeric(backend="c")
    pmodel, pdata = pinocchio_urdf(text)
    speeds = [pmodel.joints[pmodel.getJointId(j.name)].idx_v for j in definition.joints]
    if pmodel.nq != pmodel.nv or sorted(speeds) != list(range(pmodel.nv)):
        raise RuntimeError(f"{name}: a joint Pinocchio does not count as kanedyn does")
    efforts = [model.input_names.index(str(j.effort_input)) for j in definition.joints]
    return model, pmodel, pdata, speeds, efforts


def measure(n, rounds, robot=None, folder=None, style="v2pt", cpp=None):
    """Timings of kanedyn (one state, 1000 states, the standalone file from C)
    and Pinocchio, and the largest differences of the derivatives (kanedyn's
    from Pinocchio's, the file's from kanedyn's), for ``chain3d`` at n or for
    ``robot``; with
    ``cpp`` (:class:`_pinocchio_cpp.PinocchioCpp`) also Pinocchio in C++
    (``None`` without it)."""
    import pinocchio as pin

    rng = np.random.default_rng(2)
    if robot is None:
        model = kd.models.build("chain3d", n=n, style=style).numeric(constants=DEFAULTS,
                                                                    backend="c")
        pmodel, pdata = pinocchio_chain(n)
        speeds, efforts = list(range(n)), []
    else:
        model, pmodel, pdata, speeds, efforts = robot_models(robot, folder)
        n = len(speeds)
    q, u = rng.uniform(-1.5, 1.5, (2, n))
    tau = rng.uniform(-1.0, 1.0, n) if efforts else np.zeros(n)
    y = np.concatenate([q, u])
    r = np.zeros(len(model.input_names))
    r[efforts] = tau[:len(efforts)]
    qp, vp, tp = (np.zeros(pmodel.nv) for _ in range(3))
    qp[speeds], vp[speeds], tp[speeds] = q, u, tau
    if efforts:
        def one():
            return model.jacobians(0.0, y, r=r)
    else:
        def one():
            return model.jacobians(0.0, y)
    J = one()
    # the derivative module comes from the quick compiler first: gcc's code is timed
    kd.numerics.finish_compiling()
    dq, dv, _ = pin.computeABADerivatives(pmodel, pdata, qp, vp, tp)
    pick = np.ix_(speeds, speeds)
    error = max(np.max(np.abs(J.state[n:, :n] - dq[pick])),
                np.max(np.abs(J.state[n:, n:] - dv[pick])))
    lib, vec = exported(model, folder)
    p = np.array(list(model.constants.values()), dtype=float)
    f_out, D_out = np.zeros(2 * n), np.zeros((2 * n, 2 * n + len(r)))
    arguments = [a.ctypes.data_as(vec) if a.size else None for a in (y, p, r, f_out, D_out)]

    def export():
        return lib.kanedyn_bench(CALLS, *arguments)
    assert export() == 0
    export_difference = float(np.max(np.abs(D_out[:, :2 * n] - J.state)))
    states = rng.uniform(-1.5, 1.5, (1000, 2 * n))
    inputs = np.broadcast_to(r, (len(states), len(r)))
    times = interleaved({
        "kanedyn": one,
        "export": export,
        "batch": lambda: model.jacobians(np.zeros(len(states)), states,
                                         r=inputs if efforts else None),
        "pinocchio": lambda: pin.computeABADerivatives(pmodel, pdata, qp, vp, tp)},
        rounds=rounds)
    times["batch"].times = [x / len(states) for x in times["batch"].times]
    times["export"].times = [x / CALLS for x in times["export"].times]
    in_cpp = None if cpp is None else cpp.run(pmodel, qp, vp, tp, rounds)
    return times, (float(error), export_difference), n, in_cpp


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[7, 12, 30])
    parser.add_argument("--large", action="store_true", help="also n = 100")
    parser.add_argument("--rounds", type=int, default=7)
    add_option(parser)
    parser.add_argument("--no-first-use", action="store_true",
                        help="only the timings per call (not the fresh-process builds)")
    parser.add_argument("--first-use-only", action="store_true",
                        help="only the fresh-process builds (not the timings per call)")
    parser.add_argument("--no-robots", action="store_true",
                        help="not the robots of example-robot-data")
    parser.add_argument("--style", choices=("v2pt", "positions"), default="v2pt",
                        help="how chain3d is written (positions: the same chain that SymPy "
                             "builds in seconds at n = 100, where v2pt takes it minutes)")
    args = parser.parse_args()
    sizes = args.sizes + ([100] if args.large else [])
    print(machine_info())
    with tempfile.TemporaryDirectory() as folder:
        cpp = None if args.first_use_only else announced(folder, args.pinocchio_cpp)
        print("\n| model (n) | kanedyn jacobians, us (median) | the same, 1000 states in one "
              "call, us per state (median) | Pinocchio computeABADerivatives, us (median) | "
              "kanedyn / Pinocchio, one (medians) | batch / Pinocchio (medians) | "
              "Pinocchio computeABADerivatives in C++, us (median) | kanedyn (Python call) / "
              "Pinocchio C++ (medians) | batch / Pinocchio C++ (medians) | "
              "kanedyn's standalone C from a C loop, us (median) | standalone C / "
              "Pinocchio C++ (medians) | largest difference (kanedyn - Pinocchio; "
              "C++ - Python Pinocchio; standalone C - kanedyn) |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        cases = [] if args.no_robots or robot_text("Panda") is None else list(ROBOTS)
        cases += sizes
        if args.first_use_only:
            cases = []
        for case in cases:
            robot = case if isinstance(case, str) else None
            times, (error, export_error), n, in_cpp = measure(
                0 if robot else case, args.rounds, robot, folder, args.style, cpp)
            a, c, b, e = times["kanedyn"], times["batch"], times["pinocchio"], times["export"]
            export_text = f"{1e6 * e.best:.2f} ({1e6 * e.median:.2f})"
            if in_cpp is None:
                cpp_text = f"n/a | n/a | n/a | {export_text} | n/a"
                cpp_difference = "n/a"
            else:
                d = in_cpp.derivatives
                cpp_text = (f"{1e6 * d.best:.1f} ({1e6 * d.median:.1f}) | "
                            f"{a.best / d.best:.2f} ({a.median / d.median:.2f}) | "
                            f"{c.best / d.best:.2f} ({c.median / d.median:.2f}) | "
                            f"{export_text} | "
                            f"{e.best / d.best:.2f} ({e.median / d.median:.2f})")
                cpp_difference = f"{in_cpp.difference:.1e}"
            label = f"{robot} ({n})" if robot else f"chain3d ({n})"
            print(f"| {label} | {1e6 * a.best:.1f} ({1e6 * a.median:.1f}) | "
                  f"{1e6 * c.best:.1f} ({1e6 * c.median:.1f}) | "
                  f"{1e6 * b.best:.1f} ({1e6 * b.median:.1f}) | "
                  f"{a.best / b.best:.2f} ({a.median / b.median:.2f}) | "
                  f"{c.best / b.best:.2f} ({c.median / b.median:.2f}) | {cpp_text} | "
                  f"{error:.1e}; {cpp_difference}; {export_error:.1e} |")
    if args.no_first_use:
        return
    print("\n| chain3d n | operations of the derivative code | first rhs, s | "
          "first jacobians, s | jacobians / rhs | CPU s, rhs: process + children | "
          "the same, jacobians | CPU of the process, jacobians / rhs | "
          "first jacobians after the rhs's optimized build, s (/ its first rhs) | load |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    ops, builds = [], []
    byte_compile_package()
    for n in sizes:
        count = operations(n, args.style)
        ops.append(count)
        load = os.getloadavg()[0]
        rhs, jac, (rp, rc), (jp, jc) = first_use(n, args.style)
        rhs_b, jac_b, _, _ = first_use(n, args.style, after_build=True)
        load = (load + os.getloadavg()[0]) / 2
        builds.append(jac)
        print(f"| {n} | {count} | {rhs:.2f} | {jac:.2f} | {jac / rhs:.2f} | "
              f"{rp:.2f} + {rc:.2f} | {jp:.2f} + {jc:.2f} | {jp / rp:.2f} | "
              f"{jac_b:.2f} ({jac_b / rhs_b:.2f}) | {load:.1f} |")
    if len(sizes) > 1:
        for what, values in (("operations of the derivative code", ops),
                             ("first jacobians call", builds)):
            slope = np.polyfit(np.log(sizes), np.log(values), 1)[0]
            print(f"\ngrowth of the {what}: ~ n^{slope:.2f}")


if __name__ == "__main__":
    main()
