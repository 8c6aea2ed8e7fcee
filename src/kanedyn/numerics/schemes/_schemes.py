r"""How a numerical model turns its equations into accelerations: constraint schemes.

Every formulation evaluates the same terms at a state: the unreduced mass
matrix :math:`M` (o x o) and forcing :math:`f`, and the constraints at the
acceleration level, :math:`K\dot u + f_a = 0` (m rows).  With the constraint
forces :math:`K^T\lambda` the equations are the index-1 system

.. math::

    M\dot u = f + K^T\lambda,\qquad K\dot u + f_a = 0 .

The schemes below differ in how they solve it and in what they do about the
drift of the position- and velocity-level constraints :math:`h(q) = 0`,
:math:`c(q, u) = 0` that the integration leaves:

=============================  =====================================================
``Elimination``                dependent speeds eliminated with a fixed partition
                               (Kane's method); drift projected onto the constraints
                               by solving for the dependent variables
``IndexOne``                   the index-1 system solved for :math:`\dot u, \lambda`
                               together; no stabilization
``Baumgarte``                  index 1 with :math:`K\dot u + f_a = -2\alpha c -
                               \beta^2 P^+ h` (Baumgarte 1972)
``Projection``                 index 1; drift removed by projecting the state onto
                               the constraints (least change of all coordinates,
                               mass-weighted change of all speeds)
``Penalty``                    :math:`(M + \alpha K^TK)\dot u = f - \alpha K^T(f_a +
                               2\xi\omega c + \omega^2 P^+h)` (Bayo et al. 1988)
``AugmentedLagrangian``        the penalty system iterated on :math:`\lambda`
                               until the constraints hold (Bayo & Ledesma 1996)
``UdwadiaKalaba``              :math:`\dot u = a + M^{-1/2}(KM^{-1/2})^+(b - Ka)`,
                               :math:`a = M^{-1}f` (Udwadia & Kalaba 1992)
``Partitioning``               independent and dependent variables chosen at every
                               evaluation by pivoted QR of the constraint Jacobian
                               (Wehage & Haug 1982); dependent ones solved from the
                               independent ones after drift
``NullSpace``                  Maggi's equations: :math:`N^TMN z = N^T(f - M\dot
                               u_p)` with an orthonormal basis :math:`N` of the null
                               space of :math:`K`
``AugmentedLagrangianIndex3``  index-3 augmented Lagrangian with mass-orthogonal
                               projections, trapezoidal rule with a fixed step
                               (Bayo & Ledesma 1996): its own integrator, which
                               passes singular configurations (see
                               :mod:`kanedyn._index3`)
=============================  =====================================================

:math:`P^+h` maps the configuration-constraint residual onto the velocity
constraint rows (:math:`\dot h = P c` on the constraint manifold); see
:func:`stabilization`.

A scheme is a small frozen object: ``formulate(..., method="lagrange-baumgarte")``
picks one by name, ``eom.numeric(scheme=kd.schemes.Baumgarte(alpha=20.0))``
chooses another for the same equations.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import scipy.linalg as sla

from ..._errors import ModelError, OptionError

__all__ = ["Scheme", "Elimination", "IndexOne", "Baumgarte", "Projection", "Penalty",
           "AugmentedLagrangian", "UdwadiaKalaba", "Partitioning", "NullSpace",
           "AugmentedLagrangianIndex3", "SCHEMES", "as_scheme", "stabilization",
           "complement_solve", "al_solve"]


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
    """

    name: ClassVar[str] = "scheme"
    project: ClassVar[bool] = False
    c_backend: ClassVar[bool] = False
    c_terms: ClassVar[bool] = False

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


def _kkt(mass, force, K, rhs):
    r"""Solve :math:`[M, -K^T; K, 0][\dot u; \lambda] = [f; r]`."""
    o, m = mass.shape[0], K.shape[0]
    A = np.zeros((o + m, o + m))
    A[:o, :o] = mass
    A[:o, o:] = -K.T
    A[o:, :o] = K
    return np.linalg.solve(A, np.concatenate([force, rhs]))[:o]


