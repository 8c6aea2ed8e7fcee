"""Axisymmetric members along a body axis: diameter tables and rest placement.

Shared by the Morison and hydrostatic elements.  A member is described by
stations ``(s, D)``: axial coordinate ``s`` (m) from the member's origin point
along its unit axis, and diameter ``D`` (m), linear between stations.
"""

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ..._errors import ModelError
from ..._expressions import as_expression

__all__ = ["MemberGeometry", "rest_placement"]


class MemberGeometry:
    """Piecewise-linear diameter ``D(s)`` of an axisymmetric member.

    Parameters
    ----------
    stations : sequence of (s, D)
        Strictly increasing ``s`` (m), positive ``D`` (m); at least two.
    owner : str
        Name used in error messages.
    """

    def __init__(self, stations, owner):
        try:
            arr = np.array([(float(s), float(d)) for s, d in stations], dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{owner}: stations must be pairs (s, D) of numbers, got "
                             f"{stations!r}") from None
        if arr.shape[0] < 2 or np.any(np.diff(arr[:, 0]) <= 0) or np.any(arr[:, 1] <= 0):
            raise ModelError(f"{owner}: stations need at least two (s, D) pairs with "
                             f"increasing s and positive D, got {stations!r}")
        self.s, self.D = arr[:, 0], arr[:, 1]
        self.owner = owner

    def diameter(self, s):
        """D(s), m (outside the stations: an error)."""
        s = np.asarray(s, dtype=float)
        if np.any(s < self.s[0] - 1e-12) or np.any(s > self.s[-1] + 1e-12):
            raise ModelError(f"{self.owner}: s outside the member [{self.s[0]}, "
                             f"{self.s[-1]}]")
        return np.interp(s, self.s, self.D)

    def area(self, s):
        """Cross-section area pi D^2/4, m^2."""
        return np.pi * self.diameter(s) ** 2 / 4

    def quadrature(self, lo, hi, order=4):
        """Gauss-Legendre points and weights on ``[lo, hi]``, split at the stations.

        Exact for polynomials of degree ``2 order - 1`` between stations.
        """
        cuts = np.unique(np.concatenate([[lo, hi], self.s[(self.s > lo) & (self.s < hi)]]))
        x, w = np.polynomial.legendre.leggauss(order)
        pts, wts = [], []
        for a, b in zip(cuts[:-1], cuts[1:]):
            pts.append((a + b) / 2 + (b - a) / 2 * x)
            wts.append((b - a) / 2 * w)
        return np.concatenate(pts), np.concatenate(wts)

    def integrals(self, lo, hi):
        """``(volume, first moment int A s ds, projected area int D ds)`` on ``[lo, hi]``."""
        s, w = self.quadrature(lo, hi)
        A = self.area(s)
        return float(w @ A), float(w @ (A * s)), float(w @ self.diameter(s))


def rest_placement(owner, origin, axis, body_frame, frame, fixed_point, rest_configuration):
    """Numeric position of ``origin`` from ``fixed_point`` and the axis, in ``frame``, at rest.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, sympy.Matrix)
        Origin position (3,), m; unit axis direction (3,); the axis's
        components in ``body_frame`` (constant, 3 x 1).
    """
    for label, obj, kind in (("origin", origin, me.Point), ("fixed_point", fixed_point,
                                                           me.Point),
                             ("body_frame", body_frame, me.ReferenceFrame),
                             ("frame", frame, me.ReferenceFrame)):
        if not isinstance(obj, kind):
            raise ModelError(f"{owner}: {label} must be a {kind.__name__}, got "
                             f"{type(obj).__name__}")
    if not isinstance(axis, me.Vector):
        raise ModelError(f"{owner}: axis must be a sympy.physics.vector.Vector fixed in "
                         f"{body_frame}")
    if not isinstance(rest_configuration, dict):
        raise ModelError(f"{owner}: rest_configuration must be a dict {{coordinate: value}}")
    axis_b = axis.to_matrix(body_frame)
    if me.find_dynamicsymbols(axis_b):
        raise ModelError(f"{owner}: axis must be constant in {body_frame}")
    norm = sm.sqrt(sum(c ** 2 for c in axis_b))
    try:
        if abs(float(norm) - 1) > 1e-9:
            raise ModelError(f"{owner}: axis must be a unit vector, |axis| = {float(norm)}")
    except TypeError:
        raise ModelError(f"{owner}: axis components must be numbers") from None
    rest = {as_expression(k, f"{owner}: rest_configuration key"):
            as_expression(v, f"{owner}: rest_configuration[{k}]")
            for k, v in rest_configuration.items()}

    def numeric(mat, what):
        mat = mat.xreplace(rest)
        free = mat.free_symbols | me.find_dynamicsymbols(mat)
        free.discard(me.dynamicsymbols._t)
        if free:
            raise ModelError(f"{owner}: the {what} at rest depends on "
                             f"{sorted(map(str, free))}; give them in rest_configuration")
        return np.array([float(c) for c in mat], dtype=float)

    r0 = numeric(origin.pos_from(fixed_point).to_matrix(frame), "origin position")
    e0 = numeric(axis.to_matrix(frame), "axis direction")
    return r0, e0, axis_b
