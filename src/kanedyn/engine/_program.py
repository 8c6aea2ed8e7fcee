r"""Straight-line programs of named intermediates.

A :class:`Program` holds an ordered list of assignments ``z_k = f_k(...)`` where
each right-hand side is a small SymPy expression in earlier intermediates, *base
variables* (coordinates, speeds, time, specified inputs) and constants.  Nothing
is ever expanded: a rotation matrix entry of body 10 refers to the entries of
body 9, and so on.  This is what keeps derivation fast and the generated code
small (the approach of Autolev and MotionGenesis).

The program differentiates itself in forward mode:

* :meth:`Program.diff` gives :math:`\partial e / \partial x` for a base variable
  ``x`` by the chain rule over the intermediates ``e`` depends on;
* :meth:`Program.dt` gives the time derivative with every generalized speed held
  fixed, :math:`\dot e|_{\dot u = 0} = \sum_j \partial e/\partial q_j\,\dot q_j +
  \partial e/\partial t + \dots`; the part proportional to :math:`\dot u` is
  obtained from :meth:`diff` with respect to the speeds (partial velocities).

Identical right-hand sides are stored once (hash-consing), which eliminates most
common subexpressions while the program is built.
"""

from __future__ import annotations

import cmath
import copy
import functools
import itertools
import math
import random
from bisect import insort

import numpy as np
import sympy as sm
from sympy.core.basic import _args_sortkey
from sympy.core.function import AppliedUndef

from ._cse import eliminate_repeated

__all__ = ["Program", "SAMPLE_SEEDS", "random_sampler", "kd_dpow", "free_symbols_of", "difference"]

SAMPLE_SEEDS = (101, 202)  # random points used for identity tests

_ZERO = sm.S.Zero
_ONE = sm.S.One
#: ``Basic.free_symbols``, which classes binding variables (``Derivative``,
#: ``Integral``, ``Lambda``, ``Subs``) override
_UNION_OF_ARGUMENTS = sm.Basic.__dict__["free_symbols"]


def free_symbols_of(expr):
    """``expr.free_symbols``, by one walk over the tree: SymPy's property makes
    a set at every node (2.4 against 1.1 ms for the 1088 intermediates of
    chain3d n = 10, read some four times each on the way to the C code).  A
    node of a class with a ``free_symbols`` of its own (one binding variables)
    is asked for it."""
    if expr.is_Symbol:
        return {expr}
    found, stack = set(), [expr]
    while stack:
        node = stack.pop()
        if node.is_Symbol:
            found.add(node)
        elif type(node).free_symbols is _UNION_OF_ARGUMENTS:
            stack.extend(node.args)
        else:
            found |= node.free_symbols
    return found


def _is_trivial(expr):
    """True for expressions not worth a name: atoms and ``number * atom``."""
    if expr.is_Atom:
        return True
    if expr.is_Mul and len(expr.args) == 2:
        a, b = expr.args
        return a.is_Number and b.is_Atom
    return False


def _rebuilt(expr, args):
    """``expr``'s node on new ``args`` (each a name of the argument it replaces):
    a ``Min`` or ``Max`` unevaluated, the same function of the same values.
    Evaluated, each would look for arguments it can prove no larger (smaller)
    than another, SymPy factoring their differences, several milliseconds a
    node: most of the derivation of a turbine whose 153 blade nodes each clip
    a speed (docs/benchmarks.md)."""
    if isinstance(expr, _MIN_MAX):
        return expr.func(*args, evaluate=False)
    return expr.func(*args)


_MIN_MAX = (sm.Min, sm.Max)