def _rate_matrix(model, t, y):
    r""":math:`\partial\dot q/\partial u` (n x o); the identity for rate speeds.

    The kinematic equations are linear in the speeds, so differences of
    ``qdot`` with unit changes of the speeds give the columns exactly (up to
    round-off).
    """
    n = model.n_q
    if model.rates_are_speeds:
        return np.eye(n)
    base = model._dynamics(t, y)[0]
    A = np.empty((n, model.n_u))
    for j in range(model.n_u):
        yj = np.array(y, dtype=float)
        yj[n + j] += 1.0
        A[:, j] = model._dynamics(t, yj)[0] - base
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
        P = J @ _rate_matrix(model, t, y) @ np.linalg.pinv(B)
        s = s + position_gain * np.linalg.lstsq(P, h, rcond=None)[0]
    return s


@dataclass(frozen=True)
class Elimination(Scheme):
    """Dependent speeds eliminated numerically with the model's partition.

    Kane's method as kanedyn evaluates it: the unreduced rows of the
    dependent speeds are folded into the independent ones,
    :math:`\\tilde M = M_i + A_r^T M_d` (:math:`A_r = -B_d^{-1}B_i`), and the
    acceleration constraints complete the square system.  Models whose
    formulation found no partition valid everywhere solve the index-1
    system instead.  Drift is projected away by solving the constraints for
    the dependent coordinates and speeds.
    """

    name: ClassVar[str] = "elimination"
    project: ClassVar[bool] = True
    c_backend: ClassVar[bool] = True

    def accelerations(self, model, t, y, terms):
        _, mass, force, vel_B, acc_K, acc_f = terms
        if model.multiplier_form and model.n_u_dep:
            return _kkt(mass, force, acc_K, -acc_f)
        M, f = model._assemble(mass, force, vel_B, acc_K, acc_f)
        return np.linalg.solve(M, f)


@dataclass(frozen=True)
class IndexOne(Scheme):
    """Lagrange's equations with multipliers as an index-1 DAE, no stabilization."""

    name: ClassVar[str] = "index-1"

    def constrained(self, model, t, y, mass, force, K, acc_f):
        return _kkt(mass, force, K, -acc_f)


@dataclass(frozen=True)
class Baumgarte(IndexOne):
    r"""Index 1 with Baumgarte stabilization :math:`\ddot h + 2\alpha\dot h + \beta^2h = 0`.

    Attributes
    ----------
    alpha, beta : float
        Damping rate and natural frequency of the constraint error, 1/s.
    """

    name: ClassVar[str] = "baumgarte"
    alpha: float = 10.0
    beta: float = 10.0

    def constrained(self, model, t, y, mass, force, K, acc_f):
        s = stabilization(model, t, y, 2.0 * self.alpha, self.beta ** 2)
        return _kkt(mass, force, K, -acc_f - s)


@dataclass(frozen=True)
class Projection(IndexOne):
    """Index 1; after drift the state is projected onto the constraints.

    Coordinates: the least (Euclidean) change of all coordinates that
    satisfies the configuration constraints (Gauss–Newton, minimum norm);
    speeds: the least change in the kinetic-energy metric,
    :math:`\\Delta u = -M^{-1}B^T(BM^{-1}B^T)^{-1}c`.
    """

    name: ClassVar[str] = "projection"
    project: ClassVar[bool] = True

    def project_state(self, model, t, y, tol=1e-12, max_iterations=50):
        y = np.array(y, dtype=float)
        n = model.n_q
        for _ in range(max_iterations if model.n_q_dep else 0):
            h, J, _, _ = model._constraint_terms(t, y)
            if np.max(np.abs(h)) <= tol:
                break
            y[:n] -= np.linalg.lstsq(J, h, rcond=None)[0]
        for _ in range(max_iterations if model.n_u_dep else 0):
            _, _, B, c = model._constraint_terms(t, y)
            if np.max(np.abs(c)) <= tol * (1.0 + np.max(np.abs(y[n:]))):
                break
            mass = model._dynamics(t, y)[1]
            MiBt = np.linalg.solve(mass, B.T)
            y[n:] -= MiBt @ np.linalg.solve(B @ MiBt, c)
        return y


