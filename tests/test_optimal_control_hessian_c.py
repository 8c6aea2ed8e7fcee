"""The exact Hessian on the C backend: its weighted second derivatives, the
contraction with the weights and w_x, and the solves with M generated as C
(``kanedyn.numerics.backends._c_hessians``).  Checked against

- the NumPy backend's, which evaluates the second derivatives as NumPy code
  and does the solves and the contraction in NumPy (to 1e-12 relative);
- central differences of the exact gradient of the Lagrangian (the NLP's
  Jacobian, which shares none of the second derivatives);
- the NumPy backend's exact-Hessian solve: the same iterations and optimum.
"""

import functools

import numpy as np
import pytest
import sympy as sm
from test_optimal_control_hessian import _forced as forced_model
from test_optimal_control_hessian import _hessians

import kanedyn as kd
from kanedyn.numerics import weighted_hessian_pattern, weighted_hessians
from kanedyn.numerics.backends._c_build import compiler_command

pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (pip install "
                    "'kanedyn[optimal]', part of the test extra)")
pytestmark = pytest.mark.skipif(compiler_command() is None, reason="no C compiler")

T = sm.Symbol("T")


def _pendulum(backend):
    definition = kd.models.build("pendulum", torque=True)
    s = definition.symbols
    return definition.numeric(definition.derive(), backend=backend), [s["m"], s["l"]], 1


def _cart_pole(backend):
    definition = kd.models.build("n-link-pendulum-on-cart", n=1)
    s = definition.symbols
    model = definition.numeric(definition.derive(), backend=backend, constants={
        s["m_c"]: 1.0, s["m"]: 0.5, s["l"]: 0.8, s["g"]: 9.81})
    return model, [s["m"], s["l"], s["m_c"]], 1


def _chain(backend):
    definition = kd.models.build("chain3d", n=3)
    s = definition.symbols
    return definition.numeric(definition.derive(), backend=backend), [s["m"], s["l"]], 0


def _forced(backend):
    model, (_, _, _, k) = forced_model(backend)
    return model, [k], 1


BUILDERS = {"pendulum": _pendulum, "cart-pole": _cart_pole, "chain3d n=3": _chain,
            "forced": _forced}


@functools.cache
def _built(name, backend):
    """``BUILDERS[name](backend)``, derived once for the module: a model keeps
    its generated second derivatives (one per choice of extra variables), so
    the tests that share a model and a choice generate them once.  The
    builders give the equations to ``numeric``: a C model then makes no
    derivation-cache entry, whose module gcc would build at once (3 s of the
    file's CPU); its quick module gives gcc's numbers to the bit
    (tests/test_quick_compile.py)."""
    return BUILDERS[name](backend)


MODELS = {name: functools.partial(_built, name) for name in BUILDERS}


@pytest.mark.parametrize("name", list(MODELS))
@pytest.mark.parametrize("extra", ["none", "parameters and time"])
def test_c_weighted_hessians_equal_numpy(name, extra):
    """``weighted_hessians`` at random points with random weights: C equal to
    NumPy to 1e-12 of the largest entry, with and without the columns of
    chosen constants and the time."""
    (c, symbols, nr), (numpy, _, _) = MODELS[name]("c"), MODELS[name]("numpy")
    names = list(c.constants)
    parameters = [names.index(str(s)) for s in symbols] if extra != "none" else []
    rng = np.random.default_rng(5)
    N = 9
    t, Y = rng.random(N), rng.normal(size=(N, c.n_states))
    R, weights = rng.normal(size=(N, nr)), rng.normal(size=(N, c.n_states))
    found = {m._data["backend"]: weighted_hessians(m, t, Y, R, weights, parameters=parameters,
                                                   time=extra != "none")
             for m in (c, numpy)}
    nx = c.n_states + nr + len(parameters) + (extra != "none")
    assert found["c"].shape == found["numpy"].shape == (N, nx, nx)
    scale = np.max(np.abs(found["numpy"]))
    assert scale > 0.1
    assert np.max(np.abs(found["c"] - found["numpy"])) < 1e-12 * scale


