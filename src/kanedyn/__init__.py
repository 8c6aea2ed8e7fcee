"""kanedyn: multibody dynamics by Kane's method.

Public API (see the README and ``docs/``)::

    import kanedyn as kd
    eom = kd.kane(system)                     # or KanesMethod-style keywords
    model = eom.numeric(constants={...})
    res = kd.simulate(model, (0, 10), y0)
"""

from .modeling._contacts import (SURFACE_COORDINATES, Contact, Ellipsoid, ImplicitSurface, Plane,
                       Sphere, Surface)
from .simulation._hybrid import ModeChange
from .simulation._impact import Impact
from .formulations._eom import EquationsOfMotion
from ._errors import (ConstraintError, KanedynError, KinematicsError,
                      MissingValueError, ModelError, OptionError, SimulationInterrupted,
                      SingularConfigurationWarning)
from .formulations._registry import FORMULATIONS, formulate, kane
from .analysis._newton_euler import NewtonEulerCheck, check_newton_euler
from .numerics._model import NumericModel
from .numerics._orthogonal_speeds import MassMatrices, OrthogonalSpeedsModel, orthogonalize_speeds
from .simulation._results import SimulationResult
from .simulation._simulate import TrustWarning, simulate
from .modeling._vector_constraints import (AngularVelocity, OrthogonalVelocities, PointVelocity,
                                  VectorConstraint)
from . import models, schemes

__version__ = "0.1.0"

__all__ = [
    "kane",
    "formulate",
    "FORMULATIONS",
    "EquationsOfMotion",
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
    "Impact",
    "check_newton_euler",
    "NewtonEulerCheck",
    "NumericModel",
    "orthogonalize_speeds",
    "OrthogonalSpeedsModel",
    "MassMatrices",
    "simulate",
    "SimulationResult",
    "models",
    "schemes",
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
