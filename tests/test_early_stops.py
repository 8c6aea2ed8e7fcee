"""Runs that stop early (Ctrl-C, a failure at the first step) through every output
path: what was computed is kept, and every output says what happened instead of
raising an indexing error."""

import pickle
import signal

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.cli import main


# Ctrl-C reaches the runs as in a terminal, whatever the disposition inherited
pytestmark = pytest.mark.usefixtures("terminal_signals")


def ctrl_c_at_call(n):
    """A user event that presses Ctrl-C once, at its ``n``-th call under the run's
    guard (which turns a first SIGINT into a stop with the partial result)."""
    calls = []

    def event(t, y):
        if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
            calls.append(t)
            if len(calls) == n:
                signal.raise_signal(signal.SIGINT)
        return 1.0

    return event


def interrupted(model, t_span, y0, n, **options):
    with pytest.raises(kd.SimulationInterrupted) as stop:
        kd.simulate(model, t_span, y0, events=[ctrl_c_at_call(n)], **options)
    return stop.value.result


@pytest.fixture(scope="module")
def falling_rod():
    definition = kd.models.build("falling-rod")
    model = definition.numeric(definition.derive(), backend="numpy")
    return model, definition.initial(model)


def test_a_contact_run_stopped_before_its_first_output_time(falling_rod, tmp_path):
    model, y0 = falling_rod
    res = interrupted(model, (0.0, 2.0), y0, 1, t_eval=[0.0, 2.0])
    assert res.t.size == 0 and res.message == "interrupted"
    summary = res.summary()
    assert summary["points"] == 0 and summary["t_end"] is None
    assert summary["energy_balance"] is None and res.energy_balance().size == 0
    rows = res.to_csv(tmp_path / "rod.csv").read_text().splitlines()
    assert len(rows) == 1  # the header only
    assert "interrupted" in res._repr_html_()


def test_an_interrupted_contact_run_keeps_the_state_it_reached(falling_rod):
    """Sparse output times: the state where the last segment ended (before its
    impacts) is kept, so that its impacts, energy balance and final state agree."""
    model, y0 = falling_rod
    res = interrupted(model, (0.0, 1000.0), y0, 50, t_eval=[0.0, 1000.0])
    assert res.t.size == 2 and 0.0 < res.t[-1] < 1000.0
    assert res.impacts and all(impact.t <= res.t[-1] for impact in res.impacts)
    assert abs(res.summary()["energy_balance"]) < 1e-6
    full = kd.simulate(model, (0.0, res.t[-1]), y0, t_eval=[0.0, res.t[-1]])
    np.testing.assert_allclose(res.y[:, -1], full.y[:, -1], rtol=1e-6, atol=1e-8)


def test_energy_balance_counted_from_the_first_output_time(falling_rod):
    model, y0 = falling_rod
    from_start = kd.simulate(model, (0.0, 1.0), y0, t_eval=np.linspace(0.0, 1.0, 6))
    from_later = kd.simulate(model, (0.0, 1.0), y0, t_eval=np.linspace(0.5, 1.0, 6))
    assert from_later.impacts
    assert np.max(np.abs(from_start.energy_balance())) < 1e-6
    assert np.max(np.abs(from_later.energy_balance())) < 1e-6


def test_a_contact_result_with_mode_changes_pickles(falling_rod):
    model, y0 = falling_rod
    res = kd.simulate(model, (0.0, 1.0), y0)
    assert res.mode_history
    again = pickle.loads(pickle.dumps(res))
    assert again.mode_history == res.mode_history
    assert again.mode_history[0].t == res.mode_history[0].t


def test_a_sweep_row_keeps_the_message_of_a_run_with_no_output():
    """A force that is not finite after t = 0 stops every run before its first
    output time: the rows say so (not an indexing error) and have no values."""
    definition = kd.models.build("n-link-pendulum-on-cart")
    (force,) = definition.specified
    model = definition.numeric(specified={force: lambda t, y=None: 0.0 if t == 0 else np.nan},
                               backend="numpy")
    table = kd.sweep(model, {"m_c": [1.0, 2.0]}, definition.initial(model), (0.0, 2.0),
                     outputs=("final", "max", "t_end"), scheduler="serial", progress=False,
                     t_eval=np.linspace(0.5, 2.0, 4))
    assert not table["success"].any()
    assert table["message"].str.contains("not finite at t=").all()
    assert table[["final_q0", "max_q0", "t_end"]].isna().all().all()


