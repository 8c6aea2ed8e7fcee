r"""The elastic robot's rest-to-rest rotation by optimal control, against its torque pulse.

The built-in ``flexible-robot`` turns its hub by :math:`\theta_f` with the
pulse :math:`\tau_0\sin(2\pi t/T_m)`, which would stop a rigid robot at rest
and leaves the elastic link vibrating.  :func:`flexible_robot_rest_to_rest`
asks instead for the torque that ends the manoeuvre with the hub at
:math:`\theta_f` and the link at rest and undeformed (every elastic
coordinate and rate zero): of least :math:`\int\tau^2 dt` in the same time
(``objective="effort"``), or in the least time with the pulse's peak torque
as the limit (``objective="time"``, with :math:`10^{-3}\int\tau^2 dt` added
so that the torque is unique where it is not at its limits).

Both torques are then simulated with ``kd.simulate`` (Radau) and the link
left free for ``after`` seconds: the largest tip deflection after the
manoeuvre is its residual vibration.  The rigid robot (inertia :math:`J_0`
about the hub, taken from the pulse's amplitude :math:`\tau_0 = 2\pi\theta_f
J_0/T_m^2`) gives what the flexible optimum approaches from above: the
least effort :math:`12 J_0^2\theta_f^2/T^3`, the least time :math:`2\sqrt{
\theta_f J_0/\tau_{max}}`.
"""

from __future__ import annotations

import types
from dataclasses import dataclass
from functools import partial

import numpy as np

from .._errors import KanedynError
from ._optimal_problems import (InputPeaks, OptimalProblem, build_model, input_peaks,
                                limit_lines, merged_bounds, numeric_of, register_problem,
                                result_lines, solution_word, solve)
from ._studies import StudyOption

__all__ = ["flexible_robot_rest_to_rest", "RestToRest"]

#: samples per second of the simulated runs (the tip's vibration is resolved
#: to 200 Hz with ten samples per period)
SAMPLES = 2000


