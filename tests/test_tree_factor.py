"""The tree-following L^T D L solve of the C backend (issue 18, target 2).

The compiled right-hand side solves M u' = f along the elimination tree of the
mass matrix's structural zeros; checked against the numpy backend (a LAPACK
LU solve of the same M and f) and against the dense factorization of the
same module source, on random kinematic trees read from URDF.
"""

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.numerics.backends import _c as _cbackend
from kanedyn.numerics.backends import _c_build
from kanedyn.numerics.backends._c import elimination_tree, solver_source

needs_compiler = pytest.mark.skipif(_cbackend.compiler_command() is None,
                                    reason="no C compiler")


def ancestors_pattern(parent):
    """Structure of a tree mass matrix: (i, j) nonzero iff one is an ancestor."""
    n = len(parent)
    nz = np.eye(n, dtype=bool)
    for k in range(n):
        i = parent[k]
        while i >= 0:
            nz[k, i] = nz[i, k] = True
            i = parent[i]
    return nz


@pytest.mark.parametrize("seed", range(5))
def test_tree_numbered_parents_first_has_no_fill(seed):
    rng = np.random.default_rng(seed)
    n = 25
    parent = [-1] + [int(rng.integers(-1, k)) for k in range(1, n)]
    assert elimination_tree(ancestors_pattern(parent)) == parent


def test_children_numbered_first_fill_in():
    # a star: leaves 0..3, centre 4; eliminating the centre first couples them all
    nz = np.eye(5, dtype=bool)
    nz[4, :] = nz[:, 4] = True
    assert elimination_tree(nz) == [-1, 0, 1, 2, 3]
    # numbered centre first: every leaf's parent is the centre
    nz = np.eye(5, dtype=bool)
    nz[0, :] = nz[:, 0] = True
    assert elimination_tree(nz) == [-1, 0, 0, 0, 0]


def random_tree_urdf(path, parent, seed):
    """A URDF file of revolute joints; link k + 1 hangs from link parent[k] + 1."""
    rng = np.random.default_rng(seed)
    axes = ("1 0 0", "0 1 0", "0 0 1")
    lines = ['<?xml version="1.0"?>', '<robot name="tree">']
    for k in range(len(parent) + 1):
        m = rng.uniform(0.5, 2.0)
        c = rng.uniform(-0.1, 0.1, 3)
        lines.append(f'<link name="l{k}"><inertial><origin xyz="{c[0]} {c[1]} {c[2]}"/>'
                     f'<mass value="{m}"/><inertia ixx="{0.02 * m}" ixy="0.001" '
                     f'ixz="-0.002" iyy="{0.03 * m}" iyz="0.0005" izz="{0.025 * m}"/>'
                     '</inertial></link>')
    for k, p in enumerate(parent):
        o = rng.uniform(-0.3, 0.3, 3)
        lines.append(f'<joint name="j{k + 1}" type="continuous"><parent link="l{p + 1}"/>'
                     f'<child link="l{k + 1}"/><origin xyz="{o[0]} {o[1]} {o[2]}"/>'
                     f'<axis xyz="{axes[int(rng.integers(3))]}"/></joint>')
    lines.append("</robot>")
    path.write_text("\n".join(lines))
    return path


@needs_compiler
@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_random_trees_tree_and_dense_solves_agree(tmp_path, monkeypatch, seed):
    rng = np.random.default_rng(seed)
    parent = [-1, -1, 0, 1, 2, 2, 3, 0, 5][:5] + [int(rng.integers(-1, k))
                                                   for k in range(5, 9)]
    definition = kd.models.from_urdf(random_tree_urdf(tmp_path / "t.urdf", parent, seed),
                                     efforts=False)
    eom = definition.derive()
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path / "cache"))
    # M evaluated and factored (not the articulated-body pass, test_speed_tree.py)
    monkeypatch.setattr(_cbackend, "TREE_MIN_SPEEDS", 10**9)
    tree = definition.numeric(eom, backend="c")
    assert solver_source(tree._functions, tree._sizes)[0] == "#define KD_SOLVE 2"
    reference = definition.numeric(eom, backend="numpy")
    # the same module with the dense factorization (its own cache: same key)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path / "dense"))
    monkeypatch.setattr(_c_build, "_LOADED", {})
    monkeypatch.setattr(_cbackend, "solver_source", lambda *a: ["#define KD_SOLVE 1"])
    dense = definition.numeric(eom, backend="c")
    n = tree.n_q
    for _ in range(10):
        y = np.hstack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-2.0, 2.0, n)])
        want = reference.rhs(0.0, y)
        for model in (tree, dense):
            got = model.rhs(0.0, y)
            assert np.max(np.abs(got - want)) <= 1e-12 * np.max(np.abs(want))
        # the tree solve skips exactly the structural zeros of M
        M = reference.mass_matrix(0.0, y)
        assert np.all(M[~ancestors_pattern(eval_parent(tree))] == 0.0)


def eval_parent(model):
    line = solver_source(model._functions, model._sizes)[1]
    return [int(v) for v in line[line.index("{") + 1:line.index("}")].split(",")]
