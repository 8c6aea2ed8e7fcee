"""The Campbell diagram's figure: tracked modes against rotor speed, with the rotor harmonics."""

from __future__ import annotations

import numpy as np

from .._errors import OptionError
from .._output_files import save_figure
from ._plotting import pyplot

__all__ = ["plot_campbell"]

#: unit -> factor from rad/s
_SPEED_UNITS = {"rpm": 30 / np.pi, "rad/s": 1.0}
#: unit -> factor from Hz
_FREQUENCY_UNITS = {"Hz": 1.0, "rad/s": 2 * np.pi}


def _factor(table, unit, what):
    if unit not in table:
        raise OptionError(f"CampbellDiagram.plot: {what} must be one of "
                          f"{', '.join(table)}, got {unit!r}")
    return table[unit]


def plot_campbell(diagram, path=None, speed_unit="rpm", frequency_unit="Hz", title=None,
                  max_frequency=None):
    """Frequencies of the tracked modes against rotor speed, with the nP lines.

    Parameters
    ----------
    diagram : CampbellDiagram
    path : str or Path, optional
        Save the figure there.
    speed_unit : {"rpm", "rad/s"}
    frequency_unit : {"Hz", "rad/s"}
    title : str, optional
    max_frequency : float, optional
        Upper limit of the frequency axis (in ``frequency_unit``); modes
        entirely above it are left out.

    Returns
    -------
    matplotlib.figure.Figure
    """
    x_scale = _factor(_SPEED_UNITS, speed_unit, "speed_unit")
    y_scale = _factor(_FREQUENCY_UNITS, frequency_unit, "frequency_unit")
    plt = pyplot()
    x = diagram.speeds * x_scale
    y = diagram.frequencies * y_scale
    top = max_frequency if max_frequency is not None else 1.08 * np.nanmax(y)
    fig, ax = plt.subplots(figsize=(9, 5.6), layout="constrained")
    per_rev = np.abs(diagram.speeds) / (2 * np.pi) * y_scale   # 1P in frequency_unit
    for n in diagram.harmonics:
        ax.plot(x, n * per_rev, color="0.55", lw=0.9, ls="--")
        end = np.nonzero(n * per_rev <= top)[0]
        if end.size:
            k = end[-1]
            inside = (2, 2) if k == len(x) - 1 else (-18, -12)  # leaves through the top
            ax.annotate(f"{n}P", (x[k], n * per_rev[k]), fontsize="small", color="0.35",
                        xytext=inside, textcoords="offset points")
    cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles = ["-", "-.", ":"]
    for j, label in enumerate(diagram.labels):
        if not np.any(y[:, j] <= top):
            continue
        ax.plot(x, y[:, j], marker=".", ms=4, lw=1.6, color=cycle[j % len(cycle)],
                ls=styles[(j // len(cycle)) % len(styles)], label=label)
    ax.set_xlim(x.min(), x.max())
    ax.set_ylim(0.0, top)
    ax.set_xlabel(f"rotor speed [{speed_unit}]")
    ax.set_ylabel(f"frequency [{frequency_unit}]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", frameon=False,
              borderaxespad=0.0, title="modes (largest coordinate)")
    ax.set_title(title or "Campbell diagram (dashed: rotor harmonics nP)", fontsize="medium")
    if path is not None:
        save_figure(fig, path, dpi=120)
    return fig
