"""Analysis: checks, comparisons and plots of what the layers below computed.

``_newton_euler``  body-by-body Newton-Euler residuals with identified forces
``_compare``       formulations side by side; work-precision
``_plotting``      figures of results (Matplotlib, imported lazily)
``_flexible_plots`` mode shapes of reduced members; deformed flexible bodies
``_studies``       the study registry (``kd.run_study``, ``kanedyn study``)
``_oc3_studies``   studies of the oc3-spar model
``_bicycle_plot``  the Whipple bicycle's eigenvalues with its modes named
"""

from ._bicycle_plot import PUBLISHED_STABLE_SPEEDS, bicycle_modes, plot_bicycle_eigenvalues
from ._compare import (NONHOLONOMIC_EXAMPLES, FormulationComparison, WorkPrecision,
                       compare_formulations, work_precision)
from ._flexible_plots import (deformed_nodes, member_arc_length, natural_modes,
                              plot_deflection, plot_mode_shapes)
from ._newton_euler import NewtonEulerCheck, check_newton_euler
from ._plotting import draw_nonnegative, log_scale_ok, plot_result, pyplot, unit_text
from ._studies import (STUDIES, Study, StudyOption, StudyResult, available_studies,
                       register_study, run_study)

__all__ = ["check_newton_euler", "NewtonEulerCheck", "compare_formulations",
           "work_precision", "FormulationComparison", "WorkPrecision",
           "NONHOLONOMIC_EXAMPLES", "plot_result", "pyplot", "log_scale_ok",
           "draw_nonnegative", "unit_text", "plot_mode_shapes",
           "plot_deflection", "natural_modes", "member_arc_length", "deformed_nodes",
           "bicycle_modes", "plot_bicycle_eigenvalues", "PUBLISHED_STABLE_SPEEDS",
           "STUDIES", "available_studies", "Study", "StudyOption", "StudyResult",
           "register_study", "run_study"]
