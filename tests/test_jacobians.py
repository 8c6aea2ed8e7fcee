"""Exact derivatives of the right-hand side (``NumericModel.jacobians``, issue 34).

Checked against what does not share their code: fourth-order central
differences of ``model.rhs`` (and of ``with_constants`` for the parameters) on
every built-in model, Pinocchio's ``computeABADerivatives`` on random trees and
real robots, and SymPy's linearization of the same equations.
"""

import functools
import tempfile
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from test_tree_factor import random_tree_urdf

import kanedyn as kd
from kanedyn.numerics.backends import _c as _cbackend

needs_compiler = pytest.mark.skipif(_cbackend.compiler_command() is None,
                                    reason="no C compiler")


def differences(fun, x, step=1e-4, scaled=False):
    """Fourth-order central differences of ``fun`` at ``x``, one column per entry
    (truncation error ~ step**4: 1e-16 of the scale here); ``scaled``: steps
    relative to each entry (parameters: a small inertia stays positive)."""
    x = np.asarray(x, dtype=float)
    columns = []
    for j in range(x.size):
        h = step * (abs(x[j]) if scaled and x[j] else max(1.0, abs(x[j])))

        def at(k):
            z = x.copy()
            z[j] += k * h
            return np.asarray(fun(z), dtype=float)
        columns.append((-at(2) + 8 * at(1) - 8 * at(-1) + at(-2)) / (12 * h))
    return np.array(columns).T


def relative(a, b):
    return np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))


def with_contacts(name):
    return name in {"sphere-slug", "slug-ellipsoid", "block-on-incline", "bead-in-tube",
                    "bouncing-ball", "ladder", "falling-rod"}


def a_state(definition, model, seed=0):
    """The model's initial state, moved at random where no constraint binds it."""
    y = np.asarray(definition.initial(model), dtype=float)
    if model.n_q_dep == 0 and model.n_u_dep == 0:
        y = y + 0.05 * np.random.default_rng(seed).standard_normal(y.size)
    return y


MODELS = sorted(name for name in kd.models.REGISTRY if not with_contacts(name))


@pytest.fixture(scope="module")
def numpy_models():
    """``numpy_models(name)``: the built-in model's definition, its equations and
    its NumPy model, derived once per module (per xdist worker): the tests only
    evaluate them, so the derivative functions a model generates on its first
    ``jacobians`` call are generated once for all the tests that take it."""
    built = {}

    def get(name):
        if name not in built:
            definition = kd.models.build(name)
            eom = definition.derive()
            built[name] = (definition, eom, definition.numeric(eom, backend="numpy"))
        return built[name]
    return get


@pytest.mark.slow
@pytest.mark.parametrize("name", MODELS)
def test_every_builtin_model_matches_differences_of_its_rhs(name, numpy_models):
    """State, inputs and constants, at a state of the model (off the constraint
    manifold where the differences step: the full-state derivative)."""
    definition, _, model = numpy_models(name)
    y = a_state(definition, model)
    J = model.jacobians(0.0, y, parameters=True)
    assert J.state.shape == (y.size, y.size)
    np.testing.assert_allclose(J.f, model.rhs(0.0, y), rtol=1e-12, atol=1e-12)
    assert relative(J.state, differences(lambda z: model.rhs(0.0, z), y)) < 1e-8
    if model.input_names:  # differences of rhs with the inputs' values changed (each
        # with_inputs copy shares the model's code): on oc3-spar (60 inputs, 240 calls)
        # 0.8 ms a call, where the derivatives' own f at each r took 3 ms after a first
        # call of 2 s
        r0 = np.array([inp(0.0, y) for _, inp in model._inputs])
        names = model.input_names
        fr = differences(lambda r: model.with_inputs(dict(zip(names, r))).rhs(0.0, y), r0)
        assert relative(J.inputs, fr) < 1e-8
    names = list(model.constants)
    p0 = np.array([model.constants[k] for k in names])
    assert J.parameter_names == tuple(names) and J.parameters.shape == (y.size, len(names))
    if names:
        fp = differences(lambda p: model.with_constants(dict(zip(names, p))).rhs(0.0, y), p0,
                         scaled=True)
        assert relative(J.parameters, fp) < 1e-8


