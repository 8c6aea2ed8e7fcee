"""Static equilibria and steady motions (``kd.equilibrium``, issue 34 item 4),
against closed forms and the published bicycle benchmark."""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.models._bicycle_analysis import upright_state


def pendulum_with_torque():
    """A point mass m on a massless rod of length l, a constant torque T."""
    q, u = me.dynamicsymbols("q u")
    m, l, g, T = sm.symbols("m l g T")
    N, A = me.ReferenceFrame("N"), me.ReferenceFrame("A")
    A.orient_axis(N, N.z, q)
    A.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", -l * A.y)
    P.v2pt_theory(O, N, A)
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("bob", P, m)], loads=[(P, -m * g * N.y), (A, T * N.z)])
    return eom.numeric(constants={m: 2.0, l: 0.5, g: 9.81, T: 4.0}, backend="numpy")


def test_a_pendulum_held_out_by_a_torque():
    """sin(q) = T / (m g l); small oscillations at sqrt(g cos(q) / l)."""
    model = pendulum_with_torque()
    found = kd.equilibrium(model, [0.1, 0.0])
    assert found.converged and found.residual < 1e-10
    angle = np.arcsin(4.0 / (2.0 * 9.81 * 0.5))
    assert found.y[0] == pytest.approx(angle, abs=1e-12)
    omega = np.sqrt(9.81 * np.cos(angle) / 0.5)
    np.testing.assert_allclose(found.frequencies, omega / (2 * np.pi), rtol=1e-10)
    assert found.stable
    above = kd.equilibrium(model, [3.0, 0.0])  # the other root, above the pivot
    assert above.y[0] == pytest.approx(np.pi - angle, abs=1e-12) and not above.stable


def test_no_equilibrium_is_said():
    """A torque above m g l: no equilibrium; the result says so."""
    model = pendulum_with_torque().with_constants({"T": 20.0})
    found = kd.equilibrium(model, [0.1, 0.0], max_iterations=20)
    assert not found.converged and found.message and found.residual > 1
    assert np.all(np.isnan(found.eigenvalues))


def conical_pendulum():
    """A point mass on a rod of length L hanging from a fixed point: heading psi
    about the vertical, then the tilt theta."""
    psi, theta, w_psi, w_theta = me.dynamicsymbols("psi theta w_psi w_theta")
    m, L, g = sm.symbols("m L g")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [psi, N.z])
    B = A.orientnew("B", "Axis", [theta, A.x])
    B.set_ang_vel(N, w_psi * N.z + w_theta * A.x)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", -L * B.z)
    P.v2pt_theory(O, N, B)
    eom = kd.kane(frame=N, q_ind=[psi, theta], u_ind=[w_psi, w_theta],
                  kd_eqs=[psi.diff() - w_psi, theta.diff() - w_theta],
                  bodies=[me.Particle("bob", P, m)], loads=[(P, -m * g * N.z)])
    return eom.numeric(constants={m: 1.5, L: 0.8, g: 9.81}, backend="numpy")


def test_a_conical_pendulum_in_steady_motion():
    """Spinning at Omega about the vertical: cos(theta) = g / (L Omega^2) (the
    rod hanging straight down, theta = 0, is the other steady motion)."""
    model = conical_pendulum()
    spin = 6.0
    found = kd.equilibrium(model, {"psi": 0.0, "theta": 1.0, "w_psi": spin, "w_theta": 0.0},
                           hold="w_psi", moving="psi")
    assert found.converged
    assert np.cos(found.y[model.index("theta")]) == pytest.approx(9.81 / (0.8 * spin ** 2),
                                                                  abs=1e-12)
    assert found.y[model.index("w_psi")] == spin  # held
    assert abs(found.y[model.index("w_theta")]) < 1e-15


@pytest.fixture(scope="module")
def bicycle():
    definition = kd.models.build("whipple-bicycle")
    return definition.numeric(backend="numpy")


def test_the_bicycle_running_upright_and_its_published_eigenvalues(bicycle):
    """From a leaning, steered guess at 5 m/s (the rear wheel's rate held, the
    position, heading and wheel angles moving): upright straight running, with
    the four eigenvalues of Meijaard et al. (2007) and zeros for the rest."""
    y = upright_state(bicycle, 5.0)
    y[bicycle.index("q4")], y[bicycle.index("q7")] = 0.05, -0.02
    found = kd.equilibrium(bicycle, y, hold="u6", moving=["q1", "q2", "q3", "q6", "q8"])
    assert found.converged
    assert abs(found.y[bicycle.index("q4")]) < 1e-12 and abs(found.y[bicycle.index("q7")]) < 1e-12
    published = np.array([-14.07838969279820, -0.77534188219585 - 4.46486771378823j,
                          -0.77534188219585 + 4.46486771378823j, -0.32286642900409])
    nonzero = found.eigenvalues[np.abs(found.eigenvalues) > 1e-8]
    assert nonzero.size == 4
    assert np.max(np.abs(nonzero - published)) < 1e-9
    assert found.stable
    slow = kd.equilibrium(bicycle, upright_state(bicycle, 3.0), hold="u6",
                          moving=["q1", "q2", "q3", "q6", "q8"])
    assert slow.converged and not slow.stable  # below the weave speed, 4.29 m/s


