"""Bad input gets a clear error that names the symbol, point or frame at fault."""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd


def particle_on_line():
    q, u = me.dynamicsymbols("q u")
    m = sm.symbols("m")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x)
    return q, u, m, N, O, P


def test_velocity_of_point_cannot_be_found():
    q, u, m, N, O, P = particle_on_line()
    lost = me.Point("Lost")  # neither a velocity nor a position chain
    with pytest.raises(kd.KinematicsError, match="Lost"):
        kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                bodies=[me.Particle("p", P, m), me.Particle("lost", lost, m)])


def test_missing_origin_velocity_names_the_origin():
    """The velocity of O is never set: the error names O, where the chain of
    positions starts, not P, the point whose velocity was asked for."""
    q, u = me.dynamicsymbols("q u")
    m = sm.symbols("m")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q, N.z])
    A.set_ang_vel(N, u * N.z)
    O = me.Point("O")  # no O.set_vel(N, 0)
    J = O.locatenew("J", A.x)
    P = J.locatenew("P", A.y)
    O.locatenew("C", N.y)  # a branch of the chain
    with pytest.raises(kd.KinematicsError, match=r"^the velocity of point P in N cannot be "
                       r"found: no point of its chain of positions \(set_pos/locatenew: P, J, "
                       r"O, C\) has a velocity in N; set the velocity of the one fixed in N, "
                       r"likely the chain's origin O: O.set_vel\(N, 0\)$"):
        kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                bodies=[me.Particle("bob", P, m)])


def test_frame_not_oriented():
    q, u, m, N, O, P = particle_on_line()
    loose = me.ReferenceFrame("Loose")
    body = me.RigidBody("b", P, loose, m, (me.inertia(loose, 1, 1, 1), P))
    with pytest.raises(kd.KinematicsError, match="Loose"):
        kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u], bodies=[body])


def test_kinematic_equations_nonlinear_in_qdot():
    q, u, m, N, O, P = particle_on_line()
    with pytest.raises(kd.ModelError, match="nonlinear"):
        kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() ** 2 - u],
                bodies=[me.Particle("p", P, m)])


def test_kinematic_equations_singular():
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    m = sm.symbols("m")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q1 * N.x + q2 * N.y)
    with pytest.raises(kd.ModelError, match="cannot be solved for q'"):
        kd.kane(frame=N, q_ind=[q1, q2], u_ind=[u1, u2],
                kd_eqs=[q1.diff() + q2.diff() - u1, 2 * q1.diff() + 2 * q2.diff() - u2],
                bodies=[me.Particle("p", P, m)])


def test_speed_missing():
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    m = sm.symbols("m")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q1 * N.x + q2 * N.y)
    with pytest.raises(kd.ModelError, match="u2"):
        kd.kane(frame=N, q_ind=[q1, q2], u_ind=[u1],
                kd_eqs=[q1.diff() - u1, q2.diff() - u2], bodies=[me.Particle("p", P, m)])


def test_speed_given_twice():
    q, u, m, N, O, P = particle_on_line()
    with pytest.raises(kd.ModelError, match="u is given twice"):
        kd.kane(frame=N, q_ind=[q], u_ind=[u], u_dep=[u], kd_eqs=[q.diff() - u],
                velocity_constraints=[u], bodies=[me.Particle("p", P, m)])
    with pytest.raises(kd.ModelError, match="given twice"):
        kd.kane(frame=N, q_ind=[q, q], u_ind=[u], kd_eqs=[q.diff() - u],
                bodies=[me.Particle("p", P, m)])


def test_dependent_speeds_and_constraints_must_match():
    d = kd.models.build("rolling-disk")
    args = dict(d.kane_args)
    args["velocity_constraints"] = args["velocity_constraints"][:1]
    with pytest.raises(kd.ModelError, match="2 dependent speeds .* 1 velocity"):
        kd.kane(**args)


def test_missing_coordinate_equation():
    q1, q2, u1 = me.dynamicsymbols("q1 q2 u1")
    m = sm.symbols("m")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q1 * N.x)
    with pytest.raises(kd.ModelError, match="2 generalized coordinates but 1"):
        kd.kane(frame=N, q_ind=[q1, q2], u_ind=[u1], kd_eqs=[q1.diff() - u1],
                bodies=[me.Particle("p", P, m)])


def test_singular_constraint_jacobian_at_initial_state(circle_particle):
    eom, (q1, q2, u1, u2, m, g, L) = circle_particle
    model = eom.numeric(constants={m: 1, g: 9.81, L: 1})
    # q1 = L puts the particle where q2 = 0: d(constraint)/d(q2) = 2 q2 = 0
    with pytest.raises(kd.ConstraintError, match="dependent coordinates q2"):
        kd.simulate(model, (0, 1), {q1: 1.0, q2: 0.0, u1: 0.0})
    with pytest.raises(kd.ConstraintError, match="dependent coordinates q2"):
        model.consistent_state(0.0, [1.0, 1e-30, 0.0, 0.0])


def test_missing_constants_are_named(circle_particle):
    eom, (q1, q2, u1, u2, m, g, L) = circle_particle
    with pytest.raises(kd.MissingValueError, match="L.*g|g.*L"):
        eom.numeric(constants={m: 1.0})


def test_unknown_constant_is_rejected(circle_particle):
    eom, (q1, q2, u1, u2, m, g, L) = circle_particle
    with pytest.raises(kd.ModelError, match="mass"):
        eom.numeric(constants={m: 1.0, g: 9.81, L: 1.0, "mass": 2.0})


def test_missing_initial_values_are_named(circle_particle):
    eom, (q1, q2, u1, u2, m, g, L) = circle_particle
    model = eom.numeric(constants={m: 1, g: 9.81, L: 1})
    with pytest.raises(kd.MissingValueError, match="u1"):
        kd.simulate(model, (0, 1), {q1: 0.5, q2: -0.8})
    with pytest.raises(ValueError, match="4 entries"):
        kd.simulate(model, (0, 1), [0.5, -0.8])


def test_missing_specified_input_is_named():
    d = kd.models.build("n-link-pendulum-on-cart", n=1)
    eom = d.derive()
    with pytest.raises(kd.MissingValueError, match="F"):
        eom.numeric(constants=d.constants)


def test_auxiliary_unknowns_must_match():
    """More force symbols than auxiliary equations is an error, not a guess."""
    d = kd.models.build("pendulum", tension=True)
    eom = d.derive()
    model = eom.numeric(constants=d.constants)
    assert model.aux_names == ("T",)


def test_inconsistent_y_shape_for_rhs_helpers(circle_particle):
    eom, (q1, q2, u1, u2, m, g, L) = circle_particle
    model = eom.numeric(constants={m: 1, g: 9.81, L: 1})
    with pytest.raises(ValueError, match="4 entries"):
        model.consistent_state(0.0, np.zeros(3))
