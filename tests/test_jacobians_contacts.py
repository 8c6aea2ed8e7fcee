"""Exact derivatives within contact modes against central differences of the mode solve."""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.numerics._contact_dynamics import SlipReference, solve_modes

T0 = 0.3


def _differences(fun, x, h=1e-6):
    """Fourth-order central differences of ``fun`` (array out) at ``x``."""
    columns = []
    for j in range(x.size):
        step = np.zeros(x.size)
        step[j] = h * max(1.0, abs(x[j]))
        f = [fun(x + s * step) for s in (-2, -1, 1, 2)]
        columns.append((f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * step[j]))
    return np.array(columns).T


def _solved(model, y, modes, directions=None, r=None):
    """``[qdot, udot, contact forces]`` of the mode solve."""
    sol = solve_modes(model, T0, y, modes, directions, inputs=r)
    return np.concatenate([sol.qdot, sol.udot, sol.force.ravel()])


def _relative(a, b):
    return np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))


def _check(model, y, modes, directions=None, tol=1e-8):
    J = model.jacobians(T0, y, modes=modes, directions=directions, parameters=True)
    n, k = model.n_states, len(model.contacts)
    assert np.array_equal(J.f, _solved(model, y, modes, directions)[:n])
    D = _differences(lambda z: _solved(model, z, modes, directions), y)
    assert _relative(J.state, D[:n]) < tol
    assert _relative(J.contact_forces_state.reshape(3 * k, n), D[n:]) < tol
    p = np.array(list(model.constants.values()), dtype=float)
    P = _differences(lambda v: _solved(model.with_constants(dict(zip(model.constants, v))),
                                       y, modes, directions), p)
    assert _relative(J.parameters, P[:n]) < tol
    assert _relative(J.contact_forces_parameters.reshape(3 * k, -1), P[n:]) < tol
    return J


CASES = [("block-on-incline", ("slip",)), ("block-on-incline", ("stick",)),
         ("sphere-slug", ("slip",)), ("slug-ellipsoid", ("slip",)),
         ("bead-in-tube", ("slip", "slip")), ("bead-in-tube", ("slip", "separated")),
         ("ladder", ("slip", "slip", "separated")), ("ladder", ("stick", "slip", "separated")),
         ("falling-rod", ("stick", "separated")), ("bouncing-ball", ("slip",))]


@pytest.fixture(scope="module")
def built():
    models = {}

    def get(name):
        if name not in models:
            definition = kd.models.build(name)
            model = definition.numeric()
            models[name] = (model, np.asarray(definition.initial(model), dtype=float))
        return models[name]
    return get


@pytest.mark.parametrize("name, modes", CASES, ids=[f"{n}-{'-'.join(m)}" for n, m in CASES])
def test_built_in_contact_models_off_the_constraints(built, name, modes):
    """Random states off the contact constraints (drift), so the Baumgarte terms
    and the drift-corrected slip velocities of several active contacts count."""
    model, y0 = built(name)
    y = y0 + 0.05 * np.random.default_rng(1).standard_normal(y0.size)
    _check(model, y, modes)


@pytest.mark.parametrize("name, modes", [("block-on-incline", ("slip",)),
                                         ("bead-in-tube", ("slip", "slip")),
                                         ("ladder", ("slip", "slip", "separated"))])
def test_slip_directions_from_references(built, name, modes):
    """Nearly at rest the friction follows the reference directions (projected on
    the tangent plane, or on what the other active contacts allow)."""
    model, y0 = built(name)
    rng = np.random.default_rng(2)
    y = y0 + 0.05 * rng.standard_normal(y0.size)
    y[model.n_q:] = 1e-5 * rng.standard_normal(model.n_u)
    directions = [SlipReference(rng.standard_normal(3), still=1e-3) for _ in modes]
    _check(model, y, modes, directions)


def _particle_on_ball(backend="numpy"):
    """A particle with z' = y x' held on a ball by a bilateral contact with Coulomb
    and viscous friction (coefficients named constants), pushed by an input."""
    x, y, z = me.dynamicsymbols("x y z")
    ux, uy, uz = me.dynamicsymbols("u_x u_y u_z")
    F = me.dynamicsymbols("F")
    m, k, mu, c = sm.symbols("m k mu c", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y + z * N.z)
    P.set_vel(N, ux * N.x + uy * N.y + uz * N.z)
    ball = kd.Contact(P, kd.Sphere(N, O, 2.0, inside=False, name="ball"), mu_k=mu,
                      viscous=2 * c, kind="bilateral", name="ball")
    eom = kd.kane(frame=N, q_ind=[x, y, z], u_ind=[ux, uy], u_dep=[uz],
                  kd_eqs=[x.diff() - ux, y.diff() - uy, z.diff() - uz],
                  bodies=[me.Particle("p", P, m)],
                  loads=[(P, -k * (x * N.x + y * N.y) + F * N.y)],
                  constraints=[kd.PointVelocity(P, -y * N.x + N.z, names="R")],
                  contacts=[ball])
    return eom.numeric(constants={m: 1.3, k: 4.0, mu: 0.3, c: 0.1}, specified={F: 0.7},
                       backend=backend)


