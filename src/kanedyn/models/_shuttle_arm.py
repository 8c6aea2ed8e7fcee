r"""The Shuttle Remote Manipulator System (SRMS, "Canadarm") moving a payload.

The system on which Cyril, Angeles & Misra (1991) demonstrated the natural
orthogonal complement: a six-joint arm on the orbiter performing a typical
payload manoeuvre.  The public figures, the assumptions that fill the gaps
and the manoeuvre are described in :func:`shuttle_arm`.
"""

from __future__ import annotations

import math

import sympy as sm
import sympy.physics.mechanics as me

from ..modeling import BeamMember, FlexibleBody
from ._base import ModelDefinition

__all__ = ["shuttle_arm", "quintic", "SRMS_START_DEG", "SRMS_END_DEG"]

#: Joint angles at the start of the manoeuvre, degrees (shoulder yaw,
#: shoulder pitch, elbow pitch, wrist pitch, wrist yaw, wrist roll).
SRMS_START_DEG = (0.0, 15.0, -30.0, 15.0, 0.0, 0.0)
#: Joint angles at the end of the manoeuvre, degrees (same order).
SRMS_END_DEG = (-20.0, 35.0, -50.0, 5.0, 10.0, 30.0)

# Nominal joint inertias (kg m^2): the diagonal of the mass matrix at the
# start configuration with the default parameters, used only to scale the
# servo gains (computed once with kanedyn; rounded).
_J_PAYLOAD = (3.4e6, 3.5e6, 1.6e6, 3.8e5, 1.9e5, 1.7e5)
_J_EMPTY = (3.9e4, 3.9e4, 1.1e4, 1.5e2, 58.0, 1.1)

T = me.dynamicsymbols._t


def quintic(t, start, end, duration):
    r"""Quintic rest-to-rest profile and its rate, as SymPy expressions of ``t``.

    .. math::

        q(t) = q_0 + (q_1 - q_0)\,s(\tau),\quad s = 10\tau^3 - 15\tau^4 + 6\tau^5,
        \quad \tau = \min(\max(t/T_m, 0), 1),

    so the angle is constant before 0 and after :math:`T_m`; rate and
    acceleration vanish at both ends (the clipped form needs no
    ``Piecewise``).

    Returns
    -------
    (angle, rate) : tuple of SymPy expressions, rad and rad/s.
    """
    tau = sm.Min(sm.Max(t / duration, 0), 1)
    delta = end - start
    angle = start + delta * tau ** 3 * (10 - 15 * tau + 6 * tau ** 2)
    rate = 30 * delta * tau ** 2 * (1 - tau) ** 2 / duration
    return angle, rate


def _boom_member(name, length, mass):
    """A boom as a graphite–epoxy tube (see :func:`shuttle_arm`), 4 modal coordinates."""
    radius, wall, E, G = 0.19, 1e-3, 1e11, 4e10
    area, second = 2 * math.pi * radius * wall, math.pi * radius ** 3 * wall
    per_length = mass / length
    beam = BeamMember.uniform(name, length, mass_per_length=per_length, EA=E * area,
                              GJ=G * 2 * second, EI_y=E * second, EI_z=E * second,
                              polar_inertia=per_length * radius ** 2,
                              rotary_inertia_y=per_length * radius ** 2 / 2,
                              rotary_inertia_z=per_length * radius ** 2 / 2, n_elements=16)
    reduced = beam.craig_bampton([-1], n_modes=4)
    tip = beam.n_nodes - 1
    return reduced.keep_modes(["bending_xy_1", "bending_xz_1", f"constraint_{tip}_uy",
                               f"constraint_{tip}_uz"])