def _penalty_weight(mass, K, factor):
    """Penalty :math:`\\alpha` = factor times the ratio of the matrices' scales."""
    KtK = K.T @ K
    return factor * np.max(np.abs(np.diag(mass))) / max(np.max(np.abs(np.diag(KtK))), 1e-300)


@dataclass(frozen=True)
class Penalty(Scheme):
    r"""Penalty formulation: the constraint forces are a stiff spring–damper.

    .. math::

        (M + \alpha K^TK)\dot u = f - \alpha K^T(f_a + 2\xi\omega c + \omega^2P^+h)

    Attributes
    ----------
    factor : float
        :math:`\alpha` relative to the scales of :math:`M` and :math:`K^TK`
        (dimensionless).  Larger: smaller constraint error, stiffer system.
    xi, omega : float
        Damping ratio and natural frequency (1/s) of the constraint error.
    """

    name: ClassVar[str] = "penalty"
    factor: float = 1e7
    xi: float = 1.0
    omega: float = 10.0

    def _system(self, model, t, y, mass, K, acc_f):
        """Penalty :math:`\\alpha`, :math:`M + \\alpha K^TK` and :math:`f_a + s`."""
        s = stabilization(model, t, y, 2.0 * self.xi * self.omega, self.omega ** 2)
        alpha = _penalty_weight(mass, K, self.factor)
        return alpha, mass + alpha * K.T @ K, acc_f + s

    def constrained(self, model, t, y, mass, force, K, acc_f):
        alpha, A, target = self._system(model, t, y, mass, K, acc_f)
        return np.linalg.solve(A, force - alpha * K.T @ target)


@dataclass(frozen=True)
class AugmentedLagrangian(Penalty):
    r"""Augmented Lagrangian: the penalty system with iterated multipliers.

    .. math::

        (M + \alpha K^TK)\dot u_{k+1} = f + K^T\lambda_k - \alpha K^T(f_a + s),
        \qquad \lambda_{k+1} = \lambda_k - \alpha(K\dot u_{k+1} + f_a + s),

    from :math:`\lambda_0 = 0` until the acceleration constraints hold to
    ``tol`` (relative), so a moderate :math:`\alpha` suffices.

    Attributes
    ----------
    factor, xi, omega : float
        As for :class:`Penalty` (default factor 1e4).
    tol : float
        Relative tolerance of the acceleration-constraint residual.
    max_iterations : int
    """

    name: ClassVar[str] = "augmented-lagrangian"
    factor: float = 1e4
    tol: float = 1e-13
    max_iterations: int = 50

    def constrained(self, model, t, y, mass, force, K, acc_f):
        alpha, _, target = self._system(model, t, y, mass, K, acc_f)
        return al_solve(mass, force, K, -target, alpha, tol=self.tol,
                        max_iterations=self.max_iterations)


@dataclass(frozen=True)
class UdwadiaKalaba(Scheme):
    r"""Udwadia–Kalaba's explicit equations.

    .. math::

        \dot u = a + M^{-1/2}\,(K M^{-1/2})^+\,(b - K a),\qquad a = M^{-1}f,
        \quad b = -f_a - s,

    with the Moore–Penrose inverse (redundant constraints allowed) and an
    optional Baumgarte correction :math:`s` (gains ``alpha``, ``beta`` as
    for :class:`Baumgarte`; default none).
    """

    name: ClassVar[str] = "udwadia-kalaba"
    alpha: float = 0.0
    beta: float = 0.0

    def constrained(self, model, t, y, mass, force, K, acc_f):
        a = np.linalg.solve(mass, force)
        b = -acc_f
        if self.alpha or self.beta:
            b = b - stabilization(model, t, y, 2.0 * self.alpha, self.beta ** 2)
        w, V = np.linalg.eigh(mass)
        M_inv_half = (V / np.sqrt(w)) @ V.T
        return a + M_inv_half @ np.linalg.pinv(K @ M_inv_half) @ (b - K @ a)


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


