r"""A planar snake robot on passive wheels, driven by serpenoid joint torques.

A system of the kind on which Talaeizadeh, Forouzan and Bock (2020) compare
Kane's method with Lagrange-based formulations: a chain of rigid links on a
horizontal floor, each carried by a pair of passive wheels that cannot slip
sideways, driven by torques at the joints.  The parameters, the gait and the
choice of speeds are kanedyn's own (see :func:`snake`).
"""

from __future__ import annotations

import math

import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..modeling import PointVelocity
from ._base import ModelDefinition

__all__ = ["snake"]

T = me.dynamicsymbols._t


def snake(n=5):
    r"""A planar ``n``-link snake robot on passive wheels with serpenoid joint torques.

    Geometry and inertia.  ``n`` uniform rods of length ``l`` (m) and mass
    ``m`` (kg), central moment of inertia :math:`m l^2/12` about the
    vertical, joined end to end by revolute joints with vertical axes; the
    snake moves in the horizontal plane ``N.x``--``N.y`` (``N.z`` up), so
    gravity does no work and is left out.  Link ``i`` has frame ``L_i``,
    whose ``x`` axis points from link ``i`` towards link ``i + 1``, and mass
    centre ``G_i``; the joint ``J_i`` joins links ``i`` and ``i + 1``.

    Coordinates (``n + 2``): ``x, y`` (m), the position of ``G_1`` in ``N``,
    and the absolute headings ``theta_1 .. theta_n`` (rad) of the links
    (from ``N.x`` to ``L_i.x`` about ``N.z``).  The joint angles are
    :math:`\phi_i = \theta_{i+1} - \theta_i`, ``i = 1 .. n-1``.

    Speeds (one per coordinate, as the Lagrange-based formulations need):
    ``u_f`` and ``u_l`` (m/s), the velocity of ``G_1`` along ``L_1.x``
    (forward) and ``L_1.y`` (lateral), and ``w_1 .. w_n`` (rad/s), the
    angular rates of the links:

    .. math::

        \dot x = u_f\cos\theta_1 - u_l\sin\theta_1,\qquad
        \dot y = u_f\sin\theta_1 + u_l\cos\theta_1,\qquad
        \dot\theta_i = w_i.

    Wheels.  A passive wheel pair at every ``G_i`` rolls freely along
    ``L_i.x`` but cannot slip sideways: :math:`{}^N v^{G_i}\cdot\hat l_{iy}
    = 0`, stated as ``PointVelocity(G_i, L_i.y, names="F_i")``, whose
    multiplier ``F_i`` (N) is the lateral wheel force on link ``i`` along
    ``L_i.y``.  ``n + 2`` speeds less ``n`` constraints leave two degrees
    of freedom.  The independent speeds are ``u_f`` and ``w_1``, the
    dependent ones ``u_l, w_2 .. w_n``: constraint ``i`` contains, of the
    dependent speeds, only ``u_l`` and ``w_2 .. w_i``, the last with
    coefficient ``l/2`` (constraint 1 is :math:`u_l = 0`), so the dependent
    block of the constraint Jacobian is lower triangular with determinant
    :math:`(l/2)^{n-1}` in every configuration: it is never singular,
    whatever the joint angles.  Its condition number is largest for the
    straight snake: about 20, 53 and 127 for ``n = 3, 5, 8`` (``l =
    0.5 m``).

    Joint torques.  Joint ``i`` carries

    .. math::

        \tau_i = A\sin(\omega t + (i - 1)\beta) - k\,\phi_i - c\,\dot\phi_i,

    applied as :math:`+\tau_i\hat n_z` on link ``i + 1`` and
    :math:`-\tau_i\hat n_z` on link ``i``: a serpenoid drive torque (a wave
    running from the last link to the first, so the snake crawls towards
    ``+L.x``, last link first) with an elastic joint of stiffness ``k`` (N
    m/rad) and a viscous damper ``c`` (N m s); equivalently a PD servo of
    gains ``k, c`` tracking the joint angles :math:`(A/k)\sin(\omega t +
    (i-1)\beta)`.  ``A`` (N m), ``omega`` (rad/s), ``beta`` (rad) are
    parameters and ``t`` is explicit in the loads, so no specified inputs
    are needed.  Without the stiffness the joint angles drift towards folded
    configurations under a sinusoidal torque; with it they stay within
    about 25 degrees on the default gait.

    Joint forces.  The coordinates satisfy the joints identically, so the
    forces the links exert on each other at the joints do not appear in the
    equations and are not identified: the per-link residuals of
    :func:`kanedyn.check_newton_euler` (and the ``N-E`` columns of
    ``kanedyn compare snake``) are those joint forces, not errors.  They
    follow from the residuals by least squares (3 equations per link, 2
    unknowns per joint).

    Energy.  The potential energy is that of the joint springs,
    :math:`V = \sum_i k\phi_i^2/2` (zero for ``k = 0``; there is no gravity
    work).  The wheel forces do no work, so with ``A = 0`` and ``c = 0``
    the total energy :math:`T + V` is conserved.

    Parameters
    ----------
    n : int
        Number of links, at least 2.  The default gait (``A = 1 N m``,
        ``omega = 5 rad/s``, ``beta = 3 pi/4``, ``k = 2 N m/rad``, ``c = 0.5
        N m s``, ``m = 1 kg``, ``l = 0.5 m``) crawls forward, from rest,
        about 3 m (``n = 3``) to 4 m (``n = 5 .. 8``) in the default 10 s;
        other lengths may need another ``beta``.

    Returns
    -------
    ModelDefinition
        Initial state: a snake at rest, its joint angles alternating
        ``+-0.2 rad``, mean heading zero, ``G_1`` at the origin.
        ``symbols`` holds ``q`` (``x, y, theta_1 .. theta_n``) and ``u``
        (``u_f, u_l, w_1 .. w_n``), also as ``x, y, theta, u_f, u_l, w``;
        the frames ``N`` and ``L`` (tuple), the mass centres ``G``, the
        joints ``J`` and the links ``bodies`` (tuples); the constants ``m,
        l, A, omega, beta, k, c``; the joint angles ``phi`` and the joint
        torques ``tau`` (expressions in ``t``, ``theta``, ``w``).

    Raises
    ------
    ModelError
        If ``n`` is not an integer of at least 2 (one link has no joint).

    Notes
    -----
    Closed forms (with ``A = 0``): a straight snake rolls straight on at
    constant speed with zero wheel forces; a snake bent at equal joint
    angles :math:`\phi` with ``k = 0`` (the links are sides of a regular
    polygon whose inscribed circle, of radius :math:`R = l/(2\tan(\phi/2))`,
    touches them at their mass centres) turns rigidly at any constant rate
    :math:`\Omega` about the circle's centre, every wheel pushing its link
    towards the centre with :math:`m R\Omega^2`.

    Examples
    --------
    >>> import kanedyn as kd
    >>> definition = kd.models.build("snake", n=3)
    >>> [str(s) for s in definition.symbols["q"]]
    ['x(t)', 'y(t)', 'theta_1(t)', 'theta_2(t)', 'theta_3(t)']
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise ModelError(f"snake: n (the number of links) must be an integer of at least "
                         f"2, got n={n!r}")
    x, y = me.dynamicsymbols("x y")
    theta = tuple(me.dynamicsymbols(f"theta_{i}") for i in range(1, n + 1))
    u_f, u_l = me.dynamicsymbols("u_f u_l")
    w = tuple(me.dynamicsymbols(f"w_{i}") for i in range(1, n + 1))
    m, l = sm.symbols("m l", positive=True)
    A, omega, beta, k, c = sm.symbols("A omega beta k c", real=True)

    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    frames = []
    for i in range(n):
        L = me.ReferenceFrame(f"L_{i + 1}")
        L.orient_axis(N, N.z, theta[i])
        L.set_ang_vel(N, w[i] * N.z)
        frames.append(L)
    G = [O.locatenew("G_1", x * N.x + y * N.y)]
    G[0].set_vel(N, u_f * frames[0].x + u_l * frames[0].y)
    joints = []
    for i in range(n - 1):
        J = G[i].locatenew(f"J_{i + 1}", l / 2 * frames[i].x)
        J.v2pt_theory(G[i], N, frames[i])
        G_next = J.locatenew(f"G_{i + 2}", l / 2 * frames[i + 1].x)
        G_next.v2pt_theory(J, N, frames[i + 1])
        joints.append(J)
        G.append(G_next)

    bodies = []
    for i in range(n):
        inertia = me.inertia(frames[i], 0, m * l**2 / 12, m * l**2 / 12)
        bodies.append(me.RigidBody(f"link_{i + 1}", G[i], frames[i], m, (inertia, G[i])))

    phi = tuple(theta[i + 1] - theta[i] for i in range(n - 1))
    tau = tuple(A * sm.sin(omega * T + i * beta) - k * phi[i] - c * (w[i + 1] - w[i])
                for i in range(n - 1))
    torque = [sm.S.Zero] * n
    for i, tau_i in enumerate(tau):
        torque[i + 1] += tau_i
        torque[i] -= tau_i
    loads = [(frames[i], torque[i] * N.z) for i in range(n)]
    springs = sm.Add(*[k * p**2 / 2 for p in phi])

    wheels = [PointVelocity(G[i], frames[i].y, body=bodies[i], names=f"F_{i + 1}")
              for i in range(n)]
    kd_eqs = [x.diff(T) - (u_f * sm.cos(theta[0]) - u_l * sm.sin(theta[0])),
              y.diff(T) - (u_f * sm.sin(theta[0]) + u_l * sm.cos(theta[0]))]
    kd_eqs += [theta[i].diff(T) - w[i] for i in range(n)]

    # at rest, joint angles alternating +-0.2 rad, mean heading zero
    headings = [0.0]
    for i in range(n - 1):
        headings.append(headings[-1] + 0.2 * (-1) ** i)
    mean = sum(headings) / n
    initial = {x: 0.0, y: 0.0, u_f: 0.0, w[0]: 0.0}
    initial.update({th: h - mean for th, h in zip(theta, headings)})

    return ModelDefinition(
        name="snake",
        title=f"{n}-link snake robot on passive wheels, serpenoid joint torques",
        kane_args=dict(frame=N, q_ind=[x, y, *theta], u_ind=[u_f, w[0]],
                       u_dep=[u_l, *w[1:]], kd_eqs=kd_eqs, bodies=bodies, loads=loads,
                       constraints=wheels, potential_energy=springs),
        constants={m: 1.0, l: 0.5, A: 1.0, omega: 5.0, beta: 3 * math.pi / 4, k: 2.0,
                   c: 0.5},
        initial_state=initial,
        t_end=10.0,
        symbols=dict(q=(x, y, *theta), u=(u_f, u_l, *w), x=x, y=y, theta=theta,
                     u_f=u_f, u_l=u_l, w=w, N=N, L=tuple(frames), G=tuple(G),
                     J=tuple(joints), bodies=tuple(bodies), m=m, l=l, A=A, omega=omega,
                     beta=beta, k=k, c=c, phi=phi, tau=tau),
        description="Lateral wheel forces F_i (N) identified by vector constraints; the "
                    "joint forces are not identified (the Newton-Euler residuals of the "
                    "links are those forces); "
                    "joint torques A sin(omega t + (i-1) beta) - k phi_i - c phi_i'. "
                    "With A = 0 and c = 0 the energy (kinetic + joint springs) is "
                    "conserved.  Closed forms: a straight snake rolls on at constant "
                    "speed; a snake bent at equal joint angles turns rigidly on a "
                    "circle.")
