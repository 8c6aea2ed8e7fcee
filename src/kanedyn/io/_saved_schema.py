"""Objects in saved files: the classes a file may hold and what each may contain.

Two routes, per class:

- **constructor** (:data:`NAMED_TUPLES`): SymPy's loads and inertia
  (``Force``, ``Torque``, ``Inertia``) are named tuples whose constructor
  only checks and stores its fields; the decoder calls it on fields checked
  by type first.
- **schema** (:data:`OBJECTS`): every other object.  Their constructors
  cannot rebuild them from what was saved: kanedyn's engine, model
  description and equations are *results* (a constructor takes a model and
  derives), and SymPy's frames, points, bodies, vectors and dyadics are
  built by methods that compute (``orient``, ``set_vel``, ``locatenew``),
  refer to each other in cycles (a frame's unit vectors refer to the frame),
  and have property setters that parse text (``RigidBody.mass`` sympifies a
  string, which runs it as Python).  Such an object is created empty
  (``object.__new__``), and each attribute is written straight into its
  ``__dict__`` or its ``__slots__`` member, so no setter, property or other
  descriptor runs.  Its schema names every attribute it may have and the
  value each may hold (:class:`Spec`); the values are checked once the
  whole file is rebuilt (containers are complete only then), before
  anything uses them.

A name a schema does not list, or a value of another type, is an error that
names the file, the node, the class and the attribute (and saving such an
object fails, naming it, so a file that was written can be read).
"""

from __future__ import annotations

import functools
import importlib
import sys
import types

import numpy as np

from ._saved_sympy import described

__all__ = ["Spec", "OBJECTS", "NAMED_TUPLES", "METHODS", "resolve", "storage",
           "class_path", "is_kind", "is_sympy", "sympy_classes"]


def class_path(cls):
    """``module.qualname`` of ``cls``: how a file names a class."""
    return f"{cls.__module__}.{cls.__qualname__}"


@functools.lru_cache(maxsize=4096)
def _is_subclass(cls, paths):
    return any(class_path(k) in paths for k in cls.__mro__)


def is_kind(value, paths):
    """Whether ``value`` is an instance of a class named in ``paths`` (a
    frozenset; compared by name along its MRO, so that checking imports
    nothing)."""
    return _is_subclass(type(value), paths)


_SYMPY = []


def sympy_classes():
    """``(Basic, MatrixBase, Expr, UndefinedFunction)`` of SymPy, or ``None``
    before SymPy is imported (no SymPy object exists then; checking a value
    imports nothing)."""
    if not _SYMPY:
        if "sympy" not in sys.modules:
            return None
        import sympy
        from sympy.core.function import UndefinedFunction
        _SYMPY.append((sympy.Basic, sympy.MatrixBase, sympy.Expr, UndefinedFunction))
    return _SYMPY[0]


@functools.lru_cache(maxsize=4096)  # bounded: SymPy makes a class per function name
def _is_sympy_type(cls, basic, matrix):
    return issubclass(cls, basic) and not issubclass(cls, matrix)


def is_sympy(value):
    """Whether ``value`` is a SymPy object other than a matrix."""
    classes = sympy_classes()
    return classes is not None and _is_sympy_type(type(value), classes[0], classes[1])


def _is_matrix(value):
    classes = sympy_classes()
    return classes is not None and isinstance(value, classes[1])


class Spec:
    """What a value may be; :meth:`problem` says what is wrong, or ``None``."""

    __slots__ = ("text",)

    def __init__(self, text):
        self.text = text

    def problem(self, value, memo):
        """``None`` when ``value`` fits; otherwise the misfit, worded to follow
        the value's name (``"is a str, not a SymPy expression"``, ``"has item
        2 that is ..."``).  ``memo`` holds the ``(id(container), id(spec))``
        already checked (a container shared by many objects is checked once)."""
        raise NotImplementedError

    def __repr__(self):
        return f"<{self.text}>"


class _Leaf(Spec):
    """A value for which ``test(value)`` holds."""

    __slots__ = ("test",)

    def __init__(self, text, test):
        super().__init__(text)
        self.test = test

    def problem(self, value, memo):
        return None if self.test(value) else f"is {described(value)}, not {self.text}"


def _exact(text, *types_):
    return _Leaf(text, lambda value: type(value) in types_)


def _instance(text, *paths):
    paths = frozenset(paths)
    return _Leaf(text, lambda value: is_kind(value, paths))


