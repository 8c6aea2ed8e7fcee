r"""A reduced elastic member: what a flexible body needs of its finite-element model.

The finite-element side (:mod:`kanedyn.modeling.flexible`) produces it by
component mode synthesis; the formulation side (:class:`kanedyn.FlexibleBody`)
consumes it.  Everything is expressed in the body frame :math:`B` whose origin
is the member's *reference node* (the node clamped to the frame: the root of a
cantilever, the hub attachment of a robot link).

Nodal degrees of freedom are ordered per node as
:math:`(u_x, u_y, u_z, \theta_x, \theta_y, \theta_z)` in :math:`B` components,
so node :math:`k` owns rows :math:`6k \ldots 6k+5`.

The displacement of node :math:`k` for modal coordinates :math:`\eta` is

.. math::

    u_k(\eta) = \Phi_k\,\eta + \tfrac12\sum_{ij} G_{k,:,i,j}\,\eta_i\eta_j ,
    \qquad \theta_k(\eta) = \Psi_k\,\eta ,

with :math:`\Phi_k` (3 x m) and :math:`\Psi_k` (3 x m) the translational and
rotational rows of :attr:`ReducedMember.modes`, and :math:`G` the second-order
(foreshortening) displacement of the nodes that makes motion-induced
(geometric) stiffening part of the kinematics (Kane, Ryan & Banerjee 1987).

Structural damping
------------------
A member may carry a damping matrix :math:`D` on its modal coordinates (the
dissipation function :math:`\tfrac12\dot\eta^T D\,\dot\eta`, generalized force
:math:`-D\dot\eta`), set by :meth:`ReducedMember.with_damping` from damping
ratios per mode or Rayleigh coefficients (:func:`damping_matrix`).  A member
built from matrices or beam elements carries none (:attr:`ReducedMember.damping`
is ``None``): it is undamped unless its user gives damping, here or to the
:class:`~kanedyn.FlexibleBody` (``rayleigh=``, ``modal_damping=``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..._errors import ModelError
from ._lazy_scipy import sla

__all__ = ["ReducedMember", "reduced_frequencies", "damping_matrix"]


@dataclass(frozen=True, eq=False)
class ReducedMember:
    r"""A finite-element member reduced to ``m`` modal coordinates.

    Attributes
    ----------
    name : str
        The member's name (errors and reports use it).
    nodes : ndarray, shape (n, 3)
        Reference (undeformed) node positions in the body frame, m; node
        ``reference_node`` is at the origin of the body frame.
    mass_matrix : ndarray or scipy.sparse matrix, shape (6n, 6n)
        Finite-element mass matrix (consistent or lumped), kg and kg m^2,
        symmetric positive semidefinite, with the rigid-body inertia of the
        member (total mass, first and second moments about the reference node).
    stiffness_matrix : ndarray or scipy.sparse matrix, shape (6n, 6n)
        Finite-element stiffness matrix, N/m, N/rad, N m/rad.
    modes : ndarray, shape (6n, m)
        Displacement of every nodal degree of freedom per unit modal
        coordinate (the reduction basis expanded to all nodes: fixed-interface
        normal modes and static constraint modes, or free-free modes, ...);
        zero at the reference node's degrees of freedom.
    second_order : ndarray, shape (n, 3, m, m), or None
        :math:`G`: second-order (foreshortening) translation of each node,
        symmetric in the last two indices; ``None`` when unknown (members
        imported as matrices), which rules out geometric stiffening.
    reference_node : int
        Index of the node clamped to the body frame.
    interface_nodes : tuple of int
        Nodes where joints and loads attach (kept exactly by the reduction).
    mode_names : tuple of str
        A name per modal coordinate (e.g. ``"bending_y_1"``, ``"constraint_3_uy"``).
    full_frequencies, reduced_frequencies : ndarray
        Natural frequencies, Hz, of the full model with the reference node
        clamped and of the reduced model (for the report).
    description : str
        How the member was built and reduced.
    damping : ndarray, shape (m, m), or None
        Structural damping matrix :math:`D` of the modal coordinates (N s/m per
        unit modal speed: generalized force :math:`-D\dot\eta`), symmetric
        positive semidefinite; ``None`` (the default of every member kanedyn
        builds from matrices or beam elements): no damping of the member's own,
        a flexible body on it is undamped unless it is given ``rayleigh=`` or
        ``modal_damping=``.  Set it with :meth:`with_damping`.
    """

    name: str
    nodes: np.ndarray
    mass_matrix: object
    stiffness_matrix: object
    modes: np.ndarray
    second_order: np.ndarray | None = None
    reference_node: int = 0
    interface_nodes: tuple = ()
    mode_names: tuple = ()
    full_frequencies: np.ndarray = field(default_factory=lambda: np.zeros(0))
    reduced_frequencies: np.ndarray = field(default_factory=lambda: np.zeros(0))
    description: str = ""
    damping: np.ndarray | None = None

    def __post_init__(self):
        n = np.shape(self.nodes)[0]
        if np.shape(self.nodes) != (n, 3):
            raise ModelError(f"member {self.name!r}: nodes must have shape (n, 3), got "
                             f"{np.shape(self.nodes)}")
        for what in ("mass_matrix", "stiffness_matrix"):
            if np.shape(getattr(self, what)) != (6 * n, 6 * n):
                raise ModelError(f"member {self.name!r}: {what} must be {6 * n} x {6 * n} "
                                 f"(6 degrees of freedom per node), got "
                                 f"{np.shape(getattr(self, what))}")
        if np.ndim(self.modes) != 2 or np.shape(self.modes)[0] != 6 * n:
            raise ModelError(f"member {self.name!r}: modes must have shape ({6 * n}, m), got "
                             f"{np.shape(self.modes)}")
        m = np.shape(self.modes)[1]
        if self.second_order is not None and np.shape(self.second_order) != (n, 3, m, m):
            raise ModelError(f"member {self.name!r}: second_order must have shape "
                             f"({n}, 3, {m}, {m}), got {np.shape(self.second_order)}")
        if not 0 <= self.reference_node < n:
            raise ModelError(f"member {self.name!r}: reference node {self.reference_node} "
                             f"does not exist (nodes 0..{n - 1})")
        for k in self.interface_nodes:
            if not 0 <= k < n:
                raise ModelError(f"member {self.name!r}: interface node {k} does not exist "
                                 f"(nodes 0..{n - 1})")
        if self.mode_names and len(self.mode_names) != m:
            raise ModelError(f"member {self.name!r}: {len(self.mode_names)} mode names for "
                             f"{m} modes")
        if self.damping is not None:
            object.__setattr__(self, "damping", _checked_damping(self.name, self.damping, m))

    @property
    def n_nodes(self):
        return np.shape(self.nodes)[0]

    @property
    def n_modes(self):
        return np.shape(self.modes)[1]

    def modal_mass(self):
        """:math:`\\Phi^T M \\Phi`, shape (m, m)."""
        return np.asarray(self.modes.T @ (self.mass_matrix @ self.modes))

    def modal_stiffness(self):
        """:math:`\\Phi^T K \\Phi`, shape (m, m)."""
        return np.asarray(self.modes.T @ (self.stiffness_matrix @ self.modes))

    def node_modes(self, k):
        """``(Phi_k, Psi_k)``: translation and rotation of node ``k`` per mode, (3, m) each."""
        rows = self.modes[6 * k:6 * k + 6]
        return np.asarray(rows[:3]), np.asarray(rows[3:])

    def keep_modes(self, which):
        """The same member with only some of its modal coordinates.

        A subset of a reduction basis is again a Ritz basis, e.g. the
        in-plane bending modes of a beam that only bends in its plane of
        motion (fewer states, the same answer when the others stay unexcited).

        Parameters
        ----------
        which : sequence of str or int, or str
            Mode names (:attr:`mode_names`) or indices to keep, in the order
            wanted; a single string keeps every mode whose name starts with it
            (``"bending_xy"``).

        Returns
        -------
        ReducedMember
            With the chosen columns of :attr:`modes` and :attr:`second_order`,
            its reduced frequencies recomputed and no full-model frequencies
            (which of them the subset stands for is not known).
        """
        names = list(self.mode_names) or [f"mode_{j + 1}" for j in range(self.n_modes)]
        if isinstance(which, str):
            index = [j for j, name in enumerate(names) if name.startswith(which)]
            if not index:
                raise ModelError(f"member {self.name!r}: no mode name starts with {which!r}; "
                                 f"modes: {', '.join(names)}")
        else:
            index = []
            for item in which:
                if isinstance(item, str):
                    if item not in names:
                        raise ModelError(f"member {self.name!r}: no mode named {item!r}; "
                                         f"modes: {', '.join(names)}")
                    index.append(names.index(item))
                elif isinstance(item, (int, np.integer)) and -self.n_modes <= item < self.n_modes:
                    index.append(int(item) % self.n_modes)
                else:
                    raise ModelError(f"member {self.name!r}: mode {item!r} does not exist "
                                     f"({self.n_modes} modes)")
        if len(set(index)) != len(index):
            raise ModelError(f"member {self.name!r}: a mode is named twice in {which!r}")
        modes = self.modes[:, index]
        G = None if self.second_order is None else self.second_order[:, :, index][:, :, :, index]
        kept = [names[j] for j in index]
        frequencies = reduced_frequencies(self.stiffness_matrix, self.mass_matrix, modes)
        damping = None if self.damping is None else self.damping[np.ix_(index, index)]
        return replace(self, modes=modes, second_order=G, mode_names=tuple(kept),
                       full_frequencies=np.zeros(0), reduced_frequencies=frequencies,
                       description=f"{self.description}; kept {', '.join(kept)}",
                       damping=damping)

    def with_damping(self, ratios=None, rayleigh=None, modal_mass=None):
        r"""The same member carrying structural damping (:attr:`damping`).

        Give exactly one of ``ratios`` and ``rayleigh`` (see
        :func:`damping_matrix` for the formulas).  A flexible body built on
        the result takes this damping; giving it ``rayleigh=`` or
        ``modal_damping=`` as well is refused (the damping is given once).

        Parameters
        ----------
        ratios : float or sequence of float, optional
            Damping ratio :math:`\zeta_i` of each modal coordinate, as a
            fraction of critical (0.01 is 1 %; one number: every coordinate);
            ``0 <= zeta < 1``.  Needs a basis that diagonalizes the modal
            stiffness and the reference modal mass (normal modes only).
        rayleigh : (float, float), optional
            ``(alpha, beta)`` in 1/s and s: :math:`D = \alpha M_\eta + \beta K_\eta`.
        modal_mass : array_like, shape (m, m), optional
            The modal mass the ratios (or ``alpha``) refer to, kg; default the
            member's own :meth:`modal_mass`.  Give the modal mass of the member
            *with* what is attached to it (a rotor-nacelle mass at a tower
            top, a payload) to set the ratios of the modes of the assembly on
            a held base: the member's own mass gives ratios of the member
            alone.

        Returns
        -------
        ReducedMember

        Raises
        ------
        ModelError
            A value that is not finite, negative, a ratio of 1 or more (a
            percentage given as a fraction?), the wrong number of ratios, or
            ratios on a basis that does not diagonalize the mass and stiffness.

        Examples
        --------
        >>> damped = member.with_damping(ratios=0.01)          # doctest: +SKIP
        >>> damped = member.with_damping(rayleigh=(0.0, 2e-3))  # doctest: +SKIP
        """
        D = damping_matrix(self, ratios=ratios, rayleigh=rayleigh, modal_mass=modal_mass,
                           what=f"member {self.name!r}")
        return replace(self, damping=D)

    def frequency_comparison(self):
        """Full-model and reduced-model frequencies side by side.

        Returns
        -------
        ndarray, shape (k, 3)
            Per row: the full model's frequency (Hz, reference node clamped),
            the reduced model's (Hz) and their relative difference
            ``(reduced - full) / full``; ``k`` is the shorter of the two lists.
        """
        full = np.asarray(self.full_frequencies, float)
        reduced = np.asarray(self.reduced_frequencies, float)
        k = min(len(full), len(reduced))
        out = np.empty((k, 3))
        out[:, 0], out[:, 1] = full[:k], reduced[:k]
        with np.errstate(divide="ignore", invalid="ignore"):
            out[:, 2] = (reduced[:k] - full[:k]) / full[:k]
        return out

    def report(self):
        """A table of the reduced model's frequencies next to the full model's.

        Returns
        -------
        str
            The member, how it was reduced, then per mode: the full model's
            frequency (reference node clamped), the reduced model's and their
            relative difference (the reduced model's alone for a subset made by
            :meth:`keep_modes`); then the names of the modal coordinates.
            ``print(member.report())`` shows it.
        """
        lines = [f"member {self.name!r}: {self.n_nodes} nodes, {self.n_modes} modal "
                 f"coordinates", f"  {self.description}"]
        reduced = np.asarray(self.reduced_frequencies)
        if len(self.full_frequencies):
            comparison = self.frequency_comparison()
            lines.append(f"  {'mode':>4}  {'full (Hz)':>14}  {'reduced (Hz)':>14}  "
                         f"{'rel. diff':>10}")
            lines += [f"  {j:>4}  {full:>14.6g}  {red:>14.6g}  {rel:>10.2e}"
                      for j, (full, red, rel) in enumerate(comparison, start=1)]
            lines += [f"  {j:>4}  {'':>14}  {red:>14.6g}"
                      for j, red in enumerate(reduced[len(comparison):],
                                              start=len(comparison) + 1)]
        else:  # a subset of modes (keep_modes)
            lines.append(f"  {'mode':>4}  {'reduced (Hz)':>14}  (no full-model frequencies: "
                         f"which of them a subset of modes stands for is not known)")
            lines += [f"  {j:>4}  {red:>14.6g}" for j, red in enumerate(reduced, start=1)]
        if self.mode_names:
            lines.append(f"  modal coordinates: {', '.join(self.mode_names)}")
        return "\n".join(lines)


def damping_matrix(member, ratios=None, rayleigh=None, modal_mass=None, what=None,
                   names=("ratios", "rayleigh")):
    r"""The damping matrix of a member's modal coordinates, from ratios or Rayleigh coefficients.

    .. math::

        D = \mathrm{diag}\bigl(2\zeta_i\sqrt{k_i m_i}\bigr)
        \quad\text{(ratios)},\qquad
        D = \alpha M_\eta + \beta K_\eta \quad\text{(Rayleigh)},

    :math:`k_i, m_i` the diagonal of the modal stiffness
    :math:`K_\eta = \Phi^TK\Phi` and of the reference modal mass
    :math:`M_\eta` (default :math:`\Phi^TM\Phi`).  On a held base a
    coordinate then decays with :math:`\zeta_i` of critical when the mass it
    moves is :math:`m_i`; stiffness-proportional damping (:math:`\alpha = 0`)
    gives mode :math:`i` the ratio :math:`\beta\omega_i/2`.

    Parameters
    ----------
    member : ReducedMember
    ratios : float or sequence of float, optional
        :math:`\zeta_i`, fractions of critical, ``0 <= zeta < 1``.
    rayleigh : (float, float), optional
        ``(alpha, beta)`` >= 0, in 1/s and s.
    modal_mass : array_like, shape (m, m), optional
        Reference modal mass, kg (default the member's own).
    what : str, optional
        Who is asking, for the error messages (default: the member).
    names : (str, str)
        The option names the error messages use for ``ratios`` and
        ``rayleigh`` (a flexible body's ``modal_damping`` and ``rayleigh``).

    Returns
    -------
    ndarray, shape (m, m)
        N s/m per unit modal speed.

    Raises
    ------
    ModelError
        Both or neither given, values not finite or out of range, a ratios
        count other than the member's modes, or ratios on a basis whose modal
        stiffness or reference mass is not diagonal.
    """
    what = what or f"member {member.name!r}"
    ratio_name, rayleigh_name = names
    m = member.n_modes
    if (ratios is None) == (rayleigh is None):
        raise ModelError(f"{what}: give {rayleigh_name} or {ratio_name} (one of them)"
                         if ratios is None else
                         f"{what}: give {rayleigh_name} or {ratio_name}, not both")
    K = _symmetric(member.modal_stiffness())
    if modal_mass is None:
        M = _symmetric(member.modal_mass())
    else:
        M = np.asarray(modal_mass, dtype=float)
        if M.shape != (m, m) or not np.all(np.isfinite(M)):
            raise ModelError(f"{what}: modal_mass must be a finite {m} x {m} matrix, got "
                             f"shape {M.shape}")
        M = _symmetric(M)
    if rayleigh is not None:
        try:
            alpha, beta = (float(v) for v in rayleigh)
        except (TypeError, ValueError):
            raise ModelError(f"{what}: {rayleigh_name} must be two numbers (alpha in 1/s, "
                             f"beta in s), got {rayleigh!r}") from None
        if not (np.isfinite(alpha) and np.isfinite(beta) and alpha >= 0 and beta >= 0):
            raise ModelError(f"{what}: {rayleigh_name} coefficients must be finite and not "
                             f"negative (alpha in 1/s, beta in s), got {rayleigh!r}")
        return alpha * M + beta * K
    try:
        zeta = np.asarray(ratios, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ModelError(f"{what}: {ratio_name} must be numbers (fractions of critical), "
                         f"got {ratios!r}") from None
    if np.ndim(ratios) == 0:  # one number: every coordinate
        zeta = np.full(m, zeta[0])
    if zeta.shape != (m,):
        raise ModelError(f"{what}: {ratio_name}: {m} ratios needed (one per modal "
                         f"coordinate) or one number for all, got {zeta.size}")
    if not np.all(np.isfinite(zeta)) or np.any(zeta < 0):
        raise ModelError(f"{what}: {ratio_name} must be finite and not negative, got "
                         f"{ratios!r}")
    if np.any(zeta >= 1):
        raise ModelError(f"{what}: {ratio_name} are fractions of critical (0.01 is 1 %), "
                         f"got {zeta.max():g}: critical or beyond (was a percentage given?)")
    scale = max(np.abs(M).max(initial=0.0), 1e-300), max(np.abs(K).max(initial=0.0), 1e-300)
    for matrix, name, size in ((M, "mass", scale[0]), (K, "stiffness", scale[1])):
        if np.abs(matrix - np.diag(np.diag(matrix))).max(initial=0.0) > 1e-9 * size:
            raise ModelError(f"{what}: {ratio_name} need modes that diagonalize the modal "
                             f"{name} (normal modes only, e.g. no static constraint modes); "
                             f"use {rayleigh_name}=(alpha, beta) instead")
    return np.diag(2.0 * zeta * np.sqrt(np.clip(np.diag(K) * np.diag(M), 0.0, None)))


def _symmetric(a):
    a = np.asarray(a, dtype=float)
    return 0.5 * (a + a.T)


def _checked_damping(name, D, m):
    """``D`` as a float array after the checks of :attr:`ReducedMember.damping`."""
    try:
        D = np.array(D, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"member {name!r}: damping must be a {m} x {m} matrix of numbers "
                         "(N s/m per unit modal speed)") from None
    if D.shape != (m, m):
        raise ModelError(f"member {name!r}: damping must be {m} x {m} (one row per modal "
                         f"coordinate), got shape {D.shape}")
    if not np.all(np.isfinite(D)):
        raise ModelError(f"member {name!r}: damping must be finite")
    scale = max(np.abs(D).max(initial=0.0), 1e-300)
    if np.abs(D - D.T).max(initial=0.0) > 1e-12 * scale:
        raise ModelError(f"member {name!r}: damping must be symmetric")
    if m and np.linalg.eigvalsh(_symmetric(D)).min() < -1e-12 * scale:
        raise ModelError(f"member {name!r}: damping must be positive semidefinite (it "
                         "would feed energy into the member)")
    D.flags.writeable = False
    return D


def reduced_frequencies(K, M, modes):
    """Natural frequencies (Hz, ascending, rigid-body zeros left out) of K, M on ``modes``."""
    Kr = np.asarray(modes.T @ (K @ modes))
    Mr = np.asarray(modes.T @ (M @ modes))
    Kr, Mr = 0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T)
    if Kr.shape[0] == 0:
        return np.zeros(0)
    mu = sla.eigh(Mr, Kr, eigvals_only=True)[::-1]
    mu = mu[mu > 1e-13 * mu[0]]
    return np.sqrt(1.0 / mu) / (2 * np.pi)
