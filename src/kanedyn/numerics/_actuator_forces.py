r"""Actuator forces from the generalized forces a motion needs, by virtual work.

For independent speeds :math:`u_I` and actuator rates :math:`\dot s = J u_I`
(the dependent speeds eliminated through the velocity constraints), the
actuator forces :math:`f` do the virtual work of the generalized forces
:math:`\tau` the motion needs:

.. math:: J^T f = \tau + J^T\,\mathrm{diag}(m_\text{reflected})\,\ddot s,

:math:`\tau = M\dot u - F` in the reduced (independent-speed) form of the
forward equations, the last term the drive trains' reflected inertia on each
actuator's own rate.  As many actuators as independent speeds: :math:`J^T` is
square and solved; more: the least-norm solution, flagged ``redundant``; fewer:
an error.  The condition number of :math:`J` is always reported, and a
configuration where it exceeds ``max_condition`` is flagged, not divided by.
"""

from dataclasses import dataclass, field

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..modeling import Actuator

__all__ = ["ActuatorMap", "ActuatorForces", "actuator_forces"]

_t = me.dynamicsymbols._t


@dataclass(frozen=True)
class ActuatorForces:
    """Actuator forces at one state.

    Attributes
    ----------
    names : tuple of str
    forces : numpy.ndarray, shape (k,)
        Force (N) or torque (N m) of each actuator along its rate.
    motor_torques : dict
        ``{name: N m}`` for actuators with a transmission.
    rates, rate_derivatives : numpy.ndarray, shape (k,)
        :math:`\\dot s` and :math:`\\ddot s`.
    jacobian : numpy.ndarray, shape (k, p)
        :math:`\\partial \\dot s/\\partial u_I`.
    generalized_forces : numpy.ndarray, shape (p,)
        :math:`\\tau = M\\dot u - F` on the independent speeds.
    condition : float
        Condition number of the Jacobian: the norm of the rates' Jacobian over
        all speeds times that of the basis :math:`[I; A_r]` of admissible
        speeds, over the smallest singular value of :math:`J` (:math:`J`'s
        ordinary condition number without constraints; large also for a single
        actuator at a dead centre; ``inf`` where :math:`J` loses rank).
    redundant : bool
        More actuators than independent speeds (the least-norm solution).
    success : bool
        False at a singular configuration (``condition > max_condition``).
    message : str
    """

    names: tuple
    forces: np.ndarray
    motor_torques: dict
    rates: np.ndarray
    rate_derivatives: np.ndarray
    jacobian: np.ndarray
    generalized_forces: np.ndarray
    condition: float
    redundant: bool
    success: bool
    message: str
    extra: dict = field(default_factory=dict)

    def __getitem__(self, name):
        try:
            return self.forces[self.names.index(name)]
        except ValueError:
            raise KeyError(f"no actuator {name!r}; actuators: {', '.join(self.names)}") \
                from None