class Program:
    """An ordered set of named intermediates with forward differentiation.

    Parameters
    ----------
    t : sympy.Symbol
        The time symbol.

    Notes
    -----
    Base variables are declared with :meth:`declare` together with their time
    derivative.  Symbols that are neither base variables nor intermediates are
    constants: their derivatives are zero.
    """

    def __init__(self, t):
        self.t = t
        self._defs = {}  # intermediate -> right-hand side
        self._index = {}  # intermediate -> position
        self._order = []
        self._cons = {}  # right-hand side -> intermediate (hash-consing)
        self._parents = {}  # intermediate -> frozenset of intermediates in its rhs
        self._deps = {}  # intermediate -> frozenset of leaf symbols it depends on
        self._base_dt = {t: _ONE}  # base variable -> time derivative
        self._dt_hint = {}  # intermediate -> known time derivative (expression)
        self._dt = {}
        self._diff = {}  # var -> {intermediate: derivative}
        self._subs = {}  # frozenset(mapping) -> {intermediate: substituted}
        self._explicit = {}
        self._shadow = {}  # seed -> {symbol: value}
        self._samplers = {}
        self._analytic = {}  # intermediate -> whether its definition is analytic
        self._varying_set = None  # base variables with a derivative (see _varying)

    # ------------------------------------------------------------------ build
    def copy(self):
        """An independent extension of this program.

        The copy holds every intermediate (same symbols, same definitions) and
        every cache; intermediates added to it later are not seen by this
        program, whose listing, size and fingerprint stay as they are.  Random
        samplers are copied with their state, so identity tests on either
        program give the values they would have given on this one.
        """
        new = Program.__new__(Program)
        for name, value in vars(self).items():
            if name == "_samplers":
                value = {k: copy.deepcopy(v) for k, v in value.items()}
            elif isinstance(value, dict):
                value = {k: dict(v) if isinstance(v, dict) else v for k, v in value.items()}
            elif isinstance(value, (list, set)):
                value = type(value)(value)
            setattr(new, name, value)
        return new

    def declare(self, symbol, derivative=_ZERO):
        """Declare ``symbol`` a base variable whose time derivative is ``derivative``.

        ``derivative`` may be a callable returning the expression; it is called
        the first time the derivative is needed.
        """
        self._base_dt[symbol] = (derivative if callable(derivative)
                                 else sm.sympify(derivative, strict=True))
        self._varying_set = None

    def set_derivative(self, symbol, derivative):
        """Change the time derivative of a declared base variable."""
        if symbol not in self._base_dt:
            raise KeyError(f"{symbol} is not a base variable of this program")
        self._base_dt[symbol] = sm.sympify(derivative, strict=True)
        self._varying_set = None
        self._dt.clear()

    def _base_derivative(self, symbol):
        value = self._base_dt.get(symbol, _ZERO)
        if callable(value):
            value = self._base_dt[symbol] = sm.sympify(value(), strict=True)
            self._varying_set = None
        return value

    def is_base(self, symbol):
        return symbol in self._base_dt

    def is_intermediate(self, symbol):
        return symbol in self._defs

    def let(self, expr, name="z"):
        """Return a name for ``expr``: a new or existing intermediate, or ``expr``.

        Atoms and ``number * atom`` are returned unchanged.
        """
        expr = sm.sympify(expr, strict=True)
        if _is_trivial(expr):
            return expr
        if expr.is_Mul and expr.args[0].is_Number and expr.args[0].is_negative:
            return -self.let(-expr, name)  # -sin(q) shares the name of sin(q)
        found = self._cons.get(expr)
        if found is not None:
            return found
        sym = sm.Dummy(name)
        free = free_symbols_of(expr)
        parents = frozenset(s for s in free if s in self._defs)
        deps = set(s for s in free if s not in self._defs)
        for p in parents:
            deps |= self._deps[p]
        self._defs[sym] = expr
        self._index[sym] = len(self._order)
        self._order.append(sym)
        self._cons[expr] = sym
        self._parents[sym] = parents
        self._deps[sym] = frozenset(deps)
        return sym

    def let_tree(self, expr, name="z", threshold=8, leaf=None):
        """Name the subexpressions of a large expression, bottom up.

        Every subtree of at least ``threshold`` operations, and every function
        application, becomes an intermediate; identical subtrees are named
        once, and each distinct node is visited once (SymPy shares
        subexpressions, so walking the tree instead would be exponential).
        Large expressions from SymPy (expanded direction cosines) thus become
        compact programs.  ``leaf(node)``, if given, replaces applied
        undefined functions and derivatives (e.g. ``q(t)``).
        """
        expr = sm.sympify(expr, strict=True)
        memo = {}

        def visit(e):
            found = memo.get(e)
            if found is not None:
                return found
            if leaf is not None and isinstance(e, (AppliedUndef, sm.Derivative)):
                out = (leaf(e), 0)
            elif e.is_Atom:
                out = (e, 0)
            else:
                parts = [visit(a) for a in e.args]
                new_args = [p for p, _ in parts]
                new = e if all(a is b for a, b in zip(new_args, e.args)) else _rebuilt(e, new_args)
                size = 1 + sum(k for _, k in parts)
                if size >= threshold or e.is_Function:
                    new, size = self.let(new, name), 0
                out = (new, size)
            memo[e] = out
            return out

        return visit(expr)[0]

    def let_matrix(self, matrix, name="z"):
        """Name every entry of ``matrix``; returns an immutable matrix of names."""
        matrix = sm.Matrix(matrix)
        rows, cols = matrix.shape
        out = [self.let(matrix[i, j], f"{name}{i}{j}" if cols > 1 else f"{name}{i}")
               for i in range(rows) for j in range(cols)]
        return sm.ImmutableMatrix(rows, cols, out)

    def hint_dt(self, symbol, derivative):
        """Record a known time derivative of an intermediate (first one wins)."""
        if symbol in self._defs and symbol not in self._dt_hint:
            self._dt_hint[symbol] = sm.sympify(derivative, strict=True)

    def definition(self, symbol):
        return self._defs[symbol]

    def __len__(self):
        return len(self._order)

    # ---------------------------------------------------------------- queries
    def deps(self, expr):
        """Leaf symbols (base variables and constants) ``expr`` depends on."""
        out = set()
        for s in free_symbols_of(sm.sympify(expr, strict=True)):
            d = self._deps.get(s)
            if d is not None:
                out |= d
            else:
                out.add(s)
        return frozenset(out)

    def _varying(self):
        """Base variables whose time derivative is not identically zero (kept
        until a derivative is declared or changed)."""
        found = vars(self).get("_varying_set")  # absent from older pickles
        if found is None:
            found = self._varying_set = frozenset(
                s for s, d in self._base_dt.items() if callable(d) or d != 0)
        return found

    def _free_intermediates(self, expr):
        return [s for s in free_symbols_of(expr) if s in self._defs]

    def needed(self, exprs, stop=None, leaf=None):
        """Intermediates ``exprs`` depend on, in definition order.

        ``stop(symbol)`` returning True leaves that symbol out; ``leaf(symbol)``
        returning True keeps it but does not follow its parents.
        """
        seen = set()
        stack = []
        for e in exprs:
            stack.extend(self._free_intermediates(sm.sympify(e, strict=True)))
        while stack:
            s = stack.pop()
            if s in seen or (stop is not None and stop(s)):
                continue
            seen.add(s)
            if leaf is None or not leaf(s):
                stack.extend(p for p in self._parents[s] if p not in seen)
        return sorted(seen, key=self._index.__getitem__)

    # ------------------------------------------------------------ derivatives
    def _chain(self, expr, derivative_of, guarded=False):
        """Total derivative of ``expr`` given derivatives of its free symbols."""
        return total_derivative(expr, derivative_of, guarded)

    def diff(self, expr, var, name=None, guarded=False):
        r"""Partial derivative :math:`\partial\,\mathrm{expr}/\partial\,\mathrm{var}`.

        ``var`` is any leaf symbol (base variable or constant).  The result is an expression in
        intermediates (new ones are created for the derivatives of old ones).
        ``guarded``: fractional powers differentiated as :class:`kd_dpow`
        (finite at :math:`|v| = 0`; for numerical derivatives, not for
        equations that are saved).
        """
        expr = sm.sympify(expr, strict=True)
        if var not in self.deps(expr):
            return _ZERO
        memo = self._diff.setdefault((var, "guarded") if guarded else var, {})
        todo = self.needed([expr], stop=lambda s: s in memo or var not in self._deps[s])
        tag = (name or f"d{var}") + ("g" if guarded else "")

        def d_of(s):
            if s in self._defs:  # var is a leaf, never an intermediate
                return memo.get(s, _ZERO)
            return _ONE if s == var else _ZERO

        for s in todo:
            memo[s] = self.let(self._chain(self._defs[s], d_of, guarded), f"{s.name}_{tag}")
        return self._chain(expr, d_of, guarded)

    def jacobian(self, exprs, variables, guarded=False):
        """Matrix of partial derivatives, ``len(exprs) x len(variables)``."""
        exprs, variables = list(exprs), list(variables)
        return sm.Matrix(len(exprs), len(variables),
                         [self.diff(e, v, guarded=guarded) for e in exprs for v in variables])

    def dt(self, expr):
        r"""Time derivative of ``expr`` with :math:`\dot u` held at zero.

        Base variables contribute their declared derivatives; intermediates with
        a recorded hint (:meth:`hint_dt`) use it.
        """
        expr = sm.sympify(expr, strict=True)
        varying = self._varying()
        if not (self.deps(expr) & varying):
            return _ZERO
        memo = self._dt
        todo = self.needed([expr], stop=lambda s: s in memo or not (self._deps[s] & varying),
                           leaf=self._dt_hint.__contains__)

        def d_of(s):
            if s in self._defs:
                return memo.get(s, _ZERO)
            return self._base_derivative(s)

        for s in todo:
            hint = self._dt_hint.get(s)
            value = hint if hint is not None else self._chain(self._defs[s], d_of)
            memo[s] = self.let(value, f"{s.name}_dt")
        return self._chain(expr, d_of)

    # ----------------------------------------------------------- substitution
    def subs(self, expr, mapping):
        """Replace leaf symbols by values throughout the program.

        Intermediates that depend on a replaced variable get substituted copies;
        the others are shared.
        """
        expr = sm.sympify(expr, strict=True)
        mapping = {k: sm.sympify(v, strict=True) for k, v in mapping.items()}
        if not mapping or not (self.deps(expr) & set(mapping)):
            return expr
        key = frozenset(mapping.items())
        memo = self._subs.setdefault(key, {})
        targets = set(mapping)
        todo = self.needed(
            [expr], stop=lambda s: s in memo or not (self._deps[s] & targets))
        for s in todo:
            local = dict(mapping)
            local.update((p, memo[p]) for p in self._parents[s] if p in memo)
            memo[s] = self.let(self._defs[s].xreplace(local), s.name)
        local = dict(mapping)
        local.update((s, memo[s]) for s in self._free_intermediates(expr) if s in memo)
        return expr.xreplace(local)

    def expand(self, expr, memo=None, evaluate=True):
        """The explicit expression: every intermediate replaced by its value.

        Each intermediate is expanded once, from its parents' expansions, so
        the cost is linear in the number of intermediates (the result is a
        SymPy expression whose equal subtrees are shared objects; as a tree it
        can be far larger).  ``memo`` (a dict, kept by the caller) may be
        seeded with ``{leaf symbol: replacement}`` to rewrite the leaves on
        the way, e.g. back to the model's dynamic symbols; by default the
        program's own memo (leaves unchanged) is used.  With ``evaluate=False``
        sums, products and powers are built without SymPy's automatic
        simplification (several times faster on large expressions; the
        values are the same); a memo must not mix the two.
        """
        expr = sm.sympify(expr, strict=True)
        memo = self._explicit if memo is None else memo
        if not evaluate:
            for s in self.needed([expr], stop=lambda s: s in memo):
                memo[s] = _rebuild(self._defs[s], memo)
            return _rebuild(expr, memo)
        for s in self.needed([expr], stop=lambda s: s in memo):
            rhs = self._defs[s]
            memo[s] = rhs.xreplace({p: memo[p] for p in rhs.free_symbols if p in memo})
        return expr.xreplace({p: memo[p] for p in expr.free_symbols if p in memo})

    def tree_size(self, expr, memo=None):
        """Number of nodes of ``expr`` as an explicit tree (:meth:`expand`).

        Computed from the intermediates' definitions without expanding
        (cost linear in the number of intermediates); ``memo`` may be kept by
        the caller between calls.
        """
        memo = {} if memo is None else memo
        expr = sm.sympify(expr, strict=True)
        for s in self.needed([expr], stop=lambda s: s in memo):
            memo[s] = _node_count(self._defs[s], memo)
        return _node_count(expr, memo)

    # --------------------------------------------------------------- numerics
    def shadow(self, exprs, seed):
        """Evaluate ``exprs`` numerically at the random point number ``seed``.

        Every leaf symbol gets a reproducible value in [0.5, 1.5) at each
        point; intermediate values are cached.  Used for randomized identity
        tests.  Returns a list of complex numbers (``nan`` where evaluation
        failed).
        """
        values = self._shadow.setdefault(seed, {})
        sample = self._samplers.get(seed)
        if sample is None:
            sample = self._samplers[seed] = random_sampler(seed)

        def value_of(s):
            if s not in values:
                values[s] = sample(s)
            return values[s]

        exprs = [sm.sympify(e, strict=True) for e in exprs]
        for s in self.needed(exprs, stop=lambda s: s in values):
            values[s] = _evaluate(self._defs[s], value_of)
        return [_evaluate(e, value_of) for e in exprs]

    def shadow_jacobian(self, exprs, variables, seed, step=1e-20, directions=None):
        r"""Values of :math:`\partial e_i/\partial x_j` at the random point ``seed``.

        Complex steps :math:`\operatorname{Im} e(x + ih\,e_j)/h` in every
        direction at once: one pass over the intermediates that depend on
        ``variables``, each evaluated on an array with one lane per variable
        (values of the others from :meth:`shadow`); no symbolic derivative is
        formed.  Exact to rounding for analytic expressions; ``None`` where it
        cannot be trusted (a non-analytic function on the way, such as
        ``Abs``, or a value that is not real at the point), so that the
        caller differentiates symbolically instead.

        ``directions`` (shape ``(k, len(variables))``): the derivatives in
        these directions instead, one lane per direction, :math:`J D^T`.

        Returns
        -------
        numpy.ndarray or None
            Shape ``(len(exprs), len(variables))``, or ``(len(exprs), k)``
            with ``directions``.
        """
        exprs = [sm.sympify(e, strict=True) for e in exprs]
        base = self.shadow(exprs, seed)
        values = self._shadow[seed]
        steps = (np.eye(len(variables)) if directions is None
                 else np.asarray(directions, dtype=float).T)  # (variable, lane)
        out = np.zeros((len(exprs), steps.shape[1]))
        moved = {}
        for j, x in enumerate(variables):
            if x in values:  # reached by some expression
                if values[x].imag != 0:
                    return None
                moved[x] = values[x] + 1j * step * steps[j]
        if not moved:
            return out
        targets = frozenset(moved)

        def value_of(s):
            found = moved.get(s)
            return values[s] if found is None else found

        for s in self.needed(exprs, stop=lambda s: self._deps[s].isdisjoint(targets)):
            if values[s].imag != 0 or not self._is_analytic(s):
                return None
            moved[s] = _lane_eval(self._defs[s], value_of, {})
        for i, (e, value) in enumerate(zip(exprs, base)):
            if value.imag != 0 or not _analytic(e):
                return None
            lanes = _lane_eval(e, value_of, {})
            if np.ndim(lanes) == 0:
                continue  # depends on none of the variables
            if not np.all(np.isfinite(lanes)):
                return None
            out[i] = lanes.imag / step
        return out

    def _is_analytic(self, symbol):
        known = vars(self).setdefault("_analytic", {})  # absent from older pickles
        found = known.get(symbol)
        if found is None:
            found = known[symbol] = _analytic(self._defs[symbol])
        return found

    def insensitive(self, exprs, leaves, seeds=SAMPLE_SEEDS, step=1e-20, rtol=1e-10):
        r"""Leaves each expression does not depend on, by complex-step derivatives.

        For every leaf in ``leaves`` that an expression formally depends on,
        :math:`\partial e/\partial x` is evaluated at the random points
        ``seeds`` (:meth:`shadow`) by the complex step
        :math:`\operatorname{Im} e(x + ih)/h`; leaves whose derivative
        vanishes (relative to the expression's size) at every point are
        returned.  A randomized test: use the result only after checking it
        (e.g. that substituting a value for the leaves leaves the values
        unchanged).

        Returns
        -------
        list of set
            One set of leaves per expression.
        """
        exprs = [sm.sympify(e, strict=True) for e in exprs]
        out = [set(self.deps(e)) & set(leaves) for e in exprs]
        for seed in seeds:
            base = self.shadow(exprs, seed)
            values = self._shadow[seed]
            needed = self.needed(exprs)
            for x in set().union(*out) if out else ():
                if abs(values[x].imag) > 0:
                    continue
                moved = {x: values[x] + 1j * step}

                def value_of(s, moved=moved):
                    found = moved.get(s)
                    return values[s] if found is None else found

                for s in needed:
                    if x in self._deps[s]:
                        moved[s] = _evaluate(self._defs[s], value_of)
                for k, e in enumerate(exprs):
                    if x not in out[k]:
                        continue
                    value = _evaluate(e, value_of)
                    ok = (value == value and abs(base[k].imag) == 0
                          and abs(value.imag) / step <= rtol * max(1.0, abs(base[k])))
                    if not ok:
                        out[k].discard(x)
        return out

    # --------------------------------------------------------------- listing
    def listing(self, exprs, cse=True):
        """The straight-line code computing ``exprs``: assignments and outputs.

        With ``cse``, common subexpressions of all definitions and outputs are
        eliminated jointly and the new temporaries are placed right before
        their first use, after everything they refer to.  The elimination is
        SymPy's repeated-subtree pass (``tree_cse``, the core of ``sympy.cse``,
        as :mod:`._cse` makes it)
        without ``sympy.cse``'s search for common factors of sums and products
        (``opt_cse``): that search took two thirds of the time and its savings
        (5 % fewer operations at chain3d n = 30) are found again by the C
        compiler (the same run time of the generated right-hand side).

        Returns
        -------
        assignments : list of (Symbol, Expr)
            In evaluation order.
        outputs : list of Expr
            ``exprs`` in terms of the assigned symbols.
        """
        exprs = [sm.sympify(e, strict=True) for e in exprs]
        needed = self.needed(exprs)
        if not cse or not needed:
            return [(s, self._defs[s]) for s in needed], exprs
        defs = [self._defs[s] for s in needed]
        # numbered, not fresh: the same program gives the same listing in a process
        # (set iteration follows the temporaries' hashes), so source made again
        # for a pickle is the source compiled here
        temporaries = (sm.Dummy(f"kd_cse{i}", dummy_index=i) for i in itertools.count())
        replacements, reduced = _eliminate(defs + exprs, temporaries)
        nodes = dict(replacements)
        nodes.update(zip(needed, reduced[:len(needed)]))
        ordered, done = [], set()
        for root in list(needed) + [x for x, _ in replacements]:
            stack = [(root, False)]
            while stack:  # depth first: dependencies before the node
                node, expanded = stack.pop()
                if node in done:
                    continue
                if expanded:
                    done.add(node)
                    ordered.append((node, nodes[node]))
                    continue
                stack.append((node, True))
                stack.extend((d, False) for d in free_symbols_of(nodes[node])
                             if d in nodes and d not in done)
        return ordered, list(reduced[len(needed):])

    # ----------------------------------------------------------------- sizes
    def count_ops(self, exprs, cse=False, memo=None):
        """Operations in ``exprs`` and all intermediates they need.

        ``cse=True`` counts after the joint elimination of :meth:`listing`.
        ``memo``: a dict of the counts of expressions already counted, kept
        across calls (the intermediates that several counts share are counted
        by SymPy once; ``sm.count_ops`` is most of the time of a count).
        """
        assignments, outputs = self.listing(exprs, cse=cse)
        memo = {} if memo is None else memo
        total = 0
        for e in [e for _, e in assignments] + list(outputs):
            n = memo.get(e)
            if n is None:
                n = memo[e] = int(sm.count_ops(e))
            total += n
        return int(total)

    def operation_kinds(self, exprs, cse=False):
        """Operations of :meth:`count_ops` by kind.

        Returns
        -------
        dict
            ``multiplications`` (products, quotients, negations),
            ``additions`` (sums, differences), ``powers`` and
            ``functions`` (calls of sin, cos, sqrt, ...); their sum is
            :meth:`count_ops` (every operation is of one kind).
        """
        assignments, outputs = self.listing(exprs, cse=cse)
        counts = {"multiplications": 0, "additions": 0, "powers": 0, "functions": 0}
        kinds = {"MUL": "multiplications", "DIV": "multiplications", "NEG": "multiplications",
                 "ADD": "additions", "SUB": "additions", "POW": "powers"}
        for e in [e for _, e in assignments] + list(outputs):
            visual = sm.count_ops(e, visual=True)
            for term in sm.Add.make_args(visual):
                coeff, symbol = term.as_coeff_Mul()
                if symbol.is_Symbol:
                    counts[kinds.get(symbol.name, "functions")] += int(coeff)
        return counts


