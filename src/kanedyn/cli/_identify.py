"""``kanedyn identify``: fit constants of a built-in model to measured records (CSV)."""

from __future__ import annotations

from .._errors import KanedynError
from .._progress import Progress
from ..models import build, options_adding
from ._options import (add_backend_argument, add_model_argument, derived_model, parse_sets,
                       positive_pairs, split_values)
from ._table import table

__all__ = ["add_parser", "cmd_identify"]


def _level(text):
    import argparse
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"a confidence level between 0 and 1 (0.95 for "
                                         f"95 %), got {text!r}")
    return value


def _segments(text):
    import argparse
    if text == "auto":
        return text
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"auto or a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"at least 1, got {value}")
    return value


def add_parser(sub):
    """Add the ``identify`` sub-command to ``sub``."""
    p = sub.add_parser(
        "identify", help="fit constants of a model to measured records (CSV)",
        description="Weighted least squares on the model's trajectories with the exact "
                    "Jacobian of its sensitivities (kd.identify). Each --data file is a "
                    "CSV record: a header naming a time column (t or time, [s] or [ms]) "
                    "and measured columns named after states (or a state's rate: "
                    "omega_dot); numbers only. The records start from the model's initial "
                    "state, changed with --set; the constants' values (also --set) are "
                    "the initial guesses. Prints the estimates with their standard errors "
                    "and confidence intervals; exit code 1 when the fit fails.")
    add_model_argument(p)
    p.add_argument("--data", action="append", metavar="FILE.csv", required=True,
                   help="a measured record (repeat for several)")
    p.add_argument("--fit", action="append", metavar="NAME", default=[],
                   help="a constant to fit (repeat for more)")
    p.add_argument("--initial", action="append", metavar="STATE", default=[],
                   help="a state whose initial value is fitted too, one per record")
    p.add_argument("--columns", metavar="A,B,...",
                   help="the columns of the files to fit (default: all but the time)")
    p.add_argument("--sigma", action="append", metavar="COLUMN=VALUE", default=[],
                   help="the noise's standard deviation of a column, when known "
                        "(default: estimated from the residuals)")
    p.add_argument("--level", type=_level, default=0.95,
                   help="confidence level of the intervals (default 0.95)")
    p.add_argument("--segments", type=_segments, default="auto",
                   help="1: single shooting; N: multiple shooting first; auto (default): "
                        "multiple shooting where the motion is unstable or chaotic")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option, constant (a guess, or a value held) or initial "
                        "value, e.g. m_p=0.12 or theta=0.1")
    add_backend_argument(p)
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_identify)


def cmd_identify(args):
    from ..optimization import MeasuredRecord, identify
    if not args.fit and not args.initial:
        raise KanedynError("nothing to fit: name constants with --fit (and/or states with "
                           "--initial)")
    options, values = parse_sets(args.model, args.set)
    sigma = positive_pairs(args.sigma, "--sigma", "column")
    columns = [c.strip() for c in args.columns.split(",")] if args.columns else None
    definition = build(args.model, **options)  # checks the options
    constants, initial = split_values(definition, values)
    const_names = {str(s) for s in definition.constants}
    unknown = [n for n in args.fit if n not in const_names]
    if unknown:
        adding = options_adding(args.model, unknown[0], options)
        hint = (f"; {unknown[0]} exists only with the model option "
                f"{' or '.join(adding)} (--set {adding[0]}=VALUE)" if adding else "")
        raise KanedynError(f"--fit {unknown[0]}: not a constant of {definition.name}; its "
                           f"constants: {', '.join(sorted(const_names))}{hint}")
    records = [MeasuredRecord.from_csv(path, columns=columns) for path in args.data]
    progress = Progress(enabled=not args.quiet)
    model = derived_model(definition, args.backend, constants, progress)
    y0 = definition.initial(model, initial)
    progress.stage("fitting (generating the derivatives on first use)")
    fit = identify(model, records, args.fit, initial=args.initial, y0=y0,
                   sigma=sigma or None, level=args.level, segments=args.segments)
    progress.done()
    samples = ", ".join(f"{rec.name}: {rec.t.size} samples of {', '.join(rec.channels)}"
                        for rec in records)
    print(f"{definition.name}: {fit.method}, {fit.iterations} evaluations; {samples}")
    print(fit.table())
    rows = [(name, f"{value:.4g}", "estimated" if name in fit.sigma_estimated else "given")
            for name, value in fit.sigma.items()]
    print(table(rows, ["channel", "noise std. dev.", "how"], title="noise"))
    if len(fit.names) > 1:
        rows = [[name] + [f"{c:+.3f}" for c in row]
                for name, row in zip(fit.names, fit.correlation)]
        print(table(rows, ["correlation"] + list(fit.names)))
    print(f"{'' if fit.success else 'FAILED: '}{fit.message}")
    return 0 if fit.success else 1