@pytest.fixture(scope="module")
def particle():
    return _particle_on_ball()


@pytest.mark.parametrize("speed", [0.4, 6.0], ids=["pushing", "pulling"])
def test_dependent_speeds_bilateral_viscous_and_inputs(particle, speed):
    """Dependent speeds eliminated in the mode solve, a bilateral contact whose
    normal force pulls at speed (the friction's sign follows it), viscous and
    Coulomb coefficients that are constants, an input force."""
    model = particle
    y = np.array([1.2, 0.9, 1.1, speed, -0.8 * speed, 0.0])
    J = _check(model, y, ("slip",))
    N = solve_modes(model, T0, y, ("slip",)).normal_force[0]
    assert (N < 0) == (speed > 1)  # both signs of the normal force are covered
    n = model.n_states
    R = _differences(lambda r: _solved(model, y, ("slip",), r=r), np.array([0.7]))
    assert _relative(J.inputs, R[:n]) < 1e-8
    assert _relative(J.contact_forces_inputs.reshape(3, -1), R[n:]) < 1e-8

    def multiplier(z):
        """The constraint's multiplier from the momentum balance, by least squares."""
        sol = solve_modes(model, T0, z, ("slip",))
        _, mass, force, B, _, _ = model._fn["dynamics"](T0, z, model._p, [0.7])
        rest = mass @ sol.udot - force - sol.points[0].jacobian.T @ sol.force[0]
        return np.linalg.lstsq(B.reshape(1, -1).T, rest, rcond=None)[0]
    assert _relative(J.multipliers, _differences(multiplier, y)) < 1e-8


def test_c_backend_and_many_states(particle):
    model_c = _particle_on_ball("c")
    rng = np.random.default_rng(3)
    Y = np.array([1.2, 0.9, 1.1, 0.4, -0.3, 0.0]) + 0.1 * rng.standard_normal((4, 6))
    many = model_c.jacobians(T0, Y, modes=("slip",), parameters=True)
    for i, y in enumerate(Y):
        one = particle.jacobians(T0, y, modes=("slip",), parameters=True)
        assert np.allclose(many.state[i], one.state, rtol=1e-12, atol=1e-12)
        assert np.allclose(many.contact_forces_parameters[i], one.contact_forces_parameters,
                           rtol=1e-12, atol=1e-12)
    assert many.contact_names == ("ball",)


def test_modes_are_required_and_checked(built, particle):
    model, y0 = built("bead-in-tube")
    with pytest.raises(kd.ModelError, match="floor, wall.*modes="):
        model.jacobians(0.0, y0)
    with pytest.raises(kd.ModelError, match="one mode per contact"):
        model.jacobians(0.0, y0, modes=("slip",))
    with pytest.raises(kd.ModelError, match="'wall' has mode 'slide'"):
        model.jacobians(0.0, y0, modes=("slip", "slide"))
    # sticking in the corner while sliding on the floor: 4 constraints on 3 speeds
    with pytest.raises(kd.ModelError, match="statically indeterminate"):
        model.jacobians(0.0, y0, modes=("slip", "stick"))
    pendulum = kd.models.build("pendulum").numeric()
    with pytest.raises(kd.ModelError, match="modes: this model has no contacts"):
        pendulum.jacobians(0.0, [0.1, 0.0], modes=("slip",))
    # the integrators' right-hand side has none without modes
    assert "within given contact modes" in kd.numerics.derivatives_unavailable(model)


def test_implicit_integration_takes_the_exact_jacobian_per_segment():
    """Radau through impacts and stick-slip: the segments' exact Jacobians give the
    run of solve_ivp's differences, with fewer right-hand sides (no columns
    differenced)."""
    definition = kd.models.build("falling-rod")
    model = definition.numeric()
    y0 = definition.initial(model)
    runs = {jac: kd.simulate(model, (0.0, definition.t_end), y0, method="Radau", rtol=1e-9,
                             atol=1e-9, jac=jac) for jac in ("exact", "differences")}
    exact, differences = runs["exact"], runs["differences"]
    assert exact.status == differences.status == 0
    assert len(exact.impacts) == len(differences.impacts) > 0
    assert np.max(np.abs(exact.y[:, -1] - differences.y[:, -1])) < 1e-8
    assert exact.nfev < differences.nfev
