"""Index arrays held as periodic runs (``interior_point.kkt._periodic``):
the array made again from its runs is the array (collocation patterns of
three methods, arrays with and without repeating stretches); the interior
point with its patterns held as runs takes the same iterates, bit for bit,
as with the arrays (the envelope factorization's products and J^T y walk
the runs in the arrays' order); the kernel refuses runs outside their table.

The thresholds (``PERIODIC_ENTRIES``, ``PROBE_ENTRIES``) are lowered here so
that small problems are held as runs; the solver holds them so beyond
65,536 entries (the 8,192-node pendulum swing-up).
"""

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.optimization._nlp import CollocationNLP
from kanedyn.optimization.interior_point.kkt import _periodic
from kanedyn.optimization.interior_point.kkt._periodic import (
    PeriodicIndex, entries, kernel_index, periodic)


@pytest.fixture
def small_runs(monkeypatch):
    """Arrays of 64 entries or more looked at, periods found in 16 entries."""
    monkeypatch.setattr(_periodic, "PERIODIC_ENTRIES", 64)
    monkeypatch.setattr(_periodic, "PROBE_ENTRIES", 16)


def _swing_up(nodes, method="backward-euler"):
    definition = kd.models.build("pendulum", torque=True)
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    model = definition.numeric(backend="numpy")
    return kd.OptimalControlProblem(
        model, nodes=nodes, duration=10.0, lagrange=tau ** 2, bounds={tau: (-2.0, 2.0)},
        initial={q: 0.0, u: 0.0}, final={q: np.pi, u: 0.0}, method=method)


@pytest.mark.parametrize("method", ["backward-euler", "trapezoid", "hermite-simpson"])
def test_collocation_patterns_as_runs_make_the_arrays_again(small_runs, method):
    """Each pattern array of the 400-node swing-up: held in a few runs (a
    few hundred bytes against its 4 bytes an entry), the array made again
    equal to it."""
    nlp = CollocationNLP(_swing_up(400, method), hessian="exact")
    for structure in (nlp.jacobian_structure(), nlp.hessian_structure()):
        for array in structure:
            array = np.asarray(array, dtype=np.int32)
            index = periodic(array)
            assert isinstance(index, PeriodicIndex)
            assert index.size == array.size and len(index) == array.size
            assert index.nbytes < 0.1 * array.nbytes, (index, array.nbytes)
            made = np.asarray(index)
            assert made.dtype == np.int32
            np.testing.assert_array_equal(made, array)


def test_arrays_with_and_without_runs(small_runs):
    """A stretch without a period between two that repeat, a decreasing
    run and a constant one: made again exactly; random indices, int64 and
    short arrays are returned as they are."""
    rng = np.random.default_rng(3)
    block = np.tile(np.array([0, 3, 1, 7], dtype=np.int32), 300) + np.repeat(
        np.arange(300, dtype=np.int32) * np.int32(5), 4)
    mixed = np.concatenate([block, rng.integers(0, 50, 137).astype(np.int32),
                            np.arange(900, 0, -3, dtype=np.int32),
                            np.full(200, 11, dtype=np.int32)])
    index = periodic(mixed)
    assert isinstance(index, PeriodicIndex) and len(index.runs) >= 3
    np.testing.assert_array_equal(np.asarray(index), mixed)
    # the kernel's argument: the runs and the table, or the array itself
    runs, table = kernel_index(index)
    assert runs is index.runs and table is index.table
    assert kernel_index(mixed) is mixed
    # any stretch of entries, made from the runs that hold it
    for start, stop in ((0, 0), (0, 1), (5, 1203), (1199, 1338), (1300, 1837), (0, 1837)):
        np.testing.assert_array_equal(entries(index, start, stop), mixed[start:stop])
        np.testing.assert_array_equal(entries(mixed, start, stop), mixed[start:stop])
    noise = rng.integers(0, 1000, 5000).astype(np.int32)
    for plain in (noise, np.arange(1000), np.arange(10, dtype=np.int32)):
        assert periodic(plain) is plain


