"""The compiled backend: consistency with NumPy, the build cache, the compiled loop."""

import math
import multiprocessing
import os
import pickle
import re
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import kanedyn as kd
from kanedyn.numerics.backends import _c as _cbackend
from kanedyn.numerics.backends import _c_build, _c_quick
from kanedyn.numerics.backends._python import CodegenError

pytestmark = pytest.mark.skipif(_cbackend.compiler_command() is None,
                                reason="no C compiler")


@pytest.fixture(autouse=True)
def _optimizing_compiler_only(monkeypatch):
    """These tests check the optimizing compiler's builds, their cache and their
    order; models first compiled by the quick compiler are tests/test_quick_compile.py's
    (except in the tests that take ``quick_first``)."""
    monkeypatch.setenv("KANEDYN_QUICK_CC", "")


@pytest.fixture()
def quick_first(monkeypatch):
    """For the tests whose subject is the C code's numbers, not the optimizing
    compiler's build: models first compiled by the quick compiler, as by default
    (TinyCC where it is installed; the optimizing compiler otherwise), and no
    optimized build that waits for its use to pay ever starts (those a
    derivation-cache entry wants start at once, and are waited for at the end).
    The quick module gives the optimized one's numbers to the bit
    (tests/test_quick_compile.py: rhs, batches, energies, constraint residuals
    and runs of the seven models of MODELS, the pendulum there without its
    tension output and chain3d with six links), so the
    comparisons with the NumPy backend hold for both; the lane-wise code, which
    gcc vectorizes, and the builds themselves stay on the optimizing compiler.
    The tests that take this fixture had 21.5 s of the file's 81 s of gcc CPU
    (0.9 s after)."""
    monkeypatch.delenv("KANEDYN_QUICK_CC", raising=False)
    monkeypatch.setattr(_c_quick, "USE_PER_CHARACTER", math.inf)
    yield
    # a build started here would count in the build tests' statistics
    assert _c_quick.finish_compiling(timeout=600, start_waiting=False)

MODELS = [("pendulum", {"tension": True}), ("n-link-pendulum-on-cart", {"n": 3}),
          ("chain3d", {"n": 4}), ("chaplygin-sleigh", {"lateral_force": True}),
          ("four-bar", {}), ("rolling-disk", {"normal_force": True}),
          ("whipple-bicycle", {})]


def states(definition, model, count=3, seed=3):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        y = definition.initial(model) + rng.uniform(-0.2, 0.2, model.n_states)
        if model.n_q_dep or model.n_u_dep:
            y = model.consistent_state(0.0, y)
        out.append(y)
    return out


def relative(a, b):
    a, b = np.atleast_1d(np.asarray(a, float)), np.atleast_1d(np.asarray(b, float))
    return 0.0 if b.size == 0 else float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


@pytest.mark.parametrize("name, options", MODELS)
def test_numpy_and_c_agree(name, options, quick_first):
    d = kd.models.build(name, **options)
    eom = d.derive()
    fast, slow = d.numeric(eom, backend="c"), d.numeric(eom)
    for y in states(d, slow):
        # residuals are ~1e-16 at these consistent states: compare absolutely
        np.testing.assert_allclose(fast.constraint_residuals(0.3, y),
                                   slow.constraint_residuals(0.3, y), rtol=0, atol=1e-12)
        pairs = [(fast.rhs(0.3, y), slow.rhs(0.3, y)),
                 (fast.mass_matrix(0.3, y), slow.mass_matrix(0.3, y)),
                 (fast.forcing(0.3, y), slow.forcing(0.3, y)),
                 (fast.kinetic_energy(0.3, y), slow.kinetic_energy(0.3, y))]
        if slow.has_potential:
            pairs.append((fast.potential_energy(0.3, y), slow.potential_energy(0.3, y)))
        if slow.aux_names:
            pairs.append((list(fast.auxiliary(0.3, y).values()),
                          list(slow.auxiliary(0.3, y).values())))
        for a, b in pairs:
            assert relative(a, b) < 1e-12


def test_split_functions_agree(monkeypatch, quick_first):
    """Programs split into many C functions (values passed through memory);
    outputs copied from the work array by a loop over an index table."""
    monkeypatch.setattr(_cbackend, "CHUNK", 7)
    d = kd.models.build("whipple-bicycle")
    eom = d.derive()
    fast, slow = d.numeric(eom, backend="c"), d.numeric(eom)
    assert re.search(r"static const int kd_\w+_o\d+_w\[\d+\]\[2\]", fast.c_source())
    for y in states(d, slow):
        assert relative(fast.rhs(0.0, y), slow.rhs(0.0, y)) < 1e-12


def test_arrays_of_other_byte_order_or_layout_are_converted(quick_first):
    """rhs reads float64 buffers directly only when they are native, aligned and
    contiguous; a big-endian or strided state is converted first."""
    d = kd.models.build("chain3d", n=3)
    model = d.numeric(d.derive(), backend="c")
    y = np.random.default_rng(4).uniform(-1, 1, model.n_states)
    expected = model.rhs(0.0, y)
    np.testing.assert_array_equal(model.rhs(0.0, y.astype(">f8")), expected)
    strided = np.zeros(2 * y.size)
    strided[::2] = y
    np.testing.assert_array_equal(model.rhs(0.0, strided[::2]), expected)


