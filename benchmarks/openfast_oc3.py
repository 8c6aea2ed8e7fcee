"""Regenerate the OpenFAST side of kanedyn's OC3-Hywind comparison, and draw its figure.

    python benchmarks/openfast_oc3.py run [--openfast PATH] [--discon PATH] [--cases surge,pitch]
    python benchmarks/openfast_oc3.py figure
    python benchmarks/openfast_oc3.py wind-figure

``run`` needs an OpenFAST executable (v5; ``--openfast``, else ``$OPENFAST``,
else ``openfast`` on the PATH).  Without one it says so and exits with status
0, leaving the committed outputs as they are.  It rewrites the deck's generated
files (the tower file and the WAMIT-format files, from kanedyn's OC3 data),
runs each case of ``_openfast_oc3.CASES`` in a temporary folder (the deck with
the case's initial condition, run length and output step), and writes
``tests/data/openfast_oc3/outputs/<case>.csv`` (time and the platform and
tower-top channels, OpenFAST's units) and ``summary.csv`` (the masses ElastoDyn
computes from the deck, MAP++'s line at the undisplaced platform).

The wind case also needs the baseline controller as a Bladed-style library
(``--discon``, else ``$DISCON``): OpenFAST's ``share/discon/DISCON.F90`` with
the OC3-Hywind changes (tests/data/openfast_oc3/NOTICE.md says which), built
with its CMakeLists; without one that case is skipped, saying so.

``figure`` runs kanedyn on the same cases (``oc3-spar`` with
``_openfast_oc3.KANEDYN_OPTIONS``) and draws docs/img/oc3-openfast.png with
both responses, printing the periods and damping ratios of both (the cases
without wind); ``wind-figure`` draws docs/img/oc3-openfast-wind.png, the wind
case's rotor, platform and tower responses and their means.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import _openfast_oc3 as oc3  # noqa: E402

FIGURE = oc3.ROOT / "docs" / "img" / "oc3-openfast.png"
WIND_FIGURE = oc3.ROOT / "docs" / "img" / "oc3-openfast-wind.png"
FST = "OC3Hywind.fst"
ELASTODYN = "NRELOffshrBsline5MW_OC3Hywind_ElastoDyn.dat"
SEASTATE = "SeaState.dat"
INFLOW = "NRELOffshrBsline5MW_InflowWind_Steady.dat"
#: the wind case's module files (the fst's name for each)
WIND_FILES = {"InflowFile": INFLOW, "AeroFile": "NRELOffshrBsline5MW_OC3Hywind_AeroDyn15.dat",
              "ServoFile": "NRELOffshrBsline5MW_OC3Hywind_ServoDyn.dat"}
#: where the ServoDyn file expects the controller library
DISCON_NAME = "DISCON_OC3Hywind.so"
#: the wave elevation at the platform's reference point, kept in a wave case's CSV
WAVE_CHANNEL = "Wave1Elev"
#: the masses of ElastoDyn's summary file kept (label in the file -> CSV name)
ED_SUMMARY = {"Rotor Mass": "rotor_mass", "Rotor Inertia": "rotor_inertia",
              "Tower-top Mass": "tower_top_mass", "Tower Mass": "tower_mass",
              "Platform Mass": "platform_mass", "Mass Incl. Platform": "total_mass"}
#: line 1 of MAP++'s summary file at the undisplaced platform (label -> CSV name)
MAP_SUMMARY = {"Lb": "line_on_seabed", "H": "fairlead_horizontal", "V": "fairlead_vertical",
               "T": "fairlead_tension"}


def find_openfast(given):
    """The OpenFAST executable: ``given``, ``$OPENFAST`` or ``openfast`` on the PATH, or None."""
    for candidate in (given, os.environ.get("OPENFAST"), shutil.which("openfast")):
        if candidate and Path(candidate).is_file() and os.access(candidate, os.X_OK):
            return str(Path(candidate).resolve())
    return None


def set_values(path, values):
    """Replace the value of each ``name`` in the OpenFAST file ``path`` (one value per line)."""
    text = Path(path).read_text()
    for name, value in values.items():
        pattern = re.compile(rf"^(\s*)(\S+)(\s+){re.escape(name)}(?=\s)", re.M)
        text, n = pattern.subn(lambda m: f"{m[1]}{value}{m[3]}{name}", text)
        if n != 1:
            raise SystemExit(f"{path}: {name} found {n} times, expected once")
    Path(path).write_text(text)


def read_out(path):
    """``(names, units, data)`` of OpenFAST's text output file."""
    lines = Path(path).read_text().splitlines()
    start = next(k for k, line in enumerate(lines) if line.split()[:1] == ["Time"])
    names, units = lines[start].split(), lines[start + 1].split()
    data = np.array([[float(v) for v in line.split()] for line in lines[start + 2:]
                     if line.strip()])
    return names, units, data


