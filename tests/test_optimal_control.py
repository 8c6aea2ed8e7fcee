"""Optimal control by direct collocation (``kd.OptimalControlProblem``), checked
against what shares none of its code:

- closed forms: the rest-to-rest double integrator of least effort
  (u = 6 - 12 t, objective 12), its minimum-time twin (T = 2), a free mass
  (the optimum at its bound, objective 12 m^2); the convergence orders of
  backward Euler (1) and the trapezoid (2) in the states, and of the
  re-simulation defect;
- opty on the same discrete problem (pendulum and cart-pole swing-ups, its
  equations written by hand and by SymPy's KanesMethod): the same optimum,
  and LGR of degree 1 (backward Euler's problem) reaching it too;
- Legendre-Gauss-Radau: the Radau IIA tableaux in closed form, the
  oscillator's closed form (the error falling with the degree, order 2d - 1
  with the mesh), Hermite-Simpson's optimum on a fine mesh;
- the NLP's Jacobian and gradient against central differences;
- a closed loop (a pendulum in Cartesian coordinates with its length as a
  constraint) against the same motion in its angle.

IPOPT through cyipopt is needed; without it every test here is skipped,
saying so.
"""

import re
import signal
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (pip install "
                    "'kanedyn[optimal]', part of the test extra)")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

TIGHT = {"tol": 1e-12, "max_iter": 500}


def _particle_on_a_line(force):
    """``(eom, x, v, m)``: a particle of mass m at x on a line, speed v, under
    the force ``force(x, v)``."""
    x, v = me.dynamicsymbols("x v")
    m = sm.Symbol("m")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, v * N.x)
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v],
                  bodies=[me.Particle("P", P, m)], loads=[(P, force(x, v) * N.x)])
    return eom, x, v, m


def _double_integrator(backend="numpy", mass=1.0):
    F = me.dynamicsymbols("F")
    eom, x, v, m = _particle_on_a_line(lambda x, v: F)
    model = eom.numeric(constants={m: mass}, specified={F: 0.0}, backend=backend)
    return model, (x, v, F, m)


def _rest_to_rest(model, symbols, nodes, method, **extra):
    x, v, F, _ = symbols
    problem = kd.OptimalControlProblem(model, nodes=nodes, duration=1.0, lagrange=F ** 2,
                                       initial={x: 0, v: 0}, final={x: 1, v: 0},
                                       method=method, **extra)
    result = problem.solve(problem.guess_line(inputs={F: 0.0}), options=TIGHT)
    assert result.success, result.message
    return result


@pytest.fixture(scope="module")
def integrator():
    return _double_integrator()


def _order(errors, nodes):
    return np.log(errors[0] / errors[1]) / np.log((nodes[1] - 1) / (nodes[0] - 1))


@pytest.mark.parametrize("method, order", [("backward-euler", 1), ("trapezoid", 2)])
def test_rest_to_rest_closed_form_and_order(integrator, method, order):
    """x(t) = 3t^2 - 2t^3, u = 6 - 12t, objective 12: the collocated states
    converge at the method's order, and the objective extrapolated (Richardson,
    the objective's order 2 for both) matches 12 to 1e-6."""
    model, symbols = integrator
    nodes = (201, 401)
    results = [_rest_to_rest(model, symbols, n, method) for n in nodes]
    errors = [np.max(np.abs(r["x"] - (3 * r.t ** 2 - 2 * r.t ** 3))) for r in results]
    assert abs(_order(errors, nodes) - order) < 0.15, errors
    J = [r.objective for r in results]
    assert abs(_order([J[0] - 12, J[1] - 12], nodes) - 2) < 0.05
    extrapolated = (4 * J[1] - J[0]) / 3  # h halved, order 2
    assert abs(extrapolated - 12.0) < 1e-6
    for r in results:
        assert r.constraint_violation < 1e-9
    # the control in the interior, away from the ends where the trapezoid's
    # first and last values lag by O(h)
    r = results[1]
    inner = slice(r.t.size // 4, 3 * r.t.size // 4)
    assert np.max(np.abs(r["F"][inner] - (6 - 12 * r.t[inner]))) < 0.1


@pytest.mark.parametrize("method, order", [("backward-euler", 1), ("trapezoid", 2)])
def test_resimulation_defect_shrinks_with_nodes(integrator, method, order):
    """The optimal inputs simulated (held or interpolated as collocated) end
    where the collocated states are, up to the method's error."""
    model, symbols = integrator
    nodes = (41, 81)
    defects = [_rest_to_rest(model, symbols, n, method).resimulate().max_defect
               for n in nodes]
    assert abs(_order(defects, nodes) - order) < 0.2, defects


def test_minimum_time_closed_form(integrator):
    """|F| <= 1 from rest to rest over a distance 1: bang-bang, T = 2."""
    model, (x, v, F, _) = integrator
    T = sm.Symbol("T")
    found = []
    for nodes in (41, 81):
        problem = kd.OptimalControlProblem(
            model, nodes=nodes, duration=T, mayer=T, bounds={F: (-1, 1), T: (0.5, 5)},
            initial={x: 0, v: 0}, final={x: 1, v: 0}, method="trapezoid")
        result = problem.solve(problem.guess_line(inputs={F: 0.0}, duration=3.0),
                               options={"tol": 1e-10})
        assert result.success, result.message
        found.append(result.duration)
    assert abs(found[-1] - 2.0) < 0.02
    assert abs(found[-1] - 2.0) <= abs(found[0] - 2.0)


def test_free_parameter_goes_to_its_bound():
    """The mass free in [0.5, 2]: least effort is at m = 0.5, objective 12 m^2
    (extrapolated as above)."""
    model, symbols = _double_integrator(mass=1.3)
    x, v, F, m = symbols
    results = [_rest_to_rest(model, symbols, n, "trapezoid", parameters=[m],
                             bounds={m: (0.5, 2.0)}) for n in (201, 401)]
    for r in results:
        assert abs(r.parameters["m"] - 0.5) < 1e-8
    J = [r.objective for r in results]
    assert abs((4 * J[1] - J[0]) / 3 - 12 * 0.25) < 1e-6


def test_epigraph_bound_is_the_least_peak_force(integrator):
    """An auxiliary variable s with -s <= F <= s, minimized: the least peak
    |F| of the unit rest-to-rest move in 1 s is bang-bang, F = 4 then -4
    (x = a/4 = 1).  Hermite-Simpson finds 4 to 1e-7 (the switch at t = 0.5 is
    a node); the trapezoid approaches from above at order 2.  The model
    never sees s: its simulation with the optimal force ends at x = 1."""
    model, (x, v, F, _) = integrator
    s = sm.Symbol("s")
    found = {}
    for method, nodes in (("hermite-simpson", 21), ("trapezoid", 41), ("trapezoid", 81)):
        problem = kd.OptimalControlProblem(
            model, nodes=nodes, duration=1.0, mayer=s, auxiliary={s: 10.0},
            bounds={s: (0, None)}, path_constraints=[(F - s, None, 0), (F + s, 0, None)],
            initial={x: 0, v: 0}, final={x: 1, v: 0}, method=method)
        result = problem.solve(problem.guess_line(inputs={F: 0.0}), options={"tol": 1e-10})
        assert result.success, result.message
        assert result.objective == result.parameters["s"]
        assert np.max(np.abs(result["F"])) <= result.parameters["s"] * (1 + 1e-8)
        found[method, nodes] = result.parameters["s"]
        if method == "hermite-simpson":
            assert abs(result.parameters["s"] - 4.0) < 1e-7
            run = result.resimulate()
            assert abs(run.simulation["x"][-1] - 1.0) < 1e-6
    e41, e81 = found["trapezoid", 41] - 4, found["trapezoid", 81] - 4
    assert e41 > e81 > 0
    assert abs(_order([e41, e81], (41, 81)) - 2) < 0.1


# ------------------------------------------------------------ Hermite-Simpson
def _oscillator(omega=3.0):
    """x'' + omega^2 x = F (unit mass on a spring), and the closed form of its
    least-effort rest-to-rest move from x = 0 to x = 1 in 1 s: the costate
    equations make F = a cos(omega t) + b sin(omega t), whose response from
    rest is a t sin(omega t) / (2 omega) + b (sin(omega t) - omega t
    cos(omega t)) / (2 omega^2); a, b from x(1) = 1, v(1) = 0."""
    x, v, F = me.dynamicsymbols("x v F")
    m, k = sm.symbols("m k")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, v * N.x)
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v],
                  bodies=[me.Particle("P", P, m)], loads=[(P, (F - k * x) * N.x)])
    model = eom.numeric(constants={m: 1.0, k: omega ** 2}, specified={F: 0.0})
    w = omega

    def position(t, a, b):
        return a * t * np.sin(w * t) / (2 * w) + b * (np.sin(w * t) - w * t * np.cos(w * t)) \
            / (2 * w ** 2)

    def rate(t, a, b):
        return a * (np.sin(w * t) + w * t * np.cos(w * t)) / (2 * w) \
            + b * t * np.sin(w * t) / 2

    a, b = np.linalg.solve([[position(1, 1, 0), position(1, 0, 1)],
                            [rate(1, 1, 0), rate(1, 0, 1)]], [1.0, 0.0])
    from scipy.integrate import quad
    objective = quad(lambda t: (a * np.cos(w * t) + b * np.sin(w * t)) ** 2, 0, 1,
                     epsabs=1e-14)[0]
    exact = dict(x=lambda t: position(t, a, b), v=lambda t: rate(t, a, b),
                 F=lambda t: a * np.cos(w * t) + b * np.sin(w * t), objective=objective)
    return model, (x, v, F), exact


