r"""Reader of OpenFAST's text input and summary files: values by name, tables by column.

OpenFAST's modules (ElastoDyn, HydroDyn, SeaState, ServoDyn, AeroDyn, MAP++, the
glue code's ``.fst``, and the summary files they write) keep their data as lines

.. code-block:: text

    7466330   PtfmMass    - Platform mass (kg)
    "G0"      OutFmt      - Format used for text tabular output
         0         0   AddCLin  - Additional linear stiffness ...   (then rows of numbers)

between section lines (``---- TOWER ----``), and as tables: a line of column
names, a line of units in parentheses, and rows until a blank line, a section
line or ``END``.  :func:`read_openfast_input` reads such a file into
:class:`OpenFASTInput`; nothing in it is evaluated.  A value is a decimal
literal (``384.243E6``, Fortran's ``1.0D+03``), a flag (``True``, ``F``), a
quoted string, or one unquoted word (``DEFAULT``); anything else is kept as
text and refused only where a number or a flag is asked for, with the file and
the line in the message.

Lines that are neither (titles, comments, output channel lists) are kept out of
the values; the list after a name that has no value (``OutList``) is kept as
:attr:`OpenFASTEntry.items`.  Names are matched without regard to case, as
OpenFAST matches them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from ..._errors import ModelError
from ..._input_files import read_bounded_bytes

__all__ = ["OpenFASTEntry", "OpenFASTTable", "OpenFASTInput", "read_openfast_input",
           "decimal_number"]

#: a decimal literal, Fortran's D exponent included
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eEdD][+-]?\d+)?$")
#: a variable name, with an optional index: ``PtfmMass``, ``BlPitch(1)``
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\(\d+\))?$")
_TOKEN = re.compile(r'"[^"]*"|\'[^\']*\'|[^\s,]+')
_FLAGS = {"true": True, "t": True, "false": False, "f": False}
_DASHES = ("-", "\u2013", "\u2014")  # a comment begins with a dash (ASCII, en or em)
#: largest file read (bytes); the summary files of long HydroDyn models reach a few MB
MAX_BYTES = 50_000_000


def decimal_number(token):
    """``float(token)`` for a decimal literal (``1.5``, ``3E6``, ``2.0D-3``), else None."""
    if not _NUMBER.match(token):
        return None
    return float(token.replace("d", "e").replace("D", "e"))


def _value(token):
    """A token as a number, a flag or text (quotes removed)."""
    number = decimal_number(token)
    if number is not None:
        return number
    if token.lower() in _FLAGS:
        return _FLAGS[token.lower()]
    if len(token) >= 2 and token[0] == token[-1] and token[0] in "\"'":
        return token[1:-1]
    return token


def _value_like(token):
    return (decimal_number(token) is not None or token.lower() in _FLAGS
            or (len(token) >= 2 and token[0] == token[-1] and token[0] in "\"'"))


@dataclass(frozen=True)
class OpenFASTEntry:
    """One named value (or row of values) of an OpenFAST file.

    Attributes
    ----------
    name : str
        As written (``PtfmMass``, ``BlPitch(1)``).
    values : tuple
        The tokens before the name: float, bool or str.
    line : int
        1-based line number.
    rows : tuple of tuple of float
        Lines of numbers that continue a matrix (``AddCLin``'s five further rows).
    items : tuple of str
        For a name without a value (``OutList``): the first word of each line
        that follows, up to ``END``.
    """

    name: str
    values: tuple
    line: int
    rows: tuple = ()
    items: tuple = ()


@dataclass(frozen=True)
class OpenFASTTable:
    """A table: column names, their units, and rows of cells (float or str).

    Attributes
    ----------
    source : str
        The file, as messages name it.
    line : int
        1-based line number of the column names.
    columns, units : tuple of str
    rows : tuple of tuple
        Each row's cells (a row may hold more cells than there are columns,
        as MAP's option lines do).
    """

    source: str
    line: int
    columns: tuple
    units: tuple
    rows: tuple

    def __len__(self):
        return len(self.rows)

    def _index(self, column):
        lowered = [c.lower() for c in self.columns]
        if column.lower() not in lowered:
            raise ModelError(f"{self.source}, line {self.line}: the table has no column "
                             f"{column!r} (columns: {', '.join(self.columns)})")
        return lowered.index(column.lower())

    def cells(self, column):
        """The cells of ``column`` as read (float, or str for text such as ``depth``)."""
        j = self._index(column)
        out = []
        for k, row in enumerate(self.rows):
            if j >= len(row):
                raise ModelError(f"{self.source}, line {self.line + 2 + k}: the row has "
                                 f"{len(row)} cells, none for column {column!r}")
            out.append(row[j])
        return tuple(out)

    def column(self, column):
        """The numbers of ``column``, shape (n_rows,); a cell that is not a number is an error."""
        values = self.cells(column)
        for k, cell in enumerate(values):
            if not isinstance(cell, float):
                raise ModelError(f"{self.source}, line {self.line + 2 + k}: column {column!r} "
                                 f"holds {cell!r}, not a number")
        return np.array(values, dtype=float)


@dataclass(frozen=True)
class OpenFASTInput:
    """An OpenFAST file's named values and tables (:func:`read_openfast_input`).

    Attributes
    ----------
    source : str
        The file, as messages name it.
    entries : mapping of str to tuple of OpenFASTEntry
        By lower-case name; a name written twice has two entries.
    tables : tuple of OpenFASTTable
    """

    source: str
    entries: MappingProxyType
    tables: tuple

    @property
    def names(self):
        """The names of the values, in file order."""
        found = sorted((e.line, e.name) for group in self.entries.values() for e in group)
        return tuple(name for _, name in found)

    def __contains__(self, name):
        return name.lower() in self.entries

    def entry(self, name):
        """The :class:`OpenFASTEntry` of ``name``; missing or written twice is an error."""
        group = self.entries.get(name.lower(), ())
        if not group:
            raise ModelError(f"{self.source}: no line gives {name}")
        if len(group) > 1:
            lines = ", ".join(str(e.line) for e in group)
            raise ModelError(f"{self.source}: {name} is given on lines {lines}; which one is "
                             "meant is not clear")
        return group[0]

    def _single(self, name):
        e = self.entry(name)
        if len(e.values) != 1 or e.rows:
            raise ModelError(f"{self.source}, line {e.line}: {e.name} holds "
                             f"{len(e.values) + sum(map(len, e.rows))} values, not one")
        return e, e.values[0]

    def number(self, name):
        """The value of ``name`` as a float."""
        e, v = self._single(name)
        if not isinstance(v, float):
            raise ModelError(f"{self.source}, line {e.line}: {e.name} is {v!r}, not a number")
        return v

    def integer(self, name):
        """The value of ``name`` as an int (a whole number)."""
        e, v = self._single(name)
        if not isinstance(v, float) or v != int(v):
            raise ModelError(f"{self.source}, line {e.line}: {e.name} is {v!r}, not a whole "
                             "number")
        return int(v)

    def flag(self, name):
        """The value of ``name`` as a bool (``True``/``False``/``T``/``F``)."""
        e, v = self._single(name)
        if not isinstance(v, bool):
            raise ModelError(f"{self.source}, line {e.line}: {e.name} is {v!r}, not a flag "
                             "(True or False)")
        return v

    def text(self, name):
        """The value of ``name`` as text (a quoted string without its quotes, or a word)."""
        e, v = self._single(name)
        if not isinstance(v, str):
            raise ModelError(f"{self.source}, line {e.line}: {e.name} is {v!r}, not text")
        return v

    def array(self, name):
        """The numbers of ``name``: shape (n,) for one line, (rows, n) for a matrix."""
        e = self.entry(name)
        rows = (e.values,) + e.rows
        for k, row in enumerate(rows):
            for v in row:
                if not isinstance(v, float):
                    raise ModelError(f"{self.source}, line {e.line + k}: {e.name} holds "
                                     f"{v!r}, not a number")
        if not e.rows:
            return np.array(e.values, dtype=float)
        if len({len(r) for r in rows}) != 1:
            raise ModelError(f"{self.source}, line {e.line}: the rows of {e.name} differ "
                             "in length")
        return np.array(rows, dtype=float)

    def table(self, column, rows=None):
        """The table that has ``column``.

        Parameters
        ----------
        column : str
            A column name (``"HtFract"``, ``"JointID"``, ``"UnstrLen"``).
        rows : str, optional
            The name of the value that gives the table's number of rows
            (``"NJoints"``); a table of another length is an error.

        Returns
        -------
        OpenFASTTable
        """
        found = [t for t in self.tables if column.lower() in (c.lower() for c in t.columns)]
        if not found:
            raise ModelError(f"{self.source}: no table has a column {column!r}")
        if len(found) > 1:
            lines = ", ".join(str(t.line) for t in found)
            raise ModelError(f"{self.source}: the tables on lines {lines} all have a column "
                             f"{column!r}; which one is meant is not clear")
        table = found[0]
        if rows is not None:
            n = self.integer(rows)
            if n != len(table):
                raise ModelError(f"{self.source}, line {table.line}: {rows} = {n} but the "
                                 f"table has {len(table)} rows")
        return table


def _tokens(line):
    return _TOKEN.findall(line)


def _named(tokens):
    """``(name, values)`` when the tokens are ``values... name [- comment]``, else None."""
    dash = next((k for k, t in enumerate(tokens) if t in _DASHES), None)
    if dash is not None:
        k = dash - 1
    else:  # no comment: the first name after at least one value
        k = next((k for k, t in enumerate(tokens) if k and not _value_like(t)), None)
    if k is None or k < 0 or not _NAME.match(tokens[k]) or tokens[k].lower() in _FLAGS:
        return None
    values = tokens[:k]
    if len(values) > 1 and not all(_value_like(t) for t in values):
        return None  # a title or a comment, not values
    if len(values) == 1 and not _value_like(values[0]) and dash is None:
        return None
    return tokens[k], tuple(_value(t) for t in values)


def _header(tokens):
    """The column names of a table header (text from ``[`` or ``!`` on is a comment)."""
    names = []
    for t in tokens:
        if t.startswith(("[", "!")):
            break
        names.append(t)
    return names


def _is_units(tokens, n):
    head = _header(tokens)
    return len(head) == n and all(t.startswith("(") and t.endswith(")") for t in head)


def _is_break(line):
    s = line.strip()
    return not s or s.startswith(("---", "===")) or line.startswith("END")


def _table_rows(lines, start):
    """Rows of cells from line index ``start`` up to a blank, section or ``END`` line."""
    rows, j = [], start
    while j < len(lines) and not _is_break(lines[j]):
        rows.append(tuple(_value(t) for t in _tokens(lines[j].split("!", 1)[0])))
        j += 1
    return tuple(rows), j


def _continuation(lines, start):
    """Lines of numbers only from ``start`` on (a matrix's further rows)."""
    rows, j = [], start
    while j < len(lines) and not _is_break(lines[j]):
        numbers = [decimal_number(t) for t in _tokens(lines[j])]
        if not numbers or None in numbers:
            break
        rows.append(tuple(numbers))
        j += 1
    return tuple(rows), j


def _list_items(lines, start):
    """The first word of each line from ``start`` up to a blank, section or ``END`` line."""
    items, j = [], start
    while j < len(lines) and not _is_break(lines[j]):
        items.append(str(_value(_tokens(lines[j])[0])))
        j += 1
    return tuple(items), j


def _parse(lines, source):
    entries, tables = {}, []
    i = 0
    while i < len(lines):
        line = lines[i]
        if _is_break(line) or line.lstrip().startswith("!"):
            i += 1
            continue
        tokens = _tokens(line)
        named = _named(tokens)
        head = _header(tokens)
        if (named is None and head and all(_NAME.match(t) for t in head)
                and i + 1 < len(lines) and _is_units(_tokens(lines[i + 1]), len(head))):
            rows, j = _table_rows(lines, i + 2)
            units = tuple(_header(_tokens(lines[i + 1])))
            tables.append(OpenFASTTable(source, i + 1, tuple(head), units, rows))
            i = j
            continue
        if named is None:
            i += 1
            continue
        name, values = named
        rows, items, j = (), (), i + 1
        if not values:  # a name with a list under it (OutList)
            items, j = _list_items(lines, i + 1)
        elif all(isinstance(v, float) for v in values):
            rows, j = _continuation(lines, i + 1)
        entries.setdefault(name.lower(), []).append(
            OpenFASTEntry(name, values, i + 1, rows, items))
        i = j
    frozen = MappingProxyType({k: tuple(v) for k, v in entries.items()})
    return OpenFASTInput(source, frozen, tuple(tables))


def read_openfast_input(path, *, max_bytes=MAX_BYTES):
    """Read an OpenFAST text file (an input file or a module's summary file).

    Parameters
    ----------
    path : str or Path
    max_bytes : int
        Largest file read.

    Returns
    -------
    OpenFASTInput

    Raises
    ------
    ModelError
        A file that cannot be read, is not a regular file, is larger than
        ``max_bytes`` or is not UTF-8 text, naming it.  Values and tables are
        checked when asked for (:meth:`OpenFASTInput.number`, ...).

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = os.path.join(d, "ed.dat")
    ...     with open(p, "w") as f:
    ...         _ = f.write("header\\ntitle\\n--- MASS ---\\n  7466330   PtfmMass  - (kg)\\n")
    ...     read_openfast_input(p).number("PtfmMass")
    7466330.0
    """
    source = str(path)
    data = read_bounded_bytes(Path(path), source, max_bytes, name="OpenFAST file",
                              limit=("an OpenFAST file", "give read_openfast_input(..., "
                                     "max_bytes=...) to read a larger one"),
                              wanted="an OpenFAST text file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise ModelError(f"{source}, line {line}: not UTF-8 text (byte "
                         f"{exc.object[exc.start]:#04x})") from None
    return _parse(text.splitlines(), source)
