"""Quick first builds: a model's module from TinyCC now, the optimized one later.

TinyCC (``tcc``) compiles the generated C of a model in a few hundredths of a
second where gcc needs a second of CPU or more (chain3d n = 10: 0.05 s against
1.2 s).  When it is installed, a model's first module is built with it and
used at once, and the optimizing compiler builds the module that goes into
the cache in a background thread once that pays (:func:`optimize_later`: once
the quick module has run about as long as the build takes, or at once where
the module is wanted in the cache); the optimized module then takes the quick
one's place in every model bound to it (:func:`when_optimized`), and the quick
module itself calls the optimized code from then on (a run under way included).
Both compilers translate the same C into IEEE double arithmetic without fused
multiply-adds (gcc is told ``-ffp-contract=off``; tcc never fuses) and call
the same libm, so the two modules return the same numbers: the tests compare
them to the bit.  A model's generic runtime unit, known from its sizes before it
is derived, is compiled by the quick compiler alone meanwhile
(:func:`prefetch_quick`), and the quick build links its object.

The optimized build holds the build lock of :mod:`._c_build` while gcc runs.
Another module that the process needs meanwhile and that is not cached does
not wait for it where it may come from the quick compiler too (a model's
derivative module asked for while the model's own optimized build runs: its
source is generated and compiled by tcc at once, its own optimized build
queued behind the running one); otherwise it waits (as it would have waited
for a build in the foreground).

``$KANEDYN_QUICK_CC`` chooses the quick compiler: unset, ``tcc`` when it is on
the ``PATH``; empty (or ``none``), no quick builds; else the command of a
compiler that takes tcc's options.  A unit the quick compiler cannot
translate makes no quick module: the optimized build then runs in the
foreground, as without a quick compiler.

The process waits for the optimized builds still running when it exits (the
cache then holds them for the next process); :func:`finish_compiling` waits
for them earlier.  A child forked while an optimized build runs (a pool of
forked workers) takes the optimized module from the cache once its parent
has written it: a daemon thread of the child waits for the build's file lock,
then loads the module and moves the child's models onto it as above.  The
quick module is written to a ``quick-*`` folder of the cache directory (where
the optimized modules are run from too, so a system temporary directory
mounted ``noexec`` does not matter).  Constants are printed as single
correctly rounded literals, so that no compiler folds a division of two.
"""

from __future__ import annotations

import atexit
import functools
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

from ..._fork import after_fork_in_child, remove_at_exit, spawn, wait_for
from ..._trusted_files import PRIVATE_FILE

__all__ = ["quick_command", "compile_quick", "prefetch_quick", "prefetched_folders",
           "drop_prefetched", "optimize_later", "when_optimized", "when_cached",
           "finish_compiling", "QUICK_STATS"]

#: what this process did (read by tests): ``quick``, modules built by the quick
#: compiler; ``failed``, units it could not translate (an optimized build ran
#: instead); ``started``, optimized builds started (:func:`optimize_later`);
#: ``optimized``, background builds finished; ``swaps``, models moved onto an
#: optimized module
QUICK_STATS = {"quick": 0, "failed": 0, "started": 0, "optimized": 0, "swaps": 0}

#: s of a quick module's use (the time its entry points took) per character of its
#: C before its optimized build starts: gcc -O2 takes about a second per 100,000
#: characters of generated C (the build's CPU, which then runs beside the model)
USE_PER_CHARACTER = 1e-5
#: s between two looks at the quick modules whose optimized build waits
_LOOK_EVERY = 0.1
_WATCHER = None  # the thread of _start_those_that_pay

#: tcc has no complex arithmetic: NumPy's headers declare complex types that the
#: runtime never uses, through glibc's <complex.h>; keep that header out and make
#: ``_Complex`` vanish (those typedefs become plain floating types; no declaration
#: the runtime uses changes)
_QUICK_FLAGS = ["-shared", "-fPIC", "-w", "-D_COMPLEX_H", "-D_Complex="]
#: the same for one unit compiled alone to an object (:func:`prefetch_quick`)
_OBJECT_FLAGS = ["-c"] + _QUICK_FLAGS[1:]

