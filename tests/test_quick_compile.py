"""A model's first module from the quick compiler (TinyCC), the optimized one built
meanwhile: the same numbers to the bit, every model moved onto the optimized
module, and every way the quick path can fail leaves a working model."""

import atexit
import json
import os
import pickle
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.numerics.backends import _c_build, _c_quick
from kanedyn.numerics.backends._c_quick import QUICK_STATS

#: the rule of when an optimized build pays, as the library has it (the fixture
#: below sets it to "at once" for the other tests)
USE_PER_CHARACTER = _c_quick.USE_PER_CHARACTER
QUICK_MISSING = ("TinyCC (tcc) is not installed, so every model is compiled by the "
                 "optimizing compiler alone (install it with 'apt install tcc')")


@pytest.fixture()
def fresh_cache(tmp_path, monkeypatch, generic_runtime_object):
    """A new cache directory, nothing loaded in this process, the quick
    compiler as the environment has it (tcc on the PATH).  Its object cache holds
    gcc's object of the generic runtime of chain3d and the pendulum (as a first
    model would have left it): these tests are about the quick module and the
    move onto the optimized one, whose build still compiles the model's own
    units; the runtime's compile, its prefetch and the object cache are
    tested from empty caches (test_cbackend.py, test_cache_safety.py)."""
    if _c_build.compiler_command() is None:
        pytest.skip("no C compiler")
    generic_runtime_object(tmp_path)
    # optimized builds an earlier test started in the background (a model's
    # derivatives, say) end first: they would count in QUICK_STATS here (those
    # still waiting for their use to pay are not started here nor by the tests'
    # finish_compiling, as in a process of their own)
    assert _c_quick.finish_compiling(timeout=600, start_waiting=False)
    monkeypatch.delenv("KANEDYN_QUICK_CC", raising=False)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    # every optimized build starts at once (when it pays otherwise: the tests of
    # that rule set it back)
    monkeypatch.setattr(_c_quick, "USE_PER_CHARACTER", 0.0)
    yield tmp_path
    _c_quick.finish_compiling(start_waiting=False)


def needs_tcc():
    if _c_quick.quick_command() is None:
        pytest.skip(QUICK_MISSING)


def cached_modules(folder):
    return sorted(folder.glob("_kd_*.so"))


def evaluations(definition, model, seed=7):
    """The model's compiled functions on random states: rhs, a batch, the energy
    or constraint residuals where it has them, and a short run of the compiled loop."""
    rng = np.random.default_rng(seed)
    y0 = definition.initial(model)
    Y = y0 + rng.uniform(-0.3, 0.3, (40, model.n_states))
    if model.n_q_dep or model.n_u_dep:
        Y = np.array([model.consistent_state(0.0, y) for y in Y])
    out = {"rhs": np.array([model.rhs(0.1, y) for y in Y]),
           "batch": model.rhs_batch(0.1, Y)}
    if model.has_potential:
        out["energy"] = np.array([model.total_energy(0.0, y) for y in Y[:5]])
    if model.n_q_dep or model.n_u_dep:
        out["residuals"] = np.array([model.constraint_residuals(0.0, y) for y in Y[:5]])
    run = kd.simulate(model, (0.0, 0.3), Y[0])
    out["run"] = run.y
    return out


MODELS = [("pendulum", {}), ("n-link-pendulum-on-cart", {"n": 3}), ("chain3d", {"n": 6}),
          ("chaplygin-sleigh", {"lateral_force": True}), ("four-bar", {}),
          ("rolling-disk", {"normal_force": True}), ("whipple-bicycle", {})]


@pytest.mark.slow
@pytest.mark.parametrize("name, options", MODELS, ids=[m[0] for m in MODELS])
def test_quick_module_then_the_optimized_one_give_the_same_numbers(fresh_cache, monkeypatch,
                                                                    name, options):
    """The model answers at once from TinyCC's module and moves onto gcc's
    (cached, for the next process) when it is built: rhs, batches, energies,
    constraint residuals and the compiled loop's run are equal to the bit (the
    optimized build held back until TinyCC's numbers are taken)."""
    needs_tcc()
    gate = threading.Event()  # gcc's build waits for it

    def held_back(module, build, *rest):
        _c_quick.optimize_later(module, lambda **locked: gate.wait(300) and build(**locked),
                                *rest)

    monkeypatch.setattr(_c_build, "optimize_later", held_back)
    definition = kd.models.build(name, **options)
    before = dict(QUICK_STATS)
    model = definition.numeric(backend="c")
    quick = model._module
    assert QUICK_STATS["quick"] == before["quick"] + 1
    assert Path(quick.__file__).parent != fresh_cache  # not the cache's module
    first = evaluations(definition, model)
    assert QUICK_STATS["optimized"] == before["optimized"]
    gate.set()
    assert _c_quick.finish_compiling(timeout=300, start_waiting=False)
    assert model._module is not quick
    assert Path(model._module.__file__).parent == fresh_cache
    assert QUICK_STATS["swaps"] >= before["swaps"] + 1
    then = evaluations(definition, model)
    for what in first:
        np.testing.assert_array_equal(first[what], then[what], err_msg=what)


