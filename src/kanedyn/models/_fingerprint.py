"""A digest of a model description, so that an unchanged user model is read
from the derivation cache instead of being derived again.

The digest covers what a :class:`~kanedyn.models.ModelDefinition`'s
numerical model is made of: its name, title, declared units and gravity,
default constants (symbols and values), specified inputs, and every keyword of
``kane_args`` with everything reachable from them: expressions (each distinct
node once, by identity, as :func:`kanedyn.modeling.description_symbols` walks
them), vectors, dyadics, bodies (mass, mass centre, frame, inertia,
potential energy), points (stored positions, velocities, accelerations and the
points they refer to) and frames (orientations, angular velocities and
accelerations, and the frames they refer to).  A description holding anything
else (a callable, kanedyn's contacts, force elements or flexible bodies, a
specified input given as a function) has no digest: it is derived every time.
"""

from __future__ import annotations

import hashlib

__all__ = ["description_fingerprint"]

#: ModelDefinition fields the numerical model depends on
_FIELDS = ("name", "title", "kane_args", "constants", "specified", "units", "gravity")


class _Unsupported(Exception):
    """Something in the description the digest does not cover."""


def description_fingerprint(definition):
    """A hex digest of ``definition``'s description, or ``None`` when it holds
    something the digest does not cover (see the module notes).

    Two definitions built by the same code, with fresh SymPy objects each time,
    have the same digest; a change to any expression, symbol (name or
    assumptions), number, relation between frames or points, body, load or
    constant changes it.

    Parameters
    ----------
    definition : kanedyn.models.ModelDefinition

    Returns
    -------
    str or None
    """
    import sympy as sm
    import sympy.physics.mechanics as me
    digest = _Digest(sm, me)
    try:
        parts = [digest.of(getattr(definition, name)) for name in _FIELDS]
    except _Unsupported:
        return None
    return hashlib.sha256(("\n".join([type(definition).__qualname__, *parts])).encode()
                          ).hexdigest()


class _Digest:
    """Digests of the objects of one description.

    Expressions get content digests, memoized by identity (the nodes stay
    alive during the walk).  Frames, points and bodies, whose relations may
    form cycles, get the ordinal of their first visit in a deterministic walk
    plus their names; their relations are appended to a record that the
    final digest includes.
    """

    def __init__(self, sm, me):
        self.sm, self.me = sm, me
        self.memo = {}       # id -> digest of an expression node
        self.ordinal = {}    # id -> ordinal of a frame, point or body
        self.records = []    # relations of frames, points and bodies, in visit order
        self.pending = []    # frames, points and bodies whose relations are not read yet

    def of(self, obj):
        """The digest of ``obj`` and of the relations reachable from it."""
        head = self._item(obj)
        while self.pending:
            self._relations(self.pending.pop(0))
        return hashlib.sha256("\n".join([head, *self.records]).encode()).hexdigest()

    def _hash(self, text):
        return hashlib.sha256(text.encode()).hexdigest()[:32]

    def _expression(self, expr):
        sm = self.sm
        memo = self.memo  # id -> (digest, node): the node kept, so that no id is reused
        stack = [(expr, False)]
        while stack:
            node, ready = stack.pop()
            key = id(node)
            if key in memo:
                continue
            if not isinstance(node, sm.Basic):
                raise _Unsupported(type(node).__qualname__)
            if not node.args or isinstance(node, sm.core.function.AppliedUndef):
                memo[key] = (self._hash(sm.srepr(node)), node)
            elif ready:
                memo[key] = (self._hash(type(node).__name__ + "(" + ",".join(
                    memo[id(a)][0] for a in node.args) + ")"), node)
            else:
                stack.append((node, True))
                stack.extend((a, False) for a in node.args)
        return memo[id(expr)][0]

    def _named(self, obj, kind):
        key = id(obj)
        if key not in self.ordinal:
            self.ordinal[key] = (len(self.ordinal), obj)  # kept: no id reused
            self.pending.append(obj)
        return f"{kind}#{self.ordinal[key][0]}:{obj.name}"

    def _item(self, obj):
        sm, me = self.sm, self.me
        if obj is None or isinstance(obj, (bool, int, float, complex, str)):
            return f"{type(obj).__name__}:{obj!r}"
        if isinstance(obj, sm.MatrixBase):
            return f"Matrix{obj.shape}[" + ",".join(self._expression(e) for e in obj) + "]"
        if isinstance(obj, sm.Basic):
            return self._expression(obj)
        if isinstance(obj, me.Vector):
            return "Vector[" + ";".join(f"{self._item(m)}@{self._item(f)}"
                                        for m, f in obj.args) + "]"
        if isinstance(obj, me.Dyadic):
            return "Dyadic[" + ";".join(",".join(self._item(p) for p in part)
                                        for part in obj.args) + "]"
        if isinstance(obj, me.ReferenceFrame):
            return self._named(obj, "Frame")
        if isinstance(obj, me.Point):
            return self._named(obj, "Point")
        if isinstance(obj, (me.RigidBody, me.Particle)):
            return self._named(obj, type(obj).__name__)
        if isinstance(obj, dict):
            items = [f"{self._item(k)}={self._item(v)}" for k, v in obj.items()]
            return "{" + ",".join(sorted(items)) + "}"
        if isinstance(obj, (set, frozenset)):
            return "Set{" + ",".join(sorted(self._item(v) for v in obj)) + "}"
        if isinstance(obj, (tuple, list)):  # also SymPy's Force and Torque
            return f"{type(obj).__name__}(" + ",".join(self._item(v) for v in obj) + ")"
        raise _Unsupported(type(obj).__qualname__)

    def _relations(self, obj):
        me = self.me
        if isinstance(obj, me.ReferenceFrame):
            attributes = ("_dcm_dict", "_ang_vel_dict", "_ang_acc_dict")
        elif isinstance(obj, me.Point):
            attributes = ("_pos_dict", "_vel_dict", "_acc_dict")
        else:
            attributes = ("mass", "masscenter", "frame", "central_inertia", "inertia",
                          "potential_energy")
        own = self._item(obj)
        for attribute in attributes:
            value = getattr(obj, attribute, None)
            if isinstance(value, dict):  # relations in the order they were made
                text = ",".join(f"{self._item(k)}={self._item(v)}" for k, v in value.items())
            else:
                text = self._item(value)
            self.records.append(f"{own}.{attribute}:{text}")