@pytest.mark.parametrize("name", list(MODELS))
@pytest.mark.parametrize("extra", ["none", "parameters and time"])
def test_weighted_hessian_pattern_holds_every_nonzero(name, extra):
    """``weighted_hessian_pattern``: the same on C (read from the module) and
    NumPy, symmetric; every entry outside it exactly zero at random points
    with random weights, the entries inside it not all zero.  The pendulum's
    torque and the cart's force enter linearly and not through the mass
    matrix, so the input's diagonal entry is outside it; the pendulum's mass
    matrix is constant without its constants among the columns, so then the
    torque's whole row is."""
    (c, symbols, nr), (numpy, _, _) = MODELS[name]("c"), MODELS[name]("numpy")
    names = list(c.constants)
    parameters = [names.index(str(s)) for s in symbols] if extra != "none" else []
    time = extra != "none"
    patterns = [weighted_hessian_pattern(m, parameters, time) for m in (c, numpy)]
    np.testing.assert_array_equal(patterns[0], patterns[1])
    pattern = patterns[0]
    np.testing.assert_array_equal(pattern, pattern.T)
    rng = np.random.default_rng(6)
    N = 9
    t, Y = rng.random(N), rng.normal(size=(N, c.n_states))
    R, weights = rng.normal(size=(N, nr)), rng.normal(size=(N, c.n_states))
    H = weighted_hessians(c, t, Y, R, weights, parameters=parameters, time=time)
    assert pattern.shape == H.shape[1:]
    assert np.all(H[:, ~pattern] == 0.0)
    assert np.abs(H[:, pattern]).max() > 0.1
    r = c.n_states  # the input's row and column
    if name in ("pendulum", "cart-pole"):
        assert not pattern[r, r]
    if name == "pendulum" and extra == "none":
        assert not pattern[r].any() and pattern[0, 0]
    # a copy (new constants) shares the generated code, and its pattern
    clone = numpy.with_constants({names[0]: numpy.constants[names[0]]})
    np.testing.assert_array_equal(weighted_hessian_pattern(clone, parameters, time), pattern)


def test_hessian_pattern_leaves_out_terms_that_cancel():
    """The pendulum's forces hold centripetal terms in the rate that cancel
    (its bob's acceleration along the rod dotted with a partial velocity
    across it): written, their second derivatives are not SymPy's zero, so a
    pattern of the derivatives as written (``EXPANDED_NODES = 0``: none
    expanded) holds the rate's row; expanded they are zero, and the pattern
    holds the angle's entry alone, on both backends."""
    from unittest import mock
    from kanedyn.numerics import _hessians
    definition = kd.models.build("pendulum", torque=True)
    for backend in ("numpy", "c"):
        pattern = weighted_hessian_pattern(definition.numeric(backend=backend))
        assert np.argwhere(pattern).tolist() == [[0, 0]], backend
    with mock.patch.object(_hessians, "EXPANDED_NODES", 0):
        written = weighted_hessian_pattern(definition.numeric(backend="numpy"))
    assert np.argwhere(written).tolist() == [[0, 0], [0, 1], [1, 0], [1, 1]]


def _chain_problem(model, symbols, method):
    """chain3d n = 3: the mass and the length of its links and the duration free."""
    definition = kd.models.build("chain3d", n=3)
    s = definition.symbols
    (q1, q2, q3), (u1, u2, u3) = s["q"], s["u"]
    m, l = symbols
    return kd.OptimalControlProblem(
        model, nodes=4, duration=T, parameters=[m, l],
        lagrange=m * q1 ** 2 + u2 ** 2 * l + sm.sin(q3) * u1, mayer=T * l + q3 ** 2 * m,
        bounds={T: (0.5, 5), m: (0.5, 2), l: (0.5, 2)},
        initial={q1: 0.1, q2: 0.2, q3: 0.3, u1: 0, u2: 0, u3: 0}, method=method)


def _cart_pole_problem(model, symbols, method):
    definition = kd.models.build("n-link-pendulum-on-cart", n=1)
    s = definition.symbols
    (x, theta), (v, omega), F = s["q"], s["u"], s["F"]
    return kd.OptimalControlProblem(
        model, nodes=4, duration=T, lagrange=F ** 2 + s["m"] * x ** 2, mayer=T * s["l"],
        parameters=symbols, bounds={T: (0.5, 5)},
        initial={x: 0, theta: 0, v: 0, omega: 0}, method=method)


