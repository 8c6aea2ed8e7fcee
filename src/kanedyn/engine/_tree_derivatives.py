r"""Derivatives of a tree's inertia forces with respect to its coordinates and
speeds, in spatial terms (:math:`O(n^2)` products of 6-vectors, as
articulated-body derivatives are).

Let every quantity be a spatial vector about a fixed point (the one where the
mass centre of the first body is), in inertial components, as in
:mod:`._composite`: a speed's partial twist :math:`S_i`, a body's inertia
:math:`\mathcal{I}_k`.  Speeds form a tree (:func:`._composite._speed_tree`:
speeds of one support chained in index order); :math:`j \preceq i` when
:math:`j` is :math:`i` or above it, :math:`\lambda(j)` the speed above
:math:`j`.  With :math:`\dot q = u` and every body's twist :math:`v_k =
\sum_{s\preceq k} S_s u_s`, moving :math:`q_j` moves the bodies below
:math:`j` rigidly with the twist :math:`S_j`; where moreover :math:`\partial
S_i/\partial q_j = S_j\times S_i` for :math:`j\preceq i` and 0 otherwise (a
joint axis fixed in the body above it), the inertia forces

.. math::

    \tau_i = S_i\cdot F_i,\quad F_i = \sum_{k\in B_i} \mathcal{I}_k a_k
    + v_k\times^*\mathcal{I}_k v_k,\quad
    a_k = \sum_{s\preceq k} S_s\dot u_s + (v_s\times S_s)\,u_s,

have the derivatives (the rotation of everything below :math:`j` cancels in
:math:`S_i\cdot F_i`; what remains comes from the motion above :math:`j`,
:math:`d_j = v_{\lambda(j)}\times S_j`, :math:`e_j = a_{\lambda(j)}\times S_j +
v_{\lambda(j)}\times d_j`)

.. math::

    \frac{\partial\tau_i}{\partial q_j} = \begin{cases}
        \alpha_i\cdot e_j + \beta_i\cdot d_j & j\preceq i\\
        S_i\cdot(S_j\times^* F_j + \mathcal{I}^c_j e_j + \dot{\mathcal{I}}^c_j d_j
        + d_j\times^* H_j) & i\prec j\end{cases}
    \qquad
    \frac{\partial\tau_i}{\partial u_j} = \begin{cases}
        \beta_i\cdot S_j + 2\alpha_i\cdot d_j & j\preceq i\\
        S_i\cdot(\dot{\mathcal{I}}^c_j S_j + S_j\times^* H_j + 2\mathcal{I}^c_j d_j)
        & i\prec j\end{cases}

with the composites of the bodies below :math:`i`: inertia
:math:`\mathcal{I}^c_i`, its rate :math:`\dot{\mathcal{I}}^c_i =
\sum_k v_k\times^*\mathcal{I}_k - \mathcal{I}_k v_k\times` and momentum
:math:`H_i = \sum_k \mathcal{I}_k v_k`, and :math:`\alpha_i =
\mathcal{I}^c_i S_i`, :math:`\beta_i = \dot{\mathcal{I}}^c_i S_i - S_i\times^*
H_i` (zero elsewhere).  Pinocchio's derivatives of the recursive Newton-Euler
algorithm rest on the same cancellation (Carpentier and Mansard, RSS 2018).

Loads constant in inertial components (forces :math:`F` at mass centres
:math:`c`, torques :math:`T` on body frames: gravity) are subtracted from
:math:`\tau` in the same terms.  They do not turn with the bodies: with their
sums below :math:`i`, the wrench :math:`W_i`, :math:`\sigma_i = \sum c\cdot F`,
:math:`G_i = \sum F c^T` and the summed torques and forces, moving :math:`q_j`
changes :math:`W_j` by :math:`S_j\times^* W_j` less
:math:`(\sigma\omega_j - G\omega_j + \omega_j\times T,\ \omega_j\times F)`
(:math:`\omega_j` the angular part of :math:`S_j`).  So :math:`F_j` becomes
:math:`F_j - W_j` in the second case of :math:`\partial\tau_i/\partial q_j`,
which gains that difference, and the first gains :math:`\gamma_i\cdot\omega_j`
(:func:`_load_lever`).

None of these conditions is assumed: the derivatives are compared at random
points with complex-step derivatives of the equations' own inertia forces
(:meth:`~._program.Program.shadow_jacobian`), and ``None`` is returned where
they differ or cannot be compared.

Generated code need not hold the :math:`2n^2` entries as expressions: the
vectors :math:`\alpha_i, \beta_i, \gamma_i, d_i, e_i, S_i, Y_i, Z_i` of every
speed (:data:`FACTOR_PARTS`, ``factors=True``) are :math:`O(n)` expressions,
and :func:`tree_jacobian_values` (or the C runtime's loop) forms the entries
from their numbers.
"""

