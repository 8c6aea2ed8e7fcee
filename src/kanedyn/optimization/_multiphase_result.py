"""``MultiphaseResult``: each phase's optimal trajectory, and the phases joined."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import ModelError
from ._result import build_result, status_text, write_csv

__all__ = ["MultiphaseResult", "build_multiphase_result"]


@dataclass(frozen=True)
class MultiphaseResult:
    """The solution of a :class:`MultiphaseProblem` (also a failed or
    interrupted one: then the last iterate); immutable.

    The joined views (``t``, ``result["x"]``, :meth:`table`, :meth:`plot`)
    list the phases one after the other: a junction time appears twice, as
    the end of one phase and the start of the next (the states may jump
    there when a linkage says so).

    Attributes
    ----------
    phases : tuple of OptimalControlResult
        Each phase's trajectory (its ``t``, ``y``, ``r``, ``trajectory``,
        ``resimulate()``, ...), its own objective; their message is the whole
        solve's.
    objective : float
        The sum of the phases' objectives.
    constraint_violation : float
        Largest violation of a constraint (the junctions' included) or bound.
    success, status, message, iterations, wall_time, solver
        As :class:`OptimalControlResult`.
    x : ndarray
        The decision vector (the phases' one after the other).
    multipliers : dict
        For a warm start.
    problem : MultiphaseProblem
    """

    phases: tuple
    objective: float
    constraint_violation: float
    success: bool
    status: int
    message: str
    iterations: int
    wall_time: float
    solver: str
    x: np.ndarray
    multipliers: dict
    problem: object

    @property
    def t(self):
        """The nodes' times of all phases, s (a junction's twice)."""
        return np.concatenate([p.t for p in self.phases])

    @property
    def durations(self):
        """Each phase's duration, s."""
        return tuple(p.duration for p in self.phases)

    @property
    def junction_times(self):
        """Where each phase ends and the next starts, s."""
        return tuple(float(p.t[-1]) for p in self.phases[:-1])

    def __getitem__(self, key):
        """A state's or input's values at the nodes of all phases (nan in a
        phase that lacks it), by name or dynamic symbol."""
        from ._problem import _name
        name = _name(key)
        values, found = [], False
        for p in self.phases:
            if name in p.state_names or name in p.input_names:
                values.append(p[name])
                found = True
            else:
                values.append(np.full(p.t.size, np.nan))
        if not found:
            raise KeyError(f"{key} is a state or input of no phase")
        return np.concatenate(values)

    def table(self):
        """``(columns, rows)``: ``t`` (s), ``phase`` (1, 2, ...), ``point``,
        then every state and every input of any phase (first seen first; nan
        in a phase that lacks it); each phase's rows as
        :meth:`OptimalControlResult.table`."""
        states, inputs = [], []
        for p in self.phases:
            states += [n for n in p.state_names if n not in states]
            inputs += [n for n in p.input_names if n not in inputs]
        names = states + inputs
        rows = []
        for k, p in enumerate(self.phases, start=1):
            columns, own = p.table()
            where = {name: columns.index(name) for name in columns[2:]}
            for row in own:
                rows.append((row[0], k, row[1],
                             *(row[where[n]] if n in where else np.nan for n in names)))
        return ("t", "phase", "point", *names), rows

    def to_csv(self, path):
        """Write :meth:`table` as CSV (numbers as ``repr``); returns the path."""
        return write_csv(path, *self.table())

    def plot(self, states=None, path=None, title=None):
        """Plot the joined states (``SimulationResult.plot`` of the nodes,
        without its energy and residual panels); returns the Figure.

        The phases must have the same states (plot a phase by
        ``result.phases[k].plot()``)."""
        from ..simulation import SimulationResult
        names = {p.state_names for p in self.phases}
        if len(names) > 1:
            raise ModelError("the phases have different states; plot each phase "
                             "(result.phases[k].plot())")
        first = self.phases[0]
        y = np.concatenate([p.y for p in self.phases], axis=1)
        joined = SimulationResult.build(
            first.problem.model, self.t, y, 0 if self.success else -1, self.message, [], [],
            None, {"nfev": 0, "njev": 0, "nlu": 0}, 0, y[:, 0].copy(), False,
            "collocation (phases joined)")
        methods = ", ".join(sorted({p.method for p in self.phases}))
        junctions = ", ".join(f"{t:.4g}" for t in self.junction_times)
        plural = "s" if len(self.junction_times) > 1 else ""
        return joined.plot(states=states, path=path, extras=False, title=title or (
            f"optimal trajectory, {len(self.phases)} phases ({methods}), junction{plural} "
            f"at {junctions} s"))

    def resimulate(self, rtol=1e-10, atol=1e-10, method="DOP853"):
        """Each phase's optimal inputs simulated from its collocated initial
        state (:meth:`OptimalControlResult.resimulate`): a tuple of
        :class:`Resimulation`."""
        return tuple(p.resimulate(rtol=rtol, atol=atol, method=method) for p in self.phases)

    def __repr__(self):
        return (f"<MultiphaseResult of {len(self.phases)} phases: objective "
                f"{self.objective:.8g}, violation {self.constraint_violation:.1e}, "
                f"{self.message}>")


def _worst_violation(nlp, z):
    """``(violation, text)``: the largest violation at ``z`` of a phase's row
    or bound (named as :func:`._diagnosis.worst_violation` names it, after
    its phase's number) or of a junction's row (its label); ``text`` is
    ``None`` when nothing is violated."""
    from ._diagnosis import worst_violation
    found = [(0.0, None)]
    for number, (sub, part) in enumerate(zip(nlp.phase_nlps, nlp.parts(z)), start=1):
        violation, text = worst_violation(sub, part)
        found.append((violation, text and f"phase {number}: {text}"))
    z = np.asarray(z, dtype=float)
    found += [(abs(row.function(z)[0]), row.label) for row in nlp.rows]
    return max(found, key=lambda pair: pair[0])


def build_multiphase_result(problem, solution, interrupted, tolerance=1e-4):
    """The :class:`MultiphaseResult` of ``problem`` from the solver's
    ``solution``; when the run ended unsolved, its message names the row or
    bound violated most when the violation exceeds ``tolerance`` (as
    :func:`._result.build_result`'s)."""
    nlp = problem.nlp
    violation = nlp.violation(solution.x)
    success = solution.status in (0, 1) and interrupted is None
    worst = None
    if not success:
        largest, worst = _worst_violation(nlp, solution.x)
        worst = worst if largest > tolerance else None
    phases = tuple(build_result(phase, sub, solution, interrupted, x=part, violation=violation)
                   for phase, sub, part in zip(problem.phases, nlp.phase_nlps,
                                               nlp.parts(solution.x)))
    return MultiphaseResult(
        phases=phases, objective=float(sum(p.objective for p in phases)),
        constraint_violation=violation,
        success=success, status=solution.status,
        message=status_text(solution, interrupted, violation, worst),
        iterations=solution.iterations, wall_time=solution.wall_time, solver=solution.solver,
        x=solution.x, multipliers=solution.multipliers, problem=problem)
