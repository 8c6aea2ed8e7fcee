r"""Forward sensitivity of a trajectory to its initial state and its constants.

Along :math:`\dot y = f(t, y, p)` the sensitivities
:math:`S = \partial y(t)/\partial [y_0, p]` obey

.. math::

    \dot S = \frac{\partial f}{\partial y} S + \Big[\,0 \;\; \frac{\partial f}{\partial p}\Big],
    \qquad S(t_0) = [\,I \;\; 0\,],

integrated together with the state by ``solve_ivp`` (their errors controlled
with it) with the model's exact derivatives (:meth:`NumericModel.jacobians`;
inputs that follow the state differenced on their own).  Given directions
:math:`V` of the initial state, the columns integrated are those of
:math:`\partial y/\partial y_0\,V` (the same equation from
:math:`S(t_0) = [\,V \;\; 0\,]`): a fit that needs only those integrates fewer
columns, in fewer steps.  For a model with constraints this is the sensitivity
of the index-1 equations' flow, without the projections onto the constraints
that :func:`~kanedyn.simulate` adds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import ModelError, OptionError

__all__ = ["Sensitivity", "sensitivity"]


@dataclass(frozen=True)
class Sensitivity:
    r"""A trajectory and its sensitivities, from :func:`sensitivity`.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Output times, s.
    y : ndarray, shape (n_states, N)
        The states (as ``SimulationResult.y``).
    initial : ndarray, shape (N, n_states, n_states) or (N, n_states, m)
        :math:`\partial y(t)/\partial y_0`, or its product with the ``m``
        ``directions`` given to :func:`sensitivity`.
    parameters : ndarray, shape (N, n_states, n_parameters)
        :math:`\partial y(t)/\partial p` for ``parameter_names``.
    state_names, parameter_names : tuple of str
    success : bool
    message : str
    """

    t: np.ndarray
    y: np.ndarray
    initial: np.ndarray
    parameters: np.ndarray
    state_names: tuple
    parameter_names: tuple
    success: bool
    message: str


def sensitivity(model, t_span, y0, parameters=True, t_eval=None, method="RK45", rtol=1e-8,
                atol=1e-8, directions=None):
    r"""Integrate ``model`` from ``y0`` with the sensitivities of its state.

    Parameters
    ----------
    model : NumericModel
        A model with exact derivatives (see :meth:`NumericModel.jacobians`).
    t_span : (float, float)
        Start and end time, s.
    y0 : array_like or dict
        Initial state (as for :func:`kanedyn.simulate`).
    parameters : bool or sequence of str
        The constants to differentiate with respect to: all of them
        (``True``), none (``False``), or those named (keys of
        ``model.constants``).
    t_eval : array_like, optional
        Output times (default: the solver's steps).
    method : str
        A ``solve_ivp`` method.
    rtol, atol : float
        Tolerances of the state and of the sensitivities.
    directions : array_like, shape (n_states, m), optional
        Changes of the initial state (columns) along which to differentiate:
        ``initial`` is then :math:`\partial y(t)/\partial y_0` times them,
        ``m`` columns integrated instead of ``n_states`` (default: all of
        :math:`\partial y(t)/\partial y_0`; ``m = 0``: none).

    Returns
    -------
    Sensitivity

    Examples
    --------
    >>> import kanedyn as kd
    >>> model = kd.models.build("pendulum").numeric(
    ...     constants={"m": 1.0, "l": 1.0, "g": 9.81})
    >>> s = kd.sensitivity(model, (0.0, 1.0), [0.1, 0.0], parameters=["g"])
    >>> s.parameters.shape[1:]
    (2, 1)
    >>> kd.sensitivity(model, (0.0, 1.0), [0.1, 0.0], parameters=False,
    ...                directions=[[1.0], [0.0]]).initial.shape[1:]
    (2, 1)
    """
    from scipy.integrate import solve_ivp

    from ..numerics import derivatives_unavailable, inputs_follow_state, through_inputs
    reason = derivatives_unavailable(model)
    if reason:
        raise ModelError(f"sensitivity: {reason}")
    constants = list(model.constants)
    if parameters is True:
        names = constants
    elif parameters is False or parameters is None:
        names = []
    else:
        names = [parameters] if isinstance(parameters, str) else list(parameters)
        unknown = [n for n in names if n not in constants]
        if unknown:
            raise OptionError(f"sensitivity: {', '.join(map(repr, unknown))} is not a "
                              f"constant of this model; its constants are "
                              f"{', '.join(constants) or 'none'}")
    columns = [constants.index(n) for n in names]
    t0, t1 = (float(v) for v in t_span)
    y_start = model.state(y0, t0)
    nx = model.n_states
    start = np.eye(nx) if directions is None else np.asarray(directions, dtype=float)
    if start.ndim != 2 or start.shape[0] != nx or not np.all(np.isfinite(start)):
        raise OptionError(f"sensitivity: directions must be a finite array of shape "
                          f"({nx}, m) (one change of the {nx} states per column), got shape "
                          f"{np.shape(directions)}")
    m = start.shape[1]
    k = m + len(names)
    follows = bool(inputs_follow_state(model))  # else the inputs add nothing to d f/d y
    # looked up once, not at every evaluation: the method, whether constants are
    # asked for, their columns as an index array (the same entries as the list's)
    jacobians, with_parameters = model.jacobians, bool(names)
    take = np.array(columns, dtype=np.intp)

    def augmented(t, z):
        y = z[:nx]
        S = z[nx:].reshape(nx, k)
        J = jacobians(t, y, parameters=with_parameters)
        state = J.state + through_inputs(model, t, y, J.inputs) if follows else J.state
        out = np.empty(nx + nx * k)  # [f, dS] written in place, no copies
        out[:nx] = J.f
        dS = out[nx:].reshape(nx, k)
        np.dot(state, S, out=dS)  # np.dot and take: a fraction of matmul's and of
        if with_parameters:        # fancy indexing's call overhead on these small arrays
            dS[:, m:] += J.parameters.take(take, axis=1)
        return out

    z0 = np.concatenate([y_start, np.hstack([start, np.zeros((nx, len(names)))]).ravel()])
    sol = solve_ivp(augmented, (t0, t1), z0, method=method, t_eval=t_eval, rtol=rtol,
                    atol=atol)
    N = sol.t.size
    S = sol.y[nx:].T.reshape(N, nx, k)
    return Sensitivity(t=sol.t, y=sol.y[:nx], initial=S[:, :, :m], parameters=S[:, :, m:],
                       state_names=tuple(model.state_names), parameter_names=tuple(names),
                       success=bool(sol.success), message=str(sol.message))
