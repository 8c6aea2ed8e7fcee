r"""The Shuttle arm's least-effort manoeuvre for its flexible booms.

``shuttle_arm_minimum_energy(booms="flexible")``: the rigid study's
manoeuvre (:mod:`._shuttle_arm_oc`: the same two poses, 150 s, payload,
joint-angle corridor and joint-torque limits, least
:math:`\int\sum_i\tau_i^2dt`) for the arm with ``flexible_booms=True`` (each
boom a Craig–Bampton tube, 4 modal coordinates; 28 states), ending at rest
with the booms undeformed.

The booms' modes with the joints free lie at 7.1 to 65 Hz (damping ratios
0.022 to 0.21, the slowest decaying in about 1 s), against a manoeuvre of
150 s: the booms follow the loads quasi-statically, their deflection set by
the joint torques of the moment.  An arm that ends at rest with torque on
its joints ends with its booms bent, and when the torques stop they spring
back and ring.  The rigid optimum's torques start and end away from zero,
and so leave them bent.  The manoeuvre posed here is the rigid arm's least-effort
one with every joint torque starting and ending at zero (instance
constraints), the stiff limit of the flexible problem; it is then checked
on the flexible arm, not on the model it was solved on: its torques are
simulated with ``kd.simulate`` (Radau) on the 28-state model to the final
time and ``ring`` s beyond with the torques off, as are the rigid optimum's.

Collocating the 28-state model itself (the booms' modal coordinates as
states, their coordinates and rates zero at the final time) does not
converge with IPOPT's limited-memory Hessian: with 21 to 101 nodes,
Hermite–Simpson, the trapezoid, backward Euler and LGR of degree 3, from the
quintic's or a rigid optimum's torques simulated on the flexible arm, it
stops at its iteration limit with constraint violations of 0.1 to 50, and
with the exact Hessian (the trapezoid, 31 nodes) at a point of local
infeasibility (``docs/optimal_control.md``); the mesh's steps, 1.5 to
7.5 s, are 10 to 1,000 times the modes' periods.

Residual vibration is measured by the end effector's elastic deflection,
:math:`\delta(t) = p(q, \eta) - p(q, 0)`: the tip's position with the
booms deflected less its position at the same joint angles with the booms
straight (m), at the final time, and its largest size from ``SETTLE`` to
``ring`` seconds after it with the torques off (once the booms have sprung
back, the vibration that lasts).
"""

from __future__ import annotations

import types
from dataclasses import dataclass

import numpy as np

from ._optimal_problems import (InputPeaks, build_model, input_peaks, numeric_of,
                                replayed_inputs, result_lines, solution_word, solve)

__all__ = ["FlexibleArmManoeuvre", "flexible_manoeuvre"]

#: the replays' integrator (stiff: the booms' modes are at 7 to 65 Hz); the
#: differences of solve_ivp for its Jacobian: the exact one (``jac="exact"``)
#: halves a warm run's time, but compiling the 28-state arm's derivatives costs
#: more CPU time, cold, than it saves in a study's two runs (measured).  rtol
#: 1e-8, atol 1e-10: the study's numbers are those of rtol 1e-9, atol 1e-11 to
#: 1e-4 relative (31 nodes, measured: the smallest, the ramped ring of 1.2e-9
#: m, to 1e-4, the deflections and defects to 1e-5), in half the steps and 45 %
#: less CPU time
REPLAY = {"method": "Radau", "rtol": 1e-8, "atol": 1e-10}
#: seconds simulated after the final time with the torques off
RING = 10.0
#: seconds after the final time the ring is measured from: the booms spring
#: back from a bend within about 0.1 s (their faster modes), then ring
SETTLE = 0.5
#: the joints, in the model's order
JOINTS = ("shoulder yaw", "shoulder pitch", "elbow pitch", "wrist pitch", "wrist yaw",
          "wrist roll")


