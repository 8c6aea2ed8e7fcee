"""The interior-point solver's feasibility restoration phase
(``optimization/interior_point/_restoration.py``), checked against what
shares none of its code:

- its Newton step, reduced to the NLP's KKT structure, against the full
  system (the pairs p, n not eliminated) solved by NumPy;
- its starting pairs against the optimality conditions they solve;
- Waechter & Biegler's example (Math. Program. 88, 2000) started where the
  filter blocks every step: feasible, its closed-form optimum and IPOPT's
  iterates (both enter the restoration, IPOPT's print marking its
  iterations with ``r``); infeasible from the same start, IPOPT's status 2
  at the violation's local minimizer;
- the pendulum swing-up: opty's random guess at 501 nodes (IPOPT's
  objective) and the infeasible backward-Euler problem at 100 nodes
  (IPOPT's status 2).

The comparisons with IPOPT need cyipopt; without it they are skipped.
"""

import re
import sys
from pathlib import Path

import numpy as np
import pytest

from kanedyn.optimization.interior_point import DenseKKT, InteriorPoint
from kanedyn.optimization.interior_point._options import settings
from kanedyn.optimization.interior_point._restoration import PENALTY, starting_pairs
from kanedyn.optimization.interior_point._step import StepSolver

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from test_interior_point import NO_BOUND, _NLP, ipopt_problem  # noqa: E402

#: a restoration iteration's line in the printed table: "  12r ..." (ours), "  12r-1.0..." (IPOPT's)
RESTORATION_ROW = re.compile(r"^\s*\d+r", re.MULTILINE)


def _linear_solvers():
    solvers = ["dense"]
    try:
        from kanedyn.optimization.interior_point import EnvelopeKKT, SparseKKT  # noqa: F401
        solvers += ["sparse", "envelope"]
    except ImportError:
        pass
    return solvers


# ------------------------------------------------------------ the Newton step
def test_reduced_step_equals_the_full_system():
    """The step with p and n eliminated into the rows' diagonal (StepSolver
    with their rows and signs) equals the full Newton system's, [[W + S_x,
    0, J'], [0, S_v, A'], [J, A, 0]] (A: each eliminated variable's
    coefficient -1 or +1 in its row), solved by NumPy."""
    rng = np.random.default_rng(3)
    n, m = 4, 3
    inequality = np.array([1])
    rows = np.concatenate([inequality, np.arange(m), np.arange(m)])
    signs = np.concatenate([[-1.0], -np.ones(m), np.ones(m)])
    k = rows.size
    B = rng.normal(size=(n, n))
    W = B @ B.T + n * np.eye(n)
    J = rng.normal(size=(m, n))
    hr, hc = np.tril_indices(n)
    kkt = DenseKKT(n, m, (hr, hc), (np.repeat(np.arange(m), n), np.tile(np.arange(n), m)))
    sigma = rng.uniform(0.5, 2.0, size=n + k)
    residual_w = rng.normal(size=n + k)
    residual_c = rng.normal(size=m)
    stepper = StepSolver(kkt, n, m, rows, settings({}), signs=signs)
    step = stepper.compute(W[hr, hc], J.ravel(), sigma, residual_w, residual_c, mu=0.1)
    A = np.zeros((m, k))
    A[rows, np.arange(k)] = signs
    full = np.block([[W + np.diag(sigma[:n]), np.zeros((n, k)), J.T],
                     [np.zeros((k, n)), np.diag(sigma[n:]), A.T],
                     [J, A, np.zeros((m, m))]])
    exact = np.linalg.solve(full, -np.concatenate([residual_w, residual_c]))
    assert step.delta_w == 0.0 and step.delta_c == 0.0
    assert np.max(np.abs(step.primal - exact[:n + k])) < 1e-10
    assert np.max(np.abs(step.rows - exact[n + k:])) < 1e-10