def test_a_model_at_rest_with_quadratic_drag_and_a_power_law_stop(numpy_models):
    """|v| v at v = 0 and a stop's force (theta - theta_lim)_+ ** p_lim out of
    contact: the chain rule gave 0 * inf (a ZeroDivisionError, or nan in C);
    the derivatives are finite and those of the differences."""
    definition, _, model = numpy_models("seatbelt-sensor")
    y = np.asarray(definition.initial(model), dtype=float)
    assert not np.any(y)  # at rest
    J = model.jacobians(0.0, y, parameters=True)
    assert np.all(np.isfinite(J.state)) and np.all(np.isfinite(J.parameters))
    assert relative(J.state, differences(lambda z: model.rhs(0.0, z), y)) < 1e-8


def test_quadratic_drag_on_a_particle_at_rest():
    """F = -c |v| v: dF/dv = 0 at v = 0 exactly, and 2 c |v| along v elsewhere."""
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    c = sm.symbols("c")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q1 * N.x + q2 * N.y)
    P.set_vel(N, u1 * N.x + u2 * N.y)
    speed = sm.sqrt(u1 ** 2 + u2 ** 2)
    eom = kd.kane(frame=N, q_ind=[q1, q2], u_ind=[u1, u2],
                  kd_eqs=[q1.diff() - u1, q2.diff() - u2],
                  bodies=[me.Particle("p", P, 2)],
                  loads=[(P, -c * speed * (u1 * N.x + u2 * N.y))])
    model = eom.numeric(constants={c: 0.5}, backend="numpy")
    J = model.jacobians(0.0, [0.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(J.state[2:, 2:], 0.0)
    J = model.jacobians(0.0, [0.0, 0.0, 3.0, 0.0])  # along x: d(-c|v|v_x/m)/dv_x = -2 c |v|/m
    np.testing.assert_allclose(J.state[2:, 2:], [[-1.5, 0.0], [0.0, -0.75]], rtol=1e-14)


@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=needs_compiler)])
def test_many_states_at_once(backend):
    """One state per row; every row in one call of each generated function (on
    C; with NumPy, vectorized over the rows) and the linear algebra stacked (the
    same numbers to round-off)."""
    definition = kd.models.build("four-bar")
    model = definition.numeric(backend=backend)
    y0 = np.asarray(definition.initial(model), dtype=float)
    res = kd.simulate(model, (0.0, 1.0), y0, t_eval=[0.0, 0.5, 1.0])
    Y = res.y.T
    batch = model.jacobians(res.t, Y, parameters=True)
    assert batch.state.shape == (3, 6, 6) and batch.multipliers.shape == (3, 2, 6)
    assert batch.parameters.shape == (3, 6, 8) and batch.constraints.shape == (3, 4, 6)
    for k in range(3):
        one = model.jacobians(res.t[k], Y[k], parameters=True)
        for field in ("f", "state", "parameters", "multipliers", "multipliers_parameters",
                      "constraints"):
            assert relative(getattr(batch, field)[k], getattr(one, field)) < 1e-12, field


def test_the_multipliers_derivatives(numpy_models):
    """d lambda / dy of the four-bar against differences of model.multipliers."""
    definition, _, model = numpy_models("four-bar")
    y = np.asarray(definition.initial(model), dtype=float)
    J = model.jacobians(0.0, y)
    assert J.multiplier_names == tuple(model.multiplier_names)

    def lam(z):
        return list(model.multipliers(0.0, z).values())
    assert relative(J.multipliers, differences(lam, y)) < 1e-8


@needs_compiler
@pytest.mark.parametrize("name", ["pendulum", "four-bar", "whipple-bicycle", "chain3d",
                                  "seatbelt-sensor", "n-link-pendulum-on-cart"])
def test_the_c_backend_gives_the_numpy_backends_numbers(name, numpy_models):
    definition, eom, slow = numpy_models(name)
    fast = definition.numeric(eom, backend="c")
    y = a_state(definition, slow, seed=3)
    a, b = fast.jacobians(0.0, y, parameters=True), slow.jacobians(0.0, y, parameters=True)
    for field in ("f", "state", "inputs", "parameters"):
        assert getattr(a, field).shape == getattr(b, field).shape
        if getattr(b, field).size:
            assert relative(getattr(a, field), getattr(b, field)) < 1e-11, field



