"""Modeling: what a user hands in besides SymPy's own objects, and its checks.

``_spec``                the validated model description (``ModelSpec``) from a
                         ``System`` or ``KanesMethod`` keywords
``_physical``            physical plausibility of masses and inertias
``_contacts``            contacts and the surfaces they touch
``_ground``              a ground plane for robots: collision primitives as contacts
``_vector_constraints``  constraints in vector form that identify their forces
``_actuators``           actuators, transmissions (ball screws), external wrenches
``_inertial_elements``   generalized-inertia elements: rate inertia, inerter, added mass
``_units``               units of coordinates and speeds read off the kinematics
``_piecewise``           specified inputs as data: piecewise polynomials of time (the
                         compiled module evaluates them), tabulated with a checked error
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

from .._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module (in this package) that defines it; imported on first use
#: (reading a saved model needs BodyValues, not SymPy's mechanics)
_LAZY = {
    'Actuator': '._actuators',
    'BallScrew': '._actuators',
    'ExternalWrench': '._actuators',
    'JointActuator': '._actuators',
    'LinearActuator': '._actuators',
    'drive_inputs': '._actuators',
    'AddedMass': '._inertial_elements',
    'Inerter': '._inertial_elements',
    'InertialElement': '._inertial_elements',
    'RateInertia': '._inertial_elements',
    'SURFACE_COORDINATES': '._contacts',
    'Contact': '._contacts',
    'Ellipsoid': '._contacts',
    'ImplicitSurface': '._contacts',
    'Plane': '._contacts',
    'Sphere': '._contacts',
    'Surface': '._contacts',
    'coefficient_value': '._contacts',
    'Ground': '._ground',
    'CollisionPrimitive': '._ground',
    'GROUND_SHAPES': '._ground',
    'ground_contacts': '._ground',
    'BodyValues': '._physical',
    'body_parameters': '._physical',
    'body_values': '._physical',
    'check_declared_bodies': '._physical',
    'inertia_violation': '._physical',
    'principal_moments': '._physical',
    'ModelSpec': '._spec',
    'description_symbols': '._spec',
    'parse_model': '._spec',
    'MatrixSpringDamper': '._springs',
    'SpringDamper': '._springs',
    'rotation_vector': '._springs',
    'ConeLimit': '._limits',
    'cone_contact': '._limits',
    'cone_surface': '._limits',
    'penalty_damping_for_restitution': '._limits',
    'tilt_angle': '._limits',
    'PiecewisePolynomial': '._piecewise',
    'tabulate': '._piecewise',
    'constraint_units': '._units',
    'speed_unit': '._units',
    'state_units': '._units',
    'NREL5MW_THRUST': '.offshore',
    'AiryWave': '.offshore',
    'CatenaryLine': '.offshore',
    'CatenaryMooring': '.offshore',
    'Hydrostatics': '.offshore',
    'IrregularSea': '.offshore',
    'LinearMooring': '.offshore',
    'MorisonCylinder': '.offshore',
    'RotorThrust': '.offshore',
    'PerformanceSurface': '.offshore',
    'RotorAerodynamics': '.offshore',
    'Drivetrain': '.offshore',
    'BaselineController': '.offshore',
    'AirfoilPolar': '.offshore',
    'BladeTable': '.offshore',
    'read_airfoil_polar': '.offshore',
    'read_blade_table': '.offshore',
    'OpenFASTInput': '.offshore',
    'OpenFASTTable': '.offshore',
    'OpenFASTEntry': '.offshore',
    'read_openfast_input': '.offshore',
    'BladeElementMomentum': '.offshore',
    'AnnulusSolution': '.offshore',
    'BladeElementRotor': '.offshore',
    'FlexibleBladeElementRotor': '.offshore',
    'ThrustCurve': '.offshore',
    'jonswap_gamma': '.offshore',
    'jonswap_spectrum': '.offshore',
    'kaimal_wind': '.offshore',
    'wave_number': '.offshore',
    'BeamMember': '.flexible',
    'FEMember': '.flexible',
    'FlexibleBody': '.flexible',
    'InertiaInvariants': '.flexible',
    'NodeMass': '.flexible',
    'ReducedMember': '.flexible',
    'CrashPulse': '.vehicle',
    'HalfSinePulse': '.vehicle',
    'HaversinePulse': '.vehicle',
    'TrapezoidPulse': '.vehicle',
    'VehicleMotion': '.vehicle',
    'cfc_filter': '.vehicle',
    'example_pulse': '.vehicle',
    'read_iso_mme': '.vehicle',
    'read_nhtsa_csv': '.vehicle',
    'write_iso_mme': '.vehicle',
    'write_nhtsa_csv': '.vehicle',
    'pulse_from_delta_v': '.vehicle',
    'read_pulse_csv': '.vehicle',
    'AngularVelocity': '._vector_constraints',
    'OrthogonalVelocities': '._vector_constraints',
    'PointVelocity': '._vector_constraints',
    'VectorConstraint': '._vector_constraints',
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__)
