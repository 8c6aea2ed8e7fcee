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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SEPARATED", "SLIP", "STICK", "ContactPoint", "ContactSolution", "SlipReference",
           "contact_points", "slip_direction", "solve_modes"]

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
    """

    udot: np.ndarray
    normal_force: np.ndarray
    friction: np.ndarray
    points: list
    dissipation: float
    power: float

    @property
    def force(self):
        """Total contact force per contact (normal + friction), shape (k, 3)."""
        normals = np.array([p.normal for p in self.points]).reshape(-1, 3)
        return self.normal_force[:, None] * normals + self.friction


def contact_points(model, t, y):
    """The :class:`ContactPoint` of every contact of ``model`` at ``(t, y)``."""
    gap, grad, normal, vel, jac, acc, rate = model._fn["contacts"](
        t, y, model._p, model._r(t, y))
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
    """

    direction: np.ndarray
    slow: float = np.inf


def slip_direction(point, reference=None, tiny=1e-12):
    """Unit slip direction of a sliding contact.

    Without a ``reference`` it is the direction of the slip velocity (zero
    when there is none).  With one (a :class:`SlipReference` or a direction
    vector), the slip velocity's direction is used unless the slip is slow
    and has no positive component along the reference; then the reference
    is: the friction does not flip when the slip velocity passes through
    zero, and the equations stay smooth up to the event that stops the slip.
    """
    vt = point.slip_velocity
    speed = np.linalg.norm(vt)
    moving = speed > tiny * max(1.0, np.linalg.norm(point.velocity))
    if reference is None:
        return vt / speed if moving else np.zeros(3)
    if not isinstance(reference, SlipReference):
        reference = SlipReference(np.asarray(reference, dtype=float))
    s = reference.direction
    if moving and (vt @ s > 0 or speed > reference.slow):
        return vt / speed
    s = s - (s @ point.normal) * point.normal
    norm = np.linalg.norm(s)
    return s / norm if norm > 0 else np.zeros(3)


def _redundant(rows, rtol=1e-10):
    """Whether the constraint rows (shape (k, n_u)) are linearly dependent."""
    if rows.shape[0] > rows.shape[1]:
        return True
    sv = np.linalg.svd(rows, compute_uv=False)
    return sv[-1] <= rtol * sv[0]


def solve_modes(model, t, y, modes, directions=None, stabilization=10.0):
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

    Returns
    -------
    ContactSolution

    Raises
    ------
    numpy.linalg.LinAlgError
        When the system is singular for another reason than redundant
        contact constraints (which get the least-norm contact forces).
    """
    y = np.asarray(y, dtype=float)
    o, m = model.n_u, model.n_u_dep
    p = o - m
    qd, mass, force, vel_B, acc_K, acc_f = model._dynamics(t, y)
    points = contact_points(model, t, y)
    coefficients = model.contacts
    directions = directions or [None] * len(points)
    force = force.copy()
    columns, rows, rhs, layout, slip_columns = [], [], [], [], []
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
            s = slip_direction(point, directions[c])
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
        R = np.eye(o)
    A = np.zeros((o + k, o + k))
    b = np.zeros(o + k)
    A[:p, :o] = R @ mass
    b[:p] = R @ force
    if m:
        A[p:o, :o] = acc_K
        b[p:o] = -acc_f
    if k:
        A[o:, :o] = np.array(rows).reshape(k, o)
        b[o:] = rhs
    redundant = k and _redundant(np.vstack([vel_B.reshape(m, o), A[o:, :o]]))
    # friction -mu |N| s: the sign of N is assumed positive, and corrected for
    # bilateral contacts whose normal force turns out to pull
    sign = np.ones(k)
    for _ in range(len(slip_columns) + 1):
        for i, normal_column, friction_column, _ in slip_columns:
            G[:, i] = normal_column - sign[i] * friction_column
        A[:p, o:] = -(R @ G)
        if redundant:
            # statically indeterminate (e.g. a ladder sticking at both ends): the
            # accelerations are determined, the contact forces are not; take
            # the least-norm forces
            sol = np.linalg.lstsq(A, b, rcond=None)[0]
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
                           points=points, dissipation=dissipation, power=power)
