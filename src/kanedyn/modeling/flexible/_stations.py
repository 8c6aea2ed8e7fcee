"""Station tables: section properties given at positions along a member.

Wind-turbine towers and blades are specified this way: a table whose rows are
stations (arc position along the member) and whose columns are the section
properties there.  Between stations the properties vary linearly.
"""

from __future__ import annotations

import numpy as np

from ..._errors import ModelError

__all__ = ["StationTable", "STATION_COLUMNS"]

#: column name: (meaning, unit, required)
STATION_COLUMNS = {
    "arc": ("arc position along the member", "m", True),
    "mass_per_length": ("mass per unit length", "kg/m", True),
    "EA": ("axial stiffness", "N", True),
    "GJ": ("torsional stiffness", "N m^2", True),
    "EI_y": ("bending stiffness about the local y axis (bending in the x-z plane)",
             "N m^2", True),
    "EI_z": ("bending stiffness about the local z axis (bending in the x-y plane)",
             "N m^2", True),
    "rotary_inertia_y": ("mass moment of inertia per length about the local y axis",
                         "kg m", False),
    "rotary_inertia_z": ("mass moment of inertia per length about the local z axis",
                         "kg m", False),
    "polar_inertia": ("mass moment of inertia per length about the member axis", "kg m",
                      False),
    "shear_stiffness_y": ("shear stiffness kappa G A for shear along local y", "N", False),
    "shear_stiffness_z": ("shear stiffness kappa G A for shear along local z", "N", False),
    "twist": ("angle of the section's principal axes (local y, z) about the member axis, "
              "right-handed, from the reference orientation (structural twist)", "rad", False),
}
#: columns that may be negative (angles)
_SIGNED = {"twist"}
_POSITIVE = {"EA", "GJ", "EI_y", "EI_z", "shear_stiffness_y", "shear_stiffness_z"}


class StationTable:
    """Validated section properties at stations, interpolated linearly between them.

    Parameters
    ----------
    member : str
        Name of the member (errors name it).
    table : mapping of str to sequence of float
        Columns by name (a dict of lists, a pandas DataFrame, ...); see
        :data:`STATION_COLUMNS` for names, meanings and units.  ``arc``,
        ``mass_per_length``, ``EA``, ``GJ``, ``EI_y`` and ``EI_z`` are required;
        the rotary, polar inertias, shear stiffnesses and the structural
        ``twist`` (rad) are optional.  When
        ``polar_inertia`` is absent and both rotary inertias are given it is
        their sum (perpendicular-axis theorem); when no inertia of the section
        is given, twist carries no inertia (torsion modes are then absent: their
        frequencies are infinite).

    Raises
    ------
    ModelError
        Unknown or missing columns, columns of different lengths, fewer than
        two stations, stations not in strictly increasing arc order, a missing
        (NaN) value, a negative property or a stiffness that is not positive;
        the message names the member, the station (index and arc) and the column.
    """

    def __init__(self, member, table):
        self.member = member
        if not hasattr(table, "keys"):
            raise ModelError(f"member {member!r}: the station table must map column names to "
                             f"values (a dict or a DataFrame), got {type(table).__name__}")
        names = [str(k) for k in table.keys()]
        unknown = [k for k in names if k not in STATION_COLUMNS]
        if unknown:
            raise ModelError(f"member {member!r}: unknown station column(s) {unknown}; known "
                             f"columns: {', '.join(STATION_COLUMNS)}")
        for name, (meaning, unit, required) in STATION_COLUMNS.items():
            if required and name not in names:
                raise ModelError(f"member {member!r}: the station table has no column {name!r} "
                                 f"({meaning}, {unit})")
        columns = {}
        for name in names:
            try:
                values = np.asarray(table[name], dtype=float)
            except (TypeError, ValueError) as exc:
                raise ModelError(f"member {member!r}: station column {name!r} is not a list of "
                                 f"numbers ({exc})") from None
            if values.ndim != 1:
                raise ModelError(f"member {member!r}: station column {name!r} must be "
                                 f"one-dimensional, got shape {values.shape}")
            columns[name] = values
        n = len(columns["arc"])
        for name, values in columns.items():
            if len(values) != n:
                raise ModelError(f"member {member!r}: station column {name!r} has {len(values)} "
                                 f"values, 'arc' has {n}")
        if n < 2:
            raise ModelError(f"member {member!r}: the station table needs at least two "
                             f"stations, got {n}")
        arc = columns["arc"]
        for name, values in columns.items():
            unit = STATION_COLUMNS[name][1]
            for i, v in enumerate(values):
                where = (f"member {member!r}: station {i}" +
                         ("" if name == "arc" else f" (arc {arc[i]:g} m)"))
                if not np.isfinite(v):
                    raise ModelError(f"{where} has no value for {name!r} "
                                     f"({STATION_COLUMNS[name][0]}, {unit})")
                if name in _POSITIVE and v <= 0:
                    raise ModelError(f"{where}: {name} = {v:g} {unit} must be positive")
                if name not in ("arc", *_SIGNED) and v < 0:
                    raise ModelError(f"{where}: {name} = {v:g} {unit} is negative")
        steps = np.diff(arc)
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0)) + 1
            raise ModelError(f"member {member!r}: station {i} (arc {arc[i]:g} m) is not after "
                             f"station {i - 1} (arc {arc[i - 1]:g} m): stations must be in "
                             f"strictly increasing order of arc position")
        if ("polar_inertia" not in columns and "rotary_inertia_y" in columns
                and "rotary_inertia_z" in columns):
            columns["polar_inertia"] = columns["rotary_inertia_y"] + columns["rotary_inertia_z"]
        self.columns = columns

    @property
    def arcs(self):
        """Arc positions of the stations, m, shape (n,)."""
        return self.columns["arc"]

    @property
    def span(self):
        """``(first, last)`` arc positions, m."""
        return float(self.arcs[0]), float(self.arcs[-1])

    @property
    def properties(self):
        """Names of the section properties given (besides ``arc``)."""
        return tuple(k for k in self.columns if k != "arc")

    def at(self, s):
        """Properties at arc positions ``s`` (array, m): dict of name to array like ``s``.

        Linear interpolation between stations; positions outside the table
        raise :class:`ModelError`.
        """
        s = np.asarray(s, float)
        lo, hi = self.span
        tol = 1e-9 * max(abs(lo), abs(hi), hi - lo)
        if np.any(s < lo - tol) or np.any(s > hi + tol):
            bad = s[(s < lo - tol) | (s > hi + tol)].ravel()[0]
            raise ModelError(f"member {self.member!r}: arc position {bad:g} m lies outside the "
                             f"station table ({lo:g} .. {hi:g} m)")
        return {name: np.interp(s, self.arcs, values)
                for name, values in self.columns.items() if name != "arc"}

    def mean(self, name, a, b):
        """The mean of column ``name`` over the arc interval ``[a, b]`` (m), exact.

        The column varies linearly between stations, so the trapezoidal rule on
        the interval's ends and the stations inside it integrates it exactly.
        """
        s = np.concatenate([[a], self.arcs[(self.arcs > a) & (self.arcs < b)], [b]])
        values = np.interp(s, self.arcs, self.columns[name])
        return float(np.sum(np.diff(s) * (values[1:] + values[:-1])) / (2 * (b - a)))

    def breaks(self, a, b):
        """Station arcs strictly inside ``(a, b)``, as fractions of ``b - a``."""
        inside = self.arcs[(self.arcs > a) & (self.arcs < b)]
        return (inside - a) / (b - a)
