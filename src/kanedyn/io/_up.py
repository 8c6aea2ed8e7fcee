r"""Which inertial direction the viewer draws upwards, and why.

In this order:

1. the user's word: ``up="y"``, ``"-z"``, ... or three numbers;
2. the model's declared gravity (``ModelDefinition.gravity``: URDF and MJCF
   models, built-in models that declare it): up is opposite to it;
3. the model's weights: loads at a body's mass centre that are constant in
   the inertial frame and, where the mass is a symbol, proportional to it
   (:math:`-m g\,\hat n`), and flexible bodies' ``gravity``; up is opposite
   to their sum per unit mass.  Other forces (buoyancy, springs, thrust) do
   not count, so that a floating body whose buoyancy exceeds its weight is
   still drawn the right way up;
4. otherwise +z, and the note says that nothing told.

Directions within 10 degrees of an inertial axis are snapped to it.
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import OptionError
from ..modeling import FlexibleBody

__all__ = ["up_direction", "AXES"]

#: the axis names ``up`` accepts
AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1),
        "-x": (-1, 0, 0), "-y": (0, -1, 0), "-z": (0, 0, -1)}
_SNAP = np.cos(np.radians(10))


def _components(vector, frame):
    """Measure numbers of ``vector`` in ``frame`` when it is written in that frame
    only (a weight is), else ``None``."""
    if not isinstance(vector, me.Vector):
        return None
    if any(f != frame for _, f in vector.args):
        return None
    return vector.to_matrix(frame) if vector.args else None


def _per_unit_mass(vector, mass, frame):
    """The acceleration ``vector / mass`` when ``vector`` is a weight of ``mass``."""
    comps = _components(vector, frame)
    if comps is None or comps.has(me.dynamicsymbols._t) or comps == sm.zeros(3, 1):
        return None
    mass = sm.sympify(mass, strict=True)
    per_mass = (comps / mass).applyfunc(sm.cancel)
    if mass.free_symbols and (per_mass.has(*mass.free_symbols)
                              or not all(c == 0 or c.has(*mass.free_symbols) for c in comps)):
        return None  # a force at the mass centre that is not m times a field
    return per_mass


def _weights(eom):
    """``[(body name, acceleration (3,) sympy)]`` of the weights in the loads."""
    N = eom.frame
    centres = {}
    for body in eom.bodies:
        centre = getattr(body, "masscenter", None)
        if isinstance(body, (me.RigidBody, me.Particle)) and centre is not None:
            centres.setdefault(centre, []).append(body)
    out = []
    for load in eom.loads:
        location, vector = load[0], load[1]
        for body in centres.get(location, ()):
            g = _per_unit_mass(vector, body.mass, N)
            if g is not None:
                out.append((body.name, g))
                break
    for body in eom.bodies:
        if isinstance(body, FlexibleBody) and body.gravity is not None:
            g = _components(body.gravity, N)
            if g is not None:
                out.append((body.name, g))
    return out


def _numbers(vectors, values):
    total = np.zeros(3)
    for g in vectors:
        g = g.xreplace({s: values[str(s)] for s in g.free_symbols if str(s) in values})
        try:
            total += np.array([float(c) for c in g])
        except TypeError:
            return None  # a parameter without a value
    return total


def _snapped(v):
    i = int(np.argmax(np.abs(v)))
    if abs(v[i]) > _SNAP:
        snapped = np.zeros(3)
        snapped[i] = np.sign(v[i])
        return snapped
    return v


def _against(gravity):
    norm = np.linalg.norm(gravity) if gravity is not None else 0.0
    if not np.isfinite(norm) or norm == 0:
        return None
    return _snapped(-np.asarray(gravity, dtype=float) / norm)


def up_direction(up, eom, values):
    """The unit vector drawn upwards, in inertial components, and a note saying why.

    Parameters
    ----------
    up : "auto", "x", "y", "z", "-x", "-y", "-z" or 3 numbers
        The user's word; ``"auto"`` asks the model (see the module docstring).
    eom : EquationsOfMotion
    values : dict
        ``{parameter name: value}`` of the numerical model.

    Returns
    -------
    up : ndarray, shape (3,)
    note : str
        Why: ``"given"``, ``"against the model's declared gravity"``,
        ``"against gravity: the weights of ..."`` or that nothing told.
    """
    if isinstance(up, str) and up != "auto":
        if up not in AXES:
            raise OptionError(f"up must be 'auto', one of {', '.join(AXES)} or 3 numbers, "
                              f"not {up!r}")
        return np.array(AXES[up], dtype=float), "given"
    if not isinstance(up, str):
        try:
            v = np.asarray(up, dtype=float)
        except (TypeError, ValueError):
            v = np.zeros(0)
        if v.shape != (3,) or not np.all(np.isfinite(v)) or not np.linalg.norm(v):
            raise OptionError(f"up must be 'auto', an axis name or 3 numbers, not {up!r}")
        return v / np.linalg.norm(v), "given"
    declared = getattr(eom, "_declared_gravity", None)
    v = _against(declared)
    if v is not None:
        return v, "against the model's declared gravity"
    weights = _weights(eom)
    v = _against(_numbers([g for _, g in weights], values)) if weights else None
    if v is not None:
        names = list(dict.fromkeys(name for name, _ in weights))
        shown = ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4
                                        else "")
        return v, f"against gravity: the weights of {shown}"
    return np.array([0.0, 0.0, 1.0]), ("the model declares no gravity and has no weights; "
                                       "give up=... to choose")
