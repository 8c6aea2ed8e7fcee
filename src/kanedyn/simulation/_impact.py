r"""Impacts in impulse-momentum form.

Kane's equations integrated over an impact of vanishing duration: the
generalized impulses equal the jump in generalized momenta,

.. math::

    M\,(u^+ - u^-) = \sum_c J_c^T P_c,

with :math:`M` and the partial velocities :math:`J_c` at the impact
configuration and :math:`P_c` the impulse on contact point :math:`c`.  With
velocity constraints the jump stays on them: :math:`\Delta u = S (S^T M S)^{-1}
S^T J^T P` with :math:`S` the null-space basis of the constraint Jacobian.  The
relative velocity of the contact points then changes by :math:`W P` with the
contact-space inverse inertia :math:`W = J S (S^T M S)^{-1} S^T J^T`.

A single contact is resolved by integrating over the normal impulse :math:`p`
(Darboux, Keller, Stronge): :math:`dv/dp = W(n + dP_t/dp)` with Coulomb
friction opposing the current slip (:math:`dP_t/dp = -\mu\hat s`) or, when the
slip has stopped and the static coefficient allows, the tangential impulse
that keeps it stopped.  Compression ends where the normal velocity vanishes
(normal impulse :math:`p_c`); restitution ends at :math:`p = (1 + e) p_c`
(Poisson) or when the normal velocity reaches :math:`-e\,v_n^-` (Newton).
Sticking, sliding and slip reversal follow from the integration (in closed
form where the slip keeps its direction: plane motion, a ball).  Several
contacts at once are resolved with Newton's law and the Coulomb cone as a
complementarity problem in contact space, solved directly by enumerating the
contacts' states (free, sticking, sliding) on the small contact set, with
projected Gauss-Seidel as the fallback.
"""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["Impact", "resolve_impact"]


@dataclass(frozen=True)
class Impact:
    r"""One impact: when, where, the impulses and the energy it cost.

    Attributes
    ----------
    t : float
    contacts : tuple of str
        Names of the contacts that received impulses.
    impulses : ndarray, shape (k, 3)
        Impulse on each contact point, N s.
    normal_impulses : ndarray, shape (k,)
    approach_speeds : ndarray, shape (k,)
        Normal approach speeds before the impact (>= 0), m/s.
    separation_speeds : ndarray, shape (k,)
        Normal separation speeds after it, m/s.
    energy_loss : float
        Energy the impulses dissipate on the relative motion of the contact
        points, :math:`-\tfrac12\sum_c P_c\cdot(v_c^- + v_c^+)` (>= 0), J:
        the kinetic energy lost where the surfaces are at rest.
    kinetic_energy_jump : float
        Kinetic energy after minus before, J (it can be positive when a
        moving surface strikes the system).
    """

    t: float
    contacts: tuple
    impulses: np.ndarray
    normal_impulses: np.ndarray
    approach_speeds: np.ndarray
    separation_speeds: np.ndarray
    energy_loss: float
    kinetic_energy_jump: float


def _tangent_basis(n):
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1)
    return np.column_stack([t1, np.cross(n, t1)])


def _impulse_response(model, t, y, jacobians):
    """``(D, W)``: Delta u = D P and Delta v = W P for stacked contact impulses P."""
    _, mass, _, vel_B, _, _ = model._dynamics(t, y)
    o, m = model.n_u, model.n_u_dep
    if m:
        p = o - m
        X = np.linalg.solve(vel_B[:, p:], vel_B[:, :p])
        S = np.vstack([np.eye(p), -X])
    else:
        S = np.eye(o)
    J = np.vstack(jacobians)  # (3k, o)
    D = S @ np.linalg.solve(S.T @ mass @ S, S.T @ J.T)
    return D, J @ D


def _stick_ratio(W, n, T):
    """Tangential impulse per unit normal impulse that keeps the slip at zero.

    Least squares: where the point cannot move tangentially the ratio is 0.
    """
    a = np.linalg.lstsq(T.T @ W @ T, -(T.T @ W @ n), rcond=1e-12)[0]
    return T @ a, float(np.linalg.norm(a))


