"""Build and cache of the compiled backend's extension modules (no SymPy here).

A module is compiled with the system C compiler on first use and cached on
disk under a name derived from the SHA-256 of its source and build settings
(:func:`cache_dir`: ``$KANEDYN_CACHE_DIR``, else ``$XDG_CACHE_HOME/kanedyn``
or ``~/.cache/kanedyn``; without a home directory, none).  Builds happen in a
private temporary directory and are published with an atomic rename, so
several processes may build the same module at once; every entry carries a
checksum and an entry that fails it (or fails to load) is rebuilt.  The
checksum detects damage, not who wrote the entry: nothing is loaded from a
cache directory that another user could change (:mod:`kanedyn._trusted_files`:
the directory and every one on the way to it owned by this user or root and
writable by no one else, by mode and ACL, symbolic links of others refused;
the process then builds in a private directory, made where no one else can
change it, with a warning), nor any entry in it that is not this user's or
root's or that others can write (a warning; it is removed and built again).
A module is loaded through the descriptor it was checked on, and a cached
object linked from a copy read through the one it was checked on.  Directories are created with mode 0700,
files 0600.  A build that cannot write the cache (a full disk) is done again
in the private directory, with a warning; where that fails too,
:class:`CompilerError` names the path.

A source may consist of several translation units separated by
:data:`UNIT_MARK`: they are compiled at the same time, one compiler process
per CPU, and linked into one module (large generated functions dominate the
build, and a compiler works on one unit with one core).  The object of every
unit is cached too, under the hash of its text and flags, and linked again
wherever the same unit comes back.  A unit known before its module (the
generic runtime, the same for models of any size) can be started early
with :func:`prefetch`: the build that meets it takes the running compiler
over.

Loading a cached module needs only this module, NumPy and the standard
library: a second process starts without importing SymPy.
"""

from __future__ import annotations

import atexit
import contextlib
import errno
import functools
import hashlib
import importlib.machinery
import importlib.util
import json
import os
import re
import shlex
import shutil
import signal
import stat
import sys
import sysconfig
import tempfile
import threading
import time
import warnings
from pathlib import Path

import numpy as np

from ..._errors import KanedynError
from ..._fork import FileLock, after_fork_in_child, remove_at_exit, spawn
from ..._trusted_files import (PRIVATE_FILE, UntrustedFile, descriptor_path, open_entry,
                               open_trusted, private_directory, trusted_directory,
                               untrusted_entry)
from ._c_quick import (compile_quick, drop_prefetched, optimize_later, prefetch_quick,
                       prefetched_folders, quick_command)

__all__ = ["CompilerError", "load_module", "load_fixed_module", "compiler_command",
           "missing_compiler_text", "cache_dir", "trusted_cache_dir", "prefetch",
           "unit_flags", "STATS", "NAME_TOKEN", "UNIT_MARK", "LIGHT_UNIT", "COLD_UNIT"]

NAME_TOKEN = "KDMODULENAME"  # stands for the module name in generated templates
#: separates the translation units of a module source (see :func:`load_module`)
UNIT_MARK = "\n/* ---- kanedyn: next translation unit ---- */\n"
#: first line of a translation unit compiled at -O1 (not -O2): code whose speed
#: does not depend on the optimizer's loop passes (entry points, argument
#: parsing, the integrator's bookkeeping), where -O2 only costs compile time
LIGHT_UNIT = "/* kanedyn: compiled at -O1 */\n"
#: first line of a translation unit compiled at -O0: code off every simulation's
#: path (a model's energies and constraint forces, evaluated once per output
#: point), where optimization costs compile time and saves next to nothing
COLD_UNIT = "/* kanedyn: compiled at -O0 */\n"
_LOADED = {}  # hash -> module, per process
_LOCK = threading.Lock()
#: held by a quick build made while another thread holds _LOCK (:func:`_quick_meanwhile`)
_QUICK_LOCK = threading.Lock()


class CompilerError(KanedynError, RuntimeError):
    """No usable C compiler, or compilation failed."""


class _NoSpace(CompilerError):
    """The compiler could not write its output: no space left (or over quota)."""


def cache_dir():
    """The cache directory asked for (the one used is :func:`trusted_cache_dir`):
    ``$KANEDYN_CACHE_DIR``, else ``$XDG_CACHE_HOME/kanedyn`` where that is an
    absolute path (a relative one is ignored, as the XDG specification says),
    else ``.cache/kanedyn`` in the home directory (``$HOME`` where it is an
    absolute path, else the user database's); ``None`` when there is none."""
    env = os.environ.get("KANEDYN_CACHE_DIR")
    if env:
        return Path(env)
    if os.path.isabs(os.environ.get("XDG_CACHE_HOME", "")):
        return Path(os.environ["XDG_CACHE_HOME"]) / "kanedyn"
    home = _home()
    return None if home is None else Path(home) / ".cache" / "kanedyn"


def _home():
    """This user's home directory, or ``None``: ``$HOME`` where it is an
    absolute path, else the user database's entry (none for a user id without
    one, as a container started with ``--user 12345`` has)."""
    home = os.environ.get("HOME", "")
    if os.path.isabs(home):
        return home
    try:
        import pwd
    except ImportError:  # not POSIX
        home = os.path.expanduser("~")
    else:
        try:
            home = pwd.getpwuid(os.getuid()).pw_dir
        except KeyError:  # no entry for this user id
            return None
    return home if os.path.isabs(home) else None


def _cache_origin():
    if os.environ.get("KANEDYN_CACHE_DIR"):
        return "$KANEDYN_CACHE_DIR"
    if os.path.isabs(os.environ.get("XDG_CACHE_HOME", "")):
        return "$XDG_CACHE_HOME/kanedyn"
    return "~/.cache/kanedyn"


