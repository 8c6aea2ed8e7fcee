"""``kanedyn run``: derive, simulate, write CSV, plots and a summary.

Ctrl-C or SIGTERM during the simulation ends it with what it computed, which is
written as for a finished run; the exit status is then 128 + the signal's number
(130, 143).  The data (CSV and summary) is written first and always completed;
a signal while it is written is held.  Then the plot (and the page): a first
signal is held until they are complete, a second (counting one that ended the
simulation) stops them at once; a third stops anything at once.  Every
file is written under a new name in the output folder and renamed when
complete (:mod:`kanedyn._output_files`), so that a file of the folder is never
cut short (a full disk gives an error naming the file, and an earlier file of
that name stays as it was).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from .._errors import KanedynError, SimulationInterrupted
from .._output_files import replacing
from .._progress import Progress
from .._signals import Stopped, exit_status, holding, interruption
from ..models import REGISTRY, build
from ._options import (add_backend_argument, add_model_argument, check_output_dir, integrator_name,
                       numeric_model, parse_sets, point_count, positive_float, split_values)

__all__ = ["add_parser", "cmd_run"]


def add_parser(sub):
    """Add the ``run`` sub-command to ``sub``."""
    p = sub.add_parser("run", help="derive, simulate, write CSV, plots and a summary")
    add_model_argument(p)
    p.add_argument("--t-end", type=positive_float, default=None,
                   help="end time [s] (default: the model's)")
    p.add_argument("--out", default="kanedyn-out", help="output directory")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option (n=4), parameter (m=2) or initial value (q1=0.3)")
    pulse = p.add_mutually_exclusive_group()
    pulse.add_argument("--pulse", metavar="NAME",
                       help="the model's base-motion pulse (its option 'pulse'), e.g. "
                            "halfsine, haversine, trapezoid, step, none, frontal-48kmh")
    pulse.add_argument("--pulse-file", metavar="RECORD",
                       help="a recorded pulse as the model's option 'pulse': a CSV (t, ax, "
                            "ay, az[, wx, wy, wz]) or an ISO-MME test (its folder or .mme "
                            "file; the vehicle's channels)")
    p.add_argument("--method", type=integrator_name, default="RK45",
                   help="integrator: a solve_ivp method (RK45, DOP853, Radau, BDF, ...) "
                        "or Rosenbrock23 (compiled loop, --backend c)")
    p.add_argument("--rtol", type=positive_float, default=1e-8, help="relative tolerance")
    p.add_argument("--atol", type=positive_float, default=1e-8, help="absolute tolerance")
    p.add_argument("--points", type=point_count, default=501,
                   help="output points (at least 2)")
    add_backend_argument(p)
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument("--animate", action="store_true",
                   help="also write OUT/MODEL.html, a 3D animation that opens offline")
    p.set_defaults(func=cmd_run)


def cmd_run(args):
    options, values = parse_sets(args.model, args.set)
    options.update(_pulse_option(args, options))
    definition = build(args.model, **options)  # checks the options
    constants, initial = split_values(definition, values)  # ... and the other names
    out = check_output_dir(args.out)  # before any work, not after it
    progress = Progress(enabled=not args.quiet)
    progress.stage(f"deriving {definition.title}")
    if args.backend != "numpy":
        definition.prefetch_runtime()  # the C runtime compiles meanwhile
    eom = definition.derive(progress=progress)
    model = numeric_model(definition, eom, args.backend, constants)
    y0 = definition.initial(model, initial)
    t_end = args.t_end if args.t_end is not None else definition.t_end
    progress.stage(f"simulating 0..{t_end:g} s ({args.method}, rtol={args.rtol:g})")
    stopped_by = None  # the signal that ended the simulation
    try:
        res = _simulate(model, t_end, y0, args, progress, bool(model.constraint_force_names))
    except SimulationInterrupted as stop:  # Ctrl-C, SIGTERM: write what was computed
        progress.done()
        res, stopped_by = stop.result, stop.signum
    report = (definition.report(res, definition)  # of the output points: none, no report
              if definition.report is not None and res.t.size else None)
    balance = _energy_balance(definition, res) if stopped_by is None else None
    writing, written = _Writing(stopped_by), []
    try:
        with holding(writing.on_signal):
            summary = _write_run(definition, eom, model, res, out, progress, report, balance,
                                 written, writing.pictures)
            if args.animate:
                page = _written(out / f"{definition.name}.html", written,
                                lambda path: res.animate(
                                    path, visuals=definition.shapes(constants),
                                    title=f"{definition.name}: {definition.title}",
                                    inputs=definition.animation_inputs))
                progress.stage(f"wrote {page}")
    except Stopped as stop:  # signals while writing: the files completed stay
        print(f"kanedyn: {interruption(stopped_by or stop.signum)}; stopped while writing "
              f"the outputs, complete: {', '.join(written) or 'none'}", file=sys.stderr)
        return exit_status(stopped_by or stop.signum)
    if writing.first is not None and stopped_by is None:
        print(f"kanedyn: {interruption(writing.first)} while writing the outputs; they were "
              "finished first", file=sys.stderr)
        return exit_status(writing.first)
    _print_summary(summary, balance)
    if report is not None:
        print(f"{definition.name} report: {_report_text(report)}")
    _print_identified(model, res)
    if stopped_by is not None:
        reached = (f"at t = {res.t[-1]:g} s" if res.t.size
                   else "before the first output time")
        print(f"kanedyn: {interruption(stopped_by)} {reached}; wrote the partial result",
              file=sys.stderr)
        return exit_status(stopped_by)
    return 0 if res.success else 1


class _Writing:
    """Stop signals while the outputs are written (see the module's text).

    Attributes
    ----------
    first : int or None
        The first signal, counting the one that ended the simulation.
    """

    def __init__(self, stopped_by):
        self.first = stopped_by
        self.count = 0 if stopped_by is None else 1
        self._pictures = False

    def on_signal(self, signum):
        self.count += 1
        self.first = self.first or signum
        if self.count >= 3 or (self._pictures and self.count >= 2):
            raise Stopped(signum)

    def pictures(self):
        """The data is written; now the pictures (stopped at once after two signals)."""
        self._pictures = True
        if self.count >= 2:
            raise Stopped(self.first)


def _written(path, written, write):
    """``write(path)`` (a writer of the library, which writes through
    :func:`~kanedyn._output_files.replacing`: complete or not at all); the
    name added to ``written`` when it is complete."""
    write(path)
    written.append(path.name)
    return path


def _pulse_option(args, options):
    """``{"pulse": value}`` from ``--pulse`` or ``--pulse-file`` (empty when neither)."""
    name, path = getattr(args, "pulse", None), getattr(args, "pulse_file", None)
    if name is None and path is None:
        return {}
    flag = "--pulse" if name is not None else "--pulse-file"
    _, option_types = REGISTRY[args.model]
    if "pulse" not in option_types:
        raise KanedynError(f"{flag}: model {args.model} has no pulse option (models with "
                           "one: " + ", ".join(m for m, (_, o) in REGISTRY.items()
                                               if "pulse" in o) + ")")
    if "pulse" in options:
        raise KanedynError(f"{flag}: the pulse is also given by --set pulse=...; give it once")
    if name is not None:
        return {"pulse": name}
    file = Path(path)
    if not (file.is_file() or file.is_dir()):
        raise KanedynError(f"--pulse-file {path}: no such file or ISO-MME test folder")
    return {"pulse": file}


def _report_text(report):
    text = getattr(report, "text", None)
    return text() if callable(text) else str(report)


def _report_dict(report):
    as_dict = getattr(report, "as_dict", None)
    return as_dict() if callable(as_dict) else {"text": _report_text(report)}


def _write_run(definition, eom, model, res, out, progress, report, balance, written,
               pictures):
    """CSV and summary, then the plot (``pictures()`` called between them); the names
    of the files completed go into ``written``."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise KanedynError(f"cannot create the output folder {out}: "
                           f"{exc.strerror or exc}") from None
    csv_path = _written(out / f"{definition.name}.csv", written, res.to_csv)
    summary = res.summary()
    summary.update(model=definition.name, backend=model.backend, constants=model.constants,
                   initial_state=dict(zip(model.state_names,
                                          map(float, res.initial_state))))
    if report is not None:
        summary["report"] = _report_dict(report)
    if balance is not None:
        summary["energy_terms"] = (balance.as_dict() if not isinstance(balance, str)
                                   else {"not available": balance})
    text = json.dumps(summary, indent=2, default=float)

    def write_summary(path):
        with replacing(path) as handle:
            handle.write(text)
    _written(out / "summary.json", written, write_summary)
    pictures()
    import matplotlib.pyplot as plt
    figures = []
    from ..analysis import run_figure
    from .._output_files import save_figure
    pictures_written = [out / f"{definition.name}.png"]
    try:
        _written(pictures_written[0], written,
                 lambda path: figures.append(res.plot(path=path)))
        story = run_figure(res, definition) if res.t.size else None  # the model's own
        if story is not None:
            figures.append(story)
            pictures_written.append(_written(out / f"{definition.name}_story.png", written,
                                             lambda path: save_figure(story, path, dpi=120)))
    finally:
        for fig in figures:
            plt.close(fig)
    progress.stage(f"wrote {csv_path}, {out / 'summary.json'}, "
                   + ", ".join(map(str, pictures_written)))
    return summary


