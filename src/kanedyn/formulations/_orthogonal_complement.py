r"""The natural orthogonal complement (Angeles & Lee 1988; Cyril, Angeles & Misra 1991).

Every body :math:`b` is first an unconstrained rigid body with the twist
:math:`t_b = [\omega_b;\ v_b]` (angular velocity, mass-centre velocity,
inertial components) and the Newton–Euler equations

.. math::

    M_b\,\dot t_b = w_b^A + w_b^C - W_b M_b t_b,\qquad
    M_b = \begin{bmatrix} I_b & 0\\ 0 & m_b 1\end{bmatrix},\qquad
    W_b M_b t_b = \begin{bmatrix}\omega_b\times I_b\omega_b\\ 0\end{bmatrix},

with the applied wrench :math:`w_b^A` (moment about the mass centre, then
force) and the unknown constraint wrench :math:`w_b^C`.  The kinematic
constraints of the joints are :math:`t = T u`, :math:`T = [T_1; \dots; T_n]`
(:math:`6n\times o`): the columns of :math:`T_b` are the partial angular
velocities and partial velocities of body :math:`b`.  :math:`T` spans the
motions the joints allow, so it is an orthogonal complement of the joint
constraints, and the constraint wrenches do no work on it,
:math:`T^T w^C = 0`.  With :math:`\dot t_b = T_b\dot u + \dot T_b u`,
multiplying the stacked Newton–Euler equations by :math:`T^T` eliminates
them:

.. math::

    \underbrace{\sum_b T_b^T M_b T_b}_{M}\ \dot u
    = \underbrace{\sum_b T_b^T\left(w_b - M_b\,\dot T_b u\right) + Q}_{f},
    \qquad w_b = w_b^A - W_b M_b t_b ,

where :math:`Q` collects the generalized forces of loads that act on no
single body (points or frames whose motion is not that of a body, e.g. a
point with an auxiliary velocity), :math:`\sum F\cdot\partial v_P/\partial
u`.  Closed loops and nonholonomic constraints add :math:`B u + b = 0`
(dependent speeds :math:`u_d`); their complement :math:`N = [1; X]`,
:math:`X = -K_d^{-1}K_i` from the acceleration constraints :math:`K\dot u +
f_a = 0`, reduces the equations to the symmetric positive definite system

.. math::

    N^T M N\,\dot u_i = N^T\left(f - M\dot u_p\right),\qquad
    \dot u_p = \begin{bmatrix}0\\ -K_d^{-1}f_a\end{bmatrix},\qquad
    \dot u_d = X\dot u_i - K_d^{-1}f_a ,

solved by Cholesky's factorization (as in Cyril et al., who integrated the
result with Gear's BDF method: ``kd.simulate(..., method="BDF")``).

Flexible bodies
---------------
A :class:`kanedyn.FlexibleBody` is a block of its own size :math:`6 + m` in
body-frame components :math:`w_b = (v, \omega, \zeta)` (origin velocity,
angular velocity, modal speeds): its twist map :math:`T_b = \partial
w_b/\partial u`, :math:`\dot T_b u = \dot w_b|_{\dot u = 0}`, the generalized
mass :math:`M_b(\eta)` from the inertia invariants and
:math:`w_b = F_b - \beta_b`, the applied forces (gravity, elastic, damping)
less the velocity terms of Lagrange's equations in quasi-coordinates (see
:mod:`kanedyn.formulations._flexible`, shared with Kane's method).  They are
assembled like the rigid bodies' blocks.

What is symbolic and what is numeric
------------------------------------
* Symbolic (straight-line program, shared intermediates): the per-body
  blocks :math:`T_b` (:math:`6\times o`), :math:`\dot T_b u` (6),
  :math:`M_b` (:math:`6\times 6`, inertia in inertial components, a function
  of :math:`q`) and :math:`w_b` (6), the generalized forces :math:`Q`, and,
  for the :class:`EquationsOfMotion` contract, the products
  :math:`\sum_b T_b^T(M_bT_b)` and :math:`\sum_b T_b^T(\cdot)` as named
  intermediates (``eom.mass_matrix``, ``eom.forcing``,
  ``eom.operation_counts()`` and the symbolic linearization use these).
* Numeric (:class:`kanedyn.schemes.OrthogonalComplement`, the scheme of these
  equations): the
  generated ``dynamics`` function of the numerical model evaluates only the
  blocks and assembles :math:`M = T^T\,\mathrm{blkdiag}(M_b)\,T` and
  :math:`f` with NumPy matrix products; the scheme eliminates the dependent
  speeds with :math:`N` and solves by Cholesky.

Coordinates, speeds, dependent speeds, velocity and vector constraints,
potential energy and auxiliary speeds follow Kane's conventions, so
:func:`kanedyn.simulate`, :func:`kanedyn.check_newton_euler` and
:meth:`NumericModel.multipliers` work unchanged.
"""