def test_a_periodic_index_is_not_an_array(small_runs):
    """Comparisons, arithmetic and indexing are refused (they would act on
    the object); ``numpy.asarray`` without a copy is refused; bad runs are
    refused when made."""
    index = periodic(np.arange(0, 400, 2, dtype=np.int32))
    for operation in (lambda: index == 3, lambda: index < 3, lambda: index + 1,
                      lambda: index[2], lambda: 2 * index):
        with pytest.raises(TypeError, match="numpy.asarray"):
            operation()
    with pytest.raises(ValueError, match="copy"):
        np.asarray(index, copy=False) if np.lib.NumpyVersion(np.__version__) >= "2.0.0" \
            else index.__array__(copy=False)
    with pytest.raises(ValueError, match="table of 4"):
        PeriodicIndex([[3, 2, 0]], [0, 1, 2, 3])  # bases and steps: 6 places
    with pytest.raises(ValueError, match="runs whose"):
        PeriodicIndex([[1, 2 ** 40, 0]], [0, 1])  # more entries than int32 indexes


def _solve(nodes, method, hessian):
    problem = _swing_up(nodes, method)
    guess = problem.guess_line(inputs={"tau": 0.1})
    return problem.solve(guess, solver="interior-point", hessian=hessian,
                         options={"max_iter": 25})


@pytest.mark.parametrize("method, hessian", [("backward-euler", "exact"),
                                             ("trapezoid", "exact"),
                                             ("hermite-simpson", "limited-memory")])
def test_the_same_iterates_with_patterns_as_runs(monkeypatch, method, hessian):
    """The 300-node swing-up by the interior point (its default envelope
    factorization): with its patterns held as runs (thresholds lowered), the
    same objective, iterations, solution and multipliers to the last bit as
    with the arrays (new orders after a zero pivot: the next test)."""
    from kanedyn.optimization.interior_point import _reduced

    held = []
    hold = _reduced.ReducedNLP.hold_periodic

    def hold_and_note(self):
        hold(self)
        held.append(self.jacobian_structure)
    monkeypatch.setattr(_reduced.ReducedNLP, "hold_periodic", hold_and_note)
    arrays = _solve(300, method, hessian)
    assert held and not any(isinstance(i, PeriodicIndex) for i in held[-1])
    monkeypatch.setattr(_periodic, "PERIODIC_ENTRIES", 64)
    monkeypatch.setattr(_periodic, "PROBE_ENTRIES", 16)
    runs = _solve(300, method, hessian)
    assert all(isinstance(i, PeriodicIndex) for i in held[-1])
    assert runs.iterations == arrays.iterations and runs.status == arrays.status
    assert runs.objective == arrays.objective
    np.testing.assert_array_equal(runs.x.view(np.uint64), arrays.x.view(np.uint64))
    for name in ("g", "x_lower", "x_upper"):
        np.testing.assert_array_equal(runs.multipliers[name].view(np.uint64),
                                      arrays.multipliers[name].view(np.uint64))


def test_transpose_product_of_runs_sums_as_the_arrays(small_runs):
    """J^T y of the reduced NLP with its pattern as runs (the kernel's
    product) equals NumPy's ``bincount`` of the entries' products to the
    bit; the kernel refuses runs that leave their table or do not make the
    values' count, and entries outside the matrix."""
    from kanedyn.optimization.interior_point._options import settings
    from kanedyn.optimization.interior_point._reduced import ReducedNLP
    from kanedyn.optimization.interior_point.kkt._kernel import kernel

    nlp = CollocationNLP(_swing_up(200), hessian="exact")
    x = _swing_up(200).guess_line(inputs={"tau": 0.1})
    reduced = ReducedNLP(nlp, x, settings({}))
    rows, cols = (np.asarray(a) for a in reduced.jacobian_structure)
    reduced.hold_periodic()
    assert all(isinstance(i, PeriodicIndex) for i in reduced.jacobian_structure)
    values = reduced.jacobian(reduced.start_full())
    y = np.random.default_rng(4).normal(size=reduced.m)
    found = reduced.transpose_times(values, y)
    expected = np.bincount(cols, weights=y[rows] * values, minlength=reduced.n)
    np.testing.assert_array_equal(found.view(np.uint64), expected.view(np.uint64))

    out = np.empty(reduced.n)
    row_runs, row_table = kernel_index(reduced.jacobian_structure[0])
    col_index = kernel_index(reduced.jacobian_structure[1])
    beyond = row_runs.copy()
    beyond[-1, 2] = row_table.size  # a run's place past the table's end
    with pytest.raises(ValueError, match="rows: runs that do not make"):
        kernel().transpose_product(out, values, y, (beyond, row_table), col_index)
    with pytest.raises(ValueError, match="not of the values' length"):
        kernel().transpose_product(out, values[:-1], y, rows[:-1], col_index)
    with pytest.raises(ValueError, match="outside"):
        kernel().transpose_product(out, values, y[:-1], (row_runs, row_table), col_index)


