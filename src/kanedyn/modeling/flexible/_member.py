r"""Finite-element members: beams from station tables, or matrices from elsewhere.

A member is a set of nodes (positions in the body frame, m) with six degrees
of freedom each, ordered per node as :math:`(u_x, u_y, u_z, \theta_x,
\theta_y, \theta_z)` in body-frame components (node :math:`k` owns rows
:math:`6k \ldots 6k+5`), a mass and a stiffness matrix over them.  Members
are reduced to a :class:`~kanedyn.modeling.flexible.ReducedMember` by
component mode synthesis (:meth:`FEMember.craig_bampton`,
:meth:`FEMember.guyan`, :meth:`FEMember.free_free`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._errors import ModelError, OptionError
from ._beam import PARTS, beam_element, element_axes, element_transformation
from ._eigen import DENSE_LIMIT, elastic_modes
from ._lazy_scipy import sp
from ._matrices import check_matrix, read_matrix
from ._reduction import craig_bampton, free_free, guyan, reduce_member
from ._stations import StationTable

__all__ = ["FEMember", "BeamMember", "NodeMass"]

_DOF_INDEX = {"ux": 0, "uy": 1, "uz": 2, "rx": 3, "ry": 4, "rz": 5}
_DOF_GROUPS = {"all": tuple(range(6)), "translations": (0, 1, 2), "rotations": (3, 4, 5)}


@dataclass(frozen=True)
class NodeMass:
    """A rigid mass attached to a node of a member (a tip mass, a nacelle, a payload).

    Parameters
    ----------
    node : int
        The node it is attached to (negative counts from the last node).
    mass : float
        kg, non-negative.
    inertia : array_like, shape (3,) or (3, 3), optional
        Inertia about the mass's own centre, kg m^2, in body-frame components
        (three values: the diagonal).  Default: a point mass (zero).
    offset : array_like, shape (3,), optional
        Position of the mass's centre relative to the node, m, body frame.
        Default: at the node.

    Notes
    -----
    Its 6 x 6 contribution to the node's mass matrix is

    .. math::

        \\begin{bmatrix} m\\,1 & -m\\,\\tilde r \\\\ m\\,\\tilde r &
        I_c - m\\,\\tilde r\\,\\tilde r \\end{bmatrix},

    with :math:`\\tilde r` the cross-product matrix of the offset.
    """

    node: int
    mass: float
    inertia: object = None
    offset: object = None

    def matrix(self, member="?"):
        """The 6 x 6 mass matrix at the node, kg, kg m, kg m^2 (validates the values)."""
        where = f"member {member!r}: the node mass at node {self.node}"
        m = float(self.mass)
        if not np.isfinite(m) or m < 0:
            raise ModelError(f"{where} has mass {self.mass!r}: it must be a non-negative number")
        inertia = np.zeros((3, 3)) if self.inertia is None else np.asarray(self.inertia, float)
        if inertia.shape == (3,):
            inertia = np.diag(inertia)
        if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)):
            raise ModelError(f"{where}: inertia must be 3 values (the diagonal) or a 3 x 3 "
                             f"matrix, got shape {inertia.shape}")
        scale = max(float(np.max(np.abs(inertia))), 1e-300)
        if np.max(np.abs(inertia - inertia.T)) > 1e-10 * scale:
            raise ModelError(f"{where}: the inertia matrix is not symmetric")
        if np.linalg.eigvalsh(inertia)[0] < -1e-10 * scale:
            raise ModelError(f"{where}: the inertia matrix is not positive semidefinite "
                             f"(eigenvalues {np.linalg.eigvalsh(inertia)})")
        r = np.zeros(3) if self.offset is None else np.asarray(self.offset, float)
        if r.shape != (3,) or not np.all(np.isfinite(r)):
            raise ModelError(f"{where}: offset must be 3 numbers (m), got {self.offset!r}")
        rt = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        out = np.zeros((6, 6))
        out[:3, :3] = m * np.eye(3)
        out[:3, 3:] = -m * rt
        out[3:, :3] = m * rt
        out[3:, 3:] = inertia - m * rt @ rt
        return out


def _freeze(A):
    if sp.issparse(A):
        return sp.csr_array(A)
    A = np.array(A, dtype=float)
    A.setflags(write=False)
    return A


class FEMember:
    """A finite-element member given by its nodes, mass and stiffness matrices.

    Build one with :meth:`from_matrices` (matrices computed elsewhere) or as a
    :class:`BeamMember`; reduce it with :meth:`craig_bampton`, :meth:`guyan`,
    :meth:`free_free` or :meth:`reduce`.

    Attributes
    ----------
    name : str
    nodes : ndarray, shape (n, 3)
        Node positions in the body frame, m.
    mass_matrix, stiffness_matrix : ndarray or scipy.sparse.csr_array, shape (6n, 6n)
        Including the node masses.
    elements : tuple
        ``(node_a, node_b, BeamElement, rotation)`` per beam element (empty for
        members given as matrices).
    summary : str
        How the member was built.
    """

    elements = ()

    def __init__(self, name, nodes, mass_matrix, stiffness_matrix, *, node_masses=(),
                 tolerance=1e-8, summary=None, _checked=False):
        if not isinstance(name, str) or not name:
            raise ModelError(f"a member needs a non-empty name (str), got {name!r}")
        self.name = name
        nodes = np.array(nodes, dtype=float)
        if nodes.ndim != 2 or nodes.shape[1] != 3 or len(nodes) == 0:
            raise ModelError(f"member {name!r}: nodes must be an array of shape (n, 3) (m), got "
                             f"shape {nodes.shape}")
        if not np.all(np.isfinite(nodes)):
            raise ModelError(f"member {name!r}: node positions must be finite numbers")
        nodes.setflags(write=False)
        self.nodes = nodes
        N = 6 * len(nodes)
        matrices = {}
        for what, A in (("mass", mass_matrix), ("stiffness", stiffness_matrix)):
            if not _checked:
                A = check_matrix(name, what, A, len(nodes), tolerance)
            matrices[what] = A
        extra = self._node_mass_blocks(node_masses)
        if extra:
            M = matrices["mass"]
            if sp.issparse(M):
                rows, cols, vals = [], [], []
                for k, block in extra:
                    r, c = np.meshgrid(range(6 * k, 6 * k + 6), range(6 * k, 6 * k + 6),
                                       indexing="ij")
                    rows.append(r.ravel())
                    cols.append(c.ravel())
                    vals.append(block.ravel())
                M = M + sp.csr_array((np.concatenate(vals),
                                      (np.concatenate(rows), np.concatenate(cols))),
                                     shape=(N, N))
            else:
                M = np.array(M, dtype=float)
                for k, block in extra:
                    M[6 * k:6 * k + 6, 6 * k:6 * k + 6] += block
            matrices["mass"] = M
        self.node_masses = tuple(node_masses)
        self.mass_matrix = _freeze(matrices["mass"])
        self.stiffness_matrix = _freeze(matrices["stiffness"])
        self.summary = summary or f"matrices of {N} degrees of freedom at {len(nodes)} nodes"

    @classmethod
    def from_matrices(cls, name, mass, stiffness, nodes, *, node_masses=(), tolerance=1e-8):
        """A member from mass and stiffness matrices computed elsewhere.

        Parameters
        ----------
        name : str
            The member's name.
        mass, stiffness : ndarray, scipy.sparse array or matrix, str or Path
            The matrices, shape (6n, 6n), or Matrix Market files
            (:func:`scipy.io.mmread`).  Degrees of freedom are ordered per node
            as ``ux, uy, uz, rx, ry, rz`` in body-frame components (node ``k``
            owns rows ``6k .. 6k+5``); units kg, kg m, kg m^2 and N/m, N, N m.
            Nodes without rotational stiffness and mass (solid elements) are
            allowed.
        nodes : array_like, shape (n, 3)
            Node positions in the body frame, m.
        node_masses : sequence of NodeMass
            Rigid masses added at nodes.
        tolerance : float
            Relative tolerance of the symmetry and semidefiniteness checks.

        Returns
        -------
        FEMember

        Raises
        ------
        ModelError
            A file that cannot be read, a matrix that is not square, does not
            have 6 degrees of freedom per node, has non-finite entries, is not
            symmetric or not positive semidefinite (the message names the
            member, the matrix and by how much).

        Examples
        --------
        >>> import numpy as np
        >>> k = 1e3 * np.eye(12); k[:6, 6:] = k[6:, :6] = -1e3 * np.eye(6)
        >>> member = FEMember.from_matrices("spring", np.eye(12), k + np.eye(12),
        ...                                 [[0, 0, 0], [1, 0, 0]])
        >>> member.mass_matrix.shape
        (12, 12)
        """
        mass = read_matrix(name, "mass", mass) if isinstance(mass, (str, Path)) else mass
        stiffness = (read_matrix(name, "stiffness", stiffness)
                     if isinstance(stiffness, (str, Path)) else stiffness)
        return cls(name, nodes, mass, stiffness, node_masses=node_masses, tolerance=tolerance)

    # ------------------------------------------------------------------ nodes
    @property
    def n_nodes(self):
        return len(self.nodes)

    def node_index(self, k, what="node"):
        """The index of node ``k`` (negative counts from the last), checked."""
        n = len(self.nodes)
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise ModelError(f"member {self.name!r}: {what} {k!r} is not a node index (int)")
        if not -n <= k < n:
            raise ModelError(f"member {self.name!r}: {what} {k} does not exist (nodes 0..{n - 1})")
        return int(k) % n

    def _node_mass_blocks(self, node_masses):
        blocks = []
        for item in node_masses:
            if not isinstance(item, NodeMass):
                raise ModelError(f"member {self.name!r}: node masses must be NodeMass objects, "
                                 f"got {item!r}")
            k = self.node_index(item.node, "node of a node mass")
            blocks.append((k, item.matrix(self.name)))
        return blocks

    def stiffness_parts(self):
        """Stiffness split by kind (axial, torsion, two bending planes), or ``None``."""
        return None

    # ------------------------------------------------------------ frequencies
    def _supports(self, supports):
        if not hasattr(supports, "items"):
            raise OptionError(f"member {self.name!r}: supports must map node indices to "
                              f"'all', 'translations', 'rotations' or dof names "
                              f"(ux uy uz rx ry rz), got {supports!r}")
        fixed = []
        for node, dofs in supports.items():
            k = self.node_index(node, "supported node")
            if isinstance(dofs, str):
                names = _DOF_GROUPS.get(dofs)
                if names is None:
                    names = [_DOF_INDEX.get(d, d) for d in dofs.split()]
            else:
                names = [_DOF_INDEX.get(d, d) for d in dofs]
            for d in names:
                if d not in range(6):
                    raise OptionError(f"member {self.name!r}: support {dofs!r} at node {node}: "
                                      f"use 'all', 'translations', 'rotations' or dof names "
                                      f"ux uy uz rx ry rz")
                fixed.append(6 * k + d)
        return fixed

    def natural_modes(self, count=None, *, supports, max_frequency=None, solver="auto"):
        """Lowest elastic natural modes of the full model on the given supports.

        Rigid-body motions that the supports leave free are removed exactly
        (they are not returned): a free member gives its elastic free–free
        modes, a pinned one its flexible modes.

        Parameters
        ----------
        count : int, optional
            Number of modes; or give ``max_frequency`` (Hz).
        supports : mapping of int to str or sequence of str
            Held degrees of freedom per node: ``"all"``, ``"translations"``,
            ``"rotations"``, or dof names such as ``"ux uy uz"``; ``{}`` for a
            free member.
        max_frequency : float, optional
            All modes up to this frequency, Hz.
        solver : {"auto", "dense", "sparse"}

        Returns
        -------
        frequencies : ndarray, shape (k,)
            Hz, ascending.
        modes : ndarray, shape (6n, k)
            Unit modal mass.
        """
        if (count is None) == (max_frequency is None):
            raise OptionError(f"member {self.name!r}: give exactly one of count and "
                              f"max_frequency (Hz)")
        max_omega2 = None if max_frequency is None else (2 * np.pi * max_frequency) ** 2
        omega2, X, _ = elastic_modes(self.name, self.stiffness_matrix, self.mass_matrix,
                                     self.nodes, self._supports(supports), count=count,
                                     max_omega2=max_omega2, solver=solver,
                                     what="natural modes")
        return np.sqrt(omega2) / (2 * np.pi), X

    def natural_frequencies(self, count=None, *, supports, max_frequency=None, solver="auto"):
        """The frequencies (Hz) of :meth:`natural_modes`."""
        return self.natural_modes(count, supports=supports, max_frequency=max_frequency,
                                  solver=solver)[0]

    # -------------------------------------------------------------- reduction
    def craig_bampton(self, interface_nodes=(), *, n_modes=None, max_frequency=None,
                      reference_node=0, solver="auto"):
        """Craig–Bampton reduction; see :func:`kanedyn.modeling.flexible._reduction.craig_bampton`.

        Parameters
        ----------
        interface_nodes : sequence of int
            Nodes with static constraint modes (joints and loads attach there).
        n_modes : int, optional
            Fixed-interface normal modes by count ...
        max_frequency : float, optional
            ... or all up to this frequency, Hz.
        reference_node : int
            The node clamped to the body frame.
        solver : {"auto", "dense", "sparse"}

        Returns
        -------
        ReducedMember
        """
        return craig_bampton(self, interface_nodes, n_modes=n_modes,
                             max_frequency=max_frequency, reference_node=reference_node,
                             solver=solver)

    def guyan(self, interface_nodes, *, reference_node=0, solver="auto"):
        """Guyan (static) reduction on ``interface_nodes``: Craig–Bampton with no normal modes.

        Returns
        -------
        ReducedMember
        """
        return guyan(self, interface_nodes, reference_node=reference_node, solver=solver)

    def free_free(self, *, n_modes=None, max_frequency=None, reference_node=0,
                  interface_nodes=(), solver="auto"):
        """Free–free elastic modes relative to the reference node's frame.

        Returns
        -------
        ReducedMember
        """
        return free_free(self, n_modes=n_modes, max_frequency=max_frequency,
                         reference_node=reference_node, interface_nodes=interface_nodes,
                         solver=solver)

    def reduce(self, method="craig-bampton", **options):
        """Reduce by the method named: ``"craig-bampton"``, ``"guyan"`` or ``"free-free"``.

        ``options`` are those of the method.

        Returns
        -------
        ReducedMember
        """
        return reduce_member(self, method, **options)

    def __repr__(self):
        return f"<{type(self).__name__} {self.name!r}: {self.summary}>"


class BeamMember(FEMember):
    """A beam member from a table of section properties along its length.

    Parameters
    ----------
    name : str
        The member's name.
    stations : mapping of str to sequence of float
        Section properties at stations along the member (a dict of columns or
        a pandas DataFrame): ``arc`` (m), ``mass_per_length`` (kg/m), ``EA``
        (N), ``GJ`` (N m^2), ``EI_y``, ``EI_z`` (N m^2), optional
        ``rotary_inertia_y``, ``rotary_inertia_z``, ``polar_inertia`` (kg m),
        ``shear_stiffness_y``, ``shear_stiffness_z`` (kappa G A, N; given,
        that bending plane is a Timoshenko beam) and ``twist`` (rad, the
        structural twist: each element's local y and z axes turned about its
        axis, right-handed, by the mean of ``twist`` over the element).  See
        :class:`~kanedyn.modeling.flexible._stations.StationTable`.  The
        properties vary linearly between stations; the element matrices
        integrate that variation exactly.
    n_elements : int, optional
        Number of equal elements from the first to the last station.
    direction : array_like, shape (3,), optional
        The member's axis in the body frame (default ``(1, 0, 0)``); node 0
        (the first station) is at the origin.
    reference_vector : array_like, shape (3,), optional
        Fixes each element's local y axis (its part perpendicular to the
        element's axis, then turned by the ``twist`` column if given); local
        z = x × y.  Default: body y, or body z for elements parallel to body y.
    node_arcs : sequence of float, optional
        Arc positions of the nodes, m, increasing, within the stations
        (instead of ``n_elements``).
    polyline : array_like, shape (n, 3), optional
        Node positions in the body frame, m (instead of ``n_elements`` and
        ``direction``): straight elements between consecutive nodes; arc
        positions are measured along the polyline from the first station.
    node_masses : sequence of NodeMass
        Rigid masses at nodes.
    sparse : bool, optional
        Store the matrices as SciPy sparse arrays (default: beyond 3000
        degrees of freedom).

    Examples
    --------
    >>> member = BeamMember.uniform("rod", 2.0, mass_per_length=1.0, EA=1e7, GJ=1e3,
    ...                             EI_y=1e4, EI_z=1e4, n_elements=8)
    >>> reduced = member.craig_bampton(n_modes=2)
    >>> reduced.mode_names
    ('bending_xy_1', 'bending_xz_1')
    """

    def __init__(self, name, stations, n_elements=None, *, direction=None,
                 reference_vector=None, node_arcs=None, polyline=None, node_masses=(),
                 sparse=None):
        if not isinstance(name, str) or not name:
            raise ModelError(f"a member needs a non-empty name (str), got {name!r}")
        table = stations if isinstance(stations, StationTable) else StationTable(name, stations)
        self.stations = table
        s0, s1 = table.span
        given = [k for k, v in (("n_elements", n_elements), ("node_arcs", node_arcs),
                                ("polyline", polyline)) if v is not None]
        if len(given) != 1:
            raise OptionError(f"member {name!r}: give exactly one of n_elements, node_arcs and "
                              f"polyline, got {given or 'none'}")
        if polyline is not None:
            if direction is not None:
                raise OptionError(f"member {name!r}: a polyline fixes the axis; do not give "
                                  f"direction as well")
            nodes = np.asarray(polyline, float)
            if nodes.ndim != 2 or nodes.shape[1] != 3 or len(nodes) < 2:
                raise ModelError(f"member {name!r}: polyline must have shape (n, 3) with n >= 2, "
                                 f"got {nodes.shape}")
            lengths = np.linalg.norm(np.diff(nodes, axis=0), axis=1)
            if np.any(lengths <= 0):
                i = int(np.argmax(lengths <= 0))
                raise ModelError(f"member {name!r}: polyline nodes {i} and {i + 1} coincide")
            arcs = s0 + np.concatenate([[0.0], np.cumsum(lengths)])
        else:
            axis = np.asarray((1.0, 0.0, 0.0) if direction is None else direction, float)
            if axis.shape != (3,) or not np.linalg.norm(axis) > 0:
                raise ModelError(f"member {name!r}: direction must be a nonzero 3-vector, got "
                                 f"{direction!r}")
            axis = axis / np.linalg.norm(axis)
            if n_elements is not None:
                if isinstance(n_elements, bool) or not isinstance(n_elements, (int, np.integer)) \
                        or n_elements < 1:
                    raise OptionError(f"member {name!r}: n_elements must be a positive integer, "
                                      f"got {n_elements!r}")
                arcs = np.linspace(s0, s1, int(n_elements) + 1)
            else:
                arcs = np.asarray(node_arcs, float)
                if arcs.ndim != 1 or len(arcs) < 2 or np.any(np.diff(arcs) <= 0):
                    raise ModelError(f"member {name!r}: node_arcs must be at least two "
                                     f"strictly increasing arc positions (m)")
            nodes = np.outer(arcs - s0, axis)
        tol = 1e-9 * max(abs(s0), abs(s1), s1 - s0)
        if arcs[0] < s0 - tol or arcs[-1] > s1 + tol:
            raise ModelError(f"member {name!r}: the nodes span arc {arcs[0]:g} .. {arcs[-1]:g} m "
                             f"but the stations only {s0:g} .. {s1:g} m")
        arcs = np.clip(arcs, s0, s1)
        self.node_arcs = arcs
        elements = []
        for e in range(len(nodes) - 1):
            a, b = arcs[e], arcs[e + 1]
            axis_e = nodes[e + 1] - nodes[e]
            ref = self._reference(name, e, axis_e, reference_vector)
            rotation = element_axes(axis_e, ref)
            if "twist" in table.columns:   # the principal axes turned about the element axis
                angle = table.mean("twist", a, b)
                c, s_ = np.cos(angle), np.sin(angle)
                rotation = np.vstack([rotation[0], c * rotation[1] + s_ * rotation[2],
                                      c * rotation[2] - s_ * rotation[1]])

            def section(xi, a=a, b=b):
                return table.at(a + (b - a) * xi)

            element = beam_element(float(np.linalg.norm(axis_e)), section, table.breaks(a, b))
            elements.append((e, e + 1, element, rotation))
        self.elements = tuple(elements)
        N = 6 * len(nodes)
        self._sparse = N > DENSE_LIMIT if sparse is None else bool(sparse)
        K = self._assemble(lambda el: el.stiffness)
        M = self._assemble(lambda el: el.mass)
        self._parts = None
        kinds = {"Timoshenko" if any(el.shear_parameters.values()) else "Euler–Bernoulli"
                 for _, _, el, _ in elements}
        summary = (f"{len(elements)} {'/'.join(sorted(kinds))} beam elements, {len(nodes)} "
                   f"nodes, {len(table.arcs)} stations")
        if "twist" in table.columns:
            summary += ", structural twist"
        if "polar_inertia" not in table.columns:
            summary += "; twist carries no inertia (no polar or rotary inertia given)"
        super().__init__(name, nodes, M, K, node_masses=node_masses, summary=summary,
                         _checked=True)

    @classmethod
    def uniform(cls, name, length, *, mass_per_length, EA, GJ, EI_y, EI_z,
                rotary_inertia_y=None, rotary_inertia_z=None, polar_inertia=None,
                shear_stiffness_y=None, shear_stiffness_z=None, **options):
        """A uniform beam of the given length (two stations with equal properties).

        Parameters are the station columns as numbers (see :class:`BeamMember`)
        and ``length`` (m); ``options`` go to :class:`BeamMember`
        (``n_elements``, ``direction``, ``node_masses``, ...).
        """
        if not np.isfinite(length) or length <= 0:
            raise ModelError(f"member {name!r}: length must be positive, got {length!r}")
        table = {"arc": [0.0, float(length)]}
        for key, value in dict(mass_per_length=mass_per_length, EA=EA, GJ=GJ, EI_y=EI_y,
                               EI_z=EI_z, rotary_inertia_y=rotary_inertia_y,
                               rotary_inertia_z=rotary_inertia_z, polar_inertia=polar_inertia,
                               shear_stiffness_y=shear_stiffness_y,
                               shear_stiffness_z=shear_stiffness_z).items():
            if value is not None:
                table[key] = [value, value]
        return cls(name, table, **options)

    @staticmethod
    def _reference(name, e, axis, reference_vector):
        axis = axis / np.linalg.norm(axis)
        if reference_vector is None:
            y = np.array([0.0, 1.0, 0.0])
            return y if abs(axis @ y) < 1 - 1e-9 else np.array([0.0, 0.0, 1.0])
        ref = np.asarray(reference_vector, float)
        if ref.shape != (3,):
            raise ModelError(f"member {name!r}: reference_vector must be a 3-vector, got "
                             f"{reference_vector!r}")
        if np.linalg.norm(ref - (ref @ axis) * axis) < 1e-9 * np.linalg.norm(ref):
            raise ModelError(f"member {name!r}: reference_vector {tuple(ref)} is parallel to "
                             f"element {e}'s axis")
        return ref

    def _assemble(self, pick):
        N = 6 * (len(self.elements) + 1)
        if self._sparse:
            rows, cols, vals = [], [], []
        else:
            A = np.zeros((N, N))
        for a, b, element, rotation in self.elements:
            T = element_transformation(rotation)
            block = T.T @ pick(element) @ T
            idx = np.r_[6 * a:6 * a + 6, 6 * b:6 * b + 6]
            if self._sparse:
                r, c = np.meshgrid(idx, idx, indexing="ij")
                rows.append(r.ravel())
                cols.append(c.ravel())
                vals.append(block.ravel())
            else:
                A[np.ix_(idx, idx)] += block
        if self._sparse:
            return sp.csr_array((np.concatenate(vals), (np.concatenate(rows),
                                                         np.concatenate(cols))), shape=(N, N))
        return A

    def stiffness_parts(self):
        """The assembled stiffness split by kind: axial, torsion, bending_xy, bending_xz.

        Returns
        -------
        dict of str to ndarray or sparse, shape (6n, 6n)
        """
        if self._parts is None:
            self._parts = {p: self._assemble(lambda el, p=p: el.stiffness_parts[p])
                           for p in PARTS}
        return self._parts

    def geometric_stiffness(self, axial_force=1.0):
        """The assembled geometric stiffness, shape (6n, 6n).

        Parameters
        ----------
        axial_force : float or array_like, shape (n_elements,)
            Axial force in each element, N (tension positive); default 1 N.

        Returns
        -------
        ndarray or sparse
            ``K + K_G`` is the stiffness under that axial load.
        """
        force = np.broadcast_to(np.asarray(axial_force, float), (len(self.elements),))
        forces = {id(el): f for (_, _, el, _), f in zip(self.elements, force)}
        return self._assemble(lambda el: forces[id(el)] * el.geometric_stiffness)

    def node_at(self, arc):
        """Index of the node at arc position ``arc`` (m); raises if there is none."""
        i = int(np.argmin(np.abs(self.node_arcs - arc)))
        span = self.node_arcs[-1] - self.node_arcs[0]
        if abs(self.node_arcs[i] - arc) > 1e-9 * span:
            raise ModelError(f"member {self.name!r}: no node at arc {arc:g} m (nearest: node {i} "
                             f"at {self.node_arcs[i]:g} m)")
        return i

    def properties_at(self, arc):
        """Section properties interpolated at arc positions ``arc`` (m): dict of name to array."""
        return self.stations.at(arc)
