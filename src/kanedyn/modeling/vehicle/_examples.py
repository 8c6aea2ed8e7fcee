"""The two example pulses shipped in ``pulses/`` (synthetic) and the code that makes them.

Both are synthetic, made from closed-form shapes here, not measured:

``frontal-48kmh``  frontal barrier-like pulse, 48 km/h (13.333 m/s) velocity change in
    0.1 s: a(t) = -A [sin^3(pi tau) + 0.25 sin(pi tau) sin(6 pi tau)
    + 0.06 sin(pi tau) sin(80 pi tau)] along x, tau = t / 0.1 s on [0, 1]; the last two
    terms (a late second peak and 400 Hz ringing that CFC 60 removes) integrate to zero
    over the pulse, so dv = A T 4 / (3 pi) exactly and A = 3 pi dv / (4 T) (31.9 g);
    peak 39.3 g.  Sampled at 10 kHz from -10 ms to 150 ms, in g, no rate columns.
``oblique-30deg``  the same sin^3 shape, 40 km/h (11.111 m/s) in 0.12 s, along
    -(cos 30 deg, sin 30 deg, 0) in vehicle axes, with a yaw rate
    wz = 0.5 rad/s (1 - cos(pi min(t, T) / T)) / 2 (rising to 0.5 rad/s = 28.6 deg/s);
    10 kHz from -10 ms to 170 ms, m/s^2 and deg/s.  Its accelerations are in the
    (yawing) vehicle axes, so the velocity change in N differs slightly from 11.111 m/s.

Regenerate with ``python -m kanedyn.modeling.vehicle._examples [directory]``.
"""

from __future__ import annotations

import sys
from importlib import resources
from pathlib import Path

import numpy as np

from ..._errors import ModelError
from ._series import write_pulse_csv

__all__ = ["example_pulse", "make_example_pulses", "EXAMPLES"]

#: example name -> file name in the package's ``pulses`` folder
EXAMPLES = {"frontal-48kmh": "frontal_48kmh.csv", "oblique-30deg": "oblique_30deg.csv"}


def example_pulse(name):
    """Path of a shipped example pulse: ``"frontal-48kmh"`` or ``"oblique-30deg"``."""
    if name not in EXAMPLES:
        raise ModelError(f"unknown example pulse {name!r}; available: "
                         + ", ".join(map(repr, EXAMPLES)))
    return Path(str(resources.files(__package__).joinpath("pulses", EXAMPLES[name])))


def _shape(tau):
    """sin^3(pi tau) on [0, 1], zero outside; integral 4 / (3 pi)."""
    inside = (tau >= 0) & (tau <= 1)
    return np.where(inside, np.sin(np.pi * tau) ** 3, 0.0)


def _frontal():
    T, dv = 0.1, 48 / 3.6
    t = np.round(np.arange(-100, 1501) * 1e-4, 10)
    tau = t / T
    A = 3 * np.pi * dv / (4 * T)
    window = np.where((tau >= 0) & (tau <= 1), np.sin(np.pi * tau), 0.0)
    w = (_shape(tau) + 0.25 * window * np.sin(6 * np.pi * tau)
         + 0.06 * window * np.sin(80 * np.pi * tau))
    acc = np.zeros((t.size, 3))
    acc[:, 0] = -A * w
    notes = ["kanedyn example pulse 'frontal-48kmh' (SYNTHETIC, not measured):",
             "frontal barrier-like pulse, dv = 13.333 m/s (48 km/h) in 0.1 s, along -x;",
             "a = -A [sin^3(pi tau) + 0.25 sin(pi tau) sin(6 pi tau)"
             " + 0.06 sin(pi tau) sin(80 pi tau)], tau = t/0.1 s, A = 3 pi dv/(4 T);",
             "made by kanedyn/modeling/vehicle/_examples.py; vehicle axes, 10 kHz"]
    return t, acc, None, notes, "g"


def _oblique():
    T, dv = 0.12, 40 / 3.6
    t = np.round(np.arange(-100, 1701) * 1e-4, 10)
    tau = t / T
    A = 3 * np.pi * dv / (4 * T)
    ang = np.radians(30.0)
    acc = np.zeros((t.size, 3))
    acc[:, 0] = -A * np.cos(ang) * _shape(tau)
    acc[:, 1] = -A * np.sin(ang) * _shape(tau)
    rates = np.zeros((t.size, 3))
    rates[:, 2] = 0.5 * (1 - np.cos(np.pi * np.clip(tau, 0, 1))) / 2
    notes = ["kanedyn example pulse 'oblique-30deg' (SYNTHETIC, not measured):",
             "sin^3 pulse, dv = 11.111 m/s (40 km/h) in 0.12 s along -(cos 30, sin 30, 0)"
             " in vehicle axes;",
             "yaw rate wz = 0.5 rad/s (1 - cos(pi min(t,T)/T))/2;",
             "made by kanedyn/modeling/vehicle/_examples.py; vehicle axes, 10 kHz"]
    return t, acc, rates, notes, "m/s^2"


def make_example_pulses(directory):
    """Write the example pulse files into ``directory``; returns their paths."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in (("frontal-48kmh", _frontal), ("oblique-30deg", _oblique)):
        t, acc, rates, notes, unit = make()
        path = directory / EXAMPLES[name]
        write_pulse_csv(path, t, acc, rates, notes, acceleration_unit=unit,
                        rate_unit="deg/s")
        paths.append(path)
    return paths


if __name__ == "__main__":  # pragma: no cover
    target = sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parent / "pulses"
    for p in make_example_pulses(target):
        print(p)
