"""A registry of studies: named analyses that tabulate, plot and summarize a model.

A study is a function of its options and an output folder that returns tables
(lists of rows), figures and a summary text; :func:`run_study` checks the
options against the study's declared ones, runs it, writes each table as a
CSV file and returns a frozen :class:`StudyResult`.  ``kanedyn study NAME``
is the command-line front end.
"""

from __future__ import annotations

import csv
import math
import types
from dataclasses import dataclass, field
from pathlib import Path

from .._errors import KanedynError
from .._output_files import replacing

__all__ = ["Study", "StudyOption", "StudyResult", "STUDIES", "register_study", "run_study",
           "study_option_value", "available_studies"]


@dataclass(frozen=True)
class StudyOption:
    """One option of a study.

    Attributes
    ----------
    type : type
        ``int``, ``float``, ``str`` or ``bool`` (what ``--set name=value`` converts to).
    default : object
        The value used when the option is not given.
    help : str
        What it means, with its unit.
    choices : tuple
        Allowed values (strings), empty when any value of ``type`` is allowed.
    positive : bool
        A number that must be finite and above zero (a limit, a duration).
    """

    type: type
    default: object
    help: str = ""
    choices: tuple = ()
    positive: bool = False


@dataclass(frozen=True)
class Study:
    """A registered study.

    Attributes
    ----------
    function : callable
        ``function(out, quiet, **options) -> dict`` with keys ``tables``
        (``{name: (columns, rows)}``), ``figures`` (list of paths), ``summary``
        (str) and optionally ``data`` (``{name: value}``, numbers for tests).
        ``out`` is a :class:`pathlib.Path` or ``None`` (then no figures are drawn).
    options : dict
        ``{name: StudyOption}``.
    description : str
        One line for ``kanedyn study``.
    """

    function: object
    options: dict
    description: str


@dataclass(frozen=True)
class StudyResult:
    """What a study produced (frozen).

    Attributes
    ----------
    name : str
    options : mapping
        The options the study ran with (defaults filled in).
    tables : mapping
        ``{table name: (columns, rows)}``: ``columns`` a tuple of str (with
        units), ``rows`` a tuple of tuples.
    figures : tuple of pathlib.Path
    csv_files : tuple of pathlib.Path
        One CSV file per table (empty when ``out`` was ``None``).
    summary : str
    data : mapping
        Named numbers the study exposes (for tests and further use).
    """

    name: str
    options: types.MappingProxyType
    tables: types.MappingProxyType
    figures: tuple = ()
    csv_files: tuple = ()
    summary: str = ""
    data: types.MappingProxyType = field(default_factory=lambda: types.MappingProxyType({}))

    def table(self, name):
        """``(columns, rows)`` of the table ``name``."""
        if name not in self.tables:
            raise KanedynError(f"study {self.name}: no table {name!r}; tables: "
                               f"{', '.join(self.tables)}")
        return self.tables[name]


#: name -> Study; studies register themselves with :func:`register_study`
STUDIES = {}


def register_study(name, function, options, description):
    """Add a study to :data:`STUDIES` (a name already taken raises)."""
    if name in STUDIES and STUDIES[name].function is not function:
        raise KanedynError(f"study {name!r} is already registered")
    STUDIES[name] = Study(function, dict(options), description)
    return STUDIES[name]


_TRUE, _FALSE = ("true", "yes", "on", "1"), ("false", "no", "off", "0")


def study_option_value(study_name, name, option, value):
    """``value`` converted to the option's type and checked against its choices.

    Text (from the command line) is converted, never evaluated.
    """
    kind = option.type
    try:
        if kind is bool:
            if isinstance(value, str):
                if value.strip().lower() not in _TRUE + _FALSE:
                    raise ValueError
                value = value.strip().lower() in _TRUE
            elif not isinstance(value, bool):
                raise ValueError
        elif kind is int:
            if isinstance(value, bool) or (isinstance(value, float) and not value.is_integer()):
                raise ValueError
            value = int(value)
        elif kind is float:
            if isinstance(value, bool):
                raise ValueError
            value = float(value)
        else:
            value = kind(value)
    except (TypeError, ValueError):
        raise KanedynError(f"study {study_name}: option {name} must be "
                           f"{kind.__name__}, got {value!r}") from None
    if option.positive and not (math.isfinite(value) and value > 0):
        raise KanedynError(f"study {study_name}: option {name} must be a positive number, "
                           f"not {value:g}")
    if option.choices and value not in option.choices:
        raise KanedynError(f"study {study_name}: option {name} must be one of "
                           f"{', '.join(map(str, option.choices))}, got {value!r}")
    return value


def _load_builtin():
    from . import _oc3_studies  # noqa: F401  (registers the oc3-* studies)
    from . import _oc3_campbell_study, _oc3_operating_study  # noqa: F401  (oc3 turbine)
    from . import _seatbelt_studies  # noqa: F401  (registers the seatbelt-* studies)
    from ._optimal_problems import available_problems
    available_problems()  # registers the optimal-control problems as studies


def available_studies():
    """:data:`STUDIES` with the built-in studies registered."""
    _load_builtin()
    return STUDIES


def run_study(name, out=None, quiet=True, **options):
    """Run the registered study ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`STUDIES` (``kanedyn study`` lists them).
    out : str or pathlib.Path, optional
        Folder for the figures (PNG) and tables (CSV); created if missing.
        ``None``: nothing is written and no figures are drawn.
    quiet : bool
        No progress text on stderr.
    **options
        The study's options (see ``STUDIES[name].options``); the others keep
        their defaults.

    Returns
    -------
    StudyResult

    Raises
    ------
    KanedynError
        For an unknown study or option, or a value of the wrong type.
    """
    _load_builtin()
    if name not in STUDIES:
        raise KanedynError(f"unknown study {name!r}; studies: {', '.join(sorted(STUDIES))}")
    study = STUDIES[name]
    unknown = sorted(set(options) - set(study.options))
    if unknown:
        raise KanedynError(f"study {name}: unknown option(s) {', '.join(unknown)}; options: "
                           f"{', '.join(study.options)}")
    values = {key: opt.default for key, opt in study.options.items()}
    for key, value in options.items():
        values[key] = study_option_value(name, key, study.options[key], value)
    folder = None
    if out is not None:
        folder = Path(out)
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise KanedynError(f"study {name}: cannot create the output folder {folder}: "
                               f"{exc.strerror or exc}") from None
    produced = study.function(folder, quiet, **values)
    tables = {key: (tuple(cols), tuple(tuple(r) for r in rows))
              for key, (cols, rows) in produced.get("tables", {}).items()}
    csv_files = []
    if folder is not None:
        for key, (cols, rows) in tables.items():
            path = folder / f"{name}_{key}.csv"
            with replacing(path, newline="") as handle:
                writer = csv.writer(handle)
                writer.writerow(cols)
                writer.writerows(rows)
            csv_files.append(path)
    return StudyResult(name=name, options=types.MappingProxyType(values),
                       tables=types.MappingProxyType(tables),
                       figures=tuple(Path(p) for p in produced.get("figures", ())),
                       csv_files=tuple(csv_files), summary=produced.get("summary", ""),
                       data=types.MappingProxyType(dict(produced.get("data", {}))))
