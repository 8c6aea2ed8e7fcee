"""The Whipple bicycle's eigenvalues against speed, with its modes named.

The four eigenvalues of the linearized lean/steer dynamics (upright, straight
running) are named per speed as in Meijaard et al. (2007):

* **weave**: the oscillatory pair (complex conjugate); below the speed where
  it turns oscillatory (about 0.7 m/s for the benchmark) the two positive real
  eigenvalues that merge into it;
* **caster**: the most negative real eigenvalue (large and stable);
* **capsize**: the remaining real eigenvalue, which crosses zero near
  6 m/s; below the weave's birth it is told from the weave's two real roots
  by continuity with its value at higher speed.
"""

from __future__ import annotations

import numpy as np

from .._output_files import save_figure

from ._plotting import pyplot

__all__ = ["bicycle_modes", "plot_bicycle_eigenvalues", "PUBLISHED_STABLE_SPEEDS"]

#: Weave and capsize speeds of the benchmark bicycle, m/s (Meijaard et al. 2007).
PUBLISHED_STABLE_SPEEDS = (4.29238253634111, 6.02426201538837)

_COLORS = {"weave": "tab:blue", "capsize": "tab:red", "caster": "tab:green"}


def bicycle_modes(eigenvalues, imag_tol=1e-9):
    """Name the four lean/steer eigenvalues at every speed.

    Parameters
    ----------
    eigenvalues : ndarray, complex, shape (n_speeds, 4)
        Per speed, in increasing order of speed (as from
        :func:`kanedyn.models.eigenvalues_vs_speed`), 1/s.
    imag_tol : float
        Imaginary parts below this (relative to the magnitude) count as real.

    Returns
    -------
    dict
        ``{"weave": ndarray complex (n, 2), "capsize": ndarray complex (n,),
        "caster": ndarray complex (n,)}``; the weave's two eigenvalues (the
        conjugate pair, or its two real roots at low speed, larger real part
        first); ``nan`` where a speed's eigenvalues do not fit the pattern.
    """
    ev = np.asarray(eigenvalues, dtype=complex)
    n = ev.shape[0]
    weave = np.full((n, 2), np.nan, dtype=complex)
    capsize = np.full(n, np.nan, dtype=complex)
    caster = np.full(n, np.nan, dtype=complex)
    pending = []  # speeds with four real eigenvalues, resolved by continuity
    for k in range(n):
        z = ev[k]
        real = np.abs(z.imag) <= imag_tol * np.maximum(1.0, np.abs(z))
        roots = np.sort(z[real].real)
        pair = z[~real]
        if pair.size == 2 and roots.size == 2:
            weave[k] = sorted(pair, key=lambda w: -w.imag)
            caster[k], capsize[k] = roots
        elif roots.size == 4:
            caster[k] = roots[0]
            pending.append(k)
    for k in reversed(pending):  # from the weave's birth down to standstill
        roots = np.sort(ev[k].real)[1:]
        later = capsize[k + 1].real if k + 1 < n else np.nan
        if np.isnan(later):
            continue
        i = int(np.argmin(np.abs(roots - later)))
        capsize[k] = roots[i]
        rest = np.delete(roots, i)
        weave[k] = rest[::-1]
    return {"weave": weave, "capsize": capsize, "caster": caster}


def plot_bicycle_eigenvalues(speeds, eigenvalues, stable=None, published=PUBLISHED_STABLE_SPEEDS,
                             path=None, title=None, ylim=(-10.0, 10.0)):
    """Real parts (and the weave's frequency) of the named modes against speed.

    Parameters
    ----------
    speeds : ndarray, shape (n,)
        Forward speeds, m/s, increasing.
    eigenvalues : ndarray, complex, shape (n, 4)
    stable : (float, float), optional
        Computed weave and capsize speeds, m/s: the band between them is
        shaded as self-stable.
    published : (float, float) or None
        Reference speeds marked by vertical lines.
    path : str or Path, optional
        Save the figure there.
    title : str, optional
    ylim : (float, float)
        Range of the eigenvalue axis, 1/s (the caster mode leaves it at speed).

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = pyplot()
    speeds = np.asarray(speeds, dtype=float)
    modes = bicycle_modes(eigenvalues)
    fig, ax = plt.subplots(figsize=(9, 5.2), layout="constrained")
    ax.axhline(0.0, color="0.3", lw=0.8)
    if stable is not None:
        ax.axvspan(*stable, color="tab:green", alpha=0.12,
                   label=f"self-stable: {stable[0]:.4f} < v < {stable[1]:.4f} m/s")
    weave = modes["weave"]
    ax.plot(speeds, weave[:, 0].real, color=_COLORS["weave"], lw=2, label="weave, Re")
    ax.plot(speeds, weave[:, 1].real, color=_COLORS["weave"], lw=2)
    ax.plot(speeds, np.abs(weave[:, 0].imag), color=_COLORS["weave"], lw=1.4, ls="--",
            label="weave, |Im| (frequency, rad/s)")
    ax.plot(speeds, modes["capsize"].real, color=_COLORS["capsize"], lw=2, label="capsize")
    ax.plot(speeds, modes["caster"].real, color=_COLORS["caster"], lw=2, label="caster")
    if published is not None:
        for k, v in enumerate(published):
            ax.axvline(v, color="k", lw=0.9, ls=":",
                       label="published weave and capsize speeds\n(Meijaard et al. 2007)"
                       if k == 0 else None)
        top = ylim[1]
        ax.text(published[0], top, f" v_w = {published[0]:.3f}", va="top", ha="right",
                rotation=90, fontsize="small")
        ax.text(published[1], top, f" v_c = {published[1]:.3f}", va="top", ha="left",
                rotation=90, fontsize="small")
    ax.set_ylim(*ylim)
    ax.set_xlim(speeds[0], speeds[-1])
    ax.set_xlabel("forward speed v [m/s]")
    ax.set_ylabel("eigenvalue [1/s]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", frameon=False,
              borderaxespad=0.0)
    ax.set_title(title or "Whipple bicycle: lean and steer eigenvalues against speed",
                 fontsize="medium")
    if path is not None:
        save_figure(fig, path, dpi=120)
    return fig
