"""Pinocchio's ``aba`` and ``computeABADerivatives`` timed in C++, for same-run ratios.

What it measures: the thread CPU time of one call of ``pinocchio::aba`` and of
``pinocchio::computeABADerivatives`` (the overload writing
:math:`\\partial\\ddot q/\\partial q`, :math:`\\partial\\ddot q/\\partial v` and
:math:`M^{-1}` into ``data``), called from a C++ loop, so that no Python is in
the time.

How: :func:`build` writes a C++ timing program into a folder and compiles it
once with the system ``g++ -O3 -DNDEBUG`` (plus the instruction flags it is
given: the scripts pass the ones kanedyn builds its modules with) against the
headers of the installed ``pin`` wheel (found from ``pinocchio.__file__``;
Eigen from the wheel's prefix, else from the one CasADi ships), linked with its
``libpinocchio_default``, with the compile definitions the wheel's CMake files
give that library.  Two variants (``algorithms``): ``"here"`` (the default)
compiles Pinocchio's algorithms from its headers in this program, with these
flags; ``"wheel"`` defines ``PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION`` as the
wheel's CMake target does, so the calls go to the wheel's own compiled
instantiations (what its Python binding runs), and leaves the instruction
flags out (they would not reach that code, and would lay Eigen's types out
with another alignment than the library's).

:meth:`PinocchioCpp.run` passes a Pinocchio model built in Python across as
numbers in a text file (each joint's parent, axis,
placement and body inertia; gravity), which the program reads with
``operator>>`` into a ``pinocchio::Model`` of revolute joints about x, y or z;
the state follows in the same file.  The program times ``calls`` calls per
round (``calls`` grown until a round takes at least 20 ms), for ``rounds``
rounds, with ``CLOCK_THREAD_CPUTIME_ID``, and prints the time per call of every
round, then its accelerations and derivatives at the state; :meth:`run` checks
those against the Python binding's at the same state (the largest difference),
so the model timed is the one the Python side times.

The wheel carries no ``urdf_model/model.h`` (urdfdom_headers), so
``pinocchio/parsers/urdf.hpp`` does not compile against it: robots read from
URDF text are built by the Python binding and passed across as numbers like
any other model.
"""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
from pathlib import Path

import numpy as np

from _timing import Timing

__all__ = ["PinocchioCpp", "CppResult", "build", "announced", "add_option", "AXES"]

#: Pinocchio's joint short name -> the axis index the program reads
AXES = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2}

#: the compile definitions the wheel's pinocchioTargets.cmake gives libpinocchio_default
#: (besides PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION, which ``algorithms="wheel"`` adds)
_DEFINITIONS = ("BOOST_MPL_LIMIT_LIST_SIZE=30",
                "BOOST_MPL_LIMIT_VECTOR_SIZE=30", "BOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
                "BOOST_FUSION_INVOKE_MAX_ARITY=12")

