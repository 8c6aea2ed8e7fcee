r"""A 6-dof out-parallel manipulator: carriages on fixed rails drive struts to a platform.

In an *out-parallel* manipulator (the kind whose inverse dynamics Zhao & Gao
formulate by virtual work, Robotica 2009) the actuators sit outside the
workspace: six carriages, each driven by a ball screw along a fixed rail,
carry six struts of fixed length, and the struts hold the moving platform.
The carriage travels are the actuated coordinates; the platform pose is the
independent one here, as in :func:`~kanedyn.models.stewart_platform`, because
the inverse kinematics (pose -> carriage travels) is explicit, leg by leg:
:func:`out_parallel_ik`.
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ConstraintError, ModelError
from ..modeling import BallScrew, JointActuator, drive_inputs
from ._base import ModelDefinition
from ._parallel import _rotation_xyz

__all__ = ["out_parallel_6dof", "OUT_PARALLEL_GEOMETRY", "OUT_PARALLEL_INERTIA",
           "out_parallel_anchors", "out_parallel_ik"]

#: Default geometry of :func:`out_parallel_6dof` (m, rad): rail circle radius
#: ``R_b``, platform anchor circle radius ``r_p``, strut length ``L``, home
#: height ``h`` of the platform centre above the rails' zero, half spread
#: ``gamma_b`` of the rail pairs and ``gamma_p`` of the platform anchor pairs.
OUT_PARALLEL_GEOMETRY = {"R_b": 0.6, "r_p": 0.25, "L": 0.6, "h": 0.8,
                         "gamma_b": np.radians(15.0), "gamma_p": np.radians(45.0)}

#: Default masses (kg), screw lead (m), drive-train inertias (kg m^2) and the
#: screw's forward and back-driving efficiencies ``eta``, ``eta_back`` of
#: :func:`out_parallel_6dof`.
OUT_PARALLEL_INERTIA = {"m_p": 20.0, "m_s": 2.0, "m_c": 5.0, "lead": 0.01,
                        "J_r": 2.0e-4, "J_cp": 1.0e-4, "J_sc": 3.0e-4,
                        "eta": 0.9, "eta_back": 0.8}


def _geometry(geometry):
    geo = dict(OUT_PARALLEL_GEOMETRY)
    for key, value in (geometry or {}).items():
        if key not in geo:
            raise ModelError(f"out-parallel-6dof: unknown geometry parameter {key!r}; "
                             f"known: {', '.join(geo)}")
        geo[key] = float(value)
    return geo


def out_parallel_anchors(geometry=None):
    r"""Rail feet and platform anchors of :func:`out_parallel_6dof`, leg by leg.

    Rail ``j`` is vertical (direction ``N.z``) through
    :math:`A_{0j} = R_b(\cos\beta_j, \sin\beta_j, 0)`, :math:`\beta = 120°k
    \mp \gamma_b`; its strut ends at the platform anchor (platform frame)
    :math:`c_j = r_p(\cos\pi_j, \sin\pi_j, 0)`, :math:`\pi = 120°k \mp
    \gamma_p`, ``k = 0, 1, 2``.

    Parameters
    ----------
    geometry : dict, optional
        Overrides of :data:`OUT_PARALLEL_GEOMETRY` by name.

    Returns
    -------
    A0, e, c : ndarray, shape (6, 3)
        Rail feet in ``N`` (m), rail unit directions in ``N`` and platform
        anchors in the platform frame (m).
    """
    geo = _geometry(geometry)
    beta, pi = [], []
    for k in range(3):
        for sign in (-1, 1):
            beta.append(2 * np.pi * k / 3 + sign * geo["gamma_b"])
            pi.append(2 * np.pi * k / 3 + sign * geo["gamma_p"])
    beta, pi = np.array(beta), np.array(pi)
    A0 = geo["R_b"] * np.stack([np.cos(beta), np.sin(beta), 0 * beta], axis=1)
    e = np.tile([0.0, 0.0, 1.0], (6, 1))
    c = geo["r_p"] * np.stack([np.cos(pi), np.sin(pi), 0 * pi], axis=1)
    return A0, e, c


def _rows(value, k, name):
    if value is None:
        return np.zeros((k, 6))
    V = np.atleast_2d(np.asarray(value, dtype=float))
    if V.shape != (k, 6):
        raise ValueError(f"out_parallel_ik: {name} must have the pose's shape (k, 6), "
                         f"got {np.shape(value)}")
    return V


def out_parallel_ik(pose, rate=None, accel=None, geometry=None):
    r"""Inverse kinematics of :func:`out_parallel_6dof` in closed form.

    Leg ``j``: the carriage at :math:`A_j = A_{0j} + s_j e_j` and the
    platform anchor :math:`C_j = p + R c_j` are a strut length apart,
    :math:`|A_{0j} + s_j e_j - C_j| = L`.  With :math:`w = C_j - A_{0j}`,

    .. math:: s_j = e\cdot w - \sqrt{(e\cdot w)^2 - |w|^2 + L^2}

    (the home branch: the carriage below the anchor).  With :math:`d = C_j -
    A_j = L\hat l`, the rates follow from :math:`d\cdot(\dot C - \dot s e) = 0`
    and its derivative: :math:`\dot s = d\cdot\dot C/(d\cdot e)`,
    :math:`\ddot s = (d\cdot\ddot C + |\dot C - \dot s e|^2)/(d\cdot e)`.  The
    strut direction :math:`\hat l = (\sin b, -\sin a\cos b, \cos a\cos b)`
    gives the universal-joint angles ``a = atan2(-l_y, l_z)``,
    ``b = asin(l_x)`` and their rates.

    Parameters
    ----------
    pose : array_like, shape (6,) or (k, 6)
        ``x, y, z`` (m), body-fixed X-Y-Z angles ``phi_x, phi_y, phi_z`` (rad).
    rate, accel : array_like, same shape as ``pose``, optional
        Pose rates (m/s, rad/s) and their rates (m/s², rad/s²); zero if omitted.
    geometry : dict, optional
        Overrides of :data:`OUT_PARALLEL_GEOMETRY`.

    Returns
    -------
    q, u, udot : ndarray, shape (k, 24) (or (24,) for a single pose)
        Coordinates, speeds and their rates in the model's order: the pose,
        then ``s1..6`` (m), ``a1..6``, ``b1..6`` (rad).

    Raises
    ------
    ConstraintError
        When a strut cannot reach its platform anchor from its rail; the
        message names the leg, the point and by how much the strut is too
        short (m).  Also at the end of a leg's reach, where the strut is
        perpendicular to its rail and the carriage rate is undetermined.
    """
    single = np.ndim(pose) == 1
    P = np.atleast_2d(np.asarray(pose, dtype=float))
    if P.shape[-1] != 6 or P.ndim != 2:
        raise ValueError(f"out_parallel_ik: pose must have shape (6,) or (k, 6), "
                         f"got {np.shape(pose)}")
    k = len(P)
    V, Acc = _rows(rate, k, "rate"), _rows(accel, k, "accel")
    geo = _geometry(geometry)
    L = geo["L"]
    A0, E, c = out_parallel_anchors(geometry)
    a_, b_, _ = P[:, 3], P[:, 4], P[:, 5]
    R = _rotation_xyz(P[:, 3], P[:, 4], P[:, 5])                     # (k, 3, 3)
    # angular velocity w = G(a, b) phi' and acceleration G phi'' + G' phi'
    ca, sa, cb, sb = np.cos(a_), np.sin(a_), np.cos(b_), np.sin(b_)
    da, db = V[:, 3], V[:, 4]
    G = np.zeros((k, 3, 3))
    G[:, 0, 0] = 1.0
    G[:, 1, 1], G[:, 2, 1] = ca, sa
    G[:, 0, 2], G[:, 1, 2], G[:, 2, 2] = sb, -sa * cb, ca * cb
    Gd = np.zeros((k, 3, 3))
    Gd[:, 1, 1], Gd[:, 2, 1] = -sa * da, ca * da
    Gd[:, 0, 2] = cb * db
    Gd[:, 1, 2] = -ca * cb * da + sa * sb * db
    Gd[:, 2, 2] = -sa * cb * da - ca * sb * db
    w = np.einsum("kij,kj->ki", G, V[:, 3:])
    alpha = np.einsum("kij,kj->ki", G, Acc[:, 3:]) + np.einsum("kij,kj->ki", Gd, V[:, 3:])
    q = np.zeros((k, 24))
    u = np.zeros((k, 24))
    ud = np.zeros((k, 24))
    q[:, :6], u[:, :6], ud[:, :6] = P, V, Acc
    for j in range(6):
        r = np.einsum("kij,j->ki", R, c[j])                            # R c_j
        C = P[:, :3] + r
        vC = V[:, :3] + np.cross(w, r)
        aC = Acc[:, :3] + np.cross(alpha, r) + np.cross(w, np.cross(w, r))
        e = E[j]
        wv = C - A0[j]
        along = wv @ e
        across = np.sqrt(np.maximum(np.einsum("ki,ki->k", wv, wv) - along ** 2, 0.0))
        short = across - L
        bad = np.flatnonzero(short > 0)
        if bad.size:
            i = bad[0]
            raise ConstraintError(
                f"out-parallel-6dof: leg {j + 1} cannot reach its platform anchor at "
                f"point {i} (pose {np.array2string(P[i], precision=6)}): the strut is "
                f"{short[i]:.6g} m too short (anchor {across[i]:.6g} m from rail {j + 1}, "
                f"strut length {L:.6g} m)"
                + (f"; {bad.size} points out of reach of this leg" if bad.size > 1 else ""))
        s = along - np.sqrt(L ** 2 - across ** 2)
        d = wv - s[:, None] * e                                        # C - A, length L
        de = d @ e
        flat = np.flatnonzero(de <= 1e-12 * L)
        if flat.size:
            i = flat[0]
            raise ConstraintError(
                f"out-parallel-6dof: leg {j + 1} at point {i} (pose "
                f"{np.array2string(P[i], precision=6)}): the strut is perpendicular to "
                f"rail {j + 1} (at the end of its reach), so the carriage's rate is not "
                "determined by the platform's")
        sd = np.einsum("ki,ki->k", d, vC) / de
        rel_v = vC - sd[:, None] * e
        sdd = (np.einsum("ki,ki->k", d, aC) + np.einsum("ki,ki->k", rel_v, rel_v)) / de
        rel_a = aC - sdd[:, None] * e
        lv, ldot, lddot = d / L, rel_v / L, rel_a / L
        lx, ly, lz = lv.T
        dlx, dly, dlz = ldot.T
        ddlx, ddly, ddlz = lddot.T
        yz2 = ly ** 2 + lz ** 2
        num = -dly * lz + ly * dlz
        a_j = np.unwrap(np.arctan2(-ly, lz))
        da_j = num / yz2
        dda_j = (-ddly * lz + ly * ddlz) / yz2 - num * 2 * (ly * dly + lz * dlz) / yz2 ** 2
        root = np.sqrt(1 - lx ** 2)
        b_j = np.arcsin(lx)
        db_j = dlx / root
        ddb_j = ddlx / root + lx * dlx ** 2 / root ** 3
        for col, values in ((6, (s, sd, sdd)), (12, (a_j, da_j, dda_j)),
                            (18, (b_j, db_j, ddb_j))):
            q[:, col + j], u[:, col + j], ud[:, col + j] = values
    if single:
        return q[0], u[0], ud[0]
    return q, u, ud


def out_parallel_6dof(machine=None, force_input=False):
    r"""A 6-dof out-parallel manipulator: six ball-screw carriages on vertical rails.

    Geometry (:data:`OUT_PARALLEL_GEOMETRY`, :func:`out_parallel_anchors`).
    Six vertical rails (direction ``N.z``) stand outside the workspace on a
    circle of radius ``R_b = 0.6 m``, in pairs at :math:`120°k \mp 15°`.  A
    carriage slides on each rail (travel ``s{j}``, m, from the rail's foot in
    the plane ``z = 0``; the actuated coordinate).  A strut of fixed length
    ``L = 0.6 m`` joins the carriage (universal joint, angles ``a{j}`` about
    ``N.x`` then ``b{j}`` about the turned ``y``; the strut axis is the
    resulting ``z``, pointing up to the platform) to the platform anchor
    :math:`c_j = r_p(\cos\pi_j, \sin\pi_j, 0)`, ``r_p = 0.25 m``,
    :math:`\pi_j = 120°k \mp 45°` (spherical joint).  Home pose: platform
    centre at ``h = 0.8 m`` on the axis, level; there each strut spans
    0.403 m across and 0.444 m up, the carriages at ``s = 0.356 m``.

    Inertias (:data:`OUT_PARALLEL_INERTIA`).  Platform: ``m_p = 20 kg``, a
    uniform disc of radius ``r_p``: :math:`I_{xx} = I_{yy} = m_p r_p^2/4`,
    :math:`I_{zz} = m_p r_p^2/2`, mass centre at the platform centre.  Struts:
    ``m_s = 2 kg`` uniform slender rods, mass centre half-way, :math:`m_s
    L^2/12` about axes across the strut, none along it.  Carriages:
    ``m_c = 5 kg`` (particles: they only translate).  Gravity ``g = 9.81
    m/s²`` along ``-N.z``.  Drive trains (declared as actuators, not bodies):
    each carriage is driven by a ball screw of lead ``lead = 10 mm`` with
    rotor, coupler and screw inertias ``J_r = 2e-4``, ``J_cp = 1e-4``,
    ``J_sc = 3e-4 kg m^2`` about the screw axis, so a reflected mass
    :math:`(2\pi/p)^2 (J_r + J_{cp} + J_{sc}) = 236.9` kg on each travel, and
    screw efficiencies ``eta = 0.9`` (forward) and ``eta_back = 0.8``
    (back-driven), which only enter the motor torques of an inverse study.
    These are numbers in the :class:`~kanedyn.BallScrew` objects, not
    parameters of the equations (which do not contain them).

    Coordinates.  Independent: the pose ``x, y, z`` (m) and body-fixed X-Y-Z
    angles ``phi_x, phi_y, phi_z`` (rad) of the platform, speeds
    ``vx, vy, vz, wx, wy, wz`` their rates.  Dependent: ``s1..6`` (m),
    ``a1..6, b1..6`` (rad), speeds ``ds1..6, da1..6, db1..6``, held by the
    eighteen loop closures :math:`A_{0j} + s_j N_z + L\hat l_j - (p + R c_j) = 0`.
    :func:`out_parallel_ik` gives them in closed form.

    With ``force_input=True`` the model is driven by its ball screws: the
    carriage forces are specified inputs ``F_carriage1 .. F_carriage6`` (N,
    along ``N.z`` on each carriage, positive up), and each drive train's
    reflected inertia is among the bodies (a rate inertia on the travel), so
    that an input is the force the actuator map computes
    (:func:`kanedyn.modeling.drive_inputs`); for optimal control.

    Parameters
    ----------
    machine : OutParallelMachine, optional
        Another machine's geometry, masses and drive trains
        (:func:`kanedyn.models.read_out_parallel_machine`); the defaults above
        if omitted.
    force_input : bool
        The carriage forces as inputs, the drive trains as bodies.

    Returns
    -------
    ModelDefinition
        ``actuators``: six :class:`~kanedyn.JointActuator` ``carriage1..6`` on
        the travels with their :class:`~kanedyn.BallScrew`;
        ``body_groups``: ``platform``, ``struts``, ``carriages``; ``symbols``:
        ``pose``, ``pose_rates``, ``s``, ``a``, ``b``, ``N``, the constants by
        name, ``geometry`` (the numbers of :data:`OUT_PARALLEL_GEOMETRY`);
        with ``force_input``, ``forces`` (the input symbols).
    """
    geo = _geometry(None if machine is None else machine.geometry)
    inertia = dict(OUT_PARALLEL_INERTIA if machine is None else machine.inertia)
    pose = list(me.dynamicsymbols("x y z phi_x phi_y phi_z"))
    rates = list(me.dynamicsymbols("vx vy vz wx wy wz"))
    s = list(me.dynamicsymbols("s1:7"))
    a = list(me.dynamicsymbols("a1:7"))
    b = list(me.dynamicsymbols("b1:7"))
    ds = list(me.dynamicsymbols("ds1:7"))
    da = list(me.dynamicsymbols("da1:7"))
    db = list(me.dynamicsymbols("db1:7"))
    Rb, rp, L = sm.symbols("R_b r_p L", positive=True)
    mp, ms, mc, g = sm.symbols("m_p m_s m_c g", positive=True)
    q_all, u_all = pose + s + a + b, rates + ds + da + db
    to_u = dict(zip([q.diff() for q in q_all], u_all))
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = me.ReferenceFrame("P")
    P.orient_body_fixed(N, pose[3:], "XYZ")
    P.set_ang_vel(N, P.ang_vel_in(N).subs(to_u))
    Gp = O.locatenew("Gp", pose[0] * N.x + pose[1] * N.y + pose[2] * N.z)
    Gp.set_vel(N, rates[0] * N.x + rates[1] * N.y + rates[2] * N.z)
    platform = me.RigidBody("platform", Gp, P, mp,
                            (me.inertia(P, mp * rp ** 2 / 4, mp * rp ** 2 / 4,
                                        mp * rp ** 2 / 2), Gp))
    A0_num, _, c_num = out_parallel_anchors(geo)
    # drive trains as numbers: the equations of motion do not contain them (they
    # enter through the actuators), so they are not parameters of the model
    screw = [inertia[key] for key in ("lead", "J_r", "J_cp", "J_sc", "eta",
                                                   "eta_back")]
    struts, carriages, actuators = [], [], []
    config, velocity = [], []
    for j in range(6):
        foot = [sm.Float(v / geo["R_b"]) * Rb for v in A0_num[j][:2]]
        Aj = O.locatenew(f"A{j + 1}", foot[0] * N.x + foot[1] * N.y + s[j] * N.z)
        Aj.set_vel(N, ds[j] * N.z)
        anchor = [sm.Float(v / geo["r_p"]) * rp for v in c_num[j][:2]]
        Cj = Gp.locatenew(f"C{j + 1}", anchor[0] * P.x + anchor[1] * P.y)
        Cj.v2pt_theory(Gp, N, P)
        S = me.ReferenceFrame(f"S{j + 1}")
        S.orient_body_fixed(N, (a[j], b[j], 0), "XYZ")
        S.set_ang_vel(N, S.ang_vel_in(N).subs(to_u))
        Gs = Aj.locatenew(f"Gs{j + 1}", L / 2 * S.z)
        Gs.v2pt_theory(Aj, N, S)
        tip = Aj.locatenew(f"T{j + 1}", L * S.z)
        tip.v2pt_theory(Aj, N, S)
        struts.append(me.RigidBody(f"strut{j + 1}", Gs, S, ms,
                                   (me.inertia(S, ms * L ** 2 / 12, ms * L ** 2 / 12, 0), Gs)))
        carriages.append(me.Particle(f"carriage{j + 1}", Aj, mc))
        gap = tip.pos_from(O) - Cj.pos_from(O)
        rate = tip.vel(N) - Cj.vel(N)
        config += [gap.dot(n) for n in (N.x, N.y, N.z)]
        velocity += [rate.dot(n) for n in (N.x, N.y, N.z)]
        actuators.append(JointActuator(f"carriage{j + 1}", s[j], point=Aj, axis=N.z,
                                       transmission=BallScrew(*screw)))
    bodies = [platform, *struts, *carriages]
    loads = [(body.masscenter, -body.mass * g * N.z) for body in bodies]
    heights = sm.Add(*(body.mass * g * body.masscenter.pos_from(O).dot(N.z)
                       for body in bodies))
    driven, specified, title = {}, {}, ("6-dof out-parallel manipulator: ball-screw "
                                        "carriages on rails, struts, under gravity")
    if force_input:
        forces, drive_loads, drive_trains = drive_inputs(actuators)
        loads += drive_loads
        bodies += drive_trains
        driven, specified = {"forces": forces}, {F: 0.0 for F in forces}
        title += ", carriage forces as inputs"
    home, _, _ = out_parallel_ik([0, 0, geo["h"], 0, 0, 0], geometry=geo)
    initial = {v: 0.0 for v in u_all}
    initial.update(dict(zip(q_all, home)))
    named = dict(R_b=Rb, r_p=rp, L=L, m_p=mp, m_s=ms, m_c=mc, g=g)
    values = dict(R_b=geo["R_b"], r_p=geo["r_p"], L=geo["L"], g=9.81,
                  **{key: inertia[key] for key in ("m_p", "m_s", "m_c")})
    constants = {named[key]: value for key, value in values.items()}
    units = {Rb: "m", rp: "m", L: "m", mp: "kg", ms: "kg", mc: "kg", g: "m/s^2"}
    return ModelDefinition(
        name="out-parallel-6dof",
        title=title, specified=specified,
        kane_args=dict(frame=N, q_ind=pose, u_ind=rates,
                       kd_eqs=[q.diff() - u for q, u in zip(q_all, u_all)],
                       q_dep=s + a + b, u_dep=ds + da + db,
                       configuration_constraints=config, velocity_constraints=velocity,
                       bodies=bodies, loads=loads, potential_energy=heights),
        constants=constants, constant_units=units, initial_state=initial, t_end=2.0,
        symbols=dict(pose=pose, pose_rates=rates, s=s, a=a, b=b, ds=ds, N=N, O=O,
                     platform=platform, struts=struts, carriages=carriages, geometry=geo,
                     **named, **driven),
        description="Six carriages driven by ball screws on vertical rails outside the "
                    "workspace hold the platform through fixed-length struts (universal "
                    "joint at the carriage, spherical at the platform). The platform pose "
                    "is independent; carriage travels and strut angles are dependent "
                    "(kd.models.out_parallel_ik gives them in closed form).",
        actuators=tuple(actuators),
        body_groups={"platform": ("platform",),
                     "struts": tuple(f"strut{j}" for j in range(1, 7)),
                     "carriages": tuple(f"carriage{j}" for j in range(1, 7))})
