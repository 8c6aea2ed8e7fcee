"""The figure of ``kanedyn compare nonholonomic``: each formulation's motion beside
its Newton-Euler residual.  The curves are read back from the figure and compared
with what the comparison computed (the check's residual arrays)."""

import numpy as np
import pytest

import kanedyn.analysis as analysis
from kanedyn.analysis import NONHOLONOMIC_EXAMPLES, compare_formulations, pyplot
from kanedyn.cli import main


def _drawn(ax):
    return {line.get_label(): line for line in ax.get_lines()}


def _assert_residuals_drawn(ax, cmp, kind):
    """The panel's curves are the largest |residual| over the bodies at each time."""
    lines = _drawn(ax)
    assert ax.get_ylabel() == f"N-E {kind} residual [{'N' if kind == 'force' else 'N m'}]"
    for m in cmp.methods:
        check = cmp.newton_euler[m]
        residual = check.force_residual if kind == "force" else check.moment_residual
        expected = np.max(np.abs(residual), axis=(1, 2))
        y = np.asarray(lines[m].get_ydata(), dtype=float)
        np.testing.assert_array_equal(lines[m].get_xdata(), check.t)
        positive = expected > 0
        np.testing.assert_array_equal(y[positive], expected[positive])
        if ax.get_yscale() == "log":  # exact zeros at one floor below every value
            assert np.all(y > 0) and np.all(y[~positive] < np.min(expected[positive]))


def test_compare_nonholonomic_writes_the_figure(tmp_path, monkeypatch, capsys):
    real = analysis.plot_newton_euler_residuals
    drawn = []

    def keep(comparisons, path=None):
        fig = real(comparisons, path)
        drawn.append((list(comparisons), fig, path))
        return fig

    monkeypatch.setattr(analysis, "plot_newton_euler_residuals", keep)
    code = main(["compare", "nonholonomic", "--t-end", "0.3", "--quiet",
                 "--out", str(tmp_path)])
    assert code == 0
    path = tmp_path / "compare-nonholonomic.png"
    assert path.read_bytes()[:4] == b"\x89PNG"
    assert f"motion and Newton-Euler residuals of every example: {path}" in \
        capsys.readouterr().out
    (comparisons, fig, written), = drawn
    assert written == path
    assert [c.model for c in comparisons] == list(NONHOLONOMIC_EXAMPLES)
    axes = np.array(fig.axes).reshape(len(comparisons), 3)
    for row, cmp in zip(axes, comparisons):
        assert cmp.methods == ("kane", "lagrange", "augmented")
        # the paths: x and y of each formulation
        lines = _drawn(row[0])
        names = list(cmp.units["coordinates"])
        for m in cmp.methods:
            q = cmp.coordinates[m]
            np.testing.assert_array_equal(lines[m].get_xdata(), q[names.index("x")])
            np.testing.assert_array_equal(lines[m].get_ydata(), q[names.index("y")])
        assert (row[0].get_xlabel(), row[0].get_ylabel()) == ("x [m]", "y [m]")
        _assert_residuals_drawn(row[1], cmp, "force")
        if cmp.model == "nonholonomic-particle":  # a particle: no moments
            assert not row[2].get_lines()
            assert "zero at every time" in row[2].texts[0].get_text()
        else:
            _assert_residuals_drawn(row[2], cmp, "moment")
        # the augmented Lagrangean's failure shows: residuals far above the others'
        ne = cmp.newton_euler
        assert ne["augmented"].max > 1e6 * max(ne["kane"].max, ne["lagrange"].max, 1e-300)
    # one colour per formulation, the legend's, in every panel
    legend = fig.legends[0]
    colour_of = {text.get_text().split(" ")[0]: handle.get_color()
                 for text, handle in zip(legend.get_texts(), legend.legend_handles)}
    assert len({colour_of[m] for m in ("kane", "lagrange", "augmented")}) == 3
    for ax in fig.axes:
        for line in ax.get_lines():
            if line.get_label() in colour_of and line.get_label() != "start":
                assert line.get_color() == colour_of[line.get_label()]
    pyplot().close(fig)


def test_model_without_a_plane_path():
    """The four-bar has no x, y: the coordinate on which the formulations part most."""
    cmp = compare_formulations("four-bar", ("kane", "augmented"), t_end=0.3, n_points=31)
    fig = analysis.plot_newton_euler_residuals([cmp])
    first = fig.axes[0]
    assert first.get_xlabel() == "t [s]"
    name = first.get_ylabel().split(" ")[0]
    names = list(cmp.units["coordinates"])
    k = names.index(name)
    spread = [np.max(np.abs(cmp.coordinates[m] - cmp.coordinates["kane"]), axis=1)
              for m in cmp.methods]
    assert k == int(np.argmax(np.max(spread, axis=0)))
    np.testing.assert_array_equal(_drawn(first)["augmented"].get_ydata(),
                                  cmp.coordinates["augmented"][k])
    pyplot().close(fig)


def test_no_comparison_is_refused():
    with pytest.raises(ValueError, match="at least one comparison"):
        analysis.plot_newton_euler_residuals([])
