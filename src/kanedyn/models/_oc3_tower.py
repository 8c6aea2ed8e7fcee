r"""The OC3-Hywind tower as a flexible member, with the rotor-nacelle assembly at its top.

The tower frame has its origin at the tower base (10 m above SWL on the spar
axis), z up along the tower, x downwind (fore-aft), y to port (side-side).
Node 0 is the base (the reference node, clamped), the last node the tower top
(87.6 m above SWL).  Euler-Bernoulli beam elements with the station table's
properties interpolated linearly (:func:`~kanedyn.models._oc3_data.tower_stations`);
the RNA is a rigid mass at the top node (:class:`~kanedyn.flexible.NodeMass`: mass,
offset of its centre of mass, inertia about it).

Mode names: the member's local y axis is body y, so ``bending_xz`` modes
deflect along body x (fore-aft) and ``bending_xy`` modes along body y
(side-side); :func:`oc3_tower` renames them ``fore_aft_k`` and ``side_side_k``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.linalg as sla

from .._errors import ModelError
from ..modeling import BeamMember, NodeMass
from ._oc3_data import RNA, TOWER, rna_inertia_about_cm, tower_stations

__all__ = ["oc3_tower_member", "oc3_tower", "oc3_rna_node_mass", "oc3_tower_rna_basis"]

_PLANE_NAMES = {"bending_xz": "fore_aft", "bending_xy": "side_side"}


def oc3_rna_node_mass(node=-1):
    """The RNA as a :class:`~kanedyn.flexible.NodeMass` at ``node`` (default: the tower top).

    Mass 350,000 kg, centre of mass at (-0.414, 0, 1.967) m from the tower top,
    inertia about it from the published inertia about the tower top.
    """
    return NodeMass(node, RNA["mass"].value, inertia=rna_inertia_about_cm(),
                    offset=(RNA["cm_x"].value, 0.0, RNA["cm_z"].value))


def oc3_tower_member(elements=20, *, rna=True, name="tower"):
    """The OC3 tower as a finite-element member (base at the origin, axis along body z).

    Parameters
    ----------
    elements : int
        Number of equal Euler-Bernoulli beam elements over the 77.6 m.
    rna : bool
        Lump the rotor-nacelle assembly at the top node
        (:func:`oc3_rna_node_mass`).
    name : str

    Returns
    -------
    BeamMember
    """
    if isinstance(elements, bool) or not isinstance(elements, int) or elements < 1:
        raise ModelError(f"oc3 tower: elements must be a positive integer, got {elements!r}")
    if TOWER["top_z"].value <= TOWER["base_z"].value:
        raise ModelError("oc3 tower: the tower top must be above its base")
    return BeamMember(name, tower_stations(), n_elements=elements, direction=(0.0, 0.0, 1.0),
                      node_masses=(oc3_rna_node_mass(),) if rna else ())


def oc3_tower(elements=20, modes=4, *, rna=True, interface_nodes=(), name="tower"):
    """The OC3 tower reduced by Craig-Bampton to its lowest bending modes, clamped at the base.

    Parameters
    ----------
    elements : int
        Number of beam elements (:func:`oc3_tower_member`).
    modes : int
        Number of bending modes kept (fore-aft and side-side together, lowest
        first: ``modes=2`` keeps the first fore-aft and side-side modes).
    rna : bool
        Lump the RNA at the tower top.
    interface_nodes : sequence of int
        Nodes with static constraint modes (e.g. ``(-1,)`` to attach the RNA
        as a separate rigid body; then give ``rna=False``); their constraint
        modes are kept as well.
    name : str

    Returns
    -------
    ReducedMember
        Bending modes named ``fore_aft_1``, ``side_side_1``, ``fore_aft_2``,
        ...; constraint modes keep their ``constraint_<node>_<dof>`` names.
    """
    if isinstance(modes, bool) or not isinstance(modes, int) or modes < 1:
        raise ModelError(f"oc3 tower: modes must be a positive integer, got {modes!r}")
    member = oc3_tower_member(elements, rna=rna, name=name)
    # axial and torsion modes interleave with bending ones: ask for enough normal modes
    wanted = min(2 * modes + 6, 6 * elements - 6)
    reduced = member.craig_bampton(interface_nodes, n_modes=wanted)
    bending = [j for j, n in enumerate(reduced.mode_names)
               if n.startswith(("bending_xy", "bending_xz"))]
    if len(bending) < modes:
        raise ModelError(f"oc3 tower: only {len(bending)} bending modes among the "
                         f"{wanted} lowest with {elements} elements; use more elements")
    constraint = [j for j, n in enumerate(reduced.mode_names) if n.startswith("constraint")]
    kept = reduced.keep_modes(constraint + bending[:modes])
    names = []
    for n in kept.mode_names:
        plane, _, k = n.rpartition("_")
        names.append(f"{_PLANE_NAMES[plane]}_{k}" if plane in _PLANE_NAMES else n)
    return replace(kept, mode_names=tuple(names))


def oc3_tower_rna_basis(elements=20, modes=4, *, name="tower"):
    """The bare tower on the fixed-base modes of the tower carrying the RNA.

    The reduction basis (the ``modes`` columns, their names and second-order
    displacements) is that of :func:`oc3_tower` with the RNA lumped at the top
    node; the member's own mass and stiffness matrices are those of the tower
    alone.  A model that adds the RNA as a rigid body fixed to the top node's
    frame then has, on a held base, the reduced mass matrix
    :math:`\\Phi^T(M_{tower} + M_{RNA})\\Phi` and stiffness :math:`\\Phi^T K\\Phi`
    of the loaded tower: its frequencies are the tower+RNA's fixed-base FE
    frequencies of the kept modes (the basis vectors are their eigenvectors),
    and the RNA's mass is counted once.

    Parameters
    ----------
    elements, modes : int
        As :func:`oc3_tower`.
    name : str

    Returns
    -------
    ReducedMember
        ``full_frequencies``: the loaded tower's (Hz); ``reduced_frequencies``:
        the bare tower's on this basis.
    """
    loaded = oc3_tower(elements, modes, rna=True, name=name)
    bare = oc3_tower_member(elements, rna=False, name=name)
    M = bare.mass_matrix
    V = loaded.modes
    w2 = sla.eigh(np.asarray(V.T @ (loaded.stiffness_matrix @ V)),
                  np.asarray(V.T @ (M @ V)), eigvals_only=True)
    return replace(loaded, mass_matrix=M, reduced_frequencies=np.sqrt(w2) / (2 * np.pi),
                   description=f"{loaded.description}; basis of the tower with the RNA "
                               f"lumped at its top, mass matrix of the tower alone")
