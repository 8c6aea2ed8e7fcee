"""The seat-belt sensor's run told in one figure: the pulse, the tilt, lock and release.

Top: the vehicle's acceleration in g (its components along N's x and y, the axes
of the vehicle at t = 0, and its magnitude).  Bottom: the pendulum's tilt in its
housing against the lock angle (a horizontal line) and the housing wall, the
locked intervals shaded, each lock and release instant marked and labelled (an
unintended release, the tilt falling back while the vehicle still decelerates
beyond ``release_g``, in red).  ``kanedyn run seatbelt-sensor`` writes it as
``seatbelt-sensor_story.png`` (:data:`~kanedyn.analysis.RUN_FIGURES`).
"""

from __future__ import annotations

from pathlib import Path

import math
import textwrap

import numpy as np

from ._plotting import pyplot

__all__ = ["seatbelt_run_figure", "RUN_FIGURES", "run_figure"]

_G0 = 9.80665


def seatbelt_run_figure(result, definition, report=None):
    """The pulse (g) and the tilt against the lock angle, lock and release marked.

    Parameters
    ----------
    result : SimulationResult
        A ``seatbelt-sensor`` run.
    definition : ModelDefinition
        The definition it came from (its motion and lock angle).
    report : SeatbeltReport, optional
        Default: :func:`kanedyn.models.seatbelt_report` of the output points.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from ..models import seatbelt_report, seatbelt_tilt
    plt = pyplot()
    report = seatbelt_report(result, definition) if report is None else report
    t = np.asarray(result.t, float)
    motion = definition.symbols["motion"]
    lo, hi = motion.t_range
    acc = motion.evaluate("position", 2, np.clip(t, lo, hi)) / _G0  # (3, n), g
    tilt = np.degrees(seatbelt_tilt(result.y[:2]))
    ms = 1e3 * t
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8.0, 6.2), sharex=True,
                                      gridspec_kw={"height_ratios": (1, 1.3)})
    top.plot(ms, np.linalg.norm(acc, axis=0), color="k", lw=1.6, label="|a|")
    for k, (name, color) in enumerate((("a_x", "tab:blue"), ("a_y", "tab:orange"))):
        if np.any(acc[k]):
            top.plot(ms, acc[k], color=color, lw=1.0, label=f"${name}$ (N axes)")
    top.axhline(report.release_g, color="0.5", ls=":", lw=1.0,
                label=f"{report.release_g:g} g (release check)")
    top.set_ylabel("vehicle acceleration [g]")
    # a record's file by its name; an analytic pulse by its description (whose units
    # hold a "/")
    source = Path(motion.source)
    top.set_title(f"pulse: {source.name if source.is_file() else motion.source}",
                  fontsize=9)
    top.legend(fontsize=8, loc="best")
    top.grid(alpha=0.3)
    lock = math.degrees(report.lock_angle)
    bottom.plot(ms, tilt, color="tab:green", lw=1.6, label="tilt of the pendulum")
    bottom.axhline(lock, color="tab:red", lw=1.2, label=f"lock angle {lock:g}°")
    wall = definition.symbols.get("theta_lim")
    wall_value = definition.constants.get(wall) if wall is not None else None
    if definition.symbols.get("limit") != "none" and wall_value is not None:
        bottom.axhline(math.degrees(wall_value), color="0.4", ls="--", lw=1.0,
                       label=f"housing wall {math.degrees(wall_value):g}°")
    releases = set(report.releases)

    def mark(when, text, color, marker, below):
        right = when > t[0] + 0.75 * (t[-1] - t[0])  # label to the left near the end
        bottom.plot(1e3 * when, lock, marker=marker, color=color, ms=8)
        bottom.annotate(f"{text} {1e3 * when:.2f} ms", (1e3 * when, lock),
                        xytext=(-4 if right else 4, -14 if below else 10),
                        textcoords="offset points", fontsize=8, color=color,
                        ha="right" if right else "left")

    for start, end in report.intervals:
        bottom.axvspan(1e3 * start, 1e3 * end, color="tab:red", alpha=0.08)
        if start > t[0]:
            mark(start, "lock", "tab:red", "v", False)
        if end < t[-1]:
            unintended = end in releases
            mark(end, "unintended release" if unintended else "release",
                 "tab:red" if unintended else "tab:purple", "^", True)
    bottom.set_xlabel("time [ms]")
    bottom.set_ylabel("tilt in the housing [deg]")
    bottom.grid(alpha=0.3)
    bottom.legend(fontsize=8, loc="lower right")
    fig.suptitle(textwrap.fill("Seat-belt sensor: " + report.summary(), 100), fontsize=9)
    fig.tight_layout()
    plt.close(fig)
    return fig


#: model name -> the figure ``kanedyn run`` writes besides the states' plot, as
#: ``<name>_story.png``: ``f(result, definition) -> Figure``
def _oc3_run_figure(result, definition):
    from ._oc3_turbine_plot import oc3_run_figure
    return oc3_run_figure(result, definition)


RUN_FIGURES = {"seatbelt-sensor": seatbelt_run_figure, "oc3-spar": _oc3_run_figure}


def run_figure(result, definition):
    """The model's own figure of a run (:data:`RUN_FIGURES`), or None."""
    draw = RUN_FIGURES.get(definition.name)
    return None if draw is None else draw(result, definition)
