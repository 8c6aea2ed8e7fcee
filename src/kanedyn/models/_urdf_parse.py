"""Reading a URDF file into plain records, with the line of every element.

The XML is read by the standard library's expat parser, which expands no
external entities; every number is checked to be a plain decimal in ASCII
digits, read by :func:`float` and checked to be finite, never evaluated.
Errors name the file, the element and its line.

A link's central inertia must be positive semi-definite; one that misses by
round-off, up to :data:`INERTIA_RTOL` of the largest principal moment among the
robot's links, is accepted and listed in :attr:`Robot.inertia_notes`.  (The
triangle inequality is checked on the bodies, links merged by fixed joints,
by :func:`~kanedyn.models.from_urdf`.)
"""

from __future__ import annotations

import math
import re
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._errors import ModelError
from ..modeling import inertia_violation, principal_moments
from ._urdf_meshes import resolve_mesh, shown_name

__all__ = ["URDFError", "Element", "read_xml", "parse_xml", "Robot", "Link", "Joint", "Inertial",
           "Visual", "parse_robot", "rpy_matrix", "pose_matrix", "SUPPORTED_JOINTS",
           "INERTIA_RTOL", "check_inertias", "inertia_text", "round_off_text"]

#: joint types that become coordinates (``fixed`` merges the child into the parent)
SUPPORTED_JOINTS = ("revolute", "continuous", "prismatic", "fixed")
_UNSUPPORTED_JOINTS = ("floating", "planar", "spherical")
#: an inertia that is not a solid's (a negative principal moment, or I1 + I2 < I3) by
#: at most this fraction of the largest principal moment among the robot's links is
#: taken as round-off in the file: accepted, with a warning
INERTIA_RTOL = 1e-6
#: the white space of XML (what separates numbers in a list); Unicode's other spaces
#: are not separators, as its other digits are not digits here
_XML_SPACE = " \t\r\n"
_PLAIN_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\Z", re.ASCII)


class URDFError(ModelError):
    """A URDF file that cannot be read; the message names file, element and line."""


@dataclass
class Element:
    """One XML element: tag, attributes, children and the line it starts on."""

    tag: str
    attrib: dict
    line: int
    children: list = field(default_factory=list)

    def find(self, tag):
        """The first child with ``tag``, or None."""
        return next((c for c in self.children if c.tag == tag), None)

    def findall(self, tag):
        """All children with ``tag``."""
        return [c for c in self.children if c.tag == tag]

    def label(self):
        """``<joint name='elbow'>`` (the name attribute, when there is one)."""
        name = self.attrib.get("name")
        return f"<{self.tag} name='{name}'>" if name is not None else f"<{self.tag}>"


def read_xml(path):
    """The root :class:`Element` of the XML file ``path``.

    Raises
    ------
    URDFError
        When the file cannot be read or is not well-formed XML (with its line).
    """
    path = Path(path)
    return parse_xml(path, path, "a URDF", URDFError, Element)


