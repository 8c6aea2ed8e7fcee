"""``kanedyn compare``: one model under several formulations, side by side."""

from __future__ import annotations

from .._errors import KanedynError
from ..models import REGISTRY, build, unknown_model_text
from ._options import (add_backend_argument, check_output_dir, integrator_name, parse_sets,
                       positive_float, split_values)

__all__ = ["add_parser", "cmd_compare"]


def add_parser(sub):
    """Add the ``compare`` sub-command to ``sub``."""
    p = sub.add_parser("compare", help="simulate models under several formulations; "
                                       "Newton-Euler residuals side by side")
    p.add_argument("target", help="'nonholonomic' (the nonholonomic examples) or a model")
    p.add_argument("--methods", default="kane,lagrange,augmented",
                   help="comma-separated formulations; the first is the reference")
    p.add_argument("--t-end", type=positive_float, default=None,
                   help="end time [s] (default: the model's)")
    p.add_argument("--rtol", type=positive_float, default=1e-10, help="relative tolerance")
    p.add_argument("--atol", type=positive_float, default=1e-12, help="absolute tolerance")
    p.add_argument("--integrator", type=integrator_name, default=None,
                   help="integrator for every formulation: a solve_ivp method (RK45, "
                        "DOP853, Radau, BDF, ...); default: RK45, or Radau for a model "
                        "with flexible bodies (their stiff modes)")
    add_backend_argument(p, auto="numpy: not every formulation has a C right-hand side")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option (n=6) or parameter (A=0)")
    p.add_argument("--plot", action="store_true",
                   help="save constraint-error / energy / deviation plots and the motion "
                        "beside the Newton-Euler residuals in --out")
    p.add_argument("--out", default="kanedyn-out",
                   help="output directory for --plot, the --work-precision diagram and "
                        "the figure of 'nonholonomic' (compare-nonholonomic.png: each "
                        "formulation's motion beside its Newton-Euler residual, always "
                        "written)")
    p.add_argument("--work-precision", action="store_true",
                   help="also CPU time at equal accuracy (runs at rtol 1e-6, 1e-8, 1e-10); "
                        "table and diagram (work-precision-MODEL.png in --out)")
    p.add_argument("--quiet", action="store_true",
                   help="print only the tables (no explanation of the columns)")
    p.add_argument("--target-error", type=positive_float, default=1e-6,
                   help="accuracy for --work-precision [same units as q]")
    p.set_defaults(func=cmd_compare)


def cmd_compare(args):
    from ..analysis import (NONHOLONOMIC_EXAMPLES, compare_formulations,
                            plot_newton_euler_residuals, work_precision)
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
        raise KanedynError(f"compare: {unknown_model_text(args.target)} (give "
                           f"'nonholonomic' or a model: {', '.join(REGISTRY)})")
    if args.set and len(names) > 1:
        raise KanedynError("--set applies to one model; give a model name, not "
                           f"{args.target!r}")
    for name in names:  # every --set name checked before any derivation
        options, constants = parse_sets(name, args.set)
        if constants:
            _, initial = split_values(build(name, **options), constants)
            if initial:
                raise KanedynError(f"--set {next(iter(initial))}: compare takes model options "
                                   "and parameters, not initial values")
    integrator = args.integrator or _default_integrator(names, args.set)
    study = args.target == "nonholonomic"  # its figure is always written
    out_dir = (check_output_dir(args.out) if args.plot or args.work_precision or study
               else None)  # before any work
    if not args.quiet:
        _print_explanation(args, integrator)
    # auto is numpy here: not every formulation compared has a C right-hand side
    backend = "numpy" if args.backend == "auto" else args.backend
    comparisons = []
    for name in names:
        options, constants = parse_sets(name, args.set)
        cmp = compare_formulations(name, methods, t_end=args.t_end, rtol=args.rtol,
                                   atol=args.atol, integrator=integrator,
                                   constants=constants or None, backend=backend,
                                   **options)
        comparisons.append(cmp)
        print()
        print(cmp.table())
        if args.plot or args.work_precision:
            path = out_dir / f"compare-{name}.png"
            cmp.plot(path)
            print(f"plot: {path}")
            if not cmp.newton_euler:
                print(f"no Newton-Euler figure: {cmp.newton_euler_note}")
            elif args.plot and not study:
                path = out_dir / f"newton-euler-{name}.png"
                plot_newton_euler_residuals([cmp], path)
                print(f"motion and Newton-Euler residuals: {path}")
        if args.work_precision:
            wp = work_precision(name, methods, t_end=args.t_end, target=args.target_error,
                                integrator=integrator, constants=constants or None,
                                backend=backend, **options)
            print()
            print(wp.table())
            path = out_dir / f"work-precision-{name}.png"
            wp.plot(path)
            print(f"work-precision diagram: {path}")
    if study:
        path = out_dir / "compare-nonholonomic.png"
        plot_newton_euler_residuals(comparisons, path)
        print()
        print(f"motion and Newton-Euler residuals of every example: {path}")
    return 0


def _default_integrator(names, sets):
    """RK45, or Radau where a model has flexible bodies: their bending modes make
    the equations stiff, and explicit steps crawl at their stability limit."""
    from ..modeling import FlexibleBody
    for name in names:
        options, _ = parse_sets(name, sets)
        bodies = build(name, **options).kane_args.get("bodies", ())
        if any(isinstance(b, FlexibleBody) for b in bodies):
            print(f"integrator: Radau for every formulation ({name} has flexible bodies, "
                  "whose stiff modes would hold an explicit method to tiny steps; "
                  "--integrator to choose)")
            return "Radau"
    return "RK45"


def _print_explanation(args, integrator):
    print("Each formulation starts from the same coordinates and rates (augmented-"
          "Lagrangean multipliers at 0),")
    print(f"integrated by {integrator} at rtol={args.rtol:g}, atol={args.atol:g}. "
          "mul/add/fun: operations of the generated")
    print("equations after joint CSE. N-E: Newton-Euler residuals of every body with the "
          "identified constraint forces")
    print("(the equations' own multipliers, or the best least-squares fit). |h|, |c|: "
          "position- and velocity-level constraint")
    print("errors; |dE|: energy change (meaningful on conservative runs); proj: drift "
          "projections; cpu/s: CPU s per simulated s.")
