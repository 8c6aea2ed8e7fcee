r"""The NREL 5-MW blade's structure: distributed properties, flexible member, mode shapes.

The data are the columns BlFract, StrcTwst, BMassDen, FlpStff and EdgStff of
ElastoDyn's ``NRELOffshrBsline5MW_Blade.dat`` (the blade of the 5-MW
definition, Jonkman et al. 2009, NREL/TP-500-38060, table 2-1), with its
structural damping (BldFlDmp, BldEdDmp) and its mode-shape polynomials
(BldFl1Sh, BldFl2Sh, BldEdgSh), as OpenFAST's regression tests
(github.com/OpenFAST/r-test, ``glue-codes/openfast/5MW_Baseline/``) and the
ROSCO toolbox (github.com/NREL/ROSCO, ``Examples/Test_Cases/NREL-5MW/``)
distribute them under the Apache License 2.0; see ``data/NOTICE.md``.  Only
the numbers are kept here (no text of the file).

``NREL5MW_BLADE_STRUCTURE``  the 49 stations
``BLADE_MODE_SHAPES``        ElastoDyn's polynomial mode shapes (coefficients of
                             x^2 ... x^6, x the fraction of the blade length)
``nrel5mw_blade_stations``   the station table for :class:`~kanedyn.flexible.BeamMember`
``nrel5mw_blade_member``     the blade as beam elements (root at the origin,
                             span along body z)
``nrel5mw_blade_modes``      the blade reduced to its first flap, first edge and
                             second flap modes, clamped at the root, damped

Axes of the member (the blade frame): x out of the plane of rotation,
downwind (flapwise), y in that plane against the blade's motion (edgewise,
towards the trailing edge), z along the span from the root.  The flap
stiffness resists deflection normal to the chord, the edge stiffness
deflection along it; the structural twist turns the chord from the plane of
rotation towards feather (the leading edge upwind), a rotation about -z: the
member's ``twist`` column (right-handed about +z) is minus the table's, and so
is blade pitch.  ElastoDyn models neither axial nor torsional deformation:
the member is given stiff axial and torsional properties
(:data:`AXIAL_STIFFNESS`, :data:`TORSIONAL_STIFFNESS`, no polar inertia) and
the reduction keeps bending modes only.

Mass: the table's density times :data:`MASS_SCALE`, so that its exact integral
is the published blade mass, 17,740 kg (``BLADE.mass``).  ElastoDyn reaches
that mass with its own quadrature and the factor AdjBlMs = 1.04536 of the file
(for AeroDyn 14's nodes); on the exact integral of the linearly interpolated
table that factor gives 17,609 kg.
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np

from .._errors import ModelError
from ..modeling import BeamMember
from ._oc3_data import BLADE, ROTOR

__all__ = ["NREL5MW_BLADE_STRUCTURE", "BLADE_MODE_SHAPES", "MASS_SCALE", "AXIAL_STIFFNESS",
           "TORSIONAL_STIFFNESS", "BLADE_MODE_NAMES", "blade_length",
           "nrel5mw_blade_stations", "nrel5mw_blade_member", "nrel5mw_blade_modes"]

#: (fraction of the blade length from the root, structural twist (deg), mass per length
#: (kg/m, before the scale), flapwise stiffness (N m^2), edgewise stiffness (N m^2))
NREL5MW_BLADE_STRUCTURE = (
    (0.0, 13.308, 678.935, 1.811e+10, 1.81136e+10),
    (0.00325, 13.308, 678.935, 1.811e+10, 1.81136e+10),
    (0.01951, 13.308, 773.363, 1.94249e+10, 1.95586e+10),
    (0.03577, 13.308, 740.55, 1.74559e+10, 1.94978e+10),
    (0.05203, 13.308, 740.042, 1.52874e+10, 1.97888e+10),
    (0.06829, 13.308, 592.496, 1.07824e+10, 1.48585e+10),
    (0.08455, 13.308, 450.275, 7.22972e+09, 1.02206e+10),
    (0.10081, 13.308, 424.054, 6.30954e+09, 9.1447e+09),
    (0.11707, 13.308, 400.638, 5.52836e+09, 8.06316e+09),
    (0.13335, 13.308, 382.062, 4.98006e+09, 6.88444e+09),
    (0.14959, 13.308, 399.655, 4.93684e+09, 7.00918e+09),
    (0.16585, 13.308, 426.321, 4.69166e+09, 7.16768e+09),
    (0.18211, 13.181, 416.82, 3.94946e+09, 7.27166e+09),
    (0.19837, 12.848, 406.186, 3.38652e+09, 7.0817e+09),
    (0.21465, 12.192, 381.42, 2.93374e+09, 6.24453e+09),
    (0.23089, 11.561, 352.822, 2.56896e+09, 5.04896e+09),
    (0.24715, 11.072, 349.477, 2.38865e+09, 4.94849e+09),
    (0.26341, 10.792, 346.538, 2.27199e+09, 4.80802e+09),
    (0.29595, 10.232, 339.333, 2.05005e+09, 4.5014e+09),
    (0.32846, 9.672, 330.004, 1.82825e+09, 4.24407e+09),
    (0.36098, 9.11, 321.99, 1.58871e+09, 3.99528e+09),
    (0.3935, 8.534, 313.82, 1.36193e+09, 3.75076e+09),
    (0.42602, 7.932, 294.734, 1.10238e+09, 3.44714e+09),
    (0.45855, 7.321, 287.12, 8.758e+08, 3.13907e+09),
    (0.49106, 6.711, 263.343, 6.813e+08, 2.73424e+09),
    (0.52358, 6.122, 253.207, 5.3472e+08, 2.55487e+09),
    (0.5561, 5.546, 241.666, 4.089e+08, 2.33403e+09),
    (0.58862, 4.971, 220.638, 3.1454e+08, 1.82873e+09),
    (0.62115, 4.401, 200.293, 2.3863e+08, 1.5841e+09),
    (0.65366, 3.834, 179.404, 1.7588e+08, 1.32336e+09),
    (0.68618, 3.332, 165.094, 1.2601e+08, 1.18368e+09),
    (0.7187, 2.89, 154.411, 1.0726e+08, 1.02016e+09),
    (0.75122, 2.503, 138.935, 9.088e+07, 7.9781e+08),
    (0.78376, 2.116, 129.555, 7.631e+07, 7.0961e+08),
    (0.81626, 1.73, 107.264, 6.105e+07, 5.1819e+08),
    (0.84878, 1.342, 98.776, 4.948e+07, 4.5487e+08),
    (0.8813, 0.954, 90.248, 3.936e+07, 3.9512e+08),
    (0.89756, 0.76, 83.001, 3.467e+07, 3.5372e+08),
    (0.91382, 0.574, 72.906, 3.041e+07, 3.0473e+08),
    (0.93008, 0.404, 68.772, 2.652e+07, 2.8142e+08),
    (0.93821, 0.319, 66.264, 2.384e+07, 2.6171e+08),
    (0.94636, 0.253, 59.34, 1.963e+07, 1.5881e+08),
    (0.95447, 0.216, 55.914, 1.6e+07, 1.3788e+08),
    (0.9626, 0.178, 52.484, 1.283e+07, 1.1879e+08),
    (0.97073, 0.14, 49.114, 1.008e+07, 1.0163e+08),
    (0.97886, 0.101, 45.818, 7.55e+06, 8.507e+07),
    (0.98699, 0.062, 41.669, 4.6e+06, 6.426e+07),
    (0.99512, 0.023, 11.453, 250000, 6.61e+06),
    (1.0, 0.0, 10.319, 170000, 5.01e+06),
)

#: ElastoDyn's mode shapes: coefficients of x^2 .. x^6 (x = fraction of the length),
#: normalized to 1 at the tip
BLADE_MODE_SHAPES = {
    "flap_1": (0.0622, 1.7254, -3.2452, 4.7131, -2.2555),
    "flap_2": (-0.5809, 1.2067, -15.5349, 29.7347, -13.8255),
    "edge_1": (0.3627, 2.5337, -3.5772, 2.376, -0.6952),
}

#: the modes the reduced blade keeps, in ElastoDyn's set (two flap, one edge), lowest first
BLADE_MODE_NAMES = ("flap_1", "edge_1", "flap_2")

#: N and N m^2: stiff stand-ins for the axial and torsional stiffness the table lacks
#: (axial modes above 20 Hz; torsion carries no inertia, its modes never appear)
AXIAL_STIFFNESS = 1e11
TORSIONAL_STIFFNESS = 1e11

_PLANE_NAMES = {"bending_xz": "flap", "bending_xy": "edge"}
_AXES = dict(direction=(0.0, 0.0, 1.0), reference_vector=(0.0, 1.0, 0.0))


def blade_length():
    """The blade's length from its root at the hub radius to the tip, m (61.5)."""
    return ROTOR["diameter"].value / 2 - ROTOR["hub_radius"].value


