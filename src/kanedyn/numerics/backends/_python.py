"""Python source generated from a straight-line program.

The generated function evaluates only the intermediates its outputs need, one
assignment per intermediate, with scalar ``math`` functions, and returns NumPy
arrays.  Its arguments are ``(t, y, p, r)``: time, state, constants and
specified inputs, each an indexable sequence.
"""

from __future__ import annotations

import functools
import math
import weakref

import numpy as np
import sympy as sm
from sympy.printing.numpy import SciPyPrinter
from sympy.printing.pycode import PythonCodePrinter

from ..._errors import KanedynError

__all__ = ["CodegenError", "generate_python", "compile_python"]


class CodegenError(KanedynError, ValueError):
    """An expression cannot be turned into code."""


class _Printer(PythonCodePrinter):
    """Scalar Python with ``math``; functions ``math`` lacks come from SciPy."""

    def __init__(self, names):
        super().__init__({"fully_qualified_modules": True, "standard": "python3",
                          "strict": True, "order": "none"})
        self._names = names

    def _print_Symbol(self, expr):
        try:
            return self._names[expr]
        except KeyError:
            raise CodegenError(f"symbol {expr} has no value in the generated code") \
                from None

    _print_Dummy = _print_Symbol

    def _print_not_supported(self, expr):
        return _SciPyFallback(self._names).doprint(expr)

    def _print_kd_dpow(self, expr):
        return f"_kd_dpow({', '.join(self._print(a) for a in expr.args)})"


class _SciPyFallback(SciPyPrinter):
    def __init__(self, names):
        super().__init__({"fully_qualified_modules": True, "strict": True, "order": "none"})
        self._names = names

    _print_Symbol = _Printer._print_Symbol
    _print_Dummy = _Printer._print_Symbol


class _VectorPrinter(SciPyPrinter):
    """Prints NumPy (and SciPy) calls: every intermediate is an array of states."""

    def __init__(self, names):
        super().__init__({"fully_qualified_modules": True, "strict": True, "order": "none"})
        self._names = names

    _print_Symbol = _Printer._print_Symbol
    _print_Dummy = _Printer._print_Symbol

    def _print_kd_dpow(self, expr):
        return f"_kd_dpow_lanes({', '.join(self._print(a) for a in expr.args)})"


class _Unusual(Exception):
    """An expression :func:`_direct` leaves to SymPy's printer."""


#: SymPy's precedences (``sympy.printing.precedence``) of what :func:`_direct` prints
_ADD, _MUL, _POW, _FUNC, _ATOM = 40, 50, 60, 70, 1000


def _print_python(printer, expr):
    """``printer.doprint(expr)``: by :func:`_direct` where ``printer`` is the scalar
    :class:`_Printer` and ``expr`` is made of what it prints, else by SymPy."""
    if type(printer) is _Printer and isinstance(expr, sm.Basic) and not expr.is_Float:
        try:
            return _direct(expr, printer)
        except _Unusual:
            pass
    return printer.doprint(expr)


def _direct(expr, printer):
    """The text ``printer.doprint(expr)`` gives, for the symbols, integers,
    rationals, finite floats, sums, products, powers and ``math`` functions
    that make up nearly all generated statements, without SymPy's printing
    machinery (``doprint`` walks the expression for ``re`` first, and
    ``precedence`` negates every product to look for a sign: 93 % of the time of
    the NumPy backend's derivatives of chain3d n = 12 went to the printer);
    raises :class:`_Unusual` for anything else.  The same text, so the same
    code: SymPy's rules (``StrPrinter._print_Add``, ``CodePrinter._print_Mul``,
    ``PythonCodePrinter._hprint_Pow``, ``parenthesize``) applied as they are,
    for a float below the top its digits as SymPy prints them there."""
    level = printer._print_level
    printer._print_level = 2  # what a float nested in the expression is printed at
    try:
        return _text(expr, printer)
    finally:
        printer._print_level = level


