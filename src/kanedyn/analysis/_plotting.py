"""Plots of simulation results (Matplotlib, imported lazily)."""

from __future__ import annotations

import numpy as np

__all__ = ["plot_result", "pyplot"]


def pyplot():
    """``matplotlib.pyplot`` with a non-interactive backend when there is no display."""
    import os

    import matplotlib
    if not os.environ.get("DISPLAY") and not os.environ.get("MPLBACKEND"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_result(result, states=None, path=None, extras=True):
    plt = pyplot()
    names = list(result.state_names)
    n_q = result.model.n_q
    if states is None:
        groups = [("coordinates", names[:n_q]), ("speeds", names[n_q:])]
    else:
        groups = [("states", list(states))]
    panels = [g for g in groups if g[1]]
    if extras and result.constraint_residuals.shape[0]:
        panels.append(("max |constraint residual|", None))
    if extras and result.energy is not None:
        panels.append(("energy", None))
    if extras and result.constraint_forces:
        panels.append(("constraint forces", None))
    contact_forces = result.contact_forces if extras else {}
    if contact_forces:
        panels.append(("normal force [N]", None))
        panels.append(("|friction force| [N]", None))
    fig, axes = plt.subplots(len(panels), 1, sharex=True,
                             figsize=(8, 2.4 * len(panels) + 0.6), squeeze=False)
    for ax, (title, members) in zip(axes[:, 0], panels):
        if members is not None:
            for name in members:
                ax.plot(result.t, result[name], label=name)
            ax.legend(loc="upper right", fontsize="small", ncol=max(1, len(members) // 6))
        elif title.startswith("max"):
            ax.semilogy(result.t, np.maximum(result.constraint_residual, 1e-300))
        elif title == "energy":
            ax.plot(result.t, result.energy - result.energy[0])
            title = "energy change from t0"
        elif title.startswith("normal force"):
            for name, forces in contact_forces.items():
                ax.plot(result.t, forces["normal"], label=name)
            for impact in result.impacts:
                ax.axvline(impact.t, color="0.6", lw=0.6, ls=":")
            ax.legend(loc="upper right", fontsize="small")
        elif title.startswith("|friction"):
            for name, forces in contact_forces.items():
                ax.plot(result.t, np.linalg.norm(forces["friction"], axis=1), label=name)
            ax.legend(loc="upper right", fontsize="small")
        else:
            for name, values in result.constraint_forces.items():
                ax.plot(result.t, values, label=name)
            ax.legend(loc="upper right", fontsize="small")
        ax.set_ylabel(title)
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    status = "" if result.success else f" (stopped: {result.message})"
    fig.suptitle(f"simulation{status}", fontsize="medium")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig
