"""Progress of long derivations and simulations on stderr (bars drawn by tqdm).

:class:`Progress` is what the derivations and :func:`kanedyn.simulate` report
to: ``stage(text)`` announces a step on its own line, ``update(text, fraction)``
moves a progress bar (a ``tqdm`` bar, created on the first update of a step),
``done()`` closes it.  ``tqdm`` is imported on the first bar only, so a
disabled indicator costs nothing.  A stream that is not a terminal (a log
file, a pipe) gets no bar and no carriage returns: one plain line per step
at most every ``line_interval`` seconds, and its last state when it ends.
A stream that cannot be written (a full disk under a log file, a closed pipe)
ends the progress output, never the work it reports on: the indicator then
disables itself.
"""

from __future__ import annotations

import sys
import time

__all__ = ["Progress", "NO_PROGRESS"]

_BAR_FORMAT = "{desc} {percentage:5.1f}%|{bar}| {elapsed}<{remaining}"


class Progress:
    """Prints stages and a throttled progress bar to ``stream`` when enabled.

    Parameters
    ----------
    enabled : bool
    stream : file-like, optional
        Defaults to ``sys.stderr`` (looked up at each use).
    interval : float
        Minimum seconds between two redraws of the bar.
    line_interval : float
        Minimum seconds between two lines of a step on a stream that is not a
        terminal.
    """

    def __init__(self, enabled=True, stream=None, interval=0.5, line_interval=10.0):
        self.enabled = enabled
        self.stream = stream
        self.interval = interval
        self.line_interval = line_interval
        self._last = -float("inf")
        self._shown = None  # on a stream that is not a terminal: the last line written
        self._fraction = 0.0
        self._t0 = time.perf_counter()
        self._bar = None
        self._pending = None  # the latest (text, fraction), drawn or not

    def _prefix(self):
        return f"[kanedyn {time.perf_counter() - self._t0:6.1f}s]"

    def stage(self, text):
        """Announce a new stage on its own line (closing an open bar)."""
        if not self.enabled:
            return
        self.done()

        def line(stream):
            stream.write(f"{self._prefix()} {text}\n")
            stream.flush()
        self._writing(line)

    def update(self, text, fraction=None):
        """Show ``text`` and, if given, ``fraction`` (0..1) done on the bar (throttled)."""
        if not self.enabled:
            return
        self._pending = (text, fraction)
        if fraction is not None:
            self._fraction = min(max(float(fraction), self._fraction), 1.0)
        now = time.perf_counter()
        interval = self.interval if self._terminal() else self.line_interval
        if now - self._last < interval:
            return
        self._last = now
        self._writing(self._draw)

    def _terminal(self):
        stream = self.stream or sys.stderr
        try:
            return bool(stream.isatty())
        except (AttributeError, OSError, ValueError):
            return False

    def _draw(self, stream):
        if not self._terminal():
            self._line(stream)
            return
        text, fraction = self._pending
        description = f"{self._prefix()} {text}"
        if self._bar is None:
            from tqdm import tqdm
            self._bar = tqdm(total=1.0, desc=description, file=stream, leave=True,
                             bar_format=_BAR_FORMAT, mininterval=0.0, dynamic_ncols=True)
        bar = self._bar
        bar.set_description_str(description, refresh=False)
        if fraction is not None:
            bar.n = min(max(float(fraction), bar.n), 1.0)  # never backwards
        bar.refresh()

    def _line(self, stream):
        """A plain line of the step's state (no bar, no carriage return), not the
        same line twice; fractions never go backwards."""
        text, fraction = self._pending
        if fraction is not None:
            text = f"{text} {100 * self._fraction:5.1f}%"
        if text != self._shown:
            stream.write(f"{self._prefix()} {text}\n")
            stream.flush()
            self._shown = text

    def done(self):
        """Close the bar of the current step (showing its last state), if one is open."""
        if self._shown is not None or (self._pending is not None and not self._terminal()):
            if self._pending is not None:
                self._writing(self._line)
            self._shown, self._fraction, self._last = None, 0.0, -float("inf")
        if self._bar is not None:
            def close(stream):
                if self._pending is not None:
                    self._draw(stream)
                self._bar.close()
            self._writing(close)
            self._bar = None
        self._pending = None

    def _writing(self, write):
        """``write(stream)``; a stream that cannot be written (or none: stderr
        closed) ends the progress output, not the work it reports on."""
        stream = self.stream or sys.stderr
        if stream is not None:
            try:
                write(stream)
                return
            except OSError:
                pass
        self.enabled = False
        if self._bar is not None:
            self._bar.disable = True  # its close (and finalizer) write nothing then
            self._bar = None
        self._pending = None


NO_PROGRESS = Progress(enabled=False)


def as_progress(value):
    """Accept ``True``/``False``/``None`` or a :class:`Progress`."""
    if isinstance(value, Progress):
        return value
    return Progress(enabled=bool(value))
