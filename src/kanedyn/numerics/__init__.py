"""Numerics: equations of motion become numbers.

``_model``               ``NumericModel`` and ``build_numeric_model``: generated
                         functions, state layout, constraint handling
``backends/``            code generators: ``_python`` (NumPy) and ``_c`` (a C
                         extension, with its runtime and integration loop)
``schemes/``             how evaluated terms become accelerations (one module per
                         family of constraint schemes)
``_linearize``           exact linearization, symbolic and numeric
``_inverse``             inverse dynamics: the generalized forces for given rates
``_orthogonal_speeds``   models in orthogonalized generalized speeds
``_contact_dynamics``    accelerations and contact forces per contact mode
``_diagnosis``           why a derivative is not finite, in the model's names
``_actuator_forces``     actuator forces from generalized forces by virtual work
``_inverse_parts``       inverse-dynamics and actuator forces by cause and body; power
``_singular``            distance to singular configurations, and its monitor
"""

from ._actuator_forces import ActuatorForces, ActuatorMap, actuator_forces
from ._contact_dynamics import (SEPARATED, SLIP, STICK, SlipReference, contact_points,
                                solve_modes)
from ._diagnosis import diagnose
from ._inverse_parts import (ActuatorParts, InverseParts, PowerBalance, actuator_parts,
                             inverse_parts, power_balance)
from ._linearize import linearize_numeric, linearize_symbolic
from ._model import BACKENDS, NumericModel, build_numeric_model
from ._orthogonal_speeds import MassMatrices, OrthogonalSpeedsModel, orthogonalize_speeds
from ._singular import DEFAULT_THRESHOLD, SingularityMonitor, conditioning
from .backends import STATS as COMPILE_STATS
from .backends import cache_dir, compile_python, compiler_command, generate_python

__all__ = ["COMPILE_STATS", "cache_dir", "compiler_command", "NumericModel",
           "build_numeric_model", "BACKENDS", "linearize_numeric",
           "linearize_symbolic", "MassMatrices", "OrthogonalSpeedsModel",
           "orthogonalize_speeds", "SEPARATED", "SLIP", "STICK", "SlipReference",
           "contact_points", "solve_modes", "diagnose", "DEFAULT_THRESHOLD",
           "SingularityMonitor", "conditioning", "compile_python", "generate_python",
           "ActuatorForces", "ActuatorMap", "actuator_forces", "InverseParts",
           "ActuatorParts", "PowerBalance", "inverse_parts", "actuator_parts",
           "power_balance"]
