"""``oc3-operating``: the TMD and TMDI in an irregular sea with the rotor parked and operating.

For each case, the parked rotor (``rotor="rigid"``, no wind) and each wind
speed of ``wind_speeds`` with the rotor spinning and the baseline controller
on, three runs in the same JONSWAP sea: no damper, the TMD and the TMDI
tuned as ``oc3-tmdi`` tunes them (on the parked, still-water tower mode:
:func:`~._oc3_studies.tuned_damper_options`).  The operating runs start at
the wind's operating point with the platform upright, the parked ones at the
still-water equilibrium; the first ``settle`` seconds are dropped.
Tabulated: standard deviations of the tower-top displacement and deflection
and the dampers' cut of them, platform pitch, rotor speed, blade pitch and
generator power (means and standard deviations); one figure of these
quantities for the operating cases.
"""

from __future__ import annotations

import numpy as np

from .._errors import KanedynError
from ._oc3_studies import _damping_options, _model, _pyplot, _save, _say, tuned_damper_options
from ._oc3_turbine_plot import OC3_PANELS, draw_oc3_panels, oc3_turbine_series
from ._studies import StudyOption, register_study

__all__ = []

_KINDS = ("off", "tmd", "tmdi")


def _wind_list(text):
    try:
        winds = [float(v) for v in str(text).replace(";", ",").split(",") if v.strip()]
    except ValueError:
        raise KanedynError(f"oc3-operating: wind_speeds must be numbers in m/s separated by "
                           f"commas, got {text!r}") from None
    if not winds or any(not 3.0 <= w <= 25.0 for w in winds):
        raise KanedynError(f"oc3-operating: wind_speeds must be one or more operating winds "
                           f"from cut-in 3 to cut-out 25 m/s, got {text!r}")
    return winds


def _run(opts, backend, duration, settle, operating):
    from ..simulation import simulate
    if operating:   # from the wind's operating point, the platform upright
        from ..models import oc3_spar
        d = oc3_spar(**opts)
        model = d.numeric(backend=backend)
        y0 = d.initial(model)
    else:           # from the still-water equilibrium
        d, _, model, y0 = _model(backend, **opts)
    dt = 0.1
    t_eval = np.arange(0.0, duration + dt / 2, dt)
    res = simulate(model, (0.0, duration), y0, t_eval=t_eval, rtol=1e-6, atol=1e-6)
    if not res.success:
        raise KanedynError(f"oc3-operating: the run with wind {opts['wind_speed']:g} m/s, "
                           f"tmdi={opts['tmdi']} failed: {res.message}")
    keep = res.t >= settle
    return res.t[keep], oc3_turbine_series(d, model, res.y[:, keep])


