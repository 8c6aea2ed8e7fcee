r"""Built-in models with flexible bodies: the spin-up beam and the elastic one-dof robot.

Both are beams on a hub turning about the vertical axis ``N.z`` in a
horizontal plane (no gravity), reduced by Craig–Bampton to their in-plane
bending modes and made flexible bodies (:class:`kanedyn.FlexibleBody`).
"""

from __future__ import annotations

import math

import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..modeling import BeamMember, FlexibleBody
from ._base import ModelDefinition

__all__ = ["spin_up_beam", "flexible_robot", "spin_up_angle", "in_plane_member"]

T = me.dynamicsymbols._t


def in_plane_member(name, length, *, mass_per_length, EI, EA, n_modes, n_elements,
                    node_masses=()):
    """A uniform beam along ``x`` reduced to its first ``n_modes`` bending modes in ``x-y``.

    Craig–Bampton clamped at node 0 with no interface nodes (the clamped
    normal modes), keeping the in-plane ones (``bending_xy_*``).  The
    section's torsion and out-of-plane properties do not enter the kept
    modes; they are set to the in-plane ones (a square-like section).

    Parameters
    ----------
    name : str
    length : float
        m.
    mass_per_length, EI, EA : float
        kg/m, N m^2, N.
    n_modes, n_elements : int
    node_masses : sequence of NodeMass

    Returns
    -------
    ReducedMember
    """
    if n_modes < 1 or n_elements < n_modes:
        raise ModelError(f"member {name!r}: needs n_modes >= 1 and n_elements >= n_modes, "
                         f"got n_modes={n_modes}, n_elements={n_elements}")
    beam = BeamMember.uniform(name, length, mass_per_length=mass_per_length, EA=EA, GJ=EI,
                              EI_y=EI, EI_z=EI, polar_inertia=mass_per_length * 1e-3,
                              n_elements=n_elements, node_masses=node_masses)
    # the out-of-plane, torsion and axial modes interleave: ask for enough modes
    reduced = beam.craig_bampton(n_modes=min(4 * n_modes + 4, 6 * n_elements))
    return reduced.keep_modes([f"bending_xy_{j}" for j in range(1, n_modes + 1)])


def spin_up_angle(omega_s, duration):
    r"""The prescribed hub angle of the spin-up manoeuvre, a SymPy expression of ``t``.

    .. math::

        \theta(t) = \frac{\Omega_s}{T}\left[\frac{t^2}{2}
            + \left(\frac{T}{2\pi}\right)^2\left(\cos\frac{2\pi t}{T} - 1\right)\right]
        \ (t < T),\qquad \theta(t) = \Omega_s t - \frac{\Omega_s T}{2}\ (t \ge T),

    so :math:`\dot\theta = \frac{\Omega_s}{T}\left(t - \frac{T}{2\pi}
    \sin\frac{2\pi t}{T}\right)` rises smoothly from 0 to :math:`\Omega_s`
    with zero angular acceleration at both ends.

    Parameters
    ----------
    omega_s : float or Symbol
        Final spin rate, rad/s.
    duration : float or Symbol
        Spin-up time ``T``, s.
    """
    ramp = omega_s / duration * (T ** 2 / 2 + (duration / (2 * sm.pi)) ** 2
                                 * (sm.cos(2 * sm.pi * T / duration) - 1))
    return sm.Piecewise((ramp, T < duration), (omega_s * T - omega_s * duration / 2, True))


def _positive(model, option, value, unit):
    """``value`` as a float, refused unless finite and positive (``option`` named)."""
    number = float(value)
    if not (math.isfinite(number) and number > 0):
        raise ModelError(f"{model}: {option} must be a finite number > 0 ({unit}), "
                         f"got {value!r}")
    return number


