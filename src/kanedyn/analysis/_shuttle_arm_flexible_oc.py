r"""The Shuttle arm's least-effort manoeuvre on its flexible booms.

``shuttle_arm_minimum_energy(booms="flexible")`` poses the rigid study's
problem (:mod:`._shuttle_arm_oc`: the same two poses, 150 s, payload,
joint-angle corridor and joint-torque limits, least
:math:`\int\sum_i\tau_i^2dt`) on ``shuttle-arm`` with
``flexible_booms=True``: each boom a Craig–Bampton tube with 4 modal
coordinates (28 states in all).  The manoeuvre ends at rest with the booms
undeformed: every modal coordinate and rate is zero at the final time, as
every joint rate is.  After the final time the torques are off; in
microgravity an arm at rest and undeformed then stays so, while one that
ends deflected or moving vibrates (and drifts).

What is reported:

- the rigid arm's optimum on the same mesh (its own study), and its torques
  applied open loop to the flexible arm with ``kd.simulate`` (Radau): the
  residual vibration they leave;
- the flexible optimum, its effort against the rigid one, and its torques
  replayed the same way (the defect from the collocated path, and the
  residual vibration it leaves).

Residual vibration is measured by the end effector's elastic deflection,
:math:`\delta(t) = p(q, \eta) - p(q, 0)`, the tip's position with the
booms deflected minus its position with the same joint angles and straight
booms (m): at the final time, and its largest size over ``ring`` seconds
after it with the torques off.
"""

from __future__ import annotations

import types
from dataclasses import dataclass

import numpy as np

from ._optimal_problems import build_model, numeric_of, result_lines, solve

__all__ = ["FlexibleArmManoeuvre", "flexible_manoeuvre"]

#: the replays' integrator (stiff: the booms' modes are at 7 to 65 Hz)
REPLAY = {"method": "Radau", "rtol": 1e-9, "atol": 1e-11}
#: seconds simulated after the final time with the torques off
RING = 10.0
#: the joints, in the model's order
JOINTS = ("shoulder yaw", "shoulder pitch", "elbow pitch", "wrist pitch", "wrist yaw",
          "wrist roll")


