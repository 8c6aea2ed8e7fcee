r"""Named optimal-control problems on the built-in models (``kanedyn optimize``).

A named problem is a function that poses an
:class:`~kanedyn.OptimalControlProblem` on a built-in model, solves it and
checks the optimum independently, returning a frozen study result with the
:class:`~kanedyn.OptimalControlResult` (``.result``), a ``summary`` text, named
numbers (``data``) and ``plot(path)``.  Every such function takes the same
keywords, which ``kanedyn optimize`` fills from its options:

``nodes``, ``method``, ``duration``
    the transcription (``None``: the problem's defaults);
``bounds``
    ``{state or input name: (lower, upper)}``, replacing the problem's;
``constants``
    ``{constant name: value}`` of the model;
``model_options``
    options of the built-in model (``n_modes=2``);
``backend``
    ``"c"``, ``"numpy"`` or ``"auto"``;
``ipopt``
    the NLP solver's options (``{"hessian_approximation": "exact"}`` solves
    with the exact Hessian of the Lagrangian, ``OptimalControlProblem.solve(
    hessian="exact")``; the default is IPOPT's limited-memory approximation;
    ``{"solver": "interior-point"}`` picks kanedyn's own solver instead of
    IPOPT, with the exact Hessian unless ``hessian_approximation`` is
    ``"limited-memory"``);
``degree``
    LGR's points per interval (``method="lgr"`` only; ``None``: 3);

and its own options (:attr:`OptimalProblem.options`).

:data:`OPTIMAL_PROBLEMS` maps a model's name to its problems; the modules
that define them register them (:func:`register_problem`) and
:func:`available_problems` imports those modules.  Here: the pendulum's
swing-up (:func:`pendulum_swing_up`, opty's gallery problem).
"""

from __future__ import annotations

import types
from dataclasses import dataclass, field

import numpy as np

from .._errors import KanedynError
from ._studies import StudyOption, register_study

__all__ = ["OptimalProblem", "OPTIMAL_PROBLEMS", "register_problem", "available_problems",
           "optimal_problem", "pendulum_swing_up", "SwingUp", "IPOPT_DEFAULTS",
           "InputPeaks", "input_peaks", "solution_word", "limit_lines"]

#: IPOPT's options of the named problems unless given (``ipopt=``)
IPOPT_DEFAULTS = {"tol": 1e-8, "max_iter": 3000}
#: samples per mesh interval at which the summaries and figures evaluate the
#: inputs as replayed (the transcription's polynomial between the nodes)
SAMPLES_PER_INTERVAL = 40
#: a ratio to a limit above 1 by more than this is reported as over the limit
#: (IPOPT holds bounds to about 1e-8 relative)
LIMIT_TOLERANCE = 1e-6
#: the inputs between the nodes, by method (``OptimalControlResult.inputs``)
_BETWEEN = {"trapezoid": "linear between the nodes",
            "hermite-simpson": "Hermite-Simpson's quadratic between the nodes",
            "backward-euler": "held between the nodes",
            "midpoint": "held between the nodes",
            "lgr": "LGR's polynomial on each interval"}


@dataclass(frozen=True)
class OptimalProblem:
    """A named optimal-control problem on a built-in model.

    Attributes
    ----------
    model : str
        The built-in model's name (``kanedyn list``).
    name : str
    function : callable
        ``function(nodes=, method=, duration=, bounds=, constants=,
        model_options=, backend=, ipopt=, degree=, **options)`` -> a study result with
        ``result``, ``summary``, ``data`` and ``plot(path)``.
    description : str
        One line.
    nodes, method, duration :
        The defaults.
    options : dict
        ``{name: StudyOption}`` of the problem's own options.
    required : dict
        Options of the built-in model the problem needs (``{"torque": True}``:
        the input it optimizes); the model's other options are the user's.
    """

    model: str
    name: str
    function: object
    description: str
    nodes: int
    method: str
    duration: float
    options: dict = field(default_factory=dict)
    required: dict = field(default_factory=dict)


#: model name -> {problem name: OptimalProblem}, the first one the default
OPTIMAL_PROBLEMS = {}


