"""The interior-point solver with the limited-memory BFGS Hessian
(``hessian_approximation="limited-memory"``, the default when the NLP has no
exact Hessian), checked against what shares none of its code:

- the compact representation against BFGS's rank-two recursion written out
  on dense matrices, and Powell's damping against its defining equation;
- ``LowRankKKT``'s inertia, solves and products against the whole matrix
  assembled by NumPy (its eigenvalues, ``numpy.linalg.solve``), on both KKT
  factorizations;
- IPOPT's printed iterations with ``hessian_approximation="limited-memory"``
  and ``mu_strategy="monotone"`` (the strategy this solver has; IPOPT's
  default with limited memory is the adaptive one): Hock-Schittkowski 71 and
  opty's pendulum swing-up at 501 nodes from its random guess, the same rows
  until the paths part, the same optimum;
- the restoration phase with the approximation on Waechter & Biegler's
  example (its closed-form optimum; local infeasibility, status 2).
"""

import contextlib
import io
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.optimization.interior_point import DenseKKT, InteriorPoint
from kanedyn.optimization.interior_point.kkt._low_rank import LowRankKKT
from kanedyn.optimization.interior_point._options import settings
from kanedyn.optimization.interior_point._quasi_newton import LimitedMemoryBFGS

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from test_interior_point import _hs71, ipopt_problem  # noqa: E402
from test_interior_point_restoration import START, _wachter_biegler  # noqa: E402

LIMITED = {"hessian_approximation": "limited-memory"}
#: IPOPT's update: pairs of negative curvature skipped
IPOPTS = dict(LIMITED, limited_memory_update_type="bfgs")
#: IPOPT's printed row: iteration, objective, inf_pr, inf_du, lg(mu)
ROW = re.compile(r"^\s*(\d+r?)\s*(-?\d\.\d{7}e[+-]\d\d) (\S+) +(\S+) +(\S+)", re.MULTILINE)


def _without_hessian(nlp):
    """``nlp`` (of ``test_interior_point``) without its exact Hessian, as
    ``solve(hessian="limited-memory")`` makes the NLP."""
    nlp.exact_hessian = None
    return nlp


def _pairs(rng, n, count):
    """``count`` pairs with s'y > 0: y = A s for a random positive definite A."""
    A = rng.normal(size=(n, n))
    A = A @ A.T + np.eye(n)
    S = rng.normal(size=(count, n))
    return S, S @ A.T


def _bfgs_dense(sigma, S, Y):
    """BFGS's recursion B <- B - B s s'B / s'Bs + y y' / y's from sigma I."""
    B = sigma * np.eye(S.shape[1])
    for s, y in zip(S, Y):
        Bs = B @ s
        B = B - np.outer(Bs, Bs) / (s @ Bs) + np.outer(y, y) / (y @ s)
    return B


def test_compact_representation_is_bfgs_recursion():
    """Six pairs in 12 variables (history 4: the newest four kept): the
    compact B equals the recursion from sigma I over the kept pairs, sigma
    the newest pair's s'y / s's (IPOPT's scalar1)."""
    rng = np.random.default_rng(3)
    S, Y = _pairs(rng, 12, 6)
    memory = LimitedMemoryBFGS(settings(dict(IPOPTS, limited_memory_max_history=4)))
    for s, y in zip(S, Y):
        memory.update(s, y)
    sigma = (S[-1] @ Y[-1]) / (S[-1] @ S[-1])
    assert memory.sigma == pytest.approx(sigma, rel=1e-14)
    B = memory.compact(12)
    expected = _bfgs_dense(sigma, S[-4:], Y[-4:])
    assert np.max(np.abs(B.dense() - expected)) < 1e-11 * np.max(np.abs(expected))
    v = rng.normal(size=12)
    assert np.max(np.abs(B.times(v) - expected @ v)) < 1e-11 * np.max(np.abs(expected @ v))


def test_skipped_pairs_and_the_reset():
    """A pair of negative curvature is skipped (the memory unchanged); the
    third in a row (``limited_memory_max_skipping = 2``) empties the memory
    and sigma returns to ``limited_memory_init_val``."""
    rng = np.random.default_rng(4)
    S, Y = _pairs(rng, 5, 2)
    memory = LimitedMemoryBFGS(settings(IPOPTS))
    for s, y in zip(S, Y):
        memory.update(s, y)
    held = memory.compact(5).dense()
    for k in range(2):
        memory.update(S[0], -Y[0])
        assert memory.skipped == k + 1
        assert np.array_equal(memory.compact(5).dense(), held)
    memory.update(S[0], -Y[0])
    assert memory.S is None and memory.sigma == 1.0 and memory.skipped == 0