def parse_xml(path, shown, kind, error, element):
    """The root element of the XML file ``path``, each made by ``element(tag, attrib,
    line)``; entity declarations refused (expansion bombs, external files).

    ``shown``: the file as messages name it; ``kind``: ``"a URDF"``, ``"an MJCF"``;
    ``error``: the exception class raised, with file and line, when the file cannot
    be read or is not well-formed XML.
    """
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise error(f"{shown}: cannot read the {kind.split()[-1]} file: "
                    f"{exc.strerror or exc}") from None
    parser = xml.parsers.expat.ParserCreate()
    stack, roots = [], []

    def start(tag, attrib):
        made = element(tag, dict(attrib), parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(made)
        stack.append(made)

    def end(tag):
        stack.pop()

    def no_entities(*args):
        raise error(f"{shown}:{parser.CurrentLineNumber}: entity declarations are not "
                    f"accepted in {kind} file")

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.EntityDeclHandler = no_entities
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        raise error(f"{shown}:{exc.lineno}: not a well-formed XML file "
                    f"({xml.parsers.expat.ErrorString(exc.code)})") from None
    return roots[0]


def rpy_matrix(rpy):
    """Rotation matrix of URDF roll-pitch-yaw angles (fixed axes x, y, z), shape (3, 3)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = (math.cos(r), math.sin(r), math.cos(p), math.sin(p),
                              math.cos(y), math.sin(y))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def pose_matrix(xyz, rpy):
    """Homogeneous transform (4, 4) of a URDF ``<origin xyz rpy>``."""
    T = np.eye(4)
    T[:3, :3] = rpy_matrix(rpy)
    T[:3, 3] = xyz
    return T


@dataclass(frozen=True)
class Inertial:
    """A link's ``<inertial>``: mass (kg), mass-centre pose in the link frame, inertia.

    ``inertia`` (3, 3) is about the mass centre, in the frame of ``<inertial><origin>``
    (kg m^2); ``line`` is the line of its ``<inertia>`` element.
    """

    mass: float
    xyz: tuple
    rpy: tuple
    inertia: np.ndarray
    line: int = 0


@dataclass(frozen=True)
class Visual:
    """One ``<visual>`` (or ``<collision>``) of a link, kept as data for viewers.

    Attributes
    ----------
    link : str
        The URDF link it belongs to.
    body : str
        The kanedyn body that carries it (the link itself, or the link that a
        chain of fixed joints merges it into).  Set by :func:`from_urdf`.
    shape : str
        ``"box"``, ``"cylinder"``, ``"sphere"`` or ``"mesh"``.
    size : tuple
        Box: edge lengths (x, y, z), m.  Cylinder: (radius, length), m, axis
        along z.  Sphere: (radius,), m.  Mesh: the scale factors (x, y, z).
    filename : str or None
        Mesh file as written in the URDF (``package://...``, ``file://...``
        or a path relative to the URDF file); the path of a URI is
        percent-decoded when it is looked up.
    path : str or None
        The mesh file found on disk (symbolic links resolved), or None when it was
        not found or is refused (see :meth:`mesh_file`).
    refused : str
        Why the mesh is not read although its name was understood: the file lies
        outside the folders meshes are read from (see
        :func:`~kanedyn.models.from_urdf`), the file system refuses to look the
        name up (too long, a loop of symbolic links, a folder that may not be
        searched), or a ``file:`` URI names another host; "" otherwise.
    xyz, rpy : tuple
        ``<origin>`` of the visual in its link frame, m and rad.
    transform : tuple
        Pose (4x4, row-major nested tuples) of the geometry in the frame of
        ``body``'s link (origin at that link's joint, not at the mass centre).
    rgba : tuple or None
        Colour of its ``<material>``, when given.
    line : int
        Line of the ``<visual>`` (or ``<collision>``) element in ``source``.
    source : str
        The URDF file.
    """

    link: str
    shape: str
    size: tuple
    xyz: tuple
    rpy: tuple
    line: int
    source: str
    filename: str | None = None
    path: str | None = None
    rgba: tuple | None = None
    body: str = ""
    transform: tuple = ()
    refused: str = ""

    def mesh_file(self):
        """The mesh file on disk; raises :class:`URDFError` if it was not found."""
        if self.shape != "mesh":
            raise URDFError(f"{self.source}:{self.line}: the visual of link "
                            f"'{self.link}' is a {self.shape}, not a mesh")
        where = f"{self.source}:{self.line}: mesh '{shown_name(self.filename)}' of link"
        if self.refused:
            raise URDFError(f"{where} '{self.link}' is not read: {self.refused}")
        if self.path is None:
            raise URDFError(f"{where} '{self.link}' not found (give package_dirs=[folder "
                            "that holds the package] to from_urdf)")
        return self.path


@dataclass(frozen=True)
class Link:
    """A ``<link>``: name, inertial (None when massless), visuals, line, collisions."""

    name: str
    inertial: Inertial | None
    visuals: tuple
    line: int
    collisions: tuple = ()


@dataclass(frozen=True)
class Joint:
    """A ``<joint>`` with its origin, unit axis, limits and dynamics (as data).

    ``lower``/``upper`` are m or rad; ``velocity`` m/s or rad/s; ``effort`` N or
    N m; None where the URDF gives none.  ``damping`` and ``friction`` come from
    ``<dynamics>``; ``mimic`` is ``(joint, multiplier, offset)`` or None.  None
    of these is applied to the dynamics.
    """

    name: str
    type: str
    parent: str
    child: str
    xyz: tuple
    rpy: tuple
    axis: tuple
    line: int
    lower: float | None = None
    upper: float | None = None
    velocity: float | None = None
    effort: float | None = None
    damping: float | None = None
    friction: float | None = None
    mimic: tuple | None = None


@dataclass(frozen=True)
class Robot:
    """A parsed URDF: name, links and joints by name, root link, source file.

    ``inertia_notes`` lists the links whose inertia was accepted as round-off (one
    line each, naming file, line and link), ``inertia_tolerance`` (kg m^2) is how
    far from a solid's an inertia may be to count as round-off
    (:data:`INERTIA_RTOL` of the largest principal moment of the links).
    """

    name: str
    links: dict
    joints: dict
    root: str
    source: str
    inertia_notes: tuple = ()
    inertia_tolerance: float = 0.0

    def children(self, link):
        """Joints whose parent is ``link``, in file order."""
        return [j for j in self.joints.values() if j.parent == link]


class _Reader:
    """Reads elements of one file, naming file, element and line in errors."""

    def __init__(self, source, package_dirs, mesh_dirs):
        self.source = str(source)
        self.package_dirs = [Path(d) for d in (package_dirs or [])]
        self.mesh_dirs = [Path(d) for d in (mesh_dirs or [])]

    def one(self, parent, tag, owner):
        """The ``<tag>`` child of ``parent``, or None; a second one is refused (which
        of them counts would be a guess)."""
        found = parent.findall(tag)
        if len(found) > 1:
            raise self.error(owner, f"<{parent.tag}> has {len(found)} <{tag}> elements; "
                             "give one", found[1].line)
        return found[0] if found else None

    def error(self, element, message, line=None):
        return URDFError(f"{self.source}:{line or element.line}: {element.label()}: "
                         f"{message}")

    def number(self, element, owner, key, default=None, text=None):
        raw = element.attrib.get(key) if text is None else text
        if raw is None:
            if default is None:
                raise self.error(owner, f"<{element.tag}> has no attribute '{key}'",
                                 element.line)
            return default
        raw = raw.strip(_XML_SPACE)
        if not _PLAIN_NUMBER.match(raw):
            where = f"<{element.tag} {key}='{element.attrib.get(key, raw)}'>"
            what = f"'{raw}' is not a number" if text is not None else "is not a number"
            raise self.error(owner, f"{where}: {what}", element.line)
        value = float(raw)
        if not math.isfinite(value):
            where = f"<{element.tag} {key}='{element.attrib.get(key, raw)}'>"
            raise self.error(owner, f"{where}: '{raw}' is beyond the range of floating "
                             "point", element.line)
        return value

    def vector(self, element, owner, key, n, default):
        raw = element.attrib.get(key) if element is not None else None
        if raw is None:
            return tuple(default)
        text = raw.strip(_XML_SPACE)
        parts = re.split(f"[{_XML_SPACE}]+", text) if text else []
        if len(parts) != n:
            raise self.error(owner, f"<{element.tag} {key}='{raw}'> needs {n} numbers, "
                             f"found {len(parts)}", element.line)
        return tuple(self.number(element, owner, key, text=p) for p in parts)

    def origin(self, parent_element, owner):
        origin = self.one(parent_element, "origin", owner)
        return (self.vector(origin, owner, "xyz", 3, (0.0, 0.0, 0.0)),
                self.vector(origin, owner, "rpy", 3, (0.0, 0.0, 0.0)))

    def name(self, element):
        name = element.attrib.get("name")
        if not name:
            raise URDFError(f"{self.source}:{element.line}: <{element.tag}> has no name")
        return name

    # -- links ------------------------------------------------------------------
    def inertial(self, link_el):
        el = self.one(link_el, "inertial", link_el)
        if el is None:
            return None
        mass_el = self.one(el, "mass", link_el)
        if mass_el is None:
            raise self.error(link_el, "<inertial> has no <mass>", el.line)
        mass = self.number(mass_el, link_el, "value")
        if mass < 0:
            raise self.error(link_el, f"negative mass {mass}", mass_el.line)
        in_el = self.one(el, "inertia", link_el)
        if in_el is None:
            raise self.error(link_el, "<inertial> has no <inertia>", el.line)
        c = {k: self.number(in_el, link_el, k)
             for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        inertia = np.array([[c["ixx"], c["ixy"], c["ixz"]],
                            [c["ixy"], c["iyy"], c["iyz"]],
                            [c["ixz"], c["iyz"], c["izz"]]])
        xyz, rpy = self.origin(el, link_el)
        return Inertial(mass, xyz, rpy, inertia, in_el.line)

    def geometry(self, link_el, vis_el):
        geo = self.one(vis_el, "geometry", link_el)
        if geo is None or not geo.children:
            raise self.error(link_el, f"<{vis_el.tag}> has no <geometry>", vis_el.line)
        shape = geo.children[0]
        if shape.tag == "box":
            if "size" not in shape.attrib:
                self._missing(link_el, shape, "size")
            return "box", self.vector(shape, link_el, "size", 3, None), None
        if shape.tag == "cylinder":
            return "cylinder", (self.number(shape, link_el, "radius"),
                                self.number(shape, link_el, "length")), None
        if shape.tag == "sphere":
            return "sphere", (self.number(shape, link_el, "radius"),), None
        if shape.tag == "mesh":
            filename = shape.attrib.get("filename")
            if not filename:
                self._missing(link_el, shape, "filename")
            return "mesh", self.vector(shape, link_el, "scale", 3, (1.0, 1.0, 1.0)), filename
        raise self.error(link_el, f"unknown geometry <{shape.tag}> (box, cylinder, sphere "
                         "and mesh are known)", shape.line)

    def _missing(self, owner, element, key):
        raise self.error(owner, f"<{element.tag}> has no attribute '{key}'", element.line)

    def visuals(self, link_el, name, materials, tag="visual"):
        """The ``<visual>`` (or ``<collision>``, by ``tag``) elements of a link."""
        out = []
        for vis_el in link_el.findall(tag):
            shape, size, filename = self.geometry(link_el, vis_el)
            xyz, rpy = self.origin(vis_el, link_el)
            material = self.one(vis_el, "material", link_el)
            path, refused = (resolve_mesh(filename, self.source, self.package_dirs,
                                          self.mesh_dirs) if filename else (None, ""))
            out.append(Visual(link=name, shape=shape, size=size, xyz=xyz, rpy=rpy,
                              line=vis_el.line, source=self.source, filename=filename,
                              path=path, refused=refused,
                              rgba=self.rgba(material, link_el, materials)))
        return tuple(out)

    def rgba(self, mat_el, owner, materials):
        if mat_el is None:
            return None
        colour = self.one(mat_el, "color", owner)
        if colour is not None and "rgba" in colour.attrib:
            return self.vector(colour, owner, "rgba", 4, None)
        return materials.get(mat_el.attrib.get("name"))

    # -- joints -----------------------------------------------------------------
    def joint(self, el):
        name = self.name(el)
        kind = el.attrib.get("type")
        if kind is None:
            raise self.error(el, "has no type")
        if kind in _UNSUPPORTED_JOINTS:
            raise self.error(el, f"joint type '{kind}' is not supported (supported: "
                             f"{', '.join(SUPPORTED_JOINTS)})")
        if kind not in SUPPORTED_JOINTS:
            raise self.error(el, f"unknown joint type '{kind}' (supported: "
                             f"{', '.join(SUPPORTED_JOINTS)})")
        links = {}
        for tag in ("parent", "child"):
            sub = self.one(el, tag, el)
            if sub is None or not sub.attrib.get("link"):
                raise self.error(el, f"has no <{tag} link=...>")
            links[tag] = sub.attrib["link"]
        xyz, rpy = self.origin(el, el)
        axis_el = self.one(el, "axis", el)
        axis = self.vector(axis_el, el, "xyz", 3, (1.0, 0.0, 0.0))
        norm = math.sqrt(sum(a * a for a in axis))
        if kind != "fixed":
            if norm < 1e-12:
                raise self.error(el, "joint axis is zero", axis_el.line)
            axis = tuple(a / norm for a in axis)
        extra = {}
        limit = self.one(el, "limit", el)
        if limit is not None:
            for key in ("lower", "upper", "velocity", "effort"):
                if key in limit.attrib:
                    extra[key] = self.number(limit, el, key)
        dyn = self.one(el, "dynamics", el)
        if dyn is not None:
            for key in ("damping", "friction"):
                if key in dyn.attrib:
                    extra[key] = self.number(dyn, el, key)
        mimic = self.one(el, "mimic", el)
        if mimic is not None:
            extra["mimic"] = (mimic.attrib.get("joint"),
                              self.number(mimic, el, "multiplier", default=1.0),
                              self.number(mimic, el, "offset", default=0.0))
        return Joint(name=name, type=kind, parent=links["parent"], child=links["child"],
                     xyz=xyz, rpy=rpy, axis=axis, line=el.line, **extra)


def inertia_text(amount, rule, moments):
    """``is not positive semi-definite by 3.5e-08 kg m^2 (principal moments ...)``."""
    what = ("is not positive semi-definite" if rule == "not positive semidefinite"
            else "violates the triangle inequality I1 + I2 >= I3")
    return (f"{what} by {amount:.3g} kg m^2 (principal moments "
            + ", ".join(f"{m:.6g}" for m in moments) + " kg m^2)")


def round_off_text(tolerance):
    """``3.5e-07 kg m^2 (1e-06 of the largest principal moment of the robot's links)``."""
    return (f"{tolerance:.3g} kg m^2 ({INERTIA_RTOL:g} of the largest principal moment "
            "of the robot's links)")


def check_inertias(links, source):
    """Check the links' central inertias against :data:`INERTIA_RTOL`.

    Returns
    -------
    notes : tuple of str
        One line per link whose inertia is not positive semi-definite by round-off
        only (accepted), naming file, line and link.
    tolerance : float
        kg m^2: :data:`INERTIA_RTOL` times the largest principal moment of the links.

    Raises
    ------
    URDFError
        An inertia whose principal moments overflow, or that is not positive
        semi-definite by more than ``tolerance``.
    """
    moments = {}
    for link in links.values():
        if link.inertial is not None:
            found = moments[link.name] = principal_moments(link.inertial.inertia)
            if not np.all(np.isfinite(found)):
                raise URDFError(f"{source}:{link.inertial.line}: <link name='{link.name}'>: "
                                "inertia beyond the range of floating point (principal "
                                "moments " + ", ".join(f"{m:.6g}" for m in found) + " kg m^2)")
    scale = max((float(np.max(np.abs(m))) for m in moments.values()), default=0.0)
    tolerance = INERTIA_RTOL * scale
    notes = []
    for name, found in moments.items():
        amount, rule = inertia_violation(found)
        if rule != "not positive semidefinite":  # the triangle: checked on the bodies
            continue
        where = (f"{source}:{links[name].inertial.line}: <link name='{name}'>: inertia "
                 + inertia_text(amount, rule, found))
        if amount > tolerance:
            raise URDFError(f"{where}: more than round-off, which is up to "
                            + round_off_text(tolerance))
        notes.append(where)
    return tuple(notes), tolerance


def parse_robot(path, package_dirs=None, mesh_dirs=None):
    """The :class:`Robot` of the URDF file ``path`` (checked: tree, numbers, inertias);
    mesh files are looked for as :func:`~kanedyn.models.from_urdf` says."""
    root = read_xml(path)
    reader = _Reader(path, package_dirs, mesh_dirs)
    if root.tag != "robot":
        raise URDFError(f"{path}:{root.line}: the root element is <{root.tag}>, "
                        "not <robot>: not a URDF file")
    materials = {}
    for mat in root.findall("material"):
        colour = reader.one(mat, "color", mat)
        if colour is not None and "rgba" in colour.attrib and mat.attrib.get("name"):
            materials[mat.attrib["name"]] = reader.vector(colour, mat, "rgba", 4, None)
    links = {}
    for el in root.findall("link"):
        name = reader.name(el)
        if name in links:
            raise reader.error(el, f"a second link named '{name}' (the first is on "
                               f"line {links[name].line})")
        links[name] = Link(name, reader.inertial(el), reader.visuals(el, name, materials),
                           el.line, reader.visuals(el, name, materials, "collision"))
    if not links:
        raise URDFError(f"{path}:{root.line}: <robot> has no <link>")
    inertia_notes, inertia_tolerance = check_inertias(links, str(path))
    joints, parent_of = {}, {}
    for el in root.findall("joint"):
        joint = reader.joint(el)
        if joint.name in joints:
            raise reader.error(el, f"a second joint named '{joint.name}' (the first is on "
                               f"line {joints[joint.name].line})")
        for role in ("parent", "child"):
            if getattr(joint, role) not in links:
                raise reader.error(el, f"its {role} link '{getattr(joint, role)}' does "
                                   "not exist")
        if joint.child in parent_of:
            raise reader.error(el, f"link '{joint.child}' already has a parent joint "
                               f"'{parent_of[joint.child].name}' (line "
                               f"{parent_of[joint.child].line}): a link has one parent")
        joints[joint.name] = joint
        parent_of[joint.child] = joint
    roots = [n for n in links if n not in parent_of]
    if len(roots) != 1:
        if not roots:
            raise URDFError(f"{path}: the joints form a cycle: every link has a parent")
        raise URDFError(f"{path}: {len(roots)} root links ("
                        + ", ".join(f"'{n}' line {links[n].line}" for n in roots)
                        + "); a URDF tree has one root")
    robot = Robot(root.attrib.get("name", Path(path).stem), links, joints, roots[0],
                  str(path), inertia_notes, inertia_tolerance)
    seen, stack = {roots[0]}, [roots[0]]
    while stack:
        for j in robot.children(stack.pop()):
            seen.add(j.child)
            stack.append(j.child)
    if len(seen) != len(links):  # links off the tree hang in a cycle
        cyc = next(n for n in links if n not in seen)
        raise reader.error(
            Element("joint", {"name": parent_of[cyc].name}, parent_of[cyc].line),
            f"joints form a cycle through link '{cyc}'")
    return robot
