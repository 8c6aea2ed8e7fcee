"""Orthogonalized generalized speeds u* = L^T u, M = L L^T (Lesser 1992).

Independent checks: the mass matrix in u* against the identity, simulations
in u* mapped back against simulations in u, the factor's rate against finite
differences of numpy's Cholesky factor, the kinetic energy against |u*|^2/2.
"""

import pickle
import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

ROOT = Path(__file__).resolve().parents[1]
t_sym = me.dynamicsymbols._t


# ------------------------------------------------------------------ models
def double_pendulum_args():
    """Two rigid rods, the second hinged at the end of the first (relative angle)."""
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    m1, m2, l1, l2, g = sm.symbols("m1 m2 l1 l2 g", positive=True)
    N = me.ReferenceFrame("N")
    A, B = me.ReferenceFrame("A"), me.ReferenceFrame("B")
    A.orient_axis(N, N.z, q1)
    A.set_ang_vel(N, u1 * N.z)
    B.orient_axis(A, A.z, q2)
    B.set_ang_vel(A, u2 * A.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    Ca = O.locatenew("Ca", -l1 / 2 * A.y)
    J = O.locatenew("J", -l1 * A.y)
    Cb = J.locatenew("Cb", -l2 / 2 * B.y)
    for point, base, frame in ((Ca, O, A), (J, O, A), (Cb, J, B)):
        point.v2pt_theory(base, N, frame)
    rod_a = me.RigidBody("a", Ca, A, m1, (me.inertia(A, 0, 0, m1 * l1 ** 2 / 12), Ca))
    rod_b = me.RigidBody("b", Cb, B, m2, (me.inertia(B, 0, 0, m2 * l2 ** 2 / 12), Cb))
    args = dict(frame=N, q_ind=[q1, q2], u_ind=[u1, u2],
                kd_eqs=[q1.diff() - u1, q2.diff() - u2], bodies=[rod_a, rod_b],
                loads=[(Ca, -m1 * g * N.y), (Cb, -m2 * g * N.y)])
    constants = {m1: 1.0, m2: 0.7, l1: 0.8, l2: 0.5, g: 9.81}
    return args, constants


def variable_length_pendulum():
    """A particle on a rod whose length l(t) is prescribed: M = m l(t)^2.

    The rod's extension rate is a second input ``v(t)`` (give it as l'(t)):
    SymbolTable.internal refuses the derivative l'(t) in a velocity once l(t)
    itself is known to the table.
    """
    q, u = me.dynamicsymbols("q u")
    ell, rate = me.dynamicsymbols("l v")
    m, g = sm.symbols("m g", positive=True)
    N, A = me.ReferenceFrame("N"), me.ReferenceFrame("A")
    A.orient_axis(N, N.z, q)
    A.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", -ell * A.y)
    P.set_vel(N, -rate * A.y + ell * u * A.x)
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("p", P, m)], loads=[(P, -m * g * N.y)])
    return eom, (ell, rate), {m: 1.3, g: 9.81}


def length_law(scale=2.0):
    """l(t) = 1 + 0.3 sin(scale t) and its rate, as SymPy expressions."""
    law = 1.0 + 0.3 * sm.sin(scale * t_sym)
    return law, law.diff(t_sym)


@pytest.fixture(scope="module")
def models():
    """name -> NumericModel (original speeds)."""
    out = {}
    out["chain3d"] = kd.models.build("chain3d", n=3).numeric()
    out["pendulum"] = kd.models.build("pendulum").numeric(constants={"m": 2.0, "l": 1.5})
    cart = kd.models.build("n-link-pendulum-on-cart", n=3)
    out["cart"] = cart.numeric(specified={cart.symbols["F"]: push})
    args, constants = double_pendulum_args()
    out["double"] = kd.kane(**args).numeric(constants=constants)
    out["double-lagrange"] = kd.formulate(method="lagrange", **args).numeric(
        constants=constants)
    eom, (ell, rate), constants = variable_length_pendulum()
    law, law_rate = length_law()
    out["variable"] = eom.numeric(constants=constants, specified={ell: law, rate: law_rate})
    return out


def push(t):
    """Cart force F(t), N (a module-level function: models stay picklable)."""
    return 2.0 * np.sin(3.0 * t)


