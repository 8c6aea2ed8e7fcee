"""Repeated subtrees of a straight-line program, each named once.

The elimination of :meth:`~kanedyn.engine.Program.listing`: the same result as
SymPy's repeated-subtree pass (``tree_cse`` with no optimizations and
``order="none"``, the core of ``sympy.cse``), built faster.  A subtree met a
second time (in the order of a depth-first walk of the expressions, arguments
left to right) becomes a temporary, numbered in the order its first use is
rebuilt; a tree is rebuilt around its temporaries without SymPy's automatic
evaluation, and a tree that holds none is kept as it is (SymPy's pass
constructs every node again, which was most of its time: an equal tree).
"""

from __future__ import annotations

import sympy as sm
from sympy.core.parameters import evaluate
from sympy.polys.rootoftools import RootOf
from sympy.utilities.iterables import iterable

__all__ = ["eliminate_repeated"]

#: node types that are never containers (SymPy's ``iterable`` asked only of others)
_PLAIN = (sm.Add, sm.Mul, sm.Pow, sm.Function)


def _is_container(node):
    """Whether ``node`` is a container of expressions (a ``Tuple``, a
    ``Piecewise``'s pairs): its elements are looked into, it is never named."""
    return not isinstance(node, _PLAIN) and iterable(node)


def _is_leaf(node):
    """Whether ``node`` is not looked into: no arguments (a symbol, a number),
    an order term or a root of a polynomial."""
    return not node.args or node.is_Order or isinstance(node, RootOf)


def eliminate_repeated(exprs, symbols):
    """``(replacements, reduced)``: the repeated subtrees of ``exprs`` named.

    Parameters
    ----------
    exprs : list of sympy.Expr
    symbols : iterator of sympy.Symbol
        Names for the temporaries, taken in order; one whose name is that of
        a symbol in ``exprs`` is passed over.

    Returns
    -------
    replacements : list of (Symbol, Expr)
        Each temporary and its subtree (in terms of earlier temporaries), in
        the order they are made.
    reduced : list of Expr
        ``exprs`` in terms of the temporaries.
    """
    seen, repeated, taken = set(), set(), set()
    stack = list(reversed(exprs))
    while stack:  # depth first, arguments left to right
        node = stack.pop()
        if _is_leaf(node):
            if node.is_Symbol:
                taken.add(node.name)
            continue
        if not _is_container(node):
            if node in seen:
                repeated.add(node)
                continue
            seen.add(node)
        stack.extend(reversed(node.args))

    names = (s for s in symbols if s.name not in taken)
    replacements, named = [], {}

    def rebuild(node):
        if not node.args:
            return node
        found = named.get(node)
        if found is not None:
            return found
        args = node.args
        new = [rebuild(a) for a in args]
        if any(a is not b for a, b in zip(new, args)):
            node_new = node.func(*new)
        else:
            node_new = node
        if node in repeated:  # (never a container)
            symbol = next(names)
            named[node] = symbol
            replacements.append((symbol, node_new))
            return symbol
        return node_new

    with evaluate(False):
        reduced = [rebuild(e) for e in exprs]
    return replacements, reduced
