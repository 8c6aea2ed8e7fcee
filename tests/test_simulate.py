"""kd.simulate: consistent starts, drift projection, events, failures, output files."""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd


@pytest.fixture(scope="module")
def four_bar():
    d = kd.models.build("four-bar")
    return d, d.numeric()


def test_initial_state_is_made_consistent(four_bar):
    d, model = four_bar
    res = kd.simulate(model, (0, 0.1), d.initial(model))
    assert np.max(np.abs(model.constraint_residuals(0.0, res.initial_state))) < 1e-12
    assert res.y[:, 0] == pytest.approx(res.initial_state)


def test_projection_bounds_the_drift(four_bar):
    d, model = four_bar
    y0 = d.initial(model)
    loose = dict(rtol=1e-5, atol=1e-5)
    drifting = kd.simulate(model, (0, 5), y0, project=False, **loose)
    projected = kd.simulate(model, (0, 5), y0, projection_tol=1e-6, **loose)
    assert projected.projections > 0
    assert np.max(projected.constraint_residual) <= 1e-6 * 1.0001
    assert np.max(drifting.constraint_residual) > 10 * np.max(projected.constraint_residual)


def test_events_like_solve_ivp():
    d = kd.models.build("pendulum")
    model = d.numeric()

    def bottom(t, y):
        return y[0]
    bottom.terminal = True
    bottom.direction = -1

    res = kd.simulate(model, (0, 10), {"q": 1.0, "u": 0.0}, events=[bottom],
                      rtol=1e-10, atol=1e-10)
    assert res.status == 1 and res.success
    assert len(res.t_events[0]) == 1
    assert res.t[-1] == pytest.approx(res.t_events[0][0])
    assert abs(res.y_events[0][0][0]) < 1e-10
    assert res.y_events[0][0][1] < 0


def test_failure_returns_what_was_computed():
    """An input that becomes non-finite stops the run with a message."""
    d = kd.models.build("n-link-pendulum-on-cart", n=1)
    F = d.symbols["F"]
    model = d.numeric(specified={F: lambda t: 0.0 if t < 1.0 else np.nan})
    res = kd.simulate(model, (0, 3), d.initial(model))
    assert not res.success
    assert res.status == -1
    assert "not finite" in res.message and "t=1" in res.message and "F(t)" in res.message
    assert res.t.size > 10
    assert 0.9 < res.t[-1] <= 1.0 + 1e-9
    assert np.all(np.isfinite(res.y))


def test_singular_mass_matrix_is_reported():
    """A massless particle gives a singular mass matrix: reported, not raised."""
    q, u = me.dynamicsymbols("q u")
    m = sm.symbols("m")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x)
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("p", P, m)], loads=[(P, N.x)])
    model = eom.numeric(constants={m: 0.0})
    res = kd.simulate(model, (0, 1), [0.0, 0.0])
    assert not res.success
    assert "singular" in res.message


def test_access_and_outputs(tmp_path, four_bar):
    d, model = four_bar
    q1 = d.symbols["q"][0]
    res = kd.simulate(model, (0, 1), d.initial(model), t_eval=np.linspace(0, 1, 11),
                      dense_output=True)
    np.testing.assert_array_equal(res["q1"], res[q1])
    np.testing.assert_array_equal(res["q1"], res.y[0])
    assert res.sol(0.5).shape == (model.n_states,)
    assert res.sol(1.0) == pytest.approx(res.y[:, -1], abs=1e-7)
    with pytest.raises(KeyError, match="q9"):
        res["q9"]
    csv = res.to_csv(tmp_path / "run.csv")
    header = csv.read_text().splitlines()[0].split(",")
    assert header[:7] == ["t", "q1", "q2", "q3", "u1", "u2", "u3"]
    assert "energy" in header and "constraint_residual" in header
    data = np.load(res.to_npz(tmp_path / "run.npz"))
    np.testing.assert_array_equal(data["y"], res.y)
    fig = res.plot(path=tmp_path / "run.png")
    assert (tmp_path / "run.png").stat().st_size > 1000
    labels = [ax.get_ylabel() for ax in fig.axes if ax.get_visible()]  # not a grid's filler
    # angles, angular rates, the two levels of constraint residual, energy
    assert [lb.split(" [")[-1] for lb in labels][-4:] == ["rad/s]", "m]", "m/s]", "J]"]
    assert all(lb.startswith("angle [rad]") for lb in labels[:-4])
    summary = res.summary()
    assert summary["success"] and summary["energy_drift"] < 1e-6


def test_stiff_method_names_pass_through(four_bar):
    d, model = four_bar
    res = kd.simulate(model, (0, 0.5), d.initial(model), method="Radau",
                      rtol=1e-8, atol=1e-8)
    ref = kd.simulate(model, (0, 0.5), d.initial(model), rtol=1e-10, atol=1e-10)
    assert res.success and res.method == "Radau"
    np.testing.assert_allclose(res.y[:, -1], ref.y[:, -1], atol=1e-6)