def register_problem(problem):
    """Add ``problem`` to :data:`OPTIMAL_PROBLEMS` (a name already taken raises),
    and as the study ``MODEL-NAME`` (``kanedyn study``)."""
    named = OPTIMAL_PROBLEMS.setdefault(problem.model, {})
    if problem.name in named:
        raise KanedynError(f"optimal-control problem {problem.model} {problem.name!r} is "
                           "already registered")
    named[problem.name] = problem
    run, options = _study_of(problem)
    register_study(f"{problem.model}-{problem.name}", run, options,
                   f"optimal control: {problem.description}")
    return problem


def available_problems():
    """:data:`OPTIMAL_PROBLEMS` with the built-in problems registered."""
    from . import (_bicycle_lane_change, _flexible_robot_oc,  # noqa: F401  (register)
                   _out_parallel_oc, _shuttle_arm_oc)
    return OPTIMAL_PROBLEMS


def optimal_problem(model, name=None):
    """The :class:`OptimalProblem` ``name`` of ``model`` (its first by default)."""
    problems = available_problems()
    if model not in problems:
        raise KanedynError(f"no optimal-control problem is defined on {model!r}; models "
                           f"with problems: {', '.join(problems)}")
    if name is None:
        return next(iter(problems[model].values()))
    if name not in problems[model]:
        raise KanedynError(f"{model} has no optimal-control problem {name!r}; its "
                           f"problems: {', '.join(problems[model])}")
    return problems[model][name]


# ------------------------------------------------------------- shared steps
def numeric_of(definition, constants, backend):
    """The numerical model of ``definition`` with ``constants`` (names or
    symbols) on ``backend`` (``"auto"``: C when a compiler is found)."""
    if backend == "auto":
        from ..numerics.backends import compiler_command
        backend = "c" if compiler_command() is not None else "numpy"
    known = {str(s) for s in definition.constants}
    unknown = sorted(str(k) for k in (constants or {}) if str(k) not in known)
    if unknown:
        raise KanedynError(f"{unknown[0]} is not a constant of {definition.name}; its "
                           f"constants: {', '.join(sorted(known))}")
    return definition.numeric(constants=dict(constants or {}), backend=backend)


def build_model(name, model_options, required):
    """The definition of the built-in ``name`` with ``model_options`` and the
    options the problem ``required`` (a conflict raises)."""
    from ..models import build
    options = dict(model_options or {})
    for key, value in required.items():
        if key in options and options[key] != value:
            raise KanedynError(f"this problem needs the model option {key}={value!r}, "
                               f"got {key}={options[key]!r}")
        options[key] = value
    return build(name, **options)


def merged_bounds(defaults, bounds, names):
    """``defaults`` updated by the user's ``bounds`` (names checked against
    ``names``, the model's states and inputs)."""
    out = dict(defaults)
    for key, pair in (bounds or {}).items():
        key = str(key).removesuffix("(t)")
        if key not in names:
            raise KanedynError(f"bounds name {key}, which is neither a state nor an input "
                               f"of the model ({', '.join(names)})")
        out[key] = pair
    return out


def solve(problem, guess, ipopt):
    """Solve with the named problems' IPOPT defaults updated by ``ipopt``
    (its ``hessian_approximation`` chooses the Hessian, its ``solver`` the
    NLP solver: ``"ipopt"`` unless given; ``"interior-point"`` with the exact
    Hessian unless told otherwise)."""
    options = dict(IPOPT_DEFAULTS, **(ipopt or {}))
    solver = options.pop("solver", "ipopt")
    default = "exact" if solver == "interior-point" else "limited-memory"
    hessian = options.pop("hessian_approximation", default)
    return problem.solve(guess, solver=solver, options=options, hessian=hessian)


class SplineInput:
    """An input as a function of t: a SciPy spline, evaluated as a float
    (picklable)."""

    def __init__(self, spline):
        self.spline = spline

    def __call__(self, t):
        return float(self.spline(t))


