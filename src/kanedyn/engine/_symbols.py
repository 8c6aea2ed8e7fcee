"""Plain internal symbols for the time-varying quantities of a model.

SymPy models are written with functions of time (``q1(t)``, ``Derivative(q1(t),
t)``).  Differentiating with respect to such objects is slow, so every one of
them is replaced by a plain symbol once, on the way in, and mapped back on the
way out (:meth:`SymbolTable.external`).
"""

from __future__ import annotations

from functools import partial

import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics.mechanics import dynamicsymbols

from .._errors import ModelError

__all__ = ["SymbolTable", "name_of", "time_derivative"]


def name_of(dynamic):
    """Printable name of a dynamic symbol ``q1(t)`` -> ``'q1'``."""
    if isinstance(dynamic, AppliedUndef):
        return str(dynamic.func)
    if isinstance(dynamic, sm.Derivative):
        base = name_of(dynamic.expr)
        return base + "'" * sum(c for _, c in dynamic.variable_count)
    return str(dynamic)


def time_derivative(expr, t):
    """``expr.diff(t)``; for a dynamic symbol ``q(t)`` the same ``Derivative``,
    built without SymPy's attempt to evaluate it (which takes 0.3-0.4 ms a
    symbol)."""
    if isinstance(expr, AppliedUndef) and expr.args == (t,):
        return sm.Derivative(expr, t)
    return expr.diff(t)


def _check_dynamic(sym, role):
    t = dynamicsymbols._t
    if not (isinstance(sym, AppliedUndef) and sym.args == (t,)):
        raise ModelError(
            f"{role} entry {sym!r} is not a function of time; create generalized "
            "coordinates and speeds with sympy.physics.mechanics.dynamicsymbols")


