"""Solo12 on the ground in the peers' terms: its URDF (example-robot-data) with the
joints locked in the standing posture, and MuJoCo's model of that file with the
feet as balls; used by tests/test_ground.py and docs/make_ground_figure.py.

The feet are balls of the foot mesh's radius about the ``*_FOOT`` frames; the
standing posture is the SRDF's (hips 0, HFE +-0.8 rad, KFE -+1.6 rad).
"""

import xml.etree.ElementTree as ET

import numpy as np

FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
RADIUS = 0.016  # m
POSTURE = {"FL_HFE": 0.8, "FR_HFE": 0.8, "HL_HFE": -0.8, "HR_HFE": -0.8,
           "FL_KFE": -1.6, "FR_KFE": -1.6, "HL_KFE": 1.6, "HR_KFE": 1.6}


def solo12_urdf():
    """The path of Solo12's URDF; raises PackageNotFoundError without
    example-robot-data."""
    from importlib.metadata import distribution
    robots = distribution("example-robot-data").locate_file(
        "cmeel.prefix/share/example-robot-data/robots")
    return robots / "solo_description/robots/solo12.urdf"


def posture(joint):
    """The standing angle of a joint, rad (the hips' HAA: 0)."""
    return POSTURE.get(joint, 0.0)


def locked_urdf(path, out):
    """Write to ``out`` the URDF at ``path`` with every revolute joint locked in
    the standing posture (made fixed, its origin turned by the posture angle about
    its axis); returns ``out``."""
    from scipy.spatial.transform import Rotation
    tree = ET.parse(path)
    for joint in tree.getroot().iter("joint"):
        if joint.get("type") != "revolute":
            continue
        origin = joint.find("origin")
        axis = np.array([float(v) for v in joint.find("axis").get("xyz").split()])
        turned = (Rotation.from_euler("xyz", [float(v) for v in origin.get("rpy").split()])
                  * Rotation.from_rotvec(axis * posture(joint.get("name"))))
        origin.set("rpy", " ".join(repr(float(a)) for a in turned.as_euler("xyz")))
        joint.set("type", "fixed")
        for tag in ("axis", "limit", "dynamics"):
            for element in joint.findall(tag):
                joint.remove(element)
    tree.write(out)
    return out


def mujoco_model(mujoco, path, mu):
    """MuJoCo's model of the (locked) robot in the URDF at ``path``: its own reader
    of the file (bodies, masses, inertias; visual and collision meshes left out), a
    free joint, balls at the foot frames as its only geoms, a floor plane of
    friction ``mu``; stiff contacts (time constant 0.2 ms, damping ratio 5: no
    rebound; impedance 0.99 to 0.999), elliptic friction cones, 0.02 ms steps."""
    root = ET.parse(path).getroot()
    for link in root.iter("link"):
        for tag in ("visual", "collision"):
            for element in link.findall(tag):
                link.remove(element)
    ET.SubElement(ET.SubElement(root, "mujoco"), "compiler", fusestatic="false",
                  discardvisual="true", balanceinertia="false")
    spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
    spec.option.timestep = 2e-5
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.body("base_link").add_freejoint()
    contact = dict(friction=[mu, 0.0, 0.0], solref=[2e-4, 5.0],
                   solimp=[0.99, 0.999, 0.001, 0.5, 2.0])
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5.0, 5.0, 0.1], **contact)
    for foot in FEET:
        spec.body(foot).add_geom(name=foot, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                                 size=[RADIUS, 0.0, 0.0], mass=0.0, **contact)
    return spec.compile()


def mujoco_run(mujoco, model, y0, t_end, every=None):
    """MuJoCo from kanedyn's state ``y0`` of the locked robot (position, body-fixed
    x-y-z angles, speeds along the world axes): a dict with the first time each
    foot penetrates the floor (``touchdown``), the final ``position`` (3,),
    ``angles`` (3,), ``qvel`` (6,), the summed ``normal`` force (N) and, with
    ``every`` (s), samples ``t`` (n,), ``q`` (n, 6: position and angles) and
    ``forces`` (n, 4: the feet's normal forces)."""
    from scipy.spatial.transform import Rotation
    data = mujoco.MjData(model)
    data.qpos[:3] = y0[:3]
    x, y, z, w = Rotation.from_euler("XYZ", y0[3:6]).as_quat()
    data.qpos[3:7] = w, x, y, z
    data.qvel[:3] = y0[6:9]
    feet = {model.geom(foot).id: k for k, foot in enumerate(FEET)}
    touchdown, samples = {}, []
    wrench = np.zeros(6)

    def angles():
        w, x, y, z = data.qpos[3:7]
        return Rotation.from_quat([x, y, z, w]).as_euler("XYZ")

    def normal_forces():
        out = np.zeros(len(FEET))
        for i in range(data.ncon):
            mujoco.mj_contactForce(model, data, i, wrench)
            for geom in (data.contact.geom1[i], data.contact.geom2[i]):
                if geom in feet:
                    out[feet[geom]] += wrench[0]
        return out

    next_sample = 0.0
    while data.time < t_end:
        mujoco.mj_step(model, data)
        if len(touchdown) < len(feet) and data.ncon:
            touching = data.contact.dist < 0
            for geom in np.concatenate([data.contact.geom1[touching],
                                        data.contact.geom2[touching]]):
                if geom in feet:
                    touchdown.setdefault(FEET[feet[geom]], data.time)
        if every is not None and data.time >= next_sample:
            samples.append((data.time, *data.qpos[:3], *angles(), *normal_forces()))
            next_sample += every
    out = dict(touchdown=touchdown, position=data.qpos[:3].copy(), angles=angles(),
               qvel=data.qvel.copy(), normal=normal_forces().sum())
    if samples:
        samples = np.array(samples)
        out.update(t=samples[:, 0], q=samples[:, 1:7], forces=samples[:, 7:])
    return out
