r"""Measured records for parameter identification: arrays, or a CSV file read
as numbers only.

A record is the time of each sample and one or more measured channels, each
named after what the model computes: a state (``theta``) or the rate of a
state (``omega_dot``, :math:`\dot\omega`).  Which names a model knows is
checked by :func:`~kanedyn.identify`; here the record is checked on its own:
times finite and strictly increasing, every value finite, every channel as
long as the time.

CSV format (read with :mod:`csv`; every cell is converted by ``float``, never
evaluated):

* lines starting with ``#`` are comments; blank lines are skipped;
* the first other line is the header: a time column ``t`` or ``time``
  (``t [s]`` or ``t [ms]``), and the measured columns, each ``name`` or
  ``name [unit]`` (a unit is compared with the model's unit of that state);
* every other line holds a number in every cell of the columns read.

This is the format :meth:`SimulationResult.to_csv` writes (its columns that
are not states, such as ``kinetic_energy``, are left out with ``columns=``).
Refused, naming the file, the line and the column: what is not a regular
file, a file above :data:`MAX_BYTES`, text that is not UTF-8 or not CSV, a
header without a time column, a column named twice, a cell that is not a
finite number, a row longer than the header, times that do not increase.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from .._errors import ModelError
from .._number_text import finite_number
from .._input_files import csv_rows, read_bounded_text

__all__ = ["MeasuredRecord", "MAX_BYTES", "as_records"]

#: files larger than this (bytes, 64 MiB) are refused unless ``max_bytes`` says more
MAX_BYTES = 64 * 2**20

_HEADER = re.compile(r"^\s*([^\[\]]*?)\s*(?:\[\s*([^\]]*?)\s*\])?\s*$")
_TIME_UNITS = {"s": 1.0, "ms": 1e-3}


def _frozen(values):
    array = np.array(values, dtype=float)
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class MeasuredRecord:
    r"""One measured record: sample times and channels named after the model's
    outputs.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times, s, finite and strictly increasing.
    values : dict or array_like
        ``{channel: values of shape (N,)}``, or an array of shape (N, k) with
        ``columns``.  A channel is a state's name (or dynamic symbol), or a
        state's name followed by ``_dot`` for its rate.
    columns : sequence of str, optional
        Names of the columns of ``values`` given as an array.
    sigma : float or dict, optional
        Standard deviation of each channel's noise (units of the channel),
        when known; by default :func:`~kanedyn.identify` estimates it from the
        residuals.
    y0 : dict or array_like, optional
        The initial state of this record (as for :func:`kanedyn.simulate`);
        the states whose initial values are fitted take theirs as the guess.
    inputs : dict, optional
        ``{input: number, f(t) or f(t, y)}``: the specified inputs during this
        record (``NumericModel.with_inputs``).
    start : float, optional
        Time of ``y0``, s (default: the first sample's).
    name : str, optional
        Shown in messages (default: the file, or ``"record k"``).
    units : dict, optional
        ``{channel: unit}`` as read from a file's header.
    lines : array_like, optional
        The file's line number of each sample (for messages).

    Raises
    ------
    ModelError
        Naming the record, the channel and the sample (or the file's line) at
        fault.

    Examples
    --------
    >>> import numpy as np
    >>> import kanedyn as kd
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> record = kd.MeasuredRecord(t, {"q": np.cos(t)}, y0={"q": 1.0, "u": 0.0})
    >>> record.channels
    ('q',)
    """

    t: np.ndarray
    values: dict
    sigma: dict | None = None
    y0: object = None
    inputs: dict | None = None
    start: float | None = None
    name: str | None = None
    units: dict = field(default_factory=dict)
    lines: np.ndarray | None = None

    def __init__(self, t, values, columns=None, sigma=None, y0=None, inputs=None, start=None,
                 name=None, units=None, lines=None):
        where = name or "record"
        t = _frozen(_array(t, f"{where}: t"))
        if t.ndim != 1:
            raise ModelError(f"{where}: t must be one-dimensional, got shape {t.shape}")
        values = _channels(values, columns, t.size, where)
        if lines is not None:
            lines = np.asarray(lines, dtype=np.int64)
        set_ = object.__setattr__
        set_(self, "t", t)
        set_(self, "values", values)
        set_(self, "name", name)
        set_(self, "lines", lines)
        set_(self, "units", dict(units or {}))
        set_(self, "y0", y0)
        set_(self, "inputs", dict(inputs) if inputs else None)
        _check_time(self)
        for channel, column in values.items():
            bad = np.flatnonzero(~np.isfinite(column))
            if bad.size:
                raise ModelError(f"{self._where(bad[0])}, channel {channel!r}: "
                                 f"{float(column[bad[0]])!r} is not a finite number "
                                 f"({bad.size} such value{'s' * (bad.size > 1)}); leave "
                                 "missing samples out of the record")
        if start is not None:
            start = float(start)
            if not math.isfinite(start) or start > t[0]:
                raise ModelError(f"{where}: start = {start!r} s must be finite and not after "
                                 f"the first sample ({t[0]:g} s)")
        set_(self, "start", start)
        set_(self, "sigma", _sigma(sigma, values, where))

    # ---------------------------------------------------------- reading
    @classmethod
    def from_csv(cls, path, columns=None, sigma=None, y0=None, inputs=None, start=None,
                 max_bytes=MAX_BYTES):
        """Read a record from a CSV file (see the module text for the format).

        Parameters
        ----------
        path : str or os.PathLike
        columns : sequence of str, optional
            The channels to read (default: every column but the time).
        sigma, y0, inputs, start
            As for :class:`MeasuredRecord`.
        max_bytes : int
            Largest file read (default :data:`MAX_BYTES`).

        Returns
        -------
        MeasuredRecord

        Raises
        ------
        ModelError
            Naming the file, the line and the column at fault.
        """
        source = str(path)
        rows = csv_rows(_text(path, source, max_bytes), source, "a record")
        header, header_line = None, 0
        for line, row in rows:
            if not "".join(row).strip() or row[0].lstrip().startswith("#"):
                continue
            header, header_line = row, line
            break
        if header is None:
            raise ModelError(f"{source}: no header line (a time column t and measured "
                             "columns)")
        time_col, time_factor, chosen, units = _header(header, columns, source, header_line)
        names = list(chosen)
        cells = [chosen[n] for n in names]
        times, data, lines = [], [[] for _ in names], []
        width = len(header)
        for line, row in rows:
            if not "".join(row).strip() or row[0].lstrip().startswith("#"):
                continue
            if len(row) > width and "".join(row[width:]).strip():
                raise ModelError(f"{source}: line {line} has {len(row)} cells; the header "
                                 f"(line {header_line}) names {width} columns")
            times.append(_cell(row, time_col, header[time_col].strip(), line, source))
            for store, col in zip(data, cells):
                store.append(_cell(row, col, header[col].strip(), line, source))
            lines.append(line)
        if not times:
            raise ModelError(f"{source}: no samples below the header (line {header_line})")
        t = np.array(times) * time_factor
        return cls(t, {n: np.array(d) for n, d in zip(names, data)}, sigma=sigma, y0=y0,
                   inputs=inputs, start=start, name=source, units=units, lines=lines)

    # ------------------------------------------------------------ views
    @property
    def channels(self):
        """The channels' names, in order."""
        return tuple(self.values)

    @property
    def size(self):
        """Number of measured values (samples times channels)."""
        return self.t.size * len(self.values)

    @property
    def t0(self):
        """Time of the initial state, s."""
        return float(self.t[0]) if self.start is None else self.start

    def _where(self, k):
        """``"file, line L"`` or ``"record, sample k"`` of sample ``k``."""
        where = self.name or "record"
        if self.lines is not None and k < len(self.lines):
            return f"{where}, line {int(self.lines[k])}"
        return f"{where}, sample {k} (t = {self.t[k]:g} s)"

    def __repr__(self):
        return (f"<MeasuredRecord {self.name or ''} {self.t.size} samples "
                f"{self.t[0]:g}..{self.t[-1]:g} s: {', '.join(self.values)}>")


def _array(values, what):
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{what}: not an array of numbers") from None


def _name(key):
    if isinstance(key, str):
        return key.strip()
    from ..engine import name_of
    return name_of(key)


def _channels(values, columns, n, where):
    if isinstance(values, dict):
        if columns is not None:
            raise ModelError(f"{where}: columns= is for values given as an array; a dict "
                             "names its channels")
        items = [(_name(k), v) for k, v in values.items()]
    else:
        array = _array(values, f"{where}: values")
        if array.ndim == 1:
            array = array[:, None]
        if columns is None:
            raise ModelError(f"{where}: values given as an array need columns=[names]")
        columns = [columns] if isinstance(columns, str) else list(columns)
        if array.ndim != 2 or array.shape[1] != len(columns):
            raise ModelError(f"{where}: values of shape {array.shape} for {len(columns)} "
                             f"columns ({', '.join(map(str, columns))})")
        items = [(_name(c), array[:, k]) for k, c in enumerate(columns)]
    if not items:
        raise ModelError(f"{where}: no measured channel")
    out = {}
    for name, column in items:
        if name in out:
            raise ModelError(f"{where}: channel {name!r} given twice")
        column = _frozen(_array(column, f"{where}, channel {name!r}"))
        if column.shape != (n,):
            raise ModelError(f"{where}, channel {name!r}: {column.size} values for {n} "
                             f"times (shape {column.shape})")
        out[name] = column
    return out


def _check_time(record):
    t = record.t
    where = record.name or "record"
    if t.size == 0:
        raise ModelError(f"{where}: no samples")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ModelError(f"{record._where(bad[0])}: the time {float(t[bad[0]])!r} is not a finite "
                         "number")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0)) + 1
        what = "repeats" if steps[k - 1] == 0 else "goes back"
        raise ModelError(f"{record._where(k)}: the time {what} ({t[k]:g} s after "
                         f"{t[k - 1]:g} s); samples must be in strictly increasing time "
                         "(sort them, or drop repeated samples)")