class ActuatorMap:
    """The virtual-work map from generalized forces to actuator forces of a model.

    Parameters
    ----------
    model : NumericModel
        Built by ``eom.numeric(...)`` (its equations give the symbols); the
        actuators' loads must not be among the model's loads.  An actuator's
        drive-train element (``actuator.inertia_element()``, named
        ``"<actuator name>_drive"``) among the model's bodies is detected
        (listed in ``drive_elements``) and its reflected inertia then not
        added again: the forces are the same with or without it.
    actuators : sequence of Actuator
    max_condition : float, optional
        Condition number of the rate Jacobian above which a configuration is
        reported singular (``success=False``).
    redundant : bool, optional
        Say ``True`` to allow more actuators than independent speeds (the
        least-norm solution); without it such a set is refused.
    """

    def __init__(self, model, actuators, max_condition=1e8, redundant=False):
        eom = getattr(model, "_eom", None)
        if eom is None:
            raise ModelError("ActuatorMap needs a model built by eom.numeric(...) in this "
                             "session (a loaded model keeps no equations)")
        actuators = list(actuators)
        if not actuators:
            raise ModelError("ActuatorMap needs at least one actuator")
        names = []
        for a in actuators:
            if not isinstance(a, Actuator):
                raise ModelError(f"not an actuator: {a!r} (use JointActuator or "
                                 "LinearActuator)")
            if a.name in names:
                raise ModelError(f"two actuators are named {a.name!r}")
            names.append(a.name)
        self.model, self.actuators, self.names = model, actuators, tuple(names)
        self.max_condition = float(max_condition)
        p = model.n_u_ind
        k = len(actuators)
        if k > p and not redundant:
            raise ModelError(f"{k} actuators ({', '.join(names)}) for {p} independent "
                             f"speed(s): the actuation is redundant; pass redundant=True "
                             "for the least-norm actuator forces")
        if k < p:
            raise ModelError(f"{k} actuator(s) ({', '.join(names)}) cannot drive "
                             f"{p} independent speed(s) "
                             f"({', '.join(model.state_names[model.n_q:model.n_q + p])})")
        q, u = list(eom.q), list(eom.u)
        kdd = eom.kindiffdict()
        rates = [a.rate(u, kdd) for a in actuators]
        J = sm.Matrix([[r.diff(s) for s in u] for r in rates])
        t = sm.Dummy("t")
        bias = []
        for r in rates:
            # d(rate)/dt is linear in u': with u' = 0 it is the J' u part
            b = r.diff(_t).xreplace({s.diff(_t): sm.S.Zero for s in u})
            bias.append(b.xreplace(kdd))
        # a drive train already among the model's bodies (``a.inertia_element()``,
        # named "<actuator>_drive") is in M u' - F: its reflected inertia is not
        # added a second time
        bodies = {getattr(b, "name", None) for b in getattr(eom, "bodies", ())}
        self.drive_elements = tuple(f"{a.name}_drive" for a in actuators
                                    if a.transmission is not None
                                    and f"{a.name}_drive" in bodies)
        masses = [0 if f"{a.name}_drive" in self.drive_elements else a.reflected_inertia
                  for a in actuators]
        qs = sm.symbols(f"q0:{len(q)}")
        us = sm.symbols(f"u0:{len(u)}")
        plain = dict(zip(q, qs)) | dict(zip(u, us)) | {_t: t}
        values = {s: model.constants[str(s)] for s in _free(J, bias, masses)
                  if str(s) in model.constants}
        exprs = [J, sm.Matrix(bias), sm.Matrix(masses)]
        exprs = [e.xreplace(plain).xreplace(values) for e in exprs]
        unknown = set().union(*(e.free_symbols for e in exprs)) - set(qs) - set(us) - {t}
        if unknown:
            raise ModelError(f"actuators {', '.join(names)}: no value for "
                             f"{sorted(map(str, unknown))} (not among the model's constants)")
        self._fn = sm.lambdify((t, qs, us), exprs, modules="numpy", cse=True)
        self.transmissions = {a.name: a.transmission for a in actuators
                              if a.transmission is not None}

    def _terms(self, t, y):
        model = self.model
        n = model.n_q
        J, bias, masses = self._fn(t, y[:n], y[n:])
        return (np.asarray(J, float), np.asarray(bias, float).ravel(),
                np.asarray(masses, float).ravel())

    def forces(self, t, y, udot):
        """Actuator forces at a state for given accelerations.

        Parameters
        ----------
        t : float
        y : array_like, shape (n_states,)
            A state satisfying the constraints (see ``model.consistent_state``).
        udot : array_like, shape (p,) or (n_u,)
            Rates of the independent speeds (the dependent ones are completed
            from the acceleration constraints), or of all speeds.

        Returns
        -------
        ActuatorForces
        """
        model = self.model
        y = np.asarray(model._check_y(y), float)
        udot = np.asarray(udot, float).ravel()
        qd, mass, force, vel_B, acc_K, acc_f = model._dynamics(t, y)
        o, m = model.n_u, model.n_u_dep
        p = o - m
        if udot.size == p and m:
            rest = np.linalg.solve(acc_K[:, p:], -acc_f - acc_K[:, :p] @ udot)
            udot = np.concatenate([udot, rest])
        elif udot.size != o:
            raise ModelError(f"udot has {udot.size} entries; the model has {p} independent "
                             f"speed(s) and {o} in all")
        residual = mass @ udot - force
        if m:
            dependent = vel_B[:, p:]
            sv_dep = np.linalg.svd(dependent, compute_uv=False)
            if not sv_dep[-1] > sv_dep[0] * 1e-14:
                raise ModelError(
                    "the velocity constraints do not determine the dependent speeds "
                    f"({', '.join(model.state_names[model.n_q + p:])}) at this state "
                    f"(condition number {_ratio(sv_dep):.3g}); choose other independent "
                    "speeds or a state away from this configuration")
            Ar = -np.linalg.solve(dependent, vel_B[:, :p])
            tau = residual[:p] + Ar.T @ residual[p:]
        else:
            Ar = np.zeros((0, p))
            tau = residual
        J_full, bias, masses = self._terms(t, y)
        J = J_full[:, :p] + J_full[:, p:] @ Ar
        rates = J_full @ y[model.n_q:]
        rate_dots = J_full @ udot + bias
        rhs = tau + J.T @ (masses * rate_dots)
        # relative to the rates' Jacobian over all speeds and to the basis [I; Ar] of
        # the admissible speeds: cond(J) without constraints, and large also for one
        # actuator whose rate loses its dependence on the motion (a dead centre)
        basis = np.vstack([np.eye(p), Ar])
        scale = (np.linalg.norm(J_full, 2) * np.linalg.norm(basis, 2)
                 if J_full.any() else 0.0)
        sv = np.linalg.svd(J, compute_uv=False)
        condition = float(scale / sv[-1]) if sv[-1] > 0 else float("inf")
        f = np.linalg.lstsq(J.T, rhs, rcond=None)[0]
        k = len(self.names)
        redundant = k > p
        singular = not condition <= self.max_condition
        parts = []
        if singular:
            parts.append(f"singular configuration: the actuator-rate Jacobian has condition "
                         f"number {condition:.3g} (above {self.max_condition:.3g}); the "
                         "forces given are the least-squares solution")
        if redundant:
            parts.append(f"redundant actuation: {k} actuators for {p} independent "
                         "speed(s); the forces are the least-norm solution")
        message = "; ".join(parts) or "actuator forces solved"
        torques = {name: float(f[i]) / float(self.transmissions[name].ratio)
                   for i, name in enumerate(self.names) if name in self.transmissions}
        return ActuatorForces(self.names, f, torques, rates, rate_dots, J, tau, condition,
                              redundant, not singular, message)

    def parts(self, t, q, u, udot, groups=None, gravity=None):
        """The actuator forces along a trajectory by cause and by body group.

        See :func:`kanedyn.numerics._inverse_parts.actuator_parts`; returns an
        ``ActuatorParts`` (arrays ``(k, N)``).
        """
        from ._inverse_parts import actuator_parts
        return actuator_parts(self, t, q, u, udot, groups=groups, gravity=gravity)

    def power_balance(self, t, q, u, udot, gravity=None):
        """Actuator power and the energies' rates along a trajectory.

        See :func:`kanedyn.numerics._inverse_parts.power_balance`; returns a
        ``PowerBalance``.
        """
        from ._inverse_parts import power_balance
        return power_balance(self, t, q, u, udot, gravity=gravity)


def _ratio(sv):
    return float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")


def _free(J, bias, masses):
    out = set(J.free_symbols)
    for e in (*bias, *masses):
        out |= sm.sympify(e, strict=True).free_symbols
    return out


def actuator_forces(model, actuators, t, y, udot, max_condition=1e8, redundant=False):
    """Actuator forces for a motion, by virtual work (see :class:`ActuatorMap`).

    Parameters
    ----------
    model : NumericModel
    actuators : sequence of Actuator
    t : float
    y : array_like, shape (n_states,)
    udot : array_like, shape (p,) or (n_u,)
    max_condition : float, optional
    redundant : bool, optional
        Allow more actuators than independent speeds (see :class:`ActuatorMap`).

    Returns
    -------
    ActuatorForces
    """
    return ActuatorMap(model, actuators, max_condition, redundant).forces(t, y, udot)
