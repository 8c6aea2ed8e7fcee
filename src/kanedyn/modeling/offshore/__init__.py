"""Force elements of floating offshore structures.

``_waves``         linear (Airy) regular waves, JONSWAP irregular seas, stretching
``_member``        axisymmetric members along a body axis (diameter tables)
``_morison``       Morison strip loads on slender cylinders
``_hydrostatics``  buoyancy and restoring (linear and large-angle forms)
``_catenary``      the quasi-static elastic catenary of one mooring line
``_mooring``       linearized 6x6 mooring, catenary mooring systems
``_rotor``         rotor thrust from a steady curve, aerodynamic damping, Kaimal wind
``_rotor_performance``  a rotor's torque and thrust from its Cp, Ct table (closed-form fit)
``_aerodyn_tables``  airfoil polars and blade tables read from AeroDyn 15 files
``_openfast_input``  OpenFAST's text input and summary files: values by name, tables
``_blade_element_momentum``  a rotor's annuli solved by blade-element momentum theory
``_blade_element_rotor``  BEM loads on a spinning rotor from the bodies' motion
``_flexible_blade_rotor``  BEM loads on the nodes of flexible blades as they deflect
``_drivetrain``    the spinning rotor on a tilted shaft, gearbox, generator, shaft twist
``_baseline_controller``  variable-speed, collective-pitch control as first-order states
"""

from ._aerodyn_tables import AirfoilPolar, BladeTable, read_airfoil_polar, read_blade_table
from ._baseline_controller import BaselineController
from ._blade_element_momentum import AnnulusSolution, BladeElementMomentum
from ._blade_element_rotor import BladeElementRotor
from ._catenary import CatenaryLine, catenary_spans, solve_catenary
from ._drivetrain import Drivetrain
from ._flexible_blade_rotor import FlexibleBladeElementRotor
from ._hydrostatics import HYDROSTATIC_FORMS, Hydrostatics
from ._openfast_input import (OpenFASTEntry, OpenFASTInput, OpenFASTTable,
                              read_openfast_input)
from ._mooring import OC3_MOORING, CatenaryMooring, LinearMooring, state_function
from ._morison import AddedMassStrip, MorisonCylinder
from ._rotor import NREL5MW_THRUST, RotorThrust, ThrustCurve, kaimal_spectrum, kaimal_wind
from ._rotor_performance import PerformanceSurface, RotorAerodynamics
from ._waves import (STRETCHING, AiryWave, IrregularSea, jonswap_gamma, jonswap_spectrum,
                     wave_number)

__all__ = ["AiryWave", "IrregularSea", "jonswap_spectrum", "jonswap_gamma", "wave_number",
           "STRETCHING", "MorisonCylinder", "AddedMassStrip", "Hydrostatics",
           "HYDROSTATIC_FORMS", "CatenaryLine", "catenary_spans", "solve_catenary",
           "OC3_MOORING", "CatenaryMooring", "LinearMooring", "state_function",
           "NREL5MW_THRUST", "RotorThrust", "ThrustCurve", "kaimal_spectrum", "kaimal_wind",
           "PerformanceSurface", "RotorAerodynamics", "Drivetrain", "BaselineController",
           "AirfoilPolar", "BladeTable", "read_airfoil_polar", "read_blade_table",
           "BladeElementMomentum", "AnnulusSolution", "BladeElementRotor",
           "FlexibleBladeElementRotor",
           "OpenFASTInput", "OpenFASTTable", "OpenFASTEntry", "read_openfast_input"]
