"""Mode-shape and deflection figures of flexible members.

The drawn line data is compared with what it claims to show: the columns of
the reduction basis, the natural modes of the full finite-element model
(a Craig–Bampton basis with every fixed-interface mode spans the whole
model, so the reduced member's natural modes are the full model's), and the
node positions SymPy gives for ``FlexibleBody.node_point`` at the simulated
modal coordinates.
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn import OptionError
from kanedyn.analysis import deformed_nodes, member_arc_length, plot_deflection, pyplot

pytest.importorskip("matplotlib")

LENGTH = 1.0


def _arm(n_elements=5, **overrides):
    props = dict(mass_per_length=2.0, EA=1e7, GJ=1e3, EI_y=40.0, EI_z=20.0,
                 polar_inertia=1e-4)
    props.update(overrides)
    return kd.flexible.BeamMember.uniform("arm", LENGTH, n_elements=n_elements, **props)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    pyplot().close("all")


@pytest.fixture(scope="module")
def reduced():
    return _arm().craig_bampton(n_modes=3)


@pytest.fixture(scope="module")
def run(reduced):
    """A cantilever on a hub turned by a torque about N.z: (body, frame, result)."""
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    theta, omega = me.dynamicsymbols("theta omega")
    B = N.orientnew("B", "Axis", [theta, N.z])
    B.set_ang_vel(N, omega * N.z)
    arm = kd.FlexibleBody("arm", B, O, reduced)
    hub = me.RigidBody("hub", O, B, 1.0, (me.inertia(B, 0, 0, 0.05), O))
    torque = sm.Symbol("T")
    eom = kd.kane(frame=N, q_ind=[theta, *arm.q], u_ind=[omega, *arm.u],
                  kd_eqs=[theta.diff() - omega, *arm.kd_eqs], bodies=[hub, arm],
                  loads=[(B, torque * N.z)])
    model = eom.numeric(constants={torque: 2.0})
    res = kd.simulate(model, (0.0, 0.5), np.zeros(model.n_states),
                      t_eval=np.linspace(0.0, 0.5, 51), rtol=1e-9, atol=1e-11)
    assert res.success
    return arm, B, res


def _panels(fig):
    return [ax for ax in fig.axes if ax.get_visible()]


def _lines(ax):
    return {line.get_label(): line for line in ax.get_lines()}


def _translations(member, shape):
    return np.asarray(shape).reshape(member.n_nodes, 6)[:, :3]


# ------------------------------------------------------------- mode shapes
def test_uncoupled_natural_modes_are_the_basis_columns(reduced):
    """Without interface nodes the fixed-interface modes are the natural modes."""
    fig = kd.flexible.plot_mode_shapes(reduced)
    panels = _panels(fig)
    assert len(panels) == 3
    arc = np.linspace(0.0, LENGTH, reduced.n_nodes)
    for j, ax in enumerate(panels):
        expected = _translations(reduced, reduced.modes[:, j])
        lines = _lines(ax)
        drawn = [name for name in lines if name.startswith("u_")]
        # bending in x-y shows u_y only, in x-z u_z only
        plane = reduced.mode_names[j].split("_")[1]
        assert drawn == [f"u_{plane[1]}"]
        axis = "xyz".index(plane[1])
        np.testing.assert_allclose(lines[drawn[0]].get_xdata(), arc, atol=1e-12)
        np.testing.assert_allclose(lines[drawn[0]].get_ydata(), expected[:, axis],
                                   rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(lines["undeformed"].get_ydata(), 0.0)
        title = ax.get_title()
        assert f"natural mode {j + 1}" in title
        assert f"{reduced.reduced_frequencies[j]:.4g} Hz" in title
        assert reduced.mode_names[j] in title
        assert ax.get_ylabel() == "displacement [m]"
    assert "[m]" in panels[-1].get_xlabel() and "arc length" in panels[-1].get_xlabel()
    assert "'arm'" in fig._suptitle.get_text()


def test_natural_modes_of_a_complete_basis_are_the_full_models():
    """Craig–Bampton with all 18 fixed-interface modes + the tip's 6 constraint modes
    spans the clamped 4-element beam: its natural modes are the full model's."""
    member = _arm(n_elements=4, GJ=2.0)
    reduced = member.craig_bampton(interface_nodes=[-1], n_modes=18)
    full_hz, full_modes = member.natural_modes(24, supports={0: "all"})
    modes = [1, 2, 3, 6]
    fig = kd.flexible.plot_mode_shapes(reduced, modes=modes)
    panels = _panels(fig)
    assert len(panels) == len(modes)
    for ax, number in zip(panels, modes):
        j = number - 1
        assert f"{full_hz[j]:.4g} Hz" in ax.get_title()
        shape = full_modes[:, j].reshape(-1, 6)
        rotation = np.max(np.abs(shape[:, :3])) < 1e-6 * np.max(np.abs(shape[:, 3:]))
        part = shape[:, 3:] if rotation else shape[:, :3]
        tip = np.argmax(np.linalg.norm(part, axis=1))
        part = part / (np.linalg.norm(part[tip])
                       * np.sign(part[tip, np.argmax(np.abs(part[tip]))]))
        symbol = "θ" if rotation else "u"
        lines = _lines(ax)
        drawn = [name for name in lines if name != "undeformed"]
        assert drawn, ax.get_title()
        for name in drawn:
            assert name[0] == symbol
            np.testing.assert_allclose(lines[name].get_ydata(), part[:, "xyz".index(name[-1])],
                                       atol=1e-7)
        assert ax.get_ylabel() == ("rotation [rad]" if rotation else "displacement [m]")
    # the torsion mode (GJ small) shows a rotation about the beam's axis
    torsion = [ax for ax in panels if "θ_x" in _lines(ax)]
    assert torsion, [ax.get_title() for ax in panels]


