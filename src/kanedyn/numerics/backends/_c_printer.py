"""SymPy's C99 printer as the compiled backend prints what its own printer
(:func:`._c._direct`) leaves to it: symbols by their names in the generated code,
integer powers as products, ``sign`` and :class:`~kanedyn.engine.kd_dpow` as the
runtime's functions, rationals as one correctly rounded literal.  Imported when
first needed (SymPy's printing and code generation modules are not otherwise
needed to compile a model)."""

from __future__ import annotations

import sympy as sm
from sympy.printing.c import C99CodePrinter, get_math_macros

from ._c import _number_literal
from ._python import _Printer

__all__ = ["SymPyCPrinter"]


class SymPyCPrinter(C99CodePrinter):
    """SymPy's C99 printer with the symbols in ``names`` (a dict read as it
    grows) printed as their names; any other symbol is a :class:`CodegenError`."""

    #: SymPy's table of math.h constants, made once (SymPy's printer makes it anew
    #: for every printer unless its class has one: 3 ms each)
    math_macros = None

    def __init__(self, names):
        if SymPyCPrinter.math_macros is None:
            SymPyCPrinter.math_macros = get_math_macros()
        super().__init__({"strict": True, "order": "none"})
        self._names = names

    _print_Symbol = _Printer._print_Symbol  # names, or a CodegenError
    _print_Dummy = _Printer._print_Symbol

    def _print_Pow(self, expr):
        base, exp = expr.args
        b = self.parenthesize(base, 60)  # tighter than multiplication
        if exp.is_Integer:
            n = int(exp)
            if n == 2:
                return f"({b}*{b})"
            if n == 3:
                return f"({b}*{b}*{b})"
            if n == -1:
                return f"(1.0/{b})"
            if n == -2:
                return f"(1.0/({b}*{b}))"
            return f"kd_powi({self._print(base)}, {n})"
        if exp == sm.S.Half:
            return f"sqrt({self._print(base)})"
        if exp == -sm.S.Half:
            return f"(1.0/sqrt({self._print(base)}))"
        return f"pow({self._print(base)}, {self._print(exp)})"

    def _print_sign(self, expr):
        return f"kd_sign({self._print(expr.args[0])})"

    def _print_kd_dpow(self, expr):
        return f"kd_dpow({', '.join(self._print(a) for a in expr.args)})"

    def _print_Rational(self, expr):
        return _number_literal(expr)

    # conditions folded to a constant (a Piecewise's derivative can hold them): C has no
    # true/false without <stdbool.h>
    def _print_BooleanTrue(self, expr):
        return "1"

    def _print_BooleanFalse(self, expr):
        return "0"