@dataclass(frozen=True)
class RestToRest:
    """The optimal rest-to-rest rotation of the elastic robot and today's pulse.

    Attributes
    ----------
    result : OptimalControlResult
    objective_kind : str
        ``"effort"`` or ``"time"``.
    angle : float
        The rotation, rad.
    t_optimal, t_pulse : ndarray
        Times of the two simulated runs (Radau, rtol = atol = 1e-10), s: the
        manoeuvre, then ``after`` s with no torque.
    duration_optimal, duration_pulse : float
        How long each manoeuvre takes, s.
    hub_optimal, hub_pulse, tip_optimal, tip_pulse, torque_optimal, torque_pulse : ndarray
        Hub angle (rad), tip deflection across the link (m) and motor torque
        (N m) along the runs.
    data : mapping
        ``residual_optimal``, ``residual_pulse`` (the peak of the tip
        deflection's magnitude after the manoeuvre, m), ``effort_optimal``,
        ``effort_pulse`` (integral of the torque squared, N^2 m^2 s),
        ``peak_optimal`` (N m, the largest torque as replayed, the same as
        ``peak_replayed``),
        ``peak_pulse`` (N m), ``duration_optimal``, ``duration_pulse`` (s),
        ``final_angle`` (the simulated hub angle at the end of the optimal
        run, rad), ``rigid_effort`` and ``rigid_time`` (the rigid robot's
        least effort in the optimal's duration and least time with its peak
        torque), ``inertia`` (J_0, kg m^2), ``objective`` (N^2 m^2 s for
        ``"effort"``; s for ``"time"``: the duration plus ``regularization``
        times the integral of the torque squared), ``regularization`` (that
        weight, 1/(N^2 m^2); 0 for ``"effort"``), and of
        :class:`InputPeaks`: ``limit_ratio_points``, ``limit_ratio_replayed``
        (the torque's peak over its limit at the nodes and midpoints and as
        replayed; nan without a limit), ``peak_replayed`` (N m) and
        ``peak_replayed_time`` (s).
    input_peaks : InputPeaks
        The torque at the collocation points and as replayed against its limit.
    """

    result: object
    objective_kind: str
    angle: float
    t_optimal: np.ndarray
    t_pulse: np.ndarray
    duration_optimal: float
    duration_pulse: float
    hub_optimal: np.ndarray
    hub_pulse: np.ndarray
    tip_optimal: np.ndarray
    tip_pulse: np.ndarray
    torque_optimal: np.ndarray
    torque_pulse: np.ndarray
    data: types.MappingProxyType
    input_peaks: InputPeaks

    @property
    def summary(self):
        d = self.data
        what = ("least integral of torque^2" if self.objective_kind == "effort"
                else "least time")
        objective = (("integral of tau^2", "N^2 m^2 s") if self.objective_kind == "effort"
                     else (f"duration + {d['regularization']:g} x integral of tau^2", "s"))
        word = solution_word(self.result)
        w = max(14, len(word) + 2)  # the result's column
        return "\n".join(result_lines(self.result, objective) + [
            f"{np.degrees(self.angle):.6g} deg rest to rest, {what}; simulated (Radau) and "
            "left free:",
            f"  {'':28s}{word:>{w}s}{'sine pulse':>14s}",
            f"  {'duration [s]':28s}{d['duration_optimal']:{w}.4f}{d['duration_pulse']:14.4f}",
            f"  {'integral tau^2 [N^2m^2s]':28s}{d['effort_optimal']:{w}.5g}"
            f"{d['effort_pulse']:14.5g}",
            f"  {'peak torque, replayed [N m]':28s}{d['peak_optimal']:{w}.5g}"
            f"{d['peak_pulse']:14.5g}",
            f"  {'residual tip, peak [mm]':28s}{1e3 * d['residual_optimal']:{w}.4g}"
            f"{1e3 * d['residual_pulse']:14.4g}",
            "  (residual tip: the largest tip deflection after the manoeuvre, the link free)",
            self.input_peaks.line("torque", "N m"),
            f"residual vibration {d['residual_pulse'] / d['residual_optimal']:.3g}x smaller; "
            f"simulated final hub angle {np.degrees(d['final_angle']):.5f} deg; the rigid "
            f"robot's least {'effort' if self.objective_kind == 'effort' else 'time'} "
            + (f"{d['rigid_effort']:.5g} N^2 m^2 s" if self.objective_kind == "effort"
               else f"{d['rigid_time']:.5g} s")])

    def plot(self, path):
        """Hub angle, tip deflection, torque, and the residual vibration on a
        log scale; optimal against the pulse.  Returns the path written."""
        from .._output_files import save_figure
        from ._plotting import pyplot
        plt = pyplot()
        d = self.data
        word = solution_word(self.result)
        fig, axes = plt.subplots(4, 1, figsize=(8, 10), sharex=True, constrained_layout=True)
        label_o = (f"{word}: least integral of torque^2" if self.objective_kind == "effort"
                   else f"{word}: least time") + f" ({self.result.method}, " \
            f"{self.result.t.size} nodes)"
        label_p = f"sine pulse (today's model), {d['duration_pulse']:g} s"
        curves = ((self.t_optimal, self.hub_optimal, self.tip_optimal, self.torque_optimal,
                   "C0", "-", label_o),
                  (self.t_pulse, self.hub_pulse, self.tip_pulse, self.torque_pulse, "C3", "--",
                   label_p))
        for t, hub, tip, torque, color, style, label in curves:
            axes[0].plot(t, np.degrees(hub), style, color=color, label=label)
            axes[1].plot(t, 1e3 * tip, style, color=color, lw=0.9)
            axes[2].plot(t, torque, style, color=color)
        for t, tip, end, color, style, which in (
                (self.t_optimal, self.tip_optimal, d["duration_optimal"], "C0", "-", "optimal"),
                (self.t_pulse, self.tip_pulse, d["duration_pulse"], "C3", "--", "pulse")):
            late = t >= end
            residual = d[f"residual_{which}"]
            name = word if which == "optimal" else which
            axes[3].semilogy(t[late], np.maximum(1e3 * np.abs(tip[late]), 1e-9), style,
                             color=color, lw=0.6,
                             label=f"{name}: residual peak {1e3 * residual:.3g} mm")
            for ax in axes:
                ax.axvline(end, color=color, ls=":", lw=0.8)
        axes[0].set_ylabel("hub angle [deg]")
        axes[1].set_ylabel("tip deflection [mm]")
        axes[2].set_ylabel("motor torque [N m]")
        if np.isfinite(self.input_peaks.limits[0]):
            limit_lines(axes[2], self.input_peaks.limits[0], "N m")
            axes[2].legend(fontsize=8, loc="upper right")
        axes[3].set_ylabel("|tip deflection| after\nthe manoeuvre [mm]")
        low = max(1e-3 * min(d["residual_optimal"], d["residual_pulse"]) * 1e3, 1e-6)
        axes[3].set_ylim(low, 3e3 * max(d["residual_optimal"], d["residual_pulse"]))
        axes[3].set_xlabel("t [s] (dotted: end of each manoeuvre)")
        axes[0].legend(fontsize=8, loc="lower right")
        axes[3].legend(fontsize=8, loc="upper right", ncol=2)
        for ax in axes:
            ax.grid(alpha=0.3)
        fig.suptitle(f"Elastic robot, {np.degrees(self.angle):.4g} deg rest to rest: the "
                     f"{word} torque leaves {d['residual_pulse'] / d['residual_optimal']:.3g}x "
                     "less vibration than the pulse\n(both simulated with Radau, then left "
                     "free)", fontsize=10)
        written = save_figure(fig, path, dpi=110)
        plt.close(fig)
        return written


