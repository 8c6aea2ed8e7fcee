"""Shared fixtures: models that are expensive to derive are built once per session.

The suite runs in two processes on two cores (``pytest -n 2``): each uses one
BLAS thread (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, set here before NumPy
is imported, and inherited by the programs the tests start).  BLAS threads of
both processes on the same two cores only wait for each other: the IPOPT
swing-up comparisons of ``test_interior_point.py`` took 13.4 s of CPU with the
default threads and 9.4 s with one, in the same wall time, on a quiet machine.

On an x86-64 processor with AVX2 the OpenBLAS kernels are set too
(``OPENBLAS_CORETYPE=Haswell``, for NumPy's OpenBLAS and the one bundled with
IPOPT): OpenBLAS picks them by the processor, and its AVX-512 ones round
differently.  A few tests follow a solver's path to its end (an IPOPT
limited-memory solve, the interior point stalling near an optimum), and that
path, not the optimum, changes with the rounding: with the AVX-512 kernels
the interior point's limited-memory swing-up of
``test_interior_point_limited_memory.py`` stalled with no acceptable iterate
(status -2) where with the AVX2 ones it ended at one (status 1).
"""

import os
import platform

for _threads in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_threads] = "1"


def _has_avx2():
    """Whether this is an x86-64 Linux processor with AVX2 and FMA (the
    Haswell kernels' instructions)."""
    if platform.machine() not in ("x86_64", "AMD64"):
        return False
    try:
        with open("/proc/cpuinfo") as info:
            flags = next((line.split() for line in info if line.startswith("flags")), [])
    except OSError:
        return False
    return "avx2" in flags and "fma" in flags


if _has_avx2():
    os.environ["OPENBLAS_CORETYPE"] = "Haswell"

import contextlib  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import zipfile  # noqa: E402

import pytest  # noqa: E402
import sympy as sm  # noqa: E402
import sympy.physics.mechanics as me  # noqa: E402

import kanedyn as kd  # noqa: E402


def pytest_sessionfinish(session):
    """One full garbage collection at the end of the session, then every object
    left frozen (``gc.freeze``): pytest's check for exceptions raised where
    nothing catches them (``unraisableexception``) collects five times more when
    the session closes, and each of those collections walks the whole heap a
    worker holds by then (SymPy's expressions, the derived models): 21 s of the
    two workers' CPU in a full run, sampled with py-spy.  The one collection
    here still finalizes what is garbage, with pytest's hook in place to report
    any exception it raises; the five after it walk only what was made since."""
    import gc
    gc.collect()
    gc.freeze()


@pytest.fixture(scope="session")
def bicycle():
    """(definition, eom, numeric model) of the Whipple bicycle, benchmark parameters."""
    definition = kd.models.build("whipple-bicycle")
    eom = definition.derive()
    return definition, eom, definition.numeric(eom)


@pytest.fixture(scope="session")
def flexible_robot_least_effort():
    """``kd.studies.flexible_robot_rest_to_rest(model_options={"n_modes": 2},
    after=0.5)``: the elastic robot's rotation of least effort, 2 bending modes,
    the link left free 0.5 s after (the default 2 s: the largest tip deflection
    after comes 0.049 s after the optimal torque ends, 0.045 s after the pulse,
    so both residuals are those of the 2-s run to the last digit, 3.0392653e-05
    and 4.9352271e-03 m, and the hub ends within 5.2e-5 rad of 90 deg either
    way, measured).  Checked in ``test_optimal_studies.py``; printed by
    ``kanedyn optimize`` in ``test_cli_optimize.py``."""
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (the test extra)")
    return kd.studies.flexible_robot_rest_to_rest(model_options={"n_modes": 2}, after=0.5)


@pytest.fixture(scope="session")
def generic_runtime_object(tmp_path_factory):
    """``seed(cache)``: put the optimizing compiler's object of the generic C
    runtime unit of a model without inputs or dependent coordinates and speeds
    (chain3d, the pendulum: :func:`~kanedyn.numerics.backends._c.predicted_runtime_unit`)
    into the object cache of the cache directory ``cache``, compiled once per
    session, as a model built earlier in that cache would have left it.  About
    1.2 s of gcc at -O1 per cache that then links it instead of compiling it:
    for the tests whose subject is not that compile (those of the compile itself,
    of the object cache and of prefetching start from an empty cache)."""
    from kanedyn.numerics.backends import _c_build
    from kanedyn.numerics.backends._c import predicted_runtime_unit
    command = _c_build.compiler_command()
    if command is None:  # nothing to link: the tests that need a compiler skip
        return lambda cache: None
    folder = tmp_path_factory.mktemp("generic-runtime")
    unit = predicted_runtime_unit({"n_q": 1, "n_u": 1, "n_q_dep": 0, "n_u_dep": 0,
                                   "n_p": 0, "n_r": 0})
    flags, made = _c_build._unit_object(unit, command, folder)
    source = folder / "unit.c"
    source.write_text(unit)
    made.parent.mkdir()
    subprocess.run(command + flags + _c_build._includes()
                   + ["-c", str(source), "-o", str(made)], check=True)

    def seed(cache):
        objects = cache / "objects"
        for folder in (cache, objects):  # private, as kanedyn makes them
            folder.mkdir(mode=0o700, exist_ok=True)
        target = objects / made.name
        shutil.copyfile(made, target)
        target.chmod(0o600)

    return seed