def _text(expr, printer):
    if expr.is_Symbol:
        return printer._print_Symbol(expr)
    if expr.is_Number:
        if expr.is_Integer:
            return str(expr.p)
        if expr.is_Rational:
            return f"{expr.p}/{expr.q}"
        if expr.is_Float and math.isfinite(float(expr)):
            return printer._print_Float(expr)
        raise _Unusual
    if expr.is_Add:
        parts = []
        for term in expr.args:
            text = _text(term, printer)
            if text.startswith("-") and not term.is_Add:
                parts.append("-")
                text = text[1:]
            else:
                parts.append("+")
            parts.append(f"({text})" if term.is_Add or _precedence(term) < _ADD else text)
        sign = parts.pop(0)
        return ("" if sign == "+" else sign) + " ".join(parts)
    if expr.is_Mul:
        return _product(expr, printer)
    if expr.is_Pow:
        return _power(expr.base, expr.exp, printer)
    name = _CALLS.get(type(expr))
    if name is None:
        raise _Unusual
    return f"{name}({', '.join(_text(a, printer) for a in expr.args)})"


def _precedence(expr):
    """``sympy.printing.precedence.precedence(expr)`` of what :func:`_text` prints."""
    if expr.is_Symbol:
        return _ATOM
    if expr.is_Number:
        if expr.is_Integer:
            return _ADD if expr.p < 0 else _ATOM
        if expr.is_Rational:
            return _ADD if expr.p < 0 else _MUL
        if expr.is_Float:
            return _ADD if float(expr) < 0 else _ATOM
        raise _Unusual
    if expr.is_Add:
        return _ADD
    if expr.is_Mul:
        first = expr.args[0]
        if first.is_Number and not (first.is_Rational or first.is_Float):
            raise _Unusual  # zoo and the like: SymPy's test differs
        return _ADD if first.is_Number and _negative(first) else _MUL
    if expr.is_Pow:
        return _POW
    if type(expr) in _CALLS:
        return _FUNC
    raise _Unusual


def _negative(number):
    return number.p < 0 if number.is_Rational else float(number) < 0


def _parenthesized(expr, level, printer):
    """``parenthesize(expr, level, strict=False)``."""
    text = _text(expr, printer)
    return f"({text})" if _precedence(expr) <= level else text


def _product(expr, printer):
    """``CodePrinter._print_Mul`` (the order of the factors kept: ``order="none"``)."""
    prec = _precedence(expr)
    factors = expr.args
    sign = ""
    if factors[0].is_Number and _negative(factors[0]):
        # SymPy prints -c * rest as "-" and the product _keep_coeff(c, rest)
        sign, coefficient, factors = "-", -factors[0], factors[1:]
        if any(f.is_Number for f in factors):
            raise _Unusual  # a product not in canonical form
        if coefficient is not sm.S.One:
            if len(factors) == 1 and (factors[0].is_Add or factors[0].is_Pow
                                      and factors[0].base.is_Number):
                raise _Unusual  # c * rest evaluated would not be these two factors
            factors = (coefficient, *factors)
    above, below = [], []
    for item in factors:
        if item.is_Pow and item.exp.is_Rational and item.exp.is_negative \
                and item.is_commutative:
            if item.exp is sm.S.NegativeOne:
                if item.base.is_Mul:
                    raise _Unusual  # SymPy's extra parentheses (its issue 14160)
                below.append((item.base, None))
            else:
                below.append((item.base, -item.exp))
        else:
            above.append(item)
    if len(above) == 1 and sign == "-":
        top = [_parenthesized(above[0], 0.5 * (_POW + _MUL), printer)]
    else:
        top = [_parenthesized(item, prec, printer) for item in above] or ["1"]
    bottom = [_parenthesized(base, prec, printer) if exp is None
              else _power(base, exp, printer)  # a power binds tighter than any prec here
              for base, exp in below]
    text = sign + "*".join(top)
    if len(bottom) == 1:
        return f"{text}/{bottom[0]}"
    if bottom:
        return f"{text}/({'*'.join(bottom)})"
    return text


