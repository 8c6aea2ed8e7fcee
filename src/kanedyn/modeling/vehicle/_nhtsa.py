"""Crash-test records in the simple CSV of the NHTSA test database's signal export.

The conventions kanedyn reads (the export has no published schema; these are the
ones it assumes, and what :func:`write_nhtsa_csv` writes):

* comma separated (read with :mod:`csv`, never evaluated), UTF-8 (a byte-order
  mark is skipped); the first line is the header, every other line a sample;
* the first column is the time, headed ``Time`` with an optional unit in
  parentheses or brackets, ``Time (s)`` or ``Time [ms]``; without a unit, seconds;
* every other column is a channel, headed by its name (NHTSA's curve description,
  e.g. ``VEHICLE CG X ACCELERATION``) with an optional unit: ``(G)``, ``(g)``,
  ``(G's)``, ``(m/s^2)`` for accelerations, ``(deg/s)``, ``(rad/s)`` for angular
  rates; without a unit an acceleration is in g and a rate in deg/s (the export's
  units).

Channels are picked by name (case and repeated spaces ignored) or by column number
(1 the first channel after the time).  Refused, naming the file, the column and
the line: a missing time column, an unknown unit, a channel not in the header or
named twice, an empty cell or text, time that does not increase, and the checks of
:func:`read_pulse_csv` (file size, UTF-8, peaks, speed change).
"""

from __future__ import annotations

import csv
import math
import re

import numpy as np

from ..._errors import ModelError
from ..._output_files import replacing
from ._iso_mme import ISO_UNITS
from ._series import MAX_BYTES, _csv_rows, _read_columns, _read_text, series_from_channels

__all__ = ["read_nhtsa_csv", "write_nhtsa_csv"]

_TARGETS = ("ax", "ay", "az", "wx", "wy", "wz")
_CELL = re.compile(r"^\s*(.*?)\s*(?:[\(\[]\s*([^\)\]]*?)\s*[\)\]])?\s*$")
_TIME_UNITS = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "msec": 1e-3}
_ACC_UNITS = dict(ISO_UNITS["a"], **{"g's": ISO_UNITS["a"]["g"]})
_DEFAULT_UNIT = {"a": "g", "w": "deg/s"}


def _name(text):
    return " ".join(text.split()).upper()


def read_nhtsa_csv(path, channels, *, max_bytes=MAX_BYTES):
    """Read vehicle accelerations (and angular rates) from an NHTSA signal CSV.

    Parameters
    ----------
    path : str or pathlib.Path
    channels : dict
        ``{"ax": name or column number, "ay": ..., "wz": ...}``; an absent key
        is a zero channel; ``ax`` is required.
    max_bytes : int
        Largest file read, bytes.

    Returns
    -------
    PulseSeries
        SI units; :attr:`~PulseSeries.notes` names the columns read.

    Raises
    ------
    ModelError
        Naming the file, the column and the line at fault.
    """
    source = str(path)
    if not isinstance(channels, dict) or "ax" not in channels:
        raise ModelError(f"read_nhtsa_csv({source}): channels must be a dict with at least "
                         "'ax' (a column name or number), e.g. {'ax': 'VEHICLE CG X "
                         "ACCELERATION'}")
    unknown = set(channels) - set(_TARGETS)
    if unknown:
        raise ModelError(f"read_nhtsa_csv({source}): channels: unknown key(s) "
                         f"{sorted(unknown)}; use " + ", ".join(_TARGETS))
    rows = _csv_rows(_read_text(path, source, max_bytes, "read_nhtsa_csv"), source)
    header_line, header = next(((n, r) for n, r in rows if r and "".join(r).strip()),
                               (0, None))
    if header is None:
        raise ModelError(f"{source}: empty; an NHTSA CSV starts with a header line "
                         "(Time, then the channels)")
    cells = [_CELL.match(cell).groups() for cell in header]
    name, unit = cells[0]
    if name.lower() != "time":
        raise ModelError(f"{source}: line {header_line}: the first column is {header[0]!r}; "
                         "an NHTSA CSV starts with the time column ('Time' or 'Time (s)')")
    time_factor = _TIME_UNITS.get((unit or "s").lower())
    if time_factor is None:
        raise ModelError(f"{source}: column {header[0]!r}: unknown time unit {unit!r}; use "
                         + ", ".join(_TIME_UNITS))
    names = [_name(n) for n, _ in cells]
    columns, labels, notes, chosen = {"t": (0, time_factor)}, {}, [], {}
    for target, wanted in channels.items():
        if isinstance(wanted, (int, np.integer)) and not isinstance(wanted, bool):
            index = int(wanted) if 1 <= wanted < len(header) else None
        else:
            found = [i for i in range(1, len(names)) if names[i] == _name(str(wanted))]
            if len(found) > 1:
                raise ModelError(f"{source}: line {header_line}: columns "
                                 f"{', '.join(map(str, found))} are all named {wanted!r}; "
                                 "give the column number")
            index = found[0] if found else None
        if index is None:
            raise ModelError(f"{source}: no column {wanted!r} (for {target}) in the header "
                             f"(line {header_line}): " + ", ".join(map(repr, header[1:])))
        kind = target[0]
        unit = cells[index][1] or _DEFAULT_UNIT[kind]
        units = _ACC_UNITS if kind == "a" else ISO_UNITS["w"]
        factor = units.get(unit.replace(" ", "").lower())
        if factor is None:
            what = "acceleration" if kind == "a" else "angular rate"
            raise ModelError(f"{source}: column {header[index]!r} (for {target}): unknown "
                             f"unit {unit!r} for an {what}; use one of " + ", ".join(units))
        if any(col == index for col, _ in columns.values()):
            raise ModelError(f"{source}: column {header[index]!r} is chosen twice")
        columns[header[index]] = (index, factor)
        chosen[target] = header[index]
        labels[target] = f"column {header[index]!r}"
        notes.append(f"{target}: column {index} {header[index]!r}")
    data, lines = _read_columns(rows, header, header_line, columns, [], source)
    t = data.pop("t")
    return series_from_channels(t, {tg: data[col] for tg, col in chosen.items()}, source,
                                labels, notes, time_factor, lines,
                                f"the header (line {header_line})", f"column {header[0]!r}")


def write_nhtsa_csv(path, t, channels):
    """Write a record in the CSV :func:`read_nhtsa_csv` reads.

    Parameters
    ----------
    path : str or pathlib.Path
    t : array_like, shape (n,)
        Time, s (written as ``Time (s)``).
    channels : sequence of (str, str, array_like)
        ``(name, unit, values)``: e.g. ``("VEHICLE CG X ACCELERATION", "G", a)``.
    """
    t = np.asarray(t, float)
    header = ["Time (s)"] + [f"{name} ({unit})" for name, unit, _ in channels]
    columns = [t] + [np.asarray(v, float) for _, _, v in channels]
    with replacing(path, newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        for row in np.column_stack(columns):
            writer.writerow([repr(float(v)) if math.isfinite(v) else "" for v in row])
