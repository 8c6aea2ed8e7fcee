r"""Contact forces and accelerations for given contact modes (numerical).

For contact :math:`c` with relative velocity :math:`v_c = J_c u + b_c`, unit
normal :math:`n_c` and modes

``separated``
    no force;
``slip``
    normal force :math:`N_c n_c` and Coulomb friction
    :math:`-\mu_k |N_c| \hat s_c` (:math:`\hat s_c` the slip direction), one
    unknown :math:`N_c`, one equation :math:`\dot v_{n,c} = 0`;
``stick``
    an unknown force vector :math:`\lambda_c` and :math:`\dot v_c = 0`,

Kane's equations with the contact constraints relaxed (the normal speed is
not eliminated, so the ideal normal force appears with the partial velocities
of the relative motion) read

.. math::

    M\dot u = f + \sum_c J_c^T \lambda_c,\qquad
    \lambda_c = N_c n_c - \mu_k |N_c| \hat s_c\ \text{(slip)},

and are solved together with the contact equations (and the model's own
velocity constraints) as one linear system in :math:`(\dot u, N, \lambda)`.
Drift of the contact constraints is damped by Baumgarte stabilization
:math:`\ddot d + 2\omega\dot d + \omega^2 d = 0` on the normal distance.

The slip direction :math:`\hat s_c` is taken from the slip velocity with the
drift of the *other* active contact constraints removed (see
:func:`slip_velocities`): a point sliding along the corner of a floor and a
wall slides along the corner, whatever rounding-level speed the integration
leaves across the wall.  Where sticking contacts are redundant (their
constraints are dependent) the accelerations are determined and the forces
are not; the forces taken are the ones that need the least friction, each
sticking contact using the same fraction of its static cone (see
:func:`solve_modes`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SEPARATED", "SLIP", "STICK", "ContactPoint", "ContactSolution", "SlipReference",
           "contact_points", "slip_choice", "slip_direction", "slip_velocities", "solve_modes"]

SEPARATED, SLIP, STICK = "separated", "slip", "stick"


@dataclass(frozen=True)
class ContactPoint:
    """Kinematics of one contact at one instant (inertial components)."""

    gap: float
    grad_norm: float
    normal: np.ndarray  # (3,)
    velocity: np.ndarray  # (3,) relative velocity
    jacobian: np.ndarray  # (3, o)
    acceleration: np.ndarray  # (3,) d/dt velocity with u' = 0
    normal_rate: float  # d/dt (n . velocity) with u' = 0

    @property
    def distance(self):
        """Signed distance to the surface, to first order (positive: free)."""
        return self.gap / self.grad_norm

    @property
    def normal_speed(self):
        return float(self.normal @ self.velocity)

    @property
    def slip_velocity(self):
        return self.velocity - self.normal_speed * self.normal


@dataclass(frozen=True)
class ContactSolution:
    r"""Accelerations and contact forces for one set of modes.

    Attributes
    ----------
    udot : ndarray, shape (n_u,)
    normal_force : ndarray, shape (k,)
        Normal force magnitude per contact (0 when separated), N.
    friction : ndarray, shape (k, 3)
        Friction force on the contact point, N.
    points : list of ContactPoint
    dissipation : float
        Power of the friction forces on the relative motion (<= 0), W.
    power : float
        Power of all contact forces on the system (:math:`\sum_c F_c \cdot
        J_c u`), W: the dissipation plus the power a moving surface
        delivers.
    slip_velocity : ndarray, shape (k, 3)
        Slip velocity of each contact with the drift of the other active
        contact constraints removed (:func:`slip_velocities`), m/s.
    qdot : ndarray, shape (n_q,)
        Coordinate rates at the same state (from the same evaluation).
    """

    udot: np.ndarray
    normal_force: np.ndarray
    friction: np.ndarray
    points: list
    dissipation: float
    power: float
    slip_velocity: np.ndarray = None
    qdot: np.ndarray = None

    @property
    def force(self):
        """Total contact force per contact (normal + friction), shape (k, 3)."""
        normals = np.array([p.normal for p in self.points]).reshape(-1, 3)
        return self.normal_force[:, None] * normals + self.friction


def contact_points(model, t, y, inputs=None):
    """The :class:`ContactPoint` of every contact of ``model`` at ``(t, y)``
    (``inputs``: the specified inputs' values, by default their providers')."""
    gap, grad, normal, vel, jac, acc, rate = model._fn["contacts"](
        t, y, model._p, model._r(t, y) if inputs is None else list(inputs))
    o = model.n_u
    return [ContactPoint(gap=float(gap[c]), grad_norm=float(grad[c]), normal=normal[c],
                         velocity=vel[c], jacobian=jac[3 * c:3 * c + 3].reshape(3, o),
                         acceleration=acc[c], normal_rate=float(rate[c]))
            for c in range(len(gap))]


@dataclass(frozen=True)
class SlipReference:
    """Reference of a sliding contact for :func:`slip_direction`.

    Attributes
    ----------
    direction : ndarray, shape (3,)
        Unit vector: the slip direction when the current mode began, or the
        one a slip starts in.
    slow : float
        Slip speed (m/s) below which a slip velocity turned away from
        ``direction`` counts as stopping; ``inf``: at any speed.
    still : float
        Slip speed (m/s) at or below which the slip is taken as stopped or
        just starting: its direction is ``direction`` (which comes from the
        forces that start the slip, or from the slip before it stops), not
        the direction of a rounding-level velocity.
    """

    direction: np.ndarray
    slow: float = np.inf
    still: float = 0.0


def slip_direction(point, reference=None, tiny=1e-12, velocity=None, space=None):
    """Unit slip direction of a sliding contact.

    Parameters
    ----------
    point : ContactPoint
    reference : SlipReference or array_like, optional
    tiny : float
        Relative speed below which there is no slip velocity to follow.
    velocity : array_like, shape (3,), optional
        The slip velocity to follow, m/s; by default the point's own
        (:attr:`ContactPoint.slip_velocity`).  :func:`solve_modes` passes
        the one with the other contacts' drift removed
        (:func:`slip_velocities`).
    space : ndarray, shape (3, 3), optional
        Orthogonal projector onto the slip velocities the other active
        contacts allow (:func:`slip_velocities`); by default the tangent
        plane.  A reference direction is projected onto it: a direction
        recorded when the slip began does not turn with a moving surface,
        and must not point across a wall the point slides along.

    Without a ``reference`` it is the direction of the slip velocity (zero
    when there is none).  With one (a :class:`SlipReference` or a direction
    vector), the slip velocity's direction is used unless the slip is slow
    and has no positive component along the reference, or is at most the
    reference's ``still`` speed; then the reference is: the friction does not
    flip when the slip velocity passes through zero, the equations stay
    smooth up to the event that stops the slip, and a slip that starts from
    rest goes the way the forces drive it.
    """
    return slip_choice(point, reference, tiny, velocity, space)[0]


def slip_choice(point, reference=None, tiny=1e-12, velocity=None, space=None):
    """``(direction, source)``: :func:`slip_direction` (same arguments) and what
    it followed: ``"velocity"`` (the slip velocity's direction),
    ``"reference"`` (the reference projected) or ``"none"`` (zero)."""
    vt = point.slip_velocity if velocity is None else np.asarray(velocity, dtype=float)
    speed = np.linalg.norm(vt)
    moving = speed > tiny * max(1.0, np.linalg.norm(point.velocity))
    if reference is None:
        return (vt / speed, "velocity") if moving else (np.zeros(3), "none")
    if not isinstance(reference, SlipReference):
        reference = SlipReference(np.asarray(reference, dtype=float))
    s = reference.direction
    if moving and speed > reference.still and (vt @ s > 0 or speed > reference.slow):
        return vt / speed, "velocity"
    s = s - (s @ point.normal) * point.normal if space is None else space @ s
    norm = np.linalg.norm(s)
    return (s / norm, "reference") if norm > 0 else (np.zeros(3), "none")


def _constraint_rows(point, mode):
    """Rows (of J u + b) an active contact holds and their current values."""
    if mode == SLIP:
        return (point.normal @ point.jacobian)[None, :], np.array([point.normal_speed])
    return point.jacobian, np.asarray(point.velocity, dtype=float)


def slip_velocities(points, modes, mass=None, constraints=None, rcond=1e-10):
    r"""Slip velocities with the drift of the other active contacts removed.

    The integration keeps the contact constraints only to its tolerance: a
    bead sliding along the corner of a floor and a wall has a rounding-level
    speed across the wall (1e-11 m/s), which would set the direction of the
    floor friction once the slip along the corner has nearly stopped.  For
    each sliding contact ``c`` the generalized speeds are corrected by the
    smallest change (in the kinetic-energy metric :math:`M`) that makes the
    *other* active contacts hold exactly (the normal speed of a sliding one,
    the whole relative velocity of a sticking one) and keeps the model's own
    velocity constraints:

    .. math::

        \delta u = -M^{-1} C^T (C M^{-1} C^T)^{+} r,

    with :math:`C` those constraint rows and :math:`r` their values (zero
    for the model's own); the slip velocity is the tangential part of
    :math:`v_c + J_c\,\delta u`.  The slip velocities those constraints allow
    span :math:`T_c J_c\,\mathcal{N}(C)` (:math:`T_c` the projection on the
    tangent plane); its orthogonal projector is returned too, for the slip
    directions taken from a reference (:func:`slip_direction`).  A contact
    with no other active contact keeps its own slip velocity and the tangent
    plane.

    Parameters
    ----------
    points : list of ContactPoint
    modes : sequence of {"separated", "slip", "stick"}
    mass : ndarray, shape (n_u, n_u), optional
        Mass matrix (the metric); the identity when absent or singular.
    constraints : ndarray, shape (n_u_dep, n_u), optional
        The model's own velocity-constraint matrix (changes keep it).
    rcond : float
        Relative cut-off of pseudo-inverses and ranks (redundant constraints).

    Returns
    -------
    velocities : ndarray, shape (k, 3)
        m/s.
    spaces : list of (ndarray, shape (3, 3)) or None
        Per contact, the projector onto its allowed slip velocities (``None``:
        the tangent plane).
    """
    out = np.array([p.slip_velocity for p in points], dtype=float).reshape(-1, 3)
    spaces = [None] * len(points)
    active = [c for c, mode in enumerate(modes) if mode in (SLIP, STICK)]
    if len(active) < 2 or not any(modes[c] == SLIP for c in active):
        return out, spaces
    o = points[0].jacobian.shape[1]
    rows, values, owner = [], [], []
    for c in active:
        block, value = _constraint_rows(points[c], modes[c])
        rows.append(block)
        values.append(value)
        owner.extend([c] * len(value))
    if constraints is not None and len(constraints):
        rows.append(np.asarray(constraints, dtype=float).reshape(-1, o))
        values.append(np.zeros(rows[-1].shape[0]))
        owner.extend([-1] * rows[-1].shape[0])
    C = np.vstack(rows)
    r = np.concatenate(values)
    owner = np.array(owner)
    try:
        WC = np.linalg.solve(mass, C.T) if mass is not None else C.T
    except np.linalg.LinAlgError:
        WC = C.T
    G = C @ WC
    for c in active:
        if modes[c] != SLIP:
            continue
        keep = owner != c
        du = -WC[:, keep] @ (np.linalg.pinv(G[np.ix_(keep, keep)], rcond=rcond) @ r[keep])
        point = points[c]
        tangent = np.eye(3) - np.outer(point.normal, point.normal)
        out[c] = tangent @ (point.velocity + point.jacobian @ du)
        _, sv, Vt = np.linalg.svd(C[keep])
        rank = int(np.sum(sv > rcond * sv[0])) if sv.size else 0
        allowed = tangent @ point.jacobian @ Vt[rank:].T
        U, sv, _ = np.linalg.svd(allowed, full_matrices=False)
        basis = U[:, sv > rcond * max(sv[0], 1e-300)] if sv.size else U[:, :0]
        spaces[c] = basis @ basis.T
    return out, spaces


def _redundant(rows, rtol=1e-10):
    """Whether the constraint rows (shape (k, n_u)) are linearly dependent."""
    if rows.shape[0] > rows.shape[1]:
        return True
    if rows.shape[0] == 1:
        return not np.any(rows)
    sv = np.linalg.svd(rows, compute_uv=False)
    return sv[-1] <= rtol * sv[0]


def _least_friction(A, b, o, sticking, rtol=1e-10):
    r"""A solution of the singular system ``A x = b`` with the least friction.

    ``x = (u', lambda)``; the accelerations are determined, the forces of
    redundant contacts are not.  Among the solutions (least squares where
    rounding makes the redundant rows slightly inconsistent) take the one
    whose sticking contacts need the least friction,
    :math:`\sum_c |f_c|^2 / (\mu_{s,c} N_c)`: the normal forces carry what
    they can (a bead in the corner of a floor and a wall: the floor carries
    the weight, the wall the push across it), and the friction along a
    common direction is shared so that every sticking contact uses the same
    fraction of its cone (they reach their limits together).  The normal
    forces of a first pass with equal weights give the weights of a second;
    what remains free is taken least-norm.

    ``sticking``: ``(offset in lambda, size, T Q, mu_s, n Q)`` per sticking
    contact, ``T Q`` (3, size) mapping its multipliers to the tangential
    force and ``n Q`` (size,) to the normal force.
    """
    x0 = np.linalg.lstsq(A, b, rcond=None)[0]
    _, sv, Vt = np.linalg.svd(A)
    Z = Vt[sv <= rtol * sv[0]].T  # null space of A, orthonormal columns
    if not Z.shape[1] or not sticking:
        return x0
    weights = np.ones(len(sticking))
    x = x0
    for _ in range(2):
        F = np.zeros((3 * len(sticking), A.shape[1]))
        for j, (i, size, TQ, _, _) in enumerate(sticking):
            F[3 * j:3 * j + 3, o + i:o + i + size] = np.sqrt(weights[j]) * TQ
        FZ = F @ Z
        x = x0 - Z @ (np.linalg.pinv(FZ, rcond=rtol) @ (F @ x0))
        # what the friction leaves free: least norm (Z Z2 has orthonormal columns)
        _, sv2, Vt2 = np.linalg.svd(FZ)
        rank = int(np.sum(sv2 > rtol * sv2[0])) if sv2.size else 0
        Y = Z @ Vt2[rank:].T
        x = x - Y @ (Y.T @ x)
        limits = np.array([mu * float(nQ @ x[o + i:o + i + size])
                           for i, size, _, mu, nQ in sticking])
        if not np.max(limits) > 0:
            break
        weights = 1.0 / np.maximum(limits, 1e-9 * np.max(limits))
    return x


def _one_contact(model, y, modes, directions, w, qd, mass, force, points):
    """:func:`solve_modes` for at most one active, unilateral contact (no
    dependent speeds): the contact force by the Schur complement of the mass
    matrix, the few small products written out.  ``None`` where it does not
    apply (several active contacts, a bilateral one, a sticking point that
    cannot move in every direction); the general path then solves.
    """
    active = [c for c, mode in enumerate(modes) if mode != SEPARATED]
    k = len(points)
    slips = np.array([pt.slip_velocity for pt in points], dtype=float).reshape(-1, 3)
    normal_force = np.zeros(k)
    friction = np.zeros((k, 3))
    if not active:
        udot = np.linalg.solve(mass, force)
        return ContactSolution(udot=udot, normal_force=normal_force, friction=friction,
                               points=points, dissipation=0.0, power=0.0,
                               slip_velocity=slips, qdot=qd)
    if len(active) > 1:
        return None
    c = active[0]
    coef = model.contacts[c]
    mode = modes[c]
    if coef["kind"] != "unilateral" or mode not in (SLIP, STICK):
        return None
    point = points[c]
    J, n = point.jacobian, point.normal
    vn = float(n @ point.velocity)
    vt = point.velocity - vn * n
    correction = 2 * w * vn + w * w * point.distance
    if coef["viscous"]:
        force = force - coef["viscous"] * (J.T @ vt)
    if mode == SLIP:
        reference = (directions or [None] * k)[c]
        s = slip_direction(point, reference, velocity=slips[c])
        column = J.T @ (n - coef["mu_k"] * s)
        sol = np.linalg.solve(mass, np.column_stack([force, column]))
        row = n @ J
        denominator = float(row @ sol[:, 1])
        if not abs(denominator) > 1e-12 * np.linalg.norm(row) * np.linalg.norm(column):
            return None
        N = (-(point.normal_rate + correction) - float(row @ sol[:, 0])) / denominator
        udot = sol[:, 0] + N * sol[:, 1]
        total = N * (n - coef["mu_k"] * s)
    else:
        sol = np.linalg.solve(mass, np.column_stack([force, J.T]))
        Wc = J @ sol[:, 1:]
        ev = np.linalg.eigvalsh(0.5 * (Wc + Wc.T))
        if not ev[0] > 1e-10 * ev[-1]:
            return None  # the point cannot move in some direction: general path
        lam = np.linalg.solve(Wc, -(point.acceleration + correction * n) - J @ sol[:, 0])
        udot = sol[:, 0] + sol[:, 1:] @ lam
        total = lam
    N = float(total @ n)
    normal_force[c] = N
    friction[c] = total - N * n - coef["viscous"] * vt
    u = y[model.n_q:]
    dissipation = float(friction[c] @ point.velocity)
    power = float((N * n + friction[c]) @ (J @ u))
    return ContactSolution(udot=udot, normal_force=normal_force, friction=friction,
                           points=points, dissipation=dissipation, power=power,
                           slip_velocity=slips, qdot=qd)


def solve_modes(model, t, y, modes, directions=None, stabilization=10.0, inputs=None):
    """Accelerations and contact forces for given modes.

    Parameters
    ----------
    model : NumericModel
    t : float
    y : array_like
    modes : sequence of {"separated", "slip", "stick"}
        One per contact (``model.contacts``).
    directions : sequence of array_like or None, optional
        Reference slip direction per sliding contact (see
        :func:`slip_direction`): the direction its slip starts in, or had
        when the current mode began.
    stabilization : float
        Baumgarte frequency :math:`\\omega` (critically damped), rad/s.
    inputs : array_like, shape (n_inputs,), optional
        Values of the specified inputs; by default their providers' at ``(t, y)``.

    Returns
    -------
    ContactSolution

    Raises
    ------
    numpy.linalg.LinAlgError
        When the system is singular for another reason than redundant
        contact constraints (whose forces are then the ones needing the
        least friction, see :func:`_least_friction`).
    """
    y = np.asarray(y, dtype=float)
    o, m = model.n_u, model.n_u_dep
    p = o - m
    if inputs is None:
        qd, mass, force, vel_B, acc_K, acc_f = model._dynamics(t, y)
    else:
        qd, mass, force, vel_B, acc_K, acc_f = model._fn["dynamics"](t, y, model._p,
                                                                     list(inputs))
    points = contact_points(model, t, y, inputs)
    coefficients = model.contacts
    if not m:
        fast = _one_contact(model, y, modes, directions, stabilization, qd, mass, force,
                            points)
        if fast is not None:
            return fast
    directions = directions or [None] * len(points)
    slips, spaces = slip_velocities(points, modes, mass, vel_B.reshape(m, o) if m else None)
    force = force.copy()
    columns, rows, rhs, layout, slip_columns, sticking = [], [], [], [], [], []
    w = stabilization
    for c, (point, mode) in enumerate(zip(points, modes)):
        if mode == SEPARATED:
            layout.append((mode, 0))
            continue
        J = point.jacobian
        n = point.normal
        coef = coefficients[c]
        vt = point.slip_velocity
        if coef["viscous"]:
            force += J.T @ (-coef["viscous"] * vt)
        correction = 2 * w * point.normal_speed + w * w * point.distance
        if mode == SLIP:
            s = slip_direction(point, directions[c], velocity=slips[c], space=spaces[c])
            # the friction column is set below with the sign of the normal force
            slip_columns.append((len(columns), J.T @ n, coef["mu_k"] * (J.T @ s),
                                 coef["kind"] == "bilateral"))
            columns.append(J.T @ n)
            rows.append(n @ J)
            rhs.append(-(point.normal_rate + correction))
            layout.append((mode, 1, s))
        elif mode == STICK:
            # constrain (and transmit force along) the directions the point can move in
            U, sv, _ = np.linalg.svd(J, full_matrices=False)
            Q = U[:, sv > 1e-12 * max(sv[0], 1e-300)] if sv.size else U[:, :0]
            sticking.append((len(columns), Q.shape[1], Q - np.outer(n, n @ Q),
                             coef["mu_s"], n @ Q))
            columns.extend((J.T @ Q).T)
            rows.extend(Q.T @ J)
            rhs.extend(-(Q.T @ (point.acceleration + correction * n)))
            layout.append((mode, Q.shape[1], Q))
        else:
            raise ValueError(f"unknown contact mode {mode!r} for contact "
                             f"{coefficients[c]['name']}")
    k = len(rows)
    G = np.array(columns).T.reshape(o, k)
    if m:
        X = np.linalg.solve(vel_B[:, p:], vel_B[:, :p])
        R = np.hstack([np.eye(p), -X.T])
    else:
        R = None  # the identity
    A = np.zeros((o + k, o + k))
    b = np.zeros(o + k)
    A[:p, :o] = mass if R is None else R @ mass
    b[:p] = force if R is None else R @ force
    if m:
        A[p:o, :o] = acc_K
        b[p:o] = -acc_f
    if k:
        A[o:, :o] = np.array(rows).reshape(k, o)
        b[o:] = rhs
    redundant = k and _redundant(A[o:, :o] if not m else
                                 np.vstack([vel_B.reshape(m, o), A[o:, :o]]))
    # friction -mu |N| s: the sign of N is assumed positive, and corrected for
    # bilateral contacts whose normal force turns out to pull
    sign = np.ones(k)
    for _ in range(len(slip_columns) + 1):
        for i, normal_column, friction_column, _ in slip_columns:
            G[:, i] = normal_column - sign[i] * friction_column
        A[:p, o:] = -G if R is None else -(R @ G)
        if redundant:
            # statically indeterminate (e.g. a ladder sticking at both ends): the
            # accelerations are determined, the contact forces are not
            sol = _least_friction(A, b, o, sticking)
        else:
            sol = np.linalg.solve(A, b)
        flips = [i for i, _, _, bilateral in slip_columns
                 if bilateral and sol[o + i] * sign[i] < 0]
        if not flips:
            break
        sign[flips] *= -1
    udot, lam = sol[:o], sol[o:]
    normal_force = np.zeros(len(points))
    friction = np.zeros((len(points), 3))
    dissipation = power = 0.0
    u = y[model.n_q:]
    i = 0
    for c, (point, entry) in enumerate(zip(points, layout)):
        mode, size = entry[0], entry[1]
        coef = coefficients[c]
        vt = point.slip_velocity
        if mode == SLIP:
            N = lam[i]
            normal_force[c] = N
            friction[c] = -coef["mu_k"] * sign[i] * N * entry[2] - coef["viscous"] * vt
        elif mode == STICK:
            total = entry[2] @ lam[i:i + size]
            N = float(total @ point.normal)
            normal_force[c] = N
            friction[c] = total - N * point.normal - coef["viscous"] * vt
        dissipation += float(friction[c] @ point.velocity)
        power += float((normal_force[c] * point.normal + friction[c]) @ (point.jacobian @ u))
        i += size
    return ContactSolution(udot=udot, normal_force=normal_force, friction=friction,
                           points=points, dissipation=dissipation, power=power,
                           slip_velocity=slips, qdot=qd)
