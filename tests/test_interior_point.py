"""kanedyn's interior-point NLP solver (``solver="interior-point"``), checked
against what shares none of its code:

- small NLPs written here as tiny objects of the solver interface: an
  equality-constrained QP against its KKT system solved by NumPy,
  Hock-Schittkowski 71 against its published optimum, a problem with
  inequality rows and an active bound against its closed form, infeasible
  constraints, a stop request, a non-finite value, the options' refusals;
- ``DenseKKT``'s inertia and solves against NumPy's eigenvalues and solve;
- kanedyn's optimal control problems against IPOPT's optimum of the same
  NLP (the exact Hessian for both): the pendulum and cart-pole swing-ups
  (trapezoid, Hermite-Simpson), a least-time problem, a free parameter at its
  bound, an epigraph with path constraints (closed form 4); a two-phase
  problem against its closed form; a warm start from IPOPT's multipliers.

The optimal control comparisons need cyipopt (IPOPT); without it they are
skipped, saying so.
"""

import functools
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sm

import kanedyn as kd
from kanedyn.optimization._solvers import SOLVERS
from kanedyn.optimization.interior_point import DenseKKT, InteriorPoint
from kanedyn.optimization.interior_point.kkt._diagonal import DiagonalEntries

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

DENSE = {"linear_solver": "dense"}
NO_BOUND = 2e19


def _ipopt_or_skip():
    pytest.importorskip("cyipopt", reason="the comparison with IPOPT needs cyipopt "
                        "(pip install 'kanedyn[optimal]', part of the test extra)")


class _NLP:
    """An NLP of the solver interface from plain functions; the Hessian's
    lower triangle dense."""

    exact_hessian = True

    def __init__(self, n, m, f, grad, g, jac, hess, x_lower=None, x_upper=None,
                 g_lower=(), g_upper=()):
        self.n, self.m = n, m
        self.x_lower = np.full(n, -NO_BOUND) if x_lower is None else np.asarray(x_lower, float)
        self.x_upper = np.full(n, NO_BOUND) if x_upper is None else np.asarray(x_upper, float)
        self.g_lower, self.g_upper = np.asarray(g_lower, float), np.asarray(g_upper, float)
        self._f, self._grad, self._g, self._jac, self._hess = f, grad, g, jac, hess
        self.calls = 0

    def objective(self, x):
        self.calls += 1
        return self._f(x)

    def gradient(self, x):
        return np.asarray(self._grad(x), float)

    def constraints(self, x):
        return np.asarray(self._g(x), float)

    def jacobian_structure(self):
        return np.repeat(np.arange(self.m), self.n), np.tile(np.arange(self.n), self.m)

    def jacobian(self, x):
        return np.asarray(self._jac(x), float).ravel()

    def hessian_structure(self):
        return np.tril_indices(self.n)

    def hessian(self, x, multipliers, objective_factor):
        return np.asarray(self._hess(x, multipliers, objective_factor), float)[
            np.tril_indices(self.n)]


def _solve(nlp, x0, options=None, **keywords):
    return InteriorPoint().solve(nlp, np.asarray(x0, float), dict(DENSE, **(options or {})),
                                 **keywords)


# ------------------------------------------------------------ small NLPs
def _equality_qp(seed=0, n=6, m=2):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    Q = A @ A.T + n * np.eye(n)
    c = rng.normal(size=n)
    B = rng.normal(size=(m, n))
    b = rng.normal(size=m)
    nlp = _NLP(n, m, lambda x: 0.5 * x @ Q @ x + c @ x, lambda x: Q @ x + c,
               lambda x: B @ x, lambda x: B, lambda x, y, s: s * Q, g_lower=b, g_upper=b)
    return nlp, Q, c, B, b


def test_equality_qp_closed_form():
    """min x'Qx/2 + c'x subject to Bx = b: the KKT system [[Q, B'], [B, 0]]
    solved by NumPy gives x and IPOPT's multipliers (Qx + c + B'y = 0)."""
    nlp, Q, c, B, b = _equality_qp()
    n, m = B.shape[1], B.shape[0]
    exact = np.linalg.solve(np.block([[Q, B.T], [B, np.zeros((m, m))]]), np.r_[-c, b])
    found = _solve(nlp, np.zeros(n))
    assert found.status == 0 and found.status_text == "solved"
    assert np.max(np.abs(found.x - exact[:n])) < 1e-9
    assert np.max(np.abs(found.multipliers["g"] - exact[n:])) < 1e-8
    assert found.iterations <= 3  # a QP without bounds: Newton's step is exact
    assert found.solver == "interior-point" and found.wall_time > 0


def _hs71():
    def hessian(x, y, s):
        H = s * np.array([[2 * x[3], x[3], x[3], 2 * x[0] + x[1] + x[2]],
                          [x[3], 0, 0, x[0]], [x[3], 0, 0, x[0]],
                          [2 * x[0] + x[1] + x[2], x[0], x[0], 0]])
        p = np.prod(x)
        H = H + y[0] * np.array([[0 if i == j else p / (x[i] * x[j]) for j in range(4)]
                                 for i in range(4)])
        return H + 2 * y[1] * np.eye(4)
    return _NLP(
        4, 2, lambda x: x[0] * x[3] * np.sum(x[:3]) + x[2],
        lambda x: [x[3] * (2 * x[0] + x[1] + x[2]), x[0] * x[3], x[0] * x[3] + 1,
                   x[0] * np.sum(x[:3])],
        lambda x: [np.prod(x), x @ x], lambda x: np.vstack([np.prod(x) / x, 2 * x]), hessian,
        x_lower=np.ones(4), x_upper=np.full(4, 5.0), g_lower=[25.0, 40.0],
        g_upper=[NO_BOUND, 40.0])


#: Hock & Schittkowski (1981), problem 71: the published optimum
HS71_OBJECTIVE = 17.0140173
HS71_X = np.array([1.0, 4.7429994, 3.8211503, 1.3794082])