@needs_compiler
@pytest.mark.parametrize("name", ["chain3d", "n-link-pendulum-on-cart", "four-bar"])
def test_repeated_one_state_calls_on_c(name, numpy_models):
    """From the second call, one state on C takes the module's one-call path
    (its work in a buffer the module keeps; on chain3d, without inputs or
    multipliers, the solve in place in the result's own array): the numbers of
    differences of ``model.rhs`` and of the NumPy backend, with and without the
    constants' columns, and each result keeps its arrays through later calls."""
    definition, eom, slow = numpy_models(name)
    fast = definition.numeric(eom, backend="c")  # its own: the first calls are checked
    states = [a_state(definition, slow, seed=seed) for seed in (3, 4)]
    for parameters in (False, True):
        first = [fast.jacobians(0.0, y, parameters=parameters) for y in states]
        kept = [J.state.copy() for J in first]
        again = [fast.jacobians(0.0, y, parameters=parameters) for y in states]
        for y, J, K, copy in zip(states, first, again, kept):
            np.testing.assert_array_equal(J.state, copy)  # not written by later calls
            assert K.state is not J.state and K.f is not J.f
            reference = slow.jacobians(0.0, y, parameters=parameters)
            for field in ("f", "state", "inputs", "parameters", "multipliers", "constraints"):
                mine, theirs = getattr(K, field), getattr(reference, field)
                assert (mine is None) == (theirs is None), field
                if theirs is not None and theirs.size:
                    assert mine.shape == theirs.shape and relative(mine, theirs) < 1e-11, field
            rhs = differences(lambda z: fast.rhs(0.0, z), y)
            assert relative(K.state, rhs) < 1e-8

def test_an_unconstrained_model_against_sympys_linearization(numpy_models):
    """For a model without constraints the full-state derivative is the A of
    the linearization about any state (here not an equilibrium): the symbolic
    one (constants substituted afterwards) and the numerical one."""
    definition, eom, model = numpy_models("n-link-pendulum-on-cart")
    y = a_state(definition, model, seed=5)
    J = model.jacobians(0.0, y, r=[1.5])
    op_point = dict(zip([*eom.q, *eom.u], y)) | {eom.specified[0]: 1.5}
    A, B, _ = eom.linearize(op_point=op_point)
    assert relative(J.state, np.array(A.subs(definition.constants), dtype=float)) < 1e-10
    assert relative(J.inputs, np.array(B.subs(definition.constants), dtype=float)) < 1e-10
    A, B, _ = model.linearize(y, r=[1.5])
    assert relative(J.state, A) < 1e-10 and relative(J.inputs, B) < 1e-10


def test_refused_where_not_generated():
    contact = kd.models.build("bouncing-ball")
    with pytest.raises(kd.ModelError, match="contacts"):
        contact.numeric(backend="numpy").jacobians(0.0, [1.0, 0.0])
    four_bar = kd.models.build("four-bar")

    class Mine(kd.schemes.IndexOne):  # a scheme of one's own: its equations unknown
        name = "mine"

        def acceleration_system(self):
            return None
    model = four_bar.numeric(backend="numpy", scheme=Mine())
    with pytest.raises(kd.ModelError, match="scheme 'mine' does not say what its "
                                            "accelerations satisfy"):
        model.jacobians(0.0, four_bar.initial(model))
    pendulum = kd.models.build("pendulum").numeric(backend="numpy")
    with pytest.raises(ValueError, match="r must have 0 entries"):
        pendulum.jacobians(0.0, [0.1, 0.0], r=[1.0])
    with pytest.raises(ValueError, match="the state must have 2 entries"):
        pendulum.jacobians(0.0, [0.1, 0.0, 0.0])


# ------------------------------------------------------------------ Pinocchio
def pinocchio():
    return pytest.importorskip("pinocchio", reason="the derivatives are compared with "
                               "Pinocchio's computeABADerivatives (pip install pin)")


def pinocchio_derivatives(pmodel, definition, q, u, tau):
    from test_urdf import pinocchio_state
    pin = pinocchio()
    data = pmodel.createData()
    qp, vp, tp, index = pinocchio_state(pmodel, definition, q, u, tau)
    dq, dv, dtau = pin.computeABADerivatives(pmodel, data, qp, vp, tp)
    pick = np.ix_(index, index)
    return dq[pick], dv[pick], dtau[pick]


