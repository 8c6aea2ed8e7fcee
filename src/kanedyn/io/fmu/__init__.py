"""FMU export: a numerical model as an FMI 2.0 FMU (model exchange and co-simulation).

``_variables``    the FMI variables (states, derivatives, parameters, inputs, energy
                  outputs, the co-simulation solver's settings) and their value
                  references
``_description``  ``modelDescription.xml``
``_wrapper``      ``fmi2.c``: the FMI 2.0 functions around the standalone C export
``_export``       :func:`export_fmu`: the sources, the compiled binary, the archive
"""

from ._export import FMU_SOURCES, export_fmu
from ._variables import SETTINGS

__all__ = ["export_fmu", "FMU_SOURCES", "SETTINGS"]
