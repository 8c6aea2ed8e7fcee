"""Andrews' squeezing mechanism against the IVP test set (Hairer & Wanner II, VII.7).

The test set ("andrews") gives consistent initial accelerations and
multipliers, and a reference solution at t = 0.03 s computed to about 1e-14;
the multipliers there have the opposite sign of kanedyn's (it writes
M q'' = f - G^T lambda, kanedyn M u' = f + B^T lambda, with the same rows).
"""

import numpy as np
import pytest

import kanedyn as kd

#: the test set's consistent start (at rest): accelerations, rad/s², and multipliers
START_ACCELERATIONS = np.array([14222.4439199541138705911625887,
                                -10666.8329399655854029433719415, 0.0, 0.0, 0.0, 0.0, 0.0])
START_MULTIPLIERS = np.array([98.5668703962410896057654982170,
                              -6.12268834425566265503114393122, 0.0, 0.0, 0.0, 0.0])
#: the test set's reference solution at t = 0.03 s: coordinates (rad), rates (rad/s),
#: multipliers
END = 0.03
END_STATE = np.array([0.1581077119629904e2, -0.1575637105984298e2, 0.4082224013073101e-1,
                      -0.5347301163226948, 0.5244099658805304, 0.5347301163226948,
                      0.1048080741042263e1, 0.1139920302151208e4, -0.1424379294994111e4,
                      0.1103291221937134e2, 0.1929337464421385e2, 0.5735699284790808,
                      -0.1929337464421385e2, 0.3231791658026955])
END_MULTIPLIERS = np.array([0.1991753333731910e3, -0.2975531228015052e2, 0.2306654119098399e2,
                            0.3145271365475927e2, 0.2264249232082739e2, 0.1161740700019673e2])


@pytest.fixture(scope="module")
def andrews():
    definition = kd.models.build("andrews-squeezer")
    kane = definition.numeric(definition.derive())
    return definition, kane, kane.state(definition.initial(kane))


@pytest.mark.parametrize("method", ["kane", "lagrange"])
def test_start_matches_the_test_set(andrews, method):
    definition, kane, y0 = andrews
    model = kane if method == "kane" else definition.numeric(definition.derive(method=method))
    np.testing.assert_allclose(y0[:7], kd.models.ANDREWS_INITIAL, atol=1e-15)
    accelerations = model.rhs(0.0, y0)[7:]
    np.testing.assert_allclose(accelerations, START_ACCELERATIONS, rtol=0,
                               atol=1e-12 * np.max(START_ACCELERATIONS))
    multipliers = np.array(list(model.multipliers(0.0, y0).values()))
    np.testing.assert_allclose(multipliers, -START_MULTIPLIERS, rtol=0, atol=1e-12 * 100)


def test_motion_matches_the_reference_solution(andrews):
    definition, kane, y0 = andrews
    res = kd.simulate(kane, (0.0, END), y0, method="DOP853", rtol=1e-10, atol=1e-10)
    assert res.success
    np.testing.assert_allclose(res.y[:7, -1], END_STATE[:7], rtol=0, atol=1e-8)
    np.testing.assert_allclose(res.y[7:, -1], END_STATE[7:], rtol=0, atol=5e-6)
    multipliers = np.array(list(kane.multipliers(END, res.y[:, -1]).values()))
    np.testing.assert_allclose(multipliers, -END_MULTIPLIERS, rtol=0,
                               atol=1e-6 * np.max(END_MULTIPLIERS))
    # the potential energy holds the spring and the drive torque's work
    energy = [kane.total_energy(t, y) for t, y in zip(res.t, res.y.T)]
    assert np.ptp(energy) < 1e-9 * np.max(np.abs(energy))


def test_index3_scheme_converges_to_the_reference(andrews):
    """The index-3 scheme's trapezoidal rule is second order on this stiff case: halving
    the step divides the error by 5.0 here (5.5, 5.0, 4.6 from h = 2e-4 down to 2.5e-5)."""
    definition, _, y0 = andrews
    lagrange = definition.derive(method="lagrange")
    errors = []
    for step in (1e-4, 5e-5):
        model = definition.numeric(lagrange,
                                   scheme=kd.schemes.AugmentedLagrangianIndex3(step=step))
        res = kd.simulate(model, (0.0, END), model.state(y0))
        assert res.success
        errors.append(np.max(np.abs(res.y[:7, -1] - END_STATE[:7])))
    assert errors[1] < 3e-3
    assert 3.5 < errors[0] / errors[1] < 6.0
