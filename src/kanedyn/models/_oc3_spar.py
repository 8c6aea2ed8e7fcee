r"""The OC3-Hywind spar floating wind turbine with a flexible tower and a TMD / TMDI.

Bodies and coordinates (inertial frame ``N``: x downwind, y to port, z up,
origin ``O`` on the still water line (SWL) at the undisplaced spar axis):

* the platform, a rigid body with 6 dof: ``surge``, ``sway``, ``heave`` (the
  displacement of the SWL reference point ``P`` on the spar axis, ``N``
  components, m) and ``roll``, ``pitch``, ``yaw`` (rad): body-fixed z-y-x
  (yaw, then pitch, then roll) Tait-Bryan angles of the platform frame ``B``
  from ``N``.  The speeds are the coordinates' time derivatives.
* the tower, from 10 m to 87.6 m above the SWL: a rigid body fixed to the
  platform (``tower_modes=0``) or a :class:`~kanedyn.FlexibleBody` reduced by
  Craig-Bampton to its lowest 2 or 4 bending modes (clamped to the platform):
  the fixed-base modes of the tower with the RNA lumped at its top
  (:func:`~kanedyn.models.oc3_tower_rna_basis`), on which the member's own
  mass and stiffness are the bare tower's (the RNA is a rigid body of its own,
  counted once), with structural damping of ``tower_damping`` of critical in
  every kept mode (the published 1 % of the isolated tower by default; see
  :mod:`kanedyn.models._oc3_tower`);
* the rotor-nacelle assembly (RNA), a rigid body fixed to the tower top (the
  top node's frame ``A``): mass, centre-of-mass offset and inertia of the
  NREL 5-MW turbine;
* the damper mass of a TMD (``tmdi="tmd"`` or ``"tmdi"``), a particle sliding
  along the nacelle's fore-aft axis ``A.x`` at the tower top (coordinate
  ``s_d``, m), held by a spring ``k_d`` and a dashpot ``c_d``; with
  ``"tmdi"`` an inerter of inertance ``b`` joins it to the tower at a lower
  height (its kinetic energy is :math:`\tfrac12 b \dot r^2`, with ``r`` the
  fore-aft component, along the platform's ``B.x``, of the damper mass's position
  relative to the tower point: the one-dimensional inerter of the TMDI
  literature, loaded by the tower's relative bending deflection (a component
  along the nacelle's ``A.x`` would rotate with the top slope, whose lever to a
  low tower point cancels most of that deflection);
  a two-terminal :class:`~kanedyn.Inerter` on the nearly vertical line between
  the two points would hardly be loaded by fore-aft motion).

Forces: gravity; hydrostatics (``"linear"``: the published buoyancy-and-waterplane
matrix about ``P`` with the published displaced volume's buoyancy, the weight
term coming from gravity on the bodies; ``"large_angle"``:
:class:`~kanedyn.offshore.Hydrostatics` of the spar geometry); added mass (``"sheet"``:
the published 6 x 6 potential-flow matrix as a :class:`~kanedyn.AddedMass`;
``"morison"``: strip theory with Ca = 1); the published additional linear
damping (a :class:`~kanedyn.MatrixSpringDamper` with K = 0); Morison drag and
wave excitation (:class:`~kanedyn.offshore.MorisonCylinder`, kinematics at the
undisplaced position); mooring (``"linear"``: :meth:`~kanedyn.offshore.LinearMooring.oc3`;
``"linear-symmetric"``: its symmetric part, conservative;
``"catenary"``: three quasi-static elastic catenary lines plus the yaw spring
of the delta connection; ``"none"``); rotor thrust at the hub (5.0191 m upwind
of the tower axis, 90 m above the SWL) along the shaft tilted 5 deg,
:math:`\cos 5^\circ A_x - \sin 5^\circ A_z`
(:class:`~kanedyn.offshore.RotorThrust` with the NREL 5-MW curve of the free hub-height
wind, the aerodynamic damping on the hub's velocity along the shaft).

With ``rotor="spinning"`` the rotor azimuth (and with ``drivetrain="flexible"`` the
low-speed shaft's twist) is a degree of freedom, the rotor's thrust and torque come from
its performance table, and with ``controller="on"`` the baseline controller's three
states join the coordinates (:mod:`kanedyn.models._oc3_rotor`); with
``blades="flexible"`` the blades are flexible bodies with three modes each
(:mod:`kanedyn.models._oc3_blades`).
"""

from __future__ import annotations

import math

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..modeling import (NREL5MW_THRUST, AddedMass, AiryWave, CatenaryLine, CatenaryMooring,
                        FlexibleBody, Hydrostatics, IrregularSea, LinearMooring,
                        MatrixSpringDamper, MorisonCylinder, RateInertia, RotorThrust,
                        jonswap_gamma, kaimal_wind, rotation_vector)
from ._oc3_options import OC3_SPAR_OPTIONS
from ._base import ModelDefinition
from ._oc3_data import (ENVIRONMENT, HYDRO, MOORING, PLATFORM, RNA, ROTOR, TOWER,
                        added_mass_matrix, damping_matrix, hydrostatic_matrix,
                        mooring_stiffness_matrix, rna_inertia_about_cm,
                        tower_rigid_properties)
from ._oc3_blades import rna_without_blades
from ._oc3_potential import coupled_energy, gradient_loads, restoring_energy, split_loads
from ._oc3_rotor import AERO_MODELS, rna_inertia_pieces, spinning_rotor
from ._oc3_tower import oc3_tower_rna_basis
from ._oc3_shapes import oc3_shape_specs