def test_the_optimized_build_starts_once_the_quick_module_has_paid_for_it(fresh_cache,
                                                                          monkeypatch):
    """A model whose module nothing wants in the cache (equations derived by the
    caller) runs on TinyCC's module; gcc's build starts once the quick module's
    entry points have taken about what the build costs (``USE_PER_CHARACTER``
    s per character compiled), not before; the model then moves onto gcc's module
    and its numbers do not change."""
    needs_tcc()
    monkeypatch.setattr(_c_quick, "USE_PER_CHARACTER", USE_PER_CHARACTER)
    definition = kd.models.build("chain3d", n=4)
    before = dict(QUICK_STATS)
    model = definition.numeric(definition.derive(), backend="c")
    quick = model._module
    upgrade = _c_quick._UPGRADES[quick]
    # what gcc would compile (the units whose objects are not cached), about a second
    # per 100,000 characters
    assert 0.1 < upgrade.use_to_start < 5.0
    y = definition.initial(model) + 0.1
    first = model.rhs(0.0, y)
    time.sleep(3 * _c_quick._LOOK_EVERY)
    assert 0.0 < quick._quick_use() < upgrade.use_to_start
    assert QUICK_STATS["started"] == before["started"] and model._module is quick
    while quick._quick_use() < upgrade.use_to_start:
        kd.simulate(model, (0.0, 50.0), y)
    deadline = time.monotonic() + 60
    while QUICK_STATS["started"] == before["started"] and time.monotonic() < deadline:
        time.sleep(0.05)
    assert QUICK_STATS["started"] == before["started"] + 1
    assert _c_quick.finish_compiling(timeout=600, start_waiting=False)
    assert model._module is not quick and len(cached_modules(fresh_cache)) == 1
    assert model.rhs(0.0, y).tobytes() == first.tobytes()


_SHORT_USE = """
import json, kanedyn as kd
from kanedyn.numerics.backends._c_quick import QUICK_STATS
cached = kd.models.build("pendulum").numeric(backend="c")  # for the derivation cache
definition = kd.models.build("chain3d", n=3)
model = definition.numeric(definition.derive(), backend="c")
model.rhs(0.0, definition.initial(model))
print(json.dumps(QUICK_STATS))
"""


def test_a_build_that_never_paid_is_not_made_at_exit(fresh_cache):
    """A process that used a quick module for less than its build costs exits
    without building it (the next one compiles it with TinyCC again); a module
    the derivation cache names is built at once and cached, and that entry
    written."""
    needs_tcc()
    done = subprocess.run([sys.executable, "-c", _SHORT_USE], capture_output=True, text=True,
                          timeout=600, env=dict(os.environ, KANEDYN_CACHE_DIR=str(fresh_cache)))
    assert done.returncode == 0, done.stderr[-2000:]
    stats = json.loads(done.stdout.splitlines()[-1])
    assert stats["quick"] == 2 and stats["started"] == 1
    assert len(cached_modules(fresh_cache)) == 1  # the pendulum's
    assert len(list(fresh_cache.glob("derived/*.kdnum"))) == 1
    assert not list(fresh_cache.glob("quick-*"))  # the quick modules' folders removed


def test_copies_made_before_the_optimized_build_move_on_too(fresh_cache):
    """A copy with other constants shares the quick module and moves onto the
    optimized one with the original; its own constants are kept."""
    needs_tcc()
    definition = kd.models.build("chain3d", n=3)
    model = definition.numeric(backend="c")
    heavier = model.with_constants({"m": 2.0})
    y = definition.initial(model) + 0.2
    expected = heavier.rhs(0.0, y)
    assert heavier._module is model._module
    _c_quick.finish_compiling(start_waiting=False)
    assert heavier._module is model._module
    assert Path(heavier._module.__file__).parent == fresh_cache
    np.testing.assert_array_equal(heavier.rhs(0.0, y), expected)
    assert not np.allclose(model.rhs(0.0, y), expected)