def _eliminate(exprs, symbols):
    """``(replacements, reduced)`` of the repeated subtrees of ``exprs``.

    The trees are rebuilt around the new temporaries without SymPy's
    automatic evaluation: each is the original tree with its repeated parts
    named, which evaluation would only have rebuilt node by node (half the
    time of the pass; chain3d gives the same right-hand side to the bit).
    :func:`._cse.eliminate_repeated` gives what SymPy's ``tree_cse`` gives
    (``order="none"``, unevaluated) in a third of its time: the trees without
    a temporary are not constructed again."""
    return eliminate_repeated(exprs, symbols)


_DERIVATIVES = {
    sm.sin: lambda a: sm.cos(a),
    sm.cos: lambda a: -sm.sin(a),
    sm.tan: lambda a: 1 + sm.tan(a) ** 2,
    sm.exp: lambda a: sm.exp(a),
    sm.log: lambda a: 1 / a,
    sm.asin: lambda a: 1 / sm.sqrt(1 - a ** 2),
    sm.acos: lambda a: -1 / sm.sqrt(1 - a ** 2),
    sm.atan: lambda a: 1 / (1 + a ** 2),
    sm.sinh: lambda a: sm.cosh(a),
    sm.cosh: lambda a: sm.sinh(a),
    sm.tanh: lambda a: 1 - sm.tanh(a) ** 2,
    sm.Abs: lambda a: sm.sign(a),  # all quantities are real
    sm.sign: lambda a: _ZERO,
}