def solution_word(result):
    """What the summaries, tables, titles and legends call ``result``'s
    inputs and path: ``"optimal"`` when the solver solved the problem, else
    ``"last-iterate (not solved)"`` (an interrupted or failed solve)."""
    return "optimal" if result.success else "last-iterate (not solved)"


def result_lines(result, objective=None):
    """The summary lines every named problem prints about its solve.

    Parameters
    ----------
    result : OptimalControlResult
    objective : tuple of str, optional
        ``(what it is, unit)`` of the objective, which the study knows and
        this function does not (``("integral of tau^2", "N^2 m^2 s")``).
    """
    status = "solved" if result.success else "NOT solved"
    method = result.method if result.degree is None else (
        f"{result.method} of degree {result.degree}")
    value = (f"objective {result.objective:.10g}" if objective is None else
             f"objective {result.objective:.10g} {objective[1]} ({objective[0]})")
    return [f"{status}: {result.message}",
            f"{value}; {result.t.size} nodes, {method}, duration {result.duration:.6g} s; "
            f"{result.iterations} iterations in {result.wall_time:.2f} s"]


def replayed_inputs(result):
    """``(t, values)``: the inputs as replayed (``result.inputs()``, the
    transcription's polynomial between the nodes) at
    :data:`SAMPLES_PER_INTERVAL` points per mesh interval, the nodes among
    them; shapes (K,) in s and (n_inputs, K) in the inputs' units."""
    t = np.linspace(result.t[0], result.t[-1],
                    SAMPLES_PER_INTERVAL * (result.t.size - 1) + 1)
    values = [np.array([f(x) for x in t], dtype=float) for f in result.inputs().values()]
    return t, np.array(values).reshape(len(values), t.size)


def collocation_points_text(result):
    """Where the NLP holds the inputs' bounds: ``"the nodes"``, ``"the nodes
    and midpoints"`` or ``"the nodes and interior points"``."""
    if result.t_mid is None:
        return "the nodes"
    return ("the nodes and midpoints" if result.method == "hermite-simpson"
            else "the nodes and interior points")


@dataclass(frozen=True)
class InputPeaks:
    """The inputs' peaks at the collocation points (what the NLP bounds) and
    as replayed between them (what a simulation of ``result.inputs()``
    applies), against their limits.

    Attributes
    ----------
    names : tuple of str
        The inputs.
    limits : ndarray, shape (n,)
        Each input's limit, the larger magnitude of its finite bounds
        (``inf``: unbounded), in the input's unit.
    peak_points : ndarray, shape (n,)
        Each input's largest magnitude at the collocation points.
    peak_replayed, time_replayed : ndarray, shape (n,)
        Each input's largest magnitude as replayed, sampled at
        :data:`SAMPLES_PER_INTERVAL` points per mesh interval, and when (s).
    between : str
        What the inputs are between the nodes (``"linear between the nodes"``).
    points : str
        Where the NLP holds the bounds (``"the nodes and midpoints"``).
    """

    names: tuple
    limits: np.ndarray
    peak_points: np.ndarray
    peak_replayed: np.ndarray
    time_replayed: np.ndarray
    between: str
    points: str

    @property
    def _limited(self):
        """Which inputs have a limit (finite, above zero)."""
        return np.isfinite(self.limits) & (self.limits > 0)

    def _ratio(self, peaks):
        limited = self._limited
        return float(np.max(peaks[limited] / self.limits[limited])) if limited.any() else np.nan

    @property
    def ratio_points(self):
        """The largest peak over its limit at the collocation points (nan: no limits)."""
        return self._ratio(self.peak_points)

    @property
    def ratio_replayed(self):
        """The largest peak over its limit as replayed (nan: no limits)."""
        return self._ratio(self.peak_replayed)

    @property
    def worst(self):
        """Index of the input of the largest replayed ratio to its limit (of
        the largest replayed peak when none is limited)."""
        limited = self._limited
        if not limited.any():
            return int(np.argmax(self.peak_replayed))
        ratios = np.where(limited, self.peak_replayed / np.where(limited, self.limits, 1.0),
                          -np.inf)
        return int(np.argmax(ratios))

    @property
    def over(self):
        """Whether a replayed input goes over its limit (beyond
        :data:`LIMIT_TOLERANCE`)."""
        return bool(self.ratio_replayed > 1 + LIMIT_TOLERANCE)

    @property
    def data(self):
        """Named numbers: ``limit_ratio_points``, ``limit_ratio_replayed``
        (nan without limits), ``peak_replayed`` (the worst input's replayed
        peak, its unit) and ``peak_replayed_time`` (s)."""
        k = self.worst
        return dict(limit_ratio_points=self.ratio_points,
                    limit_ratio_replayed=self.ratio_replayed,
                    peak_replayed=float(self.peak_replayed[k]),
                    peak_replayed_time=float(self.time_replayed[k]))

    def line(self, what, unit):
        """One summary line about ``what`` (``"joint torque"``) in ``unit``:
        the largest ratio to its limit (or, none limited, the largest
        magnitude) at the collocation points and as replayed, naming the
        worst input and when; over 1, that the limits hold at the
        collocation points only."""
        k = self.worst
        where = f"({self.names[k]} at t = {self.time_replayed[k]:.4g} s)"
        if np.isnan(self.ratio_points):
            return (f"  largest |{what}| [{unit}], no limit: at {self.points} "
                    f"{np.max(self.peak_points):.6g}; as replayed ({self.between}) "
                    f"{self.peak_replayed[k]:.6g} {where}")
        text = (f"  largest {what} as a ratio to its limit: at {self.points} (where the NLP "
                f"bounds it) {self.ratio_points:.6f}; as replayed ({self.between}) "
                f"{self.ratio_replayed:.6f} {where}")
        if self.over:
            text += (f": the limits hold at {self.points} only; the replayed "
                     f"{self.names[k]} peaks at {self.peak_replayed[k]:.6g} {unit} against "
                     f"its limit {self.limits[k]:.6g} {unit}")
        return text


