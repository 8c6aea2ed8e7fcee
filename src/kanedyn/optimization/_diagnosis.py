r"""What an unsolved optimal control run's message says beyond the solver's
status: which constraint row or bound is violated most, in the problem's
terms, and whether the problem looks unbounded below.

**The most violated row** (:func:`worst_violation`): the largest violation of
a row of :class:`._nlp.CollocationNLP` (its order: the dynamics' defects, the
path constraints, a constrained model's residuals, the instance constraints)
or of a variable's bound, named as the user wrote the problem: "the dynamics
of u between nodes 99 and 100 (t = 4.95 to 5 s)", "the path constraint
x - y <= 1 at node 3 (t = 0.3 s)", "the bound of q at node 0 (t = 0 s)".

**Unbounded below** (:func:`unbounded_hint`): a run that ended unsolved with
the objective below :data:`UNBOUNDED_FALL` times ``max(1, |objective at the
guess|)`` below zero, or with IPOPT's status 4 (diverging iterates: a
variable beyond ``diverging_iterates_tol``, 1e20), is said to be possibly
unbounded, naming the states, inputs and free parameters that grew by at
least :data:`GREW` times ``max(1, their largest |value| in the guess)``.  A
bounded problem stopped early does not trip it unless its objective's scale
exceeds 1e8 times its value at the guess (and then the hint says "may").
"""

from __future__ import annotations

import numpy as np

from ._nlp import violations

__all__ = ["worst_violation", "unbounded_hint", "UNBOUNDED_FALL", "GREW"]

#: the objective fell below -UNBOUNDED_FALL * max(1, |objective at the guess|)
UNBOUNDED_FALL = 1e8
#: a variable "grew": its largest |value| rose to GREW * max(1, its guess's)
GREW = 1e3


def worst_violation(nlp, z):
    """``(violation, text)``: the largest violation at ``z`` and what is
    violated (a row of the NLP or a variable's bound, in the problem's terms;
    ``None`` when nothing is violated)."""
    rows, bounds = violations(nlp, z)
    worst_row = float(np.max(rows, initial=0.0))
    worst_bound = float(np.max(bounds, initial=0.0))
    if max(worst_row, worst_bound) <= 0.0 or not np.isfinite(max(worst_row, worst_bound)):
        return max(worst_row, worst_bound), None
    times = _point_times(nlp, z)
    if worst_row >= worst_bound:
        return worst_row, _row_text(nlp, int(np.argmax(rows)), times)
    return worst_bound, "the bound of " + _variable_text(nlp, int(np.argmax(bounds)), times)


def _point_times(nlp, z):
    """Times of the layout's points (nodes, then interior points), s."""
    L = nlp.layout
    T = L.split(z, nlp.problem.duration_value)[3]
    return float(L.start_time(z, nlp.start_time)) + float(T) * L.positions()


def _at_point(nlp, j, times):
    """``"node 3 (t = 0.3 s)"`` or ``"interior point 2 of interval 1 (t = ... s)"``."""
    L = nlp.layout
    if j < L.nodes:
        return f"node {j} (t = {times[j]:.6g} s)"
    m = len(L.interior)
    k, i = divmod(j - L.nodes, m)
    label = "midpoint" if m == 1 else f"interior point {i + 1}"
    return f"the {label} of the interval from node {k} to {k + 1} (t = {times[j]:.6g} s)"


def _interval(k, times):
    return f"between nodes {k} and {k + 1} (t = {times[k]:.6g} to {times[k + 1]:.6g} s)"


def _scheme_row(scheme, kind):
    """Which of an interval scheme's rows ``kind`` is: Hermite-Simpson's
    Simpson row or midpoint row, LGR's row at a Radau point."""
    if scheme.name == "hermite-simpson":
        return " (Simpson's row)" if kind == 0 else " (the midpoint's row)"
    return f" (at the interval's Radau point {kind + 1} of {scheme.n_rows})"


