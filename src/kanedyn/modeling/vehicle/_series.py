"""Reading and checking vehicle motion records (CSV) of crash and sled tests.

File format (comma separated, read with :mod:`csv`, never evaluated):

* lines starting with ``#`` are comments (and are kept as :attr:`PulseSeries.notes`);
* the first other line is the header; every column used states its unit in brackets:
  ``t [s]`` or ``t [ms]`` (also ``time``), ``ax [g]`` or ``ax [m/s^2]`` (also
  ``m/s2``) for ``ax, ay, az``, and ``wx [rad/s]`` or ``wx [deg/s]`` for
  ``wx, wy, wz``; accelerations and angular rates are in vehicle axes; the
  accelerations are the vehicle's own (gravity is not in them);
* ``t, ax, ay, az`` are required; an angular-rate column that is absent means no
  rotation about that axis; a column that is present must have a number on every row;
* other columns are ignored.

A UTF-8 byte-order mark (which spreadsheet programs write) is skipped.  Refused, with
the file, the column and where possible the line: a missing column or unit, an
unknown unit, an empty cell, text or NaN, time that does not increase strictly, fewer
than :data:`MIN_SAMPLES` samples, an acceleration above :data:`MAX_G` g or an angular
rate above :data:`MAX_RATE` rad/s (units that cannot be right), a cell longer than
the :mod:`csv` module's field limit (131,072 characters) or text that is not CSV.
Refused before anything is read: what is not a regular file (a folder, a named pipe,
a device such as ``/dev/zero``) and a file larger than :data:`MAX_BYTES` (64 MiB;
``max_bytes=`` sets the limit).  The columns read are kept as arrays of floats as the
rows are parsed, so memory is about the file's size and the arrays returned.

A record whose accelerations imply a speed change above :data:`MAX_SPEED_CHANGE`
(the largest ``|integral of a dt|`` from the first sample on; crash and sled tests
stay below about 35 m/s) is read, with a :class:`UserWarning`: a time column in
milliseconds labelled ``[s]`` makes a 0.1 s pulse last 100 s and its speed change a
thousand times too large.
"""

from __future__ import annotations

import csv
import math
import re
import warnings
from array import array
from dataclasses import dataclass, field

import numpy as np

from ..._errors import ModelError
from ..._input_files import csv_rows, read_bounded_bytes, read_bounded_text
from ..._output_files import replacing
from ._pulses import G0

__all__ = ["PulseSeries", "read_pulse_csv", "write_pulse_csv", "series_from_channels",
           "MAX_G", "MAX_RATE",
           "MIN_SAMPLES", "MAX_SPEED_CHANGE", "MAX_BYTES"]

#: accelerations above this (in g) are refused as wrong units or a broken channel
MAX_G = 1000.0
#: angular rates above this (rad/s, about 3 revolutions per 20 ms) are refused
MAX_RATE = 1000.0
#: fewer samples than this are refused
MIN_SAMPLES = 4
#: a speed change above this (m/s, 360 km/h) implied by the accelerations is warned of
MAX_SPEED_CHANGE = 100.0
#: files larger than this (bytes, 64 MiB) are refused unless ``max_bytes`` says more:
#: a crash pulse (10 kHz, 0.3 s, 7 channels) is about 0.2 MB, a million rows of seven
#: channels about 60 MB
MAX_BYTES = 64 * 2**20

_UNITS = {
    "t": {"s": 1.0, "ms": 1e-3},
    "a": {"g": G0, "m/s^2": 1.0, "m/s2": 1.0, "m/s**2": 1.0},
    "w": {"rad/s": 1.0, "deg/s": np.pi / 180},
}
_ACC = ("ax", "ay", "az")
_RATE = ("wx", "wy", "wz")
_HEADER = re.compile(r"^\s*([A-Za-z_]+)\s*(?:\[\s*([^\]]*?)\s*\])?\s*$")


