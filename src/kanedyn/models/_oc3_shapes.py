"""How the 3D viewer draws the OC3-Hywind turbine: the spar, the tower and the
rotor-nacelle assembly at their published sizes (``ModelDefinition.shape_specs``).

Offsets are from each body's mass centre in its frame (the platform's ``B``,
the tower top's ``A``; z up the tower, x downwind); lengths in metres from
:mod:`kanedyn.models._oc3_data`.  The spar's conical taper is drawn as a
cylinder of the mean diameter; a flexible tower is drawn by the viewer as its
deformed member, a rigid one as a cylinder of the mean diameter.
"""

from __future__ import annotations

from ._oc3_data import PLATFORM, ROTOR, TOWER

__all__ = ["oc3_shape_specs"]

#: nacelle box (fore-aft, side, height), m, and its centre downwind of the yaw axis
NACELLE = ((14.0, 4.0, 4.0), 4.0)
HUB_RADIUS = 1.8  # m
ROTOR_DISC = 0.6  # m, thickness of the (translucent) swept disc


def _v(group, key):
    return group[key].value


def _cylinder(body, bottom, top, diameter, centre_z, **options):
    return ("Cylinder", body, dict(radius=diameter / 2, length=top - bottom, axis="z",
                                   offset=(0.0, 0.0, (bottom + top) / 2 - centre_z),
                                   **options))


def oc3_shape_specs(platform, tower, rna, rigid_tower_cm_z, rna_cm, top_z):
    """Shape specs of the turbine's bodies.

    Parameters
    ----------
    platform, tower, rna : bodies
    rigid_tower_cm_z : float or None
        The rigid tower's mass centre above the SWL, m; None for a flexible tower.
    rna_cm : tuple of 2 float
        The RNA's mass centre from the tower top (downwind x, up z), m.
    top_z : float
        The tower top above the SWL, m.

    Returns
    -------
    tuple
        ``(kind, body, options)`` for :class:`~kanedyn.models.ModelDefinition`.
    """
    cm = _v(PLATFORM, "cm_z")
    specs = [
        _cylinder(platform, _v(PLATFORM, "taper_top_z"), _v(PLATFORM, "top_z"),
                  _v(PLATFORM, "upper_diameter"), cm),
        _cylinder(platform, _v(PLATFORM, "taper_bottom_z"), _v(PLATFORM, "taper_top_z"),
                  (_v(PLATFORM, "upper_diameter") + _v(PLATFORM, "lower_diameter")) / 2, cm),
        _cylinder(platform, -_v(PLATFORM, "draft"), _v(PLATFORM, "taper_bottom_z"),
                  _v(PLATFORM, "lower_diameter"), cm),
    ]
    if rigid_tower_cm_z is not None:
        specs.append(_cylinder(tower, _v(TOWER, "base_z"), _v(TOWER, "top_z"),
                               (_v(TOWER, "base_diameter") + _v(TOWER, "top_diameter")) / 2,
                               rigid_tower_cm_z))
    cx, cz = rna_cm
    (length, width, height), downwind = NACELLE
    hub = (-_v(ROTOR, "overhang") - cx, 0.0, _v(ROTOR, "hub_height") - top_z - cz)
    specs += [
        ("Box", rna, dict(lengths=(length, width, height),
                          offset=(downwind - cx, 0.0, height / 2 - cz))),
        ("Sphere", rna, dict(radius=HUB_RADIUS, offset=hub)),
        ("Cylinder", rna, dict(radius=_v(ROTOR, "diameter") / 2, length=ROTOR_DISC,
                               axis="x", offset=hub, opacity=0.3)),
    ]
    return tuple(specs)