class kd_dpow(sm.Function):  # noqa: N801  (its name is what the generated code calls)
    r"""The derivative :math:`e\,b^{e-1}\,db` of a power :math:`b^e` (a
    fractional :math:`e < 1`, or a parameter), that is 0 where :math:`db = 0`.

    The chain rule through :math:`|v| = \sqrt{v\cdot v}` at :math:`v = 0`
    gives :math:`0 \cdot \infty` (its factor :math:`b^{e-1}` is singular,
    while :math:`db = 2v\cdot dv` vanishes); every product of :math:`|v|` with
    a factor that vanishes there (quadratic drag :math:`|v|v`) is
    differentiable at :math:`v = 0`, with this value.  Where :math:`db \neq 0`
    at :math:`b = 0` the derivative is infinite, and so is this.  Made by
    :meth:`Program.diff` with ``guarded=True`` (numerical derivatives, not the
    derivation); the backends print it as a call of ``kd_dpow``.
    """

    nargs = 3

    @classmethod
    def eval(cls, base, exponent, db):
        if db.is_zero:
            return _ZERO
        return None


def _is_zero(x):
    """``x == 0`` (a SymPy expression other than a number is not 0)."""
    if isinstance(x, sm.Basic):
        return x is _ZERO or (x.is_Number and x == 0)
    return x == 0


