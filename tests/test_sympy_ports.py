"""Code written for ``sympy.physics.mechanics`` works with ``kd.kane``.

The README promises that models and scripts written for SymPy's
``KanesMethod`` port unchanged.  Each test runs the same model through
SymPy's ``KanesMethod`` (the independent reference: kanedyn never calls it)
and through kanedyn, on separately built copies (SymPy caches velocities in
its ``Point`` objects), and compares what a ported script would use:

* ``linearize(op_point=..., A_and_B=...)`` with the speeds' time derivatives
  in the operating point, in both of SymPy's return forms;
* ``eom.numeric(constants=...)`` given every parameter of the description,
  also ones that cancel out of the equations (SymPy users pass them all);
* ``mass_matrix_full`` / ``forcing_full`` of a chain written as SymPy's
  documentation writes models, evaluated with ``sm.lambdify``, ``me.msubs``
  and ``.subs``;
* pickling of derived equations.
"""

from __future__ import annotations

import importlib.util
import json
import pathlib
import pickle
import subprocess
import sys
import warnings

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

T = me.dynamicsymbols._t
ROOT = pathlib.Path(__file__).resolve().parents[1]


def _peers():
    """benchmarks/_peers.py, where the SymPy-docs chain is written (shared
    with benchmarks/bench_derivation.py so that the two never diverge)."""
    spec = importlib.util.spec_from_file_location("kanedyn_bench_peers",
                                                  ROOT / "benchmarks" / "_peers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def sympy_kane(args):
    """SymPy's KanesMethod on kane() keyword arguments, equations formed."""
    km = me.KanesMethod(
        args["frame"], args["q_ind"], args["u_ind"], kd_eqs=args["kd_eqs"],
        q_dependent=args.get("q_dep") or None, u_dependent=args.get("u_dep") or None,
        configuration_constraints=args.get("configuration_constraints") or None,
        velocity_constraints=args.get("velocity_constraints") or None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        km.kanes_equations(args["bodies"], args["loads"])
    return km


def as_float(matrix, values):
    """A SymPy matrix with ``values`` substituted, as a float array."""
    return np.array(matrix.xreplace(values).evalf(), dtype=float)


# ------------------------------------------------------------ linearization
LINEARIZE_CASES = [("pendulum", {}), ("n-link-pendulum-on-cart", {"n": 2}),
                   ("four-bar", {})]


def _operating_point(definition, eom, km, accelerations="model", shift=0.1):
    """A consistent state with its accelerations, keyed for each tool.

    ``accelerations``: "model" (from the equations of motion), "zero" (not
    satisfying them) or "independent" (only the independent speeds').
    """
    model = definition.numeric(eom)
    y = model.consistent_state(0.0, definition.initial(model) + shift)
    udot = model.rhs(0.0, y)[model.n_q:]
    if accelerations == "zero":
        udot = np.zeros_like(udot)
    n_ud = len(eom.u_ind) if accelerations == "independent" else len(eom.u)
    points = []
    for q, u in ((eom.q, eom.u), (km.q, km.u)):
        point = dict(zip(q, y[:len(q)]))
        point.update(zip(u, y[len(q):]))
        point.update({s.diff(T): v for s, v in zip(list(u)[:n_ud], udot)})
        points.append(point)
    return points


@pytest.mark.parametrize("name, options", LINEARIZE_CASES)
@pytest.mark.parametrize("A_and_B", [True, False])
def test_linearize_with_accelerations_matches_sympy(name, options, A_and_B):
    """Symbolic and numerical linearization against KanesMethod.linearize.

    The operating point carries u' (as SymPy's users write it); both return
    forms must give SymPy's matrices: (A, B, r), and (M, A, B, r) of the
    implicit form M [dq'; du'] = A [dq_i; du_i] + B dr.
    """
    d_kd, d_sm = kd.models.build(name, **options), kd.models.build(name, **options)
    eom = kd.kane(**d_kd.kane_args)
    km = sympy_kane(d_sm.kane_args)
    op_kd, op_sm = _operating_point(d_kd, eom, km)
    ours = eom.linearize(op_point=op_kd, A_and_B=A_and_B)
    theirs = km.linearize(op_point=op_sm, A_and_B=A_and_B)
    assert len(ours) == len(theirs) == (3 if A_and_B else 4)
    assert [str(s) for s in ours[-1]] == [str(s) for s in theirs[-1]]  # r
    numeric = eom.linearize(op_point=op_kd, A_and_B=A_and_B, constants=d_kd.constants,
                            specified=d_kd.specified)
    for mine, num, ref in zip(ours[:-1], numeric[:-1], theirs[:-1]):
        assert mine.shape == ref.shape
        if ref.shape == (0, 0):  # no inputs: SymPy's empty B
            continue
        expected = as_float(ref, d_sm.constants)
        scale = max(1.0, np.max(np.abs(expected)))
        np.testing.assert_allclose(as_float(mine, d_kd.constants), expected,
                                   rtol=0, atol=1e-11 * scale)
        np.testing.assert_allclose(num, expected, rtol=0, atol=1e-11 * scale)


def test_accelerations_are_used_as_given():
    """u' = 0 away from equilibrium (not a solution of the equations): SymPy
    substitutes the given values, and so does kanedyn; the numerical path
    warns that they do not satisfy the equations of motion."""
    d_kd, d_sm = kd.models.build("four-bar"), kd.models.build("four-bar")
    eom = kd.kane(**d_kd.kane_args)
    km = sympy_kane(d_sm.kane_args)
    op_kd, op_sm = _operating_point(d_kd, eom, km, accelerations="zero")
    for A_and_B in (True, False):
        ours = eom.linearize(op_point=op_kd, A_and_B=A_and_B)
        theirs = km.linearize(op_point=op_sm, A_and_B=A_and_B)
        with pytest.warns(RuntimeWarning, match="do not satisfy the equations"):
            numeric = eom.linearize(op_point=op_kd, A_and_B=A_and_B,
                                    constants=d_kd.constants)
        for mine, num, ref in zip(ours[:-1], numeric[:-1], theirs[:-1]):
            if ref.shape == (0, 0):
                continue
            expected = as_float(ref, d_sm.constants)
            np.testing.assert_allclose(as_float(mine, d_kd.constants), expected,
                                       atol=1e-11 * max(1.0, np.max(np.abs(expected))))
            np.testing.assert_allclose(num, expected,
                                       atol=1e-11 * max(1.0, np.max(np.abs(expected))))


def test_independent_accelerations_suffice():
    """With constraints, u1' alone: u2', u3' follow from the acceleration
    constraints; the result equals the one with all three given and the one
    with none (computed from the equations of motion)."""
    d = kd.models.build("four-bar")
    eom = d.derive()
    model = d.numeric(eom)
    y = model.consistent_state(0.0, d.initial(model) + 0.1)
    udot = model.rhs(0.0, y)[3:]
    state = {**dict(zip(eom.q, y[:3])), **dict(zip(eom.u, y[3:]))}
    given = {**state, eom.u[0].diff(T): udot[0]}
    every = {**state, **{u.diff(T): v for u, v in zip(eom.u, udot)}}
    reference = eom.linearize(op_point=state, constants=d.constants)[0]
    for point in (given, every):
        np.testing.assert_allclose(eom.linearize(op_point=point, constants=d.constants)[0],
                                   reference, atol=1e-10)
        np.testing.assert_allclose(as_float(eom.linearize(op_point=point)[0], d.constants),
                                   reference, atol=1e-10)
    with pytest.raises(ValueError, match="u1'"):
        eom.linearize(op_point={**state, eom.u[1].diff(T): udot[1]})


def test_rates_in_operating_point_are_accepted():
    """SymPy scripts often put q' in the operating point: accepted, unused."""
    d = kd.models.build("pendulum")
    eom = d.derive()
    q, u = d.symbols["q"], d.symbols["u"]
    A, _, _ = eom.linearize(op_point={q: 0, u: 0, q.diff(T): 0, u.diff(T): 0})
    l, g = d.symbols["l"], d.symbols["g"]
    assert sm.simplify(A - sm.Matrix([[0, 1], [-g / l, 0]])) == sm.zeros(2, 2)


# ----------------------------------------------------------------- constants
def _turntable():
    """A rod turning about the vertical N.z under gravity -g N.z, with a tip
    point P at distance L (no body there): g and L drop out of the equations
    but are parameters of the description."""
    q, u = me.dynamicsymbols("q u")
    m, a, g, L, c = sm.symbols("m a g L c", positive=True)
    N, A = me.ReferenceFrame("N"), me.ReferenceFrame("A")
    A.orient_axis(N, N.z, q)
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", a * A.x)
    G.v2pt_theory(O, N, A)
    P = O.locatenew("P", L * A.x)
    P.v2pt_theory(O, N, A)
    rod = me.RigidBody("rod", G, A, m, (me.inertia(A, 0, 0, m * a ** 2 / 3), G))
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u], bodies=[rod],
                  loads=[(G, -m * g * N.z), (A, -c * u * N.z)])
    return eom, (q, u, m, a, g, L, c)