def _oscillator_solve(model, symbols, nodes, method):
    x, v, F = symbols
    problem = kd.OptimalControlProblem(model, nodes=nodes, duration=1.0, lagrange=F ** 2,
                                       initial={x: 0, v: 0}, final={x: 1, v: 0},
                                       method=method)
    result = problem.solve(problem.guess_line(inputs={F: 0.0}), options=TIGHT)
    assert result.success, result.message
    return result


def test_hermite_simpson_and_midpoint_inputs_are_piecewise_polynomials():
    """The optimum's inputs of Hermite-Simpson and of the midpoint rule are
    ``PiecewisePolynomial`` objects (which a C model compiles): Hermite-Simpson's
    the quadratic through the collocated inputs at each interval's ends and
    midpoint, the midpoint rule's the average of the ends, held; both
    extrapolate their end pieces."""
    from kanedyn.modeling import PiecewisePolynomial
    model, symbols, _ = _oscillator()
    hs = _oscillator_solve(model, symbols, 11, "hermite-simpson")
    f = hs.inputs()["F"]
    assert isinstance(f, PiecewisePolynomial)
    F, F_mid = hs.r[0], hs.r_mid[0]
    np.testing.assert_allclose([f(t) for t in hs.t], F, rtol=0, atol=1e-12 * np.abs(F).max())
    np.testing.assert_allclose([f(t) for t in hs.t_mid], F_mid, rtol=0,
                               atol=1e-12 * np.abs(F).max())
    h = hs.t[1] - hs.t[0]  # beyond the end: the last interval's quadratic
    quadratic = np.polyfit([hs.t[-2], hs.t_mid[-1], hs.t[-1]], [F[-2], F_mid[-1], F[-1]], 2)
    assert f(hs.t[-1] + 0.5 * h) == pytest.approx(np.polyval(quadratic, hs.t[-1] + 0.5 * h),
                                                  rel=1e-9)
    mid = _oscillator_solve(model, symbols, 11, "midpoint")
    g = mid.inputs()["F"]
    assert isinstance(g, PiecewisePolynomial)
    held = 0.5 * (mid.r[0][:-1] + mid.r[0][1:])
    inside = mid.t[:-1] + 0.3 * (mid.t[1] - mid.t[0])
    np.testing.assert_allclose([g(t) for t in inside], held, rtol=1e-14, atol=1e-14)
    assert g(mid.t[-1] + 0.1) == pytest.approx(held[-1], rel=1e-14)


def test_hermite_simpson_fourth_order_on_a_closed_form():
    """The oscillator's least-effort move (closed form above, objective
    17.1998...): Hermite-Simpson's states, objective and re-simulation defect
    converge at order 4 (measured 4.00, 4.00, 3.99); its inputs at the nodes
    and midpoints at order 2, their errors of opposite signs in the ratio of
    Simpson's weights (so that they cancel in the states)."""
    model, symbols, exact = _oscillator()
    nodes = (11, 21, 41)
    results = [_oscillator_solve(model, symbols, n, "hermite-simpson") for n in nodes]
    for name in ("x", "v"):
        errors = [np.max(np.abs(r[name] - exact[name](r.t))) for r in results]
        assert all(abs(_order(errors[i:i + 2], nodes[i:i + 2]) - 4) < 0.1
                   for i in range(2)), (name, errors)
    assert np.max(np.abs(results[-1]["x"] - exact["x"](results[-1].t))) < 1e-7
    J = [abs(r.objective - exact["objective"]) for r in results]
    assert all(abs(_order(J[i:i + 2], nodes[i:i + 2]) - 4) < 0.1 for i in range(2)), J
    defects = [r.resimulate(rtol=1e-12, atol=1e-12).max_defect for r in results]
    assert all(abs(_order(defects[i:i + 2], nodes[i:i + 2]) - 4) < 0.2
               for i in range(2)), defects
    r = results[-1]
    node_error = r["F"] - exact["F"](r.t)
    mid_error = r.r_mid[0] - exact["F"](r.t_mid)
    inputs = [np.max(np.abs(q["F"] - exact["F"](q.t))) for q in results]
    assert abs(_order(inputs[1:], nodes[1:]) - 2) < 0.1, inputs
    inner = slice(5, -5)
    np.testing.assert_allclose(mid_error[inner], -0.5 * 0.5 * (
        node_error[:-1] + node_error[1:])[inner], rtol=0.05)


