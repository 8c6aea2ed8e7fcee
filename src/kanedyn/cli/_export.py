"""``kanedyn export``: a built-in model as an FMI 2.0 or 3.0 FMU (model exchange and
co-simulation), compiled from its standalone C."""

from __future__ import annotations

from .._errors import KanedynError
from .._progress import Progress
from ..models import REGISTRY, build
from ._options import (check_output_file, parse_sets, positive_float, positive_pairs,
                       split_values)

__all__ = ["add_parser", "cmd_export"]


def add_parser(sub):
    """Add the ``export`` sub-command to ``sub``."""
    p = sub.add_parser(
        "export", help="write a model as an FMU (FMI 2.0 or 3.0, model exchange and "
                       "co-simulation)",
        description="Derive a model and write it as an FMI 2.0 or 3.0 FMU for model "
                    "exchange and co-simulation: the standalone C of its equations and the FMI "
                    "functions, compiled with the system C compiler (no Python needed to "
                    "run it), the sources included.  States are outputs, constants "
                    "parameters, specified inputs inputs; a model's contact events are "
                    "event indicators (model exchange) and handled inside the step "
                    "(co-simulation).")
    p.add_argument("model", choices=list(REGISTRY))
    p.add_argument("--fmu", metavar="FILE", required=True,
                   help="the FMU to write (a name ending in .fmu)")
    p.add_argument("--fmi-version", type=int, choices=(2, 3), default=2,
                   help="the FMI standard written: 2 (FMI 2.0, the default) or 3 (FMI 3.0)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option (n=4), parameter (m=2: its value in the FMU) or "
                        "initial value (q1=0.3: the state's start value)")
    p.add_argument("--nominal", action="append", metavar="STATE=VALUE", default=[],
                   help="a state's nominal value, its typical magnitude (importers scale "
                        "their absolute tolerance by it; default 1), e.g. eta_link_1=1e-3")
    p.add_argument("--t-end", type=positive_float, default=None,
                   help="stop time of the FMU's default experiment [s] (default: the "
                        "model's)")
    p.add_argument("--rtol", type=positive_float, default=1e-10,
                   help="relative tolerance of the co-simulation step (FMU parameter "
                        "kanedyn.rtol)")
    p.add_argument("--atol", type=positive_float, default=1e-10,
                   help="absolute tolerance of the co-simulation step (kanedyn.atol)")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_export)


def cmd_export(args):
    from ..io import export_fmu
    if not str(args.fmu).lower().endswith(".fmu"):  # before the derivation
        raise KanedynError(f"--fmu {args.fmu}: the file name must end in .fmu")
    options, values = parse_sets(args.model, args.set)
    definition = build(args.model, **options)  # checks the options
    check_output_file(args.fmu, "--fmu")
    constants, initial = split_values(definition, values)  # names checked before deriving
    nominals = positive_pairs(args.nominal, "--nominal", "state")
    unknown = sorted(set(nominals) - set(definition.state_names))
    if unknown:
        raise KanedynError(f"--nominal {unknown[0]}: not a state of {definition.name}; its "
                           f"states: {', '.join(definition.state_names)}")
    eom = definition.derive(progress=Progress(enabled=not args.quiet))
    model = definition.numeric(eom, constants=constants, backend="numpy")
    written = export_fmu(model, args.fmu, definition.initial(model, initial),
                         t_end=args.t_end or definition.t_end, rtol=args.rtol,
                         atol=args.atol, constant_units=definition.constant_units,
                         title=f"{definition.name}: {definition.title}",
                         fmi_version=args.fmi_version, nominals=nominals)
    contacts = f", {len(model.contacts)} contacts" if model.contacts else ""
    print(f"wrote {written} (FMI {args.fmi_version}.0; {model.n_states} states, "
          f"{len(model.constants)} parameters, {len(model.input_names)} inputs{contacts})")
    return 0
