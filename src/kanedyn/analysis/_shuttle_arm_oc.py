r"""The Shuttle arm's payload manoeuvre of least effort, against its quintic profile.

The built-in ``shuttle-arm`` (rigid booms, the Hubble-class payload) moves
its six joints from :data:`~kanedyn.models.SRMS_START_DEG` to
``SRMS_END_DEG`` along quintic profiles in 150 s.  With ``torque_input=True``
the joint torques are inputs, and :func:`shuttle_arm_minimum_energy` asks
for the torques of least :math:`\int\sum_i\tau_i^2 dt` (the effort, the
usual "energy" of a control: with the torque proportional to the motor
current, proportional to the motors' copper losses) between the same two
poses, at rest at both, in the same time, with

- joint-torque limits: each joint's torque at most the largest its quintic
  needs (``torque_factor`` times it), taken from the inverse dynamics of the
  quintic, so that the quintic itself is a feasible point and the two
  efforts compare;
- joint-angle limits: each joint within the range its quintic sweeps,
  widened by ``margin`` degrees on both sides (10 by default).  Without them
  the least-effort motion folds the elbow and turns the wrist joints by
  hundreds of degrees, swinging the 11 t payload through the orbiter's
  space and the wrist yaw through 90 degrees, where the wrist pitch and roll
  axes line up; IPOPT then finds no optimum at fine meshes, and the torques
  replayed open loop leave the collocated path (``docs/optimal_control.md``).

The optimum is checked by simulating its torques with ``kd.simulate``
(Radau) open loop, and with the model's own PD servos added as a tracking
term on top of the optimal torques (the feedforward):

.. math::

    \tau_i = \tau_i^*(t) + J_i\omega_c^2\,(q_i^*(t) - q_i)
             + 2\zeta_c J_i\omega_c\,(u_i^*(t) - u_i),

with :math:`q^*, u^*` the collocated trajectory, cubic Hermite between the
nodes (node values and rates: Hermite-Simpson's own polynomial).  In
microgravity nothing pulls the arm back to a path, so an open-loop replay
drifts with any error (the collocation's); the tracking term removes the
drift, and its size says how far the feedforward alone is from right.

``booms="flexible"`` asks for the same manoeuvre for the arm with flexible
booms (:mod:`._shuttle_arm_flexible_oc`).
"""

from __future__ import annotations

import types
from dataclasses import dataclass

import numpy as np

from .._errors import KanedynError
from ._optimal_problems import (InputPeaks, OptimalProblem, SplineInput, build_model,
                                input_peaks, merged_bounds, numeric_of, optimal_problem,
                                register_problem, replayed_inputs, result_lines,
                                solution_word, solve)
from ._studies import StudyOption

__all__ = ["shuttle_arm_minimum_energy", "ArmManoeuvre"]

#: the replays' integrator
REPLAY = {"method": "Radau", "rtol": 1e-10, "atol": 1e-10}
#: the joints, in the model's order
JOINTS = ("shoulder yaw", "shoulder pitch", "elbow pitch", "wrist pitch", "wrist yaw",
          "wrist roll")
#: points of the quintic's inverse dynamics (its torques, effort and the guess)
QUINTIC_POINTS = 1501
#: the study's choices of booms
BOOMS = ("rigid", "flexible")


