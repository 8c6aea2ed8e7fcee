"""Where a URDF's mesh file name points, and whether it may be read.

A mesh is named by a ``package://PKG/path`` URI, a ``file:`` URI (RFC 8089:
``file:///path``, ``file://localhost/path`` or ``file:/path``) or a path relative
to the URDF file.  The path of a URI is percent-decoded (RFC 3986), a relative
path is taken as written.  The file found is read only when it lies, symbolic
links resolved, inside one of the allowed folders (see
:func:`~kanedyn.models.from_urdf`).  A name the file system refuses to look up
(too long, a loop of symbolic links, a folder that may not be searched) is
reported as why the mesh is not read, never raised: a mesh is an error only
when it is asked for (:meth:`Visual.mesh_file`).
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from urllib.parse import unquote, urlsplit

__all__ = ["resolve_mesh", "shown_name"]

#: mesh names longer than this are shortened in messages
_SHOWN = 100

#: errors of a lookup that mean "no such file" (the name may still be refused by a
#: later candidate); every other OSError is reported with its cause
_ABSENT = (errno.ENOENT, errno.ENOTDIR)

_ALLOWED = ("the URDF's, package_dirs, mesh_dirs, and for package://PKG a folder PKG "
            "above the URDF that holds a package.xml")


def resolve_mesh(filename, source, package_dirs=(), mesh_dirs=()):
    """``(path, refused)`` of the mesh ``filename`` written in the URDF ``source``.

    Parameters
    ----------
    filename : str
        The ``<mesh filename=...>`` as written.
    source : str or path-like
        The URDF file (relative names are relative to its folder).
    package_dirs, mesh_dirs : sequence of path-like
        Folders of packages, and further folders meshes may be read from.

    Returns
    -------
    path : str or None
        The regular file found (symbolic links resolved), None when it was not
        found or is refused.
    refused : str
        Why the mesh is not read although its name was understood (outside the
        allowed folders, a name the file system refuses, a ``file:`` URI of
        another host); "" when it is read or simply not found.
    """
    urdf_dir = Path(source).resolve().parent
    roots = [urdf_dir, *map(Path, package_dirs), *map(Path, mesh_dirs)]
    try:
        candidates, refused = _candidates(filename, urdf_dir, package_dirs, roots)
    except ValueError as exc:  # urlsplit: a malformed authority ("file://[x/...")
        return None, f"it is not a valid URI ({exc})"
    if refused:
        return None, refused
    looked_up = [_regular_file(candidate) for candidate in candidates]
    found = [path for path, _ in looked_up if path is not None]
    roots = [root.resolve() for root in roots]
    for path in found:
        if any(path.is_relative_to(root) for root in roots):
            return str(path), ""
    if found:
        return None, (f"{found[0]} is outside the folders meshes are read from "
                      f"({_ALLOWED}): give mesh_dirs=[its folder] to from_urdf to read it")
    return None, next((problem for _, problem in looked_up if problem), "")


def _candidates(filename, urdf_dir, package_dirs, roots):
    """``(paths to look at, refused)``; adds a ROS package's folder to ``roots``."""
    scheme = filename.partition(":")[0].lower() if ":" in filename else ""
    if scheme == "package":
        uri = urlsplit(filename)
        package, rest = unquote(uri.netloc), unquote(uri.path).lstrip("/")
        if not package:
            return [], "a package:// URI names a package: package://PKG/path"
        candidates = [Path(d) / package / rest for d in package_dirs]
        for folder in (urdf_dir, *urdf_dir.parents):  # the ROS package it is in
            if folder.name == package and _regular_file(folder / "package.xml")[0]:
                candidates.append(folder / rest)
                roots.append(folder)
        return candidates, ""
    if scheme == "file":
        uri = urlsplit(filename)
        if uri.netloc.lower() not in ("", "localhost"):
            return [], (f"the file: URI names a file on the host '{uri.netloc}'; only "
                        "local files are read (file:///path or file://localhost/path)")
        path = unquote(uri.path)
        if not path.startswith("/"):
            return [], "a file: URI needs an absolute path (file:///path)"
        return [Path(path)], ""
    return [urdf_dir / filename], ""


def _regular_file(path):
    """``(resolved path or None, problem)`` of a regular file at ``path``."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return None, ""
        return path.resolve(strict=True), ""
    except OSError as exc:
        if exc.errno in _ABSENT:
            return None, ""
        return None, f"its name cannot be looked up: {exc.strerror or exc}"
    except ValueError:  # a NUL character, from a percent-decoded %00
        return None, "its name holds a NUL character"


def shown_name(filename):
    """``filename`` for a message: a name longer than 100 characters shortened."""
    if len(filename) <= _SHOWN:
        return filename
    return f"{filename[:_SHOWN // 2]}...({len(filename)} characters)"
