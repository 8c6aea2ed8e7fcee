"""``oc3-campbell``: the Campbell diagram of the ``oc3-spar`` model with its rotor spinning.

The model is ``oc3_spar(rotor="spinning", controller="off", wind_speed=0, ...)``
with the study's model options passed through; :func:`kanedyn.campbell`
holds the rotor speed at each value from 0 to ``max_rpm`` (the azimuth
moving, every other state at its steady value) and follows the modes by
their shapes.  Without wind the rotor feels no aerodynamic load, so the
diagram shows the structure's modes and the rotor's gyroscopic coupling
only; with ``blades="flexible"`` the blades' modes in multiblade coordinates
(collective, forward and backward whirl), the generator free.

:func:`oc3_locked_generator_modes`: the modes of the parked turbine with the
generator locked and the platform held, the condition of the 5-MW
definition's full-system frequencies (its table 9-1, for a land-based tower).
"""

from __future__ import annotations

import functools
import inspect
import math
from dataclasses import dataclass

import numpy as np

from .._errors import KanedynError
from .._output_files import save_figure
from ..engine import name_of
from ._oc3_studies import _damping_options, _pyplot, _say
from ._studies import StudyOption, register_study

__all__ = ["oc3_campbell_diagram", "oc3_locked_generator_modes", "LockedGeneratorModes"]

#: residual accepted for the steady motions, rad/s^2 and m/s^2: the flexible blades'
#: rotor-speed row stops near 3e-9 (round-off of torques of 1e7 N m on 4e7 kg m^2)
_STEADY_TOLERANCE = 1e-8


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
    from ._campbell import campbell
    _check_speeds(max_rpm, n_speeds)
    d, model = _turbine(backend, rotor="spinning", controller="off", wind_speed=0.0,
                        **options)
    speeds = np.linspace(0.0, max_rpm, n_speeds) * math.pi / 30
    blades = d.symbols["rotor"]["blades"]
    rotating = None if not blades else [[name_of(q) for q in b.q] for b in blades]
    return campbell(model, speeds, d.initial(model), speed="rotor_speed", azimuth="azimuth",
                    rotating=rotating, tol=_STEADY_TOLERANCE)


def _turbine(backend, **options):
    """``(definition, numeric model)`` of ``oc3_spar(**options)`` on ``backend``, kept
    for the turbine's other analyses (:func:`_built_turbine`)."""
    from ..models import oc3_spar
    bound = inspect.signature(oc3_spar).bind(**options)
    bound.apply_defaults()
    return _built_turbine(backend, tuple(sorted(bound.arguments.items())))


@functools.lru_cache(maxsize=4)
def _built_turbine(backend, options):
    """``(definition, numeric model)`` of ``oc3_spar(**dict(options))`` (every option
    given, defaults included, so that the same turbine asked for in other words is
    one entry): the Campbell diagram and the locked-generator modes of one turbine
    share its derivation and, on the NumPy backend, the derivatives its equilibria
    and linearizations generate (the flexible-blade turbine's: half of the CPU time
    of each analysis).  Neither changes the model."""
    from ..models import oc3_spar
    d = oc3_spar(**dict(options))
    return d, d.numeric(backend=backend)


def _check_speeds(max_rpm, n_speeds):
    if not (max_rpm > 0 and math.isfinite(max_rpm)):
        raise KanedynError(f"oc3-campbell: max_rpm must be a positive number of rpm, "
                           f"got {max_rpm!r}")
    if n_speeds < 2:
        raise KanedynError(f"oc3-campbell: n_speeds must be at least 2, got {n_speeds}")


def _campbell_study(out, quiet, max_rpm, n_speeds, tower_modes, drivetrain, tmdi, backend,
                    tower_damping, tower_damping_reference, blades):
    options = dict(tower_modes=tower_modes, drivetrain=drivetrain, tmdi=tmdi,
                   tower_damping=tower_damping,
                   tower_damping_reference=tower_damping_reference, blades=blades)
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
                                  f"{blades} blades)\n{tower_modes} tower modes, drivetrain "
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
    "blades": StudyOption(str, "rigid", "blades rigid, or flexible (their flap and edge "
                          "modes in multiblade coordinates)", ("rigid", "flexible")),
    **_damping_options(),
}, "Campbell diagram of the spinning rotor on the spar (no wind): platform, tower, "
   "drivetrain and, with flexible blades, blade modes against rotor speed")