_STATE = threading.Lock()  # guards _UPGRADES
#: held while a build is started (:func:`_start_now`), by the thread that starts the
#: builds that pay and by :func:`finish_compiling`, which then finds every build started
_STARTS = threading.Lock()
#: s: longest wait of optimize_later for its build to hold the entry's file lock
_LOCKED_WITHIN = 0.2
_UPGRADES = {}  # quick module -> _Upgrade
#: (command, includes, unit) -> (compiler process, the object it writes, its folder):
#: this process's units started early (:func:`prefetch_quick`)
_PREFETCHED = {}
_WARNED = set()


class _Upgrade:
    """The optimized build of one quick module: its thread, the optimized module
    once loaded, the callbacks waiting for it, and how a forked child fetches
    the module its parent builds."""

    def __init__(self, folder=None):
        self.thread = None
        self.start = None  # () -> None: starts the build not started yet (see optimize_later)
        self.use_to_start = 0.0  # s of the quick module's use at which it starts
        self.final = None
        self.callbacks = []
        self.cache_callbacks = []  # of when_cached: the building process's own
        self.folder = folder  # of the quick module's file
        self.fetch = None  # () -> the optimized module built by another process, or None


def quick_command():
    """The quick compiler's command as a list, or ``None`` (see the module
    docstring); a ``$KANEDYN_QUICK_CC`` that is not a command of a program is
    reported once (a warning) and not used.  ``None`` too where Python loads
    extension modules with ``RTLD_GLOBAL``: TinyCC ignores symbol visibility, so
    the functions of two quick modules would resolve to one another's."""
    if sys.getdlopenflags() & getattr(os, "RTLD_GLOBAL", 0):
        return None
    value = os.environ.get("KANEDYN_QUICK_CC")
    if value is None:
        found = shutil.which("tcc")
        return [found] if found else None
    try:
        parts = shlex.split(value)
    except ValueError as exc:
        _warn_once(value, f"$KANEDYN_QUICK_CC is {value!r}, which is not a command ({exc}); "
                          "models are compiled by the optimizing compiler only")
        return None
    if not parts or parts == ["none"]:
        return None
    if shutil.which(parts[0]) is None:
        _warn_once(value, f"$KANEDYN_QUICK_CC is {value!r}, which is not a program on this "
                          "machine; models are compiled by the optimizing compiler only")
        return None
    return parts


def _warn_once(what, text):
    """Warn with ``text`` the first time ``what`` goes wrong in this process."""
    if what not in _WARNED:
        _WARNED.add(what)
        warnings.warn(text, RuntimeWarning, stacklevel=5)


def compile_quick(name, units, command, includes, loader, directory, timeout):
    """The module ``name`` built by the quick compiler from the C sources
    ``units`` (one run, in a ``quick-*`` folder of the cache ``directory``,
    where modules may be run from), loaded with ``loader(name, path)`` and
    registered for :func:`optimize_later` (mode 0600, checked and loaded as a
    cached module is); ``None`` when the compiler fails,
    takes longer than ``timeout`` seconds, makes a module that does not load or
    cannot write its folder (a full disk; counted in :data:`QUICK_STATS`
    ``failed``; the first failure of a process is reported with a warning).
    The folder is made with mode 0700 (:func:`tempfile.mkdtemp`).

    The module's file stays until the process that made it exits: the dynamic
    loader knows a loaded library by its file's identity, and a file removed
    could lend its inode to the optimized module, which would then be taken for
    this one.  A folder left by a killed process is removed with the stale
    builds of :mod:`._c_build`."""
    problem, module, folder, paths, taken = None, None, None, [], []
    try:
        folder = Path(tempfile.mkdtemp(prefix="quick-", dir=directory))
        remove_at_exit(folder)
        for k, text in enumerate(units):
            made = _prefetched_object(command, includes, text, timeout)
            if made is not None:  # compiled meanwhile: linked
                paths.append(str(made))
                taken.append(made.parent)
                continue
            path = folder / f"unit{k}.c"
            paths.append(str(path))
            path.write_text(text)
        drop_prefetched()  # a unit of another module (a wrong guess)
        out = folder / f"{name}.so"
        with open(folder / "said.txt", "w+") as output:  # a file: no pipe a fork could hold
            run = spawn(command + _QUICK_FLAGS + includes + paths + ["-o", str(out), "-lm"],
                        stdout=output, stderr=subprocess.STDOUT)
            try:
                wait_for(run, timeout)
            except BaseException:  # a timeout or Ctrl-C: the compiler does not run on
                run.kill()
                run.wait()
                raise
            output.seek(0)
            said = output.read().strip()[-500:]
        if run.returncode != 0:
            problem = f"exit status {run.returncode}" + (f": {said}" if said else "")
        else:
            os.chmod(out, PRIVATE_FILE)  # whatever the umask: the loader checks it
            module = loader(name, out)
    except (OSError, ImportError, subprocess.TimeoutExpired) as exc:
        problem = str(exc)
    finally:
        for path in paths:
            Path(path).unlink(missing_ok=True)
        for place in taken:
            shutil.rmtree(place, ignore_errors=True)
    if module is None:
        QUICK_STATS["failed"] += 1
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
        _warn_once("failed", f"the quick compiler {command[0]} could not build a model's "
                             f"module ({problem or 'no module written'}); such modules are built "
                             "by the optimizing compiler alone")
        return None
    QUICK_STATS["quick"] += 1
    with _STATE:
        _UPGRADES[module] = _Upgrade(folder)
    return module


