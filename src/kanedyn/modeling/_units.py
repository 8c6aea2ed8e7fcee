r"""Units of generalized coordinates and speeds, read off the model description.

Parameters carry no units in SymPy, so only what the kinematics fix for certain
is used (SI throughout):

* a coordinate in the argument of a trigonometric function, with a numeric
  coefficient (``sin(q)``, ``cos(q1 + q2)``, every ``orient_axis``) is an
  angle, rad;
* a coordinate that a position's measure number contains with a numeric (or
  purely trigonometric) coefficient (``q * N.x``, ``q * cos(a) * A.y``) is a
  length, m;
* a speed or coordinate rate in an angular velocity with such a coefficient
  (``set_ang_vel(N, u * N.z)``) is an angular rate, rad/s; in a point
  velocity, a speed, m/s;
* the terms of one kinematic differential equation with such coefficients
  share a unit (``q' - u``: ``u`` has ``q``'s unit per second);
* a flexible body's modal coordinate has the unit of the nodal displacement
  its mode is scaled to: m where the mode's largest nodal translation is 1,
  rad for a mode without translation whose largest rotation is 1, and the
  constraint modes' ``ux``/``rx`` by their names.

A coordinate with contradicting evidence, or none, has unit ``None``
(unknown): a wrong unit on an axis is worse than none.  Declared units (for
example ``{q: "m"}`` from a model definition) override what is inferred for
their coordinate or speed and propagate through the kinematic equations.
"""

from __future__ import annotations

from collections import deque

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me
from sympy.core.function import AppliedUndef
from sympy.core.traversal import iterargs

from ..engine import is_small, name_of

__all__ = ["state_units", "constraint_units", "speed_unit"]

_TRIG = (sm.sin, sm.cos, sm.tan, sm.cot, sm.sec, sm.csc)
_MAX_NODES = 400  # larger expressions are not expanded (no evidence from them)


def speed_unit(unit):
    """The unit of the rate of a coordinate of unit ``unit`` (``None``: unknown)."""
    if unit is None:
        return None
    return "1/s" if unit in ("", "1") else f"{unit}/s"



def _dimensionless(coef):
    """A nonzero number, possibly times trigonometric functions (whose values are
    pure numbers): no parameter, coordinate or time outside them."""
    coef = sm.sympify(coef, strict=True)
    if coef == 0:
        return False
    bare = coef.replace(lambda e: isinstance(e, _TRIG), lambda e: sm.S.One)
    return not bare.free_symbols and not bare.atoms(AppliedUndef)


def _frames_and_points(frame, bodies, loads):
    """Every frame connected to ``frame`` and every point connected to the bodies."""
    frames = {frame}
    points = set()
    for b in bodies:
        f = getattr(b, "frame", None)
        if isinstance(f, me.ReferenceFrame):
            frames.add(f)
        for attr in ("masscenter", "point", "origin"):
            p = getattr(b, attr, None)
            if isinstance(p, me.Point):
                points.add(p)
    for load in loads:
        for where in (getattr(load, "point", None), getattr(load, "frame", None)):
            if isinstance(where, me.Point):
                points.add(where)
            elif isinstance(where, me.ReferenceFrame):
                frames.add(where)
    out_f, out_p = set(), set()
    queue = deque(frames)
    while queue:
        f = queue.popleft()
        if f in out_f:
            continue
        out_f.add(f)
        queue.extend(set(f._dcm_dict) | set(f._ang_vel_dict))
    queue = deque(points)
    while queue:
        p = queue.popleft()
        if p in out_p:
            continue
        out_p.add(p)
        queue.extend(p._pos_dict)
    return out_f, out_p


def _measures(vec):
    """Measure numbers of a SymPy Vector (one per frame component)."""
    if not isinstance(vec, me.Vector):
        return []
    return [m for matrix, _ in vec.args for m in matrix]


class _Evidence:
    """Units per symbol (a set of candidates) and equalities between symbols."""

    def __init__(self, symbols):
        self.seen = {s: set() for s in symbols}
        self.links = []

    def add(self, sym, unit):
        if sym in self.seen:
            self.seen[sym].add(unit)

    def _groups(self):
        """The symbols joined by :attr:`links`, a list per group."""
        parent = {s: s for s in self.seen}

        def find(s):
            while parent[s] != s:
                parent[s] = parent[parent[s]]
                s = parent[s]
            return s

        for a, b in self.links:
            parent[find(a)] = find(b)
        groups = {}
        for s in self.seen:
            groups.setdefault(find(s), []).append(s)
        return groups.values()

    def told(self, declared, wanted):
        """Whether each symbol of ``wanted`` shares its group with a declared one:
        :meth:`resolve` then takes the declared units, whatever the evidence."""
        return all(any(s in declared for s in members) or not any(s in wanted for s in members)
                   for members in self._groups())

    def resolve(self, declared):
        out = {}
        for members in self._groups():
            said = {declared[s] for s in members if s in declared}
            units = said if said else set().union(*(self.seen[s] for s in members))
            unit = next(iter(units)) if len(units) == 1 else None
            for s in members:
                out[s] = declared.get(s, unit)
        return out


