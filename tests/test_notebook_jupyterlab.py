"""The notebook widget in a real JupyterLab session: a Jupyter server with a
Python kernel, the notebook opened in headless Chromium, its cells run with
the keyboard as a user runs them.

``test_notebook.py`` tests the widget's front end against a stand-in for
anywidget's model; this test checks what only a live session shows: that
JupyterLab loads the widget's module through anywidget's extension, that the
kernel's ``res.widget()`` draws the pendulum in the output area, and that the
synced ``time`` travels both ways (set in a cell, the scene moves; scrubbed in
the browser, the kernel's trait has the new value).
"""

import json
import os
import re
import socket
import subprocess
import sys
import time
import urllib.request

import pytest

from test_viewer import CHROMIUM

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(CHROMIUM is None, reason="no chromium executable found (Debian: "
                       "apt-get install chromium); JupyterLab is not tested in a browser"),
]

CELLS = [
    "import numpy as np\n"
    "import kanedyn as kd\n"
    "definition = kd.models.build('pendulum')\n"
    "model = definition.numeric(backend='numpy')\n"
    "res = kd.simulate(model, (0, 2), definition.initial(model),\n"
    "                  t_eval=np.linspace(0, 2, 81), rtol=1e-9, atol=1e-9)\n"
    "view = res.widget(height=360)\n"
    "view",
    "view.time = 1.5",
    "print(f'kernel time {view.time:.3f}')",
]

#: the widget's element: the anywidget element that holds the viewer (render()'s ``el``)
SCENE = """(() => { let e = document.querySelector('.kd-viewer');
    while (e && !e.kanedynScene) e = e.parentElement;
    return e ? e.kanedynScene : null; })()"""


def _notebook():
    return {"cells": [{"cell_type": "code", "execution_count": None, "id": f"cell{k}",
                       "metadata": {}, "outputs": [], "source": source}
                      for k, source in enumerate(CELLS)],
            "metadata": {"kernelspec": {"display_name": "Python 3", "language": "python",
                                        "name": "python3"}},
            "nbformat": 4, "nbformat_minor": 5}


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for_server(url, process, timeout=120.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if process.poll() is not None:
            raise AssertionError(f"the Jupyter server exited with {process.returncode}")
        try:
            with urllib.request.urlopen(url, timeout=2) as reply:
                if reply.status == 200:
                    return
        except OSError:
            time.sleep(0.5)
    raise AssertionError(f"the Jupyter server did not answer {url} within {timeout} s")


@pytest.fixture
def jupyterlab(tmp_path):
    """A JupyterLab server on a free local port with its own configuration,
    data, runtime and settings directories (nothing of the user's): yields
    ``(base url with the token, notebook path)``."""
    pytest.importorskip("jupyterlab", reason="the session test needs jupyterlab "
                        "(the test extra)")
    pytest.importorskip("anywidget", reason="the widget needs anywidget (the notebook extra)")
    root = tmp_path / "root"
    root.mkdir()
    (root / "widget.ipynb").write_text(json.dumps(_notebook()), encoding="utf-8")
    env = dict(os.environ)
    for key, sub in (("JUPYTER_CONFIG_DIR", "config"), ("JUPYTER_DATA_DIR", "data"),
                     ("JUPYTER_RUNTIME_DIR", "runtime"),
                     ("JUPYTERLAB_SETTINGS_DIR", "settings"),
                     ("JUPYTERLAB_WORKSPACES_DIR", "workspaces"), ("IPYTHONDIR", "ipython")):
        env[key] = str(tmp_path / sub)
    env["JUPYTER_PLATFORM_DIRS"] = "1"
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)  # this kanedyn
    port, token = _free_port(), "kanedyn-test"
    log = open(tmp_path / "server.log", "wb")
    server = subprocess.Popen(
        [sys.executable, "-m", "jupyterlab", "--no-browser", "--ServerApp.ip=127.0.0.1",
         f"--ServerApp.port={port}", "--ServerApp.port_retries=0",
         f"--IdentityProvider.token={token}", f"--ServerApp.root_dir={root}",
         "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
         "--ServerApp.terminals_enabled=False", "--allow-root"],  # CI runs as root
        env=env, stdout=log, stderr=subprocess.STDOUT, cwd=root)
    base = f"http://127.0.0.1:{port}"
    try:
        _wait_for_server(f"{base}/api/status?token={token}", server)
        yield base, token
    finally:
        server.terminate()
        try:
            server.wait(timeout=20)
        except subprocess.TimeoutExpired:
            server.kill()
        log.close()