def input_peaks(result, limits):
    """The :class:`InputPeaks` of ``result`` with ``limits`` ``{input name
    or symbol: (lower, upper)}`` (a missing side ``None`` or infinite; other
    names ignored)."""
    bounds = {str(k).removesuffix("(t)"): v for k, v in limits.items()}
    limit = []
    for name in result.input_names:
        sides = [abs(float(v)) for v in bounds.get(name, (None, None))
                 if v is not None and np.isfinite(float(v))]
        limit.append(max(sides) if sides else np.inf)
    peak_points = np.max(np.abs(result.points()[2]), axis=1)
    t, values = replayed_inputs(result)
    at = np.argmax(np.abs(values), axis=1)
    return InputPeaks(
        names=tuple(result.input_names), limits=np.array(limit), peak_points=peak_points,
        peak_replayed=np.abs(values[np.arange(values.shape[0]), at]), time_replayed=t[at],
        between=_BETWEEN.get(result.method, "the transcription's polynomial"),
        points=collocation_points_text(result))


def limit_lines(ax, limit, unit):
    """Dashed lines at ``+-limit`` on ``ax``, the upper one labelled (none
    when ``limit`` is infinite)."""
    if np.isfinite(limit):
        for side in (-1, 1):
            ax.axhline(side * limit, color="0.4", ls="--", lw=0.8,
                       label=f"limits +-{limit:.4g} {unit}" if side > 0 else None)


def defect_text(defect, units):
    """``{state: largest difference}`` as text, the largest for each unit
    and the state it is of (``"1.5e-04 m (q2), 3e-05 rad (q4)"``)."""
    by_unit = {}
    for name, value in defect.items():
        unit = units.get(name) or "(unit unknown)"
        if unit not in by_unit or value > by_unit[unit][1]:
            by_unit[unit] = (name, value)
    return ", ".join(f"{value:.2g} {unit} ({name})"
                     for unit, (name, value) in sorted(by_unit.items()))