def compare_with_pinocchio(path, states=3, seed=0, backend="numpy", built=None):
    """Worst relative difference of d(u')/d(q, u, tau) over random states;
    ``built``: ``(definition, Pinocchio's model, numeric model)`` of ``path``
    already made (else made here, the numeric model on ``backend``)."""
    if built is None:
        definition = kd.models.from_urdf(path)
        # the equations given: no derivation-cache entry, for which gcc would build
        # the C module at once (the first module's numbers are its to the bit,
        # tests/test_quick_compile.py; 3.3 s of gcc for the Panda)
        built = (definition, pinocchio().buildModelFromUrdf(str(path)),
                 definition.numeric(definition.derive(), backend=backend))
    definition, pmodel, model = built
    n = len(definition.joints)
    efforts = [model.input_names.index(str(j.effort_input)) for j in definition.joints]
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(states):
        q, u, tau = rng.uniform(-1.5, 1.5, (3, n))
        r = np.zeros(len(model.input_names))
        r[efforts] = tau
        J = model.jacobians(0.0, np.concatenate([q, u]), r=r)
        dq, dv, dtau = pinocchio_derivatives(pmodel, definition, q, u, tau)
        for mine, theirs in ((J.state[n:, :n], dq), (J.state[n:, n:], dv),
                             (J.inputs[n:, efforts], dtau)):
            worst = max(worst, relative(mine, theirs))
    return worst


@functools.cache
def random_tree(seed):
    """``(definition, Pinocchio's model, NumPy model)`` of the random tree of seven
    joints of ``seed``, made once per process: test_jacobians_trees.py asserts
    on the same model that its derivatives come from the spatial formulas."""
    rng = np.random.default_rng(seed)
    parent = [-1] + [int(rng.integers(-1, k)) for k in range(6)]
    with tempfile.TemporaryDirectory() as folder:
        path = random_tree_urdf(Path(folder) / "tree.urdf", parent, seed)
        definition = kd.models.from_urdf(path)
        return definition, pinocchio().buildModelFromUrdf(str(path)), definition.numeric(
            backend="numpy")


@functools.cache
def random_tree_against_pinocchio(seed):
    """Worst relative difference between the derivatives of :func:`random_tree`
    ``(seed)`` and Pinocchio's, over three random states, computed once per
    process for this file's test and test_jacobians_trees.py's."""
    return compare_with_pinocchio(None, seed=seed, built=random_tree(seed))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_trees_match_pinocchio(seed):
    assert random_tree_against_pinocchio(seed) < 1e-9


def robot_file(relative_path):
    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        pytest.skip("needs example-robot-data (pip install example-robot-data)")
    return dist.locate_file("cmeel.prefix/share/example-robot-data/robots/" + relative_path)


@pytest.mark.slow
@needs_compiler
@pytest.mark.parametrize("robot", ["ur_description/urdf/ur5_robot.urdf",
                                   "panda_description/urdf/panda.urdf",
                                   "solo_description/robots/solo12.urdf",
                                   "talos_data/robots/talos_left_arm.urdf"])
def test_real_robots_match_pinocchio(robot):
    assert compare_with_pinocchio(robot_file(robot), backend="c") < 1e-9


# ------------------------------------------------------- used by simulate
def test_stiff_methods_get_the_exact_jacobian_by_default(monkeypatch):
    """Radau, BDF and LSODA are given ``jac``: the derivatives, not n_states
    evaluations of the right-hand side per Jacobian; the same run as with
    solve_ivp's differences."""
    definition = kd.models.build("four-bar")
    model = definition.numeric(backend="numpy")
    y0 = definition.initial(model)
    calls = {"rhs": 0}
    rhs = model.rhs

    def counting(t, y):
        calls["rhs"] += 1
        return rhs(t, y)
    monkeypatch.setattr(model, "rhs", counting)
    for method in ("Radau", "BDF", "LSODA"):
        calls["rhs"] = 0
        exact = kd.simulate(model, (0.0, 1.0), y0, method=method)
        with_exact = calls["rhs"]
        calls["rhs"] = 0
        differenced = kd.simulate(model, (0.0, 1.0), y0, method=method, jac="differences")
        assert exact.success and differenced.success
        np.testing.assert_allclose(exact.y[:, -1], differenced.y[:, -1], atol=1e-6)
        if method != "LSODA":  # LSODA differences inside its Fortran, unseen here
            assert exact.njev >= 1 and exact.njev == differenced.njev
            assert calls["rhs"] - with_exact >= model.n_states * differenced.njev