@dataclass(frozen=True)
class FlexibleArmManoeuvre:
    """The least-effort manoeuvre with the torques from and to zero, checked
    on the flexible booms against the rigid optimum.

    Attributes
    ----------
    result : OptimalControlResult
        The rigid arm's least-effort manoeuvre with every joint torque zero
        at the start and the end (the study's limits otherwise).
    rigid : ArmManoeuvre
        The rigid study on the same mesh (torques free at the ends).
    rigid_on_flexible, replay : object
        The rigid optimum's and ``result``'s torques simulated on the arm
        with flexible booms (Radau, rtol 1e-8, atol 1e-10) to the final
        time, then ``ring`` s with the torques off from the state reached:
        ``pieces`` (the two SimulationResults), ``t`` and ``sol(t)`` (dense
        output of either; states: joint angles, the booms' modal
        coordinates, then their rates).
    torque_limits : ndarray, shape (6,)
        N m, the rigid study's.
    ring : float
        s simulated after the final time.
    deflection : callable
        ``deflection(Y) -> ndarray (3, K)``: the end effector's elastic
        deflection (m, in the orbiter's frame) at flexible-arm states Y (28, K).
    data : mapping
        ``objective`` and ``effort_ramped`` (``result``'s objective),
        ``effort_rigid`` (the rigid optimum's), ``effort_quintic`` (all
        N^2 m^2 s), ``effort_ratio`` (ramped over rigid); ``torque_ratio``
        (the largest torque over its limit at the nodes and interior points,
        the same as ``limit_ratio_points``); ``limit_ratio_points``,
        ``limit_ratio_replayed`` (that ratio at the collocation points and
        as replayed: Hermite-Simpson's quadratic between the nodes
        overshoots the nodes' and midpoints' values), ``peak_replayed`` (N m,
        the worst joint's replayed peak) and ``peak_replayed_time`` (s, when;
        :class:`InputPeaks`),
        ``torque_ends`` (N m, the largest torque at the two ends); for
        ``rigid_on_flexible`` (prefix ``rigid_torques_``) and ``replay``
        (prefix ``ramped_``): ``deflection_end`` (m) and
        ``deflection_rate_end`` (m/s), the size of the elastic tip deflection
        and of its rate at the final time (torques on), ``ring_peak`` (m,
        its largest size from ``SETTLE`` = 0.5 s after the final time on,
        torques off: the vibration that lasts once the booms have sprung
        back), ``modal_end`` (the largest modal
        coordinate or rate then: the constraint modes' in m and m/s),
        ``angle_end`` (rad, the largest joint-angle error then),
        ``speed_end`` (rad/s, the largest joint rate then);
        ``defect_angle`` (rad) and ``defect_tip`` (m): ``replay`` at the
        nodes against the collocated (rigid) path, joint angles and end
        effector.
    input_peaks : InputPeaks
        ``result``'s torques at the collocation points and as replayed
        against their limits.
    """

    result: object
    rigid: object
    rigid_on_flexible: object
    replay: object
    torque_limits: np.ndarray
    ring: float
    deflection: object
    data: types.MappingProxyType
    input_peaks: InputPeaks

    @property
    def _rigid_name(self):
        """What the summary and figure call the rigid study's result."""
        word = solution_word(self.rigid.result)
        return "rigid optimum" if word == "optimal" else f"rigid {word}"

    @property
    def summary(self):
        d, r = self.data, self.result
        mm = 1e3
        rigid = self._rigid_name
        rigid_torques = f"{rigid}'s:"
        solved = ("solved" if r.success else
                  f"posed (the {solution_word(r)} reported)")

        def residual(prefix):
            return (f"elastic tip deflection {mm * d[prefix + 'deflection_end']:.3g} mm, "
                    f"its rate {mm * d[prefix + 'deflection_rate_end']:.3g} mm/s; joint "
                    f"angles off by {d[prefix + 'angle_end']:.3g} rad, joint rates up to "
                    f"{d[prefix + 'speed_end']:.3g} rad/s; torques off, from {SETTLE:g} to "
                    f"{self.ring:g} s after: deflection up to "
                    f"{mm * d[prefix + 'ring_peak']:.3g} mm")
        status = [] if self.rigid.result.success else [
            f"the rigid study on the same mesh: NOT solved: {self.rigid.result.message}"]
        return "\n".join(result_lines(r, ("integral of sum tau_i^2", "N^2 m^2 s")) + status + [
            f"booms: flexible (Craig-Bampton, 4 modal coordinates each, 28 states); the "
            f"manoeuvre {solved} on the rigid arm with every torque zero at "
            f"both ends (largest end torque {d['torque_ends']:.2g} N m), checked on the "
            "flexible arm; torque limits [N m]: "
            + ", ".join(f"{v:.4g}" for v in self.torque_limits),
            f"  effort, integral of sum tau_i^2 [N^2 m^2 s]: torques from and to zero "
            f"{d['effort_ramped']:.7g}, {rigid} {d['effort_rigid']:.7g} (ratio "
            f"{d['effort_ratio']:.5f}), quintic {d['effort_quintic']:.7g}",
            self.input_peaks.line("joint torque (from and to zero)", "N m"),
            "check: the torques simulated on the flexible arm (Radau), at the final time:",
            f"  {rigid_torques:29s}" + residual("rigid_torques_"),
            "  torques from and to zero:    " + residual("ramped_"),
            f"  the latter against the collocated path at the nodes: joint angles "
            f"{d['defect_angle']:.3g} rad, end effector {mm * d['defect_tip']:.3g} mm"])

    def plot(self, path):
        """Torques of both optima over their limits, the elastic tip
        deflection of both on the flexible arm over the manoeuvre and after
        it, and the effort as it accrues; returns the path written."""
        from .._output_files import save_figure
        from ._plotting import pyplot
        plt = pyplot()
        r, d, T = self.result, self.data, self.result.duration
        rigid_name = self._rigid_name
        fig, axes = plt.subplots(4, 1, figsize=(8, 12), constrained_layout=True)
        fine, ramped = replayed_inputs(r)
        rigid = np.array([[f(t) for t in fine] for f in self.rigid.result.inputs().values()])
        for i in range(6):
            axes[0].plot(fine, ramped[i] / self.torque_limits[i], color=f"C{i}",
                         label=f"tau{i + 1} {JOINTS[i]}")
            axes[0].plot(fine, rigid[i] / self.torque_limits[i], ":", color=f"C{i}")
        axes[0].plot([], [], "k:", label=rigid_name)
        axes[0].set_ylabel("joint torque / its limit\n(solid: from and to zero,\n"
                           f"dotted: {rigid_name})")
        axes[0].set_xlabel("t [s]")
        axes[0].legend(ncol=4, fontsize=7, loc="lower center", bbox_to_anchor=(0.5, 1.0),
                       frameon=False)
        whole = np.linspace(0.0, T + self.ring, 6001)
        late = np.linspace(T - 5.0, T + self.ring, 3001)
        for run, style, label in (
                (self.rigid_on_flexible, "-", f"{rigid_name}'s torques"),
                (self.replay, "--", "torques from and to zero")):
            axes[1].plot(whole, 1e3 * np.linalg.norm(self.deflection(run.sol(whole)), axis=0),
                         style, label=label)
            axes[2].semilogy(late - T, np.maximum(1e3 * np.linalg.norm(
                self.deflection(run.sol(late)), axis=0), 1e-9), style, label=label)
        axes[1].set_ylabel("end effector's elastic\ndeflection |delta| [mm]")
        axes[1].set_xlabel("t [s] (torques off after the dashed line)")
        axes[2].set_ylabel("|delta| [mm], log scale")
        axes[2].set_xlabel(f"t - {T:g} s [s] (torques off after 0)")
        for ax, at in ((axes[1], T), (axes[2], 0.0)):
            ax.axvline(at, color="0.4", lw=0.8, ls="--")
            ax.legend(fontsize=8, title="simulated on the flexible arm (Radau):",
                      title_fontsize=8)
        for u, style, label in ((ramped, "-", f"from and to zero: {d['effort_ramped']:.6g}"),
                                (rigid, ":", f"{rigid_name}: {d['effort_rigid']:.6g}")):
            rate = np.sum(u ** 2, axis=0)
            accrued = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1])
                                                       * np.diff(fine))])
            axes[3].plot(fine, accrued / 1e6, style, color="k", label=label + " N^2 m^2 s")
        axes[3].set_ylabel("effort so far, integral of\nsum tau_i^2 [10^6 N^2 m^2 s]")
        axes[3].set_xlabel("t [s]")
        axes[3].legend(fontsize=8)
        for ax in axes:
            ax.grid(alpha=0.3)
        fig.suptitle(
            f"Shuttle arm, flexible booms, 11 t payload, {T:g} s ({r.method}, {r.t.size} "
            f"nodes{'' if r.success else ', ' + solution_word(r)})\nend effector's "
            f"deflection at the end: {rigid_name}'s torques "
            f"{1e3 * d['rigid_torques_deflection_end']:.3g} mm,\ntorques from and to zero "
            f"{1e3 * d['ramped_deflection_end']:.2g} mm at "
            f"+{100 * (d['effort_ratio'] - 1):.2g} % effort", fontsize=10)
        written = save_figure(fig, path, dpi=110)
        plt.close(fig)
        return written


