r"""Flexible bodies in the formulations, from their inertia invariants.

For a :class:`kanedyn.FlexibleBody` with body-frame velocity components
:math:`w = (v, \omega, \zeta)` (origin velocity, angular velocity, modal speeds)
and kinetic energy :math:`T = \tfrac12 w^TM_b(\eta)w`, Lagrange's equations in
quasi-coordinates give the body's inertia forces

.. math::

    -F^*_b = M_b\dot w + \beta,\qquad
    \beta = \dot M_b w + \begin{bmatrix}
        \omega\times p_v \\
        \omega\times p_\omega + v\times p_v \\
        - \partial T/\partial\eta
    \end{bmatrix},\qquad p = M_b w ,

and the applied forces in the same components

.. math::

    F_b = \begin{bmatrix} m g_B \\ c(\eta)\times g_B \\
        (\partial c/\partial\eta)^T g_B - K\eta - D\zeta\end{bmatrix},

:math:`g_B` gravity in body components, :math:`c(\eta)` the first moment of
mass about the origin (gravity is the gradient of its potential).  One body's *block*
(:func:`flexible_block`) holds :math:`w`, its twist map
:math:`T_b = \partial w/\partial u` (the partial velocities, one column per
speed), :math:`\dot T_b u = \dot w|_{\dot u=0}`, :math:`M_b`, :math:`\beta`
and :math:`F_b`.  The formulations use it as follows.

* Kane's method (:func:`flexible_terms`): with :math:`W_r` the columns of
  :math:`T_b`, :math:`F^*_r = W_r^T F^*_b`:

  .. math::

      M_{rs} \mathrel{+}= W_r^TM_bW_s,\qquad
      n_r \mathrel{+}= W_r^T\left(M_b\dot T_b u + \beta\right),\qquad
      F_r \mathrel{+}= W_r^TF_b .

* The natural orthogonal complement: the block joins the rigid bodies'
  Newton–Euler blocks, :math:`M \mathrel{+}= T_b^TM_bT_b`, :math:`f
  \mathrel{+}= T_b^T(F_b - \beta - M_b\dot T_b u)`.
* Lagrange's equations: :math:`T` joins the kinetic energy (mass matrix and
  velocity terms follow from its derivatives) and :math:`W_r^TF_b` the
  generalized forces (``inertia=False``: no :math:`\beta`).

:math:`M_b` is written with the body's numerical invariants
(:class:`kanedyn.modeling.flexible.InertiaInvariants`) as a polynomial of
second degree in :math:`\eta`, its entries named intermediates of the program.

Generalized-inertia elements (:class:`kanedyn.RateInertia`,
:class:`kanedyn.Inerter`, :class:`kanedyn.AddedMass`) are blocks of the same
kind (:func:`inertial_block`): :math:`w` their rates, :math:`T_b = \partial
w/\partial u`, :math:`M_b = M_w` constant, :math:`\beta = 0` and
:math:`F_b = 0`.  :func:`flexible_bodies` returns both kinds and
:func:`flexible_block` builds either.
"""

from __future__ import annotations

import numpy as np
import sympy as sm

from .._errors import ModelError
from ..engine import add, cross
from ..modeling import FlexibleBody, InertialElement

__all__ = ["BLOCK_BODIES", "FlexibleBlock", "FlexibleTerms", "flexible_block",
           "flexible_bodies", "flexible_terms", "inertial_block", "project"]

BLOCK_BODIES = (FlexibleBody, InertialElement)  # bodies that reduce to a block

_DROP = 1e-14  # relative size below which an invariant's entry is zero


class FlexibleBlock:
    r"""One flexible body's quantities in body-frame components (size :math:`6 + m`).

    Attributes
    ----------
    body : FlexibleBody
    w : tuple
        :math:`(v, \omega, \zeta)`, auxiliary speeds zero.
    partials : list of tuple
        :math:`W_r = \partial w/\partial u_r`, one per speed (the columns of
        the twist map :math:`T_b`).
    mass : list of list
        :math:`M_b(\eta)`, symmetric.
    momentum : list
        :math:`p = M_bw`.
    kinetic : expression
        :math:`\tfrac12 w^Tp`.
    active : list
        :math:`F_b`: gravity, elastic and damping forces.
    rate, bias : list or None
        :math:`\dot T_bu = \dot w|_{\dot u = 0}` and the velocity terms
        :math:`\beta` (``None`` when built with ``inertia=False``).
    """

    __slots__ = ("body", "w", "partials", "mass", "momentum", "kinetic", "active", "rate",
                 "bias")

    def __init__(self, **fields):
        for name in self.__slots__:
            setattr(self, name, fields[name])

    @property
    def size(self):
        """:math:`6 + m`."""
        return len(self.w)


