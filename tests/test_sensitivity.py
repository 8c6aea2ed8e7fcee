"""Forward sensitivities of trajectories (``kd.sensitivity``, issue 34 item 3),
against a closed form and differences of whole runs."""

import numpy as np
import pytest
import sympy as sm

import kanedyn as kd


@pytest.fixture()
def oscillator(line_particle):
    """A mass m = 2 kg on a spring k = 50 N/m."""
    m, k = sm.symbols("m k")
    eom, _, _ = line_particle(m, force=lambda q, u: -k * q)
    return eom.numeric(constants={m: 2.0, k: 50.0}, backend="numpy")


def test_an_oscillator_against_its_closed_form(oscillator):
    """x = x0 cos(w t) + v0 sin(w t) / w, w = sqrt(k / m)."""
    model = oscillator
    x0, v0, m, k = 0.3, -1.2, 2.0, 50.0
    w = np.sqrt(k / m)
    t = np.linspace(0.0, 3.0, 7)
    s = kd.sensitivity(model, (0.0, 3.0), [x0, v0], t_eval=t, rtol=1e-11, atol=1e-12)
    assert s.success and s.parameter_names == ("k", "m")
    np.testing.assert_allclose(s.initial[:, 0, 0], np.cos(w * t), atol=1e-8)
    np.testing.assert_allclose(s.initial[:, 0, 1], np.sin(w * t) / w, atol=1e-8)
    dx_dw = -x0 * t * np.sin(w * t) + v0 * (t * np.cos(w * t) / w - np.sin(w * t) / w ** 2)
    np.testing.assert_allclose(s.parameters[:, 0, 0], dx_dw / (2 * np.sqrt(k * m)),
                               atol=1e-8)
    np.testing.assert_allclose(s.parameters[:, 0, 1], -dx_dw * k / (2 * np.sqrt(k * m) * m),
                               atol=1e-8)


def test_a_chain_against_differences_of_whole_runs():
    """chain3d (2 bodies, 3D): d y(T) / d (y0, l, g) against central differences of
    runs at tight tolerances."""
    definition = kd.models.build("chain3d", n=2)
    model = definition.numeric(backend="numpy")
    y0 = np.asarray(definition.initial(model), dtype=float) + 0.2
    T = 1.5
    s = kd.sensitivity(model, (0.0, T), y0, parameters=["l", "g"], t_eval=[T],
                       rtol=1e-10, atol=1e-10)

    def end(y, **constants):
        run = model.with_constants(constants) if constants else model
        return kd.simulate(run, (0.0, T), y, t_eval=[T], rtol=1e-12, atol=1e-12).y[:, -1]

    for j in (0, 3):
        h = 1e-5
        up, down = y0.copy(), y0.copy()
        up[j] += h
        down[j] -= h
        np.testing.assert_allclose(s.initial[-1][:, j], (end(up) - end(down)) / (2 * h),
                                   atol=1e-6)
    for k, name in enumerate(("l", "g")):
        value = model.constants[name]
        h = 1e-6 * value
        column = (end(y0, **{name: value + h}) - end(y0, **{name: value - h})) / (2 * h)
        np.testing.assert_allclose(s.parameters[-1][:, k], column, rtol=1e-5, atol=1e-6)


def test_directions_of_the_initial_state_against_the_closed_form(oscillator):
    """``directions``: the columns are d x / d y0 times the directions given
    (the closed form's cos(w t) and sin(w t) / w combined), the parameters'
    columns as without them; a bad shape is refused."""
    model = oscillator
    w = np.sqrt(50.0 / 2.0)
    t = np.linspace(0.0, 3.0, 7)
    V = np.array([[1.0, 0.5], [0.0, -2.0]])
    s = kd.sensitivity(model, (0.0, 3.0), [0.3, -1.2], t_eval=t, rtol=1e-11, atol=1e-12,
                       directions=V)
    full = kd.sensitivity(model, (0.0, 3.0), [0.3, -1.2], t_eval=t, rtol=1e-11, atol=1e-12)
    assert s.initial.shape == (t.size, 2, 2)
    np.testing.assert_allclose(s.initial[:, 0, 0], np.cos(w * t), atol=1e-8)
    np.testing.assert_allclose(s.initial[:, 0, 1], 0.5 * np.cos(w * t) - 2.0 * np.sin(w * t) / w,
                               atol=1e-8)
    np.testing.assert_allclose(s.parameters, full.parameters, atol=1e-8)
    none = kd.sensitivity(model, (0.0, 3.0), [0.3, -1.2], t_eval=t, directions=np.zeros((2, 0)))
    assert none.initial.shape == (t.size, 2, 0) and none.parameters.shape == (t.size, 2, 2)
    with pytest.raises(kd.OptionError, match=r"directions must be a finite array of shape "
                                             r"\(2, m\)"):
        kd.sensitivity(model, (0.0, 1.0), [0.1, 0.0], directions=[1.0, 0.0])


def test_bad_requests(oscillator):
    model = oscillator
    with pytest.raises(kd.OptionError, match="'c' is not a constant of this model; its "
                                             "constants are k, m"):
        kd.sensitivity(model, (0.0, 1.0), [0.1, 0.0], parameters=["c"])
    contact = kd.models.build("bouncing-ball")
    with pytest.raises(kd.ModelError, match="sensitivity: a model with contacts has exact "
                                            "derivatives within given contact modes only"):
        kd.sensitivity(contact.numeric(backend="numpy"), (0.0, 1.0), [1.0, 0.0])
    none = kd.sensitivity(model, (0.0, 1.0), [0.1, 0.0], parameters=False)
    assert none.parameters.shape == (none.t.size, 2, 0)