def prefetch_quick(unit, command, includes, directory):
    """Start the quick compiler ``command`` on the translation unit ``unit``
    alone, to an object in a ``quick-*`` folder of the cache ``directory``, now,
    before its module is built: a :func:`compile_quick` with the same command
    and ``includes`` whose units hold the same text links that object instead
    of compiling the unit (it waits for the compiler where it still runs).

    For the generic runtime of a model (see :func:`._c_build.prefetch`): some
    two thirds of the quick compiler's time on a small model's units is that
    unit's (Python's and NumPy's headers), which then runs while the model is
    derived.  At most one unit is prefetched at a time (a new one drops the
    previous one); one that :func:`compile_quick` does not take is dropped by
    it, and at exit (:func:`drop_prefetched`).  Nothing happens where the
    folder cannot be made or the compiler not started (the unit is then
    compiled with the others)."""
    key = (tuple(command), tuple(includes), unit)
    with _STATE:
        if key in _PREFETCHED:
            return
    drop_prefetched()
    folder = None
    try:
        folder = Path(tempfile.mkdtemp(prefix="quick-", dir=directory))
        remove_at_exit(folder)
        source = folder / "unit.c"
        source.write_text(unit)
        with open(folder / "said.txt", "w") as output:  # a file: no pipe a fork could hold
            run = spawn(command + _OBJECT_FLAGS + includes
                        + [str(source), "-o", str(folder / "unit.o")],
                        stdout=output, stderr=subprocess.STDOUT)
    except OSError:  # a full disk, say
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
        return
    with _STATE:
        _PREFETCHED[key] = (run, folder / "unit.o", folder)


def _prefetched_object(command, includes, unit, timeout):
    """The object of ``unit`` from :func:`prefetch_quick` once its compiler has
    ended (``None`` where none was started, or it failed: its folder is then
    removed, and the unit is compiled with the others, which reports what is
    wrong with it)."""
    with _STATE:
        found = _PREFETCHED.pop((tuple(command), tuple(includes), unit), None)
    if found is None:
        return None
    run, made, folder = found
    try:
        wait_for(run, timeout)
    except BaseException:  # a timeout or Ctrl-C: the compiler does not run on
        _stop(found)
        raise
    if run.returncode == 0 and made.exists():
        return made
    _stop(found)
    return None


def prefetched_folders():
    """The folders of this process's units from :func:`prefetch_quick` (not
    stale, however old: a long derivation may outlast the age of a stale build)."""
    with _STATE:
        return {folder for _, _, folder in _PREFETCHED.values()}


def drop_prefetched():
    """Stop the units of :func:`prefetch_quick` that no build took and remove
    their folders."""
    while True:
        with _STATE:
            if not _PREFETCHED:
                return
            found = _PREFETCHED.popitem()[1]
        _stop(found)


def _stop(prefetched):
    """Stop a prefetched compiler run ``(process, object, folder)`` (tcc is one
    process: no compiler proper of its own to stop) and remove its folder."""
    run, _, folder = prefetched
    if run.poll() is None:
        run.kill()
        run.wait()
    shutil.rmtree(folder, ignore_errors=True)