def _sigma(sigma, values, where):
    if sigma is None:
        return None
    if isinstance(sigma, dict):
        given = {_name(k): v for k, v in sigma.items()}
        unknown = [k for k in given if k not in values]
        if unknown:
            raise ModelError(f"{where}: sigma names {', '.join(map(repr, unknown))}, not a "
                             f"channel of the record ({', '.join(values)})")
    else:
        given = dict.fromkeys(values, sigma)
    out = {}
    for k, v in given.items():
        if isinstance(v, (str, bytes, bool)):
            raise ModelError(f"{where}: sigma of {k!r} must be a positive number, got {v!r}")
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise ModelError(f"{where}: sigma of {k!r} must be a positive number, got "
                             f"{v!r}") from None
        if not (math.isfinite(v) and v > 0):
            raise ModelError(f"{where}: sigma of {k!r} must be a positive finite number, got "
                             f"{v!r}")
        out[k] = v
    return out


# ----------------------------------------------------------------- CSV
def _header(row, columns, source, line):
    """``(time column, time factor, {channel: column}, {channel: unit})``."""
    parsed = []
    for col, cell in enumerate(row):
        match = _HEADER.match(cell)
        name, unit = (match.group(1), match.group(2)) if match else (cell.strip(), None)
        parsed.append((col, name, unit))
    time = [(c, n, u) for c, n, u in parsed if n.lower() in ("t", "time")]
    if not time:
        raise ModelError(f"{source}: line {line}: no time column in the header "
                         f"({', '.join(row)}); name it t or time, e.g. 't [s]'")
    if len(time) > 1:
        raise ModelError(f"{source}: line {line}: two time columns "
                         f"({', '.join(repr(row[c]) for c, _, _ in time)})")
    time_col, _, time_unit = time[0]
    if time_unit and time_unit not in _TIME_UNITS:
        raise ModelError(f"{source}: column {row[time_col]!r}: unknown time unit "
                         f"{time_unit!r}; use s or ms")
    found, units = {}, {}
    for col, name, unit in parsed:
        if col == time_col or not name:
            continue
        if name in found:
            raise ModelError(f"{source}: line {line}: column {name!r} appears twice in the "
                             "header")
        found[name] = col
        units[name] = unit or None
    if columns is not None:
        columns = [columns] if isinstance(columns, str) else [_name(c) for c in columns]
        missing = [c for c in columns if c not in found]
        if missing:
            raise ModelError(f"{source}: no column {', '.join(map(repr, missing))} in the "
                             f"header (line {line}: {', '.join(found) or 'only the time'})")
        found = {c: found[c] for c in columns}
        units = {c: units[c] for c in columns}
    if not found:
        raise ModelError(f"{source}: line {line}: the header names no measured column "
                         "besides the time")
    return time_col, _TIME_UNITS[time_unit] if time_unit else 1.0, found, units


