"""The articulated-body solve of the C backend over the tree of speeds (issue 18).

For a tree of joints Kane's mass matrix is ``M_rs = S_r^T I(B_r & B_s) S_s``;
the compiled right-hand side then never forms M and solves ``M u' = f`` by an
articulated-body pass (``KD_SOLVE 3``).  Checked against the straight-line
path of the same model (M evaluated and factored, ``KD_SOLVE 1`` or ``2``) and
against the numpy backend (a LAPACK solve of the same M and f), on chains,
a pendulum on a cart (a prismatic root) and random trees read from URDF.
"""

import numpy as np
import pytest
from test_tree_factor import random_tree_urdf

import kanedyn as kd
from kanedyn.numerics.backends import _c as _cbackend
from kanedyn.numerics.backends._c import solver_source

needs_compiler = pytest.mark.skipif(_cbackend.compiler_command() is None,
                                    reason="no C compiler")


def both_paths(definition, tmp_path, monkeypatch):
    """(articulated-body C model, straight-line C model, numpy model)."""
    eom = definition.derive()
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(_cbackend, "TREE_MIN_SPEEDS", 2)  # also for small models
    tree = definition.numeric(eom, backend="c")
    assert solver_source(tree._functions, tree._sizes)[0] == "#define KD_SOLVE 3"
    monkeypatch.setattr(_cbackend, "TREE_MIN_SPEEDS", 10**9)
    straight = definition.numeric(eom, backend="c")
    assert solver_source(straight._functions, straight._sizes)[0] != "#define KD_SOLVE 3"
    monkeypatch.undo()
    return tree, straight, definition.numeric(eom, backend="numpy")


def check_agree(models, seed, states=10, tol=1e-12):
    tree, straight, reference = models
    rng = np.random.default_rng(seed)
    n, o = tree.n_q, tree.n_u
    for _ in range(states):
        y = np.hstack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-2.0, 2.0, o)])
        want = straight.rhs(0.0, y)
        got = tree.rhs(0.0, y)
        assert np.max(np.abs(got - want)) <= tol * np.max(np.abs(want))
        numpy = reference.rhs(0.0, y)
        assert np.max(np.abs(got - numpy)) <= tol * np.max(np.abs(numpy))
        # the batch entry point and the compiled integrator share the solve
        assert np.array_equal(tree.rhs_batch(0.0, y[None, :])[0], got)


@needs_compiler
@pytest.mark.parametrize("n", [2, 10])
def test_chain3d_articulated_and_straight_line_agree(tmp_path, monkeypatch, n):
    definition = kd.models.build("chain3d", n=n, style="positions")
    check_agree(both_paths(definition, tmp_path, monkeypatch), seed=n)


@needs_compiler
@pytest.mark.slow
def test_chain3d_30_articulated_and_straight_line_agree(tmp_path, monkeypatch):
    definition = kd.models.build("chain3d", n=30, style="positions")
    check_agree(both_paths(definition, tmp_path, monkeypatch), seed=30, states=5)


@needs_compiler
@pytest.mark.parametrize("name", ["ladder", "shuttle-arm"])
def test_builtin_models(tmp_path, monkeypatch, name):
    # ladder: three speeds of one free planar body (one support, chained speeds)
    definition = kd.models.build(name)
    check_agree(both_paths(definition, tmp_path, monkeypatch), seed=3)


@needs_compiler
def test_pendulum_on_cart(tmp_path, monkeypatch):
    definition = kd.models.build("n-link-pendulum-on-cart", n=3)
    check_agree(both_paths(definition, tmp_path, monkeypatch), seed=1)


@needs_compiler
@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_trees(tmp_path, monkeypatch, seed):
    rng = np.random.default_rng(seed)
    parent = [-1] + [int(rng.integers(-1, k)) for k in range(1, 9)]
    path = random_tree_urdf(tmp_path / "t.urdf", parent, seed)
    definition = kd.models.from_urdf(path, efforts=False)
    check_agree(both_paths(definition, tmp_path, monkeypatch), seed=seed)


@needs_compiler
def test_simulation_uses_the_same_accelerations(tmp_path, monkeypatch):
    definition = kd.models.build("chain3d", n=3, style="positions")
    tree, straight, _ = both_paths(definition, tmp_path, monkeypatch)
    y0 = np.hstack([np.full(3, 0.3), np.zeros(3)])
    a = kd.simulate(tree, (0.0, 1.0), y0, rtol=1e-10, atol=1e-10)
    b = kd.simulate(straight, (0.0, 1.0), y0, rtol=1e-10, atol=1e-10)
    assert a.success and b.success
    assert np.max(np.abs(a.y[:, -1] - b.y[:, -1])) < 1e-8


def test_speed_tree_outputs_only_for_trees(monkeypatch):
    assert _cbackend.speed_tree_outputs(None, (), (), lambda e: e) is None
    monkeypatch.setattr(_cbackend, "TREE_MIN_SPEEDS", 2)
    tree = {"parent": [-1, 0], "order": [1, 0], "S": [(0,) * 6] * 2,
            "inertia": [(0,) * 10] * 2}
    found = _cbackend.speed_tree_outputs(tree, (1, 2), (3, 4), lambda e: e)
    assert found[1] == ((-1, 0), (1, 0))
    assert [shape for shape, _ in found[0]] == [(2,), (2,), (12,), (20,)]
    monkeypatch.setattr(_cbackend, "TREE_MIN_SPEEDS", 3)  # chosen by size
    assert _cbackend.speed_tree_outputs(tree, (1, 2), (3, 4), lambda e: e) is None
