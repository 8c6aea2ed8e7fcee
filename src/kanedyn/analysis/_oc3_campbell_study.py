"""``oc3-campbell``: the Campbell diagram of the ``oc3-spar`` model with its rotor spinning.

The model is ``oc3_spar(rotor="spinning", controller="off", wind_speed=0, ...)``
with the study's model options passed through; :func:`kanedyn.campbell`
holds the rotor speed at each value from 0 to ``max_rpm`` (the azimuth
moving, every other state at its steady value) and follows the modes by
their shapes.  Without wind the rotor feels no aerodynamic load, so the
diagram shows the structure's modes and the rotor's gyroscopic coupling
only (blades rigid: no blade modes).
"""

from __future__ import annotations

import math

import numpy as np

from .._errors import KanedynError
from .._output_files import save_figure
from ._oc3_studies import _damping_options, _pyplot, _say
from ._studies import StudyOption, register_study

__all__ = ["oc3_campbell_diagram"]


def oc3_campbell_diagram(max_rpm=12.1, n_speeds=12, backend="c", **options):
    """The Campbell diagram of ``oc3_spar(rotor="spinning", **options)`` without wind.

    Parameters
    ----------
    max_rpm : float
        Highest rotor speed, rpm (12.1: the 5-MW rotor's rated speed).
    n_speeds : int
        Rotor speeds from 0 to ``max_rpm``, evenly spaced (at least 2).
    backend : {"c", "numpy"}
        Numerical backend of the model.
    **options
        Further options of :func:`kanedyn.models.oc3_spar` (``tower_modes``,
        ``drivetrain``, ``tmdi``, ``tower_damping``, ...); ``rotor``,
        ``controller`` and ``wind_speed`` are set here.

    Returns
    -------
    CampbellDiagram
        Speeds in rad/s, frequencies in Hz.
    """
    from ..models import oc3_spar
    from ._campbell import campbell
    _check_speeds(max_rpm, n_speeds)
    d = oc3_spar(rotor="spinning", controller="off", wind_speed=0.0, **options)
    model = d.numeric(backend=backend)
    speeds = np.linspace(0.0, max_rpm, n_speeds) * math.pi / 30
    return campbell(model, speeds, d.initial(model), speed="rotor_speed", azimuth="azimuth")


def _check_speeds(max_rpm, n_speeds):
    if not (max_rpm > 0 and math.isfinite(max_rpm)):
        raise KanedynError(f"oc3-campbell: max_rpm must be a positive number of rpm, "
                           f"got {max_rpm!r}")
    if n_speeds < 2:
        raise KanedynError(f"oc3-campbell: n_speeds must be at least 2, got {n_speeds}")


def _campbell_study(out, quiet, max_rpm, n_speeds, tower_modes, drivetrain, tmdi, backend,
                    tower_damping, tower_damping_reference):
    options = dict(tower_modes=tower_modes, drivetrain=drivetrain, tmdi=tmdi,
                   tower_damping=tower_damping,
                   tower_damping_reference=tower_damping_reference)
    _check_speeds(max_rpm, n_speeds)  # before saying what it does
    _say(quiet, f"oc3-campbell: {n_speeds} rotor speeds, 0 to {max_rpm:g} rpm")
    diagram = oc3_campbell_diagram(max_rpm=max_rpm, n_speeds=n_speeds, backend=backend,
                                   **options)
    rpm = diagram.speeds * 30 / math.pi
    columns = ("rotor speed [rpm]", "steady motion found [-]",
               *(f"{label} frequency [Hz]" for label in diagram.labels),
               *(f"{label} damping ratio [-]" for label in diagram.labels))
    rows = [(float(r), bool(ok), *map(float, f), *map(float, z))
            for r, ok, f, z in zip(rpm, diagram.converged, diagram.frequencies,
                                   diagram.damping_ratios)]
    at_rest = {label: float(diagram.frequencies[0, j]) for j, label in
               enumerate(diagram.labels)}
    change = np.nanmax(np.abs(diagram.frequencies / diagram.frequencies[0] - 1), axis=0)
    figures = []
    if out is not None:
        fig = diagram.plot(title=(f"oc3-spar Campbell diagram (spinning rotor, no wind, "
                                  f"rigid blades)\n{tower_modes} tower modes, drivetrain "
                                  f"{drivetrain}, damper {tmdi}; dashed: rotor harmonics nP"))
        path = out / "oc3-campbell.png"
        save_figure(fig, path, dpi=110)
        _pyplot().close(fig)
        figures.append(path)
    lines = [f"{label}: {at_rest[label]:.4g} Hz at rest, largest change up to "
             f"{max_rpm:g} rpm {100 * change[j]:.2f} %"
             for j, label in enumerate(diagram.labels)]
    summary = (f"{len(diagram.labels)} modes at {n_speeds} rotor speeds (0 to {max_rpm:g} "
               f"rpm), {int(np.sum(~diagram.converged))} steady motions not found, smallest "
               f"MAC between neighbouring speeds {float(np.nanmin(diagram.mac)):.3f}\n"
               + "\n".join(lines))
    return dict(tables={"modes": (columns, rows)}, figures=figures, summary=summary,
                data={"diagram": diagram})


register_study("oc3-campbell", _campbell_study, {
    "max_rpm": StudyOption(float, 12.1, "highest rotor speed, rpm (12.1: rated)"),
    "n_speeds": StudyOption(int, 12, "rotor speeds from 0 to max_rpm (at least 2)"),
    "tower_modes": StudyOption(int, 2, "tower bending modes (0: rigid tower, 2 or 4)"),
    "drivetrain": StudyOption(str, "flexible", "low-speed shaft: rigid or with its "
                              "published torsional stiffness and damping",
                              ("rigid", "flexible")),
    "tmdi": StudyOption(str, "off", "damper in the nacelle", ("off", "tmd", "tmdi")),
    "backend": StudyOption(str, "c", "numerical backend", ("numpy", "c")),
    **_damping_options(),
}, "Campbell diagram of the spinning rotor on the spar (no wind, rigid blades): "
   "platform, tower and drivetrain modes against rotor speed")