def _power(base, exp, printer):
    """``PythonCodePrinter._hprint_Pow`` of ``base ** exp``."""
    if exp == sm.S.Half:
        return f"math.sqrt({_text(base, printer)})"
    if base.is_commutative and exp.is_commutative:
        if -exp is sm.S.Half:
            return f"1/math.sqrt({_text(base, printer)})"
        if exp is sm.S.NegativeOne:
            return f"1/{_parenthesized(base, _POW, printer)}"
    return f"{_parenthesized(base, _POW, printer)}**{_parenthesized(exp, _POW, printer)}"


def _kd_dpow(b, e, db):
    """``kanedyn.engine.kd_dpow``: :math:`e\\,b^{e-1}db`, 0 where ``db == 0``."""
    return 0.0 if db == 0 else e * math.pow(b, e - 1) * db


def _kd_dpow_lanes(b, e, db):
    """:func:`_kd_dpow` of arrays."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(db == 0, 0.0, e * np.power(b, e - 1) * db)


def _stack(values, shape, k):
    """Array of shape ``shape + (k,)`` from entries that are scalars or (k,) arrays."""
    out = np.empty((len(values), k))
    for i, v in enumerate(values):
        out[i] = v
    return out.reshape(tuple(shape) + (k,))


def generate_python(program, name, arguments, outputs, origin=None, vectorized=False,
                    cse=False):
    """Source of a function ``name(t, y, p, r)``.

    Parameters
    ----------
    program : Program
    name : str
    arguments : dict
        ``{"y": [symbols], "p": [symbols], "r": [symbols]}``: which symbol is
        which entry of each argument.
    outputs : list of (shape, list of expressions)
        Returned in order; shape ``()`` is a scalar, ``(n,)`` a vector,
        ``(n, m)`` a matrix (row-major expression list).
    origin : callable, optional
        ``origin(expr)`` describes where an expression came from (for errors).
    vectorized : bool
        Generate NumPy code for many states at once: ``y`` has shape
        ``(n_states, k)``, ``p`` and ``r`` entries are scalars or ``(k,)``
        arrays, and every output gets a trailing axis of length ``k``.
    cse : bool
        Eliminate common subexpressions jointly first (:meth:`Program.listing`).

    Returns
    -------
    str

    Notes
    -----
    The source is kept for the program (while it lives), under everything it
    is made from: a program gives the same listing of the same expressions
    every time (:meth:`Program.listing`), so a function asked for again (a
    second numerical model of the same equations: other constants, another
    constraint scheme) is that text, not printed again (SymPy's printer took
    93 % of making a model of the Stewart platform's Lagrange equations).
    """
    key = (name, vectorized, bool(cse),
           tuple((arg, tuple(symbols)) for arg, symbols in arguments.items()),
           tuple((tuple(shape), tuple(exprs)) for shape, exprs in outputs))
    try:
        hash(key)
    except TypeError:  # an output not a SymPy expression or a number: made each time
        return _generate_python(program, name, arguments, outputs, origin, vectorized, cse)
    made = _SOURCES.setdefault(program, {})
    source = made.get(key)
    if source is None:
        source = _generate_python(program, name, arguments, outputs, origin, vectorized,
                                  cse)
        if len(made) >= SOURCES_PER_PROGRAM:  # bounded: the oldest goes
            made.pop(next(iter(made)))
        made[key] = source
    return source


#: program -> {what a function is made from: its source} (see generate_python)
_SOURCES = weakref.WeakKeyDictionary()
#: the sources kept per program: a model's functions and its derivatives' with
#: room to spare; models made with numbers substituted for inputs (a new text
#: each) do not grow it without bound
SOURCES_PER_PROGRAM = 32


def _generate_python(program, name, arguments, outputs, origin, vectorized, cse):
    """:func:`generate_python` itself, without the kept sources."""
    names = {program.t: "t"}
    lines = [f"def {name}(t, y, p, r):"]
    if vectorized:
        lines.append("    _k = y.shape[1]")
    for arg, symbols in arguments.items():
        for i, s in enumerate(symbols):
            local = f"_{arg}{i}"
            names[s] = local
            lines.append(f"    {local} = {arg}[{i}]")
    printer = _VectorPrinter(names) if vectorized else _Printer(names)
    flat = [e for _, exprs in outputs for e in exprs]
    assignments, flat = program.listing(flat, cse=cse)
    for k, (s, expr) in enumerate(assignments):
        local = f"_z{k}"
        try:
            code = _print_python(printer, expr)
        except CodegenError as exc:
            raise CodegenError(f"{exc} (in the intermediate {s.name}"
                               f"{origin(s) if origin else ''})") from None
        except Exception as exc:  # printer cannot handle the expression
            raise CodegenError(
                f"cannot generate code for {expr} (intermediate {s.name}): {exc}") from None
        names[s] = local
        lines.append(f"    {local} = {code}")
    results = []
    position = 0
    for k, (shape, exprs) in enumerate(outputs):
        count = len(exprs)
        codes = [_print_python(printer, e) for e in flat[position:position + count]]
        position += count
        if vectorized:
            lines.append(f"    _out{k} = _stack([{', '.join(codes)}], {tuple(shape)}, _k)")
        elif shape == ():
            lines.append(f"    _out{k} = {codes[0]}")
        elif len(shape) == 1:
            lines.append(f"    _out{k} = _array([{', '.join(codes)}], dtype=float)"
                         if codes else f"    _out{k} = _zeros(0)")
        else:
            rows, cols = shape
            if rows * cols == 0:
                lines.append(f"    _out{k} = _zeros(({rows}, {cols}))")
            else:
                body = ", ".join("[" + ", ".join(codes[i * cols:(i + 1) * cols]) + "]"
                                 for i in range(rows))
                lines.append(f"    _out{k} = _array([{body}], dtype=float)")
        results.append(f"_out{k}")
    lines.append(f"    return ({', '.join(results)}{',' if len(results) == 1 else ''})")
    return "\n".join(lines) + "\n"


def _calls():
    """``{function: name}`` of the functions :func:`_direct` prints: ``math``'s, as
    :class:`_Printer` names them, and :func:`~kanedyn.engine.kd_dpow`."""
    from ...engine import kd_dpow
    names = _Printer({}).known_functions
    calls = {f: names[f.__name__] for f in (sm.sin, sm.cos, sm.tan, sm.asin, sm.acos,
                                            sm.atan, sm.atan2, sm.sinh, sm.cosh, sm.tanh,
                                            sm.exp, sm.log, sm.Abs)}
    calls[kd_dpow] = "_kd_dpow"
    return calls


_CALLS = _calls()


class _LazySciPy:
    """``scipy`` for generated code, imported on first attribute access."""

    def __getattr__(self, name):
        import scipy.special
        return getattr(scipy, name)


#: names the generated code uses (functools: NumPy's printer writes Max and Min of
#: arrays as functools.reduce over numpy.maximum/minimum)
_NAMESPACE = {"functools": functools, "math": math, "numpy": np, "scipy": _LazySciPy(),
              "_array": np.array, "_zeros": np.zeros, "_stack": _stack, "_kd_dpow": _kd_dpow,
              "_kd_dpow_lanes": _kd_dpow_lanes}


def compile_python(source, name):
    """Execute generated source and return the function called ``name`` (a new
    function each call; the compiled code of a source met again is reused)."""
    namespace = dict(_NAMESPACE)
    exec(_compiled(source, name), namespace)
    return namespace[name]


@functools.lru_cache(maxsize=32)
def _compiled(source, name):
    """The code object of ``source``: the same source, the same code (a model
    made again of the same equations, :func:`generate_python`)."""
    return compile(source, f"<kanedyn:{name}>", "exec")
