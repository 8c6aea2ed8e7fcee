"""Studies whose runs go through ``kd.simulate_many`` (issue 39): the seat-belt lock map
(its lock an expression event) and the OC3 spar in irregular seas over seeds (the
thrust compiled, the fluid kinematics sampled), each against its old path, one
``kd.simulate`` per run with Python functions."""

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.numerics.backends import _c as _cbackend

pytestmark = [pytest.mark.skipif(_cbackend.compiler_command() is None,
                                 reason="simulate_many runs in the C backend"),
              pytest.mark.slow]


def _counting(monkeypatch):
    """The calls of simulate_many, counted: the runs of each (the sweep takes it from
    its module, the studies from the simulation package, where it stays once loaded)."""
    import kanedyn.simulation
    from kanedyn.simulation import _ensemble
    calls = []
    original = _ensemble.simulate_many

    def counted(*args, **kwargs):
        calls.append(len(np.atleast_2d(args[1])))
        return original(*args, **kwargs)
    monkeypatch.setattr(_ensemble, "simulate_many", counted)
    monkeypatch.setattr(kanedyn.simulation, "simulate_many", counted)
    return calls


def test_seatbelt_lock_map_equals_runs_with_the_python_event(monkeypatch):
    """The lock map's sweep integrates its runs together (its tilt crossing compiled) and
    gives the lock times and crossing counts of one kd.simulate per run with the tilt
    crossing as a Python function of (t, y) (kanedyn.models.lock_events): times within
    1e-9 s."""
    pytest.importorskip("pandas")
    from kanedyn.analysis._seatbelt_studies import seatbelt_study_model
    from kanedyn.models import lock_events
    calls = _counting(monkeypatch)
    grid = dict(peak_g=[0.1, 5.0, 20.0], duration=[0.04, 0.1], direction=[0.0, 45.0],
                roll_rate=[0.0])
    lock_map = kd.studies.seatbelt_lock_map(**grid, t_end=0.15)
    assert sum(calls) == 12
    definition, model = seatbelt_study_model()
    python_event = lock_events(definition)
    parameters = dict(grid, direction=np.radians(grid["direction"]))
    old = kd.sweep(model, parameters, definition.initial(model), (0.0, 0.15),
                   outputs=("events",), events=python_event, scheduler="serial",
                   progress=False)
    assert sum(calls) == 12  # the Python event: run by run
    new = lock_map.table
    assert old.success.all() and new.success.all()
    assert np.array_equal(new.lock_crossings.to_numpy(), old.event0_count.to_numpy())
    assert new.locked.sum() >= 6 and (~new.locked).sum() >= 2
    times, reference = new.lock_time.to_numpy(), old.event0_first.to_numpy()
    assert np.array_equal(np.isnan(times), np.isnan(reference))
    assert np.nanmax(np.abs(times - reference)) <= 1e-9


def test_oc3_irregular_sea_seeds_in_the_ensemble(monkeypatch):
    """Two seeds of the OC3 spar (flexible tower, drag, Hs 6 m, Tp 10 s, steady wind 11.4
    m/s) through simulate_many against one kd.simulate per seed with the Python thrust
    and fluid kinematics: the tower-top and base outputs within 3e-3 of their standard
    deviations, those within 5e-4 of themselves (the kinematics sampled every
    SEA_INPUT_STEP s)."""
    from kanedyn.analysis._oc3_studies import SEA_INPUT_STEP, oc3_outputs, sea_runs
    calls = _counting(monkeypatch)
    options = dict(tower_modes=2, drag=True, wave_height=6.0, wave_period=10.0,
                   wind_speed=11.4, tmdi="off")
    d, model, t, together = sea_runs([1, 2], 100.0, **options)
    assert calls == [1] and SEA_INPUT_STEP == 0.025
    _, _, t_old, one_by_one = sea_runs([1, 2], 100.0, ensemble=False, **options)
    assert calls == [1] and np.array_equal(t, t_old)
    outputs = oc3_outputs(d, model)
    keep = t >= 25.0
    for name in ("top_displacement", "top_deflection", "base_moment"):
        row = outputs[name][0]
        stds = []
        for seed in range(2):
            new, old = row @ together[seed][keep].T, row @ one_by_one[seed][keep].T
            assert np.max(np.abs(new - old)) <= 3e-3 * np.std(old), name
            assert abs(np.std(new) / np.std(old) - 1) <= 5e-4, name
            stds.append(np.std(old))
        assert abs(stds[1] / stds[0] - 1) > 0.01  # the two seas differ