def _simulate(model, t_end, y0, args, progress, forces):
    import numpy as np
    from ..simulation import simulate
    t_eval = np.linspace(0.0, t_end, max(2, int(args.points)))
    return simulate(model, (0.0, t_end), y0, method=args.method, rtol=args.rtol,
                    atol=args.atol, t_eval=t_eval, progress=progress,
                    constraint_forces=forces, dense_output=not model.contacts)


def _energy_balance(definition, res):
    """The run's energy balance term by term (:func:`kanedyn.analysis.energy_balance`),
    the reason why there is none (text), or ``None`` for a model with contacts (its
    own balance is in the summary)."""
    if res.model.contacts:
        return None
    if res.t.size < 2 or res.sol is None:
        return "the run has fewer than two output points"
    from ..analysis import energy_balance
    try:
        return energy_balance(res, load_names=definition.load_names or None,
                              potential_loads=definition.potential_loads)
    except KanedynError as exc:
        return str(exc)


def _print_summary(summary, balance):
    print(f"success: {summary['success']} ({summary['message']}), "
          f"backend: {summary['backend']}")
    reached = "none reached" if summary["t_end"] is None else f"{summary['t_end']:g} s"
    print(f"points: {summary['points']}, t_end: {reached}, "
          f"rhs evaluations: {summary['rhs_evaluations']}")
    if "impacts" in summary:  # contacts
        balance = summary["energy_balance"]
        print(f"impacts: {summary['impacts']} (energy lost {summary['impact_energy_loss']:.4g}"
              f" J), friction work {summary['friction_work']:.4g} J")
        print("energy balance error: " + ("n/a (no energy defined)" if balance is None
                                          else f"{balance:.3e} J"))
        changes = summary["mode_changes"]
        print(f"contact mode changes: {len(changes)}")
        for line in changes[:12]:
            print("  " + line)
        if len(changes) > 12:
            print(f"  ... ({len(changes) - 12} more in summary.json)")
    elif isinstance(balance, str):
        print(f"energy balance: not available ({balance})")
    elif balance is not None:
        print("energy balance over the run:")
        print("\n".join(balance.lines()))
    residual = summary["max_constraint_residual"]
    print("max constraint residual: " + ("n/a (no output points)" if residual is None
                                         else f"{residual:.3e}")
          + f" ({summary['projections']} projections)")


def _print_identified(model, res):
    """Final identified constraint forces and the largest Newton-Euler residual."""
    if not model.identified_names or res.t.size == 0:
        return
    print(f"identified constraint forces at t = {res.t[-1]:g} s: "
          + ", ".join(f"{name} = {res[name][-1]:.6g}" for name in model.identified_names))
    from ..analysis import check_newton_euler
    try:
        check = check_newton_euler(res)
    except KanedynError as exc:
        print(f"Newton-Euler check not possible: {exc}")
        return
    print(f"max Newton-Euler residual: {check.max:.3e} (multipliers from the "
          f"{check.source}; inertia scale {check.inertia_scale:.3g})")
