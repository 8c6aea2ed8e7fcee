"""The three contact simulations of ``bench_contacts.py`` (and its tests).

``falling-rod`` and ``slug-ellipsoid`` are built-in models; ``ball-3d`` is a
spinning ball (radius 0.1 m, mass 0.5 kg, solid sphere) thrown onto a rough
floor in 3D: it bounces with friction during the impacts (spin and slip
couple), then slides and rolls.
"""

from __future__ import annotations

import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn import models

__all__ = ["CASES", "build"]

CASES = ("falling-rod", "slug-ellipsoid", "ball-3d")


def _ball_3d(backend):
    x, y, z, a, b, c = me.dynamicsymbols("x y z a b c")
    ux, uy, uz, ua, ub, uc = me.dynamicsymbols("u_x u_y u_z u_a u_b u_c")
    m, r, g = 0.5, 0.1, 9.81
    N = me.ReferenceFrame("N")
    B = me.ReferenceFrame("B")
    B.orient_body_fixed(N, (a, b, c), "XYZ")
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", x * N.x + y * N.y + z * N.z)
    C.set_vel(N, ux * N.x + uy * N.y + uz * N.z)
    inertia = 2 * m * r ** 2 / 5
    ball = me.RigidBody("ball", C, B, m, (me.inertia(B, inertia, inertia, inertia), C))
    bottom = C.locatenew("P", -r * N.z)
    bottom.v2pt_theory(C, N, B)
    contact = kd.Contact(bottom, kd.Plane(N, O, N.z, name="floor"), mu_k=0.3,
                         restitution=0.6, name="floor")
    q, u = [x, y, z, a, b, c], [ux, uy, uz, ua, ub, uc]
    eom = kd.kane(frame=N, q_ind=q, u_ind=u, kd_eqs=[s.diff() - v for s, v in zip(q, u)],
                  bodies=[ball], loads=[(C, -m * g * N.z)], contacts=[contact])
    model = eom.numeric(backend=backend)
    y0 = model.state({x: 0.0, y: 0.0, z: 0.4, a: 0.0, b: 0.0, c: 0.0, ux: 1.5, uy: 0.5,
                      uz: 0.0, ua: 0.0, ub: -20.0, uc: 5.0})
    return model, y0, 1.5


def build(name, backend="numpy"):
    """``(model, y0, t_end)`` of one case."""
    if name == "ball-3d":
        return _ball_3d(backend)
    definition = models.build(name)
    eom = kd.kane(**definition.kane_args)
    model = eom.numeric(constants=definition.constants, backend=backend)
    return model, model.state(definition.initial_state), definition.t_end


