r"""Exact derivatives of the terms the stabilized constraint schemes add.

A scheme's :class:`~kanedyn.numerics.schemes.AccelerationSystem` says what its
accelerations satisfy,

.. math::

    M\dot u - f = K^T\mu,\qquad K\dot u + f_a + s + \mu/\alpha = 0,\qquad
    s = g_v\,c + g_p\,z,\quad z = P^+h,\quad P = G B^+,\quad
    G = J\,\frac{\partial\dot q}{\partial u}

(:func:`~kanedyn.numerics.schemes.stabilization`: :math:`c = Bu + b` the
velocity constraints, :math:`h` the configuration constraints with Jacobian
:math:`J`; :math:`z` is the minimum-norm least-squares solution that
``lstsq`` computes, :math:`P^+h` with the Moore-Penrose inverse, whatever the
shape of :math:`P`).  Baumgarte, Udwadia-Kalaba with gains and the converged
augmented Lagrangian have :math:`1/\alpha = 0`; the penalty scheme has
:math:`\alpha` = :func:`~kanedyn.numerics.schemes.penalty_weight`
:math:`(M, K, \text{factor})`, and :math:`\mu = -\alpha(K\dot u + f_a + s)`,
which is what :meth:`NumericModel.multipliers` reports (:math:`K = B`).
Differentiated with respect to any variable :math:`x`, the second row adds
to the index-1 system of :mod:`kanedyn.numerics._jacobians`

.. math::

    \begin{bmatrix} M & -B^T \\ K & I/\alpha \end{bmatrix}
    \begin{bmatrix} \partial_x\dot u \\ \partial_x\mu \end{bmatrix}
    = -\begin{bmatrix} \partial_x E \\ \partial_x a + \partial_x s
      - \frac{\mu}{\alpha}\,\partial_x\ln\alpha \end{bmatrix},

    \partial s = g_v\,\partial c + g_p\left(\partial(P^+)\,h + P^+\partial h\right),
    \qquad \partial P = \partial G\,B^+ + G\,\partial(B^+),

with the derivative of the Moore-Penrose inverse of a matrix of constant rank
(Golub & Pereyra 1973),

.. math::

    \partial(A^+) = -A^+\,\partial A\,A^+ + A^+A^{+T}\,\partial A^T(I - AA^+)
                    + (I - A^+A)\,\partial A^T A^{+T}A^+

(the second term vanishes for :math:`A` of full row rank, the third for full
column rank).  The term :math:`\partial(P^+)\,h` vanishes on the constraint
manifold only; it is kept, so the derivatives are exact off it too.

:math:`\partial c, \partial h, \partial G, \partial B` and the derivatives of
the diagonal of :math:`M` are generated code (:func:`part_rows`, differentiated
with the rest in :func:`kanedyn.numerics._jacobians._specification`); the rest
is NumPy.

:math:`\alpha = \text{factor}\,\max_k|M_{kk}| / \max_j (K^TK)_{jj}` is
differentiated through the entries ``np.argmax`` picks: where two entries tie
for the largest (the maximum is not differentiable there) the derivative is
that of the first of them, the one-sided derivative in the directions where
it stays the largest.

The augmented Lagrangian's iteration (:func:`~kanedyn.numerics.schemes.al_solve`)
is differentiated as its limit, the constrained solution with :math:`1/\alpha
= 0`: the derivatives are those of the converged accelerations, which the
right-hand side reaches to the iteration's round-off.  Likewise Udwadia and
Kalaba's explicit formula gives the index-1 accelerations for constraints of
full rank.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PARTS", "parts", "part_rows", "accelerations", "second_row"]

#: the generated outputs the derivatives of the stabilization may need, per
#: column group: h, c, G = J dq'/du, B (flattened rows), the diagonal of M
PARTS = ("h", "c", "G", "B", "Md")


def parts(system, n_q_dep):
    """The names (of :data:`PARTS`) whose derivatives the system needs; ``()``
    for the index-1 system (or ``system`` ``None``)."""
    if system is None or not system.stabilized:
        return ()
    need = set()
    if system.velocity_gain:
        need.add("c")
    if system.position_gain and n_q_dep:
        need |= {"h", "G", "B"}
    if system.penalty_factor is not None:
        need |= {"B", "Md"}
    return tuple(name for name in PARTS if name in need)


def part_rows(prog, names, y_syms, dynamics, constraints):
    """The expressions of the named parts, one after the other (one generated
    output per column group: the C backend takes 16 outputs at most), to be
    differentiated like the dynamics' rows; ``[]`` without parts.

    ``dynamics`` and ``constraints`` are the outputs of the model's generated
    functions of those names.
    """
    import sympy as sm
    qdot, mass, vel_B = dynamics[0][1], dynamics[1][1], dynamics[3][1]
    h, J, c = constraints[0][1], constraints[1][1], constraints[3][1]
    n, o, l = len(qdot), len(y_syms) - len(qdot), len(h)
    rows = {"h": list(h), "c": list(c), "B": list(vel_B),
            "Md": [mass[k * o + k] for k in range(o)]}
    if "G" in names:
        rates = prog.jacobian(qdot, y_syms[n:], guarded=True)
        rows["G"] = [sm.Add(*[J[i * n + k] * rates[k, j] for k in range(n)])
                     for i in range(l) for j in range(o)]
    return [e for name in names for e in rows[name]]


def _split(names, derivatives, l, m, o):
    """``{name: derivative}`` from the stacked derivatives of :func:`part_rows`
    (N, rows, X)."""
    sizes = {"h": l, "c": m, "G": l * o, "B": m * o, "Md": o}
    out, start = {}, 0
    for name in names:
        out[name] = derivatives[:, start:start + sizes[name]]
        start += sizes[name]
    return out


def accelerations(model, system, t, y, r, terms):
    r"""``(udot, values)``: the accelerations the system gives at one state, with
    the inputs ``r``, and the values its derivatives need.

    As Baumgarte and the penalty compute them
    (:func:`~kanedyn.numerics.schemes.stabilization`, then
    :func:`~kanedyn.numerics.schemes.kkt_solve` or the penalty's solve), except
    that the inputs are ``r`` throughout; for the augmented Lagrangian and
    Udwadia-Kalaba, the index-1 solution their iteration and formula reach to
    round-off.
    """
    from .schemes import kkt_solve, penalty_weight, rate_matrix
    _, mass, force, _, K, acc_f = terms
    h, J, B, c = model._fn["constraints"](t, y, model._p, list(r))
    s = system.velocity_gain * c
    values = {}
    if system.position_gain and len(h):
        G = J @ rate_matrix(model, t, y, list(r))
        Bp = np.linalg.pinv(B)
        P = G @ Bp
        s = s + system.position_gain * np.linalg.lstsq(P, h, rcond=None)[0]
        # the cut-off of lstsq's rank (rcond=None)
        Pp = np.linalg.pinv(P, rcond=np.finfo(float).eps * max(P.shape))
        values.update(h=h, G=G, B=B, Bp=Bp, P=P, Pp=Pp)
    if system.penalty_factor is None:
        return kkt_solve(mass, force, K, -acc_f - s), values
    alpha = penalty_weight(mass, K, system.penalty_factor)
    udot = np.linalg.solve(mass + alpha * K.T @ K, force - alpha * K.T @ (acc_f + s))
    columns = np.sum(K * K, axis=0)
    k, j = int(np.argmax(np.abs(np.diag(mass)))), int(np.argmax(columns))
    values.update(alpha=alpha, K=K, k=k, j=j, Mkk=mass[k, k], Dk=columns[j])
    return udot, values


def _pinv_derivative(A, Ap, dA):
    """d(A+) of stacked A (N, r, c) with A+ (N, c, r) and dA (N, X, r, c)."""
    A, Ap = A[:, None], Ap[:, None]
    ApT, dAT = np.swapaxes(Ap, -1, -2), np.swapaxes(dA, -1, -2)
    rows, cols = A.shape[-2:]
    return (-Ap @ dA @ Ap + Ap @ ApT @ dAT @ (np.eye(rows) - A @ Ap)
            + (np.eye(cols) - Ap @ A) @ dAT @ ApT @ Ap)


def second_row(system, names, values, derivatives, mu, sizes):
    r""":math:`\partial s - (\mu/\alpha)\,\partial\ln\alpha`, shape (N, m, X): what
    the stabilization adds to :math:`\partial a` at N states.

    Parameters
    ----------
    system : AccelerationSystem
    names : tuple of str
        :func:`parts`.
    values : dict of ndarray
        Those of :func:`accelerations`, stacked (first axis N).
    derivatives : ndarray, shape (N, rows, X)
        The generated derivatives of the parts ``names`` (:func:`part_rows`).
    mu : ndarray, shape (N, m)
        The multipliers.
    sizes : tuple of int
        ``(n_q_dep, n_u)``.
    """
    N, m = mu.shape
    l, o = sizes
    X = derivatives.shape[2]
    d = _split(names, derivatives, l, m, o)
    out = np.zeros((N, m, X))
    if "c" in d:
        out += system.velocity_gain * d["c"]
    if "G" in d:
        dG = np.moveaxis(d["G"].reshape(N, l, o, X), 3, 1)
        dB = np.moveaxis(d["B"].reshape(N, m, o, X), 3, 1)
        dP = dG @ values["Bp"][:, None] + values["G"][:, None] @ _pinv_derivative(
            values["B"], values["Bp"], dB)
        dz = (_pinv_derivative(values["P"], values["Pp"], dP) @ values["h"][:, None, :, None]
              + values["Pp"][:, None] @ np.moveaxis(d["h"], 2, 1)[..., None])[..., 0]
        out += system.position_gain * np.moveaxis(dz, 1, 2)
    if system.penalty_factor is not None:
        at = np.arange(N)
        dK = d["B"].reshape(N, m, o, X)[at, :, values["j"]]  # (N, m, X): column j
        dD = 2.0 * np.einsum("ni,nix->nx", values["K"][at, :, values["j"]], dK)
        dD[values["Dk"] <= 1e-300] = 0.0  # the floor of penalty_weight: a constant
        d_log = (d["Md"][at, values["k"]] / values["Mkk"][:, None]
                 - dD / np.maximum(values["Dk"], 1e-300)[:, None])
        out -= (mu / values["alpha"][:, None])[:, :, None] * d_log[:, None, :]
    return out