def test_hermite_simpson_and_trapezoid_meet():
    """A nonlinear problem with no closed form (the pendulum swung to 2 rad
    and stopped in 3 s, least effort): the trapezoid's optimum approaches
    Hermite-Simpson's as the nodes grow, at the trapezoid's order 2, and
    Hermite-Simpson's own changes are far smaller (objectives at 21, 41, 81,
    161 nodes: 18.65427, 18.65145, 18.65127, 18.65126 against the
    trapezoid's 20.01, 18.98, 18.73, 18.67)."""
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend="numpy")
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))

    def solve(nodes, method):
        problem = kd.OptimalControlProblem(
            model, nodes=nodes, duration=3.0, lagrange=tau ** 2, initial={q: 0, u: 0},
            final={q: 2.0, u: 0}, method=method)
        result = problem.solve(problem.guess_line(inputs={tau: 0.0}), options=TIGHT)
        assert result.success, result.message
        return result

    reference = solve(81, "hermite-simpson")
    coarser = solve(41, "hermite-simpson")
    nodes = (21, 41, 81)
    gaps = []
    for n in nodes:
        r = solve(n, "trapezoid")
        step = (reference.t.size - 1) // (n - 1)
        gaps.append(np.max(np.abs(r["q"] - reference["q"][::step])))
    assert all(abs(_order(gaps[i:i + 2], nodes[i:i + 2]) - 2) < 0.15 for i in range(2)), gaps
    hs_change = np.max(np.abs(coarser["q"] - reference["q"][::2]))
    assert hs_change < 1e-2 * gaps[-1], (hs_change, gaps)
    assert abs(reference.objective - coarser.objective) < 1e-2 * abs(
        reference.objective - solve(81, "trapezoid").objective)


def test_hermite_simpson_result_guesses_and_warm_start(tmp_path):
    """The midpoints travel with the result: the quadratic inputs pass
    through them, a solution seeds a finer Hermite-Simpson problem and a
    trapezoid one, a warm start from itself takes no more iterations."""
    model, symbols, exact = _oscillator()
    x, v, F = symbols
    result = _oscillator_solve(model, symbols, 11, "hermite-simpson")
    assert result.t_mid.shape == (10,) and result.y_mid.shape == (2, 10)
    force = result.inputs()["F"]
    np.testing.assert_allclose([force(t) for t in result.t_mid], result.r_mid[0], atol=1e-14)
    np.testing.assert_allclose([force(t) for t in result.t], result["F"], atol=1e-14)
    again = result.problem.solve(result, warm_start=True, options=TIGHT)
    assert again.success and again.iterations <= result.iterations
    for nodes, method in ((21, "hermite-simpson"), (21, "trapezoid")):
        finer = kd.OptimalControlProblem(model, nodes=nodes, duration=1.0, lagrange=F ** 2,
                                         initial={x: 0, v: 0}, final={x: 1, v: 0},
                                         method=method)
        guess = finer.guess_from(result)
        assert guess.shape == (finer.n_variables,)
        refined = finer.solve(result, options=TIGHT)
        assert refined.success, refined.message
    with pytest.raises(kd.ModelError, match="warm start"):
        finer.solve(result, warm_start=True)


# ------------------------------------------------------ Legendre-Gauss-Radau
def test_lgr_points_weights_and_differentiation():
    """The Radau IIA abscissae and weights of degrees 2 and 3 (their closed
    forms: 1/3, 1 with 3/4, 1/4; (4 -+ sqrt 6)/10, 1 with (16 -+ sqrt 6)/36,
    1/9); the quadrature exact to degree 2d - 2 and not 2d - 1; the
    differentiation matrix exact on polynomials of degree d."""
    from kanedyn.optimization._interval import lgr
    s6 = np.sqrt(6.0)
    closed = {2: ([1 / 3, 1.0], [0.75, 0.25]),
              3: ([(4 - s6) / 10, (4 + s6) / 10, 1.0], [(16 - s6) / 36, (16 + s6) / 36, 1 / 9])}
    for d, (points, weights) in closed.items():
        scheme = lgr(d)
        np.testing.assert_allclose(scheme.positions, [0.0] + points, atol=1e-15)
        np.testing.assert_allclose(scheme.weights, [0.0] + weights, atol=1e-15)
    for d in (1, 2, 3, 5, 8):
        scheme = lgr(d)
        sigma, w = np.array(scheme.positions), scheme.weights
        for k in range(2 * d):
            exact = 1.0 / (k + 1)
            if k <= 2 * d - 2:
                assert abs(w @ sigma ** k - exact) < 1e-14, (d, k)
            else:
                assert abs(w @ sigma ** k - exact) > 1e-12, (d, k)
        for k in range(d + 1):  # rows: D y = y' at the Radau points
            np.testing.assert_allclose(scheme.a @ sigma ** k,
                                       k * sigma[1:] ** max(k - 1, 0) if k else 0.0,
                                       atol=1e-11 * d ** 2)


def _oscillator_lgr(model, symbols, nodes, degree):
    x, v, F = symbols
    problem = kd.OptimalControlProblem(model, nodes=nodes, duration=1.0, lagrange=F ** 2,
                                       initial={x: 0, v: 0}, final={x: 1, v: 0},
                                       method="lgr", degree=degree)
    result = problem.solve(problem.guess_line(inputs={F: 0.0}), options=TIGHT)
    assert result.success, result.message
    return result


def test_lgr_converges_on_a_closed_form():
    """The oscillator's least-effort move (closed form above): on a mesh of 4
    intervals the states' error falls more than 100-fold with each degree
    from 2 to 5 (measured 4.7e-3, 2.4e-5, 7.1e-8, 1.1e-10), and for a
    degree the states and objective converge at order 2d - 1 as the
    intervals halve (2, 4, 8 intervals; measured 3.2 and 5.1 for degrees 2
    and 3), as does the re-simulation defect (the optimal inputs, polynomials
    of degree d - 1 between the points, simulated: measured 4.8 for degree
    3).  The inputs at the Radau points follow the closed form too."""
    model, symbols, exact = _oscillator()
    by_degree = [_oscillator_lgr(model, symbols, 5, d) for d in (2, 3, 4, 5)]
    errors = [np.max(np.abs(r["x"] - exact["x"](r.t))) for r in by_degree]
    assert all(errors[i + 1] < errors[i] / 100 for i in range(3)), errors
    assert errors[-1] < 1e-9
    best = by_degree[-1]
    assert abs(best.objective - exact["objective"]) < 1e-7
    assert np.max(np.abs(best.r_mid[0] - exact["F"](best.t_mid))) < 1e-4
    assert best.t_mid.shape == (4 * 4,) and best.y_mid.shape == (2, 16)
    nodes = (3, 5, 9)
    for degree in (2, 3):
        results = [_oscillator_lgr(model, symbols, n, degree) for n in nodes]
        for name in ("x", "v"):
            e = [np.max(np.abs(r[name] - exact[name](r.t))) for r in results]
            assert _order(e[1:], nodes[1:]) > 2 * degree - 1 - 0.3, (degree, name, e)
        J = [abs(r.objective - exact["objective"]) for r in results]
        assert _order(J[1:], nodes[1:]) > 2 * degree - 1 - 0.3, (degree, J)
    defects = [r.resimulate(rtol=1e-13, atol=1e-13).max_defect for r in results[1:]]
    assert _order(defects, nodes[1:]) > 4.5, defects