_PROGRAM = r"""
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/aba-derivatives.hpp>
#include <algorithm>
#include <fstream>
#include <iostream>
#include <time.h>
#include <vector>

static double thread_seconds() {
    timespec now;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
    return now.tv_sec + 1e-9 * now.tv_nsec;
}

// seconds per call of `call`, one entry per round
template <typename Call> std::vector<double> per_call(Call call, int rounds) {
    long calls = 1;
    for (;;) {
        double start = thread_seconds();
        for (long k = 0; k < calls; ++k) call();
        if (thread_seconds() - start >= 0.02) break;
        calls *= 2;
    }
    std::vector<double> times;
    for (int r = 0; r < rounds; ++r) {
        double start = thread_seconds();
        for (long k = 0; k < calls; ++k) call();
        times.push_back((thread_seconds() - start) / calls);
    }
    return times;
}

static Eigen::VectorXd read_vector(std::istream &in, int size) {
    Eigen::VectorXd out(size);
    for (int i = 0; i < size; ++i) in >> out[i];
    return out;
}

static void print(const char *name, const Eigen::MatrixXd &values) {
    std::cout << name;
    for (int i = 0; i < values.rows(); ++i)
        for (int j = 0; j < values.cols(); ++j) std::cout << ' ' << values(i, j);
    std::cout << '\n';
}

int main(int argc, char **argv) {
    if (argc != 3) { std::cerr << "usage: timing MODEL_FILE ROUNDS\n"; return 2; }
    std::ifstream in(argv[1]);
    int rounds = std::atoi(argv[2]), joints = 0;
    in >> joints;
    pinocchio::Model model;
    Eigen::VectorXd gravity = read_vector(in, 6);
    model.gravity = pinocchio::Motion(gravity);
    for (int k = 0; k < joints; ++k) {
        int parent = 0, axis = 0;
        in >> parent >> axis;
        Eigen::Matrix3d rotation, inertia;
        for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) in >> rotation(i, j);
        Eigen::Vector3d translation = read_vector(in, 3);
        double mass = 0.0;
        in >> mass;
        Eigen::Vector3d lever = read_vector(in, 3);
        for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) in >> inertia(i, j);
        pinocchio::SE3 placement(rotation, translation);
        pinocchio::Model::JointIndex id;
        std::string name = "joint" + std::to_string(k + 1);
        if (axis == 0) id = model.addJoint(parent, pinocchio::JointModelRX(), placement, name);
        else if (axis == 1) id = model.addJoint(parent, pinocchio::JointModelRY(), placement, name);
        else id = model.addJoint(parent, pinocchio::JointModelRZ(), placement, name);
        model.appendBodyToJoint(id, pinocchio::Inertia(mass, lever, inertia),
                                pinocchio::SE3::Identity());
    }
    Eigen::VectorXd q = read_vector(in, model.nq), v = read_vector(in, model.nv),
                    tau = read_vector(in, model.nv);
    if (!in) { std::cerr << "the model file ended early\n"; return 3; }
    pinocchio::Data data(model);
    std::vector<double> aba = per_call([&] { pinocchio::aba(model, data, q, v, tau); }, rounds);
    Eigen::VectorXd accelerations = pinocchio::aba(model, data, q, v, tau);
    std::vector<double> derivatives = per_call([&] {
        pinocchio::computeABADerivatives(model, data, q, v, tau, data.ddq_dq, data.ddq_dv,
                                         data.Minv);
    }, rounds);
    pinocchio::computeABADerivatives(model, data, q, v, tau, data.ddq_dq, data.ddq_dv,
                                     data.Minv);
    std::cout.precision(17);
    print("aba_seconds", Eigen::Map<Eigen::RowVectorXd>(aba.data(), rounds));
    print("derivatives_seconds", Eigen::Map<Eigen::RowVectorXd>(derivatives.data(), rounds));
    print("accelerations", accelerations.transpose());
    print("ddq_dq", data.ddq_dq);
    print("ddq_dv", data.ddq_dv);
    return 0;
}
"""


class CppResult:
    """What one run of the C++ program gave.

    Attributes
    ----------
    aba, derivatives : Timing
        Seconds per call of ``pinocchio::aba`` and of
        ``pinocchio::computeABADerivatives``, one entry per round.
    difference : float
        Largest absolute difference of the accelerations and both derivative
        matrices from the Python binding's at the same state.
    """

    def __init__(self, aba, derivatives, difference):
        self.aba = aba
        self.derivatives = derivatives
        self.difference = difference


def _prefix():
    """The wheel's install prefix: the folder above ``pinocchio`` holding
    ``include/pinocchio``."""
    import pinocchio
    for folder in Path(pinocchio.__file__).resolve().parents:
        if (folder / "include" / "pinocchio" / "multibody.hpp").is_file():
            return folder
    raise RuntimeError("no include/pinocchio above pinocchio's Python package")


def _eigen(prefix):
    """An include folder holding ``Eigen/Core``: the wheel's prefix's first, else
    CasADi's."""
    folders = [prefix / "include" / "eigen3", prefix / "include"]
    casadi = importlib.util.find_spec("casadi")
    if casadi is not None and casadi.origin:
        folders.append(Path(casadi.origin).parent / "include" / "eigen3")
    for folder in folders:
        if (folder / "Eigen" / "Core").is_file():
            return folder
    raise RuntimeError("no Eigen headers (Eigen/Core) in the pin wheel's prefix or CasADi")


def _model_text(pmodel, q, v, tau):
    """The model and state as the program reads them: numbers separated by white
    space."""
    numbers = [pmodel.njoints - 1, *pmodel.gravity.vector]
    for k in range(1, pmodel.njoints):
        kind = pmodel.joints[k].shortname()
        if kind not in AXES:
            raise ValueError(f"joint {pmodel.names[k]}: {kind} is not read by the C++ program")
        placement, inertia = pmodel.jointPlacements[k], pmodel.inertias[k]
        numbers += [pmodel.parents[k], AXES[kind], *placement.rotation.ravel(),
                    *placement.translation, inertia.mass, *inertia.lever,
                    *inertia.inertia.ravel()]
    numbers += [*q, *v, *tau]
    return " ".join(repr(float(x)) if not isinstance(x, int) else str(x) for x in numbers)


