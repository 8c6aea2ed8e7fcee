"""FMU export: a numerical model as an FMI 2.0 or 3.0 FMU (model exchange and
co-simulation).

``_variables``    the FMI variables (states, derivatives, parameters, inputs, energy
                  outputs, the co-simulation solver's settings) and their value
                  references
``_description``  ``modelDescription.xml`` (both versions), FMI 3.0's
                  ``buildDescription.xml``
``_c_core``       the C shared by both interfaces: an instance, values by value
                  reference, derivatives, projection events, the co-simulation step
``_c_fmi2``       ``fmi2.c``'s FMI 2.0 types and functions around the core
``_c_fmi3``       ``fmi3.c``'s FMI 3.0 types and functions around the core
``_wrapper``      the interface's C source: a version's types, the core, its functions
``_export``       :func:`export_fmu`: the sources, the compiled binary, the archive
"""

from ._export import FMI_VERSIONS, FMU_SOURCES, export_fmu
from ._variables import SETTINGS

__all__ = ["export_fmu", "FMU_SOURCES", "FMI_VERSIONS", "SETTINGS"]