def compiler_command():
    """The C compiler command as a list, or ``None`` when none is available."""
    cc = os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc"
    parts = shlex.split(cc)
    if not parts or shutil.which(parts[0]) is None:
        return None
    return parts


def missing_compiler_text():
    """Why no compiler is available (names ``$CC`` when it is set)."""
    cc = os.environ.get("CC")
    if cc:
        return f"$CC is {cc!r}, which is not a program on this machine"
    return "no C compiler found (set $CC or install gcc or clang)"


def _vex_flags():
    """``["-mavx"]`` where this process runs on an x86-64 CPU with AVX that its
    system enables (as NumPy's dispatch found it), else ``[]``.

    The same scalar arithmetic in the three-operand VEX encoding of AVX
    instead of SSE2's two-operand one, which overwrites an operand: the
    register copies that needs in long generated code are gone, and more loads
    are operands (the Panda arm's derivative module: its dynamics in 4,933
    instructions instead of 6,471, the first part of its derivatives in 5,426
    instead of 7,081), the numbers bit for bit the same (no fused multiply-adds:
    ``-ffp-contract=off``).  One-state ``model.jacobians`` on C took 0.82x
    the time on the Panda, 0.86x on chain3d n = 7, 0.91x at n = 12, 0.92x on
    Solo12 (the module built both ways in one process, interleaved, thread
    CPU time, minima; load 2-3).  Part of every build's key
    (:func:`_build_key`): a cache shared with a machine without AVX keeps
    its modules apart."""
    if not sysconfig.get_platform().endswith(("x86_64", "amd64")):  # 1 ms less than platform
        return []
    try:
        try:
            from numpy._core._multiarray_umath import __cpu_features__ as features
        except ImportError:  # NumPy < 2
            from numpy.core._multiarray_umath import __cpu_features__ as features
        return ["-mavx"] if features.get("AVX") else []
    except Exception:  # noqa: BLE001  (not known: the baseline instructions)
        return []


_VEX = _vex_flags()
#: -ffp-contract=off: no fused multiply-adds where the target has them (aarch64), so
#: that the quick compiler's module (:mod:`._c_quick`) gives the same numbers;
#: :func:`_vex_flags` after the optimization level
_FLAGS = ["-O2", *_VEX, "-fPIC", "-shared", "-std=gnu11", "-fno-math-errno",
          "-ffp-contract=off", "-w"]
#: flags of one translation unit of a module built from several (linked with -shared)
_UNIT_FLAGS = ["-O2", *_VEX, "-fPIC", "-fvisibility=hidden", "-std=gnu11",
               "-fno-math-errno", "-ffp-contract=off", "-w"]
_LIGHT_FLAGS = ["-O1"] + _UNIT_FLAGS[1:]
_COLD_FLAGS = ["-O0"] + _UNIT_FLAGS[1:]
#: compile time per character of a unit relative to -O2 (gcc 12 on generated
#: code and the runtime: -O1 0.6, -O0 0.3), to start the longest run first
_EFFORT = {"-O2": 1.0, "-O1": 0.6, "-O0": 0.3}
_STALE_BUILD = 3600.0  # s: a build-* folder this old was left by a killed build
_PRIVATE = []  # this process's private cache directory, when the shared one is unusable
#: cache directory -> why a build could not write it (a full disk): read only from then on
_FULL = {}
_REFUSED = set()  # cache entries refused (reported once each)


def _build_key(source, command):
    digest = hashlib.sha256()
    flags = " ".join(command + _FLAGS + _UNIT_FLAGS + _LIGHT_FLAGS + _COLD_FLAGS)
    for part in (source, flags, sys.version, np.__version__,
                 sysconfig.get_config_var("EXT_SUFFIX") or ""):
        digest.update(part.encode())
        digest.update(b"\0")
    return digest.hexdigest()[:24]


def _checksum(handle):
    """SHA-256 of what the binary file ``handle`` holds (damage detection only:
    whoever can write a module can write its checksum)."""
    return hashlib.file_digest(handle, "sha256").hexdigest()


def _load(name, path, handle=None):
    """Import the extension module ``name`` from the cache file ``path``, which
    :func:`~kanedyn._trusted_files.open_trusted` checks (``handle``: already
    opened by it): loaded through that descriptor where the system allows
    (:func:`~kanedyn._trusted_files.descriptor_path`), so that the file mapped is
    the file checked; ``__file__`` names ``path``.

    Raises
    ------
    UntrustedFile
        Another user could have written it (nothing is loaded).
    ImportError
        It does not load.
    """
    if handle is None:
        handle = open_trusted(path)
    with handle:  # closed once loaded: the library's mapping holds the file
        # elsewhere than Linux by its path, which the directory rules protect
        via = descriptor_path(handle) or str(path)
        loader = importlib.machinery.ExtensionFileLoader(name, via)
        spec = importlib.util.spec_from_file_location(name, via, loader=loader)
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    module.__file__ = str(path)
    return module


