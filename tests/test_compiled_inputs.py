"""Specified inputs as piecewise polynomials evaluated in the compiled module (issue 37).

The seat-belt sensor's vehicle motion reaches the C module as data; its runs are
compared with the path of every run before: the same model with the inputs as
Python callables evaluating the motion (SciPy's splines, the closed-form pulse,
the integrated angles), called from the compiled loop at every right-hand side.
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.modeling import PiecewisePolynomial, tabulate
from kanedyn.models import build, lock_events

PULSES = ("frontal-48kmh", "oblique-30deg", "halfsine")


def _python_inputs(definition):
    """The definition's inputs as Python callables of the motion (the old path).

    The three components of a (kind, order) come from one ``motion.evaluate`` at
    the time asked: the callables keep the last time and its values, so the
    compiled loop's 16 inputs per right-hand side cost 6 evaluations instead of
    16 (2.7 times fewer, measured: 431,488 calls before over the three pulses'
    runs).  The values are those of ``motion.evaluate`` at exactly that time
    whatever was asked before (a pure function of t;
    ``test_the_python_inputs_do_not_depend_on_the_calls_before``).
    """
    motion = definition.symbols["motion"]
    last = {}

    def component(kind, order, index, t):
        kept = last.get((kind, order))
        if kept is None or kept[0] != t:
            kept = last[kind, order] = (t, motion.evaluate(kind, order, t))
        return float(kept[1][index])

    return {key: (lambda t, where=_component(motion, key): component(*where, t))
            for key in definition.specified}


def _component(motion, key):
    """``(kind, order, index)`` of an input ``key`` in ``motion.evaluate``."""
    base = key.expr if isinstance(key, sm.Derivative) else key
    order = len(key.variables) if isinstance(key, sm.Derivative) else 0
    i = motion.symbols.index(base)
    kind, index = ("position", i) if i < 3 else ("angles", i - 3)
    return kind, order, index


@pytest.fixture(scope="module")
def sensor():
    """``sensor(pulse, limit)``: the built definition, built once per module (the
    recorded pulses integrate their orientation when built)."""
    built = {}

    def get(pulse, limit="penalty"):
        if (pulse, limit) not in built:
            built[pulse, limit] = build("seatbelt-sensor", pulse=pulse, limit=limit)
        return built[pulse, limit]
    return get


def test_the_python_inputs_do_not_depend_on_the_calls_before(sensor):
    """Every input at shuffled times, asked twice in a row and interleaved with the
    other inputs, equals ``motion.evaluate`` at that time to the bit (a record
    with rotation: all six (kind, order) pairs are inputs)."""
    d = sensor("oblique-30deg", "none")
    motion = d.symbols["motion"]
    inputs = _python_inputs(d)
    assert len(inputs) == 16
    rng = np.random.default_rng(2)
    times = rng.permutation(np.concatenate([np.linspace(0.0, d.t_end, 7), [0.05, 0.05]]))
    for t in times:
        for key in rng.permutation(len(inputs)):
            key = list(inputs)[key]
            kind, order, index = _component(motion, key)
            fresh = float(motion.evaluate(kind, order, float(t))[index])
            assert inputs[key](float(t)) == fresh and inputs[key](float(t)) == fresh


@pytest.mark.parametrize("pulse", PULSES)
def test_tables_match_the_motion(pulse, sensor):
    """Every input within 1e-13 of its component's largest magnitude (a record
    without rotation: its splines' own pieces, to rounding)."""
    motion = sensor(pulse).symbols["motion"]
    lo, hi = motion.t_range if np.isfinite(motion.t_range[0]) else (-0.05, 0.4)
    t = np.linspace(lo, hi, 20011)
    for key, tables in motion.piecewise().items():
        exact = motion.evaluate(*key, t)
        for row, table in zip(exact, tables):
            assert np.max(np.abs(table(t) - row)) <= 1e-13 * max(np.max(np.abs(row)), 1e-300)


@pytest.mark.parametrize("pulse", PULSES)
def test_compiled_run_equals_the_python_inputs_run(pulse, sensor):
    """Without the housing wall (a smooth problem) the run equals the old path's to
    1e-9 of the state's size; with the wall the lock crossings do."""
    d = sensor(pulse, "none")
    compiled = d.numeric(backend="c")
    python = d.numeric(backend="c", specified=_python_inputs(d))
    assert compiled._c_model(compiled._module) is not None
    t_eval = np.linspace(0.0, d.t_end, 301)
    a, b = (kd.simulate(m, (0.0, d.t_end), d.initial(m), rtol=1e-8, atol=1e-8,
                        t_eval=t_eval) for m in (compiled, python))
    assert a.success and b.success
    assert np.max(np.abs(a.y - b.y)) <= 1e-9 * max(1.0, np.max(np.abs(b.y)))
    d = sensor(pulse)
    crossings = []
    for specified in (None, _python_inputs(d)):
        m = d.numeric(backend="c", specified=specified)
        res = kd.simulate(m, (0.0, d.t_end), d.initial(m), rtol=1e-8, atol=1e-8,
                          events=lock_events(d))
        crossings.append(np.asarray(res.t_events[0]))
    assert crossings[0].size == crossings[1].size >= 1
    assert crossings[0][0] == pytest.approx(crossings[1][0], rel=1e-9)  # the lock
    # after the wall's kink (k = 5 N m/rad from 30 deg) the runs part more: a
    # relative change of 1e-15 in the inputs moves the state by 4.5e-4 rad at
    # rtol 1e-8 (measured); the releases still agree to 1e-7
    np.testing.assert_allclose(crossings[0], crossings[1], rtol=1e-7)


