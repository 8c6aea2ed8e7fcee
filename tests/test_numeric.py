"""NumericModel: the contract of rhs, pickling, inputs, and SymPy-convention matrices."""

import pickle

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd


@pytest.fixture(scope="module")
def cart():
    d = kd.models.build("n-link-pendulum-on-cart", n=2)
    return d, d.derive()


def test_rhs_returns_a_fresh_array(cart):
    d, eom = cart
    model = d.numeric(eom)
    y = d.initial(model)
    first = model.rhs(0.0, y)
    reference = first.copy()
    first[:] = 1e9  # a caller (or an integrator) overwriting its result
    second = model.rhs(0.0, y)
    assert second is not first
    np.testing.assert_array_equal(second, reference)


def test_pickle_round_trip(cart):
    d, eom = cart
    model = d.numeric(eom)
    clone = pickle.loads(pickle.dumps(model))
    y = d.initial(model) + 0.1
    np.testing.assert_array_equal(clone.rhs(0.3, y), model.rhs(0.3, y))
    assert clone.state_names == model.state_names


def test_state_order_and_names(cart):
    d, eom = cart
    model = d.numeric(eom)
    assert model.state_names == ("q0", "q1", "q2", "u0", "u1", "u2")
    assert [str(s) for s in eom.q] == ["q0(t)", "q1(t)", "q2(t)"]


def test_specified_input_forms(cart):
    """A number, f(t), f(t, y) and a SymPy expression give the same result."""
    d, eom = cart
    F = d.symbols["F"]
    t = me.dynamicsymbols._t
    y = d.initial(d.numeric(eom)) + 0.2
    forms = [0.7 * np.cos(0.5), lambda tt: 0.7 * np.cos(tt),
             lambda tt, yy: 0.7 * np.cos(tt), 0.7 * sm.cos(t)]
    values = [d.numeric(eom, specified={F: form}).rhs(0.5, y) for form in forms]
    for v in values[1:]:
        np.testing.assert_allclose(v, values[0], rtol=1e-14, atol=1e-14)
    # the input moves the cart: the cart acceleration changes with it
    zero = d.numeric(eom, specified={F: 0.0}).rhs(0.5, y)
    assert abs(values[0][3] - zero[3]) > 1e-3


def test_feedback_input_sees_the_state(cart):
    d, eom = cart
    F = d.symbols["F"]
    model = d.numeric(eom, specified={F: lambda t, y: -10.0 * y[3]})
    y = d.initial(model)
    y[3] = 1.0
    pushed = model.rhs(0.0, y)
    y[3] = -1.0
    pulled = model.rhs(0.0, y)
    assert pushed[3] < pulled[3]


def test_numeric_matches_explicit_sympy_matrices():
    """The numerical mass matrix and forcing equal the explicit ones."""
    d = kd.models.build("four-bar")
    eom = d.derive()
    model = d.numeric(eom)
    y = model.consistent_state(0.0, d.initial(model))
    subs = dict(zip(eom.state, y))
    subs.update(d.constants)
    M = np.array(eom.mass_matrix.xreplace(subs).evalf(), dtype=float)
    F = np.array(eom.forcing.xreplace(subs).evalf(), dtype=float).ravel()
    np.testing.assert_allclose(model.mass_matrix(0.0, y), M, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(model.forcing(0.0, y), F, rtol=1e-12, atol=1e-12)
    full = model.mass_matrix_full(0.0, y)
    assert full.shape == (6, 6)
    np.testing.assert_allclose(np.linalg.solve(full, model.forcing_full(0.0, y)),
                               model.rhs(0.0, y), rtol=1e-12, atol=1e-12)


def test_prescribed_base_motion():
    """A pendulum on a horizontally oscillating pivot: exact input derivatives."""
    q, u, x = me.dynamicsymbols("q u x")
    m, l, g, A, w = sm.symbols("m l g A w")
    t = me.dynamicsymbols._t
    N = me.ReferenceFrame("N")
    B = me.ReferenceFrame("B")
    B.orient_axis(N, N.z, q)
    B.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    pivot = O.locatenew("pivot", x * N.x)
    bob = pivot.locatenew("bob", -l * B.y)
    bob.v2pt_theory(pivot, N, B)
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("p", bob, m)], loads=[(bob, -m * g * N.y)])
    assert x.diff(t, 2) in eom.specified
    consts = {m: 1.0, l: 0.5, g: 9.81, A: 0.1, w: 3.0}
    model = eom.numeric(constants=consts, specified={x: A * sm.sin(w * t)})
    qq, uu, tt = 0.4, -0.3, 0.7
    # l q'' = -g sin q - x'' cos q, with x'' = -A w^2 sin(w t)
    xdd = -0.1 * 9.0 * np.sin(3.0 * tt)
    expected = (-9.81 * np.sin(qq) - xdd * np.cos(qq)) / 0.5
    np.testing.assert_allclose(model.rhs(tt, [qq, uu]), [uu, expected], rtol=1e-13)
    # the same with callables for the input and its derivatives
    model2 = eom.numeric(constants={m: 1.0, l: 0.5, g: 9.81}, specified={
        x: lambda s: 0.1 * np.sin(3 * s), x.diff(t): lambda s: 0.3 * np.cos(3 * s),
        x.diff(t, 2): lambda s: -0.9 * np.sin(3 * s)})
    np.testing.assert_allclose(model2.rhs(tt, [qq, uu]), model.rhs(tt, [qq, uu]),
                               rtol=1e-13)


