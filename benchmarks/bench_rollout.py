"""Benchmark (not a test): 10^4 runs at once, kanedyn's ensembles against ``mujoco.rollout``.

Issue 39's benchmark of ensembles: trajectories per second of

* **chain**: a spatial 5-link pendulum chain (``benchmarks/data/chain5.xml``, hinges
  alternating about x and y, no contacts, no damping), read by MuJoCo and by
  ``kd.models.from_mjcf`` (qacc checked against ``mj_forward`` at a random state),
  ``--runs`` runs of 10 s, each from its own random state (seeded);
* **seatbelt**: the lock map's model (half-sine pulse, the lock a ``kd.Event``)
  under ``--runs`` random pulses (2-30 g, 40-120 ms, 0-90 deg), 0.22 s each;
* **bicycle**: the Whipple bicycle (benchmark parameters), ``--runs`` runs of
  ``--bicycle-time`` s from upright with random forward speeds (4.5-8 m/s) and
  lean rates (-0.5 to 0.5 rad/s); the speeds lie above the weave speed (4.3 m/s),
  so that no run falls over.

Contenders, written the way a user writes them: one ``kd.simulate_many`` call on 1
and 2 threads; a Python ``for`` loop of ``kd.simulate`` (the compiled RK45 loop)
and ``kd.sweep(..., scheduler="serial")``, each on ``--sample`` runs and scaled
(the same per-run cost, the rates are per trajectory); on the chain,
``mujoco.rollout`` (RK4) with ``nthread`` 1 and 2 (a persistent ``Rollout`` pool,
the runs in chunks of ``--chunk`` so that its state output, every step of every
run, fits in memory).

*At equal error* (the chain): a reference (``kd.simulate``, DOP853, rtol = atol =
1e-12) of ``--error-sample`` runs; kanedyn's error at its ``--rtol`` (= atol) and
MuJoCo's at RK4 steps ``10 s / k`` for k on a ladder of ratio 2^(1/4) (each rung
halves RK4's error); the step whose error is nearest kanedyn's (in log) is timed
and both errors printed (median and largest over the sample of the final
state's largest absolute error, qpos and qvel).

Interleaved rounds (:func:`_timing.interleaved`) on the process's CPU clock (all its
threads), minimum and median: trajectories per CPU second are per core, whatever
else runs on the machine; the wall time of each call is printed beside it.  The
loop and the sweep run the first ``--sample`` runs (the sweep draws its own
sample of the same ranges: ``kd.sweep`` takes ranges, not a list of runs).

Run: ``PYTHONPATH=src python benchmarks/bench_rollout.py [--runs 10000]
[--rounds 2] [--cases chain seatbelt bicycle] [--quick]``.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

import kanedyn as kd
from _timing import interleaved, optimized_modules_only  # noqa: E402
from bench_numerics import cpu_name  # noqa: E402

CHAIN = Path(__file__).parent / "data" / "chain5.xml"


def _timed(contenders, rounds):
    """:func:`_timing.interleaved` on the process's CPU clock (every thread of this
    process: CPU seconds, so trajectories per CPU second are per core, whatever else
    the machine runs), the wall time of each call recorded beside it."""
    import time
    walls = {name: [] for name in contenders}

    def wrap(name, func):
        def run():
            start = time.perf_counter()
            func()
            walls[name].append(time.perf_counter() - start)
        return run

    t = interleaved({name: wrap(name, func) for name, func in contenders.items()},
                    rounds=rounds, min_time=0, clock="process")
    return t, walls


def _report(title, timed, runs, sample):
    """Trajectories per CPU second (per core: the process's CPU time, all its threads)
    from the minimum and the median over the rounds, and per wall second."""
    t, walls = timed
    print(f"\n{title}")
    print(f"  {'contender':28s} {'CPU s min':>9s} {'median':>8s} {'wall min':>9s}"
          f" {'traj/CPU s':>10s} {'(median)':>9s} {'traj/wall s':>11s}")
    rates = {}
    for key, timing in t.items():
        count = sample if key in ("loop", "sweep") else runs
        rates[key] = count / timing.best
        print(f"  {key:28s} {timing.best:9.3f} {timing.median:8.3f} {min(walls[key]):9.3f}"
              f" {count / timing.best:10.1f} {count / timing.median:9.1f}"
              f" {count / min(walls[key]):11.1f}   ({count} runs)")
    return rates


def _ratios(rates, pairs):
    for a, b in pairs:
        print(f"  per CPU second, {a} / {b}: {rates[a] / rates[b]:.2f}x")


def _chain(args):
    import mujoco
    from mujoco import rollout
    definition = kd.models.from_mjcf(CHAIN)
    model = definition.numeric(backend="c")
    mj = mujoco.MjModel.from_xml_path(str(CHAIN))
    data = mujoco.MjData(mj)
    rng = np.random.default_rng(7)
    qpos, qvel = rng.uniform(-1, 1, mj.nq), rng.uniform(-1, 1, mj.nv)
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco.mj_forward(mj, data)
    check = np.max(np.abs(definition.qacc(model, 0.0, definition.state_from_mujoco(
        model, qpos, qvel)) - data.qacc))
    assert check < 1e-9, check
    runs, t_end = args.chain_runs or args.runs, 10.0
    rng = np.random.default_rng(1)
    Y0 = np.hstack([rng.uniform(-0.5, 0.5, (runs, 5)), rng.uniform(-1.0, 1.0, (runs, 5))])
    span, tol = (0.0, t_end), args.rtol
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    nstate = mujoco.mj_stateSize(mj, spec)

    def mj_states(y):
        s = np.zeros((len(y), nstate))
        s[:, 1:1 + mj.nq], s[:, 1 + mj.nq:1 + mj.nq + mj.nv] = y[:, :5], y[:, 5:]
        return s

    S0 = mj_states(Y0)

    def mj_run(pool, datas, rows, nstep, buffer):
        end = np.empty((len(rows), nstate))
        for i in range(0, len(rows), args.chunk):
            chunk = S0[rows[i:i + args.chunk]]
            out = buffer[:len(chunk), :nstep]
            pool.rollout(mj, datas, chunk, nstep=nstep, state=out)
            end[i:i + len(chunk)] = out[:, -1]
        return end[:, 1:1 + mj.nq + mj.nv]

    # ---- errors against the reference on a sample
    k = min(args.error_sample, runs)
    reference = np.array([kd.simulate(model, span, Y0[i], method="DOP853", rtol=1e-12,
                                      atol=1e-12).y[:, -1] for i in range(k)])

    def error(y_end):
        e = np.max(np.abs(y_end - reference), axis=1)
        return np.median(e), e.max()

    kd_err = error(kd.simulate_many(model, Y0[:k], span, rtol=tol, atol=tol).y_end)
    ladder = sorted({int(round(250 * 2 ** (j / 4))) for j in range(0, 29)})
    best = None
    with rollout.Rollout(nthread=1) as pool:
        print(f"\nchain5.xml: qacc of from_mjcf vs mj_forward at a random state: {check:.1e}"
              f"\nerrors of the final state over {k} runs (median, largest) against DOP853 "
              f"at 1e-12:\n  kanedyn RK45 rtol = atol = {tol:g}: {kd_err[0]:.2e}, {kd_err[1]:.2e}")
        for nstep in ladder:
            mj.opt.timestep = t_end / nstep
            buffer = np.empty((min(k, args.chunk), nstep, nstate))
            e = error(mj_run(pool, [data], np.arange(k), nstep, buffer))
            gap = abs(np.log(e[0] / kd_err[0]))
            print(f"  MuJoCo RK4 dt = {t_end / nstep:.3e} s ({nstep} steps): "
                  f"{e[0]:.2e}, {e[1]:.2e}")
            if best is None or gap < best[0]:
                best = (gap, nstep, e)
            if e[0] < kd_err[0] / 4:
                break
    _, nstep, mj_err = best
    mj.opt.timestep = t_end / nstep
    print(f"  timed: MuJoCo at dt = {t_end / nstep:.3e} s ({nstep} steps; median error "
          f"{mj_err[0]:.2e} against kanedyn's {kd_err[0]:.2e})")
    buffer = np.empty((args.chunk, nstep, nstate))
    pools = {1: rollout.Rollout(nthread=1), 2: rollout.Rollout(nthread=2)}
    datas = {n: [mujoco.MjData(mj) for _ in range(n)] for n in pools}
    sample = min(args.sample, runs)
    out = {}

    def mj_threads(n):
        def run():
            out[f"mj{n}"] = mj_run(pools[n], datas[n], np.arange(runs), nstep, buffer)
        return run

    def many(n):
        def run():
            out[f"many{n}"] = kd.simulate_many(model, Y0, span, rtol=tol, atol=tol,
                                               threads=n).y_end
        return run

    def loop():
        out["loop"] = np.array([kd.simulate(model, span, Y0[i], rtol=tol, atol=tol).y[:, -1]
                                for i in range(sample)])

    names = model.state_names
    ranges = {name: ((-0.5, 0.5) if name.startswith("q") else (-1.0, 1.0)) for name in names}

    def sweep():
        out["sweep"] = kd.sweep(model, ranges, Y0[0], span, n=sample, seed=1,
                                scheduler="serial", progress=False, rtol=tol, atol=tol)

    contenders = {"simulate_many, 1 thread": many(1), "simulate_many, 2 threads": many(2),
                  "loop": loop, "sweep": sweep,
                  "mujoco.rollout, nthread=1": mj_threads(1),
                  "mujoco.rollout, nthread=2": mj_threads(2)}
    t = _timed(contenders, args.rounds)
    for pool in pools.values():
        pool.close()
    assert np.array_equal(out["many1"][:sample], out["loop"])
    assert np.array_equal(out["many1"], out["many2"]) and out["sweep"]["success"].all()
    assert np.array_equal(out["mj1"], out["mj2"])
    err_mj = error(out["mj1"][:k])
    rates = _report(f"chain n = 5, {runs} runs of {t_end:g} s (kanedyn error {kd_err[0]:.1e}, "
                    f"MuJoCo {err_mj[0]:.1e})", t, runs, sample)
    _ratios(rates, [("simulate_many, 1 thread", "mujoco.rollout, nthread=1"),
                    ("simulate_many, 2 threads", "mujoco.rollout, nthread=2"),
                    ("simulate_many, 1 thread", "loop"), ("simulate_many, 1 thread", "sweep")])


def _kd_only(title, model, Y0, span, sample, rounds, constants=None, events=None,
             sweep_ranges=None, y0=None, **options):
    runs = len(Y0)
    out = {}
    constants = constants or {}

    def many(n):
        def run():
            out[f"many{n}"] = kd.simulate_many(model, Y0, span, constants=constants,
                                               events=events, threads=n, **options)
        return run

    def loop():
        ends = []
        for i in range(sample):
            run = model.with_constants({k: v[i] for k, v in constants.items()}) \
                if constants else model
            ends.append(kd.simulate(run, span, Y0[i], events=events, **options).y[:, -1])
        out["loop"] = np.array(ends)

    def sweep():
        out["sweep"] = kd.sweep(model, sweep_ranges, y0, span, n=sample, seed=1,
                                scheduler="serial", progress=False,
                                outputs=("final",) if events is None else ("final", "events"),
                                events=[events] if events is not None else None, **options)

    t = _timed({"simulate_many, 1 thread": many(1), "simulate_many, 2 threads": many(2),
                "loop": loop, "sweep": sweep}, rounds)
    difference = np.max(np.abs(out["many1"].y_end[:sample] - out["loop"]))
    assert np.array_equal(out["many1"].y_end, out["many2"].y_end)
    assert out["sweep"]["success"].all()
    rates = _report(f"{title} (simulate_many's final states within {difference:.1e} of the "
                    f"loop's)", t, runs, sample)
    _ratios(rates, [("simulate_many, 1 thread", "loop"), ("simulate_many, 1 thread", "sweep"),
                    ("simulate_many, 2 threads", "simulate_many, 1 thread")])


def _seatbelt(args):
    from kanedyn.analysis._seatbelt_studies import (_lock_angle, _lock_event,
                                                    seatbelt_study_model)
    definition, model = seatbelt_study_model()
    y0 = np.asarray(definition.initial(model), dtype=float)
    runs = args.runs
    rng = np.random.default_rng(2)
    ranges = {"peak_g": (2.0, 30.0), "duration": (0.04, 0.12),
              "direction": (0.0, np.pi / 2), "roll_rate": (0.0, 0.0)}
    constants = {k: rng.uniform(lo, hi, runs) for k, (lo, hi) in ranges.items()}
    ranges.pop("roll_rate")
    _kd_only(f"seat-belt sensor, {runs} half-sine pulses of 0.22 s, lock event", model,
             np.tile(y0, (runs, 1)), (0.0, 0.22), min(args.sample, runs), args.rounds,
             constants=constants, events=_lock_event(_lock_angle(None)), sweep_ranges=ranges,
             y0=y0)


def _bicycle(args):
    from kanedyn.models import upright_state
    d = kd.models.build("whipple-bicycle")
    model = d.numeric(backend="c")
    runs = args.runs
    rng = np.random.default_rng(3)
    speeds = rng.uniform(4.5, 8.0, runs)
    lean_rates = rng.uniform(-0.5, 0.5, runs)
    Y0 = []
    lean = model.state_names.index("u4")
    for v, w in zip(speeds, lean_rates):
        y = np.array(upright_state(model, v), dtype=float)
        y[lean] = w
        Y0.append(y)
    Y0 = np.array(Y0)
    span = (0.0, args.bicycle_time)
    base, rR = Y0[0].copy(), model.constants["rR"]
    _kd_only(f"Whipple bicycle, {runs} runs of {span[1]:g} s (speed 4.5-8 m/s, lean rate "
             "+-0.5 rad/s)", model, Y0, span, min(args.sample, runs), args.rounds,
             sweep_ranges={"u4": (-0.5, 0.5), "u6": (-8.0 / rR, -4.5 / rR)}, y0=base)


def main():
    optimized_modules_only()
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=10_000)
    parser.add_argument("--chain-runs", type=int, default=None,
                        help="runs of the chain (default: --runs)")
    parser.add_argument("--sample", type=int, default=200,
                        help="runs of the loop and of kd.sweep (scaled)")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--rtol", type=float, default=1e-8, help="kanedyn's rtol = atol")
    parser.add_argument("--error-sample", type=int, default=20)
    parser.add_argument("--chunk", type=int, default=250,
                        help="runs per mujoco.rollout call")
    parser.add_argument("--bicycle-time", type=float, default=3.0)
    parser.add_argument("--quick", action="store_true", help="200 runs, sample 20, 1 round")
    parser.add_argument("--cases", nargs="+", default=["chain", "seatbelt", "bicycle"],
                        choices=["chain", "seatbelt", "bicycle"])
    args = parser.parse_args()
    if args.quick:
        args.runs, args.sample, args.rounds, args.error_sample = 200, 20, 1, 5
        args.chain_runs = None
    print(f"{cpu_name()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; "
          "CPU time of the process (all threads) in interleaved rounds, wall time beside")
    if "chain" in args.cases:
        _chain(args)
    if "seatbelt" in args.cases:
        _seatbelt(args)
    if "bicycle" in args.cases:
        _bicycle(args)
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
