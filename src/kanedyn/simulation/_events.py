"""Events given as expressions: ``kd.Event``, for ``kd.simulate`` and ``kd.simulate_many``.

An event is where a function of the run crosses zero.  ``kd.simulate`` takes it as a
Python function ``g(t, y)`` (solve_ivp's convention) or as an :class:`Event`, a SymPy
expression of the time, the model's states, inputs and constants; ``simulate_many``
takes expressions only, since its runs go on in C threads where no Python runs.  The
same :class:`Event` gives the same events in both: ``kd.simulate`` evaluates it as a
Python function of ``(t, y)`` (:func:`python_event`), ``simulate_many`` compiles all of
a call's events into one C function (:func:`compiled_event_table`) that its threads
evaluate along each step's continuous extension, as the compiled loop evaluates the
Python ones.
"""

from __future__ import annotations

import functools
import numbers
import sys
from dataclasses import dataclass

import numpy as np

from .._errors import ModelError, OptionError

__all__ = ["Event", "as_event", "listed", "python_event", "compiled_event_table"]


@dataclass(frozen=True)
class Event:
    r"""An event: where a SymPy expression of the run crosses zero.

    Parameters
    ----------
    expression : sympy.Expr
        A function of the time ``t``, the model's coordinates and speeds (its
        dynamic symbols, such as ``q1``), its specified inputs and constants (by
        their symbols), e.g. ``q1 - 0.5`` or ``L*sin(q1) - 0.1``; a number wherever
        the run goes (not a condition such as ``q1 > 0.5``).
    terminal : bool
        End the run at the first zero (``status = 1``).
    direction : {0, 1, -1}
        Zeros crossed either way (0), only upward (1) or only downward (-1), as
        solve_ivp's ``direction``.
    name : str, optional
        For messages (default: the expression).

    Notes
    -----
    ``kd.simulate(..., events=[...])`` and ``kd.simulate_many(..., events=[...])``
    take it (a bare SymPy expression is an Event with the defaults);
    ``simulate_many`` compiles it to C.  Both locate a zero as the compiled loop
    does: Brent's method on the step's continuous extension.
    """

    expression: object
    terminal: bool = False
    direction: float = 0.0
    name: str | None = None

    def __post_init__(self):
        import sympy as sm

        from .._expressions import as_expression
        what = f"event {self.name}" if self.name is not None else "an event's expression"
        expression = as_expression(self.expression, what)
        if isinstance(expression, sm.logic.boolalg.Boolean):
            hint = (f"; give {expression.lhs - expression.rhs}"
                    if isinstance(expression, sm.core.relational.Relational) else "")
            raise OptionError(f"event {expression} is a condition; an event is a value "
                              f"that crosses zero{hint}")
        if not isinstance(expression, sm.Expr):
            raise OptionError(f"an event must be a SymPy expression, got "
                              f"{type(expression).__name__} {expression!r}")
        if not isinstance(self.terminal, (bool, np.bool_)):
            raise OptionError(f"event {expression}: terminal must be True or False, got "
                              f"{self.terminal!r}")
        direction = self.direction
        if isinstance(direction, bool) or not isinstance(direction, numbers.Real) \
                or direction not in (-1, 0, 1):
            raise OptionError(f"event {expression}: direction must be -1, 0 or 1, got "
                              f"{direction!r}")
        if self.name is not None and not isinstance(self.name, str):
            raise OptionError(f"event {expression}: name must be text, got {self.name!r}")
        object.__setattr__(self, "expression", expression)
        object.__setattr__(self, "terminal", bool(self.terminal))
        object.__setattr__(self, "direction", float(direction))
        object.__setattr__(self, "name", self.name or str(expression))


def listed(events):
    """The ``events`` option as a list: ``None`` none, one event, or a list or tuple."""
    if events is None:
        return []
    return list(events) if isinstance(events, (list, tuple)) else [events]


def as_event(event):
    """``event`` as an :class:`Event` when it is one or a SymPy expression, else
    ``None`` (a Python function, or anything else: the caller says what it
    takes).  SymPy is not imported for this: an object is an expression only
    where SymPy was imported to make it."""
    if isinstance(event, Event):
        return event
    sympy = sys.modules.get("sympy")
    if sympy is not None and isinstance(event, sympy.Basic):
        return Event(event)
    return None


def _layout(model):
    """What the events of ``model`` are compiled against: its state, constant and
    input names, in order (not the constants' values)."""
    return (tuple(model.state_names), tuple(model.constants),
            tuple(name.removesuffix("(t)") for name in model.input_names))