def _single(W, v0, n, mu_k, mu_s, e, law):
    """Impulse on one contact point; ``v0`` its relative velocity before.

    Integrates over the normal impulse in phases (sliding, sticking), each
    ended by the end of compression, the end of restitution or a change of
    the friction state.
    """
    vn0 = float(n @ v0)
    if vn0 >= 0:
        return np.zeros(3)
    T = _tangent_basis(n)
    stick_rate, stick_ratio = _stick_ratio(W, n, T)
    can_stick = stick_ratio <= mu_s * (1 + 1e-12)
    scale = max(np.linalg.norm(v0), 1e-300)
    slip_tol = 1e-9 * scale
    p_scale = abs(vn0) / max(float(n @ W @ n), 1e-300)
    p_bound = 1e3 * p_scale * (1 + mu_k) + 1e-300
    newton_target = -e * vn0

    def slip_start_direction():
        """Direction in which slip grows from rest when sticking is impossible."""
        d = -stick_rate / max(np.linalg.norm(stick_rate), 1e-300)
        for _ in range(100):
            g = T @ (T.T @ (W @ (n - mu_k * d)))
            nd = g / max(np.linalg.norm(g), 1e-300)
            if np.linalg.norm(nd - d) < 1e-15:
                break
            d = nd
        return d

    p, v, Pt = 0.0, np.array(v0, dtype=float), np.zeros(3)
    pc = None  # normal impulse at the end of compression
    for _ in range(100):  # phases
        if pc is None:
            stop_p = p_bound
        elif law == "poisson":
            stop_p = (1 + e) * pc
        else:
            stop_p = p_bound
        if stop_p <= p:
            break
        vt = v - (n @ v) * n
        sliding = np.linalg.norm(vt) > slip_tol
        if not sliding and can_stick:
            rate = W @ (n + stick_rate)  # linear in p
            rn = float(n @ rate)
            targets = [stop_p]
            if pc is None and rn > 0:
                targets.append(p - float(n @ v) / rn)
            if pc is not None and law == "newton" and rn > 0:
                targets.append(p + (newton_target - float(n @ v)) / rn)
            p_next = min(x for x in targets if x >= p)
            v = v + (p_next - p) * rate
            Pt = Pt + (p_next - p) * stick_rate
            p = p_next
        else:
            direction = vt / np.linalg.norm(vt) if sliding else slip_start_direction()
            constant = W @ (n - mu_k * direction)
            drift = constant - (n @ constant) * n
            along = float(drift @ direction)
            if np.linalg.norm(drift - along * direction) <= 1e-13 * np.linalg.norm(constant):
                # the slip velocity changes along its own direction (plane
                # motion, a ball): the direction is constant until the slip
                # stops and the velocity is linear in p; events in closed form
                targets = [stop_p]
                if sliding and along < 0:
                    targets.append(p - float(vt @ direction) / along)
                rn = float(n @ constant)
                if pc is None and rn > 0:
                    targets.append(p - float(n @ v) / rn)
                if pc is not None and law == "newton" and rn > 0:
                    targets.append(p + (newton_target - float(n @ v)) / rn)
                p_next = min(x for x in targets if x >= p)
                v = v + (p_next - p) * constant
                Pt = Pt - (p_next - p) * mu_k * direction
                p = p_next
                vt = v - (n @ v) * n
                if sliding and along < 0 and float(vt @ direction) <= slip_tol:
                    v = v - (vt @ direction) * direction  # stopped exactly
            else:
                p, v, Pt = _slide_numerically(W, n, mu_k, direction, slip_tol, p, v, Pt, pc,
                                              stop_p, law, newton_target, scale)
        vn = float(n @ v)
        if pc is None and vn >= -1e-14 * scale:
            pc = p
            if e == 0:
                break
            continue
        if pc is not None and law == "newton" and vn >= newton_target - 1e-14 * scale:
            break
        if pc is not None and law == "poisson" and p >= (1 + e) * pc * (1 - 1e-15):
            break
    return p * n + Pt


def _slide_numerically(W, n, mu_k, direction, slip_tol, p, v, Pt, pc, stop_p, law,
                       newton_target, scale):
    """One sliding phase whose slip turns: integrated over the normal impulse."""
    def rate(q, z, direction=direction):  # z = [relative velocity, tangential impulse]
        wt = z[:3] - (n @ z[:3]) * n
        speed = np.linalg.norm(wt)
        d = wt / speed if speed > slip_tol else direction
        return np.concatenate([W @ (n - mu_k * d), -mu_k * d])

    events = []

    def stopped(q, z, direction=direction):
        return (z[:3] - (n @ z[:3]) * n) @ direction
    stopped.terminal, stopped.direction = True, -1
    events.append(stopped)
    if pc is None:
        def compressed(q, z):
            return n @ z[:3]
        compressed.terminal, compressed.direction = True, 1
        events.append(compressed)
    elif law == "newton":
        def restituted(q, z):
            return n @ z[:3] - newton_target
        restituted.terminal, restituted.direction = True, 1
        events.append(restituted)
    sol = solve_ivp(rate, (p, stop_p), np.concatenate([v, Pt]), rtol=1e-12,
                    atol=1e-14 * scale, method="DOP853", events=events)
    return sol.t[-1], sol.y[:3, -1], sol.y[3:, -1]


