"""Tendons and actuators of an MJCF model: what the builder of
:mod:`._build` adds for them.

* tendons: a fixed tendon's length ``sum(coef * q)``, a spatial tendon's the sum
  of its straight segments between consecutive sites (a pulley dividing the
  branch after it); their springs and damping, applied as ``coef * force`` on
  each joint, or as a force along each segment;
* actuators: ``force = gain * (ctrl, or the activation) + bias``, the clamps
  written with absolute values; an activation is a first-order state beside the
  coordinates, its equation ``act' = rate`` among the kinematic differential
  equations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import sympy as sm
import sympy.physics.mechanics as me

from ...modeling import RateInertia

__all__ = ["MJCFActuator", "Actuation", "spring_force", "damping_force", "clamp"]


@dataclass(frozen=True)
class MJCFActuator:
    """An actuator: ``ctrl`` is its specified input (``ctrl_<name>``), ``force`` the
    actuator force as an expression of it (clamps included); its joint receives
    ``gear * force`` (when ``tendon``, the tendon named by ``joint`` does: a fixed
    one on each joint times its coefficient, a spatial one along its segments).

    With activation dynamics (``dyntype`` ``integrator``, ``filter`` or
    ``filterexact``), ``act`` is its activation, a first-order state
    ``act_<name>`` of the model (MuJoCo's ``act`` entry ``act_index``), and
    ``act_rate`` its derivative: ``ctrl`` (integrator) or ``(ctrl - act) / tau``
    (filters; ``tau`` in s), ``ctrl`` clamped to ``ctrlrange``; the force uses the
    activation instead of ``ctrl`` (with ``actearly``, the activation one time step
    ahead); with ``actrange`` the rate stops at its ends.
    """

    name: str
    type: str
    joint: str
    gear: float
    ctrl: object
    force: object
    ctrlrange: tuple | None
    forcerange: tuple | None
    line: int
    tendon: bool = False  # ``joint`` names a fixed tendon
    dyntype: str = "none"
    tau: float = 0.0
    actrange: tuple | None = None
    actearly: bool = False
    act: object = None
    act_rate: object = None
    act_index: int | None = None


def spring_force(x, a, b=0.0, c=0.0):
    """MuJoCo's polynomial spring force ``-(a x + b x^2 + c x^3)``."""
    return -sum((sm.Float(k) * x ** p for k, p in ((a, 1), (b, 2), (c, 3)) if k),
                sm.S.Zero)


def damping_force(v, a, b=0.0, c=0.0):
    """MuJoCo's polynomial damping force ``-(a v + b v|v| + c v^3)``."""
    return -sum((sm.Float(k) * term for k, term in ((a, v), (b, v * sm.Abs(v)),
                                                      (c, v ** 3)) if k), sm.S.Zero)


def clamp(x, lo, hi):
    """``x`` clamped to ``[lo, hi]``, written with absolute values (whose
    derivatives, signs, every backend's generated code evaluates)."""
    lo, hi = sm.Float(lo), sm.Float(hi)
    return (lo + hi + sm.Abs(x - lo) - sm.Abs(x - hi)) / 2


class Actuation:
    """The tendon and actuator methods of the MJCF model builder (a mixin: the
    builder holds the joints, sites, loads and states they add to)."""

    def tendons(self):
        """Length, rate and passive forces of the tendons."""
        joints = {j.name: j for j in self.joint_infos}
        self.tendon_of = {}
        for tendon in self.m.tendons:
            if tendon.path:
                L, Ldot, apply = self.spatial(tendon)
            else:
                L = sum((sm.Float(c) * joints[j].q[0] for j, c in tendon.joints), sm.S.Zero)
                Ldot = sum((sm.Float(c) * joints[j].u[0] for j, c in tendon.joints),
                           sm.S.Zero)
                apply = self.joint_forces(tendon.joints)
            self.tendon_of[tendon.name] = (L, Ldot, apply)
            tid = self.names(tendon.name, "tendon", tendon.element)
            if tendon.armature > 0:
                self.tendon_armature(tendon, tid, Ldot)
            force = sm.S.Zero
            if "spring" not in self.off and any(tendon.stiffness):
                if tendon.springlength is None:  # the length at the spring references
                    lo = hi = self.spring_length(L)
                else:
                    lo, hi = tendon.springlength
                x = L - (sm.Float(lo) if lo == hi else clamp(L, lo, hi))
                force += spring_force(x, *tendon.stiffness)
            if "damper" not in self.off:
                force += damping_force(Ldot, *tendon.damping)
            if force != 0:
                self.tendon_load(tendon.name, force)

    def tendon_armature(self, tendon, tid, Ldot):
        """A tendon's armature as MuJoCo adds it: ``armature * J_k^T J_k`` for the
        part ``J_k`` of the length's gradient in each kinematic tree (the bodies
        below one child of the world) the tendon spans, the coupling between trees
        left out: a :class:`RateInertia` on each tree's part of the rate.  That is
        exact for a fixed tendon (constant ``J``); a spatial tendon spanning
        several trees is refused (MuJoCo's velocity term then is not that of the
        trees' parts)."""
        trees = {}
        for j in self.joint_infos:
            body = self.m.body(j.body)
            while body.parent != 0:
                body = self.m.bodies[body.parent]
            trees.setdefault(body.name, []).extend(j.u)
        every = [u for us in trees.values() for u in us]
        parts = {}
        for root, speeds in trees.items():
            rate = Ldot.xreplace({u: 0 for u in every if u not in speeds})
            if rate != 0:
                parts[root] = rate
        if tendon.path and len(parts) > 1:
            raise tendon.element.error(
                f"armature of a spatial tendon spanning several kinematic trees (below "
                f"bodies {', '.join(sorted(parts))}) is not supported")
        for root, rate in parts.items():
            name = f"armature_tendon_{tid}" + (f"_{root}" if len(parts) > 1 else "")
            self.bodies.append(RateInertia(name, [rate], tendon.armature))

    def joint_forces(self, members):
        """What applies a fixed tendon's force ``f``: ``coef * f`` on each joint."""
        def apply(force):
            for joint, coef in members:
                self.generalized_load(self.dofs[joint], sm.Float(coef) * force)
        return apply

    def spatial(self, tendon):
        """Length, rate and what applies the force of a spatial tendon through sites:
        each straight segment between consecutive sites of a branch counts its
        length divided by the branch's divisor, and a force ``f`` (positive: it
        lengthens the tendon) pushes each segment's ends apart by ``f / divisor``."""
        segments = []
        for (a, d), (b, _) in zip(tendon.path, tendon.path[1:]):
            if a is not None and b is not None:
                segments.append((self.site_points[a], self.site_points[b], d))
        L, Ldot, ends = sm.S.Zero, sm.S.Zero, []
        to_u = self.qdot_to_u()
        for P1, P2, d in segments:
            r = P2.pos_from(P1)
            length = sm.sqrt(r.dot(r))
            e = r / length
            v = (P2.pos_from(self.O).dt(self.N) - P1.pos_from(self.O).dt(self.N))
            L += length / sm.Float(d)
            Ldot += e.dot(v).xreplace(to_u) / sm.Float(d)
            ends.append((P1, P2, e / sm.Float(d)))

        def apply(force):
            for P1, P2, e in ends:
                self.loads.append((P2, force * e))
                self.loads.append((P1, -force * e))
        return L, Ldot, apply

    def spring_length(self, L):
        """A tendon's length with hinge and slide joints at their spring references
        (others at qpos0): MuJoCo's default spring length."""
        values = {q: self.initial[q] for q in self.q}
        for j in self.joint_infos:
            if j.type in ("hinge", "slide"):
                values[j.q[0]] = j.springref
        return float(L.xreplace(values).evalf())

    def tendon_load(self, name, force):
        self.tendon_of[name][2](force)

    def actuators(self):
        joints = {j.name: j for j in self.joint_infos}
        clamp_ctrl = "clampctrl" not in self.off
        for act in self.m.actuators:
            aid = self.names(act.name, "actuator", act.element)
            ctrl = me.dynamicsymbols(f"ctrl_{aid}")
            if act.tendon:
                L, Ldot, _ = self.tendon_of[act.joint]
            else:
                L, Ldot = joints[act.joint].q[0], joints[act.joint].u[0]
            length, velocity = act.gear * L, act.gear * Ldot
            c = ctrl
            if act.ctrlrange is not None and clamp_ctrl:
                c = clamp(ctrl, *act.ctrlrange)
            state, rate = None, None
            if act.dyntype != "none" and self.inputs:  # (no inputs: no forces, no states)
                state, rate, c = self.activation(act, aid, c)
            g0, g1, g2 = (sm.Float(x) for x in act.gain)
            b0, b1, b2 = (sm.Float(x) for x in act.bias)
            force = (g0 + g1 * length + g2 * velocity) * c + b0 + b1 * length + b2 * velocity
            if act.forcerange is not None:
                force = clamp(force, *act.forcerange)
            self.actuator_infos.append(MJCFActuator(
                act.name, act.type, act.joint, act.gear, ctrl, force, act.ctrlrange,
                act.forcerange, act.element.line, act.tendon, act.dyntype, act.tau,
                act.actrange, act.actearly, state, rate,
                None if state is None else len(self.activations) - 1))
            if not self.inputs:
                continue
            self.specified[ctrl] = 0.0
            if "actuation" in self.off:
                continue
            if act.tendon:
                self.tendon_load(act.joint, act.gear * force)
            else:
                self.generalized_load(self.dofs[act.joint], act.gear * force)

    def activation(self, act, aid, ctrl):
        """``(state, its rate, what the force uses)`` of an actuator's activation
        (``ctrl``: its control, clamped)."""
        state = me.dynamicsymbols(f"act_{aid}")
        if act.dyntype == "integrator":
            rate = ctrl
        else:
            rate = (ctrl - state) / sm.Float(act.tau)
        used = state
        if act.actearly:  # the activation MuJoCo's next time step will have
            dt = self.m.option.timestep
            if act.dyntype == "filterexact":
                used = state + (ctrl - state) * sm.Float(-math.expm1(-dt / act.tau))
            else:
                used = state + sm.Float(dt) * rate
            if act.actrange is not None:
                used = clamp(used, *act.actrange)
        if act.actrange is not None:  # the activation stops at the ends of its range
            lo, hi = (sm.Float(x) for x in act.actrange)
            rate = sm.Piecewise((sm.Min(rate, 0), state >= hi),
                                (sm.Max(rate, 0), state <= lo), (rate, True))
        self.activations.append(state)
        self.kd_act.append(state.diff() - rate)
        self.initial[state] = 0.0
        return state, rate, used