def _ramp_model():
    """A particle driven by a spring whose anchor follows an input s(t)."""
    q, u, s = me.dynamicsymbols("q u s")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x)
    P.set_vel(N, u * N.x)
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("bob", P, 1.0)], loads=[(P, 100.0 * (s - q) * N.x)])
    return eom, s


def test_c_and_numpy_evaluate_a_table_alike():
    eom, s = _ramp_model()
    table = tabulate(lambda t: np.sin(7 * t)[None], np.linspace(0, 2, 5), 1, ["sin 7t"])[0]
    c = eom.numeric(specified={s: table}, backend="c")
    py = eom.numeric(specified={s: table}, backend="numpy")
    closed = eom.numeric(specified={s: sm.sin(7 * me.dynamicsymbols._t)}, backend="numpy")
    for t in np.linspace(0.0, 2.0, 37):
        y = np.array([0.3 * t, -0.2])
        np.testing.assert_allclose(c.rhs(t, y), py.rhs(t, y), rtol=1e-15, atol=1e-15)
        # the table within 1e-13 of sin 7t at its check points (1.3e-13 between them
        # measured); the force is 100 (s - q)
        np.testing.assert_allclose(c.rhs(t, y), closed.rhs(t, y), rtol=0, atol=1e-10)
    batch = c.rhs_batch(np.linspace(0.0, 2.0, 5), np.tile([0.1, 0.2], (5, 1)))
    np.testing.assert_allclose(batch, [py.rhs(t, [0.1, 0.2]) for t in np.linspace(0, 2, 5)],
                               rtol=1e-15, atol=1e-15)


def test_a_time_outside_the_table_names_the_input():
    eom, s = _ramp_model()
    table = PiecewisePolynomial([0.0, 0.5, 1.0], [[1.0, 0.0], [1.0, 0.5]], "ramp.csv: s")
    c = eom.numeric(specified={s: table}, backend="c")
    assert c.rhs(1.0, [0.0, 0.0])[1] == pytest.approx(100.0)
    with pytest.raises(ValueError, match=r"specified input s\(t\): ramp\.csv: s: defined for "
                                         r"0 s <= t <= 1 s only \(asked at t = 1\.5 s\)"):
        c.rhs(1.5, [0.0, 0.0])
    res = kd.simulate(c, (0.0, 2.0), [0.0, 0.0])  # the compiled loop keeps what it had
    assert not res.success
    assert "specified input s(t): ramp.csv: s: defined for 0 s <= t <= 1 s only" in res.message
    assert res.t[-1] <= 1.0 + 1e-9


def test_piecewise_polynomial_checks_its_data():
    with pytest.raises(kd.ModelError, match=r"x: the breaks must increase strictly"):
        PiecewisePolynomial([0.0, 0.0, 1.0], [[1.0], [2.0]], "x")
    with pytest.raises(kd.ModelError, match=r"x: a piecewise polynomial needs n \+ 1 breaks"):
        PiecewisePolynomial([0.0, 1.0], [[1.0], [2.0]], "x")
    with pytest.raises(kd.ModelError, match=r"x: breaks and coefficients must be finite"):
        PiecewisePolynomial([0.0, 1.0], [[np.nan]], "x")
    ok = PiecewisePolynomial([0.0, 1.0], [[2.0, 1.0]], "x", extrapolate=True)
    assert ok(3.0) == 7.0  # 2 t + 1, continued


def test_one_time_and_many_times_give_the_same_bits():
    """A table asked at one time (Python floats, the numpy backend's per-step call)
    and at many (NumPy arrays) evaluates the same operations: equal bit for bit,
    at random times, at the breaks and just inside the accepted span; a time
    outside it or NaN is refused the same way."""
    rng = np.random.default_rng(7)
    for k in (1, 2, 4, 8):
        breaks = np.cumsum(rng.uniform(0.1, 1.0, 16))
        table = PiecewisePolynomial(breaks, rng.normal(size=(15, k)), "r.csv: x")
        times = np.concatenate([rng.uniform(breaks[0], breaks[-1], 500), breaks,
                                table.limits()])
        one = [table(t) for t in times.tolist()] + [table(t) for t in times[:20]]
        assert all(type(v) is float for v in one)
        np.testing.assert_array_equal(one, np.concatenate([table(times), table(times[:20])]))
        for bad in (float("nan"), breaks[-1] + 1.0, int(breaks[0]) - 1):
            with pytest.raises(kd.ModelError, match=r"r\.csv: x: defined for .* only"):
                table(bad)


def test_tabulate_refuses_what_it_cannot_reach():
    with pytest.raises(kd.ModelError, match=r"tabulate: jump: not within 1e-13 .* near "
                                            r"t = 0\.3"):
        tabulate(lambda t: np.sign(t - 0.3)[None], [0.0, 1.0], 1, ["jump"])
