r"""``OptimalControlResult``: the optimal trajectory, the solver's account, and a
check of the optimal inputs by simulation.

The inputs between nodes are what the transcription assumed
(:func:`input_functions`): backward Euler holds :math:`r_{k+1}` over
:math:`(t_k, t_{k+1}]`, the midpoint rule :math:`(r_k + r_{k+1})/2`, the
trapezoid interpolates linearly, Hermite-Simpson quadratically through
:math:`r_k`, the midpoint's :math:`\bar r_k` and :math:`r_{k+1}`, LGR of
degree d by the polynomial of degree d - 1 through the inputs at the
interval's d Radau points (its interior points and :math:`r_{k+1}`) over
:math:`(t_k, t_{k+1}]`.  Those continuous at the nodes or held on
:math:`[t_k, t_{k+1})` (Hermite-Simpson's, the midpoint rule's) are
:class:`~kanedyn.modeling.PiecewisePolynomial` objects, which a compiled
model compiles into its module as it does any such input.
:meth:`OptimalControlResult.resimulate` integrates the model with those
inputs by ``kd.simulate`` and reports how far the simulated states end from
the collocated ones at the nodes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._solvers import IPOPT_STATUS
from ._transcription import interval_scheme

__all__ = ["OptimalControlResult", "Resimulation", "build_result", "input_functions",
           "status_text", "write_csv"]


class _Held:
    """An input as the transcription saw it, a function of t (picklable).

    ``"polynomial"``: on :math:`(t_k, t_{k+1}]` the polynomial through
    ``table[k]`` at the positions ``points`` (fractions of the interval),
    evaluated in its Lagrange form in float arithmetic (no NumPy on scalars:
    a simulation calls it at every step and for every column of a
    differenced Jacobian)."""

    def __init__(self, t, values, kind, points=None, table=None):
        self.t, self.values, self.kind = np.asarray(t), np.asarray(values), kind
        # floats and lists of them, which the calls' arithmetic takes fastest
        self.points = None if points is None else [float(p) for p in points]
        self.table = None if table is None else np.asarray(table, dtype=float).tolist()
        self._start, self._span = float(self.t[0]), float(self.t[-1] - self.t[0])

    def __call__(self, t):
        n = self.t.size
        if self.kind == "linear":
            return float(np.interp(t, self.t, self.values))
        s = (t - self._start) / self._span * (n - 1)
        if self.kind == "polynomial":
            # s clamped first only so that math.ceil takes an infinite t
            k = min(max(math.ceil(min(max(s, -1.0), n) - 1e-12) - 1, 0), n - 2)
            return _lagrange_value(self.points, self.table[k], float(s - k))
        if self.kind == "right":  # r_{k+1} on (t_k, t_{k+1}]
            k = int(min(max(np.ceil(s - 1e-12), 1), n - 1))
            return float(self.values[k])
        k = int(min(max(np.floor(s), 0), n - 2))  # midpoint: the average on [t_k, t_k+1)
        return float(0.5 * (self.values[k] + self.values[k + 1]))


def _lagrange_value(nodes, values, x):
    """The polynomial through ``values`` at ``nodes``, at ``x`` (floats): the
    Lagrange basis of ``_interval.lagrange_weights`` at one point, summed."""
    total = 0.0
    for j, (p, value) in enumerate(zip(nodes, values)):
        weight = 1.0
        for m, q in enumerate(nodes):
            if m != j:
                weight *= (x - q) / (p - q)
        total += value * weight
    return total


_HOLD = {"backward-euler": "right", "midpoint": "average", "trapezoid": "linear"}


def input_functions(method, t, r, names, r_mid=None, degree=None):
    """``{input name: f(t)}`` of the inputs as collocated by ``method``
    (``r_mid``: the inputs at the interior points, (n_inputs, (N - 1) m),
    for Hermite-Simpson and LGR): piecewise polynomials for Hermite-Simpson
    and the midpoint rule, :class:`_Held` otherwise."""
    scheme = interval_scheme(method, degree)
    if scheme is None:
        if method == "midpoint":  # held on [t_k, t_k+1), as a piecewise polynomial's
            return {name: _piecewise(name, t, 0.5 * (row[:-1] + row[1:])[:, None])
                    for name, row in zip(names, r)}
        return {name: _Held(t, row, _HOLD[method]) for name, row in zip(names, r)}
    m = len(scheme.interior)
    g = list(scheme.input_positions)
    points = np.array(scheme.positions)[g]
    # through both ends of each interval (Hermite-Simpson): continuous at the
    # nodes, so a piecewise polynomial's [t_k, t_k+1) is the held (t_k, t_k+1]
    continuous = points[0] == 0.0 and points[-1] == 1.0
    basis = _power_basis(points, t) if continuous else None
    out = {}
    for name, row, inner in zip(names, r, r_mid if m else [()] * len(names)):
        every = np.column_stack([row[:-1], np.reshape(inner, (t.size - 1, m)), row[1:]])
        if continuous:
            out[name] = _piecewise(name, t, every[:, g] @ basis)
        else:
            out[name] = _Held(t, row, "polynomial", points, every[:, g])
    return out


def _power_basis(points, t):
    """``B`` (d, d): the values of a polynomial at ``points`` (fractions of
    an interval of the uniform mesh ``t``) times ``B`` are its coefficients in
    powers of the time since the interval's start, highest first (the
    Lagrange basis in power form)."""
    d = len(points)
    basis = np.zeros((d, d))
    for j in range(d):
        others = [p for m, p in enumerate(points) if m != j]
        ascending = np.polynomial.polynomial.polyfromroots(others) if others else np.ones(1)
        basis[j] = ascending / np.prod([points[j] - p for p in others])
    h = (t[-1] - t[0]) / (t.size - 1)
    return (basis / h ** np.arange(d))[:, ::-1]


def _piecewise(name, t, coefficients):
    """Input ``name`` on the nodes ``t`` as a
    :class:`~kanedyn.modeling.PiecewisePolynomial` (extrapolating its end
    pieces, as :class:`_Held` does), which a C model compiles into its module."""
    from ..modeling import PiecewisePolynomial
    return PiecewisePolynomial(t, coefficients, f"optimal input {name}", extrapolate=True)


@dataclass(frozen=True)
class Resimulation:
    """The optimal inputs simulated with ``kd.simulate``.

    Attributes
    ----------
    simulation : SimulationResult
        At the node times.
    defect : dict
        ``{state name: largest |simulated - collocated| over the nodes}``
        (units of the state).
    max_defect : float
        The largest of them.
    """

    simulation: object
    defect: dict
    max_defect: float


@dataclass(frozen=True)
class OptimalControlResult:
    """The solution of an :class:`OptimalControlProblem` (also a failed or
    interrupted one: then the last iterate); immutable.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Node times, s.
    y : ndarray, shape (n_states, N)
        States at the nodes (the ``SimulationResult`` layout).
    r : ndarray, shape (n_inputs, N)
        Inputs at the nodes.
    state_names, input_names : tuple of str
    parameters : dict
        ``{name: value}`` of the free parameters and the auxiliary variables.
    duration : float
        s.
    objective : float
    constraint_violation : float
        Largest violation of a constraint (defects included) or bound.
    success : bool
        The solver converged (IPOPT status 0 or 1).
    status : int
        The solver's code (IPOPT's: 0 solved, 1 acceptable, 2 infeasible,
        4 diverging, 5 stopped, -1 iteration limit, ...).
    message : str
    iterations : int
    wall_time : float
        Seconds in the solver.
    method : str
    degree : int or None
        LGR's degree.
    solver : str
    x : ndarray
        The decision vector.
    multipliers : dict
        For a warm start.
    problem : OptimalControlProblem
    t_mid, y_mid, r_mid : ndarray or None
        Hermite-Simpson and LGR: the interior points' times ((N - 1) m,),
        states (n_states, (N - 1) m) and inputs (n_inputs, (N - 1) m), interval
        by interval (the midpoints, m = 1; LGR's interior Radau points, m =
        degree - 1); ``None`` otherwise.
    """

    t: np.ndarray
    y: np.ndarray
    r: np.ndarray
    state_names: tuple
    input_names: tuple
    parameters: dict
    duration: float
    objective: float
    constraint_violation: float
    success: bool
    status: int
    message: str
    iterations: int
    wall_time: float
    method: str
    solver: str
    x: np.ndarray
    multipliers: dict
    problem: object
    t_mid: np.ndarray = None
    y_mid: np.ndarray = None
    r_mid: np.ndarray = None
    degree: int = None

    def __getitem__(self, key):
        """A state's or an input's values at the nodes, by name or dynamic symbol."""
        from ._problem import _name
        name = _name(key)
        if name in self.state_names:
            return self.y[self.state_names.index(name)]
        if name in self.input_names:
            return self.r[self.input_names.index(name)]
        raise KeyError(f"{key} is neither a state ({', '.join(self.state_names)}) nor an "
                       f"input ({', '.join(self.input_names) or 'none'})")

    def inputs(self):
        """``{input name: f(t)}``: the inputs between the nodes as the
        transcription assumed them."""
        return input_functions(self.method, self.t, self.r, self.input_names, self.r_mid,
                               self.degree)

    def model(self):
        """The numerical model with the optimal free parameters and inputs."""
        model = self.problem.model
        constants = {k: v for k, v in self.parameters.items()
                     if k not in self.problem.auxiliary}
        if constants:
            model = model.with_constants(constants)
        return model.with_inputs(self.inputs()) if self.input_names else model

    @property
    def trajectory(self):
        """The collocated trajectory as a ``SimulationResult`` (``.plot()``,
        ``.animate(...)``, ``["q"]``, ``.to_csv``)."""
        from ..simulation import SimulationResult
        model = self.model()
        return SimulationResult.build(
            model, self.t, self.y, 0 if self.success else -1, self.message, [], [], None,
            {"nfev": 0, "njev": 0, "nlu": 0}, 0, self.y[:, 0].copy(), False,
            f"collocation ({self.method})")

    def _ordered(self):
        t, y, r = self.t, self.y, self.r
        kind = np.zeros(t.size, dtype=int)
        if self.t_mid is not None:
            t = np.concatenate([t, self.t_mid])
            y = np.concatenate([y, self.y_mid], axis=1)
            r = np.concatenate([r, self.r_mid], axis=1)
            kind = np.concatenate([kind, np.ones(self.t_mid.size, dtype=int)])
            order = np.argsort(t, kind="stable")
            t, y, r, kind = t[order], y[:, order], r[:, order], kind[order]
        return t, y, r, kind

    def points(self):
        """``(t, y, r)`` at every collocation point in time order: the nodes
        and the interior points (Hermite-Simpson's midpoints, LGR's interior
        Radau points); shapes (K,), (n_states, K), (n_inputs, K)."""
        return self._ordered()[:3]

    def table(self):
        """``(columns, rows)`` of the collocated trajectory: ``t`` (s),
        ``point`` (``node``, ``midpoint`` for Hermite-Simpson's midpoints or
        ``interior`` for LGR's interior points, in time order with the nodes),
        every state, every input (SI units of the model); one row per point."""
        t, y, r, kind = self._ordered()
        columns = ("t", "point", *self.state_names, *self.input_names)
        scheme = interval_scheme(self.method, self.degree)
        labels = ("node", scheme.label if scheme else None)
        rows = [(float(t[j]), labels[kind[j]], *map(float, y[:, j]),
                 *map(float, r[:, j])) for j in range(t.size)]
        return columns, rows

    def to_csv(self, path):
        """Write :meth:`table` as CSV (numbers as ``repr``); returns the path."""
        return write_csv(path, *self.table())

    def plot(self, states=None, path=None, title=None):
        """Plot the collocated states (``SimulationResult.plot``); returns the Figure."""
        return self.trajectory.plot(states=states, path=path,
                                    title=title or f"optimal trajectory ({self.method}, "
                                                   f"{self.t.size} nodes)")

    def animate(self, path, **options):
        """The collocated motion as a 3D animation (``SimulationResult.animate``)."""
        return self.trajectory.animate(path, **options)

    def resimulate(self, rtol=1e-10, atol=1e-10, method="DOP853"):
        """Simulate the optimal inputs from the collocated initial state.

        Returns
        -------
        Resimulation
            The run at the node times and its largest difference from the
            collocated states.  It shrinks with the node count at the
            method's order.
        """
        from ..simulation import simulate
        model = self.model()
        run = simulate(model, (self.t[0], self.t[-1]), self.y[:, 0], t_eval=self.t,
                       rtol=rtol, atol=atol, method=method, backend="scipy")
        n = min(run.t.size, self.t.size)
        diff = np.abs(run.y[:, :n] - self.y[:, :n])
        defect = {name: float(np.max(d)) for name, d in zip(self.state_names, diff)}
        if n < self.t.size:  # the run ended early: say so by an infinite defect
            defect = {name: np.inf for name in self.state_names}
        return Resimulation(run, defect, max(defect.values()) if defect else 0.0)

    def __repr__(self):
        return (f"<OptimalControlResult {self.method}, {self.t.size} nodes: objective "
                f"{self.objective:.8g}, violation {self.constraint_violation:.1e}, "
                f"{self.message}>")


def write_csv(path, columns, rows):
    """Write a table as CSV (numbers as ``repr``, text as it is); returns the path."""
    import csv
    from pathlib import Path

    from .._output_files import replacing
    path = Path(path)
    with replacing(path, newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([v if isinstance(v, str) else repr(v) for v in row])
    return path


def status_text(solution, interrupted, violation, worst=None, hint=None):
    """The result's message: the solver's status and its meaning, its advice
    (:attr:`._solvers.NLPSolution.advice`, left out with a ``hint``, which
    advises itself), an interruption, the largest violation (``worst``: what
    is violated most, :func:`._diagnosis.worst_violation`'s text) and
    ``hint`` (e.g. that the problem may be unbounded below,
    :func:`._diagnosis.unbounded_hint`)."""
    from .._signals import interruption
    meaning = IPOPT_STATUS.get(solution.status, "") if solution.solver == "ipopt" else ""
    solver = solution.solver
    if solution.hessian:
        solver += f" ({solution.hessian} Hessian)"
    text = f"{solver}: {solution.status_text}"
    if solution.advice and not hint:
        text += f" ({solution.advice})"
    text += f" (status {solution.status}"
    text += f": {meaning})" if meaning else ")"
    if interrupted is not None:
        text = (f"{interruption(interrupted)} at iteration {solution.iterations}: the last "
                f"iterate is returned; " + text)
    text += (f" after {solution.iterations} iterations; largest constraint violation "
             f"{violation:.2e}")
    if worst:
        text += f", of {worst}"
    if hint:
        text += f"; {hint}"
    return text


def build_result(problem, nlp, solution, interrupted, x=None, violation=None, start=None,
                 tolerance=1e-4):
    """The :class:`OptimalControlResult` of ``problem`` from the solver's
    ``solution``; ``x``, ``violation``: a phase's part of a multiphase
    solution and the whole problem's violation (default: the solution's).

    When the run ended unsolved, the message of a whole problem (no ``x``
    given) names its most violated row or bound when the violation exceeds
    ``tolerance`` (the solvers' ``constr_viol_tol``, IPOPT's default 1e-4,
    units of the row), and with ``start`` (the solver's starting vector)
    says when the problem may be unbounded below (:mod:`._diagnosis`)."""
    from ._diagnosis import unbounded_hint, worst_violation
    L = nlp.layout
    whole = x is None
    x = solution.x if x is None else x
    Y, R, P, T = L.split(x, problem.duration_value)
    Yi, Ri = L.split_interior(x)
    t0 = float(L.start_time(x, nlp.start_time))
    success = solution.status in (0, 1) and interrupted is None
    worst = hint = None
    if whole and not success:
        violation, worst = worst_violation(nlp, x)
        worst = worst if violation > tolerance else None
    elif violation is None:
        violation = nlp.violation(x)
    objective = float(nlp.objective(x))
    if whole and not success and start is not None:
        hint = unbounded_hint(nlp, x, start, solution.status, objective)
    text = status_text(solution, interrupted, violation, worst, hint)
    positions = float(T) * L.positions()
    t = t0 + positions[:L.nodes]
    mid = {}
    if L.n_interior:
        mid = dict(t_mid=t0 + positions[L.nodes:], y_mid=Yi.T.copy(), r_mid=Ri.T.copy())
    multipliers = solution.multipliers
    if x is not solution.x:  # a phase: its own vector, no multipliers of its own
        x = x[:L.n_variables - int(L.free_start_time)]
        multipliers = {key: None for key in multipliers}
    return OptimalControlResult(
        t=t, y=Y.T.copy(), r=R.T.copy(), state_names=problem.symbols.states,
        input_names=problem.symbols.inputs,
        parameters=dict(zip(problem.symbols.free, map(float, P))), duration=float(T),
        objective=objective, constraint_violation=violation,
        success=success, status=solution.status,
        message=text, iterations=solution.iterations, wall_time=solution.wall_time,
        method=problem.method, solver=solution.solver, x=x,
        multipliers=multipliers, problem=problem, degree=problem.degree, **mid)