SCLERONOMIC = ("chain3d", "pendulum", "cart", "double", "double-lagrange")
ALL = SCLERONOMIC + ("variable",)


def random_states(model, k, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.5, 1.5, size=(k, model.n_states))


def cholesky_rate_fd(model, t, y, h=1e-5):
    """Central difference of numpy's Cholesky factor along q' (and t)."""
    n = model.n_q
    qd = model.rhs(t, y)[:n]

    def factor(s):
        ys = y.copy()
        ys[:n] += s * qd
        return np.linalg.cholesky(model.mass_matrix(t + s, ys))

    return (factor(h) - factor(-h)) / (2 * h)


# ------------------------------------------------------------------- (a)
@pytest.mark.parametrize("name", ALL)
def test_mass_matrix_is_identity_along_the_motion(models, name):
    model = models[name]
    ortho = kd.orthogonalize_speeds(model)
    for k, y in enumerate(random_states(model, 5, seed=1)):
        t = 0.1 * k
        ys = ortho.from_original(y, t)
        mm = ortho.mass_matrices(t, ys)
        assert np.allclose(mm.original, model.mass_matrix(t, y), rtol=1e-14, atol=0)
        assert mm.identity_error < 1e-12
        assert np.max(np.abs(ortho.mass_matrix(t, ys) - np.eye(model.n_u))) < 1e-12
        # the original mass matrix itself is not the identity (the check can fail)
        assert np.max(np.abs(mm.original - np.eye(model.n_u))) > 1e-2


@pytest.mark.parametrize("name", ["chain3d", "cart", "double"])
def test_constant_factor_is_identity_at_the_reference_only(models, name):
    model = models[name]
    y_ref, y_other = random_states(model, 2, seed=2)
    ortho = kd.orthogonalize_speeds(model, at=y_ref)
    assert not ortho.along_motion
    assert ortho.mass_matrices(0.0, ortho.from_original(y_ref)).identity_error < 1e-12
    assert ortho.mass_matrices(0.0, ortho.from_original(y_other)).identity_error > 1e-3
    # the reference may be given by name, coordinates only
    by_name = kd.orthogonalize_speeds(
        model, at={model.state_names[i]: y_ref[i] for i in range(model.n_q)})
    assert np.array_equal(by_name.reference_factor, ortho.reference_factor)


def test_diagonal_form_of_the_simple_pendulum(models):
    ortho = kd.orthogonalize_speeds(models["pendulum"])
    mm = ortho.mass_matrices(0.0, [0.4, 2.0])
    assert mm.original.shape == (1, 1) and mm.orthogonalized.shape == (1, 1)
    assert mm.original[0, 0] == pytest.approx(2.0 * 1.5 ** 2)  # m l^2
    assert mm.orthogonalized[0, 0] == pytest.approx(1.0, abs=1e-15)
    with pytest.raises(ValueError):
        mm.factor[0, 0] = 2.0  # frozen


# ------------------------------------------------------------------- (b)
@pytest.mark.parametrize("name", ["chain3d", "cart", "double", "pendulum", "variable"])
@pytest.mark.parametrize("at", ["motion", "reference"])
def test_simulation_in_new_speeds_agrees(models, name, at):
    model = models[name]
    y0 = random_states(model, 1, seed=3)[0]
    ortho = kd.orthogonalize_speeds(model, at=None if at == "motion" else y0, t=0.0)
    t_eval = np.linspace(0.0, 2.0, 41)
    options = dict(rtol=1e-10, atol=1e-10, t_eval=t_eval)
    ref = kd.simulate(model, (0.0, 2.0), y0, **options)
    res = kd.simulate(ortho, (0.0, 2.0), ortho.from_original(y0, 0.0), **options)
    assert ref.success and res.success
    assert res.state_names[model.n_q:] == tuple(
        f"{s}_star" for s in model.state_names[model.n_q:])
    back = ortho.to_original(res.y, res.t)
    scale = 1.0 + np.max(np.abs(ref.y))
    assert np.max(np.abs(back - ref.y)) < 1e-7 * scale
    # the energies are those of the original model at the mapped states
    assert np.allclose(res.kinetic_energy, ref.kinetic_energy, rtol=1e-7, atol=1e-9)


