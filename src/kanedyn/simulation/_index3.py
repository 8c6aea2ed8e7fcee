r"""The index-3 augmented Lagrangian integrator (Bayo & Ledesma 1996).

The equations of motion in dependent coordinates with the configuration
constraints :math:`\Phi(q, t) = 0` (Jacobian :math:`\Phi_q`) enforced by a
penalty :math:`\alpha` and iterated multipliers :math:`\lambda`,

.. math::

    M\ddot q + \Phi_q^T(\alpha\Phi + \lambda) = Q,\qquad
    \lambda_{k+1} = \lambda_k + \alpha\Phi_{k+1},

are discretized with the trapezoidal rule, :math:`\dot q_{n+1} = \tfrac2h
q_{n+1} - \hat{\dot q}_n`, :math:`\ddot q_{n+1} = \tfrac4{h^2}q_{n+1} -
\hat{\ddot q}_n`, and the residual :math:`\tfrac{h^2}4(M\ddot q +
\Phi_q^T(\alpha\Phi + \lambda) - Q)` of step ``n + 1`` is driven to zero by
Newton's method with the approximate tangent :math:`W = M + \tfrac{h^2}4
\alpha\Phi_q^T\Phi_q`, the multipliers updated at every iteration.  The
positions then satisfy the constraints *at the new step*; the velocities and
accelerations are projected onto the velocity and acceleration constraints in
the metric of :math:`W` (mass-orthogonal projections regularized by the
penalty),

.. math::

    \dot q^* = \arg\min\; \tfrac12(\dot q^* - \dot q)^TM(\dot q^* - \dot q)
    \quad\text{s.t.}\quad B\dot q^* + b = 0,

solved by the same augmented-Lagrangian iteration, which converges to the
exact projection where the constraints have full rank and stays finite where
they lose it.  Nothing is ever divided by the smallest singular value of the
constraint Jacobian, so the scheme passes singular configurations; and since
the positions are found from the constraints at the *next* step, where the
Jacobian has its full rank again, it stays on the branch the motion follows.

This is the formulation with which the reference solutions of the IFToMM
benchmark problems were computed (González et al. 2006).  It needs speeds
equal to the coordinate rates (Lagrange's equations, or Kane's with
:math:`u = \dot q`) and holonomic constraints only.
"""

from __future__ import annotations

import numpy as np

from .._errors import ModelError, OptionError
from ..numerics.schemes import al_solve
from ._results import SimulationResult

__all__ = ["check_index3_model", "integrate_index3", "run_index3"]


def check_index3_model(model, name):
    """Raise :class:`ModelError` unless the index-3 integrator applies to ``model``."""
    problems = []
    if not getattr(model, "rates_are_speeds", False):
        problems.append("its speeds are not the coordinate rates (u = q'); derive the "
                        "equations with method='lagrange', or with Kane's method and "
                        "kd_eqs q' - u = 0")
    if getattr(model, "n_u_dep", 0) != getattr(model, "n_q_dep", 0):
        problems.append(f"it has {model.n_u_dep - model.n_q_dep} velocity constraint(s) "
                        "that are not derivatives of configuration constraints "
                        "(nonholonomic)")
    if getattr(model, "contacts", None):
        problems.append("it has contacts")
    if problems:
        raise ModelError(f"the {name!r} scheme cannot integrate this model: "
                         + "; ".join(problems))


class _Hermite:
    """Cubic Hermite interpolation of the state over one step."""

    def __init__(self, t0, t1, q0, v0, a0, q1, v1, a1):
        self.t0, self.h = t0, t1 - t0
        self.ends = (q0, v0, a0, q1, v1, a1)

    def __call__(self, t):
        q0, v0, a0, q1, v1, a1 = self.ends
        h = self.h
        s = (t - self.t0) / h
        h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
        h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
        q = h00 * q0 + h10 * h * v0 + h01 * q1 + h11 * h * v1
        v = h00 * v0 + h10 * h * a0 + h01 * v1 + h11 * h * a1
        return np.concatenate([q, v])


