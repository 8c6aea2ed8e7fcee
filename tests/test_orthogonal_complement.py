"""The natural orthogonal complement (method="orthogonal-complement") and the Shuttle arm.

The NOC evaluates per-body twist maps, mass blocks and wrenches and assembles
M = sum T_b^T M_b T_b numerically; Kane's method (the reference, its own
code path) must give the same accelerations, multipliers, constraint forces
and trajectories.  Independent checks: the mass matrix is the Hessian of the
kinetic energy in the speeds; the symbolic products equal the numerical
assembly; on the Shuttle arm, the rate of change of kinetic energy equals the
joint-torque power, and the end effector follows the reference motion.
"""

import pickle

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn._errors import ModelError
from kanedyn.numerics import compiler_command
from kanedyn.schemes import OrthogonalComplement

NOC = "orthogonal-complement"

CASES = [("pendulum", {}), ("pendulum", {"tension": True}),
         ("n-link-pendulum-on-cart", {}), ("chain3d", {"n": 3}), ("four-bar", {}),
         ("rolling-disk", {}), ("rolling-disk", {"normal_force": True}),
         ("shuttle-arm", {}), ("shuttle-arm", {"payload": False})]


@pytest.fixture(scope="module")
def derived():
    """{(name, options): (definition, Kane model, NOC eom, NOC model)}, built lazily."""
    cache = {}

    def get(name, **options):
        key = (name, tuple(sorted(options.items())))
        if key not in cache:
            definition = kd.models.build(name, **options)
            kane = definition.numeric(definition.derive())
            eom = definition.derive(method=NOC)
            cache[key] = definition, kane, eom, definition.numeric(eom)
        return cache[key]
    return get


def _states(definition, model, count, seed, spread=0.5):
    rng = np.random.default_rng(seed)
    y0 = definition.initial(model)
    n = model.n_q
    for _ in range(count):
        y = y0.copy()
        y[:model.n_q_ind] += rng.uniform(-spread, spread, model.n_q_ind)
        y[n:n + model.n_u_ind] += rng.uniform(-1.0, 1.0, model.n_u_ind)
        yield model.state(y) if (model.n_q_dep or model.n_u_dep) else y


@pytest.mark.parametrize("name, options", CASES)
def test_accelerations_equal_kane(derived, name, options):
    definition, kane, eom, noc = derived(name, **options)
    assert eom.method == NOC and isinstance(noc.scheme, OrthogonalComplement)
    for k, y in enumerate(_states(definition, kane, 5, seed=3)):
        t = 0.7 + 20.0 * k  # the Shuttle arm's references depend on time
        a, b = kane.rhs(t, y), noc.rhs(t, y)
        assert np.max(np.abs(a - b)) <= 1e-10 * np.max(np.abs(a)), (name, options, a, b)
        if kane.multiplier_names:
            lk, ln = kane.multipliers(t, y), noc.multipliers(t, y)
            for key in lk:
                assert abs(lk[key] - ln[key]) <= 1e-9 * (1.0 + abs(lk[key])), key
        if kane.aux_names:
            fk, fn = kane.auxiliary(t, y), noc.auxiliary(t, y)
            for key in fk:
                assert abs(fk[key] - fn[key]) <= 1e-9 * (1.0 + abs(fk[key])), key


def test_cholesky_solves_the_reduced_system(derived, monkeypatch):
    """The scheme factors a symmetric positive definite matrix: N^T M N with
    dependent speeds (four-bar), M itself without (chain)."""
    import scipy.linalg as sla  # the scheme's factorization (imported where used)
    calls = []
    original = sla.cho_factor

    def spy(A, *args, **kwargs):
        calls.append(np.array(A))
        return original(A, *args, **kwargs)

    monkeypatch.setattr(sla, "cho_factor", spy)
    for name, options, size in (("four-bar", {}, 1), ("chain3d", {"n": 3}, 3)):
        definition, _, eom, noc = derived(name, **options)
        assert isinstance(eom.scheme, OrthogonalComplement)
        calls.clear()
        y = next(_states(definition, noc, 1, seed=5))
        noc.rhs(0.0, y)
        assert len(calls) == 1 and calls[0].shape == (size, size)
        assert np.allclose(calls[0], calls[0].T, rtol=1e-12, atol=0.0)
        assert np.all(np.linalg.eigvalsh(calls[0]) > 0)