def test_hock_schittkowski_71_published_optimum():
    """HS71 from (1, 5, 5, 1): the published f* = 17.0140173 and x*; the
    product row active (its multiplier negative in IPOPT's convention), x_1
    at its lower bound (its multiplier positive).  With the bounds relaxed
    by 1e-8 (IPOPT's default ``bound_relax_factor``) x_1 sits 1e-8 below 1
    and the objective (df/dx_1 = 14) 1.5e-7 below f*; without, within the
    published digits."""
    exact = _solve(_hs71(), [1.0, 5.0, 5.0, 1.0], {"bound_relax_factor": 0.0})
    assert exact.status == 0, exact.status_text
    assert abs(exact.objective - HS71_OBJECTIVE) < 1e-7
    found = _solve(_hs71(), [1.0, 5.0, 5.0, 1.0])
    assert found.status == 0, found.status_text
    assert abs(found.objective - HS71_OBJECTIVE) < 3e-7
    assert np.max(np.abs(found.x - HS71_X)) < 1e-6
    assert found.multipliers["g"][0] < 0 < found.multipliers["x_lower"][0]
    assert np.all(found.multipliers["x_upper"] < 1e-6)


def ipopt_problem(nlp):
    """cyipopt's ``Problem`` of an NLP of the solver interface (skipped
    without cyipopt)."""
    cyipopt = pytest.importorskip("cyipopt", reason="the comparison needs cyipopt (IPOPT)")

    class Callbacks:
        objective, gradient = staticmethod(nlp.objective), staticmethod(nlp.gradient)
        constraints, jacobian = staticmethod(nlp.constraints), staticmethod(nlp.jacobian)
        hessian = staticmethod(nlp.hessian)

        def jacobianstructure(self):
            return nlp.jacobian_structure()

        def hessianstructure(self):
            return nlp.hessian_structure()

    return cyipopt.Problem(n=nlp.n, m=nlp.m, problem_obj=Callbacks(), lb=nlp.x_lower,
                           ub=nlp.x_upper, cl=nlp.g_lower, cu=nlp.g_upper)


def test_hock_schittkowski_71_same_as_ipopt():
    """The same optimum and multipliers as IPOPT's, in as many iterations
    (the same algorithm: the counts are IPOPT's)."""
    nlp = _hs71()
    problem = ipopt_problem(nlp)
    problem.add_option("print_level", 0)
    problem.add_option("sb", "yes")
    x, info = problem.solve(np.array([1.0, 5.0, 5.0, 1.0]))
    found = _solve(nlp, [1.0, 5.0, 5.0, 1.0])
    assert np.max(np.abs(found.x - x)) < 1e-8
    assert np.max(np.abs(found.multipliers["g"] - info["mult_g"])) < 1e-7
    assert np.max(np.abs(found.multipliers["x_lower"] - info["mult_x_L"])) < 1e-7
    assert found.iterations == 8  # IPOPT 3.14's count on HS71


def test_inequality_rows_and_an_active_bound_closed_form():
    """min (x1-3)^2 + (x2-2)^2 + (x3+1)^2 with x1 + x2 + x3 <= 2 (an
    inequality row), 0.5 <= x1 - x2 <= 10 (inactive), x3 >= 0 (active): x =
    (1.5, 0.5, 0), the row's multiplier 3, x3's bound multiplier 5, the
    objective 5.5 (1e-7 below with the bounds relaxed by 1e-8, IPOPT's
    default ``bound_relax_factor``)."""
    target = np.array([3.0, 2.0, -1.0])
    J = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, 0.0]])
    nlp = _NLP(3, 2, lambda x: np.sum((x - target) ** 2), lambda x: 2 * (x - target),
               lambda x: J @ x, lambda x: J, lambda x, y, s: 2 * s * np.eye(3),
               x_lower=[-NO_BOUND, -NO_BOUND, 0.0], g_lower=[-NO_BOUND, 0.5],
               g_upper=[2.0, 10.0])
    found = _solve(nlp, [0.0, 0.0, 0.0])
    assert found.status == 0, found.status_text
    assert np.max(np.abs(found.x - [1.5, 0.5, 0.0])) < 1e-7
    assert abs(found.multipliers["g"][0] - 3.0) < 1e-6
    assert abs(found.multipliers["g"][1]) < 1e-7
    assert abs(found.multipliers["x_lower"][2] - 5.0) < 1e-6
    assert abs(found.objective - 5.5) < 2e-7


def test_fixed_variable_and_its_multiplier():
    """A variable with equal bounds leaves the problem: min x1^2 + x2^2 with
    x2 = 1 fixed by its bounds and x1 + x2 >= 0: x = (0, 1), the fixed
    variable's multiplier the objective's gradient there (2, on its lower
    bound in IPOPT's convention)."""
    nlp = _NLP(2, 1, lambda x: x @ x, lambda x: 2 * x, lambda x: [x[0] + x[1]],
               lambda x: [[1.0, 1.0]], lambda x, y, s: 2 * s * np.eye(2),
               x_lower=[-NO_BOUND, 1.0], x_upper=[NO_BOUND, 1.0], g_lower=[0.0],
               g_upper=[NO_BOUND])
    found = _solve(nlp, [3.0, 0.0])
    assert found.status == 0
    assert found.x[1] == 1.0 and abs(found.x[0]) < 1e-7
    assert abs(found.multipliers["x_lower"][1] - 2.0) < 1e-6


def test_infeasible_constraints_are_reported():
    """x1 + x2 = 1 and x1 + x2 = 2 together: status 2 (infeasible), not a
    solution."""
    J = np.array([[1.0, 1.0], [1.0, 1.0]])
    nlp = _NLP(2, 2, lambda x: x @ x, lambda x: 2 * x, lambda x: J @ x, lambda x: J,
               lambda x, y, s: 2 * s * np.eye(2), g_lower=[1.0, 2.0], g_upper=[1.0, 2.0])
    found = _solve(nlp, [0.0, 0.0])
    assert found.status == 2, (found.status, found.status_text)
    assert "infeasible" in found.status_text
    # bounds that forbid the row: x <= 1 with x1 + x2 >= 3
    bounded = _NLP(2, 1, lambda x: x @ x, lambda x: 2 * x, lambda x: [x[0] + x[1]],
                   lambda x: [[1.0, 1.0]], lambda x, y, s: 2 * s * np.eye(2),
                   x_upper=[1.0, 1.0], g_lower=[3.0], g_upper=[NO_BOUND])
    found = _solve(bounded, [0.0, 0.0])
    assert found.status == 2, (found.status, found.status_text)


