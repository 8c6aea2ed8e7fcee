"""``SparseKKT`` and ``EnvelopeKKT`` (kanedyn's compiled LDLᵀ of the
interior-point KKT matrix, L stored sparse or by its envelope) against dense
NumPy on the same matrix: ``numpy.linalg.solve`` for the
solutions, ``numpy.linalg.eigvalsh`` for the inertia, the dense product for
``matvec``.  Random quasi-definite and indefinite matrices (repeated entries,
empty rows, no constraints, dense rows and columns, singular ones), the KKT
matrices of a pendulum swing-up's collocation NLP (trapezoid and
Hermite-Simpson, fixed and free duration), and bad input.
"""

import os

import numpy as np
import pytest
import sympy as sm

import kanedyn as kd
from kanedyn.numerics import CompilerError
from kanedyn.optimization.interior_point import DenseKKT, EnvelopeKKT, SparseKKT

RTOL = 1e-10

#: the tests of the factorization's numbers run on both storages of L
BOTH = pytest.mark.parametrize("KKT", [SparseKKT, EnvelopeKKT], ids=["sparse", "envelope"])


def _dense(n, m, hessian, jacobian, diagonal_x, diagonal_c):
    """K as a dense array: H from its lower triangle, J, repeats summed."""
    (hr, hc, hv), (jr, jc, jv) = hessian, jacobian
    H = np.zeros((n, n))
    np.add.at(H, (hr, hc), hv)
    H = H + np.tril(H, -1).T + np.diag(diagonal_x)
    J = np.zeros((m, n))
    np.add.at(J, (jr, jc), jv)
    return np.block([[H, J.T], [J, -np.diag(diagonal_c)]])


def _eigen_inertia(K, relative=1e-9):
    eigenvalues = np.linalg.eigvalsh(K)
    zero = np.abs(eigenvalues) <= relative * np.abs(eigenvalues).max()
    return (int(np.sum((eigenvalues > 0) & ~zero)), int(np.sum((eigenvalues < 0) & ~zero)),
            int(zero.sum()))


def _random_kkt(rng, n, m, per_row=3, repeats=True):
    """Random structures (lower triangle of H, J) with repeated entries."""
    a, b = rng.integers(0, n, per_row * n), rng.integers(0, n, per_row * n)
    hr, hc = np.maximum(a, b), np.minimum(a, b)
    jr = rng.integers(0, m, per_row * m) if m else np.zeros(0, int)
    jc = rng.integers(0, n, jr.size)
    if repeats:  # some entries twice, summed
        hr, hc = np.concatenate([hr, hr[:3]]), np.concatenate([hc, hc[:3]])
        jr, jc = np.concatenate([jr, jr[:3]]), np.concatenate([jc, jc[:3]])
    return hr, hc, jr, jc


def _check(kkt, n, m, hessian, jacobian, dx, dc, rng, inertia=None):
    """Factor, then compare the inertia, two solves and matvec with NumPy."""
    found = kkt.factor(hessian[2], jacobian[2], dx, dc)
    K = _dense(n, m, hessian, jacobian, dx, dc)
    assert found == (inertia if inertia is not None else _eigen_inertia(K))
    rhs = rng.normal(size=(n + m, 2))
    x = kkt.solve(rhs)
    expected = np.linalg.solve(K, rhs)
    assert np.linalg.norm(x - expected) <= RTOL * np.linalg.norm(expected)
    x0 = kkt.solve(rhs[:, 0])
    assert x0.shape == (n + m,)
    assert np.linalg.norm(x0 - expected[:, 0]) <= RTOL * np.linalg.norm(expected[:, 0])
    np.testing.assert_allclose(kkt.matvec(rhs[:, 1]), K @ rhs[:, 1], rtol=1e-13,
                               atol=1e-13 * np.abs(K).max())
    return found


@pytest.mark.parametrize("seed", range(8))
@BOTH
def test_quasi_definite_random(seed, KKT):
    """H + diag(d_x) positive definite, d_c > 0: inertia (n, m, 0) in every
    order, and the solve to 1e-10."""
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(5, 40)), int(rng.integers(0, 30))
    hr, hc, jr, jc = _random_kkt(rng, n, m)
    hv, jv = rng.normal(size=hr.size), rng.normal(size=jr.size)
    H = np.zeros((n, n))
    np.add.at(H, (hr, hc), hv)
    H = H + np.tril(H, -1).T
    dx = np.abs(H).sum(axis=1) + rng.uniform(0.1, 1.0, n)  # diagonally dominant
    dc = rng.uniform(1e-3, 1.0, m)
    for ordering in ("pairs", "rcm", "pairs-mmd"):
        kkt = KKT(n, m, (hr, hc), (jr, jc), ordering=ordering)
        _check(kkt, n, m, (hr, hc, hv), (jr, jc, jv), dx, dc, rng, inertia=(n, m, 0))


@pytest.mark.parametrize("seed", range(8))
@BOTH
def test_indefinite_random(seed, KKT):
    """An indefinite H, some d_c exactly 0: the pivots' signs are K's inertia
    (negative ones among the variables reported, not hidden)."""
    rng = np.random.default_rng(100 + seed)
    n, m = int(rng.integers(8, 40)), int(rng.integers(1, 8))
    hr, hc, jr, jc = _random_kkt(rng, n, m)
    hv, jv = rng.normal(size=hr.size), rng.normal(size=jr.size)
    dx = rng.choice([-1.0, 1.0], n) * rng.uniform(1.0, 3.0, n)
    dc = np.where(rng.random(m) < 0.5, 0.0, rng.uniform(0.1, 1.0, m))
    kkt = KKT(n, m, (hr, hc), (jr, jc))
    positive, negative, zero = _check(kkt, n, m, (hr, hc, hv), (jr, jc, jv), dx, dc, rng)
    assert zero == 0 and negative > m  # more negative pivots than constraints


@pytest.mark.parametrize("KKT", [SparseKKT, EnvelopeKKT, DenseKKT],
                         ids=["sparse", "envelope", "dense"])
def test_diagonals_as_numbers_and_added_x_are_the_arrays_sums(KKT):
    """A diagonal given as one number and ``added_x`` (the interior point's
    delta_w, no array of the sums) factor, solve and multiply to the bit as
    the arrays ``np.full(n, d)`` and ``diagonal_x + added_x`` do (zero
    pivots and the new orders they bring included), and K's product is
    NumPy's."""
    rng = np.random.default_rng(11)
    n, m = 30, 12
    hr, hc, jr, jc = _random_kkt(rng, n, m)
    hv, jv = rng.normal(size=hr.size), rng.normal(size=jr.size)
    sigma = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0.1, 2.0, n))
    rhs = rng.normal(size=n + m)
    for dx, dc, added in ((sigma, 1e-8, 0.0), (sigma, 0.0, 0.37), (2.5, 0.25, 1e-4),
                          (-3.0, 0.0, 0.0)):
        as_arrays = KKT(n, m, (hr, hc), (jr, jc))
        full_x = np.broadcast_to(dx, (n,)) + added if added else np.broadcast_to(dx, (n,))
        expected = as_arrays.factor(hv, jv, np.array(full_x), np.full(m, dc))
        kkt = KKT(n, m, (hr, hc), (jr, jc))
        assert kkt.factor(hv, jv, dx, dc, added) == expected
        np.testing.assert_array_equal(kkt.solve(rhs), as_arrays.solve(rhs))
        np.testing.assert_array_equal(kkt.matvec(rhs), as_arrays.matvec(rhs))
        K = _dense(n, m, (hr, hc, hv), (jr, jc, jv), full_x, np.full(m, dc))
        np.testing.assert_allclose(kkt.matvec(rhs), K @ rhs, rtol=1e-13,
                                   atol=1e-13 * np.abs(K).max())


@BOTH
def test_empty_rows_and_no_constraints(KKT):
    """Variables without Hessian entries, a constraint without Jacobian
    entries (its diagonal only), and m = 0."""
    rng = np.random.default_rng(7)
    n, m = 12, 4
    hr, hc = np.array([3, 5, 5, 9]), np.array([3, 2, 5, 0])
    jr, jc = np.array([0, 0, 1, 3, 3, 3]), np.array([1, 4, 4, 7, 8, 7])  # row 2 empty
    hv, jv = rng.normal(size=4), rng.normal(size=6)
    dx, dc = rng.uniform(5.0, 6.0, n), rng.uniform(0.1, 1.0, m)
    _check(KKT(n, m, (hr, hc), (jr, jc)), n, m, (hr, hc, hv), (jr, jc, jv), dx, dc,
           rng, inertia=(n, m, 0))
    none = np.zeros(0, int)
    kkt = KKT(n, 0, (hr, hc), (none, none))
    _check(kkt, n, 0, (hr, hc, hv), (none, none, np.zeros(0)), dx - 10.0, np.zeros(0), rng,
           inertia=(0, n, 0))


