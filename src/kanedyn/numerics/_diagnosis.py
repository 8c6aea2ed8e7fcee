"""Why a state derivative is not finite: the cause, in the model's own names.

Used when a simulation cannot start or stops: a constant that is ``nan``, a
state or a specified input that is not finite, a singular mass matrix (and
the speeds without inertia, and the bodies without mass behind them), a
velocity constraint that cannot be solved for the dependent speeds.
"""

from __future__ import annotations

import numpy as np

__all__ = ["diagnose"]

_SINGULAR = 1e-12  # smallest / largest singular value below which a matrix is singular


def diagnose(model, t, y):
    """A sentence naming why ``model.rhs(t, y)`` is not finite, or ``""``.

    Parameters
    ----------
    model : NumericModel
    t : float
        Time, s.
    y : ndarray, shape (n_states,)

    Returns
    -------
    str
    """
    names = model.state_names
    constants = [f"{k} = {v}" for k, v in model.constants.items() if not np.isfinite(v)]
    if constants:
        return f"the constant(s) {', '.join(constants)} are not finite"
    if not np.isfinite(t):
        return f"the time t = {t} is not finite"
    bad = np.flatnonzero(~np.isfinite(y))
    if bad.size:
        return "the state is not finite (" + ", ".join(
            f"{names[i]} = {y[i]}" for i in bad) + f") at t={t:.6g}: the solution " \
            "diverged (a stiff method such as Radau or BDF, or a tighter tolerance, may help)"
    inputs = [(name, value) for name, value in zip(model.input_names, model._r(t, y))
              if not np.isfinite(value)]
    if inputs:
        return (f"specified input(s) not finite at t={t:.6g}: "
                + ", ".join(f"{n} = {v}" for n, v in inputs))
    try:
        qd, mass, force, vel_B, acc_K, acc_f = model._dynamics(t, y)
    except (ArithmeticError, ValueError) as exc:
        return f"evaluating the equations at t={t:.6g} failed: {exc}"
    where = f"at t={t:.6g} {_state_text(model, y)}"
    n, o, m = model.n_q, model.n_u, model.n_u_dep
    speeds = names[n:]
    for label, values, rows in (("kinematic equation of", qd, names[:n]),
                                ("forcing term of", force, speeds)):
        bad = [rows[i] for i in np.flatnonzero(~np.isfinite(np.ravel(values)))]
        if bad:
            return f"the {label} {', '.join(bad)} is not finite {where}"
    if not np.all(np.isfinite(mass)):
        bad = sorted({speeds[i] for i, j in zip(*np.nonzero(~np.isfinite(mass)))})
        return f"the mass matrix is not finite in the rows of {', '.join(bad)} {where}"
    if m:
        dep = vel_B[:, o - m:]
        if not np.all(np.isfinite(vel_B)) or _is_singular(dep):
            return (f"the velocity constraints cannot be solved for the dependent speeds "
                    f"{', '.join(speeds[o - m:])} {where} (singular constraint Jacobian)")
    try:
        reduced, _ = model._assemble(mass, force, vel_B, acc_K, acc_f)
    except np.linalg.LinAlgError:
        reduced = None
    if reduced is not None and _is_singular(reduced):
        return _singular_mass_text(model, reduced, speeds, where)
    return ""


def _is_singular(matrix):
    if matrix.size == 0:
        return False
    if not np.all(np.isfinite(matrix)):
        return True
    s = np.linalg.svd(matrix, compute_uv=False)
    return s[-1] <= _SINGULAR * max(s[0], 1e-300)


def _singular_mass_text(model, reduced, speeds, where):
    """Name the speeds without inertia and the massless bodies behind them."""
    _, s, vt = np.linalg.svd(reduced)
    null = vt[-1]
    big = np.abs(null) >= 0.1 * np.max(np.abs(null))
    combination = " + ".join(f"{null[i]:.3g}*{speeds[i]}" for i in np.flatnonzero(big)) \
        if big.sum() > 1 else speeds[int(np.argmax(np.abs(null)))]
    text = (f"singular mass matrix {where}: no inertia along {combination} (smallest/"
            f"largest singular value {s[-1] / max(s[0], 1e-300):.2g})")
    massless = [b for b in model._data.get("bodies", ()) if b.massless
                or (b.mass is not None and b.mass == 0.0)]
    if massless:
        text += "; " + ", ".join(f"{b.kind} {b.name!r} has mass {b.mass:g} kg"
                                 for b in massless)
    return text


def _state_text(model, y):
    n = model.n_q
    return "(" + ", ".join(f"{k}={v:.6g}" for k, v in zip(model.state_names[:n], y[:n])) \
        + ")"
