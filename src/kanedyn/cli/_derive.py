"""``kanedyn derive``: derive a model and print its equations of motion."""

from __future__ import annotations

import time

from .._errors import KanedynError
from .._progress import Progress
from ..models import build
from ._options import add_model_argument, check_output_file, parse_sets

__all__ = ["add_parser", "cmd_derive"]


def add_parser(sub):
    """Add the ``derive`` sub-command to ``sub``."""
    p = sub.add_parser(
        "derive", help="derive and print a model's equations of motion",
        description="Derive a model and print, after a '#' header (title, operation "
                    "counts, states, constants), its equations as plain text in compact "
                    "form: the kinematic equations q' = ..., the intermediates z0, z1, "
                    "... each defined once, and the nonzero entries of mass_matrix and "
                    "forcing (mass_matrix * u' = forcing) in terms of them.")
    add_model_argument(p)
    p.add_argument("--latex", action="store_true",
                   help="print the same equations as LaTeX (an aligned block) instead of "
                        "plain text")
    p.add_argument("--explicit", action="store_true",
                   help="write every entry out in the model's symbols instead of the "
                        "compact form (long for large models)")
    p.add_argument("--c", metavar="FILE", default=None,
                   help="also write the model as a standalone C99 file (kanedyn_rhs, "
                        "kanedyn_constraints, kanedyn_energy; the header comment documents "
                        "the interface, states and parameters with their default values)")
    p.add_argument("--jacobians", action="store_true",
                   help="with --c: the file also holds kanedyn_jacobians, the exact "
                        "derivatives of the state derivative by the state and the inputs "
                        "(as model.jacobians)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option, e.g. n=8")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_derive)


def cmd_derive(args):
    options, values = parse_sets(args.model, args.set)
    if values:
        raise KanedynError("derive takes only model options with --set "
                           f"(got {', '.join(values)})")
    definition = build(args.model, **options)  # checks the options
    if args.c is not None:
        check_output_file(args.c, "--c")
    elif args.jacobians:
        raise KanedynError("--jacobians: the exact derivatives go into the C file of --c "
                           "FILE, which was not given")
    progress = Progress(enabled=not args.quiet)
    t0 = time.perf_counter()
    eom = definition.derive(progress=progress)
    elapsed = time.perf_counter() - t0
    written = None
    if args.c is not None:  # first: the file is there even if the printout is cut short
        written = definition.numeric(eom).export_c(args.c, title=f"{definition.name}: "
                                                   f"{definition.title}",
                                                   jacobians=args.jacobians)
    counts = eom.operation_counts()
    print(f"# {definition.title}")
    if written is not None:
        print(f"# wrote {written}")
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
        print(eom.to_text(explicit=args.explicit))
    return 0