def _local_frames(normals):
    """Block-diagonal (3k, 3k) matrix of the contact frames (columns n, t1, t2)."""
    k = len(normals)
    F = np.zeros((3 * k, 3 * k))
    for c, n in enumerate(normals):
        F[3 * c:3 * c + 3, 3 * c:3 * c + 3] = np.column_stack([n, _tangent_basis(n)])
    return F


def _enumerated(L, w0, targets, mu, max_contacts=4):
    r"""Impulses of simultaneous contacts by enumerating their states (direct).

    In the contact frames (``L`` the (3k, 3k) inverse inertia, ``w0`` the
    velocities before), each contact is free (no impulse), sticking (its
    normal velocity reaches the target and its slip stops) or sliding (the
    normal velocity reaches the target and the tangential impulse is
    :math:`-\mu p_n \hat s`, :math:`\hat s` the slip direction after the
    impact, found by a fixed point).  Each assignment is one linear system
    (least norm where the impulses are indeterminate, as for a rod landing
    flat); the first whose solution satisfies every inequality (impulses
    pushing, within the cone, no penetration, slip along its direction) is
    the solution of the complementarity problem the projected Gauss-Seidel
    iteration of :func:`_simultaneous` approaches.  ``None`` when no
    assignment is consistent or there are more than ``max_contacts``.
    """
    k = len(targets)
    if k > max_contacts:
        return None
    scale = max(float(np.max(np.abs(w0))), float(np.max(np.abs(targets))), 1e-300)
    eps = 1e-10 * scale
    p_scale = scale / max(float(np.max(np.abs(np.diag(L)))), 1e-300)
    for states in itertools.product((STICK_STATE, SLIDE_STATE, FREE_STATE), repeat=k):
        if all(state == FREE_STATE for state in states):
            x = np.zeros(3 * k)
            ok = all(w0[3 * c] >= targets[c] - eps for c in range(k))
            if ok:
                return x
            continue
        if any(state == STICK_STATE and mu[c] == 0 for c, state in enumerate(states)):
            continue  # frictionless contacts slide
        directions = [None] * k
        for c, state in enumerate(states):
            if state == SLIDE_STATE:
                vt = w0[3 * c + 1:3 * c + 3]
                norm = np.linalg.norm(vt)
                directions[c] = vt / norm if norm > eps else None
        x = None
        converged = False
        for _ in range(20):  # fixed point of the slip directions
            A = np.zeros((3 * k, 3 * k))
            b = np.zeros(3 * k)
            for c, state in enumerate(states):
                r = slice(3 * c, 3 * c + 3)
                if state == FREE_STATE:
                    A[r, r] = np.eye(3)
                elif state == STICK_STATE:
                    A[r] = L[r]
                    b[r] = -w0[r]
                    b[3 * c] += targets[c]
                else:
                    A[3 * c] = L[3 * c]
                    b[3 * c] = targets[c] - w0[3 * c]
                    d = directions[c] if directions[c] is not None else np.zeros(2)
                    A[3 * c + 1:3 * c + 3, 3 * c + 1:3 * c + 3] = np.eye(2)
                    A[3 * c + 1:3 * c + 3, 3 * c] = mu[c] * d
            guess = np.linalg.lstsq(A, b, rcond=1e-12)[0]
            if np.linalg.norm(A @ guess - b) > 1e-9 * max(np.linalg.norm(b), scale * 1e-3):
                break  # Newton from the last consistent guess, if any
            x = guess
            w = w0 + L @ x
            changed = False
            for c, state in enumerate(states):
                if state != SLIDE_STATE:
                    continue
                vt = w[3 * c + 1:3 * c + 3]
                norm = np.linalg.norm(vt)
                if norm <= eps:
                    continue
                d = vt / norm
                changed = changed or directions[c] is None or bool(
                    np.linalg.norm(d - directions[c]) > 1e-14)
                directions[c] = d
            if not changed:
                converged = True
                break
        if not converged and x is not None:
            # the directions cycle: Newton's method on the slip directions
            x = _newton_states(L, w0, targets, mu, states, x, eps)
        if x is not None and _consistent(L, w0, targets, mu, states, x, eps, p_scale):
            return x
        if SLIDE_STATE in states:
            # another root of the sliding equations (the fixed point can find
            # one with a pulling normal impulse): Newton from the sticking
            # solution with its tangential impulse brought onto the cone
            # or without friction on them
            for frictionless in (False, True):
                start = _stick_start(L, w0, targets, mu, states, frictionless)
                x = _newton_states(L, w0, targets, mu, states, start, eps)
                if x is not None and _consistent(L, w0, targets, mu, states, x, eps,
                                                 p_scale):
                    return x
    return None