def test_parameters_that_cancel_are_accepted():
    eom, (q, u, m, a, g, L, c) = _turntable()
    assert set(eom.constants) == {m, a, c}
    assert set(eom.parameters) == {m, a, g, L, c}
    # J u' = -c u with J = 4 m a^2 / 3 (inertia about O)
    model = eom.numeric(constants={m: 2.0, a: 0.5, g: 9.81, L: 1.0, c: 0.3})
    assert set(model.constants) == {"m", "a", "c"}  # the values the code uses
    assert model.rhs(0.0, [0.2, 1.5])[1] == pytest.approx(-0.3 * 1.5 / (4 * 2.0 * 0.25 / 3))
    by_name = eom.numeric(constants={"m": 2.0, "a": 0.5, "g": 9.81, "L": 1.0, "c": 0.3})
    np.testing.assert_array_equal(by_name.rhs(0.0, [0.2, 1.5]), model.rhs(0.0, [0.2, 1.5]))
    with pytest.raises(kd.MissingValueError, match="c"):
        eom.numeric(constants={m: 2.0, a: 0.5, g: 9.81})


@pytest.mark.timeout(60)
def test_parameters_of_a_description_with_shared_subexpressions():
    """The parameters are read from every expression of the description once
    per distinct subexpression: a point placed by an expression in which each
    level refers to the one below twice (2**60 paths through 121 nodes) took
    forever, and chain3d's 30 frames, whose angular velocities SymPy composes
    that way, took 80 s to derive (0.8 s now)."""
    q, u = me.dynamicsymbols("q u")
    k = sm.symbols("k")
    level = q + k
    for _ in range(60):
        level = sm.Mul(level, sm.Add(level, 1, evaluate=False), evaluate=False)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x)
    P.set_vel(N, u * N.x)
    Q = O.locatenew("Q", level * N.y)  # a marker: no body there
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("p", P, 1)], loads=[(P, -u * N.x), (Q, 0 * N.x)])
    assert k in set(eom.parameters)


