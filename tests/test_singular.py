"""Singular configurations: the IFToMM A02 N-four-bar benchmark.

The mechanism's cranks pass the horizontal twice a revolution, where the
loop-closure Jacobian loses half its rank.  The references are independent
of kanedyn's formulations: the motion of the physical (parallelogram) branch
is a one-degree-of-freedom pendulum-like equation, integrated with SciPy's
DOP853 at 1e-13, and the times of the singular positions follow from its
energy integral by quadrature (``kanedyn.models.n_four_bar_exact`` and
``n_four_bar_singular_times``; checked against each other below).  The
benchmark's stated precision is 1e-3 on the path of the crank tip B0 over
20 s, sampled at 400 output steps.
"""

import pickle
import warnings

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.numerics.backends import _c as _cbackend
from kanedyn.models import n_four_bar_exact, n_four_bar_singular_times

needs_compiler = pytest.mark.skipif(_cbackend.compiler_command() is None,
                                    reason="no C compiler")


@pytest.fixture(scope="module")
def a02():
    """``{n: (definition, Kane eom)}``, derived once."""
    out = {}

    def get(n):
        if n not in out:
            d = kd.models.build("n-four-bar", n=n)
            out[n] = (d, d.derive())
        return out[n]
    return get


def run(model, y0, t_end, **options):
    """Simulate, recording the SingularConfigurationWarnings."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = kd.simulate(model, (0.0, t_end), y0, **options)
    found = [w.message for w in caught
             if issubclass(w.category, kd.SingularConfigurationWarning)]
    return res, found


def branch_error(res, n, t=None):
    """Largest |theta0 - exact|, spread of the cranks, largest |coupler angle|."""
    theta, _ = n_four_bar_exact(res.t, n=n)
    q = res.y
    return (np.max(np.abs(q[0] - theta)), np.max(np.abs(q[1:n + 1] - q[0])),
            np.max(np.abs(q[n + 1:2 * n + 1])))


# ---------------------------------------------------------------- the model
def test_model_energies_on_the_branch(a02):
    """n + 1 cranks about their pivots and n translating couplers, by hand."""
    n = 3
    d, eom = a02(n)
    model = d.numeric(eom)
    assert model.n_q == 2 * n + 1 and model.n_q_dep == 2 * n
    for theta, rate in ((np.pi / 2, -1.0), (0.4, 2.5), (-2.0, 0.7)):
        y = model.state({"theta0": theta, "dtheta0": rate, **{
            f"theta{i}": theta for i in range(1, n + 1)}, **{
            f"phi{i}": 0.0 for i in range(1, n + 1)}})
        np.testing.assert_allclose(y[1:n + 1], theta, atol=1e-12)      # parallelogram
        np.testing.assert_allclose(y[2 * n + 2:3 * n + 2], rate, atol=1e-12)
        kinetic = 0.5 * rate ** 2 * ((n + 1) * (1.0 / 3.0) + n * 1.0)   # m = L = 1
        potential = 9.81 * np.sin(theta) * ((n + 1) * 0.5 + n * 1.0)
        assert model.kinetic_energy(0.0, y) == pytest.approx(kinetic, rel=1e-13)
        assert model.potential_energy(0.0, y) == pytest.approx(potential, rel=1e-12,
                                                                abs=1e-12)


def test_model_rejects_bad_n():
    with pytest.raises(kd.ModelError, match="positive integer"):
        kd.models.build("n-four-bar", n=0)
    with pytest.raises(kd.ModelError, match="no option"):
        kd.models.build("n-four-bar", windows=3)


def test_exact_reference_agrees_with_its_quadrature():
    """The DOP853 motion passes the horizontal at the times of the energy quadrature."""
    for n in (1, 10, 40):
        times = n_four_bar_singular_times(20.0, n=n)
        assert len(times) >= 20
        theta, _ = n_four_bar_exact(np.concatenate([[0.0], times]), n=n)
        expected = -np.pi * (np.arange(len(times)) // 2 * 2 + np.arange(len(times)) % 2)
        np.testing.assert_allclose(theta[1:], expected, atol=1e-9)


# ------------------------------------------------------------ conditioning
def test_conditioning_closed_form(a02):
    r"""One rhombus: on the branch B = [[-s, s, 0], [c, -c, 1]] (speeds dtheta0,
    dtheta1, dphi1), so sigma_min / sigma_max = sqrt(lambda_min / lambda_max) of
    B B^T = [[2 s^2, -2 s c], [-2 s c, 2 c^2 + 1]]."""
    d, eom = a02(1)
    model = d.numeric(eom)
    for theta in (np.pi / 2, 0.3, 1e-3, 0.0):
        s, c = np.sin(theta), np.cos(theta)
        a, b, e = 2 * s * s, -2 * s * c, 2 * c * c + 1
        mid, rad = (a + e) / 2, np.hypot((a - e) / 2, b)
        expected = np.sqrt(max(mid - rad, 0.0) / (mid + rad))
        y = np.array([theta, theta, 0.0, -1.0, -1.0, 0.0])
        assert model.constraint_conditioning(0.0, y) == pytest.approx(expected, abs=1e-15,
                                                                      rel=1e-9)
    assert model.constraint_conditioning(0.0, np.zeros(6)) == 0.0


# --------------------------------------------------------- the warning
def check_warning_times(found, expected, count, tol=1e-6):
    assert len(found) == 1, found
    times = np.array(found[0].times)
    assert len(times) >= count
    np.testing.assert_allclose(times[:count], expected[:count], atol=tol)
    assert all(r < 1e-3 for r in found[0].ratios[:count])


def test_kane_elimination_warns_at_the_singular_positions(a02):
    """Kane's elimination (the default) solves for the dependent speeds with a
    block that is singular when the cranks are horizontal: it either stops or
    runs on, and the warning gives the times the cranks passed the horizontal."""
    n = 4
    d, eom = a02(n)
    model = d.numeric(eom)
    res, found = run(model, d.initial(model), 1.5, rtol=1e-10, atol=1e-10)
    exact = n_four_bar_singular_times(1.5, n=n)
    check_warning_times(found, exact, 2)
    assert "passed near a singular configuration at t = " in res.message
    assert f"{exact[0]:.6g}" in res.message


def test_the_note_tells_close_passages_apart(a02):
    """Two minima microseconds apart (a run stepping through a singular
    position) are printed with the digits that tell them apart, and the
    solver's message joins the note without a stray full stop."""
    d, eom = a02(4)
    model = d.numeric(eom)
    monitor = kd.numerics.SingularityMonitor(model)
    monitor.passages = [(1.235975785302133, 5e-8), (1.235978553954648, 7e-8), (1.56, 2e-8)]
    y0 = d.initial(model)
    with pytest.warns(kd.SingularConfigurationWarning):
        message = monitor.finish("Required step size is less than spacing between numbers.",
                                 0.0, y0, 1.56, None)
    assert message.startswith("Required step size is less than spacing between numbers; "
                              "passed near a singular configuration at t = 1.235976, "
                              "1.235979, 1.56 s ")


