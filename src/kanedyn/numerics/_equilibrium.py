r"""Static equilibria and steady motions, by Newton's method on the exact Jacobian.

A steady motion is a state :math:`y^*` where every speed is constant and every
coordinate that is not allowed to move is constant:

.. math::

    \dot u(y^*) = 0,\qquad \dot q_i(y^*) = 0 \ (i \notin \text{moving}),
    \qquad h(q^*) = 0,\qquad c(q^*, u^*) = 0,

with some entries of the state held at chosen values (a spin rate, a forward
speed) and the *moving* coordinates (cyclic ones: a rotor angle, a heading, a
position in the plane) left at theirs.  A static equilibrium is the case with
no speed held and nothing moving.  The unknowns are the remaining entries;
Newton's method with the exact derivatives (:meth:`NumericModel.jacobians`,
constraint rows included; inputs that are functions of the state, such as a
mooring line's force, differenced on their own) and least-squares steps (the rows may outnumber the
unknowns: dependent speeds and coordinates are unknowns too, the constraints
rows) finds them, halving a step that does not reduce the residual.  The
stability of the result is that of the linearization there
(:meth:`NumericModel.linearize`, dependent variables eliminated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import ModelError

__all__ = ["Equilibrium", "equilibrium"]


@dataclass(frozen=True)
class Equilibrium:
    r"""A steady motion (or static equilibrium) found by :func:`equilibrium`.

    Attributes
    ----------
    y : ndarray, shape (n_states,)
        The state found (SI units), consistent with the constraints.
    converged : bool
        Whether every residual fell below the tolerance.
    iterations : int
        Newton steps taken.
    residual : float
        The largest residual left: accelerations (SI units per s), rates of
        the coordinates held still, constraint residuals.
    message : str
    eigenvalues : ndarray of complex, shape (n,)
        Of the linearization about ``y`` (independent coordinates and speeds,
        ``n = n_q - n_q_dep + n_u - n_u_dep``), sorted by real part, 1/s.
    frequencies : ndarray, shape (n,)
        :math:`|\mathrm{Im}\,\lambda| / 2\pi`, Hz.
    damping_ratios : ndarray, shape (n,)
        :math:`-\mathrm{Re}\,\lambda / |\lambda|` (nan for :math:`\lambda = 0`,
        that is below :math:`10^{-10}` times the largest magnitude).
    stable : bool
        No eigenvalue has a real part above :math:`10^{-8}` times the largest
        magnitude (eigenvalues at zero, of moving coordinates and held
        speeds, are neutral, not unstable).
    state_names : tuple of str
    """

    y: np.ndarray
    converged: bool
    iterations: int
    residual: float
    message: str
    eigenvalues: np.ndarray
    frequencies: np.ndarray
    damping_ratios: np.ndarray
    stable: bool
    state_names: tuple

    def __repr__(self):
        state = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.state_names, self.y))
        return (f"<Equilibrium: {'converged' if self.converged else 'NOT converged'} in "
                f"{self.iterations} steps, residual {self.residual:.2g}, "
                f"{'stable' if self.stable else 'unstable'}; {state}>")


def _positions(model, names, what):
    """Indices of the states ``names`` (a name or a list of them)."""
    if isinstance(names, str):
        names = [names]
    out = []
    for name in names:
        try:
            out.append(model.index(name))
        except KeyError as exc:
            raise ModelError(f"equilibrium: {what}: {exc.args[0]}") from None
    return out


def equilibrium(model, y0, hold=(), moving=(), t=0.0, r=None, tol=1e-10,
                max_iterations=50):
    """Find a static equilibrium or a steady motion near ``y0``.

    Parameters
    ----------
    model : NumericModel
        A model with exact derivatives (see :meth:`NumericModel.jacobians`).
    y0 : array_like or dict
        Starting guess (SI units), which also gives the values of the held
        entries; a dict as for :meth:`NumericModel.state`.
    hold : str or sequence of str
        States kept at their value in ``y0``: the chosen speeds of a steady
        motion (a spin rate, a forward speed), or coordinates nothing
        restores (a floating body's surge without mooring).
    moving : str or sequence of str
        Coordinates allowed to change at a constant rate (a rotor angle, a
        heading, a position in the plane): their rates are not required to
        vanish and their values are not solved for.
    t : float
        Time, s.
    r : array_like, optional
        Values of the specified inputs (default: their providers at ``(t, y)``).
    tol : float
        Largest residual accepted (SI units of the accelerations and rates).
    max_iterations : int

    Returns
    -------
    Equilibrium
        Also when Newton's method does not converge (``converged=False``,
        ``message`` says why, ``y`` is the best state reached).

    Examples
    --------
    >>> import numpy as np, kanedyn as kd
    >>> model = kd.models.build("pendulum").numeric(
    ...     constants={"m": 1.0, "l": 1.0, "g": 9.81})
    >>> rest = kd.equilibrium(model, [0.3, 0.0])
    >>> abs(float(rest.y[0])) < 1e-12, rest.stable
    (True, True)
    """
    from ._jacobians import derivatives_unavailable, through_inputs
    reason = derivatives_unavailable(model)
    if reason:
        raise ModelError(f"equilibrium: {reason}")
    y = np.array(model.state(y0, t), dtype=float)
    n, nx = model.n_q, model.n_states
    held = _positions(model, hold, "hold")
    cyclic = _positions(model, moving, "moving")
    speeds = [model.state_names[i] for i in cyclic if i >= n]
    if speeds:
        raise ModelError(f"equilibrium: moving: {', '.join(speeds)} are speeds; name the "
                         "coordinates that may change (hold a speed to fix its value)")
    unknowns = [i for i in range(nx) if i not in held and i not in cyclic]
    rows = [i for i in range(nx) if i not in cyclic]  # rates that must vanish
    if not unknowns:
        raise ModelError("equilibrium: every state is held or moving: nothing to solve for")

    def residual(y):
        f = model.jacobians(t, y, r=r)
        state = f.state if r is not None else f.state + through_inputs(model, t, y, f.inputs)
        values = np.concatenate([f.f[rows], model.constraint_residuals(t, y)])
        return values, np.vstack([state[rows], f.constraints])[:, unknowns]

    values, jac = residual(y)
    size = float(np.max(np.abs(values))) if values.size else 0.0
    iterations, message = 0, "the residuals fell below the tolerance"
    while size > tol:
        if iterations == max_iterations:
            message = f"no convergence in {max_iterations} Newton steps"
            break
        if not np.all(np.isfinite(jac)):
            message = "the derivatives are not finite at the state reached"
            break
        step = np.linalg.lstsq(jac, -values, rcond=None)[0]
        iterations += 1
        for _ in range(30):  # halve a step that does not reduce the residual
            trial = y.copy()
            trial[unknowns] += step
            trial_values, trial_jac = residual(trial)
            trial_size = float(np.max(np.abs(trial_values)))
            if np.isfinite(trial_size) and trial_size < size:
                break
            step = step / 2
        else:
            message = "no step along Newton's direction reduces the residual"
            break
        y, values, jac, size = trial, trial_values, trial_jac, trial_size
    converged = size <= tol
    if converged:
        A, _, _ = model.linearize(y, t=t, r=r)
        eigenvalues = np.linalg.eigvals(A)
    else:
        eigenvalues = np.full(model.n_q_ind + model.n_u_ind, np.nan + 0j)
    eigenvalues = eigenvalues[np.lexsort((eigenvalues.imag, eigenvalues.real))]
    magnitude = np.abs(eigenvalues)
    scale = float(np.max(magnitude)) if converged and magnitude.size else 0.0
    with np.errstate(invalid="ignore", divide="ignore"):  # no ratio for round-off zeros
        damping = np.where(magnitude > 1e-10 * scale, -eigenvalues.real / magnitude, np.nan)
    stable = bool(converged and np.all(eigenvalues.real <= 1e-8 * max(scale, 1e-300)))
    return Equilibrium(y=y, converged=converged, iterations=iterations, residual=size,
                       message=message, eigenvalues=eigenvalues,
                       frequencies=np.abs(eigenvalues.imag) / (2 * np.pi),
                       damping_ratios=damping, stable=stable,
                       state_names=tuple(model.state_names))
