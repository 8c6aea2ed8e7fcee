"""SymPy expressions in saved files: the classes a file may name and how each is rebuilt.

A saved file stores an expression as a tree of nodes, each naming a class
from :func:`expression_rules` and referring to its arguments.  Rebuilding a
node must never compute: an evaluating constructor can run without bound
(``Max(9**10**4000, 9)`` compares the two numbers; ``And`` and
``ExprCondPair`` simplify their arguments; ``Derivative`` walks its whole
expression for its free symbols, which on a shared tree is exponential in
its depth), and assumptions queries can expand.  So every argument is
checked by kind first (an :class:`~sympy.core.expr.Expr` where SymPy wants
one, a Boolean where it wants a condition), and each class is built by the
route that keeps it exactly as stored:

- the public constructor with ``evaluate=False`` where that is all it does
  with them (``Add``, ``Mul``, ``Pow``, the elementary functions,
  inequalities, ``Eq``, ``Ne``, ``Not``, ``Tuple``);
- ``Basic.__new__`` on the checked arguments where the constructor would
  still compute with ``evaluate=False`` (``Max``/``Min`` sort their
  arguments by a key that evaluates numbers; ``And``/``Or`` simplify;
  ``Piecewise``/``ExprCondPair`` fold nested conditions; ``Derivative``
  collects free symbols), setting the one attribute their constructor sets
  (``_argset`` of ``Max``, ``Min``, ``And``, ``Or``).

The rebuilt object equals the one saved (same class, same arguments in the
same order).
"""

from __future__ import annotations

import functools

__all__ = ["ASSUMPTIONS", "SINGLETONS", "Refused", "expression_rules",
           "described"]

#: SymPy's singletons a file may name (``S.<name>``)
SINGLETONS = ("Zero", "One", "NegativeOne", "Half", "Pi", "Exp1", "ImaginaryUnit",
              "Infinity", "NegativeInfinity", "ComplexInfinity", "NaN", "true", "false",
              "EulerGamma")


class Refused(Exception):
    """A node whose arguments do not fit its class (the decoder names file and node)."""


def described(value):
    """``"a Mul"``, ``"an Integer"``: the type of ``value``, for messages."""
    name = type(value).__name__
    return f"{'an' if name[:1].lower() in 'aeiou' else 'a'} {name}"


@functools.cache
def _assumption_names():
    from sympy.core.assumptions import _assume_defined
    return frozenset(_assume_defined)


class _Assumptions:
    """The assumption names SymPy knows (``real``, ``positive``, ...): symbols and
    undefined functions take no other keyword (any other would become a class
    attribute of an undefined function)."""

    def __contains__(self, name):
        return name in _assumption_names()


ASSUMPTIONS = _Assumptions()


class _Rule:
    """How one class is rebuilt: its argument kinds, their number, the builder."""

    __slots__ = ("cls", "kinds", "rest", "low", "high", "build", "distinct")

    def __init__(self, cls, kinds, build, rest=None, low=None, distinct=False):
        self.cls, self.kinds, self.rest, self.build = cls, kinds, rest, build
        self.low = len(kinds) if low is None else low
        self.high = None if rest is not None else len(kinds)
        self.distinct = distinct

    def check(self, args):
        n = len(args)
        if n < self.low or (self.high is not None and n > self.high):
            wanted = (f"{self.low}" if self.high == self.low else
                      f"{self.low} to {self.high}" if self.high is not None else
                      f"at least {self.low}")
            raise Refused(f"{self.cls.__name__} takes {wanted} arguments, got {n}")
        for i, arg in enumerate(args):
            kind = self.kinds[i] if i < len(self.kinds) else self.rest
            if not kind.fits(arg):
                raise Refused(f"argument {i} of {self.cls.__name__} is {described(arg)}, "
                              f"not {kind.text}")
        if self.distinct and len(set(args)) != n:
            raise Refused(f"{self.cls.__name__} with repeated arguments")


class _Kind:
    __slots__ = ("text", "fits")

    def __init__(self, text, fits):
        self.text, self.fits = text, fits


@functools.cache
def expression_rules():
    """``{class name: rule}`` of the expression classes a file may name."""
    import sympy as sm
    from sympy.core.function import AppliedUndef
    from sympy.functions.elementary.piecewise import ExprCondPair
    from sympy.logic.boolalg import Boolean

    def is_expr(a):
        return isinstance(a, sm.Expr) and not isinstance(a, sm.MatrixBase)

    expr = _Kind("an expression", is_expr)
    boolean = _Kind("a condition", lambda a: isinstance(a, Boolean))
    basic = _Kind("a SymPy object", lambda a: isinstance(a, sm.Basic)
                  and not isinstance(a, sm.MatrixBase))
    pair = _Kind("an (expression, condition) pair", lambda a: type(a) is ExprCondPair)
    # Derivative(f, (v, n)): v a symbol or function of time, n a whole number >= 1
    count = _Kind("a (variable, order) pair", lambda a: type(a) is sm.Tuple and len(a) == 2
                  and isinstance(a[0], (sm.Symbol, AppliedUndef))
                  and isinstance(a[1], sm.Integer) and a[1] >= 1)

    def unevaluated(cls, args):
        return cls(*args, evaluate=False)

    def stored(cls, args):
        return sm.Basic.__new__(cls, *args)

    def with_argset(cls, args):
        obj = sm.Basic.__new__(cls, *args)
        obj._argset = frozenset(args)
        return obj

    rules = {}

    def add(classes, kinds, build, **options):
        for cls in classes:
            rules[cls.__name__] = _Rule(cls, kinds, build, **options)

    add((sm.Add, sm.Mul), (), lambda cls, args: cls(*args, evaluate=False, _sympify=False),
        rest=expr, low=2)
    add((sm.Pow, sm.atan2), (expr, expr), unevaluated)
    add((sm.sin, sm.cos, sm.tan, sm.cot, sm.asin, sm.acos, sm.atan, sm.sinh, sm.cosh,
         sm.tanh, sm.exp, sm.log, sm.Abs, sm.sign, sm.re, sm.im, sm.floor, sm.ceiling),
        (expr,), unevaluated)
    add((sm.Heaviside,), (expr, expr), unevaluated, low=1)
    add((sm.Max, sm.Min), (), with_argset, rest=expr, low=2, distinct=True)
    add((sm.And, sm.Or), (), with_argset, rest=boolean, low=2, distinct=True)
    add((sm.Not,), (boolean,), unevaluated)
    add((sm.StrictGreaterThan, sm.StrictLessThan, sm.GreaterThan, sm.LessThan, sm.Eq, sm.Ne),
        (expr, expr), unevaluated)
    add((sm.Piecewise,), (), stored, rest=pair, low=1)
    add((ExprCondPair,), (expr, boolean), stored)
    add((sm.Tuple,), (), lambda cls, args: sm.Tuple(*args), rest=basic, low=0)
    add((sm.Derivative,), (expr,), stored, rest=count, low=2)
    return rules
