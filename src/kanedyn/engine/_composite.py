r"""Composite-rigid-body assembly of Kane's mass matrix and forcing.

Take every body's partial twist about one common point :math:`O`,

.. math::

    S_{kr} = (W_{kr},\; V_{kr} - W_{kr}\times p_k),

where :math:`p_k` is the position of body :math:`k`'s mass centre from
:math:`O`.  In a tree of joints a speed :math:`u_r` moves every body it moves
rigidly, so :math:`S_{kr} = S_r` on its support :math:`B_r` (the bodies it
moves) and the supports of two speeds are nested or disjoint.  Then

.. math::

    M_{rs} = S_r^T\, \mathcal{I}(B_r\cap B_s)\, S_s,\qquad
    f_r = S_r^T\, \mathcal{W}(B_r),

with :math:`\mathcal{I}(B) = \sum_{k\in B} \mathcal{I}_k^O` the composite
spatial inertia about :math:`O` and :math:`\mathcal{W}(B)` the summed wrenches
about :math:`O`.  Composites are accumulated from the smallest support up, so
the mass matrix costs :math:`O(n^2)` operations and the forcing :math:`O(n)`,
against :math:`O(n^3)` and :math:`O(n^2)` for the body-by-body sums.

Nothing is assumed: the structure is detected from the equations themselves
(supports from the partial velocities, equality of the :math:`S_{kr}` by the
randomized identity test) and the generic sums are used when it is absent.
"""

from __future__ import annotations

import sympy as sm
import sympy.physics.mechanics as me

from ._kinematics import PartialVelocities, add, cross, dot
from ._program import SAMPLE_SEEDS

__all__ = ["composite_equations", "composite_inertia_forces"]


def _nonzero(vec):
    return any(c != 0 for c in vec)


def _close(a, b, tol=1e-9):
    scale = 1.0 + max(abs(x) for x in list(a) + list(b))
    return all(abs(x - y) <= tol * scale for x, y in zip(a, b))


def _power(twist, wrench):
    """The product of a twist and a wrench (6-vectors in the same order): one
    sum of the nonzero products (a third faster than nested binary sums)."""
    return sm.Add(*[sm.Mul(a, b) for a, b in zip(twist, wrench) if a != 0 and b != 0])


def _moves(partials, r):
    """Whether partial ``r`` is nonzero (by dependence, without forming it,
    when ``partials`` is a :class:`PartialVelocities`)."""
    if isinstance(partials, PartialVelocities):
        return partials.moves(r)
    return _nonzero(partials[r])


def _supports(body_terms, o):
    """``B_r``: indices of the bodies each real speed moves."""
    return [frozenset(k for k, t in enumerate(body_terms)
                      if _moves(t.partial_velocities, r)
                      or _moves(t.partial_angular_velocities, r))
            for r in range(o)]


def _nested(supports):
    unique = set(supports)
    for a in unique:
        for b in unique:
            inter = a & b
            if inter and inter != a and inter != b:
                return False
    return True


def _partial_values(prog, body_terms, o, seed):
    """``values(k, r) -> (W, V)``: the partial (angular) velocities of body
    ``k`` and real speed ``r`` at the random point ``seed``.

    By complex steps through the velocities in all speeds at once where they
    can be trusted (:meth:`Program.shadow_jacobian`; no partial velocity is
    formed), else from the partials themselves.
    """
    speeds = getattr(body_terms[0].partial_velocities, "speeds", None) if body_terms else None
    if speeds is not None:
        exprs = [c for t in body_terms for c in t.omega + t.velocity]
        jacobian = prog.shadow_jacobian(exprs, speeds[:o], seed)
        if jacobian is not None:
            return lambda k, r: (jacobian[6 * k:6 * k + 3, r], jacobian[6 * k + 3:6 * k + 6, r])
    return lambda k, r: (prog.shadow(body_terms[k].partial_angular_velocities[r], seed),
                         prog.shadow(body_terms[k].partial_velocities[r], seed))


def _rigid(prog, body_terms, positions, supports):
    """Whether S_kr is the same for every body k of each support B_r."""
    for seed in SAMPLE_SEEDS:
        pos = [prog.shadow(p, seed) for p in positions]
        values = _partial_values(prog, body_terms, len(supports), seed)
        for r, support in enumerate(supports):
            ref = None
            for k in sorted(support):
                W, V = values(k, r)
                p = pos[k]
                S = list(W) + [V[i] - (W[(i + 1) % 3] * p[(i + 2) % 3]
                                       - W[(i + 2) % 3] * p[(i + 1) % 3]) for i in range(3)]
                if any(v != v for v in S):  # nan: cannot decide
                    return False
                if ref is None:
                    ref = S
                elif not _close(S, ref):
                    return False
    return True