def test_an_input_that_follows_the_state_is_in_the_jacobian():
    """A feedback force F = -k_p q - k_d u on the cart: the integrators'
    Jacobian is the total derivative, the input's part by differences."""
    from kanedyn.numerics import state_jacobian
    definition = kd.models.build("n-link-pendulum-on-cart")
    eom = definition.derive()
    F = eom.specified[0]
    model = definition.numeric(eom, specified={F: lambda t, y: -40.0 * y[0] - 8.0 * y[4]},
                               backend="numpy")
    y = a_state(definition, model, seed=7)
    total = state_jacobian(model)(0.0, y)
    assert relative(total, differences(lambda z: model.rhs(0.0, z), y)) < 1e-7
    assert relative(model.jacobians(0.0, y).state, total) > 1e-3  # the input held fixed


def test_jac_options():
    pendulum = kd.models.build("pendulum")
    model = pendulum.numeric(backend="numpy")
    with pytest.raises(kd.OptionError, match="jac must be 'exact', 'differences'"):
        kd.simulate(model, (0.0, 0.1), pendulum.initial(model), method="Radau", jac="exakt")
    res = kd.simulate(model, (0.0, 0.1), pendulum.initial(model), method="Radau",
                      jac=lambda t, y: np.array([[0.0, 1.0], [-9.81, 0.0]]))
    assert res.success


@pytest.mark.parametrize("name", ["four-bar", "whipple-bicycle", "rolling-disk", "n-four-bar",
                                  "andrews-squeezer", "pin-slot", "stewart-platform", "snake",
                                  "n-link-pendulum-on-cart", "knife-edge"])
def test_linearize_through_the_derivatives_agrees_with_its_own_jacobians(name, numpy_models):
    """model.linearize now reduces the full-state derivative with the constraint
    rows; the linearization's own generated Jacobians (a second formulation of
    the reduction) agree to round-off, away from equilibrium."""
    from kanedyn.numerics import linearize_numeric
    definition, _, model = numpy_models(name)
    y = np.asarray(definition.initial(model), dtype=float)
    y = model.consistent_state(0.0, y + 0.05 * np.random.default_rng(1).standard_normal(y.size))
    A, B, r = model.linearize(y)
    A0, B0, r0 = linearize_numeric(model, y)
    assert r == r0 and B.shape == B0.shape
    assert relative(A, A0) < 1e-12
    if B.size:
        assert relative(B, B0) < 1e-12


def test_larger_models_get_the_exact_jacobian_once_it_is_built():
    """Above EXACT_JACOBIAN_STATES states the first build costs seconds to
    minutes: a run does not start it unasked; once built (jac="exact", or
    model.jacobians), later runs use it."""
    from kanedyn.numerics import derivatives_built
    from kanedyn.simulation._simulate import EXACT_JACOBIAN_STATES
    definition = kd.models.build("chain3d", n=11)
    model = definition.numeric(backend="numpy")
    assert model.n_states > EXACT_JACOBIAN_STATES
    y0 = definition.initial(model)
    kd.simulate(model, (0.0, 0.05), y0, method="Radau")
    assert not derivatives_built(model)
    asked = kd.simulate(model, (0.0, 0.05), y0, method="Radau", jac="exact")
    assert derivatives_built(model)
    again = kd.simulate(model, (0.0, 0.05), y0, method="Radau")
    np.testing.assert_array_equal(asked.y, again.y)


_RADAU_RUN = """
import sys, kanedyn as kd
from kanedyn.numerics import derivatives_built
definition = kd.models.build("four-bar")
model = definition.numeric(backend="c")
kd.simulate(model, (0.0, 0.05), definition.initial(model), method="Radau",
            **({{"jac": "exact"}} if sys.argv[1] == "exact" else {{}}))
built = derivatives_built(model)
if sys.argv[1] == "exact":  # a run this short leaves the quick compiler's module
    kd.numerics.finish_compiling()  # (its optimized build would not pay): into the cache
print(built)
"""