class _Container(Spec):
    """A container of type ``kind`` whose parts fit their specs (checked once
    per container and spec, however many objects share it)."""

    __slots__ = ("kind",)

    def __init__(self, text, kind):
        super().__init__(text)
        self.kind = kind

    def _fits(self, value):
        return type(value) is self.kind

    def _parts(self, value):
        """``(spec, part, what the part is)`` of each part of ``value``."""
        raise NotImplementedError

    def problem(self, value, memo):
        if not self._fits(value):
            return f"is {described(value)}, not {self.text}"
        key = (id(value), id(self))
        if key in memo:
            return None
        for spec, part, where in self._parts(value):
            found = spec.problem(part, memo)
            if found is not None:
                return f"has {where} that {found}"
        memo.add(key)
        return None


class _Items(_Container):
    """A tuple, list, set or frozenset (``kind``) of items fitting ``item``."""

    __slots__ = ("item",)

    def __init__(self, kind, item):
        super().__init__(f"a {kind.__name__} of {item.text}", kind)
        self.item = item

    def problem(self, value, memo):
        test = getattr(self.item, "test", None)  # most items are leaves: one pass
        if test is not None and type(value) is self.kind and all(map(test, value)):
            return None
        return super().problem(value, memo)

    def _parts(self, value):
        ordered = self.kind in (tuple, list)
        return ((self.item, v, f"item {i}" if ordered else "an item")
                for i, v in enumerate(value))


class _Fields(_Container):
    """A tuple of exactly these items."""

    __slots__ = ("items",)

    def __init__(self, *items):
        super().__init__("(" + ", ".join(i.text for i in items) + ")", tuple)
        self.items = items

    def _fits(self, value):
        return type(value) is tuple and len(value) == len(self.items)

    def _parts(self, value):
        return ((spec, v, f"item {i}") for i, (spec, v) in enumerate(zip(self.items, value)))


class _Dict(_Container):
    __slots__ = ("key", "value")

    def __init__(self, key, value):
        super().__init__(f"a dict of {key.text} to {value.text}", dict)
        self.key, self.value = key, value

    def _parts(self, value):
        for k, v in value.items():
            yield self.key, k, "a key"
            yield self.value, v, "a value"


class _Either(Spec):
    __slots__ = ("options",)

    def __init__(self, *options):
        super().__init__(" or ".join(o.text for o in options))
        self.options = options

    def problem(self, value, memo):
        deeper = None  # the misfit inside an option of the right type, if any
        for option in self.options:
            found = option.problem(value, memo)
            if found is None:
                return None
            if not found.startswith("is "):
                deeper = found
        return deeper or f"is {described(value)}, not {self.text}"


def _method(path, name):
    """A bound method ``owner.name``, its owner of the class ``path``."""
    return _Leaf(f"the method {path.rpartition('.')[2]}.{name}", lambda value: (
        type(value) is types.MethodType and value.__name__ == name
        and class_path(type(value.__self__)) == path))


def _partial(method):
    """``functools.partial`` of ``method`` (its arguments are checked when the
    decoder builds it, see :data:`METHODS`)."""
    return _Leaf(f"a partial of {method.text}", lambda value: (
        type(value) is functools.partial and method.test(value.func)))


# ---------------------------------------------------------------- the specs
def _tuple(item):
    return _Items(tuple, item)


def _list(item):
    return _Items(list, item)


def _optional(spec):
    return _Either(NONE, spec)


NONE = _exact("None", type(None))
BOOL = _exact("a boolean", bool)
INT = _exact("a whole number", int)
FLOAT = _exact("a float", float)
STR = _exact("a string", str)
COMPLEX = _exact("a complex number", complex)
ARRAY = _exact("a NumPy array", np.ndarray)
EXPR = _Leaf("a SymPy expression", is_sympy)
MATRIX = _Leaf("a SymPy matrix", _is_matrix)
RANDOM = _exact("a random-number generator", __import__("random").Random)
EXPRS = _tuple(EXPR)
#: a tuple or list of expressions (the blocks of flexible bodies keep both)
_SEQUENCE = _Either(_tuple(EXPR), _list(EXPR))
STRS = _tuple(STR)

_VECTOR = "sympy.physics.vector."
_MECHANICS = "sympy.physics.mechanics."
FRAME = _instance("a ReferenceFrame", _VECTOR + "frame.ReferenceFrame")
POINT = _instance("a Point", _VECTOR + "point.Point")
VECTOR = _instance("a Vector", _VECTOR + "vector.Vector")
DYADIC = _instance("a Dyadic", _VECTOR + "dyadic.Dyadic")
RIGID_OR_PARTICLE = _instance("a RigidBody or Particle", _MECHANICS + "rigidbody.RigidBody",
                              _MECHANICS + "particle.Particle")
