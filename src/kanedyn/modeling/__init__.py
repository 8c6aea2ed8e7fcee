"""Modeling: what a user hands in besides SymPy's own objects, and its checks.

``_spec``                the validated model description (``ModelSpec``) from a
                         ``System`` or ``KanesMethod`` keywords
``_physical``            physical plausibility of masses and inertias
``_contacts``            contacts and the surfaces they touch
``_vector_constraints``  constraints in vector form that identify their forces
``_actuators``           actuators, transmissions (ball screws), external wrenches
``_inertial_elements``   generalized-inertia elements: rate inertia, inerter, added mass
``_units``               units of coordinates and speeds read off the kinematics
``flexible``             flexible members: beam elements, station tables, component
                         mode synthesis, the reduced member, flexible bodies
``_springs``             linear spring-dampers between points and in 6 dof
``_limits``              constraint torque functions: a tilt limited by a cone (penalty
                         law or unilateral contact)
``offshore``             floating structures: waves, Morison loads, hydrostatics,
                         mooring lines and systems, rotor thrust, turbulent wind
``visuals``              shapes that draw bodies in the 3D viewer
``vehicle``              prescribed vehicle motion: crash pulses, CSV records, CFC
                         filters, the moving frame (``VehicleMotion``)
"""

from ._actuators import (Actuator, BallScrew, ExternalWrench, JointActuator,
                         LinearActuator)
from ._inertial_elements import AddedMass, Inerter, InertialElement, RateInertia
from ._contacts import (SURFACE_COORDINATES, Contact, Ellipsoid, ImplicitSurface, Plane,
                        Sphere, Surface, coefficient_value)
from ._physical import BodyValues, body_parameters, body_values, check_declared_bodies
from ._spec import ModelSpec, description_symbols, parse_model
from ._springs import MatrixSpringDamper, SpringDamper, rotation_vector
from ._limits import (ConeLimit, cone_contact, cone_surface, penalty_damping_for_restitution,
                      tilt_angle)
from ._units import constraint_units, speed_unit, state_units
from .offshore import (NREL5MW_THRUST, AiryWave, CatenaryLine, CatenaryMooring, Hydrostatics,
                       IrregularSea, LinearMooring, MorisonCylinder, RotorThrust, ThrustCurve,
                       jonswap_gamma, jonswap_spectrum, kaimal_wind, wave_number)
from .flexible import (BeamMember, FEMember, FlexibleBody, InertiaInvariants, NodeMass,
                       ReducedMember)
from .vehicle import (CrashPulse, HalfSinePulse, HaversinePulse, TrapezoidPulse,
                      VehicleMotion, cfc_filter, example_pulse, pulse_from_delta_v,
                      read_pulse_csv)
from ._vector_constraints import (AngularVelocity, OrthogonalVelocities, PointVelocity,
                                  VectorConstraint)

__all__ = ["ModelSpec", "parse_model", "description_symbols", "Contact", "Surface", "Plane",
           "Sphere", "Ellipsoid", "ImplicitSurface", "SURFACE_COORDINATES",
           "coefficient_value", "VectorConstraint", "PointVelocity", "AngularVelocity",
           "OrthogonalVelocities", "BodyValues", "body_parameters", "body_values",
           "check_declared_bodies", "state_units", "constraint_units", "speed_unit",
           "ReducedMember", "BeamMember", "FEMember", "NodeMass",
           "FlexibleBody", "InertiaInvariants", "Actuator", "JointActuator",
           "LinearActuator", "BallScrew", "ExternalWrench", "InertialElement", "RateInertia",
           "Inerter", "AddedMass",
           "SpringDamper", "MatrixSpringDamper", "rotation_vector", "LinearMooring", "CatenaryLine",
           "CatenaryMooring", "RotorThrust", "ThrustCurve", "NREL5MW_THRUST", "kaimal_wind",
           "AiryWave", "IrregularSea",
           "jonswap_spectrum", "jonswap_gamma", "wave_number", "MorisonCylinder",
           "Hydrostatics", "VehicleMotion", "CrashPulse",
           "HalfSinePulse", "HaversinePulse", "TrapezoidPulse", "pulse_from_delta_v",
           "read_pulse_csv", "cfc_filter", "example_pulse", "ConeLimit", "cone_contact",
           "cone_surface", "penalty_damping_for_restitution", "tilt_angle"]
