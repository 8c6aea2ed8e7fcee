"""The ``kanedyn`` command line.

::

    kanedyn list
    kanedyn derive MODEL [--latex] [--set name=value ...]
    kanedyn run MODEL [--t-end T] [--out DIR] [--set name=value ...]
    kanedyn demo [--out DIR]
    kanedyn compare nonholonomic|MODEL [--methods kane,lagrange,augmented] [--t-end T]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import sympy as sm

from .._version import __version__
from .._errors import KanedynError, SimulationInterrupted
from .._number_text import parse_number
from .._progress import Progress
from ..engine import name_of
from ..models import REGISTRY, build

__all__ = ["main"]


def _parse_sets(model_name, pairs):
    """Split ``name=value`` pairs into model options, constants and initial values."""
    _, option_types = REGISTRY[model_name]
    options, rest = {}, {}
    for pair in pairs or ():
        if "=" not in pair:
            raise KanedynError(f"--set expects name=value, got {pair!r}")
        key, value = (s.strip() for s in pair.split("=", 1))
        if key in option_types:
            options[key] = _option_value(model_name, key, option_types[key], value)
        else:
            rest[key] = _finite(parse_number(value, f"--set {key}"), key, value)
    return options, rest


def _finite(number, key, text):
    if not np.isfinite(number):
        raise KanedynError(f"--set {key}: {text!r} is not a finite number")
    return number


def _option_value(model_name, key, kind, text):
    """A model option from its text (never evaluated as code)."""
    what = f"option {key} of {model_name}"
    if kind is bool:
        if text.lower() not in ("true", "false", "1", "0", "yes", "no"):
            raise KanedynError(f"{what} is true or false, got {text!r}")
        return text.lower() in ("true", "1", "yes")
    if kind is int:
        try:
            return int(text)
        except ValueError:
            raise KanedynError(f"{what} is a whole number, got {text!r}") from None
    if kind is float:
        return _finite(parse_number(text, what), key, text)
    return text


def _split_values(definition, model, values):
    constants, initial = {}, {}
    const_names = {str(s) for s in definition.constants}
    for key, value in values.items():
        if key in const_names:
            constants[key] = value
        elif key in model.state_names:
            initial[key] = value
        else:
            raise KanedynError(
                f"--set {key}: not an option, parameter or state of {definition.name}; "
                f"parameters: {', '.join(sorted(const_names))}; states: "
                f"{', '.join(model.state_names)}")
    return constants, initial


def cmd_list(args):
    print(f"{'model':26s} description (options: --set NAME=VALUE)")
    for name, (builder, options) in REGISTRY.items():
        print(f"{name:26s} {builder().title}")
        if options:
            opts = ", ".join(f"{k}=<{t.__name__}>" for k, t in options.items())
            print(f"{'':26s}   options: {opts}")
    return 0


def cmd_derive(args):
    options, values = _parse_sets(args.model, args.set)
    if values:
        raise KanedynError("derive takes only model options with --set "
                           f"(got {', '.join(values)})")
    definition = build(args.model, **options)
    progress = Progress(enabled=not args.quiet)
    t0 = time.perf_counter()
    eom = definition.derive(progress=progress)
    elapsed = time.perf_counter() - t0
    counts = eom.operation_counts()
    print(f"# {definition.title}")
    print(f"# derived in {elapsed:.3f} s: {eom!r}")
    print(f"# operations: mass matrix {counts['mass_matrix']}, forcing "
          f"{counts['forcing']}, constraints {counts['constraints']}, all jointly "
          f"{counts['all']} ({counts['intermediates']} intermediates)")
    print(f"# states: {', '.join(eom.state_names)}")
    print(f"# constants: {', '.join(map(str, eom.constants))}")
    if eom.specified:
        print(f"# specified inputs: {', '.join(map(str, eom.specified))}")
    if args.latex:
        print(eom.to_latex(explicit=args.explicit))
    else:
        compact = not args.explicit and eom._program.count_ops(
            list(eom._compact_mass_matrix) + list(eom._compact_forcing)) > 400
        if compact:
            print(eom.to_latex(explicit=False))
        else:
            for qd, rhs in eom.kindiffdict().items():
                print(f"{name_of(qd)} = {rhs}")
            print("# mass_matrix * u' = forcing, with u' = "
                  f"[{', '.join(name_of(u) + chr(39) for u in eom.u)}]")
            M, F = eom.mass_matrix, eom.forcing
            for i in range(M.rows):
                for j in range(M.cols):
                    if M[i, j] != 0:
                        print(f"mass_matrix[{i}, {j}] = {sm.sstr(M[i, j])}")
            for i in range(F.rows):
                print(f"forcing[{i}] = {sm.sstr(F[i])}")
    return 0


def _write_run(definition, eom, model, res, out, progress):
    out.mkdir(parents=True, exist_ok=True)
    csv_path = res.to_csv(out / f"{definition.name}.csv")
    fig = res.plot(path=out / f"{definition.name}.png")
    import matplotlib.pyplot as plt
    plt.close(fig)
    summary = res.summary()
    summary.update(model=definition.name, constants=model.constants,
                   initial_state=dict(zip(model.state_names,
                                          map(float, res.initial_state))))
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=float))
    progress.stage(f"wrote {csv_path}, {out / (definition.name + '.png')}, "
                   f"{out / 'summary.json'}")
    return summary


def cmd_run(args):
    options, values = _parse_sets(args.model, args.set)
    definition = build(args.model, **options)
    progress = Progress(enabled=not args.quiet)
    progress.stage(f"deriving {definition.title}")
    eom = definition.derive(progress=progress)
    probe = definition.numeric(eom)
    constants, initial = _split_values(definition, probe, values)
    model = definition.numeric(eom, constants=constants) if constants else probe
    y0 = definition.initial(model, initial)
    t_end = args.t_end if args.t_end is not None else definition.t_end
    progress.stage(f"simulating 0..{t_end:g} s ({args.method}, rtol={args.rtol:g})")
    try:
        res = _simulate(model, t_end, y0, args, progress, bool(model.constraint_force_names))
    except SimulationInterrupted as stop:  # Ctrl-C: write what was computed
        progress.done()
        res = stop.result
    summary = _write_run(definition, eom, model, res, Path(args.out), progress)
    _print_summary(summary)
    _print_identified(model, res)
    if res.message == "interrupted":
        print(f"kanedyn: interrupted at t = {res.t[-1]:g} s; wrote the partial result",
              file=sys.stderr)
        return 130
    return 0 if res.success else 1


def _simulate(model, t_end, y0, args, progress, forces):
    from ..simulation import simulate
    t_eval = np.linspace(0.0, t_end, max(2, int(args.points)))
    return simulate(model, (0.0, t_end), y0, method=args.method, rtol=args.rtol,
                    atol=args.atol, t_eval=t_eval, progress=progress,
                    constraint_forces=forces)


def _print_summary(summary):
    drift = summary["energy_drift"]
    print(f"success: {summary['success']} ({summary['message']})")
    print(f"points: {summary['points']}, t_end: {summary['t_end']:g} s, "
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
    else:
        print("energy drift (relative): " + ("n/a (no energy defined)" if drift is None
                                             else f"{drift:.3e}"))
    print(f"max constraint residual: {summary['max_constraint_residual']:.3e} "
          f"({summary['projections']} projections)")


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


def cmd_demo(args):
    """Derive the Whipple bicycle, map its stability against speed, ride it."""
    from ..analysis import pyplot
    from ..models import eigenvalues_vs_speed, stability_speeds, upright_state

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    progress = Progress(enabled=not args.quiet)
    definition = build("whipple-bicycle")
    progress.stage("deriving the nonlinear Whipple bicycle (Kane's method)")
    t0 = time.perf_counter()
    eom = definition.derive(progress=progress)
    t_derive = time.perf_counter() - t0
    model = definition.numeric(eom)
    print(f"Whipple bicycle: {len(eom.q)} coordinates ({len(eom.q_dep)} dependent), "
          f"{len(eom.u)} speeds ({len(eom.u_dep)} dependent); derived in "
          f"{t_derive:.2f} s")

    progress.stage("linearizing about upright straight running, v = 0..10 m/s")
    speeds = np.linspace(0.0, 10.0, 41)
    eigs = eigenvalues_vs_speed(model, speeds)
    print("\n  v [m/s]   eigenvalues of the lean/steer dynamics [1/s]")
    for v, ev in zip(speeds[::4], eigs[::4]):
        print(f"  {v:6.2f}   " + "  ".join(f"{z.real:9.4f}{z.imag:+9.4f}j" for z in ev))
    weave, capsize = stability_speeds(model)
    print(f"\nself-stable speed range: {weave:.10f} < v < {capsize:.10f} m/s")
    print("published (Meijaard et al. 2007): 4.29238253634111 < v < 6.02426201538837")

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for k in range(4):
        ax.plot(speeds, eigs[:, k].real, "k.", ms=3)
        ax.plot(speeds, np.abs(eigs[:, k].imag), "b.", ms=2)
    ax.axvspan(weave, capsize, color="g", alpha=0.15, label="self-stable")
    ax.set_ylim(-10, 10)
    ax.set_xlabel("forward speed v [m/s]")
    ax.set_ylabel("eigenvalues: real (black), |imag| (blue) [1/s]")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "bicycle_eigenvalues.png", dpi=120)
    plt.close(fig)

    progress.stage("simulating a self-stable ride at 5 m/s after a push (lean rate 0.5 rad/s)")
    from ..simulation import simulate
    y0 = upright_state(model, 5.0)
    y0[model.index("u4")] = 0.5
    y0 = model.consistent_state(0.0, y0)
    t_end = args.t_end
    res = simulate(model, (0.0, t_end), y0, rtol=1e-8, atol=1e-8,
                   t_eval=np.linspace(0.0, t_end, 501), progress=progress)
    res.to_csv(out / "bicycle_ride.csv")
    fig = res.plot(states=["q4", "q7", "u4", "u7"], path=out / "bicycle_ride.png")
    plt.close(fig)
    lean, steer = res["q4"], res["q7"]
    tail = res.t >= res.t[-1] - 1.0
    print(f"ride: success={res.success}; max |lean| {np.max(np.abs(lean)):.4f} rad; "
          f"|lean| over the last second <= {np.max(np.abs(lean[tail])):.2e} rad, "
          f"|steer| <= {np.max(np.abs(steer[tail])):.2e} rad")
    print(f"energy drift {res.energy_drift():.2e}, max constraint residual "
          f"{np.max(res.constraint_residual):.2e}")
    print(f"wrote {out / 'bicycle_eigenvalues.png'}, {out / 'bicycle_ride.png'}, "
          f"{out / 'bicycle_ride.csv'}")
    return 0 if res.success else 1


def cmd_compare(args):
    from ..analysis import NONHOLONOMIC_EXAMPLES, compare_formulations, work_precision
    from ..formulations import FORMULATIONS
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if m not in FORMULATIONS]
    if unknown:
        raise KanedynError(f"unknown formulation(s) {', '.join(unknown)}; available: "
                           f"{', '.join(sorted(FORMULATIONS))}")
    if args.target == "nonholonomic":
        names = list(NONHOLONOMIC_EXAMPLES)
    elif args.target in REGISTRY:
        names = [args.target]
    else:
        raise KanedynError(f"compare: unknown target {args.target!r}; give 'nonholonomic' "
                           f"or a model: {', '.join(REGISTRY)}")
    if args.set and len(names) > 1:
        raise KanedynError("--set applies to one model; give a model name, not "
                           f"{args.target!r}")
    print("Each formulation starts from the same coordinates and rates (augmented-"
          "Lagrangean multipliers at 0),")
    print(f"integrated by {args.integrator} at rtol={args.rtol:g}, atol={args.atol:g}. "
          "mul/add/fun: operations of the generated")
    print("equations after joint CSE. N-E: Newton-Euler residuals of every body with the "
          "identified constraint forces")
    print("(the equations' own multipliers, or the best least-squares fit). |h|, |c|: "
          "position- and velocity-level constraint")
    print("errors; |dE|: energy change (meaningful on conservative runs); proj: drift "
          "projections; cpu/s: CPU s per simulated s.")
    out_dir = Path(args.out) if args.plot else None
    for name in names:
        options, constants = _parse_sets(name, args.set)
        cmp = compare_formulations(name, methods, t_end=args.t_end, rtol=args.rtol,
                                   atol=args.atol, integrator=args.integrator,
                                   constants=constants or None, **options)
        print()
        print(cmp.table())
        if out_dir is not None:
            out_dir.mkdir(parents=True, exist_ok=True)
            path = out_dir / f"compare-{name}.png"
            cmp.plot(path)
            print(f"plot: {path}")
        if args.work_precision:
            wp = work_precision(name, methods, t_end=args.t_end, target=args.target_error,
                                integrator=args.integrator, constants=constants or None,
                                **options)
            print()
            print(wp.table())
    return 0


def _parser():
    parser = argparse.ArgumentParser(
        prog="kanedyn", description="Multibody dynamics by Kane's method.")
    parser.add_argument("--version", action="version", version=f"kanedyn {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("list", help="list the built-in models")
    p.set_defaults(func=cmd_list)

    p = sub.add_parser("derive", help="derive and print a model's equations of motion")
    p.add_argument("model", choices=list(REGISTRY))
    p.add_argument("--latex", action="store_true", help="print LaTeX")
    p.add_argument("--explicit", action="store_true",
                   help="explicit expressions even for large models")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option, e.g. n=8")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_derive)

    p = sub.add_parser("run", help="derive, simulate, write CSV, plots and a summary")
    p.add_argument("model", choices=list(REGISTRY))
    p.add_argument("--t-end", type=float, default=None, help="end time [s]")
    p.add_argument("--out", default="kanedyn-out", help="output directory")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option (n=4), parameter (m=2) or initial value (q1=0.3)")
    p.add_argument("--method", default="RK45", help="solve_ivp method")
    p.add_argument("--rtol", type=float, default=1e-8)
    p.add_argument("--atol", type=float, default=1e-8)
    p.add_argument("--points", type=int, default=501, help="output points")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("compare", help="simulate models under several formulations; "
                                       "Newton-Euler residuals side by side")
    p.add_argument("target", help="'nonholonomic' (the nonholonomic examples) or a model")
    p.add_argument("--methods", default="kane,lagrange,augmented",
                   help="comma-separated formulations; the first is the reference")
    p.add_argument("--t-end", type=float, default=None, help="end time [s]")
    p.add_argument("--rtol", type=float, default=1e-10)
    p.add_argument("--atol", type=float, default=1e-12)
    p.add_argument("--integrator", default="RK45", help="solve_ivp method for every "
                                                         "formulation (e.g. BDF)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option (n=6) or parameter (A=0)")
    p.add_argument("--plot", action="store_true",
                   help="save constraint-error / energy / deviation plots in --out")
    p.add_argument("--out", default="kanedyn-out", help="output directory for --plot")
    p.add_argument("--work-precision", action="store_true",
                   help="also CPU time at equal accuracy (runs at rtol 1e-6, 1e-8, 1e-10)")
    p.add_argument("--target-error", type=float, default=1e-6,
                   help="accuracy for --work-precision [same units as q]")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("demo", help="the Whipple bicycle: stability against speed "
                                    "and a self-stable ride")
    p.add_argument("--out", default="kanedyn-out", help="output directory")
    p.add_argument("--t-end", type=float, default=5.0, help="ride length [s]")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_demo)
    return parser


def main(argv=None):
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except KanedynError as exc:
        print(f"kanedyn: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into e.g. head, which closed early
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:
        print("kanedyn: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