_ENGINE = "kanedyn.engine."
_MODELING = "kanedyn.modeling."
_FORMULATIONS = "kanedyn.formulations."
PROGRAM = _instance("a Program", _ENGINE + "_program.Program")
TABLE = _instance("a SymbolTable", _ENGINE + "_symbols.SymbolTable")
BODY = _instance("a body (RigidBody, Particle, FlexibleBody or inertial element)",
                 _MECHANICS + "rigidbody.RigidBody", _MECHANICS + "particle.Particle",
                 _MODELING + "flexible._body.FlexibleBody",
                 _MODELING + "_inertial_elements.InertialElement")
LOAD = _instance("a Force or Torque", _MECHANICS + "loads.Force", _MECHANICS + "loads.Torque")
CONTACT = _instance("a Contact", _MODELING + "_contacts.Contact")
SURFACE = _instance("a contact surface", _MODELING + "_contacts.Surface")
PARTIALS = _instance("a PartialVelocities", _ENGINE + "_kinematics.PartialVelocities")
ACTION = _instance("a ConstraintAction", _MODELING + "_vector_constraints.ConstraintAction")

_SURFACE = {"frame": FRAME, "origin": POINT, "gap": EXPR, "name": STR}
_INERTIAL = {"name": STR, "inertia": MATRIX}
_VECTOR_CONSTRAINT = {"names": STRS, "_what": STR}