def load_module(key_text, make_template, timeout=600, quick=False):
    """Compile (or fetch from the cache) and import a generated module.

    Parameters
    ----------
    key_text : str
        What the module computes (:func:`fingerprint`); its hash names the
        module and its cache entry.
    make_template : callable
        ``make_template()``: the C source, in which :data:`NAME_TOKEN` stands
        for the module name; called only when the module is not cached.  A
        string (translation units separated by :data:`UNIT_MARK`) or an
        iterator of units: each is compiled as soon as it comes, while the
        next ones are made (one CPU is left to the caller until the last).
    quick : bool
        Whether a module that is not cached may come from the quick compiler
        first (:mod:`._c_quick`; a caller that asks for it moves its users onto
        the optimized module with :func:`~._c_quick.when_optimized`).

    A cache directory that cannot be written (read-only, or a path that is a
    file) is used read-only where it holds a valid entry; otherwise the
    module is built in a private directory of this process, with a warning.

    Raises
    ------
    CompilerError
        No compiler, or compilation failed (with the compiler's message).
    """
    command = compiler_command()
    if command is None:
        raise CompilerError(missing_compiler_text())
    key = _build_key(key_text, command)
    module = _LOADED.get(key)  # no waiting for an optimized build of the same module
    if module is None and _LOCK.locked():  # a build runs (in the background, perhaps):
        module = _cached_meanwhile(key)     # a cached module need not wait for it
    if module is not None:
        return module
    make_template = _once(make_template)
    module, later = None, None
    if quick and _LOCK.locked():  # an optimized build runs: a quick module need not wait
        with _QUICK_LOCK:
            module, later, tried = _quick_meanwhile(f"_kd_{key}", key, make_template,
                                                    command, timeout)
        quick = not tried  # a quick compiler that failed is not run again
    if module is None:
        with _LOCK:
            try:
                module, later = _load_or_build(f"_kd_{key}", key, make_template, command,
                                               timeout, quick)
            finally:  # a prefetched unit is for this module: not wanted any longer
                _drop_prefetched()
    if later is not None:  # started once the lock is free: the build takes it
        optimize_later(module, *later)
    return module


#: the fixed kernels this process has loaded, by ``(generation, source, $CC,
#: $PATH)`` (the compiler the module's build key names, found again if either changes)
_FIXED = {}


def load_fixed_module(generation, source):
    """A compiled kernel of one fixed source (no generated part): built on
    first use, then from the cache (:func:`load_module`); once loaded, held
    by this process while ``$CC`` and ``$PATH`` stay as they were (no
    compiler looked up, no source hashed again: 0.27 ms a call for the
    interior point's KKT kernel, asked for twice a solve).

    Parameters
    ----------
    generation : str
        Changes whenever the source's meaning changes (the cache key holds it).
    source : str
        The C source, in which ``@NAME@`` stands for the module name.

    Raises
    ------
    CompilerError
        No C compiler, or the compilation failed.
    """
    held = (generation, source, os.environ.get("CC"), os.environ.get("PATH"))
    module = _FIXED.get(held)
    if module is None:
        named = source.replace("@NAME@", NAME_TOKEN)
        module = _FIXED[held] = load_module(f"{generation}\n{named}", lambda: named)
    return module


def _once(make_template):
    """``make_template`` called at most once: a second call returns the first's
    template (an iterator of units kept as they come, :class:`_Replayable`)."""
    made = []

    def template():
        if not made:
            found = make_template()
            made.append(found if isinstance(found, str) else _Replayable(found))
        return made[0]
    return template


def _quick_meanwhile(name, key, make_template, command, timeout):
    """``(module, later, tried)``: ``(module, later)`` as :func:`_load_or_build`
    for a module from the quick compiler, made while another thread holds the
    build lock (the optimized build of another module, which takes seconds of
    gcc: generating this module's source and compiling it with tcc need not
    wait for it); ``(None, None)`` where that is not possible as it comes (no
    quick compiler, a cache directory that is not the shared one, writable and
    trusted, a quick compiler that fails, a write that fails): the caller then
    builds under the lock, with the template already made, and without the
    quick compiler where ``tried`` (it ran and failed)."""
    quick_cc = quick_command()
    directory, unusable, unwritable = _shared_cache()
    if quick_cc is None or unusable is not None or unwritable is not None:
        return None, None, False
    module = _LOADED.get(key)
    if module is not None:
        return module, None, False
    so_path, manifest = _entry(directory, name)
    try:
        with FileLock(directory / f"{name}.lock"):
            module = _try_cached(name, so_path, manifest, repair=False)
            if module is None:
                units = [unit.replace(NAME_TOKEN, name) for unit in _units(make_template())]
                module = compile_quick(name, units, quick_cc, _includes(), _load, directory,
                                       timeout)
                if module is None:
                    return None, None, True
                later = _later(name, key, units, command, timeout, _single(make_template()),
                               directory)
            else:
                later = None
    except OSError:  # a full disk, say: the build under the lock deals with it
        return None, None, False
    _LOADED[key] = module
    return module, later, False


def _units(template):
    """The translation units of a template (a string or an iterator of units)."""
    return template.split(UNIT_MARK) if isinstance(template, str) else template


def _single(template):
    """Whether a template is one translation unit given as a string."""
    return isinstance(template, str) and UNIT_MARK not in template


def cached_module(key_text):
    """The module of ``key_text`` (as for :func:`load_module`) where this process
    has it or the cache holds it (loaded read only), else ``None``: nothing is
    built."""
    command = compiler_command()
    if command is None:
        return None
    key = _build_key(key_text, command)
    return _LOADED.get(key) or _cached_meanwhile(key)


def _entry(directory, name):
    """``(module file, manifest)`` of the cache entry of the module ``name``."""
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    return directory / f"{name}{suffix}", directory / f"{name}.json"


def _cached_meanwhile(key):
    """The cached module of ``key`` loaded without the build lock (and recorded),
    or ``None``: read only, an entry being written or damaged is left to the
    build path."""
    directory, unusable, _ = _shared_cache(writing=False)
    if unusable is not None:
        return None
    name = f"_kd_{key}"
    module = _try_cached(name, *_entry(directory, name), repair=False)
    if module is not None:
        module = _LOADED.setdefault(key, module)
    return module


