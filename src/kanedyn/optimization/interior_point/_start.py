r"""The starting point (Waechter & Biegler 2006, section 3.6).

The free variables and the slacks (the inequality rows' values) are pushed
into the bounds' interior (``bound_push``, ``bound_frac``; their
``slack_`` twins), the bound multipliers set to ``bound_mult_init_val``,
and the rows' multipliers :math:`y` found by least squares,

.. math::

    \begin{bmatrix} I & J^T \\ J & -D \end{bmatrix}
    \begin{bmatrix} v \\ y \end{bmatrix} =
    -\begin{bmatrix} \nabla f - z_L + z_U \\ [0;\ r_s] \end{bmatrix}

(the slacks' identity eliminated, :math:`D` one on the inequality rows and
zero on the equality rows, :math:`r_s = -v_L + v_U` the slack bound
multipliers' part), or zero when that fails or gives
:math:`\|y\|_\infty >` ``constr_mult_init_max``.  A warm start (IPOPT's
multipliers of an earlier solve) takes its multipliers instead, the bound
multipliers raised to ``warm_start_mult_bound_push``, and pushes the
point by the ``warm_start_`` amounts.
"""

from __future__ import annotations

import numpy as np

__all__ = ["primal_start", "least_squares_multipliers", "warm_multipliers"]


def primal_start(bounds, n, x, row_values, inequality, settings, warm):
    """``w = (x, s)`` inside the bounds: ``x`` the free variables, the slacks
    from the inequality rows' values ``row_values[inequality]``."""
    if warm:
        push, frac = settings.warm_start_bound_push, settings.warm_start_bound_frac
        slack_push, slack_frac = push, frac
    else:
        push, frac = settings.bound_push, settings.bound_frac
        slack_push, slack_frac = settings.slack_bound_push, settings.slack_bound_frac
    w = np.concatenate([x, row_values[inequality]])
    pushed_x = bounds.push(w, push, frac)[:n]
    pushed_s = bounds.push(w, slack_push, slack_frac)[n:]
    return np.concatenate([pushed_x, pushed_s])


def least_squares_multipliers(kkt, n, m, inequality, jacobian_values, hessian_size,
                              gradient_w, limit):
    """The rows' multipliers by least squares (see the module), or zeros;
    ``gradient_w()`` makes the right-hand side's gradient (of ``w``: the
    objective's less the bound multipliers') once the matrix is factored."""
    if len(inequality):
        diagonal_c = np.zeros(m)
        diagonal_c[inequality] = 1.0
    else:  # zero on every row: a number, no array
        diagonal_c = 0.0
    inertia = kkt.factor(np.zeros(hessian_size), jacobian_values, 1.0, diagonal_c)
    if m == 0 or int(inertia[2]) > 0:
        return np.zeros(m)
    gradient = gradient_w()
    rhs = np.empty(n + m)
    rhs[:n] = -gradient[:n]
    rhs[n:] = 0.0
    rhs[n:][inequality] = -gradient[n:]
    del gradient
    # solved in rhs's own storage; y not a view that holds the whole solution
    y = kkt.solve(rhs, overwrite=True)[n:].copy()
    if not np.isfinite(y).all() or np.abs(y).max(initial=0.0) > limit:
        return np.zeros(m)
    return y


def warm_multipliers(bounds, n, y, z_lower_x, z_upper_x, floor):
    """The bound multipliers of ``w`` from a warm start's (the variables'
    ones given, the slacks' from the inequality rows' multipliers ``y_I``:
    :math:`v_L = \\max(-y_I, 0)`, :math:`v_U = \\max(y_I, 0)`), at least
    ``floor``."""
    size = bounds.size
    lower, upper = np.zeros(size), np.zeros(size)
    lower[:n], upper[:n] = z_lower_x, z_upper_x
    lower[n:], upper[n:] = np.maximum(-y, 0.0), np.maximum(y, 0.0)
    return (np.maximum(lower[bounds.lower_index], floor),
            np.maximum(upper[bounds.upper_index], floor))