@dataclass(frozen=True)
class FlexibleArmManoeuvre:
    """The least-effort manoeuvre on the flexible booms, against the rigid one.

    Attributes
    ----------
    result : OptimalControlResult
        The flexible optimum (states ``q1 .. q6``, the booms' modal
        coordinates ``eta_*`` and their rates).
    rigid : ArmManoeuvre
        The rigid arm's study on the same mesh.
    rigid_on_flexible, replay : SimulationResult
        The rigid optimum's torques and the flexible optimum's simulated on
        the flexible arm (Radau), from the start to ``ring`` s past the
        final time, the torques zero after it (dense output).
    torque_limits : ndarray, shape (6,)
        N m, the rigid study's.
    ring : float
        s simulated after the final time.
    deflection : callable
        ``deflection(Y) -> ndarray (3, K)``: the end effector's elastic
        deflection (m, in the orbiter's frame) at states Y (n, K).
    data : mapping
        ``objective``, ``effort_flexible`` and ``effort_rigid`` (the
        collocated objectives, N^2 m^2 s), ``effort_ratio`` (flexible over
        rigid); ``torque_ratio`` (largest torque over its limit at the
        nodes and interior points); for ``rigid_on_flexible`` (prefix
        ``rigid_torques_``) and ``replay`` (prefix ``optimal_``):
        ``deflection_end`` (m) and ``deflection_rate_end`` (m/s), the size of
        the elastic tip deflection and its rate at the final time,
        ``ring_peak`` (m, its largest size after the final time),
        ``modal_end`` (the largest modal coordinate and rate at the final
        time, m or m/s for the constraint modes, dimensionless for the
        clamped modes), ``angle_end`` (rad, the largest joint-angle error at
        the final time), ``speed_end`` (rad/s, the largest joint rate then);
        ``defect_angle``, ``defect_modal`` and ``defect_tip`` (the flexible
        optimum's replay against the collocated path at the nodes: joint
        angles, rad; modal coordinates; the end effector, m).
    """

    result: object
    rigid: object
    rigid_on_flexible: object
    replay: object
    torque_limits: np.ndarray
    ring: float
    deflection: object
    data: types.MappingProxyType

    @property
    def summary(self):
        d, r = self.data, self.result
        mm = 1e3

        def residual(prefix):
            return (f"elastic tip deflection {mm * d[prefix + 'deflection_end']:.3g} mm, "
                    f"its rate {mm * d[prefix + 'deflection_rate_end']:.3g} mm/s, largest "
                    f"modal coordinate or rate {d[prefix + 'modal_end']:.3g}, joint angles "
                    f"off by {d[prefix + 'angle_end']:.3g} rad, joint rates "
                    f"{d[prefix + 'speed_end']:.3g} rad/s; then {self.ring:g} s with the "
                    f"torques off: the deflection up to {mm * d[prefix + 'ring_peak']:.3g} mm")
        return "\n".join(result_lines(r) + [
            f"flexible booms (Craig-Bampton, 4 modal coordinates each; "
            f"{len(r.state_names)} states); {r.duration:g} s between the two poses, ending "
            "at rest with every modal coordinate and rate zero; torque limits [N m]: "
            + ", ".join(f"{v:.4g}" for v in self.torque_limits),
            f"  effort, integral of sum tau_i^2 [N^2 m^2 s]: flexible {d['effort_flexible']:.7g}, "
            f"rigid arm on the same mesh {d['effort_rigid']:.7g} (ratio "
            f"{d['effort_ratio']:.6f}); largest torque over its limit {d['torque_ratio']:.6f}",
            "check: torques simulated on the flexible arm (Radau), at the final time:",
            "  the rigid optimum's:   " + residual("rigid_torques_"),
            "  the flexible optimum's: " + residual("optimal_"),
            f"  the flexible optimum's replay against the collocated path at the nodes: "
            f"joint angles {d['defect_angle']:.3g} rad, modal coordinates "
            f"{d['defect_modal']:.3g}, end effector {mm * d['defect_tip']:.3g} mm"])

    def plot(self, path):
        """Torques of both optima over their limits, the elastic tip
        deflection of both replays over the manoeuvre and after it, and the
        effort as it accrues; returns the path written."""
        from .._output_files import save_figure
        from ._plotting import pyplot
        plt = pyplot()
        r, d, T = self.result, self.data, self.result.duration
        fig, axes = plt.subplots(4, 1, figsize=(8, 12), constrained_layout=True)
        fine = np.linspace(r.t[0], r.t[-1], 3001)
        flex = np.array([[f(t) for t in fine] for f in r.inputs().values()])
        rigid = np.array([[f(t) for t in fine] for f in self.rigid.result.inputs().values()])
        for i in range(6):
            axes[0].plot(fine, flex[i] / self.torque_limits[i], color=f"C{i}",
                         label=f"tau{i + 1} {JOINTS[i]}")
            axes[0].plot(fine, rigid[i] / self.torque_limits[i], ":", color=f"C{i}")
        axes[0].plot([], [], "k:", label="rigid optimum")
        axes[0].set_ylabel("joint torque / its limit\n(solid flexible, dotted rigid optimum)")
        axes[0].set_xlabel("t [s]")
        axes[0].legend(ncol=4, fontsize=7, loc="lower center", bbox_to_anchor=(0.5, 1.0),
                       frameon=False)
        tip = self.deflection
        late = np.linspace(T - 5.0, T + self.ring, 3001)
        whole = np.linspace(0.0, T + self.ring, 6001)
        for run, style, label in ((self.rigid_on_flexible, "-", "rigid optimum's torques"),
                                  (self.replay, "--", "flexible optimum's torques")):
            axes[1].plot(whole, 1e3 * np.linalg.norm(tip(run.sol(whole)), axis=0), style,
                         label=label)
            axes[2].plot(late - T, 1e3 * np.linalg.norm(tip(run.sol(late)), axis=0), style,
                         label=label)
        axes[1].set_ylabel("end effector's elastic\ndeflection |delta| [mm]")
        axes[1].set_xlabel("t [s]")
        axes[2].set_ylabel("|delta| [mm]")
        axes[2].set_xlabel(f"t - {T:g} s [s] (torques off after the final time)")
        for ax in axes[1:3]:
            ax.axvline(T if ax is axes[1] else 0.0, color="0.4", lw=0.8, ls="--")
            ax.legend(fontsize=8, title="on the flexible arm (Radau):", title_fontsize=8)
        for u, style, label in ((flex, "-", f"flexible optimum: {d['effort_flexible']:.6g}"),
                                (rigid, ":", f"rigid optimum: {d['effort_rigid']:.6g}")):
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
            f"Shuttle arm on flexible booms, 11 t payload, {T:g} s: least effort ending at "
            f"rest, booms undeformed\nresidual deflection at the end: rigid optimum's torques "
            f"{1e3 * d['rigid_torques_deflection_end']:.3g} mm, flexible optimum's "
            f"{1e3 * d['optimal_deflection_end']:.2g} mm; effort +{100 * (d['effort_ratio'] - 1):.2g} %"
            f" ({r.method}, {r.t.size} nodes)", fontsize=10)
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


def _off_after(inputs, T):
    """The inputs, zero after ``T``: ``{symbol: f(t)}``."""
    return {k: (lambda t, f=f: f(t) if t <= T else 0.0) for k, f in inputs.items()}


