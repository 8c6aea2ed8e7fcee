r"""A lane change of the Whipple bicycle with the steer torque as its only input.

The nonlinear, nonholonomic ``whipple-bicycle`` (``steer_torque=True``: the
benchmark's steer torque :math:`T_\delta` between the rear and front frames)
runs upright and straight at ``speed``; :func:`bicycle_lane_change` asks for
the steer torque of least :math:`\int T_\delta^2 dt` that moves the rear
contact ``offset`` metres sideways in ``duration`` seconds and ends upright
and straight again: heading, lean, steer and their rates zero.  Nothing
drives the rear wheel, so the speed is free: it starts at ``speed`` and
changes only as the lean exchanges potential and kinetic energy (reported).

The collocation imposes the no-slip and contact constraints at every node
and midpoint (only the independent states are collocated); the optimal
torque is then simulated with ``kd.simulate`` (Radau) from the initial state,
and where that run ends is the check.
"""

from __future__ import annotations

import types
from dataclasses import dataclass

import numpy as np

from .._errors import KanedynError
from ._optimal_problems import (InputPeaks, OptimalProblem, build_model, defect_text,
                                input_peaks, merged_bounds, numeric_of, optimal_problem,
                                register_problem, replayed_inputs, result_lines,
                                solution_word, solve)
from ._studies import StudyOption

__all__ = ["bicycle_lane_change", "LaneChange"]

#: the independent states of the bicycle (the dependent q5, u1, u2, u3, u5,
#: u8 follow from the constraints)
_INDEPENDENT = ("q1", "q2", "q3", "q4", "q6", "q7", "q8", "u4", "u6", "u7")


@dataclass(frozen=True)
class LaneChange:
    """The optimal lane change and its simulation.

    Attributes
    ----------
    result : OptimalControlResult
    simulation : SimulationResult
        The optimal steer torque simulated with Radau (rtol = atol = 1e-9)
        at 50 points per second.
    offset, speed, duration : float
        m, m/s, s.
    data : mapping
        ``objective`` (the integral of T_delta^2, N^2 m^2 s); ``peak_torque``
        (N m, at the nodes), ``peak_lean``, ``peak_steer`` (rad);
        ``speed_min``, ``speed_max`` (m/s, of the rear wheel's centre over
        the nodes); and, where the simulation ends, ``lateral`` (m),
        ``heading``, ``lean``, ``steer`` (rad), ``lean_rate``,
        ``steer_rate`` (rad/s); ``defect``, the largest difference between
        the simulated and collocated states at the nodes (in the unit of the
        state it is of; the summary gives the largest of each unit); and of
        :class:`InputPeaks`: ``limit_ratio_points``,
        ``limit_ratio_replayed`` (the steer torque over its limit at the
        nodes and midpoints and as replayed; nan without a limit, the
        default), ``peak_replayed`` (N m, the steer torque's largest as
        replayed) and ``peak_replayed_time`` (s).
    input_peaks : InputPeaks
        The steer torque at the collocation points and as replayed.
    defects : dict
        ``{state name: largest |simulated - collocated| at the nodes}``.
    """

    result: object
    simulation: object
    offset: float
    speed: float
    duration: float
    data: types.MappingProxyType
    input_peaks: InputPeaks
    defects: dict

    @property
    def summary(self):
        d = self.data
        units = self.result.problem.model.state_units
        return "\n".join(result_lines(self.result, ("integral of T_delta^2", "N^2 m^2 s")) + [
            f"lane change of {self.offset:g} m at {self.speed:g} m/s in {self.duration:g} s: "
            f"peak steer torque {d['peak_torque']:.4g} N m, lean "
            f"{np.degrees(d['peak_lean']):.3g} deg, steer {np.degrees(d['peak_steer']):.3g} "
            f"deg; speed {d['speed_min']:.4g} to {d['speed_max']:.4g} m/s (at the nodes)",
            self.input_peaks.line("steer torque", "N m"),
            f"check: the {solution_word(self.result)} torque simulated (Radau) ends "
            f"{d['lateral']:.6g} m aside, heading {np.degrees(d['heading']):.2g} deg, lean "
            f"{np.degrees(d['lean']):.2g} deg, steer {np.degrees(d['steer']):.2g} deg; "
            "largest difference from the collocated states at the nodes (the largest of "
            "each unit): "
            + defect_text(self.defects, units)])

    def plot(self, path):
        """Path of the rear contact, lean and steer, steer torque; returns the path."""
        from .._output_files import save_figure
        from ._plotting import pyplot
        plt = pyplot()
        r, run = self.result, self.simulation
        fig, axes = plt.subplots(4, 1, figsize=(8, 10), constrained_layout=True)
        word = solution_word(r)
        axes[0].plot(r["q1"], r["q2"], "o", ms=3, label="collocated (nodes)")
        axes[0].plot(run["q1"], run["q2"], "-", label="simulated (Radau)")
        axes[0].set_xlabel("forward x [m]")
        axes[0].set_ylabel("lateral y [m]\n(rear contact)")
        axes[0].invert_yaxis()  # y to the right, as seen from above with x forward
        axes[0].legend(fontsize=8)
        for name, label, color in (("q4", "lean", "C0"), ("q7", "steer", "C1"),
                                   ("q3", "heading", "C2")):
            axes[1].plot(run.t, np.degrees(run[name]), color=color, label=label)
            axes[1].plot(r.t, np.degrees(r[name]), "o", ms=2, color=color)
        axes[1].set_ylabel("angle [deg]")
        axes[1].legend(fontsize=8, ncol=3, title="lines: simulated; dots: collocated",
                       title_fontsize=8)
        fine, torque = replayed_inputs(r)
        axes[2].plot(fine, torque[r.input_names.index("T_delta")], lw=0.9,
                     label=f"as replayed ({self.input_peaks.between})")
        axes[2].plot(r.t, r["T_delta"], "o", ms=2, color="C0", label="nodes")
        axes[2].set_ylabel("steer torque\nT_delta [N m]")
        axes[2].legend(fontsize=8)
        speed = -np.asarray(run["u6"]) * self._rear_radius
        axes[3].plot(run.t, speed)
        axes[3].set_ylabel("speed [m/s]\n(rear wheel rate x radius)")
        for ax in axes[1:]:
            ax.set_xlabel("t [s]")
        for ax in axes:
            ax.grid(alpha=0.3)
        fig.suptitle(f"Whipple bicycle: lane change of {self.offset:g} m at {self.speed:g} "
                     f"m/s in {self.duration:g} s, least integral of steer torque^2\n"
                     f"({r.method}, {r.t.size} nodes; steer torque the only input"
                     f"{'' if r.success else '; ' + word})",
                     fontsize=10)
        written = save_figure(fig, path, dpi=110)
        plt.close(fig)
        return written

    @property
    def _rear_radius(self):
        return self.result.problem.model.constants["rR"]


