r"""OC3-Hywind spar with the NREL 5-MW turbine: the published properties as data.

Every figure is a :class:`Figure` (value, unit, source, meaning), grouped in
read-only mappings: :data:`PLATFORM`, :data:`ENVIRONMENT`, :data:`HYDRO`,
:data:`MOORING`, :data:`TOWER`, :data:`RNA`, :data:`ROTOR`, :data:`DRIVETRAIN`,
:data:`CONTROLLER` (the baseline controller; the OC3 gains), :data:`BLADE` (the
blade's integrated properties), and the tower's
distributed properties :data:`TOWER_STATIONS`.  Functions assemble the 6 x 6
matrices of the rigid floating system about the *SWL reference point* (on the
spar axis at the still water line; x downwind, y to port, z up; rows ordered
surge, sway, heave, roll, pitch, yaw).

Sources (figures as they appear in NREL's public FAST/OpenFAST input decks of
the OC3-Hywind system and in the project's data sheet
``shared/data/oc3_hywind.md``):

* ``OC3`` -- J. Jonkman, *Definition of the Floating System for Phase IV of
  OC3*, NREL/TP-500-47535, 2010 (platform, hydrostatics, added mass, damping,
  mooring, tower of the floating system).
* ``5MW`` -- J. Jonkman, S. Butterfield, W. Musial, G. Scott, *Definition of
  a 5-MW Reference Wind Turbine for Offshore System Development*,
  NREL/TP-500-38060, 2009 (rotor and rotor-nacelle assembly; drivetrain,
  sec. 5; baseline controller, sec. 7 and the parameters of its source code
  in appendix A).  ``OC3`` also gives the floating turbine's detuned pitch
  gains and region-3 constant generator torque (sec. 7 of the OC3 report).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from .._errors import ModelError

__all__ = ["Figure", "SOURCES", "PLATFORM", "ENVIRONMENT", "HYDRO", "MOORING", "TOWER",
           "TOWER_STATIONS", "RNA", "ROTOR", "DRIVETRAIN", "CONTROLLER", "BLADE",
           "tower_stations",
           "tower_rigid_properties",
           "rna_inertia_about_cm", "rigid_body_mass_matrix", "system_mass_matrix",
           "system_mass_properties", "hydrostatic_matrix", "added_mass_matrix",
           "damping_matrix", "mooring_stiffness_matrix", "all_figures"]

#: short source keys and their full references
SOURCES = MappingProxyType({
    "OC3": "Jonkman 2010, Definition of the Floating System for Phase IV of OC3, "
           "NREL/TP-500-47535",
    "5MW": "Jonkman, Butterfield, Musial, Scott 2009, Definition of a 5-MW Reference Wind "
           "Turbine for Offshore System Development, NREL/TP-500-38060",
})


@dataclass(frozen=True)
class Figure:
    """One published property.

    Attributes
    ----------
    value : float
        In SI units (``unit``).
    unit : str
    source : str
        A key of :data:`SOURCES`.
    meaning : str
        What it is (with the axes and reference point where that matters).
    """

    value: float
    unit: str
    source: str
    meaning: str


def _group(**figures):
    return MappingProxyType({k: Figure(float(v[0]), v[1], v[2], v[3])
                             for k, v in figures.items()})


ENVIRONMENT = _group(
    water_density=(1025.0, "kg/m^3", "OC3", "sea water density"),
    water_depth=(320.0, "m", "OC3", "water depth"),
    gravity=(9.80665, "m/s^2", "OC3", "gravitational acceleration"),
)

PLATFORM = _group(
    mass=(7_466_330.0, "kg", "OC3", "spar mass including ballast"),
    cm_z=(-89.9155, "m", "OC3", "spar centre of mass, z above SWL (below: negative)"),
    roll_inertia_cm=(4_229_230_000.0, "kg m^2", "OC3", "spar roll inertia about its CM"),
    pitch_inertia_cm=(4_229_230_000.0, "kg m^2", "OC3", "spar pitch inertia about its CM"),
    yaw_inertia_cm=(164_230_000.0, "kg m^2", "OC3", "spar yaw inertia about its CM"),
    draft=(120.0, "m", "OC3", "depth of the spar bottom below SWL"),
    top_z=(10.0, "m", "OC3", "spar top (tower base), z above SWL"),
    upper_diameter=(6.5, "m", "OC3", "spar diameter from z = +10 m to z = -4 m"),
    taper_top_z=(-4.0, "m", "OC3", "top of the conical taper, z above SWL"),
    taper_bottom_z=(-12.0, "m", "OC3", "bottom of the conical taper, z above SWL"),
    lower_diameter=(9.4, "m", "OC3", "spar diameter from z = -12 m to z = -120 m"),
    displaced_volume=(8029.21, "m^3", "OC3", "displaced volume in the undisplaced position"),
)

HYDRO = _group(
    C33=(332_941.0, "N/m", "OC3", "hydrostatic heave stiffness (waterplane)"),
    C44_buoyancy=(-4_999_184_000.0, "N m/rad", "OC3",
                  "hydrostatic roll stiffness, buoyancy and waterplane part only"),
    C55_buoyancy=(-4_999_184_000.0, "N m/rad", "OC3",
                  "hydrostatic pitch stiffness, buoyancy and waterplane part only"),
    A11=(7.759e6, "kg", "OC3", "added mass, surge"),
    A22=(7.759e6, "kg", "OC3", "added mass, sway"),
    A33=(2.4125e5, "kg", "OC3", "added mass, heave"),
    A44=(3.7936e10, "kg m^2", "OC3", "added mass, roll, about the SWL reference point"),
    A55=(3.7936e10, "kg m^2", "OC3", "added mass, pitch, about the SWL reference point"),
    A15=(-4.8314e8, "kg m", "OC3", "added mass, surge-pitch coupling (A51 = A15)"),
    A24=(4.8314e8, "kg m", "OC3", "added mass, sway-roll coupling (A42 = A24 = -A15)"),
    drag_coefficient=(0.6, "1", "OC3", "Morison drag coefficient of the spar"),
    inertia_added_mass_coefficient=(1.0, "1", "OC3",
                                    "Morison added-mass coefficient Ca (when no potential-flow "
                                    "added mass is used)"),
    B11=(1e5, "N s/m", "OC3", "additional linear damping, surge"),
    B22=(1e5, "N s/m", "OC3", "additional linear damping, sway"),
    B33=(1.3e5, "N s/m", "OC3", "additional linear damping, heave"),
    B66=(1.3e7, "N m s/rad", "OC3", "additional linear damping, yaw"),
)

MOORING = _group(
    n_lines=(3, "1", "OC3", "number of lines, 120 deg apart (delta connection as single lines)"),
    anchor_radius=(853.87, "m", "OC3", "anchor radius from the spar axis"),
    anchor_depth=(320.0, "m", "OC3", "anchor depth below SWL"),
    fairlead_radius=(5.2, "m", "OC3", "fairlead radius from the spar axis"),
    fairlead_depth=(70.0, "m", "OC3", "fairlead depth below SWL"),
    unstretched_length=(902.2, "m", "OC3", "unstretched line length"),
    line_diameter=(0.09, "m", "OC3", "line diameter"),
    line_mass_per_length=(77.7066, "kg/m", "OC3", "line mass per unit length (in air)"),
    line_EA=(384.243e6, "N", "OC3", "line extensional stiffness"),
    K11=(41_180.0, "N/m", "OC3", "linearized mooring stiffness, surge"),
    K22=(41_180.0, "N/m", "OC3", "linearized mooring stiffness, sway"),
    K33=(11_940.0, "N/m", "OC3", "linearized mooring stiffness, heave"),
    K44=(311_100_000.0, "N m/rad", "OC3", "linearized mooring stiffness, roll"),
    K55=(311_100_000.0, "N m/rad", "OC3", "linearized mooring stiffness, pitch"),
    K66=(11_560_000.0, "N m/rad", "OC3", "linearized mooring stiffness, yaw (lines only)"),
    K66_yaw_spring=(98_340_000.0, "N m/rad", "OC3",
                    "additional yaw spring standing for the delta connection"),
    K15=(-2_821_000.0, "N/rad", "OC3", "surge force per pitch rotation (K24 = -K15)"),
    K51=(-2_816_000.0, "N", "OC3", "pitch moment per surge displacement (K42 = -K51)"),
)

TOWER = _group(
    base_z=(10.0, "m", "OC3", "tower base, z above SWL"),
    top_z=(87.6, "m", "OC3", "tower top (yaw bearing), z above SWL"),
    mass=(249_718.0, "kg", "OC3", "tower mass"),
    base_diameter=(6.5, "m", "OC3", "outer diameter at the base"),
    base_thickness=(0.027, "m", "OC3", "wall thickness at the base"),
    top_diameter=(3.87, "m", "OC3", "outer diameter at the top"),
    top_thickness=(0.019, "m", "OC3", "wall thickness at the top"),
    density=(8500.0, "kg/m^3", "OC3", "effective steel density (paint, bolts, welds)"),
    youngs_modulus=(210e9, "Pa", "OC3", "Young's modulus of steel"),
    damping_ratio=(0.01, "1", "OC3", "structural damping ratio of every tower mode, fraction "
                   "of critical, of the isolated tower without the RNA (the 5-MW "
                   "definition's, kept by OC3)"),
)

#: the tower's distributed properties at 11 stations: ``fraction`` of the
#: flexible length (77.6 m) from the base; ``mass_per_length`` kg/m;
#: ``EI_fore_aft``, ``EI_side_side``, ``GJ`` N m^2; ``EA`` N.  Source: OC3.
TOWER_STATIONS = MappingProxyType({
    "fraction": (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0),
    "mass_per_length": (4667.00, 4345.28, 4034.76, 3735.44, 3447.32, 3170.40, 2904.69,
                        2650.18, 2406.88, 2174.77, 1953.87),
    "EI_fore_aft": (603.903e9, 517.644e9, 440.925e9, 373.022e9, 313.236e9, 260.897e9,
                    215.365e9, 176.028e9, 142.301e9, 113.630e9, 89.488e9),
    "EI_side_side": (603.903e9, 517.644e9, 440.925e9, 373.022e9, 313.236e9, 260.897e9,
                     215.365e9, 176.028e9, 142.301e9, 113.630e9, 89.488e9),
    "GJ": (464.718e9, 398.339e9, 339.303e9, 287.049e9, 241.043e9, 200.767e9, 165.729e9,
           135.458e9, 109.504e9, 87.441e9, 68.863e9),
    "EA": (115.302e9, 107.354e9, 99.682e9, 92.287e9, 85.169e9, 78.328e9, 71.763e9, 65.475e9,
           59.464e9, 53.730e9, 48.272e9),
})

RNA = _group(
    mass=(350_000.0, "kg", "5MW", "rotor-nacelle assembly mass (hub 56,780 + nacelle 240,000 + "
                                  "three blades)"),
    hub_mass=(56_780.0, "kg", "5MW", "hub mass"),
    nacelle_mass=(240_000.0, "kg", "5MW", "nacelle mass"),
    cm_x=(-0.414, "m", "5MW", "RNA centre of mass from the tower top, downwind"),
    cm_z=(1.967, "m", "5MW", "RNA centre of mass from the tower top, up"),
    Ixx_top=(4.370e7, "kg m^2", "5MW", "RNA inertia about the tower top, roll axis"),
    Iyy_top=(2.353e7, "kg m^2", "5MW", "RNA inertia about the tower top, pitch axis"),
    Izz_top=(2.542e7, "kg m^2", "5MW", "RNA inertia about the tower top, yaw axis"),
    Izx_top=(1.169e6, "kg m^2", "5MW",
             "RNA inertia tensor component zx about the tower top (= -integral of x z dm)"),
)

ROTOR = _group(
    n_blades=(3, "1", "5MW", "number of blades"),
    diameter=(126.0, "m", "5MW", "rotor diameter"),
    hub_radius=(1.5, "m", "5MW", "hub radius (hub diameter 3 m): the blades' root"),
    hub_height=(90.0, "m", "5MW", "hub height above SWL"),
    rated_wind_speed=(11.4, "m/s", "5MW", "rated wind speed"),
    rated_rotor_speed=(12.1, "rpm", "5MW", "rated rotor speed"),
    shaft_tilt=(5.0, "deg", "5MW", "shaft tilt"),
    precone=(2.5, "deg", "5MW", "blade precone"),
    overhang=(5.0191, "m", "5MW", "hub overhang (upwind of the yaw axis)"),
    air_density=(1.225, "kg/m^3", "5MW", "air density of the rotor's design and tables"),
)

DRIVETRAIN = _group(
    rotor_inertia=(38_759_227.0, "kg m^2", "5MW",
                   "rotor (hub and blades) inertia about the shaft: the published drivetrain "
                   "inertia 43,784,725 cast to the low-speed shaft less 97^2 x 534.116 (sec. 7.4)"),
    hub_inertia=(115_926.0, "kg m^2", "5MW", "hub inertia about the shaft"),
    generator_inertia=(534.116, "kg m^2", "5MW", "generator inertia about the high-speed shaft"),
    gear_ratio=(97.0, "1", "5MW", "gearbox ratio, high-speed to low-speed shaft"),
    shaft_stiffness=(867_637_000.0, "N m/rad", "5MW",
                     "drivetrain torsional stiffness, low-speed shaft"),
    shaft_damping=(6_215_000.0, "N m s/rad", "5MW",
                   "drivetrain torsional damping, low-speed shaft"),
    generator_efficiency=(0.944, "1", "5MW", "electrical efficiency of the generator"),
)

CONTROLLER = _group(
    filter_corner=(1.570796, "rad/s", "5MW",
                   "corner of the one-pole generator-speed low-pass filter (0.25 Hz)"),
    cut_in_speed=(70.16224, "rad/s", "5MW", "generator speed where region 1 1/2 begins (670 rpm)"),
    region2_start_speed=(91.21091, "rad/s", "5MW",
                         "generator speed where region 2 begins (871 rpm)"),
    region25_speed=(121.6805, "rad/s", "5MW",
                    "generator speed at the end of region 2 1/2 (99 % of 1173.7 rpm)"),
    reference_speed=(122.9096, "rad/s", "5MW",
                     "rated generator speed, the pitch controller's set point (1173.7 rpm)"),
    region2_gain=(2.332287, "N m/(rad/s)^2", "5MW",
                  "region-2 torque constant (0.0255764 N m/rpm^2)"),
    slip=(0.10, "1", "5MW", "slip of the region-2 1/2 induction-generator line"),
    rated_power=(5_296_610.0, "W", "5MW", "rated mechanical power"),
    max_torque=(47_402.91, "N m", "5MW", "generator torque limit"),
    region3_pitch=(0.01745329, "rad", "5MW",
                   "pitch from which the torque law is in region 3 (1 deg)"),
    kp=(0.006275604, "s", "OC3", "pitch controller proportional gain at zero pitch, detuned for "
                               "the floating turbine (onshore 0.01882681)"),
    ki=(0.0008965149, "1", "OC3", "pitch controller integral gain at zero pitch, detuned for the "
                                 "floating turbine (onshore 0.008068634)"),
    gain_doubling_pitch=(0.1099965, "rad", "5MW",
                         "pitch where the pitch sensitivity of power doubles (6.302336 deg)"),
    min_pitch=(0.0, "rad", "5MW", "lower pitch limit"),
    max_pitch=(1.570796, "rad", "5MW", "upper pitch limit (90 deg)"),
    max_pitch_rate=(0.1396263, "rad/s", "5MW", "pitch rate limit (8 deg/s)"),
)

BLADE = _group(
    mass=(17_740.0, "kg", "5MW", "blade mass (integrated; the flexible blades' distributed "
                                 "mass is scaled to it)"),
    cm_from_root=(20.475, "m", "5MW", "blade centre of mass from the root along the blade"),
    second_moment_root=(11_776_047.0, "kg m^2", "5MW",
                        "blade second mass moment of inertia about the root"),
    damping_ratio=(0.00477465, "1", "5MW",
                   "structural damping ratio of the blade's modes (flap 1, flap 2, edge 1), "
                   "fraction of critical, of the isolated blade (0.477465 %)"),
)

_GROUPS = {"ENVIRONMENT": ENVIRONMENT, "PLATFORM": PLATFORM, "HYDRO": HYDRO,
           "MOORING": MOORING, "TOWER": TOWER, "RNA": RNA, "ROTOR": ROTOR,
           "DRIVETRAIN": DRIVETRAIN, "CONTROLLER": CONTROLLER, "BLADE": BLADE}


def all_figures():
    """Every scalar figure: ``[(group, name, Figure)]`` (the model card's table)."""
    return [(g, k, f) for g, group in _GROUPS.items() for k, f in group.items()]


def _v(group, name):
    return group[name].value


# ----------------------------------------------------------------- tower
def _tube(fraction):
    """Outer diameter and wall thickness (m) at ``fraction`` of the tower, linear between ends."""
    f = np.asarray(fraction, float)
    D = _v(TOWER, "base_diameter") + f * (_v(TOWER, "top_diameter") - _v(TOWER, "base_diameter"))
    t = (_v(TOWER, "base_thickness")
         + f * (_v(TOWER, "top_thickness") - _v(TOWER, "base_thickness")))
    return D, t


def tower_stations(*, polar_inertia=True):
    """The station table of the tower for :class:`~kanedyn.flexible.BeamMember` (axis along body z).

    Parameters
    ----------
    polar_inertia : bool
        Add ``polar_inertia`` (kg m), the mass moment of inertia per length
        about the tower axis, ``m' (r_o^2 + r_i^2) / 2`` of the thin steel tube
        whose diameter and wall thickness vary linearly between the published
        base and top values (the published table gives none; without it twist
        carries no inertia).  The bending rotary inertia is left out
        (Euler-Bernoulli beams).

    Returns
    -------
    dict of str to ndarray, shape (11,)
        ``arc`` (m from the tower base), ``mass_per_length`` (kg/m), ``EA``
        (N), ``GJ``, ``EI_y``, ``EI_z`` (N m^2) and optionally
        ``polar_inertia``.  With the tower along body z, the member's local y
        axis is body y: ``EI_y`` (bending in the local x-z plane, deflection
        along body -x) is the fore-aft stiffness, ``EI_z`` the side-side one.
    """
    f = np.array(TOWER_STATIONS["fraction"])
    length = _v(TOWER, "top_z") - _v(TOWER, "base_z")
    m = np.array(TOWER_STATIONS["mass_per_length"])
    table = {"arc": f * length, "mass_per_length": m,
             "EA": np.array(TOWER_STATIONS["EA"]), "GJ": np.array(TOWER_STATIONS["GJ"]),
             "EI_y": np.array(TOWER_STATIONS["EI_fore_aft"]),
             "EI_z": np.array(TOWER_STATIONS["EI_side_side"])}
    if polar_inertia:
        D, t = _tube(f)
        ro, ri = D / 2, D / 2 - t
        table["polar_inertia"] = m * (ro ** 2 + ri ** 2) / 2
    return table


def _linear_moments(z, w, powers):
    """Exact integrals of ``w(z) z^p`` for piecewise-linear ``w`` over the stations ``z``."""
    out = []
    for p in powers:
        total = 0.0
        for za, zb, wa, wb in zip(z[:-1], z[1:], w[:-1], w[1:]):
            slope = (wb - wa) / (zb - za)
            c0 = wa - slope * za          # w = c0 + slope z
            total += (c0 * (zb ** (p + 1) - za ** (p + 1)) / (p + 1)
                      + slope * (zb ** (p + 2) - za ** (p + 2)) / (p + 2))
        out.append(total)
    return out


def tower_rigid_properties(*, section_inertia=True):
    """The tower as a rigid body: mass, centre of mass, inertia about its centre of mass.

    The mass per length varies linearly between the 11 stations (as in the
    finite-element member); integrals are exact for that interpolation.

    Parameters
    ----------
    section_inertia : bool
        Include the inertia of the tube sections (polar about the axis, half
        of it about each transverse axis; see :func:`tower_stations`),
        integrated by Simpson's rule on a fine grid; otherwise the tower is a
        line of mass (no yaw inertia).

    Returns
    -------
    mass : float
        kg.
    cm : ndarray, shape (3,)
        Centre of mass relative to the SWL reference point, m.
    inertia : ndarray, shape (3, 3)
        About the centre of mass, kg m^2.
    """
    z = _v(TOWER, "base_z") + np.array(TOWER_STATIONS["fraction"]) * (
        _v(TOWER, "top_z") - _v(TOWER, "base_z"))
    w = np.array(TOWER_STATIONS["mass_per_length"])
    m0, m1, m2 = _linear_moments(z, w, (0, 1, 2))
    zc = m1 / m0
    transverse = m2 - m0 * zc ** 2
    inertia = np.diag([transverse, transverse, 0.0])
    if section_inertia:
        from scipy.integrate import simpson
        f = np.linspace(0.0, 1.0, 2001)
        D, t = _tube(f)
        ro, ri = D / 2, D / 2 - t
        mpl = np.interp(f, TOWER_STATIONS["fraction"], w)
        polar = simpson(mpl * (ro ** 2 + ri ** 2) / 2, x=f * (z[-1] - z[0]))
        inertia += np.diag([polar / 2, polar / 2, polar])
    return m0, np.array([0.0, 0.0, zc]), inertia


def rna_inertia_about_cm():
    """The RNA's inertia about its own centre of mass, kg m^2, shape (3, 3).

    From the published inertia about the tower top by the parallel-axis
    theorem, :math:`I_c = I_{top} + m\\,\\tilde r\\,\\tilde r` with :math:`r`
    the centre of mass's offset from the tower top.
    """
    m = _v(RNA, "mass")
    Ixz = _v(RNA, "Izx_top")
    top = np.array([[_v(RNA, "Ixx_top"), 0.0, Ixz],
                    [0.0, _v(RNA, "Iyy_top"), 0.0],
                    [Ixz, 0.0, _v(RNA, "Izz_top")]])
    r = np.array([_v(RNA, "cm_x"), 0.0, _v(RNA, "cm_z")])
    return top + m * _skew(r) @ _skew(r)


def _skew(r):
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


# ----------------------------------------------------------- 6 x 6 matrices
def rigid_body_mass_matrix(mass, cm, inertia_cm):
    """6 x 6 mass matrix of a rigid body about the SWL reference point.

    Parameters
    ----------
    mass : float
        kg.
    cm : array_like, shape (3,)
        Centre of mass relative to the reference point, m.
    inertia_cm : array_like, shape (3, 3)
        Inertia about the centre of mass, kg m^2.

    Returns
    -------
    ndarray, shape (6, 6)
        ``[[m 1, -m r~], [m r~, I_c - m r~ r~]]`` (kg, kg m, kg m^2): the
        kinetic energy is ``1/2 v^T M v`` with ``v`` the velocity of the
        reference point and the angular velocity.
    """
    r = np.asarray(cm, float)
    S = _skew(r)
    M = np.zeros((6, 6))
    M[:3, :3] = mass * np.eye(3)
    M[:3, 3:] = -mass * S
    M[3:, :3] = mass * S
    M[3:, 3:] = np.asarray(inertia_cm, float) - mass * S @ S
    return M


_PARTS = ("platform", "tower", "rna")


def _parts(include):
    include = tuple(include)
    bad = [p for p in include if p not in _PARTS]
    if bad:
        raise ModelError(f"OC3 system: unknown part(s) {bad}; parts are {', '.join(_PARTS)}")
    out = {}
    if "platform" in include:
        out["platform"] = (_v(PLATFORM, "mass"), np.array([0.0, 0.0, _v(PLATFORM, "cm_z")]),
                           np.diag([_v(PLATFORM, "roll_inertia_cm"),
                                    _v(PLATFORM, "pitch_inertia_cm"),
                                    _v(PLATFORM, "yaw_inertia_cm")]))
    if "tower" in include:
        out["tower"] = tower_rigid_properties()
    if "rna" in include:
        out["rna"] = (_v(RNA, "mass"),
                      np.array([_v(RNA, "cm_x"), 0.0, _v(TOWER, "top_z") + _v(RNA, "cm_z")]),
                      rna_inertia_about_cm())
    return out


def system_mass_matrix(include=_PARTS):
    """6 x 6 mass matrix of the rigid system about the SWL reference point.

    Parameters
    ----------
    include : sequence of {"platform", "tower", "rna"}
        The parts (all by default); the tower is rigid here (see
        :func:`tower_rigid_properties`).

    Returns
    -------
    ndarray, shape (6, 6)
        kg, kg m, kg m^2.
    """
    return sum(rigid_body_mass_matrix(*p) for p in _parts(include).values())


def system_mass_properties(include=_PARTS):
    """Total mass (kg) and centre of mass (m, shape (3,), from the SWL reference point)."""
    parts = _parts(include).values()
    mass = sum(p[0] for p in parts)
    return mass, sum(p[0] * p[1] for p in parts) / mass


def hydrostatic_matrix(*, weight=True):
    """6 x 6 hydrostatic restoring matrix about the SWL reference point, N/m, N m/rad.

    Parameters
    ----------
    weight : bool
        Add the restoring of the whole system's weight in roll and pitch,
        :math:`-m g z_G` (platform, tower and RNA, :func:`system_mass_properties`);
        without it, only the published buoyancy and waterplane part.
    """
    C = np.zeros((6, 6))
    C[2, 2] = _v(HYDRO, "C33")
    C[3, 3] = _v(HYDRO, "C44_buoyancy")
    C[4, 4] = _v(HYDRO, "C55_buoyancy")
    if weight:
        mass, cm = system_mass_properties()
        C[3, 3] -= mass * _v(ENVIRONMENT, "gravity") * cm[2]
        C[4, 4] -= mass * _v(ENVIRONMENT, "gravity") * cm[2]
    return C


def added_mass_matrix():
    """6 x 6 constant (infinite-frequency-like) added mass about the SWL point, kg, kg m, kg m^2."""
    A = np.diag([_v(HYDRO, k) for k in ("A11", "A22", "A33", "A44", "A55")] + [0.0])
    A[0, 4] = A[4, 0] = _v(HYDRO, "A15")
    A[1, 3] = A[3, 1] = _v(HYDRO, "A24")
    return A


def damping_matrix():
    """6 x 6 additional linear damping of OC3, N s/m, N m s/rad."""
    return np.diag([_v(HYDRO, "B11"), _v(HYDRO, "B22"), _v(HYDRO, "B33"), 0.0, 0.0,
                    _v(HYDRO, "B66")])


def mooring_stiffness_matrix(*, yaw_spring=True):
    """6 x 6 linearized mooring stiffness about the undisplaced position, N/m, N/rad, N m/rad.

    As published: the surge-pitch and sway-roll couplings are not exactly
    symmetric (``K15 = -2.821e6`` N/rad, ``K51 = -2.816e6`` N; 0.2 %).

    Parameters
    ----------
    yaw_spring : bool
        Add the additional yaw spring that stands for the delta connection.
    """
    K = np.diag([_v(MOORING, k) for k in ("K11", "K22", "K33", "K44", "K55", "K66")])
    if yaw_spring:
        K[5, 5] += _v(MOORING, "K66_yaw_spring")
    K[0, 4] = _v(MOORING, "K15")
    K[1, 3] = -_v(MOORING, "K15")
    K[4, 0] = _v(MOORING, "K51")
    K[3, 1] = -_v(MOORING, "K51")
    return K
