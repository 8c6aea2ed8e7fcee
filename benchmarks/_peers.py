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
