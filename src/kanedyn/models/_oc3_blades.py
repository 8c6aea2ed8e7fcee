r"""The OC3 turbine's flexible blades (``rotor="spinning"``, ``blades="flexible"``).

Parts of the ``oc3-spar`` builder:

* :func:`flexible_blades`: three :class:`~kanedyn.FlexibleBody` blades on the
  spinning hub, each the NREL 5-MW blade clamped at its root and reduced to its
  first flap, first edge and second flap modes
  (:func:`~kanedyn.models._nrel5mw_blade_structure.nrel5mw_blade_modes`, the
  published 0.477465 % of critical in each), with geometric stiffening (the
  centrifugal stiffening of the spinning blades) and gravity;
* :func:`blade_thrust_loads`: with ``aero="thrust"`` the performance table's
  thrust and torque spread over each blade's nodes;
* :func:`rna_without_blades`: the rotor-nacelle assembly's mass, centre of mass
  and inertia less the three blades' and the hub's inertia about the shaft
  (which the blades and the drivetrain's rotor now carry).

Blade :math:`k` (:math:`k = 1, 2, 3`) hangs from the rotor frame :math:`R`
(azimuth :math:`\psi` about the shaft :math:`S_x`) at the azimuth
:math:`\psi + 2\pi(k-1)/3`: the frame :math:`R_k` is :math:`R` turned about
:math:`S_x`, the blade's root is at the hub radius (1.5 m) along :math:`R_{k,z}`
(no precone), and its body frame :math:`B_k` is :math:`R_k` turned by the pitch
:math:`\theta` about :math:`-R_{k,z}` (towards feather: the leading edge
upwind), so :math:`B_{k,x}` points downwind for :math:`\theta = 0` (flapwise),
:math:`B_{k,y}` against the blade's motion (edgewise) and :math:`B_{k,z}` along
the span.  The pitch turns the whole blade at its root: with the controller on
it is the controller's pitch state, whose rate (the actuator's) is part of the
blade's angular velocity; the pitch bearing's moment that drives it is no
load of the equations (its work is the energy balance's prescribed-motion
term).  With the controller off the blades stay at the steady pitch of the
wind.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ..modeling import FlexibleBody
from ..modeling.flexible import InertiaInvariants
from ._nrel5mw_blade_structure import nrel5mw_blade_modes
from ._oc3_data import DRIVETRAIN, RNA, ROTOR, TOWER, rna_inertia_about_cm

__all__ = ["BLADE_MODE_LABELS", "flexible_blades", "blade_thrust_loads", "rna_without_blades",
           "oc3_blade_member", "blade_annulus_nodes"]

#: the blade modes' coordinate names (``flap1_blade2`` ...) and speeds (``u_flap1_blade2``)
BLADE_MODE_LABELS = ("flap1", "edge1", "flap2")


def _v(group, key):
    return group[key].value


@functools.lru_cache(maxsize=1)
def oc3_blade_member():
    """The reduced NREL 5-MW blade the model uses (nodes at the AeroDyn stations, damped)."""
    return nrel5mw_blade_modes()


def blade_annulus_nodes(member, bem):
    """The member's node at each annulus of ``bem`` (the AeroDyn stations inside the blade)."""
    span = member.nodes[:, 2] - member.nodes[member.reference_node, 2]
    return [int(np.argmin(np.abs(span + bem.hub_radius - r))) for r in bem.radius]


def _blade_inertia(member):
    """``(mass, J)``: one undeflected blade's mass (kg) and its second moment about the hub
    centre along its span, :math:`\\int m r^2\\,dr` (kg m^2), the root at the hub radius."""
    inv = InertiaInvariants(member, stiffening=False)
    mass = inv.mass
    first = float(inv.first_moment[0][2])             # about the root, along the span
    second = float(inv.M0[3, 3])                      # about the root, flapwise axis
    r_h = _v(ROTOR, "hub_radius")
    return mass, second + 2 * r_h * first + mass * r_h ** 2