def _slots(layout, event):
    """``{symbol or dynamic symbol of the expression: (array, index)}`` with array
    ``"t"``, ``"y"`` (the state), ``"p"`` (the constants) or ``"r"`` (the inputs)
    of a model of ``layout`` (:func:`_layout`)."""
    import sympy as sm
    from sympy.core.function import AppliedUndef
    t = sm.Symbol("t")
    expression = event.expression
    rates = sorted(map(str, expression.atoms(sm.Derivative)))
    if rates:
        raise ModelError(f"event {event.name}: it holds the derivative(s) "
                         f"{', '.join(rates)}; an event is a function of the state: write "
                         "the rates of the coordinates with the speeds (the kinematic "
                         "equations)")
    states, constants, inputs = ({name: i for i, name in enumerate(names)}
                                 for names in layout)
    slots, unknown = {}, []
    for function in expression.atoms(AppliedUndef):
        name = str(function.func)
        if function.args != (t,):
            unknown.append(str(function))
        elif name in states:
            slots[function] = ("y", states[name])
        elif name in inputs:
            slots[function] = ("r", inputs[name])
        else:
            unknown.append(name)
    for symbol in expression.free_symbols:
        if symbol == t:
            slots[symbol] = ("t", 0)
        elif str(symbol) in constants:
            slots[symbol] = ("p", constants[str(symbol)])
        else:
            unknown.append(str(symbol))
    if unknown:
        raise ModelError(
            f"event {event.name}: {', '.join(sorted(set(unknown)))} "
            f"{'is' if len(set(unknown)) == 1 else 'are'} not the time t or a state, input "
            f"or constant of this model (states: {', '.join(states)}; constants: "
            f"{', '.join(constants) or 'none'}; inputs: "
            f"{', '.join(inputs) or 'none'}); give numbers for other values")
    return slots


def _arguments(layout, events):
    """``(expressions, {dummy: (array, index)})``: the events' expressions in one
    dummy symbol per entry of t, y, p and r they use."""
    import sympy as sm
    dummies, expressions = {}, []
    for event in events:
        replace = {}
        for key, slot in _slots(layout, event).items():
            if slot not in dummies:
                dummies[slot] = sm.Dummy(f"{slot[0]}{slot[1]}")
            replace[key] = dummies[slot]
        expressions.append(event.expression.xreplace(replace))
    return expressions, {d: slot for slot, d in dummies.items()}


@functools.lru_cache(maxsize=256)
def _lambdified(layout, event):
    """``(f, uses_inputs)``: ``event`` as a Python function ``f(t, *y, *p[, *r])`` of a
    model of ``layout`` (made once per event and layout: a sweep's runs share it)."""
    import sympy as sm
    (expression,), slots = _arguments(layout, [event])
    n_y, n_p = len(layout[0]), len(layout[1])
    order = {"t": lambda i: 0, "y": lambda i: 1 + i, "p": lambda i: 1 + n_y + i,
             "r": lambda i: 1 + n_y + n_p + i}
    uses_inputs = any(array == "r" for array, _ in slots.values())
    arguments = [sm.Dummy() for _ in range(1 + n_y + n_p
                                           + (len(layout[2]) if uses_inputs else 0))]
    for dummy, (array, index) in slots.items():
        arguments[order[array](index)] = dummy
    return sm.lambdify(arguments, expression, modules="math"), uses_inputs


def python_event(model, event):
    """``event`` as ``kd.simulate`` calls events: a function ``g(t, y)`` with
    ``terminal``, ``direction`` and ``__name__``, the model's constants bound
    (those of ``model``: bind to the model that runs) and its inputs evaluated at
    ``(t, y)`` where the expression has them."""
    function, uses_inputs = _lambdified(_layout(model), event)
    p = [float(v) for v in model.constants.values()]

    def value(t, y):
        return float(function(t, *y, *p, *(model._r(t, y) if uses_inputs else ())))

    value.terminal = event.terminal
    value.direction = event.direction
    value.__name__ = event.name
    return value


def compiled_event_table(model, events):
    """``(capsule, directions, terminal)`` of ``events`` (a list of :class:`Event`)
    for the C model's ``integrate_many``: all of them compiled into one function
    (:func:`kanedyn.numerics.backends.compiled_events`)."""
    return (_compiled(_layout(model), tuple(events)),
            np.array([e.direction for e in events], dtype=float),
            np.array([float(e.terminal) for e in events]))


@functools.lru_cache(maxsize=64)
def _compiled(layout, events):
    """The capsule of ``events`` for a model of ``layout`` (made once per process and
    set of events: a sweep's batches share it; the module is cached on disk)."""
    from ..numerics.backends import CodegenError, compiled_events
    expressions, slots = _arguments(layout, events)
    names = {d: "t" if array == "t" else f"{array}[{index}]"
             for d, (array, index) in slots.items()}
    sizes = tuple(len(names_) for names_ in layout)
    try:
        return compiled_events(expressions, names, sizes, [e.name for e in events])
    except CodegenError as exc:
        raise ModelError(f"simulate_many compiles its events to C, which cannot evaluate "
                         f"this: {str(exc).split('; the numpy backend')[0]}") from None
