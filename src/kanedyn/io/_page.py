"""The animation page: one HTML file that opens without a network.

The page holds three parts, all inline:

* three.js 0.187.0 (``_vendor/three``: the module build, its core and
  OrbitControls), each gzip-compressed and base64-encoded in a
  ``<script type="application/octet-stream">`` element; the page unpacks
  them with the browser's ``DecompressionStream`` and imports them from
  ``blob:`` URLs (no import map, no file next to the page);
* the scene (:func:`kanedyn.io.scene_data`) as JSON in a
  ``<script type="application/json">`` element, read with ``JSON.parse``;
* the viewer's own script: the scene code shared with the notebook widget
  (``_viewer.js``, :func:`viewer_script`) and the page's start
  (``_viewer_page.js``).
"""

from __future__ import annotations

import base64
import gzip
import html
import json
from functools import lru_cache
from importlib import resources
from pathlib import Path

from .._errors import OptionError
from .._output_files import replacing
from ._viewer import DEFAULT_MAX_FRAMES, scene_data

__all__ = ["animate", "page_html", "script_json", "vendored_three", "viewer_script",
           "VIEWER_CSS", "THREE_VERSION"]

THREE_VERSION = "0.187.0"
_THREE_FILES = {"core": "three.core.js", "main": "three.module.js",
                "orbit": "OrbitControls.js"}
#: the page's element of each part of three.js
_THREE_ELEMENTS = {"core": "kd-three-core", "main": "kd-three", "orbit": "kd-orbit"}


@lru_cache(maxsize=1)
def vendored_three():
    """``{"core", "main", "orbit"}``: base64 of gzip of three.js's core, its module
    build and OrbitControls (``_vendor/three``), as the viewer's script unpacks them."""
    folder = resources.files("kanedyn.io").joinpath("_vendor", "three")
    out = {}
    for key, name in _THREE_FILES.items():
        data = folder.joinpath(name).read_bytes()
        out[key] = base64.b64encode(gzip.compress(data, 9, mtime=0)).decode("ascii")
    return out


def viewer_script(start):
    """The viewer's module: the scene code (``_viewer.js``) and then ``start``, the
    page's (``"page"``) or the notebook widget's (``"widget"``) own file."""
    folder = resources.files("kanedyn.io")
    return "\n".join(folder.joinpath(name).read_text(encoding="utf-8")
                     for name in ("_viewer.js", f"_viewer_{start}.js"))


#: the viewer's look, the same in the page and the notebook widget
VIEWER_CSS = """
.kd-viewer { position: relative; height: 480px; overflow: hidden; background: #f4f5f7;
  font: 14px/1.35 system-ui, -apple-system, "Segoe UI", sans-serif; color: #222; }
.kd-viewer .kd-view { position: absolute; inset: 0 0 56px 0; }
.kd-viewer .kd-bar { position: absolute; left: 0; right: 0; bottom: 0; height: 56px;
  display: flex; align-items: center; gap: 12px; padding: 0 14px; background: #fff;
  border-top: 1px solid #d0d4da; box-sizing: border-box; }
.kd-viewer .kd-bar button { width: 76px; height: 32px; font-size: 14px; }
.kd-viewer .kd-slider { flex: 1; }
.kd-viewer .kd-time { font-variant-numeric: tabular-nums; min-width: 170px;
  text-align: right; }
.kd-viewer .kd-info { position: absolute; left: 12px; top: 10px;
  background: rgba(255,255,255,0.85); padding: 8px 12px; border-radius: 6px;
  max-width: 40%; }
.kd-viewer h1.kd-title { font-size: 16px; margin: 0 0 4px 0; padding: 0; border: 0; }
.kd-viewer .kd-legend span.swatch { display: inline-block; width: 12px; height: 12px;
  margin-right: 6px; vertical-align: -1px; border-radius: 2px; }
.kd-viewer .kd-notes { color: #8a4b00; font-size: 12px; }
.kd-viewer .kd-error { color: #b00020; white-space: pre-wrap; }
"""


#: characters of JSON text written as ``\\uXXXX`` escapes inside the page's
#: ``<script>``: no ``<`` (``</script>`` or ``<!--`` would end the element early or
#: swallow the rest of the page), ``>`` and ``&`` (markup), and the line separators
#: that end a line of JavaScript
_SCRIPT_UNSAFE = {ord(c): f"\\u{ord(c):04x}" for c in "<>&\u2028\u2029"}


def script_json(value):
    """``value`` as JSON that can stand inside a ``<script>`` element as it is.

    Names of bodies, points and files are the user's text; every character that
    the HTML parser or JavaScript could read as more than a string is escaped,
    and ``JSON.parse`` gives the text back unchanged.
    """
    return json.dumps(value, separators=(",", ":"), allow_nan=False).translate(
        _SCRIPT_UNSAFE)


def page_html(scene):
    """The complete page of a scene (:func:`kanedyn.io.scene_data`), as a string."""
    blobs = "\n".join(f'<script id="{_THREE_ELEMENTS[key]}" type="application/octet-stream">'
                      f'{value}</script>' for key, value in vendored_three().items())
    data = script_json(scene)
    title = html.escape(scene.get("title") or "kanedyn")
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="kanedyn (three.js {THREE_VERSION}, MIT licence)">
<title>{title}</title>
<style>
html, body {{ margin: 0; height: 100%; overflow: hidden; }}
{VIEWER_CSS}
#kd-root {{ position: absolute; inset: 0; height: auto; }}
</style>
</head>
<body>
<div id="kd-root"></div>
{blobs}
<script id="kd-scene" type="application/json">{data}</script>
<script type="module">
{viewer_script("page")}
</script>
</body>
</html>
"""


def animate(result, path, visuals=(), trace=(), up="auto", max_frames=DEFAULT_MAX_FRAMES,
            title=None, inputs=None):
    """Write the 3D animation of a simulation as one self-contained HTML file.

    Parameters
    ----------
    result : SimulationResult
    path : str or Path
        The page to write (``.html``).
    visuals, trace, up, max_frames, title, inputs
        See :func:`kanedyn.io.scene_data`.

    Returns
    -------
    Path
        The page written.
    """
    path = Path(path)
    if path.suffix.lower() not in (".html", ".htm"):
        raise OptionError(f"the animation is an HTML page: give a path ending in .html, "
                          f"not {str(path)!r}")
    if not path.parent.is_dir():
        raise OptionError(f"cannot write {path}: folder {path.parent} does not exist")
    scene = scene_data(result, visuals=visuals, trace=trace, up=up, max_frames=max_frames,
                       title=title, inputs=inputs)
    with replacing(path) as handle:
        handle.write(page_html(scene))
    return path
