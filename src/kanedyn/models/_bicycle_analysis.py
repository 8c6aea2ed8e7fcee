"""Linear stability of the Whipple bicycle: eigenvalues against speed.

The nonlinear model is linearized numerically about upright, straight running
at forward speed ``v``; the lean/steer block of the state matrix is the
benchmark's :math:`\\dot x = A x`, :math:`x = (\\phi, \\delta, \\dot\\phi,
\\dot\\delta)` (Meijaard et al. 2007).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

__all__ = ["upright_state", "roll_steer_matrix", "eigenvalues_vs_speed",
           "stability_speeds"]

_INDEPENDENT = ("q1", "q2", "q3", "q4", "q6", "q7", "q8", "u4", "u6", "u7")
_ROLL_STEER = ("q4", "q7", "u4", "u7")


def upright_state(model, speed, rear_radius=None):
    """Consistent state of upright straight running at ``speed`` m/s."""
    names = model.state_names
    rR = rear_radius if rear_radius is not None else model.constants["rR"]
    y = np.zeros(model.n_states)
    y[names.index("u6")] = -speed / rR
    y[names.index("u1")] = speed
    return model.consistent_state(0.0, y)


def roll_steer_matrix(model, speed):
    """4 x 4 state matrix of (lean, steer, lean rate, steer rate) at ``speed``."""
    A, _, _ = model.linearize(upright_state(model, speed))
    sel = [_INDEPENDENT.index(n) for n in _ROLL_STEER]
    return A[np.ix_(sel, sel)]


def eigenvalues_vs_speed(model, speeds):
    """Eigenvalues (sorted by real part) of :func:`roll_steer_matrix` per speed.

    Returns
    -------
    ndarray, complex, shape (len(speeds), 4)
    """
    out = np.empty((len(speeds), 4), dtype=complex)
    for k, v in enumerate(speeds):
        ev = np.linalg.eigvals(roll_steer_matrix(model, v))
        out[k] = ev[np.argsort(ev.real)]
    return out


def _max_real(model, v):
    return float(np.max(np.linalg.eigvals(roll_steer_matrix(model, v)).real))


def stability_speeds(model, weave_bracket=(3.0, 5.0), capsize_bracket=(5.0, 8.0),
                     xtol=1e-13):
    """Weave and capsize speeds: where the largest real part crosses zero.

    Returns
    -------
    (float, float)
        Lower and upper limit of the self-stable speed range, m/s.
    """
    weave = brentq(lambda v: _max_real(model, v), *weave_bracket, xtol=xtol, rtol=1e-15)
    capsize = brentq(lambda v: _max_real(model, v), *capsize_bracket, xtol=xtol,
                     rtol=1e-15)
    return weave, capsize