def test_a_second_model_of_the_same_equations_waits_for_nothing(fresh_cache):
    """While the optimized build runs, the same module asked for again is the
    quick one, given at once (no wait for the optimized build)."""
    needs_tcc()
    definition = kd.models.build("chain3d", n=3)
    eom = definition.derive()
    quick, compiles = QUICK_STATS["quick"], _c_build.STATS["compiles"]
    model = definition.numeric(eom, backend="c")
    again = definition.numeric(eom, backend="c")
    _c_quick.finish_compiling(start_waiting=False)
    assert QUICK_STATS["quick"] == quick + 1
    assert _c_build.STATS["compiles"] == compiles + 1
    assert model._module is again._module
    assert Path(model._module.__file__).parent == fresh_cache


def test_another_module_does_not_wait_for_an_optimized_build(fresh_cache, monkeypatch):
    """The derivative module asked for while the model's optimized build holds the
    build lock (gcc held back here) comes from the quick compiler at once; its
    numbers equal those of gcc's module to the bit, and the NumPy backend's
    derivatives to 1e-12."""
    needs_tcc()
    gate, build = threading.Event(), _c_build._build

    def held_back(*args, **options):  # called under the build lock
        gate.wait(300)
        return build(*args, **options)

    monkeypatch.setattr(_c_build, "_build", held_back)
    definition = kd.models.build("chain3d", n=3)
    model = definition.numeric(backend="c")
    y = np.random.default_rng(3).uniform(-1.0, 1.0, (4, model.n_states))
    before, found = dict(QUICK_STATS), []
    asked = threading.Thread(target=lambda: found.append(model.jacobians(0.0, y)))
    asked.start()
    asked.join(120)
    assert found, "the derivatives waited for the optimized build"
    assert _c_build._LOCK.locked() and not gate.is_set()
    assert QUICK_STATS["quick"] == before["quick"] + 1
    gate.set()
    assert _c_quick.finish_compiling(timeout=300, start_waiting=False)
    assert QUICK_STATS["optimized"] >= before["optimized"] + 2  # the model's and this one
    optimized = model.jacobians(0.0, y)
    np.testing.assert_array_equal(found[0].state, optimized.state)
    numpy = definition.numeric(backend="numpy").jacobians(0.0, y)
    scale = np.abs(numpy.state).max()
    assert np.abs(found[0].state - numpy.state).max() <= 1e-12 * scale


def test_a_quick_compiler_failing_meanwhile_leaves_the_build_under_the_lock(fresh_cache,
                                                                            monkeypatch):
    """The quick compiler failing on a module asked for while another's optimized
    build holds the lock: that module is built by gcc once the lock is free
    (the quick compiler not run again on it), with the same numbers."""
    needs_tcc()
    gate, build = threading.Event(), _c_build._build

    def held_back(*args, **options):
        gate.wait(300)
        return build(*args, **options)

    monkeypatch.setattr(_c_build, "_build", held_back)
    monkeypatch.setattr(_c_quick, "_WARNED", set())
    definition = kd.models.build("chain3d", n=3)
    model = definition.numeric(backend="c")  # from tcc; gcc's build held back
    y = np.random.default_rng(5).uniform(-1.0, 1.0, (3, model.n_states))
    monkeypatch.setenv("KANEDYN_QUICK_CC", "false")
    assert _c_build._LOCK.locked()  # by the model's optimized build
    before, found = dict(QUICK_STATS), []
    asked = threading.Thread(target=lambda: found.append(model.jacobians(0.0, y)))
    with pytest.warns(RuntimeWarning, match="could not build"):
        asked.start()
        time.sleep(0.5)
        gate.set()
        asked.join(300)
    assert found and QUICK_STATS["failed"] == before["failed"] + 1
    assert QUICK_STATS["quick"] == before["quick"]
    numpy = definition.numeric(backend="numpy").jacobians(0.0, y)
    assert np.abs(found[0].state - numpy.state).max() <= 1e-12 * np.abs(numpy.state).max()


@pytest.mark.parametrize("setting", ["", "none"])
def test_quick_compiler_turned_off(fresh_cache, monkeypatch, setting):
    monkeypatch.setenv("KANEDYN_QUICK_CC", setting)
    before = dict(QUICK_STATS)
    model = kd.models.build("pendulum").numeric(backend="c")
    assert QUICK_STATS == before
    assert Path(model._module.__file__).parent == fresh_cache


