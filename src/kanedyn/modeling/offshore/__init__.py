"""Force elements of floating offshore structures.

``_catenary``  the quasi-static elastic catenary of one mooring line
``_mooring``   linearized 6x6 mooring, catenary mooring systems
``_rotor``     rotor thrust from a steady curve, aerodynamic damping, Kaimal wind
"""

from ._catenary import CatenaryLine, catenary_spans, solve_catenary
from ._mooring import OC3_MOORING, CatenaryMooring, LinearMooring, state_function
from ._rotor import NREL5MW_THRUST, RotorThrust, ThrustCurve, kaimal_spectrum, kaimal_wind

__all__ = ["CatenaryLine", "catenary_spans", "solve_catenary", "OC3_MOORING",
           "CatenaryMooring", "LinearMooring", "state_function", "NREL5MW_THRUST",
           "RotorThrust", "ThrustCurve", "kaimal_spectrum", "kaimal_wind"]
