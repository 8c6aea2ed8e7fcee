"""Plots of simulation results (Matplotlib, imported lazily).

Conventions shared by kanedyn's figures:

* the title names the model (its description from the model definition);
* every axis label carries a unit in brackets, ``[?]`` where kanedyn cannot
  tell it (never a guessed one); quantities of different units never share an
  axis: angles, lengths, angular rates and speeds get panels of their own, and
  within a unit, curves whose ranges differ by more than a factor of
  :data:`RANGE_SPLIT` (a spinning wheel's angle beside a lean angle) too;
* a logarithmic axis only where the data allow it (:func:`log_scale_ok`);
  exact zeros on such an axis are drawn at a stated floor;
* legends beside the axes, never over the curves.
"""

from __future__ import annotations

import math

import numpy as np

from .._output_files import save_figure

__all__ = ["plot_result", "pyplot", "unit_text", "log_scale_ok", "draw_nonnegative",
           "legend_beside", "RANGE_SPLIT"]

#: curves of one unit whose ranges differ by more than this go to separate panels
RANGE_SPLIT = 20.0

_Q_WHAT = {"rad": "angle", "m": "length"}
_U_WHAT = {"rad/s": "angular rate", "m/s": "speed"}


def pyplot():
    """``matplotlib.pyplot`` with a non-interactive backend when there is no display."""
    import os

    import matplotlib
    if not os.environ.get("DISPLAY") and not os.environ.get("MPLBACKEND"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def unit_text(units):
    """``"[m]"`` for one unit, ``"[m, rad]"`` for several, ``"[?]"`` when any is unknown."""
    units = list(units)
    if not units or any(u is None for u in units):
        return "[?]"
    distinct = list(dict.fromkeys(units))
    return f"[{', '.join(distinct)}]"


def log_scale_ok(values, decades=2.0):
    """Whether ``values`` belong on a logarithmic axis.

    True when the finite values are non-negative, some are positive, and the
    positive ones span more than ``decades`` decades (exact zeros are then
    drawn at a floor, see :func:`draw_nonnegative`).
    """
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if not v.size or np.any(v < 0):
        return False
    pos = v[v > 0]
    return pos.size > 1 and math.log10(pos.max() / pos.min()) > decades


def _floor(values):
    """A power of ten one decade below the smallest positive value."""
    pos = values[np.isfinite(values) & (values > 0)]
    return 10.0 ** (math.floor(math.log10(pos.min())) - 1)


def draw_nonnegative(ax, t, series, colors=None, labels=None):
    """Draw non-negative series (errors, residuals) on a log axis where allowed.

    Parameters
    ----------
    ax : matplotlib Axes
    t : ndarray, shape (N,)
    series : dict
        ``{key: ndarray (<= N,)}``; ``None`` entries are skipped.
    colors, labels : dict, optional
        Per key; default: Matplotlib's cycle and the key.

    Returns
    -------
    bool
        True when the axis is logarithmic.  Exact zeros on a logarithmic axis
        are drawn at a floor one decade below the smallest positive value, and
        a note on the axis says so.
    """
    drawn = {k: np.asarray(v, dtype=float) for k, v in series.items() if v is not None}
    everything = np.concatenate([v.ravel() for v in drawn.values()]) if drawn else np.zeros(0)
    use_log = log_scale_ok(everything)
    floor = _floor(everything) if use_log else None
    zeros = False
    for key, v in drawn.items():
        kwargs = {"label": (labels or {}).get(key, str(key))}
        if colors and key in colors:
            kwargs["color"] = colors[key]
        if use_log:
            zeros |= bool(np.any(v == 0))
            v = np.where(v == 0, floor, v)
        ax.plot(t[:v.size], v, **kwargs)
    if use_log:
        ax.set_yscale("log")
        if zeros:
            ax.text(0.01, 0.02, f"exact zeros drawn at {floor:.0e}", transform=ax.transAxes,
                    fontsize="x-small", color="0.4", va="bottom")
    return use_log


def legend_beside(ax, handles=None, labels=None, title=None):
    """A legend to the right of ``ax`` (one column per 16 entries)."""
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    return ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                     fontsize="small", frameon=False, ncol=max(1, math.ceil(len(handles) / 16)),
                     title=title, title_fontsize="small", borderaxespad=0.0)


