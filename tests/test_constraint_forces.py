"""Identified constraint forces: multipliers, nonlinear constraints, Newton-Euler check."""

import pickle

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

TOL = dict(rtol=1e-10, atol=1e-12)


def _block_on_ground():
    """A particle resting on the ground, held by PointVelocity(P, N.z)."""
    x, z, ux, uz = me.dynamicsymbols("x z u_x u_z")
    m, g = sm.symbols("m g")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + z * N.z)
    P.set_vel(N, ux * N.x + uz * N.z)
    eom = kd.kane(frame=N, q_ind=[x], q_dep=[z], u_ind=[ux], u_dep=[uz],
                  kd_eqs=[x.diff() - ux, z.diff() - uz], configuration_constraints=[z],
                  bodies=[me.Particle("block", P, m)], loads=[(P, -m * g * N.z)],
                  constraints=[kd.PointVelocity(P, N.z, names="N")])
    return eom, (m, g)


def test_multiplier_is_the_force_along_the_direction():
    eom, (m, g) = _block_on_ground()
    model = eom.numeric({m: 2.0, g: 9.81})
    y = model.state({"x": 0.3, "u_x": 1.5})
    assert model.multipliers(0.0, y)["N"] == pytest.approx(2.0 * 9.81, rel=1e-14)
    assert model.constraint_forces(0.0, y) == {"N": pytest.approx(19.62, rel=1e-14)}
    assert eom.multiplier_names == ("N",)
    (kind, point, vector, body), = eom.identified_forces["N"]
    assert (kind, point.name, body) == ("force", "P", None)
    assert vector == eom.frame.z


def _orthogonal_pair():
    x1, y1, x2, y2 = me.dynamicsymbols("x1 y1 x2 y2")
    a1, b1, a2, b2 = me.dynamicsymbols("a1 b1 a2 b2")
    m1, m2, k = sm.symbols("m1 m2 k")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x1 * N.x + y1 * N.y)
    P.set_vel(N, a1 * N.x + b1 * N.y)
    Q = O.locatenew("Q", x2 * N.x + y2 * N.y)
    Q.set_vel(N, a2 * N.x + b2 * N.y)
    eom = kd.kane(frame=N, q_ind=[x1, y1, x2, y2], u_ind=[a1, b1, a2], u_dep=[b2],
                  kd_eqs=[x1.diff() - a1, y1.diff() - b1, x2.diff() - a2, y2.diff() - b2],
                  bodies=[me.Particle("p", P, m1), me.Particle("q", Q, m2)],
                  loads=[(P, -k * (x1 * N.x + y1 * N.y)), (Q, -k * (x2 * N.x + y2 * N.y))],
                  potential_energy=k * (x1**2 + y1**2 + x2**2 + y2**2) / 2,
                  constraints=[kd.OrthogonalVelocities(P, Q)])
    return eom, {m1: 1.0, m2: 2.0, k: 3.0}, (a1, b1, a2, b2, N)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_nonlinear_constraint_orthogonal_velocities(backend):
    eom, constants, (a1, b1, a2, b2, N) = _orthogonal_pair()
    # identified forces: lambda v_Q at P and lambda v_P at Q
    forces = eom.identified_forces["F_P_Q"]
    assert [(f[0], f[1].name) for f in forces] == [("force", "P"), ("force", "Q")]
    assert forces[0][2] == a2 * N.x + b2 * N.y and forces[1][2] == a1 * N.x + b1 * N.y
    model = eom.numeric(constants, backend=backend)
    # the dependent speed from the nonlinear constraint by Newton's method
    y0 = model.state({"x1": 1, "y1": 0, "x2": 0, "y2": 1, "a1": 0.3, "b1": 1.0,
                      "a2": 1.0, "b2": 5.0})
    assert y0[-1] == pytest.approx(-0.3, abs=1e-14)
    res = kd.simulate(model, (0, 5), y0, **TOL)
    assert res.success
    # the forces do no work: v_P . v_Q = 0 makes lambda (v_Q . v_P + v_P . v_Q) vanish
    assert np.ptp(res.energy) < 1e-8
    assert np.max(np.abs(res.constraint_residuals)) < 1e-8
    if backend == "numpy":
        check = kd.check_newton_euler(res)
        assert check.source == "equations"
        assert check.max < 1e-10 * check.inertia_scale