def test_damped_pair_has_a_fifth_of_the_curvature():
    """``damped-bfgs``: a pair with s'y < 0.2 s'Bs enters as r = theta y +
    (1 - theta) B s with s'r = 0.2 s'Bs (B before it), and B stays positive
    definite; a pair of enough curvature enters as it is."""
    rng = np.random.default_rng(5)
    S, Y = _pairs(rng, 6, 2)
    memory = LimitedMemoryBFGS(settings(LIMITED))  # damped: the default
    for s, y in zip(S, Y):
        memory.update(s, y)
    assert np.array_equal(memory.Y, Y)  # enough curvature: not damped
    before = memory.compact(6).dense()
    s, y = rng.normal(size=6), rng.normal(size=6)
    y -= (s @ y + 1.0) * s / (s @ s)  # s'y = -1
    memory.update(s, y)
    r = memory.Y[-1]
    assert s @ r == pytest.approx(0.2 * s @ before @ s, rel=1e-12)
    assert np.min(np.linalg.eigvalsh(memory.compact(6).dense())) > 0


def _kkt_classes():
    classes = [DenseKKT]
    try:
        from kanedyn.optimization.interior_point import EnvelopeKKT, SparseKKT
        from kanedyn.optimization.interior_point.kkt._kernel import kernel
        kernel()
        classes += [SparseKKT, EnvelopeKKT]
    except Exception as exc:  # no compiler: DenseKKT only, said in the output
        print(f"SparseKKT and EnvelopeKKT not checked: {exc}")
    return classes


@pytest.mark.parametrize("kkt_class", _kkt_classes(), ids=lambda c: c.__name__)
@pytest.mark.parametrize("curvature", ["positive", "indefinite"])
def test_low_rank_kkt_against_the_assembled_matrix(kkt_class, curvature):
    """K = [[B + diag(dx), J'], [J, -diag(dc)]] with B = sigma I - V M^-1 V'
    assembled by NumPy: the same inertia (its eigenvalues' signs), solve
    and product.  ``indefinite``: a negative dx makes the (1,1) block
    indefinite, so the inertia is not (n, m, 0)."""
    rng = np.random.default_rng(6)
    n, m = 9, 4
    S, Y = _pairs(rng, n, 3)
    memory = LimitedMemoryBFGS(settings(LIMITED))
    for s, y in zip(S, Y):
        memory.update(s, y)
    B = memory.compact(n)
    J = rng.normal(size=(m, n))
    J[rng.random((m, n)) < 0.4] = 0.0
    J[np.arange(m), np.arange(m)] = 1.0 + rng.random(m)
    rows, cols = np.nonzero(J)
    dx = rng.random(n) + (-6.0 if curvature == "indefinite" else 0.1)
    dc = np.full(m, 1e-8)
    K = np.block([[B.dense() + np.diag(dx), J.T], [J, -np.diag(dc)]])
    eigenvalues = np.linalg.eigvalsh(K)
    expected = (int(np.sum(eigenvalues > 0)), int(np.sum(eigenvalues < 0)), 0)
    kkt = LowRankKKT(kkt_class(n, m, ([], []), (rows, cols)))
    assert kkt.factor(B, J[rows, cols], dx, dc) == expected
    if curvature == "positive":
        assert expected == (n, m, 0)
    else:
        assert expected[1] > m
    b = rng.normal(size=n + m)
    assert np.max(np.abs(kkt.solve(b) - np.linalg.solve(K, b))) < 1e-9
    assert np.max(np.abs(kkt.matvec(b) - K @ b)) < 1e-12 * np.max(np.abs(K @ b))
    kkt.release()
    # with no pairs the base system alone: B = sigma I
    empty = LimitedMemoryBFGS(settings(LIMITED)).compact(n)
    K0 = np.block([[np.diag(dx + 1.0), J.T], [J, -np.diag(dc)]])
    kkt.factor(empty, J[rows, cols], dx, dc)
    assert np.max(np.abs(kkt.solve(b) - np.linalg.solve(K0, b))) < 1e-9


