"""An MJCF file as plain records: compiler and physics options, the body tree
with joints, geoms, sites and inertials, actuators and equality constraints.

Default classes are resolved here, as MuJoCo does: an element takes the
attributes of its ``class``, else of the ``childclass`` of the nearest body (or
frame) above it that names one, else of the top-level default class ``main``;
a nested ``<default class=...>`` starts from its parent class.  Angles are
turned into radians (``<compiler angle="degree">`` is MuJoCo's default) and
orientations into rotation matrices.  Errors name the file, the element and
its line (for a value that comes from a default class, the line of the
``<default>`` element that gives it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._frames import (ORIENTATIONS, axis_angle_matrix, euler_matrix, quat_matrix,
                      xyaxes_matrix, zaxis_matrix)
from ._meshes import MESH_INERTIA_MODES, Mesh
from ._xml import MJCFError, number, numbers, read_mjcf

__all__ = ["Model", "Body", "Joint", "Geom", "Site", "Inertial", "Actuator", "Equality",
           "Compiler", "Option", "parse_mjcf", "JOINT_TYPES", "GEOM_TYPES",
           "ACTUATOR_TYPES"]

JOINT_TYPES = ("hinge", "slide", "ball", "free")
GEOM_TYPES = ("plane", "hfield", "sphere", "capsule", "ellipsoid", "cylinder", "box",
              "mesh", "sdf")
#: actuators read: force = gain * (ctrl, or the activation) + bias
ACTUATOR_TYPES = ("motor", "position", "velocity", "general", "damper", "intvelocity",
                  "cylinder")
_OTHER_ACTUATORS = ("muscle", "adhesion", "plugin")
#: activation dynamics read (MuJoCo's dyntype)
DYNTYPES = ("none", "integrator", "filter", "filterexact")
_FLAGS = ("constraint", "equality", "frictionloss", "limit", "contact", "spring", "damper",
          "passive", "gravity", "clampctrl", "warmstart", "filterparent", "actuation",
          "refsafe", "sensor", "midphase", "eulerdamp", "autoreset", "nativeccd", "island",
          "override", "energy", "fwdinv", "invdiscrete", "multiccd", "sleep")


@dataclass(frozen=True)
class Compiler:
    """``<compiler>`` settings that change the model (MuJoCo's defaults)."""

    angle: str = "degree"
    eulerseq: str = "xyz"
    inertiafromgeom: str = "auto"
    inertiagrouprange: tuple = (0, 5)
    settotalmass: float = -1.0
    boundmass: float = 0.0
    boundinertia: float = 0.0
    balanceinertia: bool = False
    autolimits: bool = True
    alignfree: bool = False
    meshdir: str | None = None  # mesh files' folder (else assetdir), from the model's
    assetdir: str | None = None


@dataclass(frozen=True)
class Option:
    """``<option>``: gravity (m/s^2), fluid density (kg/m^3) and viscosity (Pa s),
    wind (m/s), and the flags that are disabled (e.g. ``{"contact", "gravity"}``)."""

    gravity: tuple = (0.0, 0.0, -9.81)
    density: float = 0.0
    viscosity: float = 0.0
    wind: tuple = (0.0, 0.0, 0.0)
    timestep: float = 0.002
    disabled: frozenset = frozenset()
    enabled: frozenset = frozenset()


@dataclass(frozen=True)
class Joint:
    """A joint: type, anchor ``pos`` and unit ``axis`` in its body's frame,
    ``range`` (rad or m; None when not limited), reference and spring reference
    positions, stiffness, damping, armature and friction loss (SI units)."""

    name: str
    type: str
    pos: tuple
    axis: tuple
    range: tuple | None
    ref: float
    springref: float
    stiffness: float
    damping: float
    armature: float
    frictionloss: float
    element: object = None
    #: the coefficients of x^2, x^3 of a polynomial spring -(a x + b x^2 + c x^3)
    #: and of v|v|, v^3 of polynomial damping -(a v + b v|v| + c v^3)
    stiffness_terms: tuple = (0.0, 0.0)
    damping_terms: tuple = (0.0, 0.0)


@dataclass(frozen=True)
class Tendon:
    """A fixed tendon: its length is ``sum(coef * q)`` over ``joints``
    (``[(joint name, coef)]``); a spatial one (``path`` not empty) is a path
    through sites, ``path`` = ``[(site name, divisor)]`` with ``None`` for a
    pulley (it ends a branch; the divisor of the branch after it is the
    pulley's); a spring ``-(a x + b x^2 + c x^3)`` of the
    displacement ``x`` from ``springlength`` (a dead band when two values differ;
    None: the length at the joints' spring references), polynomial damping,
    armature, ``range`` (not enforced)."""

    name: str
    joints: tuple
    stiffness: tuple
    damping: tuple
    springlength: tuple | None
    armature: float
    range: tuple | None
    frictionloss: float
    element: object = None
    path: tuple = ()


@dataclass(frozen=True)
class Geom:
    """A geom: type, ``size`` (MuJoCo's half-sizes and radii), pose in its body's
    frame, ``mass`` (None: from ``density``), ``density`` (kg/m^3), group."""

    name: str
    type: str
    size: tuple
    pos: np.ndarray
    R: np.ndarray
    mass: float | None
    density: float
    group: int
    shellinertia: bool
    rgba: tuple | None
    element: object = None
    contype: int = 1
    conaffinity: int = 1
    material: str | None = None
    mesh: str | None = None  # the <mesh> asset of a mesh geom


@dataclass(frozen=True)
class Site:
    """A site: name, type, size, pose in its body's frame."""

    name: str
    type: str
    size: tuple
    pos: np.ndarray
    R: np.ndarray
    body: str = ""
    element: object = None


@dataclass(frozen=True)
class Inertial:
    """A body's ``<inertial>``: mass (kg), mass centre ``pos`` (m) and the
    central inertia (3, 3) in the body's frame (kg m^2)."""

    mass: float
    pos: np.ndarray
    inertia: np.ndarray
    element: object = None
    axes: np.ndarray | None = None  # principal axes when given (diaginertia)


@dataclass
class Body:
    """A body: pose in its parent's frame, joints (in order), geoms, sites,
    ``<inertial>``, children; ``index`` is MuJoCo's body number (world 0)."""

    name: str
    index: int
    parent: int
    pos: np.ndarray
    R: np.ndarray
    joints: list
    geoms: list
    sites: list
    inertial: Inertial | None
    gravcomp: float
    mocap: bool
    element: object = None
    children: list = field(default_factory=list)


@dataclass(frozen=True)
class Actuator:
    """An actuator of a joint: force = gain * ctrl + bias, with
    ``gain = gainprm[0] + gainprm[1] * length + gainprm[2] * velocity`` (the last
    two only for an affine gain) and
    ``bias = biasprm[0] + biasprm[1] * length + biasprm[2] * velocity``, where
    ``length = gear * q`` and ``velocity = gear * q'``; the joint receives
    ``gear * force``.  ``ctrlrange``/``forcerange`` are None when not limited."""

    name: str
    type: str
    joint: str
    gear: float
    gain: tuple
    bias: tuple
    ctrlrange: tuple | None
    forcerange: tuple | None
    element: object = None
    tendon: bool = False  # ``joint`` names a fixed tendon
    #: activation dynamics: ``none`` (the force uses ctrl), ``integrator``
    #: (act' = ctrl), ``filter`` and ``filterexact`` (act' = (ctrl - act) / tau,
    #: tau in s); the force then uses the activation
    dyntype: str = "none"
    tau: float = 0.0
    actrange: tuple | None = None
    actearly: bool = False


@dataclass(frozen=True)
class Equality:
    """An ``<equality>`` constraint: ``connect`` (a point of ``body1``, ``anchor`` in
    its frame, on ``body2``), ``weld`` (``body2`` fixed to ``body1`` in the pose
    ``relpose`` = (pos, quat w-first) of body2 in body1's frame, or as at the
    reference configuration when None), ``joint`` (``joint1 = polynomial of
    joint2``, ``polycoef``, both less their values at the reference configuration)
    or ``tendon`` (the same of two fixed tendons' lengths, named in ``joint1``
    and ``joint2``)."""

    type: str
    name: str
    body1: str = ""
    body2: str = ""
    anchor: tuple = (0.0, 0.0, 0.0)
    relpose: tuple | None = None
    joint1: str = ""
    joint2: str = ""
    polycoef: tuple = (0.0, 1.0, 0.0, 0.0, 0.0)
    element: object = None
    site1: str = ""  # a connect or weld between two sites: they coincide
    site2: str = ""


@dataclass
class Model:
    """The records of one MJCF file."""

    name: str
    source: str
    compiler: Compiler
    option: Option
    bodies: list          # index order (depth first, file order), world first
    actuators: list
    equalities: list
    world_sites: list
    world_geoms: list
    materials: dict = field(default_factory=dict)  # name -> rgba
    tendons: list = field(default_factory=list)
    meshes: dict = field(default_factory=dict)  # name -> Mesh

    def body(self, name):
        return next((b for b in self.bodies if b.name == name), None)

    def joints(self):
        """``[(joint, body)]`` in MuJoCo's order."""
        return [(j, b) for b in self.bodies for j in b.joints]


# -- attributes with defaults --------------------------------------------------------

class _Attrs:
    """An element's attributes merged with its default class: ``{key: (text,
    element that gives it)}``."""

    def __init__(self, element, defaults):
        self.element = element
        self.values = dict(defaults)
        for key, text in element.attrib.items():
            self.values[key] = (text, element)

    def has(self, key):
        return key in self.values

    def text(self, key, default=None):
        return self.values[key][0] if key in self.values else default

    def _origin(self, key):
        text, origin = self.values[key]
        if origin is self.element:
            return origin, key
        # from a default class: name the default element that gives it
        return _Proxy(origin, key, text), key

    def number(self, key, default):
        if key not in self.values:
            return default
        origin, key = self._origin(key)
        return number(origin, key)

    def numbers(self, key, default, **count):
        if key not in self.values:
            return default
        origin, key = self._origin(key)
        return numbers(origin, key, **count)

    def error(self, key, message):
        origin, key = self._origin(key)
        return origin.error(f"{key}='{self.values[key][0]}': {message}")

    def choice(self, key, default, allowed):
        value = self.text(key, default)
        if value not in allowed:
            raise self.error(key, f"'{value}' is not one of {', '.join(allowed)}")
        return value

    def flag(self, key, default):
        """A MuJoCo boolean ("true"/"false"), or "auto"."""
        return self.choice(key, default, ("true", "false", "auto"))


class _Proxy:
    """A default-class element standing in for an attribute it gives."""

    def __init__(self, origin, key, text):
        self.origin, self.attrib = origin, {key: text}

    def error(self, message):
        return MJCFError(f"{self.origin.source}:{self.origin.line}: "
                         f"{self.origin.label()} (a default): {message}")


def _bool(attrs, key, default):
    return attrs.choice(key, default, ("true", "false")) == "true"


# -- the reader ----------------------------------------------------------------

class _Reader:
    def __init__(self, root, source):
        self.root, self.source = root, source
        self.compiler = self._compiler()
        self.defaults = {}
        self.default_lines = {}
        for el in root.findall("default"):
            self._default(el, "main", {}, top=True)
        self.defaults.setdefault("main", {})

    # compiler and options ---------------------------------------------------------
    def _compiler(self):
        values = {}
        for el in self.root.findall("compiler"):
            a = _Attrs(el, {})
            if a.has("coordinate") and a.text("coordinate") != "local":
                raise a.error("coordinate", "only local coordinates are read (MuJoCo "
                              "itself has dropped 'global')")
            if a.has("angle"):
                values["angle"] = a.choice("angle", "degree", ("degree", "radian"))
            if a.has("eulerseq"):
                seq = a.text("eulerseq")
                if len(seq) != 3 or any(c not in "xyzXYZ" for c in seq):
                    raise a.error("eulerseq", "needs three of the letters x, y, z, X, Y, Z")
                values["eulerseq"] = seq
            if a.has("inertiafromgeom"):
                values["inertiafromgeom"] = a.choice("inertiafromgeom", "auto",
                                                     ("true", "false", "auto"))
            if a.has("inertiagrouprange"):
                values["inertiagrouprange"] = tuple(
                    int(v) for v in a.numbers("inertiagrouprange", None, n=2))
            for key in ("settotalmass", "boundmass", "boundinertia"):
                if a.has(key):
                    values[key] = a.number(key, None)
            for key in ("balanceinertia", "autolimits", "alignfree"):
                if a.has(key):
                    values[key] = _bool(a, key, "false")
            if values.get("alignfree"):
                raise a.error("alignfree", "free bodies moved to their inertial frames "
                              "are not supported (their qpos would not be the body's)")
            for key in ("meshdir", "assetdir"):
                if a.has(key):
                    values[key] = a.text(key)
            if a.has("fusestatic") and _bool(a, "fusestatic", "false"):
                pass  # merging bodies without joints changes nothing in the dynamics
        return Compiler(**values)

    def option(self):
        values, disabled, enabled = {}, set(), set()
        for el in self.root.findall("option"):
            a = _Attrs(el, {})
            if a.has("gravity"):
                values["gravity"] = a.numbers("gravity", None, n=3)
            if a.has("wind"):
                values["wind"] = a.numbers("wind", None, n=3)
            for key in ("density", "viscosity", "timestep"):
                if a.has(key):
                    values[key] = a.number(key, None)
            for flag_el in el.findall("flag"):
                for key, text in flag_el.attrib.items():
                    if key not in _FLAGS:
                        raise flag_el.error(f"unknown flag '{key}'")
                    if text not in ("enable", "disable"):
                        raise flag_el.error(f"{key}='{text}': give 'enable' or 'disable'")
                    (disabled if text == "disable" else enabled).add(key)
                    (enabled if text == "disable" else disabled).discard(key)
        return Option(disabled=frozenset(disabled), enabled=frozenset(enabled), **values)

    # default classes -------------------------------------------------------------
    def _default(self, el, parent_class, inherited, top=False):
        name = el.attrib.get("class", "main" if top else None)
        if name is None:
            raise el.error("a nested <default> needs a class name")
        if top and name == "main" and name in self.defaults:
            # a further top-level <default> adds to the top class, as MuJoCo merges
            # them; classes it declares start from the top class as it is then
            inherited = self.defaults.pop(name)
        elif name in self.defaults:
            raise el.error(f"a second default class '{name}' (the first is on line "
                           f"{self.default_lines[name]})")
        table = {tag: dict(values) for tag, values in inherited.items()}
        for child in el.children:
            if child.tag == "default":
                continue
            tag = "actuator" if child.tag in ACTUATOR_TYPES + _OTHER_ACTUATORS \
                else child.tag
            entry = table.setdefault(tag, {})
            for key, text in child.attrib.items():
                if key == "class":
                    raise child.error("an element of a default class has no 'class'")
                entry[key] = (text, child)
        self.defaults[name] = table
        self.default_lines[name] = el.line
        for child in el.findall("default"):
            self._default(child, name, table)

    def attrs(self, el, tag, childclass):
        cls = el.attrib.get("class") or childclass or "main"
        if cls not in self.defaults:
            raise el.error(f"class '{cls}' is not a default class of this model")
        return _Attrs(el, self.defaults[cls].get(tag, {}))

    # poses ---------------------------------------------------------------------------
    def angle(self, value):
        return math.radians(value) if self.compiler.angle == "degree" else value

    def rotation(self, a):
        """The rotation matrix of the orientation attribute of ``a`` (identity if none)."""
        own = [k for k in ORIENTATIONS if k in a.element.attrib]
        if len(own) > 1:
            raise a.element.error(f"gives {' and '.join(own)}: give one orientation")
        keys = own or [k for k in ORIENTATIONS if a.has(k)][:1]
        if not keys:
            return np.eye(3)
        key = keys[0]
        if key == "quat":
            q = a.numbers("quat", None, n=4)
            if np.linalg.norm(q) < 1e-12:
                raise a.error("quat", "a zero quaternion")
            return quat_matrix(q)
        if key == "axisangle":
            v = a.numbers("axisangle", None, n=4)
            n = np.linalg.norm(v[:3])
            if n < 1e-12:
                raise a.error("axisangle", "a zero axis")
            return axis_angle_matrix(np.array(v[:3]) / n, self.angle(v[3]))
        if key == "euler":
            v = a.numbers("euler", None, n=3)
            return euler_matrix([self.angle(x) for x in v], self.compiler.eulerseq)
        if key == "xyaxes":
            v = a.numbers("xyaxes", None, n=6)
            R = xyaxes_matrix(v[:3], v[3:])
            if R is None:
                raise a.error("xyaxes", "the two axes are parallel or zero")
            return R
        v = a.numbers("zaxis", None, n=3)
        R = zaxis_matrix(v)
        if R is None:
            raise a.error("zaxis", "a zero axis")
        return R

    def pose(self, a):
        return np.array(a.numbers("pos", (0.0, 0.0, 0.0), n=3)), self.rotation(a)

    # elements ----------------------------------------------------------------------
    def joint(self, el, childclass, index):
        if el.tag == "freejoint":
            a = _Attrs(el, {})
            kind = "free"
        else:
            a = self.attrs(el, "joint", childclass)
            kind = a.choice("type", "hinge", JOINT_TYPES)
        name = el.attrib.get("name") or f"joint{index}"
        axis = np.array(a.numbers("axis", (0.0, 0.0, 1.0), n=3))
        n = np.linalg.norm(axis)
        if kind in ("hinge", "slide"):
            if n < 1e-12:
                raise a.error("axis", "a zero joint axis")
            axis = axis / n
        angular = kind in ("hinge", "ball")
        scale = self.angle if kind == "hinge" else (lambda x: x)
        limited = a.flag("limited", "auto")
        rng = None
        if a.has("range"):
            lo, hi = a.numbers("range", None, n=2)
            if angular:
                lo, hi = self.angle(lo), self.angle(hi)
            if limited == "true" or (limited == "auto" and self.compiler.autolimits):
                if lo > hi and kind != "ball":
                    raise a.error("range", "the lower limit is above the upper one")
                rng = (lo, hi)
        elif limited == "true":
            raise el.error("limited='true' without a range")
        values = {}
        for key in ("armature", "frictionloss"):
            values[key] = a.number(key, 0.0)
            if values[key] < 0:
                raise a.error(key, "must not be negative")
        for key in ("stiffness", "damping"):
            coefs = a.numbers(key, (0.0,), at_least=1, at_most=3) + (0.0, 0.0)
            if coefs[0] < 0:
                raise a.error(key, "must not be negative")
            values[key], values[f"{key}_terms"] = coefs[0], tuple(coefs[1:3])
            if kind in ("ball", "free") and any(coefs[1:3]):
                raise a.error(key, f"polynomial terms on a {kind} joint are not supported")
        if a.has("springdamper"):
            raise a.error("springdamper", "not supported (give stiffness and damping)")
        if a.has("actuatorfrcrange") and a.flag("actuatorfrclimited", "auto") != "false":
            raise a.error("actuatorfrcrange", "not supported (limits of the total "
                          "actuator force on a joint)")
        if kind in ("ball", "free") and values["stiffness"] != 0:
            raise a.error("stiffness", f"a spring on a {kind} joint is not supported")
        return Joint(name=name, type=kind,
                     pos=tuple(a.numbers("pos", (0.0, 0.0, 0.0), n=3)),
                     axis=tuple(axis), range=rng, ref=scale(a.number("ref", 0.0)),
                     springref=scale(a.number("springref", 0.0)), element=el, **values)

    def geom(self, el, childclass, index):
        a = self.attrs(el, "geom", childclass)
        kind = a.choice("type", "sphere", GEOM_TYPES)
        size = list(a.numbers("size", (), at_least=0, at_most=3))
        size += [0.0] * (3 - len(size))
        mesh = a.text("mesh")
        if kind == "mesh" and mesh is None:
            raise el.error("a mesh geom needs a mesh attribute")
        if kind != "mesh" and mesh is not None:
            raise a.error("mesh", f"a {kind} fitted to a mesh is not supported (give "
                          "type='mesh', or the size without a mesh)")
        pos, R = self.pose(a)
        if a.has("fromto"):
            if kind not in ("capsule", "cylinder", "box", "ellipsoid"):
                raise a.error("fromto", f"a {kind} geom cannot be given by fromto")
            both = [k for k in ("pos",) + ORIENTATIONS if k in el.attrib]
            if both:
                raise el.error(f"gives fromto and {both[0]}: give one")
            ends = np.array(a.numbers("fromto", None, n=6))
            d = ends[3:] - ends[:3]
            if np.linalg.norm(d) < 1e-12:
                raise a.error("fromto", "the two ends coincide")
            pos = (ends[3:] + ends[:3]) / 2
            R = zaxis_matrix(-d)  # MuJoCo's compiled frame: z from the second end to the first
            if kind in ("capsule", "cylinder"):
                size[1] = np.linalg.norm(d) / 2
            else:  # the sizes across are both the first size
                size[1], size[2] = size[0], np.linalg.norm(d) / 2
        needed = {"sphere": 1, "capsule": 2, "cylinder": 2, "ellipsoid": 3, "box": 3}
        if kind in needed and any(s <= 0 for s in size[:needed[kind]]):
            raise el.error(f"a {kind} needs {needed[kind]} positive size(s), got size "
                           f"{' '.join(f'{s:g}' for s in size[:needed[kind]])}")
        mass = a.number("mass", None) if a.has("mass") else None
        density = a.number("density", 1000.0)
        if mass is not None and mass < 0:
            raise a.error("mass", "a negative mass")
        rgba = a.numbers("rgba", None, n=4) if a.has("rgba") else None
        shell = a.text("shellinertia", "false")

        return Geom(name=el.attrib.get("name") or f"geom{index}", type=kind,
                    size=tuple(size), pos=pos, R=R, mass=mass, density=density,
                    group=int(a.number("group", 0)), shellinertia=shell == "true",
                    rgba=rgba, element=el, contype=int(a.number("contype", 1)),
                    conaffinity=int(a.number("conaffinity", 1)),
                    material=a.text("material"), mesh=mesh)

    def site(self, el, childclass, index, body):
        a = self.attrs(el, "site", childclass)
        pos, R = self.pose(a)
        size = list(a.numbers("size", (0.005,), at_least=0, at_most=3))
        if a.has("fromto"):
            ends = np.array(a.numbers("fromto", None, n=6))
            d = ends[3:] - ends[:3]
            if np.linalg.norm(d) < 1e-12:
                raise a.error("fromto", "the two ends coincide")
            pos, R = (ends[3:] + ends[:3]) / 2, zaxis_matrix(-d)
        return Site(name=el.attrib.get("name") or f"site{index}",
                    type=a.text("type", "sphere"), size=tuple(size), pos=pos, R=R,
                    body=body, element=el)

    def inertial(self, el):
        a = _Attrs(el, {})
        if not a.has("pos"):
            raise el.error("has no attribute 'pos'")
        if not a.has("mass"):
            raise el.error("has no attribute 'mass'")
        mass = a.number("mass", None)
        if mass < 0:
            raise a.error("mass", "a negative mass")
        pos, R = self.pose(a)
        if a.has("fullinertia") and a.has("diaginertia"):
            raise el.error("gives diaginertia and fullinertia: give one")
        axes = None
        if a.has("fullinertia"):
            xx, yy, zz, xy, xz, yz = a.numbers("fullinertia", None, n=6)
            J = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        elif a.has("diaginertia"):
            J = np.diag(a.numbers("diaginertia", None, n=3))
            axes = R
        else:
            raise el.error("has neither diaginertia nor fullinertia")
        return Inertial(mass=mass, pos=pos, inertia=R @ J @ R.T, element=el, axes=axes)


def _compose(pose, child):
    """Pose (pos, R) of ``child`` given in a frame at ``pose``."""
    (p0, R0), (p1, R1) = pose, child
    return p0 + R0 @ p1, R0 @ R1


class _Tree:
    """The body tree, read depth first in file order (MuJoCo's numbering)."""

    def __init__(self, reader):
        self.r = reader
        self.bodies, self.counts = [], {"joint": 0, "geom": 0, "site": 0}
        self.world_sites, self.world_geoms = [], []

    def world(self, el):
        world = Body("world", 0, -1, np.zeros(3), np.eye(3), [], [], [], None, 0.0, False,
                     el)
        self.bodies.append(world)
        if el is not None:
            if el.findall("joint") or el.findall("freejoint"):
                raise (el.findall("joint") + el.findall("freejoint"))[0].error(
                    "the world body cannot have joints")
            self.contents(el, world, None, (np.zeros(3), np.eye(3)))
        return world

    def contents(self, el, body, childclass, frame):
        """Geoms, sites, inertial and child bodies of ``el`` (a body or a frame)."""
        identity = frame[1] is None or (np.allclose(frame[0], 0) and
                                        np.allclose(frame[1], np.eye(3)))
        for child in el.children:
            tag = child.tag
            if tag in ("joint", "freejoint"):
                if el.tag == "frame":
                    raise child.error("a joint inside a <frame> is not supported")
                body.joints.append(self.r.joint(child, childclass, self.counts["joint"]))
                self.counts["joint"] += 1
            elif tag == "geom":
                g = self.r.geom(child, childclass, self.counts["geom"])
                self.counts["geom"] += 1
                if not identity:
                    pos, R = _compose(frame, (g.pos, g.R))
                    g = Geom(**{**g.__dict__, "pos": pos, "R": R})
                (self.world_geoms if body.index == 0 else body.geoms).append(g)
            elif tag == "site":
                s = self.r.site(child, childclass, self.counts["site"], body.name)
                self.counts["site"] += 1
                if not identity:
                    pos, R = _compose(frame, (s.pos, s.R))
                    s = Site(**{**s.__dict__, "pos": pos, "R": R})
                (self.world_sites if body.index == 0 else body.sites).append(s)
            elif tag == "inertial":
                if body.inertial is not None:
                    raise child.error("a body has one <inertial>")
                if el.tag == "frame":
                    raise child.error("an <inertial> inside a <frame> is not supported")
                body.inertial = self.r.inertial(child)
            elif tag == "body":
                self.body(child, body, childclass, frame)
            elif tag == "frame":
                a = self.r.attrs(child, "frame", childclass)
                inner = _compose(frame, self.r.pose(a))
                self.contents(child, body, child.attrib.get("childclass", childclass),
                              inner)
            elif tag in ("attach", "replicate", "composite", "flexcomp", "skin",
                         "plugin"):
                raise child.error(f"<{tag}> is not supported")
            # camera, light: nothing for the dynamics

    def body(self, el, parent, childclass, frame):
        childclass = el.attrib.get("childclass", childclass)
        if childclass is not None and childclass not in self.r.defaults:
            raise el.error(f"childclass '{childclass}' is not a default class of this "
                           "model")
        a = _Attrs(el, {})
        pos, R = _compose(frame, self.r.pose(a))
        index = len(self.bodies)
        name = el.attrib.get("name") or f"body{index}"
        body = Body(name, index, parent.index, pos, R, [], [], [], None,
                    a.number("gravcomp", 0.0), _bool(a, "mocap", "false"), el)
        self.bodies.append(body)
        parent.children.append(index)
        self.contents(el, body, childclass, (np.zeros(3), np.eye(3)))
        if body.mocap and body.joints:
            raise el.error("a mocap body cannot have joints")
        free = [j for j in body.joints if j.type == "free"]
        if free and (len(body.joints) > 1 or parent.index != 0):
            raise free[0].element.error("a free joint must be the only joint of a body "
                                        "whose parent is the world")


def _actuator(reader, el, index, joints, tendons):
    a = reader.attrs(el, "actuator", None)
    name = el.attrib.get("name") or f"actuator{index}"
    kind = el.tag
    for key in ("site", "body", "jointinparent", "cranksite", "slidersite"):
        if a.has(key):
            raise el.error(f"a transmission by '{key}' is not supported (joints and "
                           "tendons are)")
    if a.has("tendon"):
        joint = a.text("tendon")
        if joint not in tendons:
            raise a.error("tendon", "no tendon of that name")
    elif not a.has("joint"):
        raise el.error("has no joint or tendon (the transmissions supported)")
    else:
        joint = a.text("joint")
        if joint not in joints:
            raise a.error("joint", "no joint of that name")
        if joints[joint].type not in ("hinge", "slide"):
            raise a.error("joint", f"an actuator of a {joints[joint].type} joint is not "
                          "supported (hinge and slide joints)")
    gear = a.numbers("gear", (1.0,), at_least=1, at_most=6)[0]
    gain, bias = (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    if kind == "position":
        kp = a.number("kp", 1.0)
        kv = a.number("kv", 0.0)
        if a.has("dampratio"):
            raise a.error("dampratio", "not supported (give kv)")
        gain, bias = (kp, 0.0, 0.0), (0.0, -kp, -kv)
    elif kind == "velocity":
        kv = a.number("kv", 1.0)
        gain, bias = (kv, 0.0, 0.0), (0.0, 0.0, -kv)
    elif kind == "damper":
        kv = a.number("kv", 1.0)
        gain, bias = (0.0, 0.0, -kv), (0.0, 0.0, 0.0)
    elif kind == "intvelocity":
        kp, kv = a.number("kp", 1.0), a.number("kv", 0.0)
        if a.has("dampratio"):
            raise a.error("dampratio", "not supported (give kv)")
        gain, bias = (kp, 0.0, 0.0), (0.0, -kp, -kv)
    elif kind == "cylinder":
        area = a.number("area", 1.0)
        if a.has("diameter"):
            area = math.pi / 4 * a.number("diameter", None) ** 2
        gain, bias = (area, 0.0, 0.0), a.numbers("bias", (0.0, 0.0, 0.0), n=3)
    elif kind == "general":
        gaintype = a.choice("gaintype", "fixed", ("fixed", "affine", "muscle", "user"))
        biastype = a.choice("biastype", "none", ("none", "affine", "muscle", "user"))
        if gaintype not in ("fixed", "affine"):
            raise a.error("gaintype", f"'{gaintype}' is not supported")
        if biastype not in ("none", "affine"):
            raise a.error("biastype", f"'{biastype}' is not supported")
        gp = a.numbers("gainprm", (1.0,), at_least=1, at_most=10) + (0.0,) * 3
        bp = a.numbers("biasprm", (0.0,), at_least=1, at_most=10) + (0.0,) * 3
        gain = gp[:1] + ((gp[1], gp[2]) if gaintype == "affine" else (0.0, 0.0))
        bias = tuple(bp[:3]) if biastype == "affine" else (0.0, 0.0, 0.0)
    dyntype, tau = _activation(a, kind)
    ranges = {}
    for what in ("ctrl", "force", "act"):
        if what == "act" and dyntype == "none":
            continue
        limited = a.flag(f"{what}limited", "auto")
        key = f"{what}range"
        if a.has(key) and (limited == "true" or (limited == "auto"
                                                 and reader.compiler.autolimits)):
            lo, hi = a.numbers(key, None, n=2)
            if lo > hi:
                raise a.error(key, "the lower limit is above the upper one")
            ranges[what] = (lo, hi)
        elif limited == "true" and not a.has(key):
            raise el.error(f"{what}limited='true' without a {key}")
    return Actuator(name=name, type=kind, joint=joint, gear=gear, gain=tuple(gain),
                    bias=tuple(bias), ctrlrange=ranges.get("ctrl"),
                    forcerange=ranges.get("force"), element=el,
                    tendon=a.has("tendon"), dyntype=dyntype, tau=tau,
                    actrange=ranges.get("act"),
                    actearly=dyntype != "none" and _bool(a, "actearly", "false"))


def _activation(a, kind):
    """``(dyntype, time constant in s)`` of an actuator, as MuJoCo's shortcuts set
    them: position with a ``timeconst`` filters exactly, cylinder filters,
    intvelocity integrates."""
    if kind == "position":
        tau = a.number("timeconst", 0.0)
        return ("filterexact", tau) if tau > 0 else ("none", 0.0)
    if kind == "cylinder":
        dyntype, tau, key = "filter", a.number("timeconst", 1.0), "timeconst"
    elif kind == "intvelocity":
        return "integrator", 0.0
    elif kind == "general":
        dyntype = a.choice("dyntype", "none", DYNTYPES + ("muscle", "user"))
        if dyntype in ("muscle", "user"):
            raise a.error("dyntype", f"'{dyntype}' activation dynamics are not supported "
                          "(none, integrator, filter and filterexact are)")
        tau, key = a.numbers("dynprm", (1.0,), at_least=1, at_most=10)[0], "dynprm"
        if a.has("actdim") and a.number("actdim", -1) not in (-1, 0 if dyntype == "none"
                                                               else 1):
            raise a.error("actdim", "one activation per actuator is supported")
    else:
        return "none", 0.0
    if dyntype in ("filter", "filterexact") and tau <= 0:
        raise a.error(key, f"the time constant of a {dyntype} must be positive")
    return dyntype, tau


def _equality(reader, el, index, bodies, joints, tendons, sites):
    a = reader.attrs(el, "equality", None)
    if a.text("active", "true") == "false":
        return None
    name = el.attrib.get("name") or f"equality{index}"
    if el.tag in ("connect", "weld"):
        if a.has("site1") or a.has("site2"):
            found = {}
            for key in ("site1", "site2"):
                if not a.has(key):
                    raise el.error(f"gives {'site2' if key == 'site1' else 'site1'} "
                                   f"without {key}")
                found[key] = a.text(key)
                if found[key] not in sites:
                    raise a.error(key, "no site of that name")
            if el.tag == "weld" and a.has("torquescale") \
                    and a.number("torquescale", 1.0) != 1.0:
                raise a.error("torquescale", "not supported (a weld is rigid here)")
            return Equality(el.tag, name, sites[found["site1"]].body,
                            sites[found["site2"]].body, element=el, site1=found["site1"],
                            site2=found["site2"])
        if not a.has("body1"):
            raise el.error("has no body1")
        names = {}
        for key in ("body1", "body2"):
            names[key] = a.text(key, "world")
            if names[key] not in bodies:
                raise a.error(key, "no body of that name")
        if names["body1"] == names["body2"]:
            raise el.error("body1 and body2 are the same body")
        if el.tag == "connect" and not a.has("anchor"):
            raise el.error("has no anchor")
        anchor = a.numbers("anchor", (0.0, 0.0, 0.0), n=3)
        relpose = None
        if el.tag == "weld":
            if a.has("torquescale") and a.number("torquescale", 1.0) != 1.0:
                raise a.error("torquescale", "not supported (a weld is rigid here)")
            if a.has("relpose"):
                rp = a.numbers("relpose", None, n=7)
                if any(rp[3:]):  # MuJoCo: a zero quaternion means "as at qpos0"
                    relpose = (rp[:3], rp[3:])
        return Equality(el.tag, name, names["body1"], names["body2"], anchor, relpose,
                        element=el)
    if el.tag in ("joint", "tendon"):
        what, table = (("joint", joints) if el.tag == "joint" else ("tendon", tendons))
        if not a.has(f"{what}1"):
            raise el.error(f"has no {what}1")
        found = {}
        for key in (f"{what}1", f"{what}2"):
            if a.has(key):
                found[key] = a.text(key)
                if found[key] not in table:
                    raise a.error(key, f"no {what} of that name")
                if what == "joint" and joints[found[key]].type not in ("hinge", "slide"):
                    raise a.error(key, "an equality of hinge and slide joints only")
        coef = a.numbers("polycoef", (0.0, 1.0, 0.0, 0.0, 0.0), n=5)
        return Equality(el.tag, name, joint1=found[f"{what}1"],
                        joint2=found.get(f"{what}2", ""), polycoef=coef, element=el)
    raise el.error(f"<{el.tag}> equality constraints are not supported (connect, weld, "
                   "joint and tendon are)")


def _spatial_path(el, sites):
    """``[(site name, divisor) or (None, divisor)]`` of a spatial tendon: its
    sites in order, a pulley (None) starting a branch of its divisor."""
    path, divisor, branch = [], 1.0, 0
    for child in el.children:
        if child.tag == "geom":
            raise child.error("a spatial tendon wrapping around a geom is not supported "
                              "(spatial tendons through sites are)")
        if child.tag == "pulley":
            divisor = number(child, "divisor") if "divisor" in child.attrib else None
            if divisor is None or divisor <= 0:
                raise child.error("a pulley needs a positive divisor")
            if branch < 2:
                raise child.error("a pulley must follow a branch of at least two sites")
            path.append((None, divisor))
            branch = 0
            continue
        if child.tag != "site":
            raise child.error(f"<{child.tag}> in a spatial tendon: sites, pulleys and "
                              "geoms make its path")
        site = child.attrib.get("site")
        if site is None or site not in sites:
            raise (child.error(f"site='{site}': no site of that name") if site
                   else child.error("has no site"))
        path.append((site, divisor))
        branch += 1
    if branch < 2:
        raise el.error("a spatial tendon (and each branch after a pulley) needs at "
                       "least two sites")
    return tuple(path)


def _tendons(reader, root, joints, sites):
    """The fixed tendons, and the spatial ones through sites."""
    out, names = [], {}
    for section in root.findall("tendon"):
        for el in section.children:
            if el.tag not in ("fixed", "spatial"):
                raise el.error(f"unknown tendon <{el.tag}>")
            a = reader.attrs(el, "tendon", None)
            name = el.attrib.get("name") or f"tendon{len(out)}"
            if name in names:
                raise el.error(f"a second tendon named '{name}'")
            members = []
            path = _spatial_path(el, sites) if el.tag == "spatial" else ()
            for j in el.children if el.tag == "fixed" else ():
                if j.tag != "joint":
                    raise j.error("a fixed tendon holds <joint> elements only")
                ja = _Attrs(j, {})
                if not ja.has("joint") or ja.text("joint") not in joints:
                    raise (ja.error("joint", "no joint of that name") if ja.has("joint")
                           else j.error("has no joint"))
                if joints[ja.text("joint")].type not in ("hinge", "slide"):
                    raise ja.error("joint", "a fixed tendon of hinge and slide joints only")
                members.append((ja.text("joint"), ja.number("coef", None)
                                if ja.has("coef") else j.error("has no coef")))
                if isinstance(members[-1][1], MJCFError):
                    raise members[-1][1]
            if not members and not path:
                raise el.error("a fixed tendon without joints")
            coefs = {}
            for key in ("stiffness", "damping"):
                coefs[key] = a.numbers(key, (0.0,), at_least=1, at_most=3) + (0.0, 0.0)
                if coefs[key][0] < 0:
                    raise a.error(key, "must not be negative")
            spring = a.numbers("springlength", (-1.0,), at_least=1, at_most=2)
            springlength = None if spring == (-1.0,) or spring == (-1.0, -1.0) else (
                (spring[0], spring[0]) if len(spring) == 1 else spring)
            if springlength is not None and springlength[0] > springlength[1]:
                raise a.error("springlength", "the two values decrease")
            limited = a.flag("limited", "auto")
            rng = None
            if a.has("range") and (limited == "true" or (limited == "auto"
                                                          and reader.compiler.autolimits)):
                rng = a.numbers("range", None, n=2)
            for key in ("actuatorfrcrange", "springyield"):
                if a.has(key) and any(a.numbers(key, None, at_least=1, at_most=2)):
                    raise a.error(key, "not supported")
            tendon = Tendon(name, tuple(members), coefs["stiffness"][:3],
                            coefs["damping"][:3], springlength, a.number("armature", 0.0),
                            rng, a.number("frictionloss", 0.0), el, path)
            names[name] = tendon
            out.append(tendon)
    return out


def _meshes(reader, root):
    """The ``<mesh>`` assets (read as records; their files are read when used)."""
    out = {}
    for asset in root.findall("asset"):
        for el in asset.findall("mesh"):
            a = reader.attrs(el, "mesh", None)
            file = a.text("file")
            name = el.attrib.get("name") or (Path(file).stem if file else None)
            if name is None:
                raise el.error("a mesh without a file needs a name")
            if name in out:
                raise el.error(f"a second mesh named '{name}' (the first is on line "
                               f"{out[name].element.line})")
            for key in ("builtin", "plugin", "content_type"):
                if a.has(key):
                    raise a.error(key, "not supported (meshes from files, or vertex and "
                                  "face, are)")
            refquat = a.numbers("refquat", (1.0, 0.0, 0.0, 0.0), n=4)
            if np.linalg.norm(refquat) < 1e-12:
                raise a.error("refquat", "a zero quaternion")
            vertex = a.numbers("vertex", None, at_least=0) if a.has("vertex") else None
            face = a.numbers("face", None, at_least=0) if a.has("face") else None
            out[name] = Mesh(name=name, file=file, vertex=vertex, face=face,
                             scale=a.numbers("scale", (1.0, 1.0, 1.0), n=3),
                             refpos=a.numbers("refpos", (0.0, 0.0, 0.0), n=3),
                             refrot=quat_matrix(refquat),
                             inertia=a.choice("inertia", "legacy", MESH_INERTIA_MODES),
                             maxhullvert=int(a.number("maxhullvert", -1)), element=el)
    return out


def parse_mjcf(path):
    """The :class:`Model` of the MJCF file ``path``."""
    root = read_mjcf(path)
    reader = _Reader(root, str(path))
    option = reader.option()
    tree = _Tree(reader)
    worlds = root.findall("worldbody")
    tree.world(worlds[0] if worlds else None)
    world = tree.bodies[0]
    for extra in worlds[1:]:  # MuJoCo merges several <worldbody> sections
        tree.contents(extra, world, None, (np.zeros(3), np.eye(3)))
    bodies = tree.bodies
    seen = {}
    for b in bodies:
        if b.name in seen:
            raise b.element.error(f"a second body named '{b.name}' (the first is on line "
                                  f"{seen[b.name].element.line})")
        seen[b.name] = b
    joints = {}
    for b in bodies:
        for j in b.joints:
            if j.name in joints:
                raise j.element.error(f"a second joint named '{j.name}' (the first is on "
                                      f"line {joints[j.name].element.line})")
            joints[j.name] = j
    sites = {site.name: site for b in bodies for site in b.sites}
    sites.update({site.name: site for site in tree.world_sites})
    tendons = {t.name: t for t in _tendons(reader, root, joints, sites)}
    actuators, equalities = [], []
    for section in root.findall("actuator"):
        for el in section.children:
            if el.tag in _OTHER_ACTUATORS:
                raise el.error(f"<{el.tag}> actuators are not supported (motor, position, "
                               "velocity, damper, intvelocity, cylinder and general "
                               "without muscle dynamics are)")
            if el.tag not in ACTUATOR_TYPES:
                raise el.error(f"unknown actuator <{el.tag}>")
            actuators.append(_actuator(reader, el, len(actuators), joints, tendons))
    names = {}
    for act in actuators:
        if act.name in names:
            raise act.element.error(f"a second actuator named '{act.name}'")
        names[act.name] = act
    for section in root.findall("equality"):
        for el in section.children:
            eq = _equality(reader, el, len(equalities), seen, joints, tendons, sites)
            if eq is not None:
                equalities.append(eq)
    meshes = _meshes(reader, root)
    for geom in [g for b in bodies for g in b.geoms] + tree.world_geoms:
        if geom.mesh is not None and geom.mesh not in meshes:
            raise geom.element.error(f"mesh='{geom.mesh}': no mesh asset of that name")
    materials = {}
    for asset in root.findall("asset"):
        for mat in asset.findall("material"):
            if mat.attrib.get("name") and "rgba" in mat.attrib:
                materials[mat.attrib["name"]] = numbers(mat, "rgba", n=4)
    return Model(name=root.attrib.get("model", "MuJoCo Model"), source=str(path),
                 compiler=reader.compiler, option=option, bodies=bodies,
                 actuators=actuators, equalities=equalities,
                 world_sites=tree.world_sites, world_geoms=tree.world_geoms,
                 materials=materials, tendons=list(tendons.values()), meshes=meshes)
