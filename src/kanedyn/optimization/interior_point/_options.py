"""The interior-point solver's options: IPOPT's names where IPOPT has the
option, their defaults IPOPT's (Waechter & Biegler 2006; IPOPT's option
list), checked before the solve."""

from __future__ import annotations

import math
import numbers
from types import SimpleNamespace

from ..._errors import OptionError

__all__ = ["DEFAULTS", "CHOICES", "RANGES", "settings"]

#: option -> default
DEFAULTS = {
    # termination
    "tol": 1e-8,                         # scaled optimality error
    "max_iter": 3000,
    "max_cpu_time": 1e20,                # s of process time
    "dual_inf_tol": 1.0,                 # unscaled, for "solved"
    "constr_viol_tol": 1e-4,
    "compl_inf_tol": 1e-4,
    "acceptable_tol": 1e-6,
    "acceptable_iter": 15,               # consecutive acceptable iterates; 0: off
    "acceptable_dual_inf_tol": 1e10,
    "acceptable_constr_viol_tol": 1e-2,
    "acceptable_compl_inf_tol": 1e-2,
    "diverging_iterates_tol": 1e20,
    "print_level": 0,                    # 0 silent, >= 1 a line per iteration
    # barrier parameter (monotone, Fiacco-McCormick)
    "mu_init": 0.1,
    "mu_min": 1e-11,
    "barrier_tol_factor": 10.0,          # kappa_epsilon
    "mu_linear_decrease_factor": 0.2,    # kappa_mu
    "mu_superlinear_decrease_power": 1.5,  # theta_mu
    "tau_min": 0.99,
    "kappa_d": 1e-5,                     # damping of single-bounded variables
    # starting point
    "bound_push": 1e-2,
    "bound_frac": 1e-2,
    "slack_bound_push": 1e-2,
    "slack_bound_frac": 1e-2,
    "bound_relax_factor": 1e-8,
    "bound_mult_init_val": 1.0,
    "constr_mult_init_max": 1e3,         # least-squares multipliers above: zero
    "warm_start_bound_push": 1e-3,
    "warm_start_bound_frac": 1e-3,
    "warm_start_mult_bound_push": 1e-3,
    # scaling
    "nlp_scaling_method": "gradient-based",
    "nlp_scaling_max_gradient": 100.0,
    "nlp_scaling_min_value": 1e-8,
    "obj_scaling_factor": 1.0,
    # line search (filter)
    "max_soc": 4,
    "kappa_soc": 0.99,
    "alpha_min_frac": 0.05,
    # inertia correction
    "first_hessian_perturbation": 1e-4,
    "min_hessian_perturbation": 1e-20,
    "max_hessian_perturbation": 1e20,
    "perturb_inc_fact_first": 100.0,
    "perturb_inc_fact": 8.0,
    "perturb_dec_fact": 1.0 / 3.0,
    "jacobian_regularization_value": 1e-8,
    "jacobian_regularization_exponent": 0.25,
    # linear algebra
    "linear_solver": "auto",  # "envelope", "sparse", "dense"; auto: envelope if it builds
    "max_refinement_steps": 10,
    "residual_ratio_max": 1e-10,
    # the Hessian: None follows solve(hessian=...) (exact when the NLP has
    # it); "limited-memory" BFGS (._quasi_newton), IPOPT's defaults
    "hessian_approximation": None,
    "limited_memory_max_history": 6,
    "limited_memory_init_val": 1.0,
    "limited_memory_init_val_min": 1e-8,
    "limited_memory_init_val_max": 1e8,
    "limited_memory_max_skipping": 2,
    # Powell's damping (._quasi_newton); "bfgs": IPOPT's update, skipping pairs
    "limited_memory_update_type": "damped-bfgs",
    # accepted for IPOPT compatibility, one value only
    "mu_strategy": "monotone",
    # memory: NumPy's arrays of 4 MiB or more each in a mapping of their own
    # while the solver runs ("mapped", ._mapped), or NumPy's handler's ("numpy")
    "large_arrays": "mapped",
}

#: options that take text -> the values accepted
CHOICES = {
    "nlp_scaling_method": ("gradient-based", "none"),
    "linear_solver": ("auto", "sparse", "envelope", "dense"),
    "hessian_approximation": ("exact", "limited-memory"),
    "limited_memory_update_type": ("bfgs", "damped-bfgs"),
    "mu_strategy": ("monotone",),
    "large_arrays": ("mapped", "numpy"),
}