def _consistent(L, w0, targets, mu, states, x, eps, p_scale):
    """Whether impulses ``x`` satisfy the inequalities of their states."""
    w = w0 + L @ x
    for c, state in enumerate(states):
        pn, pt = x[3 * c], x[3 * c + 1:3 * c + 3]
        vn, vt = w[3 * c], w[3 * c + 1:3 * c + 3]
        if state == FREE_STATE:
            ok = vn >= targets[c] - eps
        elif state == STICK_STATE:
            ok = pn >= -1e-12 * p_scale and np.linalg.norm(pt) <= mu[c] * pn * (
                1 + 1e-12) + 1e-12 * p_scale
        else:
            speed = np.linalg.norm(vt)
            ok = (pn >= -1e-12 * p_scale and speed > eps
                  and np.linalg.norm(pt + mu[c] * pn * vt / speed) <= 1e-9 * (
                      abs(pn) + 1e-12 * p_scale))
        if not ok:
            return False
    return True


def _stick_start(L, w0, targets, mu, states, frictionless=False):
    """Sticking impulses for the sliding contacts, brought onto their cones
    (``frictionless``: without tangential impulses on them)."""
    k = len(states)
    A = np.zeros((3 * k, 3 * k))
    b = np.zeros(3 * k)
    for c, state in enumerate(states):
        r = slice(3 * c, 3 * c + 3)
        if state == FREE_STATE:
            A[r, r] = np.eye(3)
        elif state == SLIDE_STATE and frictionless:
            A[3 * c] = L[3 * c]
            b[3 * c] = targets[c] - w0[3 * c]
            A[3 * c + 1:3 * c + 3, 3 * c + 1:3 * c + 3] = np.eye(2)
        else:
            A[r] = L[r]
            b[r] = -w0[r]
            b[3 * c] += targets[c]
    x = np.linalg.lstsq(A, b, rcond=1e-12)[0]
    for c, state in enumerate(states):
        if state == SLIDE_STATE:
            pt = x[3 * c + 1:3 * c + 3]
            norm = np.linalg.norm(pt)
            if norm > 0:
                x[3 * c + 1:3 * c + 3] = pt * (mu[c] * abs(x[3 * c]) / norm)
    return x


FREE_STATE, STICK_STATE, SLIDE_STATE = 0, 1, 2


def _norm(v):
    """``np.linalg.norm(v)`` of a real vector, as NumPy computes it (the square
    root of ``v.dot(v)``), without its checks: the Newton iterations below take
    it hundreds of thousands of times."""
    return math.sqrt(v.dot(v))


_EYE2 = np.eye(2)