def optimize_later(module, build, fetch=None, effort=0.0):
    """Build the optimized replacement of the quick ``module`` (from
    :func:`compile_quick`) in a background thread once it pays (see below):
    ``build(when_locked=f)`` returns it and calls ``f()`` once it holds the
    cache entry's file lock, which the start waits for (briefly: a child forked
    after it then waits for the module; ``build`` may take locks, which the
    caller must not hold).  The quick module then runs the optimized code and
    the callbacks of :func:`when_optimized` are called.  A build that fails
    leaves the quick module in place, with a warning.  ``fetch()``, when given,
    returns the optimized module once this process has built it (or ``None``):
    a child forked during the build calls it (see :func:`_catch_up_after_fork`).

    The build starts once the quick module's entry points have taken
    :data:`USE_PER_CHARACTER` s per character the build compiles at -O2 (or
    the like: ``effort``), about the CPU time gcc takes to build it: from then
    on, TinyCC's slower code would cost more than the build.  It starts at
    once when something asks for the module in the cache (:func:`when_cached`:
    the derivation cache), when :func:`finish_compiling` is called, or for a
    module that does not time its use.  A build not started when the process exits never is: the next
    process compiles the module again with the quick compiler (a few
    hundredths of a second).  While the interpreter shuts down (a model built
    in an ``atexit`` function) the build runs at once, in this thread."""
    with _STATE:
        upgrade = _UPGRADES.setdefault(module, _Upgrade())
        upgrade.fetch = fetch
    if not threading.main_thread().is_alive():  # shutting down: no thread would be joined
        _upgrade(module, upgrade, build)
        if upgrade.folder is not None:  # exit hooks registered now would not run
            shutil.rmtree(upgrade.folder, ignore_errors=True)
        return
    upgrade.start = functools.partial(_start, module, upgrade, build)
    upgrade.use_to_start = USE_PER_CHARACTER * effort
    if upgrade.use_to_start <= 0 or not hasattr(module, "_quick_use"):
        _start_now(upgrade)
        return
    _watch()


def _start_now(upgrade):
    """Start ``upgrade``'s build where it has not started yet (under
    :data:`_STARTS`: its thread is running and recorded once that is free)."""
    with _STARTS:
        with _STATE:
            start, upgrade.start = upgrade.start, None
        if start is not None:
            QUICK_STATS["started"] += 1
            start()


def _watch():
    """Make sure the thread that starts the builds whose use pays runs."""
    global _WATCHER
    with _STATE:
        if _WATCHER is not None and _WATCHER.is_alive():
            return
        _WATCHER = threading.Thread(target=_start_those_that_pay, daemon=True,
                                    name="kanedyn-optimized-when-it-pays")
        _WATCHER.start()


def _start_those_that_pay():
    """Every :data:`_LOOK_EVERY` s, start the builds whose quick module has been
    used :attr:`_Upgrade.use_to_start` s; ends when none waits (or the
    interpreter shuts down: no build starts then)."""
    while threading.main_thread().is_alive():
        time.sleep(_LOOK_EVERY)
        with _STATE:
            waiting = [(module, upgrade) for module, upgrade in _UPGRADES.items()
                       if upgrade.start is not None]
        if not waiting:
            return
        for module, upgrade in waiting:
            if module._quick_use() >= upgrade.use_to_start \
                    and threading.main_thread().is_alive():
                _start_now(upgrade)


def _start(module, upgrade, build):
    """Start the optimized build of the quick ``module`` (see :func:`optimize_later`)."""
    locked = threading.Event()
    upgrade.thread = threading.Thread(
        target=_upgrade, args=(module, upgrade, lambda: build(when_locked=locked.set)),
        name="kanedyn-optimized-build")
    upgrade.thread.start()
    # a child forked from now on finds the build's file lock held and waits for the
    # module (not longer: another process may hold that lock, building it)
    locked.wait(_LOCKED_WITHIN)