def _finite_coefficient(c):
    """Whether the number ``c`` is one SymPy keeps as a product's coefficient
    as it is: a nonzero rational, or a nonzero finite float."""
    if c.is_Rational:
        return c is not _ZERO
    # a float's mantissa is 0 for zero, infinities and nan only
    return c.is_Float and bool(c._mpf_[1])


def _plain_product(args):
    """``(coefficient, factors, bases)`` of the arguments of a product as
    SymPy's ``Mul`` makes them, or ``False`` where :func:`_replaced_factor`
    cannot rebuild a product of them.

    ``args`` are taken as SymPy's canonical ones where they are: a finite
    nonzero number first or none, then factors as :func:`_plain_factors`
    accepts them.
    """
    if args[0].is_Number:
        coefficient, factors = args[0], args[1:]
        if not _finite_coefficient(coefficient):
            return False
    else:
        coefficient, factors = _ONE, args
    bases = _plain_factors(factors)
    return False if bases is None else (coefficient, factors, bases)


@functools.lru_cache(maxsize=1 << 14)
def _plain_factors(factors):
    """``{base: position}`` of the factors of a product, or ``None`` unless
    they are commutative symbols, functions, powers or sums in SymPy's sort
    order, no two with the same base (:meth:`~sympy.core.expr.Expr.as_base_exp`,
    so ``exp(x)`` has the base ``E``), none a power of a number or of ``I``.
    Kept for the last products seen (a definition's products are met once
    per variable; numbers, whose hash SymPy computes anew each time, are
    not part of the key)."""
    bases = {}
    for k, f in enumerate(factors):
        b = _factor_base(f)
        if b is None or b in bases:
            return None
        bases[b] = k
        if k and factors[k - 1].compare(f) >= 0:
            return None
    return bases


