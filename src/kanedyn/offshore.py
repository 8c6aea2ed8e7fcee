"""Floating offshore structures: waves, hydrodynamic loads, moorings, the rotor (``kd.offshore``).

Force elements that reduce themselves to loads (``to_loads()``); the ``oc3-spar``
model is built from them and ``docs/offshore.md`` describes each::

    AiryWave          one linear (Airy) regular wave
    IrregularSea      a JONSWAP irregular sea: a sum of Airy components
    jonswap_spectrum  the JONSWAP spectral density S(omega) (m^2 s/rad)
    jonswap_gamma     the peak enhancement factor IEC 61400-3 recommends
    wave_number       k of the finite-depth dispersion relation omega^2 = g k tanh(k h)
    MorisonCylinder   Morison strip loads (inertia and drag) on a slender cylinder
    Hydrostatics      buoyancy and restoring, linear or large-angle
    LinearMooring     a 6x6 mooring stiffness about the undisplaced position
    CatenaryLine      the quasi-static elastic catenary of one mooring line
    CatenaryMooring   a mooring system of catenary lines
    RotorThrust       rotor thrust along the shaft from a steady curve and the relative wind
    ThrustCurve       a steady thrust curve T(V)
    NREL5MW_THRUST    the NREL 5-MW rotor's steady thrust curve
    kaimal_wind       a seeded longitudinal wind speed series at hub height (Kaimal)
    PerformanceSurface  a rotor's torque and thrust coefficients fitted to its Cp, Ct table
    RotorAerodynamics   quasi-steady rotor thrust and torque from a PerformanceSurface
    Drivetrain        the spinning rotor on a tilted shaft, gearbox, generator (shaft twist)
    BaselineController  variable-speed, collective-pitch control as first-order states
    AirfoilPolar      an airfoil's lift and drag coefficients against the angle of attack
    BladeTable        a blade's aerodynamic stations: span, twist, chord, airfoil number
    read_airfoil_polar  an AirfoilPolar from an AeroDyn 15 airfoil file
    read_blade_table  a BladeTable from an AeroDyn 15 blade file
    read_openfast_input  an OpenFAST text input or summary file: values by name, tables
    OpenFASTInput     what read_openfast_input returns (number, flag, text, array, table)
    OpenFASTTable     a table of an OpenFAST file: columns, units, rows
    OpenFASTEntry     one named value (or matrix) of an OpenFAST file, with its line
    BladeElementMomentum  a rotor's annuli solved by blade-element momentum theory
    AnnulusSolution   the annuli's inflow angles, inductions and loads
    BladeElementRotor   quasi-steady BEM force and moment on a spinning rotor from the motion
    FlexibleBladeElementRotor  quasi-steady BEM loads on the nodes of flexible blades

These names were at ``kd.`` before: that spelling still gives the same object,
with a DeprecationWarning naming the new one.
"""

from ._lazy import NAMESPACES as _NAMESPACES
from ._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module that defines it (relative to ``kanedyn``); imported on first use
_LAZY = {
    "AiryWave": ".modeling.offshore",
    "IrregularSea": ".modeling.offshore",
    "jonswap_spectrum": ".modeling.offshore",
    "jonswap_gamma": ".modeling.offshore",
    "wave_number": ".modeling.offshore",
    "MorisonCylinder": ".modeling.offshore",
    "Hydrostatics": ".modeling.offshore",
    "LinearMooring": ".modeling.offshore",
    "CatenaryLine": ".modeling.offshore",
    "CatenaryMooring": ".modeling.offshore",
    "RotorThrust": ".modeling.offshore",
    "ThrustCurve": ".modeling.offshore",
    "NREL5MW_THRUST": ".modeling.offshore",
    "kaimal_wind": ".modeling.offshore",
    "PerformanceSurface": ".modeling.offshore",
    "RotorAerodynamics": ".modeling.offshore",
    "Drivetrain": ".modeling.offshore",
    "BaselineController": ".modeling.offshore",
    "AirfoilPolar": ".modeling.offshore",
    "BladeTable": ".modeling.offshore",
    "read_airfoil_polar": ".modeling.offshore",
    "read_blade_table": ".modeling.offshore",
    "read_openfast_input": ".modeling.offshore",
    "OpenFASTInput": ".modeling.offshore",
    "OpenFASTTable": ".modeling.offshore",
    "OpenFASTEntry": ".modeling.offshore",
    "BladeElementMomentum": ".modeling.offshore",
    "AnnulusSolution": ".modeling.offshore",
    "BladeElementRotor": ".modeling.offshore",
    "FlexibleBladeElementRotor": ".modeling.offshore",
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__,
                                        neighbours=_NAMESPACES)
