"""What the collocation NLP and the interior point's reduced NLP hold per
node, and that holding less left their values alone.

- The reduced NLP's patterns (``interior_point._reduced.ReducedNLP``) are
  in ``int32`` and equal what an independent ``int64`` computation of
  the same reduction gives (the free variables' ranks by ``searchsorted``),
  and of the full patterns only the few entries left out are held;
  its scaled Jacobian values equal the full values times the rows' scales,
  with scales of one and with scales below one.
- The NLP with the exact Hessian holds at most 80 bytes per node of the
  pendulum swing-up (backward Euler, NumPy backend) after construction,
  and one Hessian evaluation (its first, which makes the sparse maps)
  peaks at most 120 bytes per node above what is held (traced by
  ``tracemalloc``, a difference of two node counts, so the fixed part
  cancels, with runs of 500 points (``_hessian.CHUNK_POINTS``) so that
  both counts are several runs; measured 53 and 65; with the bounds held
  and a map of every point's entries, 133 and 164; with the patterns
  held and the Hessian evaluated over all points at once, 237 and 904;
  with the per-point linear map held in full and the temporaries not
  summed in place, 369 held).
"""

import tracemalloc

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.optimization._nlp import CollocationNLP
from kanedyn.optimization.interior_point._options import settings
from kanedyn.optimization.interior_point._reduced import ReducedNLP


def _swing_up(nodes):
    definition = kd.models.build("pendulum", torque=True)
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    model = definition.numeric(backend="numpy")
    return kd.OptimalControlProblem(
        model, nodes=nodes, duration=10.0, lagrange=tau ** 2, bounds={tau: (-2.0, 2.0)},
        initial={q: 0.0, u: 0.0}, final={q: np.pi, u: 0.0}, method="backward-euler")


def _guess(nodes):
    t = np.linspace(0.0, 10.0, nodes)
    return np.concatenate([np.stack([np.pi * t / 10.0, np.full(nodes, np.pi / 10.0)],
                                    axis=1).ravel(), 0.1 * np.sin(t)])


@pytest.fixture(scope="module")
def small():
    nlp = CollocationNLP(_swing_up(30), hessian="exact")
    return nlp, ReducedNLP(nlp, _guess(30), settings({}))


def test_reduced_patterns_int32_and_as_computed_in_int64(small):
    """The reduced patterns (the Hessian's made when asked) and the entries
    left out of the full ones (in the fixed variables' columns: the only
    ones held) against a reduction in int64 by ``searchsorted``; the
    reduced values are the full ones at the kept entries."""
    nlp, reduced = small
    x = _guess(30)
    free = np.flatnonzero(nlp.x_lower != nlp.x_upper)
    for is_jacobian, structure, held, dropped, full, values in (
            (True, nlp.jacobian_structure(), reduced.jacobian_structure,
             reduced._jacobian_dropped, nlp.jacobian(x), reduced.jacobian(x)),
            (False, nlp.hessian_structure(), reduced.hessian_structure(),
             reduced._hessian_dropped, nlp.hessian(x, np.ones(nlp.m), 1.0),
             reduced.hessian(x, np.ones(reduced.m)))):
        rows, cols = (np.asarray(a, dtype=np.int64) for a in structure)
        keep = np.isin(cols, free) & (True if is_jacobian else np.isin(rows, free))
        expected_rows = rows[keep] if is_jacobian else np.searchsorted(free, rows[keep])
        expected_cols = np.searchsorted(free, cols[keep])
        assert held[0].dtype == held[1].dtype == dropped.dtype == np.int32
        np.testing.assert_array_equal(dropped, np.flatnonzero(~keep))
        assert 0 < dropped.size < 12  # the four fixed states' entries, not all kept ones
        np.testing.assert_array_equal(held[0], expected_rows)
        np.testing.assert_array_equal(held[1], expected_cols)
        np.testing.assert_array_equal(values, np.asarray(full)[keep])
    assert reduced.hessian_size == reduced.hessian_structure()[0].size
    assert reduced.m == nlp.m  # every row kept: the Jacobian's rows are the full ones
    # the full start vector: the guess with the fixed states at their values
    start = reduced.start_full()
    fixed = nlp.x_lower == nlp.x_upper
    np.testing.assert_array_equal(start[~fixed], x[~fixed])
    np.testing.assert_array_equal(start[fixed], nlp.x_lower[fixed])