def _load_or_build(name, key, make_template, command, timeout, quick=False):
    """``(module, later)``: the module ``name`` of :func:`load_module` (called
    under its lock) and, for a module from the quick compiler, the functions
    that build and load its optimized replacement and that load it once another
    process built it (the arguments of :func:`~._c_quick.optimize_later`; else
    ``None``)."""
    module = _LOADED.get(key)
    if module is not None:
        return module, None
    directory, unusable, unwritable = _shared_cache()
    if unusable is None and unwritable is not None:
        module = _try_cached(name, *_entry(directory, name), repair=False)
        if module is not None:
            _LOADED[key] = module
            return module, None
    if unusable is not None or unwritable is not None:
        directory = _private_cache(_cache_problem(unusable or unwritable))
    units, single = None, False  # made once: a build that finds no room is done again

    def load_or_build(directory):
        nonlocal units, single
        _remove_stale_builds(directory, timeout)
        so_path, manifest = _entry(directory, name)
        with FileLock(directory / f"{name}.lock"):
            module = _try_cached(name, so_path, manifest)
            if module is not None:
                return module, None
            if units is None:
                template = make_template()
                single = _single(template)
                units = _Replayable(unit.replace(NAME_TOKEN, name)
                                    for unit in _units(template))
            quick_cc = quick_command() if quick else None
            if quick_cc is not None:
                units = list(units)
                module = compile_quick(name, units, quick_cc, _includes(), _load,
                                       directory, timeout)
            if module is not None:
                return module, _later(name, key, units, command, timeout, single,
                                      directory)
            _build(units, command, so_path, manifest, timeout, single=single)
            return _load(name, so_path), None

    module, later = _with_room(directory, load_or_build)
    _LOADED[key] = module
    return module, later


def _later(name, key, units, command, timeout, single, directory):
    """The arguments of :func:`~._c_quick.optimize_later` for the quick module
    ``name`` of the translation units ``units``: its optimized build, its load
    from the cache (a forked child's) and the build's effort."""
    return (functools.partial(_optimized, name, key, units, command, timeout, single,
                              directory),
            functools.partial(_from_the_cache, name, key, directory),
            _build_effort(units, command, directory))


def _optimized(name, key, units, command, timeout, single, directory, when_locked=None):
    """Build (or find in the cache, built by another process meanwhile) and load
    the module ``name`` of :func:`load_module` that a quick module stands in for
    (in the background thread of :func:`~._c_quick.optimize_later`, which learns
    from ``when_locked()`` that the entry's file lock is held)."""
    def build(so_path, manifest):
        _build(iter(units), command, so_path, manifest, timeout, single=single)

    with _LOCK:
        return _with_room(directory, lambda place: _from_the_cache(name, key, place, build,
                                                                   when_locked))


def _from_the_cache(name, key, directory, build=None, when_locked=None):
    """The module ``name`` loaded from its cache entry in ``directory`` under
    the entry's file lock (then ``when_locked()`` is called), after
    ``build(module file, manifest)`` where there is none, and recorded as the
    module of ``key``.  Without ``build``: read only, ``None`` where there is
    no valid entry (a forked child waiting for the module its parent builds:
    the file lock is waited for, not the build lock of this process)."""
    so_path, manifest = _entry(directory, name)
    with FileLock(directory / f"{name}.lock"):
        if when_locked is not None:
            when_locked()
        module = _try_cached(name, so_path, manifest, repair=build is not None)
        if module is None and build is not None:
            build(so_path, manifest)
            module = _load(name, so_path)
    if module is not None:
        _LOADED[key] = module
    return module


class _Replayable:
    """The items of an iterator, which each iteration yields from the first:
    those an earlier one took, then the ones it takes on."""

    def __init__(self, items):
        self.items, self.taken = iter(items), []

    def __iter__(self):
        k = 0
        while True:
            if k == len(self.taken):
                try:
                    self.taken.append(next(self.items))
                except StopIteration:
                    return
            yield self.taken[k]
            k += 1


def _with_room(directory, work):
    """``work(directory)``; where it cannot write the shared cache ``directory``
    (a full disk, a quota, a directory removed meanwhile) ``work(private
    directory)`` (with a warning, and ``directory`` read only from then on).

    Raises
    ------
    CompilerError
        The private directory cannot be written either (naming the path)."""
    try:
        return work(directory)
    except (OSError, _NoSpace) as exc:
        if _PRIVATE and directory == _PRIVATE[0]:
            raise _unwritten(directory, exc) from None
        _FULL[directory] = f"could not be written ({_what_failed(exc)})"
        full = isinstance(exc, _NoSpace) or exc.errno in (errno.ENOSPC, errno.EDQUOT)
        private = _private_cache(f"the cache directory {directory} {_FULL[directory]}",
                                 "free some space there to keep them" if full else None)
    try:
        return work(private)
    except (OSError, _NoSpace) as exc:
        raise _unwritten(private, exc) from None


def _what_failed(exc):
    """What a failed write ``exc`` (an :class:`OSError`, or :class:`_NoSpace`:
    the compiler's line that says so) says, with the path it names."""
    if isinstance(exc, _NoSpace):
        return next(line.strip() for line in str(exc).splitlines()
                    if any(words in line for words in _NO_SPACE))
    if exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or exc}"
    return str(exc.strerror or exc)


def _unwritten(directory, exc):
    return CompilerError(f"a compiled module could not be built in {directory} "
                         f"({_what_failed(exc)}); free some space there or set "
                         "KANEDYN_CACHE_DIR (TMPDIR for a private directory) to a disk "
                         "with room")


