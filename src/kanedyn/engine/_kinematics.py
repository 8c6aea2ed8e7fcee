r"""Kinematics of frames and points as named intermediates, in inertial components.

For every reference frame ``F`` reached from the inertial frame ``N`` the
direction cosine matrix :math:`{}^N C^F` (``F`` components to ``N`` components)
and the angular velocity :math:`{}^N\omega^F` are built recursively from the
parent frame's, one small expression per entry.  Point velocities follow the
relations the user wrote (positions, ``set_vel``, ``v2pt_theory``):

* a point without a stored velocity in ``N`` gets
  :math:`v_P = v_O + {}^N\!\frac{d}{dt} r^{OP}` along the chain of positions to
  the nearest point whose velocity is known (SymPy's own rule);
* a point with a stored velocity keeps it as the definition, but where the
  stored expression is large (``v2pt_theory`` expands direction cosines
  symbolically) kanedyn tries the compact forms :math:`v_O + \omega^F\times r^{OP}`
  and :math:`v_O + \dot r^{OP}` and adopts one that is *identical* to the stored
  expression.  Identity is established by evaluating both at random points
  (randomized polynomial identity testing), never assumed.

Accelerations and partial velocities are not built here: they are the program's
time derivatives and partial derivatives of these velocities.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence

import sympy as sm
import sympy.physics.mechanics as me

from .._errors import KinematicsError
from ._program import SAMPLE_SEEDS, _sum, _times, fast_eval

__all__ = ["Kinematics", "PartialVelocities", "cross", "dot", "add", "matvec",
           "dyadic_matrix", "inertia_components"]

_ZERO3 = (sm.S.Zero,) * 3
_SMALL = 60  # stored velocities with at most this many nodes are used as they are


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sm.Add(a[0] * b[0], a[1] * b[1], a[2] * b[2])


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def _product(A, B):
    """``A * B`` of two 3 x 3 SymPy matrices, each entry the sum of its products
    as SymPy's product makes it (``Add`` of the nonzero ``A[i, k] * B[k, j]``), but
    without its conversion to and from a domain matrix (0.45 against 0.07 ms:
    4 ms of deriving a chain of ten links)."""
    return sm.Matrix(3, 3, [sm.Add(*[A[i, k] * B[k, j] for k in range(3)])
                            for i in range(3) for j in range(3)])


class PartialVelocities(Sequence):
    r"""Partial derivatives of a vector with respect to each speed, formed when
    first read.

    Item ``r`` is the 3-tuple :math:`\partial v/\partial u_r` with the
    ``fixed`` leaves (auxiliary speeds) then set to their values; a tree of
    joints needs few of the :math:`n^2` partial velocities of its bodies
    (:mod:`._composite`), so they are not all formed up front.

    Parameters
    ----------
    prog : Program
    vector : tuple of 3 expressions
    speeds : sequence of Symbol
    fixed : dict
        ``{leaf: value}`` substituted after differentiating.
    """

    __slots__ = ("prog", "vector", "speeds", "fixed", "_formed", "_leaves")

    def __init__(self, prog, vector, speeds, fixed):
        self.prog, self.vector = prog, tuple(vector)
        self.speeds, self.fixed = tuple(speeds), dict(fixed)
        self._formed, self._leaves = {}, None

    def __len__(self):
        return len(self.speeds)

    def __getitem__(self, r):
        if isinstance(r, slice):
            return [self[i] for i in range(len(self))[r]]
        r = range(len(self))[r]
        found = self._formed.get(r)
        if found is None:
            prog, speed = self.prog, self.speeds[r]
            found = self._formed[r] = tuple(prog.subs(prog.diff(c, speed), self.fixed)
                                            for c in self.vector)
        return found

    def on(self, program):
        """These partials continued on ``program`` (an extension of :attr:`prog`,
        e.g. :meth:`Program.copy`): those formed are shared, new ones are
        added to ``program`` only."""
        new = PartialVelocities(program, self.vector, self.speeds, self.fixed)
        new._formed, new._leaves = dict(self._formed), self._leaves
        return new

    def moves(self, r):
        """Whether the vector depends on speed ``r`` (its partial is not zero
        by structure), without forming the partial."""
        if self._leaves is None:
            self._leaves = frozenset().union(*(self.prog.deps(c) for c in self.vector))
        return self.speeds[r] in self._leaves


def _is_zero_vector(vec):
    return vec == me.Vector(0) or all(m == sm.zeros(3, 1) for m, _ in vec.args)


def is_small(expr, limit):
    """True when ``expr`` has at most ``limit`` nodes (stops counting early)."""
    count = 0
    stack = [expr]
    while stack:
        e = stack.pop()
        count += 1
        if count > limit:
            return False
        stack.extend(e.args)
    return True


def _close(a, b, tol=1e-9):
    scale = 1.0 + max(abs(x) for x in list(a) + list(b))
    return all(abs(x - y) <= tol * scale for x, y in zip(a, b))


def _chain_origin(point):
    """The point a chain of ``locatenew`` calls most likely starts from.

    Each point's first stored position is to the point it was located from, and
    an origin's to the first point located from it; following first positions
    from ``point`` ends in that pair, origin last.
    """
    seen = []
    while point not in seen:
        seen.append(point)
        point = next(iter(point._pos_dict))
    return seen[-1]


def _no_velocity_text(point, connected, N):
    """Why the velocity of ``point`` cannot be found: no point of ``connected`` (the
    points its positions lead to, ``point`` first) has one in ``N``."""
    start = f"the velocity of point {point} in {N} cannot be found: "
    if len(connected) == 1:
        return (start + f"it has no velocity set in {N} and is located from no other "
                f"point; call {point}.set_vel({N}, ...) or locate it (locatenew/set_pos) "
                f"from a point whose velocity in {N} is known")
    origin = _chain_origin(point)
    shown = ", ".join(map(str, connected[:8])) + (", ..." if len(connected) > 8 else "")
    return (start + f"no point of its chain of positions (set_pos/locatenew: {shown}) "
            f"has a velocity in {N}; set the velocity of the one fixed in {N}, likely the "
            f"chain's origin {origin}: {origin}.set_vel({N}, 0)")


def _bfs_parents(start, neighbours):
    """Breadth-first search; returns {node: parent} over everything reachable."""
    parents = {start: None}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        for nb in neighbours(node):
            if nb not in parents:
                parents[nb] = node
                queue.append(nb)
    return parents


class Kinematics:
    """Frames and points of a model, as intermediates of a :class:`Program`.

    Parameters
    ----------
    program : Program
    table : SymbolTable
    frame : sympy.physics.mechanics.ReferenceFrame
        The inertial frame ``N``; all vectors are returned in its components.
    bodies : sequence
        The model's bodies (used to know which frame a mass centre is fixed in).
    """

    def __init__(self, program, table, frame, bodies=()):
        self.prog = program
        self.table = table
        self.N = frame
        self._dcm = {frame: sm.ImmutableMatrix.eye(3)}
        self._omega = {frame: _ZERO3}
        self._vel = {}
        self._position_trees = {}
        self._resolving = set()
        self._pending_hints = []
        self._dcm_parent = _bfs_parents(frame, lambda f: f._dcm_dict.keys())
        self._omega_parent = _bfs_parents(frame, lambda f: f._ang_vel_dict.keys())
        self._body_frame = {}
        for b in bodies:
            if isinstance(b, me.RigidBody):
                self._body_frame.setdefault(b.masscenter, b.frame)

    def on(self, program):
        """These kinematics continued on ``program`` (an extension of
        :attr:`prog`, e.g. :meth:`Program.copy`): frames and points already
        resolved are shared, new ones are added to ``program`` only."""
        new = Kinematics.__new__(Kinematics)
        for name, value in vars(self).items():
            if isinstance(value, (dict, list, set)):
                value = type(value)(value)
            setattr(new, name, value)
        new._position_trees = {origin: (parents, dict(memo)) for origin, (parents, memo)
                               in self._position_trees.items()}
        new.prog = program
        return new

    # ------------------------------------------------------------ conversion
    def internal(self, expr, where):
        return self.table.internal(expr, where)

    def scalar(self, expr, where, name="s"):
        """Internal form of a user expression; large ones become programs."""
        expr = sm.sympify(expr, strict=True)
        if is_small(expr, _SMALL):
            return self.table.internal(expr, where)
        return self.prog.let_tree(expr, name,
                                  leaf=lambda node: self.table.internal(node, where))

    def vector(self, vec, where):
        """Inertial components of a SymPy ``Vector`` (not named)."""
        if vec == 0 or vec == me.Vector(0):
            return _ZERO3
        if not isinstance(vec, me.Vector):
            raise KinematicsError(f"{where} is not a sympy.physics.vector Vector: {vec!r}")
        terms = ([], [], [])
        for measures, frame in vec.args:
            comps = [self.scalar(m, where) for m in measures]
            given = [j for j in range(3) if comps[j] != 0]
            if not given:
                continue
            C = self.dcm(frame)
            for i in range(3):
                terms[i].extend(C[i, j] * comps[j] for j in given)
        return tuple(sm.Add(*t) for t in terms)

    def let_vector(self, vec, name):
        return tuple(self.prog.let(c, f"{name}_{a}") for c, a in zip(vec, "xyz"))

    # ---------------------------------------------------------------- frames
    def dcm(self, frame):
        """Matrix mapping ``frame`` components to inertial components."""
        found = self._dcm.get(frame)
        if found is not None:
            return found
        if frame not in self._dcm_parent:
            raise KinematicsError(
                f"the orientation of frame {frame} relative to the inertial frame "
                f"{self.N} is not defined; orient it (e.g. {frame}.orient_axis("
                f"{self.N}, ...)) directly or through other frames")
        path = []
        f = frame
        while f not in self._dcm:
            path.append(f)
            f = self._dcm_parent[f]
        for f in reversed(path):
            parent = self._dcm_parent[f]
            local = parent._dcm_dict[f]  # parent.dcm(f): f components -> parent's
            where = f"orientation of {f}"
            local = local.applyfunc(lambda e, where=where: self.internal(e, where))
            product = _product(self._dcm[parent], local)
            C = self.prog.let_matrix(product, f"C_{f}_")
            self._dcm[f] = C
            self._pending_hints.append(f)
        return self._dcm[frame]

    def angular_velocity(self, frame):
        r"""Inertial components of :math:`{}^N\omega^F` (named intermediates)."""
        found = self._omega.get(frame)
        if found is not None:
            return found
        if frame not in self._omega_parent:
            raise KinematicsError(
                f"the angular velocity of frame {frame} in the inertial frame "
                f"{self.N} is not defined; orient {frame} or call {frame}.set_ang_vel")
        path = []
        f = frame
        while f not in self._omega:
            path.append(f)
            f = self._omega_parent[f]
        for f in reversed(path):
            parent = self._omega_parent[f]
            local = self.vector(f._ang_vel_dict[parent],
                                f"angular velocity of {f} in {parent}")
            self._omega[f] = self.let_vector(add(self._omega[parent], local), f"w_{f}")
        return self._omega[frame]

    def _flush_hints(self):
        r"""Record :math:`\dot C = \tilde\omega C` for every new rotation matrix."""
        while self._pending_hints:
            f = self._pending_hints.pop()
            C = self._dcm[f]
            w = self.angular_velocity(f)
            for j in range(3):
                col = (C[0, j], C[1, j], C[2, j])
                rate = cross(w, col)
                for i in range(3):
                    if col[i].is_Symbol:
                        self.prog.hint_dt(col[i], rate[i])

    def dt(self, expr):
        r"""Time derivative with :math:`\dot u = 0` (see :meth:`Program.dt`)."""
        self._flush_hints()
        return self.prog.dt(expr)

    def dt_vector(self, vec):
        self._flush_hints()
        return tuple(self.prog.dt(c) for c in vec)

    # ---------------------------------------------------------------- points
    def position(self, point, origin):
        """Inertial components of the position of ``point`` from ``origin``.

        Follows the positions given with ``set_pos``/``locatenew``; returns
        ``None`` when no chain of positions connects the two points.  Results
        are built from the positions of the points on the way (shared).
        """
        tree = self._position_trees.get(origin)
        if tree is None:
            tree = self._position_trees[origin] = (
                _bfs_parents(origin, lambda p: p._pos_dict.keys()), {origin: _ZERO3})
        parents, memo = tree
        if point not in parents:
            return None
        path = []
        p = point
        while p not in memo:
            path.append(p)
            p = parents[p]
        for p in reversed(path):
            rel = self._relative_position(p, parents[p])
            memo[p] = self.let_vector(add(memo[parents[p]], rel), f"p_{p}")
        return memo[point]

    def velocity(self, point):
        """Inertial components of the velocity of ``point`` in ``N``."""
        found = self._vel.get(point)
        if found is not None:
            return found
        if point in self._resolving:
            raise KinematicsError(
                f"the velocity of point {point} in {self.N} depends on itself through "
                "the positions and velocities given; check set_pos/set_vel calls")
        self._resolving.add(point)
        try:
            stored = point._vel_dict.get(self.N)
            if stored is not None:
                vel = self._from_stored(point, stored)
            else:
                vel = self._from_positions(point)
        finally:
            self._resolving.discard(point)
        self._vel[point] = vel
        return vel

    def _relative_position(self, point, other):
        """Inertial components of the position of ``point`` from ``other`` (named)."""
        vec = self.vector(point._pos_dict[other], f"position of {point} from {other}")
        return self.let_vector(vec, f"r_{other}_{point}")

    def _from_positions(self, point):
        N = self.N
        parents = {point: None}
        queue = deque([point])
        target = None
        while queue and target is None:
            node = queue.popleft()
            for nb in node._pos_dict:
                if nb in parents:
                    continue
                parents[nb] = node
                if N in nb._vel_dict or nb in self._vel:
                    target = nb
                    break
                queue.append(nb)
        if target is None:
            raise KinematicsError(_no_velocity_text(point, list(parents), N))
        vel = self.velocity(target)
        node = target
        while node is not point:
            child = parents[node]
            r = self._relative_position(child, node)
            vel = self.let_vector(add(vel, self.dt_vector(r)), f"v_{child}")
            if child is not point:
                self._vel.setdefault(child, vel)
            node = child
        return vel

    def _from_stored(self, point, stored):
        if _is_zero_vector(stored):
            return _ZERO3
        where = f"velocity of {point} in {self.N}"
        small = all(is_small(m, _SMALL) for measures, _ in stored.args for m in measures)
        if not small:
            compact = self._recognize(point, stored)
            if compact is not None:
                return compact
        return self.let_vector(self.vector(stored, where), f"v_{point}")

    def _stored_values(self, stored, seed):
        """Inertial components of a SymPy vector at random point ``seed``.

        Evaluated directly on the (external) SymPy expression, so that large
        stored velocities need not be converted when a compact form is found.
        """
        leaf_values = {}

        def value_of(node):
            if node not in leaf_values:
                internal = self.table.internal(node, "a stored velocity")
                leaf_values[node] = self.prog.shadow([internal], seed)[0]
            return leaf_values[node]

        memo = {}
        out = [0j, 0j, 0j]
        for measures, frame in stored.args:
            x = [fast_eval(m, value_of, memo) for m in measures]
            C = self.prog.shadow(list(self.dcm(frame)), seed)
            for i in range(3):
                out[i] += sum(C[3 * i + j] * x[j] for j in range(3))
        return out

    def _candidates(self, point):
        """Compact velocity expressions that ``point``'s stored velocity may equal."""
        for other in point._pos_dict:
            if other in self._resolving:
                continue
            try:
                v_other = self.velocity(other)
                r = self._relative_position(point, other)
            except KinematicsError:
                continue
            yield add(v_other, self.dt_vector(r))
            for frame in self._candidate_frames(point, other):
                try:
                    w = self.angular_velocity(frame)
                except KinematicsError:
                    continue
                yield add(v_other, cross(w, r))

    def _candidate_frames(self, point, other):
        """Frames in which both points may be fixed (``v2pt_theory``), likeliest first."""
        frames = []
        for p in (point, other):
            frames.extend(f for f, v in p._vel_dict.items()
                          if f is not self.N and _is_zero_vector(v))
            if p in self._body_frame:
                frames.append(self._body_frame[p])
        frames.extend(f for _, f in point._pos_dict[other].args)
        seen = set()
        for f in frames:
            if f not in seen and f is not self.N:
                seen.add(f)
                yield f

    def _recognize(self, point, stored):
        self._flush_hints()
        target = [self._stored_values(stored, seed) for seed in SAMPLE_SEEDS]
        if any(any(c != c for c in vals) for vals in target):  # nan: cannot test
            return None
        for cand in self._candidates(point):
            if all(_close(self.prog.shadow(cand, seed), vals)
                   for seed, vals in zip(SAMPLE_SEEDS, target)):
                return self.let_vector(cand, f"v_{point}")
        return None