def _model_units(model):
    try:
        return model.state_units
    except AttributeError:  # a model without units (another kind of model object)
        return {}


def _split_by_range(names, peaks, depth=2):
    """Split names at the widest gap between peak magnitudes while it is wider than
    :data:`RANGE_SPLIT`, into at most ``depth + 1`` groups, smallest first (curves
    that stay at zero go with the smallest)."""
    live = [i for i in range(len(names)) if peaks[i] > 0]
    order = sorted(live, key=lambda i: peaks[i])
    gaps = [peaks[order[k + 1]] / peaks[order[k]] for k in range(len(order) - 1)]
    if depth == 0 or not gaps or max(gaps) <= RANGE_SPLIT:
        return [names]
    cut = int(np.argmax(gaps)) + 1
    large = {names[i] for i in order[cut:]}
    out = []
    for part in ([n for n in names if n not in large], [n for n in names if n in large]):
        out += _split_by_range(part, [peaks[names.index(n)] for n in part], depth - 1)
    return out


def _state_panels(result, states, units):
    """``[(ylabel, [names])]``: one panel per level (coordinates, speeds) and unit."""
    names = list(result.state_names)
    n_q = result.model.n_q
    chosen = names if states is None else list(states)
    for name in chosen:
        if name not in names:
            raise KeyError(f"{name} is not a state of this result; states are "
                           f"{', '.join(names)}")
    groups = {}
    for name in chosen:
        level = "q" if names.index(name) < n_q else "u"
        groups.setdefault((level, units.get(name)), []).append(name)
    panels = []
    for (level, unit), members in sorted(groups.items(),
                                         key=lambda kv: (kv[0][0] != "q", str(kv[0][1]))):
        what = (_Q_WHAT if level == "q" else _U_WHAT).get(unit)
        what = what or ("coordinate" if level == "q" else "speed")
        label = f"{what} {unit_text([unit])}"
        peaks = [float(np.max(np.abs(v[np.isfinite(v)]), initial=0.0))
                 for v in (result[n] for n in members)]
        for part in _split_by_range(members, peaks):
            panels.append((label, part))
    return panels


def _rate_of(model):
    """``{speed name: coordinate name}`` where a kinematic equation reads q' = u."""
    eom = getattr(model, "_eom", None)
    if eom is None:
        return {}
    from ..engine import name_of
    out = {}
    for eq in eom.kd_eqs:
        terms = eq.args if eq.is_Add else ()
        if len(terms) != 2:
            continue
        rate = [a for a in terms if a.is_Derivative]
        speed = [-a for a in terms if not a.is_Derivative]
        if len(rate) == 1 and len(speed) == 1 and speed[0].is_Function:
            out[name_of(speed[0])] = name_of(rate[0].expr)
    return out


def _state_colors(result, states):
    """One colour per coordinate drawn, the same in every panel; a speed ``u = q'``
    gets its coordinate's, other speeds the following ones."""
    names = list(result.state_names)
    n_q = result.model.n_q
    chosen = names if states is None else list(states)
    coordinates = [n for n in chosen if names.index(n) < n_q]
    speeds = [n for n in chosen if names.index(n) >= n_q]
    rate_of = _rate_of(result.model)
    index = {name: k for k, name in enumerate(coordinates)}
    free = iter(range(len(coordinates), len(coordinates) + len(speeds)))
    unpaired = iter(range(len(speeds)))
    for name in speeds:
        paired = rate_of.get(name)
        if paired in index:
            index[name] = index[paired]
        else:
            index[name] = next(free) if coordinates else next(unpaired)
    count = max(index.values(), default=0) + 1
    if count > 20:
        return {}  # Matplotlib's cycle per panel
    import matplotlib
    colors = matplotlib.colormaps["tab10" if count <= 10 else "tab20"].colors
    return {name: colors[k] for name, k in index.items()}


def _force_units(model):
    """``{constraint force name: "N" | "N m" | None}`` from the identified actions."""
    eom = getattr(model, "_eom", None)
    if eom is None:
        return {}
    out = {}
    for name, actions in eom.identified_forces.items():
        kinds = {kind for kind, *_ in actions}
        out[name] = {"force": "N", "torque": "N m"}.get(kinds.pop()) if len(kinds) == 1 \
            else None
    return out


