r"""The quasi-static elastic catenary of one mooring line.

A line of unstretched length :math:`L`, weight per length in water :math:`w`
and axial stiffness :math:`EA` hangs between an anchor on the seabed and a
fairlead a horizontal span :math:`x_F` and a vertical span :math:`z_F` away.
The horizontal and vertical tensions at the fairlead, :math:`H` and
:math:`V`, satisfy (Jonkman 2007, NREL/TP-500-41958, sec. 4.2; the equations
MAP uses), without seabed friction:

line partly on the seabed (:math:`L_B = L - V/w > 0`)

.. math::
    x_F &= L_B + \frac{H}{w}\operatorname{asinh}\frac{V}{H} + \frac{HL}{EA} \\
    z_F &= \frac{H}{w}\left(\sqrt{1 + (V/H)^2} - 1\right) + \frac{V^2}{2\,EA\,w}

line fully suspended (:math:`V \ge wL`, or ``seabed=False``)

.. math::
    x_F &= \frac{H}{w}\left(\operatorname{asinh}\frac{V}{H}
           - \operatorname{asinh}\frac{V - wL}{H}\right) + \frac{HL}{EA} \\
    z_F &= \frac{H}{w}\left(\sqrt{1 + (V/H)^2} - \sqrt{1 + ((V - wL)/H)^2}\right)
           + \frac{1}{EA}\left(VL - \frac{wL^2}{2}\right)

The two are solved for :math:`(H, V)` in the variables :math:`\ln H, \ln V`
by Newton's method with the equations' analytic Jacobian
(:func:`catenary_jacobian`), warm-started from the last solution, to a step of
1e-13; where that does not converge (or without a warm start), by SciPy
(``scipy.optimize.root``, MINPACK's hybrid method, from Peyrot and Goulois's
guess or the warm start).  The spans fix the tensions uniquely, so both find
the same root.
"""

import numpy as np

from ..._errors import ModelError

__all__ = ["catenary_spans", "solve_catenary", "CatenaryLine"]


def catenary_spans(H, V, length, w, EA, seabed=True):
    """Spans ``(x_F, z_F)`` (m) of a line with fairlead tensions ``H``, ``V`` (N).

    The forward catenary equations (see the module docstring).
    """
    L = length
    if seabed and V < w * L:
        LB = L - V / w
        x = LB + H / w * np.arcsinh(V / H) + H * L / EA
        z = H / w * (np.sqrt(1 + (V / H) ** 2) - 1) + V ** 2 / (2 * EA * w)
    else:
        Va = V - w * L
        x = H / w * (np.arcsinh(V / H) - np.arcsinh(Va / H)) + H * L / EA
        z = (H / w * (np.sqrt(1 + (V / H) ** 2) - np.sqrt(1 + (Va / H) ** 2))
             + (V * L - w * L ** 2 / 2) / EA)
    return x, z


def catenary_jacobian(H, V, length, w, EA, seabed=True):
    """Derivatives of the spans, ``((dx/dH, dx/dV), (dz/dH, dz/dV))`` (m/N).

    The forward equations of :func:`catenary_spans` differentiated, on the
    same branch (partly on the seabed when ``seabed`` and ``V < w L``).
    """
    L = length
    u = V / H
    root = np.sqrt(1 + u * u)
    if seabed and V < w * L:
        return ((np.arcsinh(u) / w - u / (w * root) + L / EA, (1 / root - 1) / w),
                ((root - 1) / w - u * u / (w * root), u / (w * root) + V / (EA * w)))
    ua = (V - w * L) / H
    root_a = np.sqrt(1 + ua * ua)
    return (((np.arcsinh(u) - np.arcsinh(ua)) / w - (u / root - ua / root_a) / w + L / EA,
             (1 / root - 1 / root_a) / w),
            ((root - root_a) / w - (u * u / root - ua * ua / root_a) / w,
             (u / root - ua / root_a) / w + L / EA))


def _newton(x, z, length, w, EA, seabed, H, V):
    """``(H, V)`` by Newton's method in ``ln H, ln V`` from ``(H, V)``, or None when it
    does not reach a step of 1e-13 within 20 iterations (each step kept below 1)."""
    p, q = np.log(H), np.log(V)
    for _ in range(20):
        H, V = np.exp(p), np.exp(q)
        xs, zs = catenary_spans(H, V, length, w, EA, seabed)
        (a, b), (c, d) = catenary_jacobian(H, V, length, w, EA, seabed)
        a, b, c, d = a * H, b * V, c * H, d * V          # per ln H, ln V
        det = a * d - b * c
        if not (np.isfinite(det) and det != 0):
            return None
        dp = -(d * (xs - x) - b * (zs - z)) / det
        dq = -(a * (zs - z) - c * (xs - x)) / det
        if not (abs(dp) < 1 and abs(dq) < 1):
            return None
        p, q = p + dp, q + dq
        if max(abs(dp), abs(dq)) < 1e-13:
            return float(np.exp(p)), float(np.exp(q))
    return None


def _first_guess(x, z, L, w):
    """Peyrot and Goulois's starting values of (H, V)."""
    if x == 0:
        lam = 1e6
    elif L ** 2 <= x ** 2 + z ** 2:
        lam = 0.2
    else:
        lam = np.sqrt(3 * ((L ** 2 - z ** 2) / x ** 2 - 1))
    H = max(abs(w * x / (2 * lam)), 1e-6 * w * L)
    V = w / 2 * (z / np.tanh(lam) + L)
    return H, max(V, 1e-6 * w * L)


