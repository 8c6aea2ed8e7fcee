"""The interior point's large arrays in mappings of their own
(``optimization/interior_point/_mapped.py``) and the KKT kernel's large
scratch and results likewise: the handler's scope, the arrays' contents,
memory handed back, and the same iterates either way."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest
import scipy.sparse as sp

from kanedyn.optimization.interior_point import _mapped

if _mapped.module() is None:
    pytest.skip("a C compiler, POSIX and NumPy's memory handlers (1.22) are needed",
                allow_module_level=True)

MIB = 2 ** 20
LARGE = _mapped.MAPPED_BYTES // 8  # float64 entries of a mapped array


def _resident_bytes():
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def test_the_handler_is_in_force_only_inside_the_context():
    """Arrays made inside keep the handler (also past the context); outside,
    NumPy's own is in force again; a context inside another changes nothing."""
    core = _mapped._core()
    before = core.get_handler_name()
    with _mapped.mapped_large_arrays():
        assert core.get_handler_name() == _mapped.HANDLER_NAME
        big, small = np.ones(2 * LARGE), np.arange(10.0)
        with _mapped.mapped_large_arrays():
            assert core.get_handler_name() == _mapped.HANDLER_NAME
        assert core.get_handler_name() == _mapped.HANDLER_NAME
    assert core.get_handler_name() == before
    assert core.get_handler_name(big) == core.get_handler_name(small) == _mapped.HANDLER_NAME
    assert big.sum() == 2 * LARGE and small.sum() == 45.0
    with _mapped.mapped_large_arrays(enabled=False):
        assert core.get_handler_name() == before