def _linear_terms(expr, variables):
    """``[(variable, coefficient)]`` of the terms of ``expr`` linear in one variable."""
    expr = sm.sympify(expr, strict=True)
    if not is_small(expr, _MAX_NODES) or not expr.has(*variables):
        return []  # (without a variable, no term of the expansion holds one)
    out = []
    for term in sm.Add.make_args(sm.expand(expr)):
        nodes = set(iterargs(term))  # what term.has(v) looks through, read once
        present = [v for v in variables if v in nodes]
        if len(present) != 1:
            continue
        v = present[0]
        coef, rest = term.as_independent(v, as_Add=False)
        if rest == v and _dimensionless(coef):
            out.append((v, coef))
    return out


def _modal_units(body):
    """Unit of each modal coordinate of a flexible body (see the module docstring)."""
    member = body.member
    modes = np.asarray(member.modes, dtype=float)
    names = tuple(member.mode_names) or ("",) * modes.shape[1]
    out = []
    for j, name in enumerate(names):
        parts = name.split("_")
        if name.startswith("constraint_") and parts[-1] in ("ux", "uy", "uz", "rx", "ry",
                                                             "rz"):
            out.append("m" if parts[-1][0] == "u" else "rad")
            continue
        block = modes[:, j].reshape(-1, 6)
        trans = np.linalg.norm(block[:, :3], axis=1).max(initial=0.0)
        rot = np.linalg.norm(block[:, 3:], axis=1).max(initial=0.0)
        if abs(trans - 1.0) < 1e-9:
            out.append("m")
        elif trans == 0.0 and abs(rot - 1.0) < 1e-9:
            out.append("rad")
        else:
            out.append(None)
    return out


def state_units(spec, declared=None):
    """Units of the coordinates and speeds of a model description.

    Parameters
    ----------
    spec : ModelSpec
    declared : dict, optional
        ``{coordinate or speed (symbol or name): unit}`` that override the
        inference (a speed's unit may also be given through its coordinate).

    Returns
    -------
    dict
        ``{state name: unit or None}`` for ``spec.q + spec.u``: coordinates
        ``"rad"``/``"m"``, speeds ``"rad/s"``/``"m/s"`` (declared units as
        given); ``None`` where the description does not tell.
    """
    t = me.dynamicsymbols._t
    q, u = tuple(spec.q), tuple(spec.u) + tuple(spec.u_aux)
    qdot = {qi.diff(t): qi for qi in q}
    by_name = {name_of(s): s for s in q + u}
    declared_base, declared_exact = {}, {}
    for key, unit in (declared or {}).items():
        sym = by_name.get(key) if isinstance(key, str) else key
        if sym in q:
            declared_base[sym] = unit
        elif sym in u:
            declared_exact[sym] = unit
    # speeds are tracked by the unit of their time integral ("m" for m/s)
    ev = _Evidence(q + u)
    for eq in spec.kd_eqs:
        terms = [qdot.get(var, var) for var, _ in _linear_terms(eq, list(qdot) + list(u))]
        ev.links.extend(zip(terms, terms[1:]))
    # a unit read from the kinematics decides nothing where each coordinate, and each
    # speed not declared itself, is joined to a declared one: they are not read then
    # (the flexible-blade OC3 spar's many node points: a third of its run's plot)
    if not ev.told(declared_base, set(q) | (set(u) - set(declared_exact))):
        _read_kinematics(spec, ev, q, u, qdot)
    base = ev.resolve(declared_base)
    out = {}
    for s in q:
        out[name_of(s)] = base[s]
    for s in u:
        out[name_of(s)] = declared_exact.get(s, speed_unit(base[s]))
    return out