def _operating_study(out, quiet, wind_speeds, Hs, Tp, seed, duration, settle, aero,
                     mass_ratio, inertance_ratio, inerter_height, backend, tower_damping,
                     tower_damping_reference):
    winds = _wind_list(wind_speeds)
    if not 0 <= settle < duration:
        raise KanedynError(f"oc3-operating: settle must be at least 0 and below duration "
                           f"({duration:g} s), got {settle:g}")
    dampers = {"off": {}}
    for kind in _KINDS[1:]:
        _say(quiet, f"oc3-operating: tuning the {kind.upper()}")
        dampers[kind] = tuned_damper_options(kind, mass_ratio, inertance_ratio,
                                             inerter_height, backend, tower_damping,
                                             tower_damping_reference)[0]
    sea = dict(tower_modes=2, drag=True, sea="irregular", wave_height=Hs, wave_period=Tp,
               seed=seed, tower_damping=tower_damping,
               tower_damping_reference=tower_damping_reference)
    runs = {}
    for wind in [0.0, *winds]:
        operating = wind > 0
        for kind in _KINDS:
            opts = dict(sea, wind_speed=wind, tmdi=kind, **dampers[kind])
            if operating:
                opts.update(rotor="spinning", controller="on", aero=aero)
            _say(quiet, f"oc3-operating: wind {wind:g} m/s, damper {kind} ({duration:g} s)")
            runs[wind, kind] = _run(opts, backend, duration, settle, operating)
    columns = ("wind [m/s]", "rotor", "damper", "std tower-top displacement [m]",
               "std tower-top deflection [m]", "deflection std cut [-]",
               "mean platform pitch [deg]", "std platform pitch [deg]",
               "mean rotor speed [rpm]", "std rotor speed [rpm]", "mean blade pitch [deg]",
               "mean generator power [MW]", "std generator power [MW]")
    rows, data = [], {}
    for (wind, kind), (_, s) in runs.items():
        base = np.std(runs[wind, "off"][1]["top_deflection"])
        cut = 1 - np.std(s["top_deflection"]) / base

        def stat(key, f):
            return round(float(f(s[key])), 5) if key in s else ""
        rows.append((wind, "operating" if wind else "parked", kind,
                     stat("top_displacement", np.std), stat("top_deflection", np.std),
                     round(float(cut), 5), stat("platform_pitch", np.mean),
                     stat("platform_pitch", np.std), stat("rotor_speed", np.mean),
                     stat("rotor_speed", np.std), stat("blade_pitch", np.mean),
                     stat("generator_power", np.mean), stat("generator_power", np.std)))
        data[wind, kind] = dict(zip(columns, rows[-1]))
    figures = []
    if out is not None:
        figures.append(_figure(out, runs, winds, Hs, Tp, seed, aero))
    summary = "\n".join(
        f"wind {r[0]:g} m/s ({r[1]}), {r[2]:4s}: std deflection {r[4]:.4g} m"
        + (f" ({100 * r[5]:.1f} % below no damper)" if r[2] != "off" else "")
        + f", std displacement {r[3]:.4g} m, pitch {r[6]:.3g} +- {r[7]:.3g} deg"
        + (f", rotor {r[8]:.4g} rpm, blade pitch {r[10]:.3g} deg, power {r[11]:.4g} MW"
           if r[1] == "operating" else "") for r in rows)
    return dict(tables={"statistics": (columns, rows)}, figures=figures, summary=summary,
                data=data)


def _figure(out, runs, winds, Hs, Tp, seed, aero):
    plt = _pyplot()
    fig, axes = plt.subplots(len(OC3_PANELS), len(winds), figsize=(5.2 * len(winds) + 1.5,
                                                                  11.5),
                             sharex=True, squeeze=False)
    labels = {"off": "no damper", "tmd": "TMD", "tmdi": "TMDI"}
    for col, wind in enumerate(winds):
        for kind, style in zip(_KINDS, ("-", "--", ":")):
            t, s = runs[wind, kind]
            draw_oc3_panels(axes[:, col], t, s, label=labels[kind], ls=style, lw=0.9)
        axes[0, col].set_title(f"wind {wind:g} m/s, controller on, aero {aero}", fontsize=9)
        axes[-1, col].set_xlabel("time [s]")
    axes[0, -1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle(f"oc3-spar operating in JONSWAP Hs {Hs:g} m, Tp {Tp:g} s, seed {seed}",
                 fontsize=10)
    return _save(fig, out / "oc3-operating.png")


register_study("oc3-operating", _operating_study, {
    "wind_speeds": StudyOption(str, "11.4,18", "steady hub-height winds, m/s, comma "
                               "separated (each from 3 to 25; the parked case is added)"),
    "Hs": StudyOption(float, 6.0, "significant wave height, m"),
    "Tp": StudyOption(float, 10.0, "JONSWAP peak period, s"),
    "seed": StudyOption(int, 1, "seed of the sea's random phases"),
    "duration": StudyOption(float, 300.0, "simulated time of each run, s"),
    "settle": StudyOption(float, 100.0, "start-up time dropped from the statistics, s"),
    "aero": StudyOption(str, "thrust", "rotor aerodynamics of the operating runs",
                        ("thrust", "bem")),
    "mass_ratio": StudyOption(float, 0.02, "damper mass / (tower + RNA mass)"),
    "inertance_ratio": StudyOption(float, 0.02, "TMDI inertance / (tower + RNA mass)"),
    "inerter_height": StudyOption(float, 60.0, "inerter's tower end above the SWL, m"),
    "backend": StudyOption(str, "c", "numerical backend", ("numpy", "c")),
    **_damping_options(),
}, "TMD and TMDI in an irregular sea with the rotor parked and operating (spinning, "
   "controller on): tower-top deflection and displacement, platform pitch, rotor speed, "
   "blade pitch, power")