def _factor_base(f):
    """The base of ``f`` as a factor :func:`_replaced_factor` places
    (a commutative symbol, function, power or sum whose base is not a number
    or ``I``), else ``None``."""
    if not (f.is_Symbol or f.is_Function or f.is_Pow or f.is_Add) or f.is_commutative is not True:
        return None
    b = f.as_base_exp()[0]
    return None if b.is_Number or b is sm.I else b


def _replaced_factor(product, i, da):
    r"""``Mul(*args)`` with ``args[i]`` replaced by ``da``, built without
    SymPy's ``Mul.flatten`` where the result is the plain product: a term
    :math:`\partial a_i \prod_{k \neq i} a_k` of the product rule.

    ``product`` is :func:`_plain_product` of ``args``; see :func:`_merged`.
    """
    coefficient, factors, bases = product
    if i == 0 and coefficient is not _ONE:
        return None  # the coefficient itself (its derivative is 0)
    return _merged(product, i - 1 if coefficient is not _ONE else i, da)


def _times(a, b):
    """``a * b`` (``Mul(a, b)`` of SymPy expressions, a Python integer taken as
    SymPy's), built as :func:`_merged` builds products where it can."""
    if type(a) is int and isinstance(b, sm.Expr):
        a = sm.Integer(a)
    elif type(b) is int and isinstance(a, sm.Expr):
        b = sm.Integer(b)
    if not (isinstance(a, sm.Expr) and isinstance(b, sm.Expr)) or (a.is_Number and b.is_Number) \
            or a is _ZERO or b is _ZERO:
        return a * b
    product = _plain_product(a.args if a.is_Mul else (a,))
    found = None if product is False else _merged(product, None, b)
    return a * b if found is None else found


def _merged(product, k, da):
    r"""The product ``product`` (:func:`_plain_product`) without its factor
    ``k`` (``None``: none left out) times ``da``, built without SymPy's
    ``Mul.flatten`` where the result is the plain product; ``None`` where it
    is not.

    The new coefficient is the product of the two numbers (in ``flatten``'s
    order), the factors of ``da`` are put where SymPy's sort puts them.
    ``None`` where ``flatten`` would do more: a zero or infinite coefficient,
    a factor of ``da`` with the base of another factor (``x * x = x**2``), a
    product of a number and a sum (which SymPy distributes), ``da`` not a
    number, a factor or a product of them; the caller then calls ``Mul``.
    """
    coefficient, factors, bases = product
    if not isinstance(da, sm.Basic):
        return None  # a Python number from a caller's derivative_of
    if da.is_Number:
        number, new, new_bases = da, (), ()
    elif da.is_Mul:
        inner = _plain_product(da.args)
        if inner is False:
            return None
        number, new, new_bases = inner
    else:
        b = _factor_base(da)
        if b is None:
            return None
        number, new, new_bases = _ONE, (da,), (b,)
    c = number if coefficient is _ONE else coefficient * number if number is not _ONE \
        else coefficient
    if not _finite_coefficient(c):
        return None
    rest = list(factors) if k is None else list(factors[:k] + factors[k + 1:])
    for b in new_bases:
        at = bases.get(b)
        if at is not None and at != k:
            return None
    for f in new:
        insort(rest, f, key=_args_sortkey)
    if c is not _ONE:
        rest.insert(0, c)
    if len(rest) <= 2 and any(f.is_Add for f in rest):
        return None  # 2*(x + y) is distributed (and the two-factor rules of flatten)
    return sm.Mul._exec_constructor_postprocessors(sm.Mul._from_args(rest, True))


def _plus(a, b):
    """``a + b`` (``Add(a, b)`` of SymPy expressions), built by :func:`_sum`
    where it can."""
    if not (isinstance(a, sm.Expr) and isinstance(b, sm.Expr)) or (a.is_Number and b.is_Number):
        return a + b
    return _sum([a, b])


def difference(a, b):
    """``a - b`` (``Add(a, -b)`` of SymPy expressions), built by :func:`_sum`
    where it can."""
    if not (isinstance(a, sm.Expr) and isinstance(b, sm.Expr)) or (a.is_Number and b.is_Number):
        return a - b
    return _sum([a, -b])