def bicycle_lane_change(*, nodes=None, method=None, duration=None, bounds=None,
                        constants=None, model_options=None, backend="c", ipopt=None,
                        degree=None, offset=3.0, speed=5.0):
    r"""The Whipple bicycle's lane change of least :math:`\int T_\delta^2 dt`.

    Parameters
    ----------
    nodes, method, duration :
        Default 61 nodes, ``"hermite-simpson"``, 4 s.
    bounds, constants, model_options, backend, ipopt, degree :
        As every named problem (:mod:`._optimal_problems`).
    offset : float
        Sideways displacement of the rear contact, m (positive to the right).
    speed : float
        Forward speed at the start, m/s.

    Returns
    -------
    LaneChange
    """
    from ..models import upright_state
    from ..optimization import OptimalControlProblem
    from ..simulation import simulate
    if not np.isfinite(speed) or speed <= 0:
        raise KanedynError(f"speed must be a positive number (m/s), got {speed!r}")
    if not np.isfinite(offset):
        raise KanedynError(f"offset must be a finite number (m), got {offset!r}")
    spec = optimal_problem("whipple-bicycle", "lane-change")
    nodes = nodes or spec.nodes
    method = method or spec.method
    T = float(duration or spec.duration)
    definition = build_model("whipple-bicycle", model_options, spec.required)
    model = numeric_of(definition, constants, backend)
    T_delta = definition.symbols["T_delta"]
    y0 = upright_state(model, speed)
    names = model.state_names
    initial = {n: float(y0[names.index(n)]) for n in _INDEPENDENT}
    final = {"q2": float(offset), "q3": 0.0, "q4": 0.0, "q7": 0.0, "u4": 0.0, "u7": 0.0}
    limits = merged_bounds({}, bounds, list(names) + ["T_delta"])
    problem = OptimalControlProblem(model, nodes=nodes, duration=T, lagrange=T_delta ** 2,
                                    bounds=limits, initial=initial, final=final,
                                    method=method, degree=degree)
    # the guess: riding straight on, as the model does without a torque
    straight = simulate(model.with_inputs({T_delta: 0.0}), (0.0, T), y0, rtol=1e-9,
                        atol=1e-9, dense_output=True)
    result = solve(problem, problem.guess_from(straight, inputs={T_delta: 0.0}), ipopt)
    check = result.resimulate(method="Radau", rtol=1e-9, atol=1e-9)
    run = simulate(result.model(), (0.0, T), result.y[:, 0], method="Radau", rtol=1e-9,
                   atol=1e-9, t_eval=np.linspace(0.0, T, int(50 * T) + 1))
    end = {n: float(run[n][-1]) for n in ("q2", "q3", "q4", "q7", "u4", "u7")}
    rR = model.constants["rR"]
    data = dict(objective=result.objective,
                peak_torque=float(np.max(np.abs(result["T_delta"]))),
                peak_lean=float(np.max(np.abs(result["q4"]))),
                peak_steer=float(np.max(np.abs(result["q7"]))),
                speed_min=float(np.min(-result["u6"] * rR)),
                speed_max=float(np.max(-result["u6"] * rR)),
                lateral=end["q2"], heading=end["q3"], lean=end["q4"], steer=end["q7"],
                lean_rate=end["u4"], steer_rate=end["u7"], defect=check.max_defect)
    peaks = input_peaks(result, limits)
    data.update(peaks.data)
    return LaneChange(result, run, float(offset), float(speed), T,
                      types.MappingProxyType(data), peaks, dict(check.defect))


register_problem(OptimalProblem(
    model="whipple-bicycle", name="lane-change", function=bicycle_lane_change,
    description="3 m sideways at 5 m/s in 4 s, upright and straight at the end, steer "
                "torque the only input, least integral of its square; simulated to check",
    nodes=61, method="hermite-simpson", duration=4.0, required={"steer_torque": True},
    options={
        "offset": StudyOption(float, 3.0, "sideways displacement of the rear contact [m]"),
        "speed": StudyOption(float, 5.0, "forward speed at the start [m/s]",
                             positive=True)}))
