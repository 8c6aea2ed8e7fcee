r"""``Linkage``: how two consecutive phases of a multiphase problem join, and
the rows it adds to the NLP.

At the junction time :math:`t_j` (where the phase before ends and the phase
after starts) a linkage holds

.. math::

    y^-_i(t_j) = y^+_i(t_j) \;\text{(continuous states or inputs)},\qquad
    \psi\big(y^-(t_j), r^-(t_j), y^+(t_j), r^+(t_j), t_j\big) = 0
    \;\text{(equations)},

with :math:`y^-, r^-` the last node of the phase before and :math:`y^+,
r^+` the first node of the phase after.  The equations are SymPy
expressions in which ``q.subs(t, Linkage.before)`` is a state (or input) of
the phase before and ``q.subs(t, Linkage.after)`` one of the phase after;
either marker standing alone is :math:`t_j`.  Each row's gradient is
SymPy's, evaluated by one NumPy function; :math:`t_j = t_0 + T` of the phase
before, so its derivative falls on that phase's start time and duration
where they are variables.

Every row is linear in the variables or a small expression: the rows are
kept as ``(columns, function of z -> (value, gradient))``.
"""

from __future__ import annotations

import numpy as np
import sympy as sm

from .._errors import ModelError
from .._expressions import as_expression

__all__ = ["Linkage", "junction_rows", "JunctionRow"]


class Linkage:
    r"""How a phase joins the next one in a :class:`MultiphaseProblem`.

    Parameters
    ----------
    continuous : sequence of states or inputs, optional
        Equal at the end of the phase before and the start of the phase after
        (dynamic symbols or names; each must belong to both phases).  By
        default every state both phases have (by name), their dependent
        states (closed loops) left to the constraints; ``[]`` for none.
    equations : sequence of SymPy expressions, optional
        Equal to zero at the junction, in the states and inputs of the phase
        before at its end, ``q.subs(t, Linkage.before)``, and of the phase
        after at its start, ``q.subs(t, Linkage.after)``; a marker standing
        alone is the junction time :math:`t_j`, s.

    Attributes
    ----------
    before, after : sympy.Symbol
        The markers :math:`t_j^-` and :math:`t_j^+` (class attributes).

    Examples
    --------
    A velocity that jumps by 0.5 m/s at the junction, the position continuous:

    >>> import sympy.physics.mechanics as me
    >>> import kanedyn as kd
    >>> x, v = me.dynamicsymbols("x v")
    >>> t, L = me.dynamicsymbols._t, kd.Linkage
    >>> jump = kd.Linkage(continuous=[x],
    ...                   equations=[v.subs(t, L.after) - v.subs(t, L.before) - 0.5])
    """

    before = sm.Symbol("t_j^-")
    after = sm.Symbol("t_j^+")

    def __init__(self, continuous=None, equations=()):
        if continuous is not None:
            if isinstance(continuous, (str, bytes)) or not hasattr(continuous, "__iter__"):
                raise ModelError(f"continuous must be a sequence of states or inputs, got "
                                 f"{continuous!r}")
            continuous = tuple(continuous)
        if isinstance(equations, (str, bytes)) or not hasattr(equations, "__iter__"):
            raise ModelError(f"equations must be a sequence of SymPy expressions, got "
                             f"{equations!r}")
        self.continuous = continuous
        self.equations = tuple(equations)

    def __repr__(self):
        continuous = ("the shared states" if self.continuous is None
                      else ", ".join(map(str, self.continuous)) or "nothing")
        return f"<Linkage: continuous {continuous}; {len(self.equations)} equations>"


class JunctionRow:
    """One row at a junction: ``columns`` (global) and ``function(z) ->
    (value, gradient over columns)``; ``hessian(z)``, its second derivatives
    over the columns, or ``None`` for a linear row; ``label``, what the row
    says in the problem's terms (an unsolved run's message names it)."""

    def __init__(self, columns, function, hessian=None, label=""):
        self.columns, self.function = np.asarray(columns, dtype=int), function
        self.hessian, self.label = hessian, label


