"""Plots of simulation results (Matplotlib, imported lazily).

Conventions shared by kanedyn's figures:

* the title names the model (its description from the model definition);
* every axis label carries a unit in brackets, ``[?]`` where kanedyn cannot
  tell it (never a guessed one); quantities of different units never share an
  axis: angles, lengths, angular rates and speeds get panels of their own, and
  within a unit, curves whose ranges differ by more than a factor of
  :data:`RANGE_SPLIT` (a spinning wheel's angle beside a lean angle) too;
* a flexible body's modal coordinates (and their rates) get panels of their
  own, named after the body;
* curves that never exceed :data:`NOISE_FLOOR` (numerical noise of a motion
  the run does not excite, or a state at rest) are not drawn; the title names
  them;
* a logarithmic axis only where the data allow it (:func:`log_scale_ok`);
  exact zeros on such an axis are drawn at a stated floor;
* legends beside the axes, never over the curves;
* a figure that fits a screen: at most :data:`MAX_FIGURE_PX` pixels as saved
  (one column of panels, two beyond :data:`ONE_COLUMN` panels: coordinates
  left, speeds right).
"""

from __future__ import annotations

import math

import numpy as np

from .._output_files import save_figure

__all__ = ["plot_result", "pyplot", "unit_text", "log_scale_ok", "draw_nonnegative",
           "legend_beside", "RANGE_SPLIT", "NOISE_FLOOR", "MAX_FIGURE_PX", "ONE_COLUMN"]

#: curves of one unit whose ranges differ by more than this go to separate panels
RANGE_SPLIT = 20.0
#: a state whose magnitude never exceeds this (SI units) is not drawn by default
NOISE_FLOOR = 1e-12
#: (width, height) limit of a saved state figure, pixels
MAX_FIGURE_PX = (1600, 1000)
#: up to this many panels in one column; more: two columns
ONE_COLUMN = 4
_DPI = 120

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


def _modal_bodies(model):
    """``{modal coordinate or speed name: flexible body name}``."""
    eom = getattr(model, "_eom", None)
    if eom is None:
        return {}
    from ..engine import name_of
    from ..modeling import FlexibleBody
    return {name_of(s): body.name for body in eom.bodies if isinstance(body, FlexibleBody)
            for s in (*body.q, *body.u)}


def _peak(values):
    values = np.asarray(values, dtype=float)
    return float(np.max(np.abs(values[np.isfinite(values)]), initial=0.0))


def _state_panels(result, states, units):
    """``([(ylabel, level, [names])], [names not drawn])``: one panel per level
    (``"q"`` coordinates, ``"u"`` speeds), flexible body and unit, split by
    range; with ``states=None`` the states that stay within :data:`NOISE_FLOOR`
    are left out (all drawn when every one does)."""
    names = list(result.state_names)
    n_q = result.model.n_q
    chosen = names if states is None else list(states)
    for name in chosen:
        if name not in names:
            raise KeyError(f"{name} is not a state of this result; states are "
                           f"{', '.join(names)}")
    peaks = {name: _peak(result[name]) for name in chosen}
    quiet = [n for n in chosen if peaks[n] <= NOISE_FLOOR] if states is None else []
    if len(quiet) == len(chosen):
        quiet = []
    modal = _modal_bodies(result.model)
    groups = {}
    for name in chosen:
        if name in quiet:
            continue
        level = "q" if names.index(name) < n_q else "u"
        groups.setdefault((level, modal.get(name, ""), units.get(name)), []).append(name)
    panels = []
    for (level, body, unit), members in sorted(
            groups.items(), key=lambda kv: (kv[0][0] != "q", kv[0][1], str(kv[0][2]))):
        if body:
            what = f"{body} modes" if level == "q" else f"{body} mode rates"
        else:
            what = (_Q_WHAT if level == "q" else _U_WHAT).get(unit)
            what = what or ("coordinate" if level == "q" else "speed")
        label = f"{what} {unit_text([unit])}"
        for part in _split_by_range(members, [peaks[n] for n in members]):
            panels.append((label, level, part))
    return panels, quiet


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
    """``{constraint force name: "N" | "N m" | None}``: identified forces by their
    actions; forces of auxiliary speeds by the loads they enter (a torque on a
    frame: N m; a force at a point: N)."""
    eom = getattr(model, "_eom", None)
    if eom is None:
        return {}
    out = {}
    for name, actions in eom.identified_forces.items():
        kinds = {kind for kind, *_ in actions}
        out[name] = {"force": "N", "torque": "N m"}.get(kinds.pop()) if len(kinds) == 1 \
            else None
    import sympy.physics.mechanics as me
    for name in getattr(model, "aux_names", ()):
        kinds = set()
        for load in eom.loads:
            where, vector = load[0], load[1]
            if any(name in {str(x) for x in m.free_symbols}
                   for matrix, _ in vector.args for m in matrix):
                kinds.add("N m" if isinstance(where, me.ReferenceFrame) else "N")
        out[name] = kinds.pop() if len(kinds) == 1 else None
    return out


def _count(n, noun):
    return f"{n} {noun}" + ("" if n == 1 else "s")


