"""What the checks of a run cost: the search for singular configurations and the
energy check.

``kd.simulate`` looks for the times a constrained run passes near a singular
configuration (``singular_threshold``, default 1e-3; ``None`` turns it off).  On
the compiled loop the search runs inside the loop, step by step.  Two figures:

* the Whipple bicycle (benchmark parameters), 5 s on the compiled RK45 loop,
  with and without the search: thread CPU per run, interleaved in rounds
  (minima and spreads), and their ratio;
* the four-bar linkage to 10^4 s on the compiled loop with 501 output times,
  each in a fresh process: peak resident memory (``ru_maxrss``) and the CPU of
  the run (``time.process_time``), with and without the search.

Every run judges its energy balance (``kanedyn.simulation._energy_check``),
sampled during the integration.  Two more figures, thread CPU, interleaved:

* the compiled loop alone (``model._c.integrate``, the private entry point
  ``kd.simulate`` calls, RK45 at rtol = atol = 1e-8, no output times, no
  projection, no search) with the balance sampled and with its private switch
  ``energy=False``: chain3d n = 5 (gravity a potential; and as loads, the
  model of ``bench_numerics.py``), the pendulum over 1000 s, the four-bar and
  the Whipple bicycle over 5 s;
* ``kd.simulate`` on the numpy backend (``solve_ivp``) with the balance sampled
  and without (the sampler replaced by one that does nothing, so that nothing
  is judged either): chain3d n = 5 over 1 s, the seat-belt sensor's run.

    python benchmarks/bench_singular_monitor.py [--rounds 7] [--t-end 1e4] [--energy-only]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile

# _timing and _fresh_process live next to this script (on sys.path when run directly)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _fresh_process import byte_compile_package, run_python  # noqa: E402
from _timing import interleaved, optimized_modules_only, ratio_text  # noqa: E402

#: one run of the four-bar in a fresh process: its peak memory and CPU, as JSON
_FOUR_BAR = """
import json, resource, time
import numpy as np
import kanedyn as kd
d = kd.models.build("four-bar")
model = d.numeric(d.derive(), backend="c")
y0 = d.initial(model)
kd.simulate(model, (0.0, 0.01), y0)  # what simulate loads on first use
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.process_time()
res = kd.simulate(model, (0.0, {t_end}), y0, t_eval=np.linspace(0.0, {t_end}, 501),
                  singular_threshold={threshold})
