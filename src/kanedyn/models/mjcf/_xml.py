"""Reading an MJCF file into elements that know their file and line.

The XML is read by the standard library's expat parser: entity declarations
(the "billion laughs" and external entities) are refused, an external DTD is
never fetched.  ``<include file=...>`` elements are replaced by the children of
the included file's ``<mujoco>`` root, as MuJoCo does; an included file is read
only from the folder of the main file or below it, at most once, and an
include that includes itself is refused.  Numbers are plain decimals in ASCII
digits read by :func:`float`, checked to be finite, never evaluated.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from ..._errors import ModelError
from .._urdf_parse import Element as _XMLElement
from .._urdf_parse import parse_xml

__all__ = ["MJCFError", "Element", "read_mjcf", "number", "numbers"]

_XML_SPACE = " \t\r\n"
_PLAIN_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\Z", re.ASCII)
#: included files nested deeper than this are refused (a chain, not a cycle: those
#: are refused anyway)
MAX_INCLUDE_DEPTH = 20


class MJCFError(ModelError):
    """An MJCF file that cannot be read; the message names file, element and line."""


@dataclass
class Element(_XMLElement):
    """One XML element (URDF's reader's record) and the file it is in (as shown
    in messages: an included file's own name)."""

    source: str = ""

    def where(self):
        """``model.xml:12: <joint name='elbow'>``."""
        return f"{self.source}:{self.line}: {self.label()}"

    def error(self, message):
        """An :class:`MJCFError` naming this element's file and line."""
        return MJCFError(f"{self.where()}: {message}")


def _parse(path, shown):
    return parse_xml(path, shown, "an MJCF", MJCFError,
                     lambda tag, attrib, line: Element(tag, attrib, line, source=shown))


def read_mjcf(path):
    """The ``<mujoco>`` root :class:`Element` of ``path``, includes expanded.

    Raises
    ------
    MJCFError
        A file that cannot be read, is not well-formed XML, or whose root is not
        ``<mujoco>``; an include that is missing, outside the main file's folder,
        read twice or nested too deep.
    """
    path = Path(path)
    root = _parse(path, str(path))
    if root.tag != "mujoco":
        raise MJCFError(f"{path}:{root.line}: the root element is <{root.tag}>, not "
                        "<mujoco>: not an MJCF file")
    folder = path.resolve().parent
    seen = {path.resolve(): (str(path), 0)}
    _expand(root, folder, seen, 0)
    return root


def _expand(element, folder, seen, depth):
    """Replace every ``<include>`` below ``element`` by its file's children."""
    out = []
    for child in element.children:
        if child.tag != "include":
            _expand(child, folder, seen, depth)
            out.append(child)
            continue
        name = child.attrib.get("file")
        if not name:
            raise child.error("has no attribute 'file'")
        if depth >= MAX_INCLUDE_DEPTH:
            raise child.error(f"includes nested more than {MAX_INCLUDE_DEPTH} deep")
        target = (folder / name).resolve()
        if not target.is_relative_to(folder):
            raise child.error(f"file '{name}' is outside the folder of the main file "
                              f"({folder}): not read")
        if target in seen:
            first, line = seen[target]
            raise child.error(f"file '{name}' is included a second time (first by "
                              f"{first}:{line})" if line else
                              f"file '{name}' includes the main file")
        if not target.is_file():
            raise child.error(f"file '{name}' not found (looked for {target})")
        seen[target] = (child.source, child.line)
        shown = str(Path(child.source).parent / name) if child.source else name
        sub = _parse(target, shown)
        if sub.tag != "mujoco":
            raise MJCFError(f"{shown}:{sub.line}: the root element of an included file is "
                            f"<{sub.tag}>, not <mujoco>")
        _expand(sub, folder, seen, depth + 1)
        out.extend(sub.children)
    element.children = out


def number(element, key, text=None):
    """The attribute ``key`` of ``element`` (or ``text``, a part of it) as a float."""
    raw = (element.attrib[key] if text is None else text).strip(_XML_SPACE)
    if not _PLAIN_NUMBER.match(raw):
        what = f"'{raw}' is not a number" if text is not None else "is not a number"
        raise element.error(f"{key}='{element.attrib[key]}': {what}")
    value = float(raw)
    if not math.isfinite(value):
        raise element.error(f"{key}='{element.attrib[key]}': '{raw}' is beyond the range "
                            "of floating point")
    return value


def numbers(element, key, n=None, at_least=None, at_most=None):
    """The attribute ``key`` as a tuple of floats, checked for its count."""
    text = element.attrib[key].strip(_XML_SPACE)
    parts = re.split(f"[{_XML_SPACE}]+", text) if text else []
    ok = (len(parts) == n) if n is not None else (
        (at_least is None or len(parts) >= at_least)
        and (at_most is None or len(parts) <= at_most))
    if not ok:
        need = (f"{n}" if n is not None else f"{at_least} to {at_most}"
                if at_most is not None else f"at least {at_least}")
        raise element.error(f"{key}='{element.attrib[key]}' needs {need} numbers, "
                            f"found {len(parts)}")
    return tuple(number(element, key, text=p) for p in parts)