def _row_text(nlp, i, times):
    """Row ``i`` of ``nlp`` in the problem's terms."""
    pb, L, defects = nlp.problem, nlp.layout, nlp.defects
    states, inputs = pb.symbols.states, pb.symbols.inputs
    nd = len(defects.rows)
    kinds = getattr(getattr(defects, "scheme", None), "n_rows", 1)
    dynamics = (L.nodes - 1) * kinds * nd
    if i < dynamics:
        k, rest = divmod(i, kinds * nd)
        kind, row = divmod(rest, nd)
        which = _scheme_row(defects.scheme, kind) if kinds > 1 else ""
        return f"the dynamics of {states[defects.rows[row]]} {_interval(k, times)}{which}"
    if i < defects.n_rows:  # LGR: the first node's input tied to the first interval's
        return (f"the first node's input {inputs[i - dynamics]} tied to the inputs of the "
                f"first interval")
    i -= defects.n_rows
    K = L.n_points
    for path in pb.path:
        if i < K:
            return (f"the path constraint {path.text} in [{path.lower:g}, {path.upper:g}] "
                    f"at {_at_point(nlp, i, times)}")
        i -= K
    if i < K * pb.n_residuals:
        j, c = divmod(i, pb.n_residuals)
        model = pb.model
        kind = "configuration" if c < model.n_q_dep else "velocity"
        return f"the model's {kind} constraint {c + 1} at {_at_point(nlp, j, times)}"
    i -= K * pb.n_residuals
    return f"the instance constraint {pb.instances[i].text} = 0"


def _variable_text(nlp, i, times):
    """Decision variable ``i`` of ``nlp`` in the problem's terms."""
    pb, L = nlp.problem, nlp.layout
    states, inputs, free = pb.symbols.states, pb.symbols.inputs, pb.symbols.free
    ns, nr = L.n_states, L.n_inputs
    if i < L.input_start:
        k, j = divmod(i, ns)
        return f"{states[j]} at {_at_point(nlp, k, times)}"
    if i < L.free_start:
        k, j = divmod(i - L.input_start, nr)
        return f"{inputs[j]} at {_at_point(nlp, k, times)}"
    if i < L.free_start + L.n_free:
        return f"the free parameter {free[i - L.free_start]}"
    if i == L.duration_index:
        return "the duration"
    if i == L.start_index:
        return "the start time"
    i -= L.interior_start
    if i < L.n_interior * ns:
        k, j = divmod(i, ns)
        return f"{states[j]} at {_at_point(nlp, L.nodes + k, times)}"
    k, j = divmod(i - L.n_interior * ns, nr)
    return f"{inputs[j]} at {_at_point(nlp, L.nodes + k, times)}"


def _largest(nlp, z):
    """``{name: signed value of largest magnitude}`` of the states, inputs
    (nodes and interior points) and free parameters at ``z``."""
    pb, L = nlp.problem, nlp.layout
    Y, R, P, _ = L.split(z, pb.duration_value)
    Yi, Ri = L.split_interior(z)
    out = {}
    for names, values in ((pb.symbols.states, np.concatenate([Y, Yi])),
                          (pb.symbols.inputs, np.concatenate([R, Ri]))):
        for name, column in zip(names, values.T):
            out[name] = float(column[np.argmax(np.abs(column))]) if column.size else 0.0
    out.update(zip(pb.symbols.free, map(float, P)))
    return out


def unbounded_hint(nlp, z, start, status, objective):
    """The hint that the problem may be unbounded below (see the module's
    text), or ``None``.

    Parameters
    ----------
    nlp : CollocationNLP
    z, start : ndarray
        The last iterate and the guess the solver started from.
    status : int
        The solver's status (IPOPT's codes); the caller asks only for an
        unsolved run.
    objective : float
        The objective at ``z``.
    """
    begun = float(nlp.objective(start))
    fell = objective < -UNBOUNDED_FALL * max(1.0, abs(begun))
    if not (fell or status == 4):
        return None
    before, after = _largest(nlp, start), _largest(nlp, z)
    growth = {name: abs(after[name]) / max(1.0, abs(before[name])) for name in after}
    grew = sorted((name for name in after if growth[name] >= GREW),
                  key=lambda name: -growth[name])
    parts = []
    if fell:
        parts.append(f"the objective fell to {objective:.2g} from {begun:.2g}")
    if grew:
        named = ", ".join(f"{name} to {after[name]:.2g}" for name in grew[:3])
        more = f" and {len(grew) - 3} more" if len(grew) > 3 else ""
        parts.append(f"{named.replace(' to ', ' grew to ', 1)}{more}")
    advice = (f"bound {', '.join(grew[:3])}" if grew else "bound the variables it decreases "
              "along") + ", or add final conditions or constraints that hold them"
    return f"{' and '.join(parts)}: the problem may be unbounded below ({advice})"
