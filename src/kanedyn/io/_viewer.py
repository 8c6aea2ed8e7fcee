r"""The scene of a 3D animation: what is drawn, and where it is at each frame.

:func:`scene_data` turns a :class:`~kanedyn.SimulationResult` into plain data
(lists of numbers, JSON-ready) that the page of :mod:`kanedyn.io._page` draws:

* every body as a group placed at each frame by its reference point (a rigid
  body's or particle's mass centre, a flexible body's origin) and, for rigid
  and flexible bodies, its frame's orientation as a unit quaternion
  :math:`(x, y, z, w)` of the rotation matrix :math:`{}^N C^B` (body
  components to inertial components);
* the shapes declared for a body (:mod:`kanedyn.visuals`) or, when none is,
  the default: for a rigid body the ellipsoid of equal central inertia,
  semi-axes :math:`a_i^2 = \tfrac{5}{2m}(I_j + I_k - I_i)` along the principal
  axes (each at least 5 % of the largest), for a particle or a massless body
  a sphere of 3 % of the scene's size;
* the "skeleton": segments of constant length joining the points that
  locate each body, from the point fixed in the inertial frame that the
  model's positions start at (a pendulum's rod, a chain's links; not the
  translation of a cart or of a free body);
* flexible members deformed: their node positions at every frame
  (:func:`kanedyn.analysis.deformed_nodes` placed by the body's pose);
* contact surfaces: planes as a finite patch around the motion, spheres and
  ellipsoids whole; implicit surfaces are listed as not drawn;
* the paths of chosen points (``trace``);
* shapes fixed in the inertial frame (a robot's fixed base), placed once;
* the height of the ground grid (``floor``): the lowest height along "up"
  that anything drawn reaches over all the frames (:mod:`._floor`).

Positions and orientations are evaluated from the model's own kinematics
(named intermediates of its program, :class:`kanedyn.engine.Kinematics`),
in one vectorized function generated once per model and kept on it.
"""

from __future__ import annotations

import numbers

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError, OptionError
from ..analysis import deformed_nodes
from ..engine import name_of
from ..modeling import (SURFACE_COORDINATES, Ellipsoid, FlexibleBody, InertialElement,
                        Plane, Sphere, body_parameters)
from ..modeling.visuals import Mesh, Shape
from ..numerics import compile_python, generate_python
from ._floor import lowest_height
from ._meshes import read_mesh
from ._up import up_direction

__all__ = ["scene_data", "quaternions", "PALETTE", "FIXED_COLOR", "DEFAULT_MAX_FRAMES"]

#: colours of bodies, in order (then repeated)
PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#bcbd22", "#7f7f7f")
#: colour of shapes fixed in the inertial frame that declare none
FIXED_COLOR = "#9aa3ad"
DEFAULT_MAX_FRAMES = 2000
_PARTICLE_SIZE = 0.03  # particle sphere radius, fraction of the scene size


# ------------------------------------------------------------------ numbers
def quaternions(C):
    """Unit quaternions ``(x, y, z, w)`` of rotation matrices, shape (..., 4).

    Parameters
    ----------
    C : ndarray, shape (..., 3, 3)
        Rotation matrices (columns: the rotated axes).
    """
    C = np.asarray(C, dtype=float)
    m00, m11, m22 = C[..., 0, 0], C[..., 1, 1], C[..., 2, 2]
    # Shepperd's method: the largest of the four squared components first
    s = np.stack([1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22,
                  1 + m00 + m11 + m22], axis=-1)
    k = np.argmax(s, axis=-1)
    q = np.empty(C.shape[:-2] + (4,))
    d = {(0, 1): C[..., 0, 1] + C[..., 1, 0], (0, 2): C[..., 0, 2] + C[..., 2, 0],
         (1, 2): C[..., 1, 2] + C[..., 2, 1], (0, 3): C[..., 2, 1] - C[..., 1, 2],
         (1, 3): C[..., 0, 2] - C[..., 2, 0], (2, 3): C[..., 1, 0] - C[..., 0, 1]}
    for i in range(4):
        sel = k == i
        root = np.sqrt(np.maximum(s[..., i], 1e-300))
        for j in range(4):
            if j == i:
                value = 0.5 * root
            else:
                value = d[(min(i, j), max(i, j))] * 0.5 / root
            q[..., j] = np.where(sel, value, q[..., j] if i else 0.0)
    q *= np.where(q[..., 3:4] < 0, -1.0, 1.0)  # w >= 0 (either sign is the same rotation)
    # continuity along the frames: no sign flips between neighbours
    if q.ndim == 2 and len(q) > 1:
        flips = np.cumsum(np.einsum("ij,ij->i", q[1:], q[:-1]) < 0) % 2
        q[1:] *= np.where(flips[:, None] == 1, -1.0, 1.0)
    return q