@pytest.mark.parametrize("method, extra", [("hermite-simpson", {}), ("lgr", {"degree": 3})])
def test_interval_methods_on_a_model_without_inputs(method, extra):
    """A model with no inputs (the interior points' input columns empty) on
    the interval methods: the damping c of x'' = -4x - c x' (x(0) = 1, x'(0)
    = 0) as the free parameter that brings x(1) to 0.3 (Mayer term; a
    Lagrange term of the time alone adds a constant, and its quadrature's
    gradient, which failed to reshape its empty input columns); against the
    root of the underdamped closed form (scipy's brentq)."""
    from scipy.optimize import brentq
    k, c = sm.symbols("k c")
    eom, x, v, m = _particle_on_a_line(lambda x, v: -k * x - c * v)
    model = eom.numeric(constants={m: 1.0, k: 4.0, c: 1.0}, backend="numpy")

    def x_at_1(damping):  # x(1) of the underdamped oscillator from (1, 0)
        a, w = damping / 2, np.sqrt(4.0 - damping ** 2 / 4)
        return np.exp(-a) * (np.cos(w) + a / w * np.sin(w))

    exact = brentq(lambda d: x_at_1(d) - 0.3, 0.0, 3.9)
    problem = kd.OptimalControlProblem(
        model, nodes=21, duration=1.0, method=method, mayer=(x - 0.3) ** 2,
        lagrange=me.dynamicsymbols._t,
        parameters={c: (0.0, 3.9)}, initial={x: 1.0, v: 0.0}, **extra)
    guess = problem.guess_from(kd.simulate(model, (0.0, 1.0), [1.0, 0.0]))
    result = problem.solve(guess, options=TIGHT)
    assert result.success, result.message
    assert abs(result.parameters["c"] - exact) < 1e-5, (result.parameters, exact)


def test_lgr_degree_one_is_backward_euler(integrator):
    """Degree 1 collocates at the right end of each interval: backward
    Euler's discrete problem, the same optimum and states (the first input,
    which backward Euler leaves free, is tied to the first interval's)."""
    model, symbols = integrator
    euler = _rest_to_rest(model, symbols, 21, "backward-euler")
    radau = _rest_to_rest(model, symbols, 21, "lgr", degree=1)
    assert abs(euler.objective - radau.objective) < 1e-9
    assert np.max(np.abs(euler.y - radau.y)) < 1e-8
    assert np.max(np.abs(euler.r[:, 1:] - radau.r[:, 1:])) < 1e-7
    assert radau.r[0, 0] == pytest.approx(radau.r[0, 1], abs=1e-12)


def test_lgr_pendulum_swing_meets_hermite_simpson():
    """The pendulum swung to 2 rad and stopped in 3 s with least effort (no
    closed form): LGR of degree 4 on 20 intervals (81 points) reaches
    Hermite-Simpson's optimum on 160 intervals (321 points) to 1e-7
    (measured 18.6512581 and 18.6512570; Hermite-Simpson's own change from
    80 to 160 intervals is 1.1e-5), with the same angles at the nodes; at
    degree 3 the gap shrinks at order 5 from 20 to 40 intervals."""
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend="numpy")
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))

    def solve(nodes, method, degree=None):
        problem = kd.OptimalControlProblem(
            model, nodes=nodes, duration=3.0, lagrange=tau ** 2, initial={q: 0, u: 0},
            final={q: 2.0, u: 0}, method=method, degree=degree)
        result = problem.solve(problem.guess_line(inputs={tau: 0.0}), options=TIGHT)
        assert result.success, result.message
        return result

    reference = solve(161, "hermite-simpson")
    radau = solve(21, "lgr", 4)
    assert abs(radau.objective - reference.objective) < 1e-7 * reference.objective
    assert np.max(np.abs(radau["q"] - reference["q"][::8])) < 1e-5
    gaps = [abs(solve(n, "lgr", 3).objective - reference.objective) for n in (21, 41)]
    assert _order(gaps, (21, 41)) > 4.5, gaps


def test_lgr_result_inputs_guesses_and_table(tmp_path):
    """LGR's inputs between the points are the polynomial of degree d - 1
    through each interval's Radau points: they pass through the collocated
    inputs, and the first node's input is that polynomial's value; the
    re-simulated optimum ends where it was collocated; a Hermite-Simpson
    solution seeds an LGR problem and the other way round; the table marks
    the interior points."""
    model, symbols, exact = _oscillator()
    x, v, F = symbols
    result = _oscillator_lgr(model, symbols, 5, 4)
    force = result.inputs()["F"]
    np.testing.assert_allclose([force(t) for t in result.t_mid], result.r_mid[0], atol=1e-12)
    np.testing.assert_allclose([force(t) for t in result.t], result["F"], atol=1e-12)
    assert abs(force(0.1) - exact["F"](0.1)) < 1e-3
    columns, rows = result.table()
    assert [row[1] for row in rows[:5]] == ["node", "interior", "interior", "interior",
                                             "node"]
    assert np.all(np.diff([row[0] for row in rows]) > 0)
    hermite = kd.OptimalControlProblem(model, nodes=11, duration=1.0, lagrange=F ** 2,
                                       initial={x: 0, v: 0}, final={x: 1, v: 0},
                                       method="hermite-simpson")
    seeded = hermite.solve(result, options=TIGHT)
    assert seeded.success and abs(seeded.objective - exact["objective"]) < 1e-3
    back = result.problem.solve(seeded, options=TIGHT)
    assert back.success and abs(back.objective - result.objective) < 1e-9
    again = result.problem.solve(result, warm_start=True, options=TIGHT)
    assert again.success and again.iterations <= result.iterations


@pytest.mark.parametrize("method, degree", [
    ("backward-euler", None), ("trapezoid", None), ("midpoint", None),
    ("hermite-simpson", None), ("lgr", 1), ("lgr", 3)])
@pytest.mark.parametrize("free", [False, True])
def test_nlp_derivatives_against_differences(method, degree, free):
    """Jacobian of all constraint kinds and the objective's gradient (Lagrange
    and Mayer terms, free parameters, an auxiliary variable, free duration)
    against central differences of the NLP's own functions."""
    from kanedyn.optimization._nlp import CollocationNLP
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend="numpy")
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    t = me.dynamicsymbols._t
    T, w = sm.symbols("T w")
    duration = T if free else 2.0
    problem = kd.OptimalControlProblem(
        model, nodes=6, duration=duration, lagrange=tau ** 2 + q ** 2 * u + sm.sin(t) * u,
        mayer=q ** 2 + w ** 2 + (T if free else 0),
        bounds={tau: (-2, 2), **({T: (0.5, 5)} if free else {})},
        initial={q: 0, u: 0}, final={q: np.pi}, method=method, degree=degree,
        parameters=["m", "l"],
        auxiliary={w: 0.7}, path_constraints=[(u ** 2 + tau * q - w * u, -5, 5)],
        instance_constraints=[q.subs(t, 2 * duration / 5) - 0.3 * u.subs(t, 0) + w],
        periodic=[u])
    nlp = CollocationNLP(problem)
    z = np.random.default_rng(0).normal(size=nlp.n)
    if free:
        z[-1] = 2.0
    check_against_differences(nlp, z, 1e-7)