def test_constraint_forces_pass_through():
    model = kd.models.build("pendulum", tension=True).numeric()
    ortho = kd.orthogonalize_speeds(model)
    res = kd.simulate(ortho, (0.0, 1.0), ortho.from_original([1.0, 0.5]), rtol=1e-10,
                      atol=1e-10, constraint_forces=True)
    q, u = ortho.to_original(res.y)
    exact = 1.0 * (9.81 * np.cos(q) + 1.0 * u ** 2)  # m (g cos q + l u^2)
    assert np.allclose(res["T"], exact, rtol=1e-9, atol=1e-9)


# ------------------------------------------------------------------- (c)
@pytest.mark.parametrize("name", ALL)
def test_factor_rate_matches_finite_differences(models, name):
    model = models[name]
    ortho = kd.orthogonalize_speeds(model)
    for k, y in enumerate(random_states(model, 3, seed=4)):
        t = 0.3 * k
        L, L_dot = ortho.cholesky_factor(t, ortho.from_original(y, t))
        assert np.allclose(L, np.linalg.cholesky(model.mass_matrix(t, y)), rtol=1e-14,
                           atol=1e-15)
        fd = cholesky_rate_fd(model, t, y)
        # relative to the rate (to 1e-3 L per second for the pendulum's
        # constant factor, whose difference quotient is round-off, ~1e-11)
        scale = max(np.max(np.abs(fd)), 1e-3 * np.max(np.abs(L)))
        assert np.max(np.abs(L_dot - fd)) < 1e-6 * scale
        assert np.max(np.abs(fd)) > 1e-3 or name == "pendulum"


@pytest.mark.parametrize("name", ["chain3d", "cart", "variable"])
def test_new_accelerations_are_rates_of_the_new_speeds(models, name):
    """u*' from rhs is d/dt (L^T u) along the original motion (central difference)."""
    model = models[name]
    ortho = kd.orthogonalize_speeds(model)
    h = 1e-6
    for y in random_states(model, 3, seed=5):
        t = 0.2
        yd = model.rhs(t, y)
        fd = (ortho.from_original(y + h * yd, t + h)
              - ortho.from_original(y - h * yd, t - h)) / (2 * h)
        exact = ortho.rhs(t, ortho.from_original(y, t))
        assert np.allclose(exact, fd, rtol=1e-6, atol=1e-6 * np.max(np.abs(fd)))


# ------------------------------------------------------------------- (d)
@pytest.mark.parametrize("name", SCLERONOMIC)
def test_kinetic_energy_is_half_the_square_of_the_new_speeds(models, name):
    model = models[name]
    ortho = kd.orthogonalize_speeds(model)
    for y in random_states(model, 4, seed=6):
        ys = ortho.from_original(y)
        ke = model.kinetic_energy(0.0, y)
        assert 0.5 * ys[model.n_q:] @ ys[model.n_q:] == pytest.approx(ke, rel=1e-12)
        assert ortho.kinetic_energy(0.0, ys) == pytest.approx(ke, rel=1e-12)


def test_kinetic_energy_with_a_constant_factor(models):
    model = models["chain3d"]
    y_ref, y_other = random_states(model, 2, seed=7)
    ortho = kd.orthogonalize_speeds(model, at=y_ref)
    for y, equal in ((y_ref, True), (y_other, False)):
        ys = ortho.from_original(y)
        half_square = 0.5 * ys[model.n_q:] @ ys[model.n_q:]
        ke = model.kinetic_energy(0.0, y)
        assert (abs(half_square - ke) < 1e-12 * ke) == equal


# -------------------------------------------------------------- round trip
def test_state_maps_round_trip_and_pickle(models):
    model = models["cart"]
    ortho = kd.orthogonalize_speeds(model)
    Y = random_states(model, 4, seed=8).T
    assert np.allclose(ortho.to_original(ortho.from_original(Y)), Y, rtol=1e-13, atol=1e-13)
    y = ortho.from_original(Y[:, 0])
    clone = pickle.loads(pickle.dumps(ortho))
    assert np.array_equal(clone.rhs(0.3, y), ortho.rhs(0.3, y))
    heavier = ortho.with_constants({"m": 1.0})
    assert heavier.constants["m"] == 1.0
    assert heavier.mass_matrices(0.0, y).identity_error < 1e-12


