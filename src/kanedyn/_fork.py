"""Builds and forks: nothing a forked child inherits is left half made.

The optimized build of a model runs in a background thread
(:mod:`kanedyn.numerics.backends._c_quick`) while the main thread may fork (a
pool of forked workers started right after ``numeric(backend="c")``).  A fork
copies the process at one instant, so:

* a lock file is opened and recorded in :data:`_HELD` (or closed and forgotten)
  in one step that a fork waits for: a child closes its copies of every lock
  file of its parent, whose lock it would otherwise hold for its whole life;
* a compiler is started (:func:`spawn`) in one step that a fork waits for:
  a child forked while ``subprocess`` starts one would hold the pipe on which
  the parent waits for the compiler's ``exec``, and the parent's build would
  wait for the child;
* folders are removed at exit by the process that made them only
  (:func:`remove_at_exit`), not by a child that exits;
* the modules using these call their hooks in a child
  (:func:`after_fork_in_child`): first those that make locks anew, then those
  that start threads.

The steps a fork waits for never wait themselves (a file lock is waited for
after its step), so a fork waits for milliseconds at most; a fork from the
thread inside such a step (a signal handler that forks) does not wait for it.
The fork hooks are registered when kanedyn is imported, so that a fork hook of
the user's, registered later, runs before the fork waits (one that waits for
the optimized build, :func:`kanedyn.numerics.finish_compiling`, then finds the
build free to go on; a hook registered before kanedyn was imported runs after
it, and must not wait for the build).  This module imports nothing heavy:
``import kanedyn`` loads it.
"""

from __future__ import annotations

import atexit
import os
import threading

__all__ = ["FileLock", "spawn", "wait_for", "remove_at_exit", "after_fork_in_child"]

#: held by the steps a fork waits for (re-entrant: a fork from the thread inside such
#: a step, e.g. from a signal handler, does not wait for itself)
_GUARD = threading.RLock()
#: the files of the lock files this process holds
_HELD = set()
_RESETS, _STARTS = [], []  # hooks in a child: locks made anew, then threads started


class FileLock:
    """Exclusive advisory lock on a file (POSIX ``flock``; a no-op elsewhere),
    created with mode 0600; a symbolic link in its place is not followed (an
    :class:`OSError`)."""

    def __init__(self, path):
        self.path = path
        self.handle = None

    def __enter__(self):
        with _GUARD:
            self.handle = open(self.path, "a+", opener=_private_no_link)  # noqa: SIM115
            _HELD.add(self.handle)
        try:
            import fcntl
            fcntl.flock(self.handle, fcntl.LOCK_EX)
        except ImportError:  # pragma: no cover  (non-POSIX)
            pass
        except BaseException:  # e.g. Ctrl-C while waiting: not held, not kept
            self.__exit__()
            raise
        return self

    def __exit__(self, *exc):
        with _GUARD:
            _HELD.discard(self.handle)
            self.handle.close()  # closing releases the lock


def _private_no_link(path, flags):
    return os.open(path, flags | getattr(os, "O_NOFOLLOW", 0), 0o600)


def spawn(command, **options):
    """``subprocess.Popen(command, **options)``, started in a step a fork waits for."""
    import subprocess
    with _GUARD:
        return subprocess.Popen(command, **options)


def wait_for(process, timeout):
    """``process.wait(timeout=timeout)``, woken when the process ends: with a
    timeout ``Popen.wait`` polls, sleeping 1, 2, 4, 8 ms and so on between its
    looks, so that it sees a compiler run of 9 ms end after 15 ms.  Where Linux
    gives a descriptor of the process (``os.pidfd_open``), that is waited on
    instead; elsewhere ``Popen.wait`` is called."""
    if process.returncode is not None:
        return process.returncode
    if timeout is not None and not 0 < timeout < 2_000_000:  # poll's milliseconds
        return process.wait(timeout=timeout)  # its own answer (at once, or no limit)
    try:
        descriptor = os.pidfd_open(process.pid)
    except (AttributeError, OSError):  # not Linux 5.3 or later; or already reaped
        return process.wait(timeout=timeout)
    import select
    try:  # poll, not select: a descriptor numbered past 1023 is fine
        waiting = select.poll()
        waiting.register(descriptor, select.POLLIN)
        ended = waiting.poll(None if timeout is None else timeout * 1000)
    finally:
        os.close(descriptor)
    if not ended:
        import subprocess
        raise subprocess.TimeoutExpired(process.args, timeout)
    return process.wait()


def remove_at_exit(folder):
    """Remove ``folder`` when this process exits (not when a child forked from
    it does: the parent may still use it)."""
    atexit.register(_remove_own, folder, os.getpid())


def _remove_own(folder, pid):
    if os.getpid() == pid:
        import shutil
        shutil.rmtree(folder, ignore_errors=True)


def after_fork_in_child(hook, *, starts_threads=False):
    """Call ``hook()`` in every child forked from now on, after the child has
    closed its copies of the parent's lock files; hooks that start threads run
    after all the others (the locks those threads take are then new)."""
    (_STARTS if starts_threads else _RESETS).append(hook)


def _in_child():
    global _GUARD
    _GUARD = threading.RLock()
    for handle in list(_HELD):
        handle.close()
    _HELD.clear()
    for hook in _RESETS + _STARTS:
        hook()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(before=lambda: _GUARD.acquire(), after_in_parent=lambda: _GUARD.release(),
                        after_in_child=_in_child)
