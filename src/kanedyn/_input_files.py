"""Files read for the user: a regular file of bounded size, as bytes or UTF-8 text.

A named pipe, a device or a folder given where a file is expected is refused
(opened without waiting for a writer), and so is a file larger than the reader
allows (also one that grows while it is read), each with a message naming it.
"""

from __future__ import annotations

import csv
import io
import os
import stat
import xml.parsers.expat

from ._errors import ModelError

__all__ = ["read_bounded_bytes", "read_bounded_text", "csv_rows", "refuse_xml_entities"]

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def read_bounded_bytes(path, source, max_bytes, *, name, limit, wanted="a CSV file"):
    """The bytes of the regular file ``path`` of at most ``max_bytes`` bytes.

    Parameters
    ----------
    path : str or Path
    source : str
        The file as messages name it.
    max_bytes : int
    name : str
        What the file is, after "cannot read" (``"pulse file"``, ``"the record"``).
    limit : (str, str)
        What may have ``max_bytes`` bytes (``"a pulse record"``) and how to read a
        larger one (``"give read_pulse_csv(..., max_bytes=...) to read a larger one"``).
    wanted : str
        What to give instead of a file that is not a regular one.
    """
    try:  # O_NONBLOCK: opening a named pipe does not wait for a writer
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise ModelError(f"cannot read {name} {source}: {exc.strerror}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            kind = next((what for test, what in _KINDS if test(info.st_mode)), "not a file")
            raise ModelError(f"{source}: {kind}, not a regular file; give {wanted}")
        with open(fd, "rb", closefd=False) as handle:
            data = handle.read(info.st_size + 1) if info.st_size <= max_bytes else b""
            if info.st_size < len(data) <= max_bytes:  # it grew, or its size is not known
                data += handle.read(max_bytes + 1 - len(data))
    except OSError as exc:
        raise ModelError(f"cannot read {name} {source}: {exc.strerror}") from None
    finally:
        os.close(fd)
    if info.st_size > max_bytes or len(data) > max_bytes:  # (or it grew while read)
        what, larger = limit
        raise ModelError(f"{source}: {max(info.st_size, len(data))} bytes, more than the "
                         f"{max_bytes} {what} may have ({larger})")
    return data


def refuse_xml_entities(data, source, kind):
    """Check that the XML bytes ``data`` are well formed and declare no entities.

    For XML handed to another library's parser (COLLADA meshes): an entity
    declaration can expand into gigabytes or name a file of this machine, and no
    file of the formats read here needs one.

    Parameters
    ----------
    data : bytes
    source : str
        The file as messages name it.
    kind : str
        What the file is, after "in" (``"a COLLADA file"``).

    Raises
    ------
    ModelError
        Naming the file and the line of the declaration or of the syntax error.
    """
    parser = xml.parsers.expat.ParserCreate()

    def no_entities(*args):
        raise ModelError(f"{source}:{parser.CurrentLineNumber}: entity declarations "
                         f"are not accepted in {kind}")

    parser.EntityDeclHandler = no_entities
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        raise ModelError(f"{source}:{exc.lineno}: not a well-formed XML file "
                         f"({xml.parsers.expat.ErrorString(exc.code)})") from None


def read_bounded_text(path, source, max_bytes, *, name, limit):
    """:func:`read_bounded_bytes` of a UTF-8 CSV file, as a text stream (a
    byte-order mark, which spreadsheet programs write, skipped)."""
    data = read_bounded_bytes(path, source, max_bytes, name=name, limit=limit)
    try:  # checked whole (to name the offset), then decoded as it is read
        data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ModelError(f"{source}: not UTF-8 text (byte {exc.object[exc.start]:#04x} "
                         f"at offset {exc.start}); save it as UTF-8 CSV") from None
    return io.TextIOWrapper(io.BytesIO(data), encoding="utf-8-sig", newline="")


def csv_rows(text, source, what):
    """``(line number, cells)`` of the CSV text stream ``text``; a cell over the csv
    module's field limit, or text it cannot read, is refused naming the line
    (``what``: what the file should be, ``"a pulse record"``)."""
    reader = csv.reader(text)
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            line = reader.line_num
            if "field limit" in str(exc):
                raise ModelError(f"{source}: line {line}: a cell longer than "
                                 f"{csv.field_size_limit()} characters; not {what}") from None
            raise ModelError(f"{source}: line {line}: not readable as CSV ({exc})") from None
        yield reader.line_num, row