def test_arrays_hold_what_was_written_and_zeros_are_zero():
    """np.zeros of a kept mapping (one freed by an array of ones of the same
    size) is zero; ``resize`` keeps the contents, growing and shrinking."""
    with _mapped.mapped_large_arrays():
        ones = np.ones(LARGE + 3)
        del ones  # kept for the next array of its length
        zeros = np.zeros(LARGE + 3)
        assert not zeros.any()
        a = np.arange(LARGE + 3, dtype=float)
        a.resize(3 * LARGE, refcheck=False)
        assert np.array_equal(a[:LARGE + 3], np.arange(LARGE + 3)) and not a[LARGE + 3:].any()
        a.resize(LARGE // 2, refcheck=False)  # below the size: NumPy's allocator's
        assert np.array_equal(a, np.arange(LARGE // 2))
        b = np.empty(0)
        b.resize(2 * LARGE, refcheck=False)
        assert b.size == 2 * LARGE


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc (Linux)")
def test_freed_arrays_go_back_to_the_system():
    """Freed mappings are kept while the context is open (at most
    CACHED_BLOCKS); an array of another length hands back kept ones (the
    oldest first) of at least its own bytes before it maps its own, so the
    resident memory does not grow; all go back when the context closes; an
    array that outlives the context hands its own back when it goes."""
    compiled = _mapped.module()
    alive, _ = compiled.counts()  # (mappings of arrays other tests may hold)
    start = _resident_bytes()
    with _mapped.mapped_large_arrays():
        arrays = [np.ones(5 * MIB) for _ in range(10)]  # 40 MB each
        assert _resident_bytes() - start > 380 * MIB
        del arrays
        assert compiled.counts() == (alive, _mapped.CACHED_BLOCKS)
        before = _resident_bytes()
        other = np.ones(6 * MIB)  # 48 MB, another length: two kept ones handed back
        assert compiled.counts() == (alive + 1, _mapped.CACHED_BLOCKS - 2)
        assert _resident_bytes() <= before + MIB
        del other
        outliving = np.ones(40 * MIB)  # 320 MB
    assert compiled.counts() == (alive + 1, 0)
    assert _resident_bytes() - start > 300 * MIB
    del outliving
    assert _resident_bytes() - start < 100 * MIB
    assert compiled.counts() == (alive, 0)


def test_the_kernel_s_large_results_are_scipy_s_patterns():
    """The kernel's csr of 1.2 million entries (a result of more than 4 MiB,
    in a mapping that gives back the part its merged repeats leave) is
    SciPy's canonical pattern."""
    from kanedyn.optimization.interior_point.kkt._kernel import kernel
    from kanedyn.optimization.interior_point.kkt._ordering import _part
    rng = np.random.default_rng(3)
    n_rows, n_cols, entries = 300_000, 200_000, 1_200_000
    rows = rng.integers(0, n_rows, entries).astype(np.int32)
    cols = rng.integers(0, n_cols, entries).astype(np.int32)
    rows[::7], cols[::7] = rows[1::7][:rows[::7].size], cols[1::7][:cols[::7].size]  # repeats
    indptr, indices = (np.frombuffer(b, dtype=np.int32) for b in kernel().csr(
        n_rows, n_cols, False, _part(rows, cols, 0)))
    expected = sp.coo_matrix((np.ones(entries), (rows, cols)), shape=(n_rows, n_cols)).tocsr()
    expected.sum_duplicates()
    assert np.array_equal(indptr, expected.indptr)
    assert np.array_equal(indices, expected.indices)


def test_the_same_iterates_with_either_allocator():
    """The 40,000-node swing-up (its factors, Jacobian and vectors of several
    MB: mapped) solved with ``large_arrays="mapped"`` and ``"numpy"``: the
    same iterates to the bit, and the multipliers of the fixed variables
    from the last Jacobian evaluated as from one evaluated again."""
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))
    import _ocp_peers as peers
    nodes = 40_000
    problem, _ = peers.pendulum_kanedyn(nodes)
    guess = peers.pendulum_guess(nodes)
    results = [problem.solve(guess, solver="interior-point", hessian="exact",
                             options=dict(max_iter=4, large_arrays=choice))
               for choice in ("mapped", "numpy")]
    a, b = results
    assert a.iterations == b.iterations == 4
    assert a.x.tobytes() == b.x.tobytes()
    for key in a.multipliers:
        assert np.asarray(a.multipliers[key]).tobytes() == \
            np.asarray(b.multipliers[key]).tobytes()


def test_an_unknown_choice_is_refused():
    from kanedyn._errors import OptionError
    from kanedyn.optimization.interior_point._options import settings
    with pytest.raises(OptionError, match="large_arrays='disk'.*'mapped', 'numpy'"):
        settings({"large_arrays": "disk"})


def test_the_fixed_variables_multipliers_from_the_last_jacobian(monkeypatch):
    """The multipliers of the fixed variables (the swing-up's ends) from the
    Jacobian's entries kept at the last evaluation are those of the NLP's
    Jacobian evaluated again at the optimum, to the bit."""
    import kanedyn as kd
    from kanedyn.optimization.interior_point import _reduced
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend="numpy")
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    problem = kd.OptimalControlProblem(
        model, nodes=40, duration=2.0, lagrange=tau ** 2, bounds={tau: (-20.0, 20.0)},
        initial={q: 0.0, u: 0.0}, final={q: 1.0, u: 0.0})
    guess = problem.guess_line(inputs={tau: 0.0})

    def solved():
        return problem.solve(guess, solver="interior-point", hessian="exact")
    kept = solved()
    jacobian = _reduced.ReducedNLP.jacobian

    def forgetting(self, x_full):  # as if no entry were kept: evaluated again
        values = jacobian(self, x_full)
        self.fixed_jacobian = None
        return values
    monkeypatch.setattr(_reduced.ReducedNLP, "jacobian", forgetting)
    again = solved()
    assert kept.status == again.status == 0
    assert np.abs(kept.multipliers["x_lower"]).max() > 0  # the fixed ends have some
    for key in kept.multipliers:
        assert np.asarray(kept.multipliers[key]).tobytes() == \
            np.asarray(again.multipliers[key]).tobytes()
