"""The search for singular configurations as a run goes (issue 33, item 4).

The compiled loop looks for the minima of sigma_min / sigma_max of the
constraint Jacobian step by step, in C, and keeps only the minima it finds
(before, it kept every step of a constrained run for a search afterwards: the
four-bar to 10^4 s took 1 GB).  The minima it finds are those of the numpy path
(SciPy's event location), forward and backward in time, first and last states
included.
"""

import tracemalloc
import warnings

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.numerics.backends import _c as _cbackend

pytestmark = pytest.mark.skipif(_cbackend.compiler_command() is None, reason="no C compiler")


def passages(model, t_span, y0, **options):
    """Times and ratios of the SingularConfigurationWarning of a run (empty: none)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        kd.simulate(model, t_span, y0, rtol=1e-10, atol=1e-10, **options)
    found = [w.message for w in caught
             if issubclass(w.category, kd.SingularConfigurationWarning)]
    assert len(found) <= 1
    return (np.array(found[0].times), np.array(found[0].ratios)) if found else (
        np.zeros(0), np.zeros(0))


@pytest.fixture(scope="module")
def four_bar():
    d = kd.models.build("four-bar")
    eom = d.derive()
    return d, {backend: d.numeric(eom, backend=backend) for backend in ("numpy", "c")}


def test_memory_of_a_long_compiled_run_is_set_by_its_outputs(four_bar):
    """300 s of the four-bar (23,000 steps) with 11 output times: the run's
    allocations stay far below what its steps would take (the search kept
    them: 26 MB; now 0.02 MB)."""
    d, models = four_bar
    model = models["c"]
    y0 = d.initial(model)
    kd.simulate(model, (0.0, 1.0), y0, t_eval=[0.0, 1.0])  # what the first run loads
    tracemalloc.start()
    try:
        res = kd.simulate(model, (0.0, 300.0), y0, t_eval=np.linspace(0.0, 300.0, 11))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert res.success and res.nfev > 100_000
    assert peak < 2e6


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_a_backward_run_finds_the_minima_of_the_forward_run(four_bar, backend):
    """Minima of the ratio (a threshold of 0.9 makes the four-bar's swing count):
    integrated back from the end state, the same times and ratios, not the maxima
    (a search that looked for a rising rate in the order of the steps reported
    the maxima of a backward run)."""
    d, models = four_bar
    model = models[backend]
    y0 = d.initial(model)
    end = kd.simulate(model, (0.0, 3.0), y0, rtol=1e-10, atol=1e-10,
                      singular_threshold=None).y[:, -1]
    t_fw, r_fw = passages(model, (0.0, 3.0), y0, singular_threshold=0.9)
    t_bw, r_bw = passages(model, (3.0, 0.0), end, singular_threshold=0.9)
    assert len(t_fw) == 4  # the first and last states and two minima between
    np.testing.assert_allclose(t_bw, t_fw, atol=1e-6)
    np.testing.assert_allclose(r_bw, r_fw, rtol=1e-6)


def test_the_compiled_search_finds_the_numpy_paths_minima():
    """The n-four-bar (n = 2) leaves its branch at the first singular position and
    passes near singular positions again and again: the compiled loop finds every
    minimum that SciPy's event location finds, at the same times; a run that
    starts near a singular position and one that stops near one count their first
    and last states."""
    d = kd.models.build("n-four-bar", n=2)
    eom = d.derive()
    numpy_model, c_model = d.numeric(eom), d.numeric(eom, backend="c")
    y0 = d.initial(numpy_model)
    t_np, r_np = passages(numpy_model, (0.0, 1.5), y0)
    t_c, r_c = passages(c_model, (0.0, 1.5), y0)
    assert len(t_np) >= 2 and len(t_c) == len(t_np)
    np.testing.assert_allclose(t_c, t_np, atol=1e-6)
    assert np.all((r_c < 1e-3) & (r_np < 1e-3))
    first = t_np[0]
    near = numpy_model.state({"theta0": 1e-5, "theta1": 1e-5, "theta2": 1e-5, "phi1": 0.0,
                              "phi2": 0.0, "dtheta0": 1.0})
    for model in (numpy_model, c_model):
        assert passages(model, (0.0, 0.1), near)[0][0] == 0.0        # starts near one
        stop = passages(model, (0.0, first - 1e-6), y0)[0]           # stops near one
        assert stop[-1] == pytest.approx(first - 1e-6, abs=1e-12)


def test_the_screen_spares_the_steps_far_from_singular_positions():
    """What keeps the search cheap (the Whipple bicycle's 5 s run: 1.02 times the
    time without it, benchmarks/bench_singular_monitor.py): a step whose bound on
    the ratio stays above the threshold is not examined.  The bicycle's steps are
    all spared; the n-four-bar's steps near its singular positions are not."""
    def examined(name, t_end, **options):
        d = kd.models.build(name, **options)
        model = d.numeric(d.derive(), backend="c")
        atol = np.full(model.n_states, 1e-8)
        out = model._c.integrate(0.0, t_end, d.initial(model), None, 1e-8, atol, np.inf, 0.0,
                                 "RK45", None, 1e-6, False, 1e-3, 1e-7)
        return out["singular_examined"], out["nfev"] // 6, len(out["singular_t"])

    spared, steps, found = examined("whipple-bicycle", 5.0)
    assert spared == 0 and steps > 50 and found == 0
    near, steps, found = examined("n-four-bar", 1.5, n=2)
    assert 0 < near < steps and found >= 2