def _shared_cache(writing=True):
    """``(directory, unusable, unwritable)``: the cache directory of
    :func:`cache_dir` (followed and checked by
    :func:`~kanedyn._trusted_files.trusted_directory`: its path with symbolic
    links resolved, created with mode 0700 where missing), why nothing may be
    loaded from it (there is none, it is a file, cannot be created, or another
    user could change it; ``None``: modules may be loaded from it) and why
    modules cannot be written to it (``None``: they can; not looked at without
    ``writing``)."""
    requested = cache_dir()
    if requested is None:
        return None, _NO_HOME, None
    if os.path.exists(requested) and not os.path.isdir(requested):
        return requested, "is a file, not a directory", None
    try:
        directory, untrusted = trusted_directory(
            requested, advice="set KANEDYN_CACHE_DIR to a directory of your own")
    except OSError as exc:
        return requested, f"cannot be written ({exc.strerror or exc})", None
    if untrusted is not None:
        return directory, (f"could be changed by another user, who could make this "
                           f"process run their code: {untrusted}; nothing is loaded from "
                           "it"), None
    return directory, None, (_FULL.get(directory) or _unwritable(directory)) if writing \
        else None


_NO_HOME = ("there is no cache directory: KANEDYN_CACHE_DIR is not set, nor XDG_CACHE_HOME "
            "to an absolute path, and the home directory is unknown ($HOME is not an "
            "absolute path and the user database has no entry for this user)")


def _cache_problem(problem):
    """``problem`` of :func:`_shared_cache`, with the cache directory named."""
    requested = cache_dir()
    if requested is None:
        return problem
    return f"the cache directory {requested} ({_cache_origin()}) {problem}"


def trusted_cache_dir():
    """The directory this process keeps its caches in: :func:`cache_dir` (its
    path resolved, created with mode 0700 where missing) when no user but this
    one and root can change it or a directory above it (it may be read only),
    else this process's private directory (a warning names the problem)."""
    directory, unusable, _ = _shared_cache(writing=False)
    return directory if unusable is None else _private_cache(_cache_problem(unusable))


def _unwritable(directory):
    """Why modules cannot be written to the existing ``directory`` (``None``
    when they can)."""
    try:
        with tempfile.NamedTemporaryFile(dir=directory, prefix=".probe-"):
            pass
    except OSError as exc:
        return f"cannot be written ({exc.strerror or exc})"
    return None


def _private_cache(reason, keep=None):
    """This process's private cache directory (created and announced once:
    ``reason`` why the shared one is not used, ``keep`` what keeps the modules
    for the next process, by default a ``$KANEDYN_CACHE_DIR`` of one's own)."""
    keep = keep or "set KANEDYN_CACHE_DIR to a writable directory of your own to keep them"
    if not _PRIVATE:
        try:
            path, passed_over = private_directory("kanedyn-cache-")
        except OSError as exc:
            raise CompilerError(f"{reason}, and no private directory can be made ({exc}); set "
                                "KANEDYN_CACHE_DIR to a directory of your own") from None
        remove_at_exit(path)
        _PRIVATE.append(path)
        warnings.warn(f"{reason}; compiled modules are built in {path} for this process "
                      f"only ({keep})" + "".join(f"; temporary directory passed over: {problem}"
                                                for problem in passed_over),
                      RuntimeWarning, stacklevel=4)
    return _PRIVATE[0]


#: the folders a build, a prefetched unit and a quick build make in the cache
#: (:func:`tempfile.mkdtemp`'s names), and the files they hold: all that
#: :func:`_remove_stale_builds` removes
_WORK_FOLDER = re.compile(r"(build|prefetch|quick)-[a-z0-9_]{8}")
_WORK_FILE = re.compile(r"unit\d*\.[co]|manifest\.json|said\.txt|_kd_[0-9a-f]{24}\..*")


def _remove_stale_builds(directory, timeout):
    """Remove the ``build-*``, ``prefetch-*`` and ``quick-*`` folders that killed
    builds and processes left behind in the trusted cache ``directory`` (not
    this process's prefetched units): only folders of this user with the names
    kanedyn gives them, and only where they hold nothing but files with the
    names kanedyn writes there (anything else is left as it is)."""
    limit = time.time() - max(_STALE_BUILD, 2 * timeout)
    own = {made.parent for _, _, made, _ in _PREFETCHED.values()} | prefetched_folders()
    try:
        found = os.listdir(directory)
    except OSError:
        return
    for folder in (directory / name for name in found if _WORK_FOLDER.fullmatch(name)):
        try:
            info = folder.lstat()
            if folder in own or not stat.S_ISDIR(info.st_mode) \
                    or info.st_uid != os.geteuid() or info.st_mtime >= limit:
                continue
            names = os.listdir(folder)
            if not all(_WORK_FILE.fullmatch(name) for name in names):
                continue
            for name in names:
                if not stat.S_ISDIR((folder / name).lstat().st_mode):
                    (folder / name).unlink()
            folder.rmdir()
        except OSError:
            pass


def _try_cached(name, so_path, manifest, repair=True):
    """The cached module, if its entry is complete, this user's or root's and
    writable by no one else (:func:`~kanedyn._trusted_files.open_trusted`), and
    passes its checksum.

    A corrupt, stale or untrusted entry is removed (``repair``) so that it is
    rebuilt; an untrusted one is reported.
    """
    if not (os.path.lexists(so_path) and os.path.lexists(manifest)):
        return None
    try:
        with open_trusted(manifest) as handle:
            recorded = json.loads(handle.read())["sha256"]
        with open_trusted(so_path) as handle:  # the file checked, loaded through its descriptor
            if recorded != _checksum(handle):
                raise ValueError("checksum mismatch")
            return _load(name, so_path, handle)
    except Exception as exc:  # noqa: BLE001  corrupt or stale entry: rebuild it
        if isinstance(exc, UntrustedFile):
            _refuse(str(exc), repair)
        for path in (so_path, manifest) if repair else ():
            try:
                path.unlink()
            except OSError:
                pass
        return None


