"""Orthogonalized speeds of constrained systems: v* = L^T u_i, L L^T = C^T M C.

Independent checks: the mass matrix in v* against the identity, simulations in
v* mapped back against kd.simulate of Kane's equations (the model's own
elimination of the dependent speeds), the multipliers against the model's
(Kane's accelerations) and the sleigh's closed-form lateral force, the rate
of the factor against finite differences of numpy's Cholesky factor, the
kinetic energy against |v*|^2/2.
"""

import pickle

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

#: rolling disk, Chaplygin sleigh with its lateral speed dependent, a particle
#: with z' = y x' (nonholonomic), four-bar (holonomic closed loop), snake robot
#: on wheels (nonholonomic, driven by joint torques in time)
NAMES = ("rolling-disk", "knife-edge", "nonholonomic-particle", "four-bar", "snake")
#: models whose reduced metric C^T M C changes along the motion
VARYING = ("nonholonomic-particle", "four-bar", "snake")


@pytest.fixture(scope="module")
def built():
    """name -> (definition, NumericModel, consistent initial state)."""
    out = {}
    for name in NAMES:
        definition = kd.models.build(name)
        model = definition.numeric()
        out[name] = definition, model, model.state(definition.initial(model))
    return out


def consistent_states(model, y0, k, seed):
    """``k`` consistent states near ``y0`` (coordinates +-0.3, speeds +-1.5 about it)."""
    rng = np.random.default_rng(seed)
    n, n_i, p = model.n_q, model.n_q_ind, model.n_u_ind
    out = []
    for _ in range(k):
        y = y0.copy()
        y[:n_i] += rng.uniform(-0.3, 0.3, n_i)
        y[n:n + p] += rng.uniform(-1.5, 1.5, p)
        out.append(model.consistent_state(0.0, y))
    return out


def test_state_layout(built):
    _, model, _ = built["rolling-disk"]
    ortho = kd.orthogonalize_speeds(model)
    assert ortho.state_names == ("q1", "q2", "q3", "q4", "q5", "u1_star", "u2_star",
                                 "u3_star")
    assert (ortho.n_q, ortho.n_u, ortho.n_q_dep, ortho.n_u_dep) == (5, 3, 0, 0)
    _, four_bar, _ = built["four-bar"]
    ortho = kd.orthogonalize_speeds(four_bar)
    assert ortho.state_names == ("q1", "q2", "q3", "u1_star")
    assert (ortho.n_q, ortho.n_u, ortho.n_q_dep) == (3, 1, 2)


@pytest.mark.parametrize("name", NAMES)
def test_mass_matrix_is_identity_on_the_admissible_subspace(built, name):
    _, model, y0 = built[name]
    ortho = kd.orthogonalize_speeds(model)
    farthest = 0.0
    for y in consistent_states(model, y0, 5, seed=1):
        ys = ortho.from_original(y)
        assert np.allclose(ortho.to_original(ys), y, rtol=1e-12, atol=1e-12)
        mm = ortho.mass_matrices(0.0, ys)
        C = ortho.admissible_basis(0.0, ys)
        _, M, _, B, _, _ = model._dynamics(0.0, y)
        assert np.allclose(mm.original, M, rtol=1e-14, atol=0)
        assert np.max(np.abs(B @ C)) < 1e-12 * np.max(np.abs(B))
        assert np.allclose(mm.reduced, C.T @ M @ C, rtol=1e-13, atol=1e-14)
        assert mm.identity_error < 1e-12
        farthest = max(farthest, np.max(np.abs(mm.reduced - np.eye(ortho.n_u))))
    assert farthest > 1e-2  # the reduced mass matrix is not the identity itself


@pytest.mark.parametrize("name", NAMES)
def test_kinetic_energy_is_half_the_square_of_the_new_speeds(built, name):
    _, model, y0 = built[name]
    ortho = kd.orthogonalize_speeds(model)
    for y in consistent_states(model, y0, 3, seed=2):
        ys = ortho.from_original(y)
        ke = model.kinetic_energy(0.0, y)
        assert 0.5 * ys[model.n_q:] @ ys[model.n_q:] == pytest.approx(ke, rel=1e-12)


@pytest.mark.parametrize("name,t_end", [("rolling-disk", 3.0), ("knife-edge", 5.0),
                                        ("nonholonomic-particle", 3.0), ("four-bar", 2.0),
                                        ("snake", 2.0)])
