"""The signals that stop a run: Ctrl-C (SIGINT) and SIGTERM (what batch schedulers,
``kill`` and ``timeout`` send).

While kanedyn holds them (:func:`holding`: a simulation under way, the command
line writing its outputs) a stop signal calls kanedyn's handler instead of
stopping the program where it stands; the holder decides what the first, the
second and the third signal do (see :class:`kanedyn.simulation._run_guard.RunGuard`).
kanedyn takes a signal over only in the main thread and only where it has its
ordinary action: SIGINT Python's own handler (``signal.default_int_handler``,
which raises ``KeyboardInterrupt``), SIGTERM its default action (the end of the
process) or :func:`stop_at_once`.  A signal that is ignored (as SIGINT is for a
job that a shell starts in the background) or that the user gave a handler of
their own is left alone.

:func:`stop_at_once` is the command line's handler of SIGTERM outside those
blocks: it stops the command as Ctrl-C does.  When the command has written what
it has, the ``kanedyn`` program ends by the signal (:func:`end_by`), as a program
that kept the signal's default action would: a shell then reports 130 or 143
(128 + the signal's number), stops a loop over such commands, and ``timeout``
and batch schedulers see a death by the signal.  Imports nothing heavy.
"""

from __future__ import annotations

import signal
import sys
import threading
from contextlib import contextmanager

__all__ = ["STOP_SIGNALS", "Stopped", "stop_at_once", "holding", "taking_over",
           "exit_status", "signal_name", "interruption", "last_received", "end_by",
           "end_by_signal_if_uncaught"]

#: the signals that stop a run, where the platform has them
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM")
                     if hasattr(signal, name))

_LAST = {"signum": None}  # the last stop signal a handler of kanedyn's received


class Stopped(KeyboardInterrupt):
    """A stop signal that acts at once: ``KeyboardInterrupt`` naming its signal.

    Attributes
    ----------
    signum : int
    """

    def __init__(self, signum):
        super().__init__(f"stopped by {signal_name(signum)}")
        self.signum = signum


def signal_name(signum):
    """``"SIGINT"``, ``"SIGTERM"``, ... for a signal number."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


def interruption(signum):
    """``"interrupted"`` for Ctrl-C, ``"interrupted by SIGTERM"`` (and so on)."""
    name = signal_name(signum)
    return "interrupted" if name == "SIGINT" else f"interrupted by {name}"


def exit_status(signum):
    """The exit status of a program stopped by ``signum``: 128 + its number."""
    return 128 + int(signum)


def end_by(signum):
    """End the process by ``signum``, as its default action does.

    stdout and stderr are flushed first (a stream that cannot be written is
    left as it is), the default action restored and the signal raised in this
    thread.  Returns only where the signal does not end the process.  For the
    end of a program (the command line), never a library's call: nothing else
    of the process runs after it (no ``finally``, no exit hook not run yet).
    """
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):
            pass
    signal.signal(signum, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signum})
    signal.raise_signal(signum)


def end_by_signal_if_uncaught():
    """Make a script that lets a stop exception reach its top end by the signal.

    Python ends by SIGINT only for an uncaught exception that is exactly
    ``KeyboardInterrupt``; a :class:`kanedyn.SimulationInterrupted` (its
    subclass) or one of SIGTERM would end the script with status 1, and a shell
    loop or a batch scheduler would not see the signal.  Installed once, on the
    first stop, and only over Python's own ``sys.excepthook`` (not in an
    interactive session, nor over a hook of the user's or of IPython): the
    traceback is printed as before, then the process ends by the exception's
    ``signum``.
    """
    if sys.excepthook is not sys.__excepthook__ or sys.flags.interactive or hasattr(sys, "ps1"):
        return

    def report_then_end(kind, value, traceback):
        sys.__excepthook__(kind, value, traceback)
        signum = getattr(value, "signum", None)
        if isinstance(value, KeyboardInterrupt) and signum in STOP_SIGNALS:
            end_by(signum)

    sys.excepthook = report_then_end


def last_received():
    """The last stop signal one of kanedyn's handlers received (``None``: none)."""
    return _LAST["signum"]


def stop_at_once(signum, frame):
    """A signal handler: raise :class:`Stopped` (what Python's does for Ctrl-C)."""
    _LAST["signum"] = signum
    raise Stopped(signum)


def _ordinary(signum):
    """Whether ``signum`` has its ordinary action (see the module's text)."""
    handler = signal.getsignal(signum)
    return (handler is signal.default_int_handler or handler is stop_at_once
            or (signum != signal.SIGINT and handler == signal.SIG_DFL))


@contextmanager
def holding(on_signal):
    """Call ``on_signal(signum)`` for every stop signal during the block.

    Only the signals kanedyn may take over (main thread, ordinary action); the
    handlers are restored at the end.  ``on_signal`` may raise (e.g.
    :class:`Stopped`) to stop the block where it stands.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        _LAST["signum"] = signum
        on_signal(signum)

    previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS if _ordinary(s)}
    try:
        yield
    finally:
        for s, old in previous.items():
            signal.signal(s, old)


@contextmanager
def taking_over():
    """For a command of the command line: SIGTERM stops it as Ctrl-C does (its
    handler :func:`stop_at_once`) where SIGTERM has its default action."""
    take = (threading.current_thread() is threading.main_thread()
            and hasattr(signal, "SIGTERM") and signal.getsignal(signal.SIGTERM) == signal.SIG_DFL)
    _LAST["signum"] = None
    if not take:
        yield
        return
    signal.signal(signal.SIGTERM, stop_at_once)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
