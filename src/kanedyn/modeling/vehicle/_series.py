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

A record whose accelerations imply a speed change above :data:`MAX_SPEED_CHANGE`
(the largest ``|integral of a dt|`` from the first sample on; crash and sled tests
stay below about 35 m/s) is read, with a :class:`UserWarning`: a time column in
milliseconds labelled ``[s]`` makes a 0.1 s pulse last 100 s and its speed change a
thousand times too large.
"""

from __future__ import annotations

import csv
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..._errors import ModelError
from ..._output_files import replacing
from ._pulses import G0

__all__ = ["PulseSeries", "read_pulse_csv", "write_pulse_csv", "MAX_G", "MAX_RATE",
           "MIN_SAMPLES", "MAX_SPEED_CHANGE"]

#: accelerations above this (in g) are refused as wrong units or a broken channel
MAX_G = 1000.0
#: angular rates above this (rad/s, about 3 revolutions per 20 ms) are refused
MAX_RATE = 1000.0
#: fewer samples than this are refused
MIN_SAMPLES = 4
#: a speed change above this (m/s, 360 km/h) implied by the accelerations is warned of
MAX_SPEED_CHANGE = 100.0

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


def read_pulse_csv(path):
    """Read and check a vehicle motion record; see the module text for the format.

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file.

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
    try:  # utf-8-sig: the byte-order mark that spreadsheet programs write is skipped
        lines = Path(path).read_text(encoding="utf-8-sig").splitlines()
    except OSError as exc:
        raise ModelError(f"cannot read pulse file {source}: {exc.strerror}") from None
    except UnicodeDecodeError as exc:
        raise ModelError(f"{source}: not UTF-8 text (byte {exc.object[exc.start]:#04x} "
                         f"at offset {exc.start}); save it as UTF-8 CSV") from None
    notes, rows, header, header_line = [], [], None, 0
    for line_no, row in _csv_rows(lines, source):
        if not row or not "".join(row).strip():
            continue
        if row[0].lstrip().startswith("#"):
            notes.append(",".join(row).lstrip()[1:].strip())
            continue
        if header is None:
            header, header_line = row, line_no
            columns = _parse_header(row, source)
            continue
        if len(row) > len(header) and "".join(row[len(header):]).strip():
            raise ModelError(f"{source}: line {line_no} has {len(row)} cells, the header "
                             f"(line {header_line}) names {len(header)} columns")
        rows.append((line_no, row))
    if header is None:
        raise ModelError(f"{source}: no header line (need t, ax, ay, az with units)")
    data = {}
    for name, (col, factor) in columns.items():
        values = np.empty(len(rows))
        for k, (line_no, row) in enumerate(rows):
            cell = row[col].strip() if col < len(row) else ""
            try:
                value = float(cell)
            except ValueError:
                value = None
            if value is None or not np.isfinite(value):
                shown = cell if cell else "an empty cell"
                raise ModelError(f"{source}: column {name!r}, line {line_no}: {shown!r} "
                                 "is not a finite number")
            values[k] = value * factor
        data[name] = values
    t = data["t"]
    if len(t) < MIN_SAMPLES:
        raise ModelError(f"{source}: {len(t)} samples below the header (line "
                         f"{header_line}); at least {MIN_SAMPLES} are needed")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        raise ModelError(f"{source}: column 't': time does not increase at line "
                         f"{rows[k + 1][0]} ({t[k + 1]:g} s after {t[k]:g} s)")
    for name in _ACC:
        peak = np.max(np.abs(data[name])) / G0
        if peak > MAX_G:
            raise ModelError(f"{source}: column {name!r}: peak {peak:.4g} g is above "
                             f"{MAX_G:g} g; check the unit in the header")
    for name in _RATE:
        if name in data and np.max(np.abs(data[name])) > MAX_RATE:
            raise ModelError(f"{source}: column {name!r}: angular rate "
                             f"{np.max(np.abs(data[name])):.4g} rad/s is above "
                             f"{MAX_RATE:g} rad/s; check the unit in the header")
    acceleration = np.column_stack([data[n] for n in _ACC])
    _warn_speed_change(t, acceleration, columns["t"][1], source)
    zeros = np.zeros_like(t)
    return PulseSeries(
        t=t, acceleration=acceleration,
        angular_rate=np.column_stack([data.get(n, zeros) for n in _RATE]),
        source=source, rate_columns=tuple(n for n in _RATE if n in data),
        notes=tuple(notes))


def _csv_rows(lines, source):
    """``(line number, cells)`` of the CSV text ``lines``; a cell over the csv module's
    field limit or text it cannot read is refused, naming the line."""
    reader = csv.reader(lines)
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            line = reader.line_num
            if "field limit" in str(exc):
                raise ModelError(f"{source}: line {line}: a cell longer than "
                                 f"{csv.field_size_limit()} characters; not a pulse "
                                 "record") from None
            raise ModelError(f"{source}: line {line}: not readable as CSV ({exc})") from None
        yield reader.line_num, row


def _warn_speed_change(t, acceleration, time_factor, source):
    """Warn when the accelerations (m/s^2, shape (n, 3)) imply a speed change above
    :data:`MAX_SPEED_CHANGE`: a sign of a time column in the wrong unit."""
    steps = 0.5 * (acceleration[1:] + acceleration[:-1]) * np.diff(t)[:, None]
    speed = float(np.max(np.linalg.norm(np.cumsum(steps, axis=0), axis=1)))
    if speed <= MAX_SPEED_CHANGE:
        return
    hint = ("if the times are in milliseconds, write 't [ms]' (the speed change is then "
            f"{speed / 1000:.3g} m/s)" if time_factor == 1.0 else "check the unit of 't'")
    warnings.warn(f"{source}: the accelerations imply a speed change of {speed:.4g} m/s "
                  f"({3.6 * speed:.4g} km/h) over {t[-1] - t[0]:.4g} s, above "
                  f"{MAX_SPEED_CHANGE:g} m/s; {hint}", UserWarning, stacklevel=3)


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
