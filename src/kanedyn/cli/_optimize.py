"""``kanedyn optimize``: a named optimal-control problem on a built-in model.

::

    kanedyn optimize                              # the models and their problems
    kanedyn optimize pendulum --nodes 401 --bound tau=-1.5:1.5 --plot swing.png
    kanedyn optimize flexible-robot --problem minimum-time --set n_modes=2
    kanedyn optimize whipple-bicycle --set offset=2 --duration 3 --output lane.csv
    kanedyn optimize pendulum --method lgr --degree 4 --nodes 41
    kanedyn optimize pendulum --hessian exact
    kanedyn optimize pendulum --solver interior-point
    kanedyn optimize pendulum --solver interior-point --hessian limited-memory

The problem is posed, solved by IPOPT (or kanedyn's own interior-point
solver, ``--solver interior-point``, with the exact Hessian unless
``--hessian limited-memory``) and checked by
simulation (each problem says how); the summary is printed.  Exit code 0
when the solver solved it, 1 when it did not (the last iterate is still
written), 2 for bad input.
"""

from __future__ import annotations

import math

from .._errors import KanedynError
from .._number_text import parse_number
from .._progress import Progress
from ._options import BACKENDS, check_output_file, parse_sets, positive_float, whole_number

__all__ = ["add_parser", "cmd_optimize"]


def add_parser(sub):
    """Add the ``optimize`` sub-command to ``sub``."""
    p = sub.add_parser(
        "optimize", help="solve a named optimal-control problem on a built-in model; "
                         "without MODEL, list them",
        description="Direct collocation with the exact sparse Jacobian, solved by IPOPT "
                    "(the optimal extra: pip install 'kanedyn[optimal]') or kanedyn's own "
                    "interior-point solver (--solver interior-point), then checked by "
                    "simulating the optimal inputs. Exit code 1 when the solver does not "
                    "solve the problem (what it reached is still written).")
    p.add_argument("model", nargs="?", default=None,
                   help="a built-in model with named problems (kanedyn optimize lists them)")
    p.add_argument("--problem", default=None,
                   help="the model's problem (default: its first)")
    p.add_argument("--nodes", type=whole_number(2, "nodes"), default=None,
                   help="collocation nodes (default: the problem's)")
    p.add_argument("--method", default=None,
                   help="collocation: trapezoid, backward-euler, midpoint, hermite-simpson, "
                        "lgr (default: the problem's)")
    p.add_argument("--degree", type=whole_number(1, "point per interval"), default=None,
                   help="with --method lgr: the Legendre-Gauss-Radau points per interval "
                        "(default 3; order 2 degree - 1)")
    p.add_argument("--duration", type=positive_float, default=None,
                   help="duration [s] (a free duration's guess; default: the problem's)")
    p.add_argument("--bound", action="append", metavar="NAME=LOW:HIGH", default=[],
                   help="bounds of a state or input at every point, e.g. tau=-1.5:1.5 "
                        "(a side left empty is unbounded: tau=:2); replaces the problem's")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option (n_modes=2), constant (m_p=0.2) or option of the "
                        "problem (offset=2)")
    p.add_argument("--backend", choices=BACKENDS, default="auto",
                   help="numerical backend: auto (default: c when a C compiler is found), "
                        "numpy or c")
    p.add_argument("--solver", choices=("ipopt", "interior-point"), default="ipopt",
                   help="the NLP solver: IPOPT (default) or kanedyn's own interior-point "
                        "method (no extra needed)")
    p.add_argument("--tol", type=positive_float, default=None,
                   help="the solver's tolerance (default 1e-8)")
    p.add_argument("--max-iter", type=whole_number(1, "iteration"), default=None,
                   help="the solver's iteration limit (default 3000)")
    p.add_argument("--hessian", choices=("limited-memory", "exact"), default=None,
                   help="the Hessian of the Lagrangian: the limited-memory (BFGS) "
                        "approximation (IPOPT's default) or the exact one from the model's "
                        "second derivatives (the interior-point solver's default; refused, "
                        "with the reason, for models with constraints or contacts)")
    p.add_argument("--plot", default=None, metavar="FILE",
                   help="write the problem's figure (PNG)")
    p.add_argument("--output", default=None, metavar="CSV",
                   help="write the collocated trajectory: t, point (node or midpoint), "
                        "states, inputs")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_optimize)


