r"""Exact derivatives of the accelerations and contact forces within given contact modes.

With the modes held (each contact separated, sliding or sticking; the slip
reference directions and a bilateral contact's friction sign as they are),
:func:`~kanedyn.numerics._contact_dynamics.solve_modes` solves

.. math::

    M\dot u - f - B^T\mu - \sum_c J_c^T F_c = 0,\qquad K\dot u + f_a = 0,
    \qquad \rho_c = 0,

with, for a sliding contact, :math:`F_c = N_c d_c`, :math:`d_c = n_c -
\sigma_c\mu_{k,c} s_c` and :math:`\rho_c = n_c^T(J_c\dot u + a_c) +
2\omega\,n_c^Tv_c + \omega^2\,\text{gap}_c/|\nabla\text{gap}_c|`
(:math:`n_c^Ta_c` the normal rate), and for a sticking one :math:`F_c =
Q_c\lambda_c`, :math:`\rho_c = Q_c^T(J_c\dot u + a_c + \text{corr}_c\,n_c)`,
:math:`Q_c` an orthonormal basis of the range of :math:`J_c` (the directions
the point can move in).  A viscous friction :math:`-\eta_c v_{t,c}` adds
:math:`-\eta_c J_c^Tv_{t,c}` to :math:`f`.  Differentiated with respect to
any variable :math:`x`, the unknowns :math:`(\partial\dot u, \partial\mu,
\partial N \text{ or } \partial\lambda)` solve the same matrix

.. math::

    \begin{bmatrix} M & -B^T & -J^T D \\ K & 0 & 0 \\ D^TJ & 0 & 0\end{bmatrix}

(:math:`D` the columns :math:`d_c` and :math:`Q_c`) with the right-hand side
of the partial derivatives at fixed unknowns: :math:`\partial_x E` (the
generated derivative of :math:`M\dot u - f - B^T\mu` of
:mod:`kanedyn.numerics._jacobians`), :math:`\partial_x a`, and the derivatives
of :math:`J_c^TF_c`, :math:`\rho_c` and the viscous term, formed here from the
generated derivatives of the contact kinematics (gap, its gradient's norm,
normal, relative velocity, :math:`J_c`, :math:`a_c`, normal rate), of
:math:`M` and of :math:`B`.

The pieces chosen numerically are differentiated as what they are:

* the slip direction :math:`s = v_t/|v_t|` through :math:`\partial s = (I -
  ss^T)\,\partial v_t/|v_t|`; a reference direction projected on the tangent
  plane (or on the slip velocities the other active contacts allow) through
  the projection;
* the slip velocity with the drift of the other active contacts removed,
  :math:`v_t = T(v + J\delta u)`, :math:`\delta u = -WC^T(CWC^T)^+r`
  (:func:`~kanedyn.numerics._contact_dynamics.slip_velocities`), through
  :math:`W = M^{-1}`, :math:`C`, :math:`r` and the derivative of the
  pseudo-inverse of constant rank; the projector onto the slip velocities
  allowed, :math:`P = AA^+` with :math:`A = TJ(I - C^+C)`, through
  :math:`\partial P = (I - P)\,\partial A\,A^+ + A^{+T}\partial A^T(I - P)`;
* the range of a sticking point's :math:`J_c` (rank below 3: a planar
  model) through the same projector formula, the basis moved with it
  (:math:`\partial Q = \partial P\,Q`; :math:`\partial\dot u` does not depend
  on the basis).

Friction and viscous coefficients that are expressions of the model's
constants contribute to :math:`\partial/\partial p`.  Statically
indeterminate modes (redundant contact constraints, whose forces
:func:`~kanedyn.numerics._contact_dynamics.solve_modes` chooses by least
friction) are refused, naming the contacts.
"""

from __future__ import annotations

import numpy as np

from .._errors import ModelError
from ._contact_dynamics import SEPARATED, SLIP, STICK, slip_choice, slip_velocities, solve_modes

__all__ = ["contact_rows", "contact_evaluate", "check_modes", "segment_jacobian"]


def contact_rows(model):
    """The expressions whose derivatives a contact model's derivative code
    generates besides the dynamics: the outputs of its ``contacts`` function,
    then the entries of :math:`M` and of :math:`B` (flattened rows)."""
    _, outputs = model._functions["contacts"]
    dynamics = model._functions["dynamics"][1]
    return [e for _, exprs in outputs for e in exprs] + list(dynamics[1][1]) + list(
        dynamics[3][1])


