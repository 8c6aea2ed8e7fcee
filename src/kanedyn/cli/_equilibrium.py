"""``kanedyn equilibrium``: a built-in model's static equilibrium or steady motion,
and its stability."""

from __future__ import annotations

import numpy as np

from .._errors import KanedynError
from .._progress import Progress
from ..models import build
from ._options import (add_backend_argument, add_model_argument, derived_model, parse_sets,
                       split_values)
from ._table import table

__all__ = ["add_parser", "cmd_equilibrium"]


def add_parser(sub):
    """Add the ``equilibrium`` sub-command to ``sub``."""
    p = sub.add_parser(
        "equilibrium", help="find a static equilibrium or steady motion and its stability",
        description="Newton's method on the exact derivatives from the model's initial "
                    "state (or the values given with --set): every acceleration, the "
                    "rate of every coordinate not --moving and every constraint residual "
                    "vanish, the --hold states keep their values. Prints the state found "
                    "and the eigenvalues of the linearization there (frequency, damping "
                    "ratio); exit code 1 when Newton's method does not converge.")
    add_model_argument(p)
    p.add_argument("--hold", action="append", metavar="STATE", default=[],
                   help="a state kept at its value: a speed of a steady motion, or a "
                        "coordinate nothing restores (repeat for more)")
    p.add_argument("--moving", action="append", metavar="COORDINATE", default=[],
                   help="a coordinate that may change at a constant rate: a heading, a "
                        "wheel angle (repeat for more)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option, parameter or starting value, e.g. g=9.81 or q1=0.3")
    add_backend_argument(p)
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_equilibrium)


def cmd_equilibrium(args):
    from ..numerics import equilibrium
    options, values = parse_sets(args.model, args.set)
    definition = build(args.model, **options)  # checks the options
    constants, initial = split_values(definition, values)
    for option, names in (("--hold", args.hold), ("--moving", args.moving)):
        unknown = [n for n in names if n not in definition.state_names]
        if unknown:
            raise KanedynError(f"{option} {unknown[0]}: not a state of {definition.name}; "
                               f"states: {', '.join(definition.state_names)}")
    progress = Progress(enabled=not args.quiet)
    model = derived_model(definition, args.backend, constants, progress)
    y0 = definition.initial(model, initial)
    progress.stage("solving (generating the derivatives on first use)")
    found = equilibrium(model, y0, hold=args.hold, moving=args.moving)
    progress.done()
    print(f"{definition.name}: {'converged' if found.converged else 'NOT converged'} in "
          f"{found.iterations} Newton steps, largest residual {found.residual:.2g}"
          + ("" if found.converged else f" ({found.message})"))
    print(table([(name, value) for name, value in zip(found.state_names, found.y)],
                ["state", "value (SI)"], floatfmt=".10g"))
    if found.converged:
        rows = [(f"{ev.real:.6g}", f"{ev.imag:.6g}", f"{f:.6g}",
                 "" if np.isnan(z) else f"{z:.4g}")
                for ev, f, z in zip(found.eigenvalues, found.frequencies,
                                    found.damping_ratios)]
        print(table(rows, ["Re, 1/s", "Im, 1/s", "frequency, Hz", "damping ratio"],
                    title=f"eigenvalues of the linearization: "
                          f"{'stable' if found.stable else 'UNSTABLE'}"))
    return 0 if found.converged else 1
