"""Numerics: equations of motion become numbers.

``_model``               ``NumericModel`` and ``build_numeric_model``: generated
                         functions, state layout, constraint handling
``backends/``            code generators: ``_python`` (NumPy) and ``_c`` (a C
                         extension, with its runtime and integration loop)
``schemes/``             how evaluated terms become accelerations (one module per
                         family of constraint schemes)
``_linearize``           exact linearization, symbolic and numeric
``_inverse``             inverse dynamics: the generalized forces for given rates
``_jacobians``           exact derivatives of the right-hand side (state, inputs,
                         constants), generated from the equations' program
``_hessians``            second derivatives of the right-hand side, weighted by
                         multipliers (the exact Hessian of optimal control)
``_stabilization_derivatives``
                         what the stabilized schemes (Baumgarte, penalty, augmented
                         Lagrangian) add to those derivatives
``_equilibrium``         static equilibria and steady motions (Newton on them)
``_orthogonal_speeds``   models in orthogonalized generalized speeds
``_orthogonal_constrained``
                         the same on the speeds that velocity constraints admit
``_contact_dynamics``    accelerations and contact forces per contact mode
``_contact_derivatives`` their exact derivatives within the modes
``_diagnosis``           why a derivative is not finite, in the model's names
``_actuator_forces``     actuator forces from generalized forces by virtual work
``_inverse_parts``       inverse-dynamics and actuator forces by cause and body; power
``_load_powers``         the power of each load, of prescribed motion, of damping
``_singular``            distance to singular configurations, and its monitor
"""

from .._lazy import lazy_attributes as _lazy_attributes
from .backends._c_build import STATS as COMPILE_STATS

#: public name -> the module (in this package) that defines it; imported on first use
#: (a numerical model read from the derivation cache needs neither SymPy nor SciPy)
_LAZY = {
    'ActuatorForces': '._actuator_forces',
    'ActuatorMap': '._actuator_forces',
    'actuator_forces': '._actuator_forces',
    'SEPARATED': '._contact_dynamics',
    'SLIP': '._contact_dynamics',
    'STICK': '._contact_dynamics',
    'SlipReference': '._contact_dynamics',
    'contact_points': '._contact_dynamics',
    'solve_modes': '._contact_dynamics',
    'segment_jacobian': '._contact_derivatives',
    'diagnose': '._diagnosis',
    'ActuatorParts': '._inverse_parts',
    'InverseParts': '._inverse_parts',
    'PowerBalance': '._inverse_parts',
    'actuator_parts': '._inverse_parts',
    'inverse_parts': '._inverse_parts',
    'LoadPowers': '._load_powers',
    'load_powers': '._load_powers',
    'Jacobians': '._jacobians',
    'hessians_unavailable': '._hessians',
    'weighted_hessians': '._hessians',
    'weighted_hessian_pattern': '._hessians',
    'names_time': '._hessians',
    'EXACT_SCHEMES': '._jacobians',
    'derivatives_unavailable': '._jacobians',
    'derivatives_built': '._jacobians',
    'exact_loop': '._jacobians',
    'inputs_follow_state': '._jacobians',
    'Equilibrium': '._equilibrium',
    'equilibrium': '._equilibrium',
    'state_jacobian': '._jacobians',
    'through_inputs': '._jacobians',
    'power_balance': '._inverse_parts',
    'linearize_numeric': '._linearize',
    'linearize_symbolic': '._linearize',
    'BACKENDS': '._model',
    'NumericModel': '._model',
    'build_numeric_model': '._model',
    'MassMatrices': '._orthogonal_speeds',
    'OrthogonalSpeedsModel': '._orthogonal_speeds',
    'ConstrainedOrthogonalSpeedsModel': '._orthogonal_constrained',
    'orthogonalize_speeds': '._orthogonal_speeds',
    'DEFAULT_THRESHOLD': '._singular',
    'SingularityMonitor': '._singular',
    'conditioning': '._singular',
    'cache_dir': '.backends._c_build',
    'compiler_command': '.backends._c_build',
    'cached_module': '.backends._c_build',
    'load_module': '.backends._c_build',
    'load_fixed_module': '.backends._c_build',
    'NAME_TOKEN': '.backends._c_build',
    'CompilerError': '.backends._c_build',
    'finish_compiling': '.backends._c_quick',
    'prefetch_runtime': '.backends._c',
    'compile_python': '.backends._python',
    'generate_python': '.backends._python',
}

__all__ = ["COMPILE_STATS", *_LAZY]

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__)