def test_fresh_arrays_and_solve_ivp(quick_first):
    """Each call returns a new array, so solve_ivp integrates correctly."""
    d = kd.models.build("chain3d", n=3)
    eom = d.derive()
    fast, slow = d.numeric(eom, backend="c"), d.numeric(eom)
    y = np.array([0.1, -np.pi / 2 + 0.2, 0.1, 0.0, 0.0, 0.0])  # swinging, not chaotic
    first = fast.rhs(0.0, y)
    keep = first.copy()
    first[:] = 0.0
    np.testing.assert_array_equal(fast.rhs(0.0, y), keep)
    a = solve_ivp(fast.rhs, (0, 1), y, rtol=1e-10, atol=1e-10)
    b = solve_ivp(slow.rhs, (0, 1), y, rtol=1e-10, atol=1e-10)
    assert a.t.size == b.t.size
    np.testing.assert_allclose(a.y, b.y, rtol=0, atol=1e-8)  # step choices differ by rounding


def test_batch_states_and_parameters(quick_first):
    d = kd.models.build("n-link-pendulum-on-cart", n=2)
    eom = d.derive()
    for backend in ("c", "numpy"):
        model = d.numeric(eom, backend=backend, specified={d.symbols["F"]: 0.3})
        Y = np.array(states(d, model, count=5))
        np.testing.assert_allclose(model.rhs_batch(0.1, Y),
                                   [model.rhs(0.1, y) for y in Y], rtol=1e-13, atol=1e-13)
        names = list(model.constants)
        P = np.tile([model.constants[n] for n in names], (5, 1))
        P[:, names.index("g")] = np.linspace(1.0, 20.0, 5)
        batch = model.rhs_batch(0.1, Y, P)
        for i in range(5):
            single = d.numeric(eom, backend="numpy", constants={"g": P[i, names.index("g")]},
                               specified={d.symbols["F"]: 0.3})
            np.testing.assert_allclose(batch[i], single.rhs(0.1, Y[i]), rtol=1e-12, atol=1e-12)


def test_pickled_c_model():
    d = kd.models.build("four-bar")
    model = d.numeric(backend="c")
    clone = pickle.loads(pickle.dumps(model))
    y = model.consistent_state(0.0, d.initial(model))
    np.testing.assert_array_equal(clone.rhs(0.0, y), model.rhs(0.0, y))


# ---------------------------------------------------------------- the cache
def _build_in_process(cache):
    os.environ["KANEDYN_CACHE_DIR"] = cache
    d = kd.models.build("chain3d", n=3)
    model = d.numeric(backend="c")
    return model.rhs(0.0, d.initial(model)).tolist()


def test_concurrent_builds(tmp_path):
    """Several processes building the same module at once all succeed."""
    context = multiprocessing.get_context("spawn")
    with context.Pool(3) as pool:
        results = pool.map(_build_in_process, [str(tmp_path)] * 3)
    assert results[0] == results[1] == results[2]
    assert len(list(tmp_path.glob("_kd_*.json"))) == 1
    assert not list(tmp_path.glob("build-*"))  # temporary directories removed


def test_corrupt_cache_entry_is_rebuilt(tmp_path, monkeypatch, generic_runtime_object):
    """A damaged module in the cache is built again, with the same numbers (the
    generic runtime's object in the cache: the module is what is rebuilt)."""
    generic_runtime_object(tmp_path)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    d = kd.models.build("pendulum")
    eom = d.derive()
    expected = d.numeric(eom, backend="c").rhs(0.0, [0.4, 0.1])
    (library,) = tmp_path.glob("_kd_*.so")
    library.unlink()  # a new file: the library this process has mapped stays intact
    library.write_bytes(b"not a shared library")
    monkeypatch.setattr(_c_build, "_LOADED", {})
    np.testing.assert_array_equal(d.numeric(eom, backend="c").rhs(0.0, [0.4, 0.1]), expected)


def test_without_compiler_falls_back_to_numpy(monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    d = kd.models.build("pendulum")
    with pytest.warns(RuntimeWarning, match="CC is '/nonexistent/cc', which is not a program"):
        model = d.numeric(backend="c")
    assert repr(model).endswith("backend='numpy'>")
    assert np.isfinite(model.rhs(0.0, [0.3, 0.0])).all()


def particle_with_force(force_of_q):
    q, u = me.dynamicsymbols("q u")
    k = sm.symbols("k")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x)
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("p", P, 1)], loads=[(P, force_of_q(q, k) * N.x)])
    return eom, k


def test_unsupported_piecewise_is_reported():
    """A Piecewise that does not cover every case has no C form."""
    eom, k = particle_with_force(lambda q, k: sm.Piecewise((-k * q, q > 0), (0, q < -1)))
    with pytest.raises(CodegenError, match=r"q\(t\) > 0.*F_P.*numpy"):
        eom.numeric(constants={k: 2.0}, backend="c")
    model = eom.numeric(constants={k: 2.0})  # where it is defined, numpy evaluates it
    np.testing.assert_allclose(model.rhs(0.0, [0.5, 0.0]), [0.0, -1.0])
    np.testing.assert_allclose(model.rhs(0.0, [-2.0, 0.0]), [0.0, 0.0])


def test_unsupported_function_is_reported():
    """A Bessel function: not in C's math library; the numpy backend uses SciPy."""
    from scipy.special import jv
    eom, k = particle_with_force(lambda q, k: -k * sm.besselj(1, q))
    with pytest.raises(CodegenError, match="besselj"):
        eom.numeric(constants={k: 2.0}, backend="c")
    model = eom.numeric(constants={k: 2.0})
    np.testing.assert_allclose(model.rhs(0.0, [0.7, 0.0]), [0.0, -2.0 * jv(1, 0.7)])
    np.testing.assert_allclose(model.rhs_batch(0.0, [[0.7, 0.0], [0.2, 0.0]])[:, 1],
                               -2.0 * jv(1, np.array([0.7, 0.2])))