def write_deck():
    """The deck's generated files, from kanedyn's OC3 data."""
    oc3.write_tower_file(oc3.DECK / "NRELOffshrBsline5MW_OC3Hywind_ElastoDyn_Tower.dat")
    (oc3.DECK / "HydroData").mkdir(exist_ok=True)
    oc3.write_wamit_files(oc3.DECK / "HydroData" / "Spar")


def run_case(openfast, case, work, discon=None):
    """Run ``case`` in the folder ``work``; its output file's path."""
    shutil.copytree(oc3.DECK, work, dirs_exist_ok=True)
    set_values(work / FST, {"TMax": f"{case.duration:g}", "DT_Out": f"{case.step:g}"})
    values = {k: f"{v:g}" for k, v in case.elastodyn.items()}
    if "BlPitch(1)" in values:   # the three blades alike
        values.update({"BlPitch(2)": values["BlPitch(1)"], "BlPitch(3)": values["BlPitch(1)"]})
    set_values(work / ELASTODYN, {**values, **case.settings})
    if case.wind:
        set_values(work / FST, {"CompInflow": "1", "CompAero": "2", "CompServo": "1",
                                **{k: f'"{v}"' for k, v in WIND_FILES.items()}})
        set_values(work / INFLOW, {"HWindSpeed": f"{case.wind:g}"})
        shutil.copy(discon, work / DISCON_NAME)
    set_values(work / SEASTATE, case.seastate)
    if case.hydrodyn:
        set_values(work / FST, {"HydroFile": f'"{case.hydrodyn}"'})
    log = work / "openfast.log"
    with open(log, "w") as out:
        done = subprocess.run([openfast, FST], cwd=work, stdout=out, stderr=subprocess.STDOUT,
                              timeout=6 * 3600, check=False)
    if done.returncode != 0:
        tail = "\n".join(log.read_text().splitlines()[-15:])
        raise SystemExit(f"OpenFAST failed on the {case.name} case ({done.returncode}):\n{tail}")
    return work / FST.replace(".fst", ".out")


def write_csv(case, out_file):
    names, units, data = read_out(out_file)
    channels = [*oc3.CHANNELS, *([WAVE_CHANNEL] if case.waves else []),
                *(oc3.WIND_CHANNELS if case.wind else [])]
    keep = [0] + [names.index(c) for c in channels]
    header = ",".join(f"{names[k]} {units[k]}".replace("(", "[").replace(")", "]") for k in keep)
    oc3.OUTPUTS.mkdir(parents=True, exist_ok=True)
    np.savetxt(oc3.OUTPUTS / f"{case.name}.csv", data[:, keep], delimiter=",", fmt="%.7g",
               header=header, comments="")


def _summary_rows(path, labels, pattern):
    text = Path(path).read_text()
    rows = []
    for label, key in labels.items():
        m = re.search(pattern.format(re.escape(label)), text, re.M)
        if m is None:
            raise SystemExit(f"{path}: no line {label!r}")
        rows.append(f"{key},{m[1]}")
    return rows