@dataclass(frozen=True)
class LockedGeneratorModes:
    """Modes of the parked turbine, generator locked, platform held.

    Attributes
    ----------
    frequencies : ndarray, shape (n,)
        Damped natural frequencies, Hz, ascending.
    damping_ratios : ndarray, shape (n,)
    labels : tuple of str
        ``"drivetrain"``, ``"tower <coordinate>"`` or ``"<blade mode> collective"``
        / ``"<blade mode> asymmetric"`` (the largest part of the mode's shape,
        coordinates weighted by the square roots of their mass-matrix
        diagonal; a blade mode is collective when the three blades' parts add
        up to most of it).
    shapes : ndarray of complex, shape (n_coordinates, n)
        In the weighted coordinates of ``coordinates``.
    coordinates : tuple of str
        The tower's and blades' coordinates, then ``"rotor"`` (the rotor's angle,
        equal to the shaft's twist when the generator is locked).
    """

    frequencies: np.ndarray
    damping_ratios: np.ndarray
    labels: tuple
    shapes: np.ndarray
    coordinates: tuple

    def mode(self, label):
        """Frequency (Hz) of the mode labelled ``label`` (the lowest if several)."""
        found = [f for f, name in zip(self.frequencies, self.labels) if name == label]
        if not found:
            raise KanedynError(f"no mode labelled {label!r}; labels: {', '.join(self.labels)}")
        return float(found[0])


def oc3_locked_generator_modes(backend="c", **options):
    r"""Modes of the parked ``oc3-spar`` turbine with its generator locked and the platform held.

    The condition of the 5-MW definition's full-system natural frequencies
    (Jonkman et al. 2009, table 9-1; rotor speed 0, generator locked): the
    static equilibrium without wind, rotor speed 0 (:func:`kanedyn.equilibrium`),
    its exact linearization, and the second-order system :math:`M\ddot q + C\dot q
    + Kq = 0` (:math:`K = -MA_{uq}`, :math:`C = -MA_{uu}` from the state matrix)
    restricted to the platform held (its six coordinates removed) and the
    generator locked (the rotor's azimuth equal to the shaft's twist, one
    coordinate ``"rotor"``).  Needs ``drivetrain="flexible"`` (set here).

    Parameters
    ----------
    backend : {"c", "numpy"}
    **options
        Further options of :func:`kanedyn.models.oc3_spar` (``blades``,
        ``tower_modes``, ...); ``rotor``, ``controller``, ``wind_speed`` and
        ``drivetrain`` are set here.

    Returns
    -------
    LockedGeneratorModes
    """
    from ..numerics import equilibrium
    d, model = _turbine(backend, rotor="spinning", controller="off", wind_speed=0.0,
                        drivetrain="flexible", **options)
    found = equilibrium(model, d.initial(model), hold=["rotor_speed", "azimuth"],
                        tol=_STEADY_TOLERANCE)
    if not found.converged:
        raise KanedynError(f"oc3 locked-generator modes: no static equilibrium "
                           f"({found.message})")
    A, _, _ = model.linearize(found.y)
    nq = model.n_q_ind
    names = list(model.state_names[:nq])
    M = model.mass_matrix(0.0, found.y)
    K, C = -M @ A[nq:, :nq], -M @ A[nq:, nq:]
    platform = {"surge", "sway", "heave", "roll", "pitch", "yaw"}
    kept = [n for n in names if n not in platform | {"azimuth", "shaft_twist"}]
    T = np.zeros((nq, len(kept) + 1))
    for j, n in enumerate(kept):
        T[names.index(n), j] = 1.0
    T[[names.index("azimuth"), names.index("shaft_twist")], -1] = 1.0
    Mr, Kr, Cr = T.T @ M @ T, T.T @ K @ T, T.T @ C @ T
    n = Mr.shape[0]
    S = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(Mr, Kr), -np.linalg.solve(Mr, Cr)]])
    values, vectors = np.linalg.eig(S)
    pick = values.imag > 1e-9 * np.max(np.abs(values))
    values, vectors = values[pick], vectors[:n, pick]
    order = np.argsort(values.imag)
    values, vectors = values[order], vectors[:, order]
    shapes = vectors * np.sqrt(np.diag(Mr))[:, None]
    shapes = shapes / np.linalg.norm(shapes, axis=0)
    coordinates = tuple(kept) + ("rotor",)
    labels = tuple(_locked_label(shapes[:, k], coordinates) for k in range(shapes.shape[1]))
    return LockedGeneratorModes(values.imag / (2 * np.pi), -values.real / np.abs(values),
                                labels, shapes, coordinates)


def _locked_label(shape, coordinates):
    """``"drivetrain"``, ``"tower <coordinate>"`` or a blade mode's family and symmetry."""
    big = coordinates[int(np.argmax(np.abs(shape)))]
    if big == "rotor":
        return "drivetrain"
    if not big.endswith(("blade1", "blade2", "blade3")):
        return f"tower {big}"
    family = big.rpartition("_")[0]
    parts = np.array([shape[coordinates.index(f"{family}_blade{k}")] for k in (1, 2, 3)])
    # collective: the three in phase, their sum holding most of their size
    collective = abs(parts.sum()) ** 2 / (3 * np.sum(np.abs(parts) ** 2)) > 0.5
    return f"{family} {'collective' if collective else 'asymmetric'}"