def test_sphere_on_turntable_closed_form():
    definition = kd.models.build("sphere-turntable")
    model = definition.numeric()
    res = kd.simulate(model, (0, definition.t_end), model.state(definition.initial(model)),
                      constraint_forces=True, **TOL)
    assert res.success
    vx, vy = res["v_x"], res["v_y"]
    angle = np.unwrap(np.arctan2(vy, vx))
    omega = definition.constants[definition.symbols["Omega"]]
    # the centre's velocity turns uniformly at 2 Omega / 7
    np.testing.assert_allclose(angle - angle[0], 2 * omega / 7 * res.t, atol=1e-9)
    np.testing.assert_allclose(np.hypot(vx, vy), np.hypot(vx[0], vy[0]), rtol=1e-9)
    np.testing.assert_allclose(res["F_n"], 9.81, rtol=1e-10)
    check = kd.check_newton_euler(res)
    assert check.max < 1e-12
    fit = kd.check_newton_euler(res, multipliers="fit")
    for name in ("F_x", "F_y", "F_n"):
        np.testing.assert_allclose(fit.multipliers[name], res[name], atol=1e-10)


def test_nonholonomic_particle_newton_euler():
    definition = kd.models.build("nonholonomic-particle")
    model = definition.numeric()
    res = kd.simulate(model, (0, 3), model.state(definition.initial(model)), **TOL)
    check = kd.check_newton_euler(res)
    assert check.max < 1e-12
    assert check.unidentified == ()
    assert np.ptp(res.energy) < 1e-8


def test_forces_of_scalar_constraints_are_named_in_the_check():
    """The four-bar's loop is closed by scalar equations: their forces are in the
    residuals, and the check and the comparison say so instead of showing a bare
    residual of the size of the forces."""
    from kanedyn.analysis import compare_formulations
    definition = kd.models.build("four-bar")
    model = definition.numeric()
    y = model.state(definition.initial(model))
    check = kd.check_newton_euler(model, 0.0, y)
    assert check.unidentified == ("lambda_0", "lambda_1")
    assert check.max > 1e-2 * check.inertia_scale
    assert "forces of lambda_0, lambda_1" in check.table()
    table = compare_formulations("four-bar", methods=("kane", "lagrange"), t_end=0.1).table()
    assert "N-E residuals hold the forces of lambda_0, lambda_1" in table


def test_unidentified_forces_show_in_the_residual():
    """A pendulum in minimal coordinates: the rod tension is not identified."""
    definition = kd.models.build("pendulum")
    model = definition.numeric()
    y = np.array([0.3, 2.0])
    check = kd.check_newton_euler(model, 0.0, y)
    assert check.max > 1.0  # the missing tension, m g cos q + m l u^2, in newtons
    assert check.multipliers == {}


def test_given_multipliers_and_udot():
    eom, (m, g) = _block_on_ground()
    model = eom.numeric({m: 2.0, g: 9.81})
    y = model.state({"x": 0.0, "u_x": 1.0})
    good = kd.check_newton_euler(model, 0.0, y, multipliers={"N": 19.62})
    assert good.max < 1e-13 and good.source == "given"
    bad = kd.check_newton_euler(model, 0.0, y, multipliers={"N": 0.0})
    assert bad.max_force == pytest.approx(19.62)
    accelerating = kd.check_newton_euler(model, 0.0, y, udot=[1.0, 0.0])
    assert accelerating.max_force == pytest.approx(2.0)  # m * 1 m/s^2 unexplained
    assert "block" in accelerating.table()