_MOVE_RUN = """
import json, numpy as np, kanedyn as kd
from kanedyn.numerics.backends._c_quick import quick_command
definition = kd.models.build("chain3d")
model = definition.numeric(backend="c")
y = np.asarray(definition.initial(model), dtype=float) + 0.1
first = [model.jacobians(0.0, y).state for _ in range(2)]  # the second: one-call path
quick = model.__dict__["_jacobians_module"]
kd.numerics.finish_compiling()
later = [model.jacobians(0.0, y).state for _ in range(2)]
final = model.__dict__["_jacobians_module"]
step = 1e-6
columns = [(model.rhs(0.0, y + step * e) - model.rhs(0.0, y - step * e)) / (2 * step)
           for e in np.eye(y.size)]
print(json.dumps({"quick": quick_command() is not None, "moved": final is not quick,
                  "point": model.__dict__["_jacobian_point"].func.__self__ is final,
                  "same": bool(all(np.array_equal(a, later[-1]) for a in first + later)),
                  "differences": float(np.max(np.abs(later[-1] - np.array(columns).T)))}))
"""


@needs_compiler
def test_the_derivatives_move_onto_the_optimized_module(tmp_path, generic_runtime_object):
    """Built in a fresh cache, the derivative module comes from the quick compiler
    first (where there is one); once the optimized module is loaded the model
    calls that module's entry points (the quick module's own code around the
    evaluation is slower), with the same numbers, those of central differences
    of ``model.rhs``.  (The cache holds the generic runtime's object, as in
    tests/test_quick_compile.py: the modules are what is built.)"""
    import json
    import os
    import subprocess
    import sys
    generic_runtime_object(tmp_path / "cache")
    env = dict(os.environ, KANEDYN_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=str(Path(kd.__file__).resolve().parents[1]))
    done = subprocess.run([sys.executable, "-c", _MOVE_RUN], env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    found = json.loads(done.stdout.split("\n")[-2])
    assert found["same"] and found["differences"] < 1e-6
    if found["quick"]:
        assert found["moved"] and found["point"]

@needs_compiler
def test_a_c_model_never_waits_for_a_compilation_it_did_not_ask_for(tmp_path):
    """A stiff run on C uses the exact Jacobian when its module is in the compile
    cache (made by an earlier jac="exact"), and otherwise differences rather
    than compile it; in fresh processes sharing a cache."""
    import os
    import subprocess
    import sys
    env = dict(os.environ, KANEDYN_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=str(Path(kd.__file__).resolve().parents[1]))

    def run(how):
        done = subprocess.run([sys.executable, "-c", _RADAU_RUN.format(), how], env=env,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
        return done.stdout.split()[-1]
    assert run("default") == "False"  # not built, and not compiled for the run
    assert run("exact") == "True"
    assert run("default") == "True"  # from the cache


@needs_compiler
@pytest.mark.parametrize("name", ["four-bar", "n-link-pendulum-on-cart"])
def test_the_compiled_rosenbrock_loop_takes_the_exact_jacobian(name):
    """The compiled Rosenbrock23 loop evaluates a Jacobian at every step: with
    jac="exact" (and by default once the derivatives are built) the derivative
    module's, solved in C, instead of n_states + 1 right-hand sides; the same run
    to the tolerance."""
    definition = kd.models.build(name)
    model = definition.numeric(backend="c")
    y0 = definition.initial(model)
    run = dict(method="Rosenbrock23", rtol=1e-8, atol=1e-10)
    differenced = kd.simulate(model, (0.0, 1.0), y0, jac="differences", **run)
    exact = kd.simulate(model, (0.0, 1.0), y0, jac="exact", **run)
    default = kd.simulate(model, (0.0, 1.0), y0, **run)  # the derivatives are built now
    assert exact.success and differenced.success
    np.testing.assert_allclose(exact.y[:, -1], differenced.y[:, -1], atol=1e-6)
    np.testing.assert_array_equal(default.y, exact.y)
    assert exact.njev > 10
    saved = differenced.nfev - exact.nfev  # the differences' right-hand sides
    assert saved >= 0.9 * model.n_states * differenced.njev


@needs_compiler
def test_the_compiled_loop_refuses_what_its_jacobian_lacks():
    definition = kd.models.build("n-link-pendulum-on-cart")
    eom = definition.derive()
    F = eom.specified[0]
    model = definition.numeric(eom, specified={F: lambda t, y: -40.0 * y[0] - 8.0 * y[4]},
                               backend="c")
    y0 = definition.initial(model)
    with pytest.raises(kd.OptionError, match=r"jac='exact': the inputs F\(t\) are functions "
                                             "of the state"):
        kd.simulate(model, (0.0, 0.1), y0, method="Rosenbrock23", jac="exact")
    assert kd.simulate(model, (0.0, 0.1), y0, method="Rosenbrock23").success  # differences
    with pytest.raises(kd.OptionError, match="Rosenbrock23 loop takes jac='exact' or "
                                             "'differences'"):
        kd.simulate(model, (0.0, 0.1), y0, method="Rosenbrock23", jac=np.eye(model.n_states))


@needs_compiler
def test_constants_asked_of_a_model_without_any(line_particle):
    """A model whose constants are all numbers (the OC3 spar's built-in form):
    ``parameters=True`` gives an empty block beside the same derivatives.  The C
    module asked for them once failed to compile (its generated function had
    the constants' outputs, their call site not, with no columns to fill)."""
    eom, _q, _u = line_particle(2.0, lambda q, u: -3.0 * q ** 3 - 0.5 * u)
    y = [0.4, -0.3]
    numpy = eom.numeric(backend="numpy").jacobians(0.0, y)
    model = eom.numeric(backend="c")
    assert not model.constants
    asked = model.jacobians(0.0, y, parameters=True)
    assert asked.parameters.shape == (2, 0)
    np.testing.assert_allclose(asked.state, numpy.state, rtol=1e-14, atol=0.0)
    np.testing.assert_allclose(asked.state, [[0.0, 1.0], [-4.5 * 0.4 ** 2, -0.25]], rtol=1e-14)


# ------------------------------------------------------- the Python printer
def test_the_python_printers_text_is_sympys(numpy_models, monkeypatch):
    """The NumPy backend's scalar code is printed without SymPy's printer where
    a statement is made of symbols, numbers, sums, products, powers and
    ``math`` functions (``backends._python._direct``): the same text as SymPy's
    ``PythonCodePrinter`` gives, so the same code and numbers.  Checked on
    expressions that take each of its rules, and on every statement of the
    functions of the Whipple bicycle and of the Stewart platform (floats,
    rationals, roots; compared whole, printed both ways)."""
    from kanedyn.engine import kd_dpow
    from kanedyn.numerics.backends import _python
    a, b, c, d = sm.symbols("a b c d")
    printer = _python._Printer({a: "y[0]", b: "y[1]", c: "p[2]", d: "r[3]"})
    half, third = sm.Rational(1, 2), sm.Rational(1, 3)
    expressions = [
        a * b - c * d, -2 * a * (b + c), half * d * a - b, -half * d * a - b, a / (b * c),
        (a + b) ** 2, a ** -3, sm.sqrt(a + b), 1 / sm.sqrt(a), -a / sm.sqrt(b + c),
        sm.sin(a) * sm.cos(b) - 0.25 * c, -(a + b), 2.5 * a ** 2 / b, a - sm.Rational(3, 4),
        a ** sm.Rational(3, 2), b / a ** sm.Rational(3, 2), sm.atan2(a, b), sm.Abs(a - b),
        a * (b - c) / (c + d) ** 2, sm.exp(-a), sm.Integer(-3), third, (-a) ** 3, c ** -5,
        0.1 * a - 1e-20 * b, 1 / (a + b), -1 / a, -2 / a, -a / (b * c), -0.5 * a, a ** 0.5,
        a ** -0.5, a ** b, a ** -b, -sm.Rational(3, 2) * a ** 2 / (b + c), -sm.sin(a),
        sm.sin(a) ** 2, c / ((a + 1) * (b + 2)), 1.5 * a ** sm.Rational(-3, 2),
        sm.Float(-2.0) * a * b, sm.log(a) * sm.tanh(b), kd_dpow(a, 2.5, b) + sm.asin(c),
        a, sm.Integer(0), sm.Float(0.1), sm.sign(a) * b]
    for e in expressions:
        assert _python._print_python(printer, e) == printer.doprint(e), e
    with pytest.raises(_python.CodegenError, match="symbol x has no value"):
        _python._print_python(printer, a + sm.Symbol("x"))

    def by_sympy(expr, printer):
        raise _python._Unusual
    for name in ("whipple-bicycle", "stewart-platform"):
        _, _, model = numpy_models(name)
        program = model._eom._program
        for function, (arguments, outputs) in model._functions.items():
            direct = _python._generate_python(program, function, arguments, outputs, None,
                                              False, model._cse)
            with monkeypatch.context() as patch:
                patch.setattr(_python, "_direct", by_sympy)
                printed = _python._generate_python(program, function, arguments, outputs,
                                                   None, False, model._cse)
            assert direct == printed, (name, function)