def test_backward_euler_pattern_holds_one_entry_a_row_at_the_earlier_node():
    """Backward Euler's defect rows hold the earlier node's states through
    the difference alone: one entry a row there (-1, the row's own state),
    not the node's whole state block (the pattern holds no structural
    zeros there; the rest against differences above)."""
    from kanedyn.optimization._nlp import CollocationNLP
    definition = kd.models.build("pendulum", torque=True)
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    problem = kd.OptimalControlProblem(
        definition.numeric(backend="numpy"), nodes=5, duration=2.0, lagrange=tau ** 2,
        initial={q: 0, u: 0}, final={q: 1.0}, method="backward-euler")
    nlp = CollocationNLP(problem)
    rows, cols = nlp.jacobian_structure()
    values = nlp.jacobian(np.random.default_rng(1).normal(size=nlp.n))
    for k in range(4):  # interval k: rows 2k, 2k + 1; node k's states: columns 2k, 2k + 1
        earlier = (rows // 2 == k) & (rows < 8) & (cols // 2 == k) & (cols < 10)
        assert sorted(zip(rows[earlier] - 2 * k, cols[earlier] - 2 * k)) == [(0, 0), (1, 1)]
        assert np.all(values[earlier] == -1.0)


def check_against_differences(nlp, z, tolerance):
    """The NLP's sparse Jacobian and gradient at ``z`` against central
    differences of its constraints and objective; no nonzero difference
    outside the Jacobian's pattern."""
    J = sp.coo_matrix((nlp.jacobian(z), nlp.jacobian_structure()),
                      shape=(nlp.m, nlp.n)).toarray()
    J_fd, g_fd = np.zeros_like(J), np.zeros(nlp.n)
    for i in range(nlp.n):
        e = np.zeros(nlp.n)
        e[i] = 1e-6
        J_fd[:, i] = (nlp.constraints(z + e) - nlp.constraints(z - e)) / 2e-6
        g_fd[i] = (nlp.objective(z + e) - nlp.objective(z - e)) / 2e-6
    assert np.max(np.abs(J - J_fd)) < tolerance
    assert np.max(np.abs(nlp.gradient(z) - g_fd)) < tolerance
    rows, cols = nlp.jacobian_structure()
    pattern = sp.coo_matrix((np.ones(len(rows)), (rows, cols)),
                            shape=(nlp.m, nlp.n)).toarray()
    assert np.all(pattern[np.abs(J_fd) > 1e-9] > 0)


def _circle_pendulum():
    """The torque-driven pendulum with the bob's Cartesian coordinates x
    (independent) and y (dependent: x^2 + y^2 = l^2), the torque as a force
    tau / l along the circle."""
    x, y, vx, vy, tau = me.dynamicsymbols("x y v_x v_y tau")
    m, g, l = sm.symbols("m g l")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, vx * N.x + vy * N.y)
    eom = kd.kane(frame=N, q_ind=[x], q_dep=[y], u_ind=[vx], u_dep=[vy],
                  kd_eqs=[x.diff() - vx, y.diff() - vy],
                  configuration_constraints=[x ** 2 + y ** 2 - l ** 2],
                  velocity_constraints=[x * vx + y * vy],
                  bodies=[me.Particle("bob", P, m)],
                  loads=[(P, -m * g * N.y + tau / l ** 2 * (-y * N.x + x * N.y))])
    model = eom.numeric(constants={m: 1.0, g: 9.81, l: 1.0}, specified={tau: 0.0})
    return model, (x, y, vx, vy, tau)


@pytest.mark.parametrize("method, nodes, tolerance", [
    ("trapezoid", 101, 1e-3), ("hermite-simpson", 101, 1e-6), ("lgr", 21, 1e-6)])
def test_closed_loop_matches_the_angle_formulation(method, nodes, tolerance):
    """A rest-to-rest swing to 0.5 rad in 2 s of least effort: in Cartesian
    coordinates with the constraint at every node (and, Hermite-Simpson and
    LGR, every interior point) it reaches the optimum of the angle
    formulation (both converge to it at the method's order: 1.2e-4 apart with
    the trapezoid, 4e-8 with Hermite-Simpson at 101 nodes, 2.9e-7 with LGR
    of degree 3 at 21), and keeps the constraints at every point."""
    model, (x, y, vx, vy, tau) = _circle_pendulum()
    angle = 0.5
    problem = kd.OptimalControlProblem(
        model, nodes=nodes, duration=2.0, lagrange=tau ** 2, initial={x: 0, vx: 0},
        final={x: np.sin(angle), vx: 0}, method=method)
    guess = problem.guess_line(start={y: -1, vy: 0}, end={y: -np.cos(angle), vy: 0},
                               inputs={tau: 0.0})
    closed = problem.solve(guess, options=TIGHT)
    assert closed.success, closed.message
    points = closed.y.T if closed.y_mid is None else np.vstack([closed.y.T, closed.y_mid.T])
    residuals = np.array([model.constraint_residuals(0.0, yk) for yk in points])
    assert np.max(np.abs(residuals)) < 1e-9

    definition = kd.models.build("pendulum", torque=True)
    pendulum = definition.numeric(backend="numpy")
    q, u, tau2 = (definition.symbols[k] for k in ("q", "u", "tau"))
    angle_problem = kd.OptimalControlProblem(
        pendulum, nodes=nodes, duration=2.0, lagrange=tau2 ** 2, initial={q: 0, u: 0},
        final={q: angle, u: 0}, method=method)
    reference = angle_problem.solve(angle_problem.guess_line(inputs={tau2: 0.0}),
                                    options=TIGHT)
    assert abs(closed.objective - reference.objective) / reference.objective < tolerance
    assert np.max(np.abs(np.arcsin(closed["x"]) - reference["q"])) < tolerance


# ---------------------------------------------------------------- against opty
def _opty_or_skip():
    return pytest.importorskip("opty", reason=(
        "the comparison needs opty: its pip requirement 'cyipopt' builds against a system "
        "IPOPT, so it is not in the test extra; .ci/run installs it with pip install "
        "--no-deps opty cython, beside the test extra's cyipopt-wheels"))