def _bounds(items):
    out = {}
    for item in items:
        if "=" not in item or ":" not in item.split("=", 1)[1]:
            raise KanedynError(f"--bound {item!r}: expected NAME=LOW:HIGH (a side may be "
                               "empty)")
        name, pair = (s.strip() for s in item.split("=", 1))
        low, high = (s.strip() for s in pair.split(":", 1))
        values = []
        for text, side in ((low, "lower"), (high, "upper")):
            if not text:
                values.append(None)
                continue
            value = parse_number(text, f"--bound {name} ({side})")
            if math.isnan(value):
                raise KanedynError(f"--bound {name}: the {side} bound is nan")
            values.append(None if math.isinf(value) else value)
        if values[0] is not None and values[1] is not None and values[0] > values[1]:
            raise KanedynError(f"--bound {name}: the lower bound {values[0]:g} is above the "
                               f"upper bound {values[1]:g}")
        out[name] = tuple(values)
    return out


def _text_options(problem, pairs):
    """``--set`` pairs split into the problem's text options ``{name: text}``
    (their choices checked by ``study_option_value``) and the other pairs
    (model options, constants, the problem's numeric options)."""
    texts, rest = {}, []
    for pair in pairs or ():
        key = pair.split("=", 1)[0].strip()
        option = problem.options.get(key)
        if "=" in pair and option is not None and option.type is str:
            texts[key] = pair.split("=", 1)[1].strip()
        else:
            rest.append(pair)
    return texts, rest


def _list(problems):
    for model, named in problems.items():
        print(f"{model}:")
        for name, problem in named.items():
            print(f"  {name}: {problem.description}")
            print(f"      defaults: {problem.nodes} nodes, {problem.method}, "
                  f"{problem.duration:g} s")
            for key, opt in problem.options.items():
                print(f"      {key}={opt.default!r}  {opt.help}")


def cmd_optimize(args):
    """List the problems, or solve one; the exit code (1: the solver did not solve it)."""
    from ..analysis import available_problems, optimal_problem
    from ..analysis import study_option_value
    from ..optimization import COLLOCATION_METHODS, SOLVERS
    problems = available_problems()
    if args.model is None:
        _list(problems)
        return 0
    missing = SOLVERS[args.solver].available()
    if missing:
        raise KanedynError(missing)
    problem = optimal_problem(args.model, args.problem)
    if args.method is not None and args.method not in COLLOCATION_METHODS:
        raise KanedynError(f"--method {args.method!r}: available "
                           f"{', '.join(COLLOCATION_METHODS)}")
    if args.degree is not None and (args.method or problem.method) != "lgr":
        raise KanedynError(f"--degree is for --method lgr (the problem's method is "
                           f"{args.method or problem.method})")
    texts, numeric = _text_options(problem, args.set)
    model_options, values = parse_sets(args.model, numeric)
    values.update(texts)  # the problem's text options (booms=flexible), as written
    options, constants = {}, {}
    if args.degree is not None:  # only then: a problem may predate LGR's degree
        options["degree"] = args.degree
    names = None
    for key, value in values.items():
        if key in problem.options:
            options[key] = study_option_value(f"{args.model} {problem.name}", key,
                                              problem.options[key], value)
            continue
        if names is None:  # the model's constants, with the options asked for
            from ..models import build
            definition = build(args.model, **{**model_options, **problem.required})
            names = sorted(str(c) for c in definition.constants)
        if key not in names:
            raise KanedynError(f"--set {key}: not an option or constant of {args.model}, nor "
                               f"an option of its problem {problem.name}; constants: "
                               f"{', '.join(names)}; problem options: "
                               f"{', '.join(problem.options) or 'none'}")
        constants[key] = value
    bounds = _bounds(args.bound)
    plot = check_output_file(args.plot, "--plot") if args.plot else None
    output = check_output_file(args.output, "--output") if args.output else None
    ipopt = {}
    if args.tol is not None:
        ipopt["tol"] = args.tol
    if args.max_iter is not None:
        ipopt["max_iter"] = args.max_iter
    if args.hessian is not None:
        ipopt["hessian_approximation"] = args.hessian
    if args.solver != "ipopt":
        ipopt["solver"] = args.solver
    progress = Progress(enabled=not args.quiet)
    progress.stage(f"{args.model} {problem.name}: building the model and its derivatives, "
                   "solving, checking by simulation")
    found = problem.function(nodes=args.nodes, method=args.method, duration=args.duration,
                             bounds=bounds, constants=constants, model_options=model_options,
                             backend=args.backend, ipopt=ipopt, **options)
    progress.done()
    print(f"{args.model} {problem.name}")
    print(found.summary)
    if output is not None:
        print(f"wrote {found.result.to_csv(output)}")
    if plot is not None:
        print(f"wrote {found.plot(plot)}")
    return 0 if found.result.success else 1