def rna_without_blades(cm_x):
    r"""The RNA less the three blades and the hub's inertia about the shaft.

    The published RNA (350,000 kg, centre of mass at ``(cm_x, 0, cm_z)`` from
    the tower top, inertia about it) holds the blades; with flexible blades they
    are bodies of their own, undeflected in the plane normal to the shaft with
    their centre of mass at the hub: each blade's mass :math:`m_b` and second
    moment :math:`J` about the hub give the three an inertia :math:`3J` about
    the shaft and :math:`\tfrac32 J` about any axis in their plane.  The rest
    keeps the mass :math:`m - 3m_b`, the centre of mass that leaves the whole's
    where it was, and the inertia that leaves the whole's unchanged, less the
    hub's inertia about the shaft (the drivetrain's rotor carries it).

    Parameters
    ----------
    cm_x : float
        The RNA's centre of mass from the tower top, downwind, m (the
        published -0.414, or 0 with ``rna_offset=False``).

    Returns
    -------
    (float, ndarray, ndarray)
        Mass (kg), centre of mass from the tower top (m, nacelle components,
        shape (3,)) and inertia about it (kg m^2, (3, 3)).
    """
    m_b, J = _blade_inertia(oc3_blade_member())
    m, c = _v(RNA, "mass"), np.array([cm_x, 0.0, _v(RNA, "cm_z")])
    tilt = math.radians(_v(ROTOR, "shaft_tilt"))
    s = np.array([math.cos(tilt), 0.0, -math.sin(tilt)])
    hub = np.array([-_v(ROTOR, "overhang"), 0.0,
                    _v(ROTOR, "hub_height") - _v(TOWER, "top_z")])
    blades = 3 * m_b
    rest = m - blades
    c_rest = (m * c - blades * hub) / rest

    def shift(mass, d):
        return mass * (d @ d * np.eye(3) - np.outer(d, d))
    I_blades = 3 * J * np.outer(s, s) + 1.5 * J * (np.eye(3) - np.outer(s, s))
    I_rest = (rna_inertia_about_cm() - I_blades - shift(blades, hub - c)
              - shift(rest, c_rest - c) - _v(DRIVETRAIN, "hub_inertia") * np.outer(s, s))
    return rest, c_rest, I_rest


def flexible_blades(drive, hub, N, origin, pitch, pitch_rate, gravity):
    r"""The three flexible blades on the drivetrain's rotor frame (see the module text).

    Parameters
    ----------
    drive : Drivetrain
        Its ``rotor_frame`` :math:`R` (the azimuth about the shaft).
    hub : Point
        The hub centre, its velocity in ``N`` known in the speeds.
    N : ReferenceFrame
    origin : Point
        A point fixed in ``N`` (the gravitational energy's reference).
    pitch : sympy.Expr or float
        The collective pitch, rad (a state of the controller or a number).
    pitch_rate : sympy.Expr or float
        Its rate in the states, rad/s (the controller's actuator; 0 for a number).
    gravity : float
        m/s^2, acting along ``-N.z``.

    Returns
    -------
    dict
        ``bodies`` (the three FlexibleBody), ``q``, ``u``, ``kd_eqs``,
        ``potential`` (strain and gravitational energy), ``radial`` (each
        blade's undeflected span direction :math:`R_{k,z}`), ``units``.
    """
    member = oc3_blade_member()
    R = drive.rotor_frame
    r_h = _v(ROTOR, "hub_radius")
    bodies, radial, potential, q, u, kd_eqs, units = [], [], [], [], [], [], {}
    for k in range(3):
        Rk = R.orientnew(f"R_{k + 1}", "Axis", [sm.Float(2 * math.pi * k / 3), R.x])
        Bk = Rk.orientnew(f"blade{k + 1}", "Axis", [-sm.sympify(pitch), Rk.z])
        Bk.set_ang_vel(Rk, -sm.sympify(pitch_rate) * Rk.z)
        root = hub.locatenew(f"blade{k + 1}_root", r_h * Rk.z)
        root.v2pt_theory(hub, N, Rk)
        coords = me.dynamicsymbols(" ".join(f"{m}_blade{k + 1}" for m in BLADE_MODE_LABELS))
        speeds = me.dynamicsymbols(" ".join(f"u_{m}_blade{k + 1}" for m in BLADE_MODE_LABELS))
        blade = FlexibleBody(f"blade{k + 1}", Bk, root, member, coordinates=coords,
                             speeds=speeds, stiffening=True, gravity=-gravity * N.z)
        bodies.append(blade)
        radial.append(Rk.z)
        q += list(blade.q)
        u += list(blade.u)
        kd_eqs += list(blade.kd_eqs)
        potential.append(blade.gravitational_energy(origin) + blade.strain_energy)
        units.update(dict.fromkeys(blade.q, "m"))
    return dict(bodies=bodies, q=q, u=u, kd_eqs=kd_eqs, potential=sm.Add(*potential),
                radial=radial, units=units)


