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
