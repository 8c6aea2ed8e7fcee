"""The constraint scheme interface and the solves its siblings share."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

__all__ = ["Scheme", "AccelerationSystem", "stabilization", "rate_matrix", "complement_solve",
           "al_solve", "kkt_solve", "penalty_weight"]


@dataclass(frozen=True)
class AccelerationSystem:
    r"""The equations a scheme's accelerations satisfy, as exact derivatives need them.

    .. math::

        M\dot u - f = K^T\mu,\qquad K\dot u + f_a + s + \mu/\alpha = 0,
        \qquad s = g_v\,c + g_p\,P^+h

    (:func:`stabilization` gives :math:`s`).  Without stabilization and
    penalty this is the index-1 system every exact scheme solves; with
    :math:`1/\alpha = 0` the constraints hold at the acceleration level
    (Baumgarte, the converged augmented Lagrangian); with a finite
    :math:`\alpha` they are a penalty (:class:`Penalty`).

    Attributes
    ----------
    velocity_gain : float
        :math:`g_v`, 1/s (0: none).
    position_gain : float
        :math:`g_p`, 1/s² (0: none).
    penalty_factor : float or None
        ``factor`` of :math:`\alpha` = :func:`penalty_weight` ``(M, K, factor)``;
        ``None``: :math:`1/\alpha = 0`.
    """

    velocity_gain: float = 0.0
    position_gain: float = 0.0
    penalty_factor: float | None = None

    @property
    def stabilized(self):
        """Whether the system differs from the index-1 one (a gain or a penalty)."""
        return bool(self.velocity_gain or self.position_gain or self.penalty_factor is not None)


@dataclass(frozen=True)
class Scheme:
    """Base of the constraint schemes (see the module docstring).

    Class attributes
    ----------------
    name : str
        Registry name.
    project : bool
        Whether :func:`kanedyn.simulate` projects constraint drift by default.
    c_backend : bool
        Whether the compiled C backend implements the scheme.
    c_terms : bool
        Whether the scheme runs in Python on the terms that the C backend's
        compiled functions evaluate (a ``backend="c"`` model then keeps the
        Python ``rhs`` of the scheme).
    integrator : str or None
        Name of the scheme's own integrator (one of
        :data:`kanedyn.simulation.OWN_INTEGRATORS`), which
        :func:`kanedyn.simulate` hands a run to; ``None``: ``solve_ivp`` or the
        compiled loop.
    """

    name: ClassVar[str] = "scheme"
    project: ClassVar[bool] = False
    c_backend: ClassVar[bool] = False
    c_terms: ClassVar[bool] = False
    integrator: ClassVar[str | None] = None

    def prepare(self, model):
        """Called once when a numerical model is built; may add functions."""

    def accelerations(self, model, t, y, terms):
        r""":math:`\dot u`, shape (n_u,), from the evaluated dynamics ``terms``.

        ``terms = (qdot, mass, force, vel_B, acc_K, acc_f)`` as returned by
        the model's generated ``dynamics`` function.  Without dependent
        speeds :math:`M\dot u = f` is solved directly; otherwise
        :meth:`constrained` does the scheme's work.
        """
        _, mass, force, _, acc_K, acc_f = terms
        if not model.n_u_dep:
            return np.linalg.solve(mass, force)
        return self.constrained(model, t, y, mass, force, acc_K, acc_f)

    def constrained(self, model, t, y, mass, force, K, acc_f):
        r""":math:`\dot u` with the constraints :math:`K\dot u + f_a = 0` (m >= 1)."""
        raise NotImplementedError

    def project_state(self, model, t, y):
        """A state on the constraints near ``y`` (after drift)."""
        return model.consistent_state(t, y)

    def acceleration_system(self):
        """The :class:`AccelerationSystem` the accelerations satisfy, or ``None``
        where it is not known (then the model has no exact derivatives:
        :meth:`kanedyn.NumericModel.jacobians` refuses it, naming the scheme)."""
        return None


def kkt_solve(mass, force, K, rhs):
    r"""Solve :math:`[M, -K^T; K, 0][\dot u; \lambda] = [f; r]`."""
    o, m = mass.shape[0], K.shape[0]
    A = np.zeros((o + m, o + m))
    A[:o, :o] = mass
    A[:o, o:] = -K.T
    A[o:, :o] = K
    return np.linalg.solve(A, np.concatenate([force, rhs]))[:o]


def rate_matrix(model, t, y, r=None):
    r""":math:`\partial\dot q/\partial u` (n x o); the identity for rate speeds.

    The kinematic equations are linear in the speeds, so differences of
    ``qdot`` with unit changes of the speeds give the columns exactly (up to
    round-off).

    Parameters
    ----------
    model : NumericModel
    t : float
    y : ndarray, shape (n_states,)
    r : sequence of float, shape (n_inputs,), optional
        Values of the inputs; default: their providers at ``(t, y)``.

    Returns
    -------
    ndarray, shape (n_q, n_u)
    """
    n = model.n_q
    if model.rates_are_speeds:
        return np.eye(n)

    def rates(z):
        if r is None:
            return model._dynamics(t, z)[0]
        return model._fn["dynamics"](t, z, model._p, r)[0]
    base = rates(y)
    A = np.empty((n, model.n_u))
    for j in range(model.n_u):
        yj = np.array(y, dtype=float)
        yj[n + j] += 1.0
        A[:, j] = rates(yj) - base
    return A


def stabilization(model, t, y, velocity_gain, position_gain):
    r"""Baumgarte-type correction :math:`s` of the acceleration constraints.

    .. math::

        s = g_v\,c + g_p\,P^+h,\qquad P = J\,\frac{\partial\dot q}{\partial u}\,B^+,

    with the configuration constraints :math:`h` (Jacobian :math:`J`) and the
    velocity constraints :math:`c = Bu + b`: on the constraint manifold
    :math:`\dot h = P c`, so :math:`\dot c = -s` gives :math:`\ddot h +
    g_v\dot h + g_p h = 0` for the holonomic part and :math:`\dot c + g_v c =
    0` for the rest.

    Parameters
    ----------
    model : NumericModel
    t : float
    y : ndarray, shape (n_states,)
    velocity_gain, position_gain : float
        :math:`g_v` (1/s) and :math:`g_p` (1/s²).

    Returns
    -------
    ndarray, shape (n_u_dep,)
    """
    h, J, B, c = model._constraint_terms(t, y)
    s = velocity_gain * c
    if len(h) and position_gain:
        P = J @ rate_matrix(model, t, y) @ np.linalg.pinv(B)
        s = s + position_gain * np.linalg.lstsq(P, h, rcond=None)[0]
    return s


def complement_solve(mass, force, K, acc_f, dep, solve=np.linalg.solve):
    r""":math:`\dot u` with the speeds ``dep`` eliminated through the constraints.

    With :math:`\dot u_d = X\dot u_i + x_0` from :math:`K\dot u + f_a = 0`,
    the complement :math:`N` (identity on the independent speeds, :math:`X`
    on the dependent ones) and the particular solution :math:`\dot u_p`
    (:math:`x_0` on the dependent speeds),

    .. math::

        N^TMN\,\dot u_i = N^T(f - M\dot u_p),\qquad \dot u = \dot u_p + N\dot u_i .

    Parameters
    ----------
    mass : ndarray, shape (o, o)
    force : ndarray, shape (o,)
    K : ndarray, shape (m, o)
    acc_f : ndarray, shape (m,)
    dep : array_like of int, shape (m,)
        Indices of the dependent speeds.
    solve : callable
        ``solve(A, b)`` for the reduced (symmetric) system, e.g. by Cholesky.

    Returns
    -------
    ndarray, shape (o,)
    """
    o = mass.shape[0]
    dep = np.asarray(dep)
    ind = np.setdiff1d(np.arange(o), dep)
    N = np.zeros((o, ind.size))
    N[ind, np.arange(ind.size)] = 1.0
    N[dep] = -np.linalg.solve(K[:, dep], K[:, ind])
    particular = np.zeros(o)
    particular[dep] = -np.linalg.solve(K[:, dep], acc_f)
    return particular + N @ solve(N.T @ mass @ N, N.T @ (force - mass @ particular))


_EPS = np.finfo(float).eps


def _cholesky(A):
    """``(factor, solve)``: the Cholesky factor of the positive definite ``A`` and
    ``solve(factor, b)``, by LAPACK's potrf and potrs as ``scipy.linalg.cho_factor``
    and ``cho_solve`` (``check_finite=False``) call them, without those functions'
    checks and wrappers (78 -> 23 us an augmented-Lagrangian solve of 31 x 31, one
    factor and two or three solves; the index-3 scheme makes tens of thousands over
    the A02 benchmark of tests/test_singular.py).  The same routines on the same arrays:
    the same factor and solutions to the bit.

    Raises
    ------
    numpy.linalg.LinAlgError
        When ``A`` is not positive definite (as ``cho_factor``).
    """
    import scipy.linalg as sla  # imported when first needed
    A = np.asarray(A)
    if A.ndim != 2 or A.shape[0] != A.shape[1] or A.size == 0:  # cho_factor's own cases
        return sla.cho_factor(A, check_finite=False), functools.partial(
            sla.cho_solve, check_finite=False)
    potrf, potrs = sla.get_lapack_funcs(("potrf", "potrs"), (A,))
    factor, info = potrf(A, lower=False, overwrite_a=False, clean=False)
    if info > 0:
        raise np.linalg.LinAlgError(f"{info}-th leading minor of the array is not "
                                    "positive definite")
    if info < 0:
        raise ValueError(f"LAPACK reported an illegal value in {-info}-th argument on "
                         "entry to \"POTRF\".")

    def solve(factor, b):
        x, info = potrs(factor, b, lower=False, overwrite_b=False)
        if info != 0:
            raise ValueError(f"illegal value in {-info}th argument of internal potrs")
        return x
    return factor, solve


def al_solve(mass, rhs, C, target, weight, max_iterations=30, scale=None):
    r"""Solve :math:`Mx = r + C^T\lambda`, :math:`Cx = d` by augmented-Lagrangian iteration.

    .. math::

        (M + wC^TC)x_{k+1} = r + C^T\lambda_k + wC^Td,\qquad
        \lambda_{k+1} = \lambda_k + w(d - Cx_{k+1}),

    from :math:`\lambda_0 = 0`.  :math:`A = M + wC^TC` is positive definite
    whenever :math:`M` is positive definite on the null space of :math:`C`,
    whatever the rank of :math:`C`: with a rank-deficient or redundant
    :math:`C` the components of :math:`d` it cannot reach are left
    unreached (a least-squares compromise), instead of making the solve
    singular.

    Each iterate is computed as a correction of the last, from the residuals
    of the two equations themselves,

    .. math::

        \delta_k = A^{-1}g_k,\qquad g_k = r + C^T\lambda_k - Mx_k + wC^T(d - Cx_k),
        \qquad x_{k+1} = x_k + \delta_k,

    the same iterate in exact arithmetic.  Solved for :math:`x` itself, the
    penalized system (condition number about :math:`w\|C^TC\|/\|M\|`) leaves
    a round-off of that many machine epsilons in :math:`x`, whatever the
    number of iterations; as a correction, its round-off scales with the
    correction.

    When to stop is not a tolerance on the constraint residual :math:`Cx - d`
    (a small residual allows a multiplier error :math:`w` times larger, and
    the error of :math:`x` it causes in the directions :math:`C` leaves free).
    In exact arithmetic the corrections shrink in the norm of :math:`A`,
    :math:`\|\delta_k\|_A^2 = \delta_k^Tg_k` (at no cost), at every
    iteration, by the factor :math:`\rho_k = \|\delta_k\|_A/\|\delta_{k-1}\|_A`
    (the multiplier error is multiplied by :math:`(I + wCM^{-1}C^T)^{-1}`), so
    what the corrections still to come would add is about
    :math:`\max|\delta_k|\,\rho_k/(1 - \rho_k)`.  The iteration stops when
    that is below one machine epsilon of ``scale`` (further corrections would
    change nothing), when a correction is no smaller than the last (the
    round-off of the residuals is reached; it is not applied), or after
    ``max_iterations`` corrections.  The first correction has no rate to go
    by (:math:`\rho = 1/2` is taken), except with :math:`r = 0`: the first
    solve is then itself a correction (from :math:`x = 0` with the
    multiplier step :math:`wd`) and gives the rate.

    Parameters
    ----------
    mass : ndarray, shape (o, o)
    rhs : ndarray, shape (o,)
    C : ndarray, shape (m, o)
    target : ndarray, shape (m,)
    weight : float
        :math:`w`, in the units of :math:`M` over those of :math:`C^TC`.
    max_iterations : int
        Corrections at most (each is one solve with the factor of :math:`A`).
    scale : float, optional
        Magnitude of what :math:`x` is part of; default :math:`\max|x|`.  A
        correction is negligible below one machine epsilon of it (a projection
        that solves for a small change of the speeds gives their magnitude).

    Returns
    -------
    ndarray, shape (o,)
    """
    # unchecked: non-finite terms give non-finite x, as np.linalg.solve does elsewhere
    factor, solve = _cholesky(mass + weight * (C.T @ C))
    g = rhs + weight * (C.T @ target)
    x = solve(factor, g)
    lam = np.zeros(C.shape[0])
    residual = target - C @ x
    last = np.inf if np.any(rhs) else float(x @ g)  # with r = 0, x is a correction
    for _ in range(max_iterations):
        lam = lam + weight * residual
        g = rhs + C.T @ (lam + weight * residual) - mass @ x
        step = solve(factor, g)
        size = float(step @ g)  # the squared A-norm of the correction
        if not 0.0 < size < last:  # no smaller than the last: round-off reached
            break
        x = x + step
        rho = np.sqrt(size / last) if last < np.inf else 0.5
        to_come = np.abs(step).max() * rho / (1.0 - rho)
        if to_come <= _EPS * (scale if scale is not None else np.abs(x).max()):
            break
        residual = target - C @ x
        last = size
    return x


def penalty_weight(mass, K, factor):
    """Penalty :math:`\\alpha` = factor times the ratio of the matrices' scales."""
    # the arrays' own methods, not np.max/np.diag: the index-3 scheme calls this three
    # times a step (60,000 times over the A02 benchmark of tests/test_singular.py)
    KtK = K.T @ K
    return factor * np.abs(np.diagonal(mass)).max() / max(np.abs(KtK.diagonal()).max(),
                                                          1e-300)
