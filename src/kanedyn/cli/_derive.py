"""``kanedyn derive``: derive a model and print its equations of motion."""

from __future__ import annotations

import time

import sympy as sm

from .._errors import KanedynError
from .._progress import Progress
from ..engine import name_of
from ..models import REGISTRY, build
from ._options import parse_sets

__all__ = ["add_parser", "cmd_derive"]


def add_parser(sub):
    """Add the ``derive`` sub-command to ``sub``."""
    p = sub.add_parser("derive", help="derive and print a model's equations of motion")
    p.add_argument("model", choices=list(REGISTRY))
    p.add_argument("--latex", action="store_true", help="print LaTeX")
    p.add_argument("--explicit", action="store_true",
                   help="explicit expressions even for large models")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option, e.g. n=8")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_derive)


def cmd_derive(args):
    options, values = parse_sets(args.model, args.set)
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