def test_a_quick_compiler_that_fails_leaves_the_optimized_build(fresh_cache, monkeypatch):
    """``false`` as the quick compiler: it makes no module, and the optimized
    build runs in the foreground."""
    monkeypatch.setenv("KANEDYN_QUICK_CC", "false")
    monkeypatch.setattr(_c_quick, "_WARNED", set())
    before = dict(QUICK_STATS)
    definition = kd.models.build("pendulum")
    with pytest.warns(RuntimeWarning, match=r"quick compiler \S*false could not build a "
                                            r"model's module \(exit status 1\)"):
        model = definition.numeric(backend="c")
    assert QUICK_STATS["failed"] == before["failed"] + 1
    assert QUICK_STATS["quick"] == before["quick"]
    assert Path(model._module.__file__).parent == fresh_cache
    assert np.all(np.isfinite(model.rhs(0.0, definition.initial(model))))


def test_a_quick_compiler_that_is_not_a_program_is_named(fresh_cache, monkeypatch):
    monkeypatch.setenv("KANEDYN_QUICK_CC", "/nonexistent/tcc-x")
    with pytest.warns(RuntimeWarning, match=r"KANEDYN_QUICK_CC is '/nonexistent/tcc-x'"):
        model = kd.models.build("pendulum").numeric(backend="c")
    assert Path(model._module.__file__).parent == fresh_cache


def test_a_failed_optimized_build_keeps_the_quick_module(fresh_cache, monkeypatch):
    """gcc failing in the background: a warning, and the model goes on with the
    quick module (its numbers are gcc's anyway)."""
    needs_tcc()

    def broken(*args, **kwargs):
        raise _c_build.CompilerError("the C compiler gcc failed (exit status 1): test")

    monkeypatch.setattr(_c_build, "_build", broken)
    definition = kd.models.build("pendulum")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = definition.numeric(backend="c")
        quick = model._module
        _c_quick.finish_compiling(start_waiting=False)
    assert any("optimized build of a compiled model failed" in str(w.message)
               and "exit status 1" in str(w.message) for w in caught)
    assert model._module is quick
    assert cached_modules(fresh_cache) == []
    run = kd.simulate(model, (0.0, 0.5), definition.initial(model))
    assert run.success


def test_the_first_use_trace_with_the_quick_compiler(monkeypatch):
    """``benchmarks/trace_first_use.py``: one quick compiler run before the first
    rhs, the optimizing compiler's runs after it, and the optimized module in use
    at the end."""
    needs_tcc()
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from trace_first_use import trace
    marks, runs = trace(2)
    at = dict((stage, s) for s, stage in marks)
    assert "optimized module in use" in at
    quick = [run for run in runs if run[2].startswith("quick compiler")]
    # the generic runtime's run, started before the derivation, then the build's
    assert [what.split(":")[0] for _, _, what in quick] == [
        "quick compiler (tcc), prefetched", "quick compiler (tcc)"]
    assert quick[0][0] <= at["derivation starts"]
    assert all(end <= at["first rhs"] for _, end, _ in quick)
    assert not any(what.startswith("prefetched") for _, _, what in runs)
    assert sum(what == "link" for _, _, what in runs) == 1


def test_the_runtime_is_compiled_quickly_while_the_model_is_derived(fresh_cache,
                                                                    monkeypatch):
    """With the quick compiler, a built-in model's generic runtime unit (predicted
    before the derivation) is compiled by it alone meanwhile, and the quick build
    links that object with the units it compiles itself (the module's numbers are
    the numpy backend's); the prefetch's folder goes with the build, and a unit
    that no build takes is stopped and removed by the next build."""
    needs_tcc()
    runs = []
    spawn = _c_quick.spawn

    def record(cmd, **options):
        runs.append(list(cmd))
        return spawn(cmd, **options)

    monkeypatch.setattr(_c_quick, "spawn", record)
    definition = kd.models.build("chain3d", n=4)
    model = definition.numeric(backend="c")
    early, build = runs
    made = early[early.index("-o") + 1]
    assert "-c" in early and "-c" not in build
    assert made in build  # linked, not compiled again
    compiled = [Path(part).name for part in build if part.endswith(".c")]
    assert "unit0.c" not in compiled and "unit1.c" in compiled
    assert not Path(made).parent.exists() and not _c_quick._PREFETCHED
    reference = definition.numeric(definition.derive(), backend="numpy")
    y = definition.initial(model) + 0.1
    np.testing.assert_allclose(model.rhs(0.0, y), reference.rhs(0.0, y), rtol=1e-12,
                               atol=1e-12)

    _c_build.prefetch(_c_build.LIGHT_UNIT + "int kd_probe(void) { return 1; }\n")
    ((_, _, folder),) = _c_quick._PREFETCHED.values()
    old = time.time() - 3 * 3600  # as old as a stale build's folder: this process's, kept
    os.utime(folder, (old, old))
    _c_build._remove_stale_builds(fresh_cache, 600)
    assert folder.exists()
    other = kd.models.build("pendulum")
    other.numeric(other.derive(), backend="c")  # equations given: nothing prefetched
    assert not _c_quick._PREFETCHED and not folder.exists()
    assert len(runs) == 4  # the probe, and the pendulum's build from its sources
    assert not any(part.endswith(".o") for part in runs[-1])


