r"""Readers of the two tables a blade-element rotor needs, in AeroDyn's text format.

``read_airfoil_polar``  an airfoil's lift and drag coefficients against the angle
                        of attack (AeroDyn 15 "AirfoilInfo" file, one table)
``read_blade_table``    a blade's aerodynamic stations: span, twist, chord and
                        airfoil number (AeroDyn 15 blade file)

Both read numbers only: a value is a decimal literal (``-1.5``, ``3.5420000E+00``,
read by ``_openfast_input.decimal_number``); nothing in a file is evaluated.  A
line that does not hold what the format says there raises a
:class:`~kanedyn.ModelError` naming the file and the line number.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._errors import ModelError
from ._openfast_input import decimal_number

__all__ = ["AirfoilPolar", "BladeTable", "read_airfoil_polar", "read_blade_table"]


@dataclass(frozen=True)
class AirfoilPolar:
    """Steady lift and drag coefficients of an airfoil against the angle of attack.

    Attributes
    ----------
    name : str
    angle_of_attack : ndarray, shape (n,)
        deg, strictly increasing, covering -180 to 180.
    lift, drag : ndarray, shape (n,)
        :math:`C_l`, :math:`C_d` (dimensionless).
    """

    name: str
    angle_of_attack: np.ndarray
    lift: np.ndarray
    drag: np.ndarray

    def __post_init__(self):
        a = np.asarray(self.angle_of_attack, float)
        cl, cd = np.asarray(self.lift, float), np.asarray(self.drag, float)
        if a.ndim != 1 or a.size < 2 or cl.shape != a.shape or cd.shape != a.shape:
            raise ModelError(f"AirfoilPolar {self.name!r}: angle_of_attack, lift and drag "
                             f"must be 1-D of one length >= 2, got {a.shape}, {cl.shape}, "
                             f"{cd.shape}")
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(cl))
                and np.all(np.isfinite(cd))):
            raise ModelError(f"AirfoilPolar {self.name!r}: values must be finite")
        if np.any(np.diff(a) <= 0) or a[0] > -180 or a[-1] < 180:
            raise ModelError(f"AirfoilPolar {self.name!r}: angle_of_attack must increase "
                             f"strictly and cover -180 to 180 deg, got {a[0]:g} to {a[-1]:g}")
        for key, value in (("angle_of_attack", a), ("lift", cl), ("drag", cd)):
            value.setflags(write=False)
            object.__setattr__(self, key, value)


@dataclass(frozen=True)
class BladeTable:
    """A blade's aerodynamic stations from root to tip.

    Attributes
    ----------
    span : ndarray, shape (n,)
        m, distance along the blade from its root, increasing.
    twist : ndarray, shape (n,)
        deg, the local chord's angle to the rotor plane (positive toward
        feather, as the pitch).
    chord : ndarray, shape (n,)
        m.
    airfoil : ndarray of int, shape (n,)
        1-based number of the station's airfoil in the rotor's list.
    """

    span: np.ndarray
    twist: np.ndarray
    chord: np.ndarray
    airfoil: np.ndarray


def _lines(path):
    path = Path(path)
    try:
        text = path.read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"{path}: cannot be read as a text file ({exc})") from None
    return path, text.splitlines()


def _numbers(path, number, line, count, what):
    """The first ``count`` tokens of ``line`` as floats, or an error naming the line."""
    values = [decimal_number(tok) for tok in line.split()[:count]]
    if len(values) < count or None in values:
        raise ModelError(f"{path}, line {number}: expected {count} numbers ({what}), got "
                         f"{line.strip()[:80]!r}")
    return values


def _keyword(path, lines, key):
    """(index, integer value) of the line ``<value> <key> ...``."""
    for i, line in enumerate(lines):
        tokens = line.split()
        if len(tokens) >= 2 and tokens[1] == key:
            value = _numbers(path, i + 1, line, 1, key)[0]
            if value != int(value) or value < 0:
                raise ModelError(f"{path}, line {i + 1}: {key} must be a whole number, got "
                                 f"{tokens[0]!r}")
            return i, int(value)
    raise ModelError(f"{path}: no line gives {key}; is this an AeroDyn 15 file?")


def read_airfoil_polar(path, name=None):
    """Read an AeroDyn 15 airfoil file (one table of alpha, Cl, Cd[, Cm]).

    Parameters
    ----------
    path : str or Path
    name : str, optional
        The polar's name (the file's stem by default).

    Returns
    -------
    AirfoilPolar

    Raises
    ------
    ModelError
        A file with several tables (``NumTabs`` > 1: a Reynolds-number or
        control-setting family, which this reader does not pick from), a
        missing ``NumAlf`` or a row that is not numbers, naming file and line.
    """
    path, lines = _lines(path)
    _, tables = _keyword(path, lines, "NumTabs")
    if tables != 1:
        raise ModelError(f"{path}: NumTabs = {tables}; only files of one table are read")
    start, rows = _keyword(path, lines, "NumAlf")
    data, number = [], start + 1
    while len(data) < rows:
        if number >= len(lines):
            raise ModelError(f"{path}: NumAlf = {rows} but the file ends after "
                             f"{len(data)} rows")
        line = lines[number]
        number += 1
        if line.strip().startswith("!") or not line.strip():
            continue
        data.append(_numbers(path, number, line, 3, "alpha, Cl, Cd"))
    a = np.array(data)
    return AirfoilPolar(name or path.stem, a[:, 0], a[:, 1], a[:, 2])


def read_blade_table(path):
    """Read an AeroDyn 15 blade file: span, twist, chord and airfoil number per station.

    The two lines after ``NumBlNds`` name the columns and give their units; the
    columns ``BlSpn``, ``BlTwist``, ``BlChord`` and ``BlAFID`` are found by name.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    BladeTable
    """
    path, lines = _lines(path)
    start, rows = _keyword(path, lines, "NumBlNds")
    if start + 3 + rows > len(lines):
        raise ModelError(f"{path}: NumBlNds = {rows} but the file ends before that")
    names = lines[start + 1].split()
    columns = {}
    for key in ("BlSpn", "BlTwist", "BlChord", "BlAFID"):
        if key not in names:
            raise ModelError(f"{path}, line {start + 2}: no column {key} in the header")
        columns[key] = names.index(key)
    width = max(columns.values()) + 1
    table = np.array([_numbers(path, start + 4 + k, lines[start + 3 + k], width,
                               " ".join(names[:width])) for k in range(rows)])
    ids = table[:, columns["BlAFID"]]
    if np.any(ids != np.round(ids)) or np.any(ids < 1):
        raise ModelError(f"{path}: BlAFID must be whole numbers from 1")
    span = table[:, columns["BlSpn"]]
    if np.any(np.diff(span) <= 0):
        raise ModelError(f"{path}: BlSpn must increase from root to tip")
    return BladeTable(span, table[:, columns["BlTwist"]], table[:, columns["BlChord"]],
                      ids.astype(int))