def _title(result, title, quiet, width):
    """The figure's title: the model, the run, the states not drawn; lines wrapped
    to about ``width`` characters."""
    import textwrap
    model = result.model
    if title is None:
        name, text = getattr(model, "name", None), getattr(model, "title", None)
        if text and name:
            title = f"{name}: {text}"
        else:
            title = text or name or (
                f"model with {_count(model.n_q, 'coordinate')} and "
                f"{_count(model.n_u, 'speed')}")
    method = getattr(result, "method", None)
    detail = f"{method}, " if isinstance(method, str) else ""
    detail += f"t = {result.t[0]:g} to {result.t[-1]:g} s" if result.t.size else "no output"
    if not result.success:
        detail += f"; stopped: {result.message}"
    lines = [title, detail]
    if quiet:
        shown = ", ".join(quiet[:10]) + (f" and {len(quiet) - 10} more" if len(quiet) > 10
                                         else "")
        lines.append(f"not drawn, within {NOISE_FLOOR:g} throughout (numerical noise or at "
                     f"rest): {shown}")
    return "\n".join(textwrap.fill(line, width) for line in lines)


def _layout(panels, height_per_panel=1.9):
    """``(figsize, [(row, column)] per panel, rows, columns)``: one column up to
    :data:`ONE_COLUMN` panels; beyond, coordinates left and speeds right, the
    other panels below the shorter column; at most :data:`MAX_FIGURE_PX`."""
    if len(panels) <= ONE_COLUMN:
        cells = [(i, 0) for i in range(len(panels))]
        columns = 1
    else:
        columns, filled, cells = 2, [0, 0], []
        for kind, _, level, _ in panels:
            c = {"q": 0, "u": 1}.get(level) if kind == "state" else min((0, 1),
                                                                      key=filled.__getitem__)
            cells.append((filled[c], c))
            filled[c] += 1
    rows = max(r for r, _ in cells) + 1
    max_w, max_h = (x / _DPI for x in MAX_FIGURE_PX)
    width = 9.0 if columns == 1 else max_w
    return (width, min(1.2 + height_per_panel * rows, max_h)), cells, rows, columns


def plot_result(result, states=None, path=None, extras=True, labels=None, title=None):
    """Figure of a simulation result (see :meth:`SimulationResult.plot`)."""
    plt = pyplot()
    model = result.model
    units = _model_units(model)
    labels = dict(labels or {})
    state_panels, quiet = _state_panels(result, states, units)
    panels = [("state", label, level, members) for label, level, members in state_panels]
    colors = _state_colors(result, states)
    if extras and result.constraint_residuals.shape[0]:
        config_units, velocity_units = getattr(model, "constraint_units", ([], []))
        l = model.n_q_dep
        if l:
            panels.append(("residual", f"|config. constraint| {unit_text(config_units)}",
                           None, (0, l)))
        if model.n_u_dep:
            panels.append(("residual", f"|velocity constraint| {unit_text(velocity_units)}",
                           None, (l, l + model.n_u_dep)))
    energy = result.energy if extras else None
    if energy is not None and np.any(np.isfinite(energy)):
        panels.append(("energy", "E - E(t0) [J]", None, None))
    if extras and result.constraint_forces:
        by_unit = {}
        force_units = _force_units(model)
        for name in result.constraint_forces:
            by_unit.setdefault(force_units.get(name), []).append(name)
        for unit, members in by_unit.items():
            what = {"N": "constraint force", "N m": "constraint torque"}.get(unit,
                                                                         "multiplier")
            panels.append(("forces", f"{what} {unit_text([unit])}", None, members))
    contact_forces = result.contact_forces if extras else {}
    if any(np.any(f["normal"] != 0) for f in contact_forces.values()):
        panels.append(("normal", "normal force [N]", None, None))
    if any(np.any(f["friction"] != 0) for f in contact_forces.values()):
        panels.append(("friction", "|friction force| [N]", None, None))
    impacts = [impact.t for impact in getattr(result, "impacts", ())] if extras else []
    figsize, cells, rows, columns = _layout(panels)
    fig, grid = plt.subplots(rows, columns, sharex=True, squeeze=False, figsize=figsize,
                             layout="constrained")
    axes = [grid[cell] for cell in cells]
    for ax in grid.ravel():
        if not any(ax is used for used in axes):
            ax.set_visible(False)
    for ax, (kind, ylabel, _, members) in zip(axes, panels):
        if kind == "state":
            for name in members:
                ax.plot(result.t, result[name], label=labels.get(name, name),
                        color=colors.get(name))
        elif kind == "residual":
            lo, hi = members
            rows_ = np.abs(result.constraint_residuals[lo:hi])
            series = {"max |residual|": np.max(rows_, axis=0)}
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
                       label="impacts" if k == 0 and ax is axes[0] else None)
        ax.set_ylabel(ylabel, fontsize="small" if rows > 3 else None)
        ax.grid(True, alpha=0.3)
        legend_beside(ax)
    for column in range(columns):  # the lowest panel of each column shows the time axis
        lowest = max((cell for cell in cells if cell[1] == column), default=None)
        if lowest is not None:
            grid[lowest].set_xlabel("t [s]")
            grid[lowest].xaxis.set_tick_params(labelbottom=True)
    fig.suptitle(_title(result, title, quiet, int(12 * figsize[0])), fontsize="medium")
    if path is not None:
        save_figure(fig, path, dpi=_DPI)
    return fig
