"""``kd.simulate_many``: many runs in C threads, equal to ``kd.simulate``'s compiled
loop run by run; inputs as records; failures, time limits and Ctrl-C keep what
was computed; the sweep integrates its local runs that way."""

import signal
import threading

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.numerics.backends import _c as _cbackend

pytestmark = pytest.mark.skipif(_cbackend.compiler_command() is None,
                                reason="simulate_many runs in the C backend; no C compiler")


def _model(name, **options):
    definition = kd.models.build(name, **options)
    model = definition.numeric(backend="c")
    return model, np.asarray(definition.initial(model), dtype=float)


@pytest.fixture(scope="module")
def pendulum():
    return _model("pendulum", torque=True)


@pytest.mark.parametrize("name", ["pendulum", "four-bar", "whipple-bicycle"])
def test_runs_equal_the_compiled_loop_run_by_run(name):
    """Different constants and initial states per run (the closed loop and the
    bicycle's dependent values completed per run, drift projected): the numbers
    and the evaluation counts of kd.simulate's compiled RK45."""
    model, y0 = _model(name)
    rng = np.random.default_rng(4)
    first = "g" if "g" in model.constants else list(model.constants)[0]
    values = model.constants[first] * (1 + 0.1 * rng.standard_normal(5))
    Y0 = y0 + 0.02 * rng.standard_normal((5, y0.size))
    t_eval = np.linspace(0.0, 1.5, 16)
    many = kd.simulate_many(model, Y0, (0.0, 1.5), constants={first: values}, t_eval=t_eval,
                            rtol=1e-9, atol=1e-9, threads=2)
    assert np.all(many.success) and many.y.shape == (5, 16, model.n_states)
    for i in range(5):
        one = kd.simulate(model.with_constants({first: values[i]}), (0.0, 1.5), Y0[i],
                          t_eval=t_eval, rtol=1e-9, atol=1e-9)
        assert one.method == "RK45 (compiled)"
        assert np.max(np.abs(one.y.T - many.y[i])) <= 1e-13
        assert one.nfev == many.nfev[i] and one.projections == many.projections[i]
    assert np.array_equal(many[model.state_names[0]], many.y[:, :, 0])
    run = many.run(2)
    assert np.array_equal(run.y, many.y[2].T) and run.success


def test_input_records_and_constant_inputs(pendulum):
    """A torque record per run, linear between samples: the same run as kd.simulate
    with np.interp of the record as the input's function."""
    model, y0 = pendulum
    times = np.linspace(0.0, 2.0, 9)
    record = np.random.default_rng(5).uniform(-1.0, 1.0, (3, times.size))
    t_eval = np.linspace(0.0, 2.0, 21)
    many = kd.simulate_many(model, y0, (0.0, 2.0), inputs={"tau": record}, input_times=times,
                            t_eval=t_eval)
    for i in range(3):
        driven = model.with_inputs({"tau": lambda t, r=record[i]: np.interp(t, times, r)})
        one = kd.simulate(driven, (0.0, 2.0), y0, t_eval=t_eval)
        assert np.max(np.abs(one.y.T - many.y[i])) <= 1e-12
    held = kd.simulate_many(model, y0, (0.0, 2.0), inputs={"tau": [0.0, 0.5]})
    one = kd.simulate(model.with_inputs({"tau": 0.5}), (0.0, 2.0), y0)
    assert np.max(np.abs(held.y_end[1] - one.y[:, -1])) <= 1e-12
    assert held.y.shape == (2, 2, 2)  # the two ends of the span without t_eval


