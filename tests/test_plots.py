"""Figures worth looking at: titles, units on every axis, one unit per axis, log axes
only for positive data, legends whose colours match the curves, the work-precision
diagram, the bicycle's named modes.

Units are checked against what the models' kinematics say (a coordinate that turns a
frame is an angle, one that moves a point along an axis is a length), colours against
the lines actually drawn.
"""

from dataclasses import replace

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.analysis import (FormulationComparison, WorkPrecision, bicycle_modes,
                              log_scale_ok, plot_bicycle_eigenvalues, pyplot)
from kanedyn.modeling import state_units, parse_model


def _run(name, t_end, n=41, **options):
    d = kd.models.build(name, **options)
    model = d.numeric()
    y0 = d.initial(model)
    if model.n_q_dep or model.n_u_dep:
        y0 = model.consistent_state(0.0, y0)
    return kd.simulate(model, (0.0, t_end), y0, t_eval=np.linspace(0.0, t_end, n),
                       rtol=1e-9, atol=1e-9)


def _panels(fig):
    return [ax for ax in fig.axes if ax.get_visible() and ax.get_ylabel()]


def _check_figure(fig):
    """Title, units on every axis, no log axis over non-positive data."""
    title = fig._suptitle.get_text() if fig._suptitle else fig.axes[0].get_title()
    assert title and not title.startswith("simulation")
    for ax in _panels(fig):
        label = ax.get_ylabel()
        assert label.count("[") == 1 and label.endswith("]"), label
        if ax.get_yscale() == "log":
            for line in ax.get_lines():
                y = np.asarray(line.get_ydata(), dtype=float)
                assert np.all(y[np.isfinite(y)] > 0), (label, line.get_label())
            assert ax.get_ylim()[0] > 1e-30, (label, ax.get_ylim())


# ------------------------------------------------------------------ units
def test_units_from_the_kinematics():
    """Angles turn frames, lengths move points; speeds follow the kinematic equations."""
    cart = kd.models.build("n-link-pendulum-on-cart", n=2).derive().state_units
    assert cart == {"q0": "m", "q1": "rad", "q2": "rad", "u0": "m/s", "u1": "rad/s",
                    "u2": "rad/s"}
    disk = kd.models.build("rolling-disk").derive().state_units
    assert disk["q1"] == "m" and disk["q4"] == "rad"
    assert disk["u1"] == "rad/s" and disk["u4"] == "m/s"  # body rate vs. contact speed
    robot = kd.models.build("flexible-robot").derive().state_units
    assert robot["theta"] == "rad" and robot["eta_link_1"] == "m"
    assert robot["zeta_link_1"] == "m/s"
    # the four-bar's loop closure is in metres: its link lengths are lengths
    config, velocity = kd.models.build("four-bar").derive().constraint_units
    assert config == ["m", "m"] and velocity == ["m/s", "m/s"]