from __future__ import annotations

import numpy as np
import sympy as sm

from ._composite import _Composite, _spatial_inertias, _speed_tree, _structure
from ._program import SAMPLE_SEEDS, _is_zero, difference, _plus, _sum as _plain_sum, _times

__all__ = ["tree_inertia_derivatives", "tree_jacobian_values", "FACTOR_PARTS"]

#: the vectors of each speed from which the entries are formed, in the order of
#: the rows of the factors (``tree_inertia_derivatives(..., factors=True)``), and
#: their lengths: 45 rows
FACTOR_PARTS = (("alpha", 6), ("beta", 6), ("gamma", 3), ("d", 6), ("e", 6), ("S", 6),
                ("Y", 6), ("Z", 6))

_ZERO6 = (sm.S.Zero,) * 6


# The vectors' entries are built as the operators build them (``a * b`` is
# ``Mul(a, b)``, ``a - b`` is ``Add(a, -b)``: the same expressions) by the
# helpers of ._program that skip SymPy's flatten where the result is a plain
# product or sum (4x less time forming chain3d's factors at n = 30).
def cross(a, b):
    """``_kinematics.cross``: :math:`a \\times b` of two 3-vectors."""
    return (difference(_times(a[1], b[2]), _times(a[2], b[1])),
            difference(_times(a[2], b[0]), _times(a[0], b[2])),
            difference(_times(a[0], b[1]), _times(a[1], b[0])))


def add(a, b):
    """``_kinematics.add``: the sum of two vectors."""
    return tuple(_plus(x, y) for x, y in zip(a, b))


def _scaled(vec, c):
    return tuple(_times(c, x) for x in vec)


def _sum(*vectors):
    return tuple(_plain_sum(list(parts)) for parts in zip(*vectors))


def _motion_cross(a, b):
    """:math:`a\\times b` of two twists (angular part first)."""
    return cross(a[:3], b[:3]) + add(cross(a[:3], b[3:]), cross(a[3:], b[:3]))


def _force_cross(a, f):
    """:math:`a\\times^* f` of a twist and a wrench (moment first)."""
    return add(cross(a[:3], f[:3]), cross(a[3:], f[3:])) + cross(a[:3], f[3:])


def _applied(inertia, x):
    """The spatial inertia (10 entries: J00 J01 J02 J11 J12 J22, h, m) times a twist."""
    J00, J01, J02, J11, J12, J22, hx, hy, hz, m = inertia
    J = ((J00, J01, J02), (J01, J11, J12), (J02, J12, J22))
    w, v, h = x[:3], x[3:], (hx, hy, hz)
    ang = add(tuple(_plain_sum([_times(J[i][j], w[j]) for j in range(3)]) for i in range(3)),
              cross(h, v))
    return ang + add(cross(w, h), _scaled(v, m))


def _rate(inertia, v):
    """The rate :math:`v\\times^*\\mathcal{I} - \\mathcal{I}v\\times` of a spatial
    inertia moving with the twist ``v``: the same 10 entries (its mass 0)."""
    J00, J01, J02, J11, J12, J22, hx, hy, hz, m = inertia
    J = ((J00, J01, J02), (J01, J11, J12), (J02, J12, J22))
    w, vo, h = v[:3], v[3:], (hx, hy, hz)
    A = [cross(w, (J[0][j], J[1][j], J[2][j])) for j in range(3)]  # A[j][i] = (w x J)_ij
    hv = _plain_sum([_times(a, b) for a, b in zip(h, vo)])
    rate = [_plus(difference(difference(_plus(A[j][i], A[i][j]), _times(h[i], vo[j])),
                         _times(vo[i], h[j])), _times(2, hv) if i == j else 0)
            for i in range(3) for j in range(i, 3)]
    return tuple(rate) + add(cross(w, h), _scaled(vo, m)) + (sm.S.Zero,)


