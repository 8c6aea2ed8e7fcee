"""A model definition from a URDF robot description (``kd.models.from_urdf``).

Every moving joint (revolute, continuous, prismatic) gives one coordinate
``q_<joint>`` (rad or m) and its rate ``u_<joint> = q_<joint>'``; a fixed joint
merges its child link into the parent's body (mass, mass centre and inertia
combined exactly, so the dynamics are those of the rigidly attached links).
Masses, mass centres and central inertias of the bodies are parameters
(``m_<body>``, ``cx_<body>``, ..., ``Ixx_<body>``, ...); joint origins and axes
are numbers.  The joint efforts ``tau_<joint>`` (N m or N) are specified inputs,
zero by default.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..modeling import inertia_violation, principal_moments
from ._base import ModelDefinition
from ._urdf_parse import (URDFError, Visual, inertia_text, parse_robot, pose_matrix,
                          round_off_text)
from ._robot_ground import robot_ground_contacts
from ._urdf_ground import URDF_NONE_USABLE, urdf_collision_shapes
from ._urdf_shapes import urdf_shapes

__all__ = ["from_urdf", "URDFDefinition", "URDFError", "JointInfo", "Visual",
           "PINOCCHIO_GRAVITY", "named_rigid_body"]

#: Pinocchio's default ``model.gravity`` (linear part), m/s^2, in the base frame
PINOCCHIO_GRAVITY = (0.0, 0.0, -9.81)

_INERTIA_KEYS = (("xx", 0, 0), ("yy", 1, 1), ("zz", 2, 2), ("xy", 0, 1), ("yz", 1, 2),
                 ("zx", 2, 0))


@dataclass(frozen=True)
class JointInfo:
    """A moving joint of a URDF model, as data (limits are not enforced).

    Attributes
    ----------
    name, type : str
        URDF name and type (``revolute``, ``continuous``, ``prismatic``).
    parent, child : str
        URDF link names.
    axis : tuple
        Unit axis in the joint frame.
    q, u : sympy.Function
        The coordinate (rad or m) and its rate (rad/s or m/s).
    effort_input : sympy.Function or None
        The specified joint torque/force ``tau_<joint>`` (N m or N).
    lower, upper, velocity, effort : float or None
        ``<limit>`` values (rad or m, rad/s or m/s, N m or N); None if absent.
    damping, friction : float or None
        ``<dynamics>`` values (not applied).
    mimic : tuple or None
        ``(joint, multiplier, offset)`` of ``<mimic>``; the joint is kept
        independent (as Pinocchio does by default).
    line : int
        Line of the ``<joint>`` element.
    """

    name: str
    type: str
    parent: str
    child: str
    axis: tuple
    q: object
    u: object
    effort_input: object
    lower: float | None
    upper: float | None
    velocity: float | None
    effort: float | None
    damping: float | None
    friction: float | None
    mimic: tuple | None
    line: int


@dataclass(frozen=True)
class URDFDefinition(ModelDefinition):
    """A :class:`ModelDefinition` read from a URDF file, with its robot data.

    Besides the attributes of :class:`ModelDefinition`:

    Attributes
    ----------
    source : str
        The URDF file.
    joints : tuple of JointInfo
        The moving joints, in coordinate order (depth first, file order).
    visuals : tuple of Visual
        Every ``<visual>`` (shape, size, mesh file, pose in its body's link frame).
    collisions : tuple of Visual
        Every ``<collision>``, the same records (used by :meth:`shapes` when a
        visual mesh is of a format the viewer cannot read).
    link_bodies : dict
        ``{link name: (body name, 4x4 pose of the link in the body's link frame)}``;
        the body name is ``""`` for links fixed to the ground.
    gravity : tuple
        The gravity vector in the base frame, m/s^2.
    base : str
        ``"fixed"`` or ``"floating"``.
    """

    source: str = ""
    joints: tuple = ()
    visuals: tuple = ()
    collisions: tuple = ()
    link_bodies: dict = field(default_factory=dict)
    gravity: tuple = PINOCCHIO_GRAVITY
    base: str = "fixed"

    def limits(self):
        """``{joint: (lower, upper, velocity, effort)}`` (None where not given)."""
        return {j.name: (j.lower, j.upper, j.velocity, j.effort) for j in self.joints}

    def visual_shapes(self, constants=None):
        """The viewer shapes of the visuals, and what could not be drawn.

        Parameters
        ----------
        constants : dict, optional
            ``{Symbol or name: value}`` overriding the default constants (the
            mass centres ``cx_<body>``... place the shapes).

        Returns
        -------
        shapes : list of kanedyn.visuals.Shape
        notes : list of str
            One line per visual replaced by collision geometry or skipped, naming
            the link, the file and line, and the reason.
        """
        values = dict(self.constants)
        values.update(self._constant_overrides(constants or {}))
        return urdf_shapes(self, values)

    def shapes(self, constants=None):
        """Shapes drawing the robot with its own ``<visual>`` geometry.

        A visual mesh that the viewer cannot read (``.stl``, ``.obj`` and, with
        trimesh and pycollada, COLLADA ``.dae`` are read) is replaced by the
        link's ``<collision>`` geometry when that can be drawn.  Visuals of links
        fixed to the ground are shapes fixed in the inertial frame.  Visuals
        that are still not drawable (and those of massless links, which the
        viewer does not draw) are skipped with a
        :class:`UserWarning` naming each; :meth:`visual_shapes` returns the list.

        Parameters
        ----------
        constants : dict, optional
            Overrides of the default constants.

        Returns
        -------
        list of kanedyn.visuals.Shape
        """
        shapes, notes = self.visual_shapes(constants)
        skipped = [n for n in notes if n.startswith("skipped")]
        if skipped:
            warnings.warn(f"{self.source}: {len(skipped)} visual(s) not drawn:\n  "
                          + "\n  ".join(skipped), UserWarning, stacklevel=2)
        return shapes


def _identifier(name, taken, what, source):
    ident = re.sub(r"\W", "_", name)
    if not ident or ident[0].isdigit():
        ident = "_" + ident
    if ident in taken and taken[ident] != name:
        raise URDFError(f"{source}: {what} names '{name}' and '{taken[ident]}' both "
                        f"become the symbol name '{ident}'; rename one")
    taken[ident] = name
    return ident


#: an entry of a rotation, an axis or an offset this close to an integer is that
#: integer (the identity test of :func:`_rotation_frame` takes the same bound)
_ROUND_OFF = 1e-15


def _number(value):
    """The SymPy number of a rotation's entry, an axis', an offset's or the gravity
    direction's component: the integer it is within :data:`_ROUND_OFF` of, else
    the float.  A rotation
    by a multiple of pi/2, written in radians (``rpy="1.5707963267948966 0 0"``,
    as the Panda's URDF has), has entries cos(pi/2) = 6.1e-17 and 1.0: as
    floats they cost a product and a sum each wherever they enter the
    generated code (276 times in the Panda's derivative module), and 1.0 is not
    1 to SymPy, so the products they leave are not simplified."""
    value = float(value)
    whole = round(value)
    if abs(value - whole) <= _ROUND_OFF:
        return sm.Integer(whole)
    return sm.Float(value)


def _as_vector(frame, values):
    vec = me.Vector(0)
    for v, base in zip(values, (frame.x, frame.y, frame.z)):
        v = _number(v)
        if v != 0:
            vec += v * base
    return vec


def _rotation_frame(parent, R, name):
    """``parent`` itself when ``R`` is the identity, else a frame fixed in it."""
    if np.allclose(R, np.eye(3), rtol=0, atol=_ROUND_OFF):
        return parent
    frame = me.ReferenceFrame(name)
    frame.orient_dcm(parent, sm.Matrix(R.T).applyfunc(_number))
    return frame


def _group_mass(links):
    """Mass, mass centre (3,) and central inertia (3, 3) of rigidly joined links.

    ``links`` is ``[(Inertial or None, T)]`` with ``T`` the pose of the link frame
    in the body's frame.
    """
    parts = []
    for inertial, T in links:
        if inertial is None:
            continue
        R_in = pose_matrix(inertial.xyz, inertial.rpy)
        T_c = T @ R_in
        R = T_c[:3, :3]
        parts.append((inertial.mass, T_c[:3, 3], R @ inertial.inertia @ R.T))
    mass = sum(p[0] for p in parts)
    if mass > 0:
        centre = sum(m * r for m, r, _ in parts) / mass
    else:
        centre = np.zeros(3)
    inertia = np.zeros((3, 3))
    for m, r, J in parts:
        d = r - centre
        inertia += J + m * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, centre, inertia


def _nearest_solid(inertia):
    """The nearest central inertia (3, 3) of a solid: negative principal moments set
    to zero and the largest lowered to the sum of the others."""
    moments, axes = np.linalg.eigh(inertia)
    solid = np.maximum(moments, 0.0)
    if inertia_violation(solid)[1] is not None:  # the triangle inequality
        solid[2] = solid[0] + solid[1]
    return axes @ np.diag(solid) @ axes.T


def from_urdf(path, *, gravity=PINOCCHIO_GRAVITY, base="fixed", package_dirs=None,
              mesh_dirs=None, efforts=True, ground=None, ground_points=None, t_end=1.0):
    """A model definition of the robot described by a URDF file.

    Parameters
    ----------
    path : str or path-like
        The URDF file.
    gravity : sequence of 3 floats, optional
        Gravitational acceleration in the frame of the root link, m/s^2.  URDF
        says nothing about gravity; the default ``(0, 0, -9.81)`` is Pinocchio's
        ``model.gravity``.  Its magnitude is the parameter ``g``.
    base : {"fixed", "floating"}, optional
        ``"fixed"``: the root link is the ground.  ``"floating"``: the root link
        moves freely (position of its origin ``x, y, z`` in the base frame;
        body-fixed x-y-z angles ``phi, theta, psi``; speeds ``v_x, v_y, v_z`` of
        its origin and ``w_x, w_y, w_z`` of its rotation, along its own axes).
    package_dirs : list of str, optional
        Folders that hold the packages of ``package://PKG/...`` mesh URIs.  The
        folders above the URDF file named ``PKG`` that hold a ``package.xml`` (a
        ROS package) are searched too.
    mesh_dirs : list of str, optional
        Folders from which mesh files may be read besides the URDF's own folder,
        those of ``package_dirs`` and, for ``package://PKG/...``, the ROS package
        ``PKG`` above the URDF.  A mesh file outside all of them (a path with
        ``..``, an absolute path, a ``file://`` URI, symbolic links resolved) is
        not read: a URDF file handed to you cannot make the viewer embed other
        files of yours in its page.  A mesh that is refused or not found is an
        error only when it is asked for (:meth:`Visual.mesh_file`);
        :meth:`URDFDefinition.shapes` skips it with a warning.
    efforts : bool, optional
        Add the joint torques/forces ``tau_<joint>`` as specified inputs (zero by
        default; give ``specified={...}`` to :meth:`ModelDefinition.numeric`).
    ground : kanedyn.Ground, optional
        A rigid ground plane ``z = ground.height`` of the base frame: every
        ``<collision>`` sphere (its centre against the plane raised by its
        radius) and box (its eight vertices) of a moving body becomes a
        :class:`~kanedyn.Contact` with the ground's friction and restitution,
        named ``<link>/collision<k>`` (``#<vertex>`` appended for a box).
        Cylinders and meshes are not used (a :class:`UserWarning` names them);
        none usable is an error.
    ground_points : dict, optional
        With ``ground``: contact points given explicitly, ``{link name: [(x, y,
        z), ...]}`` in the link's frame (m), for links whose collision geometry
        is a mesh.  A point ``(x, y, z, r)`` is a sphere of radius ``r`` centred
        there.  Each becomes a contact named ``<link>/point<k>``; the link's
        ``<collision>`` elements are then not used (nor warned about).  An
        unknown link, or one fixed to the ground, is an error naming it.
    t_end : float, optional
        Default simulation length, s.

    Returns
    -------
    URDFDefinition
        Ready for ``definition.derive()`` or ``kd.kane(**definition.kane_args)``;
        joint data in ``.joints``, limits by ``.limits()``, visuals in ``.visuals``.

    Raises
    ------
    URDFError
        A file that cannot be read, naming the file, the element and its line.

    Warns
    -----
    UserWarning
        Naming the links whose inertia is not a solid's by round-off only (up to
        ``INERTIA_RTOL = 1e-6`` of the largest principal moment of the robot's
        links): accepted, and where a body's merged inertia is still not a solid's
        it is replaced by the nearest one.

    Examples
    --------
    >>> import kanedyn as kd                                    # doctest: +SKIP
    >>> robot = kd.models.from_urdf("ur5.urdf")                  # doctest: +SKIP
    >>> model = robot.numeric()                                  # doctest: +SKIP
    """
    if base not in ("fixed", "floating"):
        raise ModelError(f"base must be 'fixed' or 'floating', not {base!r}")
    gravity = tuple(float(x) for x in gravity)
    if len(gravity) != 3 or not all(np.isfinite(gravity)):
        raise ModelError(f"gravity must be three finite numbers (m/s^2), not {gravity}")
    robot = parse_robot(path, package_dirs, mesh_dirs)
    build = _Builder(robot, base, efforts)
    build.walk()
    if base == "floating":
        build.floating_base()
    for joint, parent_body, T_parent in build.order:
        build.joint(joint, parent_body, T_parent)
    build.bodies(gravity)
    _check_masses(build.order, build.carried, robot.source)
    _warn_inertias(robot, build.adjusted)

    visuals, collisions = [], []
    for link in robot.links.values():
        body, T = build.group[link.name]
        for records, out in ((link.visuals, visuals), (link.collisions, collisions)):
            for vis in records:
                pose = T @ pose_matrix(vis.xyz, vis.rpy)
                out.append(replace(vis, body=body, transform=tuple(map(tuple, pose))))
    q_list, u_list = build.q, build.u
    group = build.group
    kane_args = dict(frame=build.N, q_ind=q_list, u_ind=u_list, kd_eqs=build.kd_eqs,
                     bodies=build.rigid_bodies, loads=build.loads)
    contacts = robot_ground_contacts(
        ground, ground_points, urdf_collision_shapes(collisions, build), group, build,
        caller="from_urdf", kind="link", error=URDFError, source=robot.source,
        none_usable=URDF_NONE_USABLE)
    if contacts is not None:
        kane_args["contacts"] = contacts
    symbols = dict(q=q_list, u=u_list, g=build.g, N=build.N, O=build.O,
                   frames={link: build.frame_of[group[link][0]] for link in robot.links},
                   points={link: build.point_of[group[link][0]] for link in robot.links})
    return URDFDefinition(
        name=robot.name, title=f"{robot.name} from {robot.source} ({len(q_list)} coordinates)",
        kane_args=kane_args, constants=build.constants,
        initial_state={s: 0.0 for s in q_list + u_list},
        t_end=float(t_end), specified=build.specified, symbols=symbols,
        description=f"URDF robot '{robot.name}' read from {robot.source}; {base} base.",
        source=robot.source, joints=tuple(build.joint_infos), visuals=tuple(visuals),
        collisions=tuple(collisions),
        link_bodies=dict(group), gravity=gravity, base=base)


class _Builder:
    """Frames, points, bodies and loads of a parsed robot, built joint by joint."""

    def __init__(self, robot, base, efforts):
        self.robot, self.base, self.efforts = robot, base, efforts
        self.source = robot.source
        self.N = me.ReferenceFrame("N")
        self.O = me.Point("O")
        self.O.set_vel(self.N, 0)
        self.names, self.taken = {}, {}
        self.q, self.u, self.kd_eqs, self.loads, self.joint_infos = [], [], [], [], []
        self.specified, self.constants, self.rigid_bodies, self.carried = {}, {}, [], {}
        self.frame_of, self.point_of = {"": self.N}, {"": self.O}
        self.g = sm.Symbol("g", nonnegative=True)
        self.adjusted = []  # notes on the bodies whose inertia was moved to a solid's

    def walk(self):
        """``group``: link -> (body, pose in the body's link frame); ``order``: the
        moving joints depth first in file order, with their parent body and pose."""
        robot = self.robot
        self.group = {robot.root: ("" if self.base == "fixed" else robot.root, np.eye(4))}
        self.order = []
        stack = [robot.root]
        while stack:
            children = robot.children(stack.pop())
            for joint in children:
                body, T_parent = self.group[joint.parent]
                if joint.type == "fixed":
                    self.group[joint.child] = (body, T_parent @ pose_matrix(joint.xyz,
                                                                             joint.rpy))
                else:
                    self.group[joint.child] = (joint.child, np.eye(4))
                    self.order.append((joint, body, T_parent))
            stack.extend(j.child for j in reversed(children))

    def floating_base(self):
        """Six coordinates of the root link: origin position, body-fixed x-y-z angles."""
        N, root = self.N, self.robot.root
        ident = self.names[root] = _identifier(root, self.taken, "link", self.source)
        x, y, z, phi, theta, psi = me.dynamicsymbols("x y z phi theta psi")
        vx, vy, vz, wx, wy, wz = me.dynamicsymbols("v_x v_y v_z w_x w_y w_z")
        B = me.ReferenceFrame(f"F_{ident}")
        B.orient_body_fixed(N, (phi, theta, psi), "xyz")
        w_q = B.ang_vel_in(N)
        B.set_ang_vel(N, wx * B.x + wy * B.y + wz * B.z)
        P = self.O.locatenew(f"P_{ident}", x * N.x + y * N.y + z * N.z)
        v = vx * B.x + vy * B.y + vz * B.z
        P.set_vel(N, v)
        self.kd_eqs += [qd - v.dot(e) for qd, e in zip((x.diff(), y.diff(), z.diff()),
                                                        (N.x, N.y, N.z))]
        self.kd_eqs += [w_q.dot(e) - w for e, w in zip((B.x, B.y, B.z), (wx, wy, wz))]
        self.q += [x, y, z, phi, theta, psi]
        self.u += [vx, vy, vz, wx, wy, wz]
        self.frame_of[root], self.point_of[root] = B, P

    def joint(self, joint, parent_body, T_parent):
        """The child's frame and origin, the coordinate, the effort of one joint."""
        ident = _identifier(joint.name, self.taken, "joint", self.source)
        body_ident = self.names[joint.child] = _identifier(joint.child, self.taken, "link",
                                                            self.source)
        q, u = me.dynamicsymbols(f"q_{ident} u_{ident}")
        T_joint = T_parent @ pose_matrix(joint.xyz, joint.rpy)
        P_frame = self.frame_of[parent_body]
        J = _rotation_frame(P_frame, T_joint[:3, :3], f"J_{ident}")
        axis_J = _as_vector(J, joint.axis)
        joint_point = self.point_of[parent_body].locatenew(
            f"J_{ident}", _as_vector(P_frame, T_joint[:3, 3]))
        if joint.type == "prismatic":
            C = J
            P = joint_point.locatenew(f"P_{body_ident}", q * axis_J)
        else:
            C = me.ReferenceFrame(f"F_{body_ident}")
            C.orient_axis(J, axis_J, q)
            C.set_ang_vel(J, u * axis_J)
            P = joint_point
        self.frame_of[joint.child], self.point_of[joint.child] = C, P
        self.q.append(q)
        self.u.append(u)
        self.kd_eqs.append(q.diff() - u)
        tau = None
        if self.efforts:
            tau = me.dynamicsymbols(f"tau_{ident}")
            self.specified[tau] = 0.0
            # a force on the child's origin, the reaction at the joint origin of the
            # parent (same line of action); a torque pair for revolute joints
            action, reaction = (P, joint_point) if joint.type == "prismatic" else (C, P_frame)
            self.loads.append((action, tau * axis_J))
            if parent_body != "":
                self.loads.append((reaction, -tau * axis_J))
        self.joint_infos.append(JointInfo(
            name=joint.name, type=joint.type, parent=joint.parent, child=joint.child,
            axis=joint.axis, q=q, u=u, effort_input=tau, lower=joint.lower,
            upper=joint.upper, velocity=joint.velocity, effort=joint.effort,
            damping=joint.damping, friction=joint.friction, mimic=joint.mimic,
            line=joint.line))

    def solid(self, body, inertia):
        """The central inertia of ``body`` (links merged), checked to be a solid's: as it
        is, or, when it misses by round-off only (``robot.inertia_tolerance``), the
        nearest solid's (noted in ``adjusted``)."""
        moments = principal_moments(inertia)
        amount, rule = inertia_violation(moments)
        if rule is None:
            return inertia
        links = [name for name, (head, _) in self.group.items() if head == body]
        link = self.robot.links[body]
        line = link.inertial.line if len(links) == 1 else link.line  # its <inertia>
        where = (f"{self.source}:{line}: <link name='{body}'>: the central inertia of its "
                 "body" + (f" (links {', '.join(links)} merged by fixed joints)"
                           if len(links) > 1 else "") + " " + inertia_text(amount, rule,
                                                                           moments))
        if amount > self.robot.inertia_tolerance:
            raise URDFError(f"{where}: more than round-off, which is up to "
                            + round_off_text(self.robot.inertia_tolerance))
        self.adjusted.append(f"{where}: replaced by the nearest inertia of a solid")
        return _nearest_solid(inertia)

    def bodies(self, gravity):
        """One RigidBody per moving link and the links fixed to it; gravity loads."""
        members = {}
        for link, (body, T) in self.group.items():
            members.setdefault(body, []).append((self.robot.links[link].inertial, T))
        g_norm = float(np.linalg.norm(gravity))
        g_dir = None
        if g_norm > 0:
            self.constants[self.g] = g_norm
            g_dir = _as_vector(self.N, np.array(gravity) / g_norm)
        heads = [self.robot.root] + [j.child for j, _, _ in self.order]
        for body in heads:
            if self.group[body][0] != body:
                continue  # the ground (fixed base)
            with np.errstate(over="ignore", invalid="ignore"):
                mass, centre, inertia = _group_mass(members[body])
            if not (np.isfinite(mass) and np.all(np.isfinite(centre))
                    and np.all(np.isfinite(inertia))):
                link = self.robot.links[body]
                raise URDFError(f"{self.source}:{link.line}: <link name='{body}'>: the mass, "
                                "mass centre or inertia of the links it carries is beyond "
                                "the range of floating point")
            inertia = self.solid(body, inertia)
            self.carried[body] = mass + float(np.abs(inertia).sum())
            if mass == 0 and not inertia.any():
                continue  # a massless body: a frame only
            rigid = named_rigid_body(self.names[body], self.frame_of[body],
                                     self.point_of[body], mass, centre, inertia,
                                     self.constants)
            self.rigid_bodies.append(rigid)
            if g_dir is not None and mass > 0:
                self.loads.append((rigid.masscenter, rigid.mass * self.g * g_dir))


def named_rigid_body(ident, frame, origin, mass, centre, inertia, constants):
    """The rigid body ``ident`` fixed in ``frame`` whose mass (kg), mass centre (m,
    from the point ``origin`` in ``frame`` components, shape (3,)) and central
    inertia (kg m^2, ``frame`` components, shape (3, 3)) are named constants
    (``m_<ident>``, ``cx_<ident>``..., ``Ixx_<ident>``...), their values put in
    ``constants`` (a dict, changed)."""
    m = sm.Symbol(f"m_{ident}", nonnegative=True)
    c = sm.symbols(f"cx_{ident} cy_{ident} cz_{ident}", real=True)
    G = origin.locatenew(f"G_{ident}", sum(
        (ci * e for ci, e in zip(c, (frame.x, frame.y, frame.z))), me.Vector(0)))
    constants[m] = mass
    constants.update({ci: float(v) for ci, v in zip(c, centre)})
    comps = {}
    for key, i, k in _INERTIA_KEYS:
        comps[key] = sm.Symbol(f"I{key}_{ident}", real=True)
        constants[comps[key]] = float(inertia[i, k])
    dyadic = me.inertia(frame, comps["xx"], comps["yy"], comps["zz"], comps["xy"],
                        comps["yz"], comps["zx"])
    return me.RigidBody(ident, G, frame, m, (dyadic, G))


def _warn_inertias(robot, adjusted):
    """One warning naming the links and bodies whose inertia is not a solid's only
    by round-off (accepted; a body's replaced by the nearest solid's)."""
    notes = robot.inertia_notes + tuple(adjusted)
    if notes:
        warnings.warn(f"{robot.source}: {len(notes)} inertia(s) not a solid's by "
                      f"round-off only, up to {round_off_text(robot.inertia_tolerance)}, "
                      "accepted:\n  " + "\n  ".join(notes), UserWarning, stacklevel=3)


def _check_masses(order, carried, source):
    """Every moving joint must carry some mass or inertia beyond it."""
    carried = dict(carried)
    for joint, parent_body, _ in reversed(order):  # children before parents
        carried[parent_body] = carried.get(parent_body, 0.0) + carried.get(joint.child, 0.0)
    for joint, _, _ in order:
        if carried.get(joint.child, 0.0) == 0.0:
            raise URDFError(f"{source}:{joint.line}: <joint name='{joint.name}'>: "
                            "moves only massless links (no <inertial> beyond it): its "
                            "acceleration is undetermined")