def _tip_row(definition):
    link = definition.symbols["link"]
    Phi, _ = link.member.node_modes(link.member.n_nodes - 1)
    return Phi[1], [q.func.__name__ for q in link.q]


def _run(model, t_end, y0):
    from ..simulation import simulate
    t_eval = np.linspace(0.0, t_end, int(round(SAMPLES * t_end)) + 1)
    run = simulate(model, (0.0, t_end), y0, method="Radau", rtol=1e-10, atol=1e-10,
                   t_eval=t_eval)
    if not run.success:
        raise KanedynError(f"the check's simulation failed: {run.message}")
    return run


def _pulse_amplitude(definition):
    """``tau_0`` of the pulse ``tau_0 sin(2 pi min(t/T_m, 1))`` as built."""
    pulse = definition.symbols["pulse"]
    t = next(iter(pulse.free_symbols - set(definition.constants)), None)
    T_m = definition.symbols["T_m"]
    return pulse.subs(t, T_m / 4)  # sin(pi/2) = 1


def flexible_robot_rest_to_rest(*, nodes=None, method=None, duration=None, bounds=None,
                                constants=None, model_options=None, backend="c", ipopt=None,
                                degree=None, objective="effort", angle=90.0, after=2.0,
                                torque_limit=0.0, pulse_duration=1.0, regularization=1e-3):
    r"""The elastic robot's rest-to-rest rotation of least effort or least
    time, and the torque pulse it uses today, both simulated and compared.

    Parameters
    ----------
    nodes, method : int, str
        Collocation (default 201 nodes, ``"hermite-simpson"``).
    duration : float
        ``objective="effort"``: the manoeuvre's duration, s (default 1); the
        pulse compared takes as long.  ``"time"``: the guess of the duration.
    bounds, constants, model_options, backend, ipopt, degree :
        As every named problem (:mod:`._optimal_problems`); ``model_options``
        of ``flexible-robot`` (``n_modes``, ``n_elements``, ``stiffening``).
    objective : {"effort", "time"}
    angle : float
        The rotation, degrees.
    after : float
        How long the link is left free after each manoeuvre, s.
    torque_limit : float
        ``objective="time"``: the limit, N m; 0 means the pulse's peak.
    pulse_duration : float
        ``objective="time"``: the duration of the pulse compared, s.
    regularization : float
        ``objective="time"``: the weight of :math:`\int\tau^2 dt` added to
        the duration.

    Returns
    -------
    RestToRest
    """
    import sympy as sm

    from ..optimization import OptimalControlProblem
    if objective not in ("effort", "time"):
        raise KanedynError(f"objective must be 'effort' or 'time', got {objective!r}")
    for name, value in (("angle", angle), ("after", after), ("pulse_duration", pulse_duration)):
        if not np.isfinite(value) or value <= 0:
            raise KanedynError(f"{name} must be a positive number, got {value!r}")
    if not np.isfinite(torque_limit) or torque_limit < 0:
        raise KanedynError(f"torque_limit must be a number >= 0 (0: the pulse's peak), got "
                           f"{torque_limit!r}")
    spec = _spec(objective)
    nodes = nodes or spec.nodes
    method = method or spec.method
    theta_f = np.radians(angle)
    definition = build_model("flexible-robot", model_options, spec.required)
    model = numeric_of(definition, constants, backend)
    options = {k: v for k, v in (model_options or {}).items() if k != "torque_input"}
    T_pulse = float(duration or spec.duration) if objective == "effort" else pulse_duration
    pulsed = build_model("flexible-robot", options, {})
    pulse_constants = dict(constants or {}, T_m=T_pulse, theta_f=theta_f)
    pulse_model = numeric_of(pulsed, pulse_constants, backend)
    values = {str(k): v for k, v in pulsed.constants.items()}
    values.update(pulse_constants)
    tau_0 = float(_pulse_amplitude(pulsed).xreplace(
        {s: values[str(s)] for s in pulsed.constants}))
    inertia = tau_0 * T_pulse ** 2 / (2 * np.pi * theta_f)

    tau = definition.symbols["tau"]
    names = list(model.state_names) + ["tau"]
    initial = {n: 0.0 for n in model.state_names}
    final = dict(initial, theta=theta_f)
    if objective == "effort":
        T = T_pulse
        limits = merged_bounds({}, bounds, names)
        problem = OptimalControlProblem(model, nodes=nodes, duration=T, lagrange=tau ** 2,
                                        bounds=limits, initial=initial, final=final,
                                        method=method, degree=degree)
        guess = problem.guess_line(inputs={tau: 0.0})
    else:
        limit = torque_limit or tau_0
        T = sm.Symbol("T_f", positive=True)
        limits = merged_bounds({"tau": (-limit, limit)}, bounds, names)
        limits[T] = (0.05 * T_pulse, 5.0 * T_pulse)
        problem = OptimalControlProblem(model, nodes=nodes, duration=T, mayer=T,
                                        lagrange=regularization * tau ** 2, bounds=limits,
                                        initial=initial, final=final, method=method,
                                        degree=degree)
        guess = problem.guess_line(inputs={tau: 0.0}, duration=float(duration or T_pulse))
    result = solve(problem, guess, ipopt)

    # the independent check: both torques simulated by Radau, then left free
    row, etas = _tip_row(definition)
    T_opt = result.duration
    driven = result.model()
    first = _run(driven, T_opt, result.y[:, 0])
    rest = _run(model.with_inputs({tau: 0.0}), after, first.y[:, -1])
    t_o = np.concatenate([first.t, T_opt + rest.t[1:]])
    y_o = np.concatenate([first.y, rest.y[:, 1:]], axis=1)
    index = {n: k for k, n in enumerate(model.state_names)}
    tip_o = row @ y_o[[index[n] for n in etas]]
    fn = result.inputs()["tau"]
    torque_o = np.array([fn(t) if t <= T_opt else 0.0 for t in t_o])
    pulse_run = _run(pulse_model, T_pulse + after, np.zeros(pulse_model.n_states))
    tip_p = row @ np.array([pulse_run[n] for n in etas])
    torque_p = tau_0 * np.sin(2 * np.pi * np.minimum(pulse_run.t / T_pulse, 1.0))
    fine = np.linspace(0.0, T_opt, 20001)
    data = dict(
        objective=result.objective,
        residual_optimal=float(np.max(np.abs(tip_o[t_o > T_opt]))),
        residual_pulse=float(np.max(np.abs(tip_p[pulse_run.t > T_pulse]))),
        effort_optimal=float(np.trapezoid([fn(t) ** 2 for t in fine], fine)),
        effort_pulse=tau_0 ** 2 * T_pulse / 2,
        peak_pulse=tau_0,
        duration_optimal=T_opt, duration_pulse=T_pulse,
        final_angle=float(y_o[index["theta"], -1]), inertia=inertia,
        rigid_effort=12 * inertia ** 2 * theta_f ** 2 / T_opt ** 3,
        rigid_time=2 * np.sqrt(theta_f * inertia / (torque_limit or tau_0)),
        regularization=float(regularization) if objective == "time" else 0.0)
    peaks = input_peaks(result, limits)
    data.update(peaks.data)
    data["peak_optimal"] = float(np.max(peaks.peak_replayed))
    return RestToRest(
        result=result, objective_kind=objective, angle=theta_f, t_optimal=t_o,
        t_pulse=pulse_run.t, duration_optimal=T_opt, duration_pulse=T_pulse,
        hub_optimal=y_o[index["theta"]], hub_pulse=pulse_run["theta"], tip_optimal=tip_o,
        tip_pulse=tip_p, torque_optimal=torque_o, torque_pulse=torque_p,
        data=types.MappingProxyType(data), input_peaks=peaks)


