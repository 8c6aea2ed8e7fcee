"""The ``oc3-spar`` turbine's quantities along a run, and their figure.

:func:`oc3_turbine_series` turns a run's states into the quantities a wind
engineer reads (tower-top displacement and deflection, platform pitch, rotor
speed, blade pitch, generator power, in m, deg, rpm, MW; with flexible blades
the first blade's tip deflection out of and in the plane of rotation, m);
:func:`oc3_run_figure` draws them, one panel each: ``kanedyn run oc3-spar``
writes it as ``oc3-spar_story.png`` (:data:`RUN_FIGURES`), and the
``oc3-operating`` study draws the same panels for its runs.
"""

from __future__ import annotations

import math

import numpy as np

from ._plotting import pyplot

__all__ = ["OC3_PANELS", "BLADE_PANELS", "oc3_turbine_series", "oc3_run_figure",
           "draw_oc3_panels", "blade_tip_deflection"]

#: key -> (axis label with unit); the panels in order
OC3_PANELS = {
    "top_displacement": "tower-top fore-aft\ndisplacement [m]",
    "top_deflection": "tower-top deflection\n(rel. platform) [m]",
    "platform_pitch": "platform pitch [deg]",
    "rotor_speed": "rotor speed [rpm]",
    "blade_pitch": "blade pitch [deg]",
    "generator_power": "generator power\n(electrical) [MW]",
}
#: with flexible blades, further panels of :func:`oc3_run_figure`
BLADE_PANELS = {
    "tip_out_of_plane": "blade-1 tip deflection,\nout of plane (downwind) [m]",
    "tip_in_plane": "blade-1 tip deflection,\nin plane (with the rotation) [m]",
}


def oc3_turbine_series(definition, model, y):
    """The quantities of :data:`OC3_PANELS` along the states ``y``.

    Parameters
    ----------
    definition : ModelDefinition
        An ``oc3_spar`` definition.
    model : NumericModel
        Its numerical model.
    y : ndarray, shape (n_states, n_times)

    Returns
    -------
    dict
        ``{key: ndarray (n_times,)}`` in the units of :data:`OC3_PANELS`;
        the rotor's three only with ``rotor="spinning"`` (blade pitch and
        power: the controller's or the held inputs' values).
    """
    from ..modeling.offshore import state_function
    from ._oc3_studies import oc3_outputs
    y = np.asarray(y, float)
    rows = oc3_outputs(definition, model)
    names = list(model.state_names)
    out = {"top_displacement": rows["top_displacement"][0] @ y,
           "top_deflection": rows["top_deflection"][0] @ y,
           "platform_pitch": np.degrees(y[names.index("pitch")])}
    rotor = definition.symbols.get("rotor")
    if rotor is None:
        return out
    out["rotor_speed"] = y[names.index("rotor_speed")] * 30 / math.pi
    from ..engine import name_of
    symbols = {name_of(x): x for x in [*definition.symbols["q"], *definition.symbols["u"]]}
    states = [symbols[name] for name in names]
    inputs = {k: v for k, v in definition.specified.items() if not callable(v)}
    pitch = state_function([rotor["pitch"]], states, inputs, "blade pitch")
    power = state_function([rotor["electrical_power"]], states,
                           {**dict(definition.constants), **inputs}, "generator power")
    out["blade_pitch"] = np.degrees([float(pitch(c)[0]) for c in y.T])
    out["generator_power"] = np.array([float(power(c)[0]) for c in y.T]) / 1e6
    if rotor.get("blades"):
        blade = rotor["blades"][0]
        rows = [names.index(name_of(q)) for q in blade.q]
        out["tip_out_of_plane"], out["tip_in_plane"] = blade_tip_deflection(
            blade, y[rows], np.radians(out["blade_pitch"]))
    return out


def blade_tip_deflection(blade, eta, pitch):
    r"""A flexible blade's tip deflection out of and in its plane of rotation, m.

    The tip node's displacement :math:`\Phi\eta + \tfrac12 G\eta\eta` in the
    blade frame (x flapwise, y against the motion, z along the span: the
    ``oc3-spar`` blades), turned back by the pitch into the unpitched blade's
    axes: out of plane along the shaft (downwind), in plane along the blade's
    motion.

    Parameters
    ----------
    blade : FlexibleBody
    eta : ndarray, shape (m, n_times)
        Its modal coordinates.
    pitch : ndarray, shape (n_times,)
        rad.

    Returns
    -------
    (ndarray, ndarray)
        Out of plane and in plane, shape (n_times,) each.
    """
    member = blade.member
    Phi, _ = member.node_modes(member.n_nodes - 1)
    d = Phi @ eta
    if blade.stiffening and member.second_order is not None:
        d = d + 0.5 * np.einsum("aij,in,jn->an", member.second_order[-1], eta, eta)
    c, s = np.cos(pitch), np.sin(pitch)
    # the blade frame is the unpitched one turned by -pitch about the span
    return c * d[0] + s * d[1], -(-s * d[0] + c * d[1])


def draw_oc3_panels(axes, t, series, label=None, panels=OC3_PANELS, **style):
    """Plot ``series`` (of :func:`oc3_turbine_series`) on ``axes`` (one per key of
    ``panels``, key -> axis label)."""
    for ax, key in zip(axes, panels):
        if key in series:
            ax.plot(t, series[key], label=label, **style)
        ax.set_ylabel(panels[key], fontsize=8)
        ax.grid(True, lw=0.3)


def oc3_run_figure(result, definition):
    """The run's tower, platform and rotor quantities, one panel each (or None).

    Parameters
    ----------
    result : SimulationResult
        An ``oc3-spar`` run.
    definition : ModelDefinition

    Returns
    -------
    matplotlib.figure.Figure or None
        None when the rotor is not spinning (the states' plot shows the rest).
    """
    if definition.symbols.get("rotor") is None:
        return None
    series = oc3_turbine_series(definition, result.model, result.y)
    panels = dict(OC3_PANELS)
    if "tip_out_of_plane" in series:
        panels.update(BLADE_PANELS)
    plt = pyplot()
    fig, axes = plt.subplots(len(panels), 1, figsize=(8.0, 1.75 * len(panels)), sharex=True)
    draw_oc3_panels(axes, result.t, series, panels=panels, lw=1.0, color="tab:blue")
    axes[-1].set_xlabel("time [s]")
    o = definition.symbols["options"]
    axes[0].set_title(f"oc3-spar: wind {o['wind_speed']:g} m/s, rotor {o['rotor']}, "
                      f"controller {o['controller']}, aero {o['aero']}, blades "
                      f"{o['blades']}, sea {o['sea']}", fontsize=9)
    fig.tight_layout()
    return fig
