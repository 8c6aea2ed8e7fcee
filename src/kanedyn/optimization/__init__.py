"""Optimization: optimal control by direct collocation on the exact derivatives.

``_problem``       ``OptimalControlProblem``: the objective, bounds and constraints,
                   checked when stated; ``solve``
``_terms``         the user's SymPy expressions in the model's symbols, compiled
                   with their gradients
``_transcription`` the decision vector and the dynamics' defects of each
                   one-step collocation method (backward Euler, trapezoid,
                   midpoint)
``_interval``      collocation on points inside the intervals: Hermite-Simpson,
                   Legendre-Gauss-Radau of any degree
``_nlp``           the nonlinear program: bounds, objective, constraints and
                   their sparse Jacobian from ``model.jacobians``
``_hessian``       the exact Hessian of the NLP's Lagrangian (``hessian="exact"``)
``_solvers``       the NLP solvers behind one interface (IPOPT through cyipopt,
                   kanedyn's interior-point method)
``interior_point`` ``InteriorPoint``: kanedyn's own primal-dual interior-point NLP
                   solver (IPOPT's algorithm) and its KKT factorizations
                   (``DenseKKT``, ``SparseKKT``)
``_guess``         initial guesses: a straight line, a simulation, a solution
``_result``        ``OptimalControlResult``, the inputs as collocated, and the
                   check of the optimal inputs by simulation
``_multiphase``    ``MultiphaseProblem``: phases in sequence solved as one NLP
``_linkage``       ``Linkage``: how phases join, and the junctions' rows
``_multiphase_result`` ``MultiphaseResult``: each phase's trajectory, and joined
``_multiphase_hessian`` the exact Hessian of a multiphase NLP's Lagrangian
``_records``       ``MeasuredRecord``: measured channels from arrays or a CSV file
``_identify``      ``identify``: constants and initial states fitted to records
                   (single and multiple shooting on the sensitivities)
``_estimates``     the fit's solve and ``IdentificationResult``: estimates,
                   covariance, confidence intervals

Uses numerics' derivatives and simulation's ``simulate``; no layer below
imports it.
"""

from .._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module (in this package) that defines it; imported on first use
_LAZY = {
    "OptimalControlProblem": "._problem",
    "OptimalControlResult": "._result",
    "MultiphaseProblem": "._multiphase",
    "MultiphaseResult": "._multiphase_result",
    "Linkage": "._linkage",
    "Resimulation": "._result",
    "NLPSolution": "._solvers",
    "SOLVERS": "._solvers",
    "COLLOCATION_METHODS": "._transcription",
    "identify": "._identify",
    "IdentificationResult": "._estimates",
    "MeasuredRecord": "._records",
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__)
