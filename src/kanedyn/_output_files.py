"""Files written for the user: complete, or not there at all.

Every file kanedyn writes under a name the user gives (CSV tables, plots, pages,
C sources, saved equations, a sweep's parts and table) goes through
:func:`replacing`: the content is written to a new file in the target's folder,
created by :func:`tempfile.mkstemp` (a random name, ``O_CREAT | O_EXCL``, so it
never opens a file or symbolic link someone else put there, mode 0600 while it
is written) and written through that file descriptor only, never reopened by
name.  When it is complete it gets the mode an ordinary new file would get
(0666 less the umask, or the ``permissions`` asked for) and is renamed over the
target with :func:`os.replace` (a symbolic link at the target is replaced, not
followed).  A write that fails (a full disk, no permission) or is stopped
removes the temporary file and leaves the target as it was; an ``OSError``
becomes :class:`~kanedyn.OutputFileError` naming the target and the cause.

A target that exists and is not a regular file (``/dev/stdout``, a named pipe,
a device) cannot be replaced: it is written directly, as ``open`` would.

:func:`save_figure` saves a Matplotlib figure the same way.  Imports nothing
heavy.
"""

from __future__ import annotations

import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

from ._errors import OutputFileError

__all__ = ["replacing", "save_figure", "new_file_mode"]


def new_file_mode():
    """The mode of a new file: 0666 less the process's umask (read from
    ``/proc/self/status`` where it is, so that the umask is never changed)."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    umask = os.umask(0o077)  # elsewhere: read it by setting it (and back at once)
    os.umask(umask)
    return 0o666 & ~umask


def _special(path):
    """Whether ``path`` exists and is not a regular file (a device, a pipe)."""
    try:
        return not stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return False


@contextmanager
def replacing(path, mode="w", *, newline=None, encoding=None, permissions=None):
    """A file object on a new file that replaces ``path`` when the block ends.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write.
    mode : {"w", "wb"}
        Text or binary.
    newline, encoding : str, optional
        As for :func:`open` (text only; ``encoding`` defaults to UTF-8).
    permissions : int, optional
        The mode of the finished file; default 0666 less the umask.

    Yields
    ------
    file object

    Raises
    ------
    OutputFileError
        An ``OSError`` while the file was created, written, closed or renamed
        (naming ``path``); nothing is left behind and ``path`` is as it was.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    path = Path(path)
    text = {} if mode == "wb" else {"newline": newline, "encoding": encoding or "utf-8"}
    if _special(path):
        try:
            with open(path, mode, **text) as handle:
                yield handle
        except OSError as exc:
            raise OutputFileError(path, exc) from None
        return
    part = None
    try:
        fd, part = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name[:64]}.",
                                    suffix=".part")
        with os.fdopen(fd, mode, **text) as handle:
            yield handle
            handle.flush()
            os.chmod(handle.fileno() if os.chmod in os.supports_fd else part,
                     new_file_mode() if permissions is None else permissions)
        os.replace(part, path)
    except OSError as exc:
        _remove(part)
        raise OutputFileError(path, exc) from None
    except BaseException:
        _remove(part)
        raise


def _remove(part):
    if part is not None:
        try:
            os.unlink(part)
        except OSError:
            pass


def save_figure(figure, path, **options):
    """``figure.savefig`` through :func:`replacing`; returns the path written.

    The format is the suffix's, as Matplotlib reads it; a name without a suffix
    gets Matplotlib's default format and its suffix (``rcParams["savefig.format"]``).
    ``options`` go to ``savefig`` (``dpi``, ``bbox_inches``, ...).
    """
    path = Path(path)
    kind = path.suffix[1:].lower()
    if not kind:
        import matplotlib
        kind = matplotlib.rcParams["savefig.format"]
        path = path.with_name(f"{path.name}.{kind}")
    with replacing(path, "wb") as handle:
        figure.savefig(handle, format=kind, **options)
    return path
