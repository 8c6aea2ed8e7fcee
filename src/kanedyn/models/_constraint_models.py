r"""Models whose joints are vector constraints: the constraint forces are identified.

Each body is free (all its coordinates kept) and every joint, contact or
guide is a :class:`kanedyn.PointVelocity` written as a dot product, so each
multiplier is a named constraint-force magnitude along a known direction
(Roithmayr & Hodges 2013) and :func:`kanedyn.check_newton_euler` verifies
every body's Newton–Euler equations with those forces.  Each model states a
closed form or a hand check of its forces in its docstring.
"""

from __future__ import annotations

import math

import sympy as sm
import sympy.physics.mechanics as me

from ..modeling import PointVelocity
from ._base import ModelDefinition

__all__ = ["rod_bead", "pin_slot", "knife_edge", "rolling_disk_contact", "block_wedge"]

T = me.dynamicsymbols._t


def _rates(q, u):
    """Kinematic differential equations ``q_i' = u_i``."""
    return [a.diff() - b for a, b in zip(q, u)]


def rod_bead():
    r"""A bead on a horizontal rod turning uniformly about the vertical.

    The rod (frame ``A``) turns about ``N.z`` at the prescribed rate
    ``omega`` (rad/s) through the fixed point ``O``; gravity ``g`` (m/s²)
    acts along ``-N.z``.  The bead (mass ``m``, kg) is located by ``r`` along
    the rod and by the dependent offsets ``y, z`` across it (kept zero by the
    configuration constraints); speeds ``u1..u3`` are the rates of ``r, y,
    z`` (``u2, u3`` dependent).  The rod's guide is
    ``PointVelocity(P, [A.y, A.z], relative_to=(A, O))``: the horizontal and
    vertical forces of the rod on the bead, ``N_h`` and ``N_v`` (N).

    Closed form: :math:`r = r_0\cosh\omega t + (v_0/\omega)\sinh\omega t`,
    :math:`N_h = 2 m\omega\dot r` (Coriolis), :math:`N_v = m g`.
    """
    r, y, z = me.dynamicsymbols("r y z")
    u = me.dynamicsymbols("u1:4")
    m, omega, g = sm.symbols("m omega g", positive=True)
    N = me.ReferenceFrame("N")
    A = me.ReferenceFrame("A")
    A.orient_axis(N, N.z, omega * T)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", r * A.x + y * A.y + z * A.z)
    P.set_vel(N, P.pos_from(O).dt(N).subs(
        {r.diff(): u[0], y.diff(): u[1], z.diff(): u[2]}))
    bead = me.Particle("bead", P, m)
    guide = PointVelocity(P, [A.y, A.z], relative_to=(A, O), names=["N_h", "N_v"])
    return ModelDefinition(
        name="rod-bead", title="bead on a uniformly turning horizontal rod (vector guide)",
        kane_args=dict(frame=N, q_ind=[r], q_dep=[y, z], u_ind=[u[0]],
                       u_dep=[u[1], u[2]], kd_eqs=_rates((r, y, z), u),
                       configuration_constraints=[y, z], bodies=[bead],
                       loads=[(P, -m * g * N.z)], constraints=[guide]),
        constants={m: 0.5, omega: 2.0, g: 9.81},
        initial_state={r: 0.1, u[0]: 0.0, y: 0.0, z: 0.0}, t_end=1.5,
        symbols=dict(r=r, y=y, z=z, u=u, m=m, omega=omega, g=g, N=N, A=A, O=O, P=P,
                     bead=bead),
        description="r = r0 cosh(omega t) + (v0/omega) sinh(omega t); rod forces "
                    "N_h = 2 m omega r' (along A.y), N_v = m g (along A.z).")


def _planar_body(N, O, name, body_name, mass, inertia):
    """A rigid body free in the x-y plane: mass centre ``(x, y)``, angle from N.x."""
    q = me.dynamicsymbols(f"x_{name} y_{name} theta_{name}")
    u = me.dynamicsymbols(f"u_x{name} u_y{name} w_{name}")
    F = me.ReferenceFrame(name)
    F.orient_axis(N, N.z, q[2])
    F.set_ang_vel(N, u[2] * N.z)
    G = O.locatenew(f"G_{name}", q[0] * N.x + q[1] * N.y)
    G.set_vel(N, u[0] * N.x + u[1] * N.y)
    body = me.RigidBody(body_name, G, F, mass, (me.inertia(F, 0, 0, inertia), G))
    return q, u, F, G, body