def test_envelope_factors_the_same_with_patterns_as_runs():
    """The backward-Euler swing-up at 40,000 nodes (its Jacobian 320,000
    entries, its Hessian 80,000: held as runs at the default thresholds), the
    interior point's start system, whose factorization makes two new orders
    (the band swept forward after a zero pivot; the structures made again
    from the runs):
    ``EnvelopeKKT`` given the runs holds a few hundred bytes of them, and
    gives the same inertia, orders, solution and product, bit for bit, as
    given the arrays; then with Hessian values too."""
    from kanedyn.optimization.interior_point._options import settings
    from kanedyn.optimization.interior_point._reduced import ReducedNLP
    from kanedyn.optimization.interior_point.kkt._envelope import EnvelopeKKT

    nodes = 40_000
    problem = _swing_up(nodes)
    nlp = CollocationNLP(problem, hessian="exact")
    reduced = ReducedNLP(nlp, problem.guess_line(inputs={"tau": 0.1}), settings({}))
    n, m = reduced.n, reduced.m
    x = reduced.start_full()
    jv = reduced.kept_jacobian(np.asarray(nlp.jacobian(x), dtype=float))
    arrays = (reduced.hessian_structure(), reduced.jacobian_structure)
    reduced.hold_periodic()
    runs = (reduced.hessian_structure(), reduced.jacobian_structure)
    assert all(isinstance(i, PeriodicIndex) for s in runs for i in s)
    assert sum(i.nbytes for s in runs for i in s) < 2000
    rng = np.random.default_rng(5)
    hv = rng.normal(size=reduced.hessian_size)
    rhs = rng.normal(size=n + m)
    found = []
    for hessian, jacobian in (arrays, runs):
        kkt = EnvelopeKKT(n, m, hessian, jacobian)
        start = kkt.factor(np.zeros(reduced.hessian_size), jv, np.ones(n), np.zeros(m))
        first = (start, kkt.reanalyses, kkt.analysis.nnz_factor,
                 kkt.analysis.permutation.copy(), kkt.solve(rhs), kkt.matvec(rhs))
        again = kkt.factor(hv, jv, np.full(n, 3.0), 1e-8)
        found.append(first + (again, kkt.solve(rhs), kkt.matvec(rhs)))
    assert found[0][1] == 2 and found[0][0] == (n, m, 0)
    for a, b in zip(*found):
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a.view(np.uint8), b.view(np.uint8))
        else:
            assert a == b


def test_the_kernel_walks_runs_across_its_blocks(small_runs):
    """The kernel takes an index's entries 1,024 at a time: runs of periods
    1, 3 and 7 (a period cut by a block's end), stretches without a period
    and runs of one repeat, in rows and columns laid out differently.  Its
    J^T y from the runs equals NumPy's ``bincount`` from the arrays, bit for
    bit."""
    from kanedyn.optimization.interior_point.kkt._kernel import kernel

    rng = np.random.default_rng(6)

    def run(period, repeats, steps, bases):
        return (np.asarray(bases, dtype=np.int64)[None, :]
                + np.arange(repeats)[:, None] * np.asarray(steps)[None, :]).ravel()
    rows = np.concatenate([run(3, 1001, [1, 1, 2], [0, 5, 9]), rng.integers(0, 900, 333),
                           run(1, 2500, [1], [7]), run(7, 400, [2] * 7, range(7)),
                           rng.integers(0, 900, 5)]).astype(np.int32)
    cols = np.concatenate([run(1, 3003, [1], [0]), rng.integers(0, 3000, 333),
                           run(5, 500, [3] * 5, [1, 0, 4, 2, 3]),
                           run(2, 1400, [1, 2], [0, 1]), rng.integers(0, 3000, 5)]
                          ).astype(np.int32)
    assert rows.size == cols.size
    n, m = int(cols.max()) + 1, int(rows.max()) + 1
    index_rows, index_cols = periodic(rows), periodic(cols)
    assert isinstance(index_rows, PeriodicIndex) and isinstance(index_cols, PeriodicIndex)
    assert {1, 3, 7} <= set(index_rows.runs[:, 0].tolist())
    values, y = rng.normal(size=rows.size), rng.normal(size=m)
    out = np.empty(n)
    kernel().transpose_product(out, values, y, kernel_index(index_rows),
                               kernel_index(index_cols))
    expected = np.bincount(cols, weights=y[rows] * values, minlength=n)
    np.testing.assert_array_equal(out.view(np.uint64), expected.view(np.uint64))
