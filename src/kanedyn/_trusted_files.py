"""Files no other user can change: what kanedyn's cache may load code and data from.

The cache holds compiled modules (loaded into the process: their constructors
run as its user, root included) and derivation-cache entries; a checksum
stored beside a file proves nothing about who wrote it.  The rules follow
OpenSSH's ``StrictModes``: a directory or file is trusted when it is owned by
this process's effective user or by root and no other user can write it.

- Who can write is read from the mode and, where the system has them (Linux),
  from the POSIX access control list (``system.posix_acl_access``): a named
  user other than this one and root, or a group, whose entry grants writing
  (through the ACL's mask) makes a path untrusted like the group or other
  bits do.  A directory that kanedyn writes into (the cache directory and
  the folders in it) must not carry a default ACL that would give another
  user or a group writing access to what is created there.
- A group may write only where it is this user's private group: this user's
  primary group, named as the user, with no other member listed and no other
  user in the user database having it as primary group (Debian's user private
  groups, where a umask of 002 makes everything group-writable).  Group 0
  (root) never is: processes of other users can hold it (containers started
  with ``--group-add 0``, OpenShift's arbitrary user ids).
- A directory is followed from ``/`` one component at a time, as given: each
  directory passed through must be trusted (a world-writable one with the
  sticky bit, ``/tmp``, is allowed above the last: no one can rename or remove
  there what is not theirs), and a symbolic link is followed only when it is
  this user's or root's (the kernel's ``fs.protected_symlinks`` does not cover
  a link that a program reads, as ``os.path.realpath`` does).  Missing
  directories are created with mode 0700, without the ACLs they would inherit,
  and only below directories already found trusted.
- Entries are opened without following a symbolic link and checked on the
  open descriptor (``fstat``; the ACL read from it too).  A module is loaded
  through that descriptor (:func:`descriptor_path`, ``/proc/self/fd/N`` on
  Linux): what the dynamic loader maps is the file that was checked, whoever
  renames what in between.

Where the platform has no file owners (Windows), everything is trusted; where
Python cannot read ACLs (macOS, BSD) or the file system keeps other kinds (NFSv4),
they are not examined and a module is loaded by its path, which the directory
rules protect.
"""

from __future__ import annotations

import errno
import functools
import itertools
import os
import stat
import struct
import tempfile
from pathlib import Path

from ._errors import KanedynError

__all__ = ["UntrustedFile", "trusted_directory", "untrusted_entry", "open_trusted",
           "open_entry", "private_directory", "descriptor_path", "PRIVATE_FILE"]

#: mode of the files kanedyn writes into its cache (directories: 0o700)
PRIVATE_FILE = 0o600
_POSIX = hasattr(os, "geteuid")
_MAX_LINKS = 40  # symbolic links followed in one path (Linux's own limit)
#: the extended attributes holding a file's POSIX ACLs, and the tags of their entries
_ACCESS_ACL, _DEFAULT_ACL = "system.posix_acl_access", "system.posix_acl_default"
_USER_OBJ, _USER, _GROUP_OBJ, _GROUP, _MASK, _OTHER = 0x01, 0x02, 0x04, 0x08, 0x10, 0x20
_WRITES = 0o2  # the write bit of an ACL entry's permissions


class UntrustedFile(KanedynError, OSError):
    """A cache entry that another user could have written: it is not loaded."""


def trusted_directory(path, advice=None):
    """Follow the directory ``path`` from ``/`` (see the module notes), create
    what is missing of it (mode 0700) and say why another user could change it
    or a directory on the way (``None``: no one but this user and root can).

    Parameters
    ----------
    path : str or os.PathLike
        Absolute, or relative to the working directory.
    advice : str, optional
        A remedy besides the fix named (e.g. a directory of one's own),
        appended to the problem.

    Returns
    -------
    (pathlib.Path, str or None)
        The directory with symbolic links resolved (the path checked, to be
        used from then on) and what is wrong, naming the path at fault, its
        owner and mode and the fix.

    Raises
    ------
    OSError
        A component is not a directory (``NotADirectoryError``), a missing
        one cannot be created, or the links loop.  Nothing is created below a
        directory that is not trusted.
    """
    directory, problem = _walk(path, create=True, advice=advice)
    if problem is None:
        problem = _why(directory, os.lstat(directory), "directory", advice=advice)
    return directory, problem


