r"""Kane's generalized forces of flexible bodies, from their inertia invariants.

For a :class:`kanedyn.FlexibleBody` with body-frame velocity components
:math:`w = (v, \omega, \zeta)` (origin velocity, angular velocity, modal speeds)
and kinetic energy :math:`T = \tfrac12 w^TM_b(\eta)w`, Lagrange's equations in
quasi-coordinates give the body's inertia forces

.. math::

    -F^*_b = \begin{bmatrix}
        \dot p_v + \omega\times p_v \\
        \dot p_\omega + \omega\times p_\omega + v\times p_v \\
        \dot p_\zeta - \partial T/\partial\eta
    \end{bmatrix},\qquad p = M_b w ,

and with the partial velocities :math:`W_r = \partial w/\partial u_r` Kane's
:math:`F^*_r = W_r^T F^*_b`:

.. math::

    M_{rs} \mathrel{+}= W_r^TM_bW_s,\qquad
    n_r \mathrel{+}= W_r^T\left(\dot p|_{\dot u=0} + g(w, p)\right),\qquad
    F_r \mathrel{+}= W_r^T\left(M_b[:, v]\,g_B - [0; 0; K\eta + D\zeta]\right),

:math:`g` the gyroscopic terms above and :math:`g_B` gravity in body
components.  :math:`M_b` is written with the body's numerical invariants
(:class:`kanedyn.modeling.flexible.InertiaInvariants`) as a polynomial of
second degree in :math:`\eta`, its entries named intermediates of the program.
"""

from __future__ import annotations

import numpy as np
import sympy as sm

from .._errors import ModelError
from ..engine import add, cross

__all__ = ["FlexibleTerms", "flexible_terms"]

_DROP = 1e-14  # relative size below which an invariant's entry is zero


class FlexibleTerms:
    """What one flexible body adds to Kane's equations.

    Attributes
    ----------
    body : FlexibleBody
    mass : list of list
        Rows (every speed, auxiliary ones included) by real speeds.
    active, remainder : list
        One per speed (real then auxiliary).
    kinetic : expression
    w : tuple
        Body-frame velocity components :math:`(v, \\omega, \\zeta)`.
    partials : list of tuple
        :math:`W_r`, one per speed.
    """

    __slots__ = ("body", "mass", "active", "remainder", "kinetic", "w", "partials")

    def __init__(self, **fields):
        for name in self.__slots__:
            setattr(self, name, fields[name])


def _coefficient(value, scale):
    # float() first: SymPy converts a NumPy scalar to a Float about twice as slowly
    value = float(value)
    return sm.Float(value) if abs(value) > _DROP * scale else None


def _polynomial(prog, M0, M1, M2, eta, pairs, scale, name):
    """``M0 + sum_i eta_i M1_i + 1/2 sum_ij eta_i eta_j M2_ij`` (a symmetric matrix)."""
    size = M0.shape[0]
    m = len(eta)
    out = [[None] * size for _ in range(size)]
    for a in range(size):
        for b in range(a, size):
            terms = []
            c = _coefficient(M0[a, b], scale)
            if c is not None:
                terms.append(c)
            for i in range(m):
                c = _coefficient(M1[i, a, b], scale)
                if c is not None:
                    terms.append(c * eta[i])
            for (i, j), p in pairs.items():
                value = M2[i, j, a, b] * (0.5 if i == j else 1.0)
                c = _coefficient(value, scale)
                if c is not None:
                    terms.append(c * p)
            out[a][b] = out[b][a] = prog.let(sm.Add(*terms), f"{name}_{a}_{b}")
    return out