def _residual(run, T, deflection, end, n_modal, prefix):
    """The residual vibration of ``run`` (dense, to T + ring): named numbers."""
    yT = run.sol(T)
    h = 1e-4  # s: the deflection's rate by a central difference of the dense output
    rate = (deflection(run.sol(T + h)[:, None]) - deflection(run.sol(T - h)[:, None])) / (2 * h)
    after = np.linspace(T, run.t[-1], 4001)
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
    """The study on the flexible booms (``shuttle_arm_minimum_energy(booms=
    "flexible")``; its parameters).

    Returns
    -------
    FlexibleArmManoeuvre
    """
    from ..models import SRMS_END_DEG, SRMS_START_DEG
    from ..optimization import OptimalControlProblem
    from ..simulation import simulate
    from ._optimal_problems import merged_bounds, optimal_problem
    from ._shuttle_arm_oc import shuttle_arm_minimum_energy
    spec = optimal_problem("shuttle-arm", "minimum-energy")
    # the rigid arm on the same mesh: its limits, its optimum, its torques
    rigid = shuttle_arm_minimum_energy(
        nodes=nodes, method=method, duration=duration, constants=constants,
        model_options=model_options, backend=backend, ipopt=ipopt, degree=degree,
        margin=margin, torque_factor=torque_factor,
        bounds={k: v for k, v in (bounds or {}).items()
                if str(k).removesuffix("(t)") in _RIGID_NAMES})
    T = rigid.result.duration
    definition = build_model("shuttle-arm", {**(model_options or {}), "flexible_booms": True},
                             spec.required)
    model = numeric_of(definition, constants, backend)
    taus = definition.symbols["tau"]
    n_modal = len(definition.kane_args["q_ind"]) - 6
    start, end = np.radians(SRMS_START_DEG), np.radians(SRMS_END_DEG)
    defaults = {}
    for i in range(6):
        low, high = rigid.angle_limits[i]
        if np.isfinite(low) or np.isfinite(high):
            defaults[f"q{i + 1}"] = (low if np.isfinite(low) else None,
                                     high if np.isfinite(high) else None)
        defaults[f"tau{i + 1}"] = (-rigid.torque_limits[i], rigid.torque_limits[i])
    names = list(model.state_names) + [f"tau{i + 1}" for i in range(6)]
    limits = merged_bounds(defaults, bounds, names)
    rest = {name: 0.0 for name in model.state_names[6:]}  # modal, rates: zero
    problem = OptimalControlProblem(
        model, nodes=rigid.result.t.size, duration=T, lagrange=sum(x ** 2 for x in taus),
        bounds=limits, method=rigid.result.method, degree=rigid.result.degree,
        initial={**{f"q{i + 1}": start[i] for i in range(6)}, **rest},
        final={**{f"q{i + 1}": end[i] for i in range(6)}, **rest})

    # the rigid optimum's torques on the flexible arm: the residual, and the guess
    optimal_rigid = rigid.result.inputs()
    fed = {tau: optimal_rigid[str(tau.func)] for tau in taus}
    y0 = np.concatenate([start, np.zeros(len(model.state_names) - 6)])
    rigid_on_flexible = simulate(model.with_inputs(_off_after(fed, T)), (0.0, T + ring), y0,
                                 dense_output=True, **REPLAY)
    result = solve(problem, problem.guess_from(rigid_on_flexible, inputs=fed), ipopt)

    # the flexible optimum's torques on the flexible arm
    optimal = result.inputs()
    replay = simulate(result.model().with_inputs(
        _off_after({tau: optimal[str(tau.func)] for tau in taus}, T)),
        (0.0, T + ring), result.y[:, 0], dense_output=True, **REPLAY)
    deflection = _Deflection(definition)
    tip = deflection.tip
    at_nodes = replay.sol(result.t)
    bound = np.array([max(abs(v) for v in _sides(limits[f"tau{i + 1}"])) for i in range(6)])
    data = dict(
        objective=result.objective, effort_flexible=result.objective,
        effort_rigid=rigid.result.objective,
        effort_ratio=result.objective / rigid.result.objective,
        torque_ratio=float(np.max(np.max(np.abs(result.points()[2]), axis=1) / bound)),
        defect_angle=float(np.max(np.abs(at_nodes[:6] - result.y[:6]))),
        defect_modal=float(np.max(np.abs(at_nodes[6:6 + n_modal]
                                         - result.y[6:6 + n_modal]))),
        defect_tip=float(np.max(np.linalg.norm(tip(at_nodes) - tip(result.y), axis=0))),
        **_residual(rigid_on_flexible, T, deflection, end, n_modal, "rigid_torques_"),
        **_residual(replay, T, deflection, end, n_modal, "optimal_"))
    return FlexibleArmManoeuvre(
        result=result, rigid=rigid, rigid_on_flexible=rigid_on_flexible, replay=replay,
        torque_limits=bound, ring=float(ring), deflection=deflection,
        data=types.MappingProxyType(data))


def _sides(pair):
    return tuple(np.inf if v is None else float(v) for v in pair)


#: the rigid arm's states and inputs (bounds on the modal states are the
#: flexible problem's only)
_RIGID_NAMES = {f"{k}{i}" for k in ("q", "u", "tau") for i in range(1, 7)}
