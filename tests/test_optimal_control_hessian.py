"""The exact Hessian of the Lagrangian (``solve(hessian="exact")``) on the
problems beyond a fixed duration and the defects alone: a free duration,
free parameters and auxiliary variables, path and instance constraints, on
every collocation method (the one-step ones, Hermite-Simpson, LGR).  Checked
against what shares none of its second derivatives:

- central differences of the exact gradient of the Lagrangian (the NLP's
  constraint Jacobian transposed times the multipliers, plus the objective's
  gradient) at a random point with random multipliers;
- the limited-memory solve of the same problem from the same guess: the
  same optimum, in no more iterations.

(The fixed-duration problems' checks are in test_optimal_control.py.)
"""

import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from test_optimal_control import hessian_and_differences

import kanedyn as kd

pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (pip install "
                    "'kanedyn[optimal]', part of the test extra)")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

TIGHT = {"tol": 1e-12, "max_iter": 500}
METHODS = ["backward-euler", "trapezoid", "midpoint", "hermite-simpson", "lgr"]
T = sm.Symbol("T")


@pytest.fixture(scope="module")
def pendulum():
    definition = kd.models.build("pendulum", torque=True)
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    return definition.numeric(backend="numpy"), (q, u, tau)


def _hessians(problem, seed=3):
    """``(exact, by differences, nlp)`` at a random point (positive free
    parameters, a duration of 1.5) with random multipliers."""
    from kanedyn.optimization._nlp import CollocationNLP
    nlp = CollocationNLP(problem, hessian="exact")
    L = nlp.layout
    rng = np.random.default_rng(seed)
    z, multipliers, sigma = rng.normal(size=nlp.n), rng.normal(size=nlp.m), 0.7
    z[L.free_start:L.free_start + L.n_free] = 1.0 + 0.3 * rng.random(L.n_free)
    if L.free_duration:
        z[L.duration_index] = 1.5
    H, H_fd = hessian_and_differences(nlp, z, multipliers, sigma)
    return H, H_fd, nlp


def _problem(kind, model, symbols, method):
    q, u, tau = symbols
    extra = dict(degree=3) if method == "lgr" else {}
    m, l, s = sm.Symbol("m"), sm.Symbol("l"), sm.Symbol("s")
    if kind == "free duration":  # the integrand and the Mayer term name T too
        return kd.OptimalControlProblem(
            model, nodes=4, duration=T, lagrange=tau ** 2 + sm.sin(q) * u * tau + T * q ** 2,
            mayer=T + q ** 2 * u * T, bounds={tau: (-2, 2), T: (0.5, 5)},
            initial={q: 0, u: 0}, method=method, **extra)
    if kind == "free parameters":  # mass and length (in M and F), an auxiliary s
        return kd.OptimalControlProblem(
            model, nodes=4, duration=T, parameters=[m, l], auxiliary={s: 1.0},
            lagrange=tau ** 2 * l + sm.sin(q) * u * tau * m + s * q ** 2,
            mayer=T * l + q ** 2 * u * m * s,
            bounds={tau: (-2, 2), T: (0.5, 5), m: (0.5, 2), l: (0.5, 2)},
            initial={q: 0, u: 0}, method=method, **extra)
    return kd.OptimalControlProblem(  # path and instance constraints
        model, nodes=4, duration=T, lagrange=tau ** 2, parameters=[m],
        path_constraints=[(u ** 2 * m + sm.cos(q) * tau + T * q, -1, 4), (tau * u, -2, 2)],
        instance_constraints=[q.func(0) * q.func(T) ** 2 + m * u.func(T) * T - 1,
                              sm.sin(u.func(T / 3)) - tau.func(0)],
        bounds={tau: (-2, 2), T: (0.5, 5), m: (0.5, 2)}, initial={u: 0}, method=method,
        **extra)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("kind", ["free duration", "free parameters", "constraints"])
def test_exact_hessian_against_differences(pendulum, kind, method):
    """Each kind of problem on each method: the exact Hessian within 1e-7 of
    its largest entry of the central differences of the exact gradient."""
    model, symbols = pendulum
    H, H_fd, _ = _hessians(_problem(kind, model, symbols, method))
    assert np.max(np.abs(H)) > 1.0
    assert np.max(np.abs(H - H_fd)) < 1e-7 * np.max(np.abs(H))