def _table():
    return np.array(NREL5MW_BLADE_STRUCTURE, dtype=float)


@functools.lru_cache(maxsize=1)
def _mass_scale():
    t = _table()
    arc, density = t[:, 0] * blade_length(), t[:, 2]
    return BLADE["mass"].value / float(np.sum(np.diff(arc) * (density[1:] + density[:-1]) / 2))


#: the factor on the table's mass per length that makes the blade's mass the published
#: 17,740 kg (1.05315; see the module text)
MASS_SCALE = _mass_scale()


def nrel5mw_blade_stations():
    """The blade's station table for :class:`~kanedyn.flexible.BeamMember` (along body z).

    Returns
    -------
    dict of str to ndarray, shape (49,)
        ``arc`` (m from the root), ``mass_per_length`` (kg/m, scaled by
        :data:`MASS_SCALE`), ``EI_y`` (flapwise, N m^2), ``EI_z`` (edgewise),
        ``EA`` (N) and ``GJ`` (N m^2) (stiff stand-ins) and ``twist`` (rad,
        minus the structural twist: see the module text).
    """
    t = _table()
    n = len(t)
    return {"arc": t[:, 0] * blade_length(), "mass_per_length": t[:, 2] * MASS_SCALE,
            "EA": np.full(n, AXIAL_STIFFNESS), "GJ": np.full(n, TORSIONAL_STIFFNESS),
            "EI_y": t[:, 3], "EI_z": t[:, 4], "twist": -np.radians(t[:, 1])}


