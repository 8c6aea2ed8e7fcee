r"""The out-parallel manipulator's platform path of least peak carriage force.

``out-parallel-6dof`` with ``force_input=True`` is driven by its six
carriage forces :math:`F_i` (inputs, N, along the rails; the ball screws'
reflected inertia is in the model, so :math:`F_i` is the force the screw
delivers).  Today's motion is the inverse study's quintic: from the home
pose to the home pose plus 5 cm and 10° in every pose axis, rest to rest in
2 s.  :func:`out_parallel_least_peak_force` asks for the platform path
between the same two poses in the same time whose largest carriage force is
least, with the ball screws' force limit :math:`|F_i| \le F_{max}`, in
epigraph form:

.. math::

    \min_{s,\,F,\,\text{path}}\; s + \epsilon\int_0^T\sum_i F_i^2\,dt
    \quad\text{s.t.}\quad -s \le F_i(t) \le s,\; |F_i(t)| \le F_{max},

the bound :math:`s` an auxiliary variable of the problem, the small
:math:`\epsilon` picking among paths of the same peak the one of least
:math:`\int\sum F_i^2`.  The platform is at rest at both ends and stays
there: the forces at the ends are the static ones (those of the quintic's
ends, where its acceleration is zero), so no path has a lower peak than the
largest static force in the two poses.

Checks, each computed apart from the collocation:

- the inverse dynamics of the optimal path (:func:`inverse_study` on the
  plain model, with the collocated pose splined): its forces against the
  collocated ones, and the limit check on them;
- the same inverse study of the quintic: its peak and the first violation
  of the limit;
- the optimal forces simulated with ``kd.simulate`` (Radau).
"""

from __future__ import annotations

import types
from dataclasses import dataclass

import numpy as np

from .._errors import KanedynError
from ._optimal_problems import (InputPeaks, OptimalProblem, SplineInput, build_model,
                                defect_text, input_peaks, merged_bounds, numeric_of,
                                optimal_problem, register_problem, replayed_inputs,
                                result_lines, solution_word, solve)
from ._studies import StudyOption

__all__ = ["out_parallel_least_peak_force", "PeakForcePath"]

#: the replay's integrator
REPLAY = {"method": "Radau", "rtol": 1e-10, "atol": 1e-10}
#: points of the quintic's inverse study (its peak force, the guess)
QUINTIC_POINTS = 401
_POSE = ("x", "y", "z", "phi_x", "phi_y", "phi_z")
_RATES = ("vx", "vy", "vz", "wx", "wy", "wz")


