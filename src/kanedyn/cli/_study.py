"""``kanedyn study``: run a registered study (tables as CSV, figures as PNG, a summary).

::

    kanedyn study                       # list the studies and their options
    kanedyn study oc3-rao --set n_periods=10 --set check_periods= --out rao-out
"""

from __future__ import annotations

from .._errors import KanedynError
from ._options import check_output_dir

__all__ = ["add_parser", "cmd_study"]


def add_parser(sub):
    """Add the ``study`` sub-command to ``sub``."""
    p = sub.add_parser("study", help="run a study (tables, figures, summary); without a "
                                     "name, list the studies")
    p.add_argument("name", nargs="?", default=None, help="study name (see kanedyn study)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="study option (n_periods=10)")
    p.add_argument("--out", default=None, help="output folder for CSV tables and PNG figures")
    p.add_argument("--quiet", action="store_true", help="no progress text")
    p.set_defaults(func=cmd_study)


def _parse(items):
    values = {}
    for item in items or ():
        if "=" not in item:
            raise KanedynError(f"--set {item!r}: expected NAME=VALUE")
        key, value = item.split("=", 1)
        key = key.strip()
        if not key:
            raise KanedynError(f"--set {item!r}: the name is empty")
        values[key] = value.strip()
    return values


def cmd_study(args):
    """List the studies, or run one and print its tables' files and summary."""
    from ..analysis import available_studies, run_study  # the studies import SciPy, SymPy

    STUDIES = available_studies()
    if args.name is None:
        for name in sorted(STUDIES):
            study = STUDIES[name]
            print(f"{name}: {study.description}")
            for key, opt in study.options.items():
                choices = f" ({'|'.join(opt.choices)})" if opt.choices else ""
                print(f"    {key}={opt.default!r}{choices}  {opt.help}")
        return 0
    if args.name not in STUDIES:
        raise KanedynError(f"unknown study {args.name!r}; studies: {', '.join(sorted(STUDIES))}")
    options = _parse(args.set)
    if args.out is not None:
        check_output_dir(args.out)
    result = run_study(args.name, out=args.out, quiet=args.quiet, **options)
    print(result.summary)
    for path in (*result.csv_files, *result.figures):
        print(f"wrote {path}")
    return 0
