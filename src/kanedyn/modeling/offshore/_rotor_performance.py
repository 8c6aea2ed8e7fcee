r"""A rotor's steady aerodynamics from its performance table: torque and thrust.

``PerformanceSurface``  the torque and thrust coefficients
                        :math:`C_Q(\lambda, \theta) = C_P/\lambda` and
                        :math:`C_T(\lambda, \theta)` as smooth fits of a table
                        (tensor Chebyshev polynomials), in closed form so that
                        compiled code evaluates them
``RotorAerodynamics``   the thrust at the hub along the shaft and the torque on
                        the rotor about it, from the relative wind

With :math:`V_{rel} = V - v_{hub}\cdot s` the wind relative to the moving hub
along the shaft :math:`s`, :math:`\Omega` the rotor's speed relative to the
nacelle, :math:`\lambda = \Omega R / V_{rel}`,

.. math:: T = \tfrac12\rho\pi R^2 V_{rel}^2 C_T(\lambda, \theta), \qquad
          Q = \tfrac12\rho\pi R^3 V_{rel}^2 C_Q(\lambda, \theta)

(quasi-steady: no dynamic inflow, no skew, uniform wind over the disk).
"""

import numpy as np
import sympy as sm
from numpy.polynomial import chebyshev

from ..._errors import ModelError

__all__ = ["PerformanceSurface", "RotorAerodynamics"]


def _clamp(x, lo, hi):
    # unevaluated: SymPy's search for comparable arguments costs minutes on the large
    # expressions of a rotor's inflow, and the bounds are numbers
    return sm.Min(sm.Max(x, lo, evaluate=False), hi, evaluate=False)


class PerformanceSurface:
    r"""Steady torque and thrust coefficients of a rotor, fitted to its table.

    :math:`C_P` and :math:`C_T` are each fitted by least squares with a tensor
    product of Chebyshev polynomials of degree ``degree`` in :math:`\lambda`
    and :math:`\theta` over the table's box; the torque coefficient is
    :math:`C_Q = C_P/\lambda`.  Outside the box the arguments are clamped to
    its edges (the fit is not extrapolated; :math:`C_Q` stays finite at a
    standing rotor).

    Parameters
    ----------
    tip_speed_ratios : sequence of float, shape (n,)
        Rows of the table, increasing.
    pitch_degrees : sequence of float, shape (m,)
        Collective blade pitch of the columns, deg, increasing.
    power, thrust : array_like, shape (n, m)
        :math:`C_P` and :math:`C_T`.
    degree : int
        Degree of the fit in each argument (the fit has ``(degree + 1)**2``
        coefficients per coefficient).
    """

    def __init__(self, tip_speed_ratios, pitch_degrees, power, thrust, degree=8):
        lam = np.asarray(tip_speed_ratios, float)
        deg = np.asarray(pitch_degrees, float)
        cp, ct = np.asarray(power, float), np.asarray(thrust, float)
        if lam.ndim != 1 or deg.ndim != 1 or cp.shape != (lam.size, deg.size) \
                or ct.shape != cp.shape:
            raise ModelError("PerformanceSurface: power and thrust must be tables of shape "
                             f"(len(tip_speed_ratios), len(pitch_degrees)) = "
                             f"({lam.size}, {deg.size}), got {cp.shape} and {ct.shape}")
        if np.any(np.diff(lam) <= 0) or np.any(np.diff(deg) <= 0) or lam[0] <= 0:
            raise ModelError("PerformanceSurface: tip_speed_ratios (positive) and "
                             "pitch_degrees must be strictly increasing")
        if not (isinstance(degree, int) and 1 <= degree < min(lam.size, deg.size)):
            raise ModelError(f"PerformanceSurface: degree must be an int from 1 to "
                             f"{min(lam.size, deg.size) - 1}, got {degree!r}")
        self.tip_speed_ratios, self.pitch_degrees = lam, deg
        self.power, self.thrust = cp, ct
        self.lam_box = (lam[0], lam[-1])
        self.pitch_box = (np.radians(deg[0]), np.radians(deg[-1]))
        L, P = np.meshgrid(lam, np.radians(deg), indexing="ij")
        V = chebyshev.chebvander2d(*self._scaled(L.ravel(), P.ravel()), [degree, degree])
        self.power_fit = np.linalg.lstsq(V, cp.ravel(), rcond=None)[0].reshape(
            degree + 1, degree + 1)
        self.thrust_fit = np.linalg.lstsq(V, ct.ravel(), rcond=None)[0].reshape(
            degree + 1, degree + 1)

    def _scaled(self, lam, pitch):
        (l0, l1), (p0, p1) = self.lam_box, self.pitch_box
        return (2 * (lam - l0) / (l1 - l0) - 1, 2 * (pitch - p0) / (p1 - p0) - 1)

    def coefficients(self, tip_speed_ratio, pitch):
        r"""``(C_P, C_T)`` of the fit (arrays) at :math:`\lambda` and pitch (rad),
        the arguments clamped to the table's box."""
        x, y = self._scaled(np.clip(tip_speed_ratio, *self.lam_box),
                            np.clip(pitch, *self.pitch_box))
        return (chebyshev.chebval2d(x, y, self.power_fit),
                chebyshev.chebval2d(x, y, self.thrust_fit))

    def torque_coefficient(self, tip_speed_ratio, pitch):
        r""":math:`C_Q = C_P/\lambda` (array) of the fit, as :meth:`expressions` gives it."""
        cp, _ = self.coefficients(tip_speed_ratio, pitch)
        return cp / np.clip(tip_speed_ratio, *self.lam_box)

    def expressions(self, tip_speed_ratio, pitch):
        r"""``(C_Q, C_T)`` as SymPy expressions of :math:`\lambda` and pitch (rad)."""
        lam = _clamp(tip_speed_ratio, *map(float, self.lam_box))
        x, y = self._scaled(lam, _clamp(pitch, *map(float, self.pitch_box)))
        n = self.power_fit.shape[0]
        tx, ty = [sm.S.One, x], [sm.S.One, y]
        for _ in range(2, n):
            tx.append(2 * x * tx[-1] - tx[-2])
            ty.append(2 * y * ty[-1] - ty[-2])

        def series(c):
            return sm.Add(*[tx[i] * sm.Add(*[sm.Float(c[i, j]) * ty[j] for j in range(n)])
                            for i in range(n)])
        return series(self.power_fit) / lam, series(self.thrust_fit)