def test_a_timeless_model_skips_its_time_differences(pendulum):
    """The pendulum names no time, so with the exact Hessian its df/dt (a free
    duration's) is zero without differences: the constraint Jacobian is the
    limited-memory NLP's, which takes them (exactly zero too); the forced
    model below names the time."""
    from kanedyn.numerics import names_time
    from kanedyn.optimization._nlp import CollocationNLP
    model, symbols = pendulum
    assert not names_time(model) and names_time(_forced()[0])
    problem = _problem("free duration", model, symbols, "hermite-simpson")
    exact, plain = CollocationNLP(problem, hessian="exact"), CollocationNLP(problem)
    z = np.random.default_rng(4).normal(size=exact.n)
    z[exact.layout.duration_index] = 1.5
    assert exact._timeless and not plain._timeless
    assert np.array_equal(exact.jacobian(z), plain.jacobian(z))


@pytest.mark.parametrize("method", ["trapezoid", "hermite-simpson"])
def test_exact_hessian_of_the_cart_pole_with_free_masses(method):
    """Two bodies: the cart's and the pole's masses and the length free (the
    mass matrix depends on all three) with a free duration."""
    definition = kd.models.build("n-link-pendulum-on-cart", n=1)
    s = definition.symbols
    model = definition.numeric(backend="numpy", constants={
        s["m_c"]: 1.0, s["m"]: 0.5, s["l"]: 0.8, s["g"]: 9.81})
    (x, theta), (v, omega), F = s["q"], s["u"], s["F"]
    problem = kd.OptimalControlProblem(
        model, nodes=4, duration=T, lagrange=F ** 2 + s["m"] * x ** 2, mayer=T * s["l"],
        parameters=[s["m"], s["l"], s["m_c"]], bounds={T: (0.5, 5)},
        initial={x: 0, theta: 0, v: 0, omega: 0}, method=method)
    H, H_fd, _ = _hessians(problem)
    assert np.max(np.abs(H - H_fd)) < 1e-7 * np.max(np.abs(H))


def _forced(backend="numpy"):
    """A particle forced by sin 2t and damped by cos t: a model naming the time."""
    x, v, F = me.dynamicsymbols("x v F")
    t = me.dynamicsymbols._t
    m, k = sm.symbols("m k")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, v * N.x)
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v],
                  bodies=[me.Particle("P", P, m)],
                  loads=[(P, (F + sm.sin(2 * t) * x - k * sm.cos(t) * v * x) * N.x)])
    model = eom.numeric(constants={m: 1.0, k: 0.3}, specified={F: 0.0}, backend=backend)
    return model, (x, v, F, k)


@pytest.mark.parametrize("method", ["trapezoid", "midpoint", "hermite-simpson", "lgr"])
def test_exact_hessian_of_a_time_dependent_model(method):
    """A model that names the time (a forcing sin 2t and a damping cos t) with
    a free duration and a free parameter: its second derivatives in t are
    generated, but the NLP's own df/dt is by differences (step 1e-6 T), so
    the duration's row and column of the differenced gradient carry that
    noise over 1e-6 (1e-5 here): they are held to 1e-4, the rest to 1e-7."""
    model, (x, v, F, k) = _forced()
    problem = kd.OptimalControlProblem(model, nodes=4, duration=T, lagrange=F ** 2, mayer=T,
                                       parameters=[k], bounds={T: (0.5, 5)},
                                       initial={x: 0, v: 0}, method=method)
    H, H_fd, nlp = _hessians(problem)
    j = nlp.layout.duration_index
    error = np.abs(H - H_fd)
    scale = np.max(np.abs(H))
    assert np.max(np.abs(H[j])) > 0.1  # the time's curvature is there
    assert np.max(np.delete(np.delete(error, j, 0), j, 1)) < 1e-7 * scale
    assert np.max(error[j]) < 1e-4 * scale


def _both(problem, guess):
    found = {h: problem.solve(guess, options=TIGHT, hessian=h)
             for h in ("limited-memory", "exact")}
    approximate, exact = found["limited-memory"], found["exact"]
    assert approximate.success and exact.success, (approximate.message, exact.message)
    assert abs(exact.objective - approximate.objective) < 1e-8 * abs(approximate.objective)
    assert exact.iterations <= approximate.iterations
    return approximate, exact