@needs_compiler
def test_compiled_loop_warns_at_the_singular_positions(a02):
    d, eom = a02(1)
    model = d.numeric(eom, backend="c")
    res, found = run(model, d.initial(model), 1.3, rtol=1e-10, atol=1e-10)
    assert res.method == "RK45 (compiled)"
    # the single rhombus leaves its branch at the first passage (where it goes
    # next depends on round-off): only the first time is the exact one
    check_warning_times(found, n_four_bar_singular_times(1.3, n=1), 1)


def test_no_warning_away_from_singular_positions_or_when_off(a02):
    d = kd.models.build("four-bar")
    model = d.numeric(d.derive())
    res, found = run(model, d.initial(model), 2.0)
    assert res.success and not found and "singular" not in res.message
    d4, eom = a02(4)
    model = d4.numeric(eom)
    res, found = run(model, d4.initial(model), 1.0, singular_threshold=None)
    assert not found and "singular" not in res.message
    with pytest.raises(ValueError, match="singular_threshold"):
        kd.simulate(model, (0.0, 1.0), d4.initial(model), singular_threshold=2.0)


# ------------------------------------------------- the index-3 scheme
def test_index3_passes_the_singular_positions_on_the_branch(a02):
    """Both horizontal positions (right and left): the index-3 augmented
    Lagrangian stays on the parallelogram branch and follows the exact motion;
    its run is warned about too, at the exact times."""
    n = 2
    d, eom = a02(n)
    model = d.numeric(eom, scheme=kd.schemes.AugmentedLagrangianIndex3(step=2e-3))
    t_end = 1.4
    res, found = run(model, d.initial(model), t_end, t_eval=np.linspace(0, t_end, 29))
    assert res.success, res.message
    assert res.method.startswith("trapezoidal rule, index-3 augmented Lagrangian")
    error, spread, coupler = branch_error(res, n)
    assert error < 1e-5
    assert spread < 1e-6 and coupler < 1e-6
    check_warning_times(found, n_four_bar_singular_times(t_end, n=n), 2, tol=1e-5)
    assert np.max(np.abs(res.constraint_residuals[:model.n_q_dep])) < 1e-9