def test_stop_request_returns_the_current_iterate():
    """``stop()`` answering True at its fourth question: status 5 after
    three iterations, the iterate those three reach (as with max_iter=3)."""
    asked = []

    def stop():
        asked.append(1)
        return len(asked) >= 4
    stopped = _solve(_hs71(), [1.0, 5.0, 5.0, 1.0], stop=stop)
    assert stopped.status == 5 and stopped.status_text == "stopped on request"
    assert stopped.iterations == 3
    limited = _solve(_hs71(), [1.0, 5.0, 5.0, 1.0], {"max_iter": 3})
    assert limited.status == -1 and "maximum number of iterations" in limited.status_text
    assert np.array_equal(stopped.x, limited.x)
    assert not np.allclose(stopped.x, [1.0, 5.0, 5.0, 1.0])


def test_non_finite_values_are_status_minus_13():
    """nan from the objective at the start, or from the Hessian later: -13."""
    nlp, *_ = _equality_qp()
    bad = _NLP(nlp.n, nlp.m, lambda x: np.nan, nlp.gradient, nlp.constraints,
               lambda x: nlp.jacobian(x).reshape(nlp.m, nlp.n), lambda x, y, s: np.eye(nlp.n),
               g_lower=nlp.g_lower, g_upper=nlp.g_upper)
    found = _solve(bad, np.zeros(nlp.n))
    assert found.status == -13 and "invalid number" in found.status_text
    hs = _hs71()
    hs._hess = lambda x, y, s: np.full((4, 4), np.inf)
    found = _solve(hs, [1.0, 5.0, 5.0, 1.0])
    assert found.status == -13


def test_options_and_hessian_refused_with_their_names():
    nlp, *_ = _equality_qp()
    with pytest.raises(kd.OptionError, match="'tolerance'.*known:.*acceptable_tol"):
        _solve(nlp, np.zeros(nlp.n), {"tolerance": 1e-6})
    with pytest.raises(kd.OptionError, match=r"'max_itr' \(did you mean 'max_iter'\?\); known"):
        _solve(nlp, np.zeros(nlp.n), {"max_itr": 5})
    with pytest.raises(ValueError, match="linear_solver='mumps'"):
        _solve(nlp, np.zeros(nlp.n), {"linear_solver": "mumps"})
    with pytest.raises(ValueError, match="hessian_approximation='sr1'.*'limited-memory'"):
        _solve(nlp, np.zeros(nlp.n), {"hessian_approximation": "sr1"})
    with pytest.raises(ValueError, match="max_iter"):
        _solve(nlp, np.zeros(nlp.n), {"max_iter": 2.5})
    nlp.exact_hessian = None
    with pytest.raises(kd.OptionError, match='hessian_approximation=.exact.*hessian="exact"'):
        _solve(nlp, np.zeros(nlp.n), {"hessian_approximation": "exact"})


def test_print_level_prints_a_line_per_iteration(capsys):
    found = _solve(_hs71(), [1.0, 5.0, 5.0, 1.0], {"print_level": 1})
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].split()[:3] == ["iter", "objective", "inf_pr"]
    assert len(lines) == found.iterations + 2  # header, iterate 0 ... last
    assert float(lines[-1].split()[1]) == pytest.approx(HS71_OBJECTIVE, rel=1e-7)


def test_warm_start_from_its_own_multipliers():
    """From HS71's optimum and its multipliers (IPOPT's convention, as a
    solve returns them) the warm start converges at once to the same point."""
    cold = _solve(_hs71(), [1.0, 5.0, 5.0, 1.0])
    warm = _solve(_hs71(), cold.x, {"mu_init": 1e-9}, warm=cold.multipliers)
    assert warm.status == 0
    assert warm.iterations < cold.iterations / 2
    assert np.max(np.abs(warm.x - cold.x)) < 1e-7