def _dot(a, b):
    return _plain_sum([_times(x, y) for x, y in zip(a, b) if not _is_zero(x) and not _is_zero(y)])


def _named(prog, vec, name):
    return tuple(prog.let(c, name) for c in vec)


def tree_inertia_derivatives(kin, bodies, body_terms, masses, inertias, coordinates, speeds,
                             rates, o, reference, loads=(), factors=False, entries=True):
    r"""``(dq, du)``: :math:`\partial\tau/\partial q` and :math:`\partial\tau/\partial
    u` (o x o nested lists of expressions) of a tree's inertia forces with the
    rates :math:`\dot u` held, by the spatial formulas of this module; or
    ``None`` without the structure.  With ``factors=True``, ``(dq, du, factors,
    parent)``: also the vectors of every speed the entries are formed from (45
    rows of o expressions, :data:`FACTOR_PARTS`) and the speed above each speed
    (-1 at a root), for :func:`tree_jacobian_values`; with ``entries=False``
    too, ``dq`` and ``du`` are ``None``: their :math:`2o^2` expressions are not
    formed (the comparison with ``reference`` takes the entries' numbers from
    the factors', :func:`tree_jacobian_values`), so that the work grows with
    the number of speeds, not its square.

    Parameters
    ----------
    kin : Kinematics
        New intermediates go to ``kin.prog``.
    bodies, body_terms, masses, inertias
        As for :func:`~._composite.composite_inertia_forces`.
    coordinates, speeds, rates : sequence of Symbol
        :math:`q`, :math:`u` (the first ``o``) and :math:`\dot u`.
    o : int
        Number of real speeds.
    reference : sequence of o expressions, or (mass, rest)
        The inertia forces :math:`\tau` as the equations compute them
        (:math:`M\dot u + n`), less the generalized forces of ``loads``; the
        result is returned only where it agrees with their complex-step
        derivatives at the sample points.  It may be given as a pair: the
        :math:`o^2` entries of :math:`M` (row-major) and the o expressions of
        the rest; with ``entries=False`` the products with the rates are then
        taken in numbers, not formed as expressions.
    loads : sequence of (int, str, tuple)
        Loads constant in inertial components, ``(k, "F", force)`` at the mass
        centre of body ``k`` or ``(k, "T", torque)`` on its frame: their
        generalized forces are subtracted from :math:`\tau` (see
        :func:`_load_terms`).
    factors : bool, optional
        Also return the factors and the tree of speeds.
    entries : bool, optional
        Form the entries as expressions (with ``factors=True`` only, ``False``
        leaves them out).
    """
    found = _structure(kin, bodies, body_terms, o) if len(coordinates) == o else None
    if found is None:
        return None
    prog = kin.prog
    positions, supports, S = found
    composite = _Composite(supports)
    tree = _speed_tree(kin, composite, supports, S,
                       _spatial_inertias(masses, inertias, positions))
    parent, order, own = tree["parent"], tree["order"], tree["inertia"]
    S = [tuple(s) for s in tree["S"]]
    v, a, d, e = {}, {}, {}, {}
    for i in reversed(order):  # parents first: twists and accelerations
        above = parent[i]
        vp, ap = (v[above], a[above]) if above >= 0 else (_ZERO6, _ZERO6)
        d[i] = _named(prog, _motion_cross(vp, S[i]), f"dt{i}")
        e[i] = _named(prog, _sum(_motion_cross(ap, S[i]), _motion_cross(vp, d[i])), f"et{i}")
        v[i] = _named(prog, _sum(vp, _scaled(S[i], speeds[i])), f"Vt{i}")
        a[i] = _named(prog, _sum(ap, _scaled(S[i], rates[i]), _scaled(d[i], speeds[i])),
                      f"At{i}")
    children = {i: [] for i in range(o)}
    for i in range(o):
        if parent[i] >= 0:
            children[parent[i]].append(i)
    applied = _load_terms(loads, positions, _homes(composite, supports))
    Ic, Id, H, F, L = {}, {}, {}, {}, {}
    for i in order:  # children first: composites
        below = [(Ic[c], Id[c], H[c], F[c], L[c]) for c in children[i]]
        h = _applied(own[i], v[i])
        f = _sum(_applied(own[i], a[i]), _force_cross(v[i], h))
        Ic[i] = _named(prog, _sum(own[i], *[x[0] for x in below]), f"Ic{i}")
        Id[i] = _named(prog, _sum(_rate(own[i], v[i]), *[x[1] for x in below]), f"Id{i}")
        H[i] = _named(prog, _sum(h, *[x[2] for x in below]), f"Hc{i}")
        F[i] = _named(prog, _sum(f, *[x[3] for x in below]), f"Fc{i}")
        L[i] = _named(prog, _sum(applied.get(i, _ZERO_LOAD), *[x[4] for x in below]), f"Lc{i}")
    alpha, beta, gamma, Y, Z = {}, {}, {}, {}, {}
    for j in range(o):
        alpha[j] = _named(prog, _applied(Ic[j], S[j]), f"al{j}")
        turn = _named(prog, _force_cross(S[j], H[j]), f"SH{j}")
        rate = _named(prog, _applied(Id[j], S[j]), f"IS{j}")
        beta[j] = _named(prog, _sum(rate, _scaled(turn, -1)), f"be{j}")
        gamma[j] = _named(prog, _load_lever(L[j], S[j]), f"ga{j}")
        net = _sum(F[j], _scaled(L[j][:6], -1))
        Y[j] = _named(prog, _sum(_force_cross(S[j], net), _applied(Ic[j], e[j]),
                                 _applied(Id[j], d[j]), _force_cross(d[j], H[j]),
                                 _load_turn(L[j], S[j][:3])), f"Yq{j}")
        Z[j] = _named(prog, _sum(rate, turn, _scaled(_applied(Ic[j], d[j]), 2)), f"Zu{j}")
    variables = list(coordinates[:o]) + list(speeds[:o])
    above = tuple(parent[i] for i in range(o))
    rows = None
    if factors:
        parts = {"alpha": alpha, "beta": beta, "gamma": gamma, "d": d, "e": e,
                 "S": dict(enumerate(S)), "Y": Y, "Z": Z}
        used = _used_components(parts, parent, o)
        rows = [[parts[name][i][c] if used[name, i, c] else sm.S.Zero for i in range(o)]
                for name, size in FACTOR_PARTS for c in range(size)]
    if factors and not entries:
        if not _factors_agree(prog, reference, variables, rows, above, rates[:o]):
            return None
        return None, None, rows, above
    dq = [[sm.S.Zero] * o for _ in range(o)]
    du = [[sm.S.Zero] * o for _ in range(o)]
    for i in range(o):
        j = i
        while j >= 0:  # i itself and the speeds above it
            dq[i][j] = _plus(_plus(_dot(alpha[i], e[j]), _dot(beta[i], d[j])),
                             _dot(gamma[i], S[j][:3]))
            du[i][j] = _plus(_dot(beta[i], S[j]), _times(2, _dot(alpha[i], d[j])))
            if j != i:  # i is below j
                dq[j][i] = _dot(S[j], Y[i])
                du[j][i] = _dot(S[j], Z[i])
            j = parent[j]
    if isinstance(reference, tuple):  # (mass, rest)
        mass, rest = reference
        reference = [sm.Add(*[mass[r * o + s] * rates[s] for s in range(o)]) + rest[r]
                     for r in range(o)]
    if not _agrees(prog, reference, variables, dq, du):
        return None
    if not factors:
        return dq, du
    return dq, du, rows, above