def test_same_motion_as_kane(built, name, t_end):
    """DOP853 at rtol = atol = 1e-12: the runs agree to 1e-10 (measured 1e-11)."""
    _, model, y0 = built[name]
    ortho = kd.orthogonalize_speeds(model)
    t_eval = np.linspace(0.0, t_end, 31)
    options = dict(method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t_eval)
    ref = kd.simulate(model, (0.0, t_end), y0, **options)
    res = kd.simulate(ortho, (0.0, t_end), ortho.from_original(y0), **options)
    assert ref.success and res.success
    back = ortho.to_original(res.y, res.t)
    assert np.max(np.abs(back - ref.y)) < 1e-10
    # the motion is not trivial: the speeds change by more than the tolerance
    assert np.max(np.ptp(ref.y[model.n_q:], axis=1)) > 0.1
    for k in range(0, t_eval.size, 10):
        assert ortho.mass_matrices(res.t[k], res.y[:, k]).identity_error < 1e-12
    assert np.max(np.abs(res.constraint_residuals), initial=0.0) < 1e-9


@pytest.mark.parametrize("name", NAMES)
def test_constraint_forces_lie_in_the_orthogonal_complement(built, name):
    _, model, y0 = built[name]
    ortho = kd.orthogonalize_speeds(model)
    for y in consistent_states(model, y0, 3, seed=3):
        ys = ortho.from_original(y)
        g = ortho.generalized_constraint_forces(0.0, ys)
        C = ortho.admissible_basis(0.0, ys)
        assert np.max(np.abs(C.T @ g)) < 1e-12 * (1.0 + np.max(np.abs(g)))
        assert np.max(np.abs(g)) > 1e-3  # the constraints do carry forces
        lam = ortho.multipliers(0.0, ys)
        ref = model.multipliers(0.0, y)  # Kane's accelerations
        assert lam.keys() == ref.keys()
        scale = max(abs(v) for v in ref.values())
        assert all(abs(lam[k] - ref[k]) < 1e-12 * scale for k in ref)
        _, _, _, B, _, _ = model._dynamics(0.0, y)
        assert np.allclose(B.T @ np.array(list(lam.values())), g, rtol=1e-10, atol=1e-12)