def private_directory(prefix):
    """A new directory of this process's own (:func:`tempfile.mkdtemp`, mode
    0700, no ACL) in the first temporary directory that no other user can
    change: Python's (``$TMPDIR``, ...), else ``/tmp``, else ``/var/tmp``.

    Returns
    -------
    (pathlib.Path, list of str)
        The directory, and why each temporary directory tried before it was
        not used.

    Raises
    ------
    OSError
        None can be used (the message says why for each).
    """
    passed_over = []
    for place in dict.fromkeys([tempfile.gettempdir(), "/tmp", "/var/tmp"]):
        try:
            parent, problem = _walk(place, create=False)
            if problem is None:
                folder = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
                _strip_acls(folder)
                problem = _why(folder, os.lstat(folder), "directory")
                if problem is None:
                    return folder, passed_over
                os.rmdir(folder)
        except OSError as exc:
            problem = f"{place}: {exc.strerror or exc}"
        passed_over.append(problem)
    raise OSError("no temporary directory that only this user and root can change: "
                  + "; ".join(passed_over))


def untrusted_entry(path):
    """Why the cache entry ``path`` (a file or a directory, not followed if it
    is a symbolic link) may not be trusted, or ``None``; the directory holding
    it must be trusted already.  Raises :class:`OSError` (``FileNotFoundError``)
    when it cannot be examined."""
    return _why(path, os.lstat(path), "entry")


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
        info = os.fstat(handle)
        if not stat.S_ISREG(info.st_mode):
            raise UntrustedFile(f"{path} is not a regular file")
        problem = _why(path, info, "entry", source=handle)
        if problem is not None:
            raise UntrustedFile(problem)
        return os.fdopen(handle, "rb")
    except BaseException:
        os.close(handle)
        raise


def open_entry(path):
    """``(handle, problem)`` of the cache file ``path`` in a trusted folder: the
    file opened as :func:`open_trusted` does and ``None``; ``(None, why)``
    where it or its folder may not be trusted; ``(None, None)`` where it
    cannot be opened (missing)."""
    try:
        problem = untrusted_entry(path.parent)
        if problem is None:
            return open_trusted(path), None
    except UntrustedFile as exc:
        problem = str(exc)
    except OSError:
        return None, None
    return None, problem


def descriptor_path(handle):
    """A path that opens the very file the open file ``handle`` holds, whatever
    has been renamed since (``/proc/self/fd/N``), spelled as no earlier call in
    this process spelled it; ``None`` where the system has none (not Linux, or
    no ``/proc``), or after 65536 calls.

    The dynamic loader (and Python's table of extension modules) knows a
    library by the text of the path it was loaded from, and a descriptor's
    number is used again once it is closed: a second library asked for by the
    same text would be taken for the first.  So the separators of the path
    carry a count (``/proc/./self/fd/N`` is the second spelling), and the
    descriptor may be closed once the library is loaded."""
    if not _proc_fd():
        return None
    count, separators = next(_SPELLINGS), []
    for _ in range(4):
        count, digit = divmod(count, 16)
        separators.append("/" + "./" * digit)
    if count:
        return None
    return "{}proc{}self{}fd{}{}".format(*separators, handle.fileno())


_SPELLINGS = itertools.count()  # calls of descriptor_path in this process


@functools.lru_cache(maxsize=None)
def _proc_fd():
    return os.path.isdir("/proc/self/fd")