__all__ = ["oc3_spar", "OC3_SPAR_OPTIONS", "spar_geometry", "oc3_settle",
           "oc3_static_offsets", "tower_reference_mass"]

T = me.dynamicsymbols._t


_CHOICES = {"hydrostatics": ("linear", "large_angle"), "added_mass": ("sheet", "morison"),
            "tower_damping_reference": ("isolated", "with_rna"),
            "sea": ("still", "regular", "irregular"),
            "mooring": ("linear", "linear-symmetric", "catenary", "none"),
            "tmdi": ("off", "tmd", "tmdi"), "rotor": ("rigid", "spinning"),
            "controller": ("off", "on"), "drivetrain": ("rigid", "flexible"),
            "aero": AERO_MODELS, "blades": ("rigid", "flexible")}

_N_STRIPS = 10          # Morison strips over the wetted 120 m
_WIND_SERIES = 3600.0   # s of turbulent wind generated (periodic beyond)
#: the energy balance's term of a published matrix's loads beyond the potential's gradient
_BEYOND = "{} beyond its potential (the published matrix's {})"


def _v(group, key):
    return group[key].value


def spar_geometry():
    """The spar's ``(s, D)`` stations along its axis from the SWL point (m, m)."""
    return [(-_v(PLATFORM, "draft"), _v(PLATFORM, "lower_diameter")),
            (_v(PLATFORM, "taper_bottom_z"), _v(PLATFORM, "lower_diameter")),
            (_v(PLATFORM, "taper_top_z"), _v(PLATFORM, "upper_diameter")),
            (_v(PLATFORM, "top_z"), _v(PLATFORM, "upper_diameter"))]


def tower_reference_mass():
    """Mass of the tower plus the RNA (kg): the reference of the TMD mass and inertance ratios."""
    return _v(TOWER, "mass") + _v(RNA, "mass")


def _check(options):
    for key, choices in _CHOICES.items():
        if options[key] not in choices:
            raise ModelError(f"oc3-spar: option {key} must be one of {', '.join(choices)}, "
                             f"got {options[key]!r}")
    if options["tower_modes"] not in (0, 2, 4):
        raise ModelError(f"oc3-spar: option tower_modes must be 0 (rigid tower), 2 or 4, got "
                         f"{options['tower_modes']!r}")
    positive = ("tower_elements", "tmd_mass_ratio", "tmd_frequency")
    for key in positive:
        if not options[key] > 0:
            raise ModelError(f"oc3-spar: option {key} must be positive, got {options[key]!r}")
    damping = options["tower_damping"]
    if isinstance(damping, bool) or not isinstance(damping, (int, float)) \
            or not (math.isfinite(damping) and 0 <= damping < 1):
        raise ModelError(f"oc3-spar: option tower_damping is the tower's structural damping "
                         f"ratio, a fraction of critical in [0, 1) (0.01 is the published "
                         f"1 %), got {damping!r}")
    for key in ("wave_height", "wind_speed", "turbulence", "tmd_damping", "inertance_ratio"):
        if not (math.isfinite(options[key]) and options[key] >= 0):
            raise ModelError(f"oc3-spar: option {key} must be a finite number >= 0, got "
                             f"{options[key]!r}")
    if options["sea"] != "still" and not (options["wave_height"] > 0
                                          and options["wave_period"] > 0):
        raise ModelError(f"oc3-spar: sea={options['sea']} needs wave_height > 0 and "
                         "wave_period > 0")
    if options["rotor"] == "rigid":
        for key, value in (("controller", "on"), ("drivetrain", "flexible"), ("aero", "bem"),
                           ("blades", "flexible")):
            if options[key] == value:
                raise ModelError(f"oc3-spar: option {key}={value} needs rotor=spinning (the "
                                 "rigid rotor has no rotor speed)")
    elif options["wind_speed"] > 0 and not 3 <= options["wind_speed"] <= 25:
        raise ModelError(f"oc3-spar: with rotor=spinning, option wind_speed must be 0 (no "
                         f"aerodynamic loads) or from cut-in 3 to cut-out 25 m/s, got "
                         f"{options['wind_speed']!r}")
    lo, hi = _v(TOWER, "base_z"), _v(TOWER, "top_z")
    if not lo <= options["inerter_height"] < hi:
        raise ModelError(f"oc3-spar: option inerter_height must lie on the tower, in "
                         f"[{lo}, {hi}) m above the SWL, got {options['inerter_height']!r}")


