r"""Nonholonomic examples for comparing formulations (Kane, Lagrange, augmented).

Every constraint force of these models is identified by a vector constraint,
so :func:`kanedyn.check_newton_euler` can tell a right motion from a wrong
one.
"""

from __future__ import annotations

import sympy as sm
import sympy.physics.mechanics as me

from ..modeling import PointVelocity
from ._base import ModelDefinition

__all__ = ["nonholonomic_particle", "sphere_on_turntable"]

T = me.dynamicsymbols._t


def nonholonomic_particle():
    r"""A particle whose velocity obeys :math:`\dot z = y\,\dot x`, held by a spring.

    The constraint in vector form is :math:`v^P\cdot(-y\,n_x + n_z) = 0`, so
    the constraint force is :math:`\lambda(-y\,n_x + n_z)`.  A spring of
    stiffness ``k`` pulls the particle towards the ``z`` axis.  The classic
    small example on which the nonholonomic (d'Alembert) and vakonomic
    (augmented Lagrangean) motions part ways.
    """
    x, y, z = me.dynamicsymbols("x y z")
    ux, uy, uz = me.dynamicsymbols("u_x u_y u_z")
    m, k = sm.symbols("m k", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y + z * N.z)
    P.set_vel(N, ux * N.x + uy * N.y + uz * N.z)
    constraint = PointVelocity(P, -y * N.x + N.z, names="F")
    return ModelDefinition(
        name="nonholonomic-particle",
        title="particle with z' = y x' on a spring (nonholonomic vs vakonomic)",
        kane_args=dict(frame=N, q_ind=[x, y, z], u_ind=[ux, uy], u_dep=[uz],
                       kd_eqs=[x.diff() - ux, y.diff() - uy, z.diff() - uz],
                       bodies=[me.Particle("particle", P, m)],
                       loads=[(P, -k * (x * N.x + y * N.y))], constraints=[constraint],
                       potential_energy=k * (x**2 + y**2) / 2),
        constants={m: 1.0, k: 4.0},
        initial_state={x: 1.0, y: 0.0, z: 0.0, ux: 0.0, uy: 1.0},
        t_end=3.0,
        symbols=dict(q=(x, y, z), u=(ux, uy, uz), m=m, k=k, N=N, P=P),
        description="Constraint force lambda (-y n_x + n_z); energy is conserved.")


def sphere_on_turntable():
    r"""A uniform sphere rolling without slipping on a turntable spinning at Omega.

    The sphere is a free body (centre ``x, y, z``; body-fixed XYZ angles);
    its contact point ``C`` has no velocity relative to the turntable:
    ``PointVelocity(C, [N.x, N.y, N.z], relative_to=(turntable, O))``,
    identifying the friction components and the normal force.  Closed form:
    the centre's velocity turns at :math:`2\Omega/7` (the centre moves on a
    circle fixed in space, whatever the initial state), the normal force is
    :math:`m g`.
    """
    x, y, z, a1, a2, a3 = me.dynamicsymbols("x y z q_1 q_2 q_3")
    vx, vy, vz, w1, w2, w3 = me.dynamicsymbols("v_x v_y v_z w_1 w_2 w_3")
    m, r, g, Omega = sm.symbols("m r g Omega", positive=True)
    N = me.ReferenceFrame("N")
    table = me.ReferenceFrame("T")
    table.orient_axis(N, N.z, Omega * T)
    S = me.ReferenceFrame("S")
    S.orient_body_fixed(N, (a1, a2, a3), "XYZ")
    rates = S.ang_vel_in(N)
    S.set_ang_vel(N, w1 * N.x + w2 * N.y + w3 * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", x * N.x + y * N.y + z * N.z)
    G.set_vel(N, vx * N.x + vy * N.y + vz * N.z)
    C = G.locatenew("C", -r * N.z)
    C.v2pt_theory(G, N, S)
    inertia = me.inertia(S, 1, 1, 1) * sm.Rational(2, 5) * m * r**2
    sphere = me.RigidBody("sphere", G, S, m, (inertia, G))
    kd_eqs = [x.diff() - vx, y.diff() - vy, z.diff() - vz,
              rates.dot(N.x) - w1, rates.dot(N.y) - w2, rates.dot(N.z) - w3]
    rolling = PointVelocity(C, [N.x, N.y, N.z], relative_to=(table, O),
                            names=["F_x", "F_y", "F_n"])
    return ModelDefinition(
        name="sphere-turntable",
        title="uniform sphere rolling on a spinning turntable",
        kane_args=dict(frame=N, q_ind=[x, y, a1, a2, a3], q_dep=[z],
                       u_ind=[w1, w2, w3], u_dep=[vx, vy, vz], kd_eqs=kd_eqs,
                       configuration_constraints=[z - r], bodies=[sphere],
                       loads=[(G, -m * g * N.z)], constraints=[rolling]),
        constants={m: 1.0, r: 0.5, g: 9.81, Omega: 1.0},
        # at rest in space at (0.5, 0): spinning so that the contact point
        # moves with the table (0.5 Omega n_y = w x (-r n_z) => w_1 = 1)
        initial_state={x: 0.5, y: 0.0, z: 0.5, a1: 0.0, a2: 0.0, a3: 0.0,
                       w1: 1.0, w2: 0.3, w3: 0.0},
        t_end=2.0,
        symbols=dict(q=(x, y, z, a1, a2, a3), u=(vx, vy, vz, w1, w2, w3), m=m, r=r,
                     g=g, Omega=Omega, N=N, S=S, table=table, G=G, C=C),
        description="The centre's velocity turns at 2 Omega / 7; normal force m g.")
