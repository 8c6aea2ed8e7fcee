"""Force elements of floating structures: waves, Morison loads, hydrostatics.

``_waves``         linear (Airy) regular waves, JONSWAP irregular seas, stretching
``_member``        axisymmetric members along a body axis (diameter tables)
``_morison``       Morison strip loads on slender cylinders
``_hydrostatics``  buoyancy and restoring (linear and large-angle forms)
"""

from ._hydrostatics import HYDROSTATIC_FORMS, Hydrostatics
from ._morison import AddedMassStrip, MorisonCylinder
from ._waves import (STRETCHING, AiryWave, IrregularSea, jonswap_gamma, jonswap_spectrum,
                     wave_number)

__all__ = ["AiryWave", "IrregularSea", "jonswap_spectrum", "jonswap_gamma", "wave_number",
           "STRETCHING", "MorisonCylinder", "AddedMassStrip", "Hydrostatics",
           "HYDROSTATIC_FORMS"]
