"""Analysis: checks, comparisons and plots of what the layers below computed.

``_energy_balance`` the energy balance of a run, term by term
``_newton_euler``  body-by-body Newton-Euler residuals with identified forces
``_compare``       formulations side by side; work-precision
``_residual_figure`` each formulation's motion beside its Newton-Euler residual
``_plotting``      figures of results (Matplotlib, imported lazily)
``_flexible_plots`` mode shapes of reduced members; deformed flexible bodies
``_studies``       the study registry (``kd.studies.run_study``, ``kanedyn study``)
``_oc3_studies``   studies of the oc3-spar model
``_bicycle_plot``  the Whipple bicycle's eigenvalues with its modes named
``_damper_tuning`` frequency responses of linearized models; TMD / TMDI tuning
``_inverse_study`` actuator forces of parallel models along named trajectories
``_motor_torques`` motor torques of ball-screw actuators (efficiency, drive-train parts)
``_platform_wrench`` an external wrench on a platform, constant or a CSV table over time
``_csv_table``     the strict reader of numeric CSV tables over time (wrench, poses)
``_actuator_limits`` actuator limits checked along a path, the first violation named
``_pose_table``    a platform trajectory from a CSV file of poses, splined (C2)
``_seatbelt_studies`` the seat-belt sensor's lock map and regulatory check
``_seatbelt_plot`` the sensor's run in one figure (pulse, tilt, lock and release);
                   the models' own figures of a run (``RUN_FIGURES``)
``_optimal_problems`` named optimal-control problems on built-in models
                   (``kanedyn optimize``, also studies), the pendulum swing-up
``_flexible_robot_oc`` the elastic robot's optimal rest-to-rest rotation
                   against its torque pulse
``_bicycle_lane_change`` the Whipple bicycle's lane change by steer torque
``_shuttle_arm_oc`` the Shuttle arm's payload manoeuvre of least effort with
                   joint-angle and torque limits, replayed open loop and PD-tracked
``_shuttle_arm_flexible_oc`` the same for the flexible booms: torques from and
                   to zero, checked on the 28-state model against the rigid optimum's
``_out_parallel_oc`` the out-parallel manipulator's platform path of least peak
                   carriage force (epigraph), checked by inverse dynamics
``_campbell``      Campbell diagrams: steady motions over rotor speed, modes
                   followed by MAC
``_mbc``           the multiblade coordinate transformation of a state matrix
``_campbell_plot`` the Campbell diagram's figure with the rotor harmonics
"""

from .._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module (in this package) that defines it; imported on first use
#: (the command line lists its sub-commands without SciPy, SymPy or Matplotlib)
_LAZY = {
    'energy_balance': '._energy_balance',
    'EnergyBalance': '._energy_balance',
    'check_newton_euler': '._newton_euler',
    'NewtonEulerCheck': '._newton_euler',
    'compare_formulations': '._compare',
    'work_precision': '._compare',
    'FormulationComparison': '._compare',
    'WorkPrecision': '._compare',
    'NONHOLONOMIC_EXAMPLES': '._compare',
    'plot_newton_euler_residuals': '._residual_figure',
    'plot_result': '._plotting',
    'pyplot': '._plotting',
    'log_scale_ok': '._plotting',
    'draw_nonnegative': '._plotting',
    'unit_text': '._plotting',
    'plot_mode_shapes': '._flexible_plots',
    'plot_deflection': '._flexible_plots',
    'natural_modes': '._flexible_plots',
    'member_arc_length': '._flexible_plots',
    'deformed_nodes': '._flexible_plots',
    'bicycle_modes': '._bicycle_plot',
    'plot_bicycle_eigenvalues': '._bicycle_plot',
    'PUBLISHED_STABLE_SPEEDS': '._bicycle_plot',
    'den_hartog': '._damper_tuning',
    'frequency_response': '._damper_tuning',
    'model_frequency_response': '._damper_tuning',
    'FrequencyResponse': '._damper_tuning',
    'response_peaks': '._damper_tuning',
    'h2_norm': '._damper_tuning',
    'tune_damper': '._damper_tuning',
    'DamperTuning': '._damper_tuning',
    'plot_frequency_responses': '._damper_tuning',
    'inverse_study': '._inverse_study',
    'InverseStudy': '._inverse_study',
    'TRAJECTORIES': '._inverse_study',
    'trajectory_offsets': '._inverse_study',
    'motor_torques': '._motor_torques',
    'MotorTorques': '._motor_torques',
    'DRIVE_PARTS': '._motor_torques',
    'WrenchTable': '._platform_wrench',
    'read_wrench_csv': '._platform_wrench',
    'with_platform_wrench': '._platform_wrench',
    'WRENCH_COLUMNS': '._platform_wrench',
    'LIMIT_QUANTITIES': '._actuator_limits',
    'LimitViolation': '._actuator_limits',
    'LimitCheck': '._actuator_limits',
    'check_actuator_limits': '._actuator_limits',
    'PoseTable': '._pose_table',
    'read_pose_csv': '._pose_table',
    'POSE_HEADERS': '._pose_table',
    'quaternion_to_xyz': '._pose_table',
    'seatbelt_run_figure': '._seatbelt_plot',
    'run_figure': '._seatbelt_plot',
    'RUN_FIGURES': '._seatbelt_plot',
    'seatbelt_lock_map': '._seatbelt_studies',
    'SeatbeltLockMap': '._seatbelt_studies',
    'regulatory_check': '._seatbelt_studies',
    'RegulatoryCheck': '._seatbelt_studies',
    'seatbelt_study_model': '._seatbelt_studies',
    'PULSE_SHAPES': '._seatbelt_studies',
    'pendulum_swing_up': '._optimal_problems',
    'SwingUp': '._optimal_problems',
    'InputPeaks': '._optimal_problems',
    'OptimalProblem': '._optimal_problems',
    'OPTIMAL_PROBLEMS': '._optimal_problems',
    'available_problems': '._optimal_problems',
    'optimal_problem': '._optimal_problems',
    'flexible_robot_rest_to_rest': '._flexible_robot_oc',
    'RestToRest': '._flexible_robot_oc',
    'bicycle_lane_change': '._bicycle_lane_change',
    'LaneChange': '._bicycle_lane_change',
    'shuttle_arm_minimum_energy': '._shuttle_arm_oc',
    'ArmManoeuvre': '._shuttle_arm_oc',
    'FlexibleArmManoeuvre': '._shuttle_arm_flexible_oc',
    'out_parallel_least_peak_force': '._out_parallel_oc',
    'PeakForcePath': '._out_parallel_oc',
    'campbell': '._campbell',
    'CampbellDiagram': '._campbell',
    'plot_campbell': '._campbell_plot',
    'multiblade_basis': '._mbc',
    'to_multiblade': '._mbc',
    'STUDIES': '._studies',
    'available_studies': '._studies',
    'Study': '._studies',
    'StudyOption': '._studies',
    'StudyResult': '._studies',
    'register_study': '._studies',
    'run_study': '._studies',
    'study_option_value': '._studies',
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__)