# ------------------------------------------------------------- DenseKKT
@pytest.mark.parametrize("seed", range(6))
def test_dense_kkt_inertia_and_solve_against_numpy(seed):
    """Random KKT matrices (repeated entries summed, some rows of J
    repeated to make K singular): the inertia from NumPy's eigenvalues,
    the solve from NumPy's, ``matvec`` the product."""
    rng = np.random.default_rng(seed)
    n, m = 8, 4
    H = rng.normal(size=(n, n))
    H = H + H.T
    J = rng.normal(size=(m, n))
    singular = seed % 2 == 1
    if singular:
        J[-1] = J[0]
    hr, hc = np.tril_indices(n)
    h_values = H[hr, hc]
    hr, hc = np.r_[hr, 3], np.r_[hc, 1]  # a repeated entry
    h_values = np.r_[h_values - np.where((np.tril_indices(n)[0] == 3)
                                         & (np.tril_indices(n)[1] == 1), 0.25, 0.0), 0.25]
    jr, jc = np.nonzero(np.ones((m, n)))
    dx = rng.uniform(0.0, 2.0, n)
    dc = np.zeros(m) if singular else rng.uniform(0.0, 0.1, m)
    K = np.block([[H + np.diag(dx), J.T], [J, -np.diag(dc)]])
    kkt = DenseKKT(n, m, (hr, hc), (jr, jc))
    inertia = kkt.factor(h_values, J[jr, jc], dx, dc)
    eigenvalues = np.linalg.eigvalsh(K)
    scale = 1e-10 * np.max(np.abs(eigenvalues))
    expected = (int(np.sum(eigenvalues > scale)), int(np.sum(eigenvalues < -scale)),
                int(np.sum(np.abs(eigenvalues) <= scale)))
    assert inertia == expected
    b = rng.normal(size=n + m)
    assert np.allclose(kkt.matvec(b), K @ b, rtol=1e-13, atol=1e-13)
    if not singular:
        assert np.allclose(kkt.solve(b), np.linalg.solve(K, b), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_the_start_pushed_into_the_bounds_as_ipopt_pushes_it(seed):
    """``PrimalBounds.push`` (computed on the bounded entries alone) moves
    each entry to at least ``min(push max(1, |bound|), frac (upper -
    lower))`` inside its bounds, to the bit as the formula on full arrays
    (infinite where a bound is absent): entries with two bounds, one, none,
    inside, outside and on a bound."""
    from kanedyn.optimization.interior_point._bounds import PrimalBounds
    rng = np.random.default_rng(seed)
    size = 60
    kind = rng.integers(0, 4, size)  # none, lower, upper, both
    lower = np.where((kind == 1) | (kind == 3), rng.normal(size=size) * 10, -np.inf)
    upper = np.where(kind >= 2, np.where(kind == 3, lower, 0.0) + rng.uniform(1e-3, 5, size),
                     np.inf)
    bounds = PrimalBounds(lower, upper, 1e-8, 1e-5)
    w = rng.normal(size=size) * 10
    w[:5] = np.where(np.isfinite(lower[:5]), bounds.dense()[0][:5], w[:5])  # on a bound
    push, frac = 1e-2, 1e-2
    lo, up = bounds.dense()
    expected = w.copy()
    with np.errstate(invalid="ignore"):
        p_lower = np.minimum(push * np.maximum(1.0, np.abs(lo)), frac * (up - lo))
        p_upper = np.minimum(push * np.maximum(1.0, np.abs(up)), frac * (up - lo))
    i, j = np.isfinite(lo), np.isfinite(up)
    expected[i] = np.maximum(expected[i], lo[i] + p_lower[i])
    expected[j] = np.minimum(expected[j], up[j] - p_upper[j])
    pushed = bounds.push(w, push, frac)
    assert pushed.tobytes() == expected.tobytes()
    assert np.all(pushed[i] > lo[i]) and np.all(pushed[j] < up[j])
    assert np.array_equal(pushed[kind == 0], w[kind == 0])


@pytest.mark.parametrize("kinds", ["both", "mixed"])
def test_sigma_of_the_bounded_entries_alone_to_the_bit(kinds):
    """``PrimalBounds.sigma`` gives :math:`\\Sigma` at the bounded entries
    alone (one index array where every bounded entry has both bounds, else
    their union), to the bit the sums on an array of every entry; its split
    at n gives the variables' entries and the slacks' array.  A bound the
    same (to the bit) on all its entries is held as one number, read only;
    ``-0.0`` beside ``0.0`` is not the same."""
    from kanedyn.optimization.interior_point._bounds import PrimalBounds
    rng = np.random.default_rng(7)
    size, n = 50, 40
    kind = np.full(size, 3) if kinds == "both" else rng.integers(0, 4, size)
    kind[::7] = 0 if kinds == "mixed" else 3
    lower = np.where((kind == 1) | (kind == 3), -2.0, -np.inf)
    upper = np.where(kind >= 2, 2.0, np.inf)
    bounds = PrimalBounds(lower, upper, 1e-8, 1e-5)
    assert (bounds.upper_index is bounds.lower_index) == (kinds == "both")
    assert not bounds.lower.flags.writeable and bounds.lower.strides == (0,)
    w = rng.uniform(-1.5, 1.5, size)
    gaps = bounds.gaps(w)
    z = [rng.uniform(0.1, 3.0, i.size) for i in (bounds.lower_index, bounds.upper_index)]
    expected = np.zeros(size)
    expected[bounds.lower_index] = z[0] / gaps[0]
    expected[bounds.upper_index] += z[1] / gaps[1]
    sigma = bounds.sigma(z[0], z[1], *gaps)
    assert sigma.size == size and np.all(np.diff(sigma.index) > 0)
    assert sigma.dense().tobytes() == expected.tobytes()
    first, rest = sigma.split(n)
    assert first.size == n and first.dense().tobytes() == expected[:n].tobytes()
    assert rest.tobytes() == expected[n:].tobytes()
    signed = PrimalBounds(np.array([0.0, -0.0]), np.full(2, np.inf), 0.0, 1e-5)
    assert signed.lower.strides != (0,)


def test_dense_kkt_refuses_a_bad_structure():
    with pytest.raises(ValueError, match="hessian_structure.*above the diagonal"):
        DenseKKT(3, 1, ([0], [2]), ([0], [0]))
    with pytest.raises(ValueError, match="jacobian_structure.*outside the 1 x 3"):
        DenseKKT(3, 1, ([0], [0]), ([1], [0]))


# ------------------------------------------------- optimal control problems
#: the tolerances of both solvers in the comparisons
TIGHT = {"tol": 1e-10, "max_iter": 500}


@functools.cache
def _swing_up(peer, nodes, method, start):
    """``(problem, guess)``: ``_ocp_peers.<peer>_kanedyn(nodes, method)`` on
    the NumPy backend from the straight line with the input at ``start``,
    built once for the module (the dense and the sparse factorizations are
    compared with IPOPT on the same problems)."""
    import _ocp_peers as peers
    problem, _ = getattr(peers, f"{peer}_kanedyn")(nodes, method, backend="numpy")
    return problem, problem.guess_line(inputs={problem.symbols.inputs[0]: start})


#: IPOPT's optima, ``{id(problem): (problem, guess, result)}``
_IPOPT_OPTIMA = {}


def _ipopt_optimum(problem, guess):
    """IPOPT's optimum of ``problem`` from ``guess`` (the exact Hessian,
    :data:`TIGHT`), solved once for the same problem and guess objects (the
    swing-ups of :func:`_swing_up`, which the dense and the sparse
    factorizations' tests both compare with; the entry holds them, so an id
    is not reused while it is kept)."""
    kept = _IPOPT_OPTIMA.get(id(problem))
    if kept is not None and kept[0] is problem and kept[1] is guess:
        return kept[2]
    result = problem.solve(guess, solver="ipopt", hessian="exact", options=TIGHT)
    _IPOPT_OPTIMA[id(problem)] = (problem, guess, result)
    return result


def _same_optimum(problem, guess, objective_tolerance=1e-6, x_tolerance=1e-5, **options):
    """The problem solved by both solvers (the exact Hessian, tol 1e-10;
    ours with DenseKKT unless ``options`` say otherwise): ``(ours, IPOPT's)``,
    their optima compared."""
    _ipopt_or_skip()
    ours = problem.solve(guess, solver="interior-point", hessian="exact",
                         options=dict(TIGHT, **dict(DENSE, **options)))
    theirs = _ipopt_optimum(problem, guess)
    assert theirs.success, theirs.message
    assert ours.success, ours.message
    assert ours.solver == "interior-point"
    assert abs(ours.objective - theirs.objective) <= objective_tolerance * max(
        1.0, abs(theirs.objective))
    assert np.max(np.abs(ours.x - theirs.x)) < x_tolerance
    return ours, theirs


@pytest.mark.parametrize("method", ["trapezoid", "hermite-simpson"])
def test_pendulum_swing_up_ipopts_optimum(method):
    """opty's gallery swing-up (10 s, |torque| <= 2) at 50 nodes from a
    straight line: IPOPT's optimum."""
    _same_optimum(*_swing_up("pendulum", 50, method, 0.1))


@pytest.mark.parametrize("hessian, peer", [("exact", "pendulum"),
                                           ("limited-memory", "cart_pole")])
def test_a_second_order_correction_factors_the_steps_matrix_again(hessian, peer,
                                                                  monkeypatch):
    """The line search holds neither the step's factors nor its Hessian and
    sigma, nor with the exact Hessian the point's Jacobian: a second-order
    correction makes them again (the exact Hessian and the Jacobian
    evaluated again at the point; the limited-memory Hessian held, not
    updated twice, and the Jacobian with it).  On the 50-node
    Hermite-Simpson swing-up of the pendulum (exact) and the 40-node one of
    the cart-pole (limited-memory), both with many corrections: each matrix
    factored again for a correction has the step's values to the bit, its
    diagonals as the step's last factorization took them."""
    from kanedyn.optimization.interior_point import _solver, _step
    problem, guess = {"pendulum": _swing_up("pendulum", 50, "hermite-simpson", 0.1),
                      "cart_pole": _swing_up("cart_pole", 40, "hermite-simpson", 0.0)}[peer]
    factored, again = [], []
    factor, solve = _step.StepSolver._factor, _step.StepSolver.solve

    def _copy(value):
        return np.array(value, copy=True) if isinstance(value, np.ndarray) else value

    def recording_factor(self, *inputs):
        factored.append(tuple(_copy(v) for v in inputs))
        return factor(self, *inputs)

    def recording_solve(self, residual_w, residual_c, **options):
        if self._again is not None:  # the next factorization is the one made again
            again.append(len(factored))
        return solve(self, residual_w, residual_c, **options)
    evaluated_again = []
    jacobian_at = _solver._Run.jacobian_at

    def recording_jacobian_at(self, e):
        evaluated_again.append(e.jacobian is None)
        return jacobian_at(self, e)
    monkeypatch.setattr(_step.StepSolver, "_factor", recording_factor)
    monkeypatch.setattr(_step.StepSolver, "solve", recording_solve)
    monkeypatch.setattr(_solver._Run, "jacobian_at", recording_jacobian_at)
    result = problem.solve(guess, solver="interior-point", hessian=hessian,
                           options={"max_iter": 40})
    assert result.iterations > 5
    assert len(again) >= 3
    # the Jacobian let go by every exact line search, held by the limited-memory one
    assert evaluated_again == [hessian == "exact"] * len(again)
    for k in again:
        step, made = factored[k - 1], factored[k]
        for a, b in zip(step, made):
            if hasattr(a, "V"):  # the limited-memory approximation: the same object
                assert a is b
            elif isinstance(a, DiagonalEntries):  # sigma: its entries, the same
                assert a.size == b.size
                np.testing.assert_array_equal(a.index, b.index)
                np.testing.assert_array_equal(a.values, b.values)
            else:
                np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("method", ["trapezoid", "hermite-simpson"])
def test_cart_pole_swing_up_ipopts_optimum(method):
    """The cart-pole swing-up (|F| <= 20 N, |x| <= 1.5 m) at 40 nodes."""
    _same_optimum(*_swing_up("cart_pole", 40, method, 0.0))


def _double_integrator(mass=1.0):
    """``(model, (x, v, F, m))``: a particle on a line pushed by F
    (``tests/test_optimal_control.py``'s)."""
    _ipopt_or_skip()  # that module needs cyipopt
    from test_optimal_control import _double_integrator as particle
    return particle(mass=mass)


def test_least_time_free_duration():
    """|F| <= 1 from rest to rest over 1 m in the least time (bang-bang,
    T = 2 in the limit), trapezoid, 41 nodes: IPOPT's optimum, within 0.02
    of 2."""
    model, (x, v, F, _) = _double_integrator()
    T = sm.Symbol("T")
    problem = kd.OptimalControlProblem(
        model, nodes=41, duration=T, mayer=T, bounds={F: (-1, 1), T: (0.5, 5)},
        initial={x: 0, v: 0}, final={x: 1, v: 0}, method="trapezoid")
    ours, _ = _same_optimum(problem, problem.guess_line(inputs={F: 0.0}, duration=3.0))
    assert abs(ours.duration - 2.0) < 0.02


def test_free_parameter_at_its_bound_and_a_path_constraint():
    """The mass free in [0.5, 2] (least effort drives it to 0.5) and an
    auxiliary peak s with -s <= F <= s (two path constraints) weighted in
    the objective, Hermite-Simpson, 21 nodes: IPOPT's optimum, the mass at
    its bound."""
    model, (x, v, F, m) = _double_integrator(mass=1.3)
    s = sm.Symbol("s")
    problem = kd.OptimalControlProblem(
        model, nodes=21, duration=1.0, lagrange=F ** 2, mayer=s, parameters=[m],
        auxiliary={s: 10.0}, bounds={m: (0.5, 2.0), s: (0, None)},
        path_constraints=[(F - s, None, 0), (F + s, 0, None)],
        initial={x: 0, v: 0}, final={x: 1, v: 0}, method="hermite-simpson")
    ours, _ = _same_optimum(problem, problem.guess_line(inputs={F: 0.0}))
    assert abs(ours.parameters["m"] - 0.5) < 1e-7


def test_epigraph_least_peak_force_closed_form():
    """The least peak |F| of the unit rest-to-rest move in 1 s is 4
    (bang-bang); Hermite-Simpson on 21 nodes finds it (the switch is a node)."""
    model, (x, v, F, _) = _double_integrator()
    s = sm.Symbol("s")
    problem = kd.OptimalControlProblem(
        model, nodes=21, duration=1.0, mayer=s, auxiliary={s: 10.0}, bounds={s: (0, None)},
        path_constraints=[(F - s, None, 0), (F + s, 0, None)],
        initial={x: 0, v: 0}, final={x: 1, v: 0}, method="hermite-simpson")
    found = problem.solve(problem.guess_line(inputs={F: 0.0}), solver="interior-point",
                          hessian="exact", options=dict(DENSE, tol=1e-10))
    assert found.success, found.message
    assert abs(found.parameters["s"] - 4.0) < 1e-7


def test_multiphase_payload_released_closed_form():
    """Two phases (``tests/test_multiphase.py``'s models): a 1 kg cart with
    a 1 kg payload until 0.4 s, then alone, from rest at 0 to rest at 1 m in
    1 s with the least integral of F^2, Hermite-Simpson: the closed form's
    objective and positions (that module's ``_least_effort``)."""
    _ipopt_or_skip()  # test_multiphase needs cyipopt
    from test_multiphase import _cart, _least_effort
    loaded, (x, v, F) = _cart([1.0, 1.0])
    alone, _ = _cart([1.0])
    first = kd.OptimalControlProblem(loaded, nodes=5, duration=0.4, lagrange=F ** 2,
                                     initial={x: 0, v: 0}, method="hermite-simpson")
    second = kd.OptimalControlProblem(alone, nodes=7, duration=0.6, lagrange=F ** 2,
                                      final={x: 1, v: 0}, method="hermite-simpson")
    result = kd.MultiphaseProblem([first, second]).solve(
        [first.guess_line(end={x: 0.3, v: 1.0}, inputs={F: 0.0}),
         second.guess_line(start={x: 0.3, v: 1.0}, inputs={F: 0.0})],
        solver="interior-point", hessian="exact", options=dict(DENSE, tol=1e-12))
    assert result.success, result.message
    objective, position, _ = _least_effort([(0.0, 0.4, 2.0), (0.4, 1.0, 1.0)])
    assert abs(result.objective - objective) < 1e-9 * objective
    for phase in result.phases:
        assert np.max(np.abs(phase["x"] - [position(s) for s in phase.t])) < 1e-9


def test_warm_start_from_ipopts_multipliers():
    """The cart-pole solved by IPOPT, then by the interior-point solver from
    IPOPT's result and multipliers (``warm_start=True``): the same optimum in
    a handful of iterations, against many from the cold guess."""
    _ipopt_or_skip()
    import _ocp_peers as peers
    problem, _ = peers.cart_pole_kanedyn(30, "trapezoid", backend="numpy")
    guess = peers.cart_pole_guess(30)
    theirs = problem.solve(guess, solver="ipopt", hessian="exact", options={"tol": 1e-10})
    warm = problem.solve(theirs, solver="interior-point", hessian="exact", warm_start=True,
                         options=dict(DENSE, tol=1e-10, mu_init=1e-9))
    cold = problem.solve(guess, solver="interior-point", hessian="exact",
                         options=dict(DENSE, tol=1e-10))
    assert warm.success and cold.success, (warm.message, cold.message)
    assert abs(warm.objective - theirs.objective) < 1e-8 * abs(theirs.objective)
    assert warm.iterations < cold.iterations / 3


def test_registered_and_named_in_the_result():
    assert SOLVERS["interior-point"] is InteriorPoint
    assert InteriorPoint.available() is None


# ------------------------------------------------------------------ the CLI
def test_cli_optimize_with_the_interior_point_solver(capsys):
    """``kanedyn optimize pendulum --solver interior-point``: exit 0, IPOPT's
    objective (``--hessian exact``) to 1e-6; so with ``--hessian
    limited-memory`` (the solver's BFGS approximation); the summary names
    the Hessian used."""
    _ipopt_or_skip()
    from kanedyn.cli import main
    found = {}
    for solver in ("interior-point", "ipopt"):
        argv = ["optimize", "pendulum", "--nodes", "51", "--solver", solver, "--hessian",
                "exact", "--quiet", "--backend", "numpy"]
        assert main(argv) == 0
        text = capsys.readouterr().out
        assert f"solved: {solver} (exact Hessian):" in text
        found[solver] = float(text.split("objective ")[1].split()[0].rstrip(";"))
    assert found["interior-point"] == pytest.approx(found["ipopt"], rel=1e-6)
    assert main(["optimize", "pendulum", "--nodes", "51", "--solver", "interior-point",
                 "--hessian", "limited-memory", "--quiet", "--backend", "numpy"]) == 0
    text = capsys.readouterr().out
    assert "solved: interior-point (limited-memory Hessian):" in text
    assert float(text.split("objective ")[1].split()[0].rstrip(";")) == pytest.approx(
        found["ipopt"], rel=1e-6)


# ------------------------------------------- the compiled factorizations
def _compiled_or_skip():
    try:
        from kanedyn.optimization.interior_point import EnvelopeKKT, SparseKKT  # noqa: F401
    except ImportError as exc:
        pytest.skip(f"the compiled factorizations do not import: {exc}")


COMPILED = ["envelope", "sparse"]


@pytest.mark.parametrize("linear_solver", COMPILED)
@pytest.mark.parametrize("method", ["trapezoid", "hermite-simpson"])
def test_compiled_factorizations_reach_ipopts_optimum(method, linear_solver):
    """``linear_solver="envelope"`` (``EnvelopeKKT``, the default when it
    imports) and ``"sparse"`` (``SparseKKT``): the cart-pole's optimum of
    IPOPT, as with DenseKKT."""
    _compiled_or_skip()
    _same_optimum(*_swing_up("cart_pole", 40, method, 0.0), linear_solver=linear_solver)


@pytest.mark.slow
@pytest.mark.parametrize("linear_solver", COMPILED)
@pytest.mark.parametrize("nodes, method", [(50, "hermite-simpson"), (100, "trapezoid"),
                                           (100, "midpoint"), (100, "hermite-simpson")])
def test_compiled_factorizations_on_the_pendulum_swing_ups(nodes, method, linear_solver):
    """The pendulum swing-up from the straight line with either compiled
    factorization: IPOPT's optimum (objective to 1e-6 relative), in at most
    ten iterations more than IPOPT (the 50-node Hermite-Simpson one ended
    at the iteration limit, objective 12.286, when ``SparseKKT`` reported
    zero pivots that K has not)."""
    _compiled_or_skip()
    ours, theirs = _same_optimum(*_swing_up("pendulum", nodes, method, 0.1),
                                 linear_solver=linear_solver)
    assert ours.iterations <= theirs.iterations + 10


@pytest.mark.parametrize("method", ["trapezoid", "hermite-simpson"])
def test_the_envelope_takes_the_sparse_factorizations_steps(method):
    """The same matrices factored with L stored by its envelope: the
    100-node swing-up from the straight line takes the same number of
    iterations to the same optimum as with the sparse L (the sums in another
    order: the same factors up to rounding)."""
    _compiled_or_skip()
    problem, guess = _swing_up("pendulum", 100, method, 0.1)
    found = {ls: problem.solve(guess, solver="interior-point", hessian="exact",
                               options=dict(TIGHT, linear_solver=ls)) for ls in COMPILED}
    envelope, sparse = found["envelope"], found["sparse"]
    assert envelope.status == sparse.status == 0
    assert envelope.iterations == sparse.iterations
    assert envelope.objective == pytest.approx(sparse.objective, rel=1e-12)
    assert np.max(np.abs(envelope.x - sparse.x)) < 1e-9


@pytest.mark.parametrize("linear_solver", COMPILED)
def test_compiled_factorizations_on_the_small_nlps(linear_solver):
    """HS71 and the inequality problem with either compiled factorization:
    the published optimum and the closed form."""
    _compiled_or_skip()
    found = InteriorPoint().solve(_hs71(), np.array([1.0, 5.0, 5.0, 1.0]),
                                  {"linear_solver": linear_solver})
    assert found.status == 0, found.status_text
    assert np.max(np.abs(found.x - HS71_X)) < 1e-6
    nlp, Q, c, B, b = _equality_qp()
    n, m = B.shape[1], B.shape[0]
    exact = np.linalg.solve(np.block([[Q, B.T], [B, np.zeros((m, m))]]), np.r_[-c, b])
    found = InteriorPoint().solve(nlp, np.zeros(n), {"linear_solver": linear_solver})
    assert found.status == 0 and np.max(np.abs(found.x - exact[:n])) < 1e-9


def test_linear_solver_fallback_without_a_compiler(monkeypatch):
    """No C compiler: ``linear_solver="auto"`` (the default) solves with
    DenseKKT and says why; ``"sparse"`` is refused with the compiler's
    reason and the option's name."""
    from kanedyn.numerics import CompilerError
    from kanedyn.optimization.interior_point.kkt import _kernel as _kkt_kernel
    from kanedyn.optimization.interior_point.kkt import _sparse as _kkt_sparse  # noqa: F401
    from kanedyn.optimization.interior_point._solver import kkt_class
    # _kkt_sparse imported before the patch: it keeps the real kernel for later tests

    def no_compiler():
        raise CompilerError("no C compiler on this machine")
    monkeypatch.setattr(_kkt_kernel, "kernel", no_compiler)
    chosen, note = kkt_class("auto")
    assert chosen is DenseKKT and "no C compiler" in note
    with pytest.raises(CompilerError, match="linear_solver='sparse'.*no C compiler"):
        kkt_class("sparse")
    solver = InteriorPoint()
    found = solver.solve(_hs71(), np.array([1.0, 5.0, 5.0, 1.0]))
    assert "DenseKKT used" in solver.note
    assert found.status == 0 and np.max(np.abs(found.x - HS71_X)) < 1e-6


@pytest.mark.parametrize("option, value", [
    ("perturb_inc_fact_first", 0.0), ("perturb_inc_fact", 1.0), ("mu_init", 0.0),
    ("tau_min", 2.0), ("bound_frac", 0.0), ("bound_frac", 0.6),
    ("mu_superlinear_decrease_power", 0.5), ("perturb_dec_fact", 1.0)])
def test_options_outside_ipopts_ranges_are_refused(option, value):
    """A value outside IPOPT's range (a perturbation factor of 0 would never
    end the inertia correction) is refused before the solve, naming it."""
    with pytest.raises(ValueError, match=f"{option}={value!r}: give a number in"):
        InteriorPoint().solve(_hs71(), np.array([1.0, 5.0, 5.0, 1.0]), {option: value})


def test_integer_options_take_numpy_integers():
    found = InteriorPoint().solve(_hs71(), np.array([1.0, 5.0, 5.0, 1.0]),
                                  {"max_iter": np.int64(50), "print_level": np.int32(0)})
    assert found.status == 0 and np.max(np.abs(found.x - HS71_X)) < 1e-6


def test_linear_solver_choice_and_fallback(monkeypatch, capsys):
    """``linear_solver="auto"`` takes EnvelopeKKT when it imports, else
    DenseKKT with a note (printed with print_level=1, the same solution);
    ``"envelope"`` or ``"sparse"`` without its module is refused, naming the
    option."""
    from kanedyn.optimization.interior_point import EnvelopeKKT, SparseKKT
    from kanedyn.optimization.interior_point._solver import kkt_class
    assert kkt_class("dense") == (DenseKKT, None)
    assert kkt_class("auto") == (EnvelopeKKT, None) == kkt_class("envelope")
    assert kkt_class("sparse") == (SparseKKT, None)
    monkeypatch.setitem(sys.modules, "kanedyn.optimization.interior_point.kkt._envelope",
                        None)
    chosen, note = kkt_class("auto")
    assert chosen is DenseKKT and "EnvelopeKKT is not available" in note
    with pytest.raises(ImportError, match="linear_solver='envelope'.*linear_solver='dense'"):
        kkt_class("envelope")
    assert kkt_class("sparse") == (SparseKKT, None)
    monkeypatch.setitem(sys.modules, "kanedyn.optimization.interior_point.kkt._sparse", None)
    with pytest.raises(ImportError, match="linear_solver='sparse'.*linear_solver='dense'"):
        kkt_class("sparse")
    solver = InteriorPoint()
    found = solver.solve(_hs71(), np.array([1.0, 5.0, 5.0, 1.0]), {"print_level": 1})
    assert "DenseKKT used" in solver.note and "DenseKKT used" in capsys.readouterr().out
    assert found.status == 0 and np.max(np.abs(found.x - HS71_X)) < 1e-6


def test_unbounded_objective_diverges_with_status_4():
    """min x1 with only x2 = 1 constrained: the iterates run off (|x| above
    diverging_iterates_tol, 1e20), status 4."""
    nlp = _NLP(2, 1, lambda x: x[0], lambda x: [1.0, 0.0], lambda x: [x[1]],
               lambda x: [[0.0, 1.0]], lambda x, y, s: np.zeros((2, 2)), g_lower=[1.0],
               g_upper=[1.0])
    found = _solve(nlp, [0.0, 0.0])
    assert found.status == 4 and "diverged" in found.status_text
    assert found.x[0] < -1e20 and abs(found.x[1] - 1.0) < 1e-8


@pytest.mark.parametrize("inequality", [False, True])
def test_the_gradient_evaluated_again_after_the_step_gives_the_same_iterates(
        monkeypatch, inequality):
    """A large problem's objective gradient is let go through the Newton step
    and evaluated again after it (``GRADIENT_AGAIN_BYTES``): with the size
    lowered to 0 a swing-up (with a path inequality, whose slacks make the
    gradient in w a copy) takes the same iterates to the bit as without, and
    the gradient is evaluated once more an iteration."""
    from kanedyn.optimization.interior_point import _reduced, _solver
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend="numpy")
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    problem = kd.OptimalControlProblem(
        model, nodes=40, duration=2.0, lagrange=tau ** 2, bounds={tau: (-20.0, 20.0)},
        initial={q: 0.0, u: 0.0}, final={q: 1.0, u: 0.0},
        path_constraints=[(u ** 2, 0.0, 9.0)] if inequality else ())
    guess = problem.guess_line(inputs={tau: 0.0})
    calls = []
    gradient = _reduced.ReducedNLP.gradient

    def counted(self, x_full):
        calls.append(1)
        return gradient(self, x_full)
    monkeypatch.setattr(_reduced.ReducedNLP, "gradient", counted)

    def solved():
        calls.clear()
        result = problem.solve(guess, solver="interior-point", hessian="exact")
        return result, len(calls)
    held, evaluations = solved()
    monkeypatch.setattr(_solver, "GRADIENT_AGAIN_BYTES", 0)
    again, more = solved()
    assert held.status == again.status == 0
    assert held.iterations == again.iterations
    assert more == evaluations + held.iterations
    assert held.x.tobytes() == again.x.tobytes()
    for key in held.multipliers:
        assert np.asarray(held.multipliers[key]).tobytes() == \
            np.asarray(again.multipliers[key]).tobytes()


