"""Sliders over a model's constants that re-run it and redraw its notebook widget.

:func:`interact` builds (once) a compiled model, and at every slider change
makes a copy with the new constants (:meth:`NumericModel.with_constants`:
the same compiled code), simulates it and sends the new scene to the widget
(:mod:`kanedyn.io._widget`), which draws it in the same view.
"""

from __future__ import annotations

import html
import math
import numbers
import time

import numpy as np

from .._errors import KanedynError, OptionError
from ..numerics import NumericModel
from ..simulation import simulate
from ._viewer import DEFAULT_MAX_FRAMES
from ._widget import _height, widget

__all__ = ["interact", "Interactive"]

_INSTALL = "pip install 'kanedyn[notebook]'"


def _ranges(model, sliders):
    """``{name: (low, high, step)}`` of the sliders, checked against the model."""
    if not isinstance(sliders, dict) or not sliders:
        raise OptionError("sliders must be a dict {constant name: (low, high)} or "
                          "(low, high, step), with at least one constant")
    constants = dict(model.constants)
    out = {}
    for name, bounds in sliders.items():
        if name not in constants:
            raise OptionError(f"slider {name!r}: not a constant of the model; its constants "
                              f"are {', '.join(constants)}")
        try:
            values = [float(b) for b in bounds]
        except (TypeError, ValueError):
            raise OptionError(f"slider {name!r}: give (low, high) or (low, high, step) as "
                              f"numbers, not {bounds!r}") from None
        if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
            raise OptionError(f"slider {name!r}: give (low, high) or (low, high, step) as "
                              f"finite numbers, not {bounds!r}")
        low, high = values[:2]
        step = values[2] if len(values) == 3 else (high - low) / 100
        if not low < high or step <= 0:
            raise OptionError(f"slider {name!r}: needs low < high and a positive step, "
                              f"not {bounds!r}")
        if not low <= constants[name] <= high:
            raise OptionError(f"slider {name!r}: the model's value {constants[name]:g} lies "
                              f"outside ({low:g}, {high:g}); widen the range")
        out[name] = (low, high, step)
    return out


def _model_and_state(model, y0):
    """A :class:`NumericModel` and its initial state, from a model or a model
    definition (:func:`kanedyn.models.build`: compiled in C, its initial state)."""
    if isinstance(model, NumericModel):
        if y0 is None:
            raise OptionError("y0 is required with a numerical model (a model definition "
                              "gives its own initial state)")
        return model, y0
    if callable(getattr(model, "numeric", None)) and callable(getattr(model, "initial", None)):
        numeric = model.numeric(backend="c")
        return numeric, model.initial(numeric) if y0 is None else y0
    raise OptionError(f"interact needs a NumericModel or a model definition "
                      f"(kd.models.build), not {type(model).__name__}")