@pytest.mark.parametrize("method", ["trapezoid", "hermite-simpson"])
def test_minimum_time_reaches_the_limited_memory_optimum(pendulum, method):
    """The pendulum swung up in least time (|tau| <= 8 N m, a little effort
    added): the same optimum and duration as the limited-memory solve."""
    model, (q, u, tau) = pendulum
    problem = kd.OptimalControlProblem(
        model, nodes=31, duration=T, mayer=T, lagrange=1e-2 * tau ** 2,
        bounds={tau: (-8, 8), T: (0.2, 10)}, initial={q: 0, u: 0}, final={q: np.pi, u: 0},
        method=method)
    approximate, exact = _both(problem, problem.guess_line(inputs={tau: 0.0}, duration=2.0))
    assert abs(exact.duration - approximate.duration) < 1e-6


def test_path_constrained_swing_up_reaches_the_limited_memory_optimum(pendulum):
    """A swing-up whose speed (with a little of the power) is kept within a
    bound at every node."""
    model, (q, u, tau) = pendulum
    problem = kd.OptimalControlProblem(
        model, nodes=31, duration=3.0, lagrange=tau ** 2,
        path_constraints=[(u ** 2 + 0.1 * tau * u, 0, 9.0)], bounds={tau: (-8, 8)},
        initial={q: 0, u: 0}, final={q: np.pi, u: 0}, method="trapezoid")
    _both(problem, problem.guess_line(inputs={tau: 0.0}))


def test_free_mass_reaches_the_limited_memory_optimum(pendulum):
    """The swing-up with the bob's mass free (a penalty on its change), LGR of
    degree 3."""
    model, (q, u, tau) = pendulum
    m = sm.Symbol("m")
    problem = kd.OptimalControlProblem(
        model, nodes=11, duration=3.0, lagrange=tau ** 2 + 0.1 * (m - 1) ** 2, parameters=[m],
        bounds={tau: (-8, 8), m: (0.5, 2)}, initial={q: 0, u: 0}, final={q: np.pi, u: 0},
        method="lgr")
    approximate, exact = _both(problem, problem.guess_line(inputs={tau: 0.0}))
    assert abs(exact.parameters["m"] - approximate.parameters["m"]) < 1e-6


def test_instance_constraints_reach_the_limited_memory_optimum(pendulum):
    """The swing-up's ends as instance constraints (a nonlinear one among
    them) instead of bounds, Hermite-Simpson."""
    model, (q, u, tau) = pendulum
    problem = kd.OptimalControlProblem(
        model, nodes=31, duration=3.0, lagrange=tau ** 2,
        instance_constraints=[sm.cos(q.func(3.0)) + 1, u.func(3.0), q.func(0),
                              u.func(0) ** 2 + u.func(0)],
        bounds={tau: (-5, 5), q: (-1, 4)}, method="hermite-simpson")
    _both(problem, problem.guess_line(start={q: 0, u: 0}, end={q: np.pi, u: 0},
                                      inputs={tau: 0.0}))


def test_second_derivatives_no_variable_moves_are_left_out(pendulum):
    """The integrand's second derivative in the time, infinite at t = 0 (the
    trapezoid's first point) for sqrt(t), takes no part where the duration
    is fixed: no decision variable moves the time.  The Hessian's values are
    those of the integrand without the root (a constant in the variables),
    to the bit."""
    from kanedyn.optimization._nlp import CollocationNLP
    model, (q, u, tau) = pendulum
    t = me.dynamicsymbols._t

    def nlp(lagrange):
        return CollocationNLP(kd.OptimalControlProblem(
            model, nodes=6, duration=2.0, lagrange=lagrange, bounds={tau: (-2, 2)},
            initial={q: 0, u: 0}, method="trapezoid"), hessian="exact")

    with_root, without = nlp(tau ** 2 * sm.cos(q) + sm.sqrt(t)), nlp(tau ** 2 * sm.cos(q))
    rng = np.random.default_rng(5)
    z, multipliers = rng.normal(size=with_root.n), rng.normal(size=with_root.m)
    with np.errstate(divide="ignore"):  # sqrt(t)'' at t = 0
        values = with_root.hessian(z, multipliers, 0.7)
    assert np.isfinite(values).all()
    np.testing.assert_array_equal(values, without.hessian(z, multipliers, 0.7))