def _refuse(problem, removed):
    """Report (once) a cache entry that is not loaded: ``problem`` names it."""
    if problem not in _REFUSED:
        _REFUSED.add(problem)
        warnings.warn(f"{problem}: not loaded (the cache loads only files of this user or "
                      "root that no one else can write)" + (
                          "; it is removed and built again" if removed else ""),
                      RuntimeWarning, stacklevel=2)


#: what this process did (read by tests): ``compiles``, modules built;
#: ``units``, translation units compiled; ``reused``, units whose object was cached
STATS = {"compiles": 0, "units": 0, "reused": 0}


def _build(units, command, so_path, manifest, timeout, single=False):
    """Compile the translation units ``units`` (an iterable of C sources), each
    as soon as it comes, and link them into ``so_path`` (with its ``manifest``,
    both mode 0600); a ``single`` unit is built in one step.

    The object of every unit is kept in ``objects`` beside ``so_path`` under the hash
    of its text and flags, and a unit met again (the generated functions a
    model's second module shares with its first, with M or the lanes added)
    is linked from there instead of compiled.  A link that fails with reused
    objects is done again with every unit compiled."""
    STATS["compiles"] += 1
    includes = _includes()
    directory = so_path.parent

    def compile_unit(c_path, flags):
        jobs.add(command + flags + includes
                 + ["-c", str(c_path), "-o", str(c_path.with_suffix(".o"))],
                 cost=c_path.stat().st_size * _EFFORT[flags[0]])

    adopted = []  # (unit, object the prefetched compiler writes): folders removed at the end

    def link(object_paths):
        jobs.add(command + ["-shared"] + [str(path) for path in object_paths]
                 + ["-o", str(out_path), "-lm"])
        jobs.finish()

    # removed by this thread when the build ends (not by an exit hook, which a
    # child forked during a build in the background would run on its parent's folder)
    tmp = tempfile.mkdtemp(dir=directory, prefix="build-")
    with _removing_folder(tmp), _Jobs(command, timeout) as jobs, _removing(adopted):
        out_path = Path(tmp) / so_path.name
        paths, size, flags, cached, reused = [], 0, [], [], []
        for k, text in enumerate(units):
            c_path = Path(tmp) / f"unit{k}.c"
            c_path.write_text(text)
            size += len(text)
            paths.append(c_path)
            if single:
                continue
            unit_flags, unit_object = _unit_object(text, command, directory)
            flags.append(unit_flags)
            cached.append(unit_object)
            started = _take_prefetched(cached[-1].stem, first=k == 0)
            if _reuse(cached[-1], c_path.with_suffix(".o")):
                reused.append(k)
                _stop(started)
            elif started is not None and started[0].poll() is None:  # compiling this unit
                jobs.running.append(started[:2])
                adopted.append((k, started[2]))
            elif started is not None and _take_object(started, c_path.with_suffix(".o")):
                pass  # compiled before it was asked for
            else:
                compile_unit(c_path, flags[-1])
                jobs.step(build_jobs() - 1)  # one CPU keeps making the units
        if single:
            jobs.add(command + _FLAGS + includes + [str(paths[0]), "-o", str(out_path), "-lm"])
            jobs.finish()
        else:
            made = [k for k in range(len(paths)) if k not in reused]
            jobs.finish()
            for k, made_object in adopted:
                os.replace(made_object, paths[k].with_suffix(".o"))
            STATS["units"] += len(made)
            STATS["reused"] += len(reused)
            _keep_objects([(paths[k].with_suffix(".o"), cached[k]) for k in made])
            try:
                link([path.with_suffix(".o") for path in paths])
            except CompilerError as exc:
                if not reused or isinstance(exc, _NoSpace):
                    raise
                for k in reused:  # a damaged object: compile those units after all
                    with contextlib.suppress(OSError):  # a read-only object cache
                        cached[k].unlink(missing_ok=True)
                    compile_unit(paths[k], flags[k])
                jobs.finish()
                STATS["units"] += len(reused)
                STATS["reused"] -= len(reused)
                _keep_objects([(paths[k].with_suffix(".o"), cached[k]) for k in reused])
                link([path.with_suffix(".o") for path in paths])
        if not out_path.exists():
            raise CompilerError(f"the C compiler {' '.join(command)} wrote no module")
        with open(out_path, "rb") as made_module:
            checksum = _checksum(made_module)
        _private_mode(out_path)
        os.replace(out_path, so_path)
        tmp_manifest = Path(tmp) / "manifest.json"
        tmp_manifest.write_text(json.dumps({"sha256": checksum, "source_bytes": size,
                                            "units": len(paths)}))
        _private_mode(tmp_manifest)
        os.replace(tmp_manifest, manifest)


def _private_mode(path):
    """Make the file ``path`` readable and writable by its owner alone (where
    the file system cannot, a file others can write is refused when read)."""
    with contextlib.suppress(OSError):
        os.chmod(path, PRIVATE_FILE)


def unit_flags(text):
    """The compiler flags of a translation unit: -O1 for a :data:`LIGHT_UNIT`,
    -O0 for a :data:`COLD_UNIT`, else -O2 (the optimization level first)."""
    return _LIGHT_FLAGS if text.startswith(LIGHT_UNIT) else \
        _COLD_FLAGS if text.startswith(COLD_UNIT) else _UNIT_FLAGS