def flexible_terms(kin, body, speeds, n_real, aux_zero):
    """Kane's terms of one flexible body (see the module docstring).

    Parameters
    ----------
    kin : Kinematics
    body : FlexibleBody
    speeds : sequence
        Internal speed symbols, real then auxiliary.
    n_real : int
        Number of real speeds (columns of the mass matrix).
    aux_zero : dict
        Auxiliary speeds -> 0.

    Returns
    -------
    FlexibleTerms
    """
    prog, table = kin.prog, kin.table
    where = f"flexible body {body.name}"
    inv = body.invariants
    missing = [s for s in body.q if s not in table.q_ext]
    missing += [s for s in body.u if s not in table.u_ext]
    if missing:
        raise ModelError(
            f"{where}: its modal coordinates and speeds must be among the model's "
            f"coordinates and speeds; missing {', '.join(map(str, missing))} (add body.q to "
            "q_ind, body.u to u_ind and body.kd_eqs to kd_eqs)")
    eta = [table.internal(s, where) for s in body.q]
    zeta = [table.internal(s, where) for s in body.u]
    m = len(eta)

    C = kin.dcm(body.frame)
    v_N = kin.velocity(body.origin)
    w_N = kin.angular_velocity(body.frame)

    def to_body(vec, name):
        return tuple(prog.let(sum(C[i, a] * vec[i] for i in range(3)), f"{name}_{a}")
                     for a in range(3))

    v = to_body(v_N, f"vB_{body.name}")
    om = to_body(w_N, f"wB_{body.name}")
    w_full = list(v) + list(om) + list(zeta)
    w = [prog.subs(c, aux_zero) for c in w_full]
    partials = [tuple(prog.subs(prog.diff(c, s), aux_zero) for c in w_full) for s in speeds]

    pairs = {(i, j): prog.let(eta[i] * eta[j], f"ee_{body.name}")
             for i in range(m) for j in range(i, m)}
    scale = max(np.max(np.abs(inv.M0)), 1e-300)
    Mb = _polynomial(prog, inv.M0, inv.M1, inv.M2, eta, pairs, scale, f"Mb_{body.name}")
    size = 6 + m
    p = [prog.let(sm.Add(*[Mb[a][b] * w[b] for b in range(size) if Mb[a][b] != 0]),
                  f"p_{body.name}") for a in range(size)]
    dp = [prog.subs(kin.dt(c), aux_zero) for c in p]
    pv, pw = p[:3], p[3:6]
    vv, ww = w[:3], w[3:6]
    gyro = list(cross(ww, pv)) + list(add(cross(ww, pw), cross(vv, pv)))
    dT = []
    for i in range(m):
        dM = [[sm.Float(inv.M1[i, a, b]) + sum(sm.Float(inv.M2[i, j, a, b]) * eta[j]
                                               for j in range(m) if inv.M2[i, j, a, b] != 0)
               for b in range(size)] for a in range(size)]
        dT.append(sm.Add(*[w[a] * dM[a][b] * w[b] / 2 for a in range(size)
                           for b in range(size) if dM[a][b] != 0]))
    rest = [prog.let(dp[a] + (gyro[a] if a < 6 else -dT[a - 6]), f"nb_{body.name}")
            for a in range(size)]

    # active: gravity (the frame's columns of M_b times g in body components), elastic
    # and damping forces on the modal coordinates
    active_b = [sm.S.Zero] * size
    if body.gravity is not None:
        g_N = kin.vector(body.gravity, f"{where}: gravity")
        g_B = [sum(C[i, a] * g_N[i] for i in range(3)) for a in range(3)]
        active_b = [sm.Add(*[Mb[a][b] * g_B[b] for b in range(3)]) for a in range(size)]
    K, D = inv.stiffness, body.damping
    kscale = max(np.max(np.abs(K)), np.max(np.abs(D)), 1e-300)
    for i in range(m):
        elastic = [c * eta[j] for j in range(m)
                   if (c := _coefficient(K[i, j], kscale)) is not None]
        elastic += [c * w[6 + j] for j in range(m)
                    if (c := _coefficient(D[i, j], kscale)) is not None]
        active_b[6 + i] = active_b[6 + i] - sm.Add(*elastic)
    active_b = [prog.let(c, f"Fb_{body.name}") if c != 0 else c for c in active_b]

    def project(W, vec):
        return sm.Add(*[W[a] * vec[a] for a in range(size) if W[a] != 0 and vec[a] != 0])

    MW = {}
    for s in range(n_real):
        if any(c != 0 for c in partials[s]):
            MW[s] = [prog.let(sm.Add(*[Mb[a][b] * partials[s][b] for b in range(size)
                                       if partials[s][b] != 0]), f"MW_{body.name}")
                     for a in range(size)]
    mass = [[project(partials[r], MW[s]) if s in MW else sm.S.Zero for s in range(n_real)]
            for r in range(len(speeds))]
    active = [project(partials[r], active_b) for r in range(len(speeds))]
    remainder = [project(partials[r], rest) for r in range(len(speeds))]
    kinetic = sm.Add(*[w[a] * p[a] for a in range(size)]) / 2
    return FlexibleTerms(body=body, mass=mass, active=active, remainder=remainder,
                         kinetic=kinetic, w=tuple(w), partials=partials)