# (chain3d has no inputs, which the interval methods' gradient does not take yet)
@pytest.mark.parametrize("name, pose, method", [
    *[("chain3d n=3", _chain_problem, m) for m in ("backward-euler", "trapezoid", "midpoint")],
    *[("cart-pole", _cart_pole_problem, m) for m in ("trapezoid", "hermite-simpson", "lgr")]])
def test_c_exact_hessian_against_differences_and_numpy(name, pose, method):
    """Free parameters and a free duration: the NLP's exact Hessian on C
    within 1e-7 of the central differences of its exact gradient, and equal
    to the NumPy backend's to 1e-12 (relative to its largest entry)."""
    (c, symbols, _), (numpy, _, _) = MODELS[name]("c"), MODELS[name]("numpy")
    H, H_fd, _ = _hessians(pose(c, symbols, method))
    H_numpy, _, _ = _hessians(pose(numpy, symbols, method))
    scale = np.max(np.abs(H))
    assert scale > 1.0
    assert np.max(np.abs(H - H_fd)) < 1e-7 * scale
    assert np.max(np.abs(H - H_numpy)) < 1e-12 * scale


def test_c_exact_solve_is_the_numpy_exact_solve():
    """The pendulum swung up in least time (trapezoid, 31 nodes): the same
    iterations and optimum on both backends with the exact Hessian."""
    found = {}
    for backend in ("numpy", "c"):
        definition = kd.models.build("pendulum", torque=True)
        q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
        problem = kd.OptimalControlProblem(
            definition.numeric(backend=backend), nodes=31, duration=T, mayer=T,
            lagrange=1e-2 * tau ** 2, bounds={tau: (-8, 8), T: (0.2, 10)},
            initial={q: 0, u: 0}, final={q: np.pi, u: 0}, method="trapezoid")
        found[backend] = problem.solve(problem.guess_line(inputs={tau: 0.0}, duration=2.0),
                                       options={"tol": 1e-12, "max_iter": 500},
                                       hessian="exact")
    assert found["c"].success and found["numpy"].success
    assert found["c"].iterations == found["numpy"].iterations
    assert abs(found["c"].objective - found["numpy"].objective) < 1e-10
    assert np.max(np.abs(found["c"].x - found["numpy"].x)) < 1e-8


def test_c_weighted_hessians_refuse_a_singular_mass_matrix():
    """The C path's factors of M have no pivot check of their own: a point where
    M is singular (a particle in polar coordinates at r = 0, M = diag(m, m r^2))
    raises LinAlgError, as the NumPy path's solve does, rather than returning
    numbers that are not finite (the derivatives of a regular point passed for
    it, as a caller may)."""
    import sympy.physics.mechanics as me
    r, th, ur, uth = me.dynamicsymbols("r th ur uth")
    m = sm.Symbol("m")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    A = N.orientnew("A", "Axis", [th, N.z])
    A.set_ang_vel(N, uth * N.z)
    P = O.locatenew("P", r * A.x)
    P.set_vel(N, ur * A.x + r * uth * A.y)
    eom = kd.kane(frame=N, q_ind=[r, th], u_ind=[ur, uth],
                  kd_eqs=[r.diff() - ur, th.diff() - uth],
                  bodies=[me.Particle("P", P, m)], loads=[(P, -r * A.x)])
    regular = [1.0, 0.2, 0.1, 0.3]
    for backend in ("c", "numpy"):
        model = eom.numeric(constants={m: 1.0}, backend=backend)
        J = model.jacobians(0.0, np.array([regular, regular]))
        Y = np.array([regular, [0.0, 0.2, 0.1, 0.3]])
        with pytest.raises(np.linalg.LinAlgError):
            weighted_hessians(model, 0.0, Y, np.zeros((2, 0)), np.ones((2, 4)), jacobians=J)
        assert np.isfinite(weighted_hessians(model, 0.0, Y[:1], np.zeros((1, 0)),
                                             np.ones((1, 4)))).all()