def chain_with_its_build_held_back(monkeypatch):
    """``(gate, definition, model)``: chain3d n = 4 on its quick module, its
    optimized build started and waiting (its locks held) until ``gate`` is set."""
    gate, building = threading.Event(), threading.Event()
    build = _c_build._build

    def held_back(*args, **kwargs):  # the build thread
        building.set()
        gate.wait(300)
        return build(*args, **kwargs)

    monkeypatch.setattr(_c_build, "_build", held_back)
    definition = kd.models.build("chain3d", n=4)
    model = definition.numeric(backend="c")
    assert building.wait(120)
    return gate, definition, model


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork is POSIX only")
def test_a_child_forked_during_the_optimized_build(fresh_cache, monkeypatch):
    """A process forked while the optimized build holds its locks: the child
    evaluates the model and builds another without waiting for the parent's
    locks; its exit hooks remove none of the parent's folders (the build and the
    quick module go on); and it holds no copy of the parent's file lock, so a
    third process loads the cached module while the child still lives."""
    needs_tcc()
    gate, definition, model = chain_with_its_build_held_back(monkeypatch)
    quick = model._module
    y = definition.initial(model) + 0.1
    read, write = os.pipe()
    hold, release = os.pipe()  # the child lives until the parent closes ``release``
    pid = os.fork()
    if pid == 0:  # the child: its answer through the pipe, a normal exit's hooks, alive on
        code = 1
        try:
            os.close(release)
            other = kd.models.build("pendulum").numeric(backend="c")
            ok = np.all(np.isfinite(other.rhs(0.0, [0.3, 0.0])))
            answer = model.rhs(0.0, y).tobytes() if ok else b""
            atexit._run_exitfuncs()
            os.write(write, answer)
            os.close(write)
            os.read(hold, 1)  # until the parent has checked (end of file), not a set time
            code = 0
        finally:
            os._exit(code)
    os.close(write)
    os.close(hold)
    try:
        with os.fdopen(read, "rb") as pipe:
            answer = np.frombuffer(pipe.read(), dtype=float)
        np.testing.assert_array_equal(answer, model.rhs(0.0, y))
        assert Path(quick.__file__).exists()
        gate.set()
        assert _c_quick.finish_compiling(timeout=300, start_waiting=False)
        assert Path(model._module.__file__).parent == fresh_cache
        third = subprocess.run(
            [sys.executable, "-c", "import kanedyn as kd\n"
             "m = kd.models.build('chain3d', n=4).numeric(backend='c')\n"
             "print(m._module.__file__)"],
            capture_output=True, text=True, timeout=120,
            env=dict(os.environ, KANEDYN_CACHE_DIR=str(fresh_cache)))
        assert third.stdout.strip() == model._module.__file__, third.stderr[-2000:]
        assert os.waitpid(pid, os.WNOHANG) == (0, 0)  # the child lives on
    finally:
        os.close(release)  # its end: it exits
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork is POSIX only")
def test_a_child_forked_during_the_optimized_build_moves_onto_it(fresh_cache, monkeypatch):
    """A worker forked while the optimized build runs (a pool of forked workers)
    takes the optimized module from the cache once its parent has written it:
    the model it inherited, a copy it unpickled and a copy with new constants
    move onto it, and give the parent's numbers to the bit."""
    needs_tcc()
    gate, definition, model = chain_with_its_build_held_back(monkeypatch)
    quick = model._module
    y = definition.initial(model) + 0.1
    ready_read, ready_write = os.pipe()
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: copies made before the parent's build ends, then a wait
        code = 1
        try:
            copies = [model, pickle.loads(pickle.dumps(model)),
                      model.with_constants({"m": 2.0})]
            before = [copy._module is quick for copy in copies]
            os.write(ready_write, b"r")
            done = _c_quick.finish_compiling(timeout=120, start_waiting=False)
            report = {"before": before, "done": done,
                      "moved": [copy._module is not quick for copy in copies],
                      "cached": [str(Path(copy._module.__file__).parent) for copy in copies],
                      "same module": len({id(copy._module) for copy in copies}) == 1,
                      "rhs": model.rhs(0.0, y).tolist()}
            os.write(write, pickle.dumps(report))
            code = 0
        finally:
            os._exit(code)
    os.close(ready_write)
    os.close(write)
    assert os.read(ready_read, 1) == b"r"
    gate.set()
    with os.fdopen(read, "rb") as pipe:
        report = pickle.loads(pipe.read())
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    assert _c_quick.finish_compiling(timeout=300, start_waiting=False)
    assert report["before"] == [True, True, True]
    assert report["done"] and report["moved"] == [True, True, True]
    assert report["cached"] == [str(fresh_cache)] * 3 and report["same module"]
    assert model._module is not quick
    assert np.array(report["rhs"]).tobytes() == model.rhs(0.0, y).tobytes()