#: ``{class path: {attribute: spec}}``: the objects rebuilt by schema
OBJECTS = {
    # SymPy's vectors, frames, points and bodies
    _VECTOR + "vector.Vector": {"args": _list(_Fields(MATRIX, FRAME))},
    _VECTOR + "dyadic.Dyadic": {"args": _list(_Fields(EXPR, VECTOR, VECTOR))},
    _VECTOR + "frame.ReferenceFrame": {
        "name": STR, "index": _optional(INT), "_cur": INT, "indices": _list(STR),
        "str_vecs": _list(STR), "pretty_vecs": _list(STR), "latex_vecs": _list(STR),
        "_x": VECTOR, "_y": VECTOR, "_z": VECTOR, "varlist": EXPRS,
        "_var_dict": _Dict(_Fields(FRAME, BOOL), _Dict(EXPR, EXPR)),
        "_dcm_dict": _Dict(FRAME, MATRIX), "_dcm_cache": _Dict(FRAME, MATRIX),
        "_ang_vel_dict": _Dict(FRAME, VECTOR), "_ang_acc_dict": _Dict(FRAME, VECTOR),
        "_dlist": _list(_Either(_Dict(FRAME, MATRIX), _Dict(FRAME, VECTOR)))},
    _VECTOR + "point.Point": {
        "name": STR, "_pos_dict": _Dict(POINT, VECTOR), "_vel_dict": _Dict(FRAME, VECTOR),
        "_acc_dict": _Dict(FRAME, VECTOR),
        "_pdlist": _list(_Either(_Dict(POINT, VECTOR), _Dict(FRAME, VECTOR)))},
    _MECHANICS + "particle.Particle": {
        "_name": STR, "_mass": EXPR, "_masscenter": POINT, "_potential_energy": EXPR,
        "points": _list(POINT)},
    _MECHANICS + "rigidbody.RigidBody": {
        "_name": STR, "_mass": EXPR, "_masscenter": POINT, "_potential_energy": EXPR,
        "points": _list(POINT), "_frame": FRAME,
        "_inertia": _instance("an Inertia", _MECHANICS + "inertia.Inertia"),
        "_central_inertia": DYADIC},
    # kanedyn's engine
    _ENGINE + "_program.Program": {
        "t": EXPR, "_defs": _Dict(EXPR, EXPR), "_index": _Dict(EXPR, INT),
        "_order": _list(EXPR), "_cons": _Dict(EXPR, EXPR),
        "_parents": _Dict(EXPR, _Items(frozenset, EXPR)),
        "_deps": _Dict(EXPR, _Items(frozenset, EXPR)),
        "_base_dt": _Dict(EXPR, _Either(EXPR, _partial(_method(
            _ENGINE + "_symbols.SymbolTable", "_specified")))),
        "_dt_hint": _Dict(EXPR, EXPR), "_dt": _Dict(EXPR, EXPR),
        "_diff": _Dict(EXPR, _Dict(EXPR, EXPR)),
        "_subs": _Dict(_Items(frozenset, _Fields(EXPR, EXPR)), _Dict(EXPR, EXPR)),
        "_explicit": _Dict(EXPR, EXPR),
        "_shadow": _Dict(INT, _Dict(EXPR, COMPLEX)),
        "_samplers": _Dict(INT, _instance("a sampler", _ENGINE + "_program._Sampler")),
        "_analytic": _Dict(EXPR, BOOL), "_varying_set": _optional(_Items(frozenset, EXPR))},
    _ENGINE + "_program._Sampler": {"rng": RANDOM, "cache": _Dict(EXPR, COMPLEX)},
    _ENGINE + "_symbols.SymbolTable": {
        "t": EXPR, "q_ext": EXPRS, "u_ext": EXPRS, "u_aux_ext": EXPRS, "q": EXPRS,
        "u": EXPRS, "u_aux": EXPRS, "udot": EXPRS, "qdot_raw": EXPRS,
        "_int": _Dict(EXPR, EXPR), "_ext": _Dict(EXPR, EXPR),
        "_qdot_value": _Dict(EXPR, EXPR), "_replaced": _Dict(EXPR, STR),
        "specified": _Dict(EXPR, EXPR),
        "on_new_specified": _optional(_method(_ENGINE + "_program.Program", "declare"))},
    _ENGINE + "_kinematics.Kinematics": {
        "prog": PROGRAM, "table": TABLE, "N": FRAME, "_dcm": _Dict(FRAME, MATRIX),
        "_omega": _Dict(FRAME, EXPRS), "_vel": _Dict(POINT, EXPRS),
        "_position_trees": _Dict(POINT, _Fields(_Dict(POINT, _optional(POINT)),
                                                _Dict(POINT, EXPRS))),
        "_resolving": _Items(set, POINT), "_pending_hints": _list(FRAME),
        "_dcm_parent": _Dict(FRAME, _optional(FRAME)),
        "_omega_parent": _Dict(FRAME, _optional(FRAME)), "_body_frame": _Dict(POINT, FRAME)},
    _ENGINE + "_kinematics.PartialVelocities": {
        "prog": PROGRAM, "vector": EXPRS, "speeds": EXPRS,
        "fixed": _Dict(EXPR, _Either(EXPR, INT, FLOAT)),
        "_formed": _Dict(INT, EXPRS), "_leaves": _optional(_Items(frozenset, EXPR))},
    # kanedyn's model description
    _MODELING + "_spec.ModelSpec": {
        "frame": FRAME, "q_ind": EXPRS, "q_dep": EXPRS, "u_ind": EXPRS, "u_dep": EXPRS,
        "u_aux": EXPRS, "kd_eqs": EXPRS, "configuration_constraints": EXPRS,
        "velocity_constraints": _optional(EXPRS), "acceleration_constraints": _optional(EXPRS),
        "bodies": _tuple(BODY), "loads": _tuple(LOAD), "potential_energy": _optional(EXPR),
        "contacts": _tuple(CONTACT),
        "vector_constraints": _tuple(_instance(
            "a vector constraint", _MODELING + "_vector_constraints.VectorConstraint"))},
    _MODELING + "_contacts.Contact": {
        "name": STR, "point": POINT, "surface": SURFACE, "mu_k": EXPR, "mu_s": EXPR,
        "viscous": EXPR, "restitution": _optional(EXPR), "kind": STR, "restitution_law": STR},
    _MODELING + "_contacts.Plane": _SURFACE,
    _MODELING + "_contacts.ImplicitSurface": {  # a cone (modeling._limits) adds its shape
        **_SURFACE, "axis": VECTOR, "limit": EXPR, "radius": EXPR},
    _MODELING + "_contacts.Sphere": {**_SURFACE, "radius": EXPR, "inside": BOOL},
    _MODELING + "_contacts.Ellipsoid": {**_SURFACE, "axes": EXPRS, "inside": BOOL},
    _MODELING + "_inertial_elements.RateInertia": {**_INERTIAL, "rates": EXPRS},
    _MODELING + "_actuators._ActuatorRate": {**_INERTIAL, "rates": EXPRS},
    _MODELING + "_inertial_elements.Inerter": {
        **_INERTIAL, "point_a": POINT, "point_b": POINT, "frame": FRAME},
    _MODELING + "_inertial_elements.AddedMass": {
        **_INERTIAL, "point": POINT, "body_frame": FRAME, "frame": FRAME},
    _MODELING + "_vector_constraints.ConstraintAction": {
        "kind": STR, "location": POINT, "vector": EXPRS,
        "body": _optional(RIGID_OR_PARTICLE), "ground": BOOL},
    _MODELING + "_vector_constraints.PointVelocity": {
        **_VECTOR_CONSTRAINT, "point": POINT, "directions": _list(VECTOR),
        "relative_to": _Either(NONE, RIGID_OR_PARTICLE, _Fields(FRAME, POINT)),
        "_relative": _optional(_Fields(_optional(FRAME), POINT, _optional(RIGID_OR_PARTICLE))),
        "body": _optional(RIGID_OR_PARTICLE)},
    _MODELING + "_vector_constraints.AngularVelocity": {
        **_VECTOR_CONSTRAINT, "frame": FRAME, "body": _optional(RIGID_OR_PARTICLE),
        "relative_frame": _optional(FRAME), "relative_body": _optional(RIGID_OR_PARTICLE),
        "directions": _list(VECTOR)},
    _MODELING + "_vector_constraints.OrthogonalVelocities": {
        "names": STRS, "points": _Fields(POINT, POINT),
        "bodies": _tuple(_optional(RIGID_OR_PARTICLE))},
    _MODELING + "flexible._body.FlexibleBody": {
        "name": STR, "frame": FRAME, "origin": POINT,
        "member": _instance("a ReducedMember", _MODELING + "flexible._reduced.ReducedMember"),
        "q": EXPRS, "u": EXPRS, "stiffening": BOOL, "gravity": _optional(VECTOR),
        "invariants": _instance("an InertiaInvariants",
                                _MODELING + "flexible._body.InertiaInvariants"),
        "damping": ARRAY, "_points": _Dict(INT, POINT), "_frames": _Dict(INT, FRAME)},
    _MODELING + "flexible._body.InertiaInvariants": {
        "M0": ARRAY, "M1": ARRAY, "M2": ARRAY, "mass": FLOAT, "first_moment": _tuple(ARRAY),
        "stiffness": ARRAY, "n_modes": INT},
    _MODELING + "flexible._reduced.ReducedMember": {
        "name": STR, "nodes": ARRAY, "mass_matrix": ARRAY, "stiffness_matrix": ARRAY,
        "modes": ARRAY, "second_order": _optional(ARRAY), "reference_node": INT,
        "interface_nodes": _tuple(INT), "mode_names": STRS,
        "full_frequencies": _optional(ARRAY), "reduced_frequencies": _optional(ARRAY),
        "description": STR, "damping": _optional(ARRAY)},
    _MODELING + "_physical.BodyValues": {
        "name": STR, "kind": STR, "mass": _optional(FLOAT), "moments": _optional(ARRAY)},
    # kanedyn's equations of motion
    _FORMULATIONS + "_kane.BodyTerms": {
        "body": RIGID_OR_PARTICLE, "velocity": EXPRS, "omega": EXPRS,
        "partial_velocities": PARTIALS, "partial_angular_velocities": PARTIALS},
    _FORMULATIONS + "_kane.ContactTerms": {
        "contact": CONTACT, "gap": EXPR, "grad_norm": EXPR, "normal": EXPRS,
        "velocity": EXPRS, "jacobian": _list(EXPRS), "acceleration": EXPRS,
        "normal_rate": EXPR},
    _FORMULATIONS + "_flexible.FlexibleBlock": {
        "body": BODY, "w": _SEQUENCE, "partials": _Either(_list(_SEQUENCE), _tuple(_SEQUENCE)),
        "mass": _Either(_list(_SEQUENCE), _tuple(_SEQUENCE)), "momentum": _SEQUENCE,
        "kinetic": EXPR, "active": _SEQUENCE, "rate": _optional(_SEQUENCE),
        "bias": _optional(_SEQUENCE)},
    _FORMULATIONS + "_orthogonal_complement._Blocks": {
        "T": EXPRS, "Tdu": EXPRS, "Mb": EXPRS, "w": EXPRS, "Q": EXPRS, "n_bodies": INT,
        "TF": EXPRS, "TduF": EXPRS, "MbF": EXPRS, "wF": EXPRS, "sizes": _tuple(INT)},
    _FORMULATIONS + "_eom.EquationsOfMotion": {
        "_spec": _instance("a ModelSpec", _MODELING + "_spec.ModelSpec"),
        "_program": PROGRAM, "_table": TABLE,
        "_kinematics": _instance("a Kinematics", _ENGINE + "_kinematics.Kinematics"),
        "_explicit_kinematics": BOOL, "_qdot": EXPRS, "_kinematic_matrices": _tuple(MATRIX),
        "_mass": _tuple(EXPRS), "_active": EXPRS, "_remainder": EXPRS,
        "_vel_B": _tuple(EXPRS), "_vel_c": EXPRS, "_acc_K": _tuple(EXPRS), "_acc_f": EXPRS,
        "_config": EXPRS, "_aux_K": _tuple(EXPRS), "_aux_f": EXPRS, "_kinetic": EXPR,
        "_potential": _optional(EXPR),
        "_body_terms": _tuple(_instance("a BodyTerms", _FORMULATIONS + "_kane.BodyTerms")),
        "_inertial": _tuple(_tuple(EXPRS)),
        "_load_vectors": _tuple(_Fields(_Either(POINT, FRAME), EXPRS)),
        "_identified": _tuple(_Fields(STR, _tuple(ACTION))),
        "_multiplier_names": STRS,
        "_contact_terms": _tuple(_instance("a ContactTerms",
                                           _FORMULATIONS + "_kane.ContactTerms")),
        "_method": STR, "frame": FRAME, "q_ind": EXPRS, "q_dep": EXPRS, "u_ind": EXPRS,
        "u_dep": EXPRS, "u_aux": EXPRS, "bodies": _tuple(BODY), "loads": _tuple(LOAD),
        "contacts": _tuple(CONTACT), "method": STR, "_description_symbols": EXPRS,
        "_speed_tree": _optional(_Dict(STR, _list(_Either(INT, EXPRS)))),
        "name": _optional(STR), "title": _optional(STR),
        "_declared_units": _optional(_Dict(_Either(STR, EXPR), STR)),
        "_declared_gravity": _optional(_tuple(FLOAT)),
        "_noc_blocks": _instance("NOC blocks", _FORMULATIONS + "_orthogonal_complement._Blocks"),
        "_scheme": STR, "_multiplier_form": BOOL,
        "_flexible_blocks": _tuple(_instance("a FlexibleBlock",
                                             _FORMULATIONS + "_flexible.FlexibleBlock"))},
}

