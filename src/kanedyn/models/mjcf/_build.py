"""A model definition from an MJCF (MuJoCo) file (``kd.models.from_mjcf``).

Coordinates and speeds (MuJoCo's ``qpos``/``qvel`` and kanedyn's state):

* hinge and slide joints: ``q_<joint>`` is MuJoCo's ``qpos`` entry (rad or m; the
  joint turns or slides by ``q - ref`` from the pose the file gives) and
  ``u_<joint> = q_<joint>'`` its ``qvel`` entry;
* ball joints: body-fixed x-y-z angles ``phi_<joint>, theta_<joint>, psi_<joint>``
  of the child's rotation relative to the parent frame (MuJoCo's quaternion
  ``qpos`` w-first: ``R = Rx(phi) Ry(theta) Rz(psi)``), speeds
  ``wx_<joint>, wy_<joint>, wz_<joint>``: the relative angular velocity in the
  child's frame, which is MuJoCo's ``qvel``;
* free joints: the position ``x_<joint>, y_<joint>, z_<joint>`` of the body's
  origin in the world, its body-fixed x-y-z angles, and the speeds
  ``vx_, vy_, vz_<joint>`` (the origin's velocity in world components) and
  ``wx_, wy_, wz_<joint>`` (the angular velocity in the body's frame): MuJoCo's
  ``qvel`` of a free joint.

So the speeds are MuJoCo's ``qvel`` entry for entry, and their derivatives its
``qacc``; :meth:`MJCFDefinition.state_from_mujoco` and
:meth:`MJCFDefinition.mujoco_state` convert states.  The angles are singular at
``theta = +-90 deg``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ...modeling import RateInertia, inertia_violation, principal_moments
from .._base import ModelDefinition
from .._urdf import named_rigid_body
from ._actuation import Actuation, MJCFActuator, damping_force, spring_force
from ._frames import euler_matrix, matrix_quat, quat_matrix
from .._robot_ground import robot_ground_contacts
from ._ground import MJCF_NONE_USABLE, mjcf_collision_shapes
from ._inertia import NotInferable, body_mass_properties, bound, combine
from ._meshes import MeshLibrary
from ._parse import parse_mjcf
from ._xml import MJCFError

__all__ = ["from_mjcf", "MJCFDefinition", "MJCFJoint", "MJCFActuator", "MJCFSite",
           "MJCFGeom", "euler_angles", "euler_rates_matrix"]

@dataclass(frozen=True)
class MJCFJoint:
    """A joint of an MJCF model, as data.

    Attributes
    ----------
    name, type : str
        MJCF name (``joint<k>`` for an unnamed one, k its MuJoCo index) and type
        (``hinge``, ``slide``, ``ball``, ``free``).
    body : str
        The MJCF body it moves.
    q, u : tuple of sympy.Function
        Its coordinates and speeds (one each for hinge and slide, three for
        ball, six for free), in MuJoCo's ``qvel`` order.
    qpos_index, dof_index : int
        Where it starts in MuJoCo's ``qpos`` and ``qvel``.
    range : tuple or None
        ``(lower, upper)`` (rad or m; for a ball its second entry is the largest
        angle) when limited; not enforced.
    ref, springref, stiffness, damping, armature, frictionloss : float
        As in the file (SI units, angles in rad).  Friction loss is not applied.
    line : int
        Line of the ``<joint>`` element (in ``source``).
    source : str
        The file that holds it (an included file, or the model's).
    """

    name: str
    type: str
    body: str
    q: tuple
    u: tuple
    qpos_index: int
    dof_index: int
    range: tuple | None
    ref: float
    springref: float
    stiffness: float
    damping: float
    armature: float
    frictionloss: float
    line: int
    source: str


@dataclass(frozen=True)
class MJCFSite:
    """A site: its MJCF body, the kanedyn body (frame) that carries it, its
    point (``symbols["sites"][name]``) and pose (4x4) in that body's frame."""

    name: str
    body: str
    point: object
    frame: object
    transform: tuple
    type: str
    size: tuple
    line: int


@dataclass(frozen=True)
class MJCFGeom:
    """A geom, as data (for viewers and contact models).

    ``body`` is the kanedyn body that carries it (``""``: the ground),
    ``mjcf_body`` its MJCF body, ``transform`` its pose (4x4) in ``body``'s
    frame (origin at the body's origin); ``size`` is MuJoCo's (half-sizes and
    radii, m); ``rgba`` its own or its material's colour, or None; ``mass`` what
    it adds to its body (0 when the body's inertia is not taken from geoms, or
    the geom's group does not count).
    """

    name: str
    type: str
    size: tuple
    body: str
    mjcf_body: str
    transform: tuple
    rgba: tuple | None
    group: int
    contype: int
    conaffinity: int
    mass: float
    line: int
    source: str


@dataclass(frozen=True)
class MJCFDefinition(ModelDefinition):
    """A :class:`ModelDefinition` read from an MJCF file, with its MuJoCo data.

    Attributes
    ----------
    source : str
        The MJCF file.
    joints : tuple of MJCFJoint
        Every joint, in MuJoCo's order.
    actuators : tuple of MJCFActuator
    sites : tuple of MJCFSite
    geoms : tuple of MJCFGeom
        Every geom, the world's included (``body == ""``).
    equalities : tuple of str
        One line per loop-closure constraint (its kind, bodies and element line).
    body_of : dict
        ``{MJCF body: (kanedyn body name, 4x4 pose in its frame)}``; ``""`` is the
        ground (the world and the bodies welded to it).
    gravity : tuple
        The gravity vector of ``<option>`` (m/s^2), zero when disabled.
    nq, nv, na : int
        MuJoCo's ``qpos``, ``qvel`` and ``act`` lengths.
    """

    source: str = ""
    joints: tuple = ()
    actuators: tuple = ()
    sites: tuple = ()
    geoms: tuple = ()
    equalities: tuple = ()
    body_of: dict = field(default_factory=dict)
    gravity: tuple = (0.0, 0.0, -9.81)
    nq: int = 0
    nv: int = 0
    na: int = 0

    def visual_shapes(self, constants=None, groups=(0, 1, 2)):
        """The viewer shapes of the geoms in ``groups``, and what was not drawn.

        Returns
        -------
        shapes : list of kanedyn.visuals.Shape
        notes : list of str
            One line per geom skipped (a plane, mesh, height field or SDF; a
            massless body), naming file, line and geom.
        """
        from ._shapes import mjcf_shapes
        values = dict(self.constants)
        values.update(self._constant_overrides(constants or {}))
        return mjcf_shapes(self, values, groups)

    def shapes(self, constants=None):
        """Shapes drawing the model with its own geoms (groups 0 to 2, those
        MuJoCo shows by default; fully transparent geoms left out), for
        ``res.animate(..., visuals=definition.shapes())``; geoms of the ground
        are not drawn."""
        return self.visual_shapes(constants)[0]

    def state_from_mujoco(self, model, qpos, qvel, act=None):
        """kanedyn's state ``y`` (for ``model``) of MuJoCo's ``qpos``, ``qvel`` and,
        for a model whose actuators have activations, ``act`` (MuJoCo's
        ``data.act``, ``na`` entries).

        Quaternions (w-first) become body-fixed x-y-z angles (their branch with
        ``|theta| <= 90 deg``); the speeds are ``qvel`` itself.
        """
        from ...engine import name_of
        qpos, qvel = np.asarray(qpos, dtype=float), np.asarray(qvel, dtype=float)
        y = np.zeros(model.n_states)
        if self.na:
            if act is None:
                raise ValueError(f"{self.source}: the model's actuators have {self.na} "
                                 "activations: give act (MuJoCo's data.act)")
            act = np.asarray(act, dtype=float)
            if act.shape != (self.na,):
                raise ValueError(f"act has shape {act.shape}; the model has {self.na} "
                                 "activations")
            for a in self.actuators:
                if a.act is not None:
                    y[model.index(name_of(a.act))] = act[a.act_index]
        for j in self.joints:
            a, v = j.qpos_index, j.dof_index
            if j.type in ("hinge", "slide"):
                values = [qpos[a]]
            elif j.type == "ball":
                values = list(euler_angles(quat_matrix(qpos[a:a + 4])))
            else:
                values = list(qpos[a:a + 3]) + list(euler_angles(quat_matrix(qpos[a + 3:a + 7])))
            for sym, value in zip(j.q, values):
                y[model.index(name_of(sym))] = value
            for k, sym in enumerate(j.u):
                y[model.index(name_of(sym))] = qvel[v + k]
        return y

    def mujoco_state(self, model, y):
        """MuJoCo's ``(qpos, qvel)`` of kanedyn's state ``y`` (quaternions w-first)."""
        from ...engine import name_of
        y = np.asarray(y, dtype=float)
        qpos, qvel = np.zeros(self.nq), np.zeros(self.nv)
        for j in self.joints:
            a, v = j.qpos_index, j.dof_index
            q = [y[model.index(name_of(s))] for s in j.q]
            if j.type in ("hinge", "slide"):
                qpos[a] = q[0]
            elif j.type == "ball":
                qpos[a:a + 4] = matrix_quat(euler_matrix(q, "xyz"))
            else:
                qpos[a:a + 3] = q[:3]
                qpos[a + 3:a + 7] = matrix_quat(euler_matrix(q[3:], "xyz"))
            for k, s in enumerate(j.u):
                qvel[v + k] = y[model.index(name_of(s))]
        return qpos, qvel

    def mujoco_act(self, model, y):
        """MuJoCo's ``act`` (na,) of kanedyn's state ``y``: the activations."""
        from ...engine import name_of
        return np.array([y[model.index(name_of(a.act))] for a in self.actuators
                         if a.act is not None])

    def act_dot(self, model, t, y):
        """MuJoCo's ``act_dot`` (na,) at kanedyn's state ``y``: the activations'
        derivatives."""
        from ...engine import name_of
        ydot = model.rhs(t, y)
        return np.array([ydot[model.index(name_of(a.act))] for a in self.actuators
                         if a.act is not None])

    def qacc(self, model, t, y):
        """MuJoCo's ``qacc`` (nv,) at kanedyn's state ``y``: the speeds' derivatives."""
        from ...engine import name_of
        ydot = model.rhs(t, y)
        return np.array([ydot[model.index(name_of(s))] for j in self.joints for s in j.u])


def euler_angles(R):
    """Body-fixed x-y-z angles (phi, theta, psi) of ``R = Rx(phi) Ry(theta) Rz(psi)``,
    with ``|theta| <= pi/2``."""
    theta = math.asin(max(-1.0, min(1.0, R[0, 2])))
    phi = math.atan2(-R[1, 2], R[2, 2])
    psi = math.atan2(-R[0, 1], R[0, 0])
    return phi, theta, psi


def euler_rates_matrix(angles):
    """Matrix taking body-fixed x-y-z angle rates to the angular velocity in the
    rotated frame's components (numbers; for tests and conversions)."""
    phi, theta, psi = angles
    c2, s2, c3, s3 = math.cos(theta), math.sin(theta), math.cos(psi), math.sin(psi)
    return np.array([[c2 * c3, s3, 0.0], [-c2 * s3, c3, 0.0], [s2, 0.0, 1.0]])


def _vector(frame, values):
    vec = me.Vector(0)
    for v, base in zip(values, (frame.x, frame.y, frame.z)):
        if v != 0.0:
            vec += (sm.Float(float(v)) if isinstance(v, (int, float, np.floating)) else v) \
                * base
    return vec


def _fixed_frame(parent, R, name):
    """``parent`` itself when ``R`` is the identity, else a frame fixed in it whose
    axes have the components ``R[:, i]`` in ``parent``."""
    if np.allclose(R, np.eye(3), rtol=0, atol=1e-15):
        return parent
    frame = me.ReferenceFrame(name)
    frame.orient_dcm(parent, sm.Matrix(np.asarray(R).T).applyfunc(sm.Float))
    return frame


def _pose(pos, R):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = pos
    return T


class _Names:
    """kanedyn identifiers of MJCF names (characters other than letters, digits
    and ``_`` become ``_``), checked not to clash."""

    def __init__(self, source):
        self.source, self.taken = source, {}

    def __call__(self, name, what, element):
        ident = re.sub(r"\W", "_", name, flags=re.ASCII)
        if not ident or ident[0].isdigit():
            ident = "_" + ident
        key = (what, ident)
        if key in self.taken and self.taken[key] != name:
            raise element.error(f"{what} names '{name}' and '{self.taken[key]}' both "
                                f"become the symbol name '{ident}'; rename one")
        self.taken[key] = name
        return ident


class _Builder(Actuation):
    def __init__(self, model, inputs, mesh_dirs=()):
        self.m = model
        self.inputs = inputs
        compiler = model.compiler
        self.meshes = MeshLibrary(model.meshes, model.source,
                                  compiler.meshdir or compiler.assetdir, mesh_dirs)
        self.N = me.ReferenceFrame("N")
        self.O = me.Point("O")
        self.O.set_vel(self.N, 0)
        self.names = _Names(model.source)
        self.q, self.u, self.kd_eqs, self.loads, self.bodies = [], [], [], [], []
        self.activations, self.kd_act = [], []  # actuators' activations: first-order states
        self.constants, self.specified, self.initial = {}, {}, {}
        self.joint_infos, self.actuator_infos, self.site_infos = [], [], []
        self.frame_of, self.point_of = {"": self.N}, {"": self.O}
        self.head = {}  # MJCF body -> (kanedyn body, 4x4 pose in its frame)
        self.dofs = {}  # joint name -> (frame before, frame after, axis, point before, after)
        option = model.option
        self.off = set(option.disabled) | ({"spring", "damper"} if "passive" in
                                           option.disabled else set())
        self.g = sm.Symbol("g", nonnegative=True)
        self.qpos_at, self.dof_at = 0, 0
        self.box_axes = {}
        self.rigid_of = {}  # MJCF body (with joints) -> its RigidBody

    # kinematics ----------------------------------------------------------------
    def walk(self):
        world = self.m.bodies[0]
        self.head[world.name] = ("", np.eye(4))
        for body in self.m.bodies[1:]:
            parent = self.m.bodies[body.parent]
            head, T_parent = self.head[parent.name]
            T = T_parent @ _pose(body.pos, body.R)
            if not body.joints:
                self.head[body.name] = (head, T)
                continue
            self.head[body.name] = (body.name, np.eye(4))
            self.moving(body, head, T)

    def moving(self, body, parent, T):
        ident = self.names(body.name, "body", body.element)
        P_frame, P_point = self.frame_of[parent], self.point_of[parent]
        if body.joints[0].type == "free":
            self.free(body, ident)
            return
        C = _fixed_frame(P_frame, T[:3, :3], f"B0_{ident}")
        P = P_point.locatenew(f"B0_{ident}", _vector(P_frame, T[:3, 3])) \
            if np.any(T[:3, 3]) else P_point
        for k, joint in enumerate(body.joints):
            jid = self.names(joint.name, "joint", joint.element)
            C_before, P_before = C, P
            axis = _vector(C, joint.axis)
            anchor = np.asarray(joint.pos, dtype=float)
            if joint.type == "slide":
                (q,), (u,) = self.coordinates(joint, [f"q_{jid}"], [f"u_{jid}"], [joint.ref])
                self.kd_eqs.append(q.diff() - u)
                P = P.locatenew(f"P{k}_{ident}", (q - joint.ref) * axis)
                generalized = (P, P_before, axis)
            elif joint.type == "hinge":
                (q,), (u,) = self.coordinates(joint, [f"q_{jid}"], [f"u_{jid}"], [joint.ref])
                self.kd_eqs.append(q.diff() - u)
                C = me.ReferenceFrame(f"F{k}_{ident}")
                C.orient_axis(C_before, axis, q - joint.ref)
                C.set_ang_vel(C_before, u * axis)
                generalized = (C, C_before, axis)
            else:  # ball
                angles, rates = self.coordinates(
                    joint, [f"{a}_{jid}" for a in ("phi", "theta", "psi")],
                    [f"{a}_{jid}" for a in ("wx", "wy", "wz")], [0.0] * 3)
                C = me.ReferenceFrame(f"F{k}_{ident}")
                C.orient_body_fixed(C_before, angles, "xyz")
                w_q = C.ang_vel_in(C_before)
                C.set_ang_vel(C_before, sum((w * e for w, e in zip(rates, (C.x, C.y, C.z))),
                                            me.Vector(0)))
                self.kd_eqs += [w_q.dot(e) - w for e, w in zip((C.x, C.y, C.z), rates)]
                generalized = (C, C_before, None)
            if joint.type != "slide" and np.any(anchor):
                A = P_before.locatenew(f"A{k}_{ident}", _vector(C_before, anchor))
                P = A.locatenew(f"P{k}_{ident}", -_vector(C, anchor))
            self.dofs[joint.name] = generalized
            self.passive(joint, generalized)
        self.frame_of[body.name], self.point_of[body.name] = C, P

    def free(self, body, ident):
        joint = body.joints[0]
        jid = self.names(joint.name, "joint", joint.element)
        N = self.N
        start = list(body.pos) + list(euler_angles(body.R))
        qs, us = self.coordinates(
            joint, [f"{a}_{jid}" for a in ("x", "y", "z", "phi", "theta", "psi")],
            [f"{a}_{jid}" for a in ("vx", "vy", "vz", "wx", "wy", "wz")], start)
        C = me.ReferenceFrame(f"F_{ident}")
        C.orient_body_fixed(N, qs[3:], "xyz")
        w_q = C.ang_vel_in(N)
        C.set_ang_vel(N, sum((w * e for w, e in zip(us[3:], (C.x, C.y, C.z))), me.Vector(0)))
        P = self.O.locatenew(f"P_{ident}", qs[0] * N.x + qs[1] * N.y + qs[2] * N.z)
        P.set_vel(N, us[0] * N.x + us[1] * N.y + us[2] * N.z)
        self.kd_eqs += [qd.diff() - v for qd, v in zip(qs[:3], us[:3])]
        self.kd_eqs += [w_q.dot(e) - w for e, w in zip((C.x, C.y, C.z), us[3:])]
        self.frame_of[body.name], self.point_of[body.name] = C, P
        self.dofs[joint.name] = (C, N, None)
        self.passive(joint, (P, C, None))

    def coordinates(self, joint, q_names, u_names, start):
        qs = me.dynamicsymbols(" ".join(q_names), seq=True)
        us = me.dynamicsymbols(" ".join(u_names), seq=True)
        self.q += qs
        self.u += us
        for q, value in zip(qs, start):
            self.initial[q] = float(value)
        for u in us:
            self.initial[u] = 0.0
        self.joint_infos.append(MJCFJoint(
            name=joint.name, type=joint.type, body=self._body_of(joint),
            q=tuple(qs), u=tuple(us), qpos_index=self.qpos_at, dof_index=self.dof_at,
            range=joint.range, ref=joint.ref, springref=joint.springref,
            stiffness=joint.stiffness, damping=joint.damping, armature=joint.armature,
            frictionloss=joint.frictionloss, line=joint.element.line,
            source=joint.element.source))
        self.qpos_at += {"hinge": 1, "slide": 1, "ball": 4, "free": 7}[joint.type]
        self.dof_at += len(us)
        return qs, us

    def _body_of(self, joint):
        return next(b.name for b in self.m.bodies if any(j is joint for j in b.joints))

    # passive forces and actuators ------------------------------------------------
    def generalized_load(self, generalized, amount, speeds=None):
        """Loads doing the power ``amount . speeds`` on one joint's speeds."""
        target, base, axis = generalized
        if axis is not None:
            self.loads.append((target, amount * axis))
            if base is not self.N and base is not self.O:
                self.loads.append((base, -amount * axis))
            return
        if isinstance(target, me.Point):  # free joint: (origin, body frame)
            P, C = target, base
            v = list(amount[:3])
            self.loads.append((P, v[0] * self.N.x + v[1] * self.N.y + v[2] * self.N.z))
            self.loads.append((C, _vector(C, amount[3:])))
            return
        C, C_before = target, base
        torque = _vector(C, amount)
        self.loads.append((C, torque))
        if C_before is not self.N:
            self.loads.append((C_before, -torque))

    def passive(self, joint, generalized):
        info = self.joint_infos[-1]
        n = len(info.u)
        if joint.armature > 0:
            self.bodies.append(RateInertia(f"armature_{info.q[0].func.__name__}",
                                           list(info.u), np.eye(n) * joint.armature))
        amount = [sm.S.Zero] * n
        if "damper" not in self.off:
            amount = [a + damping_force(u, joint.damping, *joint.damping_terms)
                      for a, u in zip(amount, info.u)]
        if "spring" not in self.off and n == 1:
            amount[0] += spring_force(info.q[0] - joint.springref, joint.stiffness,
                                 *joint.stiffness_terms)
        if any(a != 0 for a in amount):
            self.generalized_load(generalized, amount[0] if n == 1 else amount)

    # bodies and their mass ---------------------------------------------------------
    def masses(self):
        """Mass properties of each MJCF body (in its own frame), settotalmass applied."""
        props = {}
        for body in self.m.bodies[1:]:
            try:
                mass, c, J, counted = body_mass_properties(body, self.m.compiler,
                                                           self.meshes)
            except NotInferable as exc:
                geom = exc.args[0]
                what = ("shellinertia" if geom.shellinertia
                        else f"the mass and inertia of a {geom.type} geom")
                raise geom.element.error(
                    f"{what} cannot be inferred here (sphere, ellipsoid, box, cylinder, "
                    "capsule and mesh are; a mesh's surface by <mesh inertia='shell'>); "
                    "give the body an <inertial>") from None
            if body.mocap:
                mass, J = 0.0, np.zeros((3, 3))
            mass, J = bound(mass, J, self.m.compiler)
            props[body.name] = (mass, c, J)
            # the axes of the equivalent inertia box (fluid forces), as MuJoCo picks
            # them: those of <inertial diaginertia>, of a body's only geom, else the
            # principal axes
            self.box_axes[body.name] = (self.geom_axes(counted[0]) if len(counted) == 1 else
                                        body.inertial.axes if body.inertial is not None
                                        and not counted else None)
        total = self.m.compiler.settotalmass
        if total > 0:
            now = sum(p[0] for p in props.values())
            if now <= 0:
                raise MJCFError(f"{self.m.source}: settotalmass={total:g} but the bodies "
                                "have no mass")
            scale = total / now
            props = {k: (m * scale, c, J * scale) for k, (m, c, J) in props.items()}
        return props

    def geom_axes(self, geom):
        """The axes of a geom's frame as MuJoCo compiles it: a mesh geom's are the
        principal axes of its mesh."""
        if geom.type != "mesh":
            return geom.R
        return geom.R @ np.linalg.eigh(self.meshes.properties(geom.mesh)[2])[1]

    def rigid_bodies(self):
        props = self.masses()
        members, self.own_inertia = {}, {}
        for body in self.m.bodies[1:]:
            head, T = self.head[body.name]
            mass, c, J = props[body.name]
            R = T[:3, :3]
            members.setdefault(head, []).append(
                (mass, T[:3, :3] @ c + T[:3, 3], R @ J @ R.T, body))
            self.own_inertia[body.name] = (J, R)
        self.carried = {}
        gravity = np.array(self.m.option.gravity, dtype=float)
        if "gravity" in self.off:
            gravity = np.zeros(3)
        self.gravity = tuple(gravity)
        g_norm = float(np.linalg.norm(gravity))
        g_dir = None
        if g_norm > 0:
            self.constants[self.g] = g_norm
            g_dir = _vector(self.N, gravity / g_norm)
        self.members = members
        for body in self.m.bodies[1:]:
            if self.head[body.name][0] != body.name:
                continue
            parts = members[body.name]
            mass, centre, inertia = combine([p[:3] for p in parts])
            inertia = self.solid(body, inertia, parts)
            self.carried[body.name] = mass + float(np.abs(inertia).sum())
            if mass == 0 and not inertia.any():
                continue
            ident = self.names(body.name, "body", body.element)
            frame, point = self.frame_of[body.name], self.point_of[body.name]
            rigid = named_rigid_body(ident, frame, point, mass, centre, inertia,
                                     self.constants)
            self.bodies.append(rigid)
            self.rigid_of[body.name] = rigid
            if g_dir is not None and mass > 0:
                self.loads.append((rigid.masscenter, rigid.mass * self.g * g_dir))
            for k, (m_k, c_k, _, member) in enumerate(parts):
                if member.gravcomp and m_k > 0 and g_dir is not None:
                    at = point.locatenew(f"Gc{k}_{ident}", _vector(frame, c_k))
                    self.loads.append((at, -sm.Float(member.gravcomp * m_k) * self.g
                                       * g_dir))

    def fluid(self):
        """MuJoCo's inertia-based fluid forces (``<option density viscosity wind>``):
        on each body with mass, at its mass centre, along the principal axes of its
        central inertia (the axes of its equivalent inertia box, half-sizes r):
        quadratic drag ``-2 rho r_j r_k |v_i| v_i`` and ``-rho r_i (r_j^4 + r_k^4)
        |w_i| w_i / 2``, viscous ``-6 pi beta r_eq v_i`` and ``-8 pi beta r_eq^3 w_i``
        with ``r_eq`` the mean half-size; ``v`` is the mass centre's velocity less
        the wind."""
        option = self.m.option
        rho, beta = option.density, option.viscosity
        if rho <= 0 and beta <= 0:
            return
        wind = _vector(self.N, option.wind)
        qdot_to_u = self.qdot_to_u()
        for head, parts in self.members.items():
            if head == "":
                continue
            frame, point = self.frame_of[head], self.point_of[head]
            for k, (mass, c, J, member) in enumerate(parts):
                if mass < 1e-15:
                    continue
                if any(g.element.attrib.get("fluidshape", "none") != "none"
                       for g in member.geoms):
                    geom = next(g for g in member.geoms
                                if g.element.attrib.get("fluidshape", "none") != "none")
                    raise geom.element.error("fluidshape (the ellipsoid fluid model) is "
                                             "not supported")
                J_own, R_own = self.own_inertia[member.name]
                axes = self.box_axes[member.name]
                if axes is None:
                    axes = np.linalg.eigh(J_own)[1]
                moments = np.diag(axes.T @ J_own @ axes)
                axes = R_own @ axes
                r = np.sqrt(np.maximum(0.0, 1.5 / mass * (moments.sum() - 2 * moments)))
                ident = self.names(member.name, "body", member.element)
                box = _fixed_frame(frame, axes, f"Fl_{ident}")
                G = point.locatenew(f"Fl_{ident}", _vector(frame, c))
                # the speeds in place of the rates before the projections (after
                # them, the replacement rebuilt every drag term: 2/3 of the time)
                v = (G.pos_from(self.O).dt(self.N) - wind).xreplace(qdot_to_u)
                w = box.ang_vel_in(self.N).xreplace(qdot_to_u)
                force, torque = me.Vector(0), me.Vector(0)
                r_eq = r.mean()
                for i, e in enumerate((box.x, box.y, box.z)):
                    j, l = (i + 1) % 3, (i + 2) % 3
                    vi, wi = v.dot(e), w.dot(e)
                    # |v_i| as it is: sympy's own Abs would look for the sign of the
                    # whole velocity expression (2/3 of the fish's from_mjcf time)
                    fi = -sm.Float(2 * rho * r[j] * r[l]) * sm.Abs(vi, evaluate=False) \
                        * vi - sm.Float(6 * beta * math.pi * r_eq) * vi
                    gi = -sm.Float(0.5 * rho * r[i] * (r[j] ** 4 + r[l] ** 4)) \
                        * sm.Abs(wi, evaluate=False) * wi \
                        - sm.Float(8 * beta * math.pi * r_eq ** 3) * wi
                    force += fi * e
                    torque += gi * e
                self.loads.append((G, force))
                self.loads.append((box, torque))

    def qdot_to_u(self):
        """``{q': u}`` of the coordinates whose rate is a speed (hinge, slide, free
        position)."""
        out = {}
        for j in self.joint_infos:
            pairs = zip(j.q[:3], j.u[:3]) if j.type == "free" else (
                zip(j.q, j.u) if j.type in ("hinge", "slide") else ())
            out.update({q.diff(): u for q, u in pairs})
        return out

    def solid(self, body, inertia, parts):
        moments = principal_moments(inertia)
        amount, rule = inertia_violation(moments)
        scale = max(1.0, float(np.max(np.abs(moments))))
        if rule is None or amount <= 1e-12 * scale:
            return inertia
        what = ("is not positive semi-definite" if rule == "not positive semidefinite"
                else "violates the triangle inequality I1 + I2 >= I3")
        raise body.element.error(
            f"the central inertia of its body (bodies {', '.join(p[3].name for p in parts)})"
            f" {what} by {amount:.3g} kg m^2 (principal moments "
            + ", ".join(f"{x:.6g}" for x in moments) + " kg m^2)")

    def check_masses(self):
        carried = dict(self.carried)
        armature = {}
        for info in self.joint_infos:
            armature[info.body] = armature.get(info.body, 0.0) + info.armature
        order = [b for b in self.m.bodies[1:] if self.head[b.name][0] == b.name]
        for body in reversed(order):
            parent = self.head[self.m.bodies[body.parent].name][0]
            carried[parent] = carried.get(parent, 0.0) + carried.get(body.name, 0.0)
        for body in order:
            if carried.get(body.name, 0.0) == 0.0 and armature.get(body.name, 0.0) == 0.0:
                raise body.joints[0].element.error(
                    f"moves only massless bodies (body '{body.name}' and those below it "
                    "have no mass, inertia or armature): its acceleration is undetermined")

    def geom_records(self):
        out = []
        lo, hi = self.m.compiler.inertiagrouprange
        from ._inertia import geom_mass_properties, INERTIA_SHAPES
        for body in self.m.bodies:
            head, T = self.head[body.name]
            geoms = body.geoms if body.index else self.m.world_geoms
            counted = body.index and (self.m.compiler.inertiafromgeom == "true" or (
                self.m.compiler.inertiafromgeom == "auto" and body.inertial is None))
            for g in geoms:
                mass = (geom_mass_properties(g, self.meshes)[0] if counted and lo <= g.group <= hi
                        and g.type in INERTIA_SHAPES else 0.0)
                rgba = g.rgba if g.rgba is not None else self.m.materials.get(g.material)
                Tg = T @ _pose(g.pos, g.R)
                out.append(MJCFGeom(g.name, g.type, g.size, head, body.name,
                                    tuple(map(tuple, Tg)), rgba, g.group, g.contype,
                                    g.conaffinity, mass, g.element.line, g.element.source))
        return out

    # sites -------------------------------------------------------------------------
    def sites(self):
        out = {}
        for body in self.m.bodies:
            head, T = self.head[body.name]
            for site in body.sites if body.index else self.m.world_sites:
                Ts = T @ _pose(site.pos, site.R)
                ident = self.names(site.name, "site", site.element)
                frame, point = self.frame_of[head], self.point_of[head]
                P = point.locatenew(f"S_{ident}", _vector(frame, Ts[:3, 3])) \
                    if np.any(Ts[:3, 3]) else point
                out[site.name] = P
                self.site_infos.append(MJCFSite(site.name, body.name, P, frame,
                                                tuple(map(tuple, Ts)), site.type, site.size,
                                                site.element.line))
        return out

    # loop closures -------------------------------------------------------------------
    def body_pose(self, name):
        """The origin point of MJCF body ``name``, its frame, and the pose (4x4)
        of the body in that frame."""
        head, T = self.head[name]
        return self.point_of[head], self.frame_of[head], T

    def constraints(self):
        rows, lines = [], []
        joints = {j.name: j for j in self.joint_infos}
        reference = {q: self.initial[q] for q in self.q}

        def value(name, kind):  # a joint's coordinate or a tendon's length, less qpos0's
            x = joints[name].q[0] if kind == "joint" else self.tendon_of[name][0]
            return x - x.xreplace(reference)

        for eq in self.m.equalities:
            if eq.type in ("joint", "tendon"):
                y1 = value(eq.joint1, eq.type)
                if eq.joint2:
                    x = value(eq.joint2, eq.type)
                    poly = sum(sm.Float(c) * x ** k for k, c in enumerate(eq.polycoef))
                else:
                    poly = sm.Float(eq.polycoef[0])
                rows.append([y1 - poly])
                lines.append(f"{eq.type} {eq.joint1} = polynomial of "
                             f"{eq.joint2 or 'a constant'} (line {eq.element.line})")
                continue
            if eq.site1:
                rows.append(self.site_rows(eq))
                lines.append(f"{eq.type} of sites {eq.site1}-{eq.site2} (line "
                             f"{eq.element.line})")
                continue
            P1, F1, T1 = self.body_pose(eq.body1)
            P2, F2, T2 = self.body_pose(eq.body2)
            a1 = T1[:3, :3] @ np.asarray(eq.anchor) + T1[:3, 3]
            p1 = P1.pos_from(self.O) + _vector(F1, a1)
            o2 = P2.pos_from(self.O) + _vector(F2, T2[:3, 3])
            if eq.type == "connect":
                world = self.at_reference([p1.to_matrix(self.N), o2.to_matrix(self.N),
                                           F2.dcm(self.N)])
                R2 = np.array(world[2], dtype=float).T @ T2[:3, :3]  # body2 -> N
                local = R2.T @ (np.array(world[0], dtype=float).ravel()
                                - np.array(world[1], dtype=float).ravel())
                p2 = P2.pos_from(self.O) + _vector(F2, T2[:3, :3] @ local + T2[:3, 3])
                rows.append(list((p1 - p2).to_matrix(self.N)))
                lines.append(f"connect {eq.body1}-{eq.body2} (line {eq.element.line})")
                continue
            # weld: body2's pose fixed in body1's frame
            o1 = P1.pos_from(self.O) + _vector(F1, T1[:3, 3])
            R1 = sm.Matrix(F1.dcm(self.N)).T * sm.Matrix(T1[:3, :3])
            R2s = sm.Matrix(F2.dcm(self.N)).T * sm.Matrix(T2[:3, :3])
            if eq.relpose is None:
                world = self.at_reference([o1.to_matrix(self.N), o2.to_matrix(self.N),
                                           R1, R2s])
                R1n, R2n = (np.array(w, dtype=float) for w in world[2:])
                rel_pos = R1n.T @ (np.array(world[1], dtype=float).ravel()
                                   - np.array(world[0], dtype=float).ravel())
                rel_R = R1n.T @ R2n
            else:
                rel_pos, rel_R = np.array(eq.relpose[0]), quat_matrix(eq.relpose[1])
            d = (o2 - o1).to_matrix(self.N) - R1 * sm.Matrix(rel_pos)
            E = (R1 * sm.Matrix(rel_R)).T * R2s
            rows.append(list(d) + [(E[2, 1] - E[1, 2]) / 2, (E[0, 2] - E[2, 0]) / 2,
                                   (E[1, 0] - E[0, 1]) / 2])
            lines.append(f"weld {eq.body1}-{eq.body2} (line {eq.element.line})")
        return rows, lines

    def site_rows(self, eq):
        """The two sites coincide (connect), their frames too (weld)."""
        s1, s2 = (next(s for s in self.site_infos if s.name == n)
                  for n in (eq.site1, eq.site2))
        rows = list((s1.point.pos_from(self.O) - s2.point.pos_from(self.O))
                    .to_matrix(self.N))
        if eq.type == "weld":
            R1, R2 = (sm.Matrix(s.frame.dcm(self.N)).T
                      * sm.Matrix(np.array(s.transform)[:3, :3]) for s in (s1, s2))
            E = R1.T * R2
            rows += [(E[2, 1] - E[1, 2]) / 2, (E[0, 2] - E[2, 0]) / 2,
                     (E[1, 0] - E[0, 1]) / 2]
        return rows

    def at_reference(self, exprs):
        values = {q: self.initial[q] for q in self.q}
        return [np.array(sm.Matrix(e).xreplace(values).evalf(), dtype=float) for e in exprs]

    def loops(self):
        """Choose the independent constraint rows and the dependent coordinates."""
        groups, lines = self.constraints()
        if not groups:
            return None
        exprs = [e for g in groups for e in g]
        Phi = sm.Matrix(exprs)
        values = {q: self.initial[q] for q in self.q}
        J = np.array(Phi.jacobian(self.q).xreplace(values).evalf(), dtype=float)
        scale = max(1.0, float(np.max(np.abs(J))))
        s = np.linalg.svd(J, compute_uv=False)
        rank = int(np.sum(s > 1e-9 * scale))
        if rank == 0:
            return None
        import scipy.linalg
        _, _, rows = scipy.linalg.qr(J.T, pivoting=True)
        rows = sorted(rows[:rank])
        candidates = [i for i, q in enumerate(self.q)
                      if any(q in j.q and j.type in ("hinge", "slide")
                             for j in self.joint_infos)]
        sub = J[np.ix_(rows, candidates)]
        _, _, cols = scipy.linalg.qr(sub, pivoting=True)
        chosen = [candidates[c] for c in cols[:rank]]
        if np.linalg.matrix_rank(J[np.ix_(rows, chosen)], tol=1e-9 * scale) < rank:
            raise MJCFError(f"{self.m.source}: the equality constraints ("
                            + "; ".join(lines) + ") cannot be solved for hinge or slide "
                            "coordinates at the reference configuration")
        return [exprs[i] for i in rows], [self.q[i] for i in sorted(chosen)], lines


def from_mjcf(path, *, inputs=True, ground=None, ground_points=None, t_end=1.0,
              mesh_dirs=()):
    """A model definition of the MuJoCo model in an MJCF file.

    Parameters
    ----------
    path : str or path-like
        The MJCF (MuJoCo XML) file; ``<include>`` files are read from its folder.
    inputs : bool, optional
        Add each actuator's control ``ctrl_<actuator>`` as a specified input
        (zero by default; give ``specified={...}`` to
        :meth:`ModelDefinition.numeric`).  ``False``: no actuator forces.
    ground : kanedyn.Ground, optional
        A rigid ground plane ``z = ground.height`` of the world frame: every
        sphere (its centre against the plane raised by its radius), capsule (its
        two end spheres) and box (its eight vertices) geom of a moving body with
        ``contype`` or ``conaffinity`` not zero becomes a :class:`~kanedyn.Contact`
        with the ground's friction and restitution, named after the geom
        (``<body>/geom<k>`` when it has no name; ``#<k>`` appended for the ends
        and vertices).  Other geom types are not used (a :class:`UserWarning`
        names them); the file's own planes are not used either.
    ground_points : dict, optional
        With ``ground``: contact points given explicitly, ``{body name: [(x, y,
        z), ...]}`` in the MJCF body's frame (m), for bodies whose collision
        geometry is a mesh.  A point ``(x, y, z, r)`` is a sphere of radius
        ``r`` centred there.  Each becomes a contact named ``<body>/point<k>``;
        the body's own geoms are then not used (nor warned about).  An unknown
        body, or one fixed to the world, is an error naming it.
    t_end : float, optional
        Default simulation length, s.
    mesh_dirs : sequence of path-like, optional
        Folders besides the model's own (and those below it) that mesh files may
        be read from.  A mesh file is read only for a mesh geom whose mass and
        inertia are inferred (STL and OBJ need trimesh; MuJoCo's ``.msh`` does not).

    Returns
    -------
    MJCFDefinition
        Ready for ``definition.derive()``; its state is MuJoCo's, joint by joint
        (see the module docstring and ``docs/mjcf.md``), initial state the
        reference configuration ``qpos0`` at rest.

    Raises
    ------
    MJCFError
        A file that cannot be read or uses what is not supported, naming the
        file, the element and its line.

    Examples
    --------
    >>> import kanedyn as kd                                     # doctest: +SKIP
    >>> cartpole = kd.models.from_mjcf("cartpole.xml")            # doctest: +SKIP
    >>> model = cartpole.numeric()                                # doctest: +SKIP
    """
    model = parse_mjcf(path)
    build = _Builder(model, inputs, mesh_dirs)
    build.walk()
    if not build.q:
        raise MJCFError(f"{model.source}: the model has no joints: nothing moves")
    sites = build.sites()
    build.site_points = sites
    build.tendons()
    build.actuators()
    build.rigid_bodies()
    build.fluid()
    build.check_masses()
    loops = build.loops()
    kane_args = dict(frame=build.N, bodies=build.bodies, loads=build.loads)
    q_ind, u_ind, kd_eqs = list(build.q), list(build.u), list(build.kd_eqs)
    equalities = ()
    if loops is not None:
        config, q_dep, equalities = loops
        pairs = {q: u for q, u in zip(build.q, build.u)}
        u_dep = [pairs[q] for q in q_dep]
        q_ind = [q for q in q_ind if q not in q_dep]
        u_ind = [u for u in u_ind if u not in u_dep]
        kane_args.update(q_dep=q_dep, u_dep=u_dep, configuration_constraints=config)
    # the actuators' activations join the coordinates as first-order states
    q_ind += build.activations
    kd_eqs += build.kd_act
    kane_args.update(q_ind=q_ind, u_ind=u_ind, kd_eqs=kd_eqs)
    if build.activations and inputs:
        kane_args["kd_inputs"] = [a.ctrl for a in build.actuator_infos if a.act is not None]
    geoms = tuple(build.geom_records())
    contacts = robot_ground_contacts(
        ground, ground_points, mjcf_collision_shapes(geoms, build.frame_of, build.point_of),
        build.head, build, caller="from_mjcf", kind="body", error=MJCFError,
        source=model.source, none_usable=MJCF_NONE_USABLE)
    if contacts is not None:
        kane_args["contacts"] = contacts
    if build.bodies == [] or not any(isinstance(b, me.RigidBody) for b in build.bodies):
        raise MJCFError(f"{model.source}: no body has mass")
    nq, nv = build.qpos_at, build.dof_at
    symbols = dict(q=build.q, u=build.u, g=build.g, N=build.N, O=build.O, sites=sites,
                   frames={b.name: build.frame_of[build.head[b.name][0]]
                           for b in model.bodies},
                   points={b.name: build.point_of[build.head[b.name][0]]
                           for b in model.bodies},
                   ctrl={a.name: a.ctrl for a in build.actuator_infos},
                   act={a.name: a.act for a in build.actuator_infos if a.act is not None},
                   tendons={name: t[0] for name, t in build.tendon_of.items()},
                   bodies=dict(build.rigid_of))
    return MJCFDefinition(
        name=model.name, title=f"{model.name} from {Path(model.source).name} ({nv} degrees "
        "of freedom)",
        kane_args=kane_args, constants=build.constants, initial_state=build.initial,
        t_end=float(t_end), specified=build.specified, symbols=symbols,
        description=f"MuJoCo model '{model.name}' read from {model.source}.",
        source=model.source, joints=tuple(build.joint_infos),
        actuators=tuple(build.actuator_infos), sites=tuple(build.site_infos),
        geoms=geoms,
        equalities=tuple(equalities), body_of=dict(build.head), gravity=build.gravity,
        nq=nq, nv=nv, na=len(build.activations))