class RotorAerodynamics:
    r"""Quasi-steady thrust and torque of a rotor from its :class:`PerformanceSurface`.

    Parameters
    ----------
    name : str
    surface : PerformanceSurface
    radius : float
        Rotor radius :math:`R`, m.
    air_density : float
        :math:`\rho`, kg/m^3.
    hub : sympy.physics.mechanics.Point
        The hub centre, its velocity in ``frame`` known in the speeds.
    shaft : sympy.physics.vector.Vector
        Unit vector along the shaft, downwind.
    frame : sympy.physics.mechanics.ReferenceFrame
        The inertial frame.
    rotor_frame : sympy.physics.mechanics.ReferenceFrame
        The spinning rotor's frame (the torque acts on it).
    rotor_speed : sympy.Expr
        :math:`\Omega`, the rotor's speed relative to the nacelle, rad/s.
    pitch : sympy.Expr
        Collective blade pitch, rad.
    wind : float or sympy.Expr
        Free wind speed at the hub, m/s, taken along the shaft (a number, or
        the symbol of a specified input).
    """

    def __init__(self, name, surface, radius, air_density, hub, shaft, frame, rotor_frame,
                 rotor_speed, pitch, wind):
        if not isinstance(surface, PerformanceSurface):
            raise ModelError(f"RotorAerodynamics {name!r}: surface must be a "
                             f"PerformanceSurface, got {type(surface).__name__}")
        for key, value in (("radius", radius), ("air_density", air_density)):
            if not (isinstance(value, (int, float)) and value > 0):
                raise ModelError(f"RotorAerodynamics {name!r}: {key} must be a positive "
                                 f"number, got {value!r}")
        self.name, self.surface, self.radius, self.air_density = name, surface, radius, \
            air_density
        self.hub, self.shaft, self.frame, self.rotor_frame = hub, shaft, frame, rotor_frame
        self.relative_wind = wind - hub.vel(frame).dot(shaft)
        # the floor keeps lambda finite when the hub runs with the wind (clamped anyway)
        # unevaluated, as _clamp's: SymPy's search for comparable arguments took half a
        # second of each turbine's build, and the bound is a number
        self.tip_speed_ratio = rotor_speed * radius / sm.Max(self.relative_wind, 0.1,
                                                             evaluate=False)
        cq, ct = surface.expressions(self.tip_speed_ratio, pitch)
        q = sm.Float(air_density * np.pi * radius ** 2 / 2) * self.relative_wind ** 2
        self.thrust = q * ct
        self.torque = q * radius * cq

    def to_loads(self):
        """``[(hub, T s), (rotor_frame, Q s)]``."""
        return [(self.hub, self.thrust * self.shaft),
                (self.rotor_frame, self.torque * self.shaft)]

    def __repr__(self):
        return f"RotorAerodynamics({self.name!r}, R={self.radius})"
