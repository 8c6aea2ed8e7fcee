"""Numbers written as text, read without running any code.

Text that a user types (``--set m=2*pi``) or a file holds is never handed to
``eval`` or ``sympify`` (both run Python).  It is parsed by Python's ``ast``
module, which only builds a syntax tree, and the tree is evaluated here by a
small interpreter that knows numeric literals, ``pi``, ``e``, ``inf``, ``nan``,
``+ - * /``, powers and parentheses, and nothing else: no names, calls,
attributes, subscripts or comprehensions.
"""

from __future__ import annotations

import ast
import math
import operator

from ._errors import KanedynError

__all__ = ["NumberTextError", "parse_number", "finite_number", "MAX_LENGTH"]

#: longest text accepted (characters); longer text is refused before parsing
MAX_LENGTH = 200

_CONSTANTS = {"pi": math.pi, "e": math.e, "inf": math.inf, "nan": math.nan}
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.Pow: operator.pow}
_UNARY = {ast.UAdd: operator.pos, ast.USub: operator.neg}


class NumberTextError(KanedynError, ValueError):
    """Text that is not a number or an arithmetic expression of numbers."""


def parse_number(text, what="value"):
    """The float that ``text`` denotes.

    Parameters
    ----------
    text : str
        A number (``"2"``, ``"-1.5e-3"``) or an arithmetic expression of
        numbers and the constants ``pi``, ``e`` (``"2*pi/3"``, ``"9.81**0.5"``);
        ``^`` is accepted for powers.  ``inf`` and ``nan`` are read as such
        (callers decide whether they are acceptable).
    what : str
        What the text is the value of, for error messages (``"--set m"``).

    Returns
    -------
    float

    Raises
    ------
    NumberTextError
        When the text is anything else; the message names ``what``.

    Examples
    --------
    >>> parse_number("2*pi")
    6.283185307179586
    >>> try:
    ...     parse_number("__import__('os')", "--set m")
    ... except NumberTextError as exc:
    ...     print(str(exc).split(" is ")[0], "is refused")
    --set m: "__import__('os')" is refused
    """
    if not isinstance(text, str):
        raise NumberTextError(f"{what}: expected text, got {type(text).__name__}")
    source = text.strip().replace("^", "**")
    if not source:
        raise NumberTextError(f"{what}: empty value")
    if len(source) > MAX_LENGTH:
        raise NumberTextError(f"{what}: value longer than {MAX_LENGTH} characters")
    try:
        tree = ast.parse(source, mode="eval")
        return float(_evaluate(tree.body))
    except _NotArithmetic as exc:
        raise NumberTextError(
            f"{what}: {text!r} is not a number ({exc}); write a number or arithmetic of "
            "numbers, pi and e with + - * / ** and parentheses") from None
    except (SyntaxError, RecursionError, MemoryError, ValueError):
        raise NumberTextError(f"{what}: {text!r} is not a number") from None
    except TypeError:  # a complex power, (-8)**(1/3)
        raise NumberTextError(f"{what}: {text!r} is not a real number") from None
    except ZeroDivisionError:
        raise NumberTextError(f"{what}: {text!r} divides by zero") from None
    except OverflowError:
        raise NumberTextError(f"{what}: {text!r} is too large for a float") from None


class _NotArithmetic(Exception):
    pass


def _evaluate(node):
    if isinstance(node, ast.Constant):
        value = node.value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _NotArithmetic(f"{value!r} is not numeric")
        return float(value)  # float arithmetic: 9**9**9 overflows at once
    if isinstance(node, ast.Name):
        try:
            return _CONSTANTS[node.id]
        except KeyError:
            raise _NotArithmetic(f"unknown name {node.id!r}") from None
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return _BINARY[type(node.op)](_evaluate(node.left), _evaluate(node.right))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](_evaluate(node.operand))
    raise _NotArithmetic(f"{type(node).__name__} is not allowed")


def finite_number(text, kind=float):
    """The finite number ``text`` is written as, plainly (``kind``: ``float`` or
    ``int``; no arithmetic, unlike :func:`parse_number`), or ``None`` (a cell of a
    table that is not one: the caller names it)."""
    try:
        value = kind(text)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None
