"""Exact derivatives of trees in spatial terms, and one state in one call of the C
module (issue 34, its speed goals).

For a tree of joints whose coordinates' rates are its speeds, the derivatives of
the inertia forces (and of loads constant in inertial components, gravity) come
from the spatial formulas of ``kanedyn.engine.tree_inertia_derivatives``
instead of forward differentiation of the program.  They are compared here with
what the program gives (the general path, which every other model takes),
with differences of ``model.rhs``, and, through ``tests/test_jacobians.py``,
with Pinocchio on random trees and real robots (asserted here to go through the
spatial formulas).
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from test_jacobians import (a_state, differences, needs_compiler, random_tree,
                            random_tree_against_pinocchio, relative, robot_file)
from test_tree_factor import random_tree_urdf

import kanedyn as kd
from kanedyn.engine import tree_inertia_derivatives
from kanedyn.numerics import _jacobians
from kanedyn.numerics._inverse import _tree_bodies, _workspace


def spatial_rows(model):
    """The spatial formulas' d E/d y of ``model`` (None where they do not apply)."""
    prog, kin = _workspace(model)
    args, dynamics = model._functions["dynamics"]
    return _jacobians._tree_state_rows(model, prog, kin, list(model._eom._table.udot),
                                       dynamics[1][1], args["y"], args["p"])


def by_the_program(monkeypatch, model, *args, **options):
    """``model.jacobians(*args, **options)`` of derivatives generated from the
    program (on a model that has not made its own yet)."""
    with monkeypatch.context() as patch:
        patch.setattr(_jacobians, "_tree_state_rows", lambda *args: None)
        return model.jacobians(*args, **options)


def gimbal():
    """A body on a gimbal (three speeds of one support, in the order of its
    rotations), a pendulum hanging from it on a revolute joint with a torsional
    spring and damper, gravity, a constant torque on the gimbal's body and an
    input force off a mass centre."""
    q = me.dynamicsymbols("q1:5")
    u = me.dynamicsymbols("u1:5")
    F = me.dynamicsymbols("F")
    m1, m2, g, a, b, d, ell, k, c, T0 = sm.symbols("m1 m2 g a b d l k c T0")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    A, B, C, D = (me.ReferenceFrame(name) for name in "ABCD")
    A.orient_axis(N, N.z, q[0])
    A.set_ang_vel(N, u[0] * N.z)
    B.orient_axis(A, A.x, q[1])
    B.set_ang_vel(A, u[1] * A.x)
    C.orient_axis(B, B.y, q[2])
    C.set_ang_vel(B, u[2] * B.y)
    D.orient_axis(C, C.x, q[3])
    D.set_ang_vel(C, u[3] * C.x)
    Cc = O.locatenew("Cc", a * C.z + b * C.x)
    Q = O.locatenew("Q", d * C.y)
    Dc = Q.locatenew("Dc", -ell * D.z)
    for point in (Cc, Q, Dc):
        point.set_vel(N, point.pos_from(O).dt(N))
    body = me.RigidBody("body", Cc, C, m1, (me.inertia(C, 0.3, 0.2, 0.25, 0.01, 0.02, -0.01), Cc))
    bob = me.RigidBody("bob", Dc, D, m2, (me.inertia(D, 0.05, 0.04, 0.02), Dc))
    spring = -(k * q[3] + c * u[3]) * C.x
    eom = kd.kane(frame=N, q_ind=list(q), u_ind=list(u),
                  kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)], bodies=[body, bob],
                  loads=[(Cc, -m1 * g * N.z), (Dc, -m2 * g * N.z), (C, T0 * N.x),
                         (D, spring), (C, -spring), (Q, F * N.y)])
    constants = {m1: 2.0, m2: 0.7, g: 9.81, a: 0.2, b: 0.05, d: 0.3, ell: 0.4, k: 3.0,
                 c: 0.2, T0: 0.5}
    return eom, constants, F