@pytest.mark.parametrize("kkt_class", _kkt_classes(), ids=lambda c: c.__name__)
def test_low_rank_inertia_with_steps_of_very_different_lengths(kkt_class):
    """Six pairs, the last step 1e-7 times the others' length (a step after
    heavy backtracking): B stays positive definite and J has full rank, so
    K's inertia is (n, m, 0), as NumPy's eigenvalues of the assembled K say;
    the small eigenvalues of M and G are not taken for zeros (20 random
    problems)."""
    for seed in range(20):
        rng = np.random.default_rng(100 + seed)
        n, m = 10, 3
        Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
        A = Q @ np.diag(10.0 ** rng.uniform(-2, 2, n)) @ Q.T
        S = rng.normal(size=(6, n))
        S[-1] *= 1e-7
        memory = LimitedMemoryBFGS(settings(IPOPTS))
        for s in S:
            memory.update(s, A @ s)
        B = memory.compact(n)
        assert B.M.shape == (12, 12)
        J = rng.normal(size=(m, n))
        rows, cols = np.nonzero(J)
        dx, dc = rng.random(n) * 1e-3, np.zeros(m)
        K = np.block([[B.dense() + np.diag(dx), J.T], [J, np.zeros((m, m))]])
        eigenvalues = np.linalg.eigvalsh(0.5 * (K + K.T))
        assert (int(np.sum(eigenvalues > 0)), int(np.sum(eigenvalues < 0))) == (n, m)
        kkt = LowRankKKT(kkt_class(n, m, ([], []), (rows, cols)))
        assert kkt.factor(B, J[rows, cols], dx, dc) == (n, m, 0), seed


def _rows(text):
    return [m.groups() for m in ROW.finditer(text)]


def _equal_rows(ours, theirs):
    count = 0
    for a, b in zip(ours, theirs):
        if a != b:
            break
        count += 1
    return count


def _ipopt_limited_memory(nlp, x0, tmp_path):
    """IPOPT's L-BFGS with the monotone barrier update: ``(x, status,
    printed table)``."""
    problem = ipopt_problem(nlp)
    log = tmp_path / "ipopt.txt"
    for key, value in (("print_level", 0), ("sb", "yes"), ("output_file", str(log)),
                       ("file_print_level", 5), ("hessian_approximation", "limited-memory"),
                       ("mu_strategy", "monotone")):
        problem.add_option(key, value)
    x, info = problem.solve(np.array(x0, float))
    return x, info["status"], log.read_text()


def test_hock_schittkowski_71_follows_ipopts_iterations(capsys, tmp_path):
    """HS71 from (1, 5, 5, 1): IPOPT's printed rows up to iteration 6 (the
    paths then part by less than the printed digits of the objective), the
    same optimum and multipliers."""
    found = InteriorPoint().solve(_without_hessian(_hs71()), np.array([1.0, 5.0, 5.0, 1.0]),
                                  dict(IPOPTS, linear_solver="dense", print_level=1))
    ours = _rows(capsys.readouterr().out)
    x, status, theirs = _ipopt_limited_memory(_hs71(), [1.0, 5.0, 5.0, 1.0], tmp_path)
    assert status == 0 and found.status == 0
    assert _equal_rows(ours, _rows(theirs)) >= 7
    assert np.max(np.abs(found.x - x)) < 1e-7
    assert found.iterations <= 12


def test_pendulum_swing_up_follows_ipopts_iterations(tmp_path):
    """opty's gallery swing-up, 501 nodes, backward Euler, its random guess
    (seed 0), ``tol = 1e-10``: at least the first 30 rows are IPOPT's (36
    measured: iterations 0 to 35, through 32 pairs of negative curvature
    skipped and the memory emptied ten times); both reach the objective
    15.6415536 (IPOPT by its acceptable stop, the interior point by it or by
    ``tol``: where the end game goes depends on the processor's rounding;
    on an AVX2 machine both stop at acceptable points 6.9e-9 apart, on
    another ours converged within 1e-9 of IPOPT's)."""
    pytest.importorskip("cyipopt", reason="the comparison needs cyipopt (IPOPT)")
    import _ocp_peers as peers
    problem, _ = peers.pendulum_kanedyn(501, backend="numpy")
    guess = np.random.default_rng(0).normal(size=3 * 501)
    log = tmp_path / "ipopt.txt"
    theirs = problem.solve(guess, options=dict(peers.IPOPT_OPTIONS, mu_strategy="monotone",
                                               output_file=str(log), file_print_level=5))
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        ours = problem.solve(guess, solver="interior-point",
                             options=dict(IPOPTS, tol=1e-10, print_level=1))
    assert ours.status in (0, 1) and ours.solver == "interior-point"
    assert theirs.status in (0, 1)
    assert _equal_rows(_rows(printed.getvalue()), _rows(log.read_text())) >= 30
    assert ours.objective == pytest.approx(theirs.objective, rel=1e-7)
    assert ours.objective == pytest.approx(15.6415536, abs=1e-6)