class _Side:
    """One phase at a junction: where its values live in the global vector."""

    def __init__(self, number, problem, layout, offset, start, last):
        self.number, self.problem, self.layout = number, problem, layout
        self.offset, self.start, self.node = offset, start, (layout.nodes - 1 if last else 0)

    def column(self, kind, j):
        L = self.layout
        local = L.state_index(self.node, j) if kind == "state" else L.input_index(self.node, j)
        return self.offset + local

    def named(self, key, what):
        """``(kind, index)`` of a state or input named ``key``."""
        from ._problem import _name
        s = self.problem.symbols
        name = _name(key)
        if name in s.states:
            return "state", s.states.index(name)
        if name in s.inputs:
            return "input", s.inputs.index(name)
        raise ModelError(f"{what} names {name}, which phase {self.number} lacks (its states: "
                         f"{', '.join(s.states)}; inputs: {', '.join(s.inputs) or 'none'})")



def _end_time(side):
    """``(columns, end(z))``: the phase's end time is its start time plus its
    duration, each a variable (its column listed) or fixed."""
    L, cols, fixed = side.layout, [], 0.0
    if L.free_start_time:
        cols.append(side.offset + L.start_index)
    else:
        fixed += side.start
    if L.free_duration:
        cols.append(side.offset + L.duration_index)
    else:
        fixed += side.problem.duration_value
    return cols, (lambda z: fixed + float(np.sum(z[cols])))


def junction_rows(k, linkage, before, after):
    """The :class:`JunctionRow` list of junction ``k`` (phases ``k + 1`` and
    ``k + 2`` counted from 1): the start time of the phase after (when it is
    a variable), the continuous entries, the equations."""
    rows = []
    where = f"linkage {k + 1} (phases {before.number} and {after.number})"
    end_cols, end_time = _end_time(before)
    if after.layout.free_start_time:
        start = after.offset + after.layout.start_index
        grad = np.array([1.0] + [-1.0] * len(end_cols))
        rows.append(JunctionRow([start] + end_cols, lambda z: (z[start] - end_time(z), grad),
                                label=f"{where}: phase {after.number} starts as phase "
                                      f"{before.number} ends"))
    names = _continuous_names(linkage, before, after, where)
    if not names and not linkage.equations:
        raise ModelError(f"{where} joins nothing: give it continuous states or equations "
                         "(kd.Linkage(continuous=[...], equations=[...]))")
    rows += _continuous(names, before, after, where)
    rows += [_equation(e, i, before, after, where, end_cols, end_time)
             for i, e in enumerate(linkage.equations)]
    return rows


def _continuous_names(linkage, before, after, where):
    """The entries the linkage makes continuous (by default the shared
    independent states)."""
    if linkage.continuous is not None:
        return linkage.continuous
    pb_a, pb_b = before.problem, after.problem
    shared = [n for n in pb_a.symbols.states
              if n in pb_b.symbols.states and n not in pb_a.dependent
              and n not in pb_b.dependent]
    if not shared and not linkage.equations:
        raise ModelError(
            f"{where}: the phases share no independent state (phase {before.number}: "
            f"{', '.join(pb_a.symbols.states)}; phase {after.number}: "
            f"{', '.join(pb_b.symbols.states)}), so the default linkage joins nothing; "
            "give linkages=[kd.Linkage(equations=[...])]")
    return shared