def test_corrections_factored_again_each_give_the_same_iterates(monkeypatch):
    """A large problem's second-order correction lets its factors go once it
    is solved (not held through its trial point) and makes them again for a
    further correction (``CORRECTION_AGAIN_BYTES``): with the size lowered to
    0, the 50-node Hermite-Simpson swing-up of the pendulum, whose line
    searches make several corrections in a row, takes the same iterates to
    the bit, with one factorization more for each correction after a line
    search's first; after the corrections no factors are held."""
    from kanedyn.optimization.interior_point import _solver, _step
    problem, guess = _swing_up("pendulum", 50, "hermite-simpson", 0.1)
    solves, held_after = [], []
    solve, second_order = _step.StepSolver.solve, _solver._Run._second_order

    def counted_solve(self, residual_w, residual_c, **options):
        solves.append(self._again is not None)
        return solve(self, residual_w, residual_c, **options)

    def watched(self, *args):
        found = second_order(self, *args)
        held_after.append(self.stepper.kkt.inertia is not None)  # (released: None)
        return found
    monkeypatch.setattr(_step.StepSolver, "solve", counted_solve)
    monkeypatch.setattr(_solver._Run, "_second_order", watched)

    def solved():
        solves.clear()
        result = problem.solve(guess, solver="interior-point", hessian="exact",
                               options={"max_iter": 40})
        return result, list(solves)
    once, made_once = solved()
    monkeypatch.setattr(_solver, "CORRECTION_AGAIN_BYTES", 0)
    each, made_each = solved()
    assert once.iterations == each.iterations
    assert once.x.tobytes() == each.x.tobytes()
    corrections = made_once.count(True)  # solves after a release
    assert len(made_each) == len(made_once) and made_each.count(True) > corrections > 0
    assert held_after and not any(held_after)