@dataclass(frozen=True)
class PeakForcePath:
    """The platform path of least peak carriage force, and today's quintic.

    Attributes
    ----------
    result : OptimalControlResult
        Its ``parameters["s"]`` is the bound :math:`s`, N.
    quintic : InverseStudy
        Today's quintic between the same poses over the same time, with the
        force limit checked (``quintic.limit_check``).
    inverse : InverseStudy
        The inverse dynamics of the optimal path at the nodes and midpoints,
        the limit checked likewise.
    simulation : SimulationResult
        The optimal forces simulated (Radau, rtol = atol = 1e-10) at the
        node times.
    force_limit : float
        N.
    data : mapping
        ``peak_optimal`` (the bound s), ``peak_quintic`` (N), ``reduction``
        (1 - their ratio), ``static_bound`` (the largest static force in
        the two poses, N), ``peak_inverse`` (the largest force of the
        inverse dynamics of the optimal path), ``force_difference`` (the
        largest difference between those and the collocated forces, N),
        ``violations_optimal``, ``violations_quintic`` (points and
        actuators over the limit in each inverse study),
        ``first_violation_quintic`` (its time, s; nan when none),
        ``defect`` (the largest difference of the simulated states from
        the collocated ones at the nodes, in the units of the state it is
        of: m, rad, m/s or rad/s; the summary gives the largest of each
        unit), ``objective`` (N: the peak s plus ``regularization`` times
        the integral of the summed squared forces), ``effort`` (that
        integral of the forces as replayed, N^2 s), ``regularization``
        (1/(N s)), ``force_limit`` (N), and of :class:`InputPeaks`:
        ``limit_ratio_points``, ``limit_ratio_replayed`` (the largest force
        over its limit at the nodes and midpoints and as replayed: the
        epigraph's bound s, too, holds at those points only),
        ``peak_replayed`` (N, the largest force as replayed) and
        ``peak_replayed_time`` (s).
    input_peaks : InputPeaks
        The forces at the collocation points and as replayed against their limits.
    defects : dict
        ``{state name: largest |simulated - collocated| at the nodes}``.
    """

    result: object
    quintic: object
    inverse: object
    simulation: object
    force_limit: float
    data: types.MappingProxyType
    input_peaks: InputPeaks
    defects: dict

    @property
    def summary(self):
        d, r = self.data, self.result
        word = solution_word(r)
        first = ("never" if np.isnan(d["first_violation_quintic"])
                 else f"first at t = {d['first_violation_quintic']:.4g} s")
        objective = (f"peak s + {d['regularization']:g} x integral of sum F_i^2", "N")
        units = r.problem.model.state_units
        return "\n".join(result_lines(r, objective) + [
            f"  of it the regularization term (the integral as collocated) "
            f"{r.objective - d['peak_optimal']:.6g} N, the peak s {d['peak_optimal']:.6g} N",
            f"platform rest to rest in {r.duration:g} s, home to home + 5 cm and 10 deg in "
            f"every axis; carriage forces within +-{self.force_limit:g} N",
            f"  peak carriage force [N] (s, at the nodes and midpoints): {word} "
            f"{d['peak_optimal']:.6g}, quintic "
            f"{d['peak_quintic']:.6g} ({100 * d['reduction']:.3g} % less); the largest "
            f"static force in the two poses, which no path goes below: "
            f"{d['static_bound']:.6g}",
            f"  limit {self.force_limit:g} N: the quintic exceeds it at "
            f"{d['violations_quintic']:g} (point, carriage) pairs ({first}); the {word} "
            f"path's inverse dynamics at {d['violations_optimal']:g}",
            self.input_peaks.line("carriage force", "N"),
            f"check: inverse dynamics of the {word} path (kd.studies.inverse_study, "
            f"{self.inverse.ik_method}): peak {d['peak_inverse']:.6g} N, at most "
            f"{d['force_difference']:.3g} N from the collocated forces; the forces simulated "
            "(Radau) differ from the collocated states at the nodes by at most (the largest "
            "of each unit) " + defect_text(self.defects, units)])

    def plot(self, path):
        """Carriage forces (optimal, quintic, the optimal path's inverse
        dynamics), their difference, the platform's translation and
        rotation; returns the path written."""
        from .._output_files import save_figure
        from ._plotting import pyplot
        plt = pyplot()
        r, d, q = self.result, self.data, self.quintic
        word = solution_word(r)
        fig, axes = plt.subplots(4, 1, figsize=(8, 11), sharex=True, constrained_layout=True,
                                 gridspec_kw={"height_ratios": [3, 1.2, 1.5, 1.5]})
        fine, forces = replayed_inputs(r)
        inv = self.inverse
        for i in range(forces.shape[0]):
            color = f"C{i}"
            axes[0].plot(fine, forces[i], color=color, label=f"carriage {i + 1}")
            axes[0].plot(q.t, q.forces[i], ":", color=color)
            axes[0].plot(inv.t, inv.forces[i], ".", ms=3, color=color)
            axes[1].plot(inv.t, inv.forces[i] - r.points()[2][i], ".-", ms=3, lw=0.6,
                         color=color)
        ends = q.forces[:, [0, -1]]  # the static forces, held before and after
        for i, color in enumerate(f"C{i}" for i in range(ends.shape[0])):
            axes[0].plot([r.t[0], r.t[-1]], ends[i], "o", mfc="none", ms=6, color=color)
        axes[0].plot([], [], "ko", mfc="none", label="static, held before and after")
        axes[0].axhline(self.force_limit, color="r", ls="--", lw=1,
                        label=f"limit {self.force_limit:g} N")
        axes[0].axhline(d["peak_optimal"], color="k", lw=0.8,
                        label=f"least peak s = {d['peak_optimal']:.5g} N")
        axes[0].plot([], [], "k-", label=f"{word} (as replayed)")
        axes[0].plot([], [], "k:", label=f"quintic, peak {d['peak_quintic']:.5g} N")
        axes[0].plot([], [], "k.", label=f"inverse dynamics of the {word} path")
        axes[0].set_ylabel("carriage force [N]")
        axes[0].legend(fontsize=7, ncol=3, loc="lower center", bbox_to_anchor=(0.5, 1.0),
                       frameon=False)
        axes[1].set_ylabel("inverse dynamics\n- collocated [N]")
        names = list(r.state_names)
        home = q.pose[0]
        for k, (name, color) in enumerate(zip(_POSE, ("C0", "C1", "C2") * 2)):
            ax, scale = (axes[2], 1e3) if k < 3 else (axes[3], np.degrees(1.0))
            ax.plot(r.t, scale * (r.y[names.index(name)] - home[k]), color=color,
                    label=name)
            ax.plot(q.t, scale * (q.pose[:, k] - home[k]), ":", color=color)
        axes[2].set_ylabel("platform position\nfrom home [mm]")
        axes[3].set_ylabel("platform angles [deg]")
        axes[3].set_xlabel("t [s]")
        for ax in axes[2:]:
            ax.legend(fontsize=8, ncol=3, title=f"solid {word}, dotted quintic",
                      title_fontsize=8)
        for ax in axes:
            ax.grid(alpha=0.3)
        what = "the path" if r.success else f"the {word} path towards that"
        fig.suptitle(f"Out-parallel manipulator, rest to rest in {r.duration:g} s: {what} of "
                     f"least peak carriage force, {100 * d['reduction']:.3g} % below the "
                     f"quintic's\n({r.method}, {r.t.size} nodes; dots: kanedyn's inverse "
                     f"dynamics of the {word} path)", fontsize=10)
        written = save_figure(fig, path, dpi=110)
        plt.close(fig)
        return written


