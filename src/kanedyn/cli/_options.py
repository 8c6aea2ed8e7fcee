"""Values given on the command line: model options, parameters, initial values.

Nothing given on the command line is evaluated as code.
"""

from __future__ import annotations

import numpy as np

from .._errors import KanedynError
from .._number_text import parse_number
from ..models import REGISTRY

__all__ = ["parse_sets", "split_values"]


def parse_sets(model_name, pairs):
    """Split ``name=value`` pairs into model options, constants and initial values."""
    _, option_types = REGISTRY[model_name]
    options, rest = {}, {}
    for pair in pairs or ():
        if "=" not in pair:
            raise KanedynError(f"--set expects name=value, got {pair!r}")
        key, value = (s.strip() for s in pair.split("=", 1))
        if key in option_types:
            options[key] = _option_value(model_name, key, option_types[key], value)
        else:
            rest[key] = _finite(parse_number(value, f"--set {key}"), key, value)
    return options, rest


def _finite(number, key, text):
    if not np.isfinite(number):
        raise KanedynError(f"--set {key}: {text!r} is not a finite number")
    return number


def _option_value(model_name, key, kind, text):
    """A model option from its text (never evaluated as code)."""
    what = f"option {key} of {model_name}"
    if kind is bool:
        if text.lower() not in ("true", "false", "1", "0", "yes", "no"):
            raise KanedynError(f"{what} is true or false, got {text!r}")
        return text.lower() in ("true", "1", "yes")
    if kind is int:
        try:
            return int(text)
        except ValueError:
            raise KanedynError(f"{what} is a whole number, got {text!r}") from None
    if kind is float:
        return _finite(parse_number(text, what), key, text)
    return text


def split_values(definition, model, values):
    constants, initial = {}, {}
    const_names = {str(s) for s in definition.constants}
    for key, value in values.items():
        if key in const_names:
            constants[key] = value
        elif key in model.state_names:
            initial[key] = value
        else:
            raise KanedynError(
                f"--set {key}: not an option, parameter or state of {definition.name}; "
                f"parameters: {', '.join(sorted(const_names))}; states: "
                f"{', '.join(model.state_names)}")
    return constants, initial
