"""Normalize what a user hands to :func:`kanedyn.kane` into a :class:`ModelSpec`.

Accepted are the keywords of SymPy's ``KanesMethod`` / ``kanes_equations`` (with
SymPy's own spellings ``q_dependent``, ``u_dependent`` and ``forcelist`` as
aliases) or a ``sympy.physics.mechanics.System``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import sympy as sm
import sympy.physics.mechanics as me
from sympy.physics.mechanics.loads import _parse_load

from .._errors import ModelError
from .._expressions import as_expression
from ._inertial_elements import InertialElement
from .flexible import FlexibleBody
from ._physical import check_declared_bodies
from ..engine import name_of, time_derivative

__all__ = ["ModelSpec", "parse_model", "description_symbols"]

_ALIASES = {"q_dependent": "q_dep", "u_dependent": "u_dep", "forcelist": "loads",
            "inertial_frame": "frame"}
_KEYWORDS = ("frame", "q_ind", "u_ind", "kd_eqs", "q_dep", "u_dep",
             "configuration_constraints", "velocity_constraints",
             "acceleration_constraints", "u_auxiliary", "bodies", "loads", "kd_inputs")


@dataclass(frozen=True)
class ModelSpec:
    """A validated model description (SymPy objects, external symbols)."""

    frame: me.ReferenceFrame
    q_ind: tuple
    q_dep: tuple
    u_ind: tuple
    u_dep: tuple
    u_aux: tuple
    kd_eqs: tuple
    configuration_constraints: tuple
    velocity_constraints: tuple | None
    acceleration_constraints: tuple | None
    bodies: tuple
    loads: tuple  # of sympy.physics.mechanics Force / Torque
    potential_energy: sm.Expr | None
    contacts: tuple = ()  # of kanedyn Contact
    vector_constraints: tuple = ()  # of kanedyn VectorConstraint

    @property
    def q(self):
        return self.q_ind + self.q_dep

    @property
    def u(self):
        return self.u_ind + self.u_dep


def _as_tuple(value, role):
    if value is None:
        return ()
    if isinstance(value, (sm.Basic, me.Vector)) and not isinstance(value, sm.MatrixBase):
        return (value,)
    try:
        return tuple(value)
    except TypeError:
        raise ModelError(f"{role} must be a sequence, got {value!r}") from None


def _expressions(values, role):
    """SymPy expressions ``f = 0``; an equation ``Eq(a, b)`` becomes ``a - b``."""
    out = []
    for i, value in enumerate(_as_tuple(values, role)):
        if isinstance(value, sm.Equality):
            value = value.lhs - value.rhs
        elif isinstance(value, sm.core.relational.Relational) or isinstance(value, bool):
            raise ModelError(f"{role}[{i}] is {value!r}; give an expression f (meaning "
                             "f = 0) or an equation Eq(a, b)")
        out.append(as_expression(value, f"{role}[{i}]"))
    return tuple(out)


def _check_unique(groups):
    seen = {}
    for role, group in groups:
        for s in group:
            if s in seen:
                where = role if seen[s] == role else f"{seen[s]} and {role}"
                raise ModelError(f"{name_of(s)} is given twice (in {where})")
            seen[s] = role


def parse_model(*args, **kwargs):
    """Build a :class:`ModelSpec` from a ``System`` or KanesMethod keywords."""
    potential = kwargs.pop("potential_energy", None)
    contacts = _check_contacts(kwargs.pop("contacts", None))
    vector = _check_vector_constraints(kwargs.pop("constraints", None))
    if args and isinstance(args[0], me.System):
        if len(args) > 1:
            raise ModelError("kane(system) takes no further positional arguments")
        if kwargs:
            raise ModelError(
                f"kane(system) takes the model from the System; do not also pass "
                f"{sorted(kwargs)}")
        return replace(_from_system(args[0], potential, vector), contacts=contacts)
    if kwargs:
        leftover = set(kwargs) - set(_KEYWORDS) - set(_ALIASES)
        if leftover:
            raise ModelError(f"unknown keyword argument(s) {sorted(leftover)}; "
                             f"kane() accepts {', '.join(_KEYWORDS)}")
    for alias, name in _ALIASES.items():
        if alias in kwargs:
            if name in kwargs:
                raise ModelError(f"give either {alias} or {name}, not both")
            kwargs[name] = kwargs.pop(alias)
    for name, value in zip(("frame", "q_ind", "u_ind", "kd_eqs"), args):
        if name in kwargs:
            raise ModelError(f"{name} given both positionally and as a keyword")
        kwargs[name] = value
    if len(args) > 4:
        raise ModelError("kane() takes at most 4 positional arguments "
                         "(frame, q_ind, u_ind, kd_eqs); pass the rest as keywords")
    return replace(_build(potential=potential, vector_constraints=vector, **kwargs),
                   contacts=contacts)


def _check_vector_constraints(constraints):
    from ._vector_constraints import VectorConstraint
    constraints = _as_tuple(constraints, "constraints")
    for c in constraints:
        if not isinstance(c, VectorConstraint):
            raise ModelError("constraints must be kanedyn vector constraints "
                             f"(PointVelocity, AngularVelocity, ...), got {c!r}; give "
                             "scalar expressions as velocity_constraints")
    names = [n for c in constraints for n in c.names]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ModelError("constraint-force names must be unique; repeated: "
                         + ", ".join(duplicates))
    return constraints


def _check_contacts(contacts):
    from ._contacts import Contact
    contacts = _as_tuple(contacts, "contacts")
    for c in contacts:
        if not isinstance(c, Contact):
            raise ModelError(f"contacts must be kanedyn Contact objects, got {c!r}")
    names = [c.name for c in contacts]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ModelError(f"contact names must be unique; repeated: {', '.join(duplicates)}")
    return contacts


def _from_system(system, potential, vector_constraints=()):
    loads = tuple(system.loads) + tuple(
        load for act in system.actuators for load in act.to_loads())
    vel = system.velocity_constraints
    return _build(
        frame=system.frame, q_ind=system.q_ind, q_dep=system.q_dep,
        u_ind=system.u_ind, u_dep=system.u_dep, u_auxiliary=system.u_aux,
        kd_eqs=system.kdes,
        configuration_constraints=system.holonomic_constraints,
        velocity_constraints=vel if len(vel) else None,
        bodies=system.bodies, loads=loads, potential=potential,
        vector_constraints=vector_constraints)


def _build(frame=None, q_ind=None, u_ind=None, kd_eqs=None, q_dep=None, u_dep=None,
           configuration_constraints=None, velocity_constraints=None,
           acceleration_constraints=None, u_auxiliary=None, bodies=None, loads=None,
           potential=None, vector_constraints=(), kd_inputs=None):
    if not isinstance(frame, me.ReferenceFrame):
        raise ModelError(f"frame must be the inertial sympy ReferenceFrame, got {frame!r}")
    q_ind = _as_tuple(q_ind, "q_ind")
    q_dep = _as_tuple(q_dep, "q_dep")
    u_ind = _as_tuple(u_ind, "u_ind")
    u_dep = _as_tuple(u_dep, "u_dep")
    u_aux = _as_tuple(u_auxiliary, "u_auxiliary")
    if not q_ind and not q_dep:
        raise ModelError("no generalized coordinates given (q_ind)")
    if not u_ind:
        raise ModelError("no independent generalized speeds given (u_ind)")
    _check_unique([("q_ind", q_ind), ("q_dep", q_dep)])
    _check_unique([("u_ind", u_ind), ("u_dep", u_dep), ("u_auxiliary", u_aux)])

    kd_eqs = _expressions(kd_eqs, "kd_eqs")
    q = q_ind + q_dep
    if len(kd_eqs) != len(q):
        raise ModelError(
            f"there are {len(q)} generalized coordinates but {len(kd_eqs)} kinematic "
            "differential equations (kd_eqs); give one equation per coordinate")
    _check_kd_symbols(kd_eqs, q, u_ind + u_dep, u_aux, _as_tuple(kd_inputs, "kd_inputs"))

    config = _expressions(configuration_constraints, "configuration_constraints")
    if len(config) != len(q_dep):
        raise ModelError(
            f"there are {len(q_dep)} dependent coordinates (q_dep) but {len(config)} "
            "configuration constraints; their numbers must match")
    vel = velocity_constraints
    if vel is not None:
        vel = _expressions(vel, "velocity_constraints")
        if not vel:
            vel = None
    n_vector = sum(len(c) for c in vector_constraints)
    if vel is not None or n_vector:
        n_vel = len(vel or ()) + n_vector
        source = "velocity constraints" + (
            f" ({len(vel or ())} given, {n_vector} from vector constraints)"
            if n_vector else "")
    else:
        n_vel = len(config)
        source = "velocity constraints (derived from the configuration constraints)"
    if n_vel != len(u_dep):
        listed = "".join(f"; {c!r} gives {len(c)}" for c in vector_constraints)
        raise ModelError(
            f"there are {len(u_dep)} dependent speeds (u_dep) but {n_vel} {source}; "
            f"give one velocity constraint per dependent speed{listed}")
    acc = acceleration_constraints
    if acc is not None:
        acc = _expressions(acc, "acceleration_constraints")
        if len(acc) != len(u_dep):
            raise ModelError(
                f"there are {len(u_dep)} dependent speeds but {len(acc)} acceleration "
                "constraints")

    bodies = _as_tuple(bodies, "bodies")
    if not bodies:
        raise ModelError("no bodies given: pass bodies=[...] (RigidBody, Particle, "
                         "FlexibleBody or inertial elements)")
    for b in bodies:
        if not isinstance(b, (me.RigidBody, me.Particle, FlexibleBody, InertialElement)):
            raise ModelError(f"bodies must be RigidBody, Particle, FlexibleBody or inertial "
                             f"element (RateInertia, Inerter, AddedMass) objects; got {b!r}")
    check_declared_bodies(bodies)
    parsed_loads = []
    for load in _as_tuple(loads, "loads"):
        try:
            parsed = _parse_load(load)
        except (TypeError, ValueError) as exc:
            raise ModelError(f"cannot read load {load!r}: {exc}") from None
        if not isinstance(parsed.vector, me.Vector):
            raise ModelError(f"the load on {parsed.location} is not a Vector: "
                             f"{parsed.vector!r}")
        parsed_loads.append(parsed)

    if potential is None:
        total = sum((as_expression(getattr(b, "potential_energy", 0),
                                 f"the potential energy of {getattr(b, 'name', b)}")
                     for b in bodies), sm.S.Zero)
        potential = total if total != 0 else None
    return ModelSpec(frame, q_ind, q_dep, u_ind, u_dep, u_aux, kd_eqs, config, vel, acc,
                     bodies, tuple(parsed_loads),
                     as_expression(potential, "potential_energy") if potential is not None
                     else None,
                     vector_constraints=tuple(vector_constraints))


def _check_kd_symbols(kd_eqs, q, u, u_aux, inputs=()):
    """Every dynamic symbol of the kinematic equations must be declared (``inputs``:
    specified inputs they may contain, which drive first-order states)."""
    from sympy.physics.vector import dynamicsymbols as ds
    t = ds._t
    overlap = set(inputs) & (set(q) | set(u) | set(u_aux))
    if overlap:
        raise ModelError("kd_inputs holds " + ", ".join(sorted(name_of(s) for s in overlap))
                         + ", a generalized coordinate or speed; give specified inputs")
    declared = set(q) | set(u) | {time_derivative(s, t) for s in q} | set(inputs)
    for i, eq in enumerate(kd_eqs):
        found = me.find_dynamicsymbols(eq)
        extra = [s for s in found if s not in declared and s not in u_aux]
        if extra:
            names = ", ".join(sorted(name_of(s) for s in extra))
            raise ModelError(
                f"kinematic differential equation {i} ({eq}) contains {names}, which "
                "is neither a generalized coordinate, its derivative, nor a "
                "generalized speed; add the missing speed to u_ind or u_dep")
    used = set().union(*(me.find_dynamicsymbols(eq) for eq in kd_eqs))
    missing_q = [s for s in q if time_derivative(s, t) not in used]
    if missing_q:
        raise ModelError(
            "no kinematic differential equation contains the derivative of "
            + ", ".join(name_of(s) for s in missing_q))


# ------------------------------------------------- symbols of a description
class _SymbolCollector:
    """Constant symbols reachable from SymPy mechanics objects and kanedyn's own.

    Walks expressions, vectors, dyadics, bodies, points (their stored
    positions, velocities, accelerations and the points they refer to),
    frames (orientations, angular velocities and accelerations, and the
    frames they refer to), loads and kanedyn's contact and constraint
    objects (through their attributes).
    """

    def __init__(self):
        self.symbols = set()
        self._seen = set()
        self._nodes = set()  # ids of the expression nodes read (shared subtrees once;
        # the nodes live in the description for the whole visit)

    def visit(self, obj):
        stack = [obj]
        while stack:
            item = stack.pop()
            if item is None or isinstance(item, (str, bytes, bool, int, float, complex)):
                continue
            key = id(item)
            if key in self._seen:
                continue
            self._seen.add(key)
            stack.extend(self._children(item))

    def _read(self, expr):
        """Add the symbols of ``expr``, each distinct subexpression read once:
        ``free_symbols`` walks a shared subtree as often as it is referenced,
        which for the angular velocity of the last of 24 chained frames,
        composed by SymPy, took 10 s (chain3d n = 30: 80 s)."""
        stack = [expr]
        while stack:
            node = stack.pop()
            if id(node) in self._nodes:  # by identity: equality walks the trees
                continue
            self._nodes.add(id(node))
            if node.is_Symbol:
                self.symbols.add(node)
            else:
                stack.extend(node.args)

    def _children(self, item):
        if isinstance(item, sm.MatrixBase):
            for entry in item:
                self._read(entry)
            return ()
        if isinstance(item, sm.Basic):
            self._read(item)
            return ()
        if isinstance(item, me.Vector):
            return [part for matrix, frame in item.args for part in (matrix, frame)]
        if isinstance(item, me.Dyadic):
            return [part for coef, a, b in item.args for part in (coef, a, b)]
        if isinstance(item, me.ReferenceFrame):
            return [part for attr in ("_dcm_dict", "_ang_vel_dict", "_ang_acc_dict")
                    for pair in getattr(item, attr, {}).items() for part in pair]
        if isinstance(item, me.Point):
            return [part for attr in ("_pos_dict", "_vel_dict", "_acc_dict")
                    for pair in getattr(item, attr, {}).items() for part in pair]
        if isinstance(item, (me.RigidBody, me.Particle)):
            return [getattr(item, attr, None)
                    for attr in ("mass", "masscenter", "frame", "central_inertia",
                                 "potential_energy")]
        if isinstance(item, dict):
            return [part for pair in item.items() for part in pair]
        if isinstance(item, (tuple, list, set, frozenset)):
            return list(item)
        if type(item).__module__.startswith("kanedyn") and hasattr(item, "__dict__"):
            return [v for v in vars(item).values() if not callable(v)]
        return ()


def description_symbols(spec):
    """Every constant symbol of a model description, sorted by name.

    Collected from the bodies (masses, inertia dyadics, mass centres and
    frames), every point position, velocity and acceleration and every frame
    orientation and angular velocity reachable from the bodies, loads, the
    inertial frame and kanedyn's contacts and vector constraints, the loads,
    the kinematic differential equations, the constraints and the potential
    energy.  Time, functions of time and the surface-coordinate placeholders
    of contact gap functions are excluded.

    Parameters
    ----------
    spec : ModelSpec

    Returns
    -------
    tuple of sympy.Symbol
    """
    collector = _SymbolCollector()
    collector.visit([spec.frame, spec.bodies, spec.loads, spec.kd_eqs,
                     spec.configuration_constraints, spec.velocity_constraints,
                     spec.acceleration_constraints, spec.potential_energy,
                     spec.contacts, spec.vector_constraints])
    from ._contacts import SURFACE_COORDINATES  # placeholders of gap functions
    excluded = {me.dynamicsymbols._t, *SURFACE_COORDINATES}
    return tuple(sorted((s for s in collector.symbols if s not in excluded), key=str))