def test_a_failed_run_and_the_time_limit_keep_what_was_computed(pendulum):
    """A run whose equations become singular ends with the message kd.simulate
    gives and its last state; the others finish.  A time limit ends all runs where
    they are."""
    model, y0 = pendulum
    many = kd.simulate_many(model, y0, (0.0, 1.0), constants={"l": [1.0, 0.0, 2.0]},
                            inputs={"tau": 0.0}, t_eval=np.linspace(0, 1, 5))
    assert list(many.status) == [0, -1, 0]
    one = kd.simulate(model.with_constants({"l": 0.0}), (0.0, 1.0), y0)
    assert many.message[1] == one.message and "singular" in many.message[1]
    assert np.all(np.isnan(many.y[1, 1:])) and np.isfinite(many.y_end[1]).all()
    long = kd.simulate_many(model, y0, (0.0, 1e7), inputs={"tau": np.zeros(4)},
                            timeout=0.2, threads=2)
    assert np.all(long.status == -1) and np.all(long.t_end < 1e7)
    assert all("time limit of 0.2 s" in m for m in long.message)
    # the runs the two threads were on stopped where they were; the others never began
    assert sorted(long.steps > 0) == [False, False, True, True]
    assert np.isfinite(long.y_end).all()


@pytest.mark.usefixtures("terminal_signals")
def test_ctrl_c_stops_every_run_and_returns_them(pendulum):
    model, y0 = pendulum
    timer = threading.Timer(0.3, signal.raise_signal, (signal.SIGINT,))
    timer.start()
    try:
        with pytest.raises(kd.SimulationInterrupted) as stop:
            kd.simulate_many(model, y0, (0.0, 1e7), inputs={"tau": np.zeros(3)}, threads=3,
                             timeout=60)
    finally:
        timer.cancel()
    result = stop.value.result
    assert isinstance(result, kd.EnsembleResult)
    assert all(m == "interrupted" for m in result.message)
    assert np.any(result.t_end > 0) and np.all(result.t_end < 1e7)
    assert np.all(np.isfinite(result.y_end))


def test_threads_do_not_change_the_numbers(pendulum):
    model, y0 = pendulum
    Y0 = y0 + np.linspace(0, 1, 40)[:, None] * [1.0, 0.0]
    runs = [kd.simulate_many(model, Y0, (0.0, 3.0), inputs={"tau": 0.1}, threads=k)
            for k in (1, 2, 3)]
    assert all(np.array_equal(r.y, runs[0].y) for r in runs[1:])


def test_bad_input_is_named(pendulum):
    model, y0 = pendulum
    with pytest.raises(kd.ModelError, match="give inputs=\\{'tau': ...\\}"):
        kd.simulate_many(model, y0, (0.0, 1.0))
    with pytest.raises(kd.ModelError, match="lenght are not constants"):
        kd.simulate_many(model, y0, (0.0, 1.0), constants={"lenght": 1.0}, inputs={"tau": 0})
    with pytest.raises(kd.OptionError, match="different numbers of runs \\(2, 3\\)"):
        kd.simulate_many(model, y0, (0.0, 1.0), constants={"l": [1, 2]},
                         inputs={"tau": [0, 1, 2]})
    with pytest.raises(kd.OptionError, match="must cover t_span"):
        kd.simulate_many(model, y0, (0.0, 2.0), inputs={"tau": [0.0, 1.0]},
                         input_times=[0.0, 1.0])
    with pytest.raises(kd.OptionError, match="y0 must have 2 entries"):
        kd.simulate_many(model, [0.1, 0.0, 0.0], (0.0, 1.0), inputs={"tau": 0})
    with pytest.raises(kd.ModelError, match="run 1: particle .*mass"):
        kd.simulate_many(model, y0, (0.0, 1.0), constants={"m": [1.0, -1.0]},
                         inputs={"tau": 0})
    numpy_model = kd.models.build("pendulum").numeric(backend="numpy")
    with pytest.raises(kd.ModelError, match="backend='c'"):
        kd.simulate_many(numpy_model, y0, (0.0, 1.0))
    contacts = kd.models.build("bouncing-ball")
    with pytest.raises(kd.ModelError, match="contacts \\(floor\\)"):
        kd.simulate_many(contacts.numeric(backend="c"), np.zeros(4), (0.0, 1.0))