class _CollocatedPath:
    """The collocated platform path as a pose table for :func:`inverse_study`:
    the pose cubic Hermite through the points with the collocated rates as
    slopes, the rates a not-a-knot spline whose derivative is the
    acceleration (none of it from the model's equations)."""

    label = "optimal path"
    source = "the optimal path (collocated)"

    def __init__(self, result):
        from scipy.interpolate import CubicHermiteSpline, CubicSpline
        t, y, _ = result.points()
        names = list(result.state_names)
        pose = y[[names.index(n) for n in _POSE]].T
        rate = y[[names.index(n) for n in _RATES]].T
        self.t = t
        self._pose = CubicHermiteSpline(t, pose, rate)
        self._rate = CubicSpline(t, rate, bc_type="not-a-knot")

    def __call__(self, times):
        times = np.atleast_1d(np.asarray(times, float))
        return self._pose(times), self._rate(times), self._rate(times, 1)


def out_parallel_least_peak_force(*, nodes=None, method=None, duration=None, bounds=None,
                                  constants=None, model_options=None, backend="c",
                                  ipopt=None, force_limit=200.0, regularization=1e-5):
    r"""The out-parallel manipulator's path of least peak carriage force
    between the poses of its quintic, against that quintic.

    Parameters
    ----------
    nodes, method, duration :
        Default 41 nodes, ``"hermite-simpson"``, 2 s (the quintic's).
    bounds, constants, model_options, backend, ipopt :
        As every named problem (:mod:`._optimal_problems`); ``bounds`` by
        name bound the pose (``z``) or replace a carriage's force limit
        (``F_carriage1``; the limit checks keep ``force_limit``).
    force_limit : float
        The ball screws' force limit on every carriage, N (an assumed
        rating: about 1.3 times the largest static force in the two poses).
    regularization : float
        :math:`\epsilon`, 1/(N s): the weight of :math:`\int\sum F_i^2 dt`
        added to the peak.

    Returns
    -------
    PeakForcePath
    """
    import sympy as sm

    from ..optimization import OptimalControlProblem
    from ..simulation import simulate
    from ._inverse_study import inverse_study, trajectory_offsets
    if not np.isfinite(force_limit) or force_limit <= 0:
        raise KanedynError(f"force_limit must be a positive number (N), got {force_limit!r}")
    if not np.isfinite(regularization) or regularization < 0:
        raise KanedynError(f"regularization must be a number >= 0, got {regularization!r}")
    spec = optimal_problem("out-parallel-6dof", "least-peak-force")
    nodes = nodes or spec.nodes
    method = method or spec.method
    T = float(duration or spec.duration)
    definition = build_model("out-parallel-6dof", model_options, spec.required)
    model = numeric_of(definition, constants, backend)
    plain = build_model("out-parallel-6dof", model_options, {"force_input": False})
    forces = definition.symbols["forces"]
    names = [str(F.func) for F in forces]
    limit = {"force": float(force_limit)}

    # today's quintic, by the inverse study of the plain model
    plain_model = numeric_of(plain, constants, model.backend)
    quintic = inverse_study(plain, t_end=T, points=QUINTIC_POINTS, constants=constants,
                            model=plain_model, limits=limit)
    home = quintic.pose[0]
    end = home + trajectory_offsets(plain)
    static = quintic.forces[:, [0, -1]]  # at rest: its ends have no acceleration
    held = float(np.max(np.abs(static)))
    s = sm.Symbol("s")
    limits = merged_bounds({n: (-force_limit, force_limit) for n in names}, bounds,
                           list(model.state_names) + names)
    limits[s] = (held, None)  # held still before and after: those forces count too
    rest = {n: 0.0 for n in _RATES}
    problem = OptimalControlProblem(
        model, nodes=nodes, duration=T, mayer=s, auxiliary={s: float(quintic.forces.max())},
        lagrange=regularization * sum(F ** 2 for F in forces) if regularization else None,
        bounds=limits, method=method,
        initial={**dict(zip(_POSE, home)), **rest}, final={**dict(zip(_POSE, end)), **rest},
        path_constraints=[(F - s, None, 0.0) for F in forces]
        + [(F + s, 0.0, None) for F in forces])
    # the guess: the quintic's forces simulated (its path, the dependent states
    # on their constraints)
    from scipy.interpolate import CubicSpline
    pushes = {F: SplineInput(CubicSpline(quintic.t, row)) for F, row in zip(forces,
                                                                             quintic.forces)}
    y0 = np.concatenate([quintic.q[0], quintic.u[0]])
    run = simulate(model.with_inputs(pushes), (0.0, T), y0, dense_output=True, **REPLAY)
    result = solve(problem, problem.guess_from(run, inputs=pushes), ipopt)

    # the checks
    check = result.resimulate(**REPLAY)
    points = 2 * nodes - 1 if result.t_mid is not None else nodes
    inverse = inverse_study(plain, poses=_CollocatedPath(result), points=points,
                            constants=constants, model=plain_model, limits=limit)
    collocated = result.points()[2]
    peak = float(result.parameters["s"])
    fine = np.linspace(0.0, result.duration, 20001)
    effort = float(np.trapezoid(sum(np.array([f(x) for x in fine]) ** 2
                                    for f in result.inputs().values()), fine))
    first = quintic.limit_check.first
    data = dict(
        objective=result.objective, peak_optimal=peak,
        peak_quintic=float(np.max(np.abs(quintic.forces))),
        static_bound=held,
        peak_inverse=float(np.max(np.abs(inverse.forces))),
        force_difference=float(np.max(np.abs(inverse.forces - collocated))),
        violations_optimal=float(inverse.limit_check.violations["force"]),
        violations_quintic=float(quintic.limit_check.violations["force"]),
        first_violation_quintic=np.nan if first is None else float(first.time),
        defect=check.max_defect, effort=effort, regularization=float(regularization),
        force_limit=float(force_limit))
    data["reduction"] = 1.0 - peak / data["peak_quintic"]
    peaks = input_peaks(result, limits)
    data.update(peaks.data)
    return PeakForcePath(result=result, quintic=quintic, inverse=inverse,
                         simulation=check.simulation, force_limit=float(force_limit),
                         data=types.MappingProxyType(data), input_peaks=peaks,
                         defects=dict(check.defect))


register_problem(OptimalProblem(
    model="out-parallel-6dof", name="least-peak-force", function=out_parallel_least_peak_force,
    description="the platform path of least peak carriage force (epigraph) between the "
                "quintic's poses in 2 s, forces within 200 N; against the quintic, checked "
                "by inverse dynamics and simulation",
    nodes=41, method="hermite-simpson", duration=2.0, required={"force_input": True},
    options={"force_limit": StudyOption(float, 200.0, "ball-screw force limit on every "
                                                      "carriage [N]", positive=True),
             "regularization": StudyOption(float, 1e-5, "weight of the integral of the "
                                                        "summed squared forces [1/(N s)]")}))
