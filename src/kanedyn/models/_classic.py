"""Classic small models: pendulums, the 3D chain, the Chaplygin sleigh, a four-bar."""

from __future__ import annotations

import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ._base import ModelDefinition

__all__ = ["pendulum", "n_link_pendulum_on_cart", "chain3d", "chaplygin_sleigh",
           "four_bar"]


def pendulum(tension=False, torque=False):
    """Simple pendulum: a particle on a massless rod of length ``l``.

    The angle ``q`` is measured from the downward vertical, ``u = q'``.  With
    ``tension=True`` an auxiliary speed along the rod exposes the rod tension
    ``T`` (closed form :math:`T = m(g\\cos q + l u^2)`).  With ``torque=True``
    a specified torque ``tau(t)`` (N m, zero by default) drives the rod at the
    pivot: :math:`m l^2 \\ddot q = -m g l \\sin q + \\tau` (the swing-up of
    optimal control).
    """
    q, u = me.dynamicsymbols("q u")
    m, l, g = sm.symbols("m l g", positive=True)
    N = me.ReferenceFrame("N")
    A = me.ReferenceFrame("A")
    A.orient_axis(N, N.z, q)
    A.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", -l * A.y)
    P.v2pt_theory(O, N, A)
    loads = [(P, -m * g * N.y)]
    kane_args = dict(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u])
    symbols = dict(q=q, u=u, m=m, l=l, g=g, N=N, A=A, P=P)
    if tension:
        ua = me.dynamicsymbols("u_a")
        T = me.dynamicsymbols("T")
        P.set_vel(N, P.vel(N) + ua * A.y)
        loads.append((P, T * A.y))
        kane_args["u_auxiliary"] = [ua]
        symbols.update(ua=ua, T=T)
    specified = None
    if torque:
        tau = me.dynamicsymbols("tau")
        loads.append((A, tau * N.z))
        symbols["tau"] = tau
        specified = {tau: 0.0}
    bob = me.Particle("bob", P, m)
    bob.potential_energy = -m * g * l * sm.cos(q)
    kane_args.update(bodies=[bob], loads=loads)
    return ModelDefinition(
        name="pendulum", title="simple pendulum (point mass on a massless rod)",
        kane_args=kane_args, constants={m: 1.0, l: 1.0, g: 9.81},
        constant_units={m: "kg", l: "m", g: "m/s^2"},
        initial_state={q: sm.pi / 2, u: 0.0}, t_end=10.0, symbols=symbols,
        specified=specified or {},
        description="Released from the horizontal its period is 4 K(sin(pi/4)) "
                    "sqrt(l/g); with tension=True the rod tension is an output.")


