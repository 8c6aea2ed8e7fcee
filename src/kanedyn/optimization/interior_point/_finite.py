"""Whether an array's entries are all finite, without an array of the test's
results (the iterations test every point, step and Hessian they make)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["all_finite"]


def all_finite(values):
    """Whether every entry of ``values`` (an ndarray) is finite.

    Their sum decides at once when it is finite (a term that is infinite or
    NaN makes it so too); only when it is not (an infinite or NaN entry, or
    finite entries whose sum overflows) are the entries tested one by one.
    Called under the solver's ``np.errstate(all="ignore")`` (the sum may
    overflow, or meet infinities of both signs).
    """
    return math.isfinite(np.add.reduce(values, axis=None)) or bool(np.isfinite(values).all())