def _tip(definition):
    """``f(Y) -> (3, K)``: the end effector's position (m) at states Y (n, K)
    (the joint angles, then the booms' modal coordinates, first)."""
    import sympy as sm
    q = list(definition.kane_args["q_ind"])
    dummies = sm.symbols(f"x_0:{len(q)}")
    expr = definition.symbols["tip_position"].xreplace(dict(zip(q, dummies)))
    fn = sm.lambdify(dummies, expr.xreplace(definition.constants), "numpy")

    def tip(Y):
        Y = np.asarray(Y, float)
        return np.array([np.broadcast_to(np.asarray(row, float).ravel(), Y.shape[1:])
                         for row in fn(*Y[:len(q)])])
    return tip


class _Deflection:
    """``f(Y) -> (3, K)``: the end effector's elastic deflection, m: its
    position at states Y (n, K) less that with the booms straight."""

    def __init__(self, definition):
        self.tip = _tip(definition)
        self.n_modal = len(definition.kane_args["q_ind"]) - 6

    def __call__(self, Y):
        Y = np.asarray(Y, float)
        straight = Y.copy()
        straight[6:6 + self.n_modal] = 0.0
        return self.tip(Y) - self.tip(straight)


class _Run:
    """A run on the flexible arm in two pieces: the torques on to ``T``, then
    off from the state reached (so no step crosses the switch).  ``sol(t)``
    evaluates either piece's dense output, ``pieces`` holds both."""

    def __init__(self, model, inputs, T, ring, y0):
        from ..simulation import simulate
        driven = simulate(model.with_inputs(inputs), (0.0, T), y0, dense_output=True,
                          **REPLAY)
        free = simulate(model.with_inputs({k: 0.0 for k in inputs}), (T, T + ring),
                        driven.y[:, -1], dense_output=True, **REPLAY)
        self.pieces, self.T = (driven, free), T
        self.t = np.concatenate([driven.t, free.t[1:]])
        self.success = driven.success and free.success

    def sol(self, t):
        t = np.asarray(t, float)
        driven, free = self.pieces
        if t.ndim == 0:
            return driven.sol(t) if t <= self.T else free.sol(t)
        return np.where(t <= self.T, driven.sol(np.minimum(t, self.T)),
                        free.sol(np.maximum(t, self.T)))


