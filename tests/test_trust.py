"""Trust: no code runs from user text, no hangs, nothing lost on Ctrl-C, options
the integrators cannot honour refused, results that cannot be trusted say so."""

import json
import pathlib
import re
import os
import signal
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
import warnings

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn._number_text import NumberTextError, parse_number
from kanedyn.cli import main

SCIPY_METHODS = ["RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"]


@pytest.fixture(scope="module")
def pendulum():
    definition = kd.models.build("pendulum")
    return definition, definition.derive()


# ---------------------------------------------------------- 1. text is not code
@pytest.mark.parametrize("command", ["run", "derive", "compare"])
def test_set_value_is_never_run(command, tmp_path, capsys):
    marker = tmp_path / "ran"
    payload = f"m=__import__('pathlib').Path({str(marker)!r}).write_text('x') or 1"
    argv = [command, "pendulum", "--set", payload]
    if command == "run":
        argv += ["--out", str(tmp_path), "--quiet"]
    assert main(argv) == 2
    assert not marker.exists()
    assert "--set m:" in capsys.readouterr().err


@pytest.mark.parametrize("text, value", [
    ("2", 2.0), ("-1.5e-3", -1.5e-3), ("2*pi/3", 2 * np.pi / 3), ("9.81**0.5", 9.81 ** 0.5),
    ("2^3", 8.0), ("-(1 + 2) * e", -3 * np.e), ("+4 / 8", 0.5)])
def test_number_text_reads_arithmetic(text, value):
    assert parse_number(text) == pytest.approx(value, rel=1e-15)


@pytest.mark.parametrize("text", [
    "__import__('os').system('true')", "().__class__", "open('/etc/passwd')", "x",
    "lambda: 1", "[1]", "'1'", "True", "1 if 1 else 2", "9**9**9", "(-8)**(1/3)", "1/0",
    "(" * 300 + "1" + ")" * 300, ""])
def test_number_text_refuses_everything_else(text):
    with pytest.raises(NumberTextError, match="^--set m: "):
        parse_number(text, "--set m")


# ------------------------------------------------------------------ 2. no hangs
@pytest.mark.timeout(120)
@pytest.mark.parametrize("backend", ["numpy", "c"])
@pytest.mark.parametrize("method", SCIPY_METHODS + ["Rosenbrock23"])
def test_zero_mass_ends_at_once_naming_the_body(pendulum, method, backend):
    if method == "Rosenbrock23" and backend == "numpy":
        pytest.skip("Rosenbrock23 is a method of the compiled loop")
    definition, eom = pendulum
    model = definition.numeric(eom, constants={"m": 0.0}, backend=backend)
    res = kd.simulate(model, (0, 1), definition.initial(model), method=method)
    assert not res.success and res.status == -1
    assert "singular mass matrix" in res.message and "no inertia along u" in res.message
    assert "particle 'bob' has mass 0 kg" in res.message
    assert res.t.tolist() == [0.0]


@pytest.mark.timeout(120)
@pytest.mark.parametrize("backend", ["numpy", "c"])
@pytest.mark.parametrize("method", SCIPY_METHODS + ["Rosenbrock23"])
def test_input_turning_nan_ends_the_run_keeping_the_rest(method, backend):
    if method == "Rosenbrock23" and backend == "numpy":
        pytest.skip("Rosenbrock23 is a method of the compiled loop")
    definition = kd.models.build("n-link-pendulum-on-cart", n=1)
    F = definition.symbols["F"]
    model = definition.numeric(specified={F: lambda t: np.nan if t > 0.5 else 0.0},
                               backend=backend)
    res = kd.simulate(model, (0, 2), definition.initial(model), method=method,
                      t_eval=np.linspace(0, 2, 41))
    assert not res.success
    assert res.message.startswith("specified input(s) not finite at t=0.5")
    assert "F(t) = nan" in res.message
    assert 0.4 <= res.t[-1] <= 0.5 and np.all(np.isfinite(res.y))


def _lost_sensor(t):
    if t > 0.5:
        raise RuntimeError("sensor lost")
    return 0.0


