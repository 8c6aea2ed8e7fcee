"""Standard output and standard error of a command that cannot be written.

A full disk under the file that stdout or stderr goes to (a batch system's log,
``> /dev/full``) makes writes to it raise ``OSError``.  While a command runs
(:func:`guarded`), stdout stands for its results: a write that fails ends the
command with :class:`StreamError` ("cannot write to standard output: No space
left on device", exit code 2).  stderr only carries progress and messages: a
write that fails is dropped, and the run goes on and writes its files.  Either
stream, once failed, is pointed at ``os.devnull``, so that what is still in its
buffer does not fail again when Python flushes it at exit (which would end the
process with status 120 and a message).  A closed pipe (``| head``) is not a
failure of this kind: ``BrokenPipeError`` passes through.
"""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager

from .._errors import KanedynError

__all__ = ["StreamError", "guarded"]


class StreamError(KanedynError):
    """Standard output could not be written."""


class _Guarded:
    """``stream`` whose failed writes raise :class:`StreamError` (``report``) or
    are dropped; every other attribute is the stream's."""

    def __init__(self, stream, name, report):
        self._stream, self._name, self._report = stream, name, report
        self._failed = False

    def write(self, text):
        return self._do("write", text)

    def flush(self):
        return self._do("flush")

    def _do(self, method, *args):
        if self._failed and not self._report:
            return len(args[0]) if args else None
        try:
            return getattr(self._stream, method)(*args)
        except BrokenPipeError:
            raise
        except OSError as exc:
            self._failed = True
            _to_devnull(self._stream)
            if self._report:
                raise StreamError(f"cannot write to {self._name}: "
                                  f"{exc.strerror or exc}") from None
            return len(args[0]) if args else None

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _to_devnull(stream):
    """Point the file descriptor under ``stream`` at ``os.devnull`` (where it has one)."""
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError):
        return
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, fd)
    finally:
        os.close(null)


@contextmanager
def guarded():
    """``sys.stdout`` and ``sys.stderr`` guarded for the block (see the module's text)."""
    out, err = sys.stdout, sys.stderr  # None where the descriptor was closed: left so
    if out is not None:
        sys.stdout = _Guarded(out, "standard output", report=True)
    if err is not None:
        sys.stderr = _Guarded(err, "standard error", report=False)
    try:
        yield
    finally:
        sys.stdout, sys.stderr = out, err