# ----------------------------------------------- the problems as studies too
def _study_of(problem):
    """``kanedyn study MODEL-PROBLEM``: the named problem with its defaults,
    writing the trajectory (nodes and midpoints) and the named numbers as
    tables, and the figure."""
    from ..models import REGISTRY
    model_options = {k: kind for k, kind in REGISTRY[problem.model][1].items()
                     if k not in problem.required}

    def run(out, quiet, nodes, method, duration, backend, degree=None, **options):
        chosen = {k: options.pop(k) for k in model_options if options.get(k) is not None}
        for k in model_options:
            options.pop(k, None)
        if degree is not None:  # only then: a problem may predate LGR's degree
            options["degree"] = degree
        found = problem.function(nodes=nodes, method=method, duration=duration,
                                 backend=backend, model_options=chosen, **options)
        figures = []
        if out is not None:
            figures.append(found.plot(out / f"{problem.model}-{problem.name}.png"))
        numbers = (("name", "value"), [(k, float(v)) for k, v in sorted(found.data.items())])
        return dict(tables={"trajectory": found.result.table(), "numbers": numbers},
                    figures=figures, summary=found.summary, data=dict(found.data))
    from ..optimization import COLLOCATION_METHODS
    options = {
        "nodes": StudyOption(int, problem.nodes, "collocation nodes"),
        "method": StudyOption(str, problem.method, "collocation", COLLOCATION_METHODS),
        "duration": StudyOption(float, problem.duration, "duration [s]"),
        "degree": StudyOption(int, None, "LGR's points per interval (method lgr; "
                                         "default 3)"),
        "backend": StudyOption(str, "c", "numerical backend", ("c", "numpy", "auto")),
        **{k: StudyOption(kind, None, f"option of the model {problem.model} (default: "
                                      "the model's)")
           for k, kind in model_options.items()},
        **problem.options}
    return run, options


# ------------------------------------------------------ the pendulum swing-up
@dataclass(frozen=True)
class SwingUp:
    """The pendulum's swing-up of least :math:`\\int\\tau^2 dt` and its check.

    Attributes
    ----------
    result : OptimalControlResult
    resimulation : Resimulation
        The optimal torque simulated (DOP853, 1e-10) from the collocated
        initial state.
    swing_time : float
        When (s) the collocated angle first comes within 0.1 rad of upright.
    swing_difference : float
        The largest difference (rad) of the simulated angle from the
        collocated one until then.  Upright the pendulum is unstable, and an
        open-loop torque replays the optimum there only until the
        collocation's error grows.
    data : mapping
        Named numbers: ``objective`` (the integral of tau^2, N^2 m^2 s),
        ``peak_torque`` (N m, the largest at the nodes), ``swing_time`` (s),
        ``swing_difference`` (rad), and of :class:`InputPeaks`:
        ``limit_ratio_points``, ``limit_ratio_replayed`` (the torque's peak
        over its limit at the nodes and as replayed), ``peak_replayed`` (N m)
        and ``peak_replayed_time`` (s).
    input_peaks : InputPeaks
        The torque at the nodes and as replayed against its limit.
    """

    result: object
    resimulation: object
    swing_time: float
    swing_difference: float
    data: types.MappingProxyType
    input_peaks: InputPeaks

    @property
    def summary(self):
        r = self.result
        lines = result_lines(r, ("integral of tau^2", "N^2 m^2 s")) + [
            f"peak torque at the nodes {self.data['peak_torque']:.6g} N m; final angle "
            f"{r['q'][-1]:.8g} rad, rate {r['u'][-1]:.3g} rad/s"
            + ("" if r.success else " (the final conditions, held as bounds by every "
               "iterate: not a sign of success)"),
            self.input_peaks.line("torque", "N m"),
            f"check: the {solution_word(r)} torque simulated (DOP853) "
            + ("follows the collocated angle within" if r.success else
               "differs from the collocated angle by up to")
            + f" {self.swing_difference:.2g} rad until it nears upright (t = "
            f"{self.swing_time:.3g} s), where the pendulum is unstable"]
        return "\n".join(lines)

    def plot(self, path):
        from .._output_files import save_figure
        from ._plotting import pyplot
        plt = pyplot()
        r = self.result
        fig, axes = plt.subplots(3, 1, sharex=True, figsize=(7, 7), constrained_layout=True)
        run = self.resimulation.simulation
        axes[0].plot(r.t, r["q"], label="collocated")
        axes[0].plot(run.t, run["q"], "--", label="simulated (DOP853)")
        axes[0].axhline(np.pi, color="0.6", ls=":", lw=0.8, label="upright (pi)")
        axes[0].axvline(self.swing_time, color="0.6", ls="-.", lw=0.8,
                        label="within 0.1 rad of upright")
        axes[0].set_ylabel("angle q [rad]")
        axes[1].plot(r.t, r["u"])
        axes[1].set_ylabel("rate u [rad/s]")
        fine, torque = replayed_inputs(r)
        axes[2].plot(fine, torque[0], label=f"as replayed ({self.input_peaks.between})")
        limit_lines(axes[2], self.input_peaks.limits[0], "N m")
        axes[2].legend(fontsize=8, loc="upper right")
        axes[2].set_ylabel("torque tau [N m]")
        axes[2].set_xlabel("t [s]")
        axes[0].legend(fontsize=8)
        for ax in axes:
            ax.grid(alpha=0.3)
        word = "" if r.success else f", {solution_word(r)}"
        fig.suptitle(f"pendulum swing-up of least integral of tau^2{word}\n{r.t.size} nodes, "
                     f"{r.method}, objective {r.objective:.5g} N^2 m^2 s", fontsize=10)
        written = save_figure(fig, path, dpi=110)
        plt.close(fig)
        return written