def test_refinement_makes_the_right_hand_side_again_in_chunks(monkeypatch):
    """The refinement makes rhs again a chunk at a time (rhs is solved in
    its own storage): with chunks of 2 entries and every refinement step
    taken (``residual_ratio_max`` tiny), the step equals the one made with
    the whole rhs at once to the bit, the inequality rows' part included."""
    from kanedyn.optimization.interior_point import _step
    rng = np.random.default_rng(4)
    n, m = 5, 4
    rows = np.array([0, 2])
    signs = np.array([-1.0, 1.0])
    B = rng.normal(size=(n, n))
    W = B @ B.T + n * np.eye(n)
    J = rng.normal(size=(m, n))
    hr, hc = np.tril_indices(n)
    inputs = (W[hr, hc], J.ravel(), rng.uniform(0.5, 2.0, size=n + rows.size),
              rng.normal(size=n + rows.size), rng.normal(size=m))
    steps = []
    for chunk in (_step._CHUNK, 2):
        monkeypatch.setattr(_step, "_CHUNK", chunk)
        kkt = DenseKKT(n, m, (hr, hc), (np.repeat(np.arange(m), n), np.tile(np.arange(n), m)))
        stepper = StepSolver(kkt, n, m, rows, settings({"residual_ratio_max": 1e-300}),
                             signs=signs)
        steps.append(stepper.compute(*inputs, mu=0.1))
    np.testing.assert_array_equal(steps[1].primal, steps[0].primal)
    np.testing.assert_array_equal(steps[1].rows, steps[0].rows)


@pytest.mark.parametrize("linear_solver", _linear_solvers())
def test_released_factors_are_made_again_for_a_later_solve(linear_solver):
    """The solver releases the factors after the step (not held through the
    line search); a second-order correction's solve then factors the same
    matrix again: the same solution to the bit, one factorization more (and
    with ``release`` let go again after the solve, made again for the
    next).  Released without the inputs (a new point), a solve has no factors."""
    from kanedyn.optimization.interior_point import EnvelopeKKT, SparseKKT
    rng = np.random.default_rng(5)
    n, m = 6, 3
    B = rng.normal(size=(n, n))
    W = B @ B.T + n * np.eye(n)
    J = rng.normal(size=(m, n))
    hr, hc = np.tril_indices(n)
    kind = {"dense": DenseKKT, "sparse": SparseKKT, "envelope": EnvelopeKKT}[linear_solver]
    kkt = kind(n, m, (hr, hc), (np.repeat(np.arange(m), n), np.tile(np.arange(n), m)))
    stepper = StepSolver(kkt, n, m, np.array([], dtype=int), settings({}))
    sigma = rng.uniform(0.5, 2.0, size=n)
    inputs = (W[hr, hc], J.ravel(), sigma)
    stepper.compute(*inputs, rng.normal(size=n), rng.normal(size=m), mu=0.1)
    residual_w, residual_c = rng.normal(size=n), rng.normal(size=m)
    held = stepper.solve(residual_w, residual_c)
    count = stepper.factorizations
    stepper.release(again=lambda: inputs)
    again = stepper.solve(residual_w, residual_c)
    assert stepper.factorizations == count + 1
    np.testing.assert_array_equal(again.primal, held.primal)
    np.testing.assert_array_equal(again.rows, held.rows)
    assert stepper.solve(residual_w, residual_c).primal.tolist() == held.primal.tolist()
    assert stepper.factorizations == count + 1  # factored once, then held again
    # released after each solve (a large problem's corrections): made again each time
    stepper.release(again=lambda: inputs)
    for k in (2, 3):
        assert stepper.solve(residual_w, residual_c, release=True).primal.tolist() == \
            held.primal.tolist()
        assert stepper.factorizations == count + k
    stepper.release()
    if linear_solver != "dense":
        with pytest.raises(ValueError, match="nothing is factored"):
            stepper.solve(residual_w, residual_c)


def test_starting_pairs_solve_their_optimality_conditions():
    """p, n of the paper's (33) satisfy c - p + n = 0, p, n > 0 and the
    barrier problem's stationarity rho - mu/p = lambda = -(rho - mu/n)."""
    c = np.array([-3.0, -1e-3, 0.0, 2e-6, 5.0])
    mu = 0.1
    p, n = starting_pairs(c, mu)
    assert np.all(p > 0) and np.all(n > 0)
    assert np.max(np.abs(c - p + n)) < 1e-12
    assert np.max(np.abs((PENALTY - mu / p) + (PENALTY - mu / n))) < 1e-8 * PENALTY


# ----------------------------------------------- Waechter & Biegler's example
def _wachter_biegler(a, b):
    """min x1 s.t. x1^2 - x2 + a = 0, x1 - x3 - b = 0, x2, x3 >= 0
    (Waechter & Biegler, Math. Program. 88, 2000): from x1 < 0 the
    linearized rows and the bounds block every step of a line-search
    interior point."""
    def hessian(x, y, s):
        h = np.zeros((3, 3))
        h[0, 0] = 2 * y[0]
        return h
    return _NLP(3, 2, lambda x: x[0], lambda x: [1.0, 0.0, 0.0],
                lambda x: [x[0] ** 2 - x[1] + a, x[0] - x[2] - b],
                lambda x: [[2 * x[0], -1.0, 0.0], [1.0, 0.0, -1.0]], hessian,
                x_lower=[-NO_BOUND, 0.0, 0.0], g_lower=[0.0, 0.0], g_upper=[0.0, 0.0])