@dataclass(frozen=True)
class ArmManoeuvre:
    """The Shuttle arm's manoeuvre of least effort, its quintic, and two replays.

    Attributes
    ----------
    result : OptimalControlResult
    t_quintic : ndarray, shape (K,)
        Times of the quintic's inverse dynamics, s.
    angles_quintic, torques_quintic : ndarray, shape (6, K)
        Its joint angles (rad) and torques (N m).
    open_loop, tracked : SimulationResult
        The optimal torques simulated (Radau, rtol = atol = 1e-10) alone and
        with the PD tracking term on top, at the node times.
    tracking_torque : ndarray, shape (6, N)
        The PD term along the tracked run, N m.
    angle_limits : ndarray, shape (6, 2)
        Each joint's bounds, rad (infinite without).
    torque_limits : ndarray, shape (6,)
        Each joint's torque limit (the larger side of its bounds), N m.
    tip_difference_open, tip_difference_tracked : ndarray, shape (N,)
        How far the end effector of each replay is from the collocated path's
        at the nodes, m (infinite after a run that ended early).
    data : mapping
        ``objective``; ``effort_optimal`` and ``effort_quintic`` (the
        integral of the summed squared torques, N^2 m^2 s, of the optimal
        torques as collocated and of the quintic's), ``effort_ratio``;
        ``torque_ratio`` (the largest peak torque over its limit at the
        collocation points, the same as ``limit_ratio_points``);
        ``limit_ratio_points``, ``limit_ratio_replayed`` (that ratio at the
        collocation points and as replayed: Hermite-Simpson's quadratic
        between the nodes overshoots the nodes' and midpoints' values),
        ``peak_replayed`` (N m, the worst joint's replayed peak) and
        ``peak_replayed_time`` (s, when; :class:`InputPeaks`);
        ``angle_excess`` (how far, deg, the optimum goes beyond a joint's
        start-to-end range); ``margin`` (deg);
        ``defect_angle_open``, ``defect_angle_tracked`` (the largest
        joint-angle difference from the collocation at the nodes, rad),
        ``defect_tip_open``, ``defect_tip_tracked`` (the end effector's, m),
        ``tracking_peak`` (the largest PD term, N m) and ``tracking_ratio``
        (over its joint's limit).
    input_peaks : InputPeaks
        The torques at the collocation points and as replayed against their limits.
    """

    result: object
    t_quintic: np.ndarray
    angles_quintic: np.ndarray
    torques_quintic: np.ndarray
    open_loop: object
    tracked: object
    tracking_torque: np.ndarray
    angle_limits: np.ndarray
    torque_limits: np.ndarray
    tip_difference_open: np.ndarray
    tip_difference_tracked: np.ndarray
    data: types.MappingProxyType
    input_peaks: InputPeaks

    @property
    def summary(self):
        d, r = self.data, self.result
        word = solution_word(r)
        margin = ("none" if not np.isfinite(d["margin"])
                  else f"each joint within its start-to-end range +- {d['margin']:g} deg")
        peaks = self.input_peaks
        return "\n".join(result_lines(r, ("integral of sum tau_i^2", "N^2 m^2 s")) + [
            f"{r.duration:g} s between the two poses at rest; joint-angle limits: {margin}; "
            "torque limits [N m]: " + ", ".join(f"{v:.4g}" for v in self.torque_limits),
            f"  effort, integral of sum tau_i^2 [N^2 m^2 s]: {word} {d['effort_optimal']:.6g}, "
            f"quintic {d['effort_quintic']:.6g} (ratio {d['effort_ratio']:.4f})",
            f"  peak torques [N m], {word}: at {peaks.points} "
            + ", ".join(f"{v:.4g}" for v in peaks.peak_points) + "; as replayed "
            + ", ".join(f"{v:.4g}" for v in peaks.peak_replayed),
            peaks.line("joint torque", "N m"),
            f"  beyond a joint's start-to-end range by at most {d['angle_excess']:.3g} deg",
            f"check: the {word} torques simulated (Radau) from the start, largest difference "
            "from the collocated path at the nodes:",
            f"  open loop:                  joint angles {d['defect_angle_open']:.3g} rad, "
            f"end effector {1e3 * d['defect_tip_open']:.3g} mm",
            f"  with the servos' PD term:   joint angles {d['defect_angle_tracked']:.3g} rad, "
            f"end effector {1e3 * d['defect_tip_tracked']:.3g} mm; the PD term at most "
            f"{d['tracking_peak']:.3g} N m ({100 * d['tracking_ratio']:.3g} % of its joint's "
            "limit)"])

    def plot(self, path):
        """Joint angles, torques over their limits, the effort as it accrues,
        and the replays' end-effector difference; returns the path written."""
        from .._output_files import save_figure
        from ._plotting import pyplot
        plt = pyplot()
        r, d = self.result, self.data
        word = solution_word(r)
        fig, axes = plt.subplots(4, 1, figsize=(8, 11), sharex=True, constrained_layout=True)
        tq = self.t_quintic
        fine, torque = replayed_inputs(r)
        for i in range(6):
            color = f"C{i}"
            axes[0].plot(r.t, np.degrees(r.y[i]), color=color, label=f"q{i + 1} {JOINTS[i]}")
            axes[0].plot(tq, np.degrees(self.angles_quintic[i]), ":", color=color)
            axes[1].plot(fine, torque[i] / self.torque_limits[i], color=color)
            axes[1].plot(tq, self.torques_quintic[i] / self.torque_limits[i], ":",
                         color=color)
        axes[0].plot([], [], "k:", label="quintic")
        axes[0].set_ylabel("joint angle [deg]")
        axes[0].legend(ncol=4, fontsize=8, loc="lower center", bbox_to_anchor=(0.5, 1.0),
                       frameon=False)
        for side in (-1, 1):
            axes[1].axhline(side, color="0.4", lw=0.8, ls="--")
        axes[1].set_ylabel(f"joint torque / its limit\n(solid {word},\ndotted quintic)")
        for t, tau, style, label in (
                (fine, torque, "-", f"{word}: {d['effort_optimal']:.4g}"),
                (tq, self.torques_quintic, ":", f"quintic: {d['effort_quintic']:.4g}")):
            rate = np.sum(tau ** 2, axis=0)
            accrued = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1])
                                                       * np.diff(t))])
            axes[2].plot(t, accrued / 1e6, style, color="k", label=label + " N^2 m^2 s")
        axes[2].set_ylabel("effort so far, integral of\nsum tau_i^2 [10^6 N^2 m^2 s]")
        axes[2].legend(fontsize=8)
        floor = 1e-9
        for diff, style, label in (
                (self.tip_difference_open, "-", f"{word} torques open loop"),
                (self.tip_difference_tracked, "--", "with the servos' PD term on top")):
            axes[3].semilogy(r.t[1:], np.maximum(1e3 * diff[1:], floor), style, label=label)
        axes[3].set_ylabel("end effector off the\ncollocated path [mm]\n(Radau replays)")
        axes[3].set_xlabel("t [s]")
        axes[3].legend(fontsize=8)
        for ax in axes:
            ax.grid(alpha=0.3)
        margin = ("no joint-angle limits" if not np.isfinite(d["margin"])
                  else f"joints: the quintic's range +- {d['margin']:g} deg")
        what = "least effort" if r.success else f"towards least effort, {word}"
        fig.suptitle(f"Shuttle arm, Hubble-class payload, {r.duration:g} s: {what}, "
                     f"{100 * (1 - d['effort_ratio']):.3g} % below the quintic's\n({margin}; "
                     f"torques: the quintic's peaks; {r.method}, {r.t.size} nodes)",
                     fontsize=10)
        written = save_figure(fig, path, dpi=110)
        plt.close(fig)
        return written