@pytest.mark.slow
def test_pendulum_swing_up_same_optimum_as_opty():
    """opty's gallery problem as published (501 nodes, its random guess, its
    equations written by hand), backward Euler, the same IPOPT options: the
    same objective to 1e-6.  LGR of degree 1 is the same discrete problem
    (backward Euler, its first input tied to the second): from the same guess
    it reaches opty's optimum too (measured 15.6415536236 against
    15.6415536236).  (At 101 nodes both find the backward-Euler problem
    infeasible; the midpoint rule leaves an alternating input sequence free,
    so its optimum is not unique.)  opty evaluates its constraints and
    Jacobian with its NumPy backend: the same expressions as its Cython one
    without the 24 s C compile (measured: both reach 15.641553623553134 in
    110 iterations)."""
    _opty_or_skip()
    import _ocp_peers as peers
    method = "backward-euler"
    nodes = 501
    guess = np.random.default_rng(0).normal(size=3 * nodes)
    problem, model = peers.pendulum_kanedyn(nodes, method, backend="numpy")
    ours = problem.solve(guess, options=peers.IPOPT_OPTIONS)
    theirs, info, _ = peers.solve_opty(peers.pendulum_opty(nodes, method, backend="numpy"),
                                       guess, 2, 1)
    assert ours.status in (0, 1) and info["status"] in (0, 1), (ours.message, info)
    assert abs(ours.objective - info["obj_val"]) / abs(info["obj_val"]) < 1e-6
    q, u, tau = (kd.models.build("pendulum", torque=True).symbols[k] for k in ("q", "u", "tau"))
    limit = peers.PENDULUM["torque"]
    radau = kd.OptimalControlProblem(
        model, nodes=nodes, duration=peers.PENDULUM["duration"], lagrange=tau ** 2,
        bounds={tau: (-limit, limit)}, initial={q: 0.0, u: 0.0}, final={q: np.pi, u: 0.0},
        method="lgr", degree=1).solve(guess, options=peers.IPOPT_OPTIONS)
    assert radau.success, radau.message
    assert abs(radau.objective - info["obj_val"]) / abs(info["obj_val"]) < 1e-6


@pytest.mark.slow
def test_cart_pole_swing_up_same_optimum_as_opty():
    """The cart-pole (opty's equations from SymPy's KanesMethod): the same
    objective to 1e-6.  opty on its NumPy backend, as for the pendulum
    (measured: 362.13458634195905 against its Cython backend's
    362.134586341959)."""
    _opty_or_skip()
    import _ocp_peers as peers
    nodes = 61
    guess = peers.cart_pole_guess(nodes)
    problem, _ = peers.cart_pole_kanedyn(nodes, backend="numpy")
    ours = problem.solve(guess, options=peers.IPOPT_OPTIONS)
    theirs, info, _ = peers.solve_opty(peers.cart_pole_opty(nodes, backend="numpy"), guess,
                                       4, 1)
    assert ours.status in (0, 1) and info["status"] in (0, 1), (ours.message, info)
    assert abs(ours.objective - info["obj_val"]) / abs(info["obj_val"]) < 1e-6


# ------------------------------------------------------- results, guesses, stops
def test_result_table_plot_and_warm_start(integrator, tmp_path):
    model, symbols = integrator
    x, v, F, _ = symbols
    result = _rest_to_rest(model, symbols, 21, "trapezoid")
    assert isinstance(result, kd.OptimalControlResult)
    trajectory = result.trajectory
    assert isinstance(trajectory, kd.SimulationResult)
    assert np.array_equal(trajectory["x"], result["x"])
    figure = result.plot(path=tmp_path / "ocp.png")
    assert (tmp_path / "ocp.png").stat().st_size > 0
    del figure
    problem = result.problem
    again = problem.solve(result, warm_start=True, options=TIGHT)
    assert again.success and again.iterations <= result.iterations
    assert abs(again.objective - result.objective) < 1e-9
    finer = kd.OptimalControlProblem(model, nodes=41, duration=1.0, lagrange=F ** 2,
                                     initial={x: 0, v: 0}, final={x: 1, v: 0})
    refined = finer.solve(result, options=TIGHT)  # interpolated onto 41 nodes
    assert refined.success


def test_guess_from_a_simulation(integrator):
    model, (x, v, F, _) = integrator
    pushed = model.with_inputs({F: lambda t: 6 - 12 * t})
    run = kd.simulate(pushed, (0.0, 1.0), [0.0, 0.0], rtol=1e-10, atol=1e-10,
                      dense_output=True)
    problem = kd.OptimalControlProblem(model, nodes=31, duration=1.0, lagrange=F ** 2,
                                       initial={x: 0, v: 0}, final={x: 1, v: 0})
    guess = problem.guess_from(run, inputs={F: lambda t: 6 - 12 * t})
    result = problem.solve(guess, options=TIGHT)
    assert result.success
    assert np.max(np.abs(guess[:62:2] - (3 * problem.node_times() ** 2
                                         - 2 * problem.node_times() ** 3))) < 1e-8


def test_sigint_returns_the_last_iterate():
    """Ctrl-C during a solve: the solve stops at the next iteration and returns
    its iterate, the message saying so."""
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend="numpy")
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    problem = kd.OptimalControlProblem(model, nodes=101, duration=10.0, lagrange=tau ** 2,
                                       bounds={tau: (-2, 2)}, initial={q: 0, u: 0},
                                       final={q: np.pi, u: 0}, method="backward-euler")
    guess = problem.guess_line(inputs={tau: 0.0})
    timer = threading.Timer(0.5, lambda: signal.raise_signal(signal.SIGINT))
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        timer.start()
        result = problem.solve(guess, options={"max_iter": 100000, "tol": 1e-14})
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert not result.success
    assert result.message.startswith("interrupted at iteration")
    assert result.status == 5
    assert result.x.shape == guess.shape


def test_failures_are_reported_in_the_result(integrator):
    """An infeasible problem (the force too weak to arrive) and an unbounded one
    come back as results whose message carries IPOPT's status."""
    model, (x, v, F, _) = integrator
    problem = kd.OptimalControlProblem(model, nodes=21, duration=1.0, lagrange=F ** 2,
                                       bounds={F: (-1, 1)}, initial={x: 0, v: 0},
                                       final={x: 1, v: 0})
    result = problem.solve(problem.guess_line(inputs={F: 0.0}))
    assert not result.success
    assert result.status in (2, -2) and "infeasible" in result.message
    unbounded = kd.OptimalControlProblem(model, nodes=11, duration=1.0, mayer=-x,
                                         initial={x: 0, v: 0})
    result = unbounded.solve(unbounded.guess_line(end={x: 1, v: 0}, inputs={F: 0.0}),
                             options={"max_iter": 200})
    assert not result.success
    assert "IPOPT" in result.message or "ipopt" in result.message
    assert result.status in (4, -1)