class _Dense:
    """Continuous solution: the Hermite pieces of all steps."""

    def __init__(self, pieces):
        self.pieces = pieces
        self.starts = np.array([p.t0 for p in pieces])
        self.forward = not pieces or pieces[0].h >= 0

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        scalar = t.ndim == 0
        t = np.atleast_1d(t)
        if self.forward:
            k = np.searchsorted(self.starts, t, side="right") - 1
        else:
            k = np.searchsorted(-self.starts, -t, side="right") - 1
        k = np.clip(k, 0, len(self.pieces) - 1)
        out = np.column_stack([self.pieces[j](tj) for j, tj in zip(k, t)])
        return out[:, 0] if scalar else out


def _events_in_step(events, g_old, g_new, piece):
    """Roots ``(t, k, y)`` of the active events within one step, in time order."""
    from scipy.optimize import brentq

    roots = []
    for k, event in enumerate(events):
        a, b = g_old[k], g_new[k]
        direction = getattr(event, "direction", 0.0)
        up, down = a <= 0.0 <= b, a >= 0.0 >= b
        if not ((up and direction > 0) or (down and direction < 0)
                or ((up or down) and direction == 0)) or a == b == 0.0:
            continue
        t_start, t_end = piece.t0, piece.t0 + piece.h
        if a == 0.0:
            root = t_start
        elif b == 0.0:
            root = t_end
        else:
            root = brentq(lambda s, g=event: g(s, piece(s)), min(t_start, t_end),
                          max(t_start, t_end), xtol=1e-14, rtol=4 * np.finfo(float).eps)
        roots.append((root, k, piece(root)))
    roots.sort(key=lambda r: r[0] * np.sign(piece.h))
    return roots


def _solve_step(model, scheme, dynamics, counters, t, h, q, v_hat, a_hat, lam):
    """Positions at the end of one trapezoidal step by Newton's method.

    The tangent is the approximate :math:`M + \\tfrac{h^2}4\\alpha\\Phi_q^T
    \\Phi_q`; the multipliers are updated at every iteration.  Near a singular
    configuration the corrections shrink only linearly: the constraints that
    lose rank hold the coordinates weakly (their residual is of second order
    in the distance from the branch), so the multiplier iteration creeps.
    The penalty is then raised tenfold, up to 1e4 times, for the rest of the
    step.

    Returns
    -------
    q : ndarray
    lam : ndarray
        The multipliers, updated at every iteration.
    converged : bool
    """
    quarter = h * h / 4.0
    constrained = bool(model.n_q_dep)
    alpha = None
    terms = None  # the constraint terms at q, made by the last update (None: not yet)

    def residual(q, terms):
        nonlocal alpha
        v = (2.0 / h) * q - v_hat
        a = (4.0 / h ** 2) * q - a_hat
        _, mass, force, _, _, _ = dynamics(t, q, v)
        if not constrained:
            return quarter * (mass @ a - force), mass, None
        if terms is None:
            terms = model._constraint_terms(t, np.concatenate([q, v]))
        phi, J, _, _ = terms
        if alpha is None:
            alpha = scheme.position_penalty(mass, J, h)
        return quarter * (mass @ a + J.T @ (alpha * phi + lam) - force), mass, J

    previous, boost = np.inf, 1.0
    for iteration in range(scheme.max_iterations):
        r, mass, J = residual(q, terms)
        W = mass + (quarter * alpha) * (J.T @ J) if constrained else mass
        counters["njev"] += 1
        counters["nlu"] += 1
        try:
            dq = np.linalg.solve(W, -r)
        except np.linalg.LinAlgError:
            return q, lam, False
        q = q + dq
        if not np.isfinite(q).all():
            return q, lam, False
        size = np.abs(dq).max()
        scale = 1.0 + np.abs(q).max()
        done = size <= scheme.tol * scale
        if constrained:
            # the next iteration's residual takes these terms (the same q and v)
            terms = model._constraint_terms(t, np.concatenate([q, (2.0 / h) * q - v_hat]))
            phi = terms[0]
            lam = lam + alpha * phi
            done = done and np.abs(phi).max() <= scheme.tol * scale
        if done:
            return q, lam, True
        if constrained and iteration >= 2 and size > 0.25 * previous and boost < 1e4:
            alpha *= 10.0  # slow: the multipliers are ill-determined (near a singular
            boost *= 10.0  # configuration); a larger penalty holds the weak directions
        previous = size
    return q, lam, False