START = np.array([-2.0, 1.0, 1.0])


def _ipopt_table(nlp, x0, tmp_path):
    """IPOPT (print_level 5) on ``nlp``: ``(x, status, printed table)``."""
    problem = ipopt_problem(nlp)
    log = tmp_path / "ipopt.txt"
    problem.add_option("print_level", 0)
    problem.add_option("sb", "yes")
    problem.add_option("output_file", str(log))
    problem.add_option("file_print_level", 5)
    x, info = problem.solve(np.array(x0, float))
    return x, info["status"], log.read_text()


@pytest.mark.parametrize("linear_solver", _linear_solvers())
def test_restoration_then_the_closed_form_optimum(linear_solver, capsys):
    """a = 0, b = 1 from (-2, 1, 1): the line search stalls at once (without
    a restoration phase: status -2 after 4 iterations); through four
    restorations the solver reaches the optimum x = (1, 1, 0) (x1 >= 1 on
    the feasible set, x2 = x1^2, x3 = x1 - 1), objective 1."""
    found = InteriorPoint().solve(_wachter_biegler(0.0, 1.0), START,
                                  {"linear_solver": linear_solver, "print_level": 1})
    printed = capsys.readouterr().out
    assert found.status == 0, found.status_text
    assert np.max(np.abs(found.x - [1.0, 1.0, 0.0])) < 1e-7
    assert abs(found.objective - 1.0) < 1e-7
    assert RESTORATION_ROW.search(printed)


def test_restoration_follows_ipopts_iterates(capsys, tmp_path):
    """With DenseKKT, the same problem: IPOPT also restores (its table marks
    iterations with r), ends at the same optimum, and every printed row
    (iteration, objective, violation, dual infeasibility, barrier
    parameter) is IPOPT's, restoration rows included (25 iterations)."""
    nlp = _wachter_biegler(0.0, 1.0)
    found = InteriorPoint().solve(nlp, START, {"linear_solver": "dense", "print_level": 1})
    ours = capsys.readouterr().out
    x, status, theirs = _ipopt_table(_wachter_biegler(0.0, 1.0), START, tmp_path)
    assert status == 0 and found.status == 0
    assert np.max(np.abs(found.x - x)) < 1e-7

    def rows(text):
        pattern = re.compile(r"^\s*(\d+r?)\s*(-?\d\.\d{7}e[+-]\d\d) (\S+) +(\S+) +(\S+)",
                             re.MULTILINE)
        return [m.groups() for m in pattern.finditer(text)]
    assert RESTORATION_ROW.search(theirs)
    assert rows(ours) == rows(theirs)
    assert found.iterations == len(rows(theirs)) - 1


@pytest.mark.parametrize("linear_solver", _linear_solvers())
def test_locally_infeasible_like_ipopt(linear_solver, tmp_path):
    """a = -1, b = 1/2 from (-2, 1, 1) (the paper's example): the iterates
    cannot cross x1 = 0 with x2, x3 >= 0 and stop at the l1 violation's
    local minimizer x = (-1, 0, 0) (|x1^2 - 1| + |x1 - 1/2| falls up to
    x1 = -1 from the left and rises after): status 2, IPOPT's status and
    point, both after restoration."""
    found = InteriorPoint().solve(_wachter_biegler(-1.0, 0.5), START,
                                  {"linear_solver": linear_solver})
    assert found.status == 2, found.status_text
    assert "local infeasibility" in found.status_text
    assert np.max(np.abs(found.x - [-1.0, 0.0, 0.0])) < 1e-7
    x, status, theirs = _ipopt_table(_wachter_biegler(-1.0, 0.5), START, tmp_path)
    assert status == 2 and RESTORATION_ROW.search(theirs)
    assert np.max(np.abs(found.x - x)) < 1e-7


# ------------------------------------------------------ the pendulum swing-up
def _ipopt_or_skip():
    pytest.importorskip("cyipopt", reason="the comparison with IPOPT needs cyipopt")


@pytest.mark.slow
def test_pendulum_random_guess_reaches_ipopts_objective():
    """opty's gallery swing-up at 501 nodes (backward Euler) from opty's
    random guess (normal, seed 0), the default factorization: IPOPT's
    objective to 1e-6 relative (before the restoration phase and the bound
    multipliers' step along second-order corrections: status -2)."""
    _ipopt_or_skip()
    import _ocp_peers as peers
    problem, _ = peers.pendulum_kanedyn(501, backend="numpy")
    guess = np.random.default_rng(0).normal(size=3 * 501)
    theirs = problem.solve(guess, solver="ipopt", hessian="exact")
    ours = problem.solve(guess, solver="interior-point", hessian="exact")
    assert theirs.success, theirs.message
    assert ours.success, ours.message
    assert abs(ours.objective - theirs.objective) <= 1e-6 * abs(theirs.objective)


