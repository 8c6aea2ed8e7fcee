"""Round trip: actuator forces from the inverse dynamics drive the forward model.

The forces are an exact function of time (pose(t) -> inverse kinematics ->
``ActuatorMap.forces`` on the model without drive-train elements); the forward
model is the definition's ``kane_args`` with the actuators' loads
``actuator.to_loads(F_i(t))`` and, for ball screws, the drive-train inertia
elements among its bodies.  Integrated with DOP853 at rtol = atol = 1e-11 from
the prescribed initial state, the platform follows the prescribed pose.

The Stewart platform driven by prescribed leg forces is open-loop unstable:
a pose error grows about twofold every 0.1 s (measured), so over 2 s the
round-off of the forces is amplified some 10^6 times; its manoeuvre here
lasts 1 s.
"""

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.formulations import formulate

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("name, trajectory, t_end", [
    ("3rrr", "quintic", 2.0),
    ("stewart-platform", "quintic", 1.0),
    ("out-parallel-6dof", "sinusoid", 2.0),
])
def test_forces_drive_the_platform_along_the_prescription(name, trajectory, t_end):
    study = kd.studies.inverse_study(name, trajectory=trajectory, t_end=t_end, points=21)
    assert study.power_residual() < 1e-12
    error = study.forward_check()
    assert error < 1e-7, f"{name}: pose error {error:.3e}"


def test_actuator_map_detects_the_drive_elements():
    """Forces on the model with the ball screws' drive elements equal those without."""
    definition = kd.models.build("out-parallel-6dof")
    plain = definition.numeric(definition.derive())
    args = dict(definition.kane_args)
    elements = [a.inertia_element() for a in definition.actuators]
    assert all(e is not None for e in elements)
    args["bodies"] = list(args["bodies"]) + elements
    with_drives = formulate(**args).numeric(constants=plain.constants)
    a_plain = kd.ActuatorMap(plain, definition.actuators)
    a_drive = kd.ActuatorMap(with_drives, definition.actuators)
    assert a_plain.drive_elements == ()
    assert a_drive.drive_elements == tuple(f"carriage{j}_drive" for j in range(1, 7))
    t = np.linspace(0.0, 1.0, 5)
    home = np.array([0, 0, 0.8, 0, 0, 0])
    pose, rate, accel = kd.models.quintic_pose(t, home, home + [0.04, -0.03, 0.05, 0.1,
                                                                -0.05, 0.15], 1.0)
    q, u, ud = kd.models.out_parallel_ik(pose, rate, accel)
    for j in range(1, 4):
        y = np.concatenate([q[j], u[j]])
        f_plain = a_plain.forces(t[j], y, ud[j])
        f_drive = a_drive.forces(t[j], y, ud[j])
        scale = np.max(np.abs(f_plain.forces))
        assert np.allclose(f_drive.forces, f_plain.forces, rtol=0, atol=1e-10 * scale)
        # and the reflected inertia is a large part of them: counted twice or not
        # at all would show
        bare = f_plain.forces - np.array([a.reflected_inertia for a in
                                          definition.actuators], float) \
            * f_plain.rate_derivatives
        assert np.max(np.abs(bare - f_plain.forces)) > 1e-3 * scale
