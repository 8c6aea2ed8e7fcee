r"""A flexible body: a floating frame of reference plus modal coordinates.

Kinematics
----------
The body frame :math:`B` (origin :math:`O` at the member's reference node)
moves as the user orients it; the member deforms in :math:`B` with modal
coordinates :math:`\eta` (m), whose rates are the modal speeds
:math:`\zeta = \dot\eta`.  Node :math:`k` sits at

.. math::

    r_k(\eta) = x_k + \Phi_k\eta + \tfrac12\sum_{ij}G_{k,ij}\,\eta_i\eta_j ,
    \qquad \theta_k = \Psi_k\eta ,

the second-order (foreshortening) term making motion-induced stiffening part of
the kinematics (Kane, Ryan & Banerjee 1987); ``stiffening=False`` drops it (the
"conventional" linear modal model).  With the body-frame components
:math:`w = (v_O, \omega, \zeta)` of the origin's velocity, the angular velocity
and the modal speeds, the nodal velocities (translations and rotations) are
:math:`\dot U = \mathcal A(\eta)\,w` and the kinetic energy of the
finite-element mass matrix :math:`M` is

.. math::

    T = \tfrac12\,w^T M_b(\eta)\,w,\qquad M_b = \mathcal A^T M \mathcal A
      \approx M_0 + \sum_i \eta_i M_{1,i} + \tfrac12\sum_{ij}\eta_i\eta_j M_{2,ij}

kept to second order in :math:`\eta` (the terms that give the equations their
parts linear in :math:`\eta`, geometric stiffening included).  The matrices
:math:`M_0, M_{1,i}, M_{2,ij}` are the body's *inertia invariants*, computed
here once, numerically; the formulation writes the equations of motion with
them (never node by node).  Because the equations come from one kinetic
energy, the model conserves energy exactly.

Elastic forces :math:`-K_\eta\eta` (:math:`K_\eta = \Phi^TK\Phi`), damping
:math:`-D\zeta` (Rayleigh or modal), and gravity (a uniform field, whose
generalized force is the first three columns of :math:`M_b` times the field's
body-frame components, as for a frame accelerated by :math:`-g`) act on the
modal coordinates and the frame.
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ..._errors import ModelError
from ._lazy_scipy import sp
from ._reduced import ReducedMember, damping_matrix

__all__ = ["FlexibleBody", "InertiaInvariants"]

_DROP = 1e-14  # coefficients below this fraction of the largest are zero


def _skew(v):
    """Matrices with ``skew(v) @ x == cross(v, x)`` for stacked vectors, (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


class InertiaInvariants:
    r"""The inertia invariants of a reduced member (see the module docstring).

    Attributes
    ----------
    mass : float
        Total mass, kg.
    M0 : ndarray, shape (6 + m, 6 + m)
        :math:`M_b(0)`, in the order :math:`(v_O, \omega, \zeta)`.
    M1 : ndarray, shape (m, 6 + m, 6 + m)
        :math:`\partial M_b/\partial\eta_i` at :math:`\eta = 0`.
    M2 : ndarray, shape (m, m, 6 + m, 6 + m)
        :math:`\partial^2 M_b/\partial\eta_i\partial\eta_j` (symmetric in i, j).
    first_moment : tuple of ndarray
        ``(c0, c1, c2)``: :math:`\int r\,dm = c_0 + c_1\eta + \tfrac12 c_2\eta\eta`,
        shapes (3,), (3, m), (3, m, m), kg m.
    stiffness : ndarray, shape (m, m)
        Modal stiffness :math:`\Phi^TK\Phi`.
    """

    def __init__(self, member, stiffening=True):
        n, m = member.n_nodes, member.n_modes
        mass = member.mass_matrix
        mass = mass.tocsr() if sp.issparse(mass) else np.asarray(mass, dtype=float)
        modes = np.asarray(member.modes, dtype=float)
        nodes = np.asarray(member.nodes, dtype=float) - member.nodes[member.reference_node]
        G = member.second_order if stiffening else None
        size = 6 + m
        t_rows = (6 * np.arange(n)[:, None] + np.arange(3)).ravel()  # translation dofs
        r_rows = t_rows + 3                                           # rotation dofs

        # A0: nodal velocities for w = (v_O, omega, zeta) at eta = 0
        A0 = np.zeros((6 * n, size))
        A0[t_rows, np.tile(np.arange(3), n)] = 1.0
        A0[t_rows.reshape(n, 3)[:, :, None], np.arange(3, 6)] = -_skew(nodes)
        A0[r_rows, np.tile(np.arange(3, 6), n)] = 1.0
        A0[:, 6:] = modes
        # A1_i: first-order change (omega columns: -skew(Phi_k e_i); zeta: G)
        phi_t = modes[t_rows].reshape(n, 3, m)  # (n, 3, m)
        A1 = np.zeros((m, 6 * n, size))
        for i in range(m):
            A1[i][t_rows.reshape(n, 3)[:, :, None], np.arange(3, 6)] = -_skew(phi_t[:, :, i])
            if G is not None:
                A1[i][t_rows, 6:] = G[:, :, i, :].reshape(3 * n, m)
        # A2_ij: second-order change of the omega columns, -skew(G_ij)
        A2 = np.zeros((m, m, 6 * n, size))
        if G is not None:
            for i in range(m):
                for j in range(m):
                    A2[i, j][t_rows.reshape(n, 3)[:, :, None], np.arange(3, 6)] = \
                        -_skew(G[:, :, i, j])

        MA0 = mass @ A0
        self.M0 = _symmetric(A0.T @ MA0)
        MA1 = np.array([mass @ A1[i] for i in range(m)])
        self.M1 = np.array([_symmetric(A0.T @ MA1[i] + MA1[i].T @ A0) for i in range(m)])
        self.M2 = np.zeros((m, m, size, size))
        for i in range(m):
            for j in range(i, m):
                value = A1[i].T @ MA1[j] + MA1[j].T @ A1[i]
                value = value + A2[i, j].T @ MA0 + MA0.T @ A2[i, j]
                self.M2[i, j] = self.M2[j, i] = _symmetric(value)
        self.mass = float(self.M0[0, 0])
        X0 = np.zeros(6 * n)
        X0[t_rows] = nodes.ravel()
        T = np.zeros((6 * n, 3))
        T[t_rows, np.tile(np.arange(3), n)] = 1.0
        MT = np.asarray(mass @ T)
        c2 = np.zeros((3, m, m))
        if G is not None:  # second-order translations of every node, weighted by M T
            c2 = np.einsum("ra,rij->aij", MT[t_rows], G.reshape(3 * n, m, m))
        self.first_moment = (MT.T @ X0, MT.T @ modes, c2)
        stiffness = member.stiffness_matrix
        self.stiffness = _symmetric(np.asarray(modes.T @ (stiffness @ modes)))
        self.n_modes = m


    def first_moment_of(self, eta):
        r"""The first moment of mass and its gradient as SymPy expressions of ``eta``.

        Parameters
        ----------
        eta : sequence of SymPy symbols or functions, length m

        Returns
        -------
        c : list of 3 expressions
            :math:`c_0 + c_1\eta + \tfrac12 c_2\eta\eta`, kg m.
        gradient : list of 3 lists of m expressions
            :math:`\partial c_a/\partial\eta_i = c_{1,ai} + \sum_j c_{2,aij}\eta_j`.
        """
        c0, c1, c2 = self.first_moment
        m = len(eta)
        gradient = [[sm.Float(c1[a, i]) + sm.Add(*[sm.Float(c2[a, i, j]) * eta[j]
                                                   for j in range(m) if c2[a, i, j] != 0])
                     for i in range(m)] for a in range(3)]
        c = [sm.Float(c0[a]) + sm.Add(*[(sm.Float(c1[a, i]) + gradient[a][i]) * eta[i] / 2
                                        for i in range(m)]) for a in range(3)]
        return c, gradient

def _symmetric(a):
    a = np.asarray(a, dtype=float)
    return 0.5 * (a + a.T)


class FlexibleBody:
    r"""A flexible body for :func:`kanedyn.kane`: a member reduced to modal coordinates.

    Parameters
    ----------
    name : str
    frame : sympy.physics.mechanics.ReferenceFrame
        The body frame :math:`B` (oriented by the user, like a rigid body's).
    origin : sympy.physics.mechanics.Point
        Origin of :math:`B`, at the member's reference node (its velocity must
        follow from the model's kinematics, like a rigid body's mass centre).
    member : ReducedMember
        The member reduced by component mode synthesis.
    coordinates, speeds : sequence of dynamicsymbols, optional
        The modal coordinates and speeds (default ``eta_<name>_<i>`` and
        ``zeta_<name>_<i>``); put them in ``q_ind``, ``u_ind`` and their
        kinematic equations :attr:`kd_eqs` in ``kd_eqs``.
    stiffening : bool
        Keep the second-order (foreshortening) kinematics that give
        motion-induced geometric stiffening (default ``True``); ``False`` gives
        the conventional linear modal model.
    rayleigh : (float, float), optional
        Damping :math:`D = \alpha M_\eta + \beta K_\eta`: ``(alpha, beta)`` in
        1/s and s (:math:`M_\eta, K_\eta` the member's own modal mass and
        stiffness).
    modal_damping : float or sequence of float, optional
        Damping ratios of the modal coordinates, fractions of critical (0.01
        is 1 %), ``0 <= zeta < 1``; one number for all.  Requires modal mass
        and stiffness that are diagonal in the member's basis (e.g.
        fixed-interface normal modes only); ``D = diag(2 zeta_i sqrt(k_i m_i))``
        with the member's *own* modal mass :math:`m_i`: the ratio of the member
        alone.  Bodies attached to it (a payload, a rotor-nacelle mass) add
        mass, and its modes in the assembly decay with less; to set the
        assembly's ratios use :meth:`ReducedMember.with_damping` with
        ``modal_mass=``.

        Default (neither given, and a member without
        :attr:`ReducedMember.damping`): **no damping**.  A member that carries
        damping (:meth:`ReducedMember.with_damping`, the OC3 tower) keeps
        it, and giving ``rayleigh`` or ``modal_damping`` as well is refused.
    gravity : sympy.physics.vector.Vector, optional
        A uniform gravity field acting on the body's mass (e.g. ``-g * N.z``).

    Attributes
    ----------
    q, u : tuple
        Modal coordinates and speeds.
    kd_eqs : tuple
        :math:`\dot\eta_i - \zeta_i`.
    invariants : InertiaInvariants
    damping : ndarray, shape (m, m)
        :math:`D`, N s/m per unit modal speed: the generalized force
        :math:`-D\zeta` on the modal coordinates, whose power
        :math:`-\zeta^TD\zeta` is the energy the member dissipates.
    """

    def __init__(self, name, frame, origin, member, coordinates=None, speeds=None,
                 stiffening=True, rayleigh=None, modal_damping=None, gravity=None):
        if not isinstance(member, ReducedMember):
            raise ModelError(f"flexible body {name!r}: member must be a ReducedMember (from "
                             f"component mode synthesis), got {type(member).__name__}")
        if not isinstance(frame, me.ReferenceFrame):
            raise ModelError(f"flexible body {name!r}: frame must be a ReferenceFrame")
        if not isinstance(origin, me.Point):
            raise ModelError(f"flexible body {name!r}: origin must be a Point")
        if stiffening and member.second_order is None:
            raise ModelError(
                f"flexible body {name!r}: member {member.name!r} has no second-order "
                "(foreshortening) displacements, which geometric stiffening needs (members "
                "imported as matrices have none); give stiffening=False, or build the member "
                "from beam elements")
        m = member.n_modes
        if coordinates is None:
            coordinates = me.dynamicsymbols(f"eta_{name}_1:{m + 1}") if m else ()
        if speeds is None:
            speeds = me.dynamicsymbols(f"zeta_{name}_1:{m + 1}") if m else ()
        coordinates, speeds = tuple(np.atleast_1d(coordinates)), tuple(np.atleast_1d(speeds))
        if len(coordinates) != m or len(speeds) != m:
            raise ModelError(f"flexible body {name!r}: member {member.name!r} has {m} modes; "
                             f"got {len(coordinates)} coordinates and {len(speeds)} speeds")
        self.name = name
        self.frame = frame
        self.origin = origin
        self.member = member
        self.q = coordinates
        self.u = speeds
        self.stiffening = bool(stiffening)
        self.gravity = gravity
        self.invariants = InertiaInvariants(member, stiffening=self.stiffening)
        self.damping = self._damping(rayleigh, modal_damping)
        self._points = {}
        self._frames = {}

    def __repr__(self):
        return (f"FlexibleBody({self.name!r}, member={self.member.name!r}, "
                f"{len(self.q)} modes, stiffening={self.stiffening})")

    # ---------------------------------------------------------------- model
    @property
    def kd_eqs(self):
        """Kinematic differential equations of the modal coordinates."""
        return tuple(q.diff(me.dynamicsymbols._t) - u for q, u in zip(self.q, self.u))

    @property
    def mass(self):
        """Total mass, kg."""
        return self.invariants.mass

    @property
    def modal_stiffness(self):
        return self.invariants.stiffness

    @property
    def strain_energy(self):
        r""":math:`\tfrac12\eta^TK_\eta\eta` as a SymPy expression."""
        eta = sm.Matrix(self.q)
        return (eta.T * _matrix(self.invariants.stiffness) * eta)[0, 0] / 2

    @property
    def potential_energy(self):
        """The strain energy (gravity's part needs an inertial reference point: see
        :meth:`gravitational_energy`); used when the model declares none."""
        return self.strain_energy

    def gravitational_energy(self, point):
        r"""Potential energy of :attr:`gravity` relative to a point fixed in the inertial frame.

        :math:`V_g = -g\cdot(m\,r_{O/P} + B\,c(\eta))` with :math:`c` the first
        moment of mass about :math:`O`.
        """
        if self.gravity is None:
            return sm.S.Zero
        c, _ = self.invariants.first_moment_of(self.q)
        B = self.frame
        moment = self.mass * self.origin.pos_from(point) + c[0] * B.x + c[1] * B.y + c[2] * B.z
        return -self.gravity.dot(moment)

    def _damping(self, rayleigh, modal):
        given = self.member.damping
        if given is not None:
            if rayleigh is not None or modal is not None:
                raise ModelError(
                    f"flexible body {self.name!r}: member {self.member.name!r} carries its "
                    "own damping (ReducedMember.damping, e.g. from with_damping or the OC3 "
                    "tower's default); give damping once: drop rayleigh/modal_damping here, "
                    "or build the member without damping (the OC3 tower: damping=0)")
            return np.array(given, dtype=float)
        if rayleigh is None and modal is None:
            return np.zeros((self.member.n_modes,) * 2)
        # the member's modal mass and stiffness are the invariants' M0[6:, 6:] and K
        return damping_matrix(self.member, ratios=modal, rayleigh=rayleigh,
                              what=f"flexible body {self.name!r}",
                              names=("modal_damping", "rayleigh"))

    # ---------------------------------------------------------- attachments
    def node_point(self, k):
        """The point at node ``k`` (``-1``: the last), moving with the member's deformation.

        Joints, loads, contacts and attached bodies use it like any other
        ``Point``; its position is exact in the modal coordinates (second
        order included when :attr:`stiffening`).
        """
        k = self._node(k)
        if k not in self._points:
            member = self.member
            x = member.nodes[k] - member.nodes[member.reference_node]
            Phi, _ = member.node_modes(k)
            eta = list(self.q)
            G = member.second_order if self.stiffening else None
            comps = []
            for a in range(3):
                value = sm.Float(x[a]) + sum(sm.Float(Phi[a, i]) * eta[i]
                                             for i in range(len(eta)) if Phi[a, i] != 0)
                if G is not None:
                    value += sum(sm.Float(G[k, a, i, j] / 2) * eta[i] * eta[j]
                                 for i in range(len(eta)) for j in range(len(eta))
                                 if G[k, a, i, j] != 0)
                comps.append(value)
            B = self.frame
            self._points[k] = self.origin.locatenew(
                f"{self.name}_node{k}", comps[0] * B.x + comps[1] * B.y + comps[2] * B.z)
        return self._points[k]

    def node_frame(self, k):
        """A frame at node ``k``, turned from the body frame by the node's rotation.

        The rotation :math:`\\theta_k = \\Psi_k\\eta` is applied as body-fixed
        x-y-z angles (an exact rotation matrix).
        """
        k = self._node(k)
        if k not in self._frames:
            _, Psi = self.member.node_modes(k)
            eta = list(self.q)
            angles = [sum(sm.Float(Psi[a, i]) * eta[i] for i in range(len(eta))
                          if Psi[a, i] != 0) for a in range(3)]
            F = me.ReferenceFrame(f"{self.name}_F{k}")
            F.orient_body_fixed(self.frame, angles, "xyz")
            self._frames[k] = F
        return self._frames[k]

    def _node(self, k):
        n = self.member.n_nodes
        k = int(k)
        if not -n <= k < n:
            raise ModelError(f"flexible body {self.name!r}: node {k} does not exist in member "
                             f"{self.member.name!r} (nodes 0..{n - 1}, or -{n}..-1 from the end)")
        return k % n


def _matrix(a):
    return sm.Matrix([[sm.Float(v) for v in row] for row in np.asarray(a)])