def test_unknown_constant_names_the_closest():
    eom, (q, u, m, a, g, L, c) = _turntable()
    values = {m: 2.0, a: 0.5, c: 0.3}
    with pytest.raises(kd.ModelError, match=r"gg is not a parameter.*did you mean 'g'"):
        eom.numeric(constants={**values, "gg": 9.81})
    with pytest.raises(kd.ModelError, match="did you mean 'L'"):
        eom.numeric(constants={**values, sm.Symbol("LL"): 1.0})
    with pytest.raises(kd.ModelError, match="another symbol"):  # same name, other assumptions
        eom.numeric(constants={**values, sm.Symbol("g"): 9.81})
    with pytest.raises(kd.ModelError, match="not a parameter"):
        eom.numeric(constants={**values, "m + a": 1.0})  # names are never parsed


def test_specified_input_names_are_matched_not_parsed():
    d = kd.models.build("n-link-pendulum-on-cart", n=1)
    eom = d.derive()
    F = d.symbols["F"]
    y = np.array([0.0, 0.3, 0.0, 0.0])
    by_name = d.numeric(eom, specified={"F": 1.5}).rhs(0.0, y)
    np.testing.assert_array_equal(by_name, d.numeric(eom, specified={F: 1.5}).rhs(0.0, y))
    with pytest.raises(kd.ModelError, match="did you mean 'F'"):
        eom.numeric(constants=d.constants, specified={"FF": 1.0})
    with pytest.raises(kd.ModelError, match="not a specified input"):
        eom.numeric(constants=d.constants, specified={"F + 1": 1.0})


# ----------------------------------------------------------- explicit views
def _compare_full(eom, km, constants, states):
    """mass_matrix_full and forcing_full of both tools at states, lambdified."""
    q, u = list(km.q), list(km.u)
    p = sorted(constants, key=str)
    values = [constants[s] for s in p]
    ours = sm.lambdify([q + u, p], [eom.mass_matrix_full, eom.forcing_full], cse=True)
    theirs = sm.lambdify([q + u, p], [km.mass_matrix_full, km.forcing_full], cse=True)
    assert eom.mass_matrix_full.shape == km.mass_matrix_full.shape
    assert eom.forcing_full.shape == km.forcing_full.shape
    for y in states:
        (M1, F1), (M2, F2) = ours(y, values), theirs(y, values)
        np.testing.assert_allclose(M1, M2, rtol=1e-10, atol=1e-10 * np.max(np.abs(M2)))
        np.testing.assert_allclose(F1, F2, rtol=1e-10, atol=1e-10 * np.max(np.abs(F2)))