def _run_cell(page, index, timeout=90.0):
    """Run cell ``index`` as a user does: click into it, press Shift+Enter.  The
    key is pressed again while the cell's prompt shows no run (``[ ]:``): a
    notebook page still starting under load may not take the first one.  A
    "Select Kernel" dialog (JupyterLab asks when the notebook's kernel session is
    not yet made, seen once under load) is answered as a user does: Select, the
    preselected Python 3."""
    from playwright import sync_api
    cell = page.locator(".jp-Notebook .jp-Cell").nth(index)
    prompt = cell.locator(".jp-InputPrompt")
    dialog = page.locator(".jp-Dialog", has_text="Select Kernel")
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if dialog.count():
            dialog.locator(".jp-mod-accept").click()
            dialog.wait_for(state="detached", timeout=30_000)
        try:
            cell.locator(".cm-content").click(timeout=10_000)
        except sync_api.TimeoutError:  # a dialog came up meanwhile: answered above
            continue
        page.keyboard.press("Shift+Enter")
        for _ in range(40):
            if re.search(r"\[(\*|\d+)\]", prompt.inner_text()):
                return
            page.wait_for_timeout(250)
    raise AssertionError(f"cell {index} did not start within {timeout} s")


def test_widget_in_a_jupyterlab_session(jupyterlab, tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api",
                                   reason="the browser test needs playwright (the test extra)")
    base, token = jupyterlab
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        try:
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(f"{base}/lab/tree/widget.ipynb?token={token}")
            page.wait_for_selector(".jp-Notebook .jp-Cell .cm-content", timeout=120_000)
            page.wait_for_selector(".jp-Notebook-ExecutionIndicator[data-status='idle']",
                                   timeout=120_000)
            _run_cell(page, 0)                           # the widget
            page.wait_for_function(f"{SCENE} && {SCENE}.ready", polling=250, timeout=180_000)
            drawn = page.evaluate(f"({{...{SCENE}}})")
            _run_cell(page, 1)                           # view.time = 1.5
            # (the scene may be missing for a moment while the output area is
            # drawn again: not yet, rather than an error)
            page.wait_for_function(f"{SCENE} && Math.abs({SCENE}.time - 1.5) < 1e-9",
                                   polling=250, timeout=60_000)
            # scrubbed to the end and let go in the browser ...
            page.evaluate("""(() => { const s = document.querySelector('.kd-slider');
                s.value = s.max; s.dispatchEvent(new Event('input'));
                s.dispatchEvent(new Event('change')); })()""")
            page.wait_for_timeout(500)
            _run_cell(page, 2)                           # ... the kernel's trait
            printed = page.locator(".jp-OutputArea-output", has_text="kernel time")
            printed.wait_for(timeout=60_000)
            text = printed.inner_text()
            canvases = page.evaluate(
                "document.querySelectorAll('.jp-OutputArea-output .kd-viewer canvas').length")
        except Exception as err:
            shot = tmp_path / "jupyterlab-failed.png"
            page.screenshot(path=str(shot))
            outputs = page.locator(".jp-Notebook").inner_text()
            raise AssertionError(f"{err}\nthe notebook then (screenshot {shot}):\n"
                                 f"{outputs}") from err
        finally:
            browser.close()
    assert errors == []
    assert (drawn["bodies"], drawn["frames"]) == (1, 81)
    assert canvases == 1
    assert "kernel time 2.000" in text, text
