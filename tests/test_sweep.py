"""kd.sweep: runs equal single simulations, the pendulum's period across a
grid, failed runs as rows, resuming (a deleted part, Ctrl-C, another sweep's
folder), and a worker process killed during a sweep on a real local cluster."""

import math
import os
import signal
import threading
import time

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.simulation import _sweep

pd = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")


@pytest.fixture(scope="module")
def pendulum():
    d = kd.models.build("pendulum")
    model = d.numeric()
    return d, model


# ------------------------------------------------------- without Dask
def test_grid_and_samples(pendulum):
    _, model = pendulum
    names, values = _sweep.parameter_runs(model, {"l": [0.5, 1.0, 2.0], "q": [0.1, 0.2]})
    assert names == ["l", "q"] and values.shape == (6, 2)
    assert values[:, 0].tolist() == [0.5, 0.5, 1.0, 1.0, 2.0, 2.0]
    from scipy import stats
    spec = {"m": (1.0, 2.0), "g": stats.norm(9.81, 0.01)}
    a = _sweep.parameter_runs(model, spec, n=50, seed=7)[1]
    b = _sweep.parameter_runs(model, spec, n=50, seed=7)[1]
    np.testing.assert_array_equal(a, b)
    assert a.shape == (50, 2) and np.all((a[:, 0] >= 1.0) & (a[:, 0] < 2.0))
    assert abs(a[:, 1].mean() - 9.81) < 0.01


@pytest.mark.parametrize("parameters, kwargs, error, message", [
    ({"length": [1.0], "mass": [2.0]}, {}, kd.ModelError, "length, mass: not constant"),
    ({"l": "1,2"}, {}, kd.OptionError, "parameter l: give a number"),
    ({"l": (2.0, 1.0)}, {"n": 5}, kd.OptionError, "low < high"),
    ({"l": (1.0, 2.0)}, {"n": 0}, kd.OptionError, "positive integer"),
])
def test_bad_parameters(pendulum, parameters, kwargs, error, message):
    d, model = pendulum
    with pytest.raises(error, match=message):
        kd.sweep(model, parameters, d.initial(model), (0, 1), scheduler="serial",
                 progress=False, **kwargs)


def test_bad_output(pendulum):
    d, model = pendulum
    with pytest.raises(kd.OptionError, match="unknown output.*'peak'"):
        kd.sweep(model, {"l": 1.0}, d.initial(model), (0, 1), outputs=["peak"],
                 scheduler="serial", progress=False)


def test_serial_equals_simulate_and_failures_are_rows(pendulum):
    d, model = pendulum
    y0 = d.initial(model)
    table = kd.sweep(model, {"m": [1.0, -1.0], "q": [0.3, 0.5]}, y0, (0.0, 1.0),
                     outputs=("final", "max", "nfev"), scheduler="serial", progress=False,
                     rtol=1e-10, atol=1e-10)
    assert table["run"].tolist() == [0, 1, 2, 3]
    for _, row in table.iterrows():
        if row["m"] < 0:  # a negative mass: the run fails, the sweep goes on
            assert not row["success"] and "negative mass" in row["message"]
            continue
        y = y0.copy()
        y[model.index("q")] = row["q"]
        res = kd.simulate(model.with_constants({"m": row["m"]}), (0.0, 1.0), y,
                          rtol=1e-10, atol=1e-10)
        assert row["success"] and row["final_q"] == res.y[0, -1]
        assert row["final_u"] == res.y[1, -1] and row["max_u"] == res.y[1].max()
        assert row["rhs_evaluations"] == res.nfev