def _tip_function(definition):
    """``f(Q) -> (3, K)``: the end effector's position (m) at joint angles Q (6, K)."""
    import sympy as sm
    q = definition.symbols["q"]
    dummies = sm.symbols("q_1:7")
    expr = definition.symbols["tip_position"].xreplace(dict(zip(q, dummies)))
    expr = expr.xreplace(definition.constants)
    fn = sm.lambdify(dummies, expr, "numpy")
    return lambda Q: np.array([np.broadcast_to(np.asarray(row, float).ravel(), Q.shape[1:])
                               for row in fn(*Q)])


def _quintic(model, start, end, duration):
    """Times, angles, rates and torques (inverse dynamics) of the quintic."""
    from ..models import quintic_pose
    t = np.linspace(0.0, duration, QUINTIC_POINTS)
    q, u, ud = quintic_pose(t, start, end, duration)
    return t, q.T, u.T, model.inverse_dynamics(t, q.T, u.T, ud.T)


def _pair(bounds):
    """``(lower, upper)`` with a missing side infinite."""
    lower, upper = bounds
    return (-np.inf if lower is None else float(lower), np.inf if upper is None else float(upper))


class _Tracking:
    """The servos' PD term on the collocated path, a function of (t, y)."""

    def __init__(self, result, servo):
        from scipy.interpolate import CubicHermiteSpline
        model = result.model()
        rates = np.array([model.rhs(t, y) for t, y in zip(result.t, result.y.T)])
        self.path = CubicHermiteSpline(result.t, result.y.T, rates)
        J, w, z = np.asarray(servo["J"]), servo["omega_c"], servo["zeta_c"]
        self.kp, self.kd = J * w ** 2, 2 * z * J * w
        self._at = (None, None)

    def __call__(self, t, y):
        key = (t, y.tobytes())
        if self._at[0] != key:
            ref = self.path(t)
            self._at = (key, self.kp * (ref[:6] - y[:6]) + self.kd * (ref[6:12] - y[6:12]))
        return self._at[1]