def check_modes(model, modes, directions):
    """The modes as a tuple, checked against the model's contacts."""
    names = [c["name"] for c in model.contacts]
    if modes is None:
        raise ModelError(f"this model has contacts ({', '.join(names)}): its derivatives "
                         "are those within a contact mode; give modes=[...] with one of "
                         "'separated', 'slip', 'stick' per contact")
    modes = tuple(modes)
    if len(modes) != len(names):
        raise ModelError(f"modes: give one mode per contact ({', '.join(names)}), got "
                         f"{len(modes)}")
    for name, mode in zip(names, modes):
        if mode not in (SEPARATED, SLIP, STICK):
            raise ModelError(f"modes: contact {name!r} has mode {mode!r}; use "
                             "'separated', 'slip' or 'stick'")
    if directions is not None and len(directions) != len(names):
        raise ModelError(f"directions: give one entry (or None) per contact "
                         f"({', '.join(names)}), got {len(directions)}")
    return modes


# ------------------------------------------------------------ tensor pieces
def _split(rows, k, o, m):
    """The generated derivatives (rows, X) as X-first arrays by name."""
    X = rows.shape[1]
    sizes = (("gap", (k,)), ("grad", (k,)), ("normal", (k, 3)), ("velocity", (k, 3)),
             ("jacobian", (k, 3, o)), ("acceleration", (k, 3)), ("rate", (k,)),
             ("mass", (o, o)), ("B", (m, o)))
    out, start = {}, 0
    for name, shape in sizes:
        size = int(np.prod(shape))
        out[name] = rows[start:start + size].T.reshape((X,) + shape)
        start += size
    return out


def _pinv_derivative(A, Ap, dA):
    """d(A+) (X, c, r) of A (r, c) of constant rank, A+ = Ap, dA (X, r, c)."""
    from ._stabilization_derivatives import _pinv_derivative as stacked
    return stacked(A[None], Ap[None], dA[None])[0]


def _projector_derivative(A, dA, rcond=1e-10):
    """``(P, dP)``: the orthogonal projector onto the range of ``A`` (r, c) and
    its derivative (X, r, r) for ``dA`` (X, r, c), the rank held."""
    Ap = np.linalg.pinv(A, rcond=rcond) if A.size else A.T
    P = A @ Ap
    rest = np.eye(A.shape[0]) - P
    dP = rest @ dA @ Ap + Ap.T @ np.swapaxes(dA, 1, 2) @ rest
    return P, dP


def _unit_derivative(a, da):
    """``d(a/|a|)`` (X, 3) for ``da`` (X, 3)."""
    norm = np.linalg.norm(a)
    s = a / norm
    return (da - np.outer(da @ s, s)) / norm


class _Contact:
    """One active contact's values and derivatives (X-first), and its slip
    velocity's."""

    def __init__(self, point, d, c, coef, w):
        self.J, self.n, self.v = point.jacobian, point.normal, point.velocity
        self.dJ, self.dn, self.dv = d["jacobian"][:, c], d["normal"][:, c], d["velocity"][:, c]
        self.coef = coef
        vn = float(self.n @ self.v)
        self.vt = self.v - vn * self.n
        self.dvn = self.dn @ self.v + self.dv @ self.n
        self.dvt = self.dv - np.outer(self.dvn, self.n) - vn * self.dn
        self.corr = 2 * w * vn + w * w * point.gap / point.grad_norm
        self.dcorr = 2 * w * self.dvn + w * w * (d["gap"][:, c] / point.grad_norm
                                               - point.gap * d["grad"][:, c]
                                               / point.grad_norm ** 2)
        self.acc, self.dacc = point.acceleration, d["acceleration"][:, c]
        self.rate, self.drate = point.normal_rate, d["rate"][:, c]
        self.JTvt = self.J.T @ self.vt
        self.dJTvt = np.einsum("xio,i->xo", self.dJ, self.vt) + self.dvt @ self.J

    def rows(self, mode):
        """Rows (of C u + r) of :func:`slip_velocities` for this contact:
        ``(C, dC, r, dr)``."""
        if mode == SLIP:
            C = (self.n @ self.J)[None]
            dC = (np.einsum("xi,io->xo", self.dn, self.J)
                  + np.einsum("i,xio->xo", self.n, self.dJ))[:, None]
            return C, dC, np.array([self.n @ self.v]), self.dvn[:, None]
        return self.J, self.dJ, self.v, self.dv