def shuttle_arm(payload=True, flexible_booms=False, torque_input=False):
    r"""The Shuttle arm (SRMS) moving a Hubble-class payload, in orbit.

    Public figures (NASA; JSC "Remote Manipulator System" fact page,
    prime.jsc.nasa.gov/ROV/rms.html, and KSC image release KSC-05PD-0336):
    the arm is 50 ft 3 in (15.3 m) long and 15 in (0.38 m) in diameter, weighs
    905 lb (410 kg), and has six joints: shoulder yaw and pitch, elbow pitch,
    wrist pitch, yaw and roll; the upper boom joins shoulder and elbow, the
    lower boom elbow and wrist.  JAXA's SRMS summary (iss.jaxa.jp) quotes
    end-point speeds of 60 cm/s unloaded and 6 cm/s with a payload.  The
    payload is the Hubble Space Telescope as the SRMS deployed it on STS-31
    (HubbleSite: 11,110 kg (24,500 lb) at launch, 13.2 m long, 4.2 m in
    diameter).

    Assumptions (not public figures, stated as such): the split of the
    length, upper boom ``L_2 = 6.37`` m (shoulder to elbow), lower boom
    ``L_3 = 7.06`` m (elbow to wrist pitch), wrist pitch to wrist yaw
    ``L_4 = 0.5`` m, wrist yaw to wrist roll ``L_5 = 0.5`` m, wrist roll
    to the end-effector tip ``L_6 = 0.83`` m (15.26 m in all, the shoulder
    yaw and pitch axes meeting at the shoulder ``O``); the split of the
    410 kg, shoulder housing 40, upper arm 120, lower arm 110, wrist pitch 40,
    wrist yaw 40, wrist roll and end effector 60 kg; booms are uniform
    thin-walled tubes of radius ``r_b = 0.19`` m (axial inertia :math:`m
    r_b^2`, transverse :math:`m(r_b^2/2 + L^2/12)`), the other links
    uniform solid cylinders of that radius.  The payload is a uniform solid
    cylinder (radius ``r_p = 2.1`` m, length ``L_p = 13.2`` m), its mass
    centre ``d_p = 2.5`` m beyond the end-effector tip along the
    end-effector axis (a grapple fixture on its side) and its axis
    perpendicular to the end-effector axis.  The arm is rigid (the real
    booms and joints are flexible) unless ``flexible_booms``.

    Flexible booms (``flexible_booms=True``; assumed section, not public
    figures): each boom a graphite–epoxy tube of radius ``r_b``, 1 mm
    equivalent wall, ``E = 1e11`` Pa, ``G = 4e10`` Pa (``EI = 2.15e6`` N m^2,
    ``EA = 1.19e8`` N, ``GJ = 1.72e6`` N m^2), its mass spread uniformly;
    16 beam elements, Craig–Bampton clamped at the inboard joint with the
    outboard joint as interface node, keeping the first clamped bending mode
    in each plane and the two transverse constraint modes at the outboard
    joint (4 modal coordinates per boom), stiffness-proportional Rayleigh
    damping ``beta = 1e-3`` s; geometric stiffening on.  The next joint sits on
    the boom's tip node and turns with its rotation.  The boom lengths are
    then fixed numbers (the finite-element model needs them), not parameters.

    Environment: in orbit, microgravity, so no gravity and no potential
    energy; the shoulder is fixed to the orbiter, taken as inertial.

    Kinematics.  ``N``: orbiter frame (``N.z`` out of the payload bay).
    Joint ``i`` turns frame ``A_i`` relative to its parent by ``q_i`` (rad);
    ``u_i = q_i'`` (rad/s), so the Lagrange-based formulations apply too.
    Shoulder yaw about ``N.z``; the pitch joints about ``-y`` of the parent
    (positive angles raise the arm); wrist yaw about ``A_4.z``; wrist roll
    about ``A_5.x``, the end-effector axis.  Each link lies along its
    frame's ``x`` axis.

    Manoeuvre.  Every joint follows a quintic rest-to-rest profile
    (:func:`quintic`) from :data:`SRMS_START_DEG` to :data:`SRMS_END_DEG`
    in ``T_m = 150`` s, an unberthing-like motion of the payload (peak
    end-point speed about 6 cm/s with the payload), then holds; the
    simulation runs to 200 s.  The joint drives are PD servos on the
    profile, explicit functions of time and state (no runtime inputs):

    .. math::

        \tau_i = J_i\omega_c^2\,(q_{ref,i}(t) - q_i)
                 + 2\zeta_c J_i\omega_c\,(\dot q_{ref,i}(t) - u_i),

    with nominal joint inertias ``J_i`` (the mass-matrix diagonal at the
    start, kg m^2), bandwidth ``omega_c = 0.5`` rad/s and damping ratio
    ``zeta_c = 1``; each torque acts on the outboard link and its reaction
    on the inboard one (the shoulder's on the orbiter), so the drive power
    is :math:`\sum_i \tau_i u_i`.

    With ``torque_input=True`` the six joint torques are specified inputs
    ``tau1(t) .. tau6(t)`` (N m, positive about each joint's axis as above)
    in place of the servos, for optimal control: the profile, the gains and
    their constants ``T_m``, ``omega_c``, ``zeta_c``, ``J_1 .. J_6`` are then
    not in the model.

    Parameters
    ----------
    payload : bool
        Carry the payload (default) or move the empty arm (the gains are
        then scaled by the empty arm's joint inertias).
    flexible_booms : bool
        Make the upper and lower booms flexible bodies.
    torque_input : bool
        The joint torques as inputs ``tau1 .. tau6`` instead of the PD servos.

    Returns
    -------
    ModelDefinition
        ``symbols`` holds ``q``, ``u``, the reference angles and rates
        ``q_ref``, ``u_ref`` (expressions in ``t``), the joint torques
        ``torques``, the frames ``N, A``, the end-effector ``tip`` point and
        its position ``tip_position`` (a 3x1 matrix in ``N``, m); with
        ``torque_input`` the torques are the input symbols and ``q_ref``,
        ``u_ref`` are still the quintic profile, and ``servo`` holds the
        servos' numbers (``J``, kg m^2, ``omega_c``, rad/s, ``zeta_c``) for a
        tracking term.
    """
    q = me.dynamicsymbols("q1:7")
    u = me.dynamicsymbols("u1:7")
    L2, L3, L4, L5, L6, rb = sm.symbols("L_2 L_3 L_4 L_5 L_6 r_b", positive=True)
    m1, m2, m3, m4, m5, m6 = sm.symbols("m_1:7", positive=True)
    J = sm.symbols("J_1:7", positive=True)
    omega_c, zeta_c, T_m = sm.symbols("omega_c zeta_c T_m", positive=True)

    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    A = [me.ReferenceFrame(f"A{i}") for i in range(1, 7)]
    axes = [N.z, -A[0].y, -A[1].y, -A[2].y, A[3].z, A[4].x]
    parents = [N] + A[:5]
    for i, (F, parent, axis) in enumerate(zip(A, parents, axes)):
        if flexible_booms and i in (2, 3):
            continue  # oriented from the boom's tip frame below
        F.orient_axis(parent, axis, q[i])
        F.set_ang_vel(parent, u[i] * axis)
    nominal = {L2: 6.37, L3: 7.06, L4: 0.5, L5: 0.5, L6: 0.83, rb: 0.19,
               m1: 40.0, m2: 120.0, m3: 110.0, m4: 40.0, m5: 40.0, m6: 60.0,
               omega_c: 0.5, zeta_c: 1.0, T_m: 150.0}

    def tube(frame, m, length):  # thin-walled tube along the frame's x axis
        return me.inertia(frame, m * rb ** 2, m * (rb ** 2 / 2 + length ** 2 / 12),
                          m * (rb ** 2 / 2 + length ** 2 / 12))

    def cylinder(frame, m, length):  # solid cylinder along the frame's x axis
        side = m * (3 * rb ** 2 + length ** 2) / 12
        return me.inertia(frame, m * rb ** 2 / 2, side, side)

    h1 = sm.Rational(1, 2)  # shoulder housing length along the yaw axis, m
    housing = me.inertia(A[0], m1 * (3 * rb ** 2 + h1 ** 2) / 12,
                         m1 * (3 * rb ** 2 + h1 ** 2) / 12, m1 * rb ** 2 / 2)
    bodies = [me.RigidBody("shoulder", O, A[0], m1, (housing, O))]
    booms = {}
    if flexible_booms:  # lengths and masses as numbers: the FE model needs them
        for symbol in (L2, L3, m2, m3):
            del nominal[symbol]
        L2, L3 = 6.37, 7.06
    joint = O
    for i, (name, m, length, shape) in enumerate(
            (("upper_arm", m2, L2, tube), ("lower_arm", m3, L3, tube),
             ("wrist_pitch", m4, L4, cylinder), ("wrist_yaw", m5, L5, cylinder),
             ("end_effector", m6, L6, cylinder)), start=1):
        F = A[i]
        if flexible_booms and i in (1, 2):
            member = _boom_member(name, length, 120.0 if i == 1 else 110.0)
            boom = FlexibleBody(name, F, joint, member, rayleigh=(0.0, 1e-3))
            booms[name] = boom
            bodies.append(boom)
            joint = boom.node_point(boom.member.n_nodes - 1)
            tip_frame = boom.node_frame(boom.member.n_nodes - 1)
            parents[i + 1] = tip_frame  # the next joint turns with the boom's tip
            axes[i + 1] = -tip_frame.y
            A[i + 1].orient_axis(tip_frame, axes[i + 1], q[i + 1])
            A[i + 1].set_ang_vel(tip_frame, u[i + 1] * axes[i + 1])
            continue
        G = joint.locatenew(f"G{i + 1}", length / 2 * F.x)
        G.v2pt_theory(joint, N, F)
        bodies.append(me.RigidBody(name, G, F, m, (shape(F, m, length), G)))
        nxt = joint.locatenew(f"P{i + 1}", length * F.x)
        nxt.v2pt_theory(joint, N, F)
        joint = nxt
    tip = joint

    constants = nominal
    symbols = dict(q=q, u=u, N=N, A=A, O=O, tip=tip, T_m=T_m, omega_c=omega_c,
                   zeta_c=zeta_c, J=J)
    if payload:
        m_p, r_p, L_p, d_p = sm.symbols("m_p r_p L_p d_p", positive=True)
        P = me.ReferenceFrame("P")  # payload axes: P.x along the cylinder
        P.orient_axis(A[5], A[5].y, sm.pi / 2)
        Gp = tip.locatenew("Gp", d_p * A[5].x)
        Gp.v2pt_theory(tip, N, A[5])
        side = m_p * (3 * r_p ** 2 + L_p ** 2) / 12
        bodies.append(me.RigidBody("payload", Gp, P, m_p,
                                   (me.inertia(P, m_p * r_p ** 2 / 2, side, side), Gp)))
        constants.update({m_p: 11110.0, r_p: 2.1, L_p: 13.2, d_p: 2.5})
        symbols.update(m_p=m_p, P=P, Gp=Gp)
    constants.update(zip(J, _J_PAYLOAD if payload else _J_EMPTY))

    q_ref, u_ref, torques, loads = [], [], [], []
    inputs = me.dynamicsymbols("tau1:7") if torque_input else None
    for i in range(6):
        angle, rate = quintic(T, math.radians(SRMS_START_DEG[i]),
                              math.radians(SRMS_END_DEG[i]), T_m)
        if torque_input:
            tau = inputs[i]
        else:
            tau = (J[i] * omega_c ** 2 * (angle - q[i])
                   + 2 * zeta_c * J[i] * omega_c * (rate - u[i]))
        q_ref.append(angle)
        u_ref.append(rate)
        torques.append(tau)
        loads.append((A[i], tau * axes[i]))
        if i > 0:  # reaction on the inboard link (the orbiter's is not modelled)
            loads.append((parents[i], -tau * axes[i]))
    symbols.update(q_ref=q_ref, u_ref=u_ref, torques=torques,
                   tip_position=tip.pos_from(O).to_matrix(N))
    specified, title = {}, "PD-tracked manoeuvre"
    if torque_input:  # the servos' constants are then not in the equations
        servo = {"J": tuple(constants.pop(j) for j in J), "omega_c": constants.pop(omega_c),
                 "zeta_c": constants.pop(zeta_c)}
        duration = constants.pop(T_m)
        symbols.update(q_ref=[a.subs(T_m, duration) for a in q_ref],
                       u_ref=[r.subs(T_m, duration) for r in u_ref],
                       tau=list(inputs), servo=servo)
        specified, title = {tau: 0.0 for tau in inputs}, "joint torques tau1..tau6 as inputs"

    initial = {qi: math.radians(a) for qi, a in zip(q, SRMS_START_DEG)}
    initial.update({ui: 0.0 for ui in u})
    what = "with a Hubble-class payload (11,110 kg)" if payload else "without payload"
    kind = "flexible booms, " if flexible_booms else ""
    symbols.update(booms=booms)
    modal_q = [s for boom in booms.values() for s in boom.q]
    modal_u = [s for boom in booms.values() for s in boom.u]
    modal_kd = [e for boom in booms.values() for e in boom.kd_eqs]
    return ModelDefinition(
        name="shuttle-arm",
        title=f"Shuttle arm (SRMS, 6 revolute joints, {kind}{what}), {title}",
        kane_args=dict(frame=N, q_ind=list(q) + modal_q, u_ind=list(u) + modal_u,
                       kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)] + modal_kd,
                       bodies=bodies, loads=loads),
        constants=constants, initial_state=initial, t_end=200.0, symbols=symbols,
        specified=specified,
        description="The system of Cyril, Angeles & Misra (1991): compare "
                    "method='orthogonal-complement' (with BDF) and Kane's method. "
                    "Microgravity; joint angles follow quintic profiles over T_m = "
                    "150 s under PD servos.")