def shuttle_arm_minimum_energy(*, nodes=None, method=None, duration=None, bounds=None,
                               constants=None, model_options=None, backend="c", ipopt=None,
                               degree=None, margin=10.0, torque_factor=1.0, booms="rigid"):
    r"""The Shuttle arm's manoeuvre of least :math:`\int\sum\tau_i^2dt` with
    joint-angle and joint-torque limits, against the quintic profile.

    Parameters
    ----------
    nodes, method, duration, degree :
        Default 101 nodes, ``"hermite-simpson"``, 150 s (the model's quintic);
        ``degree``: LGR's points per interval (``method="lgr"``).
    bounds, constants, model_options, backend, ipopt :
        As every named problem (:mod:`._optimal_problems`); ``bounds`` by
        joint (``q3``, ``tau1``) replace the limits below;
        ``model_options`` of ``shuttle-arm`` (``payload``; the booms are
        chosen by ``booms``).
    margin : float
        Each joint stays within the range its quintic sweeps widened by this
        on both sides, degrees (``inf``: no joint-angle limits).
    torque_factor : float
        Each joint's torque limit over the largest its quintic needs.
    booms : {"rigid", "flexible"}
        ``"flexible"``: the same manoeuvre, limits and payload on the
        flexible booms (``flexible_booms=True``), ending at rest with the
        booms undeformed, against the rigid optimum on the same mesh
        (:mod:`._shuttle_arm_flexible_oc`).

    Returns
    -------
    ArmManoeuvre, or FlexibleArmManoeuvre with ``booms="flexible"``
    """
    from ..models import SRMS_END_DEG, SRMS_START_DEG
    from ..optimization import OptimalControlProblem
    from ..simulation import simulate
    if np.isnan(margin) or margin < 0:
        raise KanedynError(f"margin must be a number of degrees >= 0 (inf: no joint-angle "
                           f"limits), got {margin!r}")
    if not np.isfinite(torque_factor) or torque_factor <= 0:
        raise KanedynError(f"torque_factor must be a positive number, got {torque_factor!r}")
    if booms not in BOOMS:
        raise KanedynError(f"booms must be one of {', '.join(BOOMS)}, got {booms!r}")
    if "flexible_booms" in (model_options or {}):
        raise KanedynError("the model option flexible_booms is set by the study's option "
                           "booms (booms='flexible', --set booms=flexible), got "
                           f"flexible_booms={model_options['flexible_booms']!r}")
    if booms == "flexible":
        from ._shuttle_arm_flexible_oc import flexible_manoeuvre
        return flexible_manoeuvre(
            nodes=nodes, method=method, duration=duration, bounds=bounds,
            constants=constants, model_options=model_options, backend=backend, ipopt=ipopt,
            degree=degree, margin=margin, torque_factor=torque_factor)
    spec = optimal_problem("shuttle-arm", "minimum-energy")
    nodes = nodes or spec.nodes
    method = method or spec.method
    T = float(duration or spec.duration)
    definition = build_model("shuttle-arm", model_options, spec.required)
    model = numeric_of(definition, constants, backend)
    taus = definition.symbols["tau"]
    start, end = np.radians(SRMS_START_DEG), np.radians(SRMS_END_DEG)

    # the quintic: its torques set the limits and, simulated, make the guess
    tq, q_quintic, _, tau_quintic = _quintic(model, start, end, T)
    peaks = np.max(np.abs(tau_quintic), axis=1)
    defaults = {}
    for i in range(6):
        low, high = sorted((start[i], end[i]))
        if np.isfinite(margin):
            defaults[f"q{i + 1}"] = (low - np.radians(margin), high + np.radians(margin))
        defaults[f"tau{i + 1}"] = (-torque_factor * peaks[i], torque_factor * peaks[i])
    names = list(model.state_names) + [f"tau{i + 1}" for i in range(6)]
    limits = merged_bounds(defaults, bounds, names)
    rest = {f"u{i + 1}": 0.0 for i in range(6)}
    problem = OptimalControlProblem(
        model, nodes=nodes, duration=T, lagrange=sum(tau ** 2 for tau in taus),
        bounds=limits, method=method, degree=degree,
        initial={**{f"q{i + 1}": start[i] for i in range(6)}, **rest},
        final={**{f"q{i + 1}": end[i] for i in range(6)}, **rest})
    from scipy.interpolate import CubicSpline
    feedforward = {tau: SplineInput(CubicSpline(tq, row))
                   for tau, row in zip(taus, tau_quintic)}
    run = simulate(model.with_inputs(feedforward), (0.0, T),
                   np.concatenate([start, np.zeros(6)]), dense_output=True, **REPLAY)
    result = solve(problem, problem.guess_from(run, inputs=feedforward), ipopt)

    # the checks: open loop, and with the PD term on top
    open_loop = result.resimulate(**REPLAY).simulation
    tracking = _Tracking(result, definition.symbols["servo"])
    optimal = result.inputs()
    driven = result.model().with_inputs(
        {tau: _Sum(optimal[str(tau.func)], tracking, i) for i, tau in enumerate(taus)})
    tracked = simulate(driven, (result.t[0], result.t[-1]), result.y[:, 0], t_eval=result.t,
                       **REPLAY)
    pd = np.array([tracking(t, y) for t, y in zip(tracked.t, tracked.y.T)]).T
    tip = _tip_function(definition)
    reference = tip(result.y[:6])

    def differences(run):
        n = run.t.size
        angles = np.abs(run.y[:6] - result.y[:6, :n])
        tips = np.linalg.norm(tip(run.y[:6]) - reference[:, :n], axis=0)
        if n < result.t.size:  # the run ended early
            tips = np.concatenate([tips, np.full(result.t.size - n, np.inf)])
        return float(np.max(angles)) if n == result.t.size else np.inf, tips

    angle_open, tip_open = differences(open_loop)
    angle_tracked, tip_tracked = differences(tracked)
    fine = np.linspace(0.0, result.duration, 20001)
    effort = float(np.trapezoid(sum(np.array([f(t) for t in fine]) ** 2
                                    for f in optimal.values()), fine))
    bound = np.array([max(abs(v) for v in _pair(limits[f"tau{i + 1}"])) for i in range(6)])
    low = np.minimum(start, end)[:, None] - result.y[:6]
    high = result.y[:6] - np.maximum(start, end)[:, None]
    effort_quintic = float(np.trapezoid(np.sum(tau_quintic ** 2, axis=0), tq))
    data = dict(
        objective=result.objective, effort_optimal=effort, effort_quintic=effort_quintic,
        effort_ratio=effort / effort_quintic,
        torque_ratio=float(np.max(np.max(np.abs(result.points()[2]), axis=1) / bound)),
        angle_excess=float(np.degrees(max(0.0, np.max(low), np.max(high)))),
        margin=float(margin), defect_angle_open=angle_open,
        defect_angle_tracked=angle_tracked, defect_tip_open=float(np.max(tip_open)),
        defect_tip_tracked=float(np.max(tip_tracked)),
        tracking_peak=float(np.max(np.abs(pd))),
        tracking_ratio=float(np.max(np.max(np.abs(pd), axis=1) / bound)))
    peaks = input_peaks(result, limits)
    data.update(peaks.data)
    angle_limits = np.array([_pair(limits.get(f"q{i + 1}", (None, None))) for i in range(6)])
    return ArmManoeuvre(
        result=result, t_quintic=tq, angles_quintic=q_quintic, torques_quintic=tau_quintic,
        open_loop=open_loop, tracked=tracked, tracking_torque=pd,
        angle_limits=angle_limits, torque_limits=bound, tip_difference_open=tip_open,
        tip_difference_tracked=tip_tracked, data=types.MappingProxyType(data),
        input_peaks=peaks)


class _Sum:
    """Joint ``i``'s optimal torque plus its PD term: an input f(t, y)."""

    def __init__(self, feedforward, tracking, i):
        self.feedforward, self.tracking, self.i = feedforward, tracking, i

    def __call__(self, t, y):
        return self.feedforward(t) + float(self.tracking(t, y)[self.i])


register_problem(OptimalProblem(
    model="shuttle-arm", name="minimum-energy", function=shuttle_arm_minimum_energy,
    description="the payload manoeuvre of least integral of sum tau_i^2 in 150 s, joints "
                "within their quintic range +- 10 deg and torques within its peaks; "
                "against the quintic, replayed open loop and PD-tracked",
    nodes=101, method="hermite-simpson", duration=150.0, required={"torque_input": True},
    options={"margin": StudyOption(float, 10.0, "joint-angle margin beyond the quintic's "
                                                "range [deg] (inf: no limits)"),
             "torque_factor": StudyOption(float, 1.0, "torque limits over the quintic's "
                                                      "peak torques", positive=True),
             "booms": StudyOption(str, "rigid", "rigid, or flexible (Craig-Bampton booms; "
                                                "ends at rest, booms undeformed)", BOOMS)}))
