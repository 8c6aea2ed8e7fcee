"""``kanedyn inverse``: actuator forces of a parallel model along a prescribed motion."""

from __future__ import annotations

from .._errors import KanedynError
from .._progress import Progress
from ..analysis import TRAJECTORIES, inverse_study, parallel_actuators
from ..models import REGISTRY, build
from ._options import (add_backend_argument, check_output_dir, parse_sets, point_count,
                       positive_float)

__all__ = ["add_parser", "cmd_inverse"]


def add_parser(sub):
    """Add the ``inverse`` sub-command to ``sub``."""
    p = sub.add_parser("inverse", help="actuator forces along a prescribed platform motion: "
                                       "CSV, plots, power balance")
    p.add_argument("model", choices=list(REGISTRY))
    p.add_argument("--trajectory", choices=TRAJECTORIES, default="quintic",
                   help="quintic (rest to rest to a pose 5 cm and 10 deg away, default) or "
                        "sinusoid (every pose axis)")
    p.add_argument("--t-end", type=positive_float, default=None,
                   help="length of the manoeuvre [s] (default: the model's)")
    p.add_argument("--points", type=point_count, default=201,
                   help="trajectory points (at least 2)")
    p.add_argument("--out", default="kanedyn-out", help="output directory")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option (gravity=true) or parameter (m_p=12)")
    p.add_argument("--forward-check", action="store_true",
                   help="also integrate the forward model driven by the computed forces "
                        "and print its largest platform-pose error")
    add_backend_argument(p)
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_inverse)


def cmd_inverse(args):
    options, values = parse_sets(args.model, args.set)
    definition = build(args.model, **options)
    if not parallel_actuators(definition) or not definition.symbols.get("pose"):
        raise KanedynError(f"model {args.model} has no actuators and platform trajectory; "
                           "kanedyn inverse takes a parallel model (3rrr, stewart-platform)")
    names = {str(s) for s in definition.constants}
    unknown = sorted(set(values) - names)
    if unknown:
        raise KanedynError(f"--set {unknown[0]}: not an option or parameter of "
                           f"{definition.name}; parameters: {', '.join(sorted(names))}")
    out = check_output_dir(args.out)
    progress = Progress(enabled=not args.quiet)
    progress.stage(f"deriving {definition.title}")
    eom = definition.derive(progress=progress)
    progress.stage(f"inverse dynamics along the {args.trajectory} trajectory "
                   f"({args.points} points)")
    study = inverse_study(definition, trajectory=args.trajectory, t_end=args.t_end,
                          points=args.points, backend=args.backend, constants=values,
                          eom=eom)
    paths = study.to_csv(out) + study.plot(out)
    progress.stage("wrote " + ", ".join(str(p) for p in paths))
    _print_table(study)
    if args.forward_check:
        progress.stage("forward dynamics driven by the computed forces (DOP853, "
                       "rtol = atol = 1e-11)")
        check = study.forward_check()
        print(f"forward check: largest platform-pose error {check.max_error:.3e} (m, rad) "
              f"over {check.t[-1] if check.t.size else 0:g} s; {check.message}")
        if not check.success:
            return 1
    return 0


def _print_table(study):
    print(f"{study.model_name}, {study.trajectory} trajectory, {study.t[-1]:g} s, "
          f"{study.t.size} points")
    width = max(len(n) for n in study.names)
    print(f"{'actuator':<{width}}  {'peak |force|':>14}  {'at t [s]':>8}")
    for name, unit, f in zip(study.names, study.units, study.forces):
        i = int(abs(f).argmax())
        print(f"{name:<{width}}  {abs(f[i]):>10.4g} {unit:<3}  {study.t[i]:>8.4g}")
    print(f"power-balance residual: {study.power_residual:.3e} of the peak actuator power "
          f"({abs(study.power.actuator).max():.4g} W)")
    print(f"largest actuator-Jacobian condition number: {study.condition.max():.4g}")