def _spec(objective):
    from ._optimal_problems import optimal_problem
    return optimal_problem("flexible-robot",
                           "rest-to-rest" if objective == "effort" else "minimum-time")


_COMMON = {
    "angle": StudyOption(float, 90.0, "rotation [deg]", positive=True),
    "after": StudyOption(float, 2.0, "time the link is left free after the manoeuvre [s]",
                         positive=True),
}
register_problem(OptimalProblem(
    model="flexible-robot", name="rest-to-rest",
    function=partial(flexible_robot_rest_to_rest, objective="effort"),
    description="least integral of torque^2 turning the hub 90 deg in 1 s, the link at "
                "rest and undeformed at the end; against the sine pulse, both simulated",
    nodes=201, method="hermite-simpson", duration=1.0, options=dict(_COMMON),
    required={"torque_input": True}))
register_problem(OptimalProblem(
    model="flexible-robot", name="minimum-time",
    function=partial(flexible_robot_rest_to_rest, objective="time"),
    description="least time turning the hub 90 deg with the 1-s pulse's peak torque as "
                "the limit, the link at rest at the end; against the pulse",
    nodes=201, method="hermite-simpson", duration=1.0, required={"torque_input": True},
    options=dict(
        _COMMON,
        torque_limit=StudyOption(float, 0.0, "torque limit [N m] (0: the pulse's peak)"),
        pulse_duration=StudyOption(float, 1.0, "duration of the pulse compared [s]",
                                   positive=True),
        regularization=StudyOption(float, 1e-3, "weight of the integral of torque^2 "
                                                "added to the time [1/(N^2 m^2)]"))))