def oc3_spar(tower_modes=2, tower_elements=10, stiffening=False, tower_damping=0.01,
             tower_damping_reference="isolated", hydrostatics="linear",
             added_mass="sheet", linear_damping=True, drag=True, sea="still", wave_height=0.0,
             wave_period=10.0, seed=1, mooring="linear", wind_speed=0.0, turbulence=0.0,
             tmdi="off", tmd_mass_ratio=0.02, tmd_frequency=0.45, tmd_damping=0.08,
             inertance_ratio=0.02, inerter_height=60.0, rna_offset=True, rotor="rigid",
             controller="off", drivetrain="rigid", aero="thrust", blades="rigid"):
    r"""The OC3-Hywind spar with the NREL 5-MW turbine (see the module text and the model card).

    Parameters
    ----------
    tower_modes : {0, 2, 4}
        0: rigid tower; 2 or 4: flexible tower with that many bending modes
        (the first fore-aft and side-side, then the second ones).
    tower_elements : int
        Beam elements of the tower before reduction.
    stiffening : bool
        Geometric (gravity) stiffening of the flexible tower's modes.
    tower_damping : float
        Structural damping ratio of every kept tower mode, a fraction of
        critical: the published 1 % by default (``TOWER.damping_ratio``;
        OC3 and the 5-MW definition), 0 for an undamped tower.  Unused by the
        rigid tower.
    tower_damping_reference : {"isolated", "with_rna"}
        ``"isolated"`` (default; the published definition, as OpenFAST's
        ElastoDyn applies it): ``tower_damping`` of critical in the modes of
        the tower *without* the RNA, which leaves the fixed-base tower carrying
        the RNA with 0.29 % in its first fore-aft and side-side modes (0.59 %
        and 0.47 % in the second); ``"with_rna"``: ``tower_damping`` of
        critical in the modes of the fixed-base tower carrying the RNA.
    hydrostatics : {"linear", "large_angle"}
    added_mass : {"sheet", "morison"}
        The published potential-flow matrix, or Morison's Ca = 1 on the strips.
    linear_damping : bool
        The published additional linear damping (surge, sway, heave, yaw).
    drag : bool
        Morison quadratic drag (Cd = 0.6) on the relative velocity.
    sea : {"still", "regular", "irregular"}
    wave_height, wave_period : float
        Regular: height H and period T; irregular: Hs and Tp (JONSWAP with
        IEC's gamma), m and s.
    seed : int
        Seed of the irregular sea's phases and of the turbulent wind.
    mooring : {"linear", "linear-symmetric", "catenary", "none"}
        ``"linear-symmetric"``, for energy checks: the published matrix's
        symmetric part as a spring derived from a potential (the published
        matrix is slightly unsymmetric and does work around closed paths).
    wind_speed : float
        Mean wind at hub height, m/s; 0: rotor parked, no thrust.
    turbulence : float
        Turbulence intensity (0: steady wind), Kaimal spectrum.
    tmdi : {"off", "tmd", "tmdi"}
    tmd_mass_ratio : float
        :math:`\mu = m_d / (m_{tower} + m_{RNA})` (599,718 kg).
    tmd_frequency : float
        Tuning frequency :math:`f_d`, Hz: :math:`k_d = m_d (2\pi f_d)^2`.
    tmd_damping : float
        Damping ratio :math:`\zeta_d`: :math:`c_d = 2\zeta_d m_d\,2\pi f_d`.
    inertance_ratio : float
        :math:`\beta = b / (m_{tower} + m_{RNA})` (``tmdi="tmdi"``).
    inerter_height : float
        Height above the SWL of the inerter's tower terminal (the nearest
        tower node of the flexible tower), m.
    rna_offset : bool
        True: the RNA's centre of mass at its published fore-aft offset
        (-0.414 m from the tower axis).  False, a test configuration: the same
        RNA with its centre of mass on the tower axis (inertia about the centre
        of mass unchanged), so the undisplaced state (at the static heave) is an
        equilibrium and heave decouples from pitch (the rigid-system checks).
    rotor : {"rigid", "spinning"}
        ``"rigid"``: the rotor is part of the RNA, thrust from the steady
        curve (above).  ``"spinning"``: the rotor azimuth is a degree of
        freedom on the 5-deg tilted shaft, the generator turns 97 times as
        fast, thrust and torque come from the rotor's performance table and
        the relative wind (:mod:`kanedyn.models._oc3_rotor`); ``wind_speed``
        0 or from 3 to 25 m/s.
    controller : {"off", "on"}
        With ``rotor="spinning"``: ``"on"``, the baseline controller with the
        OC3 gains (generator torque and blade pitch from three controller
        states); ``"off"``, generator torque and pitch are specified inputs
        ``T_generator`` (N m) and ``pitch_input`` (rad; only with wind), held at
        their steady values for ``wind_speed`` (torque 0 without wind) unless given.
    drivetrain : {"rigid", "flexible"}
        With ``rotor="spinning"``: ``"flexible"`` adds the low-speed shaft's
        torsional twist as a degree of freedom (published stiffness and
        damping).
    aero : {"thrust", "bem"}
        With ``rotor="spinning"``: ``"thrust"``, the rotor's thrust and torque
        from its performance table (the cheap option); ``"bem"``, the force
        and moment of blade-element momentum theory on the NREL 5-MW blade,
        solved at every state from the relative wind of each blade element
        (rotor speed, azimuth, the hub's and nacelle's motion): six specified
        inputs ``Frotor_x/y/z``, ``Mrotor_x/y/z`` (shaft-frame components,
        N and N m), their callables in ``specified``.  With
        ``controller="off"`` the BEM uses the steady pitch for the wind.
    blades : {"rigid", "flexible"}
        With ``rotor="spinning"``: ``"flexible"``, the three blades are
        :class:`~kanedyn.FlexibleBody` members of the NREL 5-MW blade (first
        flap, first edge and second flap modes, structural twist, the published
        0.477465 % damping, centrifugal stiffening, gravity), turned at their
        roots by the pitch; the aerodynamic loads act on their nodes
        (:mod:`kanedyn.models._oc3_blades`; with ``aero="bem"`` two inputs per
        node, ``Frotor_n_<blade>_<node>`` and ``Frotor_t_...``).  With
        ``controller="off"`` the blades keep the steady pitch for the wind.

    Returns
    -------
    ModelDefinition
        ``constants``: ``m_d``, ``k_d``, ``c_d`` (with a TMD) and ``b``
        (with the TMDI): change them through ``definition.numeric(constants=...)``.
        ``symbols``: ``q``, ``u`` (lists), ``N``, ``B``, ``A``
        (nacelle frame), ``O``, ``P``, ``top``, ``hub``, ``damper``, ``tower``
        (FlexibleBody or RigidBody), ``tower_node`` (the inerter's terminal),
        ``elements`` (the force elements by name), ``s_d``, ``m_d``, ``k_d``,
        ``c_d``, ``b``, ``potential_energy`` (SymPy),
        ``options``.  ``initial_state``: the static offsets of
        :func:`oc3_static_offsets`.
    """
    options = dict(tower_modes=tower_modes, tower_elements=tower_elements,
                   stiffening=stiffening, tower_damping=tower_damping,
                   tower_damping_reference=tower_damping_reference,
                   hydrostatics=hydrostatics, added_mass=added_mass,
                   linear_damping=linear_damping, drag=drag, sea=sea, wave_height=wave_height,
                   wave_period=wave_period, seed=seed, mooring=mooring, wind_speed=wind_speed,
                   turbulence=turbulence, tmdi=tmdi, tmd_mass_ratio=tmd_mass_ratio,
                   tmd_frequency=tmd_frequency, tmd_damping=tmd_damping,
                   inertance_ratio=inertance_ratio, inerter_height=inerter_height,
                   rna_offset=rna_offset, rotor=rotor, controller=controller,
                   drivetrain=drivetrain, aero=aero, blades=blades)
    _check(options)
    g = _v(ENVIRONMENT, "gravity")
    rho = _v(ENVIRONMENT, "water_density")
    depth = _v(ENVIRONMENT, "water_depth")

    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    names = ("surge", "sway", "heave", "roll", "pitch", "yaw")
    q6 = list(me.dynamicsymbols(" ".join(names)))
    u6 = list(me.dynamicsymbols(" ".join(f"u_{n}" for n in names)))
    x, y, z, phi, theta, psi = q6
    B = me.ReferenceFrame("B")
    B.orient_body_fixed(N, (psi, theta, phi), "zyx")
    P = O.locatenew("P", x * N.x + y * N.y + z * N.z)
    qd = {qi.diff(T): ui for qi, ui in zip(q6, u6)}
    B.set_ang_vel(N, B.ang_vel_in(N).subs(qd))
    P.set_vel(N, u6[0] * N.x + u6[1] * N.y + u6[2] * N.z)
    q, u, kd_eqs = list(q6), list(u6), [qi.diff(T) - ui for qi, ui in zip(q6, u6)]
    bodies, loads, potential = [], [], []
    elements = {}
    held, load_names = [], {}   # the loads whose work the potential holds; term names

    def add(new, hold=False, name=None):
        """Append loads; ``hold``: the potential holds their work exactly (no term of
        the energy balance); ``name``: their term's name."""
        start = len(loads)
        loads.extend(new)
        if hold:
            held.extend(range(start, len(loads)))
        if name:
            load_names.update(dict.fromkeys(range(start, len(loads)), name))

    # ---------------------------------------------------------------- platform
    m_p = _v(PLATFORM, "mass")
    Gp = P.locatenew("G_platform", _v(PLATFORM, "cm_z") * B.z)
    Gp.v2pt_theory(P, N, B)
    platform = me.RigidBody("platform", Gp, B, m_p, (me.inertia(
        B, _v(PLATFORM, "roll_inertia_cm"), _v(PLATFORM, "pitch_inertia_cm"),
        _v(PLATFORM, "yaw_inertia_cm")), Gp))
    bodies.append(platform)
    add([(Gp, -m_p * g * N.z)], hold=True)
    potential.append(m_p * g * Gp.pos_from(O).dot(N.z))

    # ------------------------------------------------------------------- tower
    base = P.locatenew("tower_base", _v(TOWER, "base_z") * B.z)
    base.v2pt_theory(P, N, B)
    if tower_modes == 0:
        m_t, cm_t, I_t = tower_rigid_properties()
        Gt = P.locatenew("G_tower", cm_t[2] * B.z)
        Gt.v2pt_theory(P, N, B)
        tower = me.RigidBody("tower", Gt, B, m_t, (me.inertia(B, *np.diag(I_t)), Gt))
        add([(Gt, -m_t * g * N.z)], hold=True)
        potential.append(m_t * g * Gt.pos_from(O).dot(N.z))
        A = B
        top = P.locatenew("top", _v(TOWER, "top_z") * B.z)
        top.v2pt_theory(P, N, B)

        def tower_point(height):
            point = P.locatenew("tower_point", height * B.z)
            point.v2pt_theory(P, N, B)
            return point, height
    else:
        member = oc3_tower_rna_basis(tower_elements, tower_modes, damping=tower_damping,
                                     damping_reference=tower_damping_reference)
        tower = FlexibleBody("tower", B, base, member, stiffening=stiffening,
                             gravity=-g * N.z)
        q += list(tower.q)
        u += list(tower.u)
        kd_eqs += list(tower.kd_eqs)
        potential.append(tower.gravitational_energy(O) + tower.strain_energy)
        A = tower.node_frame(-1)
        top = tower.node_point(-1)

        def tower_point(height):
            zs = member.nodes[:, 2] - member.nodes[member.reference_node, 2]
            k = int(np.argmin(np.abs(zs + _v(TOWER, "base_z") - height)))
            return tower.node_point(k), float(zs[k] + _v(TOWER, "base_z"))
    bodies.append(tower)

    # --------------------------------------------------------------------- RNA
    m_rna = _v(RNA, "mass")
    cm_x = _v(RNA, "cm_x") if rna_offset else 0.0
    cm_rna = np.array([cm_x, 0.0, _v(RNA, "cm_z")])
    spinning = rotor == "spinning"
    # with a spinning rotor the RNA keeps all but the spinning parts' inertia, in two
    # pieces (see rna_inertia_pieces); flexible blades take their mass as well
    if spinning and blades == "flexible":
        m_rna, cm_rna, I_rest = rna_without_blades(cm_x)
        I_rna, I_axial = rna_inertia_pieces(I_rest)
    else:
        I_rna, I_axial = rna_inertia_pieces() if spinning else (rna_inertia_about_cm(), None)
    G_rna = top.locatenew("G_rna", cm_rna[0] * A.x + cm_rna[2] * A.z)
    rna = me.RigidBody("rna", G_rna, A, m_rna, (_inertia(A, I_rna), G_rna))
    bodies.append(rna)
    if spinning:
        bodies.append(me.RigidBody("rna_axial", G_rna, A, 0, (_inertia(A, I_axial), G_rna)))
    add([(G_rna, -m_rna * g * N.z)], hold=True)
    potential.append(m_rna * g * G_rna.pos_from(O).dot(N.z))

    # -------------------------------------------------------------- TMD / TMDI
    m_d, k_d, c_d, b = sm.symbols("m_d k_d c_d b", nonnegative=True)
    m_ref = tower_reference_mass()
    md_value = tmd_mass_ratio * m_ref
    wd = 2 * math.pi * tmd_frequency
    constants = {m_d: md_value, k_d: md_value * wd ** 2, c_d: 2 * tmd_damping * md_value * wd,
                 b: inertance_ratio * m_ref}
    s_d = damper = tower_node = None
    if tmdi != "off":
        s_d, v_d = me.dynamicsymbols("s_d v_d")
        q.append(s_d)
        u.append(v_d)
        kd_eqs.append(s_d.diff(T) - v_d)
        damper = top.locatenew("damper", s_d * A.x)
        bodies.append(me.Particle("tmd", damper, m_d))
        add([(damper, -k_d * s_d * A.x - m_d * g * N.z), (top, k_d * s_d * A.x)],
            hold=True)
        add([(damper, -c_d * v_d * A.x), (top, c_d * v_d * A.x)], name="TMD dashpot")
        potential += [m_d * g * damper.pos_from(O).dot(N.z), k_d * s_d ** 2 / 2]
        if tmdi == "tmdi":
            tower_node, height = tower_point(inerter_height)
            r = damper.pos_from(tower_node).dot(B.x)
            bodies.append(RateInertia("inerter", [r.diff(T)], b))
            elements["inerter"] = (tower_node, height)

    # ------------------------------------------------- hub and spinning rotor
    # (before the states are listed: the catenary lines' inputs take them)
    hub = top.locatenew("hub", -_v(ROTOR, "overhang") * A.x
                        + (_v(ROTOR, "hub_height") - _v(TOWER, "top_z")) * A.z)
    if tower_modes:
        # the hub's velocity in the speeds (the node frame's rates are modal-coordinate
        # derivatives, which the rotor's numeric aerodynamic damping cannot take)
        rates = {qk.diff(T): uk for qk, uk in zip(tower.q, tower.u)}
        hub.set_vel(N, me.msubs(top.vel(N) + hub.pos_from(top).dt(N), rates))
        if spinning:   # and the nacelle's, which the BEM's blade elements take
            A.set_ang_vel(N, me.msubs(A.ang_vel_in(N), rates))
    spin = wind_symbol = None
    wind = float(wind_speed)
    if wind_speed > 0 and turbulence > 0:
        t_w, v_w = kaimal_wind(wind_speed, turbulence, _WIND_SERIES, 0.25, seed,
                               hub_height=_v(ROTOR, "hub_height"))
        wind = _PeriodicSeries(t_w, v_w)
        wind_symbol = me.dynamicsymbols("V_wind")   # the spinning rotor's input
    if spinning:
        if not tower_modes:
            hub.v2pt_theory(top, N, A)
        spin = spinning_rotor(A, hub, N, float(wind_speed), options, wind_symbol,
                              wind if wind_symbol is not None else None, origin=O)
        q += spin["q"]
        u += spin["u"]
        kd_eqs += spin["kd_eqs"]
        bodies += spin["bodies"]
        load_names.update({len(loads) + i: name for i, name in spin["load_names"].items()})
        held.extend(len(loads) + i for i in spin["held"])
        loads += spin["loads"]
        potential.append(spin["potential"])
        elements["rotor"] = spin["symbols"]["aerodynamics"]
    # ------------------------------------------------------------ hydrostatics
    rest = dict.fromkeys(q6, 0.0)
    if hydrostatics == "linear":
        C = hydrostatic_matrix(weight=False)
        hydro = MatrixSpringDamper("hydrostatics", B, P, N, C, np.zeros((6, 6)), O)
        buoyancy = rho * g * _v(PLATFORM, "displaced_volume")
        exact, energy = gradient_loads(
            lambda d, R: -buoyancy * d[2] + restoring_energy(C, d, R), P, O, B, N)
        add(exact, hold=True)
        add(split_loads(hydro.to_loads() + [(P, buoyancy * N.z)], exact),
            name=_BEYOND.format("hydrostatics", "second-order part"))
        potential.append(energy)
    else:
        hydro = Hydrostatics("hydrostatics", B, P, B.z, spar_geometry(), N, O, rest, rho,
                             "large_angle", g=g)
        loads += hydro.to_loads()
    elements["hydrostatics"] = hydro

    # ---------------------------------------------- added mass, waves, damping
    if added_mass == "sheet":
        bodies.append(AddedMass("added_mass", P, B, added_mass_matrix(), N))
    waves = None
    if sea == "regular":
        waves = AiryWave(wave_height, wave_period, depth)
    elif sea == "irregular":
        waves = IrregularSea(wave_height, wave_period, jonswap_gamma(wave_height, wave_period),
                             depth, n_components=200, seed=seed)
    specified = {}
    if spin is not None:
        specified.update(spin["specified"])
        if wind_symbol is not None and aero != "bem":   # the BEM calls the series itself
            specified[wind_symbol] = wind
    if drag or waves is not None or added_mass == "morison":
        morison = MorisonCylinder(
            "spar", B, P, B.z, spar_geometry(), N, O, rest, rho,
            Ca=_v(HYDRO, "inertia_added_mass_coefficient"),
            Cd=_v(HYDRO, "drag_coefficient") if drag else 0.0, n_strips=_N_STRIPS,
            waves=waves)
        elements["morison"] = morison
        if drag or waves is not None:
            add(morison.to_loads(), name="Morison drag and wave forces")
            specified.update(morison.specified())
        if added_mass == "morison":
            bodies += morison.inertia_elements()
    if linear_damping:
        damper_6 = MatrixSpringDamper("linear_damping", B, P, N, np.zeros((6, 6)),
                                      damping_matrix(), O)
        add(damper_6.to_loads(), name="additional linear damping")
        elements["linear_damping"] = damper_6

    # ----------------------------------------------------------------- mooring
    states = [*q, *u]
    if mooring == "linear":
        moor = LinearMooring.oc3(B, P, N, O)
        exact, energy = gradient_loads(
            lambda d, R: moor.vertical_load * d[2] + coupled_energy(moor.K, d, R), P, O, B, N)
        add(exact, hold=True)
        add(split_loads(moor.to_loads(), exact),
            name=_BEYOND.format("mooring", "asymmetry, second-order part"))
        potential.append(energy)
        elements["mooring"] = moor
    elif mooring == "linear-symmetric":
        moor = LinearMooring.oc3(B, P, N, O)
        K_sym = (moor.K + moor.K.T) / 2
        moor_loads, moor_energy = _conservative_spring(K_sym, P, O, B, N)
        add(moor_loads + [(P, -moor.vertical_load * N.z)], hold=True)
        potential.append(moor.vertical_load * z + moor_energy)
        elements["mooring"] = moor
    elif mooring == "catenary":
        moor = _catenary_mooring(B, P, N, O, g, rho)
        loads += moor.to_loads()
        specified.update(moor.specified(states))
        K_yaw = np.zeros((6, 6))
        K_yaw[5, 5] = _v(MOORING, "K66_yaw_spring")
        yaw_spring = MatrixSpringDamper("yaw_spring", B, P, N, K_yaw, np.zeros((6, 6)), O)
        exact, energy = gradient_loads(lambda d, R: restoring_energy(K_yaw, d, R),
                                       P, O, B, N)
        add(exact, hold=True)
        add(split_loads(yaw_spring.to_loads(), exact),
            name=_BEYOND.format("yaw spring", "second-order part"))
        potential.append(energy)
        elements["mooring"] = moor
        elements["yaw_spring"] = yaw_spring

    # ------------------------------------------------------------------- rotor
    if spinning and aero == "bem" and wind_speed > 0:    # the BEM's inputs read the state
        specified.update(elements["rotor"].specified(states))
    if not spinning and wind_speed > 0:
        # along the shaft, downwind and (tilted) downward: hub upwind and higher
        tilt = math.radians(_v(ROTOR, "shaft_tilt"))
        shaft = math.cos(tilt) * A.x - math.sin(tilt) * A.z
        # the curve is against the free hub-height wind with the tilt already in it:
        # the whole wind speed counts (wind_direction = the shaft), the hub's velocity
        # along the shaft is the aerodynamic damping
        thrust = RotorThrust("rotor", hub, shaft, N, NREL5MW_THRUST, wind,
                             wind_direction=shaft)
        loads += thrust.to_loads()
        specified.update(thrust.specified(states))
        elements["rotor"] = thrust

    initial = oc3_static_offsets(options)
    state = {q6[names.index(key)]: value for key, value in initial.items()}
    if spin is not None:
        state.update(spin["initial"])
    used = {m_d, k_d, c_d, b} if tmdi == "tmdi" else {m_d, k_d, c_d} if tmdi == "tmd" else set()
    constants = {key: value for key, value in constants.items() if key in used}
    what = [f"{tower_modes} tower modes, tower damping {100 * tower_damping:g} % "
            f"({tower_damping_reference})" if tower_modes else "rigid tower",
            f"{mooring} mooring", f"{sea} sea"]
    if wind_speed > 0:
        what.append(f"wind {wind_speed:g} m/s")
    if tmdi != "off":
        what.append(tmdi.upper())
    if spinning:
        what.append(f"spinning rotor, controller {controller}"
                    + (", flexible drivetrain" if drivetrain == "flexible" else "")
                    + (", flexible blades" if blades == "flexible" else "")
                    + (", BEM aerodynamics" if aero == "bem" else ""))
    return ModelDefinition(
        name="oc3-spar",
        title="OC3-Hywind spar floating wind turbine (" + ", ".join(what) + ")",
        kane_args=dict(frame=N, q_ind=q, u_ind=u, kd_eqs=kd_eqs, bodies=bodies, loads=loads,
                       potential_energy=sm.Add(*potential)),
        constants=constants, initial_state=state, t_end=60.0, specified=specified,
        load_names=tuple(load_names.get(i) for i in range(len(loads))) if load_names else (),
        potential_loads=tuple(held),
        symbols=dict(q=q, u=u, N=N, B=B, A=A, O=O, P=P, top=top, hub=hub, damper=damper,
                     tower=tower, tower_node=tower_node, elements=elements, s_d=s_d, m_d=m_d,
                     k_d=k_d, c_d=c_d, b=b, potential_energy=sm.Add(*potential),
                     options=options, rotor=spin["symbols"] if spin else None),
        description="OC3-Hywind (Jonkman 2010) with the NREL 5-MW RNA: rigid 6-dof spar, "
                    "tower rigid or Craig-Bampton flexible, hydrostatics, constant added "
                    "mass, linear damping, Morison drag and waves, linear or catenary "
                    "mooring, rotor thrust or a spinning rotor with drivetrain and "
                    "baseline controller, TMD or TMDI in the nacelle "
                    "(docs/oc3_model_card.md).",
        # numeric lengths hide the units from the kinematics: the angles and the modal
        # coordinates (modes scaled to a largest nodal translation of 1 m) declared
        units={**{qi: "rad" for qi in q6[3:]}, **{qi: "m" for qi in q6[:3]},
               **({qi: "m" for qi in tower.q} if tower_modes else {}),
               **({s_d: "m"} if s_d is not None else {}), **(spin["units"] if spin else {})},
        body_groups={"platform": ("platform",), "tower": ("tower",),
                     "rna": ("rna", "rna_axial", "rotor", "generator") if spinning
                     else ("rna",),
                     **({"blades": ("blade1", "blade2", "blade3")} if blades == "flexible"
                        else {})},
        gravity=(0.0, 0.0, -g),
        shape_specs=oc3_shape_specs(platform, tower, rna, None if tower_modes else cm_t[2],
                                    (cm_x, _v(RNA, "cm_z")), _v(TOWER, "top_z")))