def al_solve(mass, rhs, C, target, weight, tol=1e-13, max_iterations=10, scale=None):
    r"""Solve :math:`Mx = r + C^T\lambda`, :math:`Cx = d` by augmented-Lagrangian iteration.

    .. math::

        (M + wC^TC)x_{k+1} = r + C^T\lambda_k + wC^Td,\qquad
        \lambda_{k+1} = \lambda_k + w(d - Cx_{k+1}),

    from :math:`\lambda_0 = 0`.  :math:`M + wC^TC` is positive definite
    whenever :math:`M` is positive definite on the null space of :math:`C`,
    whatever the rank of :math:`C`: with a rank-deficient or redundant
    :math:`C` the components of :math:`d` it cannot reach are left
    unreached (a least-squares compromise), instead of making the solve
    singular.  Stops when :math:`\max|Cx - d| \le` ``tol`` times ``scale``.

    Parameters
    ----------
    mass : ndarray, shape (o, o)
    rhs : ndarray, shape (o,)
    C : ndarray, shape (m, o)
    target : ndarray, shape (m,)
    weight : float
        :math:`w`, in the units of :math:`M` over those of :math:`C^TC`.
    tol : float
        Relative tolerance of :math:`\max|Cx - d|`.
    max_iterations : int
    scale : float, optional
        Magnitude against which the residual is measured; default
        :math:`\max|Cx| + \max|d|` at each iteration.

    Returns
    -------
    ndarray, shape (o,)
    """
    factor = sla.cho_factor(mass + weight * (C.T @ C))
    lam = np.zeros(C.shape[0])
    base = rhs + weight * (C.T @ target)
    x = sla.cho_solve(factor, base)
    for _ in range(max_iterations):
        Cx = C @ x
        residual = target - Cx
        size = scale if scale is not None else (np.max(np.abs(Cx), initial=0.0)
                                                + np.max(np.abs(target), initial=0.0))
        if np.max(np.abs(residual), initial=0.0) <= tol * size + 1e-300:
            break
        lam = lam + weight * residual
        x = sla.cho_solve(factor, base + C.T @ lam)
    return x


def _pivoted_partition(A, m):
    """Column indices (dependent, independent) by QR with column pivoting."""
    piv = sla.qr(A, mode="r", pivoting=True)[1]
    return np.sort(piv[:m]), np.sort(piv[m:])


@dataclass(frozen=True)
class Partitioning(Scheme):
    """Generalized coordinate partitioning (Wehage & Haug 1982).

    At every evaluation the dependent speeds are the columns of the
    acceleration-constraint matrix chosen by QR with column pivoting (the
    best-conditioned block), eliminated as in :class:`Elimination`; after
    drift the dependent coordinates (pivoted columns of the configuration
    Jacobian) and speeds are solved from the independent ones by Newton's
    method.
    """

    name: ClassVar[str] = "partitioning"
    project: ClassVar[bool] = True

    def constrained(self, model, t, y, mass, force, K, acc_f):
        return complement_solve(mass, force, K, acc_f, _pivoted_partition(K, K.shape[0])[0])

    def project_state(self, model, t, y, tol=1e-12, max_iterations=50):
        y = np.array(y, dtype=float)
        n = model.n_q
        if model.n_q_dep:
            dep = _pivoted_partition(model._constraint_terms(t, y)[1], model.n_q_dep)[0]
            for _ in range(max_iterations):
                h, J, _, _ = model._constraint_terms(t, y)
                if np.max(np.abs(h)) <= tol:
                    break
                y[dep] -= np.linalg.solve(J[:, dep], h)
        if model.n_u_dep:
            _, _, B, c = model._constraint_terms(t, y)
            dep = _pivoted_partition(B, model.n_u_dep)[0]
            for _ in range(max_iterations):
                _, _, B, c = model._constraint_terms(t, y)
                if np.max(np.abs(c)) <= tol * (1.0 + np.max(np.abs(y[n:]))):
                    break
                y[n + dep] -= np.linalg.solve(B[:, dep], c)
        return y


