"""Benchmark (not a test): how long a slider's re-run and redraw take in a notebook.

For built-in models, ``kd.interact(definition, ...)`` (C backend, RK45, rtol =
atol = 1e-8 as ``kd.simulate``'s default, 201 frames) is driven by
``.rerun(name=value)``, alternating between two values of one constant, which
is what moving a slider does on the Python side:

* **simulate**: ``model.with_constants`` and ``kd.simulate`` (the compiled
  code reused: no compilation);
* **scene**: ``kanedyn.io.scene_data`` of the new result and its JSON text,
  sent to the widget;
* **front end** (with ``--browser``): in headless Chromium (software WebGL,
  SwiftShader), the time from the new scene text arriving at the widget's
  model to the first frame drawn (parse, build the three.js scene, render),
  measured in the page with ``performance.now()``; the page stands in for
  Jupyter as in ``tests/test_notebook.py``.

Wall time, minimum and median of ``--rounds`` re-runs.  The model is derived
and compiled before timing (the derivation cache makes later sessions quick).

Run: ``PYTHONPATH=src python benchmarks/bench_notebook.py [--rounds 7] [--browser]``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import kanedyn as kd
from kanedyn.io._page import VIEWER_CSS, script_json

#: model name -> (t_span, slider constant, two values it alternates between)
CASES = {
    "pendulum": ((0.0, 5.0), "l", (0.8, 1.2)),
    "chain3d": ((0.0, 5.0), "l", (0.4, 0.6)),
    "four-bar": ((0.0, 5.0), "l_a", (0.28, 0.32)),
    "whipple-bicycle": ((0.0, 5.0), "w", (1.0, 1.04)),
}


def python_side(name, rounds):
    """``{"simulate": [s], "scene": [s]}`` over the rounds, and the Interactive."""
    t_span, constant, values = CASES[name]
    low, high = min(values), max(values)
    shown = kd.interact(kd.models.build(name), t_span,
                        sliders={constant: (low - 0.1 * (high - low), high)})
    times = {"simulate": [], "scene": []}
    for k in range(rounds):
        started = time.perf_counter()
        model = shown._base.with_constants({constant: values[k % 2]})
        result = kd.simulate(model, t_span, shown._y0, t_eval=shown._t_eval)
        middle = time.perf_counter()
        shown.widget.draw(result)
        times["simulate"].append(middle - started)
        times["scene"].append(time.perf_counter() - middle)
        assert result.success, result.message
    return times, shown


def browser_side(shown, rounds):
    """Seconds from a new scene text to its first frame, per round, in Chromium."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from test_notebook import HOST, READY
    from test_viewer import CHROMIUM
    from playwright.sync_api import sync_playwright
    import tempfile
    scene = shown.widget.scene_json
    state = {"scene_json": scene, "time": 0.0, "height": 480}
    with tempfile.TemporaryDirectory() as folder, sync_playwright() as p:
        path = Path(folder) / "host.html"
        path.write_text(HOST.format(css=VIEWER_CSS, esm=script_json(shown.widget._esm),
                                    state=script_json(state)), encoding="utf-8")
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        page = browser.new_page(viewport={"width": 900, "height": 520})
        page.goto(path.as_uri())
        page.wait_for_function(READY, timeout=60_000)
        out = []
        for k in range(rounds):
            seconds = page.evaluate("""async (text) => {
                const before = window.host.kanedynScene.scenes;
                const start = performance.now();
                window.fake.model.set('scene_json', text + ' '.repeat(%d));
                while (window.host.kanedynScene.scenes === before)
                    await new Promise((r) => setTimeout(r, 0));
                await new Promise((r) => requestAnimationFrame(r));
                return (performance.now() - start) / 1000; }""" % (k + 1), scene)
            out.append(seconds)
        browser.close()
    return out


def _ms(times):
    return f"{1e3 * min(times):7.1f} {1e3 * statistics.median(times):7.1f}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--browser", action="store_true",
                        help="also time the widget's redraw in headless Chromium")
    args = parser.parse_args(argv)
    print(f"{'model':16s} {'states':>6s} {'simulate min/median ms':>23s} "
          f"{'scene min/median ms':>20s}" + ("  front end min/median ms" if args.browser
                                            else ""))
    for name in CASES:
        times, shown = python_side(name, args.rounds)
        line = (f"{name:16s} {shown.model.n_states:6d} {_ms(times['simulate']):>23s} "
                f"{_ms(times['scene']):>20s}")
        if args.browser:
            line += f"  {_ms(browser_side(shown, args.rounds)):>24s}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
