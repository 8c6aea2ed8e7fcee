"""Files no other user can change: what kanedyn's cache may load code and data from.

The cache holds compiled modules (loaded into the process: their constructors
run as its user, root included) and derivation-cache entries; a checksum
stored beside a file proves nothing about who wrote it.  The rules follow
OpenSSH's ``StrictModes``: a directory or file is trusted when it is owned by
this process's effective user or by root and no other user can write it, that
is, neither world-writable nor group-writable (unless its group has this user
as its only member, Debian's user private groups, where a umask of 002 makes
everything group-writable: Debian's OpenSSH allows that too).  A directory is
trusted when it and every directory above it up to ``/`` are; above it, a
world-writable directory with the sticky bit (``/tmp``) is allowed, since no
one can rename or remove there what is not theirs, and the entry below it is
checked for its owner.

A cache directory is named by its path with symbolic links resolved, so that
what was checked is what is used; entries are opened without following a
symbolic link and checked on the open descriptor (``fstat``).  Once a
directory is trusted only this user and root can change what its paths name,
so a path checked and then handed to the dynamic loader or the linker names
the file checked.  Where the platform has no file owners (Windows), everything
is trusted.
"""

from __future__ import annotations

import errno
import functools
import os
import stat

from ._errors import KanedynError

__all__ = ["UntrustedFile", "trusted_directory", "untrusted_entry", "open_trusted",
           "PRIVATE_FILE"]

#: mode of the files kanedyn writes into its cache (directories: 0o700)
PRIVATE_FILE = 0o600
_POSIX = hasattr(os, "geteuid")


class UntrustedFile(KanedynError, OSError):
    """A cache entry that another user could have written: it is not loaded."""


def trusted_directory(path):
    """Create the directory ``path`` (mode 0700 where missing) and say why
    another user could change it or a directory above it (``None``: no one
    but this user and root can).

    Parameters
    ----------
    path : pathlib.Path
        Absolute, with symbolic links resolved (``os.path.realpath``).

    Returns
    -------
    str or None
        What is wrong, naming the directory, its owner and mode and the fix.

    Raises
    ------
    OSError
        A missing directory cannot be created (nothing is created below a
        directory that is not trusted).
    """
    existing, missing = path, []
    while not os.path.lexists(existing) and existing != existing.parent:
        missing.append(existing)
        existing = existing.parent
    if missing and not os.path.isdir(existing):
        raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(existing))
    problem = _untrusted_chain(existing, path)
    if problem is not None:
        return problem
    for folder in reversed(missing):
        try:
            os.mkdir(folder, 0o700)
        except FileExistsError:  # made meanwhile (another process): checked below
            pass
    return _untrusted_chain(path, path) if missing else None


def untrusted_entry(path):
    """Why the cache entry ``path`` (a file or a directory, not followed if it
    is a symbolic link) may not be trusted, or ``None``; the directory holding
    it must be trusted already.  Raises :class:`OSError` (``FileNotFoundError``)
    when it cannot be examined."""
    return _why(path, os.lstat(path), what="entry")


def open_trusted(path):
    """The cache file ``path`` opened for reading in binary mode, after checking
    on the open descriptor that it is a regular file this user or root owns
    and no one else can write.

    Raises
    ------
    UntrustedFile
        It is not (the message names it, its owner and mode).
    OSError
        It cannot be opened (``FileNotFoundError`` when missing).
    """
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) \
        | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)
    try:
        handle = os.open(path, flags)
    except OSError:
        if os.path.islink(path):  # O_NOFOLLOW: ELOOP (or EMLINK on some systems)
            raise UntrustedFile(f"{path} is a symbolic link") from None
        raise
    try:
        problem = _why(path, os.fstat(handle), what="entry")
        if problem is not None:
            raise UntrustedFile(problem)
        return os.fdopen(handle, "rb")
    except BaseException:
        os.close(handle)
        raise


def _untrusted_chain(path, cache):
    """Why the existing directory ``path`` (the directory ``cache`` or one above
    it) or one above it is not trusted, or ``None``."""
    if not _POSIX:
        return None
    checked = path
    while True:
        info = os.lstat(checked)
        problem = _why(checked, info, what="directory" if checked == cache else "above")
        if problem is not None:
            return problem
        if checked == checked.parent:
            return None
        checked = checked.parent


def _why(path, info, what):
    """What is wrong with ``path`` (its ``lstat``/``fstat`` ``info``): ``what`` is
    ``"directory"`` (the cache directory), ``"above"`` (a directory above it:
    the sticky exemption applies) or ``"entry"`` (something in the cache,
    removed rather than repaired)."""
    if not _POSIX:
        return None
    me = os.geteuid()
    mode = info.st_mode
    sticky = what == "above" and stat.S_ISDIR(mode) and mode & stat.S_ISVTX
    if stat.S_ISLNK(mode):
        fault, fix = "is a symbolic link", None
    elif what != "entry" and not stat.S_ISDIR(mode):
        fault, fix = "is not a directory", None
    elif what == "entry" and not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        fault, fix = "is neither a regular file nor a directory", None
    elif info.st_uid not in (me, 0):
        fault, fix = "is owned by another user", f"chown {_name(me)} {path}"
    elif mode & stat.S_IWOTH and not sticky:
        fault, fix = "can be written by every user", f"chmod o-w {path}"
    elif mode & stat.S_IWGRP and not sticky and not _private_group(info.st_gid):
        fault, fix = f"can be written by the users of group {_group(info.st_gid)}", \
            f"chmod g-w {path}"
    else:
        return None
    found = f"{path} {fault} (owner {_user(info.st_uid)}, mode {stat.filemode(mode)})"
    if what == "entry" or fix is None:
        return found
    return f"{found}; fix: `{fix}`"


@functools.lru_cache(maxsize=None)
def _private_group(gid):
    """Whether the group ``gid`` has this user as its only member, by the group
    list and by the primary groups of all users (read only for a
    group-writable path)."""
    import grp
    import pwd
    me = os.geteuid()
    try:
        group = grp.getgrgid(gid)
        name = pwd.getpwuid(me).pw_name
    except KeyError:
        return False
    primary = {user.pw_uid for user in pwd.getpwall() if user.pw_gid == gid}
    listed = set(group.gr_mem)
    return primary <= {me} and listed <= {name} and bool(primary or listed)


def _name(uid):
    import pwd
    try:
        return pwd.getpwuid(uid).pw_name
    except KeyError:
        return str(uid)


def _user(uid):
    name = _name(uid)
    return f"uid {uid}" if name == str(uid) else f"{name} (uid {uid})"


def _group(gid):
    import grp
    try:
        return f"{grp.getgrgid(gid).gr_name} (gid {gid})"
    except KeyError:
        return f"gid {gid}"
