"""``kanedyn sweep``: a built-in model over a parameter grid or random samples, on Dask.

::

    kanedyn sweep pendulum --grid l=0.5:2:7 --grid q=0.1,0.2 --out sweep-out
    kanedyn sweep chain3d --set n=5 --random g=9:10 --samples 100 --seed 1 --out s2 \\
        --backend c --workers 2 --run-timeout 60
"""

from __future__ import annotations

import math
import shlex
import sys


from .._errors import KanedynError
from .._number_text import parse_number
from ..models import build
from ._options import (add_backend_argument, add_model_argument, check_output_dir, numeric_model,
                       parse_sets, positive_float, split_values)

__all__ = ["add_parser", "cmd_sweep", "parse_grid", "parse_range"]


def add_parser(sub):
    """Add the ``sweep`` sub-command to ``sub``."""
    p = sub.add_parser("sweep", help="simulate a model over a parameter grid or random "
                                     "samples (Dask), one table row per run")
    add_model_argument(p)
    p.add_argument("--grid", action="append", metavar="NAME=VALUES",
                   help="grid values: start:stop:count or a comma list (m=1:2:11, l=0.5,1)")
    p.add_argument("--random", action="append", metavar="NAME=LOW:HIGH",
                   help="uniform random samples between LOW and HIGH")
    p.add_argument("--samples", type=int, default=None, help="number of random samples")
    p.add_argument("--seed", type=int, default=None, help="seed of the random samples")
    p.add_argument("--out", required=True, help="output folder (parts, results, resume)")
    p.add_argument("--scheduler", default=None,
                   help="Dask scheduler address (tcp://host:8786), or 'serial' (no Dask); "
                        "default: a local cluster")
    p.add_argument("--workers", type=int, default=2, help="local cluster worker processes")
    p.add_argument("--run-timeout", type=positive_float, default=None, metavar="SECONDS",
                   help="time limit of each run: a run stopped there is a failed row "
                        "(default: none)")
    p.add_argument("--t-end", type=positive_float, default=None,
                   help="end time of each run [s]")
    add_backend_argument(p)
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option (n=4), fixed parameter (m=2) or initial value")
    p.add_argument("--outputs", default="final,max,min,nfev,wall_time",
                   help="comma list of: final, max, min, events, energy, nfev, wall_time, "
                        "t_end")
    p.add_argument("--method", default="RK45", help="solve_ivp method")
    p.add_argument("--rtol", type=positive_float, default=1e-8, help="relative tolerance")
    p.add_argument("--atol", type=positive_float, default=1e-8, help="absolute tolerance")
    p.add_argument("--batch-size", type=int, default=None, help="runs per Dask task")
    p.add_argument("--csv", action="store_true", help="write results.csv, not .parquet")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)


def parse_grid(text, what):
    """Values of ``start:stop:count`` or ``a,b,c`` (numbers, never evaluated as code)."""
    import numpy as np
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise KanedynError(f"{what}: expected start:stop:count, got {text!r}")
        start, stop = (_finite(parse_number(p, what), what) for p in parts[:2])
        try:
            count = int(parts[2])
        except ValueError:
            raise KanedynError(f"{what}: the count in {text!r} must be a whole number") \
                from None
        if count < 1:
            raise KanedynError(f"{what}: the count in {text!r} must be at least 1")
        return np.linspace(start, stop, count)
    items = [s for s in text.split(",")]
    if not all(s.strip() for s in items):
        raise KanedynError(f"{what}: an empty value in {text!r}")
    return np.array([_finite(parse_number(s, what), what) for s in items])


def parse_range(text, what):
    """``low:high`` of uniform random samples."""
    parts = text.split(":")
    if len(parts) != 2:
        raise KanedynError(f"{what}: expected low:high, got {text!r}")
    low, high = (_finite(parse_number(p, what), what) for p in parts)
    if not low < high:
        raise KanedynError(f"{what}: low must be below high in {text!r}")
    return (low, high)