def solve_catenary(x, z, length, w, EA, seabed=True, guess=None, name="line"):
    """Fairlead tensions ``(H, V)`` (N) for spans ``x`` (horizontal) and ``z`` (up), m.

    Parameters
    ----------
    x, z : float
        Horizontal span (>= 0) and height of the fairlead above the anchor, m.
    length, w, EA : float
        Unstretched length (m), weight per length in water (N/m), axial
        stiffness (N).
    seabed : bool
        Whether the line may lie on the seabed (the anchor is on it).
    guess : (float, float), optional
        Starting ``(H, V)``; Peyrot and Goulois's guess when not given.
    name : str
        Named in errors.

    Returns
    -------
    (float, float)

    Raises
    ------
    ModelError
        When SciPy finds no solution (e.g. a span longer than the line can
        reach at any tension).
    """
    if x < 0:
        raise ModelError(f"catenary {name}: the horizontal span must not be negative")
    scale = w * length
    largest = 1e6 * scale * max(1.0, EA / scale)  # H beyond it: no finite solution
    if guess is not None:
        found = _newton(x, z, length, w, EA, seabed, *guess)
        if found is not None and found[0] <= largest:
            return found
    h0, v0 = guess if guess is not None else _first_guess(x, z, length, w)

    def residual(p):
        H, V = np.exp(p)
        xs, zs = catenary_spans(H, V, length, w, EA, seabed)
        return [(xs - x) / length, (zs - z) / length]

    from scipy import optimize  # imported when first needed (start-up time)
    sol = optimize.root(residual, np.log([h0, v0]), method="hybr", options={"xtol": 1e-13})
    if not sol.success or np.max(np.abs(sol.fun)) > 1e-9:
        if guess is not None:  # a poor warm start: try the cold start once
            return solve_catenary(x, z, length, w, EA, seabed, None, name)
        raise ModelError(f"catenary {name}: no solution for spans x = {x:g} m, z = {z:g} m "
                         f"(length {length:g} m): {sol.message}")
    H, V = np.exp(sol.x)
    if not (np.isfinite(H) and np.isfinite(V)) or H > largest:
        raise ModelError(f"catenary {name}: no finite solution for spans x = {x:g} m, "
                         f"z = {z:g} m")
    return float(H), float(V)


class CatenaryLine:
    """One quasi-static elastic catenary line from an anchor to a fairlead point.

    Parameters
    ----------
    anchor : sequence of 3 floats
        Anchor coordinates (m) in the mooring's frame, from its origin
        (z up).
    fairlead : sympy.physics.mechanics.Point
        The fairlead, a point fixed in the floating body.
    length : float
        Unstretched length, m.
    w : float
        Weight per length in water (weight minus buoyancy), N/m.
    EA : float
        Axial stiffness, N.
    seabed : bool
        The line may lie partly on the seabed (anchor on the seabed).
    name : str, optional
        Named in errors and in the input symbols; the mooring numbers the
        lines when omitted.

    Notes
    -----
    :meth:`tensions` keeps its last solution and starts the next solve from
    it (a warm start).
    """

    def __init__(self, anchor, fairlead, length, w, EA, seabed=True, name=None):
        import sympy.physics.mechanics as me
        self.name = name
        label = f"catenary line {name!r}" if name else "catenary line"
        anchor = np.asarray(anchor, dtype=float)
        if anchor.shape != (3,) or not np.all(np.isfinite(anchor)):
            raise ModelError(f"{label}: anchor must be 3 finite coordinates, got {anchor}")
        if not isinstance(fairlead, me.Point):
            raise ModelError(f"{label}: fairlead must be a Point, got "
                             f"{type(fairlead).__name__}")
        for key, value in (("length", length), ("w", w), ("EA", EA)):
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise ModelError(f"{label}: {key} must be a positive number, got {value!r}")
        self.anchor, self.fairlead = anchor, fairlead
        self.length, self.w, self.EA = float(length), float(w), float(EA)
        self.seabed = bool(seabed)
        self._last = None

    def tensions(self, fairlead_position):
        """``(H, V)`` (N) at a fairlead at ``fairlead_position`` (3 floats, m)."""
        r = np.asarray(fairlead_position, dtype=float) - self.anchor
        x, z = float(np.hypot(r[0], r[1])), float(r[2])
        H, V = solve_catenary(x, z, self.length, self.w, self.EA, self.seabed,
                              guess=self._last, name=self.name or "line")
        self._last = (H, V)
        return H, V

    def force(self, fairlead_position):
        """Force of the line on the fairlead (3 floats, N; toward the anchor, down)."""
        p = np.asarray(fairlead_position, dtype=float)
        H, V = self.tensions(p)
        d = self.anchor[:2] - p[:2]
        n = np.hypot(*d)
        e = d / n if n > 0 else np.zeros(2)
        return np.array([H * e[0], H * e[1], -V])

    def __repr__(self):
        return (f"CatenaryLine({self.name!r}, anchor={self.anchor.tolist()}, "
                f"fairlead={self.fairlead.name}, length={self.length}, w={self.w}, "
                f"EA={self.EA})")
