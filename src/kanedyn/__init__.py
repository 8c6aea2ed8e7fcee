"""kanedyn: multibody dynamics by Kane's method.

Public API (see the README and ``docs/``)::

    import kanedyn as kd
    eom = kd.kane(system)                     # or KanesMethod-style keywords
    model = eom.numeric(constants={...})
    res = kd.simulate(model, (0, 10), y0)
"""

from . import models, schemes, visuals
from ._errors import (ConstraintError, KanedynError, KinematicsError, MissingValueError,
                      ModelError, OptionError, SimulationInterrupted,
                      SingularConfigurationWarning)
from ._version import __version__ as __version__
from .analysis import (ForwardCheck, InverseStudy, NewtonEulerCheck, check_newton_euler,
                       inverse_study, plot_mode_shapes)
from .formulations import FORMULATIONS, EquationsOfMotion, formulate, kane
from .io import SavedFileError, load
from .modeling import (SURFACE_COORDINATES, AngularVelocity, BallScrew, BeamMember, Contact,
                       Ellipsoid, ExternalWrench, JointActuator, LinearActuator,
                       FEMember, FlexibleBody, ImplicitSurface, NodeMass, OrthogonalVelocities,
                       Plane, PointVelocity, ReducedMember, Sphere, Surface, VectorConstraint)
from .numerics import (ActuatorForces, ActuatorMap, ActuatorParts, InverseParts,
                       MassMatrices, NumericModel, OrthogonalSpeedsModel, PowerBalance,
                       actuator_forces, actuator_parts, inverse_parts, orthogonalize_speeds,
                       power_balance)
from .simulation import (Impact, ModeChange, SimulationResult, SweepInterrupted, TrustWarning,
                         simulate, sweep)

__all__ = [
    "JointActuator",
    "LinearActuator",
    "BallScrew",
    "ExternalWrench",
    "ActuatorMap",
    "ActuatorForces",
    "actuator_forces",
    "InverseParts",
    "ActuatorParts",
    "PowerBalance",
    "inverse_parts",
    "actuator_parts",
    "power_balance",
    "inverse_study",
    "InverseStudy",
    "ForwardCheck",
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