class FlexibleTerms:
    """What one flexible body adds to Kane's equations.

    Attributes
    ----------
    body : FlexibleBody
    block : FlexibleBlock
    mass : list of list
        Rows (every speed, auxiliary ones included) by real speeds.
    active, remainder : list
        One per speed (real then auxiliary).
    kinetic : expression
    """

    __slots__ = ("body", "block", "mass", "active", "remainder", "kinetic")

    def __init__(self, **fields):
        for name in self.__slots__:
            setattr(self, name, fields[name])


def flexible_bodies(spec):
    """The model's flexible bodies and inertial elements (block bodies), checked.

    Parameters
    ----------
    spec : ModelSpec

    Returns
    -------
    list of FlexibleBody or InertialElement

    Raises
    ------
    ModelError
        A body's modal coordinates or speeds are not among the model's.
    """
    out = [b for b in spec.bodies if isinstance(b, BLOCK_BODIES)]
    for body in out:
        if not isinstance(body, FlexibleBody):
            continue
        missing = [s for s in body.q if s not in spec.q]
        missing += [s for s in body.u if s not in spec.u]
        if missing:
            raise ModelError(
                f"flexible body {body.name}: its modal coordinates and speeds must be among "
                f"the model's coordinates and speeds; missing {', '.join(map(str, missing))} "
                "(add body.q to q_ind, body.u to u_ind and body.kd_eqs to kd_eqs)")
    return out


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


def _gravity(inv, eta, g_B):
    r"""Gravity's forces in body components, the gradient of its potential energy.

    With the first moment of mass :math:`c(\eta) = c_0 + c_1\eta +
    \tfrac12 c_2\eta\eta` (of the interpolated displacement field) and
    :math:`V = -g\cdot(m\,r_O + c)`: :math:`m g_B` on the origin,
    :math:`c\times g_B` about it and :math:`(\partial c/\partial\eta)^Tg_B`
    on the modal coordinates, so that gravity does exactly the work its
    potential (:meth:`FlexibleBody.gravitational_energy`) loses.
    """
    c, gradient = inv.first_moment_of(eta)
    force = [sm.Float(inv.mass) * g for g in g_B]
    torque = list(cross(c, g_B))
    modal = [sm.Add(*[gradient[a][i] * g_B[a] for a in range(3)]) for i in range(len(eta))]
    return force + torque + modal


def flexible_block(kin, body, speeds, aux_zero, inertia=True):
    r"""The :class:`FlexibleBlock` of one body (see the module docstring).

    Parameters
    ----------
    kin : Kinematics
    body : FlexibleBody
        Checked by :func:`flexible_bodies`.
    speeds : sequence
        Internal speed symbols for the partial velocities.
    aux_zero : dict
        Auxiliary speeds -> 0.
    inertia : bool
        Also form :math:`\dot T_bu` and the velocity terms :math:`\beta`.

    Returns
    -------
    FlexibleBlock
    """
    if isinstance(body, InertialElement):
        return inertial_block(kin, body, speeds, aux_zero, inertia)
    prog, table = kin.prog, kin.table
    where = f"flexible body {body.name}"
    inv = body.invariants
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
    kinetic = sm.Add(*[w[a] * p[a] for a in range(size)]) / 2

    # active: gravity, elastic and damping forces on the modal coordinates
    active = [sm.S.Zero] * size
    if body.gravity is not None:
        g_N = kin.vector(body.gravity, f"{where}: gravity")
        g_B = [sum(C[i, a] * g_N[i] for i in range(3)) for a in range(3)]
        active = _gravity(inv, eta, g_B)
    K, D = inv.stiffness, body.damping
    kscale = max(np.max(np.abs(K)), np.max(np.abs(D)), 1e-300)
    for i in range(m):
        elastic = [c * eta[j] for j in range(m)
                   if (c := _coefficient(K[i, j], kscale)) is not None]
        elastic += [c * w[6 + j] for j in range(m)
                    if (c := _coefficient(D[i, j], kscale)) is not None]
        active[6 + i] = active[6 + i] - sm.Add(*elastic)
    active = [prog.let(c, f"Fb_{body.name}") if c != 0 else c for c in active]

    rate = bias = None
    if inertia:
        rate = [prog.let(prog.subs(kin.dt(c), aux_zero), f"wd_{body.name}") for c in w]
        # M_b' w (M_b depends on eta alone), and dT/deta with w held fixed
        mdot = [[prog.subs(kin.dt(Mb[a][b]), aux_zero) for b in range(size)]
                for a in range(size)]
        dT = [sm.Add(*[w[a] * prog.diff(Mb[a][b], e) * w[b] for a in range(size)
                       for b in range(size) if Mb[a][b] != 0]) / 2 for e in eta]
        vv, ww, pv, pw = w[:3], w[3:6], p[:3], p[3:6]
        gyro = list(cross(ww, pv)) + list(add(cross(ww, pw), cross(vv, pv)))
        gyro += [-d for d in dT]
        bias = [prog.let(sm.Add(*[mdot[a][b] * w[b] for b in range(size) if mdot[a][b] != 0])
                         + gyro[a], f"beta_{body.name}") for a in range(size)]
    return FlexibleBlock(body=body, w=tuple(w), partials=partials, mass=Mb, momentum=p,
                         kinetic=kinetic, active=active, rate=rate, bias=bias)