def test_resume_after_a_lost_part_and_ctrl_c(pendulum, tmp_path, monkeypatch):
    d, model = pendulum
    y0 = d.initial(model)
    grid = {"l": np.linspace(0.5, 2.0, 8)}
    out = tmp_path / "sweep"
    first = kd.sweep(model, grid, y0, (0, 1), out=out, batch_size=2, scheduler="serial",
                     progress=False)
    assert (out / "results.parquet").exists() and len(list(out.glob("part-*"))) == 4
    (out / "part-0000004.parquet").unlink()
    calls = []
    original = _sweep.run_batch

    def counting(model, batch, *args):
        calls.append([run for run, _ in batch])
        return original(model, batch, *args)
    monkeypatch.setattr(_sweep, "run_batch", counting)
    again = kd.sweep(model, grid, y0, (0, 1), out=out, batch_size=2, scheduler="serial",
                     progress=False)
    assert calls == [[4, 5]]  # only the lost runs
    pd.testing.assert_frame_equal(first, again)

    def interrupted(model, batch, *args):
        if batch[0][0] >= 4:
            raise KeyboardInterrupt
        return original(model, batch, *args)
    other = tmp_path / "other"
    monkeypatch.setattr(_sweep, "run_batch", interrupted)
    with pytest.raises(kd.SweepInterrupted, match="4 of 8 runs saved in .*run the same sweep"
                       ) as stop:
        kd.sweep(model, grid, y0, (0, 1), out=other, batch_size=2, scheduler="serial",
                 progress=False)
    assert stop.value.table["run"].tolist() == [0, 1, 2, 3]
    monkeypatch.setattr(_sweep, "run_batch", original)
    resumed = kd.sweep(model, grid, y0, (0, 1), out=other, batch_size=2, scheduler="serial",
                       progress=False)
    pd.testing.assert_frame_equal(first, resumed)
    with pytest.raises(kd.OptionError, match="holds another sweep .*t_span"):
        kd.sweep(model, grid, y0, (0, 2), out=other, scheduler="serial", progress=False)


# ---------------------------------------------------------- on Dask
@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("distributed")
    import logging
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.ERROR)
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


@pytest.mark.slow
def test_dask_sweep_equals_simulate_and_pendulum_period(pendulum, client, tmp_path):
    """On two worker processes: rows equal single runs bit for bit, and the
    small-amplitude period 4 t(q = 0) equals 2 pi sqrt(l/g) for every l."""
    d, model = pendulum
    y0 = d.initial(model)
    y0[model.index("q")], y0[model.index("u")] = 0.01, 0.0
    def crossing(t, y):  # a local function: Dask's cloudpickle ships it by value
        return y[0]
    crossing.terminal = True
    lengths = [0.25, 0.5, 1.0, 2.0, 4.0]
    table = kd.sweep(model, {"l": lengths}, y0, (0.0, 5.0), outputs=("final", "events"),
                     client=client, out=tmp_path / "p", table_format="csv", progress=False,
                     events=[crossing], rtol=1e-11, atol=1e-12)
    assert (tmp_path / "p" / "results.csv").exists()
    g = model.constants["g"]
    for _, row in table.iterrows():
        period = 4 * row["event0_first"]
        exact = 2 * math.pi * math.sqrt(row["l"] / g) * (1 + 0.01 ** 2 / 16)
        assert abs(period - exact) < 1e-7 * exact
        res = kd.simulate(model.with_constants({"l": row["l"]}), (0.0, 5.0), y0,
                          events=[crossing], rtol=1e-11, atol=1e-12)
        assert row["final_q"] == res.y[0, -1] and row["event0_first"] == res.t_events[0][0]


@pytest.mark.slow
def test_worker_killed_mid_sweep(client, tmp_path):
    """SIGKILL one worker process while batches run: Dask reruns its tasks
    and the table holds every run exactly once, all successful."""
    d = kd.models.build("chain3d", n=2)
    model = d.numeric()  # numpy: slow enough runs for the kill to land mid-sweep
    y0 = d.initial(model)
    out = tmp_path / "killed"
    n_runs = 48
    killed = {}

    def kill_one():
        deadline = time.time() + 120
        while time.time() < deadline and not list(out.glob("part-*.parquet")):
            time.sleep(0.05)
        pids = client.run(os.getpid)
        address, pid = sorted(pids.items())[0]
        killed["done_before"] = len(list(out.glob("part-*.parquet")))
        killed["processing"] = sum(len(v) for v in client.processing().values())
        os.kill(pid, signal.SIGKILL)
        killed["pid"] = pid

    thread = threading.Thread(target=kill_one, daemon=True)
    thread.start()
    table = kd.sweep(model, {"g": np.linspace(5.0, 15.0, n_runs)}, y0, (0.0, 2.0),
                     outputs=("final",), client=client, out=out, batch_size=2,
                     progress=False, rtol=1e-9, atol=1e-9)
    thread.join()
    assert "pid" in killed and killed["processing"] > 0
    assert killed["done_before"] < n_runs // 2  # killed while most batches were to come
    assert sorted(table["run"]) == list(range(n_runs))  # every run, exactly once
    assert table["run"].is_unique and table["success"].all()
    assert len(pd.read_parquet(out / "results.parquet")) == n_runs
    assert killed["pid"] not in client.run(os.getpid).values()