def test_unknown_or_contradicting_units_stay_unknown():
    q, u, s, w = me.dynamicsymbols("q u s w")
    k, m = sm.symbols("k m", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", k * s * N.x)  # s scaled by a parameter: unit not told
    P.set_vel(N, k * w * N.x)
    A = N.orientnew("A", "Axis", (q, N.z))  # q turns a frame ...
    R = O.locatenew("R", q * N.y)  # ... and moves a point along an axis
    R.set_vel(N, u * N.y)
    spec = parse_model(frame=N, q_ind=[q, s], u_ind=[u, w],
                       kd_eqs=[q.diff() - u, s.diff() - w],
                       bodies=[me.Particle("p", P, m), me.Particle("r", R, m)], loads=[])
    assert A is not None
    units = state_units(spec)
    assert units == {"q": None, "s": None, "u": None, "w": None}
    declared = state_units(spec, {"s": "m"})
    assert declared["s"] == "m" and declared["w"] == "m/s"


def test_declared_units_label_the_model():
    d = kd.models.build("pendulum")
    d = replace(d, units={"q": "deg"})  # what a definition may declare
    model = d.numeric()
    assert model.name == "pendulum" and "pendulum" in model.title
    assert model.state_units == {"q": "deg", "u": "deg/s"}


# ------------------------------------------------------------------ res.plot
def test_pendulum_plot_title_units(tmp_path):
    res = _run("pendulum", 2.0)
    fig = res.plot(path=tmp_path / "p.png")
    _check_figure(fig)
    assert "simple pendulum" in fig._suptitle.get_text()
    labels = [ax.get_ylabel() for ax in _panels(fig)]
    assert labels == ["angle [rad]", "angular rate [rad/s]", "E - E(t0) [J]"]
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"
    pyplot().close(fig)


def test_lengths_and_angles_on_separate_axes():
    res = _run("n-link-pendulum-on-cart", 1.0, n=2)
    units = res.model.state_units
    fig = res.plot()
    _check_figure(fig)
    for ax in _panels(fig)[:4]:
        names = [line.get_label() for line in ax.get_lines()]
        assert len({units[n] for n in names}) == 1, names
        assert f"[{units[names[0]]}]" in ax.get_ylabel()
    # a state's colour is the same wherever it is drawn; q_k and u_k share it
    colors = {line.get_label(): line.get_color() for ax in fig.axes for line in ax.get_lines()}
    assert colors["q1"] == colors["u1"] and colors["q0"] != colors["q1"]
    pyplot().close(fig)


def test_legends_beside_the_axes():
    res = _run("chain3d", 0.5, n=5)
    fig = res.plot()
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for ax in _panels(fig):
        legend = ax.get_legend()
        assert legend is not None
        assert legend.get_window_extent(renderer).x0 >= ax.get_window_extent(renderer).x1
    pyplot().close(fig)


def test_residual_exactly_zero_is_not_drawn_at_1e_minus_300():
    """A residual that starts at exactly 0: a log axis floored just below the data
    (with a note), or a linear one when everything is 0."""
    res = _run("four-bar", 0.5, n=21)
    rows = res.constraint_residuals.shape[0]
    residual = np.tile(np.logspace(-13, -9, res.t.size), (rows, 1))
    residual[:, 0] = 0.0
    res.__dict__["_constraint_residuals"] = residual
    fig = res.plot()
    _check_figure(fig)
    logs = [ax for ax in _panels(fig) if ax.get_yscale() == "log"]
    assert len(logs) == 2 and all("constraint" in ax.get_ylabel() for ax in logs)
    for ax in logs:
        assert ax.get_ylim()[0] > 1e-16
        assert any("exact zeros drawn at 1e-14" in t.get_text() for t in ax.texts)
    assert all(ax.get_ylabel().endswith("[m]") or ax.get_ylabel().endswith("[m/s]")
               for ax in logs)
    res.__dict__["_constraint_residuals"] = np.zeros_like(residual)
    fig2 = res.plot()
    _check_figure(fig2)
    assert not [ax for ax in _panels(fig2) if ax.get_yscale() == "log"]
    pyplot().close(fig)
    pyplot().close(fig2)


def test_log_scale_rule():
    assert log_scale_ok([0.0, 1e-12, 1e-6])
    assert not log_scale_ok([0.0, 0.0])
    assert not log_scale_ok([1.0, 2.0, 50.0])  # under two decades
    assert not log_scale_ok([-1e-9, 1e-3])


def test_spinning_wheels_do_not_swamp_lean():
    """The bicycle's wheel angles (large) leave lean and steer a panel of their own."""
    t = np.linspace(0.0, 1.0, 11)
    names = ("q4", "q6", "q7")

    class _Model:
        n_q, n_u, title, name = 3, 0, "toy", "toy"
        state_units = dict.fromkeys(names, "rad")
        constraint_units = ([], [])
        n_q_dep = n_u_dep = 0

    class _Result:
        model, state_names, success, method = _Model(), names, True, "RK45"
        energy, constraint_forces, contact_forces, impacts = None, {}, {}, []
        constraint_residuals = np.zeros((0, t.size))
        data = {"q4": 0.1 * np.sin(t), "q6": 50.0 * t, "q7": 0.05 * np.cos(t)}

        def __getitem__(self, key):
            return self.data[key]

    _Result.t = t
    from kanedyn.analysis import plot_result
    fig = plot_result(_Result())
    groups = [sorted(line.get_label() for line in ax.get_lines()) for ax in _panels(fig)]
    assert groups == [["q4", "q7"], ["q6"]]
    pyplot().close(fig)


# ----------------------------------------------------------- compare plots
def _comparison():
    t = np.linspace(0.0, 1.0, 11)
    methods = ("kane", "lagrange", "augmented")
    q = {"kane": np.vstack([t, np.sin(t)]), "lagrange": np.vstack([t + 1e-9 * t, np.sin(t)]),
         "augmented": np.vstack([t + 1e-3 * t, np.sin(t) + 1e-4 * t])}
    err = {m: 1e-12 * (k + 1) * (1 + t) for k, m in enumerate(methods)}
    return FormulationComparison(
        model="toy", methods=methods, t=t, coordinates=q, deviation={}, newton_euler={},
        position_error=err, velocity_error=err,
        energy_error={m: 1e-10 * (k + 1) * t for k, m in enumerate(methods)},
        operations={}, cpu_time={}, evaluations={}, projections={}, messages={},
        units={"coordinates": {"x": "m", "theta": "rad"}, "position": ["m"],
               "velocity": ["m/s"]})


def test_compare_colours_match_the_legend_in_every_panel():
    """Each method keeps its colour in every panel, the deviation panels included
    (where the reference, identically zero, is not drawn)."""
    cmp = _comparison()
    fig = cmp.plot()
    _check_figure(fig)
    legend = fig.legends[0]
    colour_of = {text.get_text().split(" ")[0]: handle.get_color()
                 for text, handle in zip(legend.get_texts(), legend.legend_handles)}
    assert set(colour_of) == set(cmp.methods)
    assert len(set(colour_of.values())) == 3
    deviation = [ax for ax in _panels(fig) if ax.get_ylabel().startswith("max |q")]
    assert [ax.get_ylabel() for ax in deviation] == ["max |q - q_kane|, lengths [m]",
                                                     "max |q - q_kane|, angles [rad]"]
    drawn = 0
    for ax in _panels(fig):
        for line in ax.get_lines():
            if line.get_label() in colour_of:
                assert line.get_color() == colour_of[line.get_label()], (
                    ax.get_ylabel(), line.get_label())
                drawn += 1
    # 3 methods in the constraint and energy panels; lagrange and augmented in the
    # lengths' deviation, augmented alone in the angles' (lagrange's is exactly 0)
    assert drawn == 3 * 3 + 2 + 1
    pyplot().close(fig)


def test_work_precision_diagram(tmp_path):
    wp = WorkPrecision(model="toy", methods=("kane", "lagrange"), tolerances=(1e-6, 1e-8),
                       error={"kane": np.array([1e-6, 1e-8]),
                              "lagrange": np.array([2e-6, np.nan])},
                       cpu_per_second={"kane": np.array([0.01, 0.02]),
                                       "lagrange": np.array([0.03, 0.05])},
                       target=1e-7, error_unit="[m, rad]")
    fig = wp.plot(tmp_path / "wp.png")
    assert (tmp_path / "wp.png").read_bytes()[:4] == b"\x89PNG"
    ax = fig.axes[0]
    assert ax.get_xscale() == ax.get_yscale() == "log"
    assert "[m, rad]" in ax.get_xlabel() and "[s/s]" in ax.get_ylabel()
    lines = {line.get_label(): line for line in ax.get_lines()}
    np.testing.assert_allclose(lines["kane"].get_xdata(), [1e-6, 1e-8])
    np.testing.assert_allclose(lines["lagrange"].get_xdata(), [2e-6])  # failed run left out
    assert any("lagrange at rtol 1e-08" in t.get_text() for t in ax.texts)
    pyplot().close(fig)


@pytest.mark.slow
def test_compare_cli_writes_the_work_precision_diagram(tmp_path):
    from kanedyn.cli import main
    code = main(["compare", "nonholonomic-particle", "--methods", "kane,lagrange",
                 "--t-end", "0.5", "--plot", "--work-precision", "--out", str(tmp_path)])
    assert code == 0
    for name in ("compare-nonholonomic-particle.png",
                 "work-precision-nonholonomic-particle.png"):
        assert (tmp_path / name).read_bytes()[:4] == b"\x89PNG"


# ------------------------------------------------------------------- bicycle
@pytest.mark.slow
def test_bicycle_modes_named(bicycle, tmp_path):
    """Weave (the oscillatory pair), capsize (the real one crossing zero near 6 m/s),
    caster (the large negative one), against the published stable speeds."""
    from kanedyn.models import eigenvalues_vs_speed
    _, _, model = bicycle
    speeds = np.linspace(0.0, 10.0, 101)
    modes = bicycle_modes(eigenvalues_vs_speed(model, speeds))
    weave, capsize, caster = modes["weave"], modes["capsize"].real, modes["caster"].real
    assert not np.any(np.isnan(capsize)) and not np.any(np.isnan(caster))
    assert np.all(caster < capsize) and np.all(caster[:, None] < weave.real)
    fast = speeds >= 1.0
    assert np.all(np.abs(weave[fast, 0].imag) > 0.5)  # oscillatory
    assert np.all(weave[fast, 0] == np.conj(weave[fast, 1]))
    # the published speeds (Meijaard et al. 2007): weave stable above 4.292, capsize
    # unstable above 6.024
    assert np.all((weave[:, 0].real < 0) == (speeds > 4.29238253634111))
    assert np.all((capsize > 0) == (speeds > 6.02426201538837))
    fig = plot_bicycle_eigenvalues(speeds, eigenvalues_vs_speed(model, speeds),
                                   stable=(4.2924, 6.0243), path=tmp_path / "eig.png")
    labels = fig.axes[0].get_legend_handles_labels()[1]
    for name in ("weave, Re", "capsize", "caster"):
        assert name in labels
    assert any(label.startswith("self-stable") for label in labels)
    assert (tmp_path / "eig.png").exists()
    pyplot().close(fig)


# ------------------------------------------------------------ big models
def _size_px(fig):
    width, height = fig.get_size_inches() * 120  # the dpi res.plot saves at
    return round(width), round(height)


def test_oc3_spar_plot_grouped_with_units_and_noise_named():
    """A 16-state model: coordinates left, speeds right, every unit known (the
    angles and tower modes declared by the model), the states that stay at
    numerical-noise level left out and named in the title, on one screen."""
    definition = kd.models.build("oc3-spar")
    model = definition.numeric(backend="numpy")
    res = kd.simulate(model, (0.0, 5.0), definition.initial(model),
                      t_eval=np.linspace(0.0, 5.0, 51))
    fig = res.plot()
    _check_figure(fig)
    assert _size_px(fig)[0] <= 1600 and _size_px(fig)[1] <= 1000
    panels = [(ax.get_ylabel(), sorted(line.get_label() for line in ax.get_lines()))
              for ax in _panels(fig)]
    assert not any("[?]" in label for label, _ in panels)
    assert ("angle [rad]", ["pitch"]) in panels
    assert ("tower modes [m]", ["eta_tower_2"]) in panels
    assert ("tower mode rates [m/s]", ["zeta_tower_2"]) in panels
    assert len(panels) == 9  # 4 coordinate panels, 4 speed panels, the energy
    quiet = ("sway", "roll", "yaw", "eta_tower_1", "u_sway", "u_roll", "u_yaw",
             "zeta_tower_1")
    drawn = {name for _, names in panels for name in names}
    title = fig._suptitle.get_text()
    assert "within 1e-12 throughout" in title
    for name in quiet:
        assert np.max(np.abs(res[name])) <= 1e-12 and name not in drawn and name in title
    assert {"surge", "heave", "pitch", "eta_tower_2"} <= drawn
    # coordinates in the left column, speeds in the right
    for ax in _panels(fig):
        names = [line.get_label() for line in ax.get_lines()]
        column = ax.get_subplotspec().colspan.start
        if set(names) <= set(res.state_names):
            assert column == (0 if names[0] in res.model.state_names[:model.n_q] else 1)
    # asked for by name, a quiet state is drawn
    fig2 = res.plot(states=["roll", "pitch"])
    assert sorted(line.get_label() for ax in _panels(fig2) for line in ax.get_lines()
                  if line.get_label() in ("roll", "pitch")) == ["pitch", "roll"]
    pyplot().close(fig)
    pyplot().close(fig2)


def test_spin_up_beam_drive_torque_in_newton_metres():
    res = _run("spin-up-beam", 1.0, n=11)
    res = kd.simulate(res.model, (0.0, 1.0), res.initial_state,
                      t_eval=np.linspace(0.0, 1.0, 11), constraint_forces=True)
    fig = res.plot()
    _check_figure(fig)
    (torque,) = [ax for ax in _panels(fig) if "tau" in
                 [line.get_label() for line in ax.get_lines()]]
    assert torque.get_ylabel() == "constraint torque [N m]"
    assert [ax.get_ylabel() for ax in _panels(fig)].count("beam modes [m]") >= 1
    assert _size_px(fig)[0] <= 1600 and _size_px(fig)[1] <= 1000
    pyplot().close(fig)


def test_title_names_the_model_once():
    fig = _run("pendulum", 0.5, n=5).plot()
    assert fig._suptitle.get_text().splitlines()[0] == \
        "pendulum: simple pendulum (point mass on a massless rod)"
    assert _size_px(fig) <= (1080, 1000)
    pyplot().close(fig)