def run_index3(scheme, model, t_span, y0, method="RK45", t_eval=None, events=(),
               dense_output=False, constraint_forces=False, monitor=None, progress=None,
               guard=None, **options):
    """:func:`integrate_index3` for :func:`kanedyn.simulate`, which hands it the run.

    ``method`` must be ``"trapezoidal"`` or :func:`kanedyn.simulate`'s
    default; ``solve_ivp`` options are refused.
    """
    if method not in ("RK45", "trapezoidal"):
        raise OptionError(f"the {scheme.name!r} scheme integrates with its own trapezoidal "
                          f"rule (fixed step {scheme.step:g} s); method={method!r} cannot be "
                          "used with it")
    if options:
        raise OptionError(f"option(s) {', '.join(sorted(options))} do not apply to the "
                          f"{scheme.name!r} scheme's fixed-step integrator; set its step "
                          "instead (kd.schemes.AugmentedLagrangianIndex3(step=...))")
    return integrate_index3(scheme, model, t_span, y0, t_eval=t_eval, events=events,
                            dense_output=dense_output, constraint_forces=constraint_forces,
                            monitor=monitor, progress=progress, guard=guard)


def integrate_index3(scheme, model, t_span, y0, t_eval=None, events=(), dense_output=False,
                     constraint_forces=False, monitor=None, progress=None, guard=None):
    """Integrate with the index-3 augmented Lagrangian; see the module docstring.

    Parameters
    ----------
    scheme : AugmentedLagrangianIndex3
        Step, penalty factor and tolerances.
    model : NumericModel
    t_span : (float, float)
    y0 : ndarray, shape (n_states,)
        A consistent initial state.
    t_eval : ndarray, optional
        Output times (interpolated); default every step.
    events : sequence of callable
        ``event(t, y)`` with optional ``terminal`` and ``direction``.
    dense_output : bool
    constraint_forces : bool
    monitor : SingularityMonitor, optional
    progress : Progress, optional
    guard : RunGuard, optional
        Ends the run on Ctrl-C (message ``"interrupted"``) or at its time limit
        with what was computed.

    Returns
    -------
    SimulationResult
    """
    check_index3_model(model, scheme.name)
    t0, t1 = float(t_span[0]), float(t_span[1])
    n = model.n_q
    steps = max(int(np.ceil(abs(t1 - t0) / scheme.step - 1e-9)), 1)
    h = (t1 - t0) / steps
    events = list(events)
    all_events = events + (monitor.events if monitor is not None else [])
    counters = {"nfev": 0, "njev": 0, "nlu": 0}

    def dynamics(t, q, v):
        counters["nfev"] += 1
        return model._dynamics(t, np.concatenate([q, v]))

    q, v = np.array(y0[:n], dtype=float), np.array(y0[n:], dtype=float)
    _, mass, force, _, acc_K, acc_f = dynamics(t0, q, v)
    a = scheme.constrained(model, t0, y0, mass, force, acc_K, acc_f) if model.n_u_dep \
        else np.linalg.solve(mass, force)
    lam = np.zeros(model.n_q_dep)
    g_old = [float(ev(t0, y0)) for ev in all_events]
    t_events = [[] for _ in all_events]
    y_events = [[] for _ in all_events]
    out_t, out_y, pieces = [], [], []
    t_eval = None if t_eval is None else np.asarray(t_eval, dtype=float)
    next_eval = 0
    if t_eval is None:
        out_t.append(t0)
        out_y.append(np.array(y0, dtype=float))
    status, message = 0, "the integration reached the end of the interval"
    t = t0
    for k in range(steps):
        if guard is not None and guard.stop_reason is not None:  # Ctrl-C, the time limit
            status, message = -1, guard.stop_reason
            break
        t_new = t0 + (k + 1) * h if k + 1 < steps else t1
        hk = t_new - t
        v_hat = (2.0 / hk) * q + v
        a_hat = (4.0 / hk ** 2) * q + (4.0 / hk) * v + a
        q_new = q + hk * v + 0.5 * hk * hk * a
        q_new, lam, converged = _solve_step(model, scheme, dynamics, counters, t_new, hk,
                                            q_new, v_hat, a_hat, lam)
        if not converged:
            status = -1
            message = (f"the Newton iteration of the {scheme.name} scheme did not converge "
                       f"at t={t_new:.6g} in {scheme.max_iterations} iterations; try a "
                       f"smaller step than {abs(h):.3g} s")
            break
        v_new = (2.0 / hk) * q_new - v_hat
        a_new = (4.0 / hk ** 2) * q_new - a_hat
        y_new = np.concatenate([q_new, v_new])
        if model.n_u_dep:
            y_new = scheme.project_velocities(model, t_new, y_new)
            v_new = y_new[n:]
            _, mass, force, _, acc_K, acc_f = dynamics(t_new, q_new, v_new)
            weight = scheme.weight(mass, acc_K)
            # as a correction: round-off then scales with it, not with the accelerations
            a_new = a_new + al_solve(mass, np.zeros_like(a_new), acc_K,
                                     -(acc_K @ a_new + acc_f), weight,
                                     max_iterations=scheme.projection_iterations,
                                     scale=np.abs(a_new).max())
        if not (np.isfinite(y_new).all() and np.isfinite(a_new).all()):
            status = -1
            message = f"non-finite state at t={t_new:.6g}"
            break
        piece = _Hermite(t, t_new, q, v, a, q_new, v_new, a_new)
        stop = None
        if all_events:
            g_new = [float(ev(t_new, y_new)) for ev in all_events]
            for root, j, y_root in _events_in_step(all_events, g_old, g_new, piece):
                t_events[j].append(root)
                y_events[j].append(y_root)
                if j < len(events) and getattr(events[j], "terminal", False):
                    stop = root
                    break
            g_old = g_new
        t_stop = t_new if stop is None else stop
        if t_eval is None:
            out_t.append(t_stop)
            out_y.append(y_new if stop is None else piece(stop))
        else:
            while next_eval < t_eval.size and (t_eval[next_eval] - t_stop) * np.sign(h) <= 0:
                out_t.append(t_eval[next_eval])
                out_y.append(piece(t_eval[next_eval]))
                next_eval += 1
        if dense_output:
            pieces.append(piece)
        q, v, a, t = q_new, v_new, a_new, t_new
        if progress is not None and progress.enabled:
            progress.update("simulating", (k + 1) / steps)
        if stop is not None:
            status, message = 1, "a termination event occurred"
            break
    if progress is not None:
        progress.done()
    if status == -1 and t != t0 and (not out_t or (t - out_t[-1]) * np.sign(h) > 0):
        # ended early (Ctrl-C, a step that failed): the state of the last step
        # taken is kept, as the other integrators keep theirs
        out_t.append(t)
        out_y.append(np.concatenate([q, v]))
    t_out = np.asarray(out_t, dtype=float)
    y_out = np.array(out_y, dtype=float).T.reshape(model.n_states, -1)
    if monitor is not None:
        if monitor.events:
            monitor.collect(t_events[len(events)], y_events[len(events)])
        message = monitor.finish(message, t0, y0, t, np.concatenate([q, v]), stacklevel=5,
                                 advice=f"the constraints lose rank there; the {scheme.name} "
                                 "scheme passes such positions without dividing by the "
                                 "vanishing singular values")
    return SimulationResult.build(
        model=model, t=t_out, y=y_out, status=status, message=message,
        t_events=[np.asarray(te, dtype=float) for te in t_events[:len(events)]],
        y_events=[np.asarray(ye, dtype=float).reshape(-1, model.n_states)
                  for ye in y_events[:len(events)]],
        dense_segments=_Dense(pieces) if dense_output and pieces else None,
        counters=counters, projections=0, initial_state=np.asarray(y0, dtype=float),
        constraint_forces=constraint_forces,
        method=f"trapezoidal rule, index-3 augmented Lagrangian (h = {abs(h):.3g} s)")