cpu = time.process_time() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({{"cpu": cpu, "peak_mb": peak / 1024, "before_mb": before / 1024,
                  "steps": res.nfev // 6, "success": bool(res.success)}}))
"""


def whipple(rounds):
    """Thread CPU of the Whipple bicycle's 5 s run with and without the search."""
    import kanedyn as kd
    from kanedyn.numerics.backends._c_quick import finish_compiling
    d = kd.models.build("whipple-bicycle")
    model = d.numeric(d.derive(), backend="c")
    finish_compiling()  # the optimized module, not the quick compiler's
    y0 = d.initial(model)

    def run(threshold):
        return lambda: kd.simulate(model, (0.0, 5.0), y0, singular_threshold=threshold)

    times = interleaved({"with": run(1e-3), "without": run(None)}, rounds=rounds,
                        min_time=0.2)
    print("| Whipple bicycle, 5 s, compiled RK45 | ms per run | spread |")
    print("|---|---|---|")
    for name in ("with", "without"):
        print(f"| {name} the search | {times[name].best * 1e3:.3f} | "
              f"{times[name].spread:.1%} |")
    print(f"\nwith / without: {ratio_text(times['with'], times['without'])}\n")


def four_bar(t_end, cache):
    """Peak memory and CPU of the four-bar to ``t_end`` in fresh processes."""
    run_python(_FOUR_BAR.format(t_end=1.0, threshold=1e-3), cache)  # builds the module
    print(f"| four-bar to {t_end:g} s, compiled RK45, 501 outputs | peak RSS, MB | "
          "CPU of the run, s | steps |")
    print("|---|---|---|---|")
    for name, threshold in (("with the search", 1e-3), ("without", None)):
        out = run_python(_FOUR_BAR.format(t_end=t_end, threshold=threshold), cache)
        if out.returncode:
            raise SystemExit(out.stderr)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"| {name} | {r['peak_mb']:.0f} (before the run {r['before_mb']:.0f}) | "
              f"{r['cpu']:.2f} | {r['steps']} |")


#: (model, options of kd.models.build, span s, label) of the energy check's figures
_LOOP_RUNS = (("chain3d", {"n": 5}, 5.0, "chain3d n = 5, 5 s"),
              ("chain3d", {"n": 5, "style": "positions"}, 10.0,
               "chain3d n = 5, gravity as loads, 10 s"),
              ("pendulum", {}, 1000.0, "pendulum, 1000 s"),
              ("four-bar", {}, 5.0, "four-bar, 5 s"),
              ("whipple-bicycle", {}, 5.0, "Whipple bicycle, 5 s"))
_NUMPY_RUNS = (("chain3d", {"n": 5}, 1.0, "chain3d n = 5, 1 s"),
               ("seatbelt-sensor", {}, None, "seat-belt sensor, its 0.2 s run"))


def energy_check_loop(rounds):
    """Thread CPU of the compiled loop with and without the energy balance."""
    import numpy as np

    import kanedyn as kd
    from kanedyn.numerics.backends._c_quick import finish_compiling
    print("| compiled RK45 loop | with the balance, ms | without, ms | with / without |")
    print("|---|---|---|---|")
    for name, options, t_end, label in _LOOP_RUNS:
        d = kd.models.build(name, **options)
        model = d.numeric(d.derive(), backend="c")
        finish_compiling()
        y0 = model.state(d.initial(model), 0.0)
        atol = np.full(model.n_states, 1e-8)

        def run(energy, model=model, y0=y0, atol=atol, t_end=t_end):
            return lambda: model._c.integrate(0.0, t_end, y0, None, 1e-8, atol, np.inf, 0.0,
                                              "RK45", None, 0.0, False, 0.0, 1e-7, None, 0.0,
                                              energy)
        times = interleaved({"with": run(True), "without": run(False)}, rounds=rounds,
                            min_time=0.2)
        print(f"| {label} | {times['with'].best * 1e3:.3f} | "
              f"{times['without'].best * 1e3:.3f} | "
              f"{ratio_text(times['with'], times['without'])} |")
    print()


def energy_check_numpy(rounds):
    """Thread CPU of kd.simulate on the numpy backend with and without the
    energy balance."""
    import kanedyn as kd
    from kanedyn.simulation import _energy_check
    sample = _energy_check.WorkTracker.step

    def nothing(self, *step):
        return None
    print("| kd.simulate, numpy backend, RK45 | with the balance, ms | without, ms | "
          "with / without |")
    print("|---|---|---|---|")
    for name, options, t_end, label in _NUMPY_RUNS:
        d = kd.models.build(name, **options)
        model = d.numeric(d.derive(), backend="numpy")
        y0 = model.state(d.initial(model), 0.0)
        span = (0.0, t_end or d.t_end)

        def run(step, model=model, y0=y0, span=span):
            def simulate():
                _energy_check.WorkTracker.step = step
                return kd.simulate(model, span, y0)
            return simulate
        try:
            times = interleaved({"with": run(sample), "without": run(nothing)},
                                rounds=rounds, min_time=0.5)
        finally:
            _energy_check.WorkTracker.step = sample
        print(f"| {label} | {times['with'].best * 1e3:.1f} | "
              f"{times['without'].best * 1e3:.1f} | "
              f"{ratio_text(times['with'], times['without'])} |")
    print()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--t-end", type=float, default=1e4)
    parser.add_argument("--energy-only", action="store_true",
                        help="only the energy check's figures")
    args = parser.parse_args(argv)
    cache = tempfile.mkdtemp(prefix="kanedyn-bench-monitor-")
    os.environ["KANEDYN_CACHE_DIR"] = os.path.join(cache, "kanedyn")
    optimized_modules_only()
    byte_compile_package()
    if not args.energy_only:
        whipple(args.rounds)
        four_bar(args.t_end, cache)
    energy_check_loop(args.rounds)
    energy_check_numpy(args.rounds)


if __name__ == "__main__":
    main()