class SymbolTable:
    """Two-way map between a model's dynamic symbols and internal symbols.

    Parameters
    ----------
    q : sequence of dynamicsymbols
        Generalized coordinates, independent first.
    u : sequence of dynamicsymbols
        Generalized speeds, independent first.
    u_aux : sequence of dynamicsymbols
        Auxiliary generalized speeds (constraint forces).

    Attributes
    ----------
    q, u, u_aux : tuple of sympy.Dummy
        Internal symbols in the order given.
    udot : tuple of sympy.Dummy
        Internal symbols standing for the speeds' time derivatives.
    specified : dict
        Specified (input) functions of time found so far, and their
        derivatives, external -> internal, in order of discovery.
    """

    def __init__(self, q, u, u_aux=()):
        self.t = dynamicsymbols._t
        for role, group in (("q", q), ("u", u), ("u_auxiliary", u_aux)):
            for s in group:
                _check_dynamic(s, role)
        self.q_ext = tuple(q)
        self.u_ext = tuple(u)
        self.u_aux_ext = tuple(u_aux)
        self.q = tuple(sm.Dummy(name_of(s)) for s in q)
        self.u = tuple(sm.Dummy(name_of(s)) for s in u)
        self.u_aux = tuple(sm.Dummy(name_of(s)) for s in u_aux)
        self.udot = tuple(sm.Dummy(name_of(s) + "_dot") for s in u)
        self.qdot_raw = tuple(sm.Dummy(name_of(s) + "_dot") for s in q)
        self._int = {}
        self._ext = {}
        t = self.t
        for ext, int_ in zip(self.q_ext + self.u_ext + self.u_aux_ext,
                             self.q + self.u + self.u_aux):
            self._int[ext] = int_
            self._ext[int_] = ext
        for ext, int_ in zip(self.u_ext + self.q_ext, self.udot + self.qdot_raw):
            derivative = time_derivative(ext, t)  # once: SymPy builds it anew each time
            self._int[derivative] = int_
            self._ext[int_] = derivative
        self._qdot_value = {}  # raw q' symbol -> its expression in u
        self._replaced = {}  # external dynamic symbol -> why its derivatives are refused
        self.specified = {}  # external -> internal, in discovery order
        self.on_new_specified = None  # callback(internal, derivative_internal)

    # ------------------------------------------------------------------ q'
    def set_qdot(self, values):
        """Use ``values[i]`` (expressions in u) wherever q_i' appears."""
        self._qdot_value = dict(zip(self.qdot_raw, values))

    @property
    def qdot(self):
        """Expressions substituted for q' (after :meth:`set_qdot`)."""
        return tuple(self._qdot_value.get(s, s) for s in self.qdot_raw)

    # -------------------------------------------------------------- speeds
    def add_speeds(self, u):
        """Append generalized speeds ``u`` (dynamic symbols); returns their internal symbols."""
        u = tuple(u)
        for s in u:
            _check_dynamic(s, "u")
            if s in self._int:
                raise ModelError(f"{name_of(s)} is already a symbol of this model")
        new = tuple(sm.Dummy(name_of(s)) for s in u)
        new_dot = tuple(sm.Dummy(name_of(s) + "_dot") for s in u)
        t = self.t
        for ext, int_, dot in zip(u, new, new_dot):
            self._int[ext], self._ext[int_] = int_, ext
            derivative = time_derivative(ext, t)
            self._int[derivative], self._ext[dot] = dot, derivative
        self.u_ext += u
        self.u += new
        self.udot += new_dot
        return new

    def reorder_speeds(self, order):
        """Put the speeds in the order ``order`` (a permutation of their indices)."""
        order = list(order)
        if sorted(order) != list(range(len(self.u))):
            raise ValueError(f"{order} is not a permutation of the {len(self.u)} speeds")
        self.u_ext = tuple(self.u_ext[i] for i in order)
        self.u = tuple(self.u[i] for i in order)
        self.udot = tuple(self.udot[i] for i in order)

    def substitute(self, ext, expr, reason):
        """Convert the dynamic symbol ``ext`` to the internal expression ``expr``.

        Used by formulations whose speeds are not the model's own: the
        model's speeds become functions of theirs.  Derivatives of ``ext``
        are refused by :meth:`internal` with a message ending in ``reason``.
        """
        _check_dynamic(ext, "substituted symbol")
        if ext in self._int:
            raise ModelError(f"{name_of(ext)} already stands for a symbol of this model")
        self._int[ext] = sm.sympify(expr, strict=True)
        self._replaced[ext] = reason

    # ----------------------------------------------------------- specified
    def _specified(self, func, order):
        """Internal symbol of the ``order``-th derivative of input ``func(t)``."""
        ext = func if order == 0 else sm.Derivative(func, (self.t, order))
        found = self.specified.get(ext)
        if found is not None:
            return found
        int_ = sm.Dummy(name_of(func) + ("_d%d" % order if order else ""))
        self.specified[ext] = int_
        self._int[ext] = int_
        self._ext[int_] = ext
        if self.on_new_specified is not None:
            self.on_new_specified(int_, partial(self._specified, func, order + 1))
        return int_

    # -------------------------------------------------------------- convert
    def internal(self, expr, where, allow_qdot=True, allow_udot=False):
        """Rewrite ``expr`` with internal symbols.

        ``where`` names what is converted (used in error messages).
        """
        expr = sm.sympify(expr, strict=True)
        if not expr.has(AppliedUndef):
            return expr
        t = self.t
        mapping = {}
        for d in expr.atoms(sm.Derivative):
            f = d.expr
            if d in self._int:
                target = self._int[d]
                if target in self.udot and not allow_udot:
                    raise ModelError(
                        f"{where} contains the acceleration {d}; only coordinates, "
                        "speeds and their first time derivatives may appear there")
                if target in self._qdot_value and not allow_qdot:
                    raise ModelError(f"{where} contains {d}, which is not allowed there")
                mapping[d] = self._qdot_value.get(target, target)
                continue
            if not (isinstance(f, AppliedUndef) and f.args == (t,)
                    and d.variables == (t,) * len(d.variables)):
                raise ModelError(f"{where} contains the unsupported derivative {d}")
            order = len(d.variables)
            if f in self._replaced:
                raise ModelError(f"{where} contains {d}, a derivative of {name_of(f)}; "
                                 f"{self._replaced[f]}")
            if f in self._int and f not in self.specified:  # a coordinate or speed
                if f in self.u_aux_ext:
                    mapping[d] = sm.S.Zero
                    continue
                raise ModelError(
                    f"{where} contains {d}, a derivative of order {order} of "
                    f"{name_of(f)}; write it with generalized speeds instead")
            mapping[d] = self._specified(f, order)
        for f in expr.atoms(AppliedUndef):
            if f in self._int:
                mapping[f] = self._int[f]
                continue
            if f.args != (t,):
                raise ModelError(
                    f"{where} contains {f}, an undefined function of something "
                    "other than time alone; kanedyn cannot differentiate it")
            mapping[f] = self._specified(f, 0)
        return expr.xreplace(mapping)

    def external(self, expr):
        """Rewrite an internal expression with the model's dynamic symbols."""
        expr = sm.sympify(expr, strict=True)
        return expr.xreplace({s: self._ext[s] for s in expr.free_symbols if s in self._ext})

    def external_matrix(self, matrix):
        return sm.Matrix(matrix).applyfunc(self.external)

    def is_dynamic(self, symbol):
        """True for internal symbols of coordinates, speeds and inputs."""
        return symbol in self._ext