def _read_kinematics(spec, ev, q, u, qdot):
    """Add to ``ev`` the units that the kinematics of ``spec`` tell (module text)."""
    frames, points = _frames_and_points(spec.frame, spec.bodies, spec.loads)
    qset = set(q)

    def scan_trig(expr):
        if not is_small(expr, _MAX_NODES):
            return
        for call in expr.atoms(*_TRIG):
            arg = call.args[0]
            for qi in arg.atoms(AppliedUndef) & qset:
                d = arg.diff(qi)
                if d != 0 and d.is_number:
                    ev.add(qi, "rad")

    for f in frames:
        for dcm in f._dcm_dict.values():
            for e in dcm:
                scan_trig(e)
        for w in f._ang_vel_dict.values():
            for m in _measures(w):
                for var, _ in _linear_terms(m, list(u) + list(qdot)):
                    ev.add(qdot.get(var, var), "rad")
    for p in points:
        for r in p._pos_dict.values():
            for m in _measures(r):
                scan_trig(m)
                for var, _ in _linear_terms(m, q):
                    ev.add(var, "m")
        for v in p._vel_dict.values():
            for m in _measures(v):
                for var, _ in _linear_terms(m, list(u) + list(qdot)):
                    ev.add(qdot.get(var, var), "m")
    for expr in tuple(spec.configuration_constraints) + tuple(spec.kd_eqs):
        scan_trig(expr)
    from .flexible import FlexibleBody
    for body in spec.bodies:
        if isinstance(body, FlexibleBody):
            for qi, unit in zip(body.q, _modal_units(body)):
                if unit is not None:
                    ev.add(qi, unit)


_DIMENSIONS = {"m": (1, 0), "rad": (0, 0), "m/s": (1, -1), "rad/s": (0, -1)}


def _length_parameters(spec):
    """Parameters that a position's measure number has with a pure-number coefficient."""
    _, points = _frames_and_points(spec.frame, spec.bodies, spec.loads)
    out = set()
    for p in points:
        for r in p._pos_dict.values():
            for m in _measures(r):
                if not is_small(m, _MAX_NODES):
                    continue
                params = [s for s in m.free_symbols if s != me.dynamicsymbols._t]
                for var, _ in _linear_terms(m, params):
                    out.add(var)
    return out


class _Dimensions:
    """Dimensions (length and time exponents, and whether an angle enters) of
    expressions, by a walk of the tree; ``None`` where they cannot be told.

    The terms of a sum share their dimensions, so a sum takes those of the terms
    that tell (``None`` when two terms disagree).
    """

    def __init__(self, known, lengths):
        self.known = known  # {symbol or derivative: unit}
        self.lengths = lengths
        self.memo = {}

    def __call__(self, e):
        found = self.memo.get(e, False)
        if found is False:
            found = self.memo[e] = self._walk(e)
        return found

    def _walk(self, e):
        if e.is_number:
            return (0, 0, False)
        if e in self.known:
            unit = self.known[e]
            if unit not in _DIMENSIONS:
                return None
            length, time = _DIMENSIONS[unit]
            return (length, time, length == 0)
        if e in self.lengths:
            return (1, 0, False)
        if isinstance(e, _TRIG):
            return (0, 0, False)
        if e.is_Mul:
            length, time, angle = 0, 0, False
            for factor in e.args:
                d = self(factor)
                if d is None:
                    return None
                length, time, angle = length + d[0], time + d[1], angle or d[2]
            return (length, time, angle)
        if e.is_Add:
            seen = {}
            for term in e.args:
                d = self(term)
                if d is not None:
                    seen.setdefault(d[:2], False)
                    seen[d[:2]] |= d[2]
            if len(seen) != 1:
                return None
            (length, time), angle = next(iter(seen.items()))
            return (length, time, angle)
        if e.is_Pow and e.exp.is_Rational:
            d = self(e.base)
            if d is None:
                return None
            length, time = d[0] * e.exp, d[1] * e.exp
            if not (length.is_integer and time.is_integer):
                return None
            return (int(length), int(time), d[2])
        return None


def _unit_name(dims):
    if dims is None:
        return None
    length, time, angle = dims
    return {(1, 0): "m", (1, -1): "m/s", (0, 0): "rad" if angle else None,
            (0, -1): "rad/s" if angle else None}.get((length, time))


def constraint_units(spec, units):
    """Units of the configuration and velocity constraints (``None``: unknown).

    A constraint has the unit of its terms: products and powers of pure
    numbers (and trigonometric functions), coordinates, speeds and coordinate
    rates of known unit and length parameters (those a position has with a
    pure-number coefficient, such as ``l`` in ``l * A.x``).  It is unknown when
    no term tells or two terms disagree.

    Returns
    -------
    (list, list)
        Units of the configuration constraints and of the velocity constraints.
    """
    t = me.dynamicsymbols._t
    q, u = tuple(spec.q), tuple(spec.u)
    known = {s: units.get(name_of(s)) for s in q + u}
    known.update({qi.diff(t): speed_unit(units.get(name_of(qi))) for qi in q})
    dims = _Dimensions(known, _length_parameters(spec))

    def unit_of(expr):
        return _unit_name(dims(sm.sympify(expr, strict=True)))

    config = [unit_of(h) for h in spec.configuration_constraints]
    if not spec.velocity_constraints and not spec.vector_constraints:
        velocity = [speed_unit(c) for c in config]  # the rates of the configuration's
    else:
        velocity = [unit_of(c) for c in (spec.velocity_constraints or ())]
    return config, velocity