def _tangent_derivative(contact):
    """``(T, dT)``: the tangent-plane projector and its derivative."""
    n, dn = contact.n, contact.dn
    return (np.eye(3) - np.outer(n, n),
            -(dn[:, :, None] * n[None, None, :] + n[None, :, None] * dn[:, None, :]))


def _drift_corrected(contacts, modes, c, mass, dmass, B, dB, rcond=1e-10):
    """``(dv_t, dspace)``: the derivatives of sliding contact ``c``'s slip
    velocity with the other active contacts' drift removed and of the projector
    onto the slip velocities they allow (:func:`slip_velocities`)."""
    rows, drows, values, dvalues = [], [], [], []
    for j, contact in contacts.items():
        if j == c:
            continue
        C, dC, r, dr = contact.rows(modes[j])
        rows.append(C)
        drows.append(dC)
        values.append(r)
        dvalues.append(dr)
    if B.shape[0]:
        rows.append(B)
        drows.append(dB)
        values.append(np.zeros(B.shape[0]))
        dvalues.append(np.zeros((dB.shape[0], B.shape[0])))
    C, dC = np.vstack(rows), np.concatenate(drows, axis=1)
    r, dr = np.concatenate(values), np.concatenate(dvalues, axis=1)
    WC = np.linalg.solve(mass, C.T)
    dWC = np.linalg.solve(mass, np.swapaxes(dC, 1, 2) - dmass @ WC)
    G = C @ WC
    dG = dC @ WC + C @ dWC
    Gp = np.linalg.pinv(G, rcond=rcond)
    du = -WC @ (Gp @ r)
    ddu = -(dWC @ (Gp @ r) + (_pinv_derivative(G, Gp, dG) @ r) @ WC.T + dr @ (WC @ Gp).T)
    contact = contacts[c]
    T, dT = _tangent_derivative(contact)
    moved = contact.v + contact.J @ du
    dvt = (dT @ moved + (contact.dv + contact.dJ @ du + ddu @ contact.J.T) @ T.T)
    Cp = np.linalg.pinv(C, rcond=rcond)
    free = np.eye(C.shape[1]) - Cp @ C
    dfree = -(free @ np.swapaxes(dC, 1, 2) @ Cp.T + Cp @ dC @ free)
    A = T @ contact.J @ free
    dA = dT @ contact.J @ free + T @ contact.dJ @ free + T @ contact.J @ dfree
    space, dspace = _projector_derivative(A, dA, rcond)
    return dvt, dspace


def _slip_direction(contact, point, reference, velocity, space, drift):
    """``(s, ds)``: the slip direction :func:`solve_modes` takes and its
    derivative (``drift``: ``(dv_t, dspace)`` of the drift-corrected slip
    velocity, or ``None``)."""
    s, source = slip_choice(point, reference, velocity=velocity, space=space)
    if source == "velocity":
        dvt = contact.dvt if drift is None else drift[0]
        return s, _unit_derivative(velocity, dvt)
    if source == "none":
        return s, np.zeros((contact.dv.shape[0], 3))
    ref = reference.direction if hasattr(reference, "direction") else np.asarray(
        reference, dtype=float)
    if space is None:
        T, dT = _tangent_derivative(contact)
        return s, _unit_derivative(T @ ref, dT @ ref)
    return s, _unit_derivative(space @ ref, drift[1] @ ref)


def _coefficient_derivatives(model, X, parameters):
    """``{(contact, key): d value/dp (X,)}`` of the friction coefficients that
    are expressions of the constants (parameter columns only); differentiated
    once per model (its constants do not change)."""
    if not parameters:
        return {}
    found = model.__dict__.get("_contact_coefficient_slopes")
    if found is None:
        found = model.__dict__["_contact_coefficient_slopes"] = _coefficient_slopes(
            model, X)
    return found


def _coefficient_slopes(model, X):
    import sympy as sm
    values = dict(zip(model.constants, model._p))
    out = {}
    for c, (_, exprs) in enumerate(model._data["contact_coefficients"]):
        for key in ("mu_k", "viscous"):
            expr = sm.sympify(exprs.get(key, 0), strict=True)
            if expr.is_number:
                continue
            column = np.zeros(X)
            for j, name in enumerate(model.constants):
                found = [s for s in expr.free_symbols if str(s) == name]
                if found:
                    slope = expr.diff(found[0]).xreplace(
                        {s: values[str(s)] for s in expr.free_symbols if str(s) in values})
                    column[j] = float(slope)
            out[(c, key)] = column
    return out