def gimbal_model(backend="numpy"):
    eom, constants, F = gimbal()
    return eom.numeric(constants=constants, specified={F: 0.8}, backend=backend)


def chain(n=4):
    definition = kd.models.build("chain3d", n=n)
    return definition, definition.numeric(backend="numpy")


def urdf_tree_file(tmp_path, seed=1):
    rng = np.random.default_rng(seed)
    parent = [-1] + [int(rng.integers(-1, k)) for k in range(6)]  # several roots
    return random_tree_urdf(tmp_path / "tree.urdf", parent, seed)


def one_derivation(which, urdf=None):
    """``new(backend="numpy")``: a new numeric model of the tree ``which`` (the gimbal,
    chain3d n = 4, or the URDF file ``urdf``) at each call, every one from the
    same derivation: a model keeps its own derivatives and workspace (the
    equations stay as derived), so each call's model starts as a first one."""
    if which == "gimbal":
        eom, constants, F = gimbal()
        return lambda backend="numpy": eom.numeric(constants=constants, specified={F: 0.8},
                                                   backend=backend)
    definition = (kd.models.build("chain3d", n=4) if which == "chain3d"
                  else kd.models.from_urdf(urdf))
    eom = definition.derive()
    return lambda backend="numpy": definition.numeric(eom, backend=backend)


def a_tree_state(model, seed=3):
    return np.random.default_rng(seed).uniform(-1.2, 1.2, model.n_states)


@pytest.mark.parametrize("which", ["gimbal", "chain3d", "urdf"])
def test_trees_agree_with_the_derivatives_of_the_program(which, monkeypatch, tmp_path):
    """State, inputs and constants, the same to round-off whichever way the state
    columns of the inertia forces were formed."""
    build = one_derivation(which, urdf_tree_file(tmp_path) if which == "urdf" else None)
    model, general = build(), build()
    assert spatial_rows(model) is not None
    y = a_tree_state(model)
    mine = model.jacobians(0.0, y, parameters=True)
    theirs = by_the_program(monkeypatch, general, 0.0, y, parameters=True)
    for part in ("f", "state", "inputs", "parameters"):
        a, b = getattr(mine, part), getattr(theirs, part)
        assert a.shape == b.shape and (not a.size or relative(a, b) < 1e-12), part


def factors_against_expressions(which, backend, monkeypatch, tmp_path):
    """Worst relative difference between the derivatives of a tree whose entries
    are formed from its factors when the code runs and those written as
    expressions, over three states at once, parameters included, and one."""
    new = one_derivation(which, random_tree_urdf(tmp_path / "tree.urdf",
                                                 [-1, 0, 1, -1, 3, 3, 0], 4)
                         if which == "urdf" else None)
    expressions = new(backend)
    Y = np.random.default_rng(8).uniform(-1.2, 1.2, (3, expressions.n_states))
    theirs = expressions.jacobians(0.0, Y, parameters=True)
    monkeypatch.setattr(_jacobians, "TREE_FACTOR_MIN_SPEEDS", 1)
    factored = new(backend)
    mine = factored.jacobians(0.0, Y, parameters=True)
    if backend == "numpy":
        assert factored.__dict__["_jacobian_tree"] is not None
    else:
        assert _jacobians._c_key(factored, True)[0].endswith(" factors")
    worst = relative(factored.jacobians(0.0, Y[1]).state, theirs.state[1])
    for part in ("f", "state", "inputs", "parameters"):
        a, b = getattr(mine, part), getattr(theirs, part)
        assert a.shape == b.shape, part
        worst = max(worst, relative(a, b) if a.size else 0.0)
    return worst


@pytest.mark.parametrize("which", ["gimbal", "chain3d", "urdf"])
def test_factors_formed_when_the_code_runs(which, monkeypatch, tmp_path):
    """From ``TREE_FACTOR_MIN_SPEEDS`` speeds the entries are formed from the
    per-speed factors when the code runs (NumPy: ``tree_jacobian_values``): the
    same numbers as the entries written as expressions."""
    assert factors_against_expressions(which, "numpy", monkeypatch, tmp_path) < 1e-12


