"""A minimal progress indicator for long derivations and simulations (stderr)."""

from __future__ import annotations

import sys
import time

__all__ = ["Progress", "NO_PROGRESS"]


class Progress:
    """Prints stages and throttled updates to ``stream`` when enabled.

    Parameters
    ----------
    enabled : bool
    stream : file-like, optional
        Defaults to ``sys.stderr``.
    interval : float
        Minimum seconds between two updates of the same stage.
    """

    def __init__(self, enabled=True, stream=None, interval=0.5):
        self.enabled = enabled
        self.stream = stream
        self.interval = interval
        self._last = 0.0
        self._t0 = time.perf_counter()
        self._open_line = False

    def _write(self, text, end):
        stream = self.stream or sys.stderr
        stream.write(text + end)
        stream.flush()

    def stage(self, text):
        """Announce a new stage on its own line."""
        if not self.enabled:
            return
        if self._open_line:
            self._write("", "\n")
            self._open_line = False
        self._write(f"[kanedyn {time.perf_counter() - self._t0:6.1f}s] {text}", "\n")

    def update(self, text, fraction=None):
        """Overwrite the current status line (throttled)."""
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self._last < self.interval:
            return
        self._last = now
        pct = f" {100 * fraction:5.1f}%" if fraction is not None else ""
        self._write(f"\r[kanedyn {now - self._t0:6.1f}s] {text}{pct}   ", "")
        self._open_line = True

    def done(self):
        if self.enabled and self._open_line:
            self._write("", "\n")
            self._open_line = False


NO_PROGRESS = Progress(enabled=False)


def as_progress(value):
    """Accept ``True``/``False``/``None`` or a :class:`Progress`."""
    if isinstance(value, Progress):
        return value
    return Progress(enabled=bool(value))
