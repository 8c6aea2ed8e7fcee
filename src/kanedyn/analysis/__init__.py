"""Analysis: checks, comparisons and plots of what the layers below computed.

``_newton_euler``  body-by-body Newton-Euler residuals with identified forces
``_compare``       formulations side by side; work-precision
``_plotting``      figures of results (Matplotlib, imported lazily)
``_flexible_plots`` mode shapes of reduced members; deformed flexible bodies
``_studies``       the study registry (``kd.run_study``, ``kanedyn study``)
``_oc3_studies``   studies of the oc3-spar model
``_bicycle_plot``  the Whipple bicycle's eigenvalues with its modes named
``_damper_tuning`` frequency responses of linearized models; TMD / TMDI tuning
``_inverse_study`` actuator forces of parallel models along named trajectories
``_seatbelt_studies`` the seat-belt sensor's lock map and regulatory check
"""

from ._bicycle_plot import PUBLISHED_STABLE_SPEEDS, bicycle_modes, plot_bicycle_eigenvalues
from ._damper_tuning import (DamperTuning, FrequencyResponse, den_hartog,
                             frequency_response, h2_norm, model_frequency_response,
                             plot_frequency_responses, response_peaks, tune_damper)
from ._compare import (NONHOLONOMIC_EXAMPLES, FormulationComparison, WorkPrecision,
                       compare_formulations, work_precision)
from ._flexible_plots import (deformed_nodes, member_arc_length, natural_modes,
                              plot_deflection, plot_mode_shapes)
from ._inverse_study import TRAJECTORIES, InverseStudy, inverse_study, trajectory_offsets
from ._newton_euler import NewtonEulerCheck, check_newton_euler
from ._seatbelt_studies import (PULSE_SHAPES, RegulatoryCheck, SeatbeltLockMap,
                                regulatory_check, seatbelt_lock_map, seatbelt_study_model)
from ._plotting import draw_nonnegative, log_scale_ok, plot_result, pyplot, unit_text
from ._studies import (STUDIES, Study, StudyOption, StudyResult, available_studies,
                       register_study, run_study)

__all__ = ["check_newton_euler", "NewtonEulerCheck", "compare_formulations",
           "work_precision", "FormulationComparison", "WorkPrecision",
           "NONHOLONOMIC_EXAMPLES", "plot_result", "pyplot", "log_scale_ok",
           "draw_nonnegative", "unit_text", "plot_mode_shapes",
           "plot_deflection", "natural_modes", "member_arc_length", "deformed_nodes",
           "bicycle_modes", "plot_bicycle_eigenvalues", "PUBLISHED_STABLE_SPEEDS",
           "den_hartog", "frequency_response", "model_frequency_response",
           "FrequencyResponse", "response_peaks", "h2_norm", "tune_damper", "DamperTuning",
           "plot_frequency_responses", "inverse_study", "InverseStudy", "TRAJECTORIES",
           "trajectory_offsets",
           "seatbelt_lock_map", "SeatbeltLockMap", "regulatory_check", "RegulatoryCheck",
           "seatbelt_study_model", "PULSE_SHAPES",
           "STUDIES", "available_studies", "Study", "StudyOption", "StudyResult",
           "register_study", "run_study"]