def dyadic_matrix(dyadic, frame):
    """Components of a dyadic in ``frame`` (read directly when it is expressed there)."""
    axes = {frame.x: 0, frame.y: 1, frame.z: 2}
    if all(v1 in axes and v2 in axes for _, v1, v2 in dyadic.args):
        out = sm.zeros(3, 3)
        for coef, v1, v2 in dyadic.args:
            out[axes[v1], axes[v2]] += coef
        return out
    return dyadic.to_matrix(frame)


def inertia_components(kin, body, where):
    """Central inertia of a rigid body: ``(I_B, I_N, C)``.

    ``I_B`` in the body frame (3 x 3 ``sympy.Matrix`` in the kinematics' internal
    symbols), ``I_N`` in inertial components (nested lists of named
    intermediates), ``C`` the body frame's rotation matrix; ``where`` names the
    body in error messages.
    """
    prog = kin.prog
    frame = body.frame
    I_B = dyadic_matrix(body.central_inertia, frame)
    I_B = I_B.applyfunc(lambda e: kin.internal(e, where))
    C = kin.dcm(frame)
    given = [(a, b, I_B[a, b]) for a in range(3) for b in range(3) if I_B[a, b] != 0]
    I_N = [[None] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i, 3):
            # C[i, a] * I * C[j, b] summed, without SymPy's flatten where it can
            value = _sum([_times(_times(C[i, a], I), C[j, b]) for a, b, I in given])
            I_N[i][j] = I_N[j][i] = prog.let(value, f"I_{body.name}_{i}{j}")
    return I_B, I_N, C


def matvec(A, x):
    """A 3 x 3 matrix (nested sequences) times a 3-vector, as a tuple."""
    return tuple(sm.Add(*[A[i][j] * x[j] for j in range(3)]) for i in range(3))