class _Composite:
    """Composite quantities of nested supports, accumulated smallest first."""

    def __init__(self, supports):
        order = sorted(set(supports), key=len)
        self.order = order
        self.children = {}
        for i, b in enumerate(order):
            smaller = [c for c in order[:i] if c < b]
            maximal = [c for c in smaller if not any(c < d for d in smaller)]
            self.children[b] = maximal
        self.own = {b: b - frozenset().union(*self.children[b]) for b in order}

    def accumulate(self, kin, per_body, name):
        """``{support: sum over its bodies}`` of tuples of expressions (named)."""
        total = {}
        for b in self.order:
            parts = ([total[c] for c in self.children[b]]
                     + [per_body[k] for k in sorted(self.own[b])])
            summed = tuple(sm.Add(*vals) for vals in zip(*parts))
            total[b] = tuple(kin.prog.let(v, name) for v in summed)
        return total


def _structure(kin, bodies, body_terms, o):
    """``(positions, supports, S)`` of a tree of joints, or ``None``.

    Positions of the mass centres from the first one, the supports ``B_r``
    (nested), and the representative spatial partial twists ``S_r = (W, V^O)``.
    """
    prog = kin.prog
    if not bodies or o == 0:
        return None
    origin = bodies[0].masscenter
    positions = [kin.position(b.masscenter, origin) for b in bodies]
    if any(p is None for p in positions):
        return None
    supports = _supports(body_terms, o)
    if any(not b for b in supports) or not _nested(supports):
        return None
    if not _rigid(prog, body_terms, positions, supports):
        return None
    S = []
    for r, support in enumerate(supports):
        k = min(support)
        W = body_terms[k].partial_angular_velocities[r]
        V = body_terms[k].partial_velocities[r]
        VO = tuple(a - b for a, b in zip(V, cross(W, positions[k])))
        S.append(kin.let_vector(W, f"SW{r}") + kin.let_vector(VO, f"SV{r}"))
    return positions, supports, S


def _spatial_inertias(masses, inertias, positions):
    """Spatial inertias about O: rotational J (6 entries), first moment h, mass."""
    per_body = []
    for m, I, p in zip(masses, inertias, positions):
        pp = dot(p, p)
        J = []
        for i in range(3):
            for j in range(i, 3):
                value = m * ((pp if i == j else 0) - p[i] * p[j])
                if I is not None:
                    value += I[i][j]
                J.append(value)
        per_body.append(tuple(J) + tuple(m * c for c in p) + (m,))
    return per_body


def _apply(kin, IC, twist, tag):
    """The wrench ``IC twist`` about O: (J W + h x V, W x h + m V)."""
    J00, J01, J02, J11, J12, J22, hx, hy, hz, m = IC
    J = ((J00, J01, J02), (J01, J11, J12), (J02, J12, J22))
    W, V = twist[:3], twist[3:]
    h = (hx, hy, hz)
    hV = cross(h, V)
    ang = tuple(sm.Add(*[J[i][j] * W[j] for j in range(3)], hV[i]) for i in range(3))
    lin = add(cross(W, h), tuple(m * c for c in V))
    return kin.let_vector(ang, f"Fa{tag}") + kin.let_vector(lin, f"Fl{tag}")


def composite_inertia_forces(kin, bodies, body_terms, masses, inertias, rates, o):
    r"""The rows :math:`(M\dot u)_r` of a tree by a recursive pass, or ``None``.

    With the rates :math:`\dot u` as symbols (``rates``), each body's spatial
    acceleration part :math:`A_k = \sum_{s:\,k\in B_s} S_s\dot u_s` is
    accumulated from the largest support down, its inertia wrench
    :math:`\mathcal{I}_k^O A_k` summed from the smallest support up, and

    .. math:: (M\dot u)_r = S_r^T \sum_{k\in B_r}\mathcal{I}_k^O A_k,

    :math:`O(n)` operations for a chain (the recursive Newton-Euler pass),
    against :math:`O(n^2)` for the product with the mass matrix.  Arguments
    as for :func:`composite_equations`; ``None`` without the tree structure.
    """
    found = _structure(kin, bodies, body_terms, o)
    if found is None:
        return None
    positions, supports, S = found
    tree = _Composite(supports)
    zero = (sm.S.Zero,) * 6
    parent = {}
    for i, b in enumerate(tree.order):  # smallest first: the parent is the
        parent[b] = next((c for c in tree.order[i + 1:] if b < c), None)  # next larger
    accel = {}
    for b in reversed(tree.order):  # largest first
        own = [tuple(c * rates[s] for c in S[s]) for s in range(o) if supports[s] == b]
        base = accel[parent[b]] if parent[b] is not None else zero
        summed = tuple(sm.Add(*vals) for vals in zip(base, *own))
        accel[b] = tuple(kin.prog.let(v, "Acc") for v in summed)
    home = {}  # each body's smallest support
    for b in tree.order:
        for k in tree.own[b]:
            home[k] = b
    per_body = _spatial_inertias(masses, inertias, positions)
    wrenches = [_apply(kin, per_body[k], accel[home[k]], f"i{k}") if k in home else zero
                for k in range(len(bodies))]
    sums = tree.accumulate(kin, wrenches, "Wu")
    return [_power(S[r], sums[supports[r]])
            for r in range(o)]