def test_a_run_under_way_moves_onto_the_optimized_code_unchanged(fresh_cache, tmp_path,
                                                                 monkeypatch):
    """The optimized build points the quick module's code at its own (``_adopt``)
    while a run goes on: a run that moves over halfway gives the numbers of a run
    on the optimized module alone, to the bit; an entry of another model is
    refused."""
    needs_tcc()
    definition = kd.models.build("chain3d", n=4)
    model = definition.numeric(backend="c")
    _c_quick.finish_compiling(start_waiting=False)
    optimized = model._module
    # a quick module of the same model that no optimized build moves over
    monkeypatch.setattr(_c_build, "optimize_later", lambda module, build, *rest: None)
    monkeypatch.setattr(_c_build, "_LOADED", {})
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path / "second"))
    replay = definition.numeric(backend="c")
    assert Path(replay._module.__file__).name.endswith(".so")
    assert Path(replay._module.__file__).parent.name.startswith("quick-")
    moved = []

    def move_over(t, y):  # an event function that never fires: it moves the code at t = 1
        if t > 1.0 and not moved:
            replay._module._adopt(optimized._entry)
            moved.append(t)
        return 1.0

    y0 = definition.initial(model) + 0.2
    run = kd.simulate(replay, (0.0, 2.0), y0, events=[move_over])
    reference = kd.simulate(model, (0.0, 2.0), y0, events=[lambda t, y: 1.0])
    assert moved and run.method == reference.method
    np.testing.assert_array_equal(run.t, reference.t)
    np.testing.assert_array_equal(run.y, reference.y)
    other = kd.models.build("pendulum").numeric(backend="c")
    with pytest.raises(ValueError, match="another model's"):
        replay._module._adopt(other._module._entry)


def test_a_long_compiled_run_lets_other_threads_work(fresh_cache):
    """The compiled loop lets Python's other threads work every 0.02 s of a run
    (the optimized build of a model whose quick module runs goes on meanwhile):
    a thread that notes the time as often as it can, beside one long run without
    Python callbacks, is never kept waiting for long (holding the interpreter all
    through, the loop would keep it waiting for the whole run)."""
    definition = kd.models.build("pendulum")
    model = definition.numeric(backend="c")
    _c_quick.finish_compiling(start_waiting=False)
    stamps, stop = [], threading.Event()

    def note():
        while not stop.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0)

    noting = threading.Thread(target=note)
    noting.start()
    try:
        start = time.perf_counter()
        run = kd.simulate(model, (0.0, 1.0e5), [1.0, 0.0], t_eval=[0.0, 1.0e5])
        end = time.perf_counter()
    finally:
        stop.set()
        noting.join()
    assert run.success and run.method == "RK45 (compiled)"
    assert end - start > 0.5  # long enough to tell
    during = [start] + [t for t in stamps if start < t < end] + [end]
    assert max(np.diff(during)) < 0.25


def test_rational_constants_are_one_correctly_rounded_literal(fresh_cache, monkeypatch):
    """A constant p/q printed as a division is folded by TinyCC in extended
    precision (two roundings; this one came out one bit off): printed as one
    literal, both modules give p/q correctly rounded."""
    needs_tcc()
    gate = threading.Event()
    monkeypatch.setattr(_c_build, "optimize_later", lambda module, build, *rest: (
        _c_quick.optimize_later(module, lambda **lock: gate.wait(300) and build(**lock), *rest)))
    q, u = me.dynamicsymbols("q u")
    mass = sm.symbols("m", positive=True)
    frame = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(frame, 0)
    point = origin.locatenew("P", q * frame.x)
    point.set_vel(frame, u * frame.x)
    damping = sm.Rational(542719210271983, 10**9)
    eom = kd.kane(frame=frame, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("p", point, mass)],
                  loads=[(point, -damping * u * frame.x + sm.Rational(1, 3) * frame.x)])
    model = eom.numeric(backend="c", constants={mass: 1.0})
    quick = model.rhs(0.0, [0.0, 1.0])
    gate.set()
    _c_quick.finish_compiling(start_waiting=False)
    optimized = model.rhs(0.0, [0.0, 1.0])
    assert quick[1] == optimized[1] == -542719210271983 / 10**9 + 1 / 3