def pendulum_swing_up(*, nodes=None, method=None, duration=None, bounds=None,
                      constants=None, model_options=None, backend="c", ipopt=None,
                      degree=None, limit=2.0):
    r"""Swing the pendulum from hanging to upright, at rest, with the least
    :math:`\int\tau^2 dt` and :math:`|\tau| \le` ``limit`` (opty's gallery
    problem: 10 s, 2 N m).

    The guess turns the pendulum steadily to the top, pushing gently back and
    forth; the optimum is checked by simulating its torque (``resimulate``).

    Returns
    -------
    SwingUp
    """
    if not np.isfinite(limit) or limit <= 0:
        raise KanedynError(f"limit must be a positive number (N m), got {limit!r}")
    spec = optimal_problem("pendulum", "swing-up")
    nodes = nodes or spec.nodes
    method = method or spec.method
    duration = float(duration or spec.duration)
    definition = build_model("pendulum", model_options, spec.required)
    model = numeric_of(definition, constants, backend)
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    names = list(model.state_names) + ["tau"]
    limits = merged_bounds({"tau": (-limit, limit)}, bounds, names)
    from ..optimization import OptimalControlProblem
    problem = OptimalControlProblem(
        model, nodes=nodes, duration=duration, lagrange=tau ** 2, bounds=limits,
        initial={q: 0.0, u: 0.0}, final={q: np.pi, u: 0.0}, method=method, degree=degree)
    guess = problem.guess_line(start={u: np.pi / duration}, end={u: np.pi / duration},
                               inputs={tau: lambda t: np.sin(2 * np.pi * t / duration)})
    result = solve(problem, guess, ipopt)
    check = result.resimulate()
    run = check.simulation
    near = np.flatnonzero(np.abs(result["q"] - np.pi) < 0.1)
    k = int(near[0]) if near.size else result.t.size - 1
    k = min(k, run.t.size - 1)
    difference = float(np.max(np.abs(run["q"][:k + 1] - result["q"][:k + 1])))
    data = dict(objective=result.objective, peak_torque=float(np.max(np.abs(result["tau"]))),
                swing_time=float(result.t[k]), swing_difference=difference)
    peaks = input_peaks(result, limits)
    data.update(peaks.data)
    return SwingUp(result, check, float(result.t[k]), difference,
                   types.MappingProxyType(data), peaks)


register_problem(OptimalProblem(
    model="pendulum", name="swing-up", function=pendulum_swing_up,
    description="from hanging to upright at rest in 10 s, |tau| <= 2 N m, least "
                "integral of tau^2 (opty's gallery problem)",
    nodes=201, method="trapezoid", duration=10.0, required={"torque": True},
    options={"limit": StudyOption(float, 2.0, "torque limit [N m]", positive=True)}))