def _count(n, noun):
    return f"{n} {noun}" + ("" if n == 1 else "s")


def _title(result, title):
    model = result.model
    if title is None:
        name, text = getattr(model, "name", None), getattr(model, "title", None)
        if text and name:
            title = f"{text} ({name})"
        else:
            title = text or name or (
                f"model with {_count(model.n_q, 'coordinate')} and "
                f"{_count(model.n_u, 'speed')}")
    method = getattr(result, "method", None)
    detail = f"{method}, " if isinstance(method, str) else ""
    detail += f"t = {result.t[0]:g} to {result.t[-1]:g} s" if result.t.size else "no output"
    if not result.success:
        detail += f"; stopped: {result.message}"
    return f"{title}\n{detail}"


def plot_result(result, states=None, path=None, extras=True, labels=None, title=None):
    """Figure of a simulation result (see :meth:`SimulationResult.plot`)."""
    plt = pyplot()
    model = result.model
    units = _model_units(model)
    labels = dict(labels or {})
    panels = [("state", label, members)
              for label, members in _state_panels(result, states, units)]
    colors = _state_colors(result, states)
    if extras and result.constraint_residuals.shape[0]:
        config_units, velocity_units = getattr(model, "constraint_units", ([], []))
        l = model.n_q_dep
        if l:
            panels.append(("residual", f"|config. constraint| {unit_text(config_units)}",
                           (0, l)))
        if model.n_u_dep:
            panels.append(("residual", f"|velocity constraint| {unit_text(velocity_units)}",
                           (l, l + model.n_u_dep)))
    energy = result.energy if extras else None
    if energy is not None and np.any(np.isfinite(energy)):
        panels.append(("energy", "E - E(t0) [J]", None))
    if extras and result.constraint_forces:
        by_unit = {}
        force_units = _force_units(model)
        for name in result.constraint_forces:
            by_unit.setdefault(force_units.get(name), []).append(name)
        for unit, members in by_unit.items():
            what = {"N": "constraint force", "N m": "constraint torque"}.get(unit,
                                                                         "multiplier")
            panels.append(("forces", f"{what} {unit_text([unit])}", members))
    contact_forces = result.contact_forces if extras else {}
    if any(np.any(f["normal"] != 0) for f in contact_forces.values()):
        panels.append(("normal", "normal force [N]", None))
    if any(np.any(f["friction"] != 0) for f in contact_forces.values()):
        panels.append(("friction", "|friction force| [N]", None))
    impacts = [impact.t for impact in getattr(result, "impacts", ())] if extras else []
    fig, axes = plt.subplots(len(panels), 1, sharex=True, squeeze=False,
                             figsize=(9, 2.1 * len(panels) + 1.0), layout="constrained")
    for ax, (kind, ylabel, members) in zip(axes[:, 0], panels):
        if kind == "state":
            for name in members:
                ax.plot(result.t, result[name], label=labels.get(name, name),
                        color=colors.get(name))
        elif kind == "residual":
            lo, hi = members
            rows = np.abs(result.constraint_residuals[lo:hi])
            series = {"max |residual|": np.max(rows, axis=0)}
            draw_nonnegative(ax, result.t, series)
        elif kind == "energy":
            ax.plot(result.t, energy - energy[0], color="k", label="total energy")
        elif kind == "forces":
            for name in members:
                ax.plot(result.t, result.constraint_forces[name], label=name)
        elif kind == "normal":
            for name, forces in contact_forces.items():
                ax.plot(result.t, forces["normal"], label=name)
        elif kind == "friction":
            for name, forces in contact_forces.items():
                ax.plot(result.t, np.linalg.norm(forces["friction"], axis=1), label=name)
        for line in ax.get_lines():
            if len(line.get_xdata()) == 1:  # one output time: a line would draw nothing
                line.set_marker("o")
        for k, t_impact in enumerate(impacts):
            ax.axvline(t_impact, color="0.55", lw=0.7, ls=":",
                       label="impacts" if k == 0 and ax is axes[0, 0] else None)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        legend_beside(ax)
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle(_title(result, title), fontsize="medium")
    if path is not None:
        save_figure(fig, path, dpi=120)
    return fig