def test_sleigh_lateral_force_closed_form(built):
    """F_lat = m u w I_C / J along a run in the new speeds."""
    definition, model, y0 = built["knife-edge"]
    ortho = kd.orthogonalize_speeds(model)
    res = kd.simulate(ortho, (0.0, 3.0), ortho.from_original(y0), rtol=1e-11, atol=1e-11,
                      t_eval=np.linspace(0.0, 3.0, 7), constraint_forces=True)
    c = {str(k): v for k, v in definition.constants.items()}
    J = c["I_C"] + c["m"] * c["a"] ** 2
    y = ortho.to_original(res.y)
    u, w = y[model.index("u")], y[model.index("w")]
    exact = c["m"] * u * w * c["I_C"] / J
    assert np.max(np.abs(exact)) > 1e-3
    assert np.allclose(res["F_lat"], exact, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", VARYING)
def test_factor_rate_matches_finite_differences(built, name):
    _, model, y0 = built[name]
    ortho = kd.orthogonalize_speeds(model)
    h = 1e-5
    for y in consistent_states(model, y0, 2, seed=4):
        ys = ortho.from_original(y)
        L, L_dot = ortho.cholesky_factor(0.0, ys)
        qd = ortho.rhs(0.0, ys)[:model.n_q]

        def factor(s):
            yq = ys.copy()
            yq[:model.n_q] += s * qd
            return np.linalg.cholesky(ortho.mass_matrices(s, yq).reduced)

        fd = (factor(h) - factor(-h)) / (2 * h)
        assert np.max(np.abs(fd)) > 1e-3
        assert np.max(np.abs(L_dot - fd)) < 1e-6 * np.max(np.abs(fd))


def test_constant_metric_of_body_fixed_speeds(built):
    """With their body-fixed speeds the disk's and the sleigh's reduced metrics are
    constant and diagonal, diag(5/4, 3/2, 1/4) m r^2 and diag(m, I_C + m a^2),
    though C and (for the disk) M change with the configuration: the factor's
    rate vanishes."""
    for name in ("rolling-disk", "knife-edge"):
        definition, model, y0 = built[name]
        c = {str(k): v for k, v in definition.constants.items()}
        if name == "rolling-disk":
            exact = np.diag([1.25, 1.5, 0.25]) * c["m"] * c["r"] ** 2
        else:
            exact = np.diag([c["m"], c["I_C"] + c["m"] * c["a"] ** 2])
        ortho = kd.orthogonalize_speeds(model)
        for y in consistent_states(model, y0, 3, seed=6):
            ys = ortho.from_original(y)
            assert np.allclose(ortho.mass_matrices(0.0, ys).reduced, exact, rtol=1e-13,
                               atol=1e-15)
            L, L_dot = ortho.cholesky_factor(0.0, ys)
            assert np.allclose(L, np.sqrt(exact), rtol=1e-13, atol=1e-15)
            assert np.max(np.abs(L_dot)) < 1e-12


@pytest.mark.parametrize("name", ["nonholonomic-particle", "four-bar"])
def test_constant_factor(built, name):
    _, model, y0 = built[name]
    y_ref, y_other = consistent_states(model, y0, 2, seed=5)
    ortho = kd.orthogonalize_speeds(model, at=y_ref)
    assert ortho.mass_matrices(0.0, ortho.from_original(y_ref)).identity_error < 1e-12
    assert ortho.mass_matrices(0.0, ortho.from_original(y_other)).identity_error > 1e-3
    options = dict(method="DOP853", rtol=1e-12, atol=1e-12, t_eval=np.linspace(0, 1, 11))
    ref = kd.simulate(model, (0.0, 1.0), y_other, **options)
    res = kd.simulate(ortho, (0.0, 1.0), ortho.from_original(y_other), **options)
    assert np.max(np.abs(ortho.to_original(res.y) - ref.y)) < 1e-10


def test_four_bar_projection_keeps_the_independent_state(built):
    _, model, y0 = built["four-bar"]
    ortho = kd.orthogonalize_speeds(model)
    ys = ortho.from_original(y0)
    drifted = ys.copy()
    drifted[1:3] += [1e-4, -2e-4]  # q2, q3 off the loop
    assert np.max(np.abs(ortho.constraint_residuals(0.0, drifted))) > 1e-5
    back = ortho.consistent_state(0.0, drifted)
    assert np.max(np.abs(ortho.constraint_residuals(0.0, back))) < 1e-12
    assert back[0] == drifted[0]  # q1 kept
    u1 = ortho.to_original(back)[model.index("u1")]
    assert u1 == pytest.approx(ortho.to_original(drifted)[model.index("u1")], rel=1e-12)
    assert np.allclose(back[1:3], ys[1:3], atol=1e-10)


def test_pickle_and_other_constants(built):
    _, model, y0 = built["rolling-disk"]
    ortho = kd.orthogonalize_speeds(model)
    ys = ortho.from_original(y0)
    clone = pickle.loads(pickle.dumps(ortho))
    assert np.array_equal(clone.rhs(0.2, ys), ortho.rhs(0.2, ys))
    heavier = ortho.with_constants({"m": 5.0})
    assert type(heavier) is type(ortho)
    assert heavier.mass_matrices(0.0, ys).identity_error < 1e-12


def test_inconsistent_state_is_refused(built):
    _, model, y0 = built["rolling-disk"]
    ortho = kd.orthogonalize_speeds(model)
    bad = y0.copy()
    bad[-1] += 0.1  # u5 no longer the one rolling demands
    with pytest.raises(ValueError, match="does not satisfy the constraints"):
        ortho.from_original(bad)
    with pytest.raises(ValueError, match=r"must have 10 entries \(q1"):
        ortho.from_original(y0[:8])
    with pytest.raises(ValueError, match="udot cannot be given"):
        ortho.multipliers(0.0, ortho.from_original(y0), udot=np.zeros(5))


def test_speed_dependent_constraint_matrix_is_refused():
    """z' = y x' written with a speed-dependent coefficient: its rate is not exact."""
    x, y, ux, uy = me.dynamicsymbols("x y u_x u_y")
    m = sm.symbols("m", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, ux * N.x + uy * N.y)
    eom = kd.kane(frame=N, q_ind=[x, y], u_ind=[ux], u_dep=[uy],
                  kd_eqs=[x.diff() - ux, y.diff() - uy],
                  velocity_constraints=[uy - ux ** 2], bodies=[me.Particle("p", P, m)])
    model = eom.numeric(constants={m: 1.0})
    with pytest.raises(kd.ModelError, match=r"velocity-constraint matrix \(of u_y\) "
                                            r"depends on u_x"):
        kd.orthogonalize_speeds(model)



def test_multiplier_form_is_refused(built):
    """Lagrange-d'Alembert on the sleigh keeps every rate a state (no partition)."""
    definition, _, _ = built["knife-edge"]
    model = definition.numeric(definition.derive(method="lagrange"))
    assert model.multiplier_form
    with pytest.raises(kd.ModelError, match="multiplier form"):
        kd.orthogonalize_speeds(model)