def _broken_event(t, y):
    if t > 0.5:
        raise RuntimeError("event broke")
    return 1.0


@pytest.mark.timeout(120)
@pytest.mark.parametrize("backend", ["numpy", "c"])
@pytest.mark.parametrize("method", ["RK45", "Radau", "Rosenbrock23"])
@pytest.mark.parametrize("culprit", ["input", "event"])
def test_a_raising_callback_ends_the_run_keeping_the_rest(method, backend, culprit):
    """An input's or an event's function that raises mid-run ends the run with
    what was computed and a message naming it (the exception's type and text)."""
    if method == "Rosenbrock23" and backend == "numpy":
        pytest.skip("Rosenbrock23 is a method of the compiled loop")
    definition = kd.models.build("n-link-pendulum-on-cart", n=1)
    F = definition.symbols["F"]
    force = _lost_sensor if culprit == "input" else 0.0
    model = definition.numeric(specified={F: force}, backend=backend)
    events = [_broken_event] if culprit == "event" else None
    res = kd.simulate(model, (0, 2), definition.initial(model), method=method,
                      t_eval=np.linspace(0, 2, 41), events=events)
    assert not res.success and res.status == -1
    expected = (r"specified input F\(t\): its function raised RuntimeError at t=0\.5\d*: "
                r"sensor lost" if culprit == "input" else
                r"event _broken_event raised RuntimeError at t=0\.5\d*: event broke")
    assert re.match(expected, res.message), res.message
    # an input fails inside a step, which is not accepted; an event is evaluated
    # at the end of an accepted step, which is kept
    t_failed = float(re.search(r"at t=([\d.]+)", res.message).group(1))
    last = 0.5 if culprit == "input" else t_failed
    assert 0.45 <= res.t[-1] <= last * (1 + 1e-6) and np.all(np.isfinite(res.y))


@pytest.mark.timeout(120)
@pytest.mark.parametrize("backend", ["numpy", "c"])
@pytest.mark.parametrize("method", ["RK45", "Radau", "Rosenbrock23"])
def test_a_run_ending_early_between_sparse_outputs_keeps_its_last_state(method, backend):
    """Output times 0, 50 and 100 s, a run that fails at 0.5 s: the result ends
    with the state the solver accepted last, the state of an undisturbed run
    at that time."""
    if method == "Rosenbrock23" and backend == "numpy":
        pytest.skip("Rosenbrock23 is a method of the compiled loop")
    definition = kd.models.build("n-link-pendulum-on-cart", n=1)
    F = definition.symbols["F"]
    model = definition.numeric(specified={F: _lost_sensor}, backend=backend)
    y0 = definition.initial(model)
    res = kd.simulate(model, (0, 100), y0, method=method, t_eval=[0.0, 50.0, 100.0])
    assert not res.success and "sensor lost" in res.message
    assert res.t[0] == 0.0 and res.t.size == 2 and 0.4 < res.t[-1] <= 0.5
    free = definition.numeric(specified={F: 0.0}, backend=backend)
    reference = kd.simulate(free, (0, res.t[-1]), y0, method="DOP853", rtol=1e-12,
                            atol=1e-12, t_eval=[0.0, res.t[-1]])
    np.testing.assert_allclose(res.y[:, -1], reference.y[:, -1], atol=1e-4)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_a_raising_input_with_contacts_keeps_the_rest(backend):
    """The contact path ends the same way: a ball dropped from 1 m bounces at
    0.45 s (restitution 0.5); its input fails at 1 s; the impacts before stay."""
    z, w, F = me.dynamicsymbols("z w F")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", z * N.z)
    P.set_vel(N, w * N.z)
    floor = kd.Contact(P, kd.Plane(N, O, N.z), restitution=0.5)
    eom = kd.kane(frame=N, q_ind=[z], u_ind=[w], kd_eqs=[z.diff() - w],
                  bodies=[me.Particle("ball", P, 1)], loads=[(P, (F - 9.81) * N.z)],
                  contacts=[floor])

    def force(t):
        if t > 1.0:
            raise RuntimeError("sensor lost")
        return 0.0
    model = eom.numeric(specified={F: force}, backend=backend)
    res = kd.simulate(model, (0, 2), [1.0, 0.0], t_eval=np.linspace(0, 2, 41), max_step=0.05)
    assert not res.success
    assert re.match(r"specified input F\(t\): its function raised RuntimeError at t=1\.0\d*: "
                    r"sensor lost", res.message), res.message
    assert 0.95 < res.t[-1] <= 1.0 and res.impacts  # the last accepted step after 0.95
    assert res.impacts[0].t == pytest.approx(np.sqrt(2 / 9.81), rel=1e-6)


