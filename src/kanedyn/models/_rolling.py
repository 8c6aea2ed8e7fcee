"""Rolling contact: the rolling disk and the Whipple bicycle (nonholonomic)."""

from __future__ import annotations

import sympy as sm
import sympy.physics.mechanics as me

from ._base import ModelDefinition

__all__ = ["rolling_disk", "whipple_bicycle", "MEIJAARD_2007"]


def rolling_disk(normal_force=False):
    """A thin disk rolling without slip on a horizontal plane.

    Coordinates: contact point ``q1, q2`` on the ground, yaw ``q3``, lean
    ``q4`` (from the vertical), spin ``q5``; ``N.z`` points up.  Independent
    speeds ``u1..u3`` are the disk's angular velocity components in the lean
    frame ``L``; the contact-point rates ``u4 = q1'``, ``u5 = q2'`` are
    dependent through the two no-slip constraints.  With ``normal_force=True``
    an auxiliary vertical speed of the contact point exposes the normal
    force ``N_c`` (``m g`` while upright).

    Closed form: upright rolling with spin rate ``Omega`` is stable iff
    ``Omega**2 > g / (3 r)``.
    """
    q1, q2, q3, q4, q5 = me.dynamicsymbols("q1:6")
    u1, u2, u3, u4, u5 = me.dynamicsymbols("u1:6")
    m, r, g = sm.symbols("m r g", positive=True)
    N = me.ReferenceFrame("N")
    Y = me.ReferenceFrame("Y")
    Y.orient_axis(N, N.z, q3)
    L = me.ReferenceFrame("L")
    L.orient_axis(Y, Y.x, q4)
    R = me.ReferenceFrame("R")
    R.orient_axis(L, L.y, q5)
    w_R = R.ang_vel_in(N)
    R.set_ang_vel(N, u1 * L.x + u2 * L.y + u3 * L.z)
    kd_eqs = [(w_R - R.ang_vel_in(N)).dot(L.x), (w_R - R.ang_vel_in(N)).dot(L.y),
              (w_R - R.ang_vel_in(N)).dot(L.z), q1.diff() - u4, q2.diff() - u5]
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", q1 * N.x + q2 * N.y)  # contact location on the ground
    G = C.locatenew("G", r * L.z)
    v_contact = G.vel(N) + R.ang_vel_in(N).cross(-r * L.z)
    vel = [v_contact.dot(Y.x), v_contact.dot(Y.y)]
    I_d = m * r ** 2 / 4
    disk = me.RigidBody("disk", G, R, m, (me.inertia(L, I_d, 2 * I_d, I_d), G))
    loads = [(G, -m * g * N.z)]
    kane_args = dict(frame=N, q_ind=[q1, q2, q3, q4, q5], u_ind=[u1, u2, u3],
                     u_dep=[u4, u5], kd_eqs=kd_eqs, velocity_constraints=vel,
                     bodies=[disk], loads=loads,
                     potential_energy=m * g * r * sm.cos(q4))
    symbols = dict(q=[q1, q2, q3, q4, q5], u=[u1, u2, u3, u4, u5], m=m, r=r, g=g,
                   N=N, Y=Y, L=L, R=R, C=C, G=G)
    if normal_force:
        # Let the disk's material contact point move up at the auxiliary speed
        # ua; every point of the disk, the centre included, moves with it.  The
        # normal force acts at that material point, which has no velocity in
        # the real speeds, so it enters only the auxiliary equation.
        ua = me.dynamicsymbols("u_a")
        Nc = me.dynamicsymbols("N_c")
        contact_material = me.Point("Cm")
        contact_material.set_vel(N, ua * N.z)
        G.set_vel(N, G.vel(N) + ua * N.z)
        kane_args["u_auxiliary"] = [ua]
        kane_args["loads"] = loads + [(contact_material, Nc * N.z)]
        symbols.update(ua=ua, N_c=Nc)
    return ModelDefinition(
        name="rolling-disk", title="thin disk rolling without slip (nonholonomic)",
        kane_args=kane_args, constants={m: 2.0, r: 0.3, g: 9.81},
        initial_state={q1: 0.0, q2: 0.0, q3: 0.0, q4: 0.05, q5: 0.0,
                       u1: 0.0, u2: -9.0, u3: 0.0},
        t_end=5.0, symbols=symbols,
        description="Upright rolling with spin Omega is stable iff Omega^2 > g/(3r) "
                    "(here g/(3r) = 10.9 rad^2/s^2); the default spin 9 rad/s is stable.")