def test_coordinate_shapes_are_the_columns_of_the_basis():
    reduced = _arm(n_elements=4).craig_bampton(interface_nodes=[-1], n_modes=2)
    names = ["constraint_4_uy", 1]
    fig = kd.flexible.plot_mode_shapes(reduced, modes=names, kind="coordinates")
    panels = _panels(fig)
    for ax, j in zip(panels, [reduced.mode_names.index("constraint_4_uy"), 0]):
        expected = _translations(reduced, reduced.modes[:, j])
        lines = _lines(ax)
        assert reduced.mode_names[j] in ax.get_title() and "Hz" in ax.get_title()
        assert f"coordinate {j + 1}" in ax.get_title()
        for name, line in lines.items():
            if name.startswith("u_"):
                np.testing.assert_allclose(line.get_ydata(), expected[:, "xyz".index(name[-1])],
                                           atol=1e-12)
        assert "u_y" in lines
        assert "[m/m]" in ax.get_ylabel()
    # the constraint mode is coupled to the normal modes: the title says so
    assert "uncoupled" in panels[0].get_title()


def test_mode_shapes_saved_as_png(reduced, tmp_path):
    path = tmp_path / "modes.png"
    kd.flexible.plot_mode_shapes(reduced, modes=2, path=path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("modes, words", [
    (0, ["mode 0 does not exist", "'arm'", "3 natural modes", "1..3"]),
    ([1, 4], ["mode 4 does not exist", "1..3"]),
    ("bending_xy_1", ["kind='coordinates'"]),
    ([1.5], ["counted from 1"]),
    ([], ["empty"]),
])
def test_mode_shapes_bad_modes(reduced, modes, words):
    with pytest.raises(OptionError) as info:
        kd.flexible.plot_mode_shapes(reduced, modes=modes)
    for word in words:
        assert word in str(info.value)


def test_mode_shapes_bad_input(reduced):
    with pytest.raises(OptionError, match="no mode named 'twist_1'.*bending_xy_1"):
        kd.flexible.plot_mode_shapes(reduced, modes="twist_1", kind="coordinates")
    with pytest.raises(OptionError, match="kind must be one of natural, coordinates"):
        kd.flexible.plot_mode_shapes(reduced, kind="normal")
    with pytest.raises(OptionError, match="ReducedMember.*BeamMember"):
        kd.flexible.plot_mode_shapes(_arm())


def test_arc_length_follows_a_bent_member():
    member = kd.flexible.BeamMember("bent", {"arc": [0.0, 2.0], "mass_per_length": [1.0, 1.0],
                                             "EA": [1e6, 1e6], "GJ": [1e3, 1e3], "EI_y": [1e3, 1e3],
                                             "EI_z": [1e3, 1e3]},
                                    polyline=[[0, 0, 0], [1, 0, 0], [1, 1, 0]])
    assert np.allclose(member_arc_length(member), [0.0, 1.0, 2.0])


# -------------------------------------------------------------- deflection
def _node_positions(body, frame, res, k_time):
    """Node positions from SymPy's node_point expressions at output k_time."""
    values = {q: res[str(q.func)][k_time] for q in body.q}
    out = []
    for k in range(body.member.n_nodes):
        r = body.node_point(k).pos_from(body.origin).to_matrix(frame)
        out.append([float(c.subs(values)) for c in r])
    return np.array(out)


def test_deflection_is_nodes_plus_modes_plus_foreshortening(run):
    arm, B, res = run
    times = [0.1, 0.25, 0.5]
    fig = res.plot_deflection(arm, times, scale=1)
    (ax,) = _panels(fig)  # the torque about z bends the arm in x-y only
    assert ax.get_xlabel().startswith("x [m]") and ax.get_ylabel() == "y [m]"
    lines = _lines(ax)
    labels = [name for name in lines if name.startswith("t = ")]
    assert len(labels) == 3
    for time, label in zip(times, labels):
        k = int(np.argmin(np.abs(res.t - time)))
        expected = _node_positions(arm, B, res, k)
        line = lines[label]
        np.testing.assert_allclose(line.get_xdata(), expected[:, 0], atol=1e-12)
        np.testing.assert_allclose(line.get_ydata(), expected[:, 1], atol=1e-12)
        assert label.startswith(f"t = {time:.4g} s")
        tip = expected[-1, 1]
        assert f"tip u_y = {tip * 1e3:.3g} mm" in label
        # the foreshortening is drawn: the tip is pulled in along x
        assert expected[-1, 0] < LENGTH - 1e-6
    np.testing.assert_allclose(lines["undeformed"].get_ydata(), 0.0)
    title = fig._suptitle.get_text()
    assert "'arm'" in title and "×" not in title and "foreshortening" in title


def test_deflection_scale_is_applied_and_stated(run):
    arm, B, res = run
    k = 30
    fig = res.plot_deflection(arm, res.t[k], scale=10)
    (ax,) = _panels(fig)
    line = next(line for name, line in _lines(ax).items() if name.startswith("t = "))
    nodes = np.asarray(arm.member.nodes)
    expected = nodes + 10 * (_node_positions(arm, B, res, k) - nodes)
    np.testing.assert_allclose(line.get_ydata(), expected[:, 1], atol=1e-12)
    assert "deflection drawn × 10" in fig._suptitle.get_text()
    assert ax.get_ylabel() == "y [m], deflection × 10"


def test_automatic_scale(run):
    arm, _, res = run
    fig = plot_deflection(res, arm, [0.1, 0.3])
    text = fig._suptitle.get_text()
    scale = float(text.split("×")[1].split(";")[0])
    mantissa = scale / 10 ** np.floor(np.log10(scale))
    assert min(abs(mantissa - m) for m in (1, 2, 5)) < 1e-9
    (ax,) = _panels(fig)
    drawn = max(np.max(np.abs(line.get_ydata())) for name, line in _lines(ax).items()
                if name.startswith("t = "))
    assert 0.25 * LENGTH / 2.5 < drawn <= 0.25 * LENGTH * (1 + 1e-12)


def test_deflection_between_output_times_is_interpolated(run):
    arm, _, res = run
    t = 0.5 * (res.t[10] + res.t[11])
    fig = res.plot_deflection(arm, [t], scale=1)
    eta = [0.5 * (res[str(q.func)][10] + res[str(q.func)][11]) for q in arm.q]
    (ax,) = _panels(fig)
    line = next(line for name, line in _lines(ax).items() if name.startswith("t = "))
    np.testing.assert_allclose(line.get_ydata(), deformed_nodes(arm, eta)[:, 1], atol=1e-12)


def test_deflection_uses_the_dense_solution(run):
    arm, _, res = run
    dense = kd.simulate(res.model, (0.0, 0.5), res.initial_state, dense_output=True,
                        rtol=1e-9, atol=1e-11)
    t = 0.123
    fig = dense.plot_deflection(arm, [t], scale=1)
    rows = [dense.state_names.index(str(q.func)) for q in arm.q]
    eta = dense.sol(t)[rows]
    (ax,) = _panels(fig)
    line = next(line for name, line in _lines(ax).items() if name.startswith("t = "))
    np.testing.assert_allclose(line.get_ydata(), deformed_nodes(arm, eta)[:, 1], atol=1e-12)


def test_linear_body_draws_no_second_order_term(run, reduced):
    arm, B, _ = run
    linear = kd.FlexibleBody("arm", B, arm.origin, reduced, stiffening=False)
    eta = np.array([0.05, -0.02, 0.01])
    expected = reduced.nodes + reduced.modes.reshape(reduced.n_nodes, 6, -1)[:, :3] @ eta
    np.testing.assert_allclose(deformed_nodes(linear, eta), expected, atol=1e-15)
    assert np.max(np.abs(deformed_nodes(arm, eta) - expected)) > 1e-5


def test_deflection_saved_as_png(run, tmp_path):
    arm, _, res = run
    path = tmp_path / "deflection.png"
    res.plot_deflection(arm, [0.2], path=path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_deflection_bad_input(run, reduced):
    arm, B, res = run
    with pytest.raises(OptionError, match=r"time 0\.6 s is outside the run \(0 s to 0\.5 s"):
        res.plot_deflection(arm, [0.2, 0.6])
    with pytest.raises(OptionError, match=r"time -0\.1 s is outside"):
        res.plot_deflection(arm, -0.1)
    other = kd.FlexibleBody("blade", B, arm.origin, reduced)
    with pytest.raises(OptionError, match="flexible body 'blade' is not in this simulation.*"
                                          "eta_blade_1"):
        res.plot_deflection(other, [0.2])
    with pytest.raises(OptionError, match="must be the FlexibleBody.*str"):
        res.plot_deflection("arm", [0.2])
    for scale in (0, -2, "big", float("nan")):
        with pytest.raises(OptionError, match="scale must be a positive number"):
            res.plot_deflection(arm, [0.2], scale=scale)
    with pytest.raises(OptionError, match="non-empty"):
        res.plot_deflection(arm, [])
    with pytest.raises(OptionError, match="finite"):
        res.plot_deflection(arm, [0.1, float("nan")])
    with pytest.raises(OptionError, match="times must be numbers"):
        res.plot_deflection(arm, ["soon"])


@pytest.mark.slow
def test_docs_example_draws_both_figures(tmp_path, monkeypatch):
    """The blocks of docs/flexible.md: the member, then the two figures."""
    import re
    from pathlib import Path
    text = (Path(__file__).resolve().parents[1] / "docs" / "flexible.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    figures = [b for b in blocks if "plot_mode_shapes" in b or "plot_deflection" in b]
    assert len(figures) == 2
    monkeypatch.chdir(tmp_path)
    namespace = {}
    for block in [blocks[0], *figures]:
        exec(compile(block, "docs/flexible.md", "exec"), namespace)
    for name in ("mode_shapes.png", "deflection.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "deflection drawn ×" in namespace["fig"]._suptitle.get_text()