@needs_compiler
@pytest.mark.parametrize("which", ["chain3d", "urdf"])
def test_factors_formed_in_c(which, monkeypatch, tmp_path):
    """The same in C (``kd_tree_jacobian``): on a chain (its rows vectorized) and
    on a tree of two roots."""
    assert factors_against_expressions(which, "c", monkeypatch, tmp_path) < 1e-12


def derived(definition):
    """``(definition, its equations)``: derived once for the several C models a
    test builds from them (the settings of ``_jacobians`` those tests change act
    on the derivative modules, not on the derivation)."""
    return definition, definition.derive()


def derivatives_built_with(monkeypatch, tmp_path, folder, built, states=2, **settings):
    """``model.jacobians`` at ``states`` states and at one (parameters included) of a
    new C model of ``built``, ``(definition, eom)``, whose derivative module is
    built with the settings of ``_jacobians`` given in the cache ``folder`` of
    ``tmp_path`` (a fresh one, or one that holds no derivative module of that
    module's key: the caller asserts the keys differ), and that module's cache
    key."""
    from kanedyn.numerics.backends import _c_build
    with monkeypatch.context() as patch:
        patch.setenv("KANEDYN_CACHE_DIR", str(tmp_path / folder))
        patch.setattr(_c_build, "_LOADED", {})
        for name, value in settings.items():
            patch.setattr(_jacobians, name, value)
        definition, eom = built
        model = definition.numeric(eom, backend="c")
        y = np.resize(definition.initial(model), model.n_states) + 0.1
        Y = np.stack([y * (1.0 - 0.1 * k) for k in range(states)])
        return (model.jacobians(0.0, Y, parameters=True),
                model.jacobians(0.0, Y[-1], parameters=True), _jacobians._c_key(model, True)[0])


@needs_compiler
def test_the_listings_of_the_derivative_module_give_the_same_numbers(monkeypatch, tmp_path):
    """The derivative module takes the values the dynamics computed
    (``_c._shared_sources``): below ``PLAIN_DYNAMICS_MIN_SPEEDS`` M and the forcing
    are listed with the derivatives, their common subexpressions eliminated
    together; from there M and the forcing are listed plain.  Both give the
    same derivatives, multipliers and all, to the bit (the four-bar: its solve
    uses M with multipliers; chain3d n = 7: the entries as expressions)."""
    for definition in (kd.models.build("four-bar"), kd.models.build("chain3d", n=7)):
        built = derived(definition)
        together = derivatives_built_with(monkeypatch, tmp_path, "together", built)
        apart = derivatives_built_with(monkeypatch, tmp_path, "apart", built,
                                       PLAIN_DYNAMICS_MIN_SPEEDS=0)
        for mine, theirs in zip(together[:2], apart[:2]):
            for part in ("f", "state", "parameters", "multipliers"):
                a, b = getattr(mine, part), getattr(theirs, part)
                assert (a is None and b is None) or np.array_equal(a, b), part


@needs_compiler
@pytest.mark.parametrize("which", ["chain3d", "urdf"])
def test_solved_by_the_tree_pass(which, monkeypatch, tmp_path):
    """A tree whose right-hand side is solved by the articulated-body pass (from
    12 speeds), its paths long enough (``TREE_SOLVE_MIN_DEPTH``, lowered here),
    has its derivative columns solved by that pass (``kd_tree_apply``, no M in
    the module): the derivatives of M's factors to 1e-12, one state and
    several, on chain3d n = 12 (a chain: one block of bias rows, updated in
    place) and on a random tree of 12 joints in two branches from two roots (a
    block per speed)."""
    if which == "chain3d":
        definition = kd.models.build("chain3d", n=12, style="positions")
    else:
        parent = [-1, 0, 1, 2, 3, 4, 2, 6, 7, -1, 9, 10]
        definition = kd.models.from_urdf(random_tree_urdf(tmp_path / "tree.urdf", parent, 5))
    built = derived(definition)
    # one cache for both: the model's own module is compiled once, and the two
    # derivative modules have different keys (asserted), so each is built here
    *by_pass, key = derivatives_built_with(monkeypatch, tmp_path, "cache", built, 3,
                                           TREE_SOLVE_MIN_DEPTH=0)
    *by_M, key_M = derivatives_built_with(monkeypatch, tmp_path, "cache", built, 3,
                                          TREE_SOLVE_MIN_DEPTH=10**6)
    assert "function tree" in key and "function dynamics" not in key
    assert "function dynamics" in key_M and "function tree" not in key_M
    for mine, theirs in zip(by_pass, by_M):
        for part in ("f", "state", "inputs", "parameters"):
            a, b = getattr(mine, part), getattr(theirs, part)
            assert a.shape == b.shape and (not a.size or relative(a, b) < 1e-12), part


