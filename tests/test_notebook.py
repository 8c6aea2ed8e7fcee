"""The notebook widget and the sliders: the widget's front end in a real headless
Chromium, without a Jupyter server, and the sliders' re-runs against the model.

The browser test loads the widget's ES module as anywidget does (from a
``blob:`` URL) into a page that hands it a minimal model object (``get``,
``set``, ``on``, ``off``, ``save_changes``, with ``set`` announcing
``change:NAME`` as Backbone's models do), then reads back what it drew: the
viewer's counts, screenshots before and after moving the time from Python,
the time the slider sends back (moved and let go), and a second scene drawn in the same view.
"""

import json

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.io._page import VIEWER_CSS, script_json
from test_viewer import CHROMIUM, _pixels

pytest.importorskip("anywidget", reason="the widget needs anywidget (the notebook extra)")


def _pendulum(l=1.0, points=81, t_end=2.0):
    definition = kd.models.build("pendulum")
    model = definition.numeric(backend="c").with_constants({"l": l})
    res = kd.simulate(model, (0, t_end), definition.initial(model),
                      t_eval=np.linspace(0, t_end, points), rtol=1e-9, atol=1e-9)
    assert res.success, res.message
    return res


def test_widget_carries_everything_and_draws_other_results():
    first = _pendulum()
    shown = first.widget(height=400)
    assert shown.height == 400 and shown.result is first
    scene = json.loads(shown.scene_json)
    assert len(scene["t"]) == 81 and scene["bodies"][0]["name"] == "bob"
    esm = shown._esm
    assert "export default" in esm and "const KD_THREE" in esm
    assert "http://" not in esm and "https://" not in esm  # three.js is inside, gzipped
    assert ".kd-viewer" in shown._css
    second = _pendulum(l=2.0, points=41)
    shown.draw(second)
    bob = np.array(json.loads(shown.scene_json)["bodies"][0]["position"]).reshape(-1, 3)
    np.testing.assert_allclose(np.linalg.norm(bob[:, :2], axis=1), 2.0, atol=1e-6)
    with pytest.raises(kd.OptionError, match="height must be"):
        first.widget(height=12.5)


def test_sliders_rerun_the_compiled_model():
    pytest.importorskip("ipywidgets", reason="the sliders need ipywidgets (the notebook extra)")
    shown = kd.interact(kd.models.build("pendulum"), (0, 1), sliders={"l": (0.5, 2.0)},
                        points=21)
    assert shown.model.backend == "c" and list(shown.sliders) == ["l"]
    before = shown.result
    shown.sliders["l"].value = 1.5  # as a user moving the slider
    assert dict(shown.model.constants)["l"] == 1.5 and shown.result is not before
    bob = np.array(json.loads(shown.widget.scene_json)["bodies"][0]["position"]).reshape(-1, 3)
    np.testing.assert_allclose(np.linalg.norm(bob[:, :2], axis=1), 1.5, atol=1e-6)
    # a longer pendulum swings slower: its angle lags the short one's
    res = shown.rerun(l=0.5)
    assert res["q"][-1] != pytest.approx(before["q"][-1], abs=1e-3)
    assert shown.sliders["l"].value == 0.5 and shown.seconds > 0
    assert "re-run and scene" in shown.status.value
    assert "application/vnd.jupyter.widget-view+json" in shown._repr_mimebundle_()


def test_a_run_that_stops_early_is_drawn_as_far_as_it_went():
    pytest.importorskip("ipywidgets", reason="the sliders need ipywidgets (the notebook extra)")
    # 50 s of motion cannot be computed within a microsecond: the run stops early
    shown = kd.interact(kd.models.build("pendulum"), (0, 50), sliders={"l": (0.5, 2.0)},
                        timeout=1e-6)
    assert not shown.result.success and shown.result.t[-1] < 50
    assert "the run stopped early</b>: the time limit" in shown.status.value
    assert json.loads(shown.widget.scene_json)["t"] == pytest.approx(list(shown.result.t))


def test_slider_mistakes_are_named():
    pytest.importorskip("ipywidgets", reason="the sliders need ipywidgets (the notebook extra)")
    definition = kd.models.build("pendulum")
    with pytest.raises(kd.OptionError, match="'L': not a constant of the model; its "
                                             "constants are g, l, m"):
        kd.interact(definition, (0, 1), sliders={"L": (0.5, 2.0)})
    with pytest.raises(kd.OptionError, match="value 1 lies outside"):
        kd.interact(definition, (0, 1), sliders={"l": (2.0, 3.0)})
    with pytest.raises(kd.OptionError, match="low < high"):
        kd.interact(definition, (0, 1), sliders={"l": (2.0, 0.5)})
    with pytest.raises(kd.OptionError, match="y0 is required"):
        kd.interact(definition.numeric(), (0, 1), sliders={"l": (0.5, 2.0)})
    shown = kd.interact(definition, (0, 1), sliders={"l": (0.5, 2.0)}, points=11)
    with pytest.raises(kd.OptionError, match=r"\['m'\] have no slider"):
        shown.rerun(m=2.0)
    with pytest.raises(kd.OptionError, match="outside its slider's range"):
        shown.rerun(l=5.0)