# --------------------------------------------------------- compiled loop
@pytest.fixture(scope="module")
def chain5():
    d = kd.models.build("chain3d", n=5)
    eom = d.derive()
    y0 = np.array([0.2, -np.pi / 2 + 0.3, 0.2, -0.2, 0.1, 0, 0, 0, 0, 0])
    return d, eom, y0


def test_compiled_rk45_is_scipys_rk45(chain5, quick_first):
    """Same algorithm: the same steps (up to rounding in the error estimate, which
    cancels) and states that agree to the integration tolerance."""
    d, eom, y0 = chain5
    model = d.numeric(eom, backend="c")
    ours = kd.simulate(model, (0, 10), y0, rtol=1e-8, atol=1e-8, backend="c")
    theirs = solve_ivp(model.rhs, (0, 10), y0, rtol=1e-8, atol=1e-8)
    assert ours.method == "RK45 (compiled)"
    assert abs(ours.t.size - theirs.t.size) <= 2
    assert abs(ours.nfev - theirs.nfev) <= 12
    n = min(ours.t.size, theirs.t.size)
    np.testing.assert_allclose(ours.t[:n], theirs.t[:n], rtol=0, atol=1e-8)
    np.testing.assert_allclose(ours.y[:, -1], theirs.y[:, -1], rtol=0, atol=1e-8)
    # the first steps coincide (same initial step, stages and step control) up to
    # rounding, which the error estimate amplifies (it cancels to ~1e-8): SciPy's
    # own RK45 on the numpy and on the C right-hand side (which differ by 1e-14)
    # is 5e-10 apart after four steps; a different method is ~1e-8 apart at once
    assert ours.t[1] == theirs.t[1]
    np.testing.assert_allclose(ours.t[:5], theirs.t[:5], rtol=0, atol=1e-10)
    np.testing.assert_allclose(ours.y[:, :5], theirs.y[:, :5], rtol=0, atol=1e-9)


def test_compiled_output_events_dense(chain5, quick_first):
    d, eom, y0 = chain5
    model = d.numeric(eom, backend="c")

    def crossing(t, y):
        return y[1] + np.pi / 2
    crossing.direction = -1.0

    def stop(t, y):
        return t - 7.5
    stop.terminal = True

    t_eval = np.linspace(0, 10, 101)
    ours = kd.simulate(model, (0, 10), y0, rtol=1e-10, atol=1e-10, t_eval=t_eval,
                       events=[crossing, stop], dense_output=True)
    ref = kd.simulate(model, (0, 10), y0, rtol=1e-10, atol=1e-10, t_eval=t_eval,
                      events=[crossing, stop], dense_output=True, backend="scipy")
    assert ours.status == ref.status == 1
    np.testing.assert_allclose(ours.t, ref.t)
    np.testing.assert_allclose(ours.y, ref.y, atol=1e-8)
    np.testing.assert_allclose(ours.t_events[0], ref.t_events[0], atol=1e-9)
    assert len(ours.t_events[0]) >= 2 and ours.t_events[1][0] == pytest.approx(7.5)
    for t in (0.05, 3.3, 7.4):
        np.testing.assert_allclose(ours.sol(t), ref.sol(t), atol=1e-8)


def test_compiled_projection_keeps_constraints(quick_first):
    d = kd.models.build("four-bar")
    model = d.numeric(backend="c")
    res = kd.simulate(model, (0, 5), d.initial(model), rtol=1e-6, atol=1e-6,
                      projection_tol=1e-7)
    assert res.success and res.projections > 0
    assert np.max(res.constraint_residual) <= 1e-7


def test_rosenbrock_on_a_stiff_problem(quick_first):
    q, u = me.dynamicsymbols("q u")
    k, c = sm.symbols("k c")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x)
    P.set_vel(N, u * N.x)
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("p", P, 1)], loads=[(P, (-k * q - c * u) * N.x)])
    model = eom.numeric(constants={k: 1e4, c: 1e3}, backend="c")
    ours = kd.simulate(model, (0, 2), [1.0, 0.0], method="Rosenbrock23", rtol=1e-6,
                       atol=1e-9)
    # the closed form of this linear system, exp(t A) y0 (SciPy's Radau at rtol
    # 1e-12, 2 s of CPU, agreed with it to 1e-17 at t = 2)
    A = np.array([[0.0, 1.0], [-1e4, -1e3]])
    exact = np.array([expm(t * A) @ [1.0, 0.0] for t in ours.t]).T
    assert ours.success and ours.njev > 0
    assert ours.t.size < 1000  # an explicit method would need ~1e5 steps here
    # along the run (the end alone, 2e-9 of the start, would pass a damping 1 %
    # off): 1.5e-4 at most measured (in the fast transient, where u peaks at
    # 9.6), against 9e-2 with c 1 % off; and the end to 1e-8
    np.testing.assert_allclose(ours.y, exact, rtol=0, atol=1e-3)
    np.testing.assert_allclose(ours.y[:, -1], exact[:, -1], atol=1e-8)


def test_compiled_failure_returns_what_was_computed(quick_first):
    d = kd.models.build("n-link-pendulum-on-cart", n=1)
    F = d.symbols["F"]
    model = d.numeric(backend="c", specified={F: lambda t: 0.0 if t < 1.0 else np.nan})
    res = kd.simulate(model, (0, 3), d.initial(model))
    assert res.method == "RK45 (compiled)"
    assert not res.success and res.status == -1
    assert 0.9 < res.t[-1] <= 1.0 + 1e-9
    assert np.all(np.isfinite(res.y))


def test_backend_choice_errors():
    d = kd.models.build("pendulum")
    numpy_model = d.numeric()
    with pytest.raises(ValueError, match="backend='c'"):
        kd.simulate(numpy_model, (0, 1), [0.3, 0.0], backend="c")
    with pytest.raises(ValueError, match="Rosenbrock23"):
        kd.simulate(numpy_model, (0, 1), [0.3, 0.0], method="Rosenbrock23")
    c_model = d.numeric(backend="c")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = kd.simulate(c_model, (0, 1), [0.3, 0.0], method="DOP853")
    assert res.method == "DOP853" and res.success