from __future__ import annotations

import sympy as sm
import sympy.physics.mechanics as me

from ._flexible import BLOCK_BODIES, flexible_bodies, flexible_terms
from ._kane import (BodyTerms, _contact_terms, _drop_workless, constraint_terms, kane_setup,
                    kinetic_term, potential_term)
from ..engine import SAMPLE_SEEDS, PartialVelocities, add, cross, dot, inertia_components, matvec
from .._progress import NO_PROGRESS

__all__ = ["derive_orthogonal_complement"]

_ZERO3 = (sm.S.Zero,) * 3


# ---------------------------------------------------------------- symbolic
def _same(prog, a, b):
    """Whether two component tuples are identical (random points, relative 1e-9)."""
    for seed in SAMPLE_SEEDS:
        va, vb = prog.shadow(a, seed), prog.shadow(b, seed)
        if any(v != v for v in list(va) + list(vb)):  # nan: cannot decide
            return False
        scale = 1.0 + max(abs(x) for x in list(va) + list(vb))
        if any(not abs(x - y) <= 1e-9 * scale for x, y in zip(va, vb)):
            return False
    return True


def _owner(kin, bodies, location, raw):
    """The body a load acts on: ``(index, lever arm)``, ``"ground"`` or ``None``.

    A frame belongs to a rigid body whose frame it is or whose angular
    velocity it shares; a point to the body whose mass centre it is, or a
    rigid body in which it is fixed (:math:`v_P = v_G + \\omega\\times r`),
    or a particle whose velocity it shares.  Velocities are compared with the
    auxiliary speeds included.  ``"ground"``: the location does not move
    (no generalized force); ``None``: no single body (the load's generalized
    forces are then formed from its own partial velocities).
    """
    prog = kin.prog
    if isinstance(location, me.ReferenceFrame):
        for k, (b, _, _) in enumerate(raw):
            if isinstance(b, me.RigidBody) and b.frame is location:
                return k, None
        w_loc = kin.angular_velocity(location)
        if all(c == 0 for c in w_loc) or _same(prog, w_loc, _ZERO3):
            return "ground"
        for k, (b, _, w) in enumerate(raw):
            if isinstance(b, me.RigidBody) and _same(prog, w_loc, w):
                return k, None
        return None
    for k, (b, _, _) in enumerate(raw):
        if b.masscenter is location:
            return k, None
    v_loc = kin.velocity(location)
    if all(c == 0 for c in v_loc) or _same(prog, v_loc, _ZERO3):
        return "ground"
    for k, (b, v, w) in enumerate(raw):
        if isinstance(b, me.RigidBody):
            r = kin.position(location, b.masscenter)
            if r is not None and _same(prog, v_loc, add(v, cross(w, r))):
                return k, r
        elif _same(prog, v_loc, v):
            return k, None
    return None


class _Blocks:
    """Per-body NOC blocks as program expressions (real speeds only).

    Rigid bodies and particles: ``T``: ``6 n_b x o`` row-major list;
    ``Tdu``, ``w``: ``6 n_b``; ``Mb``: ``36 n_b`` (``n_b`` row-major 6 x 6
    blocks); ``Q``: ``o``.  Flexible bodies, in body-frame components
    :math:`(v, \\omega, \\zeta)`, block ``k`` of size ``sizes[k]`` (6 plus
    its modes): ``TF``: ``sum(sizes) x o``; ``TduF``, ``wF``: ``sum(sizes)``;
    ``MbF``: the row-major ``sizes[k] x sizes[k]`` blocks one after another.
    """

    __slots__ = ("T", "Tdu", "Mb", "w", "Q", "n_bodies", "TF", "TduF", "MbF", "wF", "sizes")

    def __init__(self, **fields):
        for name in self.__slots__:
            setattr(self, name, fields[name])