def contact_evaluate(model, derivatives, t, y, r, modes, directions, stabilization,
                     parameters):
    """The mode solve and its derivatives at one state, a dict: ``f``,
    ``constraints`` (as :func:`kanedyn.numerics._jacobians._evaluate`), ``forces``
    (k, 3), and per column group (state, inputs, constants) ``groups``
    ``(d f/d x, d mu/d x)``, ``force_groups`` (k, 3, X) and ``power_groups``
    ``(d dissipation/d x, d power/d x)`` of the contact forces'
    (:class:`ContactSolution`).

    ``derivatives`` is the model's generated derivative function (arguments
    ``(t, y, p, r + udot + mu)``).
    """
    o, m, nq = model.n_u, model.n_u_dep, model.n_q
    k = len(model.contacts)
    sol = solve_modes(model, t, y, modes, directions, stabilization, inputs=r)
    qd, mass, force, vel_B, acc_K, _ = model._fn["dynamics"](t, y, model._p, list(r))
    B = np.asarray(vel_B, dtype=float).reshape(m, o)
    points = sol.points
    active = [c for c, mode in enumerate(modes) if mode != SEPARATED]
    forces = sol.force
    applied = mass @ sol.udot - force - sum(
        (points[c].jacobian.T @ forces[c] for c in active), np.zeros(o))
    mu = np.linalg.lstsq(B.T, applied, rcond=None)[0] if m else np.zeros(0)
    outputs = derivatives(t, y, model._p, list(r) + list(sol.udot) + list(mu))
    count = (len(outputs) - 2) // 4
    slips, spaces = slip_velocities(points, modes, mass, B if m else None)
    directions = directions or [None] * k
    drifting = any(space is not None for space in spaces)
    # the layout of the unknowns after (udot, mu): a column block per active contact
    blocks, rows, bases = [], [], {}
    for c in active:
        J = points[c].jacobian
        if modes[c] == SLIP:
            rows.append((points[c].normal @ J)[None])
        else:
            U, sv, _ = np.linalg.svd(J, full_matrices=False)
            Q = U[:, sv > 1e-12 * max(sv[0], 1e-300)]
            rows.append(Q.T @ J)
            bases[c] = Q
        blocks.append(rows[-1].shape[0])
    stacked = np.vstack(rows + [B]) if rows or m else np.zeros((0, o))
    if rows and _redundant_rows(stacked):
        names = ", ".join(model.contacts[c]["name"] for c in active)
        raise ModelError(f"the contacts {names} in modes "
                         f"{', '.join(modes[c] for c in active)} are statically "
                         "indeterminate (redundant constraints): their forces are chosen "
                         "by least friction, and their derivatives are not generated")
    size = o + m + sum(blocks)
    groups, force_groups, power_groups = [], [], []
    u = np.asarray(y, dtype=float)[nq:]
    for g in range(count):
        g_x, E_x, a_x = outputs[3 * g:3 * g + 3]
        d = _split(outputs[3 * count + 2 + g], k, o, m)
        X = E_x.shape[1]
        coefficient = _coefficient_derivatives(model, X, parameters and g == 2)
        S = np.zeros((size, size))
        S[:o, :o], S[:o, o:o + m], S[o:o + m, :o] = mass, -B.T, acc_K.reshape(m, o)
        rhs = np.zeros((X, size))
        rhs[:, :o], rhs[:, o:o + m] = E_x.T, a_x.T
        contacts = {c: _Contact(points[c], d, c, model.contacts[c], stabilization)
                    for c in active}
        parts, at = [], o + m
        for c, rows_c, width in zip(active, rows, blocks):
            contact, coef = contacts[c], model.contacts[c]
            viscous = coef["viscous"]
            rhs[:, :o] += viscous * contact.dJTvt + np.outer(
                coefficient.get((c, "viscous"), np.zeros(X)), contact.JTvt)
            S[at:at + width, :o] = rows_c
            F = forces[c] + viscous * contact.vt  # without the viscous part
            if modes[c] == SLIP:
                drift = None
                if drifting and spaces[c] is not None:
                    drift = _drift_corrected(contacts, modes, c, mass, d["mass"], B, d["B"])
                s, ds = _slip_direction(contact, points[c], directions[c], slips[c],
                                        spaces[c], drift)
                N = float(sol.normal_force[c])
                sign = -1.0 if coef["kind"] == "bilateral" and N < 0 else 1.0
                direction = contact.n - sign * coef["mu_k"] * s
                ddirection = contact.dn - sign * (coef["mu_k"] * ds + np.outer(
                    coefficient.get((c, "mu_k"), np.zeros(X)), s))
                column = contact.J.T @ direction
                S[:o, at] = -column
                rhs[:, :o] -= N * (np.einsum("xio,i->xo", contact.dJ, direction)
                                   + ddirection @ contact.J)
                rhs[:, at] = (contact.dn @ (contact.J @ sol.udot)
                              + contact.n @ (contact.dJ @ sol.udot).T
                              + contact.drate + contact.dcorr)
                parts.append((c, at, width, direction, N * ddirection, None))
            else:
                Q = bases[c]
                _, dP = _projector_derivative(contact.J, contact.dJ, 1e-12)
                S[:o, at:at + width] = -(contact.J.T @ Q)
                rho = contact.J @ sol.udot + contact.acc + contact.corr * contact.n
                drho = (contact.dJ @ sol.udot + contact.dacc + np.outer(contact.dcorr,
                                                                      contact.n)
                        + contact.corr * contact.dn)
                rhs[:, at:at + width] = (dP @ rho + drho) @ Q
                dPF = dP @ F
                rhs[:, :o] -= np.einsum("xio,i->xo", contact.dJ, F) + dPF @ contact.J
                parts.append((c, at, width, None, dPF, Q))
            at += width
        solved = np.linalg.solve(S, -rhs.T)  # (size, X)
        dF = np.zeros((k, 3, X))
        dwork = np.zeros((2, X))  # dissipation, power
        for c, start, width, direction, fixed, Q in parts:
            contact = contacts[c]
            change = (np.outer(direction, solved[start]) if Q is None
                      else Q @ solved[start:start + width])
            dF[c] = change + fixed.T - contact.coef["viscous"] * contact.dvt.T - np.outer(
                contact.vt, coefficient.get((c, "viscous"), np.zeros(X)))
            dwork += _work_derivatives(contact, forces[c], dF[c], u, g == 0, nq)
        groups.append((np.concatenate([g_x.reshape(nq, -1), solved[:o]]),
                       solved[o:o + m] if m else None))
        force_groups.append(dF)
        power_groups.append(dwork)
    h_y, c_y = outputs[3 * count:3 * count + 2]
    return dict(f=np.concatenate([qd, sol.udot]), constraints=np.concatenate([h_y, c_y]),
                forces=forces, groups=groups, force_groups=force_groups,
                power_groups=power_groups)