def _upgrade(module, upgrade, obtain):
    """Point the quick ``module`` at the code of the optimized module that
    ``obtain()`` returns (``None``: none came; the quick module stays) and call
    the callbacks waiting for it."""
    try:
        final = obtain()
        if final is None:
            return
        module._adopt(final._entry)  # runs under way move onto the optimized code too
    except Exception as exc:  # noqa: BLE001  reported; the quick module stays
        warnings.warn(f"the optimized build of a compiled model failed ({exc}); the "
                      "model keeps its quickly compiled module", RuntimeWarning,
                      stacklevel=1)  # from the build's thread: no caller of the user's
        return
    QUICK_STATS["optimized"] += 1
    with _STATE:
        upgrade.final = final
        callbacks = upgrade.callbacks + upgrade.cache_callbacks
        upgrade.callbacks, upgrade.cache_callbacks = [], []
    for callback in callbacks:
        try:
            callback(final)
        except Exception as exc:  # noqa: BLE001  the other callbacks still run
            warnings.warn(f"moving a compiled model onto its optimized module failed "
                          f"({exc!r}); it keeps its quickly compiled module",
                          RuntimeWarning, stacklevel=1)


def when_optimized(module, callback):
    """Call ``callback(optimized module)`` once the optimized replacement of
    ``module`` is loaded (from the build's thread; at once when it is loaded
    already); nothing for a module that is not a quick one, or whose optimized
    build failed."""
    _when(module, callback, at_once_if_final=False)


def when_cached(module, callback):
    """Call ``callback(module in the cache)`` once ``module`` is in the cache:
    at once for a module that is not a quick one (``None`` included), else as
    :func:`when_optimized` (never if its optimized build fails)."""
    _when(module, callback, at_once_if_final=True)


def _when(module, callback, at_once_if_final):
    upgrade = _UPGRADES.get(module) if module is not None else None
    if at_once_if_final and upgrade is not None:  # wanted in the cache: built now
        _start_now(upgrade)
    with _STATE:
        if upgrade is not None and upgrade.final is None:
            (upgrade.cache_callbacks if at_once_if_final else upgrade.callbacks).append(callback)
            return
    if upgrade is not None:
        callback(upgrade.final)
    elif at_once_if_final:
        callback(module)


def finish_compiling(timeout=None, start_waiting=True):
    """Start the optimized builds that wait for their quick module's use to
    pay (:func:`optimize_later`) and wait for those that run in the background
    (and for the models bound to their quick modules to move onto them).

    Parameters
    ----------
    timeout : float or None
        Longest wait, s (``None``: until they end).
    start_waiting : bool
        Whether the builds that wait for their use to pay are started too
        (``False``: only those running are waited for).

    Returns
    -------
    bool
        ``True`` when none runs any longer.
    """
    deadline = None if timeout is None else time.monotonic() + timeout
    for upgrade in list(_UPGRADES.values()) if start_waiting else ():
        _start_now(upgrade)
    with _STARTS, _STATE:  # a start under way elsewhere has recorded its thread
        threads = [u.thread for u in _UPGRADES.values() if u.thread is not None]
    for thread in threads:
        thread.join(None if deadline is None else max(0.0, deadline - time.monotonic()))
    return not any(thread.is_alive() for thread in threads)


def _catch_up_after_fork():
    """A forked child has none of its parent's build threads: for each quick
    module whose optimized build was under way, a daemon thread of the child
    waits for the parent to cache the optimized module and then moves the
    child onto it (the child's exit does not wait for it; what waits for the
    module to be cached is left to the parent); a quick module without
    ``fetch`` stays."""
    global _STATE, _STARTS, _WATCHER
    _STATE = threading.Lock()
    _STARTS = threading.Lock()
    _WATCHER = None
    waiting = False
    for module, upgrade in list(_UPGRADES.items()):
        if upgrade.final is not None:
            continue
        upgrade.cache_callbacks = []
        if upgrade.start is not None:  # not started: the child's own use decides
            waiting = True
            continue
        if upgrade.fetch is None:
            del _UPGRADES[module]
            continue
        upgrade.thread = threading.Thread(target=_upgrade, args=(module, upgrade, upgrade.fetch),
                                          name="kanedyn-optimized-fetch", daemon=True)
        upgrade.thread.start()
    if waiting:
        _watch()


after_fork_in_child(_catch_up_after_fork, starts_threads=True)
# a forked child owns none of its parent's prefetched units (nor their folders)
after_fork_in_child(_PREFETCHED.clear)
atexit.register(drop_prefetched)
