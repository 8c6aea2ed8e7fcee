"""Motion beside the Newton–Euler residual, per formulation (``kanedyn compare``).

One row per compared model: the path of the model's ``x``, ``y`` coordinates
(or, without them, the coordinate on which the formulations part most)
against time, then the largest force and moment residual of the
Newton–Euler check over the bodies at each time, on logarithmic axes.  A
formulation whose motion the identified constraint forces cannot produce (the
augmented Lagrangean on nonholonomic systems) stands out by residuals of the
order of the inertia forces, where the others stay at round-off.
"""

from __future__ import annotations

import numpy as np

from .._output_files import save_figure
from ._compare import method_colors
from ._plotting import draw_nonnegative, pyplot, unit_text

__all__ = ["plot_newton_euler_residuals"]


def _widths(methods):
    """``{method: line width}``, widest first: curves that coincide stay visible
    (the reference's wide line under the others')."""
    steps = max(len(methods) - 1, 1)
    return {m: 2.4 - 1.2 * k / steps for k, m in enumerate(methods)}


def _path_panel(ax, cmp, colors, widths):
    """The x-y path of each method (True), or the most deviating coordinate against time."""
    units = cmp.units.get("coordinates", {})
    names = list(units)
    ref = cmp.methods[0]
    if {"x", "y"} <= set(names):
        ix, iy = names.index("x"), names.index("y")
        for m in cmp.methods:
            q = cmp.coordinates[m]
            ax.plot(q[ix], q[iy], color=colors[m], lw=widths[m], label=m)
        start = cmp.coordinates[ref]
        ax.plot(start[ix, 0], start[iy, 0], "o", color="0.2", ms=4, label="start")
        ax.set_xlabel("x " + unit_text([units["x"]]))
        ax.set_ylabel("y " + unit_text([units["y"]]))
        ax.set_title("path", fontsize="small")
        return True
    q_ref = cmp.coordinates[ref]
    spread = np.zeros(q_ref.shape[0])
    for m in cmp.methods:
        n = min(cmp.coordinates[m].shape[1], q_ref.shape[1])
        diff = np.abs(cmp.coordinates[m][:, :n] - q_ref[:, :n])
        spread = np.maximum(spread, np.nanmax(diff, axis=1, initial=0.0))
    k = int(np.argmax(spread))
    name = names[k] if names else f"q{k + 1}"
    for m in cmp.methods:
        q = cmp.coordinates[m][k]
        ax.plot(cmp.t[:q.size], q, color=colors[m], lw=widths[m], label=m)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(f"{name} " + unit_text([units.get(name)]))
    ax.set_title(f"{name}, where the formulations part most", fontsize="small")
    return False


def _residual_panel(ax, cmp, colors, widths, kind):
    """Largest ``kind`` ("force" or "moment") residual over the bodies against time."""
    series = {m: getattr(cmp.newton_euler[m], f"{kind}_history") for m in cmp.methods}
    unit = "N" if kind == "force" else "N m"
    ax.set_ylabel(f"N-E {kind} residual [{unit}]")
    ax.set_xlabel("t [s]")
    ax.set_title(f"largest {kind} residual over the bodies", fontsize="small")
    if not any(np.any(np.isfinite(v) & (v != 0)) for v in series.values()):
        ax.text(0.5, 0.5, "zero at every time for every formulation\n(particles have "
                "no moment residual)" if kind == "moment" else
                "zero at every time for every formulation", transform=ax.transAxes,
                ha="center", va="center", color="0.4")
        ax.set_xticks([])
        ax.set_yticks([])
        return
    draw_nonnegative(ax, cmp.t, series, colors=colors)  # each run's times: a prefix
    for line in ax.get_lines():
        line.set_linewidth(widths[line.get_label()])
    ax.grid(True, alpha=0.3)
    unidentified = sorted({n for m in cmp.methods for n in cmp.newton_euler[m].unidentified})
    if unidentified:
        ax.text(0.99, 0.98, "holds the unidentified forces of " + ", ".join(unidentified),
                transform=ax.transAxes, ha="right", va="top", fontsize="x-small",
                color="0.3")


def plot_newton_euler_residuals(comparisons, path=None):
    """Each formulation's motion beside its Newton–Euler residual over time.

    Parameters
    ----------
    comparisons : sequence of FormulationComparison
        From :func:`compare_formulations`, one row each; every one compares
        the same formulations (the colours follow the first one's order).
    path : str or Path, optional
        Save the figure there (PNG, PDF, ... by suffix).

    Returns
    -------
    matplotlib.figure.Figure
        Per row: the path in the plane of the coordinates ``x``, ``y`` in m
        (or the coordinate with the largest spread between formulations,
        against time), the largest force residual, N, and the largest moment
        residual, N m, over the bodies at each output time (logarithmic
        where the values span decades; exact zeros drawn at a floor, noted
        on the axis).  One colour per formulation, named in the legend.
    """
    comparisons = list(comparisons)
    if not comparisons:
        raise ValueError("plot_newton_euler_residuals needs at least one comparison")
    plt = pyplot()
    methods = comparisons[0].methods
    colors = method_colors(methods)
    widths = _widths(methods)
    rows = len(comparisons)
    fig, axes = plt.subplots(rows, 3, figsize=(13, 3.1 * rows + 1.0), squeeze=False,
                             layout="constrained",
                             gridspec_kw={"width_ratios": (1.0, 1.25, 1.25)})
    paths = False
    for row, cmp in zip(axes, comparisons):
        paths |= _path_panel(row[0], cmp, colors, widths)
        _residual_panel(row[1], cmp, colors, widths, "force")
        _residual_panel(row[2], cmp, colors, widths, "moment")
        row[0].grid(True, alpha=0.3)
        row[0].annotate(f"{cmp.model} (t = 0..{cmp.t[-1]:g} s)", (0.0, 1.0),
                        xycoords="axes fraction", xytext=(0, 18), textcoords="offset points",
                        fontweight="bold", fontsize="medium", va="bottom")
    from matplotlib.lines import Line2D
    ref = methods[0]
    handles = [Line2D([], [], color=colors[m], lw=widths[m]) for m in methods]
    labels = [m + (" (reference)" if m == ref else "") for m in methods]
    if paths:
        handles.append(Line2D([], [], color="0.2", marker="o", lw=0, ms=4))
        labels.append("start")
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels),
               fontsize="small", frameon=False)
    first = comparisons[0]
    fig.suptitle("Motion and Newton-Euler residual with the identified constraint forces, "
                 f"per formulation ({first.integrator})", fontsize="medium")
    if path is not None:
        save_figure(fig, path, dpi=110)
    return fig