def test_which_trees_are_solved_by_the_pass():
    """The pass solves the derivatives of a chain from 19 speeds (on average 10
    speeds on a path to the root), not below, nor a tree of short branches."""
    def by_the_pass(parent):
        model = type("Model", (), {})()
        model._functions, model._sizes = {"tree": None}, {"speed_tree": (parent, None)}
        model.n_u_dep, model.contacts = 0, ()
        model.__dict__["_jacobian_parts"] = ()
        return _jacobians._tree_solve(model)
    assert not by_the_pass([k - 1 for k in range(18)])
    assert by_the_pass([k - 1 for k in range(19)])
    assert not by_the_pass([-1, 0, 1, -1, 3, 4, -1, 6, 7, -1, 9, 10])  # 4 legs of 3


def test_the_gimbal_against_differences():
    model = gimbal_model()
    assert spatial_rows(model) is not None
    y = a_tree_state(model, seed=5)
    J = model.jacobians(0.0, y)
    assert relative(J.state, differences(lambda z: model.rhs(0.0, z), y)) < 1e-8
    assert relative(J.inputs, differences(lambda r: model.jacobians(0.0, y, r=r).f,
                                          [0.8])) < 1e-8


def test_not_where_they_do_not_apply():
    """A particle (no orientation to turn with its joint), coordinates whose rates
    are not the speeds, and a tree given the wrong inertia forces to agree with:
    the program's derivatives (the general path), which match differences."""
    pendulum = kd.models.build("pendulum")
    model = pendulum.numeric(backend="numpy")
    assert spatial_rows(model) is None
    y = a_state(pendulum, model)
    assert relative(model.jacobians(0.0, y).state,
                    differences(lambda z: model.rhs(0.0, z), y)) < 1e-8

    q, u = me.dynamicsymbols("q u")
    N, B = me.ReferenceFrame("N"), me.ReferenceFrame("B")
    B.orient_axis(N, N.z, q)
    B.set_ang_vel(N, 2 * u * N.z)  # q' = 2 u
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", 0.5 * B.x)
    C.v2pt_theory(O, N, B)
    rod = me.RigidBody("rod", C, B, 1.0, (me.inertia(B, 0.0, 0.1, 0.1), C))
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - 2 * u], bodies=[rod],
                  loads=[(C, -9.81 * N.y)])
    model = eom.numeric(backend="numpy")
    assert spatial_rows(model) is None
    y = np.array([0.4, -0.7])
    assert relative(model.jacobians(0.0, y).state,
                    differences(lambda z: model.rhs(0.0, z), y)) < 1e-8

    _, model = chain(3)
    prog, kin = _workspace(model)
    eom, table = model._eom, model._eom._table
    args, dynamics = model._functions["dynamics"]
    mass, o = dynamics[1][1], model.n_u
    inertia = [sm.Add(*[mass[r * o + s] * table.udot[s] for s in range(o)]) + eom._remainder[r]
               for r in range(o)]
    found = _tree_bodies(eom, kin)
    assert tree_inertia_derivatives(kin, *found, table.q, table.u, table.udot, o,
                                    inertia) is not None
    wrong = [e + table.q[0] ** 2 * int(r == 1) for r, e in enumerate(inertia)]
    assert tree_inertia_derivatives(kin, *found, table.q, table.u, table.udot, o,
                                    wrong) is None
    # the same check where the entries are not formed (from the factors' numbers)
    right = tree_inertia_derivatives(kin, *found, table.q, table.u, table.udot, o, inertia,
                                     factors=True, entries=False)
    assert right is not None and right[:2] == (None, None)
    both = tree_inertia_derivatives(kin, *found, table.q, table.u, table.udot, o, inertia,
                                    factors=True)
    assert right[2:] == both[2:]
    assert tree_inertia_derivatives(kin, *found, table.q, table.u, table.udot, o, wrong,
                                    factors=True, entries=False) is None
    # and with the reference as M's entries and the rest (no product formed)
    rest = list(eom._remainder)
    assert tree_inertia_derivatives(kin, *found, table.q, table.u, table.udot, o,
                                    (list(mass), rest), factors=True,
                                    entries=False)[2:] == both[2:]
    rest[1] += table.q[0] ** 2
    assert tree_inertia_derivatives(kin, *found, table.q, table.u, table.udot, o,
                                    (list(mass), rest), factors=True, entries=False) is None