@pytest.mark.parametrize("solver", ["ipopt", "interior-point"])
def test_an_unsolved_run_names_what_is_violated_and_an_unbounded_objective(integrator,
                                                                           solver):
    """Both solvers: an infeasible problem's message names its most violated
    row (a defect: which state's dynamics, between which nodes); an unbounded
    one (x's final value maximized, nothing holding it) ends unsolved with the
    objective fallen by more than 1e8 from the guess's, and the message says
    the problem may be unbounded, naming what grew; a bounded problem stopped
    by max_iter says neither."""
    model, (x, v, F, _) = integrator
    infeasible = kd.OptimalControlProblem(model, nodes=21, duration=1.0, lagrange=F ** 2,
                                          bounds={F: (-1, 1)}, initial={x: 0, v: 0},
                                          final={x: 1, v: 0})
    result = infeasible.solve(infeasible.guess_line(inputs={F: 0.0}), solver=solver)
    assert result.status == 2, result.message
    assert re.search(r"largest constraint violation \S+, of the dynamics of [xv] between "
                     r"nodes \d+ and \d+ \(t = \S+ to \S+ s\)$", result.message), result.message
    unbounded = kd.OptimalControlProblem(model, nodes=11, duration=1.0, mayer=-x,
                                         initial={x: 0, v: 0})
    # the exact Hessian (zero here) for IPOPT too: its limited-memory steps on this
    # problem depend on the BLAS kernels (with OpenBLAS's AVX-512 ones the
    # objective crept down by 1 in 50 iterations, with its AVX2 ones it fell to -2e18)
    result = unbounded.solve(unbounded.guess_line(end={x: 1, v: 0}, inputs={F: 0.0}),
                             solver=solver, options={"max_iter": 50}, hessian="exact")
    assert not result.success and result.objective < -1e8
    assert re.search(r"the objective fell to -\S+ from -1 and F grew to \S+, v to \S+, "
                     r"x to \S+: the problem may be unbounded below \(bound F, v, x, or add "
                     r"final conditions", result.message), result.message
    bounded = kd.OptimalControlProblem(model, nodes=11, duration=1.0, lagrange=F ** 2,
                                       initial={x: 0, v: 0}, final={x: 1, v: 0})
    result = bounded.solve(bounded.guess_line(inputs={F: 0.0}), solver=solver,
                           options={"max_iter": 1})
    assert result.status == -1, result.message
    assert "unbounded" not in result.message


def test_a_status_advice_gives_way_to_the_unbounded_hint():
    """The interior point's advice after a failed restoration phase (another
    guess, or IPOPT) is in the message, but not beside the hint that the
    problem may be unbounded below, which another solver or guess would not
    change: there the hint's own advice stands alone."""
    from kanedyn.optimization._result import status_text
    from kanedyn.optimization._solvers import NLPSolution
    from kanedyn.optimization.interior_point._status import ADVICE, STATUS
    solution = NLPSolution(x=np.zeros(2), objective=-1e9, status=-2, status_text=STATUS[-2],
                           iterations=7, wall_time=0.1, multipliers={},
                           solver="interior-point", hessian="exact", advice=ADVICE[-2])
    plain = status_text(solution, None, 1e-3)
    assert plain.startswith(f"interior-point (exact Hessian): {STATUS[-2]} "
                            f"(try another initial guess, or solver='ipopt') (status -2)")
    hint = "the objective fell to -1e+09 from -1: the problem may be unbounded below (bound x)"
    hinted = status_text(solution, None, 1e-3, hint=hint)
    assert "solver='ipopt'" not in hinted and hinted.endswith(hint)
    assert hinted.startswith(f"interior-point (exact Hessian): {STATUS[-2]} (status -2)")


def test_the_most_violated_row_is_named_in_the_problems_terms(integrator):
    """The rows and bounds named at a chosen vector: a defect, a path
    constraint at a node, an instance constraint, a bound; the largest wins."""
    from kanedyn.optimization._diagnosis import _point_times, _row_text, worst_violation
    from kanedyn.optimization._nlp import CollocationNLP, violations
    model, (x, v, F, _) = integrator
    t = sm.Symbol("t")
    problem = kd.OptimalControlProblem(
        model, nodes=11, duration=1.0, lagrange=F ** 2, bounds={F: (-1, 1)},
        path_constraints=[(x + v, -1.0, 1.0)],
        instance_constraints=[x.subs(t, 1.0) - 2 * x.subs(t, 0.0) - 0.5])
    nlp = CollocationNLP(problem)
    L = nlp.layout
    z = np.zeros(nlp.n)
    assert worst_violation(nlp, z) == (0.5, "the instance constraint " +
                                       problem.instances[0].text + " = 0")
    z[L.state_index(3, 0)] = 3.0  # x at node 3: its defects by 3, its path row by 2
    assert worst_violation(nlp, z.copy()) == (3.0, "the dynamics of x between nodes 2 and 3 (t = "
                                            "0.2 to 0.3 s)")
    z[L.state_index(3, 0)] = 0.0
    z[L.state_index(4, 1)] = 2.5  # v at node 4: its path row by 1.5, its defect by 2.5
    z[L.input_index(5, 0)] = -9.0  # F at node 5: its bound by 8
    assert worst_violation(nlp, z.copy()) == (8.0, "the bound of F at node 5 (t = 0.5 s)")
    rows, _ = violations(nlp, z.copy())
    path_row = nlp.defects.n_rows + 4  # the path constraint's row at node 4
    assert rows[path_row] == pytest.approx(1.5)
    assert _row_text(nlp, path_row, _point_times(nlp, z)) == (
        "the path constraint v(t) + x(t) in [-1, 1] at node 4 (t = 0.4 s)")


def test_an_option_ipopt_refuses_is_an_option_error_with_the_close_names(integrator):
    """A misspelt option: an OptionError (a ValueError), suggesting the known
    name; a known name's bad value: said to be the value."""
    model, (x, v, F, _) = integrator
    problem = kd.OptimalControlProblem(model, nodes=5, duration=1.0, lagrange=F ** 2,
                                       initial={x: 0, v: 0}, final={x: 1, v: 0})
    guess = problem.guess_line(inputs={F: 0.0})
    with pytest.raises(kd.OptionError, match=r"IPOPT refused the option max_itr=5 \(.*an "
                                             r"unknown name .*did you mean 'max_iter'\?"):
        problem.solve(guess, options={"max_itr": 5})
    with pytest.raises(ValueError, match=r"max_iter=-5 \(.*: a value it does not take\)"):
        problem.solve(guess, options={"max_iter": -5})


@pytest.mark.parametrize("solver", ["ipopt", "interior-point"])
def test_a_hessian_option_against_the_hessian_asked_is_an_option_error(integrator, solver):
    """solve(hessian=...) and the option hessian_approximation naming the other
    Hessian: an OptionError before any iteration, both ways, for both solvers
    (IPOPT asked for an exact Hessian the NLP lacks ran and failed with "an
    invalid number" before)."""
    model, (x, v, F, _) = integrator
    problem = kd.OptimalControlProblem(model, nodes=5, duration=1.0, lagrange=F ** 2,
                                       initial={x: 0, v: 0}, final={x: 1, v: 0})
    guess = problem.guess_line(inputs={F: 0.0})
    with pytest.raises(kd.OptionError, match=r"hessian=\"exact\" and the .* option "
                                             r"hessian_approximation='limited-memory' "
                                             r"contradict each other"):
        problem.solve(guess, solver=solver, hessian="exact",
                      options={"hessian_approximation": "limited-memory"})
    with pytest.raises(kd.OptionError, match=r"hessian_approximation='exact': this NLP has "
                                             r"no exact Hessian; pass hessian=\"exact\""):
        problem.solve(guess, solver=solver, hessian="limited-memory",
                      options={"hessian_approximation": "exact"})


# ------------------------------------------------- the exact Hessian (issue 35)
def _lagrangian_gradient(nlp, z, sigma, multipliers):
    """sigma grad J + J_g^T lambda, from the NLP's exact first derivatives."""
    jac = sp.coo_matrix((nlp.jacobian(z), nlp.jacobian_structure()), shape=(nlp.m, nlp.n))
    return sigma * nlp.gradient(z) + jac.T @ multipliers


