"""kanedyn: multibody dynamics by Kane's method.

Public API (see the README and ``docs/``)::

    import kanedyn as kd
    eom = kd.kane(system)                     # or KanesMethod-style keywords
    model = eom.numeric(constants={...})
    res = kd.simulate(model, (0, 10), y0)

``kd.`` holds the general library: formulations, the bodies, elements,
contacts and constraints every model uses, numerics, simulation, general
analysis, saved files and errors.  Modules hold the rest::

    kd.models     built-in models (``kd.models.build("pendulum")``, URDF)
    kd.schemes    constraint schemes
    kd.visuals    shapes drawn in the 3D viewer
    kd.offshore   floating structures: waves, hydrodynamics, moorings, rotor
    kd.vehicle    vehicle motion: crash pulses, records, CFC filters
    kd.flexible   flexible members: finite elements, reduction, mode shapes
    kd.studies    ready-made studies of the built-in models and their drivers
"""

from . import _fork  # noqa: F401  its fork hooks registered first (see its docstring)
from ._lazy import NAMESPACES as _NAMESPACES
from ._lazy import lazy_attributes as _lazy_attributes
from ._errors import (ConstraintError, KanedynError, KinematicsError, MissingValueError,
                      ModelError, OptionError, OutputFileError, SimulationInterrupted,
                      SingularConfigurationWarning)
from ._version import __version__ as __version__

# Everything else is imported when first used (``kd.simulate``, ``from kanedyn
# import kane``): ``import kanedyn`` stays fast and imports neither SciPy nor
# Matplotlib.  public name -> the module that defines it
_LAZY = {
    'models': '.',
    'schemes': '.',
    'visuals': '.',
    'offshore': '.',
    'vehicle': '.',
    'flexible': '.',
    'studies': '.',
    'NewtonEulerCheck': '.analysis',
    'check_newton_euler': '.analysis',
    'FORMULATIONS': '.formulations',
    'EquationsOfMotion': '.formulations',
    'formulate': '.formulations',
    'kane': '.formulations',
    'SavedFileError': '.io',
    'load': '.io',
    'SURFACE_COORDINATES': '.modeling',
    'AddedMass': '.modeling',
    'AngularVelocity': '.modeling',
    'BallScrew': '.modeling',
    'Contact': '.modeling',
    'Ellipsoid': '.modeling',
    'ExternalWrench': '.modeling',
    'Inerter': '.modeling',
    'JointActuator': '.modeling',
    'LinearActuator': '.modeling',
    'RateInertia': '.modeling',
    'FlexibleBody': '.modeling',
    'ImplicitSurface': '.modeling',
    'OrthogonalVelocities': '.modeling',
    'Plane': '.modeling',
    'PointVelocity': '.modeling',
    'Sphere': '.modeling',
    'Surface': '.modeling',
    'VectorConstraint': '.modeling',
    'SpringDamper': '.modeling',
    'MatrixSpringDamper': '.modeling',
    'ActuatorForces': '.numerics',
    'ActuatorMap': '.numerics',
    'ActuatorParts': '.numerics',
    'InverseParts': '.numerics',
    'MassMatrices': '.numerics',
    'Equilibrium': '.numerics',
    'Jacobians': '.numerics',
    'equilibrium': '.numerics',
    'NumericModel': '.numerics',
    'OrthogonalSpeedsModel': '.numerics',
    'ConstrainedOrthogonalSpeedsModel': '.numerics',
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
    'Sensitivity': '.simulation',
    'sensitivity': '.simulation',
    'simulate': '.simulation',
    'sweep': '.simulation',
    'OptimalControlProblem': '.optimization',
    'OptimalControlResult': '.optimization',
    'Resimulation': '.optimization',
    'identify': '.optimization',
    'IdentificationResult': '.optimization',
    'MeasuredRecord': '.optimization',
    'VehicleMotion': '.modeling',
    'ConeLimit': '.modeling',
    'cone_contact': '.modeling',
    'cone_surface': '.modeling',
    'penalty_damping_for_restitution': '.modeling',
    'den_hartog': '.analysis',
    'frequency_response': '.analysis',
    'model_frequency_response': '.analysis',
    'FrequencyResponse': '.analysis',
    'tune_damper': '.analysis',
    'DamperTuning': '.analysis',
    'plot_frequency_responses': '.analysis',
}




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
    "Impact",
    "check_newton_euler",
    "NewtonEulerCheck",
    "NumericModel",
    "orthogonalize_speeds",
    "OrthogonalSpeedsModel",
    "ConstrainedOrthogonalSpeedsModel",
    "MassMatrices",
    "Jacobians",
    "equilibrium",
    "Equilibrium",
    "simulate",
    "SimulationResult",
    "sensitivity",
    "Sensitivity",
    "OptimalControlProblem",
    "OptimalControlResult",
    "Resimulation",
    "identify",
    "IdentificationResult",
    "MeasuredRecord",
    "sweep",
    "SweepInterrupted",
    "models",
    "schemes",
    "visuals",
    "offshore",
    "vehicle",
    "flexible",
    "studies",
    "KanedynError",
    "ModelError",
    "KinematicsError",
    "ConstraintError",
    "MissingValueError",
    "OptionError",
    "OutputFileError",
    "SimulationInterrupted",
    "TrustWarning",
    "SingularConfigurationWarning",
    "VehicleMotion",
    "ConeLimit",
    "cone_contact",
    "cone_surface",
    "penalty_damping_for_restitution",
    "den_hartog",
    "frequency_response",
    "model_frequency_response",
    "FrequencyResponse",
    "tune_damper",
    "DamperTuning",
    "plot_frequency_responses",
]

# Names that were at ``kd.`` and moved to a module: old name -> its module.  The
# old spelling gives the same object and warns once (``_lazy.py``).  A record of
# the past, not a list to extend: new names go in their module only.
_MOVED = {
    **dict.fromkeys(["AiryWave", "IrregularSea", "jonswap_spectrum", "jonswap_gamma",
                     "wave_number", "MorisonCylinder", "Hydrostatics", "LinearMooring",
                     "CatenaryLine", "CatenaryMooring", "RotorThrust", "ThrustCurve",
                     "NREL5MW_THRUST", "kaimal_wind"], "offshore"),
    **dict.fromkeys(["CrashPulse", "HalfSinePulse", "HaversinePulse", "TrapezoidPulse",
                     "pulse_from_delta_v", "read_pulse_csv", "cfc_filter",
                     "example_pulse"], "vehicle"),
    **dict.fromkeys(["ReducedMember", "BeamMember", "FEMember", "NodeMass",
                     "plot_mode_shapes"], "flexible"),
    **dict.fromkeys(["run_study", "StudyResult", "STUDIES", "seatbelt_lock_map",
                     "SeatbeltLockMap", "regulatory_check", "RegulatoryCheck",
                     "seatbelt_study_model", "inverse_study", "InverseStudy"], "studies"),
}

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__, _MOVED,
                                        neighbours=_NAMESPACES)
