r"""Component mode synthesis: Craig–Bampton, Guyan and free–free reduction.

Every reduction returns a :class:`~kanedyn.modeling.flexible.ReducedMember`
whose body frame is clamped to the member's *reference node*: the modes are
zero there, and the reduced frequencies are those of the member clamped at
that node (what a flexible body attached by its reference node to a rigid
frame has).

Craig–Bampton
    The reference node is clamped; the other interface nodes (where joints and
    loads attach) are held too while the lowest *fixed-interface normal modes*
    are computed; each of the 6 degrees of freedom of each interface node then
    gets a *static constraint mode* (unit displacement there, the others held,
    the interior in static equilibrium: :math:`\Psi = -K_{ii}^{-1}K_{ib}`).
    The reduced frequencies are upper bounds of the full model's (Rayleigh–Ritz)
    and decrease monotonically as normal modes are added.
Guyan
    Craig–Bampton with no normal modes: static condensation on the interface
    nodes.
Free–free
    The elastic modes of the unsupported member (orthogonal in mass to its six
    rigid-body motions), each minus the rigid-body motion of the reference
    node, so that they are zero there; the stiffness is unchanged by that shift
    (rigid motion stores no strain energy) and the span of rigid motion plus
    modes is the span of rigid motion plus free–free modes, so a floating body
    built on them has exactly the free–free frequencies.

Normal modes are scaled so that their largest nodal translation is 1 m per
unit modal coordinate, with its largest component positive (a mode without
translation, such as torsion of a straight member: largest rotation 1 rad).
Modes of equal frequency (a section with :math:`EI_y = EI_z`) are rotated
within their eigenspace so that each bends in one plane.  Beam members name
their normal modes by the part of the strain energy that dominates (``axial_1``, ``torsion_1``,
``bending_xy_1``, ``bending_xz_1``, ...); constraint modes are named
``constraint_<node>_<dof>`` with dof one of ``ux uy uz rx ry rz``.

Second-order displacement
    For beam members, node :math:`k`'s foreshortening
    :math:`G_{k,:,i,j} = -\sum_e t_e\,\Phi_{e,i}^T K_{G,e}\,\Phi_{e,j}`, the sum
    over the elements between the reference node and :math:`k`, :math:`t_e`
    the element's unit axis pointing away from the reference node and
    :math:`K_{G,e}` its geometric stiffness per unit axial force.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ..._errors import ModelError, OptionError
from ._beam import PARTS, element_transformation
from ._eigen import _use_dense, elastic_modes, lowest_modes, submatrix
from ._lazy_scipy import sla, sp, spla
from ._reduced import ReducedMember, reduced_frequencies

__all__ = ["craig_bampton", "guyan", "free_free", "reduce_member", "REDUCTIONS", "DOF_NAMES",
           "second_order_displacement"]

DOF_NAMES = ("ux", "uy", "uz", "rx", "ry", "rz")
#: relative gap in omega^2 below which modes count as one eigenspace
_DEGENERATE = 1e-8


def _dofs(node):
    return list(range(6 * node, 6 * node + 6))


def _mode_count(member, n_modes, max_frequency, method):
    if (n_modes is None) == (max_frequency is None):
        raise OptionError(f"member {member.name!r}: {method} needs exactly one of n_modes (a "
                          f"number of modes) and max_frequency (a cut-off, Hz)")
    if n_modes is not None:
        if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) \
                or n_modes < 0:
            raise OptionError(f"member {member.name!r}: n_modes must be a non-negative "
                              f"integer, got {n_modes!r}")
        return int(n_modes), None
    if not np.isfinite(max_frequency) or max_frequency <= 0:
        raise OptionError(f"member {member.name!r}: max_frequency must be a positive number of "
                          f"Hz, got {max_frequency!r}")
    return None, (2 * np.pi * float(max_frequency)) ** 2


def _interface(member, interface_nodes, reference):
    nodes = [member.node_index(k, "interface node") for k in interface_nodes]
    if len(set(nodes)) != len(nodes):
        raise ModelError(f"member {member.name!r}: interface nodes {tuple(interface_nodes)} "
                         f"name a node twice")
    return tuple(nodes)


def _characteristic_length(nodes, reference):
    size = float(np.max(np.linalg.norm(nodes - nodes[reference], axis=1)))
    return size if size > 0 else 1.0


def _scale_modes(V, nodes, reference):
    """Scale each column so that its largest nodal translation (else rotation) is 1.

    The node whose translation vector is longest gets a translation of length
    1 m, with its largest component positive.
    """
    n = len(nodes)
    length = _characteristic_length(nodes, reference)
    V = V.copy()
    for j in range(V.shape[1]):
        block = V[:, j].reshape(n, 6)
        trans, rot = block[:, :3], block[:, 3:]
        part = trans if np.max(np.abs(trans)) >= 1e-6 * np.max(np.abs(rot)) * length else rot
        norms = np.linalg.norm(part, axis=1)
        k = int(np.argmax(norms))
        V[:, j] /= norms[k] * np.sign(part[k, np.argmax(np.abs(part[k]))])
    return V


def _align_and_name(member, omega2, V, prefix):
    """Rotate degenerate eigenspaces onto single stiffness parts; name the modes."""
    parts = member.stiffness_parts()
    if parts is None:
        return V, tuple(f"{prefix}_{j + 1}" for j in range(V.shape[1]))
    V = V.copy()
    start = 0
    while start < len(omega2):
        stop = start + 1
        while stop < len(omega2) and omega2[stop] - omega2[stop - 1] <= _DEGENERATE * omega2[stop]:
            stop += 1
        if stop - start > 1:
            Vc = V[:, start:stop]
            weighted = sum((w + 1.0) * (Vc.T @ (parts[p] @ Vc)) for w, p in enumerate(PARTS))
            _, Q = np.linalg.eigh(0.5 * (weighted + weighted.T))
            V[:, start:stop] = Vc @ Q
        start = stop
    energy = np.array([np.einsum("ij,ij->j", V, parts[p] @ V) for p in PARTS])
    counts = dict.fromkeys(PARTS, 0)
    names = []
    for j in range(V.shape[1]):
        p = PARTS[int(np.argmax(energy[:, j]))]
        counts[p] += 1
        names.append(f"{p}_{counts[p]}")
    return V, tuple(names)


def second_order_displacement(member, modes, reference):
    """Second-order (foreshortening) translation of every node, shape (n, 3, m, m).

    ``None`` for members without beam elements.
    """
    elements = member.elements
    if not elements:
        return None
    n, m = len(member.nodes), modes.shape[1]
    adjacent = {k: [] for k in range(n)}
    for e, (a, b, _, _) in enumerate(elements):
        adjacent[a].append((e, b))
        adjacent[b].append((e, a))
    G = np.zeros((n, 3, m, m))
    seen = {reference}
    queue = deque([reference])
    while queue:
        parent = queue.popleft()
        for e, child in adjacent[parent]:
            if child in seen:
                continue
            a, b, element, rotation = elements[e]
            d = element_transformation(rotation) @ modes[_dofs(a) + _dofs(b)]
            C = d.T @ element.geometric_stiffness @ d
            t = rotation[0] if child == b else -rotation[0]
            G[child] = G[parent] - np.einsum("x,ij->xij", t, 0.5 * (C + C.T))
            seen.add(child)
            queue.append(child)
    return G


def _clamped_frequencies(member, reference, count, solver):
    """Lowest ``count`` (or fewer, if no more are finite) clamped frequencies, Hz."""
    K, M = member.stiffness_matrix, member.mass_matrix
    free = np.setdiff1d(np.arange(K.shape[0]), _dofs(reference))
    omega2, _ = lowest_modes(member.name, submatrix(K, free, free), submatrix(M, free, free),
                             count=min(count, len(free)), solver=solver, allow_fewer=True)
    return np.sqrt(omega2) / (2 * np.pi)


def _constraint_modes(member, interior, boundary, solver):
    K = member.stiffness_matrix
    Kii = submatrix(K, interior, interior)
    Kib = submatrix(K, interior, boundary)
    try:
        if _use_dense(len(interior), solver):
            Kii = Kii.toarray() if sp.issparse(Kii) else Kii
            Kib = Kib.toarray() if sp.issparse(Kib) else Kib
            return -sla.solve(Kii, Kib, assume_a="pos")
        lu = spla.splu(sp.csc_array(Kii))
        return -lu.solve(Kib.toarray() if sp.issparse(Kib) else np.asarray(Kib))
    except (np.linalg.LinAlgError, RuntimeError) as exc:
        raise ModelError(f"member {member.name!r}: the stiffness matrix is singular with the "
                         f"reference and interface nodes held (part of the member can move "
                         f"without deforming): {exc}") from None


def _finish(member, reference, interface, modes, names, description, solver):
    K, M = member.stiffness_matrix, member.mass_matrix
    reduced = reduced_frequencies(K, M, modes)
    full = _clamped_frequencies(member, reference, max(len(reduced), 1), solver)
    nodes = member.nodes - member.nodes[reference]
    return ReducedMember(
        name=member.name, nodes=nodes, mass_matrix=M, stiffness_matrix=K, modes=modes,
        second_order=second_order_displacement(member, modes, reference),
        reference_node=reference, interface_nodes=interface, mode_names=tuple(names),
        full_frequencies=full, reduced_frequencies=reduced,
        description=f"{description}; {member.summary}")


def craig_bampton(member, interface_nodes=(), *, n_modes=None, max_frequency=None,
                  reference_node=0, solver="auto"):
    """Craig–Bampton reduction: fixed-interface normal modes plus static constraint modes.

    Parameters
    ----------
    member : FEMember
        The finite-element member.
    interface_nodes : sequence of int
        Nodes where joints and loads attach besides the reference node
        (negative indices count from the last node).  Each gets six static
        constraint modes; the reference node may be listed, it is clamped.
    n_modes : int, optional
        Number of fixed-interface normal modes.
    max_frequency : float, optional
        Keep all fixed-interface normal modes up to this frequency, Hz.
        Exactly one of ``n_modes`` and ``max_frequency`` is given.
    reference_node : int
        The node clamped to the body frame.
    solver : {"auto", "dense", "sparse"}
        ``"dense"``: :func:`scipy.linalg.eigh`; ``"sparse"``:
        :func:`scipy.sparse.linalg.eigsh` in shift-invert mode; ``"auto"``:
        dense up to 3000 degrees of freedom.

    Returns
    -------
    ReducedMember
        ``m = k + 6 * (number of interface nodes other than the reference)``
        modes: the ``k`` normal modes first, then the constraint modes.
    """
    count, max_omega2 = _mode_count(member, n_modes, max_frequency, "Craig–Bampton")
    _check_solver(member, solver)
    reference = member.node_index(reference_node, "reference node")
    interface = _interface(member, interface_nodes, reference)
    others = [k for k in interface if k != reference]
    N = 6 * len(member.nodes)
    boundary = [i for k in others for i in _dofs(k)]
    held = _dofs(reference) + boundary
    interior = np.setdiff1d(np.arange(N), held)
    omega2, X, _ = elastic_modes(member.name, member.stiffness_matrix, member.mass_matrix,
                                 member.nodes, held, count=count, max_omega2=max_omega2,
                                 solver=solver, what="fixed-interface normal modes")
    X, names = _align_and_name(member, omega2, X, "normal")
    X = _scale_modes(X, member.nodes, reference)
    modes = np.zeros((N, X.shape[1] + len(boundary)))
    modes[:, :X.shape[1]] = X
    if boundary:
        Psi = _constraint_modes(member, interior, boundary, solver)
        cols = np.arange(X.shape[1], modes.shape[1])
        modes[np.asarray(boundary), cols] = 1.0
        modes[np.ix_(interior, cols)] = Psi
        names = names + tuple(f"constraint_{k}_{d}" for k in others for d in DOF_NAMES)
    if modes.shape[1] == 0:
        raise ModelError(f"member {member.name!r}: the reduction has no modes (no normal modes "
                         f"and no interface nodes besides the reference node)")
    kind = "Guyan reduction" if X.shape[1] == 0 else "Craig–Bampton"
    cutoff = "" if max_frequency is None else f" up to {max_frequency:g} Hz"
    description = (f"{kind}: {X.shape[1]} fixed-interface normal mode(s){cutoff} + "
                   f"{len(boundary)} static constraint mode(s) at node(s) {tuple(others)}; "
                   f"reference node {reference} clamped")
    return _finish(member, reference, interface, modes, names, description, solver)


def guyan(member, interface_nodes, *, reference_node=0, solver="auto"):
    """Guyan (static) reduction on the interface nodes: Craig–Bampton with no normal modes.

    Parameters
    ----------
    member : FEMember
    interface_nodes : sequence of int
        Nodes kept (at least one besides the reference node).
    reference_node : int
    solver : {"auto", "dense", "sparse"}

    Returns
    -------
    ReducedMember
        ``6 * (number of interface nodes other than the reference)`` modes.
    """
    return craig_bampton(member, interface_nodes, n_modes=0, reference_node=reference_node,
                         solver=solver)


def free_free(member, *, n_modes=None, max_frequency=None, reference_node=0,
              interface_nodes=(), solver="auto"):
    """Free–free elastic modes, measured from the reference node's frame.

    Parameters
    ----------
    member : FEMember
    n_modes : int, optional
        Number of elastic free–free modes.
    max_frequency : float, optional
        Keep all elastic free–free modes up to this frequency, Hz.
    reference_node : int
        The node that carries the body frame; the modes are zero there.
    interface_nodes : sequence of int
        Nodes where joints and loads attach (recorded; free–free modes do not
        represent them exactly).
    solver : {"auto", "dense", "sparse"}

    Returns
    -------
    ReducedMember
        Its description lists the free–free frequencies; ``reduced_frequencies``
        are those of the basis with the reference node clamped.
    """
    count, max_omega2 = _mode_count(member, n_modes, max_frequency, "the free–free reduction")
    _check_solver(member, solver)
    reference = member.node_index(reference_node, "reference node")
    interface = _interface(member, interface_nodes, reference)
    omega2, _, Y = elastic_modes(member.name, member.stiffness_matrix, member.mass_matrix,
                                 member.nodes, (), count=count, max_omega2=max_omega2,
                                 pivots=_dofs(reference), solver=solver,
                                 what="free–free modes")
    if Y.shape[1] == 0:
        raise ModelError(f"member {member.name!r}: no free–free mode below "
                         f"{max_frequency:g} Hz")
    Y, names = _align_and_name(member, omega2, Y, "free")
    Y = _scale_modes(Y, member.nodes, reference)
    hz = ", ".join(f"{f:.6g}" for f in np.sqrt(omega2) / (2 * np.pi))
    description = (f"free–free: {Y.shape[1]} elastic mode(s) (free–free frequencies {hz} Hz) "
                   f"relative to reference node {reference}")
    return _finish(member, reference, interface, Y, names, description, solver)


#: reduction methods by name, for :meth:`FEMember.reduce`
REDUCTIONS = {"craig-bampton": craig_bampton, "guyan": guyan, "free-free": free_free}


def reduce_member(member, method, **options):
    """Reduce ``member`` by the method named (``"craig-bampton"``, ``"guyan"``, ``"free-free"``)."""
    try:
        function = REDUCTIONS[method]
    except (KeyError, TypeError):
        raise OptionError(f"member {member.name!r}: unknown reduction method {method!r}; "
                          f"choose one of {', '.join(REDUCTIONS)}") from None
    return function(member, **options)


def _check_solver(member, solver):
    if solver not in ("auto", "dense", "sparse"):
        raise OptionError(f"member {member.name!r}: solver must be 'auto', 'dense' or 'sparse', "
                          f"got {solver!r}")
