r"""``MultiphaseProblem``: optimal control problems in sequence, joined at
their junctions, solved as one NLP.

.. math::

    \min \sum_{k=1}^{P} \Big(\Phi_k + \int_{t_0^{(k)}}^{t_0^{(k)} + T_k} L_k\, dt\Big)
    \quad\text{s.t. each phase's dynamics, bounds and constraints,}\quad
    t_0^{(k+1)} = t_0^{(k)} + T_k,\quad \text{the linkages}

Each phase is an :class:`OptimalControlProblem` with its own model (the same
or another: other states, inputs, constants), nodes, method, duration (fixed
or free), objective and constraints.  A phase starts where the one before
ends; when a duration before it is free, its start time is a variable of the
NLP (the last entry of its part of the decision vector), tied by one row to
the end of the phase before.  The decision vector is the phases' vectors one
after the other; the constraints are the phases' rows, then each junction's
(:mod:`._linkage`).  The Jacobian is the phases' blocks on the diagonal and
the junctions' rows, each exact.
"""

from __future__ import annotations

import numpy as np

from .._errors import ModelError
from ._linkage import Linkage, _Side, junction_rows
from ._nlp import index_arrays, largest_violation

__all__ = ["MultiphaseProblem", "MultiphaseNLP"]


class MultiphaseProblem:
    r"""Phases of optimal control joined by linkages, solved as one problem.

    Parameters
    ----------
    phases : sequence of OptimalControlProblem
        At least two, in time order.  The first starts at its
        ``start_time``; each other starts where the one before ends (leave
        its ``start_time`` out, or give that time).  Their objectives are
        summed.
    linkages : Linkage or sequence of Linkage, optional
        How each phase joins the next: one per junction, or one for all.  By
        default (``None``) every state both phases have is continuous.

    Raises
    ------
    ModelError
        Fewer than two phases, a linkage count that is not the junction
        count, a linkage naming a state or input a phase lacks, a junction
        that joins nothing, two phases with the same free-duration symbol, a
        start time that is not where the phase before ends.

    Notes
    -----
    In a phase whose start time follows a free duration, the times of its
    instance constraints are measured from its own start (it was stated
    with ``start_time`` left out, so its clock starts at 0); its model,
    objective and path constraints see the absolute time.

    Examples
    --------
    >>> ocp = kd.MultiphaseProblem([loaded, released])          # doctest: +SKIP
    >>> res = ocp.solve([loaded.guess_line(inputs={F: 0.0}),
    ...                  released.guess_line(inputs={F: 0.0})])  # doctest: +SKIP
    >>> res.phases[1]["x"], res.t, res["x"]                      # doctest: +SKIP
    """

    def __init__(self, phases, linkages=None):
        from ._problem import OptimalControlProblem
        phases = list(phases) if hasattr(phases, "__iter__") else [phases]
        if len(phases) < 2:
            raise ModelError(f"a multiphase problem needs at least two phases, got "
                             f"{len(phases)} (a single phase is solved by its own solve())")
        for k, phase in enumerate(phases):
            if not isinstance(phase, OptimalControlProblem):
                raise ModelError(f"phase {k + 1} must be an OptimalControlProblem, got "
                                 f"{type(phase).__name__}")
        self.phases = tuple(phases)
        self._durations()
        self._start_times()
        self.linkages = self._linkages(linkages)
        self.nlp = MultiphaseNLP(self)  # compiles the linkages: their errors come here

    # ------------------------------------------------------------ checks
    def _durations(self):
        seen = {}
        for k, phase in enumerate(self.phases):
            if phase.free_duration:
                name = str(phase.duration)
                if name in seen:
                    raise ModelError(f"phases {seen[name]} and {k + 1} both have the free "
                                     f"duration {name}; give each phase a symbol of its own")
                seen[name] = k + 1

    def _start_times(self):
        """``self.starts``: each phase's start time, s, or ``None`` where it
        is a variable (a free duration comes before it)."""
        first = self.phases[0]
        starts, end = [first.start_time], first.start_time + (first.duration_value or 0.0)
        free_before = first.free_duration
        for k, phase in enumerate(self.phases[1:], start=2):
            if free_before:
                if phase.start_time_given:
                    raise ModelError(
                        f"phase {k} starts where phase {k - 1} ends, which follows a free "
                        f"duration: leave its start_time out (it was given "
                        f"{phase.start_time:g} s)")
                starts.append(None)
            else:
                if phase.start_time_given and abs(phase.start_time - end) > 1e-12 * max(
                        1.0, abs(end)):
                    raise ModelError(f"phase {k} starts where phase {k - 1} ends, at "
                                     f"{end:g} s, but was given start_time="
                                     f"{phase.start_time:g}; leave it out or give {end:g}")
                starts.append(end)
                end += phase.duration_value or 0.0
            free_before = free_before or phase.free_duration
        self.starts = tuple(starts)

    def _linkages(self, linkages):
        n = len(self.phases) - 1
        if linkages is None:
            return (Linkage(),) * n
        if isinstance(linkages, Linkage):
            return (linkages,) * n
        if not hasattr(linkages, "__iter__"):
            raise ModelError(f"linkages must be a Linkage or a sequence of them, got "
                             f"{type(linkages).__name__}")
        linkages = tuple(linkages)
        if len(linkages) != n:
            raise ModelError(f"{len(self.phases)} phases have {n} junctions, but linkages= "
                             f"gives {len(linkages)} (one Linkage per junction, or one for "
                             "all)")
        for k, link in enumerate(linkages):
            if not isinstance(link, Linkage):
                raise ModelError(f"linkage {k + 1} must be a kd.Linkage, got "
                                 f"{type(link).__name__}")
        return linkages

    # ----------------------------------------------------------- guesses
    @property
    def n_variables(self):
        """Length of the decision vector: the phases' vectors one after the
        other (with a start time at the end of a phase whose start is a
        variable)."""
        return self.nlp.n

    def _vector(self, guess, warm_start):
        """``(x0, warm)`` from a previous :class:`MultiphaseResult`, one
        guess per phase (what a phase's ``solve`` takes), or a vector."""
        from ._guess import vector
        from ._multiphase_result import MultiphaseResult
        nlp = self.nlp
        if isinstance(guess, MultiphaseResult):
            if guess.problem.nlp.layouts == nlp.layouts:
                warm = guess.multipliers if warm_start else None
                return guess.x, warm
            if warm_start:
                raise ModelError("a warm start needs a previous solution of a problem with "
                                 "the same phases, nodes and variables")
            guess = guess.phases
        elif warm_start:
            raise ModelError("warm_start=True needs a previous MultiphaseResult as guess")
        if isinstance(guess, np.ndarray) and guess.ndim == 1 and guess.dtype != object:
            if guess.shape != (nlp.n,):
                raise ModelError(f"the guess must have shape ({nlp.n},) (the phases' vectors "
                                 f"one after the other), got {guess.shape}; or give one "
                                 "guess per phase")
            if not np.all(np.isfinite(guess)):
                raise ModelError("the guess contains values that are not finite")
            return np.asarray(guess, dtype=float), None
        guesses = list(guess) if hasattr(guess, "__iter__") else [guess]
        if len(guesses) != len(self.phases):
            raise ModelError(f"give one guess per phase: {len(self.phases)} phases, "
                             f"{len(guesses)} guesses")
        parts, end = [], None
        for k, (phase, g, sub) in enumerate(zip(self.phases, guesses, nlp.phase_nlps)):
            try:
                x, _ = vector(phase, g, False)
            except ModelError as exc:
                raise ModelError(f"phase {k + 1}: {exc}") from None
            L = sub.layout
            start = self.starts[k] if self.starts[k] is not None else end
            if L.free_start_time:
                x = np.append(x, start)
            T = x[L.duration_index] if L.free_duration else phase.duration_value
            end = start + T
            parts.append(x)
        return np.concatenate(parts), None

    # ------------------------------------------------------------ solve
    def solve(self, guess, *, solver="ipopt", options=None, warm_start=False,
              hessian="limited-memory"):
        """Solve all phases as one NLP from ``guess``.

        Parameters
        ----------
        guess : sequence, ndarray or MultiphaseResult
            One guess per phase (a decision vector of that phase, its
            ``guess_line`` or ``guess_from``, or an :class:`OptimalControlResult`),
            the whole decision vector, or a previous solution.
        solver, options, warm_start, hessian
            As :meth:`OptimalControlProblem.solve` (a warm start needs a
            previous :class:`MultiphaseResult` of the same layout; the exact
            Hessian, :mod:`._multiphase_hessian`, for phases it covers).

        Returns
        -------
        MultiphaseResult
            Also when the solver fails or is interrupted.
        """
        from ._multiphase_result import build_multiphase_result
        from ._solvers import solve_nlp, solver_arrays
        from .._errors import ModelError
        from ._hessian import HESSIANS
        if hessian not in HESSIANS:
            raise ModelError(f"hessian={hessian!r}: give one of {', '.join(HESSIANS)}")
        nlp = self.nlp
        if hessian == "exact":
            nlp = self.__dict__.get("_exact_nlp")
            if nlp is None:
                nlp = self.__dict__["_exact_nlp"] = MultiphaseNLP(self, hessian="exact")
        with solver_arrays(solver, options):
            x0, warm = self._vector(guess, warm_start)
            solution, signal = solve_nlp(solver, nlp, x0, options, warm)
            return build_multiphase_result(self, solution, signal)

    def __repr__(self):
        return (f"<MultiphaseProblem of {len(self.phases)} phases: "
                f"{', '.join(p.method for p in self.phases)}; "
                f"{self.nlp.n} variables>")