#: which parts meet in the products of the formulas: (part of the speed below, part
#: of the speed above or the same, components, the speed itself too)
_PRODUCTS = (("alpha", "e", 6, True), ("alpha", "d", 6, True), ("beta", "d", 6, True),
             ("beta", "S", 6, True), ("gamma", "S", 3, True), ("Y", "S", 6, False),
             ("Z", "S", 6, False))


def _used_components(parts, parent, o):
    """``{(part, speed, component): bool}``: whether a component of a factor
    meets a partner not exactly zero in some product of the formulas (the
    entries skip the others, :func:`_dot`; so do the factors, whose
    expressions may name constants the equations do not keep)."""
    used = {(name, i, c): False for name, size in FACTOR_PARTS for i in range(o)
            for c in range(size)}
    nonzero = {(name, i): tuple(x != 0 for x in parts[name][i])
               for name, _ in FACTOR_PARTS for i in range(o)}  # compared once each
    for i in range(o):
        j = i
        while j >= 0:
            for low, high, size, itself in _PRODUCTS:
                if j == i and not itself:
                    continue
                a, b = nonzero[low, i], nonzero[high, j]
                for c in range(size):
                    if a[c] and b[c]:
                        used[low, i, c] = used[high, j, c] = True
            j = parent[j]
    return used


