"""The interior-point solver's return codes: IPOPT's numbers, so that a
status means the same whichever solver ran, with this solver's own words."""

from __future__ import annotations

__all__ = ["STATUS", "ADVICE"]

#: code -> what it means for the user (the codes this solver returns)
STATUS = {
    0: "solved",
    1: "solved to an acceptable level (options acceptable_tol, acceptable_iter)",
    2: "infeasible: converged to a point of local infeasibility (the restoration phase "
       "found a local minimizer of the constraints' violation that does not satisfy "
       "them; check the constraints and bounds, or give a better initial guess)",
    4: "the iterates diverged: the objective may be unbounded below (bound the "
       "variables it decreases along)",
    5: "stopped on request",
    -1: "the maximum number of iterations was reached (options={'max_iter': ...})",
    -2: "the restoration phase failed: its line search found no acceptable step, or "
        "it converged to a feasible point the filter refuses",
    -3: "error in the step computation: no regularization gave the step's linear "
        "system the right inertia",
    -4: "the maximum CPU time was reached (options={'max_cpu_time': ...})",
    -10: "not enough degrees of freedom (more equality constraints than free variables)",
    -13: "an invalid number (nan or inf) came from the model or the objective",
}

#: code -> what the user may try, given with the status unless a diagnosis of
#: the result says more (an objective unbounded below is not helped by another
#: solver or guess)
ADVICE = {
    -2: "try another initial guess, or solver='ipopt'",
}
