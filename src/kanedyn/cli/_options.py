"""Values given on the command line: model options, parameters, initial values.

Also the argument types and options shared by several commands (``--backend``,
positive finite numbers, point counts, integrator names, output folders), so
that every bad argument ends in one line on stderr and exit code 2 before any
derivation or simulation starts.  Nothing given on the command line is
evaluated as code.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from pathlib import Path

from .._errors import KanedynError
from .._number_text import parse_number
from ..models import REGISTRY, unknown_model_text

__all__ = ["parse_sets", "split_values", "BACKENDS", "add_backend_argument", "model_name",
           "add_model_argument", "derived_model",
           "numeric_model", "positive_float", "point_count", "whole_number", "integrator_name",
           "check_output_dir", "check_output_file"]

#: numerical backends the commands offer (``--backend``)
BACKENDS = ("auto", "numpy", "c")


def add_backend_argument(parser, auto="c when a C compiler is found, else numpy"):
    """Add ``--backend {auto,numpy,c}`` (default ``auto``, meaning ``auto``) to
    ``parser``."""
    parser.add_argument("--backend", choices=BACKENDS, default="auto",
                        help=f"numerical backend: auto (default: {auto}), numpy, or c "
                             "(generated C, compiled with the system compiler and cached)")


def derived_model(definition, backend, constants, progress):
    """:func:`numeric_model` of ``definition`` derived now, each stage said by
    ``progress`` (a :class:`~kanedyn._progress.Progress`)."""
    progress.stage(f"deriving {definition.title}")
    eom = definition.derive(progress=progress)
    return numeric_model(definition, eom, backend, constants,
                         note=lambda text: progress.stage(text))


def numeric_model(definition, eom, backend, constants=None, note=print):
    """The numerical model of ``definition`` on the ``--backend`` chosen.

    ``auto`` is c when a C compiler is found (the compiler is looked for here,
    after the arguments are parsed) and numpy otherwise; a model the C backend
    cannot generate or compile runs on numpy, with ``note(text)`` saying why.
    An explicit ``c`` without a compiler is an error naming the option.
    """
    from .._errors import ModelError
    from ..numerics.backends import (CodegenError, CompilerError, compiler_command,
                                     missing_compiler_text)
    if backend == "c" and compiler_command() is None:
        raise KanedynError(f"--backend c: {missing_compiler_text()}; use --backend numpy "
                           "(or auto)")
    if backend == "auto":
        if compiler_command() is None:
            note(f"backend: numpy ({missing_compiler_text()})")
            backend = "numpy"
        else:
            try:
                return definition.numeric(eom, constants=constants, backend="c")
            except (CodegenError, CompilerError, ModelError) as exc:
                # numpy where C cannot; a model error of any backend is raised again
                model = definition.numeric(eom, constants=constants, backend="numpy")
                note(f"backend: numpy (the C backend cannot build this model: {exc})")
                return model
    return definition.numeric(eom, constants=constants, backend=backend)


def model_name(text):
    """``type=`` of a built-in model's name: refused with the names it may stand
    for (``bicycle``: did you mean whipple-bicycle?)."""
    if text in REGISTRY:
        return text
    raise argparse.ArgumentTypeError(f"{unknown_model_text(text)} (kanedyn list shows "
                                     "the models)")


def add_model_argument(parser):
    """Add the positional ``MODEL`` (a built-in model's name) to ``parser``."""
    parser.add_argument("model", type=model_name, metavar="MODEL",
                        help="a built-in model (kanedyn list shows them)")


def positive_float(text):
    """``type=`` of arguments that are finite numbers > 0 (times, tolerances)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def whole_number(least, what):
    """``type=`` of an option that takes a whole number of ``what``, at least
    ``least``."""
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") \
                from None
        if value < least:
            raise argparse.ArgumentTypeError(f"needs at least {least} {what}, got {value}")
        return value
    return parse


#: ``type=`` of ``--points``: a whole number of output times, at least 2
point_count = whole_number(2, "output points")


def integrator_name(text):
    """``type=`` of ``--method``/``--integrator``: a method :func:`simulate` knows."""
    from ..simulation import COMPILED_METHODS
    if text in COMPILED_METHODS:  # the compiled loop's: no need to read SciPy's table
        return text
    from ..simulation import METHODS
    if text not in METHODS:
        raise argparse.ArgumentTypeError(f"unknown integrator {text!r}; available: "
                                         f"{', '.join(METHODS)}")
    return text


def check_output_dir(path, option="--out"):
    """Create the output folder ``path`` and check that files can be written there.

    Called before any derivation or simulation, so that a run is not lost for
    want of a place to write it.

    Raises
    ------
    KanedynError
        Naming ``option`` and the folder, when the name is empty (``--out ""``,
        which would mean the current folder), or the folder cannot be created
        (a file on the way, no permission) or written.
    """
    _not_empty(path, option)
    path = Path(path)
    for parent in (path, *path.parents):
        if parent.exists():
            if not parent.is_dir():
                raise KanedynError(f"{option} {path}: {parent} is a file, not a folder")
            break
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise KanedynError(f"{option} {path}: cannot write there ({reason})") from None
    if not os.access(path, os.W_OK):
        raise KanedynError(f"{option} {path}: the folder is not writable")
    return path


def check_output_file(path, option):
    """Check that the file ``path`` can be written: not a folder, in a folder that
    :func:`check_output_dir` accepts (created if need be).

    Raises
    ------
    KanedynError
        Naming ``option`` and the path.
    """
    _not_empty(path, option)
    path = Path(path)
    if path.is_dir():
        raise KanedynError(f"{option} {path}: is a folder; give the name of a file")
    check_output_dir(path.parent, option=f"{option} {path}:")
    return path


def _not_empty(path, option):
    """An empty name (``--out ""``) is refused: Path("") is the current folder."""
    if not str(path):
        raise KanedynError(f"{option}: the name is empty; give a folder or file name "
                           "(. for the current folder)")


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


def positive_pairs(pairs, option, key_name):
    """``{key: value}`` from ``key=value`` texts (``--sigma``, ``--nominal``), each
    value a finite number > 0 (never evaluated as code)."""
    out = {}
    for pair in pairs or ():
        if "=" not in pair:
            raise KanedynError(f"{option} expects {key_name}=value, got {pair!r}")
        key, text = (s.strip() for s in pair.split("=", 1))
        value = parse_number(text, f"{option} {key}")
        if not (math.isfinite(value) and value > 0):
            raise KanedynError(f"{option} {key}: {text!r} is not a positive finite number")
        out[key] = value
    return out


def _finite(number, key, text):
    if not math.isfinite(number):
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


def split_values(definition, values):
    """Split ``--set`` values into parameters and initial values of ``definition``.

    Read from the definition (its constants and ``state_names``), so that a name
    that is neither is refused before any derivation.
    """
    constants, initial = {}, {}
    const_names = {str(s) for s in definition.constants}
    states = definition.state_names
    for key, value in values.items():
        if key in const_names:
            constants[key] = value
        elif key in states:
            initial[key] = value
        else:
            raise KanedynError(
                f"--set {key}: not an option, parameter or state of {definition.name}; "
                f"parameters: {', '.join(sorted(const_names)) or 'none'}; states: "
                f"{', '.join(states)}")
    return constants, initial