def test_the_derivation_cache_names_only_a_module_in_the_cache(fresh_cache, monkeypatch):
    """The derivation-cache entry of a built-in model (which names its module by
    key) is written once the optimized module is cached, and not at all when
    that build fails (the next process derives again, without a complaint)."""
    needs_tcc()

    def broken(*args, **kwargs):
        raise _c_build.CompilerError("the C compiler gcc failed (exit status 1): test")

    monkeypatch.setattr(_c_build, "_build", broken)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        kd.models.build("pendulum", lazy=True).numeric(backend="c")
        _c_quick.finish_compiling(start_waiting=False)
    assert list(fresh_cache.glob("derived/*.kdnum")) == []
    monkeypatch.undo()
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(fresh_cache))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    kd.models.build("pendulum", lazy=True).numeric(backend="c")
    _c_quick.finish_compiling(start_waiting=False)
    assert len(list(fresh_cache.glob("derived/*.kdnum"))) == 1


def test_the_quick_module_lives_in_the_cache_directory(fresh_cache):
    """Written where modules are run from (a temporary directory mounted
    noexec would not load it), in a quick-* folder removed at exit or, left by a
    killed process, with the stale builds."""
    needs_tcc()
    model = kd.models.build("pendulum").numeric(backend="c")
    folder = Path(model._module.__file__).parent
    assert folder.parent == fresh_cache and folder.name.startswith("quick-")
    _c_quick.finish_compiling(start_waiting=False)


def test_a_quick_module_that_does_not_load_leaves_the_optimized_build(fresh_cache,
                                                                      monkeypatch):
    needs_tcc()
    load = _c_build._load

    def refuses_quick(name, path):
        if "quick-" in str(path):
            raise ImportError(f"{path}: failed to map segment from shared object")
        return load(name, path)

    monkeypatch.setattr(_c_build, "_load", refuses_quick)
    monkeypatch.setattr(_c_quick, "_WARNED", set())
    with pytest.warns(RuntimeWarning, match="quick compiler .* could not build .*failed to map"):
        model = kd.models.build("pendulum").numeric(backend="c")
    assert Path(model._module.__file__).parent == fresh_cache


def test_no_quick_modules_where_extensions_share_their_symbols(monkeypatch):
    """TinyCC ignores symbol visibility: with RTLD_GLOBAL, two quick modules'
    functions would resolve to one another's."""
    needs_tcc()
    monkeypatch.setattr(sys, "getdlopenflags", lambda: os.RTLD_NOW | os.RTLD_GLOBAL)
    assert _c_quick.quick_command() is None


def test_a_quick_compiler_setting_that_is_no_command_is_named(fresh_cache, monkeypatch):
    monkeypatch.setenv("KANEDYN_QUICK_CC", 'tcc "')
    monkeypatch.setattr(_c_quick, "_WARNED", set())
    with pytest.warns(RuntimeWarning, match=r"KANEDYN_QUICK_CC is 'tcc \"', which is not a "
                                            r"command \(No closing quotation\)"):
        model = kd.models.build("pendulum").numeric(backend="c")
    assert Path(model._module.__file__).parent == fresh_cache