def _continuous(names, before, after, where):
    pb_a, pb_b = before.problem, after.problem
    rows, seen = [], set()
    for key in names:
        (kind_a, ja), (kind_b, jb) = (side.named(key, f"{where}: continuous")
                                      for side in (before, after))
        name = (pb_a.symbols.states if kind_a == "state" else pb_a.symbols.inputs)[ja]
        if name in seen:
            raise ModelError(f"{where}: continuous names {name} twice")
        seen.add(name)
        if kind_a != kind_b:
            raise ModelError(f"{where}: continuous names {name}, a {kind_a} of phase "
                             f"{before.number} but an {kind_b} of phase {after.number}")
        for side in (before, after):
            if kind_a == "state" and name in side.problem.dependent:
                raise ModelError(f"{where}: continuous names {name}, a dependent state of "
                                 f"phase {side.number} (it follows from the constraints; "
                                 "link the independent states)")
        fixed_a = pb_a.final.get(ja) if kind_a == "state" else None
        fixed_b = pb_b.initial.get(jb) if kind_a == "state" else None
        if fixed_a is not None and fixed_b is not None:
            if fixed_a != fixed_b:
                raise ModelError(f"{where}: {name} is continuous, but phase {before.number} "
                                 f"ends with {name} = {fixed_a:g} and phase {after.number} "
                                 f"starts with {name} = {fixed_b:g}")
            continue  # both ends fixed to the same value: nothing to impose
        cols = [before.column(kind_a, ja), after.column(kind_b, jb)]
        grad = np.array([1.0, -1.0])
        rows.append(JunctionRow(cols, lambda z, c=cols: (z[c[0]] - z[c[1]], grad),
                                label=f"{where}: {name} continuous"))
    return rows


def _equation(value, i, before, after, where, end_cols, end_time):
    from sympy.core.function import AppliedUndef
    what = f"{where}, equation {i} ({value})"
    expr = as_expression(value, what)
    for d in expr.atoms(sm.Derivative):
        raise ModelError(f"{what} contains the derivative {d}; write it with the speeds "
                         "(states) instead")
    swap, cols = {}, []
    for atom in sorted(expr.atoms(AppliedUndef), key=str):
        if atom.args == (Linkage.before,):
            side, at = before, "end"
        elif atom.args == (Linkage.after,):
            side, at = after, "start"
        else:
            raise ModelError(f"{what} contains {atom}: at a junction a state or input is "
                             f"written {atom.func}(Linkage.before) (the end of phase "
                             f"{before.number}) or {atom.func}(Linkage.after) (the start of "
                             f"phase {after.number})")
        try:
            kind, j = side.named(atom.func, what)
        except ModelError as exc:
            raise ModelError(f"{exc} (at its {at})") from None
        swap[atom] = sm.Dummy()
        cols.append(side.column(kind, j))
    tj = sm.Dummy("t_j")
    e = expr.xreplace(swap).xreplace({Linkage.before: tj, Linkage.after: tj})
    unknown = e.free_symbols - set(swap.values()) - {tj}
    if unknown:
        raise ModelError(f"{what} names {', '.join(sorted(map(str, unknown)))}: a linkage "
                         "names only states and inputs at the junction and its time "
                         "(write constants as numbers)")
    if not swap:
        raise ModelError(f"{what} names no state or input at the junction")
    variables = list(swap.values()) + [tj]
    fn = sm.lambdify(variables, [e] + [e.diff(v) for v in variables], modules="numpy")
    n = len(cols)
    columns = cols + end_cols

    second = sm.lambdify(variables, [e.diff(a).diff(b) for a in variables for b in variables],
                         modules="numpy")
    # the junction time is the sum of the end columns (or fixed): d t_j / d column = 1
    spread = np.zeros((n + 1, len(columns)))
    spread[np.arange(n), np.arange(n)] = 1.0
    spread[n, n:] = 1.0

    def function(z):
        out = fn(*z[cols], end_time(z))
        grad = np.array(out[1:], dtype=float)
        return float(out[0]), np.concatenate([grad[:n], np.full(len(end_cols), grad[n])])

    def hessian(z):
        H = np.array(second(*z[cols], end_time(z)), dtype=float).reshape(n + 1, n + 1)
        return spread.T @ H @ spread
    return JunctionRow(columns, function, hessian, label=what)