_INTEGERS = {"max_iter", "acceptable_iter", "print_level", "max_soc", "max_refinement_steps",
             "limited_memory_max_history", "limited_memory_max_skipping"}


#: option -> (low, high, whether ``high`` itself is allowed): IPOPT's ranges,
#: ``low`` excluded, where a value outside would stall or break the iterations
#: (a perturbation factor of 0 would never end the inertia correction's loop)
RANGES = {
    "mu_init": (0.0, math.inf, False),
    "bound_push": (0.0, math.inf, False),
    "slack_bound_push": (0.0, math.inf, False),
    "bound_frac": (0.0, 0.5, True),
    "slack_bound_frac": (0.0, 0.5, True),
    "tau_min": (0.0, 1.0, False),
    "kappa_soc": (0.0, math.inf, False),
    "mu_linear_decrease_factor": (0.0, 1.0, False),
    "mu_superlinear_decrease_power": (1.0, 2.0, False),
    "first_hessian_perturbation": (0.0, math.inf, False),
    "perturb_dec_fact": (0.0, 1.0, False),
    "perturb_inc_fact": (1.0, math.inf, False),
    "perturb_inc_fact_first": (1.0, math.inf, False),
    "limited_memory_init_val": (0.0, math.inf, False),
    "limited_memory_init_val_min": (0.0, math.inf, False),
    "limited_memory_init_val_max": (0.0, math.inf, False),
}


def _in_range(key, value):
    """Refuse ``value`` of ``key`` outside :data:`RANGES`, naming both."""
    low, high, high_allowed = RANGES[key]
    if not (value > low and (value <= high if high_allowed else value < high)):
        raise OptionError(f"interior-point option {key}={value!r}: give a number in "
                          f"({low:g}, {high:g}{']' if high_allowed else ')'}")


def similar_option(name, known):
    """``"; did you mean 'max_iter'?"`` for an option ``name`` not among the
    names ``known`` when some are spelled like it (difflib), else ``""``."""
    import difflib
    close = difflib.get_close_matches(str(name), sorted(known), n=2, cutoff=0.6)
    return f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""


def settings(options):
    """The options over :data:`DEFAULTS`, checked: a namespace of values.

    Raises
    ------
    OptionError
        (a ``ValueError``) Naming an unknown option (and listing the known ones), or a value of
        the wrong kind.
    """
    options = dict(options or {})
    unknown = sorted(set(options) - set(DEFAULTS))
    if unknown:
        hints = "".join(similar_option(name, DEFAULTS) for name in unknown)
        raise OptionError(f"unknown interior-point option(s) {', '.join(map(repr, unknown))}"
                          f"{hints}; known: {', '.join(sorted(DEFAULTS))}")
    merged = dict(DEFAULTS)
    for key, value in options.items():
        if key in CHOICES:
            if value not in CHOICES[key]:
                raise OptionError(f"interior-point option {key}={value!r}: give one of "
                                 f"{', '.join(map(repr, CHOICES[key]))}")
        elif key in _INTEGERS:
            if isinstance(value, bool) or not isinstance(value, numbers.Integral) \
                    or value < 0:
                raise OptionError(f"interior-point option {key}={value!r}: give an "
                                 "integer >= 0")
        else:
            if isinstance(value, bool) or not isinstance(value, numbers.Real) \
                    or not math.isfinite(float(value)) or float(value) < 0:
                raise OptionError(f"interior-point option {key}={value!r}: give a finite "
                                 "number >= 0")
            value = float(value)
            if key in RANGES:
                _in_range(key, value)
        merged[key] = value
    if merged["limited_memory_init_val_min"] > merged["limited_memory_init_val_max"]:
        raise OptionError("interior-point options limited_memory_init_val_min="
                          f"{merged['limited_memory_init_val_min']!r} > "
                          f"limited_memory_init_val_max={merged['limited_memory_init_val_max']!r}")
    if merged["tol"] <= 0:
        raise OptionError(f"interior-point option tol={merged['tol']!r}: give a number > 0")
    return SimpleNamespace(**merged)