def test_a_model_built_while_the_interpreter_exits(tmp_path, generic_runtime_object):
    """Built in an exit hook (no thread would be joined any longer): the optimized
    build runs at once, the model moves onto it, and no quick-* folder is left.
    (The cache holds gcc's object of the generic runtime, as in ``fresh_cache``:
    the build in the hook still compiles the model's own units.)"""
    needs_tcc()
    generic_runtime_object(tmp_path)
    code = ("import atexit\nimport kanedyn as kd\n"
            "def late():\n"
            "    m = kd.models.build('pendulum').numeric(backend='c')\n"
            "    print(m._module.__file__, m.rhs(0.0, [0.3, 0.0])[1])\n"
            "atexit.register(late)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300, env=dict(os.environ, KANEDYN_CACHE_DIR=str(tmp_path)))
    path, value = run.stdout.split()
    assert Path(path).parent == tmp_path, run.stderr[-2000:]
    assert float(value) == pytest.approx(-9.81 * np.sin(0.3), rel=1e-12)
    assert list(tmp_path.glob("quick-*")) == []


#: forks right after the model's first module, the optimized build under way:
#: ``pool``, a pool of forked workers that first wait for it; ``fork``, three
#: children forked at once that wait for it
_FORKED_AT_ONCE = """
import json, multiprocessing, os, sys
import kanedyn as kd
definition = kd.models.build("chain3d", n=4)
model = definition.numeric(backend="c")
quick = model._module
y = definition.initial(model) + 0.1

def report():
    return [model._module is not quick, model.rhs(0.0, y).tolist()]

def task(k):
    return report()

if sys.argv[1] == "pool":
    with multiprocessing.get_context("fork").Pool(
            2, initializer=kd.numerics.finish_compiling) as pool:
        children = pool.map_async(task, range(6), chunksize=1).get(timeout=120)
else:
    pipes = []
    for _ in range(3):
        read, write = os.pipe()
        if os.fork() == 0:
            done = kd.numerics.finish_compiling(timeout=60)
            os.write(write, json.dumps(report() if done else "waiting").encode())
            os._exit(0)
        os.close(write)
        pipes.append(read)
    children = [json.loads(os.fdopen(read).read()) for read in pipes]
kd.numerics.finish_compiling()
print(json.dumps({"children": children, "parent": report()}))
"""


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork is POSIX only")
@pytest.mark.parametrize("how", ["pool", "fork"])
def test_workers_forked_at_once_move_onto_the_optimized_module(tmp_path, how,
                                                               generic_runtime_object):
    """Forks right after ``numeric(backend="c")``, while the optimized build opens
    its lock file and starts its compilers: no child holds the parent's lock or
    the pipe on which the parent waits for a compiler's start, so a pool whose
    workers wait for the optimized module finishes, and every worker (every
    child forked at once) runs the optimized module, with the parent's numbers.
    (Each cache holds gcc's object of the generic runtime, as in ``fresh_cache``:
    the build under way at the forks compiles the model's own units, about 1.2 s
    of gcc less for each of the four runs.)"""
    needs_tcc()
    for attempt in range(2):  # fresh caches: a build under way at each fork
        generic_runtime_object(tmp_path / f"{attempt}")
        run = subprocess.run([sys.executable, "-c", _FORKED_AT_ONCE, how], capture_output=True,
                             text=True, timeout=300, env=dict(
                                 os.environ, KANEDYN_CACHE_DIR=str(tmp_path / f"{attempt}")))
        assert run.returncode == 0, run.stderr[-3000:]
        report = json.loads(run.stdout.strip().splitlines()[-1])
        assert report["parent"][0]
        assert report["children"] == [report["parent"]] * len(report["children"])


@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork is POSIX only")
def test_a_child_removes_none_of_its_parents_folders(tmp_path):
    """A child that exits normally (its parent's exit hooks inherited) leaves the
    parent's private cache directory (the cache directory given is a file) and
    quick-* folder in place.  (The model from its equations: no derivation-cache
    entry, so no optimized build the parent would wait for at exit; a child
    forked during one is test_a_child_forked_during_the_optimized_build's.)"""
    (tmp_path / "a-file").write_text("not a directory")
    code = ("import os, sys, warnings\nimport kanedyn as kd\n"
            "from kanedyn.numerics.backends import _c_build\n"
            "warnings.simplefilter('ignore')\n"
            "definition = kd.models.build('pendulum')\n"
            "model = definition.numeric(definition.derive(), backend='c')\n"
            "folders = [_c_build._PRIVATE[0], *_c_build._PRIVATE[0].glob('quick-*')]\n"
            "pid = os.fork()\n"
            "if pid == 0:\n"
            "    sys.exit(0)\n"
            "os.waitpid(pid, 0)\n"
            "print(len(folders), all(folder.exists() for folder in folders))\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300,
                         env=dict(os.environ, KANEDYN_CACHE_DIR=str(tmp_path / "a-file")))
    assert run.stdout.split() == ["2" if _c_quick.quick_command() else "1", "True"], \
        run.stderr[-2000:]


def test_wait_for_a_compiler_gives_its_status_or_times_out():
    """``_fork.wait_for`` (the compilers' wait, without ``Popen.wait``'s polling)
    returns a process's exit status when it ends, and raises
    ``TimeoutExpired`` for one still running after the timeout, as ``Popen.wait``."""
    from kanedyn._fork import spawn, wait_for
    done = spawn([sys.executable, "-c", "import sys; sys.exit(3)"])
    assert wait_for(done, 30) == 3 and done.returncode == 3
    assert wait_for(done, 30) == 3  # already reaped: its status again
    running = spawn([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        with pytest.raises(subprocess.TimeoutExpired):
            wait_for(running, 0.05)
        for timeout in (0, -1):  # at once, as Popen.wait (poll would wait without end)
            with pytest.raises(subprocess.TimeoutExpired):
                wait_for(running, timeout)
        assert running.poll() is None
    finally:
        running.kill()
        running.wait()