def _build_effort(units, command, directory):
    """What the optimized build of ``units`` costs, in characters compiled at
    -O2 (:data:`_EFFORT`): those whose object the cache of ``directory`` holds
    are linked, not compiled."""
    effort = 0.0
    for text in units:
        flags, cached = _unit_object(text, command, directory)
        if not cached.exists():
            effort += _EFFORT[flags[0]] * len(text)
    return effort


def _unit_object(text, command, directory):
    """``(flags, object)`` of a translation unit: its :func:`unit_flags` and its
    place in the object cache of ``directory``, under the hash of its text and
    flags."""
    flags = unit_flags(text)
    return flags, directory / "objects" / f"{_build_key(text, command + flags)}.o"


@contextlib.contextmanager
def _removing_folder(folder):
    """Remove ``folder`` however the block ends."""
    try:
        yield
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@contextlib.contextmanager
def _removing(adopted):
    """Remove the folders of the prefetched units a build took over
    (``(unit, object)`` pairs), however the build ends."""
    try:
        yield
    finally:
        for _, made in adopted:
            shutil.rmtree(made.parent, ignore_errors=True)


def _take_object(prefetched, target):
    """Move the object of a prefetched compile that has finished to ``target``;
    ``False`` (and nothing moved) when it failed or its object is gone.  Its
    files are removed either way."""
    proc, said, made, _ = prefetched
    said.close()
    try:
        if proc.returncode != 0:
            return False
        os.replace(made, target)
        return True
    except OSError:
        return False
    finally:
        shutil.rmtree(made.parent, ignore_errors=True)


def _cached_object(cached):
    """The cached object ``cached`` opened for reading where it may be linked:
    present and not empty (a crash right after publishing can leave an empty
    file, which a linker accepts as an empty script; any other damage fails the
    link, and the units are then compiled), and it and its folder this user's
    or root's and writable by no one else (else reported, and ``None``)."""
    handle, problem = open_entry(cached)
    if problem is not None:
        _refuse(problem, removed=False)
    if handle is None or os.fstat(handle.fileno()).st_size > 0:
        return handle
    handle.close()
    return None


def _usable(cached):
    """Whether the cached object ``cached`` may be linked (:func:`_cached_object`)."""
    handle = _cached_object(cached)
    if handle is not None:
        handle.close()
    return handle is not None


def _reuse(cached, target):
    """Copy the cached object ``cached``, where it may be linked, from the
    descriptor it was checked on to ``target`` in the build's folder (the
    linker reads that copy: the file checked); ``False`` where it may not."""
    handle = _cached_object(cached)
    if handle is None:
        return False
    with handle, open(target, "wb") as copy:
        shutil.copyfileobj(handle, copy)
    return True


def _keep_objects(pairs):
    """Copy objects just compiled into the object cache, ``(object, cached)``
    pairs (each published by an atomic rename: a reader never sees a partial
    file)."""
    for made, cached in pairs:
        part = cached.with_name(f".{cached.name}.{os.getpid()}")
        try:
            cached.parent.mkdir(mode=0o700, exist_ok=True)
            if untrusted_entry(cached.parent) is not None:
                return  # another user's folder: nothing is written there
            shutil.copyfile(made, part)
            _private_mode(part)
            os.replace(part, cached)
        except OSError:  # a full disk or a read-only cache: the module is built all the same
            with contextlib.suppress(OSError):
                part.unlink(missing_ok=True)
            return


#: object key -> (compiler process, its output file, the object it writes, the
#: object's place in the object cache); this process's prefetched units
_PREFETCHED = {}


def _after_fork():
    """A forked child owns neither its parent's prefetched compiles nor the build
    locks that a thread of the parent (an optimized build, :mod:`._c_quick`, or a
    quick build meanwhile) held."""
    global _LOCK, _QUICK_LOCK
    _PREFETCHED.clear()
    _LOCK, _QUICK_LOCK = threading.Lock(), threading.Lock()


after_fork_in_child(_after_fork)


def prefetch(unit):
    """Start compiling the translation unit ``unit`` now, before its module is
    built: a later :func:`load_module` whose source holds the same unit (same
    text and flags) takes the running compiler over instead of starting it.

    For the generic runtime of a model, known from its sizes before it is
    derived (:func:`~._c.predicted_runtime_unit`), so that the compiler works
    on it while the equations are derived.  Nothing happens without a
    compiler, with a cache directory that cannot be written (or trusted: see
    :func:`_shared_cache`), while another
    thread builds a module, or when the object is cached already.  With a
    quick compiler (:mod:`._c_quick`), the first module comes from it: the
    quick compiler is started on the unit instead
    (:func:`~._c_quick.prefetch_quick`: a few hundredths of a second of a
    CPU, where the optimizing compiler would take the derivation's second CPU
    for half a second).  A unit the
    next :func:`load_module` does not
    take (a wrong guess, or a module another process built meanwhile) is
    dropped by it (at once where its build starts with another unit), or
    when the process exits; an object it finished is kept in the object
    cache.  At most one unit is prefetched at a time (a new call drops the
    previous one).
    """
    command = compiler_command()
    if command is None or NAME_TOKEN in unit:
        return
    directory, unusable, unwritable = _shared_cache()
    if unusable is not None or unwritable is not None:
        return
    quick = quick_command()
    if quick is not None:  # the optimizing compiler keeps off the derivation's CPUs
        prefetch_quick(unit, quick, _includes(), directory)
        return
    flags, cached = _unit_object(unit, command, directory)
    if not _LOCK.acquire(blocking=False):  # another thread builds: no waiting for it
        return
    try:
        if cached.stem in _PREFETCHED or _usable(cached):
            return
        _drop_prefetched()
        folder, said = None, None
        try:
            folder = Path(tempfile.mkdtemp(dir=directory, prefix="prefetch-"))
            c_path = folder / "unit.c"
            c_path.write_text(unit)
            said = tempfile.TemporaryFile(mode="w+")
            proc = _compiler_process(command + flags + _includes()
                                     + ["-c", str(c_path), "-o", str(c_path.with_suffix(".o"))],
                                     said)
        except OSError:  # a full disk, say: the build compiles the unit
            if said is not None:
                said.close()
            if folder is not None:
                shutil.rmtree(folder, ignore_errors=True)
            return
        _PREFETCHED[cached.stem] = (proc, said, c_path.with_suffix(".o"), cached)
    finally:
        _LOCK.release()