def inertial_block(kin, element, speeds, aux_zero, inertia=True):
    r"""The :class:`FlexibleBlock` of a generalized-inertia element.

    :math:`w` the element's rates, :math:`M_b = M_w` (constant), no applied
    forces, and velocity terms :math:`\beta = 0` for rates that are time
    derivatives (:math:`\dot M_w = 0`); an :class:`kanedyn.AddedMass`, whose
    rates are body-frame components, has the gyroscopic terms of a rigid
    body's block, :math:`\beta = (\omega\times p_v,\ \omega\times p_\omega +
    v\times p_v)`.

    Parameters
    ----------
    kin : Kinematics
    element : InertialElement
    speeds : sequence
        Internal speed symbols for the partial velocities.
    aux_zero : dict
        Auxiliary speeds -> 0.
    inertia : bool
        Also form :math:`\dot T_bu` (with :math:`\dot u = 0`).

    Raises
    ------
    ModelError
        A rate is not linear in the speeds (naming the element and the rate).
    """
    prog = kin.prog
    where = f"{type(element).__name__} {element.name!r}"
    name = element.name
    w_full = [prog.let(c, f"w_{name}") for c in element._rates(kin)]
    size = len(w_full)
    w = [prog.subs(c, aux_zero) for c in w_full]
    partials = [tuple(prog.subs(prog.diff(c, s), aux_zero) for c in w_full) for s in speeds]
    for i in range(size):
        for col in partials:
            if col[i] != 0 and any(prog.diff(col[i], s) != 0 for s in speeds):
                raise ModelError(f"{where}: rate {i} is not linear in the generalized "
                                 "speeds (its partial velocities depend on the speeds)")
    M = element.inertia
    Mb = [[kin.internal(M[a, b], f"{where}: inertia") for b in range(size)]
          for a in range(size)]
    Mb = [[prog.let(e, f"Mw_{name}_{a}_{b}") if e != 0 and not e.is_Number else e
           for b, e in enumerate(row)] for a, row in enumerate(Mb)]
    p = [prog.let(sm.Add(*[Mb[a][b] * w[b] for b in range(size) if Mb[a][b] != 0]),
                  f"p_{name}") for a in range(size)]
    kinetic = sm.Add(*[w[a] * p[a] for a in range(size)]) / 2
    zero = [sm.S.Zero] * size
    rate = bias = None
    if inertia:
        rate = [prog.let(prog.subs(kin.dt(c), aux_zero), f"wd_{name}") for c in w]
        bias = [prog.let(c, f"beta_{name}") if c != 0 else c
                for c in element._bias(w, p, cross)]
    return FlexibleBlock(body=element, w=tuple(w), partials=partials, mass=Mb, momentum=p,
                         kinetic=kinetic, active=list(zero), rate=rate, bias=bias)


def project(W, vec):
    """:math:`W^Tx` for two sequences of expressions, zeros skipped."""
    return sm.Add(*[a * b for a, b in zip(W, vec) if a != 0 and b != 0])


def flexible_terms(kin, body, speeds, n_real, aux_zero):
    """Kane's terms of one flexible body (see the module docstring).

    Parameters
    ----------
    kin : Kinematics
    body : FlexibleBody
        Checked by :func:`flexible_bodies`.
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
    prog = kin.prog
    block = flexible_block(kin, body, speeds, aux_zero)
    Mb, partials, size = block.mass, block.partials, block.size
    rest = [prog.let(sm.Add(*[Mb[a][b] * block.rate[b] for b in range(size)
                              if Mb[a][b] != 0 and block.rate[b] != 0]) + block.bias[a],
                     f"nb_{body.name}") for a in range(size)]
    MW = {}
    for s in range(n_real):
        if any(c != 0 for c in partials[s]):
            MW[s] = [prog.let(sm.Add(*[Mb[a][b] * partials[s][b] for b in range(size)
                                       if partials[s][b] != 0]), f"MW_{body.name}")
                     for a in range(size)]
    mass = [[project(partials[r], MW[s]) if s in MW else sm.S.Zero for s in range(n_real)]
            for r in range(len(speeds))]
    active = [project(partials[r], block.active) for r in range(len(speeds))]
    remainder = [project(partials[r], rest) for r in range(len(speeds))]
    return FlexibleTerms(body=body, block=block, mass=mass, active=active,
                         remainder=remainder, kinetic=block.kinetic)
