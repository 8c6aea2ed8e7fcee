r"""Figures of flexible members: mode shapes, and the deformed member of a simulation.

Two views, each chosen for what it has to show:

* :func:`plot_mode_shapes` draws each mode as its nodal displacement
  components against the arc length along the member.  A mode's amplitude
  is arbitrary (kanedyn scales modes to a largest nodal translation of 1 m),
  so its value axis reads directly as metres per unit modal coordinate, and
  the two bending planes of a beam appear as two curves in one panel, each
  with its own sign and node markers.  A 3D view would hide the smaller
  component behind the larger and make values unreadable.
* :func:`plot_deflection` draws the member itself in its body frame, at true
  proportions (equal axis scales), one panel per transverse body axis that
  moves, with the deflection magnified by a stated factor.  Here the shape
  is what matters; the tip deflection at each time is given in the legend in
  true units.

The deformed position of node :math:`k` is

.. math::

    r_k = x_k + \Phi_k\eta + \tfrac12\,\eta^T G_k\,\eta ,

the second-order term taken when the body keeps it (``stiffening=True``).

Matplotlib is imported lazily (:func:`kanedyn.analysis.pyplot`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from .._errors import OptionError
from .._output_files import save_figure
from ..engine import name_of
from ..modeling import FlexibleBody, ReducedMember
from ._plotting import pyplot

__all__ = ["plot_mode_shapes", "plot_deflection", "natural_modes", "member_arc_length",
           "deformed_nodes"]

_AXES = "xyz"
_KINDS = ("natural", "coordinates")
#: components smaller than this fraction of a mode's largest are not drawn
_NEGLIGIBLE = 1e-3


# ---------------------------------------------------------------- geometry
def member_arc_length(member):
    """Arc length of every node along the member, m, shape (n,).

    Distances between consecutive nodes summed from node 0 (the order in
    which beam members number their nodes).
    """
    nodes = np.asarray(member.nodes, dtype=float)
    steps = np.linalg.norm(np.diff(nodes, axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def _extent(member):
    nodes = np.asarray(member.nodes, dtype=float)
    size = float(np.max(np.ptp(nodes, axis=0))) if len(nodes) > 1 else 0.0
    return size if size > 0 else 1.0


def natural_modes(member):
    r"""Natural modes of a reduced member with its reference node clamped.

    Solves :math:`K_r v = \omega^2 M_r v` with :math:`K_r = \Phi^TK\Phi`,
    :math:`M_r = \Phi^TM\Phi`; modes of infinite frequency (no inertia) are
    left out, as in :attr:`ReducedMember.reduced_frequencies`.

    Returns
    -------
    frequencies : ndarray, shape (k,)
        Hz, ascending (equal to ``member.reduced_frequencies``).
    coordinates : ndarray, shape (m, k)
        Modal coordinates :math:`v` of each natural mode, scaled so that its
        largest nodal translation is 1 m with the largest component of that
        node positive (a mode without translation: largest rotation 1 rad).
    """
    Kr = _symmetric(member.modal_stiffness())
    Mr = _symmetric(member.modal_mass())
    if Kr.shape[0] == 0:
        return np.zeros(0), np.zeros((0, 0))
    mu, V = sla.eigh(Mr, Kr)  # mu = 1 / omega^2, ascending
    mu, V = mu[::-1], V[:, ::-1]
    keep = mu > 1e-13 * mu[0]
    mu, V = mu[keep], V[:, keep]
    shapes = np.asarray(member.modes, dtype=float) @ V
    n = member.n_nodes
    for j in range(V.shape[1]):
        block = shapes[:, j].reshape(n, 6)
        part = _shown_part(block, _extent(member))[0]
        k = int(np.argmax(np.linalg.norm(part, axis=1)))
        peak = part[k, np.argmax(np.abs(part[k]))]
        factor = np.linalg.norm(part[k]) * np.sign(peak)
        V[:, j] /= factor
    return np.sqrt(1.0 / mu) / (2 * np.pi), V


def _symmetric(a):
    a = np.asarray(a, dtype=float)
    return 0.5 * (a + a.T)


def _shown_part(block, length):
    """``(values (n, 3), is_rotation)``: translations, or rotations of a mode
    that does not translate (torsion of a straight member)."""
    trans, rot = block[:, :3], block[:, 3:]
    if np.max(np.abs(trans), initial=0.0) >= 1e-6 * np.max(np.abs(rot), initial=0.0) * length:
        return trans, False
    return rot, True


def deformed_nodes(body, eta):
    """Node positions of a flexible body's member in the body frame, m, shape (n, 3).

    Parameters
    ----------
    body : FlexibleBody
    eta : array_like, shape (m,)
        Modal coordinates, m.

    Returns
    -------
    ndarray, shape (n, 3)
        :math:`x_k + \\Phi_k\\eta + \\tfrac12\\eta^TG_k\\eta` (the last term when
        ``body.stiffening``), measured from the reference node.
    """
    member = body.member
    eta = np.asarray(eta, dtype=float)
    n = member.n_nodes
    nodes = np.asarray(member.nodes, dtype=float) - member.nodes[member.reference_node]
    translation = np.asarray(member.modes, dtype=float).reshape(n, 6, -1)[:, :3, :]
    out = nodes + translation @ eta
    if body.stiffening and member.second_order is not None:
        out = out + 0.5 * np.einsum("kaij,i,j->ka", member.second_order, eta, eta)
    return out


# ------------------------------------------------------------- mode shapes
def _mode_numbers(member, modes, count, kind):
    """0-based indices of the modes asked for (given counted from 1, or by name)."""
    if modes is None:
        return list(range(count))
    if isinstance(modes, (int, np.integer, str)):
        modes = [modes]
    chosen = []
    for mode in modes:
        if isinstance(mode, str):
            if kind != "coordinates":
                raise OptionError(f"plot_mode_shapes: mode {mode!r} given by name; names "
                                  f"belong to modal coordinates: use kind='coordinates', or "
                                  f"number the natural modes 1..{count}")
            if mode not in member.mode_names:
                raise OptionError(f"plot_mode_shapes: member {member.name!r} has no mode "
                                  f"named {mode!r} (its modes: "
                                  f"{', '.join(member.mode_names)})")
            chosen.append(member.mode_names.index(mode))
            continue
        if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)):
            raise OptionError(f"plot_mode_shapes: modes must be numbers counted from 1 (or "
                              f"names of modal coordinates), got {mode!r}")
        if not 1 <= mode <= count:
            what = "natural modes" if kind == "natural" else "modal coordinates"
            raise OptionError(f"plot_mode_shapes: mode {int(mode)} does not exist: member "
                              f"{member.name!r} has {count} {what}, numbered 1..{count} "
                              f"as in its report()")
        chosen.append(int(mode) - 1)
    if not chosen:
        raise OptionError("plot_mode_shapes: modes is empty")
    return chosen


def _coordinate_names(member):
    if member.mode_names:
        return tuple(member.mode_names)
    return tuple(f"eta_{j + 1}" for j in range(member.n_modes))


def _natural_label(member, V, j, Mr):
    """Name of the modal coordinate that carries most of natural mode j's kinetic energy."""
    share = V[:, j] ** 2 * np.diag(Mr)
    share = share / share.sum() if share.sum() > 0 else share
    i = int(np.argmax(share))
    name = _coordinate_names(member)[i]
    return name if share[i] >= 0.99 else f"mostly {name} ({share[i]:.0%})"