@dataclass(frozen=True)
class PulseSeries:
    """A checked motion record in SI units.

    Attributes
    ----------
    t : numpy.ndarray, shape (n,)
        Time, s, strictly increasing.
    acceleration : numpy.ndarray, shape (n, 3)
        ax, ay, az in vehicle axes, m/s^2.
    angular_rate : numpy.ndarray, shape (n, 3)
        wx, wy, wz in vehicle axes, rad/s (zero columns for absent ones).
    source : str
        The file read (used in messages).
    rate_columns : tuple of str
        The angular-rate columns present in the file.
    notes : tuple of str
        The comment lines.
    """

    t: np.ndarray
    acceleration: np.ndarray
    angular_rate: np.ndarray
    source: str = "<data>"
    rate_columns: tuple = ()
    notes: tuple = field(default=(), repr=False)

    @property
    def uniform(self):
        """True when the sampling interval is constant (to 1e-6 relative)."""
        d = np.diff(self.t)
        return bool(np.all(np.abs(d - d.mean()) <= 1e-6 * d.mean()))

    @property
    def dt(self):
        """Mean sampling interval, s."""
        return float(np.mean(np.diff(self.t)))


def _parse_header(row, source):
    """Column name -> (index, unit factor) for the columns kanedyn reads."""
    found = {}
    for i, cell in enumerate(row):
        m = _HEADER.match(cell)
        if not m:
            continue
        name, unit = m.group(1).lower(), m.group(2)
        name = "t" if name == "time" else name
        kind = "t" if name == "t" else "a" if name in _ACC else "w" if name in _RATE else None
        if kind is None:
            continue
        if name in found:
            raise ModelError(f"{source}: column {name!r} appears twice in the header")
        if not unit:
            raise ModelError(f"{source}: column {name!r} has no unit; write it as "
                             f"'{name} [{next(iter(_UNITS[kind]))}]' (units: "
                             + ", ".join(_UNITS[kind]) + ")")
        factor = _UNITS[kind].get(unit.replace(" ", "").replace("²", "^2"))
        if factor is None:
            raise ModelError(f"{source}: column {name!r}: unknown unit {unit!r}; use one of "
                             + ", ".join(_UNITS[kind]))
        found[name] = (i, factor)
    for name in ("t",) + _ACC:
        if name not in found:
            raise ModelError(f"{source}: missing column {name!r} (header: "
                             f"{', '.join(row)}); required: t, ax, ay, az with units")
    return found


def read_pulse_csv(path, *, max_bytes=MAX_BYTES):
    """Read and check a vehicle motion record; see the module text for the format.

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file.
    max_bytes : int, optional
        Largest file read, bytes (default :data:`MAX_BYTES`, 64 MiB); a larger
        file is refused before it is read.

    Returns
    -------
    PulseSeries
        SI units, vehicle axes.

    Raises
    ------
    ModelError
        Naming the file and the column (and line) at fault.
    """
    source = str(path)
    rows = _csv_rows(_read_text(path, source, max_bytes), source)
    notes, header, header_line = [], None, 0
    for line_no, row in rows:
        if not row or not "".join(row).strip():
            continue
        if row[0].lstrip().startswith("#"):
            notes.append(_note(row))
            continue
        header, header_line = row, line_no
        break
    if header is None:
        raise ModelError(f"{source}: no header line (need t, ax, ay, az with units)")
    columns = _parse_header(header, source)
    data, lines = _read_columns(rows, header, header_line, columns, notes, source)
    t = data.pop("t")
    labels = {name: f"column {name!r}" for name in data}
    return series_from_channels(t, data, source, labels, notes, columns["t"][1], lines,
                                f"the header (line {header_line})", "column 't'")


