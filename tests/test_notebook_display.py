"""Notebook displays: _repr_html_ of results and models, _repr_latex_ of equations."""

import base64
from html.parser import HTMLParser

import numpy as np
import pytest

import kanedyn as kd


class _Page(HTMLParser):
    """Collects the text of table cells, the images and checks that tags close."""

    VOID = {"img", "br", "hr"}

    def __init__(self):
        super().__init__()
        self.stack, self.cells, self.images, self._cell = [], [], [], None

    def handle_starttag(self, tag, attrs):
        if tag in self.VOID:
            if tag == "img":
                self.images.append(dict(attrs))
            return
        self.stack.append(tag)
        if tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag):
        if tag in self.VOID:
            return
        assert self.stack and self.stack[-1] == tag, (tag, self.stack)
        self.stack.pop()
        if tag in ("td", "th"):
            self.cells.append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def _parse(text):
    page = _Page()
    page.feed(text)
    page.close()
    assert page.stack == []
    return page


def _pairs(cells):
    return dict(zip(cells[::2], cells[1::2]))


@pytest.fixture(scope="module")
def four_bar():
    definition = kd.models.build("four-bar")
    eom = definition.derive()
    model = definition.numeric(eom)
    res = kd.simulate(model, (0.0, 1.0), definition.initial(model),
                      t_eval=np.linspace(0.0, 1.0, 51))
    return eom, model, res


def test_result_html(four_bar):
    _, model, res = four_bar
    text = res._repr_html_()
    assert len(text) < 80_000  # small: a short table and a small plot
    page = _parse(text)
    cells = page.cells
    info = _pairs(cells)
    assert info["success"] == "True" and info["points"] == "51"
    assert info["t"] == "0 .. 1 s"
    assert info["rhs evaluations"] == str(res.nfev)
    assert float(info["energy drift (relative)"]) == pytest.approx(res.energy_drift(),
                                                                   rel=1e-2)
    assert float(info["max constraint residual"]) == pytest.approx(
        np.max(res.constraint_residual), rel=1e-2)
    for i, name in enumerate(model.state_names):  # the final state
        k = cells.index(name)
        assert float(cells[k + 1]) == pytest.approx(res.y[i, -1], rel=1e-5)
    (image,) = page.images
    assert image["src"].startswith("data:image/png;base64,")
    png = base64.b64decode(image["src"].split(",", 1)[1])
    assert png[:8] == b"\x89PNG\r\n\x1a\n"


def test_result_html_of_a_contact_run():
    definition = kd.models.build("bouncing-ball")
    model = definition.numeric(definition.derive())
    res = kd.simulate(model, (0.0, 0.8), definition.initial(model),
                      t_eval=np.linspace(0.0, 0.8, 81))
    info = _pairs(_parse(res._repr_html_()).cells)
    assert info["impacts"] == str(len(res.impacts)) and len(res.impacts) >= 1
    assert info["energy balance error"].endswith(" J")


def test_equations_html_and_latex(four_bar):
    eom, _, _ = four_bar
    info = _pairs(_parse(eom._repr_html_()).cells)
    assert info["coordinates q"] == "3 (2 dependent)"
    assert info["speeds u"] == "3 (2 dependent)"
    assert info["configuration constraints"] == "2" and info["velocity constraints"] == "2"
    assert info["constants"] == "g, l_a, l_b, l_c, l_d, m_a, m_b, m_c"
    counts = eom.operation_counts()
    assert info["intermediates (right-hand side)"] == str(counts["intermediates"])
    assert info["operations (right-hand side)"] == str(counts["all"])
    latex = eom._repr_latex_()
    assert latex.startswith("$\\displaystyle \\begin{aligned}") and latex.endswith("$")


def test_small_equations_html_carries_their_latex():
    definition = kd.models.build("pendulum")
    eom = definition.derive()
    text = eom._repr_html_()
    assert "$$\\begin{aligned}" in text and "\\sin" in text
    _parse(text)


def test_numeric_model_html(four_bar):
    _, model, _ = four_bar
    page = _parse(model._repr_html_())
    info = _pairs(page.cells)
    assert info["backend"] == "numpy" and info["scheme"] == "elimination"
    assert info["constraints"] == "2 configuration, 2 velocity"
    for name, value in model.constants.items():
        assert float(info[name]) == pytest.approx(value, rel=1e-6)


def test_html_escapes_names():
    from kanedyn._html import table
    page = _parse(table([("<b>", "a & b")]))
    assert page.cells == ["<b>", "a & b"]