@BOTH
def test_no_variables_or_nothing_at_all(KKT):
    """K = -diag(d_c) without variables, and the empty K."""
    none = np.zeros(0, int)
    kkt = KKT(0, 2, (none, none), (none, none))
    assert kkt.factor(np.zeros(0), np.zeros(0), np.zeros(0), [2.0, 4.0]) == (0, 2, 0)
    np.testing.assert_allclose(kkt.solve([1.0, 1.0]), [-0.5, -0.25])
    empty = KKT(0, 0, (none, none), (none, none))
    assert empty.factor(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)) == (0, 0, 0)
    assert empty.solve(np.zeros(0)).shape == (0,)


@BOTH
def test_dense_rows_and_columns_go_last(KKT):
    """A variable in every constraint (a free duration) and one coupled to
    every variable in H: both counted dense, ordered last, and the
    factorization the same as NumPy's."""
    rng = np.random.default_rng(3)
    n, m = 160, 120
    chain = np.arange(n - 2)
    hr = np.concatenate([chain, chain[1:], np.full(n - 1, n - 1)])
    hc = np.concatenate([chain, chain[:-1], np.arange(n - 1)])
    rows = np.arange(m)
    jr = np.concatenate([rows, rows, rows])
    jc = np.concatenate([rows, rows + 1, np.full(m, n - 2)])
    hv, jv = rng.normal(size=hr.size), rng.normal(size=jr.size)
    jv[:m] += 4.0  # J well conditioned (a random bidiagonal one need not be)
    dx, dc = np.full(n, 200.0), np.zeros(m)
    kkt = KKT(n, m, (hr, hc), (jr, jc))
    assert kkt.analysis.n_dense == 2
    assert set(kkt.analysis.permutation[-2:]) == {n - 2, n - 1}
    _check(kkt, n, m, (hr, hc, hv), (jr, jc, jv), dx, dc, rng, inertia=(n, m, 0))


@BOTH
def test_singular_reports_zero_pivots_and_solves_finitely(KKT):
    """A constraint with no entries and d_c = 0, and two equal constraint
    rows: K is singular (eigvalsh: two zero eigenvalues); the factorization
    reports them as zero pivots, the other pivots as K's inertia, and solve
    still returns finite numbers."""
    rng = np.random.default_rng(11)
    n, m = 10, 5
    hr = hc = np.arange(n)
    jr, jc = np.array([0, 0, 1, 1, 3, 3, 4]), np.array([0, 1, 0, 1, 5, 6, 9])  # row 2 empty
    hv = rng.uniform(1.0, 2.0, n)
    jv = np.array([1.0, 2.0, 1.0, 2.0, 0.5, -1.0, 3.0])  # rows 0 and 1 equal
    dx, dc = np.zeros(n), np.zeros(m)
    kkt = KKT(n, m, (hr, hc), (jr, jc))
    K = _dense(n, m, (hr, hc, hv), (jr, jc, jv), dx, dc)
    assert _eigen_inertia(K) == (n, m - 2, 2)
    assert kkt.factor(hv, jv, dx, dc) == (n, m - 2, 2)
    assert np.isfinite(kkt.solve(rng.normal(size=n + m))).all()
    np.testing.assert_allclose(kkt.matvec(np.arange(n + m)), K @ np.arange(n + m))
    # a tiny d_c on those rows makes K nonsingular again: inertia (n, m, 0)
    assert kkt.factor(hv, jv, dx, np.full(m, 1e-8)) == (n, m, 0)


@BOTH
def test_two_by_two_pivots_of_a_zero_diagonal(KKT):
    """K = [[0, Jᵀ], [J, 0]], J square and sparse: every diagonal entry is
    zero, so 1 x 1 pivots in any order break down at the first one; the
    paired order's 2 x 2 pivots give eigvalsh's inertia (n, n, 0) and
    NumPy's solution; the rows' own order reports zero pivots."""
    rng = np.random.default_rng(4)
    n = 30
    rows = np.arange(n)
    jr = np.concatenate([rows, rows[:-1], rows[2:]])
    jc = np.concatenate([rows, rows[1:], rows[:-2]])
    jv = rng.normal(size=jr.size)
    jv[:n] = rng.choice([-1.0, 1.0], n) * rng.uniform(3.0, 4.0, n)
    none = np.zeros(0, int)
    hessian, jacobian = (none, none, np.zeros(0)), (jr, jc, jv)
    zeros = np.zeros(n)
    _check(KKT(n, n, (none, none), (jr, jc)), n, n, hessian, jacobian, zeros, zeros,
           rng, inertia=(n, n, 0))
    single = KKT(n, n, (none, none), (jr, jc), ordering="rcm")
    assert single.factor(np.zeros(0), jv, zeros, zeros)[2] > 0


@BOTH
def test_large_barrier_terms_are_not_zero_pivots(KKT):
    """Barrier terms up to 1e14 on the variables, J square and nonsingular,
    d_c = 0: K's inertia is (n, n, 0) (H positive definite, the Schur
    complement -J H^-1 Jᵀ negative definite); the constraints' small pivots,
    about -1/1e14, are counted by their sign, not as zero; the solve's
    backward error is at rounding level."""
    rng = np.random.default_rng(9)
    n = 40
    rows = np.arange(n)
    jr, jc = np.concatenate([rows, rows[:-1]]), np.concatenate([rows, rows[1:]])
    jv = np.concatenate([rng.uniform(1.0, 2.0, n), rng.uniform(-0.5, 0.5, n - 1)])
    none = np.zeros(0, int)
    barrier = 10.0 ** rng.uniform(0.0, 14.0, n)
    kkt = KKT(n, n, (none, none), (jr, jc))
    assert kkt.factor(np.zeros(0), jv, barrier, np.zeros(n)) == (n, n, 0)
    K = _dense(n, n, (none, none, np.zeros(0)), (jr, jc, jv), barrier, np.zeros(n))
    rhs = rng.normal(size=2 * n)
    x = kkt.solve(rhs)
    backward = np.abs(K @ x - rhs).max() / (np.abs(K).max() * np.abs(x).max() + np.abs(rhs).max())
    assert backward < 1e-14


def _small_diagonal_first(small, KKT=SparseKKT):
    """``(kkt, (hr, hc), hv, first)``: H = [[small, 1], [1, 1]] with the
    small diagonal in the row eliminated first (``first``)."""
    none = np.zeros(0, int)
    hr, hc = np.array([0, 1, 1]), np.array([0, 0, 1])
    kkt = KKT(2, 0, (hr, hc), (none, none))
    first = kkt.analysis.permutation[0]
    hv = np.array([small if first == 0 else 1.0, 1.0, small if first == 1 else 1.0])
    return kkt, (hr, hc), hv, first


@pytest.mark.parametrize("small", [1e-20, 1e-9])
@BOTH
def test_small_pivot_beside_its_row_is_delayed(small, KKT):
    """H = [[small, 1], [1, 1]] with the small diagonal eliminated first: no
    cancellation, but the row below would grow by 1 / small, beyond 1e12
    (1e-20) or 1e6 (1e-9, the bound for a variable's pivot), so the pivot
    counts as zero; the factorization orders again with that row last (K's
    true inertia (1, 1, 0), eigvalsh's, and NumPy's solution); the later
    factorizations keep that order, and diagonal_x = 1e-2 there changes
    nothing."""
    rng = np.random.default_rng(8)
    none = np.zeros(0, int)
    kkt, (hr, hc), hv, first = _small_diagonal_first(small, KKT)
    _check(kkt, 2, 0, (hr, hc, hv), (none, none, np.zeros(0)), np.zeros(2), np.zeros(0),
           rng, inertia=(1, 1, 0))
    assert kkt.analysis.n_delayed == 1 and kkt.analysis.permutation[-1] == first
    assert kkt.reanalyses == 2  # the pairs made again (none here), then the delay
    dx = np.where(np.arange(2) == first, 1e-2, 0.0)
    _check(kkt, 2, 0, (hr, hc, hv), (none, none, np.zeros(0)), dx, np.zeros(0), rng)
    assert kkt.reanalyses == 2


@BOTH
def test_two_by_two_pivot_with_a_zero_eigenvalue(KKT):
    """The pair [[-1, 1], [1, -1]] is singular (eigenvalues 0 and -2): one
    zero, one negative, and a finite solution."""
    kkt = KKT(1, 1, ([0], [0]), ([0], [0]))
    assert kkt.factor([-1.0], [1.0], [0.0], [1.0]) == (0, 1, 1)
    assert _eigen_inertia(np.array([[-1.0, 1.0], [1.0, -1.0]])) == (0, 1, 1)
    assert np.isfinite(kkt.solve([1.0, 2.0])).all()
    # nonsingular again: eigvalsh's inertia
    assert kkt.factor([-1.0], [1.0], [0.0], [0.5]) == _eigen_inertia(
        np.array([[-1.0, 1.0], [1.0, -0.5]]))