def tree_jacobian_values(factors, parent):
    r""":math:`\partial\tau/\partial(q, u)` from the numbers of the factors.

    Parameters
    ----------
    factors : array_like, shape (45, o) or (N, 45, o)
        The vectors of every speed (:data:`FACTOR_PARTS`) at one state or N.
    parent : sequence of o int
        The speed above each speed, -1 at a root.

    Returns
    -------
    ndarray, shape (o, 2 o) or (N, o, 2 o)
        The derivatives with respect to the coordinates, then the speeds (units
        of the inertia forces per unit of each).
    """
    F = np.asarray(factors, dtype=float)
    o = len(parent)
    at, part = 0, {}
    for name, size in FACTOR_PARTS:
        part[name] = F[..., at:at + size, :]
        at += size
    below = np.eye(o, dtype=bool)  # below[i, j]: j is i or above it
    for i in range(o):
        j = parent[i]
        while j >= 0:
            below[i, j] = True
            j = parent[j]
    strictly_above = (below & ~np.eye(o, dtype=bool)).T  # [j, i]: j strictly above i

    def products(a, b):  # [..., i, j] = a_i . b_j
        return np.einsum("...ci,...cj->...ij", a, b)
    al, be, S = part["alpha"], part["beta"], part["S"]
    lower_q = products(al, part["e"]) + products(be, part["d"]) + products(part["gamma"],
                                                                         S[..., :3, :])
    lower_u = products(be, S) + 2.0 * products(al, part["d"])
    dq = np.where(below, lower_q, 0.0) + np.where(strictly_above, products(S, part["Y"]), 0.0)
    du = np.where(below, lower_u, 0.0) + np.where(strictly_above, products(S, part["Z"]), 0.0)
    return np.concatenate([dq, du], axis=-1)


def _homes(composite, supports):
    """``{body: speed}``: the speed of the speed tree each moved body hangs from
    (the last of the speeds of its smallest support, as in ``_speed_tree``)."""
    home = {}
    for b in composite.order:
        last = [r for r, s in enumerate(supports) if s == b][-1]
        for k in composite.own[b]:
            home[k] = last
    return home


#: the load composites: wrench about O (6), :math:`G = \sum F c^T` (9, row-major),
#: :math:`\sigma = \sum c\cdot F` and the summed torques (3)
_ZERO_LOAD = (sm.S.Zero,) * 19


def _load_terms(loads, positions, homes):
    r"""``{speed: 19 entries}``: each speed's own constant loads (see
    :data:`_ZERO_LOAD`), a force :math:`F` at the mass centre :math:`c` of a
    body or a torque :math:`T` on its frame (bodies no speed moves have
    none)."""
    out = {}
    for k, kind, vec in loads:
        if k not in homes:
            continue
        if kind == "F":
            c = positions[k]
            terms = (add(cross(c, vec), (sm.S.Zero,) * 3) + tuple(vec)
                     + tuple(_times(f, x) for f in vec for x in c)
                     + (_plain_sum([_times(x, f) for x, f in zip(c, vec)]),) + (sm.S.Zero,) * 3)
        else:
            terms = tuple(vec) + (sm.S.Zero,) * 13 + tuple(vec)
        out[homes[k]] = _sum(out.get(homes[k], _ZERO_LOAD), terms)
    return out