class Interactive:
    """Sliders, the animation widget and a status line; made by :func:`interact`.

    Attributes
    ----------
    model : NumericModel
        The model with the sliders' current constants.
    result : SimulationResult
        The last run.
    widget : SceneWidget
        The animation (``kd.widget``).
    sliders : dict
        ``{constant name: ipywidgets.FloatSlider}``.
    seconds : float
        Wall-clock time of the last re-run and redraw on the Python side
        (simulation and scene), s.
    """

    def __init__(self, model, y0, t_span, t_eval, ranges, simulate_options, view_options,
                 height):
        try:
            import ipywidgets
        except ImportError:
            raise ImportError(f"kd.interact needs ipywidgets: {_INSTALL}") from None
        self.model, self._base, self._y0 = model, model, y0
        self._t_span, self._t_eval, self._options = t_span, t_eval, simulate_options
        self.result = None
        self.seconds = math.nan
        self.sliders = {
            name: ipywidgets.FloatSlider(value=float(dict(model.constants)[name]), min=low,
                                         max=high, step=step, description=name,
                                         continuous_update=False, readout_format=".4g")
            for name, (low, high, step) in ranges.items()}
        self.status = ipywidgets.HTML()
        self.widget = widget(self._run({}), height=height, **view_options)
        for slider in self.sliders.values():
            slider.observe(self._moved, names="value")
        self.box = ipywidgets.VBox([*self.sliders.values(), self.widget, self.status])

    def _run(self, values):
        started = time.perf_counter()
        model = self._base.with_constants(values) if values else self._base
        result = simulate(model, self._t_span, self._y0, t_eval=self._t_eval, **self._options)
        self.model, self.result = model, result
        if getattr(self, "widget", None) is not None:
            self.widget.draw(result)
        self.seconds = time.perf_counter() - started
        self.status.value = ("" if result.success else
                             f"<b>the run stopped early</b>: {html.escape(result.message)}; ")
        self.status.value += f"re-run and scene: {1e3 * self.seconds:.0f} ms"
        return result

    def rerun(self, **values):
        """Set sliders to ``values`` (``{name: value}``), simulate and redraw.

        Returns
        -------
        SimulationResult
        """
        unknown = set(values) - set(self.sliders)
        if unknown:
            raise OptionError(f"{sorted(unknown)} have no slider; the sliders are "
                              f"{', '.join(self.sliders)}")
        for name, value in values.items():
            slider = self.sliders[name]
            if not slider.min <= value <= slider.max:
                raise OptionError(f"{name} = {value!r} lies outside its slider's range "
                                  f"({slider.min:g}, {slider.max:g})")
        self._quiet = True
        try:
            for name, value in values.items():
                self.sliders[name].value = float(value)
        finally:
            self._quiet = False
        return self._run({name: s.value for name, s in self.sliders.items()})

    def _moved(self, change):
        if getattr(self, "_quiet", False):
            return
        try:
            self._run({name: s.value for name, s in self.sliders.items()})
        except (KanedynError, ValueError, np.linalg.LinAlgError) as err:
            self.status.value = f"<b>not re-run</b>: {html.escape(str(err))}"

    def _repr_mimebundle_(self, **kwargs):
        return self.box._repr_mimebundle_(**kwargs)


def interact(model, t_span, y0=None, *, sliders, points=201, visuals=(), trace=(), up="auto",
             max_frames=DEFAULT_MAX_FRAMES, title=None, inputs=None, height=480,
             **simulate_options):
    """Sliders over a model's constants, each change re-running the model and
    redrawing its animation, in a notebook.

    Parameters
    ----------
    model : NumericModel or ModelDefinition
        A numerical model (``backend="c"`` for speed), or a model definition
        (:func:`kanedyn.models.build`), compiled here in C.
    t_span : (float, float)
        Start and end time, s.
    y0 : array_like or dict, optional
        Initial state (as :func:`kanedyn.simulate`); a model definition gives
        its own by default.
    sliders : dict
        ``{constant name: (low, high)}`` or ``(low, high, step)`` (default
        step: a hundredth of the range); the model's value must lie within.
    points : int
        Output times, evenly spaced over ``t_span``: the frames.
    visuals, trace, up, max_frames, title, inputs, height
        As :func:`kanedyn.io.widget`.
    **simulate_options
        Passed to :func:`kanedyn.simulate` (``rtol``, ``method``, ...).

    Returns
    -------
    Interactive
        Displayed as the sliders above the animation and a status line (the
        last re-run's time); ``.rerun(name=value)`` does what moving a slider
        does.
    """
    model, y0 = _model_and_state(model, y0)
    ranges = _ranges(model, sliders)
    if isinstance(points, bool) or not isinstance(points, numbers.Integral) or points < 2:
        raise OptionError(f"points must be a whole number of at least 2, not {points!r}")
    t_eval = np.linspace(float(t_span[0]), float(t_span[1]), int(points))
    view = dict(visuals=visuals, trace=trace, up=up, max_frames=max_frames, title=title,
                inputs=inputs)
    return Interactive(model, y0, t_span, t_eval, ranges, simulate_options, view,
                       _height(height))