def _pendulum_nlp(method, free_duration, nodes=11, written=False):
    """The swing-up's NLP (exact Hessian); ``written``: its Hessian's pattern
    that of the model's derivatives as written (none expanded,
    ``EXPANDED_NODES = 0``: the rate's entries kept, whose terms in the
    forces cancel), as a model too large to expand has it."""
    from unittest import mock
    from kanedyn.numerics import _hessians
    from kanedyn.optimization._nlp import CollocationNLP
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend="numpy")
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    T = sm.Symbol("T") if free_duration else 3.0
    problem = kd.OptimalControlProblem(
        model, nodes=nodes, duration=T, lagrange=tau ** 2, initial={q: 0, u: 0},
        final={q: 2.0, u: 0}, method=method,
        **({"bounds": {T: (0.5, 10.0)}} if free_duration else {}))
    with mock.patch.object(_hessians, "EXPANDED_NODES", 0 if written else
                           _hessians.EXPANDED_NODES):
        return CollocationNLP(problem, hessian="exact")


def _pendulum_point(method, free_duration, nodes, seed, written=False):
    """``(nlp, rng, z, jacobian_values)``: the NLP (:func:`_pendulum_nlp`) at
    a random point (the duration 3 s when free)."""
    nlp = _pendulum_nlp(method, free_duration, nodes=nodes, written=written)
    rng = np.random.default_rng(seed)
    z = rng.normal(size=nlp.n)
    if free_duration:
        z[-1] = 3.0
    return nlp, rng, z, nlp.jacobian(z)


@pytest.mark.parametrize("method", ["trapezoid", "hermite-simpson"])
@pytest.mark.parametrize("free_duration", [False, True])
@BOTH
def test_pendulum_collocation_kkt(method, free_duration, KKT):
    """The KKT matrix of a pendulum swing-up's NLP (exact Hessian at random
    multipliers): with a regularized Hessian the inertia is (n, m, 0) and
    the solve NumPy's, with d_c = 0 and with a small static d_c; with H
    made indefinite the negative pivots are eigvalsh's."""
    nlp, rng, z, jv = _pendulum_point(method, free_duration, 11, 5)
    n, m = nlp.n, nlp.m
    hv = nlp.hessian(z, rng.normal(size=m), 1.0)
    (hr, hc), (jr, jc) = nlp.hessian_structure(), nlp.jacobian_structure()
    kkt = KKT(n, m, (hr, hc), (jr, jc))
    if free_duration and method == "hermite-simpson":
        assert kkt.analysis.n_dense >= 1  # the duration's column
    hessian, jacobian = (hr, hc, hv), (jr, jc, jv)
    H = _dense(n, 0, hessian, (jr[:0], jc[:0], jv[:0]), np.zeros(n), np.zeros(0))
    shift = max(0.0, -np.linalg.eigvalsh(H).min()) + 1.0
    for dc in (np.zeros(m), np.full(m, 1e-8)):
        _check(kkt, n, m, hessian, jacobian, np.full(n, shift), dc, rng, inertia=(n, m, 0))
    # no Hessian shift, no barrier, no regularization: where no pivot is zero,
    # the inertia is eigvalsh's (the free-duration trapezoid has none zero)
    K = _dense(n, m, hessian, jacobian, np.zeros(n), np.zeros(m))
    plain = kkt.factor(hv, jv, np.zeros(n), np.zeros(m))
    assert plain[2] > 0 or plain == _eigen_inertia(K)
    if free_duration and method == "trapezoid":
        _check(kkt, n, m, hessian, jacobian, np.zeros(n), np.zeros(m), rng)
    # the reduced Hessian not positive definite: more negative eigenvalues than m
    found = _check(kkt, n, m, hessian, jacobian, np.full(n, shift) - 2 * shift * (
        np.arange(n) % 3 == 0), np.zeros(m), rng)
    assert found[1] > m


@pytest.mark.parametrize("method", ["trapezoid", "hermite-simpson"])
@pytest.mark.parametrize("free_duration", [False, True])
@BOTH
def test_pendulum_kkt_as_the_interior_point_method_builds_it(method, free_duration, KKT):
    """Barrier terms (1e3) on the variables with a bound, none elsewhere (no
    Hessian regularization), d_c = 0, the multipliers zero (a first
    iteration) or random: no zero pivot, eigvalsh's inertia, NumPy's solve."""
    nlp, rng, z, jv = _pendulum_point(method, free_duration, 21, 6)
    n, m = nlp.n, nlp.m
    bounded = np.isfinite(nlp.x_lower) | np.isfinite(nlp.x_upper)
    dx = np.where(bounded, 1e3, 0.0)
    (hr, hc), (jr, jc) = nlp.hessian_structure(), nlp.jacobian_structure()
    kkt = KKT(n, m, (hr, hc), (jr, jc))
    for multipliers in (np.zeros(m), rng.normal(size=m)):
        hv = nlp.hessian(z, multipliers, 1.0)
        found = _check(kkt, n, m, (hr, hc, hv), (jr, jc, jv), dx, np.zeros(m), rng)
        assert found[2] == 0


def test_pendulum_order_finds_the_band():
    """The NLP's own layout has no band; the order gives L far fewer entries
    than the factor of the matrix in the NLP's own order would (the
    column counts of L in the identity order, from SciPy's dense LDLᵀ
    pattern of a quasi-definite matrix)."""
    import scipy.linalg
    nlp = _pendulum_nlp("trapezoid", True, nodes=41)
    n, m = nlp.n, nlp.m
    rng = np.random.default_rng(2)
    (hr, hc), (jr, jc) = nlp.hessian_structure(), nlp.jacobian_structure()
    hv, jv = rng.normal(size=hr.size), rng.normal(size=jr.size)
    kkt = SparseKKT(n, m, (hr, hc), (jr, jc))
    K = _dense(n, m, (hr, hc, hv), (jr, jc, jv), np.full(n, 50.0), np.ones(m))
    lower, _, _ = scipy.linalg.ldl(K)
    in_own_order = int(np.sum(np.abs(np.tril(lower, -1)) > 0))
    assert kkt.analysis.nnz_factor < in_own_order / 3


def _reduced_pendulum(nodes, seed=None, written=False):
    """``(nlp, reduced, x)``: the backward-Euler swing-up's NLP
    (:func:`_pendulum_nlp`), the reduced NLP the interior point sees (its
    fixed initial and final states left out) and the point ``x`` it was made
    at (zeros, or normal with ``seed``)."""
    from kanedyn.optimization.interior_point._options import settings
    from kanedyn.optimization.interior_point._reduced import ReducedNLP
    nlp = _pendulum_nlp("backward-euler", False, nodes=nodes, written=written)
    x = np.zeros(nlp.n) if seed is None else np.random.default_rng(seed).normal(size=nlp.n)
    return nlp, ReducedNLP(nlp, x, settings({})), x


def _caterpillar(spine, seed):
    """A randomly numbered tree: a path of ``spine`` nodes, a leaf on each,
    and 3 isolated nodes (the pattern, symmetric CSR, and each node's place
    along the path: the spine node's index, its leaf's index + 0.5)."""
    import scipy.sparse as sp
    size = 2 * spine + 3
    label = np.random.default_rng(seed).permutation(size)
    a = np.r_[np.arange(spine - 1), np.arange(spine)]
    b = np.r_[np.arange(1, spine), spine + np.arange(spine)]
    graph = sp.coo_matrix((np.ones(a.size), (label[a], label[b])), shape=(size, size))
    graph = (graph + graph.T).tocsr()
    place = np.full(size, -1.0)
    place[label[:spine]] = np.arange(spine)
    place[label[spine:2 * spine]] = np.arange(spine) + 0.5
    return graph, place


def test_reverse_cuthill_mckee_starts_at_an_end_of_the_band():
    """On a tree whose nodes all but the path's have degree 1 (so that a
    node of least degree may lie anywhere along it), the order runs from
    one end of the path to the other (bandwidth 3; SciPy's order, started
    at a leaf along the path, has 4), every node once (the isolated ones
    too); from ``start`` the order ends there."""
    from kanedyn.optimization.interior_point.kkt._ordering import reverse_cuthill_mckee
    for seed in range(5):
        graph, place = _caterpillar(200, seed)
        order = reverse_cuthill_mckee(graph)
        assert np.array_equal(np.sort(order), np.arange(graph.shape[0]))
        position = np.empty(graph.shape[0], dtype=int)
        position[order] = np.arange(order.size)
        rows, cols = graph.nonzero()
        assert np.abs(position[rows] - position[cols]).max() <= 3
        along = place[order][place[order] >= 0]
        assert abs(np.corrcoef(along, np.arange(along.size))[0, 1]) > 0.99
        middle = int(np.flatnonzero(place == 100.5)[0])
        assert reverse_cuthill_mckee(graph, start=middle)[-1] == middle