def _load_lever(load, S):
    r""":math:`\gamma` with :math:`\partial(S_i\cdot W_i)/\partial q_j =
    -\gamma_i\cdot\omega_j` for :math:`j \preceq i`: the loads below ``i``
    do not turn with the bodies (:math:`\sigma W - G^T W + T\times W + F\times
    V`, ``S = (W, V)``)."""
    G, sigma, T, force = load[6:15], load[15], load[16:19], load[3:6]
    W, V = S[:3], S[3:]
    GW = tuple(_plain_sum([_times(G[3 * b + a], W[b]) for b in range(3)]) for a in range(3))
    return _sum(_scaled(W, sigma), _scaled(GW, -1), cross(T, W), cross(force, V))


def _load_turn(load, w):
    r"""What the constant loads below a speed of angular part ``w`` of its twist
    do not turn with its bodies: :math:`(\sigma w - G w + w\times T,\ w\times F)`
    (:math:`\partial W_j/\partial q_j = S_j\times^* W_j` less this)."""
    G, sigma, T, force = load[6:15], load[15], load[16:19], load[3:6]
    Gw = tuple(_plain_sum([_times(G[3 * a + b], w[b]) for b in range(3)]) for a in range(3))
    return _sum(_scaled(w, sigma), _scaled(Gw, -1), cross(w, T)) + cross(w, force)


#: random directions in which :func:`_factors_agree` compares the derivatives
FACTOR_CHECK_DIRECTIONS = 4


def _factors_agree(prog, reference, variables, rows, parent, rates, rtol=1e-9):
    r""":func:`_agrees` with the entries formed from the numbers of the factors
    ``rows`` (:func:`tree_jacobian_values`): no entry is an expression.  The
    derivatives are compared in :data:`FACTOR_CHECK_DIRECTIONS` random
    directions of (q, u) (complex steps in one lane each, not one per
    variable: the reference, :math:`M\dot u + n`, has :math:`O(n^2)`
    intermediates), which a wrong formula fails as the full matrix does.
    ``reference`` as for :func:`tree_inertia_derivatives`; given as ``(mass,
    rest)``, the derivatives of :math:`M` times the rates' values."""
    o = len(parent)
    exprs = [x for row in rows for x in row]
    for seed in SAMPLE_SEEDS:
        directions = np.random.default_rng(seed).uniform(
            -1.0, 1.0, (FACTOR_CHECK_DIRECTIONS, len(variables)))
        expected = _directional(prog, reference, variables, seed, directions, rates)
        if expected is None:
            return False
        values = np.array(prog.shadow(exprs, seed))
        if not np.all(np.isfinite(values)) or np.any(values.imag != 0):
            return False
        mine = tree_jacobian_values(values.real.reshape(len(rows), o), parent) @ directions.T
        if not _close(mine, expected, rtol):
            return False
    return True


def _directional(prog, reference, variables, seed, directions, rates):
    """Complex-step derivatives of the reference in ``directions`` at ``seed``,
    shape (o, k), or ``None`` where they cannot be trusted."""
    if not isinstance(reference, tuple):
        return prog.shadow_jacobian(reference, variables, seed, directions=directions)
    mass, rest = reference
    o = len(rest)
    dm = prog.shadow_jacobian(mass, variables, seed, directions=directions)
    dr = prog.shadow_jacobian(rest, variables, seed, directions=directions)
    w = np.array(prog.shadow(rates, seed))
    if dm is None or dr is None or np.any(w.imag != 0):
        return None
    return np.einsum("rsk,s->rk", dm.reshape(o, o, -1), w.real) + dr


def _close(mine, expected, rtol):
    return np.allclose(mine, expected, rtol=rtol, atol=rtol * max(1.0, np.abs(expected).max()))


def _agrees(prog, reference, variables, dq, du, rtol=1e-9):
    """Whether ``dq, du`` equal the complex-step derivatives of ``reference``
    with respect to ``variables`` (coordinates, then speeds) at the sample
    points (``False`` where those cannot be taken)."""
    o = len(dq)
    exprs = [row[j] for row in dq for j in range(o)] + [row[j] for row in du for j in range(o)]
    for seed in SAMPLE_SEEDS:
        expected = prog.shadow_jacobian(reference, variables, seed)
        if expected is None:
            return False
        values = np.array(prog.shadow(exprs, seed))
        if not np.all(np.isfinite(values)) or np.any(values.imag != 0):
            return False
        mine = np.hstack([values[:o * o].real.reshape(o, o), values[o * o:].real.reshape(o, o)])
        if not _close(mine, expected, rtol):
            return False
    return True