def test_a_closed_loop_hanging_still():
    """The four-bar from near its lowest configuration: a stable equilibrium
    (oscillations only) that a simulation started there does not leave."""
    definition = kd.models.build("four-bar")
    model = definition.numeric(backend="numpy")
    guess = definition.initial(model)
    guess[0] = -1.3
    found = kd.equilibrium(model, guess)
    assert found.converged and found.stable
    assert np.max(np.abs(model.rhs(0.0, found.y))) < 1e-10
    assert np.max(np.abs(model.constraint_residuals(0.0, found.y))) < 1e-12
    assert np.all(np.abs(found.eigenvalues.real) < 1e-8 * np.max(np.abs(found.eigenvalues)))
    res = kd.simulate(model, (0.0, 2.0), found.y, rtol=1e-10, atol=1e-10)
    assert np.max(np.abs(res.y - found.y[:, None])) < 1e-7


def test_bad_requests():
    model = conical_pendulum()
    y = [0.0, 0.4, 6.0, 0.0]
    with pytest.raises(kd.ModelError, match="moving: w_psi are speeds"):
        kd.equilibrium(model, y, moving="w_psi")
    with pytest.raises(kd.ModelError, match="hold: phi is not a state of this model"):
        kd.equilibrium(model, y, hold="phi")
    with pytest.raises(kd.ModelError, match="nothing to solve for"):
        kd.equilibrium(model, y, hold=["theta", "w_psi", "w_theta"], moving="psi")


@pytest.mark.slow
def test_the_floating_turbine_offset_by_rated_thrust():
    """OC3 spar, linear mooring, wind at 11.4 m/s (the rotor parked in its
    thrust curve: 794 kN): the mean offset balances the thrust along the tilted
    shaft against the published mooring stiffness in surge (to 1e-3: the
    mooring measures the pitch by its sine), and is a state the model does not
    leave."""
    import math

    import kanedyn.models._oc3_data as D
    from kanedyn.models import oc3_settle, oc3_spar
    from kanedyn.models._oc3_spar import mooring_stiffness_matrix
    definition = oc3_spar(tower_modes=0, mooring="linear", drag=False, wind_speed=11.4)
    model = definition.numeric(definition.derive())
    y = oc3_settle(definition, model)
    surge, pitch = y[model.index("surge")], y[model.index("pitch")]
    assert 20.0 < surge < 30.0 and 0.05 < pitch < 0.15  # m and rad downwind
    thrust = kd.offshore.NREL5MW_THRUST(11.4)
    along = thrust * math.cos(math.radians(D.ROTOR["shaft_tilt"].value) + pitch)
    held = mooring_stiffness_matrix()[0] @ y[:6]
    assert abs(held - along) < 1e-3 * thrust
    res = kd.simulate(model, (0.0, 20.0), y, rtol=1e-10, atol=1e-10)
    assert np.max(np.abs(res.y[model.n_q:])) < 1e-6


# ------------------------------------------------------------ the command line
def test_the_command_line(capsys):
    """kanedyn equilibrium: the state and the eigenvalues (the bicycle's
    published four at 5 m/s), exit 0; no equilibrium: exit 1, said; a state
    that is not one: exit 2, one line."""
    from kanedyn.cli import main
    argv = ["equilibrium", "whipple-bicycle", "--hold", "u6", "--set", "u6=-16.66666666667",
            "--set", "q4=0.05", "--backend", "numpy", "--quiet"]
    for q in ("q1", "q2", "q3", "q6", "q8"):
        argv += ["--moving", q]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "whipple-bicycle: converged in" in out and "stable" in out
    assert "-14.0784" in out and "4.46487" in out and "-0.322866" in out
    assert main(["equilibrium", "pendulum", "--hold", "u", "--set", "u=1", "--quiet",
                 "--backend", "numpy"]) == 1
    assert "pendulum: NOT converged" in capsys.readouterr().out
    assert main(["equilibrium", "pendulum", "--hold", "w", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err == ("kanedyn: error: --hold w: not a state of pendulum; states: q, u\n")