def test_index3_formulation_events_and_dense_output(a02):
    """The registered formulation (Lagrange's equations) with a user event at
    theta0 = 0, whose first root is the first singular time, and a terminal one."""
    d, kane = a02(2)
    eom = d.derive(method="augmented-lagrangian-index3")
    assert isinstance(eom.scheme, kd.schemes.AugmentedLagrangianIndex3)
    model = d.numeric(eom, scheme=kd.schemes.AugmentedLagrangianIndex3(step=2e-3))
    y0 = d.initial(d.numeric(kane))  # Lagrange's speeds are the rates: same layout

    def horizontal(t, y):
        return y[0]
    horizontal.direction = -1

    def bottom(t, y):
        return y[0] + np.pi / 2
    bottom.terminal = True
    res, _ = run(model, y0, 2.0, events=[horizontal, bottom],
                 dense_output=True)
    assert res.status == 1
    first = n_four_bar_singular_times(2.0, n=2)[0]
    assert res.t_events[0][0] == pytest.approx(first, abs=1e-5)
    assert res.y_events[0][0][0] == pytest.approx(0.0, abs=1e-12)
    assert res.t[-1] == pytest.approx(res.t_events[1][0])
    theta, _ = n_four_bar_exact(np.array([0.0, res.t[-1]]), n=2)
    assert theta[-1] == pytest.approx(-np.pi / 2, abs=1e-5)
    np.testing.assert_allclose(res.sol(res.t[5:-1:7]), res.y[:, 5:-1:7], atol=1e-12)


def test_index3_refuses_what_it_cannot_do(a02):
    d = kd.models.build("chaplygin-sleigh")
    model = d.numeric(d.derive(), scheme="augmented-lagrangian-index3")
    with pytest.raises(kd.ModelError, match="speeds are not the coordinate rates"):
        kd.simulate(model, (0.0, 1.0), d.initial(model))
    d = kd.models.build("knife-edge")
    kane = d.numeric(d.derive())
    model = d.numeric(d.derive(method="lagrange"), scheme="augmented-lagrangian-index3")
    with pytest.raises(kd.ModelError, match="nonholonomic"):
        kd.simulate(model, (0.0, 1.0), kane.state(d.initial(kane)))
    d2, eom = a02(1)
    model = d2.numeric(eom, scheme="augmented-lagrangian-index3")
    with pytest.raises(ValueError, match="method='DOP853'"):
        kd.simulate(model, (0.0, 0.1), d2.initial(model), method="DOP853")
    with pytest.raises(ValueError, match="max_step"):
        kd.simulate(model, (0.0, 0.1), d2.initial(model), max_step=0.01)
    with pytest.raises(kd.ModelError, match="step must be positive"):
        kd.schemes.AugmentedLagrangianIndex3(step=0.0)


@needs_compiler
def test_index3_on_the_c_backend_keeps_its_own_rhs(a02):
    d, eom = a02(1)
    scheme = kd.schemes.AugmentedLagrangianIndex3()
    fast, slow = d.numeric(eom, backend="c", scheme=scheme), d.numeric(eom, scheme=scheme)
    y = slow.state(d.initial(slow))
    y[3] = -2.0
    y = slow.state(y)
    np.testing.assert_allclose(fast.rhs(0.0, y), slow.rhs(0.0, y), rtol=1e-12, atol=1e-12)
    copy = pickle.loads(pickle.dumps(fast))
    np.testing.assert_allclose(copy.rhs(0.0, y), slow.rhs(0.0, y), rtol=1e-12, atol=1e-12)


# ------------------------------------------------ the benchmark (slow)
def benchmark_errors(res, n):
    """Largest errors of the path and the velocity of B0 at the 400 output steps."""
    theta, rate = n_four_bar_exact(res.t, n=n)
    q, u = res.y[0], res.y[2 * n + 1]
    position = np.max(np.hypot(np.cos(q) - np.cos(theta), np.sin(q) - np.sin(theta)))
    velocity = np.max(np.hypot(-np.sin(q) * u + np.sin(theta) * rate,
                               np.cos(q) * u - np.cos(theta) * rate))
    return position, velocity


@pytest.mark.slow
@needs_compiler
def test_a02_benchmark_n10(a02):
    """20 s, 400 output steps: the index-3 scheme follows the exact branch motion
    to the benchmark's precision (1e-3) and is warned at all 20 passages."""
    n = 10
    d, eom = a02(n)
    model = d.numeric(eom, backend="c", scheme="augmented-lagrangian-index3")
    t = np.linspace(0.0, 20.0, 401)
    res, found = run(model, d.initial(model), 20.0, t_eval=t)
    assert res.success, res.message
    position, velocity = benchmark_errors(res, n)
    assert position < 1e-3
    assert velocity < 1e-2
    _, spread, coupler = branch_error(res, n)
    assert spread < 1e-6 and coupler < 1e-6
    check_warning_times(found, n_four_bar_singular_times(20.0, n=n), 20, tol=1e-4)