@pytest.mark.slow
@pytest.mark.parametrize("linear_solver", _linear_solvers())
def test_pendulum_backward_euler_infeasible_like_ipopt(linear_solver):
    """The backward-Euler swing-up at 100 nodes from the line guess
    (``peers.pendulum_guess``) has no feasible point the iterates find:
    IPOPT's status 2, and this solver's."""
    _ipopt_or_skip()
    import _ocp_peers as peers
    problem, _ = peers.pendulum_kanedyn(100, backend="numpy")
    guess = peers.pendulum_guess(100)
    theirs = problem.solve(guess, solver="ipopt", hessian="exact")
    ours = problem.solve(guess, solver="interior-point", hessian="exact",
                         options={"linear_solver": linear_solver})
    assert theirs.status == 2, theirs.message
    assert ours.status == 2, ours.message


def test_soft_restoration_steps_cut_the_primal_dual_error(capsys):
    """The pendulum swing-up in free time (backward Euler, 50 nodes, the
    exact Hessian, infeasible: IPOPT ends with status 2): where the line
    search fails, steps of the soft restoration phase are taken (printed
    ``s``: the primal-dual system error fell; 4 on this path, which the
    factorizations' rounding decides: on Hermite-Simpson at 30 nodes there
    were 5 until the band's order changed, now none), then the restoration
    phase; the solve ends locally infeasible, as IPOPT's."""
    import sympy as sm
    import kanedyn as kd
    definition = kd.models.build("pendulum", torque=True)
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    T = sm.Symbol("T")
    problem = kd.OptimalControlProblem(
        definition.numeric(backend="numpy"), nodes=50, duration=T,
        lagrange=tau ** 2 + T * q ** 2, mayer=T, bounds={tau: (-2, 2), T: (0.5, 15)},
        initial={q: 0, u: 0}, final={q: np.pi, u: 0}, method="backward-euler")
    guess = problem.guess_line(inputs={tau: 0.0}, duration=8.0)
    found = problem.solve(guess, solver="interior-point", hessian="exact",
                          options={"tol": 1e-10, "print_level": 1})
    printed = capsys.readouterr().out
    soft = re.findall(r"^\s*\d+ .* (\S+) (\S+)s\s+1$", printed, re.MULTILINE)
    assert len(soft) >= 3
    assert RESTORATION_ROW.search(printed)
    assert found.status == 2, found.status_text


def test_first_step_tried_below_the_smallest_step_as_ipopt(tmp_path, capsys):
    """The 40-node backward-Euler swing-up from the straight line (infeasible
    with so few nodes), the exact Hessian, the default factorization: at
    iteration 17 the step to the boundary (4.6e-7) is below the line
    search's smallest step; IPOPT still tries it and takes it, and so does
    this solver now (before, it made no trial: rows equal to IPOPT's up to
    iteration 17 only).  At least the first 25 printed rows are IPOPT's (30
    measured, into the restoration phase), and both end locally infeasible."""
    _ipopt_or_skip()
    import _ocp_peers as peers
    problem, _ = peers.pendulum_kanedyn(40, backend="numpy")
    guess = problem.guess_line(inputs={problem.symbols.inputs[0]: 0.1})
    log = tmp_path / "ipopt.txt"
    theirs = problem.solve(guess, solver="ipopt", hessian="exact",
                           options={"tol": 1e-10, "print_level": 0,
                                    "output_file": str(log), "file_print_level": 5})
    ours = problem.solve(guess, solver="interior-point", hessian="exact",
                         options={"tol": 1e-10, "print_level": 1})
    printed = capsys.readouterr().out
    pattern = re.compile(r"^\s*(\d+r?)\s*(-?\d\.\d{7}e[+-]\d\d) (\S+) +(\S+) +(\S+)",
                         re.MULTILINE)
    rows = [m.groups() for m in pattern.finditer(printed)]
    theirs_rows = [m.groups() for m in pattern.finditer(log.read_text())]
    equal = next((k for k, (a, b) in enumerate(zip(rows, theirs_rows)) if a != b),
                 min(len(rows), len(theirs_rows)))
    assert equal >= 25
    assert theirs.status == 2 and ours.status == 2, (theirs.message, ours.message)
