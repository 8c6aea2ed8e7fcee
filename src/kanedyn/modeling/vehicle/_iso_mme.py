"""Crash-test records in the ISO 13499 (ISO-MME) exchange format.

A test is a folder with a test file ``<test>.mme`` (key/value lines: data format,
test number, ...) and a folder ``Channel`` holding the channel list ``<test>.chn``
(``Number of channels`` and ``Name of channel NNN :CODE / name`` lines) and one
file per channel, ``<test>.NNN``.  A channel file starts with header lines
``key :value`` (the key padded with spaces; kanedyn reads ``Channel code``,
``Name of the channel``, ``Unit``, ``Sampling interval`` (s), ``Time of first
sample`` (s) and ``Number of samples``; ``NOVALUE`` is no value), followed by the
samples, one per line.  Nothing in the files is evaluated; numbers are read with
:func:`float`.

Channels are picked by their 16-character ISO code (``10VEHC0000CGACXP``: test
object, position, main location, fine locations, physical dimension ``AC``
acceleration or ``AV`` angular velocity, direction ``X Y Z``, filter class) or by
their name.  Without a choice, the vehicle's own channels are taken: codes with
main location ``VEHC`` and dimension ``AC`` (and ``AV``), one per direction.

Refused, naming the file, the channel and the line: a missing or empty key, a
sample that is not a finite number, a number of samples other than the header's,
an unknown unit (accelerations ``g``, ``m/s**2``, ``m/s^2``, ``m/s2``; angular
rates ``deg/s``, ``rad/s``), a non-positive sampling interval, channels whose time
axes differ, a channel missing from the list or its file, two channels answering
one choice.  Text is read as UTF-8, else as Latin-1 (ISO 8859-1, the format's
traditional encoding).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ..._errors import ModelError
from ..._number_text import finite_number
from ..._output_files import replacing
from ._pulses import G0
from ._series import MAX_BYTES, _read_bytes, series_from_channels

__all__ = ["read_iso_mme", "write_iso_mme", "ISO_UNITS"]

#: units of the channels read, to SI: accelerations and angular rates
ISO_UNITS = {
    "a": {"g": G0, "m/s**2": 1.0, "m/s^2": 1.0, "m/s2": 1.0, "m/s²": 1.0},
    "w": {"deg/s": math.pi / 180, "°/s": math.pi / 180, "rad/s": 1.0},
}
_TARGETS = ("ax", "ay", "az", "wx", "wy", "wz")
_REQUIRED = ("Channel code", "Unit", "Sampling interval", "Time of first sample",
             "Number of samples")
_NUMBER = re.compile(r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*$")


def _text(path, max_bytes):
    data = _read_bytes(path, str(path), max_bytes, "read_iso_mme", "an ISO-MME file")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def _key_value(line):
    """``(key, value)`` of a header line ``key :value`` (None: not one)."""
    if ":" not in line or _NUMBER.match(line):
        return None
    key, value = line.split(":", 1)
    return key.strip(), value.strip()


def _test_files(path):
    """``(mme file, Channel folder)`` of a test folder or its ``.mme`` file."""
    path = Path(path)
    if path.is_dir():
        found = sorted(p for p in path.iterdir() if p.suffix.lower() == ".mme")
        if len(found) != 1:
            raise ModelError(f"{path}: an ISO-MME test folder holds one .mme file; found "
                             f"{len(found)}" + (f" ({', '.join(p.name for p in found)})"
                                                if found else ""))
        path = found[0]
    elif not path.is_file():
        raise ModelError(f"{path}: no such ISO-MME test (a folder or its .mme file)")
    folder = next((p for p in path.parent.iterdir()
                   if p.is_dir() and p.name.lower() == "channel"), None)
    if folder is None:
        raise ModelError(f"{path}: no 'Channel' folder beside it (ISO-MME keeps the "
                         "channel list and the channel files there)")
    return path, folder


def _channel_list(folder, stem, max_bytes):
    """``[(number, code, name)]`` from the ``.chn`` file of ``folder``."""
    lists = [p for p in folder.iterdir() if p.suffix.lower() == ".chn"]
    chosen = [p for p in lists if p.stem == stem] or lists
    if len(chosen) != 1:
        raise ModelError(f"{folder}: one channel list (.chn) expected, found "
                         f"{len(chosen)}")
    path = chosen[0]
    count, entries = None, []
    for line_no, line in enumerate(_text(path, max_bytes).splitlines(), 1):
        pair = _key_value(line)
        if pair is None:
            if line.strip():
                raise ModelError(f"{path}: line {line_no}: not a 'key :value' line")
            continue
        key, value = pair
        if key.lower() == "number of channels":
            try:
                count = int(value)
            except ValueError:
                raise ModelError(f"{path}: line {line_no}: number of channels {value!r} "
                                 "is not a whole number") from None
        match = re.fullmatch(r"name of channel\s+(\d+)", key, re.IGNORECASE)
        if match:
            code, _, name = value.partition("/")
            entries.append((int(match.group(1)), code.strip(), name.strip(), line_no))
    if count is None:
        raise ModelError(f"{path}: no 'Number of channels' line")
    if count != len(entries):
        raise ModelError(f"{path}: 'Number of channels' says {count}, the list names "
                         f"{len(entries)}")
    return path, entries


def _pick(entries, channels, chn):
    """``{target: (number, code, name)}`` for the channels asked for (or the
    vehicle's own)."""
    picked = {}
    if channels is None:
        for target in _TARGETS:
            dimension = "AC" if target[0] == "a" else "AV"
            hits = [e for e in entries if len(e[1]) == 16 and e[1][2:6].upper() == "VEHC"
                    and e[1][12:14].upper() == dimension
                    and e[1][14].upper() == target[1].upper()]
            if len(hits) > 1:
                raise ModelError(f"{chn}: {len(hits)} vehicle channels for {target} ("
                                 + ", ".join(e[1] for e in hits) + "); choose one with "
                                 f"channels={{{target!r}: code}}")
            if hits:
                picked[target] = hits[0]
        if "ax" not in picked:
            raise ModelError(f"{chn}: no vehicle acceleration channel (code ??VEHC??????"
                             "ACX?); choose channels with channels={'ax': code or name, ...}")
        return picked
    unknown = set(channels) - set(_TARGETS)
    if unknown:
        raise ModelError(f"read_iso_mme: channels: unknown key(s) {sorted(unknown)}; use "
                         + ", ".join(_TARGETS))
    for target, wanted in channels.items():
        hits = [e for e in entries if str(wanted).strip().upper() in
                (e[1].upper(), e[2].upper())]
        if not hits:
            raise ModelError(f"{chn}: no channel with code or name {wanted!r} (for "
                             f"{target}); channels: " + ", ".join(
                                 f"{e[1]} / {e[2]}" for e in entries))
        if len(hits) > 1:
            raise ModelError(f"{chn}: {len(hits)} channels answer {wanted!r} (for {target}):"
                             " " + ", ".join(e[1] for e in hits) + "; give the code")
        picked[target] = hits[0]
    return picked


def _read_channel(path, target, code, max_bytes):
    """``(header dict, samples in SI units, first sample line)`` of one channel file."""
    lines = _text(path, max_bytes).splitlines()
    header, start = {}, len(lines)
    for line_no, line in enumerate(lines, 1):
        pair = _key_value(line)
        if pair is None:
            start = line_no
            break
        header[pair[0].lower()] = (pair[1], line_no)
    where = f"{path}: channel {code} ({target})"
    for key in _REQUIRED:
        value = header.get(key.lower(), ("", None))[0]
        if not value or value.upper() == "NOVALUE":
            raise ModelError(f"{where}: the header (lines 1-{start - 1}) has no "
                             f"'{key}' value")
    if header["channel code"][0].upper() != code.upper():
        raise ModelError(f"{where}, line {header['channel code'][1]}: the file's channel "
                         f"code is {header['channel code'][0]}, the list's {code}")

    def number(key, kind=float):
        text, line_no = header[key.lower()]
        value = finite_number(text, kind)
        if value is None:
            raise ModelError(f"{where}, line {line_no}: {key} {text!r} is not a "
                             f"{'whole ' if kind is int else ''}number")
        return value

    dt, t0, n = (number("Sampling interval"), number("Time of first sample"),
                 number("Number of samples", int))
    if dt <= 0:
        raise ModelError(f"{where}, line {header['sampling interval'][1]}: sampling "
                         f"interval {dt:g} s must be positive")
    unit, unit_line = header["unit"]
    kind = "a" if target[0] == "a" else "w"
    factor = ISO_UNITS[kind].get(unit.replace(" ", "").lower())
    if factor is None:
        what = "acceleration" if kind == "a" else "angular rate"
        raise ModelError(f"{where}, line {unit_line}: unknown unit {unit!r} for an {what}; "
                         "use one of " + ", ".join(ISO_UNITS[kind]))
    samples = lines[start - 1:]
    while samples and not samples[-1].strip():
        samples.pop()
    values = np.empty(len(samples))
    for k, text in enumerate(samples):
        try:
            values[k] = float(text)
        except ValueError:
            values[k] = math.nan
        if not math.isfinite(values[k]):
            raise ModelError(f"{where}, line {start + k}: sample {text.strip()!r} is not a "
                             "finite number")
    if values.size != n:
        raise ModelError(f"{where}: {values.size} samples (lines {start}-"
                         f"{start + values.size - 1}), the header (line "
                         f"{header['number of samples'][1]}) says {n}")
    return (dt, t0, n), values * factor, start


def read_iso_mme(path, channels=None, *, max_bytes=MAX_BYTES):
    """Read vehicle accelerations (and angular rates) of an ISO-MME test.

    Parameters
    ----------
    path : str or pathlib.Path
        The test folder or its ``.mme`` file.
    channels : dict, optional
        ``{"ax": code or name, "ay": ..., "az": ..., "wx": ..., "wy": ..., "wz": ...}``;
        an absent key is a zero channel (no rotation about an absent rate's axis).
        Default: the vehicle's channels (see the module text); ``ax`` is required.
    max_bytes : int
        Largest file read, bytes (each file).

    Returns
    -------
    PulseSeries
        SI units; :attr:`~PulseSeries.notes` names the channels read.

    Raises
    ------
    ModelError
        Naming the file, the channel and the line at fault.
    """
    mme, folder = _test_files(path)
    chn, entries = _channel_list(folder, mme.stem, max_bytes)
    picked = _pick(entries, channels, chn)
    data, labels, notes, axis = {}, {}, [], None
    for target, (number, code, name, _) in picked.items():
        candidates = [p for p in folder.iterdir() if p.suffix == f".{number:03d}"]
        file = next((p for p in candidates if p.stem == chn.stem), None) or (
            candidates[0] if len(candidates) == 1 else None)
        if file is None:
            raise ModelError(f"{chn}: channel {number:03d} ({code}, for {target}) has no "
                             f"file {chn.stem}.{number:03d} in {folder}")
        timing, values, _ = _read_channel(file, target, code, max_bytes)
        if axis is None:
            axis, first = timing, file
        elif (timing[2] != axis[2] or not math.isclose(timing[0], axis[0], rel_tol=1e-9)
              or not math.isclose(timing[1], axis[1], rel_tol=0, abs_tol=1e-9 * axis[0])):
            raise ModelError(f"{file}: channel {code} ({target}): its time axis (interval "
                             f"{timing[0]:g} s, first sample {timing[1]:g} s, {timing[2]} "
                             f"samples) differs from {first.name}'s ({axis[0]:g} s, "
                             f"{axis[1]:g} s, {axis[2]})")
        data[target] = values
        labels[target] = f"{file.name}: channel {code} ({target})"
        notes.append(f"{target}: {code} / {name or '(no name)'} ({file.name})")
    dt, t0, n = axis
    t = t0 + dt * np.arange(n)
    return series_from_channels(t, data, str(mme), labels, notes,
                                after=f"the header of {first.name}")


def write_iso_mme(folder, test, t, channels, test_type="sled test"):
    """Write an ISO-MME test that :func:`read_iso_mme` reads (tests, conversions).

    Parameters
    ----------
    folder : str or pathlib.Path
        Created if needed; receives ``<test>.mme`` and ``Channel/``.
    test : str
        Test number (file names).
    t : array_like, shape (n,)
        Uniform times, s.
    channels : sequence of (str, str, str, array_like)
        ``(code, name, unit, values)`` per channel, values in ``unit``.
    test_type : str

    Returns
    -------
    pathlib.Path
        The ``.mme`` file.
    """
    folder = Path(folder)
    (folder / "Channel").mkdir(parents=True, exist_ok=True)
    t = np.asarray(t, float)
    dt = float(np.mean(np.diff(t)))

    def pad(key):
        return f"{key:<28}:"

    mme = folder / f"{test}.mme"
    with replacing(mme) as handle:
        for key, value in (("Data format", "ISO-MME"), ("Version", "1.6"),
                           ("Test number", test), ("Test type", test_type),
                           ("Number of test objects", "1")):
            handle.write(f"{pad(key)}{value}\n")
    with replacing(folder / "Channel" / f"{test}.chn") as handle:
        handle.write(f"{pad('Instrumentation standard')}SAE J211\n")
        handle.write(f"{pad('Number of channels')}{len(channels)}\n")
        for k, (code, name, _, _) in enumerate(channels, 1):
            handle.write(f"{pad(f'Name of channel {k:03d}')}{code} / {name}\n")
    for k, (code, name, unit, values) in enumerate(channels, 1):
        values = np.asarray(values, float)
        with replacing(folder / "Channel" / f"{test}.{k:03d}") as handle:
            for key, value in (("Channel code", code), ("Name of the channel", name),
                               ("Location", code[2:12]), ("Direction", code[14]),
                               ("Channel frequency class", "NOVALUE"),
                               ("Unit", unit), ("Sampling interval", repr(dt)),
                               ("Time of first sample", repr(float(t[0]))),
                               ("Number of samples", str(values.size)),
                               ("Data status", "ok")):
                handle.write(f"{pad(key)}{value}\n")
            handle.write("".join(f"{v!r}\n" for v in values.tolist()))
    return mme