@pytest.mark.parametrize("name", ["slug-ellipsoid", "ladder", "falling-rod",
                                  "block-on-incline"])
def test_contact_functions_agree(name, quick_first):
    d = kd.models.build(name)
    eom = d.derive()
    fast, slow = d.numeric(eom, backend="c"), d.numeric(eom)
    rng = np.random.default_rng(5)
    y0 = slow.state(d.initial_state)
    k = len(slow.contacts)
    for modes in (["slip"] * k, ["stick"] + ["separated"] * (k - 1)):
        y = y0 + np.concatenate([np.zeros(slow.n_q), rng.uniform(-0.5, 0.5, slow.n_u)])
        a = fast.contact_dynamics(0.3, y, modes)
        b = slow.contact_dynamics(0.3, y, modes)
        for x, z in ((a.udot, b.udot), (a.normal_force, b.normal_force),
                     (a.friction, b.friction)):
            assert relative(x, z) < 1e-12


def test_contact_simulation_with_the_c_backend(quick_first):
    d = kd.models.build("falling-rod")
    eom = d.derive()
    fast, slow = d.numeric(eom, backend="c"), d.numeric(eom)
    y0 = slow.state(d.initial_state)
    a = kd.simulate(fast, (0.0, 0.8), y0, rtol=1e-10, atol=1e-10)
    b = kd.simulate(slow, (0.0, 0.8), y0, rtol=1e-10, atol=1e-10)
    assert len(a.impacts) == len(b.impacts) > 3
    assert np.allclose(a.y[:, -1], b.y[:, -1], rtol=1e-9, atol=1e-9)


BATCH_MODELS = [("chain3d", {"n": 3}, {}), ("four-bar", {}, {}),  # dependent speeds
                ("rolling-disk", {}, {}),
                ("n-link-pendulum-on-cart", {"n": 2}, {"F": 0.3})]  # a specified input


@pytest.mark.parametrize("name, options, inputs", BATCH_MODELS)
def test_batch_equals_loop_on_threads(name, options, inputs):
    """rhs_batch (C on 1, 2 and all threads; numpy) equals a loop of rhs calls."""
    d = kd.models.build(name, **options)
    eom = d.derive()
    specified = {d.symbols[k]: v for k, v in inputs.items()}
    for backend in ("c", "numpy"):
        model = d.numeric(eom, backend=backend, specified=specified)
        Y = np.array(states(d, model, count=70))  # > 2 x 32 rows: two threads in use
        t = np.linspace(0.0, 1.0, len(Y))
        loop = np.array([model.rhs(ti, y) for ti, y in zip(t, Y)])
        for threads in (1, 2, None):
            batch = model.rhs_batch(t, Y, threads=threads)
            np.testing.assert_allclose(batch, loop, rtol=1e-13, atol=1e-13)
        with pytest.raises(ValueError, match="threads"):
            model.rhs_batch(t, Y, threads=0)


LANE_MODELS = [("chain3d", {"n": 5}, {}), ("chain3d", {"n": 10}, {}),
               ("n-link-pendulum-on-cart", {"n": 2}, {"F": 0.3}),  # a specified input
               ("four-bar", {}, {})]  # dependent speeds: one row at a time


@pytest.mark.slow
@pytest.mark.parametrize("name, options, inputs", LANE_MODELS)
def test_batch_lanes_equal_rhs(name, options, inputs):
    """The lane-wise batch (4 states per SIMD op) equals rhs row by row, to 1e-13.

    73 rows: blocks of 4 lanes and a remainder done one row at a time; t per row.
    """
    d = kd.models.build(name, **options)
    specified = {d.symbols[k]: v for k, v in inputs.items()}
    model = d.numeric(d.derive(), backend="c", specified=specified)
    Y = np.array(states(d, model, count=73, seed=11))
    Y[:, :model.n_q] += np.random.default_rng(2).uniform(-1.0, 1.0, (73, model.n_q))
    if model.n_q_dep or model.n_u_dep:
        Y = np.array([model.consistent_state(0.0, y) for y in Y])
    t = np.linspace(0.0, 2.0, len(Y))
    loop = np.array([model.rhs(ti, y) for ti, y in zip(t, Y)])
    assert np.all(np.isfinite(loop))
    scalar = model.rhs_batch(t, Y, threads=1, lanes=False)
    np.testing.assert_array_equal(scalar, loop)
    if model.n_u_dep:  # no lane-wise code: asked for, it is refused by name
        with pytest.raises(ValueError, match="lanes=True.*dependent speeds"):
            model.rhs_batch(t, Y, lanes=True)
    for threads in (1, 2):
        batch = model.rhs_batch(t, Y, threads=threads)
        np.testing.assert_allclose(batch, loop, rtol=1e-13, atol=1e-13)