def test_sympy_docs_chain_explicit_matrices():
    """The 3D chain written as SymPy's docs write models (v2pt_theory, full
    inertia dyadics, alternating x/y axes), n = 3: kanedyn's explicit
    matrices equal KanesMethod's at random states, and the usual SymPy tools
    work on them."""
    chain = _peers().sympy_docs_chain
    args = chain(3)
    constants = args.pop("constants")
    eom = kd.kane(**args)
    ref = chain(3)
    ref.pop("constants")
    km = sympy_kane(ref)
    rng = np.random.default_rng(3)
    _compare_full(eom, km, constants, rng.uniform(-2, 2, (5, 6)))
    # msubs / subs / xreplace give the same numbers as the numerical model
    y = rng.uniform(-2, 2, 6)
    point = {**dict(zip(eom.q, y[:3])), **dict(zip(eom.u, y[3:])), **constants}
    model = eom.numeric(constants=constants)
    expected = model.mass_matrix_full(0.0, y)
    np.testing.assert_allclose(np.array(me.msubs(eom.mass_matrix_full, point), dtype=float),
                               expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.array(eom.mass_matrix_full.subs(point), dtype=float),
                               expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(as_float(eom.forcing_full, point).ravel(),
                               model.forcing_full(0.0, y), rtol=1e-12, atol=1e-12)
    # lambdify without cse too
    f = sm.lambdify([list(eom.q) + list(eom.u), sorted(constants, key=str)],
                    eom.mass_matrix_full)
    np.testing.assert_allclose(f(y, [constants[s] for s in sorted(constants, key=str)]),
                               expected, rtol=1e-12, atol=1e-12)


def test_constrained_explicit_matrices():
    """The four-bar (two loop-closure constraints): SymPy's symbolic
    elimination and kanedyn's explicit view agree at consistent states."""
    d_kd, d_sm = kd.models.build("four-bar"), kd.models.build("four-bar")
    eom = kd.kane(**d_kd.kane_args)
    km = sympy_kane(d_sm.kane_args)
    model = d_kd.numeric(eom)
    rng = np.random.default_rng(4)
    states = []
    for _ in range(3):
        y = d_kd.initial(model)
        y[[0, 3]] += rng.uniform(-0.3, 0.3, 2)
        states.append(model.consistent_state(0.0, y))
    _compare_full(eom, km, d_kd.constants, states)


# ------------------------------------------------------------------ pickling
def _pickle_cases():
    pendulum = kd.models.build("pendulum", tension=True)
    return [
        ("auxiliary speeds", pendulum, pendulum.derive()),
        ("constraints", kd.models.build("four-bar"), None),
        ("specified input", kd.models.build("n-link-pendulum-on-cart", n=2), None),
        ("lagrange", kd.models.build("n-link-pendulum-on-cart", n=2), "lagrange"),
    ]


@pytest.mark.parametrize("case", range(4), ids=["aux", "four-bar", "cart", "lagrange"])
def test_equations_pickle(case):
    label, definition, eom = _pickle_cases()[case]
    if eom is None or eom == "lagrange":
        eom = kd.formulate(method=eom or "kane", **definition.kane_args)
    original_M = eom.mass_matrix_full  # cached views are not pickled, but rebuilt
    clone = pickle.loads(pickle.dumps(eom))
    assert clone.state_names == eom.state_names and clone.method == eom.method
    assert clone.constants == eom.constants and clone.parameters == eom.parameters
    a, b = definition.numeric(eom), definition.numeric(clone)
    rng = np.random.default_rng(case)
    for _ in range(3):
        y = a.consistent_state(0.0, rng.uniform(-1, 1, a.n_states)) if a.n_q_dep \
            else rng.uniform(-1, 1, a.n_states)
        np.testing.assert_array_equal(a.rhs(0.0, y), b.rhs(0.0, y))
    assert clone.mass_matrix_full == original_M
    assert clone.forcing_full == eom.forcing_full
    if eom.u_aux:
        assert clone.auxiliary_equations == eom.auxiliary_equations


@pytest.mark.slow
def test_equations_unpickle_in_another_process(tmp_path):
    """A fresh interpreter (other dummy-symbol counters) rebuilds the model."""
    d = kd.models.build("four-bar")
    eom = d.derive()
    path = tmp_path / "eom.pkl"
    path.write_bytes(pickle.dumps(eom))
    model = d.numeric(eom)
    y = model.consistent_state(0.0, d.initial(model))
    code = ("import json, pickle, sys, numpy as np\n"
            f"eom = pickle.loads(open({str(path)!r}, 'rb').read())\n"
            "c = {s: v for s, v in zip(eom.constants, sys.argv[1:])}\n"
            f"y = np.array({y.tolist()!r})\n"
            "print(json.dumps(eom.numeric(constants=c).rhs(0.0, y).tolist()))\n")
    values = [str(d.constants[s]) for s in eom.constants]
    out = subprocess.run([sys.executable, "-c", code, *values], capture_output=True,
                         text=True, check=True)
    np.testing.assert_array_equal(json.loads(out.stdout), model.rhs(0.0, y))