def _sum(terms):
    """``Add(*terms)``, built without SymPy's ``Add.flatten`` where the
    result is the plain sum of the terms (and of those of any sum among
    them) in SymPy's sort order: no numbers, no two like terms (equal but
    for their numerical coefficients), each a commutative product, power,
    symbol or function, no power of a number.  ``Add`` otherwise."""
    flat = []
    for t in terms:
        if t is _ZERO:
            continue
        if not isinstance(t, sm.Basic):
            return sm.Add(*terms)
        if t.is_Add:
            flat.extend(t.args)
        else:
            flat.append(t)
    if len(flat) < 2:
        return flat[0] if flat else _ZERO
    seen = set()
    for t in flat:
        if t.is_Mul:
            args = t.args
            if args[0].is_Number:
                if not _finite_coefficient(args[0]):
                    return sm.Add(*terms)
                args = args[1:]
        elif t.is_Symbol or t.is_Function or (t.is_Pow and not t.args[0].is_Number):
            args = (t,)
        else:
            return sm.Add(*terms)
        if args in seen or t.is_commutative is not True:
            return sm.Add(*terms)
        seen.add(args)
    flat.sort(key=_args_sortkey)
    return sm.Add._exec_constructor_postprocessors(sm.Add._from_args(flat, True))


def total_derivative(expr, derivative_of, guarded=False):
    r"""Total derivative :math:`\sum_s \partial e/\partial s\; ds` in one pass.

    ``derivative_of(symbol)`` gives :math:`ds` for every free symbol (``0``
    for constants).  Common node types are differentiated directly; others
    fall back to SymPy's ``diff``.  ``guarded`` (numerical derivatives): the
    derivatives of fractional powers below 1 and of powers with a parameter as
    exponent are :class:`kd_dpow` (0 where their base's derivative is, with no
    division by the base), and those of two-argument ``Max`` and ``Min`` are
    taken branch by branch, so that no singular factor is left unguarded.

    The product rule's terms and the sums are the expressions ``Mul`` and
    ``Add`` make, built directly where they are plain products and sums
    (:func:`_replaced_factor`, :func:`_sum`; most are): a third of the time
    the derivatives of the OC3 spar take.
    """
    if expr.is_Symbol:
        return derivative_of(expr)
    if expr.is_Number or expr.is_NumberSymbol:
        return _ZERO
    if expr.is_Add:
        return _sum([total_derivative(a, derivative_of, guarded) for a in expr.args])
    if expr.is_Mul:
        args = expr.args
        product = None  # (coefficient, factors, bases) once a term is formed
        terms = []
        for i, a in enumerate(args):
            da = total_derivative(a, derivative_of, guarded)
            if _is_zero(da):
                continue
            if product is None:
                product = _plain_product(args)
            term = None if product is False else _replaced_factor(product, i, da)
            terms.append(sm.Mul(*(args[:i] + (da,) + args[i + 1:])) if term is None else term)
        return _sum(terms)
    if expr.is_Pow:
        base, exponent = expr.args
        db = total_derivative(base, derivative_of, guarded)
        if exponent.is_Number:
            if db is _ZERO or db == 0:
                return _ZERO
            if guarded and not exponent.is_Integer and exponent < 1:
                return kd_dpow(base, exponent, db)
            return exponent * base ** (exponent - 1) * db
        de = total_derivative(exponent, derivative_of, guarded)
        if not guarded:
            return expr * (de * sm.log(base) + exponent * db / base)
        # a power law with a parameter as exponent (a stop's contact force,
        # its base 0 out of contact): no division by the base
        varying_exponent = _ZERO if de is _ZERO or de == 0 else sm.Piecewise(
            (_ZERO, sm.Eq(base, 0)), (expr * sm.log(base) * de, True))
        return kd_dpow(base, exponent, db) + varying_exponent
    rule = _DERIVATIVES.get(expr.func)
    if rule is not None:
        (a,) = expr.args
        da = total_derivative(a, derivative_of, guarded)
        if da is _ZERO or da == 0:
            return _ZERO
        return rule(a) * da
    if guarded and expr.func in (sm.Max, sm.Min) and len(expr.args) == 2:
        # the derivative of the branch taken (their mean where they meet), each
        # branch differentiated here: SymPy's would leave its powers unguarded
        a, b = expr.args
        first = sm.Heaviside(a - b) if expr.func is sm.Max else sm.Heaviside(b - a)
        return (first * total_derivative(a, derivative_of, guarded)
                + (1 - first) * total_derivative(b, derivative_of, guarded))
    if expr.func is sm.atan2:
        y, x = expr.args
        dy = total_derivative(y, derivative_of, guarded)
        dx = total_derivative(x, derivative_of, guarded)
        return (x * dy - y * dx) / (x ** 2 + y ** 2)
    terms = []
    for s in expr.free_symbols:
        ds = derivative_of(s)
        if ds is _ZERO or ds == 0:
            continue
        terms.append(expr.diff(s) * ds)
    return sm.Add(*terms)


_LANE_FUNCS = {sm.sin: np.sin, sm.cos: np.cos, sm.tan: np.tan, sm.exp: np.exp, sm.log: np.log,
               sm.asin: np.arcsin, sm.acos: np.arccos, sm.atan: np.arctan, sm.sinh: np.sinh,
               sm.cosh: np.cosh, sm.tanh: np.tanh}
_ANALYTIC = frozenset(_LANE_FUNCS)


def _analytic(expr):
    """True when ``expr`` is built of sums, products, powers and the analytic
    functions of :data:`_ANALYTIC` only (a complex step through it is exact)."""
    stack = [expr]
    while stack:
        e = stack.pop()
        if e.is_Symbol or e.is_Number or e.is_NumberSymbol or e is sm.I:
            continue
        if not (e.is_Add or e.is_Mul or e.is_Pow or e.func in _ANALYTIC):
            return False
        stack.extend(e.args)
    return True


