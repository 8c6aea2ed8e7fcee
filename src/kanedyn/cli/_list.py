"""``kanedyn list [MODEL]``: the built-in models, or one model's options,
parameters and states."""

from __future__ import annotations

import inspect

from .._errors import KanedynError
from ..models import OPTION_UNITS, REGISTRY, build, unknown_model_text
from ._table import table

__all__ = ["add_parser", "cmd_list", "WIDTH"]

#: the columns ``kanedyn list`` fits in
WIDTH = 100


def add_parser(sub):
    """Add the ``list`` sub-command to ``sub``."""
    p = sub.add_parser(
        "list", help="list the built-in models, or one model's options, parameters "
                     "and states",
        description="Without MODEL: every built-in model with its title (fits "
                    f"{WIDTH} columns). "
                    "With MODEL: its options with their defaults, its parameters "
                    "(constants) with their default values and units, and its states "
                    "with their initial values (the model is derived to list them).")
    p.add_argument("model", nargs="?", default=None,
                   help="a built-in model (kanedyn list shows them)")
    p.set_defaults(func=cmd_list)


def cmd_list(args):
    if args.model is None:
        names = max(len(name) for name in REGISTRY)
        rows = [(name, builder.title) for name, (builder, _) in REGISTRY.items()]
        # two spaces between the columns
        print(table(rows, ("model", "description"),
                    widths=(None, WIDTH - names - 2)))
        print("\noptions, parameters and states of a model: kanedyn list MODEL")
        return 0
    if args.model not in REGISTRY:
        raise KanedynError(f"list: {unknown_model_text(args.model)} (kanedyn list shows "
                           "the models)")
    _describe(args.model)
    return 0


def option_defaults(name):
    """``[(option, type name, default, unit)]`` of a built-in model (from its builder;
    the unit ``""`` where the option has none)."""
    builder, options = REGISTRY[name]
    signature = inspect.signature(builder)
    units = OPTION_UNITS.get(name, {})
    return [(key, kind.__name__, signature.parameters[key].default, units.get(key, ""))
            for key, kind in options.items()]


def _describe(name):
    from ..engine import name_of
    definition = build(name)
    print(f"{name}: {definition.title}")
    options = option_defaults(name)
    print()
    if options:
        print(table(options, ("option", "type", "default", "unit"),
                    title="options (--set NAME=VALUE)"))
    else:
        print("options: none")
    units = {str(k): v for k, v in definition.constant_units.items()}
    parameters = [(key, value, units.get(key, "SI")) for key, value
                  in definition.parameter_table()]
    print()
    if parameters:
        print(table(parameters, ("parameter", "default", "unit"),
                    title="parameters (--set NAME=VALUE)"))
    else:
        print("parameters: none")
    eom = definition.derive()
    given = {name_of(k) if not isinstance(k, str) else k: v
             for k, v in definition.initial_state.items()}
    dependent = {name_of(s) for s in (*eom.q_dep, *eom.u_dep)}
    units = eom.state_units
    rows = [(state, float(given.get(state, 0.0)), units.get(state) or "?")
            for state in eom.state_names]
    header = ("state", "initial value", "unit")
    if dependent:
        note = "dependent: completed from the constraints"
        rows = [row + (note if row[0] in dependent else "",) for row in rows]
        header += ("note",)
    print()
    print(table(rows, header, title="states (--set NAME=VALUE)"))
    if definition.specified:
        inputs = [(name_of(k), str(v) if not callable(v) else "a function of (t, y)")
                  for k, v in definition.specified.items()]
        print()
        print(table(inputs, ("specified input", "value"), title="specified inputs"))
    if definition.actuators:
        rows = [(a.name, a.kind, _transmission(a.transmission))
                for a in definition.actuators]
        print()
        print(table(rows, ("actuator", "kind", "transmission"), title="actuators"))
    if definition.body_groups:
        rows = [(group, ", ".join(names)) for group, names in definition.body_groups.items()]
        print()
        print(table(rows, ("body group", "bodies"), title="body groups"))


def _transmission(screw):
    if screw is None:
        return "none"
    try:
        lead, rotating = float(screw.lead), float(screw.rotating_inertia)
        reflected = float(screw.reflected_inertia)
    except TypeError:                       # symbolic: shown as given
        return f"ball screw, lead {screw.lead}, J = {screw.rotating_inertia}"
    return (f"ball screw, lead {lead:.6g} m, J_rotor + J_coupler + J_screw = {rotating:.6g} "
            f"kg m^2 (reflected {reflected:.6g} kg)")
