"""A strict reader of small numeric CSV tables over time (wrench and pose files).

One header row from a fixed set of allowed headers, then rows of finite
numbers, the first column a time strictly increasing.  Every refusal names the
file, the line and (for a bad value) the column.  Cells are parsed with
``float`` only; nothing in the file is evaluated.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .._errors import KanedynError
from .._number_text import finite_number

__all__ = ["read_numeric_csv"]


def read_numeric_csv(path, headers, what):
    """Read a table whose header is one of ``headers``; check every number.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    headers : sequence of sequence of str
        The allowed headers, each a list of column names, the first ``"t"``.
    what : str
        What the file holds, for the messages (``"wrench"``, ``"pose"``).

    Returns
    -------
    index : int
        Which of ``headers`` the file has.
    data : numpy.ndarray, shape (N, len(headers[index]))
        The rows, N >= 2, the times (column 0, s) strictly increasing.
    lines : numpy.ndarray of int, shape (N,)
        The file's line number of each row (for later checks' messages).

    Raises
    ------
    KanedynError
        Naming the file and line of a wrong header, a row of the wrong length,
        a value that is not a finite number (and its column) or a time not
        after the one before.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise KanedynError(f"{what} file {path}: cannot read it ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise KanedynError(f"{what} file {path}: not UTF-8 text") from None
    rows = [(line, r) for line, r in enumerate(csv.reader(text.splitlines()), start=1)
            if any(c.strip() for c in r)]
    found = [c.strip() for c in rows[0][1]] if rows else []
    allowed = [list(h) for h in headers]
    if found not in allowed:
        raise KanedynError(f"{path}, line {rows[0][0] if rows else 1}: the header must be "
                           + " or ".join(",".join(h) for h in allowed))
    index = allowed.index(found)
    expected = allowed[index]
    if len(rows) < 3:
        raise KanedynError(f"{path}: needs at least two rows of data")
    data, lines = [], []
    for line, row in rows[1:]:
        if len(row) != len(expected):
            raise KanedynError(f"{path}, line {line}: {len(row)} values, expected "
                               f"{len(expected)} ({','.join(expected)})")
        values = []
        for name, cell in zip(expected, row):
            x = finite_number(cell)
            if x is None:
                raise KanedynError(f"{path}, line {line}, column {name}: {cell.strip()!r} "
                                   "is not a finite number")
            values.append(x)
        if data and not values[0] > data[-1][0]:
            raise KanedynError(f"{path}, line {line}: t = {values[0]:g} s is not after the "
                               f"previous row's {data[-1][0]:g} s")
        data.append(values)
        lines.append(line)
    return index, np.array(data), np.array(lines)