class MultiphaseNLP:
    """The NLP of a :class:`MultiphaseProblem`: the phases'
    :class:`._nlp.CollocationNLP` side by side, then the junctions' rows
    (``hessian="exact"``: with the Lagrangian's exact Hessian,
    :mod:`._multiphase_hessian`)."""

    #: as :attr:`._nlp.CollocationNLP.returns_new_arrays` (their values joined
    #: into a new array)
    returns_new_arrays = True

    def __init__(self, problem, hessian="limited-memory"):
        from ._nlp import CollocationNLP
        self.problem = problem
        self.phase_nlps, self.offsets, self.row_offsets = [], [], []
        n = m = 0
        for phase, start in zip(problem.phases, problem.starts):
            nlp = CollocationNLP(phase, start_time=start, free_start_time=start is None,
                                 hessian=hessian)
            self.phase_nlps.append(nlp)
            self.offsets.append(n)
            self.row_offsets.append(m)
            n, m = n + nlp.n, m + nlp.m
        self.layouts = tuple(nlp.layout for nlp in self.phase_nlps)
        sides = [_Side(k + 1, phase, nlp.layout, offset, start, last)
                 for k, (phase, nlp, offset, start) in enumerate(zip(
                     problem.phases, self.phase_nlps, self.offsets, problem.starts))
                 for last in (False, True)]
        self.junctions = [junction_rows(k, link, sides[2 * k + 1], sides[2 * k + 2])
                          for k, link in enumerate(problem.linkages)]
        self.rows = [row for rows in self.junctions for row in rows]
        self.n, self.m = n, m + len(self.rows)
        self.x_lower = np.concatenate([nlp.x_lower for nlp in self.phase_nlps])
        self.x_upper = np.concatenate([nlp.x_upper for nlp in self.phase_nlps])
        zeros = np.zeros(len(self.rows))
        self.g_lower = np.concatenate([nlp.g_lower for nlp in self.phase_nlps] + [zeros])
        self.g_upper = np.concatenate([nlp.g_upper for nlp in self.phase_nlps] + [zeros])
        rows, cols = [], []
        for nlp, offset, row_offset in zip(self.phase_nlps, self.offsets, self.row_offsets):
            r, c = nlp.jacobian_structure()
            rows.append(r + row_offset)
            cols.append(c + offset)
        for i, row in enumerate(self.rows):
            rows.append(np.full(row.columns.size, m + i))
            cols.append(row.columns)
        self.structure = index_arrays(rows, cols, self.m, self.n)
        #: the exact Hessian of the Lagrangian, or ``None``
        self.exact_hessian = None
        if hessian == "exact":
            from ._multiphase_hessian import MultiphaseHessian
            self.exact_hessian = MultiphaseHessian(self)

    def hessian_structure(self):
        """Lower triangle of the Lagrangian's Hessian (``hessian="exact"``)."""
        return self.exact_hessian.structure

    def hessian(self, z, multipliers, objective_factor):
        """The Hessian's values at ``z`` (IPOPT's ``obj_factor`` and ``lambda``)."""
        return self.exact_hessian.values(z, objective_factor, multipliers)

    def parts(self, z):
        """Each phase's part of ``z``."""
        z = np.asarray(z, dtype=float)
        return [z[o:o + nlp.n] for o, nlp in zip(self.offsets, self.phase_nlps)]

    def objective(self, z):
        return sum(nlp.objective(x) for nlp, x in zip(self.phase_nlps, self.parts(z)))

    def gradient(self, z):
        return np.concatenate([nlp.gradient(x) for nlp, x in zip(self.phase_nlps,
                                                                   self.parts(z))])

    def constraints(self, z):
        z = np.asarray(z, dtype=float)
        own = [nlp.constraints(x) for nlp, x in zip(self.phase_nlps, self.parts(z))]
        return np.concatenate(own + [[row.function(z)[0] for row in self.rows]])

    def jacobian_structure(self):
        return self.structure

    def jacobian(self, z):
        z = np.asarray(z, dtype=float)
        own = [nlp.jacobian(x) for nlp, x in zip(self.phase_nlps, self.parts(z))]
        return np.concatenate(own + [row.function(z)[1] for row in self.rows])

    def violation(self, z):
        """Largest violation of a constraint or a bound at ``z``."""
        return largest_violation(self, z)