def _walk(path, create, advice=None):
    """``(directory, problem)``: the directory ``path`` names, followed from
    ``/`` one component at a time (symbolic links of this user or root
    followed, ``..`` taken after them as the kernel does), each directory
    passed checked as one above the cache (a sticky one allowed) and, with
    ``create``, a missing one created (mode 0700, no ACL); at the first
    problem, the path at fault and what it is."""
    if not _POSIX:
        directory = Path(os.path.realpath(path))
        if create:
            directory.mkdir(parents=True, exist_ok=True)
        return directory, None
    given = Path(os.getcwd(), path)
    pending = list(reversed(given.parts))
    current = Path(pending.pop())  # the root
    problem = _why(current, os.lstat(current), "above", advice=advice)
    links = 0
    while pending and problem is None:
        part = pending.pop()
        if part == "..":  # of a directory reached with links resolved: checked before
            current = current.parent
            continue
        candidate = current / part
        try:
            info = os.lstat(candidate)
        except FileNotFoundError:
            if not create:
                raise
            _make_private(candidate)
            info = os.lstat(candidate)
        if stat.S_ISLNK(info.st_mode):
            if info.st_uid not in (os.geteuid(), 0):
                return candidate, _why(candidate, info, "link", advice=advice)
            links += 1
            if links > _MAX_LINKS:
                raise OSError(errno.ELOOP, os.strerror(errno.ELOOP), str(given))
            target = Path(os.readlink(candidate))
            if target.is_absolute():
                current = Path(target.parts[0])
            pending.extend(reversed(target.parts[1 if target.is_absolute() else 0:]))
            continue
        if not stat.S_ISDIR(info.st_mode):
            raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(candidate))
        problem = _why(candidate, info, "above", advice=advice)
        current = candidate
    return current, problem


def _make_private(path):
    """Create the directory ``path`` with mode 0700 whatever the umask, without
    the ACLs it would inherit from its parent's default ACL (one made meanwhile
    by another process is left as it is: it is checked)."""
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        return
    _strip_acls(path)
    os.chmod(path, 0o700)


def _strip_acls(path):
    """Remove the access and default ACLs of the directory ``path`` (this
    process made it), where it has them."""
    remove = getattr(os, "removexattr", None)
    for name in (_ACCESS_ACL, _DEFAULT_ACL) if remove is not None else ():
        try:
            remove(path, name, follow_symlinks=False)
        except OSError as exc:
            if exc.errno not in (errno.ENODATA, errno.ENOTSUP, errno.EOPNOTSUPP):
                raise


def _why(path, info, what, source=None, advice=None):
    """What is wrong with ``path`` (its ``lstat``/``fstat`` ``info``; its ACLs
    read from ``source``, a descriptor, or else from ``path`` not followed), or
    ``None``.  ``what`` is ``"directory"`` (the cache directory), ``"above"`` (a
    directory passed through on the way to it: the sticky exemption applies),
    ``"link"`` (a symbolic link on the way, not this user's or root's) or
    ``"entry"`` (something in the cache, removed rather than repaired: no fix
    is named)."""
    if not _POSIX:
        return None
    mode = info.st_mode
    source = path if source is None else source
    acls = ()
    if what == "link":
        fault, fix = "is a symbolic link of another user", None
    elif stat.S_ISLNK(mode):
        fault, fix = "is a symbolic link", None
    elif what != "entry" and not stat.S_ISDIR(mode):
        fault, fix = "is not a directory", None
    elif what == "entry" and not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        fault, fix = "is neither a regular file nor a directory", None
    elif info.st_uid not in (os.geteuid(), 0):
        fault, fix = "is owned by another user", None
    elif what == "above" and stat.S_ISDIR(mode) and mode & stat.S_ISVTX:
        return None  # others may add entries there, not rename or remove this user's
    else:
        access = _acl(source, _ACCESS_ACL)
        default = _acl(source, _DEFAULT_ACL) if what != "above" and stat.S_ISDIR(mode) \
            else None
        acls = (access, default)
        found = _writer(path, mode, info.st_gid, access) or (
            default and _writer(path, mode, info.st_gid, default, default=True))
        if not found:
            return None
        fault, fix = found
    text = (f"{path} {fault} (owner {_user(info.st_uid)}, mode {stat.filemode(mode)}"
            f"{'+' if any(acls) else ''})")  # as ls shows a file with an ACL
    if what == "entry":
        return text
    if fix is not None:
        return f"{text}; fix: `{fix}`" + (f", or {advice}" if advice else "")
    return text + (f"; {advice}" if advice else "")