def _ideal_rotor_weights(bem):
    r"""Per annulus node: the share of a blade's thrust and of its torque (per metre of lever).

    An ideal rotor (uniform induction, no losses) loads its blades in
    proportion to the radius both normal to the rotor plane and along the
    motion (:math:`dT/dr \propto r`, :math:`dQ/dr \propto r^2`); on the
    annuli's trapezoidal weights :math:`w_i`: :math:`a_i = w_ir_i/\sum w r`
    (:math:`\sum a_i = 1`) and :math:`b_i = w_ir_i/\sum w r^2`
    (:math:`\sum b_i r_i = 1`).
    """
    wr = bem.weights * bem.radius
    return wr / wr.sum(), wr / np.sum(wr * bem.radius)


def blade_thrust_loads(blades, radial, shaft, N, surface, rotor_speed, pitch, wind):
    r"""The performance table's thrust and torque spread over each blade's annulus nodes.

    Each blade takes a third of the rotor's thrust and torque at its own
    relative wind, :math:`V_k = V - \bar v_k\cdot S_x`, with :math:`\bar v_k =
    \sum_i a_i v_i` the thrust-weighted mean velocity of its nodes (the hub's
    motion, the nacelle's rotation and the blade's own deflection: the
    aerodynamic damping of the platform, the tower and the blade's flap),
    spread over its nodes as an ideal rotor's (:func:`_ideal_rotor_weights`):
    :math:`T_k a_i` along :math:`S_x` and :math:`Q_k b_i` along the blade's
    motion :math:`e_t = S_x\times e_r`.

    Parameters
    ----------
    blades : list of FlexibleBody
    radial : list of Vector
        The undeflected span directions.
    shaft : Vector
        :math:`S_x`.
    N : ReferenceFrame
    surface : PerformanceSurface
    rotor_speed, pitch : sympy.Expr or float
    wind : float or sympy.Expr
        Free wind speed along the shaft, m/s.

    Returns
    -------
    (list, list, list)
        Loads ``[(node point, vector)]``, and per blade its thrust and torque
        (SymPy expressions, N and N m).
    """
    from ._nrel5mw_blade import nrel5mw_bem
    bem = nrel5mw_bem()
    member = blades[0].member
    nodes = blade_annulus_nodes(member, bem)
    a, b = _ideal_rotor_weights(bem)
    R, rho = _v(ROTOR, "diameter") / 2, _v(ROTOR, "air_density")
    loads, thrusts, torques = [], [], []
    # the thrust-weighted mean of the nodes' positions in the blade frame,
    # x + Phi eta + G eta eta / 2, and of its rate (Phi + G eta) zeta
    x = a @ (member.nodes[nodes] - member.nodes[member.reference_node])
    Phi = np.einsum("n,nam->am", a, np.stack([member.node_modes(k)[0] for k in nodes]))
    G = np.einsum("n,namj->amj", a, member.second_order[nodes])
    for blade, e_r in zip(blades, radial):
        B, eta, zeta = blade.frame, list(blade.q), list(blade.u)
        m = len(eta)
        slope = [[sm.Float(Phi[c, i]) + sm.Add(*[sm.Float(G[c, i, j]) * eta[j]
                                                 for j in range(m)]) for i in range(m)]
                 for c in range(3)]
        arm = [sm.Float(x[c]) + sm.Add(*[(sm.Float(Phi[c, i]) + slope[c][i]) * eta[i] / 2
                                         for i in range(m)]) for c in range(3)]
        rate = [sm.Add(*[slope[c][i] * zeta[i] for i in range(m)]) for c in range(3)]
        arm = arm[0] * B.x + arm[1] * B.y + arm[2] * B.z
        velocity = (blade.origin.vel(N) + B.ang_vel_in(N).cross(arm)
                    + rate[0] * B.x + rate[1] * B.y + rate[2] * B.z)
        relative = wind - velocity.dot(shaft)
        points = [blade.node_point(k) for k in nodes]
        lam = rotor_speed * R / sm.Max(relative, 0.1, evaluate=False)
        cq, ct = surface.expressions(lam, pitch)
        q = sm.Float(rho * math.pi * R ** 2 / 6) * relative ** 2
        thrust, torque = q * ct, q * R * cq
        e_t = shaft.cross(e_r)
        loads += [(p, thrust * float(ai) * shaft + torque * float(bi) * e_t)
                  for p, ai, bi in zip(points, a, b)]
        thrusts.append(thrust)
        torques.append(torque)
    return loads, thrusts, torques
