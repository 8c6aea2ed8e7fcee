"""The linearized Whipple bicycle against the published benchmark.

Reference: Meijaard, Papadopoulos, Ruina & Schwab (2007), Proc. R. Soc. A 463,
1955-1982 (values in ../shared/REFERENCES.md).  kanedyn derives the nonlinear,
nonholonomic model with Kane's method and linearizes it numerically about
upright straight running; the lean/steer block must equal the benchmark's
state matrix built from M, C1, K0 and K2.
"""

import numpy as np
import pytest

from kanedyn.models._bicycle_analysis import (roll_steer_matrix, stability_speeds,
                                              upright_state)

M = np.array([[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]])
C1 = np.array([[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]])
K0 = np.array([[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]])
K2 = np.array([[0.0, 76.59734589573222], [0.0, 2.65431523794604]])
G = 9.81


def benchmark_state_matrix(v):
    """x' = A x for x = (lean, steer, lean rate, steer rate), from the paper."""
    Minv = np.linalg.inv(M)
    return np.block([[np.zeros((2, 2)), np.eye(2)],
                     [-Minv @ (G * K0 + v ** 2 * K2), -Minv @ (v * C1)]])


def sorted_eigenvalues(A):
    ev = np.linalg.eigvals(A)
    return ev[np.lexsort((ev.imag, ev.real))]


SPEEDS = np.linspace(0.0, 10.0, 21)


@pytest.mark.parametrize("v", SPEEDS)
def test_state_matrix_matches_benchmark(bicycle, v):
    _, _, model = bicycle
    A = roll_steer_matrix(model, v)
    assert np.max(np.abs(A - benchmark_state_matrix(v))) < 1e-9 * max(1.0, v ** 2)


@pytest.mark.parametrize("v", SPEEDS)
def test_eigenvalues_match_benchmark(bicycle, v):
    _, _, model = bicycle
    got = sorted_eigenvalues(roll_steer_matrix(model, v))
    ref = sorted_eigenvalues(benchmark_state_matrix(v))
    assert np.max(np.abs(got - ref)) < 1e-9


def test_published_eigenvalues(bicycle):
    _, _, model = bicycle
    at_0 = np.sort(np.linalg.eigvals(roll_steer_matrix(model, 0.0)).real)
    np.testing.assert_allclose(
        at_0, [-5.53094371765393, -3.13164324790656, 3.13164324790656, 5.53094371765393],
        rtol=0, atol=1e-9)
    at_5 = sorted_eigenvalues(roll_steer_matrix(model, 5.0))
    ref_5 = sorted_eigenvalues(np.diag([-0.32286642900409, -14.07838969279820,
                                        complex(-0.77534188219585, 4.46486771378823),
                                        complex(-0.77534188219585, -4.46486771378823)]))
    assert np.max(np.abs(at_5 - ref_5)) < 1e-9


def test_weave_and_capsize_speeds(bicycle):
    _, _, model = bicycle
    weave, capsize = stability_speeds(model)
    assert abs(weave - 4.29238253634111) < 1e-9
    assert abs(capsize - 6.02426201538837) < 1e-9


def test_constraint_order_does_not_matter(bicycle):
    """Reversing the velocity constraints gives the same linearization."""
    import kanedyn as kd

    definition = kd.models.build("whipple-bicycle")
    args = dict(definition.kane_args)
    args["velocity_constraints"] = list(reversed(args["velocity_constraints"]))
    model = definition.numeric(kd.kane(**args))
    _, _, reference = bicycle
    for v in (0.0, 4.0, 8.0):
        A = roll_steer_matrix(model, v)
        assert np.max(np.abs(A - roll_steer_matrix(reference, v))) < 1e-10


def test_upright_straight_running_is_steady(bicycle):
    """At upright straight running all accelerations vanish."""
    _, _, model = bicycle
    y = upright_state(model, 5.0)
    assert np.max(np.abs(model.rhs(0.0, y)[model.n_q:])) < 1e-10
    assert np.max(np.abs(model.constraint_residuals(0.0, y))) < 1e-12


def test_steer_torque_input_matches_benchmark():
    """With ``steer_torque=True`` the input T_delta enters the lean and steer
    accelerations as M^-1 [0, 1]^T of the benchmark (M q'' + ... = [T_phi,
    T_delta]) at every speed; the state matrix is unchanged."""
    import kanedyn as kd
    model = kd.models.build("whipple-bicycle", steer_torque=True).numeric(backend="numpy")
    assert tuple(model.input_names) == ("T_delta(t)",)
    independent = ("q1", "q2", "q3", "q4", "q6", "q7", "q8", "u4", "u6", "u7")
    rows = [independent.index(n) for n in ("u4", "u7")]
    block = [independent.index(n) for n in ("q4", "q7", "u4", "u7")]
    for v in (0.0, 3.0, 5.0, 8.0):
        A, B, _ = model.linearize(upright_state(model, v))
        np.testing.assert_allclose(B[rows, 0], np.linalg.solve(M, [0.0, 1.0]), rtol=1e-9)
        assert np.max(np.abs(A[np.ix_(block, block)] - benchmark_state_matrix(v))) \
            < 1e-9 * max(1.0, v ** 2)