def _cell(row, col, name, line, source):
    cell = row[col].strip() if col < len(row) else ""
    value = finite_number(cell)
    if value is None:
        shown = repr(cell) if cell else "an empty cell"
        raise ModelError(f"{source}: line {line}, column {name!r}: {shown} is not a finite "
                         "number")
    return value


def _text(path, source, max_bytes):
    """The UTF-8 text (a text stream) of the regular file ``path``."""
    return read_bounded_text(path, source, max_bytes, name="the record",
                             limit=("a record", "MeasuredRecord.from_csv(..., max_bytes=...) "
                                                "reads a larger one"))


# ------------------------------------------------------------- many
def as_records(data):
    """A list of :class:`MeasuredRecord` from what :func:`identify` accepts: a
    record, a CSV path, a pair ``(t, {channel: values})``, or a list of them."""
    import pathlib
    single = (MeasuredRecord, str, pathlib.PurePath)
    if isinstance(data, single) or (isinstance(data, tuple) and len(data) == 2
                                    and isinstance(data[1], dict)):
        data = [data]
    try:
        items = list(data)
    except TypeError:
        raise ModelError(f"data must be a MeasuredRecord, a CSV file, a pair (t, "
                         f"{{channel: values}}) or a list of them, got "
                         f"{type(data).__name__}") from None
    if not items:
        raise ModelError("data: no record given")
    out = []
    for k, item in enumerate(items):
        if isinstance(item, MeasuredRecord):
            out.append(item)
        elif isinstance(item, (str, pathlib.PurePath)):
            out.append(MeasuredRecord.from_csv(item))
        elif isinstance(item, tuple) and len(item) == 2 and isinstance(item[1], dict):
            out.append(MeasuredRecord(item[0], item[1], name=f"record {k}"))
        else:
            raise ModelError(f"data item {k}: a MeasuredRecord, a CSV file or a pair (t, "
                             f"{{channel: values}}), got {type(item).__name__}")
    return out