def test_model_evaluates_the_per_body_blocks(derived):
    """The generated dynamics of a NOC model assemble blocks; copies and
    unpickled models keep that assembly."""
    definition, kane, eom, noc = derived("chain3d", n=3)
    source = noc._data["sources"]["dynamics"]
    assert "def _noc_blocks" in source and "T.T @ MT" in source
    y = next(_states(definition, noc, 1, seed=11))
    again = pickle.loads(pickle.dumps(noc))
    assert "def _noc_blocks" in again._data["sources"]["dynamics"]
    assert np.array_equal(again.rhs(0.0, y), noc.rhs(0.0, y))
    heavier = noc.with_constants({"m": 2.0})
    assert np.allclose(heavier.rhs(0.0, y), kane.with_constants({"m": 2.0}).rhs(0.0, y),
                       rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name, options", [("chain3d", {"n": 3}), ("shuttle-arm", {})])
def test_mass_matrix_is_the_kinetic_energy_hessian(derived, name, options):
    """T = u^T M u / 2 with T from the bodies' velocities (an independent path)."""
    definition, _, _, noc = derived(name, **options)
    y = next(_states(definition, noc, 1, seed=2))
    n, o = noc.n_q, noc.n_u
    M = noc.mass_matrix(0.0, y)

    def kinetic(*speeds):
        yy = y.copy()
        yy[n:] = 0.0
        for i in speeds:
            yy[n + i] += 1.0
        return noc.kinetic_energy(0.0, yy)

    H = np.array([[kinetic(i, j) - kinetic(i) - kinetic(j) if i != j else 2 * kinetic(i)
                   for j in range(o)] for i in range(o)])
    assert np.allclose(M, H, rtol=1e-10, atol=1e-10 * np.max(np.abs(M)))


@pytest.mark.parametrize("name, options", [("chain3d", {"n": 3}), ("four-bar", {})])
def test_symbolic_products_equal_numeric_assembly(derived, name, options):
    definition, _, eom, noc = derived(name, **options)
    y = next(_states(definition, noc, 1, seed=4))
    values = {s: v for s, v in zip(eom.state, y)}
    values.update(definition.constants)
    M = np.array(eom.mass_matrix.xreplace(values).evalf(), dtype=float)
    F = np.array(eom.forcing.xreplace(values).evalf(), dtype=float).ravel()
    assert np.allclose(M, noc.mass_matrix(0.0, y), rtol=1e-11, atol=1e-12)
    assert np.allclose(F, noc.forcing(0.0, y), rtol=1e-11, atol=1e-11)
    # the same equations solved with the symbolic products (Kane-style elimination)
    products = definition.numeric(eom, scheme="elimination")
    assert np.allclose(products.rhs(0.0, y), noc.rhs(0.0, y), rtol=1e-11, atol=1e-12)
    counts = eom.operation_counts()
    assert counts["mass_matrix"] > 0 and counts["forcing"] > 0


def test_linearization_matches_kane(derived):
    definition, _, eom, _ = derived("chain3d", n=3)
    kane = definition.derive()
    point = {**{q: 0.3 for q in eom.q}, **{u: 0.0 for u in eom.u}}
    A_noc = np.array(eom.linearize(op_point=point, constants=definition.constants)[0],
                     dtype=float)
    A_kane = np.array(kane.linearize(op_point=point, constants=definition.constants)[0],
                      dtype=float)
    assert np.allclose(A_noc, A_kane, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("name", ["four-bar", "rolling-disk"])
def test_trajectories_match_kane(derived, name):
    """Same integrator: the formulations agree to round-off.  NOC with BDF
    against Kane with DOP853: the difference is BDF's own global error (the
    same as Kane's equations integrated with BDF), not the formulation's."""
    definition, kane, _, noc = derived(name)
    y0 = kane.state(definition.initial(kane))
    t_end = 2.0
    t_eval = np.linspace(0.0, t_end, 21)
    runs = {(key, method): kd.simulate(model, (0.0, t_end), y0, method=method, rtol=1e-11,
                                       atol=1e-11, t_eval=t_eval)
            for key, model in (("kane", kane), ("noc", noc)) for method in ("BDF", "DOP853")}
    assert all(r.success for r in runs.values())

    def gap(a, b):
        return np.max(np.abs(runs[a].y - runs[b].y))

    assert gap(("noc", "DOP853"), ("kane", "DOP853")) < 1e-8
    assert gap(("noc", "BDF"), ("kane", "BDF")) < 1e-8
    bdf_error = gap(("kane", "BDF"), ("kane", "DOP853"))
    assert gap(("noc", "BDF"), ("kane", "DOP853")) <= 1.01 * bdf_error + 1e-8
    assert bdf_error < 1e-5
    assert np.max(np.abs(noc.constraint_residuals(t_end, runs["noc", "BDF"].y[:, -1]))) < 1e-8


def test_newton_euler_check_with_identified_forces():
    """Vector constraints: identified forces explain every body's motion."""
    definition = kd.models.build("knife-edge")
    model = definition.numeric(definition.derive(method=NOC))
    y = model.state(definition.initial(model))
    assert kd.check_newton_euler(model, 0.2, y).max < 1e-10


def test_errors():
    definition = kd.models.build("chain3d", n=2)
    kane = definition.derive()
    with pytest.raises(ModelError, match="orthogonal-complement"):
        definition.numeric(kane, scheme=OrthogonalComplement())
    with pytest.raises(ModelError, match="C backend"):
        definition.numeric(definition.derive(method=NOC), backend="c")


def test_load_on_a_point_of_no_body():
    """A force at a point with its own (auxiliary-free) velocity enters through
    its partial velocities, as Kane's method does."""
    q, u = me.dynamicsymbols("q u")
    m, k = sm.symbols("m k", positive=True)
    N, A = me.ReferenceFrame("N"), me.ReferenceFrame("A")
    A.orient_axis(N, N.z, q)
    A.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", A.x)
    G.v2pt_theory(O, N, A)
    S = me.Point("S")  # a slider on A.y, driven by a rate unrelated to any body
    S.set_vel(N, 2 * u * N.y)
    body = me.RigidBody("rod", G, A, m, (me.inertia(A, 0, 0, m), G))
    kwargs = dict(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u], bodies=[body],
                  loads=[(S, -k * q * N.y), (A, -k * u * N.z)])
    models = [kd.formulate(method=method, **kwargs).numeric(constants={m: 2.0, k: 3.0})
              for method in ("kane", NOC)]
    y = np.array([0.4, -0.7])
    assert np.allclose(models[0].rhs(0.0, y), models[1].rhs(0.0, y), rtol=1e-13)


# ------------------------------------------------------------- Shuttle arm
@pytest.fixture(scope="module")
def shuttle_runs(derived):
    """The manoeuvre: NOC with BDF, Kane with BDF, at tight tolerances."""
    definition, kane, _, noc = derived("shuttle-arm")
    t_eval = np.linspace(0.0, definition.t_end, 101)
    y0 = definition.initial(kane)
    runs = {key: kd.simulate(model, (0.0, definition.t_end), y0, method="BDF",
                             rtol=1e-10, atol=1e-11, t_eval=t_eval)
            for key, model in (("noc", noc), ("kane", kane))}
    return definition, kane, noc, runs


def test_shuttle_arm_noc_matches_kane(shuttle_runs):
    _, _, _, runs = shuttle_runs
    assert runs["noc"].success and runs["kane"].success
    # same equations to round-off; the integrations differ only by round-off
    assert np.max(np.abs(runs["noc"].y - runs["kane"].y)) < 1e-9


def _tip_and_reference(definition):
    sy, c = definition.symbols, definition.constants
    t = sm.Symbol("t")
    tip = sm.lambdify(sy["q"], sy["tip_position"].xreplace(c))
    ref = sm.lambdify(t, [e.xreplace(c).xreplace({me.dynamicsymbols._t: t})
                          for e in sy["q_ref"]])
    return tip, ref


def test_shuttle_arm_tracks_the_reference(shuttle_runs):
    """PD servos (bandwidth 0.5 rad/s): the end effector stays within 1 cm of
    where the reference joint angles put it, and settles on the end pose."""
    definition, _, _, runs = shuttle_runs
    tip, ref = _tip_and_reference(definition)
    res = runs["noc"]
    errors = [np.linalg.norm(np.ravel(tip(*res.y[:6, k])) - np.ravel(tip(*ref(t))))
              for k, t in enumerate(res.t)]
    travel = np.linalg.norm(np.ravel(tip(*ref(150.0))) - np.ravel(tip(*ref(0.0))))
    assert travel > 5.0  # m: the payload really moves
    assert max(errors) < 0.01
    assert errors[-1] < 1e-5
    assert np.max(np.abs(res.y[6:, -1])) < 1e-6  # at rest


def test_shuttle_arm_energy_balance(shuttle_runs):
    """dT/dt (central differences of the kinetic energy along the motion)
    equals the joint-torque power sum tau_i u_i: no gravity, rigid links."""
    definition, _, noc, runs = shuttle_runs
    sy, c = definition.symbols, definition.constants
    t = sm.Symbol("t")
    args = [t] + list(sy["q"]) + list(sy["u"])
    power = sm.lambdify(args, sm.Add(*[tau * u for tau, u in zip(sy["torques"], sy["u"])])
                        .xreplace(c).xreplace({me.dynamicsymbols._t: t}))
    res = runs["noc"]
    checked = 0
    for k in range(5, len(res.t) - 30, 7):
        tk, y = res.t[k], res.y[:, k]
        P = power(tk, *y)
        h = 1e-3
        ydot = noc.rhs(tk, y)
        dT = (noc.kinetic_energy(tk + h, y + h * ydot)
              - noc.kinetic_energy(tk - h, y - h * ydot)) / (2 * h)
        assert abs(dT - P) <= 1e-5 * abs(P) + 1e-12, (tk, dT, P)
        checked += 1
    assert checked >= 5


@pytest.mark.slow
def test_shuttle_arm_bdf_noc_matches_kane_dop853(shuttle_runs):
    """Kane's equations with an explicit method (DOP853, many steps: the
    servo damping makes the system stiff) against the NOC with BDF."""
    definition, kane, _, runs = shuttle_runs
    t_eval = runs["noc"].t
    # Kane's equations compiled (the same equations; DOP853 takes ~35,000 evaluations
    # here: 14.7 s of CPU with the NumPy backend, 1.0 s in C).  The two DOP853 runs
    # differ by 1.2e-9 at most, against the 1e-8 below.
    if compiler_command() is not None:
        kane = definition.numeric(kane._eom, backend="c")
    ref = kd.simulate(kane, (0.0, definition.t_end), definition.initial(kane),
                      method="DOP853", rtol=1e-10, atol=1e-11, t_eval=t_eval)
    assert ref.success
    assert np.max(np.abs(runs["noc"].y[:6] - ref.y[:6])) < 1e-8  # rad
    assert np.max(np.abs(runs["noc"].y[6:] - ref.y[6:])) < 1e-8  # rad/s