def _state_equations(L, w0, targets, mu, states, eps):
    """``(residual, jacobian)``: the equations of :func:`_enumerated` for one
    assignment of contact states, as functions of the impulses ``x``.

    ``residual(x)`` is ``F`` (3k), or None where a sliding contact's slip is
    within ``eps`` of zero; ``jacobian(x)`` is ``dF/dx`` (3k x 3k) where the
    residual is not None.  The rows of free contacts are ``x``, those of
    sticking ones the velocities after, ``w = w0 + L x``, and the normal rows
    of sliding ones ``w``, less the targets on the normal rows; the tangential
    rows of sliding contacts are :math:`p_t + \\mu p_n \\hat v_t`.  Everything
    but the sliding contacts' tangential rows is sorted once per assignment:
    the Newton iterations of :func:`_newton_states` evaluate these tens of
    thousands of times over a drop of a legged robot.
    """
    states = np.asarray(states)
    free = np.repeat(states == FREE_STATE, 3)
    shift = np.zeros(3 * len(states))
    bound = np.flatnonzero(states != FREE_STATE)
    shift[3 * bound] = np.asarray(targets)[bound]  # x - 0.0 and w - 0.0: x and w
    slides = [(3 * c, slice(3 * c + 1, 3 * c + 3), mu[c])
              for c in np.flatnonzero(states == SLIDE_STATE)]
    G0 = np.zeros((3 * len(states), 3 * len(states)))
    for c, state in enumerate(states):
        r = slice(3 * c, 3 * c + 3)
        if state == FREE_STATE:
            G0[r, r] = np.eye(3)
        elif state == STICK_STATE:
            G0[r] = L[r]
        else:
            G0[3 * c] = L[3 * c]

    def residual(x):
        w = w0 + L @ x
        F = np.where(free, x, w)
        F -= shift
        for n, t, mu_c in slides:
            vt = w[t]
            speed = _norm(vt)
            if speed <= eps:
                return None
            F[t] = x[t] + mu_c * x[n] * (vt / speed)
        return F

    def jacobian(x):
        w = w0 + L @ x
        G = G0.copy()
        for n, t, mu_c in slides:
            vt = w[t]
            speed = _norm(vt)
            d = vt / speed
            G[t] = mu_c * x[n] * ((_EYE2 - np.outer(d, d)) / speed) @ L[t]
            G[t, t] += _EYE2
            G[t, n] += mu_c * d
        return G
    return residual, jacobian


def _newton_states(L, w0, targets, mu, states, x, eps, iterations=50):
    """Impulses for given contact states by Newton's method from ``x``.

    The equations of :func:`_enumerated` (:func:`_state_equations`) with the
    slip directions taken from the velocities after the impact (:math:`p_t +
    \\mu p_n \\hat v_t = 0`), linearized in the impulses; least-norm steps,
    halved while they do not reduce the residual.  ``None`` if it does not
    converge or a sliding contact's slip vanishes.  The halvings evaluate the
    residual alone, the Jacobian only at the step taken: most residuals are the
    30 halvings of a state assignment with no root (of the 153,570 residuals of
    the locked Solo12's drop in ``tests/test_ground.py``, 130,536 were
    halvings, and 691 of its 1,135 Newton runs ended in 30 of them).
    """
    scale = max(float(np.max(np.abs(x))), float(np.max(np.abs(w0))), 1e-300)
    residual, jacobian = _state_equations(L, w0, targets, mu, states, eps)
    F = residual(x)
    for _ in range(iterations):
        if F is None:
            return None
        norm = _norm(F)
        if norm <= 1e-13 * scale:
            return x
        step = np.linalg.lstsq(jacobian(x), -F, rcond=1e-12)[0]
        for _ in range(30):
            F = residual(x + step)
            if F is not None and _norm(F) < norm:
                break
            step = 0.5 * step
        else:
            return None
        x = x + step
    return None


def _simultaneous(W, v0, normals, mu, e, iterations=2000, tol=1e-13):
    """Impulses of several contacts: Newton restitution, Coulomb cone.

    Solved directly by :func:`_enumerated` on the small contact set; by
    projected Gauss-Seidel (iterations over the contacts) where that finds no
    consistent state (more than four contacts, or sliding equations whose
    Newton iterations find only a root with a pulling impulse).  The two
    agree where each contact's tangential inverse inertia is isotropic or of
    rank one (a ball, plane motion); otherwise the radial projection of
    Gauss-Seidel sets the tangential impulse against :math:`W_{tt}^{-1} v_t`
    rather than against the slip :math:`v_t` itself, which the enumeration
    follows.
    """
    k = len(normals)
    F = _local_frames(normals)
    L = F.T @ W @ F
    w0 = F.T @ v0
    vn0 = w0[0::3]
    targets = np.where(vn0 < 0, -e * vn0, 0.0)
    x = _enumerated(L, w0, targets, np.asarray(mu, dtype=float))
    if x is not None:
        return (F @ x).reshape(k, 3)
    return _gauss_seidel(L, w0, targets, mu, F, iterations, tol)


