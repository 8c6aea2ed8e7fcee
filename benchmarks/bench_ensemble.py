"""Benchmark (not a test): many runs of one model in C threads against a loop of runs.

``--runs`` runs of two models, C backend, compiled RK45, rtol = atol = 1e-8, each
run with its own random constants and initial angle (seeded), written the way
a user writes them:

* **loop**: ``for`` over the runs, ``model.with_constants`` then ``kd.simulate``
  (each run through Python: checks, the compiled loop, the result object);
* **many, 1 thread / 2 threads**: one ``kd.simulate_many`` call (the same
  RK45 on POSIX threads without Python; the final states are checked equal to
  the loop's, bit for bit);
* **sweep**: ``kd.sweep(..., scheduler="serial")`` (its table; the runs now go
  through ``simulate_many``).

Models: the pendulum, 2 s (the issue's example of a short run), and chain3d
with n = 5, 10 s.  Wall time (threads), minimum of ``--rounds`` interleaved
rounds (:func:`_timing.interleaved`; spread = median / min - 1).

The studies whose runs now go through ``simulate_many`` (``--cases``), each against
its old path:

* **seatbelt**: the lock map's default grid (5 peaks x 5 durations x 4 directions,
  halfsine, 0.22 s each): ``kd.sweep`` serial with the lock as a Python function of
  ``(t, y)`` (``kanedyn.models.lock_events``: one ``kd.simulate`` per run, the old
  path) against the same sweep with the lock as a ``kd.Event`` (the study's:
  ``simulate_many`` with the event compiled) and one ``simulate_many`` call on 1
  and 2 threads; the lock times' largest difference printed;
* **oc3**: ``--oc3-seeds`` irregular seas of ``--oc3-duration`` s (OC3 spar, 2
  tower modes, drag, Hs 6 m, Tp 10 s, wind 11.4 m/s): one ``kd.simulate`` per seed
  with the Python thrust and fluid kinematics (models built beforehand, untimed)
  against ``sea_runs`` (the fluid kinematics of every seed sampled, timed, and the
  runs in one ``simulate_many``); the outputs' largest difference printed.  One
  round unless ``--rounds`` says otherwise for it (``--oc3-rounds``).

Run: ``PYTHONPATH=src python benchmarks/bench_ensemble.py [--runs 1000] [--rounds 3]
[--quick] [--cases models seatbelt oc3]``.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

import kanedyn as kd
from _timing import interleaved, optimized_modules_only, ratio_text  # noqa: E402
from bench_numerics import cpu_name  # noqa: E402


def _case(name, t_end, runs, rounds, **options):
    d = kd.models.build(name, **options)
    model = d.numeric(backend="c")
    y0 = np.asarray(d.initial(model), dtype=float)
    rng = np.random.default_rng(1)
    g = rng.uniform(9.0, 10.0, runs)
    length = rng.uniform(0.4, 0.6, runs) if "l" in model.constants else None
    constants = {"g": g} if length is None else {"g": g, "l": length}
    Y0 = np.tile(y0, (runs, 1))
    Y0[:, 0] += rng.uniform(0.0, 0.5, runs)
    span = (0.0, t_end)
    params = {"g": (9.0, 10.0), model.state_names[0]: (0.0, 0.5)}
    out = {}

    def loop():
        out["loop"] = np.array([
            kd.simulate(model.with_constants({k: v[i] for k, v in constants.items()}), span,
                        Y0[i]).y[:, -1] for i in range(runs)])

    def many(threads):
        def run():
            out[f"many{threads}"] = kd.simulate_many(model, Y0, span, constants=constants,
                                                     threads=threads).y_end
        return run

    def sweep():
        out["sweep"] = kd.sweep(model, params, y0, span, n=runs, seed=1, scheduler="serial",
                                progress=False)

    t = interleaved({"loop": loop, "many1": many(1), "many2": many(2), "sweep": sweep},
                    rounds=rounds, min_time=0, clock="wall")
    assert np.array_equal(out["loop"], out["many1"]), "simulate_many differs from the loop"
    assert np.array_equal(out["many1"], out["many2"])
    assert out["sweep"]["success"].all()
    print(f"\n{name} ({model.n_states} states), {runs} runs of {t_end:g} s")
    for key, label in (("loop", "loop of kd.simulate"), ("many1", "simulate_many, 1 thread"),
                       ("many2", "simulate_many, 2 threads"), ("sweep", "kd.sweep serial")):
        note = "" if key == "loop" else f"  {ratio_text(t['loop'], t[key])} faster"
        print(f"  {label:26s} {t[key].best:8.4f} s  {1e3 * t[key].best / runs:7.4f} ms/run"
              f"  spread {t[key].spread:4.0%}{note}")


def _print(title, t, reference, labels, count):
    print(f"\n{title}")
    for key, label in labels:
        note = "" if key == reference else f"  {ratio_text(t[reference], t[key])} faster"
        print(f"  {label:38s} {t[key].best:8.3f} s  {1e3 * t[key].best / count:8.3f} ms/run"
              f"  spread {t[key].spread:4.0%}{note}")


def _seatbelt(rounds):
    from kanedyn.analysis._seatbelt_studies import (_lock_angle, _lock_event,
                                                    seatbelt_study_model)
    from kanedyn.models import lock_events
    definition, model = seatbelt_study_model()
    y0 = definition.initial(model)
    grid = {"peak_g": (2.0, 5.0, 10.0, 20.0, 30.0), "duration": (0.04, 0.06, 0.08, 0.1, 0.12),
            "direction": np.radians((0.0, 30.0, 45.0, 90.0)), "roll_rate": (0.0,)}
    span, angle = (0.0, 0.22), _lock_angle(None)
    python_event, expression = lock_events(definition, angle), _lock_event(angle)
    common = dict(outputs=("events",), scheduler="serial", progress=False)
    runs = 5 * 5 * 4
    P = np.array(np.meshgrid(*grid.values(), indexing="ij")).reshape(4, -1)
    constants = dict(zip(grid, P))
    out = {}

    def sweep(events, key):
        def run():
            out[key] = kd.sweep(model, grid, y0, span, events=events, **common)
        return run

    def many(threads):
        def run():
            out[f"many{threads}"] = kd.simulate_many(model, y0, span, constants=constants,
                                                     events=expression, threads=threads)
        return run

    t = interleaved({"old": sweep(python_event, "old"), "new": sweep([expression], "new"),
                     "many1": many(1), "many2": many(2)}, rounds=rounds, min_time=0,
                    clock="wall")
    old, new = out["old"].event0_first.to_numpy(), out["new"].event0_first.to_numpy()
    first = np.array([times[0][0] if len(times[0]) else np.nan
                      for times in out["many1"].t_events])
    assert np.array_equal(np.isnan(old), np.isnan(new)) and out["old"].success.all()
    assert np.array_equal(out["old"].event0_count, out["new"].event0_count)
    _print(f"seat-belt lock map, {runs} runs of {span[1]:g} s (halfsine; locked in "
           f"{int(np.isfinite(old).sum())}; lock times differ by at most "
           f"{np.nanmax(np.abs(old - new)):.1e} s, simulate_many's by "
           f"{np.nanmax(np.abs(old - first)):.1e} s)", t, "old",
           (("old", "sweep, Python event (run by run)"), ("new", "sweep, kd.Event (simulate_many)"),
            ("many1", "simulate_many, 1 thread"), ("many2", "simulate_many, 2 threads")), runs)


def _oc3(seeds, duration, rounds):
    from kanedyn.analysis._oc3_studies import _model, oc3_outputs, sea_runs
    from kanedyn.engine import name_of
    from kanedyn.models import oc3_spar
    options = dict(tower_modes=2, drag=True, wave_height=6.0, wave_period=10.0,
                   wind_speed=11.4, tmdi="off")
    phases = list(range(1, seeds + 1))
    d, _, model, y_eq = _model("c", **dict(options, sea="irregular", seed=1))
    names = {name.removesuffix("(t)") for name in model.input_names}
    runs = [model.with_inputs({k: v for k, v in oc3_spar(**dict(options, sea="irregular",
                                                               seed=seed)).specified.items()
                               if name_of(k) in names}) for seed in phases]
    t_eval = np.arange(0.0, duration + 0.05, 0.1)
    sea_runs(phases[:1], 10.0, **options)  # its compiled model built (untimed)
    out = {}

    def old():
        out["old"] = np.array([kd.simulate(run, (0.0, duration), y_eq, t_eval=t_eval,
                                           rtol=1e-6, atol=1e-6).y.T for run in runs])

    def new():
        out["new"] = sea_runs(phases, duration, **options)[3]

    t = interleaved({"old": old, "new": new}, rounds=rounds, min_time=0, clock="wall")
    row = oc3_outputs(d, model)["top_deflection"][0]
    keep = t_eval >= min(100.0, duration / 4)  # past the start-up transient
    worst = max(np.max(np.abs(row @ (a[keep] - b[keep]).T)) / np.std(row @ a[keep].T)
                for a, b in zip(out["old"], out["new"]))
    _print(f"OC3 spar, irregular sea, {seeds} seeds of {duration:g} s (tower-top deflection "
           f"within {worst:.1e} of its standard deviation)", t, "old",
           (("old", "kd.simulate per seed, Python inputs"),
            ("new", "sea_runs: sampled seas, simulate_many")), seeds)


def main():
    optimized_modules_only()
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="100 runs, 2 rounds")
    parser.add_argument("--cases", nargs="+", default=["models", "seatbelt", "oc3"],
                        choices=["models", "seatbelt", "oc3"])
    parser.add_argument("--oc3-seeds", type=int, default=4)
    parser.add_argument("--oc3-duration", type=float, default=600.0)
    parser.add_argument("--oc3-rounds", type=int, default=1)
    args = parser.parse_args()
    if args.quick:
        args.runs, args.rounds = 100, 2
    print(f"{cpu_name()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; "
          "wall time, minimum of interleaved rounds; ratios: the old path's time over each")
    if "models" in args.cases:
        _case("pendulum", 2.0, args.runs, args.rounds)
        _case("chain3d", 10.0, args.runs, args.rounds, n=5)
    if "seatbelt" in args.cases:
        _seatbelt(args.rounds)
    if "oc3" in args.cases:
        _oc3(args.oc3_seeds, args.oc3_duration, args.oc3_rounds)


if __name__ == "__main__":
    main()