def test_the_seatbelt_report_of_a_run_with_no_output_point():
    definition = kd.models.build("seatbelt-sensor")
    model = definition.numeric(backend="numpy")
    res = interrupted(model, (0.0, 0.2), definition.initial(model), 1, t_eval=[0.0, 0.2])
    assert res.t.size == 0
    with pytest.raises(kd.ModelError, match="no output point.*interrupted"):
        kd.models.seatbelt_report(res, definition)


def test_the_newton_euler_check_refuses_flexible_bodies_and_singular_states():
    definition = kd.models.build("flexible-robot")
    model = definition.numeric(backend="numpy")
    y0 = definition.initial(model)
    with pytest.raises(kd.ModelError, match="body 'link' is a FlexibleBody"):
        kd.check_newton_euler(model, t=[0.0], y=y0)
    pendulum = kd.models.build("pendulum")
    massless = pendulum.numeric(backend="numpy").with_constants({"m": 0.0})
    with pytest.raises(kd.ModelError, match="singular there"):
        kd.check_newton_euler(massless, t=[0.0], y=pendulum.initial(massless))


def test_kanedyn_run_of_the_seatbelt_sensor_stopped_before_its_first_output(
        tmp_path, monkeypatch, capsys):
    """The report needs output points: without any it is left out, and the run's
    files and summary are still written."""
    from kanedyn.cli import _run
    simulate = _run._simulate

    def stopped_at_once(model, t_end, y0, args, progress, forces):
        with pytest.raises(kd.SimulationInterrupted) as stop:
            kd.simulate(model, (0.0, t_end), y0, events=[ctrl_c_at_call(1)],
                        t_eval=[0.0, t_end])
        raise stop.value

    monkeypatch.setattr(_run, "_simulate", stopped_at_once)
    code = main(["run", "seatbelt-sensor", "--backend", "numpy", "--out", str(tmp_path)])
    out, err = capsys.readouterr()
    assert code == 130, err
    assert "points: 0, t_end: none reached" in out and "report" not in out
    assert (tmp_path / "summary.json").exists() and (tmp_path / "seatbelt-sensor.csv").exists()
    assert simulate is not _run._simulate


def test_the_lock_map_study_tells_failed_runs_from_no_lock(tmp_path, monkeypatch):
    from kanedyn.analysis import _seatbelt_studies
    lock_map = _seatbelt_studies.seatbelt_lock_map
    monkeypatch.setattr(_seatbelt_studies, "seatbelt_lock_map", lambda **options: lock_map(
        constants={"m": 0.0, "I": 0.0}, **options))  # no inertia: no run can start
    study = kd.studies.run_study("seatbelt-map", out=tmp_path, quiet=True, peak_g="5,20",
                                 duration="0.06", direction="0", backend="numpy")
    assert "2 of 2 runs failed and say nothing about locking (first: cannot start" \
        in study.summary
    rows = study.csv_files[0].read_text().splitlines()
    assert rows[0].endswith(",run") and all("failed: cannot start" in row for row in rows[1:])


def test_a_result_of_one_output_time_is_drawn_as_points():
    definition = kd.models.build("pendulum")
    model = definition.numeric(backend="numpy")
    res = kd.simulate(model, (0.0, 1.0), definition.initial(model), t_eval=[0.5])
    lines = [line for ax in res.plot().axes for line in ax.get_lines()]
    assert len(lines) == 3 and all(line.get_marker() == "o" for line in lines)


def test_an_input_or_event_that_raises_at_the_start():
    """An input's function that raises at t0: a "cannot start" result naming it
    (as for a value that is not finite); an event that raises there: an error
    naming the event."""
    definition = kd.models.build("n-link-pendulum-on-cart")
    (force,) = definition.specified

    def broken(t, y=None):
        raise RuntimeError("no data")

    model = definition.numeric(specified={force: broken}, backend="numpy")
    y0 = definition.initial(model)
    res = kd.simulate(model, (0.0, 1.0), y0)
    assert not res.success and res.t.size == 1
    assert res.message.startswith("cannot start: specified input F(t): its function raised "
                                  "RuntimeError at t=0: no data")

    def contact_check(t, y):
        raise RuntimeError("no sensor")

    steady = definition.numeric(specified={force: 0.0}, backend="numpy")
    with pytest.raises(kd.ModelError, match="event contact_check raised RuntimeError at the "
                                            "initial state \\(t=0\\): no sensor"):
        kd.simulate(steady, (0.0, 1.0), y0, events=[contact_check])