def _gauss_seidel(L, w0, targets, mu, F, iterations, tol):
    """Projected Gauss-Seidel over the contacts, in the contact frames."""
    k = len(targets)
    X = np.zeros(3 * k)
    # the tangential blocks' least-norm inverses are the same in every sweep
    tangential = [np.linalg.pinv(L[3 * c + 1:3 * c + 3, 3 * c + 1:3 * c + 3], rcond=1e-12)
                  for c in range(k)]
    for _ in range(iterations):
        change = 0.0
        for c in range(k):
            sl = slice(3 * c, 3 * c + 3)
            local_v = w0[sl] + L[sl] @ X
            Lcc = L[sl, sl]
            local_P = X[sl]
            # normal: reach the target normal velocity, impulse >= 0
            pn = max(0.0, local_P[0] + (targets[c] - local_v[0]) / Lcc[0, 0])
            # tangential: stop the slip, within the cone
            pt = local_P[1:] - tangential[c] @ (local_v[1:] + Lcc[1:, 0] * (pn - local_P[0]))
            limit = mu[c] * pn
            norm = np.linalg.norm(pt)
            if norm > limit:
                pt *= limit / norm
            new = np.concatenate([[pn], pt])
            change = max(change, float(np.max(np.abs(F[sl, sl] @ (new - local_P)))))
            X[sl] = new
        if change <= tol * max(1.0, float(np.max(np.abs(X)))):
            break
    return (F @ X).reshape(k, 3)


def resolve_impact(model, t, y, contacts, points, restitution=None):
    """Apply an impact to the state.

    Parameters
    ----------
    model : NumericModel
    t : float
    y : ndarray
        State before the impact.
    contacts : sequence of int
        Contacts that take part (those hitting, and those already touching).
    points : sequence of ContactPoint
        Contact kinematics at ``(t, y)`` (all contacts).
    restitution : dict, optional
        ``{contact index: coefficient}`` replacing the contacts' own.

    Returns
    -------
    (ndarray, Impact)
        The state after the impact and the record.
    """
    coefficients = [model.contacts[c] for c in contacts]
    jac = [points[c].jacobian for c in contacts]
    D, W = _impulse_response(model, t, y, jac)
    v0 = np.concatenate([points[c].velocity for c in contacts])
    normals = [points[c].normal for c in contacts]
    restitution = restitution or {}
    e = np.array([restitution.get(c, coef.get("restitution", 0.0))
                  for c, coef in zip(contacts, coefficients)])
    mu = np.array([c["mu_k"] for c in coefficients])

    def solve(e, law):
        if len(contacts) == 1:
            coef = coefficients[0]
            impulses = _single(W, v0, normals[0], coef["mu_k"], coef["mu_s"], e[0],
                               law).reshape(1, 3)
        else:
            impulses = _simultaneous(W, v0, normals, mu, e)
        v1 = v0 + W @ impulses.ravel()
        return impulses, v1, -0.5 * float(impulses.ravel() @ (v0 + v1))

    law = coefficients[0]["law"] if len(contacts) == 1 else "newton"
    impulses, v1, loss = solve(e, law)
    if loss < -1e-12 * max(1.0, float(abs(impulses.ravel() @ v0))):
        # Newton's law with friction can gain energy (Kane's paradox)
        fallback = ("poisson", e) if len(contacts) == 1 else ("newton", 0 * e)
        names = ", ".join(model.contacts[c]["name"] for c in contacts)
        warnings.warn(f"the impact of {names} at t={t:.6g} would gain {-loss:.3g} J under "
                      "Newton's restitution law with friction; resolved with "
                      f"{'Poisson restitution' if len(contacts) == 1 else 'no restitution'}"
                      " instead", RuntimeWarning, stacklevel=2)
        impulses, v1, loss = solve(fallback[1], fallback[0])
    n_q = model.n_q
    y_new = np.array(y, dtype=float)
    y_new[n_q:] = y[n_q:] + D @ impulses.ravel()
    record = Impact(
        t=float(t), contacts=tuple(model.contacts[c]["name"] for c in contacts),
        impulses=impulses, normal_impulses=np.array(
            [impulses[i] @ normals[i] for i in range(len(contacts))]),
        approach_speeds=np.array([-min(0.0, normals[i] @ v0[3 * i:3 * i + 3])
                                  for i in range(len(contacts))]),
        separation_speeds=np.array([normals[i] @ v1[3 * i:3 * i + 3]
                                    for i in range(len(contacts))]),
        energy_loss=loss,
        kinetic_energy_jump=model.energies(t, y_new)[0] - model.energies(t, y)[0])
    return y_new, record