def test_batch_lanes_fall_back_where_the_mass_matrix_is_not_positive():
    """Lanes whose M is not positive definite (a negative mass) are redone by LU."""
    d = kd.models.build("chain3d", n=2)
    model = d.numeric(d.derive(), backend="c")
    rng = np.random.default_rng(8)
    Y = rng.uniform(-1, 1, (37, model.n_states))
    P = np.tile(list(model.constants.values()), (37, 1))
    masses = [i for i, name in enumerate(model.constants) if name.startswith("m")]
    P[5, masses[0]] = P[18, masses[-1]] = -3.0  # rows 5 and 18: indefinite M
    lanes = model.rhs_batch(0.0, Y, P, threads=1, lanes=True)
    np.testing.assert_array_equal(lanes, model.rhs_batch(0.0, Y, P, threads=1, lanes=False))
    for i in (5, 18, 30):  # M u' = f solved by numpy (with_constants refuses m < 0)
        qd, M, f = model._fn["dynamics"](0.0, Y[i], P[i], np.zeros(0))[:3]
        assert (np.linalg.eigvalsh(M).min() < 0) == (i != 30)
        np.testing.assert_allclose(lanes[i, :model.n_q], qd, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(lanes[i, model.n_q:], np.linalg.solve(M, f), rtol=1e-11)


def test_batch_lanes_on_a_kinematic_tree(tmp_path):
    """The lane-wise tree L^T D L (no work on the structural zeros) equals rhs."""
    parent = [-1, 0, 0, 1, 1]  # link k + 1 hangs from link parent[k] + 1
    lines = ['<?xml version="1.0"?>', '<robot name="tree">']
    for k in range(len(parent) + 1):
        lines.append(f'<link name="l{k}"><inertial><origin xyz="0.05 {0.01 * k} 0.02"/>'
                     f'<mass value="{1.0 + 0.1 * k}"/><inertia ixx="0.02" ixy="0.001" '
                     'ixz="-0.002" iyy="0.03" iyz="0.0005" izz="0.025"/></inertial></link>')
    for k, p in enumerate(parent):
        axis = ("1 0 0", "0 1 0", "0 0 1")[k % 3]
        lines.append(f'<joint name="j{k + 1}" type="continuous"><parent link="l{p + 1}"/>'
                     f'<child link="l{k + 1}"/><origin xyz="0.1 {0.05 * k} -0.2"/>'
                     f'<axis xyz="{axis}"/></joint>')
    lines.append("</robot>")
    (tmp_path / "tree.urdf").write_text("\n".join(lines))
    d = kd.models.from_urdf(tmp_path / "tree.urdf", efforts=False)
    model = d.numeric(d.derive(), backend="c")
    assert _cbackend.solver_source(model._functions, model._sizes)[0] == "#define KD_SOLVE 2"
    rng = np.random.default_rng(4)
    Y = rng.uniform(-1.5, 1.5, (41, model.n_states))
    loop = np.array([model.rhs(0.0, y) for y in Y])
    np.testing.assert_allclose(model.rhs_batch(0.0, Y, lanes=True), loop,
                               rtol=1e-13, atol=1e-13)


def test_batch_threads_with_parameters_and_singular_rows():
    d = kd.models.build("chain3d", n=2)
    model = d.numeric(d.derive(), backend="c")
    rng = np.random.default_rng(5)
    Y = rng.uniform(-1, 1, (100, model.n_states))
    P = np.tile(list(model.constants.values()), (100, 1))
    P[:, list(model.constants).index("g")] = np.linspace(1.0, 20.0, 100)
    one, two = model.rhs_batch(0.0, Y, P, threads=1), model.rhs_batch(0.0, Y, P, threads=2)
    np.testing.assert_array_equal(one, two)
    single = model.with_constants(P[57])
    np.testing.assert_allclose(two[57], single.rhs(0.0, Y[57]), rtol=1e-13, atol=1e-13)
    assert model.rhs_batch(0.0, Y[:0]).shape == (0, model.n_states)


# ------------------------------------------------ what the first module holds
def test_first_module_leaves_out_the_mass_matrix_and_the_lanes(tmp_path, monkeypatch,
                                                              generic_runtime_object):
    """The module built first has what rhs needs; M (a tree solved by the
    articulated-body pass) and the lane-wise batch come in a second module, built
    when first asked for, with the same numbers (modules counted, not units: the
    generic runtime's object is in the cache from the start)."""
    generic_runtime_object(tmp_path)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    rng = np.random.default_rng(5)
    # a tree of 12 speeds: rhs by the articulated-body pass, no M in the first module
    d = kd.models.build("chain3d", n=_cbackend.TREE_MIN_SPEEDS, style="positions")
    eom = d.derive()
    # an earlier test's optimized build would count below (a build still waiting for
    # its use to pay is not started)
    _c_quick.finish_compiling(start_waiting=False)
    before = _c_build.STATS["compiles"]
    model, reference = d.numeric(eom, backend="c"), d.numeric(eom, backend="numpy")
    assert _c_build.STATS["compiles"] == before + 1
    assert not hasattr(model._module, "dynamics")
    y = rng.uniform(-1, 1, model.n_states)
    np.testing.assert_allclose(model.rhs(0.0, y), reference.rhs(0.0, y), rtol=1e-11,
                               atol=1e-11)
    np.testing.assert_allclose(model.mass_matrix(0.0, y), reference.mass_matrix(0.0, y),
                               rtol=1e-12, atol=1e-12)
    assert _c_build.STATS["compiles"] == before + 2
    # a dense model: no lanes first; a large batch loads them
    d = kd.models.build("chain3d", n=4)
    model = d.numeric(d.derive(), backend="c")
    Y = rng.uniform(-1, 1, (model.LANES_FROM_ROWS, model.n_states))
    loop = np.array([model.rhs(0.0, row) for row in Y])
    with pytest.raises(ValueError, match="lanes=True"):
        model._c.rhs_batch(0.0, Y, lanes=True)  # the first module has none
    compiles = _c_build.STATS["compiles"]
    np.testing.assert_array_equal(model.rhs_batch(0.0, Y[:5]), loop[:5])
    assert _c_build.STATS["compiles"] == compiles  # a small batch: row by row
    np.testing.assert_allclose(model.rhs_batch(0.0, Y), loop, rtol=1e-13, atol=1e-13)
    assert _c_build.STATS["compiles"] == compiles + 1
    np.testing.assert_allclose(model._c.rhs_batch(0.0, Y, lanes=True), loop, rtol=1e-13,
                               atol=1e-13)


def test_units_shared_by_two_modules_compile_once(tmp_path, monkeypatch):
    """The second module of a model (with M) links the objects of the units it
    shares with the first (the articulated-body pass, the energy) from the object
    cache; a damaged cached object is compiled again, with the same numbers."""
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    monkeypatch.setattr(_c_build, "STATS", {"compiles": 0, "units": 0, "reused": 0})
    d = kd.models.build("chain3d", n=_cbackend.TREE_MIN_SPEEDS, style="positions")
    eom = d.derive()
    model, reference = d.numeric(eom, backend="c"), d.numeric(eom, backend="numpy")
    first = dict(_c_build.STATS)
    assert first["reused"] == 0 and first["units"] >= 3
    objects = sorted((tmp_path / "objects").glob("*.o"))  # the first module's units'
    y = np.random.default_rng(3).uniform(-1, 1, model.n_states)
    np.testing.assert_allclose(model.mass_matrix(0.0, y), reference.mass_matrix(0.0, y),
                               rtol=1e-12, atol=1e-12)
    reused = _c_build.STATS["reused"] - first["reused"]
    assert reused >= 2  # the pass and the energy at least (the generic runtime without lanes)
    assert _c_build.STATS["units"] - first["units"] >= 1  # M itself is new
    # every object of the first module damaged, the modules gone: the rebuild
    # compiles again.  Both damages in one rebuild (one compile of the units
    # less): garbage, which fails the link (the units reused are then compiled),
    # on every other object, and empty, as a crash can leave it (not reused: a
    # linker takes it as an empty script), on the rest
    def rebuild():
        for path in tmp_path.glob("_kd_*"):
            path.unlink()
        monkeypatch.setattr(_c_build, "_LOADED", {})
        return d.numeric(eom, backend="c")

    rebuild()
    assert len(objects) >= 3 and all(path.stat().st_size > 0 for path in objects)
    for k, path in enumerate(objects):
        path.write_bytes(b"" if k % 2 else b"not an object")
    before = dict(_c_build.STATS)
    again = rebuild()
    assert _c_build.STATS["units"] - before["units"] >= first["units"]
    np.testing.assert_allclose(again.rhs(0.0, y), reference.rhs(0.0, y), rtol=1e-11,
                               atol=1e-11)


def test_generic_runtime_reused_by_a_model_of_other_sizes(tmp_path, monkeypatch):
    """The generic runtime unit holds no sizes (the model's unit defines them as
    constants): the module of a model of other sizes links its object from the
    object cache instead of compiling it, and computes what the NumPy backend
    does; its first unit differs from the first module's only where the
    variant does (inputs, dependent coordinates, dependent speeds)."""
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    monkeypatch.setattr(_c_build, "STATS", {"compiles": 0, "units": 0, "reused": 0})
    sizes = {"n_q": 3, "n_u": 3, "n_q_dep": 0, "n_u_dep": 0, "n_p": 4, "n_r": 0}
    other = dict(sizes, n_q=7, n_u=6, n_p=11)
    assert _cbackend.predicted_runtime_unit(sizes) == _cbackend.predicted_runtime_unit(other)
    assert _cbackend.predicted_runtime_unit(sizes) != _cbackend.predicted_runtime_unit(
        dict(sizes, n_r=1))
    firsts, reuses, build, reuse = [], [], _c_build._build, _c_build._reuse

    def record_build(units, *args, **kwargs):
        units = list(units)
        firsts.append(units[0])
        return build(iter(units), *args, **kwargs)

    def record_reuse(cached, target):
        reuses.append(reuse(cached, target))
        return reuses[-1]

    monkeypatch.setattr(_c_build, "_build", record_build)
    monkeypatch.setattr(_c_build, "_reuse", record_reuse)
    for n in (3, 5):
        d = kd.models.build("chain3d", n=n)
        eom = d.derive()
        before, reuses[:] = dict(_c_build.STATS), []
        model, reference = d.numeric(eom, backend="c"), d.numeric(eom)
        y = np.random.default_rng(n).uniform(-1, 1, model.n_states)
        np.testing.assert_allclose(model.rhs(0.0, y), reference.rhs(0.0, y), rtol=1e-12,
                                   atol=1e-12)
        if n == 3:
            assert not any(reuses) and _c_build.STATS["reused"] == 0
    assert len(firsts) == 2 and firsts[0] == firsts[1]
    assert reuses[0]  # the generic runtime, the build's first unit, linked from the cache
    assert _c_build.STATS["reused"] - before["reused"] >= 1
    assert _c_build.STATS["units"] - before["units"] == len(reuses) - sum(reuses)


@pytest.mark.parametrize("name, options", [
    ("chain3d", {"n": 4}), ("four-bar", {}), ("rolling-disk", {}),
    ("chain3d", {"n": _cbackend.TREE_MIN_SPEEDS}),  # the articulated-body pass
])
def test_generic_runtime_compiles_while_the_model_is_derived(tmp_path, monkeypatch, name,
                                                              options):
    """A built-in model's generic runtime unit, predicted from its sizes before
    the derivation, is what the module's build makes first (dependent
    coordinates, dependent speeds, the tree pass alike), and the build takes
    the running compiler over: every unit compiled once, one compiler run
    fewer started by the build, nothing left behind."""
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    monkeypatch.setattr(_c_build, "STATS", {"compiles": 0, "units": 0, "reused": 0})
    prefetched, units, started = [], [], []
    prefetch, build, start = _c_build.prefetch, _c_build._build, _c_build._Jobs._start

    def record_prefetch(unit):
        prefetched.append(unit)
        prefetch(unit)

    def record_build(made, *args, **kwargs):
        units.extend(made)
        return build(iter(units), *args, **kwargs)

    def record_start(jobs, cmd):
        started.extend(["-c"] if "-c" in cmd else [])
        start(jobs, cmd)

    monkeypatch.setattr(_cbackend, "prefetch", record_prefetch)
    monkeypatch.setattr(_c_build, "_build", record_build)
    monkeypatch.setattr(_c_build._Jobs, "_start", record_start)
    d = kd.models.build(name, **options)
    model = d.numeric(backend="c")
    assert prefetched == [units[0]]
    assert _c_build.STATS["units"] == len(units) and _c_build.STATS["reused"] == 0
    assert len(started) == len(units) - 1
    assert not _c_build._PREFETCHED and not list(tmp_path.glob("build-*"))
    assert np.all(np.isfinite(model.rhs(0.0, d.initial(model))))


def test_command_line_run_compiles_the_runtime_while_deriving(tmp_path, monkeypatch, capsys):
    """``kanedyn run`` (C backend) starts the generic runtime before deriving the
    model, and the module's build takes that compiler run over."""
    from kanedyn.cli import main
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    taken = []
    take = _c_build._take_prefetched

    def record(key, first):
        found = take(key, first)
        taken.append(found is not None)
        return found

    monkeypatch.setattr(_c_build, "_take_prefetched", record)
    assert main(["run", "pendulum", "--out", str(tmp_path / "out"), "--quiet",
                 "--backend", "c"]) == 0
    assert "backend: c" in capsys.readouterr().out
    assert taken[0] and not any(taken[1:])


def _prefetched(unit, cache, monkeypatch):
    """Prefetch ``unit`` with the empty cache directory ``cache`` and wait for
    its compiler; ``(object it made, its place in the object cache)``."""
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(cache))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    _c_build.prefetch(unit)
    ((process, _, made, cached),) = _c_build._PREFETCHED.values()
    process.wait()
    return made, cached


