"""The 3D animation as a live notebook widget (anywidget).

The widget draws the same scene as the page (:func:`kanedyn.io.scene_data`),
with the same scene code (``_viewer.js``) started by ``_viewer_widget.js``;
three.js travels inside the widget's module, gzip-compressed as in the page,
so nothing is fetched from the network.  Its synchronized traits:

``scene_json``  the scene as JSON text; a new one (:meth:`SceneWidget.draw`)
                is drawn in the same view (camera, time and play/pause kept)
``time``        the time shown, s: set from Python it moves the scene there;
                moving the time slider sets it back (at most every 0.1 s, and
                where the slider is let go)
``height``      the widget's height, pixels

anywidget is imported when the first widget is made (the ``notebook`` extra).
"""

from __future__ import annotations

import json
import numbers
from functools import lru_cache

from .._errors import OptionError
from ._page import VIEWER_CSS, vendored_three, viewer_script
from ._viewer import DEFAULT_MAX_FRAMES, scene_data

__all__ = ["widget", "widget_esm", "scene_widget_class"]

_INSTALL = "pip install 'kanedyn[notebook]'"


def widget_esm():
    """The widget's front end: one ES module (three.js inside, nothing fetched)."""
    return ("const KD_THREE = " + json.dumps(vendored_three()) + ";\n"
            + viewer_script("widget"))


def _height(height):
    if isinstance(height, bool) or not isinstance(height, numbers.Integral) or height < 100:
        raise OptionError(f"height must be a whole number of pixels, at least 100, "
                          f"not {height!r}")
    return int(height)


@lru_cache(maxsize=1)
def scene_widget_class():
    """The widget's class, made on first use (it needs anywidget)."""
    try:
        import anywidget
        import traitlets
    except ImportError:
        raise ImportError(f"the notebook widget needs anywidget: {_INSTALL}") from None

    class SceneWidget(anywidget.AnyWidget):
        """A simulation's 3D animation in a notebook: play, pause, scrub, orbit.

        Made by :func:`kanedyn.io.widget` (``kd.widget(result)``).
        """

        _esm = widget_esm()
        _css = VIEWER_CSS
        scene_json = traitlets.Unicode("").tag(sync=True)
        time = traitlets.Float(0.0).tag(sync=True)
        height = traitlets.Int(480).tag(sync=True)

        def __init__(self, options, **kwargs):
            super().__init__(**kwargs)
            self._options = dict(options)
            self.result = None

        def draw(self, result):
            """Show another result (the same model, or another) with the options
            the widget was made with; the view, time and play/pause stay."""
            scene = scene_data(result, **self._options)
            self.result = result
            self.scene_json = json.dumps(scene, separators=(",", ":"), allow_nan=False)
            return self

    return SceneWidget


def widget(result, visuals=(), trace=(), up="auto", max_frames=DEFAULT_MAX_FRAMES, title=None,
           inputs=None, height=480):
    """The 3D animation of a simulation as a live notebook widget.

    The widget shows what :func:`kanedyn.io.animate` writes to a page (the
    same scene and controls), inside Jupyter (anywidget: JupyterLab, Notebook,
    VS Code), without a network.

    Parameters
    ----------
    result : SimulationResult
    visuals, trace, up, max_frames, title, inputs
        See :func:`kanedyn.io.scene_data`; kept for :meth:`SceneWidget.draw`.
    height : int
        Pixels (at least 100).

    Returns
    -------
    SceneWidget
        An ``anywidget.AnyWidget``: display it (last expression of a cell);
        ``.draw(result)`` shows another result, ``.time = t`` moves to ``t``.

    Raises
    ------
    ImportError
        Without anywidget (``pip install 'kanedyn[notebook]'``).
    """
    options = dict(visuals=visuals, trace=trace, up=up, max_frames=max_frames, title=title,
                   inputs=inputs)
    height = _height(height)
    shown = scene_widget_class()(options, height=height)
    return shown.draw(result)