def _residual(run, T, deflection, end, n_modal, prefix):
    """The residual vibration of ``run`` (a :class:`_Run`): named numbers."""
    yT = run.sol(T)
    h = 1e-3  # s: the deflection's rate at T, backwards, torques still on
    rate = (deflection(yT[:, None]) - deflection(run.sol(T - h)[:, None])) / h
    after = np.linspace(T + SETTLE, run.t[-1], 8001)
    modal = np.concatenate([yT[6:6 + n_modal], yT[12 + n_modal:]])
    return {prefix + "deflection_end": float(np.linalg.norm(deflection(yT[:, None]))),
            prefix + "deflection_rate_end": float(np.linalg.norm(rate)),
            prefix + "ring_peak": float(np.max(np.linalg.norm(deflection(run.sol(after)),
                                                             axis=0))),
            prefix + "modal_end": float(np.max(np.abs(modal))),
            prefix + "angle_end": float(np.max(np.abs(yT[:6] - end))),
            prefix + "speed_end": float(np.max(np.abs(yT[6 + n_modal:12 + n_modal])))}


def flexible_manoeuvre(*, nodes, method, duration, bounds, constants, model_options,
                       backend, ipopt, degree, margin, torque_factor, ring=RING):
    """The study for the flexible booms (``shuttle_arm_minimum_energy(booms=
    "flexible")``; its parameters).

    Returns
    -------
    FlexibleArmManoeuvre
    """
    from ..models import SRMS_END_DEG, SRMS_START_DEG
    from ..optimization import OptimalControlProblem
    from ._shuttle_arm_oc import shuttle_arm_minimum_energy
    # the rigid study on the same mesh: its limits, its optimum, its torques
    rigid = shuttle_arm_minimum_energy(
        nodes=nodes, method=method, duration=duration, bounds=bounds, constants=constants,
        model_options=model_options, backend=backend, ipopt=ipopt, degree=degree,
        margin=margin, torque_factor=torque_factor)
    T = rigid.result.duration
    definition = build_model("shuttle-arm", {**(model_options or {}), "flexible_booms": True},
                             {"torque_input": True})
    taus = definition.symbols["tau"]  # the rigid arm's inputs too (tau1(t) ... tau6(t))
    start, end = np.radians(SRMS_START_DEG), np.radians(SRMS_END_DEG)
    limits = {}
    for i in range(6):
        low, high = rigid.angle_limits[i]
        if np.isfinite(low) or np.isfinite(high):
            limits[f"q{i + 1}"] = (low if np.isfinite(low) else None,
                                   high if np.isfinite(high) else None)
        limits[f"tau{i + 1}"] = (-rigid.torque_limits[i], rigid.torque_limits[i])
    rest = {f"u{i + 1}": 0.0 for i in range(6)}
    # the rigid study's numerical model (the same definition, options and
    # constants): not derived a second time
    problem = OptimalControlProblem(
        rigid.result.problem.model, nodes=rigid.result.t.size,
        duration=T, lagrange=sum(x ** 2 for x in taus), bounds=limits,
        method=rigid.result.method, degree=rigid.result.degree,
        initial={**{f"q{i + 1}": start[i] for i in range(6)}, **rest},
        final={**{f"q{i + 1}": end[i] for i in range(6)}, **rest},
        instance_constraints=[tau.func(0.0) for tau in taus] + [tau.func(T) for tau in taus])
    result = solve(problem, problem.guess_from(rigid.result), ipopt)

    # both optima's torques on the flexible arm, off after the final time
    model = numeric_of(definition, constants, backend)
    n_modal = len(definition.kane_args["q_ind"]) - 6
    y0 = np.concatenate([start, np.zeros(len(model.state_names) - 6)])

    def on_flexible(found):
        # piecewise polynomials: a compiled model evaluates them itself
        inputs = found.inputs()
        return _Run(model, {tau: inputs[str(tau.func)] for tau in taus}, T, ring, y0)
    rigid_on_flexible = on_flexible(rigid.result)
    replay = on_flexible(result)
    deflection = _Deflection(definition)
    at_nodes = replay.sol(result.t)
    # the collocated (rigid) path's end effector: the flexible arm's with the
    # booms straight (the same to 1e-12, test_optimal_studies)
    collocated = np.zeros((len(model.state_names), result.t.size))
    collocated[:6] = result.y[:6]
    bound = np.array(rigid.torque_limits)
    data = dict(
        objective=result.objective, effort_ramped=result.objective,
        effort_rigid=rigid.result.objective,
        effort_ratio=result.objective / rigid.result.objective,
        effort_quintic=rigid.data["effort_quintic"],
        torque_ratio=float(np.max(np.max(np.abs(result.points()[2]), axis=1) / bound)),
        torque_ends=float(np.max(np.abs(result.points()[2][:, [0, -1]]))),
        defect_angle=float(np.max(np.abs(at_nodes[:6] - result.y[:6]))),
        defect_tip=float(np.max(np.linalg.norm(deflection.tip(at_nodes)
                                               - deflection.tip(collocated), axis=0))),
        **_residual(rigid_on_flexible, T, deflection, end, n_modal, "rigid_torques_"),
        **_residual(replay, T, deflection, end, n_modal, "ramped_"))
    peaks = input_peaks(result, limits)
    data.update(peaks.data)
    return FlexibleArmManoeuvre(
        result=result, rigid=rigid, rigid_on_flexible=rigid_on_flexible, replay=replay,
        torque_limits=bound, ring=float(ring), deflection=deflection,
        data=types.MappingProxyType(data), input_peaks=peaks)