def test_kane_from_system_with_joints():
    """kd.kane(system) reads joints, bodies, loads from a sympy System."""
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    m, l, g = sm.symbols("m l g")
    ground = me.RigidBody("ground")
    system = me.System.from_newtonian(ground)
    link1 = me.RigidBody("link1", mass=m)
    link2 = me.RigidBody("link2", mass=m)
    for link in (link1, link2):
        link.central_inertia = me.inertia(link.frame, 0, 0, m * l ** 2 / 12)
    j1 = me.PinJoint("j1", ground, link1, q1, u1, child_point=l / 2 * link1.y,
                     joint_axis=ground.z)
    j2 = me.PinJoint("j2", link1, link2, q2, u2, parent_point=-l / 2 * link1.y,
                     child_point=l / 2 * link2.y, joint_axis=link1.z)
    system.add_joints(j1, j2)
    system.apply_uniform_gravity(-g * ground.y)
    eom = kd.kane(system)
    model = eom.numeric(constants={m: 1.0, l: 0.4, g: 9.81})
    # hanging straight down at rest is an equilibrium; a displaced one is not
    assert np.max(np.abs(model.rhs(0.0, [0.0, 0.0, 0.0, 0.0]))) < 1e-12
    assert abs(model.rhs(0.0, [0.3, 0.0, 0.0, 0.0])[2]) > 1.0


def test_implicit_kinematics_full_matrices():
    """explicit_kinematics=False keeps the coefficient matrix of q' (rolling disk)."""
    d = kd.models.build("rolling-disk")
    eom_implicit = kd.kane(explicit_kinematics=False, **d.kane_args)
    eom_explicit = d.derive()
    assert eom_explicit.mass_matrix_kin == sm.eye(5)
    K = eom_implicit.mass_matrix_kin
    assert K != sm.eye(5)
    model = d.numeric(eom_explicit)
    y = model.consistent_state(0.0, d.initial(model) + 0.1)
    values = dict(zip(eom_implicit.state, y))
    values.update(d.constants)
    K_num = np.array(K.xreplace(values).evalf(), dtype=float)
    f_num = np.array(eom_implicit.forcing_kin.xreplace(values).evalf(), dtype=float).ravel()
    np.testing.assert_allclose(np.linalg.solve(K_num, f_num), model.rhs(0.0, y)[:5],
                               rtol=1e-12, atol=1e-12)


def test_latex_output():
    d = kd.models.build("pendulum")
    eom = d.derive()
    explicit = eom.to_latex()
    assert r"l^{2} m" in explicit and r"\dot{u}" in explicit
    assert eom._repr_latex_().startswith("$\\displaystyle")
    compact = kd.models.build("chain3d", n=4).derive().to_latex()
    assert "z_{0}" in compact and r"\dot{q}" in compact


def test_with_constants_and_batch_after_pickling(cart):
    d, eom = cart
    model = d.numeric(eom)
    y = d.initial(model) + 0.1
    moon = model.with_constants({"g": 1.62})
    assert moon.constants["g"] == 1.62 and model.constants["g"] == 9.81
    direct = d.numeric(eom, constants={"g": 1.62})
    np.testing.assert_allclose(moon.rhs(0.0, y), direct.rhs(0.0, y), rtol=1e-14)
    with pytest.raises(KeyError, match="gravity"):
        model.with_constants({"gravity": 1.0})
    with pytest.raises(ValueError, match="expected"):
        model.with_constants([1.0])
    Y = np.array([y, y + 0.05])
    clone = pickle.loads(pickle.dumps(model))  # before any batch call: no batch source
    np.testing.assert_allclose(clone.rhs_batch(0.0, Y), model.rhs_batch(0.0, Y), rtol=1e-13)


def test_kinematic_equations_pivot_away_from_vanishing_factors():
    """Solving the kinematic equations must not divide by sin(lean) (zero upright).

    With the disk's angles listed first, SymPy's LU would pivot on a
    sin(q4) entry; kanedyn picks pivots that vanish at no sampled point,
    including the all-zero configuration.
    """
    definition = kd.models.build("rolling-disk")
    args = dict(definition.kane_args)
    q = list(args["q_ind"])
    args["q_ind"] = [q[2], q[3], q[4], q[0], q[1]]
    eom = kd.kane(**args)
    model = definition.numeric(eom)
    upright = {"q4": 0.0}
    y = model.state(definition.initial(model, upright))
    assert np.all(np.isfinite(model.rhs(0.0, y)))
    reference = definition.numeric()
    y_ref = reference.state(definition.initial(reference, upright))
    names = reference.state_names
    perm = [names.index(n) for n in model.state_names]
    np.testing.assert_allclose(model.rhs(0.0, y), reference.rhs(0.0, y_ref)[perm],
                               atol=1e-12)



def test_a_second_model_of_the_same_equations_reuses_their_source(cart, monkeypatch):
    """A second numerical model of the same equations gets the sources its
    functions were printed to for the first (no new print: SymPy's printer
    was most of making it) and the same state derivative to the bit; the
    sources kept per program are bounded (each model made with numbers
    substituted for an input's expression would add one)."""
    from kanedyn.numerics.backends import _python
    d, eom = cart
    first = d.numeric(eom, backend="numpy")
    printed = []
    make = _python._generate_python
    monkeypatch.setattr(_python, "_generate_python",
                        lambda *args: printed.append(args[1]) or make(*args))
    again = d.numeric(eom, backend="numpy")
    assert printed == []
    y = np.linspace(0.1, 0.4, first.n_states)
    assert np.array_equal(again.rhs(0.0, y), first.rhs(0.0, y))
    t = sm.Symbol("t")
    for k in range(_python.SOURCES_PER_PROGRAM + 5):   # a new text each
        _python.generate_python(eom._program, "f", {"y": [], "p": [], "r": []},
                                [((), [t * (k + 1)])])
    assert len(printed) == _python.SOURCES_PER_PROGRAM + 5
    assert len(_python._SOURCES[eom._program]) == _python.SOURCES_PER_PROGRAM
