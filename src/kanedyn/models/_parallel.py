r"""Parallel manipulators: the planar 3-RRR, prescribed platform motions, inverse kinematics.

A parallel manipulator joins a moving platform to the ground by several legs,
so its configuration is held by loop-closure (configuration) constraints.
The models here take the **platform pose as the independent coordinates**
and the leg joint angles as dependent ones: the inverse kinematics (pose ->
joints) of these machines is explicit, leg by leg, whereas their forward
kinematics (actuated joints -> pose) has several solutions and no closed
form.  A prescribed platform motion therefore fixes the independent
coordinates, speeds and accelerations directly, and the dependent ones follow
from :func:`planar_3rrr_ik` (closed form) or :func:`newton_ik` (Newton on the
configuration constraints of any numeric model, warm-started along the
trajectory).

Trajectories: :func:`quintic_pose` (rest to rest) and :func:`sinusoid_pose`
give a pose, its rate and its second rate at given times, for any number of
pose components (``x, y, phi`` of the 3-RRR platform).
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ConstraintError, ModelError
from ..modeling import JointActuator
from ._base import ModelDefinition

__all__ = ["planar_3rrr", "PLANAR_3RRR_GEOMETRY", "planar_3rrr_ik", "quintic_pose",
           "sinusoid_pose", "newton_ik", "stewart_platform", "STEWART_GEOMETRY",
           "stewart_anchors", "stewart_leg_lengths"]

#: Default geometry of :func:`planar_3rrr` (m): base circumradius ``R_b``,
#: platform circumradius ``r_p``, proximal and distal link lengths ``l_1, l_2``.
PLANAR_3RRR_GEOMETRY = {"R_b": 0.6, "r_p": 0.15, "l_1": 0.35, "l_2": 0.35}

_ANCHOR_ANGLES = tuple(np.pi / 2 + 2 * np.pi * i / 3 for i in range(3))


# ------------------------------------------------------------------ model
def planar_3rrr(gravity=False):
    r"""A planar 3-RRR parallel manipulator: three RRR legs carry a triangular platform.

    Geometry.  Base joints :math:`A_i = R_b(\cos\alpha_i, \sin\alpha_i)` and
    platform anchors :math:`c_i = r_p(\cos\alpha_i, \sin\alpha_i)` (in the
    platform frame), :math:`\alpha_i = 90° + 120°\,(i - 1)`, ``i = 1, 2, 3``:
    both triangles equilateral, the platform's pointing the same way as the
    base's at ``phi = 0``.  Leg ``i``: a proximal link of length ``l_1`` turning
    about :math:`A_i` (absolute angle ``theta{i}`` from ``N.x``; the actuated
    joint), a distal link of length ``l_2`` (absolute angle ``psi{i}``) from the
    elbow :math:`B_i` to the platform anchor :math:`C_i`, all joints revolute
    about ``N.z``.  Defaults (:data:`PLANAR_3RRR_GEOMETRY`): ``R_b = 0.6 m``,
    ``r_p = 0.15 m``, ``l_1 = l_2 = 0.35 m``; at the home pose each leg
    spans 0.45 m of its 0.70 m reach.

    Inertias.  Links are uniform rods: masses ``m_1 = 1.0 kg`` (proximal) and
    ``m_2 = 0.8 kg`` (distal), central moments :math:`m l^2/12` about the
    joint axis.  The platform is a uniform equilateral triangular plate of
    mass ``m_p = 1.5 kg`` and circumradius ``r_p``: central moment
    :math:`I_p = m_p r_p^2/4` about ``N.z``, mass centre at the platform
    centre.

    Coordinates.  Independent: the platform pose ``x, y`` (m, its centre in
    ``N``) and ``phi`` (rad, about ``N.z``), speeds ``vx, vy`` (m/s), ``w``
    (rad/s).  Dependent: ``theta1..3, psi1..3`` (rad) and their rates
    ``dtheta1..3, dpsi1..3`` (rad/s), held by six loop closures
    :math:`A_i + l_1\hat e(\theta_i) + l_2\hat e(\psi_i) - C_i = 0` (``N.x``
    and ``N.y`` components) and their time derivatives.  The pose is the
    independent set because the inverse kinematics is then explicit
    (:func:`planar_3rrr_ik`, one two-link problem per leg) and a prescribed
    platform motion fixes the independent speeds directly.

    Parameters
    ----------
    gravity : bool
        ``False`` (default): the manipulator lies in a horizontal plane.
        ``True``: the plane is vertical, gravity ``g`` along ``-N.y``.

    Returns
    -------
    ModelDefinition
        ``symbols`` holds ``pose`` (``[x, y, phi]``), ``pose_rates``,
        ``theta``, ``psi``, ``dtheta``, ``dpsi``, ``N``, the geometry symbols
        ``R_b, r_p, l_1, l_2`` and ``anchors`` (the points :math:`C_i`).
        ``actuators``: three :class:`~kanedyn.JointActuator` ``base1..3``,
        torques on the proximal links about ``N.z`` (rates ``theta{i}'``);
        ``body_groups``: ``platform``, ``proximal``, ``distal``.
    """
    if not isinstance(gravity, bool):
        raise ModelError(f"3rrr: gravity must be True or False, got {gravity!r}")
    x, y, phi = me.dynamicsymbols("x y phi")
    vx, vy, w = me.dynamicsymbols("vx vy w")
    theta = list(me.dynamicsymbols("theta1:4"))
    psi = list(me.dynamicsymbols("psi1:4"))
    dtheta = list(me.dynamicsymbols("dtheta1:4"))
    dpsi = list(me.dynamicsymbols("dpsi1:4"))
    Rb, rp, l1, l2 = sm.symbols("R_b r_p l_1 l_2", positive=True)
    m1, m2, mp, g = sm.symbols("m_1 m_2 m_p g", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = me.ReferenceFrame("P")
    P.orient_axis(N, N.z, phi)
    P.set_ang_vel(N, w * N.z)
    Gp = O.locatenew("Gp", x * N.x + y * N.y)
    Gp.set_vel(N, vx * N.x + vy * N.y)
    bodies = [me.RigidBody("platform", Gp, P, mp,
                           (me.inertia(P, 0, 0, mp * rp ** 2 / 4), Gp))]
    centres = [Gp]
    config, velocity, anchors, actuators = [], [], [], []
    for i in range(3):
        ca, sa = sm.cos(2 * sm.pi * i / 3 + sm.pi / 2), sm.sin(2 * sm.pi * i / 3 + sm.pi / 2)
        A = O.locatenew(f"A{i + 1}", Rb * (ca * N.x + sa * N.y))
        A.set_vel(N, 0)
        C = Gp.locatenew(f"C{i + 1}", rp * (ca * P.x + sa * P.y))
        C.v2pt_theory(Gp, N, P)
        anchors.append(C)
        tip = A
        for name, q, u, length, mass in (("proximal", theta[i], dtheta[i], l1, m1),
                                         ("distal", psi[i], dpsi[i], l2, m2)):
            F = me.ReferenceFrame(f"F_{name}{i + 1}")
            F.orient_axis(N, N.z, q)
            F.set_ang_vel(N, u * N.z)
            G = tip.locatenew(f"G_{name}{i + 1}", length / 2 * F.x)
            G.set_vel(N, tip.vel(N) + length / 2 * u * F.y)
            end = tip.locatenew(f"{'B' if name == 'proximal' else 'D'}{i + 1}", length * F.x)
            end.set_vel(N, tip.vel(N) + length * u * F.y)
            bodies.append(me.RigidBody(f"{name}{i + 1}", G, F, mass,
                                       (me.inertia(F, 0, 0, mass * length ** 2 / 12), G)))
            if name == "proximal":
                actuators.append(JointActuator(f"base{i + 1}", q, frame=F, axis=N.z))
            centres.append(G)
            tip = end
        gap = tip.pos_from(O) - C.pos_from(O)
        gap_rate = tip.vel(N) - C.vel(N)
        config += [gap.dot(N.x), gap.dot(N.y)]
        velocity += [gap_rate.dot(N.x), gap_rate.dot(N.y)]
    q_ind, u_ind = [x, y, phi], [vx, vy, w]
    q_dep, u_dep = theta + psi, dtheta + dpsi
    kd_eqs = [q.diff() - u for q, u in zip(q_ind + q_dep, u_ind + u_dep)]
    kane_args = dict(frame=N, q_ind=q_ind, u_ind=u_ind, kd_eqs=kd_eqs, q_dep=q_dep,
                     u_dep=u_dep, configuration_constraints=config,
                     velocity_constraints=velocity, bodies=bodies, loads=[])
    constants = {Rb: PLANAR_3RRR_GEOMETRY["R_b"], rp: PLANAR_3RRR_GEOMETRY["r_p"],
                 l1: PLANAR_3RRR_GEOMETRY["l_1"], l2: PLANAR_3RRR_GEOMETRY["l_2"],
                 m1: 1.0, m2: 0.8, mp: 1.5}
    units = {Rb: "m", rp: "m", l1: "m", l2: "m", m1: "kg", m2: "kg", mp: "kg"}
    if gravity:
        kane_args["loads"] = [(G, -b.mass * g * N.y) for G, b in zip(centres, bodies)]
        kane_args["potential_energy"] = sm.Add(*(b.mass * g * G.pos_from(O).dot(N.y)
                                                 for G, b in zip(centres, bodies)))
        constants[g] = 9.81
        units[g] = "m/s^2"
    home, _, _ = planar_3rrr_ik(np.zeros(3))
    initial = {s: 0.0 for s in q_ind + u_ind + u_dep}
    initial.update(dict(zip(q_dep, home[3:])))
    return ModelDefinition(
        name="3rrr",
        title="planar 3-RRR parallel manipulator" + (" in a vertical plane under gravity"
                                                      if gravity else " (horizontal)"),
        kane_args=kane_args, constants=constants, constant_units=units,
        initial_state=initial, t_end=2.0,
        symbols=dict(pose=q_ind, pose_rates=u_ind, theta=theta, psi=psi, dtheta=dtheta,
                     dpsi=dpsi, N=N, R_b=Rb, r_p=rp, l_1=l1, l_2=l2, anchors=anchors),
        actuators=tuple(actuators),
        body_groups={"platform": ("platform",),
                     "proximal": tuple(f"proximal{i}" for i in range(1, 4)),
                     "distal": tuple(f"distal{i}" for i in range(1, 4))},
        description="The platform pose (x, y, phi) is independent; the six leg angles "
                    "are dependent, completed from the loop closures "
                    "(kd.models.planar_3rrr_ik gives them in closed form).")


# ----------------------------------------------------- inverse kinematics
def _geometry(geometry):
    values = dict(PLANAR_3RRR_GEOMETRY)
    for key, value in (geometry or {}).items():
        key = str(key)
        if key not in values:
            raise ModelError(f"3rrr: unknown geometry parameter {key!r}; "
                             f"known: {', '.join(values)}")
        values[key] = float(value)
    return values


def _rows(value, k, name):
    if value is None:
        return np.zeros((k, 3))
    arr = np.asarray(value, dtype=float)
    if arr.shape[-1:] != (3,):
        raise ValueError(f"3rrr inverse kinematics: {name} must have 3 components "
                         f"(x, y, phi) in its last axis, got shape {arr.shape}")
    return np.broadcast_to(arr.reshape(-1, 3), (k, 3))


def planar_3rrr_ik(pose, rate=None, accel=None, geometry=None, elbow=(1, 1, 1)):
    r"""Closed-form inverse kinematics of :func:`planar_3rrr`: leg angles, rates, accelerations.

    Each leg is a two-link arm from :math:`A_i` to the platform anchor
    :math:`C_i = (x, y) + R(\phi)c_i`; with :math:`d = C_i - A_i`,
    :math:`r = |d|`, the proximal angle is :math:`\theta_i = \arg d +
    \sigma_i\beta_i`, :math:`\cos\beta_i = (r^2 + l_1^2 - l_2^2)/(2rl_1)`, and
    the distal angle is the direction from the elbow to :math:`C_i`.  Rates and
    accelerations solve, leg by leg, the 2 x 2 time derivatives of the loop
    closure (its Jacobian is singular only at the edge of the workspace).

    Parameters
    ----------
    pose : array_like, shape (3,) or (k, 3)
        Platform pose ``x, y`` (m), ``phi`` (rad), one row per point.
    rate, accel : array_like, shape (3,) or (k, 3), optional
        Pose rates (m/s, rad/s) and their rates (m/s², rad/s²); zero if omitted.
    geometry : dict, optional
        Overrides of :data:`PLANAR_3RRR_GEOMETRY` by name (m).
    elbow : sequence of three ±1
        Branch of each leg: +1 puts the proximal link counter-clockwise of
        the line from :math:`A_i` to :math:`C_i`.

    Returns
    -------
    q, u, udot : ndarray, shape (k, 9) (or (9,) for a single pose)
        Coordinates, speeds and their rates in the model's order
        ``x, y, phi, theta1..3, psi1..3``; angles unwrapped along the points.

    Raises
    ------
    ConstraintError
        When a pose is out of reach of a leg; the message names the leg, the
        point and by how much (m).
    """
    single = np.ndim(pose) == 1
    P = np.atleast_2d(np.asarray(pose, dtype=float))
    if P.shape[-1] != 3 or P.ndim != 2:
        raise ValueError(f"3rrr inverse kinematics: pose must have shape (3,) or (k, 3), "
                         f"got {np.shape(pose)}")
    k = len(P)
    V, A = _rows(rate, k, "rate"), _rows(accel, k, "accel")
    sigma = np.asarray(elbow, dtype=float)
    if sigma.shape != (3,) or not np.all(np.abs(sigma) == 1):
        raise ValueError(f"3rrr inverse kinematics: elbow must be three values +1 or -1, "
                         f"got {elbow!r}")
    geo = _geometry(geometry)
    Rb, rp, l1, l2 = geo["R_b"], geo["r_p"], geo["l_1"], geo["l_2"]
    x, y, phi = P.T
    vx, vy, w = V.T
    ax, ay, al = A.T
    q = np.zeros((k, 9))
    u = np.zeros((k, 9))
    ud = np.zeros((k, 9))
    q[:, :3], u[:, :3], ud[:, :3] = P, V, A
    for i, alpha in enumerate(_ANCHOR_ANGLES):
        # anchor offset R(phi) c_i and the anchor's position, velocity, acceleration
        ox, oy = rp * np.cos(phi + alpha), rp * np.sin(phi + alpha)
        dx, dy = x + ox - Rb * np.cos(alpha), y + oy - Rb * np.sin(alpha)
        r = np.hypot(dx, dy)
        over, under = r - (l1 + l2), abs(l1 - l2) - r
        bad = np.flatnonzero((over > 0) | (under > 0))
        if bad.size:
            j = bad[0]
            how = (f"{over[j]:.6g} m beyond its full reach {l1 + l2:.6g} m" if over[j] > 0
                   else f"{under[j]:.6g} m inside its least reach {abs(l1 - l2):.6g} m")
            raise ConstraintError(
                f"3rrr: pose (x={x[j]:.6g}, y={y[j]:.6g}, phi={phi[j]:.6g}) at point {j} "
                f"is out of reach of leg {i + 1}: its anchor is {how}"
                + (f" ({bad.size} points out of reach of this leg)" if bad.size > 1 else ""))
        cb = np.clip((r ** 2 + l1 ** 2 - l2 ** 2) / (2 * r * l1), -1.0, 1.0)
        th = np.arctan2(dy, dx) + sigma[i] * np.arccos(cb)
        ps = np.arctan2(dy - l1 * np.sin(th), dx - l1 * np.cos(th))
        th, ps = np.unwrap(th), np.unwrap(ps)
        cv = np.array([vx - w * oy, vy + w * ox])                     # anchor velocity
        ca = np.array([ax - al * oy - w ** 2 * ox, ay + al * ox - w ** 2 * oy])
        # J [theta', psi'] = anchor velocity, J = [l1 e_perp(theta), l2 e_perp(psi)]
        J = np.empty((k, 2, 2))
        J[:, :, 0] = np.stack([-l1 * np.sin(th), l1 * np.cos(th)], axis=1)
        J[:, :, 1] = np.stack([-l2 * np.sin(ps), l2 * np.cos(ps)], axis=1)
        rates = np.linalg.solve(J, cv.T[..., None])[..., 0]
        dth, dps = rates.T
        centripetal = np.array([-l1 * np.cos(th) * dth ** 2 - l2 * np.cos(ps) * dps ** 2,
                                -l1 * np.sin(th) * dth ** 2 - l2 * np.sin(ps) * dps ** 2])
        accs = np.linalg.solve(J, (ca - centripetal).T[..., None])[..., 0]
        q[:, 3 + i], q[:, 6 + i] = th, ps
        u[:, 3 + i], u[:, 6 + i] = dth, dps
        ud[:, 3 + i], ud[:, 6 + i] = accs.T
    if single:
        return q[0], u[0], ud[0]
    return q, u, ud


def newton_ik(model, t, q_ind, u_ind=None, udot_ind=None, guess=None, tol=1e-12):
    r"""Inverse kinematics of any closed-chain numeric model by Newton's method.

    For models whose independent coordinates are the prescribed ones (the
    platform pose of the models here): at each point the dependent
    coordinates solve the configuration constraints by Newton's method
    (:meth:`NumericModel.consistent_state`), starting from the previous point's
    solution (``guess`` for the first); the dependent speeds solve the velocity
    constraints, and the dependent accelerations the acceleration constraints
    :math:`K\dot u = -f_a` (the last rows of the reduced mass matrix and
    forcing).

    Parameters
    ----------
    model : NumericModel
        With configuration constraints, independent coordinates first.
    t : array_like, shape (k,)
        Times, s.
    q_ind, u_ind, udot_ind : array_like, shape (k, n_q_ind) / (k, n_u_ind)
        Prescribed independent coordinates, speeds and their rates (speeds and
        rates zero if omitted).
    guess : array_like, shape (n_q,), optional
        Starting coordinates of the first point (default: the model's
        independent values with zero dependent ones).
    tol : float
        Newton tolerance on the configuration residual.

    Returns
    -------
    Y : ndarray, shape (k, n_states)
        Consistent states.
    udot : ndarray, shape (k, n_u)
        All speed rates.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    k, n, o = len(t), model.n_q, model.n_u
    p_q, p_u = n - model.n_q_dep, o - model.n_u_dep
    Q = np.asarray(q_ind, dtype=float).reshape(k, p_q)
    U = np.zeros((k, p_u)) if u_ind is None else np.asarray(u_ind, float).reshape(k, p_u)
    A = (np.zeros((k, p_u)) if udot_ind is None
         else np.asarray(udot_ind, float).reshape(k, p_u))
    Y = np.zeros((k, model.n_states))
    Ud = np.zeros((k, o))
    y = np.zeros(model.n_states)
    if guess is not None:
        y[:n] = np.asarray(guess, dtype=float)
    for j in range(k):
        y[:p_q] = Q[j]
        y[n:n + p_u] = U[j]
        y = model.consistent_state(t[j], y, tol=tol)
        Y[j] = y
        Ud[j, :p_u] = A[j]
        if p_u < o:
            K = model.mass_matrix(t[j], y)[p_u:]
            fa = -model.forcing(t[j], y)[p_u:]
            Ud[j, p_u:] = np.linalg.solve(K[:, p_u:], -(fa + K[:, :p_u] @ A[j]))
        y = y.copy()
    return Y, Ud


# ----------------------------------------------------------- trajectories
def _times_and_vectors(t, *vectors):
    t = np.atleast_1d(np.asarray(t, dtype=float))
    out = [np.atleast_1d(np.asarray(v, dtype=float)) for v in vectors]
    return t, out


def quintic_pose(t, start, end, duration):
    r"""Rest-to-rest quintic motion from ``start`` to ``end`` in ``duration``.

    :math:`p(t) = p_0 + (p_1 - p_0)\,s(\tau)`, :math:`s = 10\tau^3 - 15\tau^4
    + 6\tau^5`, :math:`\tau = t/T` clipped to ``[0, 1]``: zero rate and
    acceleration at both ends, held at ``end`` afterwards.

    Parameters
    ----------
    t : array_like, shape (k,)
        Times, s.
    start, end : array_like, shape (n,)
        Start and end poses (units of the pose components).
    duration : float
        T, s (positive).

    Returns
    -------
    pose, rate, accel : ndarray, shape (k, n)
    """
    t, (p0, p1) = _times_and_vectors(t, start, end)
    if p0.shape != p1.shape:
        raise ValueError(f"quintic_pose: start {p0.shape} and end {p1.shape} differ in shape")
    if not duration > 0:
        raise ValueError(f"quintic_pose: duration must be positive, got {duration!r}")
    tau = np.clip(t / duration, 0.0, 1.0)[:, None]
    inside = ((t >= 0) & (t <= duration))[:, None]
    s = tau ** 3 * (10 - 15 * tau + 6 * tau ** 2)
    ds = 30 * tau ** 2 * (1 - tau) ** 2 / duration * inside
    dds = 60 * tau * (1 - tau) * (1 - 2 * tau) / duration ** 2 * inside
    delta = (p1 - p0)[None, :]
    return p0 + delta * s, delta * ds, delta * dds


def sinusoid_pose(t, centre, amplitude, frequency, phase=0.0):
    r"""Sinusoid in each pose component: :math:`p = c + a\sin(2\pi f t + \varphi)`.

    Parameters
    ----------
    t : array_like, shape (k,)
        Times, s.
    centre, amplitude : array_like, shape (n,)
        Mean pose and amplitudes (units of the pose components).
    frequency : float or array_like, shape (n,)
        Hz.
    phase : float or array_like, shape (n,)
        rad.

    Returns
    -------
    pose, rate, accel : ndarray, shape (k, n)
    """
    t, (c, a) = _times_and_vectors(t, centre, amplitude)
    if c.shape != a.shape:
        raise ValueError(f"sinusoid_pose: centre {c.shape} and amplitude {a.shape} "
                         "differ in shape")
    om = 2 * np.pi * np.broadcast_to(np.asarray(frequency, dtype=float), c.shape)
    arg = om * t[:, None] + np.broadcast_to(np.asarray(phase, dtype=float), c.shape)
    return c + a * np.sin(arg), a * om * np.cos(arg), -a * om ** 2 * np.sin(arg)


# ------------------------------------------------------- Stewart platform
#: Default geometry of :func:`stewart_platform`: base and platform anchor
#: circle radii ``R_b, r_p`` (m), home height ``h`` (m) of the platform centre,
#: half spread ``gamma_b`` (rad) of the base anchor pairs, leg attachment
#: length ``c`` (m; cylinder and piston lengths, each centred half-way).
STEWART_GEOMETRY = {"R_b": 0.5, "r_p": 0.3, "h": 0.4, "gamma_b": np.radians(15.0),
                    "c": 0.3}


def stewart_anchors(geometry=None):
    r"""Base and platform anchor points of :func:`stewart_platform`, leg by leg.

    Base anchors :math:`A_j = R_b(\cos\beta_j, \sin\beta_j, 0)` at
    :math:`\beta = 120°k \mp \gamma_b`; platform anchors (platform frame)
    :math:`c_j = r_p(\cos\pi_j, \sin\pi_j, 0)` with :math:`\pi_j = \beta_j \mp
    2\gamma_b` (the leg from the anchor at :math:`120°k - \gamma_b` goes to
    :math:`120°k - 3\gamma_b`, its partner mirrors it): a symmetric platform
    whose legs lean alike.

    Returns
    -------
    A, c : ndarray, shape (6, 3)
        Base anchors in ``N`` and platform anchors in the platform frame, m.
    """
    geo = dict(STEWART_GEOMETRY)
    for key, value in (geometry or {}).items():
        if key not in geo:
            raise ModelError(f"stewart-platform: unknown geometry parameter {key!r}; "
                             f"known: {', '.join(geo)}")
        geo[key] = float(value)
    gb = geo["gamma_b"]
    beta, pi = [], []
    for k in range(3):
        for sign in (-1, 1):
            beta.append(2 * np.pi * k / 3 + sign * gb)
            pi.append(2 * np.pi * k / 3 + 3 * sign * gb)
    beta, pi = np.array(beta), np.array(pi)
    A = geo["R_b"] * np.stack([np.cos(beta), np.sin(beta), 0 * beta], axis=1)
    c = geo["r_p"] * np.stack([np.cos(pi), np.sin(pi), 0 * pi], axis=1)
    return A, c


def _rotation_xyz(a, b, c):
    """Rotation matrices (k, 3, 3) of body-fixed X, Y, Z angles (N components of P axes)."""
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    R = np.empty(np.shape(a) + (3, 3))
    R[..., 0, 0] = cb * cc
    R[..., 0, 1] = -cb * sc
    R[..., 0, 2] = sb
    R[..., 1, 0] = sa * sb * cc + ca * sc
    R[..., 1, 1] = -sa * sb * sc + ca * cc
    R[..., 1, 2] = -sa * cb
    R[..., 2, 0] = -ca * sb * cc + sa * sc
    R[..., 2, 1] = ca * sb * sc + sa * cc
    R[..., 2, 2] = ca * cb
    return R


def stewart_leg_lengths(pose, geometry=None):
    r"""Leg lengths of :func:`stewart_platform` at platform poses, in closed form.

    :math:`s_j = |p + R(\phi)c_j - A_j|`, with :math:`p = (x, y, z)` and
    :math:`R` the body-fixed X-Y-Z rotation of angles ``phi_x, phi_y, phi_z``.

    Parameters
    ----------
    pose : array_like, shape (6,) or (k, 6)
        ``x, y, z`` (m), ``phi_x, phi_y, phi_z`` (rad).

    Returns
    -------
    ndarray, shape (6,) or (k, 6)
        Leg lengths, m.
    """
    P = np.asarray(pose, dtype=float)
    if P.shape[-1:] != (6,) or P.ndim > 2:
        raise ValueError(f"stewart_leg_lengths: pose must have shape (6,) or (k, 6), "
                         f"got {P.shape}")
    A, c = stewart_anchors(geometry)
    R = _rotation_xyz(P[..., 3], P[..., 4], P[..., 5])
    tips = P[..., None, :3] + np.einsum("...ij,kj->...ki", R, c)
    return np.linalg.norm(tips - A, axis=-1)


def stewart_platform():
    r"""A Stewart–Gough platform: six UPS legs between a fixed base and a moving platform.

    Geometry (:data:`STEWART_GEOMETRY`, :func:`stewart_anchors`): base
    anchors on a circle of radius ``R_b = 0.5 m`` in pairs at :math:`120°k \pm
    15°`, platform anchors on a circle of radius ``r_p = 0.3 m`` at
    :math:`120°k \pm 45°`; home pose: platform centre at height ``h = 0.4 m``
    above the base centre, no rotation.  Leg ``j``: a universal joint at
    :math:`A_j` (angles ``a{j}`` about ``N.x`` then ``b{j}`` about the
    turned ``y``; the leg axis is the resulting ``z``), a prismatic joint of
    length ``s{j}`` (m, the actuated one), a spherical joint at the platform
    anchor.

    Inertias.  Platform: mass ``m_p = 10 kg``, a uniform disc of radius
    ``r_p``: :math:`I_{xx} = I_{yy} = m_p r_p^2/4`, :math:`I_{zz} = m_p
    r_p^2/2`.  Each leg: a cylinder (mass ``m_c = 1.0 kg``, centre ``c/2 =
    0.15 m`` from :math:`A_j`) and a piston (``m_r = 0.5 kg``, centre
    ``c/2`` short of the platform anchor), both slender rods of length ``c``
    (moments :math:`mc^2/12` about axes across the leg, none along it).
    Gravity ``g = 9.81 m/s²`` along ``-N.z``.

    Coordinates.  Independent: the pose ``x, y, z`` (m) and body-fixed X-Y-Z
    angles ``phi_x, phi_y, phi_z`` (rad) of the platform, speeds their rates.
    Dependent: ``a1..6, b1..6`` (rad), ``s1..6`` (m), held by the eighteen
    loop closures :math:`A_j + s_j\hat l_j - (p + R c_j) = 0`.  The inverse
    kinematics is explicit (:func:`stewart_leg_lengths`).

    Returns
    -------
    ModelDefinition
        ``actuators``: six :class:`~kanedyn.JointActuator` ``leg1..6``, axial
        forces along the leg extensions ``s{j}`` (positive pushes the platform
        away from the base); ``body_groups``: ``platform`` and ``legs``
        (cylinders and pistons).
    """
    pose = list(me.dynamicsymbols("x y z phi_x phi_y phi_z"))
    rates = list(me.dynamicsymbols("vx vy vz wx wy wz"))
    a = list(me.dynamicsymbols("a1:7"))
    b = list(me.dynamicsymbols("b1:7"))
    s = list(me.dynamicsymbols("s1:7"))
    da = list(me.dynamicsymbols("da1:7"))
    db = list(me.dynamicsymbols("db1:7"))
    ds = list(me.dynamicsymbols("ds1:7"))
    rp, cl, mp, mc, mr, g = sm.symbols("r_p c m_p m_c m_r g", positive=True)
    q_all, u_all = pose + a + b + s, rates + da + db + ds
    to_u = dict(zip([q.diff() for q in q_all], u_all))
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = me.ReferenceFrame("P")
    P.orient_body_fixed(N, pose[3:], "XYZ")
    P.set_ang_vel(N, P.ang_vel_in(N).subs(to_u))
    Gp = O.locatenew("Gp", pose[0] * N.x + pose[1] * N.y + pose[2] * N.z)
    Gp.set_vel(N, rates[0] * N.x + rates[1] * N.y + rates[2] * N.z)
    bodies = [me.RigidBody("platform", Gp, P, mp,
                           (me.inertia(P, mp * rp ** 2 / 4, mp * rp ** 2 / 4,
                                       mp * rp ** 2 / 2), Gp))]
    A_num, c_num = stewart_anchors()
    Rb = STEWART_GEOMETRY["R_b"]
    config, velocity, centres, actuators = [], [], [Gp], []
    for j in range(6):
        Aj = O.locatenew(f"A{j + 1}", sum((sm.nsimplify(v / Rb) * sm.Symbol("R_b") * e
                                           for v, e in zip(A_num[j], (N.x, N.y, N.z))),
                                          me.Vector(0)))
        Aj.set_vel(N, 0)
        Cj = Gp.locatenew(f"C{j + 1}", sum((sm.nsimplify(v / STEWART_GEOMETRY["r_p"]) * rp * e
                                            for v, e in zip(c_num[j], (P.x, P.y, P.z))),
                                           me.Vector(0)))
        Cj.v2pt_theory(Gp, N, P)
        L = me.ReferenceFrame(f"L{j + 1}")
        L.orient_body_fixed(N, (a[j], b[j], 0), "XYZ")
        L.set_ang_vel(N, L.ang_vel_in(N).subs(to_u))
        G1 = Aj.locatenew(f"Gc{j + 1}", cl / 2 * L.z)
        G1.v2pt_theory(Aj, N, L)
        G2 = Aj.locatenew(f"Gr{j + 1}", (s[j] - cl / 2) * L.z)
        G2.set_vel(N, ds[j] * L.z + me.cross(L.ang_vel_in(N), G2.pos_from(Aj)))
        tip = Aj.locatenew(f"T{j + 1}", s[j] * L.z)
        tip.set_vel(N, ds[j] * L.z + me.cross(L.ang_vel_in(N), tip.pos_from(Aj)))
        for name, G, mass in (("cylinder", G1, mc), ("piston", G2, mr)):
            moment = mass * cl ** 2 / 12
            bodies.append(me.RigidBody(f"{name}{j + 1}", G, L, mass,
                                       (me.inertia(L, moment, moment, 0), G)))
            centres.append(G)
        actuators.append(JointActuator(f"leg{j + 1}", s[j], point=tip, reaction_point=Aj,
                                       axis=L.z))
        gap = tip.pos_from(O) - Cj.pos_from(O)
        rate = tip.vel(N) - Cj.vel(N)
        config += [gap.dot(e) for e in (N.x, N.y, N.z)]
        velocity += [rate.dot(e) for e in (N.x, N.y, N.z)]
    loads = [(G, -body.mass * g * N.z) for G, body in zip(centres, bodies)]
    heights = sm.Add(*(body.mass * g * G.pos_from(O).dot(N.z)
                       for G, body in zip(centres, bodies)))
    q_dep, u_dep = a + b + s, da + db + ds
    home = np.array([0, 0, STEWART_GEOMETRY["h"], 0, 0, 0])
    tips = home[:3] + c_num - A_num
    lengths = np.linalg.norm(tips, axis=1)
    e = tips / lengths[:, None]
    initial = {v: 0.0 for v in u_all}
    initial.update(dict(zip(pose, home)))
    initial.update(dict(zip(a, np.arctan2(-e[:, 1], e[:, 2]))))
    initial.update(dict(zip(b, np.arcsin(e[:, 0]))))
    initial.update(dict(zip(s, lengths)))
    Rb_sym = sm.Symbol("R_b")
    constants = {Rb_sym: Rb, rp: STEWART_GEOMETRY["r_p"], cl: STEWART_GEOMETRY["c"],
                 mp: 10.0, mc: 1.0, mr: 0.5, g: 9.81}
    return ModelDefinition(
        name="stewart-platform", title="Stewart-Gough platform, six UPS legs, under gravity",
        kane_args=dict(frame=N, q_ind=pose, u_ind=rates,
                       kd_eqs=[q.diff() - u for q, u in zip(q_all, u_all)], q_dep=q_dep,
                       u_dep=u_dep, configuration_constraints=config,
                       velocity_constraints=velocity, bodies=bodies, loads=loads,
                       potential_energy=heights),
        constants=constants,
        constant_units={Rb_sym: "m", rp: "m", cl: "m", mp: "kg", mc: "kg", mr: "kg",
                        g: "m/s^2"},
        initial_state=initial, t_end=2.0,
        symbols=dict(pose=pose, pose_rates=rates, a=a, b=b, s=s, N=N, g=g, m_p=mp,
                     m_c=mc, m_r=mr, platform=bodies[0]),
        actuators=tuple(actuators),
        body_groups={"platform": ("platform",),
                     "legs": tuple(f"{part}{j}" for j in range(1, 7)
                                   for part in ("cylinder", "piston"))},
        description="The platform pose is independent; leg angles and lengths are "
                    "dependent (kd.models.stewart_leg_lengths gives the lengths in "
                    "closed form).")