def test_cli_zero_mass_ends_with_the_cause(tmp_path, capsys):
    assert main(["run", "pendulum", "--set", "m=0", "--out", str(tmp_path), "--quiet"]) == 1
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["success"] is False
    assert "singular mass matrix" in summary["message"] and "'bob'" in summary["message"]


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning",
                            "ignore:invalid value encountered:RuntimeWarning")
def test_diverging_state_names_the_states():
    """A run whose state becomes nan says so and suggests a stiff method."""
    model = _stiff_pair().numeric(constants={"m": 1, "k": 1, "K": 1e8})
    res = kd.simulate(model, (0, 10), [1, 1.001, 0, 0], rtol=0.1, atol=0.1)
    assert not res.success and res.t[-1] < 10
    assert "the state is not finite" in res.message and "Radau or BDF" in res.message


# ---------------------------------------------------- 3. nothing lost on Ctrl-C
_INTERRUPTED_RUN = textwrap.dedent("""
    import json, os, signal, sys, threading, time
    import kanedyn as kd
    backend, method = sys.argv[1], sys.argv[2]
    d = (kd.models.build("bouncing-ball", restitution=1.0) if backend == "contacts"
         else kd.models.build("n-link-pendulum-on-cart", n=2))
    backend = "numpy" if backend == "contacts" else backend
    model = d.numeric(d.derive(), backend=backend)
    # a first short run: what simulate imports on first use is loaded before the
    # Ctrl-C (under load the imports alone could take the second)
    kd.simulate(model, (0, 0.01), d.initial(model), method=method)
    threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT)).start()
    start = time.perf_counter()
    try:
        kd.simulate(model, (0, 1e6), d.initial(model), method=method, rtol=1e-10,
                    atol=1e-10)
        print(json.dumps({"raised": False}))
    except kd.SimulationInterrupted as stop:
        r = stop.result
        print(json.dumps({"raised": True, "keyboard": isinstance(stop, KeyboardInterrupt),
                          "success": r.success, "message": r.message, "points": r.t.size,
                          "t_end": float(r.t[-1]), "finite": bool((r.y == r.y).all()),
                          "seconds": time.perf_counter() - start}))
""")