def write_summary(out_file):
    """ElastoDyn's masses and MAP++'s line 1 (summary files of the run) as one CSV."""
    rows = (_summary_rows(out_file.with_suffix(".ED.sum"), ED_SUMMARY,
                          r"^\s*{}\s+\([^)]*\)\s+(\S+)")
            + _summary_rows(out_file.with_suffix(".MAP.sum"), MAP_SUMMARY,
                            r"^{}\s+\[[^]]*\]\s+\|\s+(\S+)"))
    (oc3.OUTPUTS / "summary.csv").write_text("quantity,value\n" + "\n".join(rows) + "\n")


def cmd_run(args):
    openfast = find_openfast(args.openfast)
    if openfast is None:
        print("openfast_oc3: no OpenFAST executable (give --openfast PATH, set $OPENFAST or "
              "put openfast on the PATH); the committed outputs are left as they are")
        return 0
    version = subprocess.run([openfast, "-v"], capture_output=True, text=True, check=False)
    print(openfast, *(line.strip() for line in version.stdout.splitlines()
                      if line.strip().startswith(("OpenFAST-", "OpenFAST v", "- Compiler"))))
    write_deck()
    names = args.cases.split(",") if args.cases else list(oc3.CASES)
    discon = args.discon or os.environ.get("DISCON")
    for name in names:
        case = oc3.CASES[name]
        if case.wind and not (discon and Path(discon).is_file()):
            print(f"{name}: skipped, no controller library (give --discon PATH or set $DISCON)")
            continue
        with tempfile.TemporaryDirectory(prefix=f"oc3-{name}-") as tmp:
            out = run_case(openfast, case, Path(tmp), discon)
            write_csv(case, out)
            if not case.wind:   # its ElastoDyn (no precone) is not the deck's
                write_summary(out)
        print(f"{name}: {case.duration:g} s written to {oc3.OUTPUTS / (name + '.csv')}")
    return 0


UNITS = {"PtfmSurge": "m", "PtfmHeave": "m", "PtfmPitch": "deg", "PtfmYaw": "deg",
         "TTDspFA": "m", "RotSpeed": "rpm", "BlPitch1": "deg", "GenPwr": "kW", "RtAeroFxh": "N"}


def _panel(ax, case, of, kd, channel=None):
    """One case's responses on ``ax``; the title gives both codes' measures."""
    (t_of, a), (t_kd, b) = of, kd
    channel = channel or case.channel
    ax.plot(t_of, a[channel], lw=1.2, label="OpenFAST")
    ax.plot(t_kd, b[channel], "--", lw=1.0, label="kanedyn")
    unit = UNITS[channel]
    ax.set_ylabel(f"{channel} [{unit}]")
    if case.waves:
        h_of, h_kd = (oc3.wave_harmonic(t, s[channel], oc3.WAVE_PERIOD, oc3.WAVE_START)
                      for t, s in ((t_of, a), (t_kd, b)))
        title = (f"{case.title}: {channel}\namplitude at the wave period (from "
                 f"{oc3.WAVE_START:g} s) {h_of.amplitude:.4g} / {h_kd.amplitude:.4g} {unit}")
    elif not case.elastodyn:     # released undisplaced: the offsets it settles to
        period = 29.5                       # the pitch period, s
        title = (f"{case.title}\nsettles to {oc3.settled_offset(t_of, a[channel], period):.4f} / "
                 f"{oc3.settled_offset(t_kd, b[channel], period):.4f} {unit}")
    else:
        m_of, m_kd = oc3.decay_measures(t_of, a[channel]), oc3.decay_measures(t_kd, b[channel])
        title = (f"{case.title}\nperiod {m_of.period:.4g} / {m_kd.period:.4g} s, damping ratio "
                 f"{m_of.damping:.4f} / {m_kd.damping:.4f}")
    print(title.replace("\n", ": "))
    ax.set_title(title + " (OpenFAST / kanedyn)", fontsize=8)
    ax.legend(fontsize=7, loc="upper right")