def test_a_prefetched_unit_no_build_takes_is_dropped(tmp_path, monkeypatch):
    """A prefetched unit the next build does not start with (a wrong guess) is
    stopped when that build starts; one that finished is kept in the object
    cache (at exit too), and a cached unit is not prefetched again."""
    unit = _c_build.LIGHT_UNIT + "int kd_probe(void) { return 1; }\n"
    made, cached = _prefetched(unit, tmp_path, monkeypatch)
    _c_build._drop_prefetched()  # what the process does at exit
    assert cached.stat().st_size > 0 and not made.parent.exists()
    _c_build.prefetch(unit)
    assert not _c_build._PREFETCHED
    _c_build.prefetch(unit.replace("return 1", "return 2"))
    ((_, _, made, _),) = _c_build._PREFETCHED.values()
    d = kd.models.build("pendulum")
    model = d.numeric(d.derive(), backend="c")  # equations given: nothing prefetched
    assert not _c_build._PREFETCHED and not made.parent.exists()
    assert model.rhs(0.0, np.zeros(model.n_states)).shape == (model.n_states,)


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads /proc (Linux)")
def test_a_dropped_prefetch_stops_the_whole_compiler(tmp_path, monkeypatch):
    """Stopping a prefetched compile stops the compiler proper too (not only the
    driver, whose cc1 would run on and leave its files), and no folder stays."""
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    sizes = {"n_q": 7, "n_u": 7, "n_q_dep": 0, "n_u_dep": 0, "n_p": 3, "n_r": 0}
    _c_build.prefetch(_cbackend.predicted_runtime_unit(sizes))  # about 0.5 s of gcc
    ((driver, _, made, _),) = _c_build._PREFETCHED.values()

    def compiling():  # processes whose command line names the unit's folder
        found = []
        for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
            try:
                if str(made.parent).encode() in cmdline.read_bytes():
                    found.append(int(cmdline.parent.name))
            except OSError:
                pass  # a process that ended meanwhile
        return found

    deadline = time.monotonic() + 10
    while set(compiling()) <= {driver.pid} and driver.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.002)  # until the driver has started the compiler proper
    _c_build._drop_prefetched()
    stopped = time.monotonic() + 0.2  # a killed process may take a moment to go (the
    while compiling() and time.monotonic() < stopped:  # compiler would run 0.4 s more)
        time.sleep(0.005)
    assert not compiling() and not list(tmp_path.glob("prefetch-*"))