def _sigint_as_in_a_terminal():
    """In the child before it starts: SIGINT at its default, as for a program run in
    a terminal (a parent that ignores it, e.g. a shell's background job, would pass
    the ignoring on, and Python then leaves Ctrl-C ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.slow
@pytest.mark.timeout(300)
@pytest.mark.parametrize("backend, method", [("numpy", "RK45"), ("numpy", "Radau"),
                                             ("c", "RK45"), ("c", "Rosenbrock23"),
                                             ("contacts", "RK45")])
def test_ctrl_c_returns_the_partial_result(backend, method):
    out = subprocess.run([sys.executable, "-c", _INTERRUPTED_RUN, backend, method],
                         capture_output=True, text=True, timeout=240,
                         preexec_fn=_sigint_as_in_a_terminal)
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report["raised"] and report["keyboard"]
    assert report["success"] is False and report["message"] == "interrupted"
    assert report["points"] > 10 and report["t_end"] > 0 and report["finite"]
    assert report["seconds"] < 60


@pytest.mark.slow
@pytest.mark.timeout(300)
@pytest.mark.parametrize("backend, t_end", [("numpy", "1e4"), ("c", "1e7")])
def test_cli_writes_what_it_has_on_ctrl_c(tmp_path, backend, t_end):
    # long enough that Ctrl-C comes during the simulation, short enough that some
    # output times are passed by then (the compiled loop integrates 1e4 s of this
    # pendulum in well under a second)
    proc = subprocess.Popen([sys.executable, "-m", "kanedyn.cli", "run", "pendulum",
                             "--t-end", t_end, "--points", "100001", "--rtol", "1e-12",
                             "--atol", "1e-12", "--backend", backend, "--out", str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_sigint_as_in_a_terminal)
    said = []  # stderr so far, read by a thread while the run goes on
    reader = threading.Thread(target=lambda: [said.append(line) for line in proc.stderr])
    reader.start()
    # wait until the simulation's time advances: an ETA in the progress (the compiled
    # loop prints none: its start), then until some output times are passed
    # (a bar with its ETA on a terminal, a plain line with the per cent done off one)
    running = (r"simulating .*<\d|simulating\s+\d+\.\d%" if backend == "numpy"
               else "the compiled RK45 loop")
    deadline = time.time() + 120
    while (not any(re.search(running, line) for line in list(said))
           and time.time() < deadline and proc.poll() is None):
        time.sleep(0.05)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    proc.stdout.read()  # stderr is the reader's
    proc.wait(timeout=120)
    reader.join()
    err = "".join(said)
    assert proc.returncode == -signal.SIGINT, err  # ended by the signal: 130 in a shell
    assert "interrupted" in err and "wrote the partial result" in err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["message"] == "interrupted" and summary["points"] > 1
    rows = (tmp_path / "pendulum.csv").read_text().splitlines()
    assert len(rows) == summary["points"] + 1


@pytest.mark.usefixtures("terminal_signals")
def test_cli_interrupted_before_the_first_output_time(tmp_path, monkeypatch, capsys):
    """Ctrl-C before the solver accepted a step (here: in its first evaluation
    under the run's guard): an empty result is written and reported as such,
    exit status 130."""
    from kanedyn.cli import _run
    simulate = _run._simulate

    def interrupted_at_once(model, *args):
        rhs, pressed = model.rhs, []

        def first_evaluation_interrupted(t, y):
            if not pressed and signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
                pressed.append(t)  # once: a second Ctrl-C would stop at once
                signal.raise_signal(signal.SIGINT)  # the run's guard turns it into a stop
            return rhs(t, y)

        model.rhs = first_evaluation_interrupted
        return simulate(model, *args)

    monkeypatch.setattr(_run, "_simulate", interrupted_at_once)
    code = main(["run", "pendulum", "--backend", "numpy", "--out", str(tmp_path)])
    out, err = capsys.readouterr()
    assert code == 130, err
    assert "interrupted before the first output time; wrote the partial result" in err
    assert "points: 0, t_end: none reached" in out
    assert "max constraint residual: n/a (no output points)" in out
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["points"] == 0 and summary["t_end"] is None
    assert (tmp_path / "pendulum.csv").read_text().splitlines()[1:] == []


# --------------------------------------------- 5. inputs the integrators honour
@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_backward_integration_with_output_times(pendulum, backend):
    definition, eom = pendulum
    model = definition.numeric(eom, backend=backend)
    y0 = definition.initial(model)
    forward = kd.simulate(model, (0, 2), y0, rtol=1e-11, atol=1e-11)
    times = np.linspace(2, 0, 9)
    back = kd.simulate(model, (2, 0), forward.y[:, -1], t_eval=times, rtol=1e-11,
                       atol=1e-11)
    assert back.success and back.t.tolist() == times.tolist()
    np.testing.assert_allclose(back.y[:, -1], y0, atol=1e-8)


# ---------------------------- 6. the C compiler and its cache, clear or warned
_CACHE_RUN = textwrap.dedent("""
    import warnings, sys
    import sympy as sm, sympy.physics.mechanics as me, kanedyn as kd
    q, u = me.dynamicsymbols("q u")
    c = sm.symbols("c")
    N = me.ReferenceFrame("N"); O = me.Point("O"); O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x); P.set_vel(N, u * N.x)
    power = int(sys.argv[1])  # a different module for each power
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("p", P, 1)], loads=[(P, -c * q ** power * N.x)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            model = eom.numeric(constants={c: 1.0}, backend="c")
            print("built", model.rhs(0.0, [1.0, 0.0])[1])
            # the optimized module into the cache (a use this short would not start
            # its build; tests/test_quick_compile.py)
            kd.numerics.finish_compiling()
        except kd.KanedynError as exc:
            print("error", type(exc).__name__, exc)
    for w in caught:
        print("warning", w.category.__name__, w.message)
""")


def _build_in(cache, power, **env):
    environment = dict(os.environ, KANEDYN_CACHE_DIR=str(cache), **env)
    out = subprocess.run([sys.executable, "-c", _CACHE_RUN, str(power)], env=environment,
                         capture_output=True, text=True, timeout=300)
    return out.stdout


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_compiler_that_does_not_compile(tmp_path):
    # without the quick compiler: with it, the model would run on TinyCC's module and
    # the optimizing compiler's failure come as a warning (tests/test_quick_compile.py)
    out = _build_in(tmp_path, 3, CC="/bin/false", KANEDYN_QUICK_CC="")
    assert "error CompilerError the C compiler /bin/false ($CC) failed" in out
    assert "does not look like a working C compiler" in out
    out = _build_in(tmp_path, 3, CC=str(tmp_path / "no-such-cc"))
    assert "which is not a program on this machine; using the numpy backend" in out
    assert "built -1.0" in out


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_cache_path_that_is_a_file(tmp_path):
    afile = tmp_path / "cache"
    afile.write_text("not a directory")
    out = _build_in(afile, 5)
    assert "built -1.0" in out
    assert f"the cache directory {afile} ($KANEDYN_CACHE_DIR) is a file" in out
    assert afile.read_text() == "not a directory"


def _make_read_only(path):
    """chmod for users, the immutable flag for root; False if neither works."""
    if os.geteuid() == 0:
        done = subprocess.run(["chattr", "+i", str(path)], capture_output=True)
        if done.returncode != 0:
            return False
    else:
        path.chmod(0o555)
    try:
        (path / "probe").write_text("x")
    except OSError:
        return True
    (path / "probe").unlink()
    return False


def _make_writable(path):
    if os.geteuid() == 0:
        subprocess.run(["chattr", "-i", str(path)], capture_output=True)
    path.chmod(0o755)


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_read_only_cache(tmp_path, generic_runtime_object):
    """A cache that cannot be written: a valid entry is used silently, a new
    module is built in a private cache with a warning.  The cache starts with the
    generic runtime's object (its first module's build is not what is tested;
    the private cache's build still compiles everything)."""
    cache = tmp_path / "cache"
    generic_runtime_object(cache)
    assert "built -1.0" in _build_in(cache, 7)
    stale = pathlib.Path(tempfile.mkdtemp(prefix="build-", dir=cache))  # as a build names it
    os.utime(stale, (time.time() - 86400, time.time() - 86400))
    assert "built -1.0" in _build_in(cache, 7)
    assert not stale.exists()  # a killed build's folder is cleaned away
    if not _make_read_only(cache):
        pytest.skip("cannot make a directory read-only here (needs chattr as root)")
    try:
        cached = _build_in(cache, 7)  # a valid entry is used read-only, silently
        assert "built -1.0" in cached and "warning" not in cached
        fresh = _build_in(cache, 9)  # a new module goes to a private cache
        assert "built -1.0" in fresh
        assert "cannot be written" in fresh and "for this process only" in fresh
    finally:
        _make_writable(cache)


# ------------------------------------------ 9. terminal events with t_eval
@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_terminal_event_with_output_times_on_a_constrained_model(backend):
    definition = kd.models.build("four-bar")
    model = definition.numeric(definition.derive(), backend=backend)
    y0 = definition.initial(model)

    def crank_turned(t, y):
        return y[0] - (y0[0] + 0.3)
    crank_turned.terminal = True
    free = kd.simulate(model, (0, 5), y0, events=crank_turned, rtol=1e-10, atol=1e-10,
                       projection_tol=1e-12)
    times = np.linspace(0, 5, 11)
    res = kd.simulate(model, (0, 5), y0, events=crank_turned, t_eval=times, rtol=1e-10,
                      atol=1e-10, projection_tol=1e-12)
    assert free.status == res.status == 1
    assert free.projections > 0  # drift projections happened before the event
    t_event = res.t_events[0][0]
    assert t_event == pytest.approx(free.t_events[0][0], abs=1e-9)
    assert res.t.tolist() == times[times <= t_event].tolist()
    assert res.y_events[0][0][0] == pytest.approx(y0[0] + 0.3, abs=1e-9)


# ----------------------------------------- 11. results that cannot be trusted
def _stiff_pair():
    """Two unit masses, a soft spring to ground and a very stiff one between them."""
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    m, k, K = sm.symbols("m k K")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P1, P2 = O.locatenew("P1", q1 * N.x), O.locatenew("P2", q2 * N.x)
    P1.set_vel(N, u1 * N.x)
    P2.set_vel(N, u2 * N.x)
    return kd.kane(frame=N, q_ind=[q1, q2], u_ind=[u1, u2],
                   kd_eqs=[q1.diff() - u1, q2.diff() - u2],
                   bodies=[me.Particle("a", P1, m), me.Particle("b", P2, m)],
                   loads=[(P1, (-k * q1 + K * (q2 - q1)) * N.x), (P2, -K * (q2 - q1) * N.x)],
                   potential_energy=k * q1 ** 2 / 2 + K * (q2 - q1) ** 2 / 2)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_energy_created_by_an_explicit_method_on_a_stiff_system(backend):
    eom = _stiff_pair()
    model = eom.numeric(constants={"m": 1, "k": 1, "K": 1e5}, backend=backend)
    with pytest.warns(kd.TrustWarning, match="the energy balance fails"):
        res = kd.simulate(model, (0, 10), [1, 1.001, 0, 0], rtol=1e-2, atol=1e-2)
    assert res.success  # the integrator saw nothing wrong ...
    assert "warning: the energy balance fails" in res.message  # ... kanedyn does
    assert "method='Radau'" in res.message
    assert np.max(np.abs(res.energy)) > 1e6 * abs(res.energy[0])
    # at a tolerance that resolves the stiff spring, the same method is trusted
    model = eom.numeric(constants={"m": 1, "k": 1, "K": 1e4}, backend=backend)
    with warnings.catch_warnings():
        warnings.simplefilter("error", kd.TrustWarning)
        tight = kd.simulate(model, (0, 2), [1, 1.001, 0, 0], rtol=1e-8, atol=1e-8)
    assert "warning" not in tight.message and tight.energy_drift() < 1e-5


def test_no_warning_for_an_accurate_run_from_zero_energy(pendulum):
    """The pendulum from horizontal has zero initial energy: no false alarm."""
    definition, eom = pendulum
    model = definition.numeric(eom, constants={"m": 2 * np.pi})
    with warnings.catch_warnings():
        warnings.simplefilter("error", kd.TrustWarning)
        res = kd.simulate(model, (0, 10), definition.initial(model), rtol=1e-8)
    assert res.success and "warning" not in res.message


def test_ctrl_c_while_the_outputs_are_written_finishes_them_first(tmp_path, monkeypatch,
                                                                   capsys):
    """A Ctrl-C after the simulation, while CSV, plot and summary are written, is held
    until they are complete (a run that finished keeps all it computed)."""
    import kanedyn.cli._run as run_module
    from kanedyn.cli import main
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals are delivered to the main thread only")
    write = run_module._write_run

    def ctrl_c_then_write(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)  # as if pressed right now
        return write(*args, **kwargs)

    monkeypatch.setattr(run_module, "_write_run", ctrl_c_then_write)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # a terminal's
    try:
        code = main(["run", "pendulum", "--t-end", "0.5", "--backend", "numpy",
                     "--out", str(tmp_path), "--quiet"])
    finally:
        signal.signal(signal.SIGINT, previous)
    assert code == 130
    assert "they were finished first" in capsys.readouterr().err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["success"] and summary["points"] > 1
    rows = (tmp_path / "pendulum.csv").read_text().splitlines()
    assert len(rows) == summary["points"] + 1 and (tmp_path / "pendulum.png").exists()
