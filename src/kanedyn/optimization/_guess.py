"""Initial guesses: a straight line, a simulation, an earlier solution.

Each gives the decision vector of :class:`._transcription.Layout`; the free
parameters start at the model's values unless an earlier solution has them.
"""

from __future__ import annotations

import numbers

import numpy as np

from .._errors import ModelError
from ._transcription import Layout

__all__ = ["line", "from_result", "vector"]


def _layout(problem):
    return Layout.of(problem)


def _interior_fractions(problem):
    """Where the interior points lie, as fractions of the duration (empty
    for a layout without them)."""
    L = _layout(problem)
    return L.positions()[L.nodes:]


def _named(values, names, what):
    """``{index: value}`` of a dict keyed by symbols or names among ``names``."""
    from ._problem import _name
    out = {}
    for key, value in values.items():
        name = _name(key)
        if name not in names:
            raise ModelError(f"{what} names {key}, which is not one of {', '.join(names)}")
        out[names.index(name)] = value
    return out


def _duration(problem, duration):
    if problem.free_duration:
        if duration is None:
            raise ModelError(f"the duration {problem.duration} is free: give the guess's "
                             "duration=...")
        return float(duration)
    if duration is not None:
        raise ModelError("duration= is only for a problem whose duration is free")
    return problem.duration_value


def _input_columns(problem, inputs, times):
    names = problem.symbols.inputs
    given = _named(inputs, names, "inputs")
    missing = [n for k, n in enumerate(names) if k not in given]
    if missing:
        raise ModelError(f"the guess needs a value for every input: missing "
                         f"{', '.join(missing)} (inputs={{...}})")
    R = np.empty((times.size, len(names)))
    for k, value in given.items():
        if callable(value):
            R[:, k] = [float(value(t)) for t in times]
        elif isinstance(value, (numbers.Real, np.number)) and not isinstance(value, bool):
            R[:, k] = float(value)
        else:
            raise ModelError(f"input guess of {names[k]} must be a number or f(t), got "
                             f"{value!r}")
    return R


def line(problem, start, end, inputs, duration):
    names = problem.symbols.states
    a = dict(problem.initial)
    a.update(_named(start, names, "start"))
    b = dict(problem.final)
    b.update(_named(end, names, "end"))
    missing = [n for k, n in enumerate(names) if k not in a or k not in b]
    if missing:
        raise ModelError(f"a straight-line guess needs both ends of every state: missing "
                         f"{', '.join(missing)} (start={{...}}, end={{...}}, or initial/final "
                         "of the problem)")
    T = _duration(problem, duration)
    s = np.linspace(0.0, 1.0, problem.nodes)[:, None]
    y0 = np.array([a[k] for k in range(len(names))], dtype=float)
    y1 = np.array([b[k] for k in range(len(names))], dtype=float)
    Y = y0 + s * (y1 - y0)
    R = _input_columns(problem, inputs, problem.node_times(T))
    inner = _interior_fractions(problem)[:, None]
    Yi = y0 + inner * (y1 - y0)
    Ri = _input_columns(problem, inputs, problem.start_time + T * inner[:, 0])
    return _layout(problem).join(Y, R, problem.parameter_start(), T, Yi, Ri)


def from_result(problem, result, inputs):
    from ._result import OptimalControlResult
    if isinstance(result, OptimalControlResult):
        if inputs is not None:
            raise ModelError("an optimal control result brings its inputs; inputs= is for "
                             "a simulation")
        if result.state_names != problem.symbols.states:
            raise ModelError(f"the earlier solution has the states {result.state_names}, "
                             f"this problem {problem.symbols.states}")
        T = result.duration
        # the earlier points (its nodes, and its interior points when it has
        # them) in order, as fractions of its duration
        s_old, y_old, r_old = result.t, result.y, result.r
        if result.t_mid is not None:
            s_old = np.concatenate([result.t, result.t_mid])
            order = np.argsort(s_old, kind="stable")
            s_old = s_old[order]
            y_old = np.concatenate([result.y, result.y_mid], axis=1)[:, order]
            r_old = np.concatenate([result.r, result.r_mid], axis=1)[:, order]
        s_old = (s_old - result.t[0]) / T

        def at(s_new):
            Y = np.stack([np.interp(s_new, s_old, row) for row in y_old], axis=1)
            R = np.stack([np.interp(s_new, s_old, row) for row in r_old], axis=1) \
                if r_old.shape[0] else np.zeros((s_new.size, 0))
            return Y, R
        Y, R = at(np.linspace(0.0, 1.0, problem.nodes))
        Yi, Ri = at(_interior_fractions(problem))
        P = np.array([result.parameters.get(n, start) for n, start in
                      zip(problem.symbols.free, problem.parameter_start())], dtype=float)
        return _layout(problem).join(Y, R, P, T if problem.free_duration else None, Yi, Ri)
    if not (hasattr(result, "t") and hasattr(result, "y") and hasattr(result, "state_names")):
        raise ModelError(f"guess_from takes a SimulationResult or an OptimalControlResult, "
                         f"not {type(result).__name__}")
    if tuple(result.state_names) != problem.symbols.states:
        raise ModelError(f"the simulation has the states {tuple(result.state_names)}, this "
                         f"problem {problem.symbols.states}")
    t = np.asarray(result.t, dtype=float)
    if t.size < 2:
        raise ModelError("the simulation has fewer than two output times")
    span = t[-1] - t[0]
    if problem.free_duration:
        T = span
    else:
        T = problem.duration_value
        if span < T * (1 - 1e-9):
            raise ModelError(f"the simulation covers {span:g} s, shorter than the duration "
                             f"{T:g} s")
    times = t[0] + np.linspace(0.0, T, problem.nodes)

    def states(at):
        if not at.size:
            return np.zeros((0, len(result.state_names)))
        if getattr(result, "sol", None) is not None:  # dense output: exact between steps
            return np.asarray(result.sol(at), dtype=float).T
        return np.stack([np.interp(at, t, row) for row in result.y], axis=1)
    Y = states(times)
    R = _input_columns(problem, inputs or {}, times)
    inner = t[0] + T * _interior_fractions(problem)
    Yi, Ri = states(inner), _input_columns(problem, inputs or {}, inner)
    return _layout(problem).join(Y, R, problem.parameter_start(), T, Yi, Ri)


def vector(problem, guess, warm_start):
    """``(x0, warm)``: the starting decision vector, and the multipliers of a warm start."""
    from ._result import OptimalControlResult
    warm = None
    if isinstance(guess, OptimalControlResult):
        same = _layout(guess.problem) == _layout(problem)
        x0 = guess.x if same else from_result(problem, guess, None)
        if warm_start:
            if not same or guess.multipliers["g"] is None:
                raise ModelError("a warm start needs a previous solution of a problem with "
                                 "the same nodes, constraints and variables")
            warm = guess.multipliers
    else:
        if warm_start:
            raise ModelError("warm_start=True needs a previous OptimalControlResult as guess")
        x0 = np.asarray(guess, dtype=float)
        if x0.shape != (problem.n_variables,):
            inner = _layout(problem).n_interior
            mid = f" and {inner} interior points" if inner else ""
            raise ModelError(f"the guess must have shape ({problem.n_variables},) (states "
                             f"and inputs at {problem.nodes} nodes{mid}, the free "
                             f"parameters, the duration when free), got {x0.shape}; use "
                             "guess_line or guess_from")
    if not np.all(np.isfinite(x0)):
        raise ModelError("the guess contains values that are not finite")
    return x0, warm