def test_the_sweep_integrates_its_runs_together():
    """The serial sweep's rows through simulate_many equal those of one
    kd.simulate per run (forced by asking for each run's wall time)."""
    pytest.importorskip("pandas")
    model, y0 = _model("chain3d", n=3)
    params = {"g": (9.0, 10.0), "l": (0.4, 0.6), "q1": (0.0, 0.5)}
    common = dict(n=30, seed=1, scheduler="serial", progress=False,
                  t_eval=np.linspace(0.0, 2.0, 21))
    together = kd.sweep(model, params, y0, (0.0, 2.0), ("final", "max", "nfev", "t_end"),
                        **common)
    one_by_one = kd.sweep(model, params, y0, (0.0, 2.0),
                          ("final", "max", "nfev", "t_end", "wall_time"), **common)
    for column in together.columns:
        if column == "message":
            assert (together[column] == one_by_one[column]).all()
        else:
            assert np.allclose(together[column].astype(float),
                               one_by_one[column].astype(float), rtol=0, atol=1e-13)


# ------------------------------------------------------------ events (issue 39)
def _pendulum_events():
    """Events on the pendulum in its time, state, constant l and input tau: a downward
    zero of the angle, a height crossing either way, a terminal upward speed."""
    import sympy as sm
    import sympy.physics.mechanics as me
    q, u, tau = me.dynamicsymbols("q u tau")
    l, t = sm.symbols("l t")
    return [kd.Event(q, direction=-1), l * sm.sin(q) - 0.2 + tau * t,
            kd.Event(u - 2.7, terminal=True, direction=1, name="fast")]


def _by_hand(length, record, times):
    """The same events as Python functions of (t, y), written without kd.Event."""
    def zero(t, y):
        return y[0]

    def height(t, y):
        return length * np.sin(y[0]) - 0.2 + np.interp(t, times, record) * t

    def fast(t, y):
        return y[1] - 2.7
    zero.direction, fast.direction, fast.terminal = -1, 1, True
    return [zero, height, fast]


def test_events_are_located_as_the_compiled_loop_locates_them(pendulum):
    """Each run's events (times and states) equal kd.simulate's with the same events as
    Python functions, and with the same kd.Event; a terminal event ends its run there
    (status 1, the end state the event's, no outputs after it) while the others go on."""
    model, y0 = pendulum
    times = np.linspace(0.0, 10.0, 21)
    record = np.random.default_rng(1).uniform(-0.3, 0.3, (3, times.size))
    lengths = [1.0, 1.5, 2.0]
    t_eval = np.linspace(0.0, 10.0, 401)  # outputs within the terminal step too
    events = _pendulum_events()
    many = kd.simulate_many(model, [1.0, 0.0], (0.0, 10.0), constants={"l": lengths},
                            inputs={"tau": record}, input_times=times, t_eval=t_eval,
                            events=events)
    assert list(many.status) == [1, 0, 0]
    assert many.message[0] == "a termination event occurred"
    for i in range(3):
        driven = model.with_constants({"l": lengths[i]}).with_inputs(
            {"tau": lambda t, r=record[i]: np.interp(t, times, r)})
        by_hand = kd.simulate(driven, (0.0, 10.0), [1.0, 0.0], t_eval=t_eval,
                              events=_by_hand(lengths[i], record[i], times))
        same = kd.simulate(driven, (0.0, 10.0), [1.0, 0.0], t_eval=t_eval, events=events)
        for one in (by_hand, same):
            assert one.status == many.status[i] and one.message == many.message[i]
            for k in range(3):
                assert len(one.t_events[k]) == len(many.t_events[i][k])
                assert np.max(np.abs(one.t_events[k] - many.t_events[i][k]),
                              initial=0.0) <= 1e-12
                assert np.max(np.abs(one.y_events[k] - many.y_events[i][k]),
                              initial=0.0) <= 1e-12
            assert np.max(np.abs(one.y.T - many.y[i][:one.t.size])) <= 1e-12
            assert np.all(np.isnan(many.y[i][one.t.size:]))  # none past its end
        if i:  # the runs that go on meet many crossings
            assert sum(len(times_k) for times_k in many.t_events[i][:2]) > 5
    first = many.t_events[0][2]
    assert first.size == 1 and many.t_end[0] == first[0] and many.t_end[0] < 10.0
    assert np.array_equal(many.y_end[0], many.y_events[0][2][0])
    assert np.all(np.isnan(many.y[0][t_eval > first[0]]))
    run = many.run(0)
    assert run.status == 1 and np.array_equal(run.t_events[2], first)