def test_constant_loads_split_from_the_others():
    """The gimbal's gravity and constant torque are taken as constant loads (their
    generalized forces, checked by complex steps through the velocities, plus the
    other loads' give the equations' active forces); a constant load changed is
    found out, numerically as by the loads' partial velocities formed."""
    model = gimbal_model()
    prog, kin = _workspace(model)
    found = _tree_bodies(model._eom, kin)
    constants = set(model._functions["dynamics"][0]["p"])
    constant, other, active = _jacobians._split_loads(model, prog, kin, found, constants)
    assert len(constant) == 3 and other != active  # two weights, the torque
    speeds = model._eom._table.u[:model.n_u]
    assert _jacobians._sum_agrees(prog, constant, other, active, speeds)
    k, kind, vec, part = constant[0]
    changed = [(k, kind, tuple(2 * c for c in vec), part)] + constant[1:]
    assert not _jacobians._sum_agrees(prog, changed, other, active, speeds)
    formed = [(k, kind, vec, list(part)) for k, kind, vec, part in changed]  # no .vector
    assert not _jacobians._sum_agrees(prog, formed, other, active, speeds)
    formed = [(k, kind, vec, list(part)) for k, kind, vec, part in constant]
    assert _jacobians._sum_agrees(prog, formed, other, active, speeds)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pinocchio_compares_the_spatial_formulas(seed):
    """test_jacobians.py compares these trees with Pinocchio: through the
    spatial formulas (the same model, and its comparison made once per process
    for both files)."""
    _, _, model = random_tree(seed)
    assert spatial_rows(model) is not None
    assert random_tree_against_pinocchio(seed) < 1e-9


@pytest.mark.slow
def test_panda_through_the_spatial_formulas():
    path = robot_file("panda_description/urdf/panda.urdf")
    assert spatial_rows(kd.models.from_urdf(path).numeric(backend="numpy")) is not None