@pytest.mark.parametrize("linear_solver", ["dense", "sparse", "envelope"])
def test_restoration_with_the_approximation(linear_solver):
    """Waechter & Biegler's a = 0, b = 1 from (-2, 1, 1) needs the
    restoration phase (its own memory): the closed-form optimum (1, 1, 0);
    a = -1, b = 1/2: locally infeasible at (-1, 0, 0), status 2."""
    if linear_solver != "dense" and len(_kkt_classes()) == 1:
        pytest.skip("the compiled kernel does not build here (no C compiler)")
    options = dict(LIMITED, linear_solver=linear_solver)
    found = InteriorPoint().solve(_without_hessian(_wachter_biegler(0.0, 1.0)), START,
                                  options)
    assert found.status == 0, found.status_text
    assert np.max(np.abs(found.x - [1.0, 1.0, 0.0])) < 1e-7
    infeasible = InteriorPoint().solve(_without_hessian(_wachter_biegler(-1.0, 0.5)), START,
                                       options)
    assert infeasible.status == 2, infeasible.status_text
    assert np.max(np.abs(infeasible.x - [-1.0, 0.0, 0.0])) < 1e-6


def test_cart_pole_without_the_exact_hessian_reaches_ipopts_optimum():
    """``solve(solver="interior-point")`` with the default ``hessian`` (no
    exact Hessian made): the limited-memory approximation reaches the
    optimum of IPOPT with the exact Hessian (cart-pole, 40 nodes,
    trapezoid)."""
    pytest.importorskip("cyipopt", reason="the comparison needs cyipopt (IPOPT)")
    import _ocp_peers as peers
    problem, _ = peers.cart_pole_kanedyn(40, "trapezoid", backend="numpy")
    guess = problem.guess_line(inputs={problem.symbols.inputs[0]: 0.0})
    tight = {"tol": 1e-10}
    ours = problem.solve(guess, solver="interior-point", options=tight)
    theirs = problem.solve(guess, solver="ipopt", hessian="exact",
                           options=dict(tight, print_level=0))
    assert ours.success and theirs.success, (ours.message, theirs.message)
    assert ours.objective == pytest.approx(theirs.objective, rel=1e-7)
    assert np.max(np.abs(ours.x - theirs.x)) < 1e-4
    # each message names the Hessian its solver used
    assert ours.message.startswith("interior-point (limited-memory Hessian): ")
    assert theirs.message.startswith("ipopt (exact Hessian): ")


def test_limited_memory_options_refused_with_their_names():
    with pytest.raises(ValueError, match='hessian="exact" and .*contradict'):
        InteriorPoint().solve(_hs71(), np.ones(4), LIMITED)
    nlp = _without_hessian(_hs71())
    with pytest.raises(kd.OptionError, match="limited_memory_update_type='sr1'.*damped-bfgs"):
        InteriorPoint().solve(nlp, np.ones(4), {"limited_memory_update_type": "sr1"})
    with pytest.raises(kd.OptionError, match="limited_memory_max_history=-1"):
        InteriorPoint().solve(nlp, np.ones(4), {"limited_memory_max_history": -1})
    with pytest.raises(kd.OptionError, match="limited_memory_init_val=0"):
        InteriorPoint().solve(nlp, np.ones(4), {"limited_memory_init_val": 0.0})
    with pytest.raises(kd.OptionError, match="init_val_min=.*> limited_memory_init_val_max"):
        InteriorPoint().solve(nlp, np.ones(4), {"limited_memory_init_val_min": 10.0,
                                                "limited_memory_init_val_max": 1.0})


