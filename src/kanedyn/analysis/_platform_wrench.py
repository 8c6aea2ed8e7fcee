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

import dataclasses
from dataclasses import dataclass

import numpy as np

from .._errors import KanedynError
from ._csv_table import read_numeric_csv

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
    _, arr, _ = read_numeric_csv(path, [["t", *WRENCH_COLUMNS]], "wrench")
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