def hessian_and_differences(nlp, z, multipliers, sigma):
    """``(H, H_fd)``: the NLP's exact Hessian of the Lagrangian at ``z`` (both
    triangles; its structure checked to be the lower triangle, as IPOPT takes
    it) and the central differences of its exact gradient, dense."""
    rows, cols = nlp.hessian_structure()
    assert np.all(rows >= cols)  # the lower triangle, as IPOPT takes it
    H = sp.coo_matrix((nlp.hessian(z, multipliers, sigma), (rows, cols)),
                      shape=(nlp.n, nlp.n)).toarray()
    H = H + np.tril(H, -1).T
    H_fd = np.zeros_like(H)
    for i in range(nlp.n):
        e = np.zeros(nlp.n)
        e[i] = 1e-6
        H_fd[:, i] = (_lagrangian_gradient(nlp, z + e, sigma, multipliers)
                      - _lagrangian_gradient(nlp, z - e, sigma, multipliers)) / 2e-6
    return H, H_fd


@pytest.mark.parametrize("system", ["pendulum", "cart-pole"])
@pytest.mark.parametrize("method", ["backward-euler", "trapezoid", "midpoint"])
def test_exact_hessian_against_differences(system, method):
    """The Lagrangian's exact Hessian (generated second derivatives of f, through
    the mass matrix's solve) against central differences of the exact
    gradient of the Lagrangian (the NLP's Jacobian transposed times the
    multipliers, plus the objective's gradient, Lagrange and Mayer terms), at a
    random point."""
    import _ocp_peers as peers

    from kanedyn.optimization._nlp import CollocationNLP
    if system == "pendulum":  # an integrand and a Mayer term curved in the states too
        definition = kd.models.build("pendulum", torque=True)
        q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
        problem = kd.OptimalControlProblem(
            definition.numeric(backend="numpy"), nodes=5, duration=2.0,
            lagrange=tau ** 2 + sm.sin(q) * u * tau, mayer=q ** 2 * u,
            bounds={tau: (-2, 2)}, initial={q: 0, u: 0}, method=method)
    else:
        problem, _ = peers.cart_pole_kanedyn(5, method=method, backend="numpy")
    nlp = CollocationNLP(problem, hessian="exact")
    rng = np.random.default_rng(3)
    z, multipliers, sigma = rng.normal(size=nlp.n), rng.normal(size=nlp.m), 0.7
    H, H_fd = hessian_and_differences(nlp, z, multipliers, sigma)
    assert np.max(np.abs(H)) > 1.0  # the dynamics' curvature is there
    assert np.max(np.abs(H - H_fd)) < 1e-7 * max(1.0, np.max(np.abs(H)))


def test_exact_hessian_reaches_the_limited_memory_optimum():
    """The cart-pole swing-up solved with the exact Hessian: the optimum of the
    limited-memory solve (a different path to it), in fewer iterations."""
    import _ocp_peers as peers
    problem, _ = peers.cart_pole_kanedyn(40, method="trapezoid", backend="numpy")
    guess = peers.cart_pole_guess(40)
    approximate = problem.solve(guess, options=TIGHT)
    exact = problem.solve(guess, options=TIGHT, hessian="exact")
    assert approximate.success and exact.success, (approximate.message, exact.message)
    assert abs(exact.objective - approximate.objective) < 1e-8 * abs(approximate.objective)
    assert np.max(np.abs(exact.x - approximate.x)) < 1e-5
    assert exact.iterations < approximate.iterations


def test_exact_hessian_refusals():
    """What the exact Hessian does not cover is refused, naming it; so are an
    unknown Hessian and a contradicting IPOPT option."""
    import _ocp_peers as peers
    model, (x, y, vx, vy, tau) = _circle_pendulum()  # a closed loop
    problem = kd.OptimalControlProblem(
        model, nodes=5, duration=1.0, lagrange=tau ** 2, initial={x: 0, vx: 0},
        final={x: 0.5, vx: 0})
    guess = problem.guess_line(start={y: -1, vy: 0}, end={y: -np.cos(0.5), vy: 0},
                               inputs={tau: 0.0})
    with pytest.raises(kd.ModelError, match='hessian="exact".*a model with constraints'):
        problem.solve(guess, hessian="exact")
    with pytest.raises(kd.ModelError, match="hessian='newton'"):
        problem.solve(guess, hessian="newton")
    plain, _ = peers.pendulum_kanedyn(5, backend="numpy")
    with pytest.raises(ValueError, match="hessian_approximation"):
        plain.solve(peers.pendulum_guess(5), hessian="exact",
                    options={"hessian_approximation": "limited-memory"})


def _ipopt_log(problem, guess, tmp_path, name, **options):
    """The solve with IPOPT's log written to a file: ``(result, log text)``."""
    path = tmp_path / f"{name}.txt"
    result = problem.solve(guess, hessian="exact", options=dict(
        options, output_file=str(path), file_print_level=4, print_user_options="yes"))
    return result, path.read_text()


def test_mumps_workspace_default_is_overridable_and_keeps_the_iterates(tmp_path):
    """kanedyn asks MUMPS for 100 % workspace over its estimate (IPOPT's own
    default: 1000 %) unless the options say otherwise; when MUMPS finds the
    workspace too small IPOPT doubles it and factorizes again, so even 1 %
    (forcing that here, as the log shows) leaves every iterate as with
    1000 %: the same solution to the last bit, in the same iterations."""
    import _ocp_peers as peers
    problem, _ = peers.cart_pole_kanedyn(1000, backend="numpy")
    guess = peers.cart_pole_guess(1000)
    ours, log = _ipopt_log(problem, guess, tmp_path, "default")
    assert re.search(r"mumps_mem_percent\s*=\s*100\b", log)
    lean, log_lean = _ipopt_log(problem, guess, tmp_path, "lean", mumps_mem_percent=1)
    wide, log_wide = _ipopt_log(problem, guess, tmp_path, "wide", mumps_mem_percent=1000)
    assert re.search(r"mumps_mem_percent\s*=\s*1000\b", log_wide)
    assert "requires more memory" in log_lean and "requires more memory" not in log_wide
    assert ours.success and lean.success and wide.success, (lean.message, wide.message)
    assert lean.iterations == wide.iterations == ours.iterations
    assert np.array_equal(lean.x, wide.x) and np.array_equal(ours.x, wide.x)


def test_patterns_are_ipopt_indices():
    """The Jacobian's and the Hessian's patterns are 32-bit (IPOPT's index
    type), one copy each; a matrix too large for them is refused, naming
    its size."""
    import _ocp_peers as peers
    from kanedyn.optimization._nlp import CollocationNLP, index_arrays
    problem, _ = peers.pendulum_kanedyn(11, method="hermite-simpson", backend="numpy")
    nlp = CollocationNLP(problem, hessian="exact")
    for rows, cols in (nlp.jacobian_structure(), nlp.hessian_structure()):
        assert rows.dtype == cols.dtype == np.int32
    with pytest.raises(kd.ModelError, match="2147483648.*32-bit"):
        index_arrays([np.arange(3)], [np.arange(3)], 5, 2 ** 31)
