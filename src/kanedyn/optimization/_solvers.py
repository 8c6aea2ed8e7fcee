"""NLP solvers behind one small interface.

A solver is an object with a ``name`` and ``solve(nlp, x0, options, warm,
stop) -> NLPSolution``; :data:`SOLVERS` maps the names ``solve(solver=...)``
accepts to them.  ``nlp`` gives ``n``, ``m``, ``x_lower``, ``x_upper``,
``g_lower``, ``g_upper``, ``objective(x)``, ``gradient(x)``,
``constraints(x)``, ``jacobian_structure()`` and ``jacobian(x)`` (values in
the pattern's order).  ``stop()`` is asked once per iteration: ``True`` ends
the solve with the current iterate.

IPOPT through cyipopt was chosen by measurement (``docs/benchmarks.md``,
``benchmarks/bench_nlp_solvers.py``): it takes the Jacobian's pattern once and
its values per call; CasADi's IPOPT reached through ``casadi.Callback`` took
time growing as N^3 (194 s at 3,000 variables against 0.12 s).  The Hessian
of the Lagrangian is IPOPT's limited-memory quasi-Newton approximation
(``hessian_approximation = "limited-memory"``) unless the NLP has an exact
one (``nlp.exact_hessian``, ``solve(hessian="exact")``): then
``hessian_structure()`` and ``hessian(x, multipliers, objective_factor)``.

``"interior-point"`` is kanedyn's own solver (:mod:`.interior_point`):
IPOPT's algorithm on the exact Hessian, its KKT systems factorized by
kanedyn (no cyipopt needed), its status codes and multipliers IPOPT's.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .._errors import ModelError, OptionError
from .interior_point import InteriorPoint

__all__ = ["NLPSolution", "Ipopt", "SOLVERS", "solver_named", "solve_nlp", "solver_arrays",
           "IPOPT_STATUS"]

#: IPOPT's return codes and what they mean for the user
IPOPT_STATUS = {
    0: "solved",
    1: "solved to an acceptable level",
    2: "infeasible: IPOPT found no point satisfying the constraints and bounds "
       "(check them, or give a better initial guess)",
    3: "the search direction became too small",
    4: "the iterates diverged: the objective may be unbounded below (bound the "
       "variables it decreases along)",
    5: "stopped on request",
    6: "a feasible point was found",
    -1: "the maximum number of iterations was reached (options={'max_iter': ...})",
    -2: "the restoration phase failed (the constraints may be infeasible or badly "
        "scaled; try another initial guess)",
    -3: "error in the step computation",
    -4: "the maximum CPU time was reached",
    -10: "not enough degrees of freedom (more equality constraints than variables)",
    -11: "invalid problem definition",
    -12: "invalid option",
    -13: "an invalid number (nan or inf) came from the model or the objective",
    -100: "unrecoverable exception",
    -101: "an exception was raised outside IPOPT",
    -102: "not enough memory",
    -199: "IPOPT's internal error",
}


@dataclass(frozen=True)
class NLPSolution:
    """What an NLP solver returned.

    Attributes
    ----------
    x : ndarray
        The last iterate (the solution when ``status`` is 0 or 1).
    objective : float
    status : int
        The solver's own code (IPOPT's, see :data:`IPOPT_STATUS`).
    status_text : str
        The solver's own status message.
    iterations : int
    wall_time : float
        Seconds in the solver (callbacks included).
    multipliers : dict
        ``{"g": ..., "x_lower": ..., "x_upper": ...}`` for a warm start.
    solver : str
    hessian : str or None
        The Hessian of the Lagrangian the solver used: ``"exact"`` or
        ``"limited-memory"`` (``None``: a solver that does not say).
    advice : str or None
        What the solver suggests to try after this status (``None``: nothing
        of its own); a result's message gives it unless its diagnosis says
        more (:func:`._result.status_text`).
    """

    x: np.ndarray
    objective: float
    status: int
    status_text: str
    iterations: int
    wall_time: float
    multipliers: dict
    solver: str
    hessian: str | None = None
    advice: str | None = None


class Ipopt:
    """IPOPT through cyipopt (the ``optimal`` extra; see docs/optimal_control.md).

    The options kanedyn sets unless given: ``hessian_approximation =
    "limited-memory"``, ``print_level = 0``, ``sb = "yes"``, and with MUMPS
    (IPOPT's linear solver unless ``linear_solver`` names another)
    ``mumps_mem_percent = 100`` (:data:`MUMPS_DEFAULTS`).  An option IPOPT
    refuses raises :class:`~kanedyn.OptionError` (a ``ValueError``), with the
    known names spelled like it; IPOPT itself prints a line about it to
    standard output first (before its ``print_level`` takes effect: not
    kept out).
    """

    name = "ipopt"
    DEFAULTS = {"hessian_approximation": "limited-memory", "print_level": 0, "sb": "yes"}
    #: MUMPS's workspace: 100 % over its own estimate, where IPOPT reserves
    #: 1000 %.  IPOPT doubles the percentage and factorizes again whenever
    #: MUMPS finds it too small, so the iterates are the same, and the
    #: reserved address space at 100,000 nodes falls by about a gigabyte
    #: (docs/optimal_control.md, "Memory").  Not set for an IPOPT built
    #: without MUMPS, which has no such option.
    MUMPS_DEFAULTS = {"mumps_mem_percent": 100}

    def _refused(self, key, value, exc):
        """The :class:`OptionError` of an option IPOPT refused: an unknown name
        or a value it does not take (IPOPT does not tell which), with the
        names kanedyn knows that are spelled like ``key``."""
        from .interior_point._options import DEFAULTS, similar_option
        known = {*DEFAULTS, *self.DEFAULTS, *self.MUMPS_DEFAULTS}
        why = ("a value it does not take" if key in known else
               f"an unknown name or a value it does not take{similar_option(key, known)}")
        return OptionError(f"IPOPT refused the option {key}={value!r} ({exc}: {why}); see "
                           "IPOPT's list of options (https://coin-or.github.io/Ipopt/OPTIONS.html)")

    @staticmethod
    def available():
        """``None`` when cyipopt imports, else why not (text)."""
        try:
            import cyipopt  # noqa: F401
        except ImportError as exc:
            return (f"the IPOPT solver needs cyipopt ({exc}); install it with "
                    "pip install 'kanedyn[optimal]' (on Linux x86-64 it brings IPOPT; "
                    "elsewhere cyipopt needs an installed IPOPT, e.g. Debian's "
                    "coinor-libipopt-dev)")
        return None

    def solve(self, nlp, x0, options=None, warm=None, stop=lambda: False):
        reason = self.available()
        if reason:
            raise ImportError(reason)
        import cyipopt
        count = [0]

        class Callbacks:
            objective = staticmethod(nlp.objective)
            gradient = staticmethod(nlp.gradient)
            constraints = staticmethod(nlp.constraints)
            jacobian = staticmethod(nlp.jacobian)

            def jacobianstructure(self):
                return nlp.jacobian_structure()

            def intermediate(self, alg_mod, iter_count, *rest):
                count[0] = int(iter_count)
                return not stop()

        exact = getattr(nlp, "exact_hessian", None) is not None
        if exact:
            Callbacks.hessianstructure = lambda self: nlp.hessian_structure()
            Callbacks.hessian = staticmethod(nlp.hessian)

        merged = dict(self.DEFAULTS, **(options or {}))
        asked = (options or {}).get("hessian_approximation")
        if exact:
            if asked not in (None, "exact"):
                raise OptionError('hessian="exact" and the IPOPT option '
                                  f'hessian_approximation={asked!r} contradict each other; '
                                  'give one')
            merged["hessian_approximation"] = "exact"
        elif asked == "exact":
            raise OptionError("IPOPT option hessian_approximation='exact': this NLP has no "
                              'exact Hessian; pass hessian="exact" to solve()')
        problem = cyipopt.Problem(n=nlp.n, m=nlp.m, problem_obj=Callbacks(),
                                  lb=nlp.x_lower, ub=nlp.x_upper,
                                  cl=nlp.g_lower, cu=nlp.g_upper)
        if warm is not None:
            merged.setdefault("warm_start_init_point", "yes")
        for key, value in merged.items():
            if isinstance(value, bool):
                value = "yes" if value else "no"
            try:
                problem.add_option(key, value)
            except (TypeError, ValueError) as exc:
                raise self._refused(key, value, exc) from None
        if merged.get("linear_solver", "mumps") == "mumps":
            for key, value in self.MUMPS_DEFAULTS.items():
                if key not in merged:
                    try:
                        problem.add_option(key, value)
                    except (TypeError, ValueError):
                        pass  # an IPOPT without MUMPS: its own linear solver runs
        start = time.perf_counter()
        if warm is not None:
            x, info = problem.solve(x0, lagrange=warm["g"], zl=warm["x_lower"],
                                    zu=warm["x_upper"])
        else:
            x, info = problem.solve(x0)
        wall = time.perf_counter() - start
        text = info["status_msg"]
        if isinstance(text, bytes):
            text = text.decode(errors="replace")
        return NLPSolution(
            x=np.asarray(x, dtype=float), objective=float(info["obj_val"]),
            status=int(info["status"]), status_text=str(text).strip(),
            iterations=count[0], wall_time=wall,
            multipliers={"g": np.asarray(info["mult_g"]),
                         "x_lower": np.asarray(info["mult_x_L"]),
                         "x_upper": np.asarray(info["mult_x_U"])},
            solver=self.name, hessian=merged["hessian_approximation"])


#: solver name -> class
SOLVERS = {"ipopt": Ipopt, "interior-point": InteriorPoint}


def solver_named(solver):
    """The solver object for a name of :data:`SOLVERS` or an object with ``solve``."""
    if isinstance(solver, str):
        try:
            return SOLVERS[solver]()
        except KeyError:
            raise ModelError(f"unknown NLP solver {solver!r}; available: "
                             f"{', '.join(SOLVERS)}") from None
    if not hasattr(solver, "solve"):
        raise ModelError(f"solver must be a name ({', '.join(SOLVERS)}) or an object with "
                         f"solve(nlp, x0, options, warm, stop), not {solver!r}")
    return solver


def solver_arrays(solver, options):
    """The context in which ``solver`` (a name or an object) has an NLP built,
    solved and its result made: its ``arrays(options)`` where it has one (the
    interior point's large arrays mapped), else none."""
    import contextlib
    arrays = getattr(solver_named(solver), "arrays", None)
    return arrays(options) if arrays is not None else contextlib.nullcontext()


def solve_nlp(solver, nlp, x0, options, warm):
    """``(NLPSolution, signal)``: ``nlp`` solved from ``x0`` by ``solver`` (a
    name or an object), a Ctrl-C (SIGINT) or SIGTERM stopping it at the next
    iteration (``signal``: its number, else ``None``) and a second one at once."""
    from .._signals import Stopped, holding
    chosen = solver_named(solver)
    stop = {"signal": None}

    def on_signal(signum):
        if stop["signal"] is not None:  # a second one: stop at once
            raise Stopped(signum)
        stop["signal"] = signum

    with holding(on_signal):
        solution = chosen.solve(nlp, x0, options=options, warm=warm,
                                stop=lambda: stop["signal"] is not None)
    return solution, stop["signal"]
