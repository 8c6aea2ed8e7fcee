"""Channel-frequency-class (CFC) filters of SAE J211/1 for crash-test channels.

The filter is the two-pole difference equation of SAE J211/1 (Appendix C), run
forward and then backward over the record, which makes it a four-pole filter with
zero phase.  For a class CFC (Hz) and a sampling interval T (s):

    wd = 2 pi CFC 2.0775,          wa = sin(wd T / 2) / cos(wd T / 2)
    a0 = wa^2 / (1 + sqrt(2) wa + wa^2),   a1 = 2 a0,   a2 = a0
    b1 = -2 (wa^2 - 1) / (1 + sqrt(2) wa + wa^2)
    b2 = (-1 + sqrt(2) wa - wa^2) / (1 + sqrt(2) wa + wa^2)
    Y[n] = a0 X[n] + a1 X[n-1] + a2 X[n-2] + b1 Y[n-1] + b2 Y[n-2]

The two passes are :func:`scipy.signal.filtfilt` with these coefficients (its
default start: an odd extension of the record by 3 max(len(a), len(b)) = 9 samples
at each end and the filter state at steady state for the first sample).  The gain at
zero frequency is exactly 1; the magnitude of the two passes is |H(f)|^2, -3 dB near
5/3 CFC (100 Hz for CFC 60), the class's F_N.
"""

from __future__ import annotations

import numpy as np

from ..._errors import ModelError

__all__ = ["CFC_CLASSES", "cfc_coefficients", "cfc_filter", "cfc_response", "parse_cfc"]

#: the channel frequency classes of SAE J211/1 (Hz)
CFC_CLASSES = (60, 180, 600, 1000)


def parse_cfc(spec, where="filter"):
    """Class number from ``"CFC60"``, ``"cfc 180"`` or ``60``; error names ``where``."""
    value = spec
    if isinstance(spec, str):
        text = spec.strip().upper().replace(" ", "")
        if text.startswith("CFC"):
            text = text[3:]
        value = int(text) if text.isdigit() else None
    if isinstance(value, (int, np.integer)) and int(value) in CFC_CLASSES:
        return int(value)
    raise ModelError(f"{where}: unknown channel frequency class {spec!r}; use one of "
                     + ", ".join(f"'CFC{c}'" for c in CFC_CLASSES) + " or None")


def cfc_coefficients(cfc, dt):
    """``(b, a)`` of the J211 two-pole pass for class ``cfc`` (Hz) and step ``dt`` (s).

    ``b = [a0, a1, a2]`` and ``a = [1, -b1, -b2]`` in :mod:`scipy.signal` form.
    """
    cfc = parse_cfc(cfc)
    dt = float(dt)
    wd = 2 * np.pi * cfc * 2.0775
    if not (dt > 0 and wd * dt / 2 < np.pi / 2):
        raise ModelError(f"CFC{cfc}: sampling interval {dt!r} s is too coarse for this "
                         "class (wd T / 2 must stay below pi/2)")
    wa = np.sin(wd * dt / 2) / np.cos(wd * dt / 2)
    den = 1 + np.sqrt(2) * wa + wa ** 2
    a0 = wa ** 2 / den
    b1 = -2 * (wa ** 2 - 1) / den
    b2 = (-1 + np.sqrt(2) * wa - wa ** 2) / den
    return np.array([a0, 2 * a0, a0]), np.array([1.0, -b1, -b2])


def cfc_filter(x, dt, cfc, where="filter"):
    """Filter samples ``x`` (shape (n,) or (n, k), along axis 0) with class ``cfc``.

    Parameters
    ----------
    x : array_like, shape (n,) or (n, k)
        Uniformly sampled channel(s).
    dt : float
        Sampling interval, s.  J211 asks for a sampling rate well above the class;
        here at least 10 CFC (6 times F_N) is required.
    cfc : int or str
        60, 180, 600, 1000 or ``"CFC60"`` etc.
    where : str
        Names the data in errors (e.g. the file).

    Returns
    -------
    numpy.ndarray
        Filtered samples, same shape.
    """
    cfc = parse_cfc(cfc, where)
    if 1.0 / dt < 10 * cfc:
        raise ModelError(f"{where}: sampling rate {1 / dt:.6g} Hz is too low for CFC{cfc}; "
                         f"J211 filtering needs at least {10 * cfc} Hz")
    b, a = cfc_coefficients(cfc, dt)
    x = np.asarray(x, dtype=float)
    if x.shape[0] <= 9:
        raise ModelError(f"{where}: {x.shape[0]} samples are too few to filter (need > 9)")
    from scipy import signal  # imported when first needed (start-up time)
    return signal.filtfilt(b, a, x, axis=0)


def cfc_response(frequency, dt, cfc):
    """Magnitude (dB) of the forward-backward filter at ``frequency`` (Hz).

    The two passes multiply the one-pass response by its conjugate: |H|^2.
    """
    b, a = cfc_coefficients(cfc, dt)
    from scipy import signal
    _, h = signal.freqz(b, a, worN=np.atleast_1d(np.asarray(frequency, float)), fs=1 / dt)
    return 20 * np.log10(np.abs(h) ** 2)