def _rounded(a, digits=6):
    return np.round(np.asarray(a, dtype=float), digits).ravel().tolist()


# --------------------------------------------------------------- kinematics
def _is_fixed(point, N):
    v = point._vel_dict.get(N)
    return v is not None and v == 0


def _component(point):
    """Points connected to ``point`` by given positions, nearest first."""
    seen, order = {point}, [point]
    i = 0
    while i < len(order):
        for other in order[i]._pos_dict:
            if other not in seen:
                seen.add(other)
                order.append(other)
        i += 1
    return order


class _Anchors:
    """Which point fixed in the inertial frame each point is measured from."""

    def __init__(self, N):
        self.N = N
        self.origin = None
        self.notes = []
        self._of = {}

    def anchor(self, point, what, required=True):
        if point in self._of:
            return self._of[point]
        fixed = [p for p in _component(point) if _is_fixed(p, self.N)]
        if not fixed:
            if required:
                raise ModelError(
                    f"cannot place {what}: no position connects point {point.name} to a "
                    f"point fixed in the inertial frame {self.N} (set_pos/locatenew from "
                    "a point with set_vel(N, 0))")
            self.notes.append(f"{what} is not drawn: no position connects point "
                              f"{point.name} to a point fixed in {self.N}")
            return None
        anchor = self.origin if self.origin in fixed else fixed[0]
        if self.origin is None:
            self.origin = anchor
        elif anchor is not self.origin:
            self.notes.append(f"{what} is measured from point {anchor.name}, which no "
                              f"position connects to {self.origin.name}: drawn as if the "
                              "two fixed points coincided")
        for p in _component(point):
            self._of.setdefault(p, anchor)
        return anchor


def _skeleton(kin, anchor, point):
    """Points from ``anchor`` to ``point`` along the given positions."""
    kin.position(point, anchor)  # builds the parent tree
    parents = kin._position_trees[anchor][0]
    path = [point]
    while path[-1] is not anchor:
        path.append(parents[path[-1]])
    return path[::-1]


