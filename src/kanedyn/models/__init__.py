"""Built-in models, usable from Python and from the CLI (``kanedyn list``).

>>> import kanedyn as kd
>>> definition = kd.models.build("pendulum")
>>> eom = definition.derive()
>>> model = definition.numeric(eom)
"""

from __future__ import annotations

from .._errors import ModelError
from ._base import ModelDefinition
from ._bicycle_analysis import eigenvalues_vs_speed, stability_speeds, upright_state
from ._classic import chain3d, chaplygin_sleigh, four_bar, n_link_pendulum_on_cart, pendulum
from ._constraint_models import block_wedge, knife_edge, pin_slot, rod_bead, rolling_disk_contact
from ._flexible_models import flexible_robot, spin_up_beam
from ._contact_models import (bead_in_tube, block_on_incline, bouncing_ball, falling_rod, ladder,
                              slug_ellipsoid, sphere_slug)
from ._iftomm import n_four_bar, n_four_bar_exact, n_four_bar_singular_times
from ._parallel import (PLANAR_3RRR_GEOMETRY, STEWART_GEOMETRY, newton_ik, planar_3rrr,
                        planar_3rrr_ik, quintic_pose, sinusoid_pose, stewart_anchors,
                        stewart_leg_lengths, stewart_platform)
from ._out_parallel import (OUT_PARALLEL_GEOMETRY, OUT_PARALLEL_INERTIA, out_parallel_6dof,
                            out_parallel_anchors, out_parallel_ik)
from ._oc3_spar import OC3_SPAR_OPTIONS, oc3_settle, oc3_spar, oc3_static_offsets
from ._oc3_tower import oc3_rna_node_mass, oc3_tower, oc3_tower_member, oc3_tower_rna_basis
from ._nonholonomic import nonholonomic_particle, sphere_on_turntable
from ._rolling import MEIJAARD_2007, rolling_disk, whipple_bicycle
from ._shuttle_arm import shuttle_arm
from ._snake import snake
from ._urdf import JointInfo, URDFDefinition, URDFError, Visual, from_urdf

__all__ = ["ModelDefinition", "REGISTRY", "build", "available", "pendulum",
           "n_link_pendulum_on_cart", "chain3d", "chaplygin_sleigh", "four_bar",
           "rolling_disk", "whipple_bicycle", "MEIJAARD_2007", "sphere_slug",
           "slug_ellipsoid", "block_on_incline", "bead_in_tube", "bouncing_ball", "ladder",
           "falling_rod",
           "nonholonomic_particle", "sphere_on_turntable", "rod_bead", "pin_slot", "knife_edge",
           "rolling_disk_contact", "block_wedge", "snake", "shuttle_arm", "n_four_bar",
           "n_four_bar_exact", "n_four_bar_singular_times", "spin_up_beam", "flexible_robot",
           "eigenvalues_vs_speed", "stability_speeds", "upright_state",
           "from_urdf", "URDFDefinition", "URDFError", "JointInfo", "Visual",
           "planar_3rrr", "PLANAR_3RRR_GEOMETRY", "planar_3rrr_ik", "newton_ik",
           "quintic_pose", "sinusoid_pose", "stewart_platform", "STEWART_GEOMETRY",
           "stewart_anchors", "stewart_leg_lengths", "out_parallel_6dof",
           "OUT_PARALLEL_GEOMETRY", "OUT_PARALLEL_INERTIA", "out_parallel_anchors",
           "out_parallel_ik", "oc3_spar", "oc3_settle", "oc3_static_offsets", "oc3_tower",
           "oc3_tower_member", "oc3_rna_node_mass", "oc3_tower_rna_basis",
           "OC3_SPAR_OPTIONS"]

#: name -> (builder, {option: type})
REGISTRY = {
    "pendulum": (pendulum, {"tension": bool}),
    "n-link-pendulum-on-cart": (n_link_pendulum_on_cart, {"n": int}),
    "chain3d": (chain3d, {"n": int, "style": str}),
    "rolling-disk": (rolling_disk, {"normal_force": bool}),
    "chaplygin-sleigh": (chaplygin_sleigh, {"lateral_force": bool}),
    "four-bar": (four_bar, {}),
    "whipple-bicycle": (whipple_bicycle, {}),
    "sphere-slug": (sphere_slug, {}),
    "slug-ellipsoid": (slug_ellipsoid, {}),
    "block-on-incline": (block_on_incline, {}),
    "bead-in-tube": (bead_in_tube, {"omega": float}),
    "bouncing-ball": (bouncing_ball, {"restitution": float}),
    "ladder": (ladder, {"frictionless": bool, "angle": float}),
    "falling-rod": (falling_rod, {"angle": float, "restitution": float, "mu": float,
                                   "law": str}),
    "nonholonomic-particle": (nonholonomic_particle, {}),
    "sphere-turntable": (sphere_on_turntable, {}),
    "rod-bead": (rod_bead, {}),
    "pin-slot": (pin_slot, {}),
    "knife-edge": (knife_edge, {}),
    "rolling-disk-contact": (rolling_disk_contact, {}),
    "block-wedge": (block_wedge, {}),
    "snake": (snake, {"n": int}),
    "shuttle-arm": (shuttle_arm, {"payload": bool, "flexible_booms": bool}),
    "n-four-bar": (n_four_bar, {"n": int}),
    "spin-up-beam": (spin_up_beam, {"omega_s": float, "stiffening": bool, "n_modes": int,
                                    "n_elements": int}),
    "flexible-robot": (flexible_robot, {"n_modes": int, "n_elements": int,
                                        "stiffening": bool}),
    "3rrr": (planar_3rrr, {"gravity": bool}),
    "stewart-platform": (stewart_platform, {}),
    "out-parallel-6dof": (out_parallel_6dof, {}),
    "oc3-spar": (oc3_spar, dict(OC3_SPAR_OPTIONS)),
}


def available():
    """``[(name, title)]`` of the built-in models."""
    return [(name, builder().title) for name, (builder, _) in REGISTRY.items()]


def build(name, **options):
    """A fresh :class:`ModelDefinition` of the named built-in model.

    Parameters
    ----------
    name : str
        One of :data:`REGISTRY` (``kanedyn list``).
    **options
        Model options, e.g. ``n=8`` for ``chain3d``.
    """
    try:
        builder, allowed = REGISTRY[name]
    except KeyError:
        raise ModelError(f"unknown model {name!r}; available: "
                         f"{', '.join(REGISTRY)}") from None
    unknown = set(options) - set(allowed)
    if unknown:
        raise ModelError(f"model {name} has no option(s) {sorted(unknown)}; "
                         f"its options: {sorted(allowed) or 'none'}")
    return builder(**options)
