r"""An out-parallel manipulator's geometry, masses and drive trains from a TOML file.

A researcher enters their own machine in a small file; every key is checked
(unknown keys and missing keys refused by name, numbers by range) and the
file is read with :mod:`tomllib` (nothing in it is run).  The sections:

``[geometry]`` (m, degrees)
    ``R_b`` rail circle radius, ``r_p`` platform anchor circle radius, ``L``
    strut length, ``h`` home height of the platform centre, ``gamma_b_deg``
    and ``gamma_p_deg`` the half spreads of the rail pairs and of the platform
    anchor pairs (degrees, in (0, 60)).  The rails are vertical (the model's
    rails are along ``N.z``).
``[masses]`` (kg)
    ``m_p`` platform (a uniform disc of radius ``r_p``), ``m_s`` each strut (a
    uniform slender rod), ``m_c`` each carriage.
``[drive]``
    ``lead`` (m), ``J_rotor``, ``J_coupler``, ``J_screw`` (kg m², >= 0),
    ``eta``, ``eta_back`` (screw efficiencies forward and back-driven, in (0, 1]).
``[limits]`` (optional, each key optional)
    ``force`` (N, on a carriage), ``speed`` (m/s, a carriage's travel rate),
    ``torque`` (N m, a motor), ``motor_speed`` (rad/s).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._errors import KanedynError

__all__ = ["OutParallelMachine", "read_out_parallel_machine", "MACHINE_KEYS"]

_POSITIVE = (0.0, False, None)
#: The sections and keys of a machine file: ``{section: {key: (unit, lowest,
#: lowest allowed?, highest or None)}}``.
MACHINE_KEYS = {
    "geometry": {"R_b": ("m", *_POSITIVE), "r_p": ("m", *_POSITIVE),
                 "L": ("m", *_POSITIVE), "h": ("m", *_POSITIVE),
                 "gamma_b_deg": ("deg", 0.0, False, 60.0),
                 "gamma_p_deg": ("deg", 0.0, False, 60.0)},
    "masses": {"m_p": ("kg", *_POSITIVE), "m_s": ("kg", *_POSITIVE),
               "m_c": ("kg", *_POSITIVE)},
    "drive": {"lead": ("m", *_POSITIVE), "J_rotor": ("kg m^2", 0.0, True, None),
              "J_coupler": ("kg m^2", 0.0, True, None),
              "J_screw": ("kg m^2", 0.0, True, None),
              "eta": ("", 0.0, False, 1.0), "eta_back": ("", 0.0, False, 1.0)},
    "limits": {"force": ("N", *_POSITIVE), "speed": ("m/s", *_POSITIVE),
               "torque": ("N m", *_POSITIVE), "motor_speed": ("rad/s", *_POSITIVE)},
}
_OPTIONAL = {"limits"}


@dataclass(frozen=True)
class OutParallelMachine:
    """One out-parallel manipulator's numbers (see the module's description).

    Attributes
    ----------
    geometry : dict
        ``R_b, r_p, L, h`` (m), ``gamma_b, gamma_p`` (rad): the keys of
        :data:`~kanedyn.models.OUT_PARALLEL_GEOMETRY`.
    inertia : dict
        ``m_p, m_s, m_c`` (kg), ``lead`` (m), ``J_r, J_cp, J_sc`` (kg m²),
        ``eta, eta_back``: the keys of :data:`~kanedyn.models.OUT_PARALLEL_INERTIA`.
    limits : dict
        ``{quantity: limit}`` of ``force`` (N), ``speed`` (m/s), ``torque``
        (N m), ``motor_speed`` (rad/s); empty when the file sets none.
    source : str
        The file it was read from (``""`` when built in code).
    """

    geometry: dict
    inertia: dict
    limits: dict
    source: str = ""


def _number(path, section, key, value):
    unit, low, low_ok, high = MACHINE_KEYS[section][key]
    where = f"{path}: [{section}] {key}"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise KanedynError(f"{where}: must be a number ({unit or 'dimensionless'}), got "
                           f"{type(value).__name__} {value!r}")
    x = float(value)
    above = x >= low if low_ok else x > low
    if not (math.isfinite(x) and above and (high is None or x <= high)):
        span = (f"{'>=' if low_ok else '>'} {low:g}" if high is None
                else f"in {'[' if low_ok else '('}{low:g}, {high:g}]")
        raise KanedynError(f"{where}: must be a finite number {span}"
                           f"{f' ({unit})' if unit else ''}, got {value!r}")
    return x


def read_out_parallel_machine(path):
    """Read a machine file (TOML; the sections in the module's description).

    Returns
    -------
    OutParallelMachine

    Raises
    ------
    KanedynError
        Naming the file and the section and key of an unknown key, a missing
        one, or a value of the wrong type or out of range; TOML syntax errors
        with their line and column.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise KanedynError(f"machine file {path}: cannot read it ({exc.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise KanedynError(f"{path}: not a valid TOML file: {exc}") from None
    values = {}
    for section in data:
        if section not in MACHINE_KEYS:
            raise KanedynError(f"{path}: unknown section [{section}]; known: "
                               + ", ".join(f"[{s}]" for s in MACHINE_KEYS))
    for section, keys in MACHINE_KEYS.items():
        table = data.get(section)
        if table is None and section in _OPTIONAL:
            values[section] = {}
            continue
        if not isinstance(table, dict):
            raise KanedynError(f"{path}: missing section [{section}] (keys "
                               f"{', '.join(keys)})")
        for key in table:
            if key not in keys:
                raise KanedynError(f"{path}: [{section}] unknown key {key!r}; known: "
                                   f"{', '.join(keys)}")
        if section not in _OPTIONAL:
            for key, (unit, *_rest) in keys.items():
                if key not in table:
                    raise KanedynError(f"{path}: [{section}] missing key {key!r}"
                                       f"{f' ({unit})' if unit else ''}")
        values[section] = {k: _number(path, section, k, v) for k, v in table.items()}
    geo, masses, drive = values["geometry"], values["masses"], values["drive"]
    geometry = {"R_b": geo["R_b"], "r_p": geo["r_p"], "L": geo["L"], "h": geo["h"],
                "gamma_b": np.radians(geo["gamma_b_deg"]),
                "gamma_p": np.radians(geo["gamma_p_deg"])}
    inertia = dict(masses, lead=drive["lead"], J_r=drive["J_rotor"],
                   J_cp=drive["J_coupler"], J_sc=drive["J_screw"], eta=drive["eta"],
                   eta_back=drive["eta_back"])
    return OutParallelMachine(geometry=geometry, inertia=inertia, limits=values["limits"],
                              source=str(path))