def _finite(value, what):
    if not math.isfinite(value):
        raise KanedynError(f"{what}: values must be finite")
    return value


def _pairs(items, flag, parse):
    out = {}
    for item in items or ():
        if "=" not in item:
            raise KanedynError(f"{flag} expects NAME=VALUES, got {item!r}")
        name, text = (s.strip() for s in item.split("=", 1))
        if name in out:
            raise KanedynError(f"{flag} {name} is given twice")
        out[name] = parse(text, f"{flag} {name}")
    return out


def _check(args):
    """Arguments checked before anything is derived."""
    if not args.grid and not args.random:
        raise KanedynError("give at least one --grid or --random parameter")
    if args.grid and args.random:
        raise KanedynError("give either --grid or --random parameters, not both")
    if args.random and (args.samples is None or args.samples < 1):
        raise KanedynError("--random needs --samples N (N >= 1)")
    if args.samples is not None and not args.random:
        raise KanedynError("--samples needs --random parameters")
    if args.workers < 1:
        raise KanedynError(f"--workers must be at least 1, got {args.workers}")
    if args.batch_size is not None and args.batch_size < 1:
        raise KanedynError(f"--batch-size must be at least 1, got {args.batch_size}")
    check_output_dir(args.out)
    if args.scheduler is not None:  # an address that answers as a Dask scheduler
        from ..simulation import check_scheduler
        args.scheduler = check_scheduler(args.scheduler)


def cmd_sweep(args):
    from ..simulation import SWEEP_OUTPUTS, SweepInterrupted, sweep
    _check(args)
    outputs = [s.strip() for s in args.outputs.split(",") if s.strip()]
    bad = [o for o in outputs if o not in SWEEP_OUTPUTS]
    if bad:
        raise KanedynError(f"--outputs: unknown {', '.join(bad)}; available: "
                           f"{', '.join(SWEEP_OUTPUTS)}")
    grid = _pairs(args.grid, "--grid", parse_grid)
    random = _pairs(args.random, "--random", parse_range)
    options, values = parse_sets(args.model, args.set)
    definition = build(args.model, **options)  # checks the options
    constants, initial = split_values(definition, values)
    known = {str(s) for s in definition.constants} | set(definition.state_names)
    for flag, names in (("--grid", grid), ("--random", random)):
        unknown = [name for name in names if name not in known]
        if unknown:
            raise KanedynError(f"{flag} {unknown[0]}: not a parameter or state of "
                               f"{definition.name}; parameters: "
                               f"{', '.join(sorted(map(str, definition.constants))) or 'none'}"
                               f"; states: {', '.join(definition.state_names)}")
    eom = definition.derive()
    model = numeric_model(definition, eom, args.backend, constants)
    y0 = definition.initial(model, initial)
    if model.n_q_dep + model.n_u_dep:
        y0 = model.consistent_state(0.0, y0)
    t_end = args.t_end if args.t_end is not None else definition.t_end
    try:
        table = sweep(model, grid or random, y0, (0.0, t_end), outputs=outputs,
                      n=args.samples if random else None, seed=args.seed, out=args.out,
                      table_format="csv" if args.csv else "parquet",
                      scheduler=args.scheduler, n_workers=args.workers,
                      batch_size=args.batch_size, progress=not args.quiet,
                      timeout=args.run_timeout, method=args.method, rtol=args.rtol,
                      atol=args.atol)
    except SweepInterrupted as stop:
        print(f"kanedyn: sweep interrupted: {len(stop.table)} of {stop.total} runs saved in "
              f"{stop.out}; run the same command again (with --out {shlex.quote(str(stop.out))}"
              ") to finish it: the saved runs are skipped", file=sys.stderr)
        return 130
    failed = int((~table["success"].astype(bool)).sum())
    name = "results.csv" if args.csv else "results.parquet"
    print(f"{len(table)} runs, {failed} failed; wrote {args.out}/{name}")
    return 0 if failed == 0 else 1