def test_reduced_jacobian_values_with_and_without_row_scales(small):
    nlp, _ = small
    x = _guess(30)
    full = np.asarray(nlp.jacobian(x))
    rows, cols = (np.asarray(a, dtype=np.int64) for a in nlp.jacobian_structure())
    free = nlp.x_lower != nlp.x_upper
    keep = free[cols]
    reduced = ReducedNLP(nlp, x, settings({}))
    np.testing.assert_array_equal(reduced.jacobian(x), full[keep])
    # rows 0 and 5 with gradients above nlp_scaling_max_gradient (100): scaled down
    steep = full.copy()
    steep[rows == 0] *= 1e4
    steep[rows == 5] *= 1e3
    reduced.scale_at(x, np.asarray(nlp.gradient(x)), steep)
    row_max = np.zeros(nlp.m)
    np.maximum.at(row_max, rows[keep], np.abs(steep[keep]))
    scale = np.where(row_max > 100.0, np.maximum(100.0 / row_max, 1e-8), 1.0)
    assert scale[0] < 1.0 and scale[5] < 1.0 and scale[1] == 1.0
    np.testing.assert_array_equal(reduced.jacobian(x), full[keep] * scale[rows[keep]])


@pytest.mark.parametrize("chunk", [1 << 16, 1])
def test_reduced_transpose_product_sums_as_bincount(small, monkeypatch, chunk):
    """J^T y of the reduced NLP equals NumPy's ``bincount`` of the entries'
    products to the bit, and the dense product to rounding: for few entries
    by that ``bincount``, for more than ``PRODUCTS_ARRAY_ENTRIES`` (1 here)
    by SciPy's product of the entries (no array of their products)."""
    from kanedyn.optimization.interior_point import _reduced
    monkeypatch.setattr(_reduced, "PRODUCTS_ARRAY_ENTRIES", chunk)
    nlp, _ = small
    x = _guess(30)
    reduced = ReducedNLP(nlp, x, settings({}))
    values = reduced.jacobian(x)
    y = np.random.default_rng(2).normal(size=reduced.m)
    rows, cols = reduced.jacobian_structure
    found = reduced.transpose_times(values, y)
    expected = np.bincount(cols, weights=y[rows] * values, minlength=reduced.n)
    np.testing.assert_array_equal(found.view(np.uint64), expected.view(np.uint64))
    dense = np.zeros((reduced.m, reduced.n))
    np.add.at(dense, (rows, cols), values)
    np.testing.assert_allclose(found, dense.T @ y, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("dropped", [[0], [9], [2, 3, 4], [0, 5, 9], [1, 3, 6, 7]])
def test_entries_left_out_in_place_as_numpy_deletes_them(monkeypatch, dropped):
    """The reduced NLP takes the fixed variables' entries out of an array the
    NLP gave it in that array's own storage (moved a chunk at a time: chunks
    of 2 here): the same values as NumPy's ``delete``, in a view of it."""
    from kanedyn.optimization.interior_point import _reduced
    monkeypatch.setattr(_reduced, "_CHUNK", 2)
    values = np.random.default_rng(1).normal(size=10)
    expected = np.delete(values, dropped)
    kept = _reduced._kept(values, np.array(dropped, dtype=np.int32), owned=True)
    np.testing.assert_array_equal(kept, expected)
    assert kept.base is values


def _traced(nodes):
    """``(held after construction, peak of one Hessian evaluation above
    what is held)``, bytes, of the exact-Hessian NLP at ``nodes``."""
    problem, z = _swing_up(nodes), _guess(nodes)
    warm = CollocationNLP(problem, hessian="exact")  # imports and compiled code first
    warm.hessian(z, np.ones(warm.m), 1.0)
    del warm
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        nlp = CollocationNLP(problem, hessian="exact")
        held = tracemalloc.get_traced_memory()[0] - start
        nlp._evaluate(z)
        before = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        nlp.hessian(z, np.ones(nlp.m), 1.0)
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    return held, peak


def test_exact_hessian_nlp_bytes_per_node(monkeypatch):
    from kanedyn.optimization import _hessian
    monkeypatch.setattr(_hessian, "CHUNK_POINTS", 500)
    (held_1, peak_1), (held_2, peak_2) = _traced(2000), _traced(6000)
    held, peak = (held_2 - held_1) / 4000, (peak_2 - peak_1) / 4000
    # nothing a node: the points' variables are made when asked (they were 12
    # bytes a node when held), their masks one point's, broadcast
    assert abs(held) <= 4
    # the values alone are 16 bytes a node: 2 entries (the angle's and the
    # torque's), where the model's and the objective's second derivatives are not
    # identically zero (6 in the lower triangle)
    assert 16 < peak <= 100


@pytest.mark.parametrize("method", ["backward-euler", "midpoint", "trapezoid",
                                    "hermite-simpson"])
def test_one_points_hessian_map_gives_every_points_sums(method):
    """Where every point has the same map and mask (no free duration), the
    Hessian's sparse map is one point's, applied to all: its values equal to
    the bit those of the map of every point's entries (the sums in the same
    order), and it holds a single point's entries."""
    definition = kd.models.build("pendulum", torque=True)
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    problem = kd.OptimalControlProblem(
        definition.numeric(backend="numpy"), nodes=40, duration=10.0, lagrange=tau ** 2,
        bounds={tau: (-2.0, 2.0)}, initial={q: 0.0, u: 0.0}, final={q: np.pi, u: 0.0},
        method=method)
    nlp = CollocationNLP(problem, hessian="exact")
    z = np.random.default_rng(1).normal(size=nlp.n)
    multipliers = np.random.default_rng(2).normal(size=nlp.m)
    alike = nlp.hessian(z, multipliers, 0.7)
    hessian = nlp.exact_hessian
    kinds = hessian.stages + [hessian.at_points] * (hessian.at_points is not None)
    assert all(p.alike for p in kinds)
    assert all(p.maps(39)[0].shape[0] == p.alike for p in kinds)
    for p in kinds:  # every point's map, as without the shortcut
        p.alike, p._maps = None, None
    every = nlp.hessian(z, multipliers, 0.7)
    assert all(p.maps(39)[0].shape[0] == p.size for p in kinds)
    np.testing.assert_array_equal(alike, every)



def test_a_terms_zero_part_adds_nothing_to_the_gradient():
    """The swing-up's integrand tau^2 has no derivative in the states: its
    part is a read-only broadcast of 0.0 (``identically_zero``, unlike an
    array of zeros, or a slice of one), which the gradient skips (no array
    of zeros made and added): the gradient is still h * 2 tau at each later
    node of an interval (backward Euler), 0 elsewhere, to the bit."""
    from kanedyn.optimization._terms import identically_zero
    problem = _swing_up(50)
    t, Y, R = np.linspace(0, 1, 50), np.ones((50, 2)), np.ones((50, 1))
    _, _, d_y, d_r, _, _ = problem.lagrange(t, Y, R, np.zeros(0), 10.0)
    assert identically_zero(d_y) and identically_zero(d_y[1:])
    assert not identically_zero(d_r) and not identically_zero(np.zeros(3))
    nodes = 600
    z, h = _guess(nodes), 10.0 / (nodes - 1)
    gradient = CollocationNLP(_swing_up(nodes)).gradient(z)
    expected = np.zeros_like(z)
    expected[2 * nodes + 1:] = h * 2.0 * z[2 * nodes + 1:]
    assert gradient.tobytes() == expected.tobytes()