#: Benchmark parameters of Meijaard, Papadopoulos, Ruina & Schwab (2007).
MEIJAARD_2007 = {
    "w": 1.02, "c": 0.08, "lam": sm.pi / 10, "g": 9.81,
    "rR": 0.3, "mR": 2.0, "IRxx": 0.0603, "IRyy": 0.12,
    "xB": 0.3, "zB": -0.9, "mB": 85.0, "IBxx": 9.2, "IByy": 11.0, "IBzz": 2.8,
    "IBxz": 2.4,
    "xH": 0.9, "zH": -0.7, "mH": 4.0, "IHxx": 0.05892, "IHyy": 0.06,
    "IHzz": 0.00708, "IHxz": -0.00756,
    "rF": 0.35, "mF": 3.0, "IFxx": 0.1405, "IFyy": 0.28,
}


def whipple_bicycle(steer_torque=False):
    r"""The Whipple bicycle, nonlinear, in the benchmark parametrization.

    Axes: ``x`` forward, ``y`` right, ``z`` down (as Meijaard et al. 2007).
    Coordinates: rear contact ``q1, q2``; yaw ``q3``; lean ``q4``; pitch ``q5``
    (dependent: both wheels touch the ground); rear wheel angle ``q6``; steer
    ``q7``; front wheel angle ``q8``.  Speeds ``u_i = q_i'``; independent
    ``u4`` (lean rate), ``u6`` (rear wheel rate), ``u7`` (steer rate); the
    other five are dependent through the no-slip constraints of both wheels
    (and the time derivative of the front contact height).

    Geometry and inertia are those of the benchmark: wheelbase ``w``, trail
    ``c``, steer axis tilt ``lam``; mass centres and inertia tensors in the
    rear-frame coordinates of the upright reference configuration.  Forward
    speed ``v`` corresponds to ``u6 = -v / rR``.

    With ``steer_torque=True`` a specified torque ``T_delta(t)`` (N m, zero by
    default) acts between the rear frame and the front frame about the steer
    axis, positive in the sense of the steer angle ``q7``: the benchmark's
    steer torque :math:`T_\delta`, the rider's input (the lane change of
    optimal control, ``kd.studies.bicycle_lane_change``).
    """
    q = me.dynamicsymbols("q1:9")
    u = me.dynamicsymbols("u1:9")
    P = {k: sm.Symbol(k, real=True) for k in MEIJAARD_2007}
    w, c, lam, g = P["w"], P["c"], P["lam"], P["g"]
    rR, rF = P["rR"], P["rF"]
    N = me.ReferenceFrame("N")
    A = me.ReferenceFrame("A")  # yaw
    A.orient_axis(N, N.z, q[2])
    L = me.ReferenceFrame("L")  # roll (lean)
    L.orient_axis(A, A.x, q[3])
    B = me.ReferenceFrame("B")  # rear frame (pitch)
    B.orient_axis(L, L.y, q[4])
    R = me.ReferenceFrame("R")  # rear wheel
    R.orient_axis(B, B.y, q[5])
    steer_axis = sm.sin(lam) * B.x + sm.cos(lam) * B.z
    H = me.ReferenceFrame("H")  # front frame (fork and handlebar)
    H.orient_axis(B, steer_axis, q[6])
    F = me.ReferenceFrame("F")  # front wheel
    F.orient_axis(H, H.y, q[7])
    A.set_ang_vel(N, u[2] * N.z)
    L.set_ang_vel(A, u[3] * A.x)
    B.set_ang_vel(L, u[4] * L.y)
    R.set_ang_vel(B, u[5] * B.y)
    H.set_ang_vel(B, u[6] * steer_axis)
    F.set_ang_vel(H, u[7] * H.y)

    O = me.Point("O")
    O.set_vel(N, 0)
    rear_contact = O.locatenew("Pr", q[0] * N.x + q[1] * N.y)
    rear_centre = rear_contact.locatenew("Rc", -rR * L.z)
    rear_mc = rear_centre.locatenew("Bo", P["xB"] * B.x + (P["zB"] + rR) * B.z)
    steer_point = rear_centre.locatenew("S", (w + c) * B.x + rR * B.z)
    front_centre = steer_point.locatenew("Fc", -c * H.x - rF * H.z)
    front_mc = steer_point.locatenew("Ho", (P["xH"] - w - c) * H.x + P["zH"] * H.z)
    down = (H.y.cross(N.z)).cross(H.y)
    down = down / sm.sqrt(1 - H.y.dot(N.z) ** 2)
    front_contact = front_centre.locatenew("Pf", rF * down)

    v_rear = rear_centre.vel(N) + R.ang_vel_in(N).cross(rR * L.z)
    v_front = front_centre.vel(N) + F.ang_vel_in(N).cross(rF * down)
    velocity_constraints = [v_rear.dot(A.x), v_rear.dot(A.y),
                            v_front.dot(A.x), v_front.dot(A.y), v_front.dot(A.z)]
    height = front_contact.pos_from(rear_contact).dot(N.z)

    bodies = [
        me.RigidBody("rear_wheel", rear_centre, R, P["mR"],
                     (me.inertia(R, P["IRxx"], P["IRyy"], P["IRxx"]), rear_centre)),
        me.RigidBody("rear_frame", rear_mc, B, P["mB"],
                     (me.inertia(B, P["IBxx"], P["IByy"], P["IBzz"], izx=P["IBxz"]),
                      rear_mc)),
        me.RigidBody("front_frame", front_mc, H, P["mH"],
                     (me.inertia(H, P["IHxx"], P["IHyy"], P["IHzz"], izx=P["IHxz"]),
                      front_mc)),
        me.RigidBody("front_wheel", front_centre, F, P["mF"],
                     (me.inertia(F, P["IFxx"], P["IFyy"], P["IFxx"]), front_centre)),
    ]
    loads = [(b.masscenter, b.mass * g * N.z) for b in bodies]
    specified, extra = {}, {}
    if steer_torque:
        T_delta = me.dynamicsymbols("T_delta")
        loads += [(H, T_delta * steer_axis), (B, -T_delta * steer_axis)]
        specified, extra = {T_delta: 0.0}, {"T_delta": T_delta}
    potential = -g * sm.Add(*[b.mass * b.masscenter.pos_from(O).dot(N.z) for b in bodies])
    kd_eqs = [qi.diff() - ui for qi, ui in zip(q, u)]
    q_ind = [q[0], q[1], q[2], q[3], q[5], q[6], q[7]]
    u_ind = [u[3], u[5], u[6]]
    u_dep = [u[0], u[1], u[2], u[4], u[7]]
    v0 = 5.0
    init = {qi: 0.0 for qi in q}
    init.update({ui: 0.0 for ui in u})
    init.update({q[3]: 0.05, u[5]: -v0 / 0.3, u[0]: v0, u[7]: -v0 / 0.35})
    constants = {P[k]: (float(v) if not isinstance(v, sm.Basic) else float(v.evalf()))
                 for k, v in MEIJAARD_2007.items()}
    return ModelDefinition(
        name="whipple-bicycle",
        title="Whipple bicycle, benchmark parameters (Meijaard et al. 2007)",
        kane_args=dict(frame=N, q_ind=q_ind, q_dep=[q[4]], u_ind=u_ind, u_dep=u_dep,
                       kd_eqs=kd_eqs, configuration_constraints=[height],
                       velocity_constraints=velocity_constraints, bodies=bodies,
                       loads=loads, potential_energy=potential),
        constants=constants, initial_state=init, t_end=5.0, specified=specified,
        symbols=dict(q=q, u=u, params=P, N=N, **extra),
        shape_specs=tuple(("Cylinder", wheel, {"radius": radius, "length": 0.1 * radius,
                                               "axis": "y"})
                          for wheel, radius in ((bodies[0], rR), (bodies[3], rF))),
        description="Self-stable between the weave speed 4.29 m/s and the capsize "
                    "speed 6.02 m/s; the default ride starts at 5 m/s with a "
                    "small lean.")