def test_events_with_dependent_coordinates_and_projection():
    """The four-bar (dependent coordinates completed per run, drift projected): an
    event on a dependent angle, terminal, at kd.simulate's time and state."""
    import sympy.physics.mechanics as me
    model, y0 = _model("four-bar")
    dependent = me.dynamicsymbols(model.state_names[1])
    event = kd.Event(dependent - y0[1] - 0.3, terminal=True, direction=1)
    Y0 = y0 + 0.02 * np.random.default_rng(2).standard_normal((3, y0.size))
    t_eval = np.linspace(0.0, 3.0, 31)
    many = kd.simulate_many(model, Y0, (0.0, 3.0), events=event, t_eval=t_eval, rtol=1e-9,
                            atol=1e-9)
    assert np.all(many.status == 1)
    for i in range(3):
        one = kd.simulate(model, (0.0, 3.0), Y0[i], events=[event], t_eval=t_eval,
                          rtol=1e-9, atol=1e-9)
        assert one.status == 1
        assert abs(one.t_events[0][0] - many.t_end[i]) <= 1e-12
        assert np.max(np.abs(one.y_events[0][0] - many.y_end[i])) <= 1e-12


def test_an_event_that_is_a_python_function_is_refused(pendulum):
    model, y0 = pendulum

    def touchdown(t, y):
        return y[0]
    with pytest.raises(kd.OptionError, match="event touchdown is a Python function, which "
                       "cannot run in the C threads.*kd.Event\\(expression"):
        kd.simulate_many(model, y0, (0.0, 1.0), inputs={"tau": 0.0}, events=[touchdown])


def test_the_sweep_integrates_runs_with_expression_events_together(monkeypatch):
    """kd.sweep hands runs whose events are expressions to simulate_many (its event
    columns equal those of one kd.simulate per run with the same events as Python
    functions); Python functions keep the runs one by one."""
    pytest.importorskip("pandas")
    import sympy.physics.mechanics as me
    from kanedyn.simulation import _ensemble
    model, y0 = _model("pendulum")
    q, u = me.dynamicsymbols("q u")
    calls = []
    original = _ensemble.simulate_many
    monkeypatch.setattr(_ensemble, "simulate_many",
                        lambda *a, **k: calls.append(1) or original(*a, **k))

    def zero(t, y):
        return y[0]

    def fast(t, y):
        return y[1] + 3.0
    fast.terminal = True
    params = {"l": (0.5, 1.0, 2.0), "q": (0.5, 1.0, 2.5)}
    common = dict(scheduler="serial", progress=False)
    together = kd.sweep(model, params, y0, (0.0, 4.0), ("events", "final", "t_end"),
                        events=[q, kd.Event(u + 3.0, terminal=True)], **common)
    assert calls
    calls.clear()
    one_by_one = kd.sweep(model, params, y0, (0.0, 4.0), ("events", "final", "t_end"),
                          events=[zero, fast], **common)
    assert not calls
    assert (together.status == one_by_one.status).all() and (together.status == 1).any()
    for column in together.columns:
        if column != "message":
            assert np.allclose(together[column].astype(float),
                               one_by_one[column].astype(float), rtol=0, atol=1e-12,
                               equal_nan=True), column