@pytest.fixture(scope="session")
def line_particle():
    """``build(mass, force=None, potential=None)``: the equations of a particle
    'bob' of ``mass`` at q N.x, its speed u along N.x, under ``force(q, u)``
    along N.x, with ``potential(q)`` declared; returns ``(eom, q, u)``."""
    def build(mass, force=None, potential=None):
        q, u = me.dynamicsymbols("q u")
        N = me.ReferenceFrame("N")
        O = me.Point("O")
        O.set_vel(N, 0)
        P = O.locatenew("P", q * N.x)
        P.set_vel(N, u * N.x)
        eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                      bodies=[me.Particle("bob", P, mass)],
                      loads=[(P, force(q, u) * N.x)] if force is not None else [],
                      potential_energy=potential(q) if potential is not None else None)
        return eom, q, u
    return build


@pytest.fixture()
def circle_particle():
    """A particle on a circle of radius L under gravity, both Cartesian
    coordinates kept: q2 and u2 dependent.  Returns ``(eom, (q1, q2, u1, u2,
    m, g, L))``."""
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    m, g, L = sm.symbols("m g L", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q1 * N.x + q2 * N.y)
    P.set_vel(N, u1 * N.x + u2 * N.y)
    eom = kd.kane(frame=N, q_ind=[q1], u_ind=[u1], q_dep=[q2], u_dep=[u2],
                  kd_eqs=[q1.diff() - u1, q2.diff() - u2],
                  configuration_constraints=[q1 ** 2 + q2 ** 2 - L ** 2],
                  velocity_constraints=[q1 * u1 + q2 * u2],
                  bodies=[me.Particle("p", P, m)], loads=[(P, -m * g * N.y)])
    return eom, (q1, q2, u1, u2, m, g, L)


@pytest.fixture()
def terminal_signals():
    """SIGINT and SIGTERM as a program run from a terminal has them, for the test:
    Python's Ctrl-C handler and SIGTERM's default action (a shell that starts the
    tests in the background passes SIGINT on ignored, and kanedyn leaves an ignored
    signal alone).  Tests that deliver these signals use it."""
    import signal
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    yield
    for s, handler in previous.items():
        signal.signal(s, handler)


@pytest.fixture()
def small_disk(tmp_path):
    """``mount(size="2m")``: a file system of its own (a tmpfs of ``size``) at a new
    folder under ``tmp_path``, unmounted when the test ends; ``mount.fill(disk)``
    fills it to the last block.  Skips, saying why, where mounting is refused
    (not root, a container without the right)."""
    mounted = []

    def mount(size="2m"):
        where = tmp_path / ("disk" if not mounted else f"disk{len(mounted)}")
        where.mkdir()
        try:
            done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size},mode=0700",
                                   "tmpfs", str(where)], capture_output=True, text=True)
        except OSError as exc:
            pytest.skip(f"cannot mount a tmpfs here ({exc})")
        if done.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here ({done.stderr.strip()})")
        mounted.append(where)
        return where

    def fill(disk):
        with open(disk / "filler", "wb", buffering=0) as filler, \
                contextlib.suppress(OSError):
            while filler.write(b"\0" * 4096):
                pass

    mount.fill = fill
    yield mount
    for where in mounted:
        subprocess.run(["umount", "-l", str(where)], check=False)


def _write_saved(path, nodes, root=0, fmt="kanedyn-equations", **manifest):
    text = json.dumps(nodes, separators=(",", ":")).encode()
    fields = {"format": fmt, "format_version": 1, "kanedyn_version": "0", "root": root,
              "nodes": len(nodes), "sha256": hashlib.sha256(text).hexdigest(), **manifest}
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("manifest.json", json.dumps(fields))
        z.writestr("nodes.json", text)
    return path


@pytest.fixture()
def saved_archive():
    """``write(path, nodes, root=0, fmt="kanedyn-equations", **manifest)``: a
    saved-data archive (``kd.load``'s format) of crafted nodes, with the
    correct checksum (which anyone can compute); returns ``path``."""
    return _write_saved