def test_infeasible_swing_up_ends_as_ipopts_with_the_exact_hessian():
    """The pendulum swing-up at 40 nodes with the trapezoid rule cannot
    reach upright within |torque| <= 2 N m: IPOPT with the exact Hessian
    ends in local infeasibility (status 2); so does the interior point with
    the damped update (with IPOPT's skipping it runs to ``max_iter``)."""
    pytest.importorskip("cyipopt", reason="the comparison needs cyipopt (IPOPT)")
    import _ocp_peers as peers
    problem, _ = peers.pendulum_kanedyn(40, "trapezoid", backend="numpy")
    guess = problem.guess_line(inputs={problem.symbols.inputs[0]: 0.1})
    theirs = problem.solve(guess, solver="ipopt", hessian="exact",
                           options={"tol": 1e-10, "print_level": 0})
    ours = problem.solve(guess, solver="interior-point", options={"tol": 1e-10})
    assert theirs.status == 2 and ours.status == 2, (theirs.message, ours.message)
    assert "infeasib" in ours.message


def test_closed_loop_which_the_exact_hessian_refuses():
    """A model with constraints (the pendulum in Cartesian coordinates, the
    circle at every node), for which ``hessian="exact"`` is refused: the
    interior point with the approximation reaches IPOPT's optimum (IPOPT
    with its own limited-memory Hessian) and keeps the constraints; the
    swing to 0.5 rad in 2 s of least effort, Hermite-Simpson, 41 nodes."""
    pytest.importorskip("cyipopt", reason="the comparison needs cyipopt (IPOPT)")
    from test_optimal_control import _circle_pendulum
    model, (x, y, vx, vy, tau) = _circle_pendulum()
    problem = kd.OptimalControlProblem(
        model, nodes=41, duration=2.0, lagrange=tau ** 2, initial={x: 0, vx: 0},
        final={x: np.sin(0.5), vx: 0}, method="hermite-simpson")
    guess = problem.guess_line(start={y: -1, vy: 0}, end={y: -np.cos(0.5), vy: 0},
                               inputs={tau: 0.0})
    with pytest.raises(kd.ModelError, match="a model with constraints"):
        problem.solve(guess, solver="interior-point", hessian="exact")
    ours = problem.solve(guess, solver="interior-point", options={"tol": 1e-10})
    theirs = problem.solve(guess, options={"tol": 1e-10, "print_level": 0})
    assert ours.success and theirs.success, (ours.message, theirs.message)
    assert ours.objective == pytest.approx(theirs.objective, rel=1e-8)
    residuals = np.array([model.constraint_residuals(0.0, yk) for yk in ours.y.T])
    assert np.max(np.abs(residuals)) < 1e-9


def test_line_search_failing_near_the_optimum_returns_the_acceptable_iterate():
    """The pendulum swing-up, 200 nodes, midpoint rule: near the optimum the
    approximation's directions stop being accepted at a point feasible to
    1e-15; as IPOPT does at an almost feasible point, the solve ends with
    the last iterate within the acceptable tolerances (status 1, IPOPT's
    objective with the exact Hessian to 1e-6), not with a failed
    restoration (status -2, before)."""
    pytest.importorskip("cyipopt", reason="the comparison needs cyipopt (IPOPT)")
    import _ocp_peers as peers
    problem, _ = peers.pendulum_kanedyn(200, "midpoint", backend="numpy")
    guess = problem.guess_line(inputs={problem.symbols.inputs[0]: 0.1})
    ours = problem.solve(guess, solver="interior-point", options={"tol": 1e-10})
    theirs = problem.solve(guess, solver="ipopt", hessian="exact",
                           options={"tol": 1e-10, "print_level": 0})
    assert theirs.status == 0 and ours.status == 1, (theirs.message, ours.message)
    assert ours.objective == pytest.approx(theirs.objective, rel=1e-6)


def test_nonholonomic_bicycle_lane_change_from_the_command_line(capsys):
    """``kanedyn optimize whipple-bicycle --solver interior-point --hessian
    limited-memory``: the Whipple bicycle's lane change (nonholonomic, which
    the exact Hessian refuses) solved (exit 0) to IPOPT's objective (its
    limited-memory Hessian) to 1e-8."""
    pytest.importorskip("cyipopt", reason="the comparison needs cyipopt (IPOPT)")
    from kanedyn.cli import main
    objectives = {}
    for solver in ("interior-point", "ipopt"):
        argv = ["optimize", "whipple-bicycle", "--solver", solver, "--hessian",
                "limited-memory", "--quiet"]
        assert main(argv) == 0
        text = capsys.readouterr().out
        assert f"solved: {solver} (limited-memory Hessian):" in text
        objectives[solver] = float(text.split("objective ")[1].split()[0].rstrip(";"))
    assert objectives["interior-point"] == pytest.approx(objectives["ipopt"], rel=1e-8)