def n_link_pendulum_on_cart(n=3):
    """A cart on a horizontal track carrying an ``n``-link planar pendulum.

    Links are massless rods of length ``l`` with point masses ``m`` at their
    ends; the cart has mass ``m_c`` and is pushed by the specified force
    ``F(t)``.  Angles ``q1..qn`` are absolute, from the downward vertical.
    """
    if n < 1:
        raise ModelError(f"n-link-pendulum-on-cart: n (the number of links) must be at "
                         f"least 1, got n={n}")
    q = me.dynamicsymbols(f"q0:{n + 1}")
    u = me.dynamicsymbols(f"u0:{n + 1}")
    F = me.dynamicsymbols("F")
    m_c, m, l, g = sm.symbols("m_c m l g", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    cart = O.locatenew("C", q[0] * N.x)
    cart.set_vel(N, u[0] * N.x)
    particles = [me.Particle("cart", cart, m_c)]
    loads = [(cart, F * N.x - m_c * g * N.y)]
    kd_eqs = [q[0].diff() - u[0]]
    heights = []
    prev = cart
    for i in range(1, n + 1):
        A = me.ReferenceFrame(f"A{i}")
        A.orient_axis(N, N.z, q[i])
        A.set_ang_vel(N, u[i] * N.z)
        P = prev.locatenew(f"P{i}", -l * A.y)
        P.v2pt_theory(prev, N, A)
        particles.append(me.Particle(f"bob{i}", P, m))
        loads.append((P, -m * g * N.y))
        kd_eqs.append(q[i].diff() - u[i])
        heights.append(P.pos_from(O).dot(N.y))
        prev = P
    potential = m * g * sm.Add(*heights)
    init = {qi: 0.0 for qi in q}
    init.update({ui: 0.0 for ui in u})
    init.update({q[i]: 0.4 / i for i in range(1, n + 1)})
    return ModelDefinition(
        name="n-link-pendulum-on-cart",
        title=f"{n}-link pendulum on a cart pushed by F(t)",
        kane_args=dict(frame=N, q_ind=list(q), u_ind=list(u), kd_eqs=kd_eqs,
                       bodies=particles, loads=loads, potential_energy=potential),
        constants={m_c: 2.0, m: 0.5, l: 0.6, g: 9.81}, initial_state=init,
        constant_units={m_c: "kg", m: "kg", l: "m", g: "m/s^2"},
        t_end=10.0, specified={F: 0.0},
        symbols=dict(q=q, u=u, F=F, m_c=m_c, m=m, l=l, g=g, N=N),
        description="The classic benchmark of PyDy; the cart force F(t) is a "
                    "specified input (zero by default; --set is not possible for "
                    "functions, give specified={F: ...} in Python).")


def chain3d(n=5, style="v2pt"):
    """A chain of ``n`` rigid links joined by revolute joints of alternating axes.

    Joint ``k`` turns link ``k`` relative to its parent about the parent's z
    axis (even k) or x axis (odd k); links have length ``l``, mass ``m`` at
    the link centre and central inertia ``diag(I_xx, I_yy, I_zz)``; gravity
    acts along ``-N.z``.  This is the derivation benchmark of kanedyn.

    ``style="v2pt"`` writes it as SymPy users do, with ``v2pt_theory`` and an
    explicit potential energy; SymPy then multiplies out direction cosines
    while the model is built, which becomes impractical beyond some 30 links.
    ``style="positions"`` gives positions only (velocities are derived by
    kanedyn) and no potential energy.
    """
    if n < 1:
        raise ModelError(f"chain3d: n (the number of links) must be at least 1, got n={n}")
    if style not in ("v2pt", "positions"):
        raise ModelError(f"chain3d: style must be 'v2pt' or 'positions', not {style!r}")
    v2pt = style == "v2pt"
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    m, l, g, Ixx, Iyy, Izz = sm.symbols("m l g I_xx I_yy I_zz", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    parent, joint = N, O
    bodies, loads, kd_eqs, heights = [], [], [], []
    for i in range(n):
        F = me.ReferenceFrame(f"B{i + 1}")
        axis = getattr(parent, "z" if i % 2 == 0 else "x")
        F.orient_axis(parent, axis, q[i])
        F.set_ang_vel(parent, u[i] * axis)
        C = joint.locatenew(f"C{i + 1}", l / 2 * F.y)
        nxt = joint.locatenew(f"P{i + 1}", l * F.y)
        if v2pt:
            C.v2pt_theory(joint, N, F)
            nxt.v2pt_theory(joint, N, F)
            heights.append(C.pos_from(O).dot(N.z))
        # the central inertia diag(I_xx, I_yy, I_zz) in F: the dyadic me.inertia()
        # gives, without its nine outer products (0.8 against 0.3 ms a link)
        central = Ixx * (F.x | F.x) + Iyy * (F.y | F.y) + Izz * (F.z | F.z)
        bodies.append(me.RigidBody(f"link{i + 1}", C, F, m, (central, C)))
        loads.append((C, -m * g * N.z))
        kd_eqs.append(q[i].diff() - u[i])
        parent, joint = F, nxt
    init = {qi: 0.3 for qi in q}
    init.update({ui: 0.0 for ui in u})
    return ModelDefinition(
        name="chain3d", title=f"3D chain of {n} links, revolute joints of alternating axes",
        kane_args=dict(frame=N, q_ind=list(q), u_ind=list(u), kd_eqs=kd_eqs,
                       bodies=bodies, loads=loads,
                       potential_energy=m * g * sm.Add(*heights) if v2pt else None),
        constants={m: 1.0, l: 0.5, g: 9.81, Ixx: 0.025, Iyy: 0.005, Izz: 0.025},
        constant_units={m: "kg", l: "m", g: "m/s^2", Ixx: "kg m^2", Iyy: "kg m^2", Izz: "kg m^2"},
        initial_state=init, t_end=5.0,
        symbols=dict(q=q, u=u, m=m, l=l, g=g, N=N),
        description="Derivation benchmark (SymPy's KanesMethod needs ~45 s at n=10).")


def chaplygin_sleigh(lateral_force=False):
    """The Chaplygin sleigh: a planar body on a knife edge at ``P``.

    The mass centre lies a distance ``a`` ahead of ``P`` on the body x axis;
    ``I_C`` is the central moment of inertia.  Speeds: ``u`` the forward speed
    of ``P`` and ``w`` the yaw rate (the knife edge allows no lateral
    velocity at ``P``).  Closed form: ``u' = a w^2``, ``J w' = -m a u w``
    with ``J = I_C + m a^2``.  With ``lateral_force=True`` an auxiliary speed
    exposes the knife-edge force ``R``.
    """
    x, y, th = me.dynamicsymbols("x y theta")
    u, w = me.dynamicsymbols("u w")
    m, a, I_C = sm.symbols("m a I_C", positive=True)
    N = me.ReferenceFrame("N")
    B = me.ReferenceFrame("B")
    B.orient_axis(N, N.z, th)
    B.set_ang_vel(N, w * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, u * B.x)
    G = P.locatenew("G", a * B.x)
    G.v2pt_theory(P, N, B)
    kd_eqs = [x.diff() - u * sm.cos(th), y.diff() - u * sm.sin(th), th.diff() - w]
    body = me.RigidBody("sleigh", G, B, m, (me.inertia(B, 0, 0, I_C), G))
    kane_args = dict(frame=N, q_ind=[x, y, th], u_ind=[u, w], kd_eqs=kd_eqs,
                     bodies=[body], loads=[])
    symbols = dict(x=x, y=y, theta=th, u=u, w=w, m=m, a=a, I_C=I_C, N=N, B=B, P=P)
    if lateral_force:
        ua, R = me.dynamicsymbols("u_a R")
        P.set_vel(N, u * B.x + ua * B.y)
        G.v2pt_theory(P, N, B)
        kane_args["u_auxiliary"] = [ua]
        kane_args["loads"] = [(P, R * B.y)]
        symbols.update(ua=ua, R=R)
    return ModelDefinition(
        name="chaplygin-sleigh", title="Chaplygin sleigh (knife edge, nonholonomic)",
        kane_args=kane_args, constants={m: 1.0, a: 0.2, I_C: 0.05},
        constant_units={m: "kg", a: "m", I_C: "kg m^2"},
        initial_state={x: 0.0, y: 0.0, th: 0.0, u: -0.5, w: 1.0}, t_end=20.0,
        symbols=symbols,
        description="Closed form u(t) = U tanh(lambda t + atanh(u0/U)), "
                    "U^2 = u0^2 + (J/m) w0^2, lambda = a m U / J.")


def four_bar():
    """A planar four-bar linkage under gravity: closed loop, one degree of freedom.

    Ground pivots ``O`` and ``D`` a distance ``l_d`` apart on ``N.x``; crank
    ``l_a`` (angle ``q1``), coupler ``l_b`` (``q2``), rocker ``l_c`` (``q3``),
    all absolute angles from ``N.x``; uniform rods of masses ``m_a, m_b, m_c``.
    ``q2, q3`` are dependent through the two loop-closure constraints.
    """
    q1, q2, q3 = me.dynamicsymbols("q1:4")
    u1, u2, u3 = me.dynamicsymbols("u1:4")
    la, lb, lc, ld = sm.symbols("l_a l_b l_c l_d", positive=True)
    ma, mb, mc, g = sm.symbols("m_a m_b m_c g", positive=True)
    N = me.ReferenceFrame("N")
    frames = []
    for qi, ui, name in ((q1, u1, "A"), (q2, u2, "B"), (q3, u3, "C")):
        F = me.ReferenceFrame(name)
        F.orient_axis(N, N.z, qi)
        F.set_ang_vel(N, ui * N.z)
        frames.append(F)
    A, B, C = frames
    O = me.Point("O")
    O.set_vel(N, 0)
    P1 = O.locatenew("P1", la * A.x)
    P1.v2pt_theory(O, N, A)
    P2 = P1.locatenew("P2", lb * B.x)
    P2.v2pt_theory(P1, N, B)
    D = O.locatenew("D", ld * N.x)
    D.set_vel(N, 0)
    P3 = D.locatenew("P3", lc * C.x)
    P3.v2pt_theory(D, N, C)
    Ga = O.locatenew("Ga", la / 2 * A.x)
    Ga.v2pt_theory(O, N, A)
    Gb = P1.locatenew("Gb", lb / 2 * B.x)
    Gb.v2pt_theory(P1, N, B)
    Gc = D.locatenew("Gc", lc / 2 * C.x)
    Gc.v2pt_theory(D, N, C)
    loop = P2.pos_from(O) - P3.pos_from(O)
    config = [loop.dot(N.x), loop.dot(N.y)]
    vel = [(P2.vel(N) - P3.vel(N)).dot(N.x), (P2.vel(N) - P3.vel(N)).dot(N.y)]
    bodies = []
    heights = []
    for name, G, F, mass, length in (("crank", Ga, A, ma, la), ("coupler", Gb, B, mb, lb),
                                     ("rocker", Gc, C, mc, lc)):
        inertia = me.inertia(F, 0, mass * length ** 2 / 12, mass * length ** 2 / 12)
        bodies.append(me.RigidBody(name, G, F, mass, (inertia, G)))
        heights.append(mass * g * G.pos_from(O).dot(N.y))
    loads = [(G, -b.mass * g * N.y) for G, b in zip((Ga, Gb, Gc), bodies)]
    return ModelDefinition(
        name="four-bar", title="planar four-bar linkage under gravity (closed loop)",
        kane_args=dict(frame=N, q_ind=[q1], u_ind=[u1], kd_eqs=[q1.diff() - u1,
                       q2.diff() - u2, q3.diff() - u3], q_dep=[q2, q3], u_dep=[u2, u3],
                       configuration_constraints=config, velocity_constraints=vel,
                       bodies=bodies, loads=loads, potential_energy=sm.Add(*heights)),
        constants={la: 0.3, lb: 1.0, lc: 0.8, ld: 0.9, ma: 0.5, mb: 1.2, mc: 1.0,
                   g: 9.81},
        constant_units={la: "m", lb: "m", lc: "m", ld: "m", ma: "kg", mb: "kg", mc: "kg",
               g: "m/s^2"},
        initial_state={q1: 1.2, u1: 2.0, q2: 0.3, q3: 1.6, u2: 0.0, u3: 0.0},
        t_end=5.0, symbols=dict(q=[q1, q2, q3], u=[u1, u2, u3], N=N),
        description="q2, q3 (and u2, u3) are dependent; the given q2, q3 are "
                    "starting guesses for Newton's method.")