# ------------------------------------------------------------------- (e)
def test_dependent_speeds_are_orthogonalized_on_the_constraints(circle_particle):
    """Particle on a circle, q2 and u2 dependent: M_r = m L^2 / q2^2, so the
    new speed is v* = sqrt(m) L u1 / |q2| (tests/test_orthogonal_speeds_constrained.py
    holds the rolling disk, the sleigh and the four-bar)."""
    eom, (q1, q2, u1, u2, m, g, L) = circle_particle
    model = eom.numeric(constants={m: 2.0, g: 9.81, L: 1.5})
    ortho = kd.orthogonalize_speeds(model)
    assert ortho.state_names == ("q1", "q2", "u1_star")
    y = model.state({"q1": 0.6, "q2": -1.0, "u1": 0.8})
    ys = ortho.from_original(y)
    assert ys[2] == pytest.approx(np.sqrt(2.0) * 1.5 * 0.8 / abs(y[1]), rel=1e-13)
    assert ortho.mass_matrices(0.0, ys).reduced[0, 0] == pytest.approx(
        2.0 * 1.5 ** 2 / y[1] ** 2, rel=1e-13)


def test_bad_reference_states(models):
    model = models["double"]
    with pytest.raises(ValueError, match=r"at must have 4 entries \(q1, q2, u1, u2\)"):
        kd.orthogonalize_speeds(model, at=[0.1, 0.2, 0.3])
    with pytest.raises(kd.MissingValueError, match="q2"):
        kd.orthogonalize_speeds(model, at={"q1": 0.1})
    with pytest.raises(KeyError, match="q9"):
        kd.orthogonalize_speeds(model, at={"q1": 0.1, "q9": 0.0})
    with pytest.raises(ValueError, match="not finite for q1"):
        kd.orthogonalize_speeds(model, at=[np.nan, 0.0])
    ortho = kd.orthogonalize_speeds(model)
    with pytest.raises(ValueError, match=r"u1_star, u2_star\), got shape \(3,\)"):
        ortho.rhs(0.0, [0.0, 0.0, 1.0])
    with pytest.raises(kd.MissingValueError, match="u2_star"):
        kd.simulate(ortho, (0.0, 1.0), {"q1": 0.1, "q2": 0.0, "u1_star": 0.0})


def test_mass_matrix_with_an_input_known_only_numerically():
    eom, (ell, rate), constants = variable_length_pendulum()
    numbers = {ell: 1.0, ell.diff(t_sym): 0.0, rate: 0.0, rate.diff(t_sym): 0.0}
    model = eom.numeric(constants=constants, specified=numbers)
    with pytest.raises(kd.ModelError, match=r"depends on l\(t\)"):
        kd.orthogonalize_speeds(model)
    law, law_rate = length_law(1.0)
    exact = eom.numeric(constants=constants, specified={ell: law, rate: law_rate})
    with pytest.raises(ValueError, match="give the time t of the reference state"):
        kd.orthogonalize_speeds(exact, at=[0.1, 0.0])
    ortho = kd.orthogonalize_speeds(exact)
    with pytest.raises(ValueError, match="give the time"):
        ortho.to_original([0.1, 1.0])


def test_unpickled_model_is_refused(models):
    clone = pickle.loads(pickle.dumps(models["pendulum"]))
    with pytest.raises(kd.ModelError, match="eom.numeric"):
        kd.orthogonalize_speeds(clone)


# ------------------------------------------------------------------- docs
@pytest.mark.parametrize("heading,agreement", [
    ("## Orthogonalized generalized speeds", 1e-7),
    ("### Constrained systems", 1e-10),  # the rolling disk, DOP853 at 1e-12
])
def test_docs_example_runs(heading, agreement):
    """The first example under ``heading`` in docs/formulations.md runs and agrees."""
    text = (ROOT / "docs" / "formulations.md").read_text()
    section = text.split(heading, 1)[1].split("\n## ", 1)[0]
    block = re.findall(r"```python\n(.*?)```", section, re.S)[0]
    namespace = {}
    exec(compile(block, "docs/formulations.md", "exec"), namespace)
    assert namespace["identity_error"] < 1e-12
    assert namespace["agreement"] < agreement
