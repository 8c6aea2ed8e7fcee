"""The OC3 platform springs' loads that are exactly the gradients of their potentials
(kanedyn.models._oc3_potential): their power against SymPy's time derivative of the
potential, and the published matrices' remainder."""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

from kanedyn.models._oc3_data import hydrostatic_matrix, mooring_stiffness_matrix
from kanedyn.models._oc3_potential import (coupled_energy, gradient_loads, restoring_energy,
                                           split_loads)
from kanedyn.modeling import MatrixSpringDamper

T = me.dynamicsymbols._t


def _platform():
    N, O = me.ReferenceFrame("N"), me.Point("O")
    O.set_vel(N, 0)
    q = me.dynamicsymbols("x y z psi theta phi")
    B = N.orientnew("B", "Body", q[3:], "zyx")
    P = O.locatenew("P", q[0] * N.x + q[1] * N.y + q[2] * N.z)
    P.set_vel(N, P.pos_from(O).dt(N))
    return N, O, B, P, q


def _power(loads, N, B, P):
    total = sm.S.Zero
    for where, vector in loads:
        velocity = B.ang_vel_in(N) if where is B else P.vel(N)
        total += vector.dot(velocity)
    return total


def _at(expr, q, values):
    rates = {qi.diff(T): v for qi, v in zip(q, values[6:])}
    return float(expr.subs(rates).subs(dict(zip(q, values[:6]))))


@pytest.mark.parametrize("which", ["hydrostatics", "mooring"])
def test_the_loads_power_is_minus_the_potentials_rate(which):
    """At random states (angles to 0.4 rad, all three rotations), the held loads' power
    equals minus SymPy's time derivative of the potential, to round-off."""
    N, O, B, P, q = _platform()
    if which == "hydrostatics":
        K = hydrostatic_matrix(weight=False)

        def energy(d, R):
            return -8.0e7 * d[2] + restoring_energy(K, d, R)
    else:
        K = np.asarray(mooring_stiffness_matrix(), float)

        def energy(d, R):
            return 1.6e6 * d[2] + coupled_energy(K, d, R)
    loads, V = gradient_loads(energy, P, O, B, N)
    power, rate = _power(loads, N, B, P), V.diff(T)
    rng = np.random.default_rng(3)
    for _ in range(3):
        values = np.concatenate([rng.uniform(-5, 5, 3), rng.uniform(-0.4, 0.4, 3),
                                 rng.uniform(-2, 2, 6)])
        p, r = _at(power, q, values), _at(rate, q, values)
        assert abs(r) > 1e3
        assert p == pytest.approx(-r, rel=1e-12)


def test_the_hydrostatic_remainder_vanishes_in_planar_pitch_and_is_second_order():
    """The published matrix's loads less the held part: zero for a pitch alone (the
    potential is exact about a principal axis), second order in the angles else."""
    N, O, B, P, q = _platform()
    K = hydrostatic_matrix(weight=False)
    held, _ = gradient_loads(lambda d, R: restoring_energy(K, d, R), P, O, B, N)
    rest = split_loads(MatrixSpringDamper("h", B, P, N, K, np.zeros((6, 6)), O).to_loads(),
                       held)
    moment = [rest[1][1].dot(e) for e in (N.x, N.y, N.z)]
    pitch = dict(zip(q, [1.0, 0.0, 0.5, 0.0, 0.3, 0.0]))
    assert max(abs(float(m.subs(pitch))) for m in moment) < 1e-6 * abs(K[4, 4])
    small, large = ([float(m.subs(dict(zip(q, [0, 0, 0, a, a, a])))) for m in moment]
                    for a in (0.01, 0.02))
    ratio = np.linalg.norm(large) / np.linalg.norm(small)
    assert ratio == pytest.approx(4.0, rel=0.05)      # second order