# ------------------------------------------------------------- one state, C
@needs_compiler
def test_one_state_in_one_call():
    """After the first call, one state takes one call of the C module: the numbers
    of the general path, and what it does not take as it comes (a list, another
    length) goes the general way (converted, or refused naming the states)."""
    model = gimbal_model(backend="c")
    y = a_tree_state(model)
    first = model.jacobians(0.0, y)
    assert "_jacobian_point" in model.__dict__
    again = model.jacobians(np.float64(0.0), y)
    rows = model.jacobians(np.zeros(1), y[None, :])
    for part in ("f", "state", "inputs", "constraints"):
        np.testing.assert_array_equal(getattr(again, part), getattr(first, part))
        np.testing.assert_array_equal(getattr(again, part), getattr(rows, part)[0])
    assert again.parameters is None and again.multipliers is None
    assert again.state_names == first.state_names and again.input_names == first.input_names
    listed = model.jacobians(0, list(y))
    np.testing.assert_array_equal(listed.state, first.state)
    with pytest.raises(ValueError, match="the state must have 8 entries"):
        model.jacobians(0.0, y[:5])
    with_r = model.jacobians(0.0, y, r=[0.8])
    np.testing.assert_array_equal(with_r.state, first.state)
    # r given as an array of the inputs: one call too (kept by the first call with r)
    assert "_jacobian_point_given_r" in model.__dict__
    given = model.jacobians(0.0, y, r=np.array([0.3]))
    general = model.jacobians(np.zeros(1), y[None, :], r=np.array([0.3]))
    for part in ("f", "state", "inputs", "constraints"):
        np.testing.assert_array_equal(getattr(given, part), getattr(general, part)[0])
    assert not np.array_equal(given.f, first.f)  # the input's force changed
    with pytest.raises(ValueError, match="r must have 1 entries"):
        model.jacobians(0.0, y, r=np.array([0.3, 0.1]))

    p = model.jacobians(0.0, y, parameters=True)
    p_again = model.jacobians(0.0, y, parameters=True)
    assert p.parameter_names == tuple(model.constants)
    np.testing.assert_array_equal(p_again.parameters, p.parameters)
    np.testing.assert_array_equal(p_again.state, first.state)


@needs_compiler
def test_one_state_with_multipliers_in_one_call():
    definition = kd.models.build("four-bar")
    model = definition.numeric(backend="c")
    y = np.asarray(definition.initial(model), dtype=float)
    first = model.jacobians(0.0, y, parameters=True)
    again = model.jacobians(0.0, y, parameters=True)
    rows = model.jacobians(0.0, y[None, :], parameters=True)
    assert not model.input_names  # no inputs: an r of any length is refused
    with pytest.raises(ValueError, match="r must have 0 entries"):
        model.jacobians(0.0, y, r=np.ones(1), parameters=True)
    np.testing.assert_array_equal(model.jacobians(0.0, y, r=np.zeros(0)).state, first.state)
    for part in ("f", "state", "inputs", "parameters", "multipliers", "multipliers_inputs",
                 "multipliers_parameters", "constraints"):
        np.testing.assert_array_equal(getattr(again, part), getattr(first, part))
        np.testing.assert_array_equal(getattr(again, part), getattr(rows, part)[0])
    assert again.multiplier_names == first.multiplier_names


@needs_compiler
def test_the_pass_solves_one_state_in_place_as_the_numpy_backend(tmp_path, monkeypatch):
    """chain3d n = 19, the smallest chain the pass solves by default: the state's
    columns only (written in place in the result), called twice at one state
    (the first call builds the module, the second is the one-state path), and a
    batch, against the NumPy backend's derivatives (M and a dense solve, another
    code path) and central differences of the right-hand side."""
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path / "cache"))
    definition = kd.models.build("chain3d", n=19, style="positions", lazy=False)
    eom = definition.derive()
    c, ref = (definition.numeric(eom, backend=b) for b in ("c", "numpy"))
    y = definition.initial(c) + np.linspace(0.1, 0.6, c.n_states)
    first, second = c.jacobians(0.0, y), c.jacobians(0.0, y)
    assert "function tree" in _jacobians._c_key(c, False)[0]  # solved by the pass
    expected = ref.jacobians(0.0, y).state
    for J in (first, second, c.jacobians(0.0, np.stack([y, y]))):
        states = J.state if J.state.ndim == 2 else J.state[1]
        assert relative(states, expected) < 1e-11
    h = 1e-6
    by_differences = np.stack([(c.rhs(0.0, y + h * e) - c.rhs(0.0, y - h * e)) / (2 * h)
                            for e in np.eye(c.n_states)], axis=1)
    assert relative(second.state, by_differences) < 1e-7
