"""The 3D chain built in the peers' own terms, for same-run comparisons.

The chain matches ``kanedyn.models.chain3d``: joint k turns link k about its
parent's z axis (even k) or x axis (odd k); link k has length ``l`` along its
own y axis, mass ``m`` at ``l/2`` on that axis and central inertia
``diag(I_xx, I_yy, I_zz)``; gravity ``g`` along ``-z``.
"""

import numpy as np

DEFAULTS = {"m": 1.0, "l": 0.5, "g": 9.81, "I_xx": 0.025, "I_yy": 0.005, "I_zz": 0.025}


def pinocchio_chain(n, params=None):
    """(pinocchio Model, Data) of the chain; raises ImportError without pinocchio."""
    import pinocchio as pin

    p = dict(DEFAULTS, **(params or {}))
    model = pin.Model()
    parent = 0
    placement = pin.SE3.Identity()
    inertia = pin.Inertia(p["m"], np.array([0.0, p["l"] / 2, 0.0]),
                          np.diag([p["I_xx"], p["I_yy"], p["I_zz"]]))
    for k in range(n):
        joint = pin.JointModelRZ() if k % 2 == 0 else pin.JointModelRX()
        parent = model.addJoint(parent, joint, placement, f"joint{k + 1}")
        model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
        placement = pin.SE3(np.eye(3), np.array([0.0, p["l"], 0.0]))
    model.gravity = pin.Motion(np.array([0.0, 0.0, -p["g"], 0.0, 0.0, 0.0]))
    return model, model.createData()


def sympy_docs_chain(n):
    """The 3D chain written as SymPy's documentation writes models.

    ``n`` rigid links; joint k turns link k about its parent's x axis (odd k)
    or y axis (even k) by ``q_k`` (``orient_axis``, angular velocities from
    ``q'``); link k has its own length ``l_k`` along its z axis, mass ``m_k``
    at ``l_k / 2`` and a full central inertia dyadic (``me.inertia`` with
    products of inertia); velocities by ``v2pt_theory``; gravity ``g`` along
    ``-N.z``; kinematic equations ``q_k' = u_k``.

    Returns
    -------
    dict
        Keyword arguments of ``KanesMethod`` / ``kanes_equations`` and of
        :func:`kanedyn.kane`: ``frame``, ``q_ind``, ``u_ind``, ``kd_eqs``,
        ``bodies``, ``loads``; plus ``constants``, a ``{Symbol: value}``
        dict of physically consistent parameters (not a keyword of either).
    """
    import sympy as sm
    import sympy.physics.mechanics as me

    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    g = sm.symbols("g")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    parent, joint = N, O
    bodies, loads, constants = [], [], {g: 9.81}
    for k in range(1, n + 1):
        m, l = sm.symbols(f"m{k} l{k}")
        Ixx, Iyy, Izz, Ixy, Iyz, Izx = sm.symbols(
            f"I{k}_xx I{k}_yy I{k}_zz I{k}_xy I{k}_yz I{k}_zx")
        A = me.ReferenceFrame(f"A{k}")
        A.orient_axis(parent, parent.x if k % 2 else parent.y, q[k - 1])
        G = joint.locatenew(f"G{k}", l / 2 * A.z)
        G.v2pt_theory(joint, N, A)
        P = joint.locatenew(f"P{k}", l * A.z)
        P.v2pt_theory(joint, N, A)
        bodies.append(me.RigidBody(f"link{k}", G, A, m,
                                   (me.inertia(A, Ixx, Iyy, Izz, Ixy, Iyz, Izx), G)))
        loads.append((G, -m * g * N.z))
        constants.update({m: 1.0 + 0.1 * k, l: 0.5 + 0.05 * k,
                          Ixx: 0.03, Iyy: 0.04, Izz: 0.02,
                          Ixy: 0.002 * k, Iyz: -0.003, Izx: 0.001})
        parent, joint = A, P
    return {"frame": N, "q_ind": list(q), "u_ind": list(u),
            "kd_eqs": [qk.diff() - uk for qk, uk in zip(q, u)],
            "bodies": bodies, "loads": loads, "constants": constants}


def humanoid_links():
    """The joints of a humanoid-like tree of 30 bodies, as data.

    A fixed pelvis (the ground); a waist/spine chain of 3 joints; a neck and head
    of 3; two arms of 6 (shoulder 3, elbow 1, wrist 2) from the top of the spine;
    two legs of 6 (hip 3, knee 1, ankle 2) from the pelvis.  Every joint is
    revolute and moves one new link.

    Returns
    -------
    list of tuple
        ``(joint, parent link, child link, origin xyz in the parent (m), axis)``,
        parents before children.
    """
    joints = []

    def limb(prefix, parent, origin, axes, step):
        for k, axis in enumerate(axes):
            child = f"{prefix}{k + 1}"
            joints.append((f"j_{child}", parent, child, origin if k == 0 else step, axis))
            parent = child
        return parent

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    top = limb("spine", "pelvis", (0.0, 0.0, 0.1), (z, y, x), (0.0, 0.0, 0.15))
    limb("head", top, (0.0, 0.0, 0.2), (z, y, x), (0.0, 0.0, 0.05))
    for side, sy in (("l", 1.0), ("r", -1.0)):
        limb(f"{side}arm", top, (0.0, 0.2 * sy, 0.15), (y, x, z, y, z, x), (0.0, 0.0, -0.12))
        limb(f"{side}leg", "pelvis", (0.0, 0.1 * sy, -0.05), (z, x, y, y, y, x),
             (0.0, 0.0, -0.2))
    return joints


def humanoid_urdf():
    """URDF text of :func:`humanoid_links` (masses 0.5-2 kg, mass centres off the
    joint axes, full central inertias), read by both kanedyn and Pinocchio."""
    joints = humanoid_links()
    links = ["pelvis"] + [child for _, _, child, _, _ in joints]
    lines = ['<?xml version="1.0"?>', '<robot name="humanoid30">']
    for k, name in enumerate(links):
        m = 0.5 + 1.5 * ((7 * k) % 11) / 10.0
        lines += [f'  <link name="{name}"><inertial>',
                  f'    <origin xyz="0.01 {0.005 * (k % 3)} -0.06" rpy="0 0 0"/>',
                  f'    <mass value="{m:.3f}"/>',
                  f'    <inertia ixx="{0.01 * m:.5f}" ixy="0.0005" ixz="-0.0003" '
                  f'iyy="{0.012 * m:.5f}" iyz="0.0002" izz="{0.006 * m:.5f}"/>',
                  '  </inertial></link>']
    for name, parent, child, xyz, axis in joints:
        lines += [f'  <joint name="{name}" type="revolute">',
                  f'    <parent link="{parent}"/><child link="{child}"/>',
                  f'    <origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="0 0 0"/>',
                  f'    <axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>',
                  '    <limit lower="-3.2" upper="3.2" effort="100" velocity="20"/>',
                  '  </joint>']
    lines.append("</robot>")
    return "\n".join(lines)


def pinocchio_urdf(text):
    """(pinocchio Model, Data) of URDF text (fixed base, Pinocchio's gravity)."""
    import pinocchio as pin

    model = pin.buildModelFromXML(text)
    return model, model.createData()
