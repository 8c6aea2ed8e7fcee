"""Values a user hands in as SymPy expressions, converted without running text.

SymPy's ``sympify`` parses a string by running it as Python, so every value that
comes from a user (a potential energy, a friction coefficient, a surface's radius)
goes through :func:`as_expression`: SymPy objects and Python or NumPy numbers are
converted as ``sympify(..., strict=True)`` converts them, text is refused before
SymPy sees it, and so is anything else SymPy does not convert strictly.
"""

from __future__ import annotations

import sympy as sm

from ._errors import ModelError

__all__ = ["as_expression"]


def as_expression(value, what):
    """``value`` as a SymPy expression.

    Parameters
    ----------
    value : sympy.Basic, int, float or a NumPy number
    what : str
        What the value is, for the error (``"contact c1: mu_k"``).

    Returns
    -------
    sympy.Basic

    Raises
    ------
    ModelError
        For text (never parsed: it would run as Python) and for anything SymPy
        does not convert strictly (a Vector, a list), naming ``what``.
    """
    if isinstance(value, (str, bytes)):
        raise ModelError(f"{what} is the text {value!r}; give a number or a SymPy "
                         "expression (text is never run as code)")
    try:
        return sm.sympify(value, strict=True)
    except sm.SympifyError:
        raise ModelError(f"{what} must be a number or a SymPy expression, got "
                         f"{type(value).__name__} {value!r}") from None