class _Program:
    """The generated function of a model's poses, and what its outputs are."""

    def __init__(self, model, trace, inputs):
        eom = getattr(model, "_eom", None)
        if eom is None:
            raise ModelError("the animation needs the model's equations, which an unpickled "
                             "NumericModel does not carry; rebuild it with eom.numeric(...)")
        prog, table, kin = eom._program, eom._table, eom._kinematics
        N = eom.frame
        anchors = _Anchors(N)
        points, frames, items = [], [], []

        def point_index(p):
            if p not in points:
                points.append(p)
            return points.index(p)

        def frame_index(f):
            if f not in frames:
                frames.append(f)
            return frames.index(f)

        frame_index(N)  # so that there is at least one frame
        segments = set()
        for k, body in enumerate(eom.bodies):
            if isinstance(body, InertialElement):
                continue  # no shape of its own
            if isinstance(body, FlexibleBody):
                ref, frame = body.origin, body.frame
            else:
                ref = body.masscenter
                frame = body.frame if isinstance(body, me.RigidBody) else None
            anchor = anchors.anchor(ref, f"body {body.name}")
            path = _skeleton(kin, anchor, ref)
            for a, b in zip(path[:-1], path[1:]):
                segments.add((point_index(a), point_index(b)))
            items.append(("body", k, point_index(ref),
                          None if frame is None else frame_index(frame), anchor))
        self.traces = []
        for p in trace:
            if not isinstance(p, me.Point):
                raise OptionError(f"trace must list sympy Points, got {p!r}")
            anchor = anchors.anchor(p, f"traced point {p.name}")
            self.traces.append((p.name, point_index(p), anchor))
        self.surfaces = []
        for contact in eom.contacts:
            s = contact.surface
            if any(s is other for other, *_ in self.surfaces):
                continue
            anchor = anchors.anchor(s.origin, f"surface {s.name}", required=False)
            if anchor is None:
                continue
            self.surfaces.append((s, point_index(s.origin), frame_index(s.frame), anchor))
        self.items = items
        self.segments = sorted(segments)
        self.points, self.frames = points, frames
        self.notes = anchors.notes
        self.origin_name = anchors.origin.name if anchors.origin is not None else None
        self.bodies = eom.bodies

        subs = model._substitutions

        def sub(e):
            e = sm.sympify(e, strict=True)
            return prog.subs(e, subs) if subs else e

        pos_exprs = []
        for p in points:
            pos_exprs.extend(sub(e) for e in kin.position(p, anchors._of[p]))
        dcm_exprs = [sub(e) for f in frames for e in kin.dcm(f)]
        outputs = [((len(points), 3), pos_exprs), ((len(frames), 3, 3), dcm_exprs)]
        args = dict(model._functions["dynamics"][0])
        known = set(args["y"]) | set(args["p"]) | set(args["r"]) | {table.t}
        leaves = set()
        for _, exprs in outputs:
            for e in exprs:
                leaves |= prog.deps(e)
        given = {table.external(s): s for s in leaves - known if table.external(s) in inputs}
        # constants given to the model that its equations do not use but the shapes'
        # places do (a link's mass centre along its joint axis): their values
        unused = model._data.get("unused_constants", {})
        fixed = {s: unused[name_of(table.external(s))] for s in leaves - known
                 if table.external(s) not in given and name_of(table.external(s)) in unused}
        self.extra = list(given)  # inputs the positions need beyond the model's: given
        self.fixed = list(fixed.values())
        unknown = sorted(name_of(table.external(s))
                         for s in leaves - known - set(given.values()) - set(fixed))
        if unknown:
            raise ModelError(f"the positions of the animation need {', '.join(unknown)}, "
                             "which the numerical model has no value for (give them with "
                             "animate(..., inputs={symbol: function of t}))")
        args["r"] = list(args["r"]) + list(given.values()) + list(fixed)
        # (n, 3, 3) outputs are written as (n*3, 3): reshape after the call
        outputs[1] = ((3 * len(frames), 3), dcm_exprs)
        source = generate_python(prog, "viewer_poses", args, outputs, vectorized=True)
        self.function = compile_python(source, "viewer_poses")

    def __call__(self, model, t, Y, inputs):
        k = len(t)
        r = [np.array([model._r(t[j], Y[:, j])[i] for j in range(k)])
             for i in range(len(model._inputs))] if model._inputs else []
        r += [np.array([float(inputs[symbol](tj)) for tj in t]) if callable(inputs[symbol])
              else np.full(k, float(inputs[symbol])) for symbol in self.extra]
        r += [np.full(k, value) for value in self.fixed]
        pos, dcm = self.function(t, Y, model._p, r)
        pos = np.broadcast_to(pos, (len(self.points), 3, k))
        dcm = np.broadcast_to(dcm, (3 * len(self.frames), 3, k))
        pos = np.moveaxis(pos, -1, 0)  # (k, points, 3)
        dcm = np.moveaxis(dcm, -1, 0).reshape(k, len(self.frames), 3, 3)
        return pos, dcm


def _program(model, trace, inputs):
    cache = model.__dict__.setdefault("_viewer_programs", {})
    key = (tuple(id(p) for p in trace), tuple(sorted(map(str, inputs))))
    if key not in cache:
        cache[key] = _Program(model, trace, inputs)
    return cache[key]