def derive_orthogonal_complement(spec, progress=NO_PROGRESS, explicit_kinematics=True):
    r"""Equations of motion by the natural orthogonal complement.

    Parameters
    ----------
    spec : ModelSpec
        The parsed model (see :func:`kanedyn.formulate`).
    progress : Progress
    explicit_kinematics : bool
        As for :func:`kanedyn.kane`.

    Returns
    -------
    EquationsOfMotion
        ``method="orthogonal-complement"``; its scheme is
        :class:`OrthogonalComplement` (numerical assembly of the per-body
        blocks, Cholesky solution).  The symbolic fields hold
        :math:`M = \sum_b T_b^T M_b T_b` and
        :math:`f = \sum_b T_b^T(w_b - M_b\dot T_b u) + Q` as intermediates.
    """
    from ._eom import EquationsOfMotion

    table, prog, kin, qdot, kin_matrices = kane_setup(spec, progress)
    speeds = table.u + table.u_aux
    o, s_aux = len(table.u), len(table.u_aux)
    n_all = o + s_aux
    aux_zero = {ua: 0 for ua in table.u_aux}

    def partials(vec):
        return PartialVelocities(prog, vec, speeds, aux_zero)

    def no_aux(vec):
        return tuple(prog.subs(c, aux_zero) for c in vec)

    # ------------------------------------------------ per-body blocks
    flexible_list = flexible_bodies(spec)
    bodies = [b for b in spec.bodies if not isinstance(b, BLOCK_BODIES)]
    raw, body_terms, masses, inertias, tdu, gyro, momenta = [], [], [], [], [], [], []
    for k, body in enumerate(bodies):
        progress.update(f"twist map of {body.name} ({k + 1}/{len(bodies)})",
                        (k + 1) / max(len(bodies), 1))
        m = prog.let(kin.internal(body.mass, f"mass of {body.name}"), f"m_{body.name}")
        rigid = isinstance(body, me.RigidBody)
        v = kin.velocity(body.masscenter)
        w = kin.angular_velocity(body.frame) if rigid else _ZERO3
        raw.append((body, v, w))
        v0, w0 = no_aux(v), no_aux(w)
        terms = BodyTerms(body, v0, w0, partials(v), partials(w))
        # twist rate with u' = 0: (alpha0, a0) = T_b' u
        a0 = kin.let_vector(kin.dt_vector(v0), f"a0_{body.name}")
        mdot = kin.dt(m)
        rate_force = tuple(mdot * c for c in v0)  # variable mass: m' v
        if rigid:
            alpha0 = kin.let_vector(kin.dt_vector(w0), f"alpha0_{body.name}")
            I_B, I_N, C = inertia_components(kin, body, f"body {body.name}")
            H = kin.let_vector(matvec(I_N, w0), f"H_{body.name}")
            g_torque = cross(w0, H)  # W_b M_b t_b
            I_B_dot = I_B.applyfunc(kin.dt)
            if any(I_B_dot):  # inertia changing in the body frame
                g_torque = add(g_torque, tuple(C * (I_B_dot * (C.T * sm.Matrix(w0)))))
        else:
            alpha0, I_N, H, g_torque = _ZERO3, None, _ZERO3, _ZERO3
        body_terms.append(terms)
        masses.append(m)
        inertias.append(I_N)
        tdu.append(alpha0 + a0)
        gyro.append(kin.let_vector(g_torque, f"g_{body.name}")
                    + kin.let_vector(rate_force, f"mr_{body.name}"))
        momenta.append(H)
    progress.done()
    flexible = []
    for k, body in enumerate(flexible_list):
        progress.update(f"twist map of flexible body {body.name} ({k + 1}/{len(flexible_list)})",
                        (k + 1) / len(flexible_list))
        flexible.append(flexible_terms(kin, body, speeds, o, aux_zero))
    if flexible:
        progress.done()

    def T_col(k, s):
        """Column ``s`` of T_b (6 entries: angular, then linear)."""
        t = body_terms[k]
        return tuple(t.partial_angular_velocities[s]) + tuple(t.partial_velocities[s])

    def M_times(k, vec6):
        """M_b times a 6-vector (inertia on the angular part, mass on the linear)."""
        I_N = inertias[k]
        ang = matvec(I_N, vec6[:3]) if I_N is not None else _ZERO3
        return tuple(ang) + tuple(masses[k] * c for c in vec6[3:])

    # --------------------------------------------------- applied wrenches
    progress.stage("wrenches")
    wrench = [[sm.S.Zero] * 6 for _ in bodies]
    extra = [sm.S.Zero] * n_all  # generalized forces of loads on no single body
    load_list = []
    for load in spec.loads:
        loc = load.location
        frame_load = isinstance(loc, me.ReferenceFrame)
        kind = "T" if frame_load else "F"
        vec = kin.let_vector(kin.vector(load.vector, f"load on {loc}"), f"{kind}_{loc}")
        load_list.append((loc, vec, None))
        if all(c == 0 for c in vec):
            continue
        owner = _owner(kin, bodies, loc, raw)
        if owner == "ground":
            continue
        if owner is None:
            base = kin.angular_velocity(loc) if frame_load else kin.velocity(loc)
            for r, part in enumerate(partials(base)):
                extra[r] += dot(vec, part)
            continue
        k, lever = owner
        moment = vec if frame_load else (cross(lever, vec) if lever is not None else _ZERO3)
        force = _ZERO3 if frame_load else vec
        wrench[k] = [a + b for a, b in zip(wrench[k], tuple(moment) + tuple(force))]
    applied = [kin.let_vector(w6[:3], f"nA_{b.name}") + kin.let_vector(w6[3:], f"fA_{b.name}")
               for w6, b in zip(wrench, bodies)]
    extra = [prog.let(e, "Q") for e in extra]

    # ----------------------------------------- symbolic products (contract)
    progress.stage("mass matrix and forcing: sum of T_b^T M_b T_b")
    mass_terms = [[[] for _ in range(o)] for _ in range(n_all)]
    active_terms = [[e] for e in extra]
    remainder_terms = [[] for _ in range(n_all)]
    for k, body in enumerate(bodies):
        cols = [T_col(k, s) for s in range(n_all)]
        nonzero = [any(c != 0 for c in col) for col in cols]
        MT = {s: kin.let_vector(M_times(k, cols[s])[:3], "MTw")
              + kin.let_vector(M_times(k, cols[s])[3:], "MTv")
              for s in range(o) if nonzero[s]}
        inertia_bias = M_times(k, tdu[k])  # M_b T_b' u
        bias = tuple(prog.let(a + g, f"bias_{body.name}")
                     for a, g in zip(inertia_bias, gyro[k]))
        for r in range(n_all):
            if not nonzero[r]:
                continue
            first = r if r < o else 0  # real rows: upper triangle, mirrored
            for s, mt in MT.items():
                if s >= first:
                    mass_terms[r][s].append(sm.Add(*[a * b for a, b in zip(cols[r], mt)]))
            active_terms[r].append(sm.Add(*[a * b for a, b in zip(cols[r], applied[k])]))
            remainder_terms[r].append(sm.Add(*[a * b for a, b in zip(cols[r], bias)]))
    for terms in flexible:  # T_b^T M_b T_b etc. of the flexible bodies' blocks
        for r in range(n_all):
            for s in range(r if r < o else 0, o):
                mass_terms[r][s].append(terms.mass[r][s])
            active_terms[r].append(terms.active[r])
            remainder_terms[r].append(terms.remainder[r])
    mass_rows = []
    for r in range(n_all):
        row = [prog.let(sm.Add(*mass_terms[r][s]), f"M_{r}_{s}") for s in range(o)]
        if r < o:
            for s in range(r):
                row[s] = mass_rows[s][r]
        mass_rows.append(row)
    fr = [prog.let(prog.subs(sm.Add(*t), aux_zero), f"Fr_{r}")
          for r, t in enumerate(active_terms)]
    before = set().union(*(prog.deps(e) for e in fr[:o])) if o else set()
    fr[:o] = _drop_workless(prog, table, fr[:o], load_list, fr[o:])
    after = set().union(*(prog.deps(e) for e in fr[:o])) if o else set()
    state = set(table.q) | set(table.u) | set(table.u_aux) | {table.t}
    # force magnitudes that do no work on the real motion: dropped from the real
    # rows, or absent there from the start (a force on a body whose real partial
    # velocities vanish, seen by the auxiliary rows only)
    in_loads = set().union(*(prog.deps(c) for _, vec, _ in load_list for c in vec))
    in_aux = set().union(*(prog.deps(e) for e in fr[o:]))
    dropped = {s: 0 for s in (before | in_aux) - after
               if s in in_loads and s not in state and not prog.is_intermediate(s)}
    nonmm = [prog.let(prog.subs(sm.Add(*t), aux_zero), f"n_{r}")
             for r, t in enumerate(remainder_terms)]

    # numeric blocks (real speeds), workless force magnitudes removed from the
    # applied forces
    def real(e):
        return prog.subs(prog.subs(e, aux_zero), dropped) if dropped else prog.subs(e, aux_zero)

    T_flat, Tdu_flat, Mb_flat, w_flat = [], [], [], []
    for k in range(len(bodies)):
        cols = [T_col(k, s) for s in range(o)]
        for i in range(6):
            T_flat.extend(cols[s][i] for s in range(o))
        Tdu_flat.extend(tdu[k])
        I_N = inertias[k]
        for i in range(6):
            for j in range(6):
                if i < 3 and j < 3:
                    Mb_flat.append(I_N[i][j] if I_N is not None else sm.S.Zero)
                else:
                    Mb_flat.append(masses[k] if i == j and i >= 3 else sm.S.Zero)
        w_flat.extend(prog.let(real(a) - prog.subs(g, aux_zero), "w")
                      for a, g in zip(applied[k], gyro[k]))
    TF, TduF, MbF, wF = [], [], [], []
    for terms in flexible:
        block = terms.block
        for i in range(block.size):
            TF.extend(block.partials[s][i] for s in range(o))
        TduF.extend(block.rate)
        MbF.extend(e for row in block.mass for e in row)
        wF.extend(prog.let(real(a) - b, "wF") for a, b in zip(block.active, block.bias))
    blocks = _Blocks(T=tuple(T_flat), Tdu=tuple(Tdu_flat), Mb=tuple(Mb_flat),
                     w=tuple(w_flat), Q=tuple(prog.let(real(e), "Q") for e in extra[:o]),
                     n_bodies=len(bodies), TF=tuple(TF), TduF=tuple(TduF), MbF=tuple(MbF),
                     wF=tuple(wF), sizes=tuple(t.block.size for t in flexible))

    # ----------------------------------------------------- constraints
    progress.stage("constraints")
    config, vel_c, vel_B, acc_K, acc_f, identified, names = constraint_terms(
        kin, spec, aux_zero)

    # ------------------------------------------------------- energies
    kinetic = kinetic_term(prog, body_terms, masses, momenta, flexible)
    potential = potential_term(kin, spec)

    contacts = tuple(_contact_terms(kin, c, table.u, aux_zero) for c in spec.contacts)
    aux_K = tuple(tuple(-mass_rows[o + a][s] for s in range(o)) for a in range(s_aux))
    aux_f = tuple(prog.let(fr[o + a] - nonmm[o + a], f"aux_{a}") for a in range(s_aux))
    # inertia force and torque with u' = 0 (the Newton-Euler check uses them)
    inertial = tuple((tuple(prog.let(a + g, "Fi") for a, g in
                            zip(M_times(k, tdu[k])[3:], gyro[k][3:])),
                      tuple(prog.let(a + g, "Ti") for a, g in
                            zip(M_times(k, tdu[k])[:3], gyro[k][:3])))
                     for k in range(len(bodies)))

    progress.stage(f"done: {len(prog)} intermediates")
    eom = EquationsOfMotion._from_derivation(
        spec=spec, program=prog, table=table, kinematics=kin,
        explicit_kinematics=explicit_kinematics,
        qdot=qdot, kinematic_matrices=kin_matrices,
        mass=tuple(tuple(row) for row in mass_rows[:o]),
        active=tuple(fr[:o]), remainder=tuple(nonmm[:o]),
        vel_B=vel_B, vel_c=vel_c, acc_K=acc_K, acc_f=acc_f, config=config,
        aux_K=aux_K, aux_f=aux_f, kinetic=kinetic, potential=potential,
        body_terms=tuple(body_terms), inertial=inertial,
        load_vectors=tuple((loc, vec) for loc, vec, _ in load_list),
        identified=identified, multiplier_names=names,
        contact_terms=contacts, method="orthogonal-complement")
    # set once, before anyone sees the result (as formulate does for schemes)
    object.__setattr__(eom, "_noc_blocks", blocks)
    object.__setattr__(eom, "_scheme", "orthogonal-complement")
    return eom
