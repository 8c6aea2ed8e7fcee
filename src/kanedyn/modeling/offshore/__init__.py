"""Force elements of floating offshore structures.

``_waves``         linear (Airy) regular waves, JONSWAP irregular seas, stretching
``_member``        axisymmetric members along a body axis (diameter tables)
``_morison``       Morison strip loads on slender cylinders
``_hydrostatics``  buoyancy and restoring (linear and large-angle forms)
``_catenary``      the quasi-static elastic catenary of one mooring line
``_mooring``       linearized 6x6 mooring, catenary mooring systems
``_rotor``         rotor thrust from a steady curve, aerodynamic damping, Kaimal wind
"""

from ._catenary import CatenaryLine, catenary_spans, solve_catenary
from ._hydrostatics import HYDROSTATIC_FORMS, Hydrostatics
from ._mooring import OC3_MOORING, CatenaryMooring, LinearMooring, state_function
from ._morison import AddedMassStrip, MorisonCylinder
from ._rotor import NREL5MW_THRUST, RotorThrust, ThrustCurve, kaimal_spectrum, kaimal_wind
from ._waves import (STRETCHING, AiryWave, IrregularSea, jonswap_gamma, jonswap_spectrum,
                     wave_number)

__all__ = ["AiryWave", "IrregularSea", "jonswap_spectrum", "jonswap_gamma", "wave_number",
           "STRETCHING", "MorisonCylinder", "AddedMassStrip", "Hydrostatics",
           "HYDROSTATIC_FORMS", "CatenaryLine", "catenary_spans", "solve_catenary",
           "OC3_MOORING", "CatenaryMooring", "LinearMooring", "state_function",
           "NREL5MW_THRUST", "RotorThrust", "ThrustCurve", "kaimal_spectrum", "kaimal_wind"]