def _inertia(A, I):
    """The inertia dyadic of a symmetric matrix in ``A`` components."""
    return me.inertia(A, I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2])


class _PeriodicSeries:
    """A sampled series as a function of time, repeated beyond its length.

    The samples padded once with their neighbours across the period's ends, as
    ``np.interp(..., period=...)`` pads them (after sorting them) at every call:
    the same numbers, without a sort of the whole series per call (a turbulent
    wind's, at every right-hand side)."""

    def __init__(self, t, v):
        self.t, self.v = np.asarray(t, float), np.asarray(v, float)
        self.period = self.t[-1] + (self.t[1] - self.t[0])
        self._t = np.concatenate([self.t[-1:] - self.period, self.t, self.t[:1] + self.period])
        self._v = np.concatenate([self.v[-1:], self.v, self.v[:1]])

    def __call__(self, t):
        return float(np.interp(t % self.period, self._t, self._v))


def _conservative_spring(K, P, O, B, N):
    r"""Loads and potential of a symmetric 6 x 6 spring that does no work around closed paths.

    With :math:`x = [d, \theta]` (:math:`d` the displacement of ``P`` from
    ``O``, :math:`\theta = \tfrac12\mathrm{vee}(R - R^T)` the
    :func:`~kanedyn.rotation_vector` of ``B`` from ``N``, ``N`` components) the
    potential is :math:`V = \tfrac12 x^T K x`; the force at ``P`` is
    :math:`-(Kx)_d` and the torque on ``B`` is :math:`-J^T (Kx)_\theta` with
    :math:`\dot\theta = J\omega`, :math:`J = \tfrac12(\mathrm{tr}R\,I - R)`
    (:math:`R` = ``N.dcm(B)``).  Linearized about the reference it is
    :math:`-K\,\delta x`, like :class:`~kanedyn.MatrixSpringDamper`, whose
    torque :math:`-(Kx)_\theta` differs at second order and is not
    conservative.

    Returns
    -------
    loads : list
        ``[(P, force), (B, torque)]``.
    energy : sympy.Expr
        :math:`V`, J.
    """
    K = np.asarray(K, float)
    d = P.pos_from(O)
    th = rotation_vector(B, N)
    x = sm.Matrix([d.dot(e) for e in (N.x, N.y, N.z)] + [th.dot(e) for e in (N.x, N.y, N.z)])
    f = sm.Matrix(6, 1, lambda i, _: sm.Add(*[sm.Float(K[i, j]) * x[j]
                                              for j in range(6) if K[i, j] != 0]))
    R = N.dcm(B)
    JT = (R.trace() * sm.eye(3) - R.T) / 2
    torque = -(JT * f[3:, 0])
    force = -(f[0] * N.x + f[1] * N.y + f[2] * N.z)
    energy = sm.Add(*[x[i] * f[i] for i in range(6)]) / 2
    return [(P, force), (B, torque[0] * N.x + torque[1] * N.y + torque[2] * N.z)], energy