def spin_up_beam(omega_s=6.0, stiffening=True, n_modes=4, n_elements=10, length=10.0,
                 EI=1.4e4, mass_per_length=1.2, EA=2.8e7, spin_up_time=15.0):
    r"""The spin-up of a cantilever on a hub (Kane, Ryan & Banerjee 1987).

    A uniform beam (``L = 10`` m, ``rho A = 1.2`` kg/m, ``EI = 1.4e4`` N m^2,
    ``EA = 2.8e7`` N: aluminium, ``A = 4e-4`` m^2, ``I = 2e-7`` m^4) clamped to
    a hub of radius 0 whose angle is prescribed (:func:`spin_up_angle`,
    ``T = 15`` s), bending in the plane of rotation.  With geometric
    (motion-induced) stiffening the tip deflection stays bounded and small
    and nearly vanishes after the spin-up; with ``stiffening=False`` (the
    "conventional" linear modal model) the centrifugal softening is not
    balanced and the deflection diverges.

    The hub's drive torque is exposed as a constraint force: an auxiliary
    speed about ``N.z`` gives ``tau`` (N m), so that ``kd.simulate(...,
    constraint_forces=True)`` returns it and the work it does,
    :math:`\int\tau\dot\theta\,dt`, can be set against the change of kinetic
    plus strain energy.

    Parameters
    ----------
    omega_s : float
        Final spin rate, rad/s (the paper: 6 and 10).
    stiffening : bool
        Geometric stiffening (the consistent model) or not.
    n_modes : int
        In-plane bending modes kept.
    n_elements : int
        Beam elements.
    length, EI, mass_per_length, EA : float
        The beam's length (m), bending stiffness in the plane (N m^2), mass per
        length (kg/m) and axial stiffness (N).
    spin_up_time : float
        ``T`` of the spin-up law (:func:`spin_up_angle`), s.

    Returns
    -------
    ModelDefinition
        ``symbols``: ``theta`` (the prescribed angle), ``theta_rate`` (its
        rate, an expression of ``t``), ``beam`` (the FlexibleBody), ``tau``,
        ``N``, ``B``.
    """
    if not (math.isfinite(omega_s) and omega_s >= 0):
        raise ModelError(f"spin-up-beam: omega_s must be a non-negative rate, got {omega_s!r}")
    beam_values = {name: _positive("spin-up-beam", name, value, unit) for name, value, unit in
                   (("length", length, "m"), ("EI", EI, "N m^2"),
                    ("mass_per_length", mass_per_length, "kg/m"), ("EA", EA, "N"),
                    ("spin_up_time", spin_up_time, "s"))}
    member = in_plane_member("beam", beam_values["length"],
                             mass_per_length=beam_values["mass_per_length"],
                             EI=beam_values["EI"], EA=beam_values["EA"], n_modes=n_modes,
                             n_elements=n_elements)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    theta, u_a = me.dynamicsymbols("theta u_a")
    tau = sm.Symbol("tau")
    B = N.orientnew("B", "Axis", [theta, N.z])
    B.set_ang_vel(N, (theta.diff(T) + u_a) * N.z)
    beam = FlexibleBody("beam", B, O, member, stiffening=stiffening)
    angle = spin_up_angle(omega_s, beam_values["spin_up_time"])
    which = "with" if stiffening else "without"
    return ModelDefinition(
        name="spin-up-beam",
        title=f"spin-up of a cantilever on a hub to {omega_s:g} rad/s, {which} geometric "
              "stiffening",
        kane_args=dict(frame=N, q_ind=list(beam.q), u_ind=list(beam.u),
                       kd_eqs=list(beam.kd_eqs), bodies=[beam], loads=[(B, tau * N.z)],
                       u_auxiliary=[u_a]),
        constants={}, initial_state={}, t_end=20.0, specified={theta: angle},
        symbols=dict(theta=theta, theta_rate=angle.diff(T), beam=beam, tau=tau, N=N, B=B,
                     member=member),
        load_names=("hub torque tau (drives the prescribed spin-up)",),
        description="Kane, Ryan & Banerjee (1987): prescribed spin-up of a cantilever; "
                    "bounded with geometric stiffening, divergent without.")