def _lane_eval(expr, value_of, memo):
    """Value of an analytic expression (:func:`_analytic`) whose leaves may be
    arrays of complex lanes (``value_of(symbol)``); ``memo`` by node."""
    if expr.is_Symbol:
        return value_of(expr)
    if expr.is_Number:
        value = _NUMBERS.get(expr)  # the value complex() gives, found again
        if value is None:
            value = _NUMBERS[expr] = complex(expr)
        return value
    if expr.is_NumberSymbol or expr is sm.I:
        return complex(expr)
    found = memo.get(expr)
    if found is not None:
        return found
    args = [_lane_eval(a, value_of, memo) for a in expr.args]
    if expr.is_Add:
        value = sum(args[1:], args[0])
    elif expr.is_Mul:
        value = args[0]
        for a in args[1:]:
            value = value * a
    elif expr.is_Pow:
        exponent = expr.args[1]
        value = args[0] ** (int(exponent) if exponent.is_Integer else args[1])
    else:
        value = _LANE_FUNCS[expr.func](args[0])
    memo[expr] = value
    return value


def _rebuild(expr, values):
    """``expr`` with symbols replaced from ``values``; sums, products and
    powers unevaluated."""
    if expr.is_Symbol:
        return values.get(expr, expr)
    if expr.is_Atom:
        return expr
    args = [_rebuild(a, values) for a in expr.args]
    if expr.is_Add or expr.is_Mul or expr.is_Pow:
        return expr.func(*args, evaluate=False)
    return expr.func(*args)


def _node_count(expr, sizes):
    """Nodes of ``expr``'s tree, symbols in ``sizes`` counting as that many."""
    if expr.is_Symbol:
        return sizes.get(expr, 1)
    if expr.is_Atom:
        return 1
    return 1 + sum(_node_count(a, sizes) for a in expr.args)


def _evaluate(expr, value_of):
    """Numerical (complex) value of a SymPy expression; ``nan`` on failure."""
    try:
        return complex(fast_eval(expr, value_of, {}))
    except (TypeError, ValueError, ZeroDivisionError, OverflowError):
        return complex("nan")


_FUNCS = {
    sm.sin: cmath.sin, sm.cos: cmath.cos, sm.tan: cmath.tan, sm.exp: cmath.exp,
    sm.log: cmath.log, sm.asin: cmath.asin, sm.acos: cmath.acos,
    sm.atan: cmath.atan, sm.sinh: cmath.sinh, sm.cosh: cmath.cosh,
    sm.tanh: cmath.tanh, sm.Abs: abs,
    sm.sign: lambda x: complex((x.real > 0) - (x.real < 0)),
    sm.atan2: lambda y, x: complex(math.atan2(y.real, x.real)),
}


_NUMBERS = {}  # SymPy number -> complex value (keyed by equality, not by hash)


def fast_eval(expr, value_of, memo):
    """Evaluate a SymPy expression tree with complex floats.

    ``value_of(node)`` gives the value of symbols and other leaves (applied
    undefined functions, derivatives).  Equal subtrees are evaluated once:
    ``memo`` is keyed by SymPy's structural hash, so that equal subtrees that
    are distinct objects (common in SymPy's expanded expressions) are found
    without deep comparisons.  Unknown node types fall back to ``evalf``.
    The values serve randomized identity tests, for which a hash collision
    (probability ~2**-64 per lookup) is immaterial; numbers, whose hashes
    collide by design (``hash(-1) == hash(-2)``), are not memoized.
    """
    if expr.is_Number:  # not memoized by hash: hash(-1) == hash(-2) in CPython
        value = _NUMBERS.get(expr)
        if value is None:
            value = _NUMBERS[expr] = complex(expr)
        return value
    key = hash(expr)
    found = memo.get(key)
    if found is not None:
        return found
    if expr.is_Symbol:
        value = value_of(expr)
    elif expr.is_Add:
        value = sum(fast_eval(a, value_of, memo) for a in expr.args)
    elif expr.is_Mul:
        value = 1
        for a in expr.args:
            value *= fast_eval(a, value_of, memo)
    elif expr.is_Pow:
        base = fast_eval(expr.args[0], value_of, memo)
        e = expr.args[1]
        if e.is_Integer:
            value = base ** int(e)
        else:
            value = base ** fast_eval(e, value_of, memo)
    elif expr.func in _FUNCS:
        value = _FUNCS[expr.func](*(fast_eval(a, value_of, memo) for a in expr.args))
    elif expr.is_NumberSymbol:
        value = complex(expr.evalf())
    elif isinstance(expr, (AppliedUndef, sm.Derivative)):
        value = value_of(expr)
    else:
        subs = {s: fast_eval(s, value_of, memo) for s in expr.free_symbols}
        value = complex(expr.xreplace({k: sm.Float(v.real) + sm.I * sm.Float(v.imag)
                                       for k, v in subs.items()}).evalf())
    value = complex(value)
    memo[key] = value
    return value


class _Sampler:
    """Callable giving each symbol a reproducible value in [0.5, 1.5); picklable."""

    __slots__ = ("rng", "cache")

    def __init__(self, seed):
        self.rng = random.Random(seed)
        self.cache = {}

    def __call__(self, symbol):
        value = self.cache.get(symbol)
        if value is None:
            value = self.cache[symbol] = complex(self.rng.uniform(0.5, 1.5))
        return value

    def __getstate__(self):
        return self.rng.getstate(), self.cache

    def __setstate__(self, state):
        self.rng = random.Random()
        self.rng.setstate(state[0])
        self.cache = state[1]


def random_sampler(seed):
    """A sampler giving each symbol a reproducible value in [0.5, 1.5)."""
    return _Sampler(seed)