def pin_slot():
    r"""A crank driving a slotted lever through a pin: every joint a vector constraint.

    The lever ``A`` (length ``l_A``, mass ``m_A``, central inertia ``I_A``)
    pivots at its end about the fixed point ``O_A`` (the origin); the crank
    ``B`` (mass ``m_B``, central inertia ``I_B``, mass centre ``e/2`` from its
    pivot) turns about the fixed point ``O_B`` a distance ``d`` above ``O_A``
    and carries the pin ``P`` at radius ``e < d``, which slides in the
    lever's slot along ``A.x``.  Both bodies are free in the plane
    (``x, y, theta`` each; gravity ``g`` along ``-N.y``); a constant torque
    ``tau`` (N m) drives the crank against bearing damping ``c`` (N m s):
    the torque on the crank is ``tau - c w_B``.  The crank angle
    ``theta_B`` is the degree of freedom; the other five coordinates are
    dependent.

    Identified forces (N): the pivot reactions on the lever ``R_Ax, R_Ay``
    and on the crank ``R_Bx, R_By`` (along ``N.x, N.y``), and the slot force
    ``N_slot`` along ``A.y`` on the pin (its reaction on the lever).  Hand
    checks: ``R_Ay + R_By = (m_A + m_B) g + m_A a_GAy + m_B a_GBy`` and, about
    ``O_B``, ``(I_B + m_B e^2/4) theta_B'' = tau - c w_B + N_slot ((P - O_B)
    x A.y).z - m_B g (e/2) cos theta_B``.
    """
    m_A, m_B, I_A, I_B = sm.symbols("m_A m_B I_A I_B", positive=True)
    l_A, e, d, g, tau, c = sm.symbols("l_A e d g tau c", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O_A")
    O.set_vel(N, 0)
    O_B = O.locatenew("O_B", d * N.y)
    O_B.set_vel(N, 0)
    qa, ua, A, G_A, lever = _planar_body(N, O, "A", "lever", m_A, I_A)
    qb, ub, B, G_B, crank = _planar_body(N, O, "B", "crank", m_B, I_B)
    pivot_A = G_A.locatenew("A_o", -l_A / 2 * A.x)   # the lever's point at O_A
    pivot_B = G_B.locatenew("B_o", -e / 2 * B.x)     # the crank's point at O_B
    pin = G_B.locatenew("P", e / 2 * B.x)
    for point, G, F in ((pivot_A, G_A, A), (pivot_B, G_B, B), (pin, G_B, B)):
        point.v2pt_theory(G, N, F)
    config = [pivot_A.pos_from(O).dot(N.x), pivot_A.pos_from(O).dot(N.y),
              pivot_B.pos_from(O_B).dot(N.x), pivot_B.pos_from(O_B).dot(N.y),
              pin.pos_from(pivot_A).dot(A.y)]
    constraints = [
        PointVelocity(pivot_A, [N.x, N.y], body=lever, names=["R_Ax", "R_Ay"]),
        PointVelocity(pivot_B, [N.x, N.y], body=crank, names=["R_Bx", "R_By"]),
        PointVelocity(pin, A.y, relative_to=lever, body=crank, names="N_slot")]
    values = {m_A: 1.0, m_B: 0.4, l_A: 0.6, e: 0.1, d: 0.3, g: 9.81, tau: 0.5, c: 0.05}
    values[I_A] = values[m_A] * values[l_A] ** 2 / 12
    values[I_B] = values[m_B] * values[e] ** 2 / 12
    # a consistent starting configuration for the default geometry
    th_b, radius, dist, half = 0.3, values[e], values[d], values[l_A] / 2
    px, py = radius * math.cos(th_b), dist + radius * math.sin(th_b)
    th_a = math.atan2(py, px)
    init = {qb[2]: th_b, ub[2]: 8.0,
            qa[0]: half * math.cos(th_a), qa[1]: half * math.sin(th_a), qa[2]: th_a,
            qb[0]: radius / 2 * math.cos(th_b), qb[1]: dist + radius / 2 * math.sin(th_b)}
    return ModelDefinition(
        name="pin-slot", title="crank and slotted lever, joints as vector constraints",
        kane_args=dict(frame=N, q_ind=[qb[2]], q_dep=[*qa, qb[0], qb[1]],
                       u_ind=[ub[2]], u_dep=[*ua, ub[0], ub[1]],
                       kd_eqs=_rates(qa, ua) + _rates(qb, ub),
                       configuration_constraints=config, bodies=[lever, crank],
                       loads=[(G_A, -m_A * g * N.y), (G_B, -m_B * g * N.y),
                              (B, (tau - c * ub[2]) * N.z)],
                       constraints=constraints),
        constants=values, initial_state=init, t_end=2.0,
        symbols=dict(qa=qa, ua=ua, qb=qb, ub=ub, m_A=m_A, m_B=m_B, I_A=I_A, I_B=I_B,
                     l_A=l_A, e=e, d=d, g=g, tau=tau, c=c, N=N, A=A, B=B, G_A=G_A, G_B=G_B,
                     O_A=O, O_B=O_B, pivot_A=pivot_A, pivot_B=pivot_B, P=pin,
                     lever=lever, crank=crank),
        description="Pivot reactions R_A*, R_B* along N.x, N.y and the slot force "
                    "N_slot along A.y; R_Ay + R_By = sum m (g + a_Gy).")


def knife_edge():
    r"""The Chaplygin sleigh with its knife edge as a vector constraint.

    A planar body (mass ``m``, central inertia ``I_C``) located by its
    contact point ``P`` (``x, y``) and heading ``theta``; the mass centre
    ``G`` lies a distance ``a`` ahead of ``P`` along ``B.x``.  Speeds: ``u``
    and ``v`` (dependent) the velocity of ``P`` along ``B.x`` and ``B.y``,
    ``w`` the yaw rate.  The knife edge is ``PointVelocity(P, B.y)``, whose
    multiplier is the lateral force ``F_lat`` (N) on the blade.

    Closed form, with :math:`J = I_C + m a^2`: :math:`\dot u = a w^2`,
    :math:`J\dot w = -m a u w`, :math:`u = U\tanh(\lambda t +
    \operatorname{atanh}(u_0/U))` with :math:`U^2 = u_0^2 + (J/m) w_0^2`,
    :math:`\lambda = a m U/J`, and :math:`w^2 = (m/J)(U^2 - u^2)` (energy).
    The lateral force is :math:`F = m\,a_G\cdot\hat b_y = m(a\dot w + u w)
    = m u w I_C/J`.
    """
    x, y, th = me.dynamicsymbols("x y theta")
    u, v, w = me.dynamicsymbols("u v w")
    m, a, I_C = sm.symbols("m a I_C", positive=True)
    N = me.ReferenceFrame("N")
    B = me.ReferenceFrame("B")
    B.orient_axis(N, N.z, th)
    B.set_ang_vel(N, w * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, u * B.x + v * B.y)
    G = P.locatenew("G", a * B.x)
    G.v2pt_theory(P, N, B)
    kd_eqs = [x.diff() - u * sm.cos(th) + v * sm.sin(th),
              y.diff() - u * sm.sin(th) - v * sm.cos(th), th.diff() - w]
    sleigh = me.RigidBody("sleigh", G, B, m, (me.inertia(B, 0, 0, I_C), G))
    return ModelDefinition(
        name="knife-edge", title="Chaplygin sleigh, knife edge as a vector constraint",
        kane_args=dict(frame=N, q_ind=[x, y, th], u_ind=[u, w], u_dep=[v],
                       kd_eqs=kd_eqs, bodies=[sleigh], loads=[],
                       constraints=[PointVelocity(P, B.y, names="F_lat")]),
        constants={m: 1.0, a: 0.2, I_C: 0.05},
        initial_state={x: 0.0, y: 0.0, th: 0.0, u: -0.5, w: 1.0}, t_end=20.0,
        symbols=dict(x=x, y=y, theta=th, u=u, v=v, w=w, m=m, a=a, I_C=I_C, N=N, B=B,
                     P=P, G=G, sleigh=sleigh),
        description="u = U tanh(lambda t + atanh(u0/U)), U^2 = u0^2 + (J/m) w0^2, "
                    "lambda = a m U/J, J = I_C + m a^2; lateral force "
                    "F_lat = m u w I_C / J.")


def rolling_disk_contact():
    r"""A thin disk rolling on the ground, free body plus a contact constraint.

    The disk (radius ``r``, mass ``m``) has all six coordinates: yaw ``q3``,
    lean ``q4`` and spin ``q5`` (the frames of the ``rolling-disk`` model)
    and its centre ``x, y, z``; ``N.z`` points up, gravity ``g`` down.
    Speeds: ``u1..u3`` the disk's angular velocity in the lean frame (as in
    ``rolling-disk``) and ``u_x, u_y, u_z`` the centre's velocity
    (dependent).  The height is dependent, ``z = r cos q4``.  The disk's
    material point ``C`` touching the ground has no velocity:
    ``PointVelocity(C, [N.x, N.y, N.z])`` identifies the friction forces
    ``F_x, F_y`` and the normal force ``F_n`` (N) on the disk at ``C``.

    Closed form: upright straight rolling has ``F_n = m g`` and no friction;
    the motion is that of ``rolling-disk`` from the same angles and rates.
    """
    q3, q4, q5, x, y, z = me.dynamicsymbols("q3 q4 q5 x y z")
    u1, u2, u3, ux, uy, uz = me.dynamicsymbols("u1 u2 u3 u_x u_y u_z")
    m, r, g = sm.symbols("m r g", positive=True)
    N = me.ReferenceFrame("N")
    Y = me.ReferenceFrame("Y")
    Y.orient_axis(N, N.z, q3)
    L = me.ReferenceFrame("L")
    L.orient_axis(Y, Y.x, q4)
    R = me.ReferenceFrame("R")
    R.orient_axis(L, L.y, q5)
    R.set_ang_vel(N, u1 * L.x + u2 * L.y + u3 * L.z)
    # R.ang_vel_in(N) = q3' N.z + q4' Y.x + q5' L.y, solved for the rates
    kd_eqs = [q3.diff() - u3 / sm.cos(q4), q4.diff() - u1,
              q5.diff() - u2 + u3 * sm.tan(q4)] + _rates((x, y, z), (ux, uy, uz))
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", x * N.x + y * N.y + z * N.z)
    G.set_vel(N, ux * N.x + uy * N.y + uz * N.z)
    C = G.locatenew("C", -r * L.z)   # the disk's point touching the ground
    C.v2pt_theory(G, N, R)
    I_d = m * r ** 2 / 4
    disk = me.RigidBody("disk", G, R, m, (me.inertia(L, I_d, 2 * I_d, I_d), G))
    contact = PointVelocity(C, [N.x, N.y, N.z], body=disk, names=["F_x", "F_y", "F_n"])
    return ModelDefinition(
        name="rolling-disk-contact",
        title="rolling disk as a free body with a vector contact constraint",
        kane_args=dict(frame=N, q_ind=[q3, q4, q5, x, y], q_dep=[z],
                       u_ind=[u1, u2, u3], u_dep=[ux, uy, uz], kd_eqs=kd_eqs,
                       configuration_constraints=[z - r * sm.cos(q4)],
                       bodies=[disk], loads=[(G, -m * g * N.z)],
                       constraints=[contact], potential_energy=m * g * z),
        constants={m: 2.0, r: 0.3, g: 9.81},
        initial_state={q3: 0.0, q4: 0.05, q5: 0.0, x: 0.0, y: 0.0, z: 0.3,
                       u1: 0.0, u2: -9.0, u3: 0.0},
        t_end=5.0,
        symbols=dict(q=[q3, q4, q5, x, y, z], u=[u1, u2, u3, ux, uy, uz], m=m, r=r, g=g,
                     N=N, Y=Y, L=L, R=R, G=G, C=C, disk=disk),
        description="Contact forces F_x, F_y (friction) and F_n (normal) at the "
                    "contact point; upright rolling: F_n = m g, no friction.")


def block_wedge():
    r"""A block sliding on a wedge that slides on a smooth floor.

    The wedge (mass ``M``, a particle at ``W``: it does not turn) is located
    by ``X`` and the dependent height ``Y = 0``; the block (mass ``m``, a
    particle at ``P``) by ``s`` along the incline (direction
    :math:`\hat t = \cos\theta\,\hat n_x + \sin\theta\,\hat n_y` through
    ``W``) and the dependent offset ``h = 0`` along its normal
    :math:`\hat n = -\sin\theta\,\hat n_x + \cos\theta\,\hat n_y`; gravity
    ``g`` along ``-N.y``.  Constraints: ``PointVelocity(W, N.y)``, the floor
    force ``N_floor`` on the wedge, and ``PointVelocity(P, n,
    relative_to=wedge)``, the incline force ``N_incline`` on the block (and
    its reaction on the wedge).

    Closed form (all constant): :math:`N_{incline} = m M g\cos\theta/(M +
    m\sin^2\theta)`, wedge acceleration :math:`A = m g\sin\theta\cos\theta/
    (M + m\sin^2\theta)` along ``N.x``, :math:`\ddot s = -(M + m) g
    \sin\theta/(M + m\sin^2\theta)`, :math:`N_{floor} = M g + N_{incline}
    \cos\theta = M (M + m) g/(M + m\sin^2\theta)`.
    """
    X, Y, s, h = me.dynamicsymbols("X Y s h")
    uX, uY, us, uh = me.dynamicsymbols("u_X u_Y u_s u_h")
    M, m, g, theta = sm.symbols("M m g theta", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    t_hat = sm.cos(theta) * N.x + sm.sin(theta) * N.y
    n_hat = -sm.sin(theta) * N.x + sm.cos(theta) * N.y
    W = O.locatenew("W", X * N.x + Y * N.y)
    W.set_vel(N, uX * N.x + uY * N.y)
    P = W.locatenew("P", s * t_hat + h * n_hat)
    P.set_vel(N, W.vel(N) + us * t_hat + uh * n_hat)
    wedge, block = me.Particle("wedge", W, M), me.Particle("block", P, m)
    constraints = [PointVelocity(W, N.y, body=wedge, names="N_floor"),
                   PointVelocity(P, n_hat, relative_to=wedge, body=block,
                                 names="N_incline")]
    return ModelDefinition(
        name="block-wedge", title="block on a wedge on a smooth floor (vector constraints)",
        kane_args=dict(frame=N, q_ind=[X, s], q_dep=[Y, h], u_ind=[uX, us],
                       u_dep=[uY, uh], kd_eqs=_rates((X, s, Y, h), (uX, us, uY, uh)),
                       configuration_constraints=[Y, h], bodies=[wedge, block],
                       loads=[(W, -M * g * N.y), (P, -m * g * N.y)],
                       constraints=constraints,
                       potential_energy=M * g * Y + m * g * P.pos_from(O).dot(N.y)),
        constants={M: 3.0, m: 1.0, g: 9.81, theta: math.pi / 6},
        initial_state={X: 0.0, s: 2.0, uX: 0.0, us: 0.0, Y: 0.0, h: 0.0}, t_end=0.8,
        symbols=dict(X=X, Y=Y, s=s, h=h, uX=uX, uY=uY, us=us, uh=uh, M=M, m=m, g=g,
                     theta=theta, N=N, W=W, P=P, t_hat=t_hat, n_hat=n_hat,
                     wedge=wedge, block=block),
        description="N_incline = m M g cos(theta)/(M + m sin^2 theta), wedge "
                    "acceleration m g sin(theta) cos(theta)/(M + m sin^2 theta), "
                    "N_floor = M (M + m) g/(M + m sin^2 theta).")