def test_a_failing_prefetched_unit_fails_its_build_and_leaves_nothing(tmp_path, monkeypatch):
    """A prefetched unit that does not compile fails the build that takes it
    with the compiler's message (as if the build had compiled it), and its
    folder is removed; the process's own prefetch folders survive the removal
    of stale build folders."""
    good = _c_build.LIGHT_UNIT + "int kd_probe_ok(void) { return 1; }\n"
    made, _ = _prefetched(good, tmp_path, monkeypatch)
    old = time.time() - 3 * 3600
    os.utime(made.parent, (old, old))
    _c_build._remove_stale_builds(tmp_path, 600)
    assert made.parent.exists()  # this process's: kept
    bad = _c_build.LIGHT_UNIT + "this is not C;\n"
    _c_build.prefetch(bad)
    with pytest.raises(_c_build.CompilerError, match="failed"):
        _c_build.load_module("a failing prefetched unit",
                             lambda: _c_build.UNIT_MARK.join([bad, good]))
    assert not _c_build._PREFETCHED and not list(tmp_path.glob("prefetch-*"))


def test_compiler_runs_start_costliest_first(tmp_path, monkeypatch):
    """Waiting compiler runs start by their cost (the size of their unit),
    the first added among equals; one at a time here, so they end in that
    order."""
    monkeypatch.setattr(_c_build, "build_jobs", lambda: 1)
    log = tmp_path / "order.txt"
    with _c_build._Jobs(["sh"], timeout=60) as jobs:
        for name, cost in (("small", 10), ("large", 300), ("medium", 50), ("large2", 300)):
            jobs.add(["sh", "-c", f"echo {name} >> {log}"], cost=cost)
        jobs.finish()
    assert log.read_text().split() == ["large", "large2", "medium", "small"]


