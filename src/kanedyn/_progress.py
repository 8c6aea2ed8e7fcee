"""Progress of long derivations and simulations on stderr (bars drawn by tqdm).

:class:`Progress` is what the derivations and :func:`kanedyn.simulate` report
to: ``stage(text)`` announces a step on its own line, ``update(text, fraction)``
moves a progress bar (a ``tqdm`` bar, created on the first update of a step),
``done()`` closes it.  ``tqdm`` is imported on the first bar only, so a
disabled indicator costs nothing.  A stream that cannot be written (a full
disk under a log file, a closed pipe) ends the progress output, never the work
it reports on: the indicator then disables itself.
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
    """

    def __init__(self, enabled=True, stream=None, interval=0.5):
        self.enabled = enabled
        self.stream = stream
        self.interval = interval
        self._last = -float("inf")
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
        now = time.perf_counter()
        if now - self._last < self.interval:
            return
        self._last = now
        self._writing(self._draw)

    def _draw(self, stream):
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

    def done(self):
        """Close the bar of the current step (showing its last state), if one is open."""
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