def cmd_figure(args):
    from kanedyn.analysis._plotting import pyplot, save_figure
    plt = pyplot()
    # one panel per case, and the wave case's surge beside its pitch
    cases = [case for case in oc3.CASES.values() if not case.wind]
    panels = [(case, None) for case in cases]
    panels += [(case, "PtfmSurge") for case in cases if case.waves]
    rows = (len(panels) + 1) // 2
    fig, axes = plt.subplots(rows, 2, figsize=(12, 2.9 * rows))
    responses = {}
    for ax, (case, channel) in zip(axes.ravel(), panels):
        if case.name not in responses:
            responses[case.name] = (oc3.read_output_csv(oc3.OUTPUTS / f"{case.name}.csv"),
                                    oc3.kanedyn_response(case))
        _panel(ax, case, *responses[case.name], channel=channel)
        ax.set_xlabel("time [s]", fontsize=8)
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    fig.suptitle("OC3-Hywind, rotor parked, no wind: OpenFAST v5 (ElastoDyn, HydroDyn "
                 "with constant added mass, MAP++) and kanedyn oc3-spar on the same inputs",
                 fontsize=10)
    fig.tight_layout()
    save_figure(fig, FIGURE, dpi=100)
    print(f"figure: {FIGURE}")
    return 0


def cmd_wind_figure(args):
    from kanedyn.analysis._plotting import pyplot, save_figure
    plt = pyplot()
    case = oc3.CASES["wind"]
    (t_of, a), (t_kd, b) = (oc3.read_output_csv(oc3.OUTPUTS / "wind.csv"),
                            oc3.kanedyn_response(case))
    channels = ["RotSpeed", "BlPitch1", "GenPwr", "RtAeroFxh", "PtfmSurge", "PtfmPitch",
                "PtfmHeave", "TTDspFA"]
    fig, axes = plt.subplots(4, 2, figsize=(12, 11))
    for ax, channel in zip(axes.ravel(), channels):
        ax.plot(t_of, a[channel], lw=1.2, label="OpenFAST")
        ax.plot(t_kd, b[channel], "--", lw=1.0, label="kanedyn")
        m_of, m_kd = (oc3.wind_mean(t, s, channel) for t, s in ((t_of, a), (t_kd, b)))
        ax.axvline(oc3.WIND_START, color="0.6", lw=0.8)
        ax.set_ylabel(f"{channel} [{UNITS[channel]}]")
        ax.set_title(f"{channel}: mean from {oc3.WIND_START:g} s {m_of:.5g} / {m_kd:.5g} "
                     f"{UNITS[channel]} (OpenFAST / kanedyn)", fontsize=8)
        print(f"{channel}: OpenFAST {m_of:.6g}, kanedyn {m_kd:.6g}, kanedyn - OpenFAST "
              f"{m_kd - m_of:.4g} ({m_kd / m_of - 1:+.2%})")
        ax.legend(fontsize=7, loc="upper right")
        ax.set_xlabel("time [s]", fontsize=8)
    fig.suptitle(f"OC3-Hywind, steady wind {case.wind:g} m/s, rotor turning, baseline "
                 "controller, still water:\nOpenFAST v5 (AeroDyn quasi-steady BEM, "
                 "controller library) and kanedyn oc3-spar (aero=bem, controller=on)",
                 fontsize=10)
    fig.tight_layout()
    save_figure(fig, WIND_FIGURE, dpi=100)
    print(f"figure: {WIND_FIGURE}")
    return 0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run OpenFAST on the cases, write the outputs")
    run.add_argument("--openfast", help="the OpenFAST executable")
    run.add_argument("--cases", help="comma-separated case names (default: all)")
    run.add_argument("--discon", help="the baseline controller library (the wind case)")
    sub.add_parser("figure", help="run kanedyn on the cases, draw docs/img/oc3-openfast.png")
    sub.add_parser("wind-figure", help="run kanedyn on the wind case, draw "
                   "docs/img/oc3-openfast-wind.png")
    args = p.parse_args(argv)
    commands = {"run": cmd_run, "figure": cmd_figure, "wind-figure": cmd_wind_figure}
    return commands[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