def series_from_channels(t, channels, source, labels, notes=(), time_factor=1.0, lines=None,
                         after="the header", time_label="time"):
    """A checked :class:`PulseSeries` from channels already in SI units.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Time, s.
    channels : dict
        ``{"ax": values, ..., "wz": values}`` (m/s^2, rad/s; shape (n,)); an
        absent channel is zero (an absent rate: no rotation about that axis).
    source : str
        The file (in messages).
    labels : dict
        ``{channel: how messages name it}`` (e.g. ``"column 'ax'"``).
    notes : sequence of str
    time_factor : float
        Seconds per unit of the file's time (for the hint of the speed-change warning).
    lines : numpy.ndarray, shape (n,), optional
        The file's line of each sample (messages name it), else the sample's index.
    after, time_label : str
        Where the samples start, and what holds the time (messages).
    """
    if len(t) < MIN_SAMPLES:
        raise ModelError(f"{source}: {len(t)} samples below {after}; at least "
                         f"{MIN_SAMPLES} are needed")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        where = f"line {lines[k + 1]}" if lines is not None else f"sample {k + 1}"
        raise ModelError(f"{source}: {time_label}: time does not increase at {where} "
                         f"({t[k + 1]:g} s after {t[k]:g} s)")
    for name in _ACC:
        peak = np.max(np.abs(channels[name])) / G0 if name in channels else 0.0
        if peak > MAX_G:
            raise ModelError(f"{source}: {labels[name]}: peak {peak:.4g} g is above "
                             f"{MAX_G:g} g; check the unit in the header")
    for name in _RATE:
        if name in channels and np.max(np.abs(channels[name])) > MAX_RATE:
            raise ModelError(f"{source}: {labels[name]}: angular rate "
                             f"{np.max(np.abs(channels[name])):.4g} rad/s is above "
                             f"{MAX_RATE:g} rad/s; check the unit in the header")
    zeros = np.zeros_like(t)
    acceleration = np.column_stack([channels.get(n, zeros) for n in _ACC])
    _warn_speed_change(t, acceleration, time_factor, source)
    return PulseSeries(
        t=t, acceleration=acceleration,
        angular_rate=np.column_stack([channels.get(n, zeros) for n in _RATE]),
        source=source, rate_columns=tuple(n for n in _RATE if n in channels),
        notes=tuple(notes))


def _read_bytes(path, source, max_bytes, reader="read_pulse_csv", wanted="a CSV file"):
    """The bytes of the regular file ``path`` of at most ``max_bytes`` bytes
    (``reader`` and ``wanted`` name the function reading it and what it reads)."""
    return read_bounded_bytes(path, source, max_bytes, name="pulse file", wanted=wanted,
                              limit=_limit(reader))


def _read_text(path, source, max_bytes, reader="read_pulse_csv"):
    """The UTF-8 text (a text stream) of the regular file ``path`` of at most
    ``max_bytes`` bytes (``reader``: the function reading it, in messages)."""
    return read_bounded_text(path, source, max_bytes, name="pulse file",
                             limit=_limit(reader))


def _limit(reader):
    return "a pulse record", f"give {reader}(..., max_bytes=...) to read a larger one"


def _note(row):
    return ",".join(row).lstrip()[1:].strip()


def _read_columns(rows, header, header_line, columns, notes, source):
    """``({column: values in SI units}, line numbers)`` of the data rows; comment
    lines among them go to ``notes``.  Each column is kept as an array of floats."""
    names = list(columns)
    cells = [columns[name][0] for name in names]
    stores = [array("d") for _ in names]
    lines = array("q")
    width = len(header)
    for line_no, row in rows:
        if not row:
            continue
        if row[0].lstrip().startswith("#"):
            notes.append(_note(row))
            continue
        if len(row) > width and "".join(row[width:]).strip():
            raise ModelError(f"{source}: line {line_no} has {len(row)} cells, the header "
                             f"(line {header_line}) names {width} columns")
        try:
            values = [float(row[col]) for col in cells]
        except (ValueError, IndexError):
            if not "".join(row).strip():
                continue
            values = None
        if values is None or not math.isfinite(sum(values)):
            _refuse_cell(row, names, cells, line_no, source)
        for store, value in zip(stores, values):
            store.append(value)
        lines.append(line_no)
    data = {name: np.frombuffer(store, dtype=float) for name, store in zip(names, stores)}
    for name, values in data.items():
        values *= columns[name][1]
    return data, np.frombuffer(lines, dtype=np.int64)


