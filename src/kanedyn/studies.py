"""Studies: ready-made analyses of the built-in models and their drivers (``kd.studies``).

``run_study(name)`` runs a registered study as ``kanedyn study NAME`` does
(``oc3-decay``, ``oc3-rao``, ``oc3-sea``, ``oc3-tmdi``: ``docs/offshore.md``;
``seatbelt-map``, ``seatbelt-regulatory``: ``docs/seatbelt.md``); the functions
behind some of them are public too::

    run_study             run a registered study, write its tables and figures
    StudyResult           what a study produced: tables, figures, CSV files, a summary
    STUDIES               name -> study, with its options
    seatbelt_lock_map     the seat-belt sensor's lock time over a grid of pulses
    SeatbeltLockMap       its table over severity, direction and roll rate
    regulatory_check      the sensor against the FMVSS 209 sensitivity requirements
    RegulatoryCheck       its pass/fail verdicts
    seatbelt_study_model  the compiled sensor model both of them run
    inverse_study         actuator forces of a parallel model along a named trajectory
                          (``kanedyn inverse``; ``docs/inverse_dynamics.md``)
    InverseStudy          its forces taken apart, with the power balance
    flexible_robot_rest_to_rest  the elastic robot's optimal rest-to-rest rotation
                          against its torque pulse, both simulated
                          (``docs/optimal_control.md``)
    RestToRest            its residual vibration, effort, time
    bicycle_lane_change   the Whipple bicycle's lane change by steer torque
    LaneChange            the optimum and its simulation
    shuttle_arm_minimum_energy  the Shuttle arm's payload manoeuvre of least effort
                          within joint-angle and torque limits, against its quintic
    ArmManoeuvre          the optimum, its open-loop and PD-tracked replays
    FlexibleArmManoeuvre  the same with booms="flexible": torques from and to zero,
                          both optima's torques simulated on the flexible booms
    out_parallel_least_peak_force  the out-parallel manipulator's path of least peak
                          carriage force, against its quintic
    PeakForcePath         the optimum, the inverse dynamics of its path, its replay
    pendulum_swing_up     the pendulum's swing-up (opty's gallery problem)
    SwingUp               the optimum and its simulation
    InputPeaks            a study's inputs at the collocation points and as replayed,
                          against their limits (``.input_peaks`` of each result above)
    OPTIMAL_PROBLEMS      model -> named optimal-control problems (``kanedyn optimize``;
                          also studies named MODEL-PROBLEM)
    OptimalProblem        one of them, with its defaults and options

These names were at ``kd.`` before: that spelling still gives the same object,
with a DeprecationWarning naming the new one.
"""

from ._lazy import NAMESPACES as _NAMESPACES
from ._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module that defines it (relative to ``kanedyn``); imported on first use
_LAZY = {
    "run_study": ".analysis",
    "StudyResult": ".analysis",
    "STUDIES": ".analysis",
    "seatbelt_lock_map": ".analysis",
    "SeatbeltLockMap": ".analysis",
    "regulatory_check": ".analysis",
    "RegulatoryCheck": ".analysis",
    "seatbelt_study_model": ".analysis",
    "inverse_study": ".analysis",
    "InverseStudy": ".analysis",
    "flexible_robot_rest_to_rest": ".analysis",
    "RestToRest": ".analysis",
    "bicycle_lane_change": ".analysis",
    "LaneChange": ".analysis",
    "shuttle_arm_minimum_energy": ".analysis",
    "ArmManoeuvre": ".analysis",
    "FlexibleArmManoeuvre": ".analysis",
    "out_parallel_least_peak_force": ".analysis",
    "PeakForcePath": ".analysis",
    "pendulum_swing_up": ".analysis",
    "SwingUp": ".analysis",
    "InputPeaks": ".analysis",
    "OPTIMAL_PROBLEMS": ".analysis",
    "OptimalProblem": ".analysis",
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__,
                                        neighbours=_NAMESPACES)