@dataclass(frozen=True)
class NullSpace(Scheme):
    r"""Maggi's equations: projection onto the null space of the constraints.

    With an orthonormal basis :math:`N` of :math:`\ker K` (from the SVD) and
    the least-norm particular solution :math:`\dot u_p = -K^+f_a`,

    .. math::

        \dot u = \dot u_p + N z,\qquad N^TMN\,z = N^T(f - M\dot u_p),

    solved by Cholesky's factorization; no stabilization.
    """

    name: ClassVar[str] = "null-space"

    def constrained(self, model, t, y, mass, force, K, acc_f):
        N = sla.null_space(K)
        particular = -np.linalg.lstsq(K, acc_f, rcond=None)[0]
        z = sla.cho_solve(sla.cho_factor(N.T @ mass @ N), N.T @ (force - mass @ particular))
        return particular + N @ z


@dataclass(frozen=True)
class AugmentedLagrangianIndex3(Scheme):
    r"""Index-3 augmented Lagrangian with mass-orthogonal projections (Bayo & Ledesma 1996).

    A scheme with its own integrator (:mod:`kanedyn._index3`):
    :func:`kanedyn.simulate` hands the run to it.  The configuration
    constraints are enforced at every step of the trapezoidal rule by a
    penalty and iterated multipliers, solved by Newton's method; velocities
    and accelerations are then projected onto their constraints in the mass
    metric, regularized by the penalty.  No solve divides by the smallest
    singular value of the constraint Jacobian, so the scheme passes singular
    configurations, and it stays on the branch the motion follows (the
    positions come from the constraints at the next step); redundant
    constraints are allowed.  This is how the reference solutions of the
    IFToMM benchmark problems were computed.

    It needs speeds equal to the coordinate rates and holonomic constraints
    only.  The step is fixed, so ``rtol`` and ``atol`` of
    :func:`kanedyn.simulate` do not apply: the error is second order in
    ``step`` (measured in ``docs/constraints.md``).  Used through
    :meth:`kanedyn.NumericModel.rhs` (e.g. for linearization) it gives the
    augmented-Lagrangian accelerations of :func:`~kanedyn._index3.al_solve`,
    without stabilization.

    Attributes
    ----------
    step : float
        Time step, s (the largest step not above it that divides the
        interval is used).
    factor : float
        Penalty: :math:`\tfrac{h^2}{4}\alpha\,\|\Phi_q^T\Phi_q\|` is
        ``factor`` times :math:`\|M\|` (largest diagonal entries).
    tol : float
        Newton tolerance on the constraint residual, relative to
        ``1 + max|q|``; the position correction must be below ``100 tol``
        (relative) as well.
    max_iterations : int
        Newton iterations per step before the run stops with a failure.
    projection_iterations : int
        Augmented-Lagrangian iterations of each velocity and acceleration
        projection.
    """

    name: ClassVar[str] = "augmented-lagrangian-index3"
    project: ClassVar[bool] = True
    c_terms: ClassVar[bool] = True
    step: float = 1e-3
    factor: float = 1e6
    tol: float = 1e-10
    max_iterations: int = 50
    projection_iterations: int = 10

    def __post_init__(self):
        for key in ("step", "factor", "tol"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value > 0):
                raise ModelError(f"{type(self).__name__}: {key} must be positive, "
                                 f"got {value!r}")
        for key in ("max_iterations", "projection_iterations"):
            if int(getattr(self, key)) < 1:
                raise ModelError(f"{type(self).__name__}: {key} must be at least 1")

    def weight(self, mass, C):
        r"""Penalty weight :math:`w` of a projection onto the rows of ``C``."""
        return _penalty_weight(mass, C, self.factor)

    def position_penalty(self, mass, J, h):
        r"""Penalty :math:`\alpha` of the configuration constraints for a step ``h``."""
        return 4.0 / (h * h) * _penalty_weight(mass, J, self.factor)

    def constrained(self, model, t, y, mass, force, K, acc_f):
        return al_solve(mass, force, K, -acc_f, self.weight(mass, K),
                        max_iterations=self.projection_iterations)

    def project_velocities(self, model, t, y):
        """Speeds projected onto the velocity constraints in the mass metric."""
        y = np.array(y, dtype=float)
        n = model.n_q
        _, _, B, c = model._constraint_terms(t, y)
        mass = model._dynamics(t, y)[1]
        # as a correction: round-off then scales with it, not with the speeds (the
        # penalized system has a condition number of about `factor`)
        y[n:] += al_solve(mass, np.zeros(model.n_u), B, -c, self.weight(mass, B),
                          max_iterations=self.projection_iterations,
                          scale=np.max(np.abs(B)) * np.max(np.abs(y[n:])))
        return y

    def project_state(self, model, t, y, max_iterations=50):
        """Coordinates by penalty-regularized Newton steps, then speeds (mass metric)."""
        y = np.array(y, dtype=float)
        n = model.n_q
        for _ in range(max_iterations if model.n_q_dep else 0):
            h, J, _, _ = model._constraint_terms(t, y)
            if np.max(np.abs(h)) <= self.tol * (1.0 + np.max(np.abs(y[:n]))):
                break
            mass = model._dynamics(t, y)[1]
            w = _penalty_weight(mass, J, self.factor)
            y[:n] -= np.linalg.solve(mass + w * J.T @ J, w * J.T @ h)
        return self.project_velocities(model, t, y) if model.n_u_dep else y

    def integrate(self, model, t_span, y0, method="RK45", t_eval=None, events=(),
                  dense_output=False, constraint_forces=False, monitor=None,
                  progress=None, guard=None, **options):
        """Run :func:`kanedyn._index3.integrate_index3` (called by :func:`kanedyn.simulate`).

        ``method`` must be ``"trapezoidal"`` or :func:`kanedyn.simulate`'s
        default; ``solve_ivp`` options are refused.
        """
        from ...simulation._index3 import integrate_index3
        if method not in ("RK45", "trapezoidal"):
            raise OptionError(f"the {self.name!r} scheme integrates with its own "
                             f"trapezoidal rule (fixed step {self.step:g} s); method="
                             f"{method!r} cannot be used with it")
        if options:
            raise OptionError(f"option(s) {', '.join(sorted(options))} do not apply to the "
                             f"{self.name!r} scheme's fixed-step integrator; set its "
                             "step instead (kd.schemes.AugmentedLagrangianIndex3(step=...))")
        return integrate_index3(self, model, t_span, y0, t_eval=t_eval, events=events,
                                dense_output=dense_output,
                                constraint_forces=constraint_forces, monitor=monitor,
                                progress=progress, guard=guard)


SCHEMES = {cls.name: cls for cls in (Elimination, IndexOne, Baumgarte, Projection,
                                     Penalty, AugmentedLagrangian, UdwadiaKalaba,
                                     Partitioning, NullSpace, AugmentedLagrangianIndex3)}


def as_scheme(scheme):
    """A :class:`Scheme` from an instance or a name of :data:`SCHEMES`."""
    if isinstance(scheme, Scheme):
        return scheme
    try:
        return SCHEMES[scheme]()
    except (KeyError, TypeError):
        raise ModelError(f"unknown constraint scheme {scheme!r}; available: "
                         f"{', '.join(SCHEMES)}") from None