def plot_mode_shapes(member, modes=None, *, kind="natural", path=None):
    r"""Plot mode shapes of a reduced member along its arc length; returns the Figure.

    One panel per mode: the undeformed member (grey, at zero) and the
    nodal displacement components :math:`u_x, u_y, u_z` (body axes, m) of
    the mode against the arc length along the member (m), nodes marked.
    Components smaller than 0.1 % of the mode's largest are not drawn (the
    legend names those that are: a beam along x shows :math:`u_y` for
    bending in x-y, :math:`u_z` for bending in x-z).  A mode that does not
    translate (torsion of a straight member) shows its rotations, rad.

    Parameters
    ----------
    member : ReducedMember
        The reduced member (``kd.flexible.BeamMember(...).craig_bampton(...)`` etc.).
    modes : int, str or sequence, optional
        The modes to draw, numbered from 1 as in ``member.report()``
        (``kind="coordinates"`` also takes names from ``member.mode_names``);
        default all.
    kind : {"natural", "coordinates"}
        ``"natural"``: the natural modes of the reduced member with its
        reference node clamped, at its reduced frequencies (Hz), each scaled
        to a largest nodal translation of 1 m and labelled with the modal
        coordinate that carries most of its kinetic energy.  ``"coordinates"``:
        the shape of each modal coordinate (column of ``member.modes``, the
        displacement per unit coordinate, m/m), labelled with its name and
        the frequency :math:`\sqrt{K_{jj}/M_{jj}}/2\pi` it would have alone,
        which is a reduced frequency when the coordinate is uncoupled from
        the others (fixed-interface normal modes of a member without
        interface nodes).
    path : str or Path, optional
        Save the figure there as PNG (120 dpi).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    OptionError
        A mode that does not exist (named with the member's mode count), an
        unknown ``kind``, or a member that is not a ``ReducedMember``.
    """
    if not isinstance(member, ReducedMember):
        raise OptionError(f"plot_mode_shapes: member must be a ReducedMember (from "
                          f"craig_bampton, guyan or free_free), got {type(member).__name__}")
    if kind not in _KINDS:
        raise OptionError(f"plot_mode_shapes: kind must be one of {', '.join(_KINDS)}; "
                          f"got {kind!r}")
    n = member.n_nodes
    Kr, Mr = _symmetric(member.modal_stiffness()), _symmetric(member.modal_mass())
    if kind == "natural":
        frequencies, V = natural_modes(member)
        shapes = np.asarray(member.modes, dtype=float) @ V
        labels = [f"natural mode {j + 1}: {frequencies[j]:.4g} Hz, "
                  f"{_natural_label(member, V, j, Mr)}" for j in range(V.shape[1])]
        heading = (f"member {member.name!r}: natural modes of the reduced member\n"
                   f"reference node {member.reference_node} clamped; each scaled to a "
                   f"largest nodal translation of 1 m")
        value_label = "displacement [m]"
    else:
        shapes = np.asarray(member.modes, dtype=float)
        names = _coordinate_names(member)
        labels = []
        for j in range(member.n_modes):
            hz = np.sqrt(max(Kr[j, j], 0.0) / Mr[j, j]) / (2 * np.pi) if Mr[j, j] > 0 \
                else np.inf
            coupled = (np.max(np.abs(np.delete(Kr[j], j)), initial=0.0) > 1e-9 * abs(Kr[j, j])
                       or np.max(np.abs(np.delete(Mr[j], j)), initial=0.0)
                       > 1e-9 * abs(Mr[j, j]))
            text = f"uncoupled {hz:.4g} Hz" if coupled else f"{hz:.4g} Hz"
            labels.append(f"coordinate {j + 1}: {names[j]}, {text}")
        heading = (f"member {member.name!r}: shapes of the modal coordinates\n"
                   f"displacement per unit coordinate; reference node "
                   f"{member.reference_node} clamped")
        value_label = "displacement per unit η [m/m]"
    chosen = _mode_numbers(member, modes, shapes.shape[1], kind)
    plt = pyplot()
    arc = member_arc_length(member)
    length = _extent(member)
    ncols = 1 if len(chosen) <= 3 else 2
    nrows = -(-len(chosen) // ncols)
    fig, axes = plt.subplots(nrows, ncols, sharex=True, squeeze=False,
                             figsize=(6.4 * ncols, 2.5 * nrows + 0.9))
    for ax, j in zip(axes.flat, chosen):
        values, rotation = _shown_part(shapes[:, j].reshape(n, 6), length)
        ax.plot([arc[0], arc[-1]], [0.0, 0.0], color="0.6", lw=2.5, label="undeformed",
                zorder=1)
        largest = np.max(np.abs(values), initial=0.0)
        symbol = "θ" if rotation else "u"
        for a in range(3):
            if largest > 0 and np.max(np.abs(values[:, a])) >= _NEGLIGIBLE * largest:
                ax.plot(arc, values[:, a], marker="o", ms=3.5, lw=1.6,
                        label=f"{symbol}_{_AXES[a]}", color=f"C{a}")
        ax.set_title(labels[j], fontsize="medium")
        if rotation:
            ax.set_ylabel("rotation per unit η [rad/m]" if kind == "coordinates"
                          else "rotation [rad]")
        else:
            ax.set_ylabel(value_label)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    for ax in axes.flat[len(chosen):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("arc length along the member s [m]")
    if nrows > 1 and len(chosen) % ncols:  # the panel above an empty slot shows s
        axes[-2, -1].xaxis.set_tick_params(labelbottom=True)
        axes[-2, -1].set_xlabel("arc length along the member s [m]")
    fig.suptitle(heading, fontsize="medium")
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, dpi=120)
    return fig


# -------------------------------------------------------------- deflection
def _body_coordinates(result, body):
    if not isinstance(body, FlexibleBody):
        raise OptionError(f"plot_deflection: body must be the FlexibleBody of the model, got "
                          f"{type(body).__name__} {body!r}")
    names = [name_of(q) for q in body.q]
    missing = [nm for nm in names if nm not in result.state_names]
    if missing:
        raise OptionError(f"plot_deflection: flexible body {body.name!r} is not in this "
                          f"simulation: its modal coordinates {', '.join(missing)} are not "
                          f"among its states ({', '.join(result.state_names)})")
    return [result.state_names.index(nm) for nm in names]


def _modal_history(result, body, times):
    """Modal coordinates at the times asked for, shape (len(times), m)."""
    rows = _body_coordinates(result, body)
    try:
        times = np.atleast_1d(np.asarray(times, dtype=float))
    except (TypeError, ValueError):
        raise OptionError(f"plot_deflection: times must be numbers, s; got {times!r}") from None
    if times.ndim != 1 or times.size == 0 or not np.all(np.isfinite(times)):
        raise OptionError(f"plot_deflection: times must be a non-empty sequence of finite "
                          f"times, s; got {times.tolist()}")
    finite = np.all(np.isfinite(result.y[rows]), axis=0)
    if not np.any(finite):
        raise OptionError(f"plot_deflection: the simulation has no finite state of body "
                          f"{body.name!r} ({result.message})")
    t = result.t[finite]
    span = t[-1] - t[0]
    slack = 1e-9 * max(span, abs(t[-1]), 1e-300)
    for value in times:
        if not t[0] - slack <= value <= t[-1] + slack:
            stopped = "" if result.success else f"; it stopped early: {result.message}"
            raise OptionError(f"plot_deflection: time {value:g} s is outside the run "
                              f"({t[0]:g} s to {t[-1]:g} s{stopped})")
    times = np.clip(times, t[0], t[-1])
    if result.sol is not None:
        return times, np.asarray(result.sol(times))[rows].T
    y = result.y[rows][:, finite]
    return times, np.array([[np.interp(value, t, row) for row in y] for value in times])


def _auto_scale(deflection, length):
    """1, 2 or 5 times a power of ten, so that the largest drawn deflection is at most
    about 25 % of the member's length; 1 when the deflection is that large already."""
    if deflection <= 0 or deflection >= 0.25 * length:
        return 1.0
    wanted = 0.25 * length / deflection
    power = 10.0 ** np.floor(np.log10(wanted))
    return float(max(f for f in (1.0, 2.0, 5.0, 10.0) if f * power <= wanted * (1 + 1e-12))
                 * power)


def _length_text(value):
    size = abs(value)
    if size >= 1 or size == 0:
        return f"{value:.3g} m"
    if size >= 1e-3:
        return f"{value * 1e3:.3g} mm"
    return f"{value * 1e6:.3g} µm"


def plot_deflection(result, body, times, *, scale="auto", path=None):
    r"""Draw a flexible body's deformed member in its body frame at chosen times.

    Each panel is a view of the member in a plane of the body frame that
    contains its long axis (the body axis along which the nodes extend
    most) and a transverse axis that moves; transverse axes whose
    displacement stays below 0.1 % of the largest are not shown (both are
    when nothing moves).  The undeformed member is grey, each time a
    coloured line through the nodes, the tip (the node farthest from the
    reference node) marked; axes have equal scales, m.  Node positions are
    :math:`x_k + s\,(\Phi_k\eta + \tfrac12\eta^TG_k\eta)` with :math:`s` the
    scale factor, stated on the figure when it is not 1; the legend gives
    each time and the tip's displacement along the panel's transverse axis
    in true units.

    Parameters
    ----------
    result : SimulationResult
    body : FlexibleBody
        A flexible body of the simulated model (its modal coordinates must
        be states of the run).
    times : float or sequence of float
        Times to draw, s, inside the run.  Between output times the states
        come from the dense solution when the run kept one
        (``dense_output=True``), else by linear interpolation.
    scale : float or "auto"
        Deflection magnification; ``"auto"`` picks 1, 2 or 5 times a power
        of ten so that the largest drawn deflection is about 25 % of the
        member's length at most (1 when it is larger already).
    path : str or Path, optional
        Save the figure there as PNG (120 dpi).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    OptionError
        ``body`` not a flexible body of the run, a time outside the run (or
        after it stopped), or a scale that is not a positive number.
    """
    times, eta = _modal_history(result, body, times)
    member = body.member
    nodes = np.asarray(member.nodes, dtype=float) - member.nodes[member.reference_node]
    displacement = np.array([deformed_nodes(body, e) - nodes for e in eta])  # (T, n, 3)
    length = _extent(member)
    if isinstance(scale, str):
        if scale != "auto":
            raise OptionError(f"plot_deflection: scale must be a positive number or 'auto', "
                              f"got {scale!r}")
        scale = _auto_scale(float(np.max(np.linalg.norm(displacement, axis=2))), length)
    elif isinstance(scale, bool) or not np.isfinite(scale) or scale <= 0:
        raise OptionError(f"plot_deflection: scale must be a positive number or 'auto', "
                          f"got {scale!r}")
    scale = float(scale)
    long_axis = int(np.argmax(np.ptp(nodes, axis=0)))
    others = [a for a in range(3) if a != long_axis]
    peak = np.max(np.abs(displacement), axis=(0, 1))
    shown = [a for a in others if peak[a] >= _NEGLIGIBLE * max(peak.max(), 1e-300)] or others
    tip = int(np.argmax(np.linalg.norm(nodes, axis=1)))
    plt = pyplot()
    drawn = nodes + scale * displacement  # (T, n, 3)
    span_h = max(np.ptp(np.concatenate([nodes[:, long_axis], drawn[..., long_axis].ravel()])),
                 1e-300)
    span_v = max(np.ptp(np.concatenate([nodes[:, a], drawn[..., a].ravel()])) for a in shown)
    # panels about as tall as the drawing at equal axis scales (axes some 5 in wide)
    height = float(np.clip(5.0 * span_v / span_h * 1.3 + 1.2, 2.0, 3.6))
    fig, axes = plt.subplots(len(shown), 1, squeeze=False,
                             figsize=(8.5, height * len(shown) + 0.9))
    colors = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, len(times)))
    for ax, a in zip(axes[:, 0], shown):
        h, v = long_axis, a
        ax.plot(nodes[:, h], nodes[:, v], color="0.6", lw=2.5, label="undeformed", zorder=1)
        for k, (time, d, r) in enumerate(zip(times, displacement, drawn)):
            ax.plot(r[:, h], r[:, v], color=colors[k], lw=1.6, marker="o", ms=3,
                    label=f"t = {time:.4g} s: tip u_{_AXES[v]} = {_length_text(d[tip, v])}")
            ax.plot(r[tip, h], r[tip, v], color=colors[k], marker="s", ms=6)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(f"{_AXES[h]} [m] (body frame)")
        ax.set_ylabel(f"{_AXES[v]} [m]" if scale == 1
                      else f"{_AXES[v]} [m], deflection × {scale:g}")
        ax.set_title(f"{_AXES[h]}-{_AXES[v]} plane", fontsize="medium")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize="small")
    notes = [] if scale == 1 else [f"deflection drawn × {scale:g}"]
    if body.stiffening and member.second_order is not None:
        notes.append("second-order foreshortening included")
    fig.suptitle(f"flexible body {body.name!r} (member {member.name!r}) in its body frame"
                 + ("\n" + "; ".join(notes) if notes else ""), fontsize="medium")
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, dpi=120, bbox_inches="tight")
    return fig