def test_the_order_kernels_refuse_patterns_that_do_not_fit():
    """The kernel's ``cuthill_mckee`` and ``compressed`` check their
    patterns before they index by them (a row longer than the node count,
    pointers that do not fit, a start or an entry out of range)."""
    from kanedyn.optimization.interior_point.kkt._kernel import kernel
    k, i32 = kernel(), (lambda *a: np.array(a, dtype=np.int32))
    order = np.empty(2, dtype=np.int32)
    for indptr, indices, start in (((0, 1, 2), (1, 0), 2), ((0, 1), (1,), -1),
                                   ((0, 3, 3), (1, 1, 1), -1), ((0, 1, 2), (1, 5), -1)):
        with pytest.raises(ValueError, match="cuthill_mckee"):
            k.cuthill_mckee(order, i32(*indptr), i32(*indices), start)
    k.cuthill_mckee(order, i32(0, 1, 2), i32(1, 0), 1)
    assert order.tolist() == [1, 0]
    with pytest.raises(ValueError, match="outside the node array"):
        k.compressed(i32(0, 1), 2, (i32(0), i32(2), 0))
    with pytest.raises(ValueError, match="beyond n_nodes"):
        k.compressed(i32(0, 3), 2, (i32(0), i32(1), 0))
    with pytest.raises(ValueError, match="mask not of the entries' length"):
        k.compressed(i32(0, 1), 2, (i32(0), i32(1), 0, np.ones(2, dtype=bool)))
    with pytest.raises(ValueError, match="rows: runs that do not make"):
        k.csr(2, 2, False, ((np.array([[2, 2, 0]]), i32(0, 1)), i32(0, 1, 0, 1), 0))


def test_the_band_is_as_narrow_at_many_nodes_as_at_few():
    """The backward-Euler swing-up's envelope, as the interior point sees
    the NLP (its fixed initial and final states left out), has as many
    entries a node at 2,000 nodes as at 200: the band runs from an end
    (SciPy's RCM, started at a node of least degree in the middle, gives
    27.8 a node at 2,000 and 15.9 at 200)."""
    per_node = []
    for nodes in (200, 2000):
        _, reduced, _ = _reduced_pendulum(nodes)
        kkt = EnvelopeKKT(reduced.n, reduced.m, reduced.hessian_structure(),
                          reduced.jacobian_structure)
        per_node.append(kkt.analysis.nnz_factor / nodes)
    assert per_node[1] < 1.02 * per_node[0]


@BOTH
def test_pairs_made_only_through_entries_not_zero_at_the_start(KKT):
    """The backward-Euler swing-up's defect rows hold their derivatives by
    every state and input of their node, some zero whatever the point (the
    angle's row by the torque).  At 200 nodes, with the interior point's
    start system (no Hessian, unit diagonal), the order made from the
    pattern alone pairs a row through such an entry and meets its zero
    pivot (a new order); made from the entries not zero at the start
    (``pairable_entries``) it does not, and the inertia is the same.  (The
    Hessian's pattern as written, the rate's entries kept: with them the rate
    has a diagonal the order may pair around.)"""
    from kanedyn.optimization.interior_point.kkt._sparse import pairable_entries
    nlp, reduced, x = _reduced_pendulum(200, seed=3, written=True)
    n, m = reduced.n, reduced.m
    hessian, jacobian = reduced.hessian_structure(), reduced.jacobian_structure
    jv = reduced.kept_jacobian(np.asarray(nlp.jacobian(x), dtype=float))
    pairable = pairable_entries(m, jacobian[0], jv)
    assert 0 < np.count_nonzero(~pairable) < jv.size
    inertia = []
    for given in ({}, {"pairable": pairable}):
        kkt = KKT(n, m, hessian, jacobian, **given)
        inertia.append(kkt.factor(np.zeros(hessian[0].size), jv, np.ones(n), np.zeros(m)))
        assert kkt.reanalyses == (0 if given else 1)
    assert inertia == [(n, m, 0)] * 2
    with pytest.raises(ValueError, match="pairable must be a boolean array of shape"):
        KKT(n, m, hessian, jacobian, pairable=pairable[:-1])


@BOTH
def test_a_zero_pivot_of_the_backward_sweep_is_swept_forward(KKT):
    """The backward-Euler swing-up at 20,000 nodes, its final state fixed:
    the interior point's start system (no Hessian, unit diagonal), swept
    backward, meets a zero pivot at the last nodes (the last rate's defect
    paired through the torque's entry h, 1/h^2 on the last free rate).  The
    pairs made again do not help (made of the same entries as the
    constructor's, given them, they are not made again); the band swept
    forward does: K's inertia
    (n positive, m negative: J has full row rank), no row delayed, and the
    envelope no longer than before (delayed to the end, each of the two
    rows would span the band: 10 entries a node more)."""
    nodes = 20_000
    nlp, reduced, _ = _reduced_pendulum(nodes)
    n, m = reduced.n, reduced.m
    jv = reduced.kept_jacobian(np.asarray(nlp.jacobian(reduced.start_full()), dtype=float))
    kkt = KKT(n, m, reduced.hessian_structure(), reduced.jacobian_structure)
    swept_backward = kkt.analysis.nnz_factor
    assert kkt.factor(np.zeros(reduced.hessian_size), jv, np.ones(n), np.zeros(m)) == (n, m, 0)
    assert kkt.reanalyses == 2 and kkt.analysis.n_delayed == 0
    assert kkt.analysis.nnz_factor <= 1.001 * swept_backward < 16.1 * nodes
    # given the start's pairable entries, as the interior point gives them, the
    # pairs made again would be the constructor's: not made, swept forward at once
    from kanedyn.optimization.interior_point.kkt._sparse import pairable_entries
    given = KKT(n, m, reduced.hessian_structure(), reduced.jacobian_structure,
                pairable=pairable_entries(m, reduced.jacobian_structure[0], jv))
    assert given.factor(np.zeros(reduced.hessian_size), jv, np.ones(n), np.zeros(m)) == \
        (n, m, 0)
    assert given.reanalyses == 1 and given.analysis.n_delayed == 0
    assert given.analysis.nnz_factor < 16.1 * nodes


def test_the_envelope_holds_the_band_in_less_memory():
    """The backward-Euler swing-up's KKT matrix in the pairs' order is a
    band that L nearly fills: its envelope holds the sparse L's entries and
    an eighth more at most (L's zeros inside the band, where the Hessian's
    pattern leaves out second derivatives identically zero), K the same
    entries counted both ways, and the envelope's storage (values only, no
    copy of K, no maps or tree) under 0.6 of the sparse one's; the
    solutions agree to rounding.  (The Hessian's pattern as written: without
    the rate's entries the envelope holds 13 % more than L at 41 nodes.)"""
    nlp, rng, z, jv = _pendulum_point("backward-euler", False, 41, 3, written=True)
    n, m = nlp.n, nlp.m
    (hr, hc), (jr, jc) = nlp.hessian_structure(), nlp.jacobian_structure()
    hv = nlp.hessian(z, rng.normal(size=m), 1.0)
    sparse, envelope = (KKT(n, m, (hr, hc), (jr, jc)) for KKT in (SparseKKT, EnvelopeKKT))
    a, b = sparse.analysis, envelope.analysis
    assert a.nnz_factor <= b.nnz_factor <= 1.125 * a.nnz_factor
    assert b.nnz_matrix == a.nnz_matrix
    held = [x.bytes_factor + x.bytes_maps + x.bytes_workspace for x in (a, b)]
    assert held[1] < 0.6 * held[0]
    dx = np.full(n, 10.0)
    assert sparse.factor(hv, jv, dx, np.zeros(m)) == envelope.factor(hv, jv, dx, np.zeros(m))
    assert b.bytes_factor == sum(x.nbytes for x in envelope._numeric + (envelope._rowptr,))
    rhs = rng.normal(size=n + m)
    expected = sparse.solve(rhs)
    np.testing.assert_allclose(envelope.solve(rhs), expected, rtol=0,
                               atol=1e-12 * np.abs(expected).max())