def _damping(value):
    value = float(value)
    if not math.isfinite(value) or value < 0:
        raise ModelError(f"flexible-robot: hub_damping must be a finite number >= 0 "
                         f"(N m s/rad), got {value!r}")
    return value


def _payload(value):
    value = float(value)
    if not math.isfinite(value) or value < 0:
        raise ModelError(f"flexible-robot: pulse_payload must be a finite mass >= 0 (kg), "
                         f"got {value!r}")
    return value


def flexible_robot(n_modes=4, n_elements=10, stiffening=True, hub_damping=None,
                   pulse_payload=None, torque_input=False, length=1.0, EI=36.5,
                   mass_per_length=0.675, EA=1.75e7):
    r"""The elastic one-dof robot: a motor-driven hub turning a flexible link with a payload.

    The robot of Meghdari & Fahimi's elastic Kane's method, with the numbers
    of a laboratory arm (assumed, stated here): an aluminium link
    ``L = 1`` m long of 50 mm x 5 mm section bending in the horizontal plane
    (``rho A = 0.675`` kg/m, ``EI = 36.5`` N m^2 in the plane, ``EA = 1.75e7``
    N), clamped to a hub of radius ``r_h = 0.05`` m and inertia
    ``J_h = 0.05`` kg m^2 about the vertical axis (mass ``m_h = 1`` kg, a disk), a payload of
    ``m_p = 0.1`` kg at the tip node.  Horizontal plane: no gravity.

    The motor torque is a rest-to-rest pulse about ``N.z``:

    .. math::

        \tau(t) = \tau_0 \sin(2\pi\min(t/T_m, 1)),\qquad
        \tau_0 = \frac{2\pi\,\theta_f\,J_0}{T_m^2},

    which turns the *rigid* robot (total inertia :math:`J_0` about the hub
    axis) by :math:`\theta_f = 90°` in :math:`T_m = 1` s and leaves it at rest;
    the flexible link keeps vibrating after the pulse (no damping, so the
    work of the motor equals the change of kinetic plus strain energy).
    With ``torque_input=True`` the motor torque is a specified input
    ``tau(t)`` (N m, zero by default) instead: what optimal control chooses
    (``kd.studies.flexible_robot_rest_to_rest``).

    Parameters
    ----------
    n_modes : int
        In-plane bending modes of the link (Craig–Bampton, clamped at the hub).
    n_elements : int
        Beam elements.
    stiffening : bool
        Geometric stiffening of the link.
    hub_damping : float, optional
        Viscous damping of the hub's bearing and motor, N m s/rad: a constant
        ``c_h`` of that value and the torque :math:`-c_h\omega` on the hub
        (default: none, and no such constant).
    pulse_payload : float, optional
        The payload mass (kg) the torque pulse is designed for: :math:`J_0`
        of the pulse then holds this number instead of the constant ``m_p``,
        so that the torque stays what it is when ``m_p`` changes (a record
        whose payload differs from the design, or a fit of ``m_p``).  Default:
        ``m_p`` itself.
    torque_input : bool
        The motor torque is the specified input ``tau(t)``, not the pulse.
    length, EI, mass_per_length, EA : float
        The link's length (m), bending stiffness in the plane (N m^2), mass per
        length (kg/m) and axial stiffness (N).  The hub (``J_h``, ``m_h``,
        ``r_h``), the payload (``m_p``) and the pulse (``T_m``, ``theta_f``) are
        parameters (constants).

    Returns
    -------
    ModelDefinition
        ``symbols``: ``theta``, ``omega`` (hub angle and rate), ``link``
        (FlexibleBody), ``torque`` (expression of ``t``: the pulse; or the
        input ``tau(t)``), ``pulse`` (the pulse's expression, always), ``tip``
        (the tip node's point), ``N``, ``B``; with ``torque_input``, ``tau``;
        with ``hub_damping``, ``c_h``.
    """
    length, EI, mass_per_length, EA = (
        _positive("flexible-robot", name, value, unit) for name, value, unit in
        (("length", length, "m"), ("EI", EI, "N m^2"),
         ("mass_per_length", mass_per_length, "kg/m"), ("EA", EA, "N")))
    member = in_plane_member("link", length, mass_per_length=mass_per_length, EI=EI, EA=EA,
                             n_modes=n_modes, n_elements=n_elements)
    J_h, m_h, r_h, m_p, T_m, theta_f = sm.symbols("J_h m_h r_h m_p T_m theta_f",
                                                   positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    theta, omega = me.dynamicsymbols("theta omega")
    B = N.orientnew("B", "Axis", [theta, N.z])
    B.set_ang_vel(N, omega * N.z)
    hub = me.RigidBody("hub", O, B, m_h, (me.inertia(B, J_h / 2, J_h / 2, J_h), O))
    root = O.locatenew("root", r_h * B.x)
    link = FlexibleBody("link", B, root, member, stiffening=stiffening)
    tip = link.node_point(member.n_nodes - 1)
    payload = me.Particle("payload", tip, m_p)
    mass = mass_per_length * length
    design = m_p if pulse_payload is None else _payload(pulse_payload)
    J_0 = (J_h + mass * (length ** 2 / 3 + r_h * length + r_h ** 2)
           + design * (r_h + length) ** 2)
    tau_0 = 2 * sm.pi * theta_f * J_0 / T_m ** 2
    pulse = tau_0 * sm.sin(2 * sm.pi * sm.Min(T / T_m, 1))
    torque, specified, extra = pulse, {}, {}
    constants = {J_h: 0.05, m_h: 1.0, r_h: 0.05, m_p: 0.1, T_m: 1.0, theta_f: math.pi / 2}
    title = "elastic one-dof robot: hub, flexible link and payload, rest-to-rest torque pulse"
    if torque_input:  # the pulse's T_m and theta_f are then not parameters
        tau = me.dynamicsymbols("tau")
        torque, specified, extra = tau, {tau: 0.0}, {"tau": tau}
        constants = {k: v for k, v in constants.items() if k not in (T_m, theta_f)}
        title = "elastic one-dof robot: hub, flexible link and payload, motor torque tau(t)"
    loads, load_names = [(B, torque * N.z)], ("motor torque",)
    if hub_damping is not None:
        c_h = sm.Symbol("c_h", nonnegative=True)
        constants[c_h] = _damping(hub_damping)
        loads.append((B, -c_h * omega * N.z))
        load_names += ("hub damping",)
        extra["c_h"] = c_h
    return ModelDefinition(
        name="flexible-robot",
        title=title,
        kane_args=dict(frame=N, q_ind=[theta] + list(link.q), u_ind=[omega] + list(link.u),
                       kd_eqs=[theta.diff(T) - omega] + list(link.kd_eqs),
                       bodies=[hub, link, payload], loads=loads),
        constants=constants, initial_state={}, t_end=3.0, specified=specified,
        symbols=dict(theta=theta, omega=omega, link=link, torque=torque, pulse=pulse, tip=tip,
                     N=N, B=B, member=member, J_h=J_h, r_h=r_h, m_p=m_p, T_m=T_m,
                     theta_f=theta_f, **extra),
        load_names=load_names,
        constant_units={J_h: "kg m^2", m_h: "kg", r_h: "m", m_p: "kg", T_m: "s",
                        theta_f: "rad", **({extra["c_h"]: "N m s/rad"} if "c_h" in extra
                                           else {})},
        description="Meghdari & Fahimi's elastic one-dof robot (laboratory numbers "
                    "assumed): finite elements, Craig–Bampton, Kane's method.")
