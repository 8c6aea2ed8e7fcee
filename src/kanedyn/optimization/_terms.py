r"""The user's SymPy expressions (objective, path and instance constraints),
read in the model's symbols and compiled with their exact gradients.

An expression may name the time ``t`` (``dynamicsymbols._t``), the states and
inputs as the dynamic symbols the model was written with (``q(t)``,
``F(t)``), the model's constants (a free parameter is a variable, any other is
replaced by its value), and the duration symbol of a free-duration problem.
Anything else is refused, naming the symbol.  Nothing is parsed from text:
expressions go through :func:`kanedyn._expressions.as_expression`.

The gradient is SymPy's derivative of the (small) expression; values and
gradients are one NumPy function (``lambdify``) evaluated on all nodes at once,
of the entries that are not constant (a zero derivative is not evaluated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import ModelError
from .._expressions import as_expression

__all__ = ["Symbols", "Term", "compile_term", "identically_zero", "instance_atoms"]


@dataclass(frozen=True)
class Symbols:
    """How the model's names map to SymPy symbols and to decision variables.

    Attributes
    ----------
    t : sympy.Symbol
        Time (``dynamicsymbols._t``).
    states, inputs : tuple of str
        The model's state names and input names (without ``(t)``).
    constants : dict
        ``{name: value}`` of the model's constants.
    free : tuple of str
        The constants that are free parameters.
    duration : sympy.Symbol or None
        The symbol of a free duration.
    """

    t: object
    states: tuple
    inputs: tuple
    constants: dict
    free: tuple
    duration: object

    def dynamic(self, atom):
        """``("state" | "input", index)`` of a dynamic symbol such as ``q(t)``."""
        name = str(atom.func)
        if name in self.states:
            return "state", self.states.index(name)
        if name in self.inputs:
            return "input", self.inputs.index(name)
        raise ModelError(
            f"{atom.func}(...) is neither a state ({', '.join(self.states)}) nor an input "
            f"({', '.join(self.inputs) or 'the model has none'}) of the model")


def _check_atoms(expr, symbols, what, instances=False):
    """Refuse what an expression may not name; return it with the fixed
    constants replaced by their values."""
    import sympy as sm
    from sympy.core.function import AppliedUndef
    for d in expr.atoms(sm.Derivative):
        raise ModelError(f"{what} contains the derivative {d}; write it with the "
                         "speeds (states) instead")
    fixed = {}
    for s in expr.free_symbols:
        if s == symbols.t or s == symbols.duration:
            continue
        name = str(s)
        if name in symbols.free:
            continue
        if name in symbols.constants:
            fixed[s] = symbols.constants[name]
            continue
        known = ", ".join(list(symbols.constants) + ["t"]
                          + ([str(symbols.duration)] if symbols.duration is not None else []))
        raise ModelError(f"{what} names {s}, which is not a symbol of the model (its "
                         f"constants and times: {known}; states and inputs are written "
                         "as dynamic symbols, q(t))")
    for atom in expr.atoms(AppliedUndef):
        symbols.dynamic(atom)  # raises for a function the model lacks
        if atom.args != (symbols.t,) and not instances:
            raise ModelError(f"{what} contains {atom}: states at given times belong in "
                             "instance constraints")
    return expr.xreplace({k: sm.Float(v) for k, v in fixed.items()})


#: the 0.0 that a block of identically zero entries is a broadcast of
_ZERO = np.zeros(1)
_ZERO.flags.writeable = False


class _Entries:
    """Expressions of ``(t, y, r, p, T)`` evaluated on K points into the
    columns of a (K, n) array: those that SymPy finds constant are stored as
    numbers (a zero is not evaluated at all), the others are one NumPy
    function (``lambdify``) of the points."""

    def __init__(self, expressions, variables):
        import sympy as sm
        self.n = len(expressions)
        self.constants = [(j, float(e)) for j, e in enumerate(expressions)
                          if not e.free_symbols and e != 0]
        varying = [(j, e) for j, e in enumerate(expressions) if e.free_symbols]
        self.columns = [j for j, _ in varying]
        self._fn = (sm.lambdify(variables, [e for _, e in varying], modules="numpy",
                                dummify=True) if varying else None)
        self._plans = {}  # of blocks(), per spans
        self._zeros = {}  # its broadcasts of 0.0, per shape

    def nonzero(self):
        """(n,) bool: the entries not identically zero."""
        out = np.zeros(self.n, dtype=bool)
        out[[j for j, _ in self.constants] + self.columns] = True
        return out

    def __call__(self, K, arguments):
        """The (K, n) array of the entries at the points of ``arguments``."""
        out = np.zeros((K, self.n))
        for j, value in self.constants:
            out[:, j] = value
        if self._fn is not None:
            for j, value in zip(self.columns, self._fn(*arguments)):
                out[:, j] = value
        return out

    def blocks(self, K, arguments, spans):
        """The entries at the points of ``arguments`` by blocks of columns:
        per ``(start, stop, flat)`` of ``spans`` (a tuple) a (K, stop -
        start) array, (K,) with ``flat`` (one column); a block whose entries
        are all identically zero a read-only broadcast of 0.0 (no memory)."""
        plan = self._plans.get(spans)
        if plan is None:  # per block: its columns' places in constants / values
            constant, varying = dict(self.constants), {j: k for k, j in enumerate(self.columns)}
            plan = self._plans[spans] = [
                (start, stop, flat, [(j - start, constant.get(j), varying.get(j))
                                     for j in range(start, stop)
                                     if j in constant or j in varying])
                for start, stop, flat in spans]
        values = self._fn(*arguments) if self._fn is not None else ()
        out = []
        for start, stop, flat, columns in plan:
            shape = (K,) if flat else (K, stop - start)
            if not columns:
                zero = self._zeros.get(shape)
                if zero is None:
                    zero = self._zeros[shape] = np.lib.stride_tricks.as_strided(
                        _ZERO, shape, (0,) * len(shape), writeable=False)
                out.append(zero)
                continue
            block = np.zeros((K, stop - start))
            for column, constant, k in columns:
                block[:, column] = constant if k is None else values[k]
            out.append(block.reshape(shape))
        return out


class Term:
    """A scalar expression of ``(t, y, r, p, T)`` and its gradient, on many nodes.

    ``__call__(t, Y, R, P, T)`` with ``t`` (K,), ``Y`` (K, n_states), ``R``
    (K, n_inputs), ``P`` (n_free,), ``T`` (float) returns ``(value, d_t, d_y,
    d_r, d_p, d_T)``: shapes (K,), (K,), (K, n_states), (K, n_inputs), (K,
    n_free), (K,); a part that is identically zero a read-only broadcast of
    0.0 (not to be written).
    """

    def __init__(self, expr, symbols):
        import sympy as sm
        from sympy.core.function import AppliedUndef
        ns, nr, nf = len(symbols.states), len(symbols.inputs), len(symbols.free)
        y = [sm.Dummy(f"y{k}") for k in range(ns)]
        r = [sm.Dummy(f"r{k}") for k in range(nr)]
        p = [sm.Dummy(f"p{k}") for k in range(nf)]
        t, T = sm.Dummy("t"), sm.Dummy("T")
        swap = {symbols.t: t}
        if symbols.duration is not None:
            swap[symbols.duration] = T
        for name, dummy in zip(symbols.free, p):
            swap.update({s: dummy for s in expr.free_symbols if str(s) == name})
        for atom in expr.atoms(AppliedUndef):
            kind, k = symbols.dynamic(atom)
            swap[atom] = y[k] if kind == "state" else r[k]
        e = expr.xreplace(swap)
        variables = [t] + y + r + p + [T]
        self._first = _Entries([e] + [e.diff(v) for v in variables], variables)
        self._sizes = (ns, nr, nf)
        edges = np.cumsum([0, 1, 1, ns, nr, nf, 1]).tolist()
        flat = (True, True, False, False, False, True)  # value, d_t, ..., d_T
        #: the parts of __call__'s result among the first derivatives' columns
        self._spans = tuple(zip(edges[:-1], edges[1:], flat))
        self._expr, self._variables = e, variables
        self._second = None

    @staticmethod
    def _arguments(t, Y, R, P):
        t = np.asarray(t, dtype=float)
        return t.size, (t, *Y.T, *R.T, *np.asarray(P, dtype=float))

    def _second_derivatives(self):
        """The :class:`_Entries` of the Hessian (made on first use)."""
        if self._second is None:
            us = self._variables[1:-1] + [self._variables[0], self._variables[-1]]
            self._second = _Entries([self._expr.diff(a).diff(b) for a in us for b in us],
                                    self._variables)
        return self._second

    def hessian(self, t, Y, R, P, T):
        """The Hessian (SymPy's second derivatives) in ``u = (y, r, p, t, T)``
        (this order), shape (K, nu, nu), ``nu = n_states + n_inputs + n_free
        + 2``."""
        K, arguments = self._arguments(t, Y, R, P)
        nu = len(self._variables)
        return self._second_derivatives()(K, arguments + (T,)).reshape(K, nu, nu)

    def hessian_pattern(self):
        """(nu, nu) bool: where :meth:`hessian` can be nonzero (SymPy's second
        derivatives that are not identically zero)."""
        nu = len(self._variables)
        return self._second_derivatives().nonzero().reshape(nu, nu)

    def __call__(self, t, Y, R, P, T):
        K, arguments = self._arguments(t, Y, R, P)
        return tuple(self._first.blocks(K, arguments + (T,), self._spans))


def identically_zero(part):
    """Whether ``part`` (an array of a :class:`Term`'s result, or a slice of
    one) is a part that is identically zero: its read-only broadcast of 0.0
    (nothing to add)."""
    return (part.size > 0 and not any(part.strides) and not part.flags.writeable
            and part.flat[0] == 0.0)


def compile_term(value, symbols, what):
    """A :class:`Term` of the user's expression ``value`` (checked, see the
    module's text); ``None`` for ``None``."""
    if value is None:
        return None
    expr = _check_atoms(as_expression(value, what), symbols, what)
    return Term(expr, symbols)


def instance_atoms(value, symbols, what):
    """``(expr, {atom: (kind, index, time)})`` of an instance constraint: the
    states and inputs it names at given times (``q(0)``, ``q(T)``)."""
    from sympy.core.function import AppliedUndef
    expr = _check_atoms(as_expression(value, what), symbols, what, instances=True)
    atoms = {}
    for atom in expr.atoms(AppliedUndef):
        if atom.args == (symbols.t,):
            raise ModelError(f"{what} contains {atom} at the running time t; an instance "
                             "constraint names states at given times, e.g. q(0) or q(T)")
        kind, k = symbols.dynamic(atom)
        atoms[atom] = (kind, k, atom.args[0])
    if not atoms:
        raise ModelError(f"{what} names no state or input at a given time")
    return expr, atoms