def _work_derivatives(contact, F, dF, u, state, nq):
    r"""Derivatives (2, X) of one contact's friction power :math:`f\cdot v` and
    power :math:`F\cdot Ju` (``F`` its total force, ``dF`` (3, X); ``state``:
    the columns are the state's, so :math:`u` varies)."""
    n, v, J = contact.n, contact.v, contact.J
    N = F @ n
    dN = n @ dF + contact.dn @ F
    friction = F - N * n
    dfriction = dF - np.outer(n, dN) - N * contact.dn.T
    dJu = contact.dJ @ u
    if state:
        dJu[nq:] += J.T  # the speeds vary: d(J u)/du = J
    return np.array([dfriction.T @ v + contact.dv @ friction,
                     dF.T @ (J @ u) + dJu @ F])


def _redundant_rows(rows, rtol=1e-10):
    from ._contact_dynamics import _redundant
    return bool(_redundant(rows, rtol))


def segment_jacobian(model, modes, directions=None, stabilization=10.0):
    """``jac(t, z)``: the exact Jacobian of the integration of a model with
    contacts within ``modes`` (state ``z = [y, dissipated energy, contact
    work]``, as :func:`kanedyn.simulation._hybrid.simulate_contacts` integrates
    it), for an implicit integrator; the inputs that are functions of the state
    included (:func:`~kanedyn.numerics._jacobians.through_inputs`)."""
    from ._jacobians import _functions, through_inputs
    derivatives = _functions(model, False)[1]
    n = model.n_states
    modes = check_modes(model, modes, directions)

    def jac(t, z):
        y = np.asarray(z[:n], dtype=float)
        at = contact_evaluate(model, derivatives, t, y, model._r(t, y), modes, directions,
                              stabilization, False)
        (state, _), (inputs, _) = at["groups"][:2]
        (work_state, work_inputs) = at["power_groups"][:2]
        out = np.zeros((n + 2, n + 2))
        out[:n, :n] = state + through_inputs(model, t, y, inputs)
        out[n:, :n] = work_state + through_inputs(model, t, y, work_inputs)
        return out

    return jac