def composite_equations(kin, bodies, body_terms, masses, inertias, inertial, loads, o,
                        tree=None):
    """Mass matrix, active and inertia-remainder forces of the real speeds.

    Parameters
    ----------
    kin : Kinematics
    bodies : sequence of RigidBody or Particle
    body_terms : sequence of BodyTerms
    masses : sequence of expressions
    inertias : sequence of 3x3 nested lists (inertial components) or None
    inertial : sequence of (force, torque)
        Inertia-remainder force and torque of each body (u' = 0).
    loads : sequence of (location, vector, partials)
    o : int
        Number of real speeds.
    tree : list, optional
        When given (and the structure is found), receives one dict describing
        the mass matrix as a tree of speeds (:func:`_speed_tree`), from which
        ``M x = b`` is solved in :math:`O(n)` by an articulated-body pass.

    Returns
    -------
    (mass, active, remainder) or None
        ``mass`` o x o rows, ``active`` and ``remainder`` lists of length o;
        ``None`` when the system lacks the structure (then use the generic sums).
    """
    prog = kin.prog
    found = _structure(kin, bodies, body_terms, o)
    if found is None:
        return None
    positions, supports, S = found

    per_body = _spatial_inertias(masses, inertias, positions)
    collect = tree
    tree = _Composite(supports)
    if collect is not None:
        collect.append(_speed_tree(kin, tree, supports, S, per_body))
    composite = tree.accumulate(kin, per_body, "IC")
    F = [_apply(kin, composite[supports[s]], S[s], s) for s in range(o)]
    mass = [[None] * o for _ in range(o)]
    for r in range(o):
        for s in range(r, o):
            br, bs = supports[r], supports[s]
            if bs <= br:
                value = _power(S[r], F[s])
            elif br <= bs:
                value = _power(S[s], F[r])
            else:
                value = sm.S.Zero
            mass[r][s] = mass[s][r] = prog.let(value, f"M_{r}_{s}")

    # wrenches about O: (moment, force); loads at mass centres or on body frames
    by_point = {b.masscenter: k for k, b in enumerate(bodies)}
    by_frame = {b.frame: k for k, b in enumerate(bodies) if isinstance(b, me.RigidBody)}
    applied = [[(sm.S.Zero,) * 3, (sm.S.Zero,) * 3] for _ in bodies]
    generic = []
    for location, vec, parts in loads:
        if isinstance(location, me.ReferenceFrame) and location in by_frame:
            k = by_frame[location]
            applied[k][0] = add(applied[k][0], vec)
        elif not isinstance(location, me.ReferenceFrame) and location in by_point:
            k = by_point[location]
            applied[k][1] = add(applied[k][1], vec)
        else:
            generic.append((vec, parts))

    def wrench(k, torque, force):
        return add(torque, cross(positions[k], force)) + tuple(force)

    active_sums = tree.accumulate(
        kin, [wrench(k, t, f) for k, (t, f) in enumerate(applied)], "Wa")
    inertial_sums = tree.accumulate(
        kin, [wrench(k, t, f) for k, (f, t) in enumerate(inertial)], "Wi")
    active, remainder = [], []
    for r in range(o):
        Wa, Wi = active_sums[supports[r]], inertial_sums[supports[r]]
        value = _power(S[r], Wa)
        value += sm.Add(*[dot(vec, parts[r]) for vec, parts in generic])
        active.append(value)
        remainder.append(_power(S[r], Wi))
    return mass, active, remainder


def _speed_tree(kin, tree, supports, S, per_body):
    """The mass matrix as a tree of speeds (for an articulated-body solve).

    Speeds sharing one support are chained in index order; the last of them
    carries the support's own bodies.  Returns ``{"parent", "order", "S",
    "inertia"}``: ``parent[r]`` the speed above ``r`` (``-1`` at a root),
    ``order`` the speeds with every child before its parent, ``S[r]`` the
    spatial partial twist (6 expressions: W, V^O), ``inertia[r]`` the summed
    spatial inertia about O of the bodies attached at ``r`` (10 expressions:
    J00 J01 J02 J11 J12 J22, h, m; zeros where none).  Then
    ``M_rs = S_r^T I(B_r & B_s) S_s`` as in :func:`composite_equations`.
    """
    o = len(supports)
    chains = {b: [r for r in range(o) if supports[r] == b] for b in tree.order}
    parent_support = {}
    for i, b in enumerate(tree.order):
        parent_support[b] = next((c for c in tree.order[i + 1:] if b < c), None)
    parent, order = [-1] * o, []
    inertia = [(sm.S.Zero,) * 10 for _ in range(o)]
    for b in tree.order:  # smallest support first: children before parents
        chain = chains[b]
        above = parent_support[b]
        parent[chain[0]] = chains[above][-1] if above is not None else -1
        for a, r in zip(chain, chain[1:]):
            parent[r] = a
        order.extend(reversed(chain))
        own = [per_body[k] for k in sorted(tree.own[b])]
        if own:
            summed = tuple(sm.Add(*vals) for vals in zip(*own))
            inertia[chain[-1]] = tuple(kin.prog.let(v, "IO") for v in summed)
    return {"parent": parent, "order": order, "S": [tuple(s) for s in S],
            "inertia": inertia}