#: ``{class path: field specs}``: named tuples rebuilt by their constructor
NAMED_TUPLES = {
    _MECHANICS + "loads.Force": (POINT, VECTOR),
    _MECHANICS + "loads.Torque": (FRAME, VECTOR),
    _MECHANICS + "inertia.Inertia": (DYADIC, POINT),
}

#: ``{(class path, method name): argument specs of a partial of it, or None}``:
#: the bound methods a file may hold (lazy derivatives of inputs)
METHODS = {
    (_ENGINE + "_program.Program", "declare"): None,
    (_ENGINE + "_symbols.SymbolTable", "_specified"): (EXPR, INT),
}


@functools.cache
def resolve(path):
    """The class named ``path`` (a key of :data:`OBJECTS` or
    :data:`NAMED_TUPLES`), imported; ``None`` when this version has no such
    class.  Only modules named in those tables are ever imported."""
    if path not in OBJECTS and path not in NAMED_TUPLES:
        raise KeyError(path)
    module, _, name = path.rpartition(".")
    try:
        cls = getattr(importlib.import_module(module), name, None)
    except ImportError:
        return None
    if not isinstance(cls, type) or class_path(cls) != path:
        return None
    return cls


@functools.cache
def storage(path):
    """``{attribute: slot descriptor or None}`` of the schema class ``path``
    (``None``: the attribute lives in the instance ``__dict__``).

    Checked here, once per class: no attribute of a schema is a property,
    method or other descriptor of its class (writing it could run code), so
    the decoder writes values where they live and runs nothing.
    """
    cls = resolve(path)
    out = {}
    for name in OBJECTS[path]:
        found = None
        for klass in cls.__mro__:
            if name in vars(klass):
                found = vars(klass)[name]
                break
        if isinstance(found, types.MemberDescriptorType):
            out[name] = found
        elif found is None or not (hasattr(found, "__get__") or hasattr(found, "__set__")
                                   or callable(found)):
            if not cls.__dictoffset__:
                raise TypeError(f"{path}.{name}: no slot and no instance dict")
            out[name] = None
        else:
            raise TypeError(f"{path}.{name} is a {type(found).__name__} of its class: "
                            "a schema may list data attributes only")
    return out
