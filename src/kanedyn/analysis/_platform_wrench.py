r"""An external wrench on a parallel model's platform: constant or a table over time.

The wrench acts *on* the platform (a tool's reaction, a payload's weight
beyond the platform's own): a force ``Fx, Fy, Fz`` (N) at its mass centre and a
moment ``Mx, My, Mz`` (N m), components in the ground frame ``N``.  It enters
the model as six specified inputs ``W_Fx .. W_Mz`` of time, so the inverse
study's parts put it in the ``wrench`` cause and the ``loads`` group and the
power balance counts its power.

A table is a CSV file with the header ``t,Fx,Fy,Fz,Mx,My,Mz`` (s, N, N m),
times strictly increasing; between rows the wrench is interpolated linearly
and it must cover the study's time span (no extrapolation).
"""

from __future__ import annotations

import csv
import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._errors import KanedynError

__all__ = ["WrenchTable", "read_wrench_csv", "with_platform_wrench", "WRENCH_COLUMNS"]

#: Columns of a wrench table after the time ``t`` (N, N, N, N m, N m, N m).
WRENCH_COLUMNS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")


@dataclass(frozen=True)
class WrenchTable:
    """A platform wrench over time, read from a CSV file.

    Attributes
    ----------
    t : numpy.ndarray, shape (N,)
        Strictly increasing times, s.
    values : numpy.ndarray, shape (N, 6)
        ``Fx, Fy, Fz`` (N), ``Mx, My, Mz`` (N m) at those times.
    source : str
        The file it was read from.
    """

    t: np.ndarray
    values: np.ndarray
    source: str

    def __call__(self, time):
        """The wrench at ``time`` (s), linearly interpolated: array of shape (6,)."""
        if not self.t[0] <= time <= self.t[-1]:
            raise KanedynError(f"{self.source}: the wrench table covers t = {self.t[0]:g} .. "
                               f"{self.t[-1]:g} s, asked for t = {time:g} s")
        return np.array([np.interp(time, self.t, col) for col in self.values.T])

    def check_covers(self, t0, t1):
        """Raise when the table does not cover ``[t0, t1]`` (s)."""
        if self.t[0] > t0 or self.t[-1] < t1:
            raise KanedynError(f"{self.source}: the wrench table covers t = {self.t[0]:g} .. "
                               f"{self.t[-1]:g} s; the trajectory needs {t0:g} .. {t1:g} s")


def read_wrench_csv(path):
    """Read a wrench table (header ``t,Fx,Fy,Fz,Mx,My,Mz``); every number checked.

    Raises
    ------
    KanedynError
        Naming the file and line of a missing column, a value that is not a
        finite number, or a time not after the one before.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise KanedynError(f"wrench file {path}: cannot read it ({exc.strerror})") from None
    rows = [r for r in csv.reader(text.splitlines()) if any(c.strip() for c in r)]
    expected = ["t", *WRENCH_COLUMNS]
    if not rows or [c.strip() for c in rows[0]] != expected:
        raise KanedynError(f"{path}, line 1: the header must be {','.join(expected)}")
    if len(rows) < 2:
        raise KanedynError(f"{path}: needs at least two rows of data")
    data = []
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(expected):
            raise KanedynError(f"{path}, line {line}: {len(row)} values, expected "
                               f"{len(expected)} ({','.join(expected)})")
        values = []
        for name, cell in zip(expected, row):
            try:
                x = float(cell)
            except ValueError:
                x = math.nan
            if not math.isfinite(x):
                raise KanedynError(f"{path}, line {line}, column {name}: {cell.strip()!r} "
                                   "is not a finite number")
            values.append(x)
        if data and not values[0] > data[-1][0]:
            raise KanedynError(f"{path}, line {line}: t = {values[0]:g} s is not after the "
                               f"previous row's {data[-1][0]:g} s")
        data.append(values)
    arr = np.array(data)
    return WrenchTable(t=arr[:, 0], values=arr[:, 1:], source=str(path))


def with_platform_wrench(definition, wrench):
    """The model definition with a wrench on its platform as six specified inputs.

    Parameters
    ----------
    definition : ModelDefinition
        A model whose ``symbols`` hold ``platform`` (a RigidBody) and ``N``.
    wrench : array_like, shape (6,), or WrenchTable, or callable
        ``Fx, Fy, Fz`` (N), ``Mx, My, Mz`` (N m) in ``N``, constant, or a
        function of time returning those six.

    Returns
    -------
    ModelDefinition
    """
    import sympy.physics.mechanics as me

    from ..modeling import ExternalWrench
    if "platform" not in definition.symbols or "N" not in definition.symbols:
        raise KanedynError(f"model {definition.name!r} names no platform body; a platform "
                           "wrench needs one (out-parallel-6dof, stewart-platform)")
    if callable(wrench):
        at = wrench
    else:
        constant = np.asarray(wrench, float)
        if constant.shape != (6,) or not np.all(np.isfinite(constant)):
            raise KanedynError("a platform wrench needs six finite numbers "
                               f"{','.join(WRENCH_COLUMNS)}, got {wrench!r}")
        at = lambda time: constant  # noqa: E731
    N, platform = definition.symbols["N"], definition.symbols["platform"]
    names = " ".join(f"W_{c}" for c in WRENCH_COLUMNS)
    W = me.dynamicsymbols(names)
    force = W[0] * N.x + W[1] * N.y + W[2] * N.z
    moment = W[3] * N.x + W[4] * N.y + W[5] * N.z
    kane_args = dict(definition.kane_args)
    kane_args["loads"] = (list(kane_args.get("loads") or [])
                          + ExternalWrench(platform, force=force, moment=moment).to_loads())
    specified = dict(definition.specified or {})
    specified.update({w: (lambda time, i=i: float(at(time)[i])) for i, w in enumerate(W)})
    return dataclasses.replace(definition, kane_args=kane_args, specified=specified)
