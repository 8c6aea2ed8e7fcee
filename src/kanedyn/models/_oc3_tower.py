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

Structural damping (:data:`TOWER_DAMPING_REFERENCES`): the reduced towers carry
a damping matrix (:attr:`~kanedyn.flexible.ReducedMember.damping`) that gives
each kept bending mode ``damping`` of critical, by default the published 1 %
(``TOWER.damping_ratio``).  The 5-MW definition gives it for every mode of the
*isolated* tower, without the rotor-nacelle assembly, and OpenFAST's ElastoDyn
applies it so: the modal damping :math:`d_i = 2\zeta k_i/\omega_{0,i}` with
:math:`\omega_{0,i}^2 = k_i/m_{0,i}` the kept (RNA-loaded) mode shape's Rayleigh
quotient on the tower without the RNA.  On a held base the tower carrying the
RNA then decays with :math:`\zeta\,\omega_i/\omega_{0,i}` of critical (0.29 % in
the first fore-aft mode, whose shape has 1.29 Hz on the tower without the RNA and
0.376 Hz with it).
``damping_reference="with_rna"`` instead gives the modes of the tower with the
RNA ``damping`` of critical on a held base (:math:`m_i` the loaded modal mass).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.linalg as sla

from .._errors import ModelError
from ..modeling import BeamMember, NodeMass
from ._oc3_data import RNA, TOWER, rna_inertia_about_cm, tower_stations

__all__ = ["oc3_tower_member", "oc3_tower", "oc3_rna_node_mass", "oc3_tower_rna_basis",
           "OC3_TOWER_DAMPING", "TOWER_DAMPING_REFERENCES"]

_PLANE_NAMES = {"bending_xz": "fore_aft", "bending_xy": "side_side"}

#: the published structural damping ratio of the tower modes (``TOWER.damping_ratio``)
OC3_TOWER_DAMPING = TOWER["damping_ratio"].value
#: what a tower damping ratio is a ratio of (see the module docstring)
TOWER_DAMPING_REFERENCES = ("isolated", "with_rna")


def _check_damping(damping, reference):
    """``float(damping)`` after the checks; errors name the option ``damping``."""
    if isinstance(damping, bool):
        raise ModelError(f"oc3 tower: damping must be a number (a fraction of critical, 0.01 "
                         f"is 1 %), got {damping!r}")
    try:
        value = float(damping)
    except (TypeError, ValueError):
        raise ModelError(f"oc3 tower: damping must be a number (a fraction of critical, 0.01 "
                         f"is 1 %), got {damping!r}") from None
    if not (np.isfinite(value) and 0.0 <= value < 1.0):
        raise ModelError(f"oc3 tower: damping must be a fraction of critical in [0, 1) (0.01 "
                         f"is 1 %, the published value), got {damping!r}")
    if reference not in TOWER_DAMPING_REFERENCES:
        raise ModelError(f"oc3 tower: damping_reference must be one of "
                         f"{', '.join(TOWER_DAMPING_REFERENCES)}, got {reference!r}")
    return value


def _damped(member, damping, reference, bare_mass, loaded_mass):
    """``member`` with the tower damping of the module docstring (none for ``damping == 0``).

    ``bare_mass``, ``loaded_mass``: the FE mass matrices of the tower without
    and with the RNA (``loaded_mass`` ``None`` when the RNA is not part of the model).
    """
    if damping == 0.0:
        return member
    V = np.asarray(member.modes)
    if reference == "isolated":
        # each kept shape's Rayleigh quotient on the bare tower (ElastoDyn's FreqTFA(i, 1))
        mass = np.diag(np.diag(np.asarray(V.T @ (bare_mass @ V))))
    else:
        if loaded_mass is None:
            raise ModelError("oc3 tower: damping_reference='with_rna' needs the RNA (rna=True)")
        mass = np.asarray(V.T @ (loaded_mass @ V))
    return member.with_damping(ratios=damping, modal_mass=mass)


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


def oc3_tower(elements=20, modes=4, *, rna=True, interface_nodes=(), name="tower",
              damping=OC3_TOWER_DAMPING, damping_reference="isolated"):
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
        modes are kept as well (and ``damping=0`` must be given: the damping
        ratios apply to bending modes only).
    name : str
    damping : float
        Structural damping ratio of every kept bending mode, a fraction of
        critical; default the published 1 % (``TOWER.damping_ratio``); 0: none.
    damping_reference : {"isolated", "with_rna"}
        ``"isolated"`` (the published definition, as OpenFAST applies it): a
        ratio of the tower without the RNA, see the module docstring;
        ``"with_rna"``: of the tower carrying the RNA (needs ``rna=True``).

    Returns
    -------
    ReducedMember
        Bending modes named ``fore_aft_1``, ``side_side_1``, ``fore_aft_2``,
        ...; constraint modes keep their ``constraint_<node>_<dof>`` names;
        ``damping``: the tower damping (``None`` for ``damping=0``).

    Raises
    ------
    ModelError
        Bad ``elements``, ``modes``, ``damping`` (not a fraction of critical in
        [0, 1)) or ``damping_reference``, each named.
    """
    if isinstance(modes, bool) or not isinstance(modes, int) or modes < 1:
        raise ModelError(f"oc3 tower: modes must be a positive integer, got {modes!r}")
    damping = _check_damping(damping, damping_reference)
    if interface_nodes and damping > 0:
        raise ModelError(f"oc3 tower: damping={damping:g} applies to bending modes only, and "
                         f"interface_nodes={tuple(interface_nodes)!r} add static constraint "
                         "modes: give damping=0 and damp the flexible body with "
                         "rayleigh=(alpha, beta)")
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
    kept = replace(kept, mode_names=tuple(names))
    if damping == 0.0:
        return kept
    bare = member.mass_matrix if not rna else oc3_tower_member(elements, rna=False).mass_matrix
    return _damped(kept, damping, damping_reference, bare, member.mass_matrix if rna else None)


def oc3_tower_rna_basis(elements=20, modes=4, *, name="tower", damping=OC3_TOWER_DAMPING,
                        damping_reference="isolated"):
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
    damping : float
        Structural damping ratio of every kept mode, a fraction of critical
        (default the published 1 %); 0: none.
    damping_reference : {"isolated", "with_rna"}
        What the ratio is a ratio of (see the module docstring): the tower
        without the RNA (the published definition, OpenFAST's; default) or
        the tower carrying it.

    Returns
    -------
    ReducedMember
        ``full_frequencies``: the loaded tower's (Hz); ``reduced_frequencies``:
        the bare tower's on this basis; ``damping``: the tower damping
        (``None`` for ``damping=0``).
    """
    damping = _check_damping(damping, damping_reference)
    loaded = oc3_tower(elements, modes, rna=True, name=name, damping=0.0)
    bare = oc3_tower_member(elements, rna=False, name=name)
    M = bare.mass_matrix
    V = loaded.modes
    w2 = sla.eigh(np.asarray(V.T @ (loaded.stiffness_matrix @ V)),
                  np.asarray(V.T @ (M @ V)), eigvals_only=True)
    basis = replace(loaded, mass_matrix=M, reduced_frequencies=np.sqrt(w2) / (2 * np.pi),
                    description=f"{loaded.description}; basis of the tower with the RNA "
                                f"lumped at its top, mass matrix of the tower alone")
    return _damped(basis, damping, damping_reference, M,
                   oc3_tower_member(elements, rna=True, name=name).mass_matrix)
