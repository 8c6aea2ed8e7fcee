"""kanedyn: multibody dynamics by Kane's method.

Public API (see the README and ``docs/``)::

    import kanedyn as kd
    eom = kd.kane(system)                     # or KanesMethod-style keywords
    model = eom.numeric(constants={...})
    res = kd.simulate(model, (0, 10), y0)
"""

from ._errors import (ConstraintError, KanedynError, KinematicsError, MissingValueError,
                      ModelError, OptionError, SimulationInterrupted,
                      SingularConfigurationWarning)
from ._version import __version__ as __version__

# Everything else is imported when first used (``kd.simulate``, ``from kanedyn
# import kane``): ``import kanedyn`` stays fast and imports neither SciPy nor
# Matplotlib.  public name -> the module that defines it
_LAZY = {
    'models': '.',
    'schemes': '.',
    'visuals': '.',
    'NewtonEulerCheck': '.analysis',
    'check_newton_euler': '.analysis',
    'plot_mode_shapes': '.analysis',
    'FORMULATIONS': '.formulations',
    'EquationsOfMotion': '.formulations',
    'formulate': '.formulations',
    'kane': '.formulations',
    'SavedFileError': '.io',
    'load': '.io',
    'AiryWave': '.modeling',
    'Hydrostatics': '.modeling',
    'IrregularSea': '.modeling',
    'MorisonCylinder': '.modeling',
    'jonswap_gamma': '.modeling',
    'jonswap_spectrum': '.modeling',
    'wave_number': '.modeling',
    'SURFACE_COORDINATES': '.modeling',
    'AddedMass': '.modeling',
    'AngularVelocity': '.modeling',
    'BallScrew': '.modeling',
    'BeamMember': '.modeling',
    'Contact': '.modeling',
    'Ellipsoid': '.modeling',
    'ExternalWrench': '.modeling',
    'Inerter': '.modeling',
    'JointActuator': '.modeling',
    'LinearActuator': '.modeling',
    'RateInertia': '.modeling',
    'FEMember': '.modeling',
    'FlexibleBody': '.modeling',
    'ImplicitSurface': '.modeling',
    'NodeMass': '.modeling',
    'OrthogonalVelocities': '.modeling',
    'Plane': '.modeling',
    'PointVelocity': '.modeling',
    'ReducedMember': '.modeling',
    'Sphere': '.modeling',
    'Surface': '.modeling',
    'VectorConstraint': '.modeling',
    'SpringDamper': '.modeling',
    'MatrixSpringDamper': '.modeling',
    'LinearMooring': '.modeling',
    'CatenaryLine': '.modeling',
    'CatenaryMooring': '.modeling',
    'RotorThrust': '.modeling',
    'ThrustCurve': '.modeling',
    'NREL5MW_THRUST': '.modeling',
    'kaimal_wind': '.modeling',
    'ActuatorForces': '.numerics',
    'ActuatorMap': '.numerics',
    'ActuatorParts': '.numerics',
    'InverseParts': '.numerics',
    'MassMatrices': '.numerics',
    'NumericModel': '.numerics',
    'OrthogonalSpeedsModel': '.numerics',
    'PowerBalance': '.numerics',
    'actuator_forces': '.numerics',
    'actuator_parts': '.numerics',
    'inverse_parts': '.numerics',
    'orthogonalize_speeds': '.numerics',
    'power_balance': '.numerics',
    'Impact': '.simulation',
    'ModeChange': '.simulation',
    'SimulationResult': '.simulation',
    'SweepInterrupted': '.simulation',
    'TrustWarning': '.simulation',
    'simulate': '.simulation',
    'sweep': '.simulation',
}


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib
    if module == ".":
        value = importlib.import_module(f".{name}", __name__)
    else:
        value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "RateInertia",
    "Inerter",
    "AddedMass",
    "JointActuator",
    "LinearActuator",
    "BallScrew",
    "ExternalWrench",
    "SpringDamper",
    "MatrixSpringDamper",
    "LinearMooring",
    "CatenaryLine",
    "CatenaryMooring",
    "RotorThrust",
    "ThrustCurve",
    "NREL5MW_THRUST",
    "kaimal_wind",
    "AiryWave",
    "IrregularSea",
    "jonswap_spectrum",
    "jonswap_gamma",
    "wave_number",
    "MorisonCylinder",
    "Hydrostatics",
    "ActuatorMap",
    "ActuatorForces",
    "actuator_forces",
    "InverseParts",
    "ActuatorParts",
    "PowerBalance",
    "inverse_parts",
    "actuator_parts",
    "power_balance",
    "kane",
    "formulate",
    "FORMULATIONS",
    "EquationsOfMotion",
    "load",
    "SavedFileError",
    "Contact",
    "Surface",
    "Plane",
    "Sphere",
    "Ellipsoid",
    "ImplicitSurface",
    "SURFACE_COORDINATES",
    "ModeChange",
    "VectorConstraint",
    "PointVelocity",
    "AngularVelocity",
    "OrthogonalVelocities",
    "FlexibleBody",
    "ReducedMember",
    "BeamMember",
    "FEMember",
    "NodeMass",
    "plot_mode_shapes",
    "Impact",
    "check_newton_euler",
    "NewtonEulerCheck",
    "NumericModel",
    "orthogonalize_speeds",
    "OrthogonalSpeedsModel",
    "MassMatrices",
    "simulate",
    "SimulationResult",
    "sweep",
    "SweepInterrupted",
    "models",
    "schemes",
    "visuals",
    "KanedynError",
    "ModelError",
    "KinematicsError",
    "ConstraintError",
    "MissingValueError",
    "OptionError",
    "SimulationInterrupted",
    "TrustWarning",
    "SingularConfigurationWarning",
]