# ------------------------------------------------------------- in Chromium
#: a page standing in for Jupyter: a model object as anywidget's, the widget's module
#: imported from a blob: URL, render() called on #host
HOST = """<!DOCTYPE html>
<html><head><meta charset="utf-8"><style>body {{ margin: 0; }} {css}</style></head>
<body><div id="host"></div>
<script id="esm" type="application/json">{esm}</script>
<script id="state" type="application/json">{state}</script>
<script type="module">
const state = JSON.parse(document.getElementById("state").textContent);
const listeners = {{}};
const saved = [];
const model = {{
  get: (key) => state[key],
  set: (key, value) => {{ state[key] = value;
                         (listeners["change:" + key] || []).forEach((f) => f()); }},
  on: (name, f) => {{ (listeners[name] = listeners[name] || []).push(f); }},
  off: (name, f) => {{ listeners[name] = (listeners[name] || []).filter((g) => g !== f); }},
  save_changes: () => {{ saved.push({{ ...state }}); }},
}};
window.fake = {{ model, saved, listeners }};
const source = JSON.parse(document.getElementById("esm").textContent);
const url = URL.createObjectURL(new Blob([source], {{ type: "text/javascript" }}));
const widget = (await import(url)).default;
window.host = document.getElementById("host");
window.cleanup = await widget.render({{ model, el: window.host }});
</script></body></html>
"""

READY = "window.host && window.host.kanedynScene && window.host.kanedynScene.ready"


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="no chromium executable found (Debian: "
                    "apt-get install chromium); the widget is not tested in a browser")
def test_widget_front_end_in_headless_chromium(tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api",
                                   reason="the browser test needs playwright (the test extra)")
    shown = _pendulum().widget(height=420)
    longer = json.loads(shown.draw(_pendulum(l=2.0, points=41)).scene_json)
    state = {"scene_json": json.dumps(json.loads(shown.draw(_pendulum()).scene_json)),
             "time": 0.0, "height": 420}
    page_file = tmp_path / "host.html"
    page_file.write_text(HOST.format(css=VIEWER_CSS, esm=script_json(shown._esm),
                                     state=script_json(state)), encoding="utf-8")
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        try:
            page = browser.new_page(viewport={"width": 900, "height": 500})
            errors = []
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(page_file.as_uri())
            page.wait_for_function(READY, timeout=60_000)
            counts = page.evaluate("({...window.host.kanedynScene})")
            host = page.locator("#host")
            before = host.screenshot()
            # the time set from Python (a synced trait) moves the scene
            moved = page.evaluate(
                "window.fake.model.set('time', 0.5), window.host.kanedynScene.time")
            after = host.screenshot()
            # scrubbing: the time slider let go at its end sends that time back
            page.evaluate("""(() => { const s = window.host.querySelector('.kd-slider');
                s.value = '1000'; s.dispatchEvent(new Event('input'));
                s.dispatchEvent(new Event('change')); })()""")
            let_go = page.evaluate("window.fake.saved.map((s) => s.time)")
            # moved without letting go: sent once within 0.1 s
            page.evaluate("""(() => { const s = window.host.querySelector('.kd-slider');
                for (const v of ['400', '450', '500']) {
                  s.value = v; s.dispatchEvent(new Event('input')); } })()""")
            page.wait_for_function("window.fake.saved.length === 2", timeout=10_000)
            page.wait_for_timeout(300)
            sent = page.evaluate("window.fake.saved.map((s) => s.time)")
            # a new scene (the sliders' re-run) is drawn in the same view
            page.evaluate(f"window.fake.model.set('scene_json', {json.dumps(json.dumps(longer))})")
            page.wait_for_function("window.host.kanedynScene.scenes === 2", timeout=60_000)
            redrawn = page.evaluate("""({frames: window.host.kanedynScene.frames,
                time: window.host.kanedynScene.time,
                canvases: window.host.querySelectorAll('canvas').length,
                legend: window.host.querySelectorAll('.kd-legend > div').length,
                height: window.host.querySelector('.kd-viewer').getBoundingClientRect().height})""")
            page.evaluate("window.fake.model.set('time', 1.0)")
            longer_shot = host.screenshot()
            page.evaluate("window.cleanup()")
            left = page.evaluate("""Object.values(window.fake.listeners)
                .reduce((n, fs) => n + fs.length, 0)""")
            page.close()
        finally:
            browser.close()
    assert errors == []
    assert (counts["bodies"], counts["segments"], counts["frames"]) == (1, 1, 81)
    assert moved == pytest.approx(0.5)
    A, B = _pixels(before), _pixels(after)
    view = (slice(0, A.shape[0] - 60), slice(0, A.shape[1]))  # the 3D view, not the bar
    changed = np.any(np.abs(A[view] - B[view]) > 30, axis=-1)
    assert changed.sum() > 300 and changed.mean() < 0.2  # the bob and rod moved, only they
    assert let_go == [pytest.approx(2.0)]
    assert sent == [pytest.approx(2.0), pytest.approx(1.0)]
    assert redrawn == {"frames": 41, "time": pytest.approx(1.0), "canvases": 1, "legend": 1,
                       "height": 420}
    C = _pixels(longer_shot)
    assert np.any(np.abs(C[view] - B[view]) > 30, axis=-1).sum() > 300
    assert left == 0  # the widget stopped listening when taken away