def _catenary_mooring(B, P, N, O, g, rho):
    w = (_v(MOORING, "line_mass_per_length")
         - rho * math.pi * _v(MOORING, "line_diameter") ** 2 / 4) * g
    lines = []
    for i in range(int(_v(MOORING, "n_lines"))):
        a = math.pi + 2 * math.pi * i / 3     # first line upwind (-x)
        c, s = math.cos(a), math.sin(a)
        fair = P.locatenew(f"fairlead{i + 1}", _v(MOORING, "fairlead_radius") * (c * B.x + s * B.y)
                           - _v(MOORING, "fairlead_depth") * B.z)
        fair.v2pt_theory(P, N, B)
        anchor = (_v(MOORING, "anchor_radius") * c, _v(MOORING, "anchor_radius") * s,
                  -_v(MOORING, "anchor_depth"))
        lines.append(CatenaryLine(anchor, fair, _v(MOORING, "unstretched_length"), w,
                                  _v(MOORING, "line_EA"), name=f"line{i + 1}"))
    return CatenaryMooring("mooring", lines, N, O)


def _system_weight(options):
    g = _v(ENVIRONMENT, "gravity")
    mass = _v(PLATFORM, "mass") + _v(TOWER, "mass") + _v(RNA, "mass")
    if options["tmdi"] != "off":
        mass += options["tmd_mass_ratio"] * tower_reference_mass()
    return mass * g