def _refuse_cell(row, names, cells, line_no, source):
    """Raise naming the first cell of ``row`` that is not a finite number; return
    when there is none (the cells are finite, only their sum overflowed)."""
    for name, col in zip(names, cells):
        cell = row[col].strip() if col < len(row) else ""
        try:
            if math.isfinite(float(cell)):
                continue
        except ValueError:
            pass
        shown = cell if cell else "an empty cell"
        raise ModelError(f"{source}: column {name!r}, line {line_no}: {shown!r} "
                         "is not a finite number")


def _csv_rows(text, source):
    """``(line number, cells)`` of the CSV text stream ``text`` (:func:`csv_rows`)."""
    return csv_rows(text, source, "a pulse record")


def _warn_speed_change(t, acceleration, time_factor, source):
    """Warn when the accelerations (m/s^2, shape (n, 3)) imply a speed change above
    :data:`MAX_SPEED_CHANGE`: a sign of a time column in the wrong unit."""
    velocity = acceleration[1:] + acceleration[:-1]  # trapezoids, summed in place
    with np.errstate(over="ignore"):  # times near the float range: an infinite speed
        velocity *= 0.5 * np.diff(t)[:, None]
        np.cumsum(velocity, axis=0, out=velocity)
        speed = float(np.sqrt(np.max(np.einsum("ij,ij->i", velocity, velocity))))
    if speed <= MAX_SPEED_CHANGE:
        return
    hint = ("if the times are in milliseconds, write 't [ms]' (the speed change is then "
            f"{speed / 1000:.3g} m/s)" if time_factor == 1.0 else "check the unit of 't'")
    warnings.warn(f"{source}: the accelerations imply a speed change of {speed:.4g} m/s "
                  f"({3.6 * speed:.4g} km/h) over {t[-1] - t[0]:.4g} s, above "
                  f"{MAX_SPEED_CHANGE:g} m/s; {hint}", UserWarning, stacklevel=4)


def write_pulse_csv(path, t, acceleration, angular_rate=None, notes=(),
                    acceleration_unit="m/s^2", rate_unit="rad/s"):
    """Write a record in the format :func:`read_pulse_csv` reads.

    Parameters
    ----------
    path : str or pathlib.Path
    t : array_like, shape (n,)
        Time, s.
    acceleration : array_like, shape (n, 3)
        m/s^2, vehicle axes; written in ``acceleration_unit`` ("m/s^2" or "g").
    angular_rate : array_like, shape (n, 3) or None
        rad/s; written in ``rate_unit`` ("rad/s" or "deg/s"); None writes no columns.
    notes : sequence of str
        Comment lines written first.
    """
    t = np.asarray(t, float)
    acc = np.asarray(acceleration, float) / _UNITS["a"][acceleration_unit]
    cols = [t] + [acc[:, i] for i in range(3)]
    header = ["t [s]"] + [f"{n} [{acceleration_unit}]" for n in _ACC]
    if angular_rate is not None:
        w = np.asarray(angular_rate, float) / _UNITS["w"][rate_unit]
        cols += [w[:, i] for i in range(3)]
        header += [f"{n} [{rate_unit}]" for n in _RATE]
    with replacing(path, newline="") as handle:
        for note in notes:
            handle.write(f"# {note}\n")
        writer = csv.writer(handle)
        writer.writerow(header)
        for row in np.column_stack(cols):
            writer.writerow([repr(float(v)) for v in row])