def nrel5mw_blade_member(node_arcs=None, *, elements=None, name="blade"):
    """The blade as Euler-Bernoulli beam elements, root at the origin, span along body z.

    Each element's local y axis is body y turned by the structural twist, so
    that ``EI_y`` (the flap stiffness) resists deflection along body x.

    Parameters
    ----------
    node_arcs : sequence of float, optional
        Node positions along the span from the root, m (from 0 to 61.5).
        Default: the AeroDyn blade stations (19 nodes), where the
        aerodynamic loads act.
    elements : int, optional
        Equal elements instead of ``node_arcs``.
    name : str

    Returns
    -------
    BeamMember
    """
    if elements is not None:
        if node_arcs is not None:
            raise ModelError("nrel5mw blade: give node_arcs or elements, not both")
        return BeamMember(name, nrel5mw_blade_stations(), n_elements=elements, **_AXES)
    if node_arcs is None:    # the AeroDyn stations; its last (61.4999 m) at the tip
        from ._nrel5mw_blade import nrel5mw_blade
        node_arcs = np.array(nrel5mw_blade()[0].span, float)
        node_arcs[-1] = blade_length()
    return BeamMember(name, nrel5mw_blade_stations(), node_arcs=node_arcs, **_AXES)


def nrel5mw_blade_modes(node_arcs=None, *, elements=None, name="blade",
                        damping=None):
    """The blade clamped at its root, reduced to its first flap, first edge and second flap modes.

    Craig-Bampton with the root as the reference node and no interface nodes:
    the lowest fixed-interface normal modes of the non-rotating blade, named by
    their dominant bending plane (:data:`BLADE_MODE_NAMES`), scaled to a
    largest nodal translation of 1 m, with structural damping of ``damping``
    of critical in each (the blade's own modal mass: ElastoDyn's definition).

    Parameters
    ----------
    node_arcs, elements, name
        As :func:`nrel5mw_blade_member`.
    damping : float, optional
        Damping ratio, a fraction of critical; default the published
        0.477465 % (``BLADE.damping_ratio``); 0: none.

    Returns
    -------
    ReducedMember
        Modes ``flap_1``, ``edge_1``, ``flap_2``; ``full_frequencies``: the
        FE model's, Hz.
    """
    damping = BLADE["damping_ratio"].value if damping is None else damping
    if isinstance(damping, bool) or not (isinstance(damping, (int, float))
                                         and math.isfinite(damping) and 0 <= damping < 1):
        raise ModelError(f"nrel5mw blade: damping must be a fraction of critical in [0, 1), "
                         f"got {damping!r}")
    member = nrel5mw_blade_member(node_arcs, elements=elements, name=name)
    reduced = member.craig_bampton(n_modes=6)
    names = []
    for n in reduced.mode_names:
        plane, _, k = n.rpartition("_")
        names.append(f"{_PLANE_NAMES.get(plane, plane)}_{k}")
    reduced = replace(reduced, mode_names=tuple(names))
    missing = [n for n in BLADE_MODE_NAMES if n not in names]
    if missing:
        raise ModelError(f"nrel5mw blade: modes {missing} not among the lowest six "
                         f"({', '.join(names)}); use more nodes")
    kept = reduced.keep_modes(list(BLADE_MODE_NAMES))
    kept = replace(kept, full_frequencies=np.array(
        [reduced.full_frequencies[names.index(n)] for n in BLADE_MODE_NAMES]))
    return kept.with_damping(ratios=damping) if damping > 0 else kept
