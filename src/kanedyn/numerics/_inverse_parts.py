r"""Inverse-dynamics forces taken apart by cause and by body; the power balance.

The generalized forces a motion needs (:func:`kanedyn.numerics._inverse.inverse_dynamics`)
are, on all speeds before the reduction to the independent ones,

.. math::

    \tau_r = \sum_k \left[V_{kr}\cdot m_k a_k + W_{kr}\cdot (I_k\alpha_k)\right]
             + \sum_k \left[V_{kr}\cdot F^*_k + W_{kr}\cdot T^*_k\right]
             - \sum_l F_l\cdot V_{lr},

body terms with the accelerations :math:`a_k = \sum_s V_{ks}\dot u_s,\
\alpha_k = \sum_s W_{ks}\dot u_s` (the *acceleration* part), the inertia force
and torque with :math:`\dot u = 0` (:math:`F^*_k, T^*_k`, the *velocity* part:
Coriolis and centripetal) and each load's generalized active force.  A load
:math:`F_l(g)` is split exactly at the gravity symbol :math:`g`: its *gravity*
part :math:`F_l(g) - F_l(0)` and the rest :math:`F_l(0)` (the *wrench* part,
which holds any :class:`~kanedyn.ExternalWrench` reduced to loads).  For
closed chains the dependent rates :math:`\dot u_D = -K_D^{-1}(K_I\dot u_I +
f_a)` split likewise: the part proportional to :math:`\dot u_I` belongs to
the acceleration part, the part from :math:`f_a` to the velocity part.  Every
row is reduced to the independent speeds with :math:`A_r` as the total is.
What the body and load sums leave out (flexible bodies' own terms) is the
``other`` part, round-off for rigid bodies and particles.

The power balance checks the same forces against the energies computed
independently: with the actuator rates :math:`\dot s = J u_I`,

.. math::

    \sum_i f_i\dot s_i = \dot T + \dot T_\text{drive} + \dot V - P_\text{wrench},

:math:`\dot T = \partial T/\partial t|_{\dot u = 0} + \sum_s (\partial
T/\partial u_s)\dot u_s` differentiated from the kinetic-energy expression,
:math:`\dot V` from the declared potential energy (taken to be that of the
gravity loads), :math:`\dot T_\text{drive} = \sum_i m_i\dot s_i\ddot s_i`
and :math:`P_\text{wrench} = \sum_l F_l(0)\cdot v_l` the power of the
non-gravity loads.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..engine import dot, inertia_components, matvec
from ._inverse import _rows, _specification, _workspace
from .backends._python import compile_python, generate_python

__all__ = ["InverseParts", "ActuatorParts", "PowerBalance", "inverse_parts",
           "actuator_parts", "power_balance"]

CAUSES = ("acceleration", "velocity", "gravity", "wrench", "other")


@dataclass(frozen=True)
class InverseParts:
    r"""The generalized forces a motion needs, by cause and by body group.

    Every array has the shape of :func:`inverse_dynamics`' result,
    ``(n_u_ind, N)`` (N for translation rates, N m for angular rates).

    Attributes
    ----------
    total : numpy.ndarray
        The sum of the parts (equal to ``model.inverse_dynamics`` to round-off).
    acceleration, velocity, gravity, wrench, other : numpy.ndarray
        By cause (see :mod:`kanedyn.numerics._inverse_parts`).
    groups : dict
        ``{group: array}``: each group's inertia forces plus its bodies'
        weights (the gravity parts of loads at their mass centres); the group
        ``"other"`` holds the bodies no group names, ``"loads"`` every other
        load part, ``"unassigned"`` the ``other`` cause.
    bodies : dict
        ``{body name: array}``: inertia forces plus weight of each body.
    times : numpy.ndarray, shape (N,)
    states : numpy.ndarray, shape (n_states, N)
        The states completed from the constraints.
    rates, rates_acceleration : numpy.ndarray, shape (n_u, N)
        All speeds' rates, and their part proportional to the independent rates.
    """

    total: np.ndarray
    acceleration: np.ndarray
    velocity: np.ndarray
    gravity: np.ndarray
    wrench: np.ndarray
    other: np.ndarray
    groups: dict
    bodies: dict
    times: np.ndarray
    states: np.ndarray
    rates: np.ndarray
    rates_acceleration: np.ndarray
    extra: dict = field(default_factory=dict, repr=False)

    def by_cause(self):
        """``{cause: array}`` in the order of :data:`CAUSES`."""
        return {c: getattr(self, c) for c in CAUSES}


@dataclass(frozen=True)
class ActuatorParts:
    r"""Actuator forces by cause and by body group (arrays of shape ``(k, N)``).

    Attributes
    ----------
    names : tuple of str
    total : numpy.ndarray
        Sum of the parts (:meth:`ActuatorMap.forces` at each point).
    causes : dict
        ``{cause: array}`` for the causes of :class:`InverseParts`, the
        acceleration and velocity parts including the drive trains'.
    groups : dict
        The body groups, ``"loads"``, ``"unassigned"`` and ``"drive train"``
        (the reflected inertia :math:`m\ddot s`).
    drive_acceleration, drive_velocity : numpy.ndarray
        The drive-train part from :math:`J\dot u` (proportional to the
        independent rates) and from the rest of :math:`\ddot s`.
    generalized : InverseParts
    """

    names: tuple
    total: np.ndarray
    causes: dict
    groups: dict
    drive_acceleration: np.ndarray
    drive_velocity: np.ndarray
    generalized: InverseParts


@dataclass(frozen=True)
class PowerBalance:
    r"""Powers along a trajectory, in W (arrays of shape ``(N,)``).

    Attributes
    ----------
    actuator : numpy.ndarray
        :math:`\sum_i f_i\dot s_i`.
    kinetic_rate, drive_rate, potential_rate : numpy.ndarray
        :math:`\dot T` (bodies), :math:`\sum_i m_i\dot s_i\ddot s_i` (drive
        trains), :math:`\dot V` (zero when the model declares no potential).
    gravity_power, wrench_power : numpy.ndarray
        Power of the loads' gravity parts and of the other load parts.
    residual : numpy.ndarray
        ``actuator - (kinetic_rate + drive_rate + potential_rate - wrench_power)``.
    """

    actuator: np.ndarray
    kinetic_rate: np.ndarray
    drive_rate: np.ndarray
    potential_rate: np.ndarray
    gravity_power: np.ndarray
    wrench_power: np.ndarray
    residual: np.ndarray


def _gravity_symbol(eom, gravity):
    if gravity is None:
        return None
    if not isinstance(gravity, sm.Symbol):
        raise ModelError(f"gravity must be a SymPy symbol (a constant of the model such as "
                         f"g), got {gravity!r}")
    if gravity not in set(eom.constants):
        raise ModelError(f"gravity symbol {gravity} is not a constant of the model; its "
                         f"constants are {', '.join(sorted(map(str, eom.constants)))}")
    return eom._table.internal(gravity, "gravity")


def _parts_specification(model, gravity):
    """Arguments, outputs and the body and load names of the ``inverse_parts`` function."""
    args, (total, B, K, fa) = _specification(model)
    eom = model._eom
    prog, kin = _workspace(model)
    table = eom._table
    if eom.method != "kane" or kin is None:
        raise ModelError(f"inverse_parts needs equations derived by kd.kane, not by "
                         f"{eom.method!r}")
    o = model.n_u
    udot = list(table.udot)
    speeds = list(table.u)
    aux_zero = {ua: 0 for ua in table.u_aux}
    subs = model._substitutions

    def sub(e):
        e = prog.subs(e, aux_zero) if aux_zero else e
        return prog.subs(e, subs) if subs else e

    acc_rows, vel_rows, names, centres = [], [], [], []
    for terms, (force, torque) in zip(eom._body_terms, eom._inertial):
        terms = terms.on(prog)
        body = terms.body
        names.append(body.name)
        centres.append(body.masscenter)
        m = kin.internal(body.mass, f"mass of {body.name}")
        V, W = terms.partial_velocities, terms.partial_angular_velocities
        a = tuple(m * sm.Add(*[V[s][i] * udot[s] for s in range(o)]) for i in range(3))
        a = kin.let_vector(a, f"ma_{body.name}")
        if isinstance(body, me.RigidBody):
            I_N = inertia_components(kin, body, f"body {body.name}")[1]
            alpha = tuple(sm.Add(*[W[s][i] * udot[s] for s in range(o)]) for i in range(3))
            Ia = kin.let_vector(matvec(I_N, alpha), f"Ialpha_{body.name}")
        else:
            Ia = (sm.S.Zero,) * 3
        acc_rows.append([sub(dot(V[r], a) + dot(W[r], Ia)) for r in range(o)])
        vel_rows.append([sub(dot(V[r], force) + dot(W[r], torque)) for r in range(o)])
    g = _gravity_symbol(eom, gravity)
    grav_rows, rest_rows, grav_power, rest_power, locations = [], [], [], [], []
    for loc, vec in eom._load_vectors:
        base = (kin.angular_velocity(loc) if isinstance(loc, me.ReferenceFrame)
                else kin.velocity(loc))
        partial = [tuple(prog.subs(prog.diff(c, ur), aux_zero) for c in base)
                   for ur in speeds]
        rest = tuple(prog.subs(c, {g: 0}) for c in vec) if g is not None else vec
        grav = tuple(c - d for c, d in zip(vec, rest))
        grav_rows.append([sub(-dot(grav, partial[r])) for r in range(o)])
        rest_rows.append([sub(-dot(rest, partial[r])) for r in range(o)])
        grav_power.append(sub(dot(grav, base)))
        rest_power.append(sub(dot(rest, base)))
        locations.append(loc)
    other = [total[1][r] - sm.Add(*[rows[r] for rows in acc_rows + vel_rows + grav_rows
                                    + rest_rows]) for r in range(o)]
    kinetic = eom._kinetic
    kinetic_rate = kin.dt(kinetic) + sm.Add(*[prog.diff(kinetic, s) * d
                                              for s, d in zip(speeds, udot)])
    potential_rate = kin.dt(eom._potential) if eom._potential is not None else sm.S.Zero
    nb, nl = len(names), len(locations)
    outputs = [((nb, o), [e for row in acc_rows for e in row]),
               ((nb, o), [e for row in vel_rows for e in row]),
               ((nl, o), [e for row in grav_rows for e in row]),
               ((nl, o), [e for row in rest_rows for e in row]),
               ((o,), other), ((), [sub(kinetic_rate)]), ((), [sub(potential_rate)]),
               ((nl,), grav_power), ((nl,), rest_power), B, K, fa]
    return args, outputs, names, centres, locations


def _function(model, gravity):
    """The generated (vectorized NumPy) function, cached on the model per gravity symbol."""
    key = ("inverse_parts", gravity)
    cache = model._data.setdefault("inverse_parts", {})
    if key not in cache:
        args, outputs, names, centres, locations = _parts_specification(model, gravity)
        source = generate_python(_workspace(model)[0], "inverse_parts", args, outputs,
                                 vectorized=True, cse=True)
        cache[key] = (source, names, centres, locations)
    source, names, centres, locations = cache[key]
    fn = model._fn.get(key)
    if fn is None:
        fn = model._fn[key] = compile_python(source, "inverse_parts")
    return fn, names, centres, locations


def _points(model, t, q, u, udot):
    """Times, completed states, inputs and independent rates of the points."""
    single = np.ndim(q) == 1 and np.ndim(u) == 1 and np.ndim(udot) == 1
    count = 1 if np.ndim(q) == 1 else np.shape(q)[-1]
    n, o = model.n_q, model.n_u
    nq, p = n - model.n_q_dep, o - model.n_u_dep
    q = _rows(q, "q", (nq, n), count)
    u = _rows(u, "u", (p, o), count)
    rates = _rows(udot, "udot", (p, o), count)[:p]
    ts = np.array(np.broadcast_to(np.asarray(t, dtype=float), (count,)))
    Y = np.zeros((model.n_states, count))
    Y[:q.shape[0]], Y[n:n + u.shape[0]] = q, u
    if model.n_q_dep or model.n_u_dep:
        for i in range(count):
            if q.shape[0] < n and i:  # guesses for the dependent coordinates
                Y[nq:n, i] = Y[nq:n, i - 1]
            Y[:, i] = model.consistent_state(ts[i], Y[:, i])
    R = (np.array([model._input_values(ts[i], Y[:, i]) for i in range(count)]).T
         if model._inputs else np.zeros((0, count)))
    return single, ts, Y, R, rates


def _evaluate(model, t, q, u, udot, gravity):
    fn, names, centres, locations = _function(model, gravity)
    single, ts, Y, R, rates = _points(model, t, q, u, udot)
    o, m = model.n_u, model.n_u_dep
    p, count = o - m, ts.size
    U = np.zeros((o, count))
    U[:p] = rates
    Ua = U.copy()
    out = fn(ts, Y, model._p, np.vstack([R, U]))
    if m:
        B, K, fa = (np.moveaxis(x, -1, 0) for x in out[-3:])
        Ua[p:] = -np.linalg.solve(K[:, :, p:], K[:, :, :p] @ U[:p].T[:, :, None])[..., 0].T
        U[p:] = Ua[p:] - np.linalg.solve(K[:, :, p:], fa[:, :, None])[..., 0].T
        out = fn(ts, Y, model._p, np.vstack([R, U]))
        acc_a = fn(ts, Y, model._p, np.vstack([R, Ua]))[0]
        X = np.linalg.solve(B[:, :, p:], B[:, :, :p])  # -A_r, one per point
    else:
        acc_a, X = out[0], None

    def reduce(x):  # (o, N) -> (p, N)
        if X is None:
            return x
        return x[:p] - (np.swapaxes(X, 1, 2) @ x[p:].T[:, :, None])[..., 0].T

    acc, vel, grav, rest, other, dT, dV, Pg, Pw = out[:9]
    body_acc = [reduce(acc_a[k]) for k in range(len(names))]
    body_vel = [reduce(vel[k] + acc[k] - acc_a[k]) for k in range(len(names))]
    load_grav = [reduce(grav[j]) for j in range(len(locations))]
    load_rest = [reduce(rest[j]) for j in range(len(locations))]
    zero = np.zeros((p, count))
    parts = {"acceleration": sum(body_acc, zero), "velocity": sum(body_vel, zero),
             "gravity": sum(load_grav, zero), "wrench": sum(load_rest, zero),
             "other": reduce(np.broadcast_to(other, (o, count)))}
    bodies = {}
    for k, (name, centre) in enumerate(zip(names, centres)):
        weight = [load_grav[j] for j, loc in enumerate(locations) if loc is centre]
        bodies[name] = body_acc[k] + body_vel[k] + sum(weight, zero)
    loads = parts["wrench"] + sum((load_grav[j] for j, loc in enumerate(locations)
                                   if loc not in centres), zero)
    powers = {"kinetic_rate": np.broadcast_to(dT, (count,)).copy(),
              "potential_rate": np.broadcast_to(dV, (count,)).copy(),
              "gravity_power": np.sum(np.broadcast_to(Pg, (len(locations), count)), axis=0),
              "wrench_power": np.sum(np.broadcast_to(Pw, (len(locations), count)), axis=0)}
    return single, ts, Y, U, Ua, parts, bodies, loads, powers


def _grouping(groups, names):
    groups = {} if groups is None else dict(groups)
    owner = {}
    for group, members in groups.items():
        if group in ("other", "loads", "unassigned", "drive train"):
            raise ModelError(f"body group name {group!r} is reserved; choose another")
        if isinstance(members, str):
            raise ModelError(f"body group {group!r}: give a list of body names, not the "
                             f"string {members!r}")
        for b in members:
            if b not in names:
                raise ModelError(f"body group {group!r}: no body {b!r}; the bodies are "
                                 f"{', '.join(names)}")
            if b in owner:
                raise ModelError(f"body {b!r} is in groups {owner[b]!r} and {group!r}")
            owner[b] = group
    return groups, owner


def inverse_parts(model, t, q, u, udot, groups=None, gravity=None):
    r"""The inverse-dynamics forces by cause and by body group.

    Parameters
    ----------
    model : NumericModel
        Built by ``eom.numeric(...)`` from equations of :func:`kanedyn.kane`.
    t, q, u, udot
        As :meth:`NumericModel.inverse_dynamics`.
    groups : dict, optional
        ``{group name: [body names]}``; bodies not named form the group
        ``"other"``.
    gravity : sympy.Symbol, optional
        The gravity constant (e.g. ``g``): each load's part ``F(g) - F(0)``
        is its gravity part (``g dF/dg`` for loads linear in ``g``).  Without
        it, no gravity part: every load is in the ``wrench`` part.

    Returns
    -------
    InverseParts
        Arrays of shape ``(n_u_ind, N)``, or ``(n_u_ind,)`` for 1-D inputs.
    """
    single, ts, Y, U, Ua, parts, bodies, loads, _ = _evaluate(model, t, q, u, udot,
                                                              gravity)
    groups, owner = _grouping(groups, list(bodies))
    zero = np.zeros_like(parts["other"])
    by_group = {g: sum((bodies[b] for b in members), zero) for g, members in groups.items()}
    by_group["other"] = sum((v for b, v in bodies.items() if b not in owner), zero)
    by_group["loads"] = loads
    by_group["unassigned"] = parts["other"]
    total = sum(parts.values(), zero)

    def shape(x):
        return x[:, 0] if single else x

    return InverseParts(total=shape(total), **{c: shape(v) for c, v in parts.items()},
                        groups={g: shape(v) for g, v in by_group.items()},
                        bodies={b: shape(v) for b, v in bodies.items()}, times=ts,
                        states=Y, rates=U, rates_acceleration=Ua)


def _actuator_terms(amap, ts, Y, U, Ua):
    """Per point: the pseudo-inverse of ``J^T``, the rates and the drive-train terms."""
    model = amap.model
    n, p = model.n_q, model.n_u_ind
    out = []
    for i in range(ts.size):
        J_full, bias, masses = amap._terms(ts[i], Y[:, i])
        vel_B = model._dynamics(ts[i], Y[:, i])[3]
        Ar = -np.linalg.solve(vel_B[:, p:], vel_B[:, :p]) if model.n_u_dep else \
            np.zeros((0, p))
        J = J_full[:, :p] + J_full[:, p:] @ Ar
        pinv = np.linalg.pinv(J.T)
        accel = masses * (J_full @ Ua[:, i])
        veloc = masses * (J_full @ (U[:, i] - Ua[:, i]) + bias)
        rates = J_full @ Y[n:, i]
        out.append((pinv, J, accel, veloc, rates, masses))
    return out


def actuator_parts(amap, t, q, u, udot, groups=None, gravity=None):
    r"""Actuator forces by cause and by body group, through :class:`ActuatorMap`'s solve.

    Each part :math:`\tau_P` of :func:`inverse_parts` maps to
    :math:`f_P = (J^T)^+\tau_P`, the drive trains' reflected inertia to
    :math:`(J^T)^+J^T m\ddot s` (:math:`m\ddot s` itself for as many
    actuators as independent speeds), split into the part from the
    independent rates and the rest; the parts sum to
    :meth:`ActuatorMap.forces`.

    Parameters
    ----------
    amap : ActuatorMap
    t, q, u, udot, groups, gravity
        As :func:`inverse_parts`.

    Returns
    -------
    ActuatorParts
        Arrays of shape ``(k, N)`` (``k`` actuators, one column per point).
    """
    parts = inverse_parts(amap.model, np.atleast_1d(t), *(np.reshape(x, (len(x), -1))
                                                         for x in (q, u, udot)),
                          groups=groups, gravity=gravity)
    terms = _actuator_terms(amap, parts.times, parts.states, parts.rates,
                            parts.rates_acceleration)

    def mapped(x):
        return np.column_stack([pinv @ x[:, i] for i, (pinv, *_) in enumerate(terms)])

    drive_a = np.column_stack([pinv @ (J.T @ a) for pinv, J, a, *_ in terms])
    drive_v = np.column_stack([pinv @ (J.T @ v) for pinv, J, _, v, *_ in terms])
    causes = {c: mapped(x) for c, x in parts.by_cause().items()}
    causes["acceleration"] = causes["acceleration"] + drive_a
    causes["velocity"] = causes["velocity"] + drive_v
    groups_ = {g: mapped(x) for g, x in parts.groups.items()}
    groups_["drive train"] = drive_a + drive_v
    total = sum(causes.values(), np.zeros_like(drive_a))
    return ActuatorParts(amap.names, total, causes, groups_, drive_a, drive_v, parts)


def power_balance(amap, t, q, u, udot, gravity=None):
    r"""Actuator power against the rates of the energies along a trajectory.

    Parameters
    ----------
    amap : ActuatorMap
    t, q, u, udot
        As :meth:`NumericModel.inverse_dynamics`, 2-D (one column per point).
    gravity : sympy.Symbol, optional
        The gravity constant: the declared potential energy is taken to be
        that of the loads' gravity parts; the other load parts do the
        ``wrench_power``.

    Returns
    -------
    PowerBalance
    """
    model = amap.model
    _, ts, Y, U, Ua, parts, _, _, powers = _evaluate(model, np.atleast_1d(t), q, u, udot,
                                                     gravity)
    tau = sum(parts.values())
    terms = _actuator_terms(amap, ts, Y, U, Ua)
    forces = [pinv @ (tau[:, i] + J.T @ (a + v)) for i, (pinv, J, a, v, _, _)
              in enumerate(terms)]
    actuator = np.array([f @ s for f, (*_, s, _) in zip(forces, terms)])
    drive = np.array([s @ (a + v) for (_, _, a, v, s, _) in terms])
    residual = actuator - (powers["kinetic_rate"] + drive + powers["potential_rate"]
                           - powers["wrench_power"])
    return PowerBalance(actuator=actuator, drive_rate=drive, residual=residual, **powers)