def test_ambiguous_load_point_needs_loads_on():
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    m, l, g, F = sm.symbols("m l g F")
    N = me.ReferenceFrame("N")
    A, B = me.ReferenceFrame("A"), me.ReferenceFrame("B")
    A.orient_axis(N, N.z, q1)
    A.set_ang_vel(N, u1 * N.z)
    B.orient_axis(A, A.z, q2)
    B.set_ang_vel(A, u2 * A.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    J = O.locatenew("J", l * A.x)  # the joint: fixed in A and in B
    J.v2pt_theory(O, N, A)
    Ga = O.locatenew("Ga", l / 2 * A.x)
    Ga.v2pt_theory(O, N, A)
    Gb = J.locatenew("Gb", l / 2 * B.x)
    Gb.v2pt_theory(J, N, B)
    I = me.inertia(A, 0, 0, 1)
    bodies = [me.RigidBody("a", Ga, A, m, (I, Ga)),
              me.RigidBody("b", Gb, B, m, (me.inertia(B, 0, 0, 1), Gb))]
    eom = kd.kane(frame=N, q_ind=[q1, q2], u_ind=[u1, u2],
                  kd_eqs=[q1.diff() - u1, q2.diff() - u2], bodies=bodies,
                  loads=[(J, F * N.y)])
    model = eom.numeric({m: 1.0, l: 1.0, F: 1.0})
    y = np.array([0.1, 0.2, 0.3, 0.4])
    with pytest.raises(kd.ModelError, match="point J.*several bodies.*loads_on"):
        kd.check_newton_euler(model, 0.0, y)
    check = kd.check_newton_euler(model, 0.0, y, loads_on={J: bodies[1]})
    assert check.max > 0.1  # the joint forces are not identified here


def test_unpickled_model_cannot_be_checked():
    eom, (m, g) = _block_on_ground()
    model = pickle.loads(pickle.dumps(eom.numeric({m: 1.0, g: 9.81})))
    with pytest.raises(kd.ModelError, match="unpickled"):
        kd.check_newton_euler(model, 0.0, model.state({"x": 0.0, "u_x": 0.0}))


def test_vector_constraints_count_towards_dependent_speeds():
    x, z, ux, uz = me.dynamicsymbols("x z u_x u_z")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + z * N.z)
    P.set_vel(N, ux * N.x + uz * N.z)
    with pytest.raises(kd.ModelError, match="1 dependent speeds.*2 velocity constraints "
                                            r"\(0 given, 2 from vector constraints\)"):
        kd.kane(frame=N, q_ind=[x, z], u_ind=[ux], u_dep=[uz],
                kd_eqs=[x.diff() - ux, z.diff() - uz], bodies=[me.Particle("p", P, 1)],
                constraints=[kd.PointVelocity(P, [N.x, N.z])])
    with pytest.raises(kd.ModelError, match="vector constraints"):
        kd.kane(frame=N, q_ind=[x, z], u_ind=[ux], u_dep=[uz],
                kd_eqs=[x.diff() - ux, z.diff() - uz], bodies=[me.Particle("p", P, 1)],
                constraints=[uz])


@pytest.mark.parametrize("name, t_end", [("nonholonomic-particle", 2.0), ("knife-edge", 4.0),
                                         ("sphere-turntable", 1.0)])
def test_only_dalembert_formulations_pass_newton_euler(name, t_end):
    from kanedyn.analysis._compare import compare_formulations
    cmp = compare_formulations(name, t_end=t_end, n_points=41)
    for method in ("kane", "lagrange"):
        check = cmp.newton_euler[method]
        assert check.max <= 1e-10 * max(1.0, check.inertia_scale), method
    assert cmp.newton_euler["kane"].source == "equations"
    assert cmp.deviation["lagrange"] < 1e-7
    augmented = cmp.newton_euler["augmented"]
    assert augmented.source == "fit"
    assert augmented.max > 1e-3 * augmented.inertia_scale  # no identified forces explain it
    assert cmp.deviation["augmented"] > 1e-3
    assert cmp.constraint_residual["augmented"] < 1e-8  # it does keep the constraint
    assert "augmented" in cmp.table()


def test_cli_compare(capsys):
    from kanedyn.cli import main
    assert main(["compare", "nonholonomic-particle", "--t-end", "1"]) == 0
    out = capsys.readouterr().out
    assert "augmented" in out and "lagrange" in out and "N-E force" in out
    assert main(["compare", "nonholonomic-particle", "--methods", "kane,nonsense"]) == 2


def test_multipliers_in_the_multiplier_form():
    """The Lagrange knife edge has no fixed partition of its rates: its multipliers
    come from the joint solve, also at heading 0 where x' cannot be dependent."""
    from kanedyn.analysis._compare import _initial_state
    definition = kd.models.build("knife-edge")
    kane = definition.numeric(definition.derive())
    lagrange = definition.numeric(definition.derive(method="lagrange"))
    assert lagrange.multiplier_form
    y = kane.state(definition.initial(kane))
    assert y[kane.index("theta")] == 0.0
    y_l = _initial_state(lagrange, kane, y, kane.rhs(0.0, y)[:kane.n_q])
    assert lagrange.constraint_forces(0.0, y_l)["F_lat"] == pytest.approx(
        kane.constraint_forces(0.0, y)["F_lat"], rel=1e-12)
