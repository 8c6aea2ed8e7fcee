"""Linearization: closed forms, non-equilibrium operating points, inputs (B)."""

import numpy as np
import pytest
import sympy as sm

import kanedyn as kd


@pytest.mark.parametrize("phi", [0.0, 0.3, -0.8])
def test_off_equilibrium_operating_point(phi, circle_particle):
    """x = L sin(phi) as the coordinate: d(x'')/dx = -(g/L) cos(2 phi) / cos(phi).

    Away from phi = 0 the particle accelerates; the accelerations and the
    constraint force at the operating point enter the linearization.
    """
    eom, (q1, q2, u1, u2, m, g, L) = circle_particle
    expected = -(9.81 / 1.3) * np.cos(2 * phi) / np.cos(phi)
    A, B, r = eom.linearize(op_point={q1: 1.3 * np.sin(phi), q2: -1.0, u1: 0.0},
                            constants={m: 0.7, g: 9.81, L: 1.3})
    np.testing.assert_allclose(A, [[0, 1], [expected, 0]], atol=1e-12)
    assert B.shape == (2, 0) and r == []


def test_symbolic_linearization_matches_numeric(circle_particle):
    eom, (q1, q2, u1, u2, m, g, L) = circle_particle
    phi = 0.3
    A, _, _ = eom.linearize(op_point={q1: L * sm.sin(phi), q2: -L * sm.cos(phi),
                                      u1: 0, u2: 0})
    assert A.free_symbols == {g, L}
    value = float(A[1, 0].subs({g: 9.81, L: 1.3}))
    assert value == pytest.approx(-(9.81 / 1.3) * np.cos(2 * phi) / np.cos(phi), rel=1e-12)


def test_pendulum_symbolic():
    d = kd.models.build("pendulum")
    eom = d.derive()
    q, u = d.symbols["q"], d.symbols["u"]
    l, g = d.symbols["l"], d.symbols["g"]
    A, B, r = eom.linearize(op_point={q: 0, u: 0})
    assert sm.simplify(A - sm.Matrix([[0, 1], [-g / l, 0]])) == sm.zeros(2, 2)


def test_cart_pendulum_input_matrix():
    """Cart (mass M) with a point-mass pendulum, force F on the cart, about hanging.

    (M + m) x'' + m l th'' = F and l th'' + x'' + g th = 0 give
    x'' = (F + m g th) / M and th'' = -(g (M + m) th + F) / (M l).
    """
    d = kd.models.build("n-link-pendulum-on-cart", n=1)
    Mc, m, l, g = 2.0, 0.5, 0.6, 9.81
    model = d.numeric(constants={"m_c": Mc, "m": m, "l": l, "g": g})
    A, B, r = model.linearize(np.zeros(4))
    expected_A = np.array([[0, 0, 1, 0], [0, 0, 0, 1],
                           [0, m * g / Mc, 0, 0], [0, -g * (Mc + m) / (Mc * l), 0, 0]])
    np.testing.assert_allclose(A, expected_A, atol=1e-12)
    np.testing.assert_allclose(B.ravel(), [0, 0, 1 / Mc, -1 / (Mc * l)], atol=1e-12)
    assert r == ["F"]


def test_operating_point_must_be_complete_and_consistent(circle_particle):
    eom, (q1, q2, u1, u2, m, g, L) = circle_particle
    with pytest.raises(kd.MissingValueError, match="u1"):
        eom.linearize(op_point={q1: 0.1, q2: -1.0}, constants={m: 1, g: 1, L: 1})
    model = eom.numeric(constants={m: 1, g: 1, L: 1})
    with pytest.raises(kd.ConstraintError, match="does not satisfy"):
        model.linearize([0.1, -0.5, 0.0, 0.0])