# ------------------------------------------------------------------ shapes
def _constants(model):
    return {str(k): v for k, v in model.constants.items()}


def _numeric(expr, values):
    expr = sm.sympify(expr, strict=True)
    expr = expr.subs({s: values[str(s)] for s in expr.free_symbols if str(s) in values})
    try:
        return float(expr)
    except TypeError:
        return None


def _default_shape(body, values, size):
    """The documented default: an ellipsoid of equal inertia, or a small sphere."""
    marker = {"kind": "sphere", "semi_axes": [_PARTICLE_SIZE * size] * 3}
    if isinstance(body, FlexibleBody):
        return None  # drawn as its deformed member
    params = body_parameters([body])
    mass = _numeric(params[0][2], values)
    inertia = params[0][3]
    if not isinstance(body, me.RigidBody) or inertia is None or not mass:
        return marker, np.eye(3)
    I = np.array([[_numeric(e, values) for e in row] for row in inertia.tolist()],
                 dtype=object)
    if any(v is None for v in I.ravel()):
        return marker, np.eye(3)
    I = I.astype(float)
    moments, axes = np.linalg.eigh(0.5 * (I + I.T))
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1
    total = moments.sum()
    sq = np.array([2.5 / mass * (total - 2 * moments[i]) for i in range(3)])
    semi = np.sqrt(np.maximum(sq, 0.0))
    if semi.max() <= 0:
        return marker, np.eye(3)
    semi = np.maximum(semi, 0.05 * semi.max())
    return {"kind": "sphere", "semi_axes": semi.tolist()}, axes


def _shape_data(shape, color):
    geometry = shape.geometry()
    if isinstance(shape, Mesh):
        geometry = dict(geometry, **read_mesh(shape.path))
    return dict(geometry, offset=_rounded(shape.offset, 9),
                quaternion=_rounded(quaternions(shape.rotation), 9),
                color=shape.color or color, opacity=shape.opacity)


# -------------------------------------------------------------- surfaces
def _surface_data(surface, values, center, size, C0, o0):
    """Plain data of a surface in its frame's coordinates, or a reason it is not drawn."""
    x = SURFACE_COORDINATES
    if isinstance(surface, Plane):
        grad = [_numeric(surface.gap.diff(xi), values) for xi in x]
        if any(g is None for g in grad):
            return f"plane {surface.name}: its normal depends on more than constants"
        n = np.array(grad) / np.linalg.norm(grad)
        c = C0.T @ (np.asarray(center) - o0)  # the scene centre in the surface frame
        c = c - (c @ n) * n
        return {"kind": "plane", "normal": _rounded(n, 9), "center": _rounded(c, 9),
                "size": 1.6 * size}
    if isinstance(surface, Sphere):
        r = _numeric(surface.radius, values)
        if r is None:
            return f"sphere {surface.name}: its radius depends on more than constants"
        return {"kind": "ellipsoid", "semi_axes": [r] * 3, "inside": bool(surface.inside)}
    if isinstance(surface, Ellipsoid):
        axes = [_numeric(a, values) for a in surface.axes]
        if any(a is None for a in axes):
            return f"ellipsoid {surface.name}: its axes depend on more than constants"
        return {"kind": "ellipsoid", "semi_axes": axes, "inside": bool(surface.inside)}
    return f"surface {surface.name} ({type(surface).__name__}) is not drawn"


# ------------------------------------------------------------------ scene
def _frames(result, max_frames):
    t = np.asarray(result.t, dtype=float)
    keep = np.flatnonzero(np.all(np.isfinite(result.y), axis=0))
    if keep.size == 0:
        raise ModelError("the result has no finite state to animate")
    if keep.size > max_frames:
        keep = keep[np.unique(np.round(np.linspace(0, keep.size - 1, max_frames)).astype(int))]
    return t[keep], np.asarray(result.y, dtype=float)[:, keep]