def _random_case(seed):
    """A small random KKT with what makes new orders: dense rows, zero
    diagonals or Jacobian values, tiny or negative diagonals, any order."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 25))
    m = int(rng.integers(0, min(n, 15) + 1))
    hr, hc, jr, jc = _random_kkt(rng, n, max(m, 1), per_row=int(rng.integers(1, 4)))
    if not m:
        jr = jc = np.zeros(0, int)
    if rng.random() < 0.3:  # a dense Hessian row
        hr = np.concatenate([hr, np.full(n - 1, n - 1)])
        hc = np.concatenate([hc, np.arange(n - 1)])
    hv, jv = rng.normal(size=hr.size), rng.normal(size=jr.size)
    mode = rng.integers(0, 3)
    if mode == 1:
        hv[hr == hc] = 0.0
    elif mode == 2:
        jv[rng.random(jv.size) < 0.3] = 0.0
    dx = rng.choice([0.0, 1.0, -1.0, 1e-20], n) * rng.uniform(0.5, 2.0, n)
    dc = rng.choice([0.0, 1e-3, 1.0], m)
    ordering = ("pairs", "rcm", "pairs-mmd")[int(rng.integers(0, 3))]
    return n, m, (hr, hc), (jr, jc), (hv, jv, dx, dc), ordering, rng


def test_the_envelope_makes_the_sparse_factorizations_decisions():
    """On 150 random KKTs, many singular or made so by the order (zero
    diagonals and Jacobian values, dense rows, all three orders): the
    envelope storage reports the sparse one's inertia, new analyses,
    delayed rows and final order, K's own product, and the same solution
    where no pivot was zero (to 1e-8 of its size: the sums' order differs)."""
    counts = {"reanalysed": 0, "delayed": 0, "zero": 0}
    for seed in range(150):
        n, m, hessian, jacobian, values, ordering, rng = _random_case(seed)
        sparse, envelope = (KKT(n, m, hessian, jacobian, ordering=ordering)
                            for KKT in (SparseKKT, EnvelopeKKT))
        inertia = sparse.factor(*values)
        assert envelope.factor(*values) == inertia, seed
        assert envelope.reanalyses == sparse.reanalyses, seed
        assert envelope.analysis.n_delayed == sparse.analysis.n_delayed, seed
        assert np.array_equal(envelope.analysis.permutation, sparse.analysis.permutation)
        rhs = rng.normal(size=n + m)
        K = _dense(n, m, hessian + values[:1], jacobian + values[1:2], *values[2:])
        np.testing.assert_allclose(envelope.matvec(rhs), K @ rhs, rtol=1e-13,
                                   atol=1e-13 * np.abs(K).max())
        x, expected = envelope.solve(rhs), sparse.solve(rhs)
        assert np.isfinite(x).all()
        if not inertia[2]:
            assert np.linalg.norm(x - expected) <= 1e-8 * np.linalg.norm(expected), seed
        counts["reanalysed"] += sparse.reanalyses > 0
        counts["delayed"] += sparse.analysis.n_delayed > 0
        counts["zero"] += inertia[2] > 0
    assert min(counts.values()) >= 10, counts  # the cases this test is for


def test_the_envelope_keeps_structures_that_cannot_change():
    """The envelope indexes its storage by the structures at every call, so
    it keeps them read-only: a caller's writeable arrays are copied (changing
    them afterwards changes nothing), read-only int32 ones, as the interior
    point's reduced NLP makes them, are kept as they are (no copy)."""
    n = 6
    hr, hc = np.arange(n, dtype=np.int32), np.arange(n, dtype=np.int32)
    none = np.zeros(0, np.int32)
    kkt = EnvelopeKKT(n, 0, (hr, hc), (none, none))
    assert kkt.analysis.nnz_factor == 0  # a diagonal H: an empty envelope
    hr[0] = 5  # the caller reuses its array: (5, 0) would lie outside the envelope
    assert kkt.factor(np.ones(n), np.zeros(0), np.full(n, 2.0), np.zeros(0)) == (n, 0, 0)
    np.testing.assert_array_equal(kkt.matvec(np.ones(n)), np.full(n, 3.0))
    kept = kkt._hessian_structure
    assert kept[0] is not hr and not any(a.flags.writeable for a in kept)
    nlp = _pendulum_nlp("trapezoid", False, nodes=5)
    from kanedyn.optimization.interior_point._reduced import ReducedNLP
    from kanedyn.optimization.interior_point._options import settings
    reduced = ReducedNLP(nlp, np.zeros(nlp.n), settings({}), exact_hessian=True)
    hessian, jacobian = reduced.hessian_structure(), reduced.jacobian_structure
    kkt = EnvelopeKKT(reduced.n, reduced.m, hessian, jacobian)
    assert all(kept is given for ours, theirs in zip(kkt._structures(), (hessian, jacobian))
               for kept, given in zip(ours, theirs))


@pytest.mark.parametrize("shape, size", [((7, 5), 30), ((5, 7), 30), ((6, 0), 0),
                                         ((0, 4), 0), ((400, 300), 60_000)])
def test_ordering_patterns_are_scipys(shape, size):
    """The order's patterns, built directly, hold the arrays of SciPy's own
    COO to CSR conversion (repeats summed, indices sorted) and of its
    slicing, on which the matching and RCM depend: columns kept at random,
    all but an empty one (the entries renumbered in place) and all."""
    import scipy.sparse as sp
    from kanedyn.optimization.interior_point.kkt._ordering import _pattern, _submatrix
    rng = np.random.default_rng(7)
    m, n = shape
    rows, cols = rng.integers(0, max(m, 1), size), rng.integers(0, max(n - 1, 1), size)
    ours = _pattern(shape, rows, cols)  # the largest by SciPy's conversion
    theirs = sp.csr_matrix((np.ones(size, dtype=np.int8), (rows, cols)), shape=shape)
    theirs.sum_duplicates()
    assert np.array_equal(ours.indptr, theirs.indptr)
    assert np.array_equal(ours.indices, theirs.indices)
    keep_rows = np.flatnonzero(rng.random(m) < 0.6)
    # the last column is empty (when there are two or more)
    for keep_cols in (np.flatnonzero(rng.random(n) < 0.6), np.arange(max(n - 1, 0)),
                      np.arange(n)):
        for r, expected in ((None, theirs[:, keep_cols].tocsr()),
                            (np.arange(m), theirs[:, keep_cols].tocsr()),
                            (keep_rows, theirs[keep_rows][:, keep_cols].tocsr())):
            sub = _submatrix(ours, r, keep_cols)
            assert sub.shape == expected.shape
            assert np.array_equal(sub.indptr, expected.indptr)
            assert np.array_equal(sub.indices, expected.indices)


def _simple():
    return SparseKKT(3, 2, ([0, 1, 2, 2], [0, 0, 2, 1]), ([0, 1, 1], [0, 1, 2]))


@pytest.mark.parametrize("arguments, message", [
    ((-1, 2, ([0], [0]), ([0], [0])), "n must be"),
    ((3, 2.5, ([0], [0]), ([0], [0])), "m must be"),
    ((3, 2, ([0, 1], [0]), ([0], [0])), "hessian_structure: rows and cols differ"),
    ((3, 2, ([0], [-1]), ([0], [0])), r"hessian_structure: cols\[0\] = -1"),
    ((3, 2, ([3], [0]), ([0], [0])), r"hessian_structure: rows\[0\] = 3"),
    ((3, 2, ([0, 1], [0, 2]), ([0], [0])), "hessian_structure: entry 1 .* above the diag"),
    ((3, 2, ([0], [0]), ([2], [0])), r"jacobian_structure: rows\[0\] = 2"),
    ((3, 2, ([0], [0]), ([0], [3])), r"jacobian_structure: cols\[0\] = 3"),
    ((3, 2, ([0.5], [0]), ([0], [0])), "hessian_structure: rows must hold integers"),
    ((3, 2, [[[0]], [[0]]], ([0], [0])), "hessian_structure: rows must be one-dim"),
    ((3, 2, ([0], [0], [0]), ([0], [0])), "hessian_structure must be a pair"),
])
def test_bad_structure(arguments, message):
    with pytest.raises(ValueError, match=message):
        SparseKKT(*arguments)


def test_bad_values_and_calls():
    kkt = _simple()
    good = (np.ones(4), np.ones(3), np.ones(3), np.ones(2))
    with pytest.raises(ValueError, match="solve: nothing is factored"):
        kkt.solve(np.ones(5))
    with pytest.raises(ValueError, match="matvec: nothing is factored"):
        kkt.matvec(np.ones(5))
    for k, name in enumerate(("hessian_values", "jacobian_values", "diagonal_x",
                              "diagonal_c")):
        wrong = list(good)
        wrong[k] = np.ones(good[k].size + 1)
        with pytest.raises(ValueError, match=f"{name} must have shape"):
            kkt.factor(*wrong)
        wrong[k] = np.where(np.arange(good[k].size) == 1, np.nan, 1.0)
        with pytest.raises(ValueError, match=rf"{name}\[1\] is not finite"):
            kkt.factor(*wrong)
    with pytest.raises(ValueError, match=r"diagonal_c\[1\] = -0.5 is negative"):
        kkt.factor(good[0], good[1], good[2], [1.0, -0.5])
    # the diagonals as numbers, and added_x
    with pytest.raises(ValueError, match="diagonal_c = -0.5 is negative"):
        kkt.factor(good[0], good[1], good[2], -0.5)
    for k, name in ((2, "diagonal_x"), (3, "diagonal_c")):
        for wrong in (np.inf, "1.0", True):
            arguments = list(good)
            arguments[k] = wrong
            with pytest.raises(ValueError, match=f"{name} must be a finite number, not"):
                kkt.factor(*arguments)
    for wrong in (np.nan, [1.0], np.ones(1), None):
        with pytest.raises(ValueError, match="added_x must be a finite number, not"):
            kkt.factor(*good, added_x=wrong)
    kkt.factor(*good)
    with pytest.raises(ValueError, match="rhs must have shape"):
        kkt.solve(np.ones(4))
    with pytest.raises(ValueError, match="rhs holds a value that is not finite"):
        kkt.solve(np.array([1.0, np.inf, 0, 0, 0]))
    with pytest.raises(ValueError, match="x must have shape"):
        kkt.matvec(np.ones((5, 1)))
    with pytest.raises(ValueError, match="ordering must be one of"):
        SparseKKT(3, 2, ([0], [0]), ([0], [0]), ordering="amd")
    with pytest.raises(ValueError, match="zero_pivot must be"):
        SparseKKT(3, 2, ([0], [0]), ([0], [0]), zero_pivot=-1.0)


def test_no_compiler(monkeypatch):
    """Without a C compiler the kernel cannot be built: CompilerError."""
    monkeypatch.setenv("CC", "kanedyn-no-such-compiler")
    with pytest.raises(CompilerError, match="kanedyn-no-such-compiler"):
        _simple()


# ------------------------------------------ the matrices the solver factors
def _factored_by_the_solver(problem, guess, max_iter, monkeypatch):
    """Every ``(n, m, structures, values)`` the interior-point solver gave
    ``SparseKKT.factor`` in ``max_iter`` iterations of ``problem`` (the
    exact Hessian, ``linear_solver="sparse"``), in order (a diagonal given
    by its entries made dense)."""
    from kanedyn.optimization.interior_point.kkt import _sparse as _kkt_sparse
    from kanedyn.optimization.interior_point.kkt._diagonal import dense_diagonal
    seen = []
    factor = _kkt_sparse.SparseKKT.factor

    def recording(self, *values):
        seen.append((self.n, self.m, self._structures(),
                     tuple(np.array(dense_diagonal(v), dtype=float) for v in values)))
        return factor(self, *values)
    monkeypatch.setattr(_kkt_sparse.SparseKKT, "factor", recording)
    problem.solve(guess, solver="interior-point", hessian="exact",
                  options={"max_iter": max_iter, "linear_solver": "sparse"})
    monkeypatch.undo()
    return seen


def _dense_of_factored(n, m, structures, values):
    """K as a dense array from ``factor``'s arguments ``values`` (the
    diagonals may be numbers, delta_w given after them)."""
    (hr, hc), (jr, jc) = structures
    hv, jv, dx, dc, *added_x = values
    dx = np.broadcast_to(dx, (n,)) + sum(added_x)
    return _dense(n, m, (hr, hc, hv), (jr, jc, jv), dx, np.broadcast_to(dc, (m,)))


def _numpy_inertia(n, m, structures, values):
    return _eigen_inertia(_dense_of_factored(n, m, structures, values))


def _each_by_a_new_factorization(seen):
    """Each matrix of ``seen`` (:func:`_factored_by_the_solver`) factored by
    a new ``SparseKKT`` and a new ``EnvelopeKKT``: eigvalsh's inertia, no
    zero eigenvalue."""
    for n, m, structures, values in seen:
        expected = _numpy_inertia(n, m, structures, values)
        assert expected[2] == 0
        for KKT in (SparseKKT, EnvelopeKKT):
            assert KKT(n, m, *structures).factor(*values) == expected


def _swing_up(nodes, method):
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import _ocp_peers as peers
    problem, _ = peers.pendulum_kanedyn(nodes, method, backend="numpy")
    return problem


def test_first_matrices_of_the_hermite_simpson_swing_up(monkeypatch):
    """The 50-node Hermite-Simpson swing-up from the straight line (the
    solver's test problem): its first KKT matrices, each factored by a new
    ``SparseKKT``, have eigvalsh's inertia, no zero pivot (the first
    Newton step's matrix had one in the order made before the values were
    known: a state left unpaired whose Hessian diagonal is 0 there)."""
    problem = _swing_up(50, "hermite-simpson")
    guess = problem.guess_line(inputs={problem.symbols.inputs[0]: 0.1})
    seen = _factored_by_the_solver(problem, guess, 2, monkeypatch)
    assert len(seen) >= 3
    _each_by_a_new_factorization(seen)


@pytest.mark.slow
def test_first_matrices_of_the_gallery_swing_up_from_a_random_guess(monkeypatch):
    """The 501-node backward-Euler swing-up from opty's random guess
    (``benchmarks/bench_optimal_control.py``): its first KKT matrices have
    eigvalsh's inertia (the first had a zero pivot: a pair made through a
    Jacobian entry of the pattern whose value is 0)."""
    problem = _swing_up(501, "backward-euler")
    guess = np.random.default_rng(0).normal(size=3 * 501)
    seen = _factored_by_the_solver(problem, guess, 1, monkeypatch)
    assert np.any(seen[0][3][1] == 0.0)  # the pattern's zeros
    _each_by_a_new_factorization(seen)


@pytest.mark.slow
def test_every_matrix_of_a_trapezoid_swing_up_solve(monkeypatch):
    """Every KKT matrix the solver factors on the 100-node trapezoid
    swing-up to its optimum, factored by one ``SparseKKT`` and one
    ``EnvelopeKKT`` as the solver does: the signs of eigvalsh's eigenvalues
    each time (with the band swept forward in time the constraint rows'
    pivots grew to 2e13 beside entries of 21 near the upright end, and one
    counted as zero at the 41st Newton step's)."""
    problem = _swing_up(100, "trapezoid")
    guess = problem.guess_line(inputs={problem.symbols.inputs[0]: 0.1})
    seen = _factored_by_the_solver(problem, guess, 100, monkeypatch)
    assert len(seen) > 50
    n, m, structures, _ = seen[0]
    kkts = [KKT(n, m, *structures) for KKT in (SparseKKT, EnvelopeKKT)]
    for *_, values in seen:
        eigenvalues = np.linalg.eigvalsh(_dense_of_factored(n, m, structures, values))
        # some as small as 1e-11 of the largest: signs still far above rounding
        assert np.abs(eigenvalues).min() > 1e-13 * np.abs(eigenvalues).max()
        expected = (int(np.sum(eigenvalues > 0)), int(np.sum(eigenvalues < 0)), 0)
        assert [kkt.factor(*values) for kkt in kkts] == [expected] * 2


def test_the_band_sweeps_each_pair_before_its_rows_other_variables():
    """The pendulum's trapezoid NLP (41 nodes, fixed duration): most of the
    other variables of the paired constraint rows come after their pair in
    the order (a backward sweep, as the Riccati recursion), whichever way
    reverse Cuthill-McKee ran.  (The Hessian's pattern as written, each node's
    state block whole; of the pattern without the rate's entries half come
    after.)"""
    nlp = _pendulum_nlp("trapezoid", False, nodes=41, written=True)
    n, m = nlp.n, nlp.m
    (hr, hc), (jr, jc) = nlp.hessian_structure(), nlp.jacobian_structure()
    kkt = SparseKKT(n, m, (hr, hc), (jr, jc))
    permutation, kind = kkt.analysis.permutation, kkt._kind
    position = np.empty(n + m, dtype=int)
    position[permutation] = np.arange(n + m)
    partner = {int(permutation[k]) - n: int(permutation[k - 1])
               for k in np.flatnonzero(kind == 2)}
    assert len(partner) == m
    after = [position[c] > position[n + r] for r, c in zip(jr, jc) if c != partner[r]]
    assert np.mean(after) > 0.6  # 0.7: a row's state and input at the later node come first


def test_structures_recovered_from_the_maps():
    """An analysis again takes the structures from the maps (they are not
    kept): the constructor's, repeats included, entry for entry."""
    rng = np.random.default_rng(12)
    n, m = 25, 9
    hr, hc, jr, jc = _random_kkt(rng, n, m)
    kkt = SparseKKT(n, m, (hr, hc), (jr, jc))
    (hr2, hc2), (jr2, jc2) = kkt._structures()
    for found, given in ((hr2, hr), (hc2, hc), (jr2, jr), (jc2, jc)):
        np.testing.assert_array_equal(found, given)


@BOTH
def test_many_zero_pivots_are_not_delayed(KKT):
    """K = 0 (100 variables, no Hessian value, no constraint): eigvalsh's
    inertia (0, 0, 100); more zero pivots than ``MAX_DELAYED``, so none is
    delayed (each would make a long row of L) and the order stays."""
    from kanedyn.optimization.interior_point.kkt._sparse import MAX_DELAYED
    n = 100
    assert n > MAX_DELAYED
    none = np.zeros(0, int)
    chain = np.arange(n - 1)
    hr, hc = np.concatenate([chain + 1, np.arange(n)]), np.concatenate([chain, np.arange(n)])
    kkt = KKT(n, 0, (hr, hc), (none, none))
    hv = np.zeros(hr.size)
    K = _dense(n, 0, (hr, hc, hv), (none, none, np.zeros(0)), np.zeros(n), np.zeros(0))
    assert kkt.factor(hv, np.zeros(0), np.zeros(n), np.zeros(0)) == _eigen_inertia(K) \
        == (0, 0, n)
    assert kkt.analysis.n_delayed == 0


@BOTH
def test_an_analysis_is_kept_for_the_same_structure(KKT):
    """A second ``KKT`` of the same structure takes the first one's
    analysis (the same read-only arrays, ``kkt._analyses``), also the one
    after a zero pivot's new order, and factors to the same numbers; a
    different structure makes its own."""
    rng = np.random.default_rng(13)
    n, m = 30, 12
    hr, hc, jr, jc = _random_kkt(rng, n, m)
    hv, jv = rng.normal(size=hr.size), rng.normal(size=jr.size)
    dx, dc = np.zeros(n), np.zeros(m)
    hv[hr == hc] = 0.0  # zero diagonals: zero pivots, two analyses again
    first, second = KKT(n, m, (hr, hc), (jr, jc)), KKT(n, m, (hr, hc), (jr, jc))
    assert second.analysis.permutation is first.analysis.permutation
    assert not first.analysis.permutation.flags.writeable
    inertia = first.factor(hv, jv, dx, dc)
    assert second.factor(hv, jv, dx, dc) == inertia
    assert second.reanalyses == first.reanalyses
    assert second.analysis.permutation is first.analysis.permutation
    rhs = rng.normal(size=n + m)
    assert np.array_equal(second.solve(rhs), first.solve(rhs))
    other = KKT(n, m, (hr, hc), (jr[:-1], jc[:-1]))
    assert other.analysis.permutation is not first.analysis.permutation


def test_the_kernels_check_of_values_is_numpys():
    """The kernel's ``invalid`` (``factor``'s and ``solve``'s checks in one
    call) against NumPy: the first entry not finite, the arrays in turn,
    else the first negative one in the arrays from ``nonnegative`` on, else
    ``None``."""
    from kanedyn.optimization.interior_point.kkt._kernel import kernel

    def numpys(arrays, nonnegative):
        for k, a in enumerate(arrays):
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:
                return k, int(bad[0])
        for k, a in enumerate(arrays[nonnegative:], start=nonnegative):
            bad = np.flatnonzero(a < 0.0)
            if bad.size:
                return k, int(bad[0])
        return None
    rng = np.random.default_rng(14)
    for _ in range(300):
        arrays = [rng.uniform(-0.2, 1.0, rng.integers(0, 6)) for _ in range(rng.integers(1, 5))]
        for a in arrays:
            a[rng.random(a.size) < 0.1] = rng.choice([np.nan, np.inf, -np.inf])
        nonnegative = int(rng.integers(0, len(arrays) + 1))
        assert kernel().invalid(*arrays, nonnegative) == numpys(arrays, nonnegative)
    assert kernel().invalid(np.ones((2, 3)), np.zeros(0), 0) is None
    assert kernel().invalid(np.array([[1.0, 2.0], [np.nan, 0.0]]), 1) == (0, 2)


def test_the_kernels_error_reductions_are_numpys_to_the_bit():
    """The kernel's ``error_reductions`` (the interior point's optimality
    error's sums and maxima in one call) against
    ``_optimality.numpy_error_reductions``, bit for bit: lengths across
    NumPy's pairwise blocks (up to 128 entries, halves beyond), magnitudes
    over ten decades, empty arrays, a NaN, infinities; and the errors
    ``optimality_errors`` makes of either the same."""
    from kanedyn.optimization.interior_point.kkt._kernel import kernel
    from kanedyn.optimization.interior_point._optimality import (numpy_error_reductions,
                                                                 optimality_errors)
    rng = np.random.default_rng(15)

    def values(size):
        return rng.normal(size=size) * 10.0 ** rng.integers(-5, 5, size=size)
    for trial in range(400):
        sizes = rng.integers(0, 700, size=5)
        dual, c, y = values(sizes[0]), values(sizes[1]), values(sizes[2])
        z_lower, z_upper = np.abs(values(sizes[3])), np.abs(values(sizes[4]))
        gap_lower, gap_upper = np.abs(values(sizes[3])), np.abs(values(sizes[4]))
        if trial % 7 == 0 and dual.size and z_lower.size:
            dual[rng.integers(dual.size)] = np.nan
            z_lower[rng.integers(z_lower.size)] = np.inf
        arguments = (dual, c, y, z_lower, z_upper, gap_lower, gap_upper,
                     float(rng.uniform(1e-11, 0.1)))
        with np.errstate(all="ignore"):  # the solver's (an infinity times 0)
            pairs = [(kernel().error_reductions(*arguments),
                      numpy_error_reductions(*arguments)),
                     (vars(optimality_errors(*arguments, kernel().error_reductions)).values(),
                      vars(optimality_errors(*arguments)).values())]
        for found, expected in pairs:
            found, expected = np.array(list(found)), np.array(list(expected), dtype=float)
            assert np.array_equal(found, expected, equal_nan=True), trial
            assert np.array_equal(np.signbit(found), np.signbit(expected)), trial


@BOTH
def test_release_drops_the_factors_until_the_next_factor(KKT):
    """After ``release`` (the interior point's call at each new point) ``solve``
    and ``matvec`` refuse; the next ``factor`` makes the storage again and
    gives the same inertia and solution to the bit."""
    rng = np.random.default_rng(3)
    n, m = 40, 15
    hr, hc, jr, jc = _random_kkt(rng, n, m)
    values = (rng.normal(size=hr.size), rng.normal(size=jr.size), np.full(n, 2.0),
              np.full(m, 0.5))
    kkt = KKT(n, m, (hr, hc), (jr, jc))
    inertia = kkt.factor(*values)
    rhs = rng.normal(size=n + m)
    solution, product = kkt.solve(rhs), kkt.matvec(rhs)
    kkt.release()
    assert kkt.inertia is None
    with pytest.raises(ValueError, match="solve: nothing is factored"):
        kkt.solve(rhs)
    with pytest.raises(ValueError, match="matvec: nothing is factored"):
        kkt.matvec(rhs)
    assert kkt.factor(*values) == inertia
    assert np.array_equal(kkt.solve(rhs), solution)
    assert np.array_equal(kkt.matvec(rhs), product)


@BOTH
def test_large_storage_is_made_after_the_freed_memory_is_handed_back(monkeypatch, KKT):
    """Numeric storage of at least ``RETURN_FREED_BYTES`` is made after the
    process's freed heap memory is handed back (once per storage made: not
    again for a factorization that reuses it); smaller storage is not."""
    from kanedyn.optimization.interior_point.kkt import _sparse as _kkt_sparse
    calls = []
    monkeypatch.setattr(_kkt_sparse, "_malloc_trim", lambda: lambda pad: calls.append(pad))
    kkt, rng = _factored(4, KKT=KKT)
    assert calls == []  # a few KB: below the threshold
    monkeypatch.setattr(_kkt_sparse, "RETURN_FREED_BYTES", 0)
    values = (rng.normal(size=kkt._entries[0]), rng.normal(size=kkt._entries[1]),
              np.full(kkt.n, 2.0), np.full(kkt.m, 0.5))
    kkt.factor(*values)  # the storage of the first factor reused
    assert calls == []
    kkt.release()
    kkt.factor(*values)
    kkt.factor(*values)
    assert calls == [0]


def _resident_bytes():
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def test_freed_heap_memory_is_handed_back_to_the_system():
    """What the interior point relies on (glibc): arrays of 2 MB made after
    glibc's mmap threshold rose past them come from the heap, and when freed
    below one still held their pages stay resident until
    ``_return_freed_memory`` hands them back (80 MB freed: at least 40
    handed back)."""
    from kanedyn.optimization.interior_point.kkt import _sparse as _kkt_sparse
    if _kkt_sparse._malloc_trim() is None or not os.path.exists("/proc/self/statm"):
        pytest.skip("glibc's malloc_trim and /proc are needed (Linux with glibc)")
    big = np.ones(2 ** 20)  # 8 MB, mapped; freed, it raises the mmap threshold past 2 MB
    del big
    arrays = [np.ones(2 ** 18) for _ in range(41)]  # 2 MB each, from the heap
    held = arrays.pop()  # the last one keeps the heap's top in place
    del arrays
    before = _resident_bytes()
    _kkt_sparse._return_freed_memory()
    assert before - _resident_bytes() > 40 * 2 ** 20
    del held


def _factored(seed, n=40, m=15, KKT=SparseKKT):
    """A ``KKT`` of a random structure, factored, and its random generator."""
    rng = np.random.default_rng(seed)
    hr, hc, jr, jc = _random_kkt(rng, n, m)
    kkt = KKT(n, m, (hr, hc), (jr, jc))
    kkt.factor(rng.normal(size=hr.size), rng.normal(size=jr.size), np.full(n, 2.0),
               np.full(m, 0.5))
    return kkt, rng


@BOTH
def test_solve_in_place_is_the_copying_solve(KKT):
    """``solve(rhs, overwrite=True)`` (the iterative refinement's) solves in
    ``rhs``'s storage and returns it, the copying solve's numbers to the bit;
    an ``rhs`` it cannot take (another dtype, not contiguous, 2-D, read-only)
    is copied and left as it was."""
    kkt, rng = _factored(7, KKT=KKT)
    rhs = rng.normal(size=kkt.size)
    expected = kkt.solve(rhs)
    b = rhs.copy()
    x = kkt.solve(b, overwrite=True)
    assert x is b
    assert np.array_equal(x, expected)
    read_only = rhs.copy()
    read_only.flags.writeable = False
    for other in (rhs.astype(np.float32), np.repeat(rhs, 2)[::2], rhs[:, None], read_only):
        before = other.copy()
        x = kkt.solve(other, overwrite=True)
        assert x is not other
        assert np.array_equal(other, before)
        assert np.array_equal(x, kkt.solve(other))


def test_column_pointers_are_int32_and_counted(monkeypatch):
    """K's and L's column pointers are int32 (4 bytes a row each), CSC of the
    entries that ``analysis`` counts, and ``bytes_factor`` is what the
    factor's arrays hold; an L with more entries than they reach is refused
    by its size (here a limit lowered to the size of a 12 x 12 dense L)."""
    from collections import OrderedDict

    from kanedyn.optimization.interior_point.kkt import _analyses as _kkt_analyses
    from kanedyn.optimization.interior_point.kkt import _sparse as _kkt_sparse
    kkt, _ = _factored(11)
    a, N = kkt.analysis, kkt.size
    for pointers, entries in ((kkt._Ap, a.nnz_matrix), (kkt._Lp, a.nnz_factor)):
        assert pointers.dtype == np.int32 and pointers.shape == (N + 1,)
        assert pointers[0] == 0 and pointers[-1] == entries
        assert (np.diff(pointers) >= 0).all()
    _, Li, Lx, D, E = kkt._numeric
    assert a.bytes_factor == sum(x.nbytes for x in (Li, Lx, kkt._Lp, D, E))
    monkeypatch.setattr(_kkt_analyses, "_KEPT", OrderedDict())  # no kept analysis
    monkeypatch.setattr(_kkt_sparse, "_LIMIT", 66)
    hr, hc = np.tril_indices(12)
    with pytest.raises(ValueError, match="L would have 66 entries, too many for 32-bit"):
        SparseKKT(12, 0, (hr, hc), ([], []))
    with pytest.raises(ValueError, match="envelope would have 66 entries, too many"):
        EnvelopeKKT(12, 0, (hr, hc), ([], []))
    monkeypatch.setattr(_kkt_sparse, "_LIMIT", 67)
    assert SparseKKT(12, 0, (hr, hc), ([], [])).analysis.nnz_factor == 66
    assert EnvelopeKKT(12, 0, (hr, hc), ([], [])).analysis.nnz_factor == 66


def _traced_analysis(nodes):
    """``(held, peak)``, bytes traced by ``tracemalloc`` above the start, of
    a ``SparseKKT`` of the backward-Euler swing-up's KKT pattern at
    ``nodes`` (as the interior point's reduced NLP gives it)."""
    import tracemalloc
    from kanedyn.optimization._nlp import CollocationNLP
    from kanedyn.optimization.interior_point._options import settings
    from kanedyn.optimization.interior_point._reduced import ReducedNLP
    definition = kd.models.build("pendulum", torque=True)
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    problem = kd.OptimalControlProblem(
        definition.numeric(backend="numpy"), nodes=nodes, duration=10.0,
        lagrange=tau ** 2, bounds={tau: (-2.0, 2.0)}, initial={q: 0.0, u: 0.0},
        final={q: np.pi, u: 0.0}, method="backward-euler")
    reduced = ReducedNLP(CollocationNLP(problem, hessian="exact"),
                         np.zeros(problem.n_variables), settings({}))
    structures = (reduced.n, reduced.m, reduced.hessian_structure(),
                  reduced.jacobian_structure)
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        kkt = SparseKKT(*structures)
        held, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert kkt.analysis.nnz_factor > 0
    return held - start, peak - start


def test_the_analysis_holds_little_and_makes_no_larger_temporaries():
    """The analysis of the swing-up's KKT pattern (5 rows a node) holds at most
    450 bytes a node (the order, K's pattern and maps, L's column pointers,
    the elimination tree: measured 145; 251 while the Hessian's pattern held
    the rate's entries whose terms cancel, 291 then with int64 column
    pointers; K's values, L and D come with the first factor) and allocates
    at most 800 bytes a node above that while it works (traced by
    ``tracemalloc``, the difference of two node counts; measured 132; 570,
    530 with int64 pointers, with the rate's entries:
    the peak, in the order, is the same, 821 bytes a node, and less is held
    after it; 1,121 held and 1,860 above when the patterns were made through
    int64 copies and SciPy's COO conversions and K's values and the factors
    were allocated here)."""
    _traced_analysis(50)  # the kernel loaded, imports done
    (held_1, peak_1), (held_2, peak_2) = _traced_analysis(2000), _traced_analysis(6000)
    held, above = (held_2 - held_1) / 4000, ((peak_2 - held_2) - (peak_1 - held_1)) / 4000
    assert 100 < held <= 450
    assert above <= 800


def test_a_diagonal_given_by_its_entries_factors_as_its_array():
    """On 60 random KKTs (singular ones too, all three orders), a
    ``diagonal_x`` given as :class:`DiagonalEntries` (its nonzero entries,
    the interior point's barrier on the bounded variables) gives the
    inertia, the new orders, the solution and K's product of its array to
    the bit, with and without ``added_x``, on both storages and on
    ``DenseKKT``."""
    from kanedyn.optimization.interior_point.kkt._diagonal import DiagonalEntries
    for seed in range(60):
        n, m, hessian, jacobian, (hv, jv, dx, dc), ordering, rng = _random_case(seed)
        index = np.flatnonzero(dx).astype(np.int32)
        entries = DiagonalEntries(index, dx[index], n)
        np.testing.assert_array_equal(entries.dense(), dx)
        added = float(rng.choice([0.0, 1e-4]))
        rhs = rng.normal(size=n + m)
        for KKT in (SparseKKT, EnvelopeKKT):
            given, dense = (KKT(n, m, hessian, jacobian, ordering=ordering) for _ in range(2))
            assert given.factor(hv, jv, entries, dc, added) == \
                dense.factor(hv, jv, dx, dc, added), seed
            assert given.reanalyses == dense.reanalyses
            assert np.array_equal(given.analysis.permutation, dense.analysis.permutation)
            assert np.array_equal(given.solve(rhs), dense.solve(rhs), equal_nan=True), seed
            assert np.array_equal(given.matvec(rhs), dense.matvec(rhs), equal_nan=True), seed
        reference = DenseKKT(n, m, hessian, jacobian)
        assert reference.factor(hv, jv, entries, dc, added) == \
            DenseKKT(n, m, hessian, jacobian).factor(hv, jv, dx, dc, added)


@BOTH
def test_a_diagonals_entries_must_increase_within_the_variables(KKT):
    """An index of ``DiagonalEntries`` that repeats, decreases or leaves
    0..n - 1, or a size other than n, is refused, naming diagonal_x."""
    from kanedyn.optimization.interior_point.kkt._diagonal import DiagonalEntries
    rng = np.random.default_rng(4)
    n, m = 6, 2
    hr, hc, jr, jc = _random_kkt(rng, n, m)
    kkt = KKT(n, m, (hr, hc), (jr, jc))
    hv, jv = rng.normal(size=hr.size), rng.normal(size=jr.size)
    for index in ([1, 1], [3, 2], [0, 6], [-1, 2]):
        entries = DiagonalEntries(np.array(index, dtype=np.int32), np.ones(2), n)
        with pytest.raises(ValueError, match="diagonal_x's index"):
            kkt.factor(hv, jv, entries, 0.0)
    with pytest.raises(ValueError, match="diagonal_x must have 6 entries, not 7"):
        kkt.factor(hv, jv, DiagonalEntries(np.array([1], np.int32), np.ones(1), 7), 0.0)
    with pytest.raises(ValueError, match=r"diagonal_x\[1\] is not finite"):
        kkt.factor(hv, jv, DiagonalEntries(np.array([1, 2], np.int32),
                                           np.array([1.0, np.nan]), n), 0.0)