def _take_prefetched(key, first):
    """The prefetched compile of the unit with object key ``key`` (removed from
    the table), or ``None``; the first unit of a build drops prefetched units
    it is not (a wrong guess would hold a CPU all through the build)."""
    found = _PREFETCHED.pop(key, None)
    if first and found is None:
        _drop_prefetched()
    return found


def _drop_prefetched():
    """Stop the prefetched compiles nobody took and remove their files (the quick
    compiler's too)."""
    while _PREFETCHED:
        _stop(_PREFETCHED.popitem()[1])
    drop_prefetched()


def _stop(prefetched):
    """Stop a prefetched compile ``(process, output file, object, its place in
    the object cache)`` (``None``: nothing) and remove its files; an object
    it finished is kept in the object cache."""
    if prefetched is None:
        return
    proc, said, made, cached = prefetched
    if proc.poll() is None:
        _kill(proc)
    elif proc.returncode == 0 and made.exists():
        _keep_objects([(made, cached)])
    said.close()
    shutil.rmtree(made.parent, ignore_errors=True)


atexit.register(_drop_prefetched)


def _includes():
    """Include options of a unit: Python's and NumPy's C headers."""
    return [f"-I{d}" for d in (sysconfig.get_paths()["include"], np.get_include())]


def _compiler_process(cmd, said):
    """Start the compiler command ``cmd`` (output to the file ``said``) in a
    process group of its own, so that :func:`_kill` stops its children too;
    in the C locale, so that a full disk is recognised in what it says
    (:data:`_NO_SPACE`)."""
    return spawn(cmd, stdout=said, stderr=said, start_new_session=True,
                 env=dict(os.environ, LC_ALL="C"))


#: what a compiler (and its assembler and linker) says, in the C locale, when it
#: cannot write for lack of space: the C library's texts of ENOSPC and EDQUOT
_NO_SPACE = tuple(os.strerror(code) for code in (errno.ENOSPC, errno.EDQUOT))


def _kill(proc):
    """Stop a compiler run and the processes it started (the driver's ``cc1``
    and ``as`` would run on, and leave their temporary files, if only the
    driver were killed)."""
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (AttributeError, OSError):  # not POSIX, or already gone
            proc.kill()
        proc.wait()


def build_jobs():
    """Compiler processes run at once: the CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover  (not Linux)
        return max(1, os.cpu_count() or 1)


class _Jobs:
    """Compiler runs, at most :func:`build_jobs` at a time, the costliest
    waiting one first (so that a long unit does not start last and run alone:
    at chain3d n = 10 the build ended 0.08 s sooner than in the order added).

    :meth:`step` starts what may start and collects what finished; a
    failed run raises :class:`CompilerError` with the compiler's message, and
    leaving the ``with`` block kills what still runs.
    """

    def __init__(self, command, timeout):
        self.command, self.pending, self.running = command, [], []
        self.deadline = time.monotonic() + timeout
        self.timeout = timeout
        self.origin = " ($CC)" if os.environ.get("CC") else ""

    def add(self, cmd, cost=0):
        """Queue the command ``cmd``; ``cost``: its expected length (the
        characters of its unit, weighted by its optimization level), the
        order in which waiting runs start."""
        self.pending.append((cost, cmd))

    def step(self, limit):
        """Collect finished runs and start waiting ones while fewer than
        ``limit`` run; return at once."""
        self._collect()
        while self.pending and len(self.running) < max(1, limit):
            costliest = max(self.pending, key=lambda job: job[0])  # the first of equals
            self.pending.remove(costliest)
            self._start(costliest[1])

    def finish(self):
        """Run everything added, :func:`build_jobs` at a time, to its end."""
        while self.pending or self.running:
            self.step(build_jobs())
            if self.running and not self._collect():
                if time.monotonic() > self.deadline:
                    raise CompilerError(f"the C compiler {self.command[0]}{self.origin} did "
                                        f"not finish in {self.timeout} s")
                time.sleep(0.005)

    def _start(self, cmd):
        said = tempfile.TemporaryFile(mode="w+")
        try:
            proc = _compiler_process(cmd, said)
        except OSError as exc:
            said.close()
            raise CompilerError(f"could not run the C compiler {self.command[0]}"
                                f"{self.origin}: {exc}") from None
        self.running.append((proc, said))

    def _collect(self):
        done = [job for job in self.running if job[0].poll() is not None]
        for proc, said in done:
            self.running.remove((proc, said))
            said.seek(0)
            text = said.read().strip()
            said.close()
            if proc.returncode != 0:
                fault = _NoSpace if any(words in text for words in _NO_SPACE) \
                    else CompilerError
                raise fault(
                    f"the C compiler {' '.join(self.command)}{self.origin} failed (exit "
                    f"status {proc.returncode})" + (
                        ":\n" + text[-4000:] if text else
                        " and printed nothing: it does not look like a working C compiler; "
                        "set $CC to gcc or clang, or use backend='numpy'"))
        return bool(done)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        for proc, said in self.running:
            _kill(proc)
            said.close()