def scene_data(result, visuals=(), trace=(), up="auto", max_frames=DEFAULT_MAX_FRAMES,
               title=None, inputs=None):
    """The animation's scene as JSON-ready data.

    Parameters
    ----------
    result : SimulationResult
    visuals : sequence of kanedyn.visuals.Shape
        Shapes drawing the bodies (see the module docstring for the default).
    trace : sequence of sympy Point
        Points whose paths are drawn.
    up : "auto", "x", "y", "z", "-x", "-y", "-z" or 3 numbers
        The inertial direction shown upwards; ``"auto"``: opposite to the
        model's declared gravity, else to its weights, else +z
        (:func:`kanedyn.io.up_direction`); ``up_note`` says which.
    max_frames : int
        At most this many of the result's output times become frames
        (evenly by index); the page interpolates between frames.
    title : str, optional
    inputs : dict, optional
        ``{specified symbol: function of t, or number}``: inputs that the
        positions need but the equations of motion do not (a vehicle's
        displacement when only its accelerations drive the model).

    Returns
    -------
    dict
    """
    if not isinstance(max_frames, int) or max_frames < 2:
        raise OptionError(f"max_frames must be an integer >= 2, got {max_frames!r}")
    model = result.model
    visuals = tuple(visuals or ())
    for v in visuals:
        if not isinstance(v, Shape):
            raise OptionError(f"visuals must be kanedyn.visuals shapes (Box, Cylinder, "
                              f"Sphere, Mesh), got {v!r}")
    trace = tuple(trace or ())
    inputs = dict(inputs or {})
    for symbol, value in inputs.items():
        if not (callable(value) or isinstance(value, numbers.Real)):
            raise OptionError(f"inputs[{symbol}] must be a function of t or a number, "
                              f"not {value!r}")
    prog = _program(model, trace, inputs)
    t, Y = _frames(result, max_frames)
    pos, dcm = prog(model, t, Y, inputs)
    values = _constants(model)

    # the size of the scene: where the reference points and traced points go
    used = sorted({item[2] for item in prog.items} | {i for _, i, _ in prog.traces}
                  | {i for seg in prog.segments for i in seg})
    cloud = [pos[:, used, :].reshape(-1, 3)]
    flexible = []
    for kind, k, ip, jf, _ in prog.items:
        body = prog.bodies[k]
        if isinstance(body, FlexibleBody):
            idx = [model.index(name_of(q)) for q in body.q]
            nodes = np.stack([deformed_nodes(body, Y[idx, j]) for j in range(len(t))])
            world = pos[:, ip, None, :] + np.einsum("kab,knb->kna", dcm[:, jf], nodes)
            flexible.append((k, world))
            cloud.append(world.reshape(-1, 3))
    cloud = np.concatenate(cloud)
    lo, hi = cloud.min(axis=0), cloud.max(axis=0)
    size = float(np.max(hi - lo))
    size = size if size > 1e-9 else 1.0
    center = 0.5 * (lo + hi)
    # the model's own size (the largest extent of its bodies' points at one time):
    # the thickness of links and default shapes of a model that travels far (a
    # sensor on a vehicle), where the scene's size is its travel
    own_points = sorted({item[2] for item in prog.items})
    own = float(np.max(np.linalg.norm(np.ptp(pos[:, own_points, :], axis=1), axis=1)))
    reach = own if 0 < 4 * own < size else size
    up_vec, up_note = up_direction(up, model._eom, values)

    frame = model._eom.frame
    by_body, fixed_shapes = {}, []
    for v in visuals:
        if isinstance(v.body, me.ReferenceFrame):
            if v.body is not frame:
                raise ModelError(f"{v._where()}: {v.body} is not the inertial frame {frame} "
                                 "of the simulated model, the only frame shapes are fixed in")
            fixed_shapes.append(v)
            continue
        if not any(v.body is b for b in prog.bodies):
            raise ModelError(f"{v._where()}: {getattr(v.body, 'name', v.body)} is not a body "
                             "of the simulated model")
        by_body.setdefault(id(v.body), []).append(v)
    bodies, floor = [], float(np.min(cloud @ up_vec))
    for n, (kind, k, ip, jf, _) in enumerate(prog.items):
        body = prog.bodies[k]
        color = PALETTE[n % len(PALETTE)]
        declared = by_body.get(id(body), [])
        # the legend's colour is the one drawn: a declared shape's own, if any
        color = next((v.color for v in declared if v.color), color)
        shapes = [_shape_data(v, color) for v in declared]
        default = False
        if not shapes:
            made = _default_shape(body, values, reach)
            if made is not None:
                geometry, axes = made
                shapes = [dict(geometry, offset=[0.0, 0.0, 0.0],
                               quaternion=_rounded(quaternions(axes), 9), color=color,
                               opacity=1.0)]
                default = True
        quat = quaternions(dcm[:, jf]) if jf is not None else np.tile([0, 0, 0, 1.0],
                                                                     (len(t), 1))
        rotation = dcm[:, jf] if jf is not None else np.broadcast_to(np.eye(3), (len(t), 3, 3))
        floor = min(floor, lowest_height(up_vec, pos[:, ip, :], rotation, shapes))
        bodies.append({"name": body.name, "color": color, "shapes": shapes,
                       "default_shape": default, "oriented": jf is not None,
                       "position": _rounded(pos[:, ip, :]), "quaternion": _rounded(quat)})
    fixed = None
    if fixed_shapes:
        color = next((v.color for v in fixed_shapes if v.color), FIXED_COLOR)
        fixed = {"name": f"{frame.name} (fixed)", "color": color,
                 "shapes": [_shape_data(v, color) for v in fixed_shapes]}
        floor = min(floor, lowest_height(up_vec, np.zeros((1, 3)), np.eye(3)[None],
                                         fixed["shapes"]))
    flex = [{"name": prog.bodies[k].name, "body": [i for i, item in enumerate(prog.items)
                                                   if item[1] == k][0],
             "n_nodes": int(world.shape[1]), "nodes": _rounded(world)}
            for k, world in flexible]
    # links of constant length only: a translation (a cart, a free body) is no rod
    segments = []
    for a, b in prog.segments:
        length = np.linalg.norm(pos[:, a] - pos[:, b], axis=1)
        if length.max() > 1e-9 * size and np.ptp(length) <= 1e-6 * max(length.max(), size):
            segments.append((a, b))
    seg_points = sorted({i for seg in segments for i in seg})
    where = {p: i for i, p in enumerate(seg_points)}
    skeleton = {"n_points": len(seg_points),
                "points": _rounded(pos[:, seg_points, :]),
                "segments": [[where[a], where[b]] for a, b in segments]}
    notes = list(prog.notes)
    surfaces = []
    for s, ip, jf, _ in prog.surfaces:
        data = _surface_data(s, values, center, size, dcm[0, jf], pos[0, ip])
        if isinstance(data, str):
            notes.append(data)
            continue
        moving = (np.ptp(pos[:, ip], axis=0).max() > 1e-12 or
                  np.ptp(dcm[:, jf].reshape(len(t), -1), axis=0).max() > 1e-12)
        rows = slice(None) if moving else slice(0, 1)
        surfaces.append(dict(data, name=s.name, position=_rounded(pos[rows, ip]),
                             quaternion=_rounded(quaternions(dcm[rows, jf]))))
    traces = [{"name": name, "color": PALETTE[(len(bodies) + i) % len(PALETTE)],
               "points": _rounded(pos[:, ip])} for i, (name, ip, _) in enumerate(prog.traces)]
    return {
        "title": title or "kanedyn animation",
        "t": _rounded(t, 9),
        "up": up_vec.tolist(),
        "up_note": up_note,
        "center": center.tolist(),
        "size": size,
        "reach": reach,
        "low": lo.tolist(), "high": hi.tolist(),
        "origin": getattr(prog, "origin_name", None),
        "bodies": bodies,
        "fixed": fixed,
        "floor": floor,
        "flexible": flex,
        "skeleton": skeleton,
        "surfaces": surfaces,
        "traces": traces,
        "notes": notes,
    }