def _writer(path, mode, gid, acl, default=False):
    """``(fault, fix)`` of the first user besides the owner who can write
    ``path`` (its ``mode``, group ``gid`` and access ACL entries ``acl``), or
    ``None``; with ``default``, ``acl`` is the directory's default ACL and the
    question who can write what is created in it (the mask of an inherited
    ACL follows the mode a file is created with: it is not counted)."""
    if acl is None:
        acl = [(_GROUP_OBJ, (mode >> 3) & 0o7, 0), (_OTHER, mode & 0o7, 0)]
    mask = 0o7 if default else next((perm for tag, perm, _ in acl if tag == _MASK), 0o7)
    for tag, perm, ident in sorted(acl, key=lambda entry: entry[0] != _OTHER):  # all first
        if not perm & (0o7 if tag in (_USER_OBJ, _OTHER) else mask) & _WRITES:
            continue
        if tag == _OTHER:
            who, fix = "every user", f"chmod o-w {path}"
        elif tag == _GROUP_OBJ and not _private_group(gid):
            who, fix = f"the users of group {_group(gid)}", f"chmod g-w {path}"
        elif tag == _GROUP and not _private_group(ident):
            who, fix = f"the users of group {_group(ident)}", f"setfacl -x g:{ident} {path}"
        elif tag == _USER and ident not in (os.geteuid(), 0):
            who, fix = _user(ident), f"setfacl -x u:{ident} {path}"
        else:
            continue
        if default:
            return (f"lets {who} write what is created in it (a default access control "
                    "list)"), f"setfacl -k {path}"
        return f"can be written by {who}" + (
            " through an access control list entry" if tag in (_USER, _GROUP) else ""), fix
    return None


def _acl(source, name):
    """The entries ``(tag, permissions, id)`` of the POSIX ACL ``name`` of
    ``source`` (a descriptor, or a path not followed), or ``None`` when it has
    none or the system cannot say (no ACLs there, not Linux)."""
    getxattr = getattr(os, "getxattr", None)
    if getxattr is None:
        return None
    try:
        data = getxattr(source, name) if isinstance(source, int) \
            else getxattr(source, name, follow_symlinks=False)
    except OSError as exc:
        if exc.errno in (errno.ENODATA, errno.ENOTSUP, errno.EOPNOTSUPP):
            return None
        raise
    if len(data) < 4 or (len(data) - 4) % 8 or struct.unpack_from("<I", data)[0] != 2:
        raise OSError(errno.EINVAL, f"its {name} is not in the format of version 2",
                      source if not isinstance(source, int) else None)
    return [struct.unpack_from("<HHI", data, 4 + 8 * k) for k in range((len(data) - 4) // 8)]


@functools.lru_cache(maxsize=None)
def _private_group(gid):
    """Whether the group ``gid`` is this user's private group: the user's
    primary group, named as the user, with no other member listed and no other
    user's primary group (read only for a path the group can write); never
    group 0."""
    import grp
    import pwd
    me = os.geteuid()
    if gid == 0:
        return False
    try:
        user = pwd.getpwuid(me)
        group = grp.getgrgid(gid)
    except KeyError:
        return False
    if user.pw_gid != gid or group.gr_name != user.pw_name \
            or not set(group.gr_mem) <= {user.pw_name}:
        return False
    return not any(entry.pw_gid == gid and entry.pw_uid != me for entry in pwd.getpwall())


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