def _catenary_vertical(heave):
    """Total vertical mooring load (N, downward positive) of the three OC3 lines at ``heave``."""
    g = _v(ENVIRONMENT, "gravity")
    rho = _v(ENVIRONMENT, "water_density")
    w = (_v(MOORING, "line_mass_per_length")
         - rho * math.pi * _v(MOORING, "line_diameter") ** 2 / 4) * g
    line = CatenaryLine((_v(MOORING, "anchor_radius"), 0.0, -_v(MOORING, "anchor_depth")),
                        me.Point("fairlead"), _v(MOORING, "unstretched_length"), w,
                        _v(MOORING, "line_EA"), name="OC3 line")
    _, V = line.tensions((_v(MOORING, "fairlead_radius"), 0.0,
                          heave - _v(MOORING, "fairlead_depth")))
    return 3 * V


def oc3_static_offsets(options):
    """Heave (m) of static equilibrium from the vertical balance (the model's initial state).

    Buoyancy of the published displaced volume plus the hydrostatic heave
    stiffness against the weight of platform, tower, RNA (and TMD mass) and
    the vertical mooring load: with linear mooring
    :math:`z_0 = (\\rho g V - W - V_0)/(C_{33} + K_{33})`; with catenary
    lines the same balance with the lines' load at the heaved fairleads
    (SciPy's ``brentq``); without mooring :math:`(\\rho g V - W)/C_{33}`.
    Pitch and tower deflection from the RNA's offset and the thrust are left
    to :func:`oc3_settle` (the linear hydrostatics only; large-angle alike to
    first order).

    Returns
    -------
    dict
        ``{"heave": z0}``.
    """
    from scipy.optimize import brentq
    g = _v(ENVIRONMENT, "gravity")
    rho = _v(ENVIRONMENT, "water_density")
    buoy = rho * g * _v(PLATFORM, "displaced_volume")
    W = _system_weight(options)
    C33 = _v(HYDRO, "C33")
    if options["mooring"] in ("linear", "linear-symmetric"):
        V0 = _catenary_vertical(0.0)
        return {"heave": (buoy - W - V0) / (C33 + mooring_stiffness_matrix()[2, 2])}
    if options["mooring"] == "none":
        return {"heave": (buoy - W) / C33}
    return {"heave": brentq(lambda zz: buoy - W - C33 * zz - _catenary_vertical(zz), -20, 20,
                            xtol=1e-12)}


def oc3_settle(definition, model, y0=None, tol=1e-10):
    """Static equilibrium of the numeric model: the coordinates where all accelerations vanish.

    :func:`kanedyn.equilibrium` (Newton's method on the exact derivatives)
    from ``y0`` (default: the definition's initial state) with the speeds at
    zero, every coordinate solved for except surge, sway and yaw without
    mooring (nothing restores them; they keep their values).

    Returns
    -------
    ndarray
        The state ``[q, 0]``.

    Raises
    ------
    ModelError
        When Newton's method does not converge.
    """
    from ..numerics import equilibrium
    y = definition.initial(model) if y0 is None else np.array(y0, float)
    y[model.n_q:] = 0.0
    names = model.state_names
    hold = [names[i] for i in range(model.n_q, model.n_states)]
    if definition.symbols["options"]["mooring"] == "none":
        hold += [names[i] for i in (0, 1, 5)]  # surge, sway, yaw: no stiffness
    found = equilibrium(model, y, hold=hold, tol=tol)
    if not found.converged:
        raise ModelError(f"oc3-spar: static equilibrium not found: {found.message}")
    return found.y