class PinocchioCpp:
    """The compiled C++ timing program (see the module's docstring).

    Parameters
    ----------
    executable : pathlib.Path
        The program :func:`build` compiled.
    description : str
        How it was compiled, for the scripts' output.
    """

    def __init__(self, executable, description=""):
        self.executable = Path(executable)
        self.description = description

    def run(self, pmodel, q, v, tau, rounds=7):
        """Time ``aba`` and ``computeABADerivatives`` in C++ on ``pmodel`` at
        ``(q, v, tau)`` (arrays of Pinocchio's sizes).

        Returns
        -------
        CppResult
        """
        import pinocchio as pin
        q, v, tau = (np.asarray(x, dtype=float) for x in (q, v, tau))
        path = self.executable.parent / "model.txt"
        path.write_text(_model_text(pmodel, q, v, tau))
        done = subprocess.run([str(self.executable), str(path), str(rounds)],
                              capture_output=True, text=True)
        if done.returncode:
            raise RuntimeError(f"the C++ timing program failed ({done.returncode}): "
                               f"{done.stderr[-500:]}")
        rows = {}
        for line in done.stdout.splitlines():
            name, *values = line.split()
            rows[name] = np.array([float(x) for x in values])
        nv = pmodel.nv
        data = pmodel.createData()
        accelerations = pin.aba(pmodel, data, q, v, tau)
        dq, dv, _ = pin.computeABADerivatives(pmodel, data, q, v, tau)
        difference = max(float(np.max(np.abs(rows["accelerations"] - accelerations))),
                         float(np.max(np.abs(rows["ddq_dq"].reshape(nv, nv) - dq))),
                         float(np.max(np.abs(rows["ddq_dv"].reshape(nv, nv) - dv))))
        return CppResult(Timing("aba C++", rows["aba_seconds"]),
                         Timing("computeABADerivatives C++", rows["derivatives_seconds"]),
                         difference)


def build(folder, algorithms="here", flags=()):
    """Compile the timing program in ``folder``.

    Parameters
    ----------
    folder : path-like
        Where the source, the program and its model files go.
    algorithms : {"here", "wheel"}
        Pinocchio's algorithms compiled in this program from the headers
        (``"here"``), or the wheel's compiled instantiations (``"wheel"``).
    flags : sequence of str
        Further compiler flags (instruction sets), e.g. ``("-mavx",)``; not
        used with ``"wheel"``: they would not reach the wheel's code, and
        they change the alignment Eigen's types are laid out with, so the
        program and the wheel's library would disagree on them (the program
        aborted at n = 100 with ``-mavx``).

    Returns
    -------
    (PinocchioCpp or None, str)
        The program, or ``None`` and the reason it could not be built (no
        pinocchio, no g++, no headers, the compiler's last error lines).
    """
    try:
        prefix = _prefix()
        eigen = _eigen(prefix)
    except (ImportError, RuntimeError) as exc:
        return None, str(exc)
    compiler = shutil.which("g++")
    if compiler is None:
        return None, "no g++ on PATH"
    source = Path(folder) / "pinocchio_timing.cpp"
    source.write_text(_PROGRAM)
    executable = Path(folder) / "pinocchio_timing"
    library = prefix / "lib"
    definitions = _DEFINITIONS
    if algorithms == "wheel":
        definitions += ("PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION",)
        flags = ()
    command = [compiler, "-std=c++17", "-O3", "-DNDEBUG", *flags,
               *(f"-D{d}" for d in definitions), f"-I{prefix / 'include'}", f"-I{eigen}",
               str(source), "-o", str(executable), f"-L{library}",
               f"-Wl,-rpath,{library}", "-lpinocchio_default"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode:
        errors = [line for line in done.stderr.splitlines() if "error" in line]
        return None, "g++ failed: " + " | ".join(errors[:3] or done.stderr.splitlines()[-3:])
    where = ("the wheel's compiled algorithms" if algorithms == "wheel" else
             "its algorithms compiled from the headers here")
    return PinocchioCpp(executable, f"{where}; g++ -O3 -DNDEBUG {' '.join(flags)}".strip()), ""


def announced(folder, algorithms="here"):
    """:func:`build` with the instruction flags kanedyn builds its own modules
    with, the outcome printed in a line (the program's description, or "n/a" and
    the reason); the program, or ``None``."""
    from kanedyn.numerics.backends._c_build import _VEX
    cpp, reason = build(folder, algorithms, _VEX)
    print(f"\nPinocchio in C++: {cpp.description if cpp is not None else f'n/a ({reason})'}")
    return cpp


def add_option(parser):
    """Add ``--pinocchio-cpp {here,wheel}`` (the ``algorithms`` of :func:`build`)
    to a script's argument parser."""
    parser.add_argument("--pinocchio-cpp", choices=("here", "wheel"), default="here",
                        help="Pinocchio in C++: its algorithms compiled from its headers "
                             "with -O3 and kanedyn's instruction flags (here), or the "
                             "pin wheel's compiled ones (wheel)")