def test_runtime_unit_at_O1_unless_it_holds_vectorized_loops(tmp_path, monkeypatch):
    """The two runtime units (entry points, integrator; the model's solve and
    table) are compiled at -O1; at -O2 where they hold the lane-wise solve
    or the contact loop; the energies at -O0 (off the simulations' path, and
    the same numbers as the numpy backend's); every other unit at -O2."""
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    compiled = []  # optimization level and first line of each compiled unit
    add = _c_build._Jobs.add

    def record(jobs, cmd, cost=0):
        if "-c" in cmd:
            with open(cmd[cmd.index("-c") + 1]) as unit:
                compiled.append((next(f for f in cmd if f.startswith("-O")), unit.readline()))
        add(jobs, cmd, cost)

    def levels():
        found = list(compiled)
        compiled.clear()
        return found

    monkeypatch.setattr(_c_build._Jobs, "add", record)

    d = kd.models.build("chain3d", n=4)
    eom = d.derive()
    model = d.numeric(eom, backend="c")
    light, cold = ("-O1", _c_build.LIGHT_UNIT), ("-O0", _c_build.COLD_UNIT)
    found = levels()  # the generic runtime first, the model's unit among the others
    assert found[0] == light and found.count(light) == 2 and found.count(cold) == 1
    assert {level for level, _ in found if (level, _) not in (light, cold)} == {"-O2"}
    y = np.random.default_rng(3).normal(size=model.n_states)
    reference = d.numeric(eom, backend="numpy").energies(0.3, y)
    np.testing.assert_allclose(model.energies(0.3, y), reference, rtol=1e-13)
    model.rhs_batch(0.0, np.zeros((model.LANES_FROM_ROWS, model.n_states)))  # lanes
    assert {level for level, _ in levels()} == {"-O2"}  # the energies' object reused
    d = kd.models.build("falling-rod")
    d.numeric(d.derive(), backend="c")
    found = levels()  # the contact loop is in the generic unit, not in the model's
    assert found[0][0] == "-O2" and found.count(light) == 1 and found.count(cold) == 1
    assert {level for level, _ in found if (level, _) not in (light, cold)} == {"-O2"}


def test_direct_printing_matches_sympys_printer():
    """Statements are printed without SymPy's printer where they are sums,
    products, powers and elementary functions: the same C text (up to the
    digits of a float literal, which name the same double, and the
    parentheses SymPy puts around a leading rational factor), SymPy's printer
    for anything else."""
    a, b, c, d = sm.symbols("a b c d")
    names = {a: "w[0]", b: "w[1]", c: "y[2]", d: "p[3]"}
    printer = _cbackend._CPrinter(names)
    exprs = [a * b - c * d, -2 * a * (b + c), sm.Rational(1, 2) * d * a - b, a / (b * c),
             (a + b) ** 2, a ** -3, sm.sqrt(a + b), 1 / sm.sqrt(a), -a / sm.sqrt(b + c),
             sm.sin(a) * sm.cos(b) - 0.25 * c, -(a + b), 2.5 * a ** 2 / b,
             a - sm.Rational(3, 4), a ** sm.Rational(3, 2), b / a ** sm.Rational(3, 2),
             sm.atan2(a, b), sm.Abs(a - b), sm.sign(c), a * (b - c) / (c + d) ** 2,
             sm.exp(-a), sm.Integer(-3), (-a) ** 3, c ** -5, 0.1 * a - 1e-20 * b, sm.nan]

    def same_value_text(text):
        text = re.sub(r"\((\d+\.\d+(?:e[-+]?\d+)?)\)", r"\1", text)  # a leading rational
        return re.sub(r"(?<![\w\[.])(\d+\.\d+(?:e[-+]?\d+)?)",
                      lambda m: repr(float(m.group(1))), text)

    for e in exprs:
        direct = _cbackend._print_c(printer, e, "test")
        assert same_value_text(direct) == same_value_text(printer.doprint(e)), e
    # an integer beyond C's integer literals is written as a double
    assert _cbackend._print_c(printer, sm.Integer(10 ** 30) * a, "test") == "1e+30*w[0]"
    unusual = sm.Piecewise((a, b > 0), (c, True))
    assert _cbackend._print_c(printer, unusual, "test") == printer.doprint(unusual)
    with pytest.raises(CodegenError, match="symbol x has no value"):
        _cbackend._print_c(printer, a + sm.Symbol("x"), "test")


def test_avx_encoding_where_the_cpu_runs_it():
    """On an x86-64 CPU with AVX (as NumPy's dispatch finds it), every unit is
    compiled with -mavx after its optimization level (the same numbers in
    fewer instructions), which is part of the build key; elsewhere nothing is
    added."""
    import sysconfig
    vex = _c_build._vex_flags()
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as features
    except ImportError:
        from numpy.core._multiarray_umath import __cpu_features__ as features
    x86 = sysconfig.get_platform().endswith(("x86_64", "amd64"))
    assert vex == (["-mavx"] if x86 and features.get("AVX") else [])
    for flags in (_c_build._FLAGS, _c_build._UNIT_FLAGS, _c_build._LIGHT_FLAGS,
                  _c_build._COLD_FLAGS):
        assert flags[0].startswith("-O") and flags[1:1 + len(vex)] == vex
