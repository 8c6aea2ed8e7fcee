"""Real-time factor of the full OC3-Hywind turbine (issue 36): kanedyn against OpenFAST.

kanedyn's ``oc3-spar`` with everything on: flexible tower (2 modes, 1 % damping),
a spinning rotor with three flexible blades (3 modes each) pitched by the
baseline controller, quasi-steady BEM on the blades' deflecting nodes,
turbulent wind (Kaimal, ``--wind`` m/s mean, ``--turbulence`` intensity), an
irregular sea (JONSWAP Hs 6 m, Tp 10 s, 200 components) with Morison drag,
linear hydrostatics, the constant added mass and the linear mooring; C backend,
rtol = atol = ``--rtol``.  Printed: the build (derive + compile) apart, then
simulated seconds per CPU second of the run (and per wall second).

OpenFAST's figure for this case is the published one: its regression test
``5MW_OC3Spar_DLL_WTurb_WavesIrr`` (``OpenFAST/r-test``: ElastoDyn with flexible
tower and blades, AeroDyn 15, turbulent 12 m/s wind, the baseline controller as a
Bladed DLL, HydroDyn with WAMIT radiation memory and irregular waves Hs 6 m,
Tp 10 s, MAP++ mooring, 60 s at dt 0.0125 s) prints its "Time Ratio (Sim/CPU)"
in the logs kept beside its reference outputs (:data:`PUBLISHED`); those ran on
the OpenFAST project's machines, not on this one.

``--openfast PATH --deck DIR`` (or ``$OPENFAST``) also times an OpenFAST
executable on this machine on a deck that the script runs as it is apart from
its run length (TMax = ``--duration``), e.g. kanedyn's structural and
hydrodynamic OC3 deck (``tests/data/openfast_oc3/deck``: ElastoDyn with the
flexible tower and a parked rigid rotor, HydroDyn without wave excitation or
radiation memory, still water, MAP++; no AeroDyn, InflowWind or ServoDyn): a
subset of the full case's modules, which would be expected to run faster than
the full case.  Without an executable or deck it says so and skips.

Run: ``python benchmarks/bench_oc3_realtime.py [--duration 60] [--openfast PATH
--deck DIR]``.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: OpenFAST's published Sim/CPU ratio of ``5MW_OC3Spar_DLL_WTurb_WavesIrr`` (60 s):
#: (platform folder of r-test, ratio, CPU s of the simulation, the log's commit)
PUBLISHED = (
    ("linux-gnu", 0.54578, 1.8323 * 60, "2668c76f4025cad35f98b6136582dec7cff631c3",
     "OpenFAST-v2.0.0-2968-g7fe8bef2, GCC 10.3.0, 2022-07-06"),
    ("macos-gnu", 0.97354, 1.0272 * 60, "22aa3c82b9ab118be4d3c573ccd1acef2863af25", ""),
    ("linux-intel", 1.1218, 53.484, "0c31ceb2e9dec70b40522f0180506a48b40d6970", ""),
)
LOG = ("https://github.com/OpenFAST/r-test/blob/{commit}/glue-codes/openfast/"
       "5MW_OC3Spar_DLL_WTurb_WavesIrr/{platform}/5MW_OC3Spar_DLL_WTurb_WavesIrr.log")

#: the options of the full model (the sea and wind from the command line)
FULL = dict(tower_modes=2, rotor="spinning", controller="on", blades="flexible", aero="bem",
            drag=True, sea="irregular", seed=1)


def time_kanedyn(options, duration, rtol):
    """``(build wall s, run CPU s, run wall s, right-hand sides, success)``."""
    import kanedyn as kd
    t0 = time.perf_counter()
    d = kd.models.oc3_spar(**options)
    model = d.numeric(backend="c")
    build = time.perf_counter() - t0
    y0 = d.initial(model)
    wall, cpu = time.perf_counter(), time.process_time()
    res = kd.simulate(model, (0.0, duration), y0, rtol=rtol, atol=rtol,
                      t_eval=np.arange(0.0, duration + 1e-9, 0.25))
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    return build, cpu, wall, res.nfev, res.success


def find_openfast(given):
    """The OpenFAST executable: ``given``, ``$OPENFAST`` or ``openfast`` on the PATH, or None."""
    for candidate in (given, os.environ.get("OPENFAST"), shutil.which("openfast")):
        if candidate and Path(candidate).is_file() and os.access(candidate, os.X_OK):
            return str(Path(candidate).resolve())
    return None


def time_openfast(executable, deck, duration):
    """OpenFAST's own ``(Sim/CPU ratio, simulation CPU s)`` and the wall s of its run of
    the ``.fst`` in ``deck`` (copied to a temporary folder, TMax = ``duration``)."""
    [fst] = sorted(Path(deck).glob("*.fst"))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp) / "deck"
        shutil.copytree(deck, work)
        main = work / fst.name
        text, n = re.subn(r"^(\s*)\S+(\s+TMax\s)", rf"\g<1>{duration:g}\g<2>",
                          main.read_text(), flags=re.M)
        if n != 1:
            raise SystemExit(f"{fst}: TMax found {n} times, expected once")
        main.write_text(text)
        t0 = time.perf_counter()
        run = subprocess.run([executable, main.name], cwd=work, capture_output=True,
                             text=True, check=False)
        wall = time.perf_counter() - t0
    if run.returncode != 0:
        raise SystemExit(f"{executable} {fst.name} failed ({run.returncode}):\n"
                         + run.stdout[-2000:] + run.stderr[-2000:])
    ratio = re.search(r"Time Ratio \(Sim/CPU\):\s*([0-9.eE+-]+)", run.stdout)
    cpu = re.search(r"Simulation CPU Time:\s*([0-9.eE+-]+)\s*(seconds|minutes)", run.stdout)
    if ratio is None or cpu is None:
        raise SystemExit(f"{executable}: no 'Time Ratio (Sim/CPU)' in its output")
    return (float(ratio[1]), float(cpu[1]) * (60.0 if cpu[2] == "minutes" else 1.0), wall)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=60.0, help="simulated time, s")
    p.add_argument("--wind", type=float, default=12.0, help="mean hub-height wind, m/s")
    p.add_argument("--turbulence", type=float, default=0.1, help="turbulence intensity")
    p.add_argument("--Hs", type=float, default=6.0, help="significant wave height, m")
    p.add_argument("--Tp", type=float, default=10.0, help="peak period, s")
    p.add_argument("--rtol", type=float, default=1e-6, help="rtol = atol of the run")
    p.add_argument("--also-thrust", action="store_true",
                   help="also time the flexible blades with aero=thrust (the performance "
                        "table spread over the nodes) and the rigid blades with BEM")
    p.add_argument("--openfast", default=None, help="an OpenFAST executable to time here")
    p.add_argument("--deck", default=str(ROOT / "tests" / "data" / "openfast_oc3" / "deck"),
                   help="the OpenFAST deck (a folder with one .fst) to time")
    a = p.parse_args(argv)
    options = dict(FULL, wind_speed=a.wind, turbulence=a.turbulence, wave_height=a.Hs,
                   wave_period=a.Tp)
    cases = [("full: flexible blades, BEM, controller, turbulent wind, irregular sea",
              options)]
    if a.also_thrust:
        cases += [("flexible blades, aero=thrust (the rest as the full model)",
                   dict(options, aero="thrust")),
                  ("rigid blades, BEM (the rest as the full model)",
                   dict(options, blades="rigid"))]
    print(f"kanedyn oc3-spar, {a.duration:g} s, wind {a.wind:g} m/s ({100 * a.turbulence:g} "
          f"% turbulence), JONSWAP Hs {a.Hs:g} m Tp {a.Tp:g} s, rtol = atol = {a.rtol:g}, "
          "C backend")
    for label, opts in cases:
        build, cpu, wall, nfev, ok = time_kanedyn(opts, a.duration, a.rtol)
        print(f"  {label}:\n    build {build:.1f} s; run {cpu:.2f} CPU s ({wall:.2f} wall s), "
              f"{nfev} right-hand sides, success {ok}: {a.duration / cpu:.2f} simulated s "
              f"per CPU s ({a.duration / wall:.2f} per wall s)")
    print("OpenFAST, published (r-test 5MW_OC3Spar_DLL_WTurb_WavesIrr, 60 s, dt 0.0125 s; "
          "the project's machines):")
    for platform, ratio, cpu, commit, what in PUBLISHED:
        print(f"  {platform}: Sim/CPU {ratio:g} ({cpu:.1f} CPU s){', ' + what if what else ''}"
              f"\n    {LOG.format(commit=commit, platform=platform)}")
    executable = find_openfast(a.openfast)
    deck = Path(a.deck)
    if executable is None:
        print("OpenFAST on this machine: skipped (no executable: --openfast PATH or "
              "$OPENFAST)")
    elif not deck.is_dir() or not list(deck.glob("*.fst")):
        print(f"OpenFAST on this machine: skipped (no deck with an .fst at {deck})")
    else:
        ratio, cpu, wall = time_openfast(executable, deck, a.duration)
        print(f"OpenFAST on this machine, {deck} ({a.duration:g} s, as the deck is "
              f"otherwise): Sim/CPU {ratio:g} ({cpu:.2f} CPU s; {wall:.2f} wall s with its "
              "initialization)")


if __name__ == "__main__":
    main()
