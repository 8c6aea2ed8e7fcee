r"""Rotor thrust from a steady thrust curve, aerodynamic damping, turbulent wind.

``RotorThrust``     thrust :math:`T(V_{rel})` at the hub along the shaft, with
                    :math:`V_{rel}` the wind speed relative to the moving hub
``ThrustCurve``     a steady thrust-against-wind-speed table (PCHIP interpolated)
``NREL5MW_THRUST``  the NREL 5-MW reference turbine's curve (sources below)
``kaimal_wind``     a seeded longitudinal turbulent wind series (IEC 61400-1
                    Kaimal spectrum, random phases)

The relative wind speed along the shaft :math:`s` is

.. math:: V_{rel} = (V(t)\,e_w - v_{hub})\cdot s

so a hub moving downwind sees less wind and feels less thrust: the
aerodynamic damping, :math:`c_{aero} = dT/dV` on the hub's velocity along the
shaft, comes out of the curve's slope.
"""

import numpy as np
import sympy.physics.mechanics as me

from ..._errors import ModelError
from ._mooring import state_function

__all__ = ["ThrustCurve", "RotorThrust", "NREL5MW_THRUST", "kaimal_wind",
           "kaimal_spectrum"]

_RHO_AIR = 1.225  # kg/m^3, the NREL 5-MW design air density
_AREA = np.pi * 63.0 ** 2  # m^2, rotor of 126 m diameter


class ThrustCurve:
    """A steady rotor thrust against wind speed, interpolated shape-preserving (PCHIP).

    Parameters
    ----------
    speeds : sequence of float
        Wind speeds at hub height, m/s, strictly increasing.
    thrusts : sequence of float
        Steady rotor thrust at each speed, N.

    Outside the table the thrust is held at its end values (zero slope).
    """

    def __init__(self, speeds, thrusts):
        v = np.asarray(speeds, dtype=float)
        f = np.asarray(thrusts, dtype=float)
        if v.ndim != 1 or v.shape != f.shape or v.size < 2:
            raise ModelError("ThrustCurve: speeds and thrusts must be 1-D of equal length "
                             f">= 2, got shapes {v.shape} and {f.shape}")
        if np.any(np.diff(v) <= 0):
            raise ModelError("ThrustCurve: speeds must be strictly increasing")
        self.speeds, self.thrusts = v, f
        self._curves = None  # the interpolant and its derivative, made on first use

    def _interpolants(self):
        if self._curves is None:
            from scipy.interpolate import PchipInterpolator  # start-up time: when needed
            f = PchipInterpolator(self.speeds, self.thrusts, extrapolate=False)
            self._curves = (f, f.derivative())
        return self._curves

    def __call__(self, V):
        """Thrust (N) at wind speed(s) ``V`` (m/s)."""
        V = np.clip(V, self.speeds[0], self.speeds[-1])
        return self._interpolants()[0](V)

    def slope(self, V):
        """:math:`dT/dV` (N s/m) at ``V``: the aerodynamic damping on the hub's speed."""
        inside = (V >= self.speeds[0]) & (V <= self.speeds[-1])
        slope = self._interpolants()[1]
        return np.where(inside, slope(np.clip(V, self.speeds[0], self.speeds[-1])), 0.0)

    def expression(self, V):
        """The thrust (N) at the SymPy expression ``V`` (m/s): the same cubic pieces
        as :meth:`__call__` (held at the end values outside the table), as a
        ``Piecewise`` that compiled code evaluates."""
        import sympy as sm
        f = self._interpolants()[0]
        x, c = f.x, f.c  # piece i: sum_k c[k, i] (V - x[i])^(3 - k)
        pieces = [(float(self.thrusts[0]), V < float(x[0]))]
        for i in range(len(x) - 1):
            s = V - float(x[i])
            cubic = ((float(c[0, i]) * s + float(c[1, i])) * s + float(c[2, i])) * s \
                + float(c[3, i])
            pieces.append((cubic, V < float(x[i + 1])))
        pieces.append((float(self.thrusts[-1]), True))
        return sm.Piecewise(*pieces)


_BELOW = np.array([3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 11.4])
#: The NREL 5-MW steady thrust curve (N against m/s at hub height).  Below
#: rated, T = 1/2 rho A C_T V^2 with rho = 1.225 kg/m^3, A = pi 63^2 m^2 and
#: C_T = 0.80 (the variable-speed region runs at a near-constant tip-speed ratio
#: and C_T; Jonkman et al. 2009, NREL/TP-500-38060, sec. 7 and fig. 9-3): it
#: gives 794 kN at the rated 11.4 m/s, the ~800 kN peak of fig. 9-3.  Above
#: rated the blades pitch and the thrust falls; the values from 12 m/s up are
#: approximate readings of fig. 9-3 (about +-10 %), to be replaced by a
#: computed curve (OpenFAST steady runs) when one is at hand.
NREL5MW_THRUST = ThrustCurve(
    np.concatenate([_BELOW, [12.0, 13.0, 14.0, 16.0, 18.0, 20.0, 22.0, 25.0]]),
    np.concatenate([0.5 * _RHO_AIR * _AREA * 0.80 * _BELOW ** 2,
                    [700e3, 590e3, 530e3, 460e3, 420e3, 390e3, 370e3, 340e3]]))


def kaimal_spectrum(f, mean_speed, sigma, hub_height=90.0):
    r"""IEC 61400-1 (ed. 3) Kaimal spectrum of the longitudinal component.

    .. math:: S_u(f) = \frac{4\sigma^2 L_u/V}{(1 + 6 f L_u/V)^{5/3}},\quad
              L_u = 8.1\,\Lambda_1,\quad \Lambda_1 = 0.7\min(z_{hub}, 60\text{ m})

    Returns
    -------
    ndarray
        One-sided spectral density, (m/s)^2/Hz.
    """
    Lu = 8.1 * 0.7 * min(hub_height, 60.0)
    x = Lu / mean_speed
    return 4 * sigma ** 2 * x / (1 + 6 * np.asarray(f) * x) ** (5 / 3)


def kaimal_wind(mean_speed, turbulence_intensity, duration, dt, seed, hub_height=90.0,
                match_variance=True):
    r"""A seeded longitudinal wind speed series at hub height.

    :math:`V(t) = \bar V + \sum_k a_k \cos(2\pi f_k t + \phi_k)` with
    :math:`f_k = k/T`, :math:`a_k = \sqrt{2 S_u(f_k)\,\Delta f}` (Kaimal,
    :func:`kaimal_spectrum`) up to the Nyquist frequency and phases
    :math:`\phi_k` uniform from ``numpy.random.default_rng(seed)``.  Over one
    period the series' variance is :math:`\sum a_k^2/2`, which misses the
    spectrum's part below :math:`1/T`; with ``match_variance`` the amplitudes
    are scaled so the standard deviation is exactly :math:`I\,\bar V` (the
    spectrum's shape is kept).

    Parameters
    ----------
    mean_speed : float
        :math:`\bar V`, m/s.
    turbulence_intensity : float
        :math:`I = \sigma/\bar V`.
    duration, dt : float
        Length and time step of the series, s.
    seed : int
        The same seed gives the same series.
    hub_height : float
        m (sets the Kaimal length scale).
    match_variance : bool

    Returns
    -------
    (ndarray, ndarray)
        Times (s) and wind speeds (m/s).
    """
    if not (mean_speed > 0 and turbulence_intensity >= 0 and duration > 0 and dt > 0
            and duration > 2 * dt):
        raise ModelError("kaimal_wind: need mean_speed > 0, turbulence_intensity >= 0 and "
                         "duration > 2 dt > 0")
    n = int(round(duration / dt))
    t = np.arange(n) * dt
    T = n * dt
    k = np.arange(1, n // 2 + 1)
    f = k / T
    sigma = turbulence_intensity * mean_speed
    amp = np.sqrt(2 * kaimal_spectrum(f, mean_speed, sigma, hub_height) / T)
    if match_variance and sigma > 0:
        amp *= sigma / np.sqrt(np.sum(amp ** 2) / 2)
    phases = np.random.default_rng(seed).uniform(0, 2 * np.pi, k.size)
    coefficients = np.zeros(n // 2 + 1, dtype=complex)
    coefficients[1:] = amp * np.exp(1j * phases) * n / 2
    if n % 2 == 0:  # the Nyquist term of a real series is a cosine of real amplitude
        coefficients[-1] = amp[-1] * np.cos(phases[-1]) * n
    return t, mean_speed + np.fft.irfft(coefficients, n)


class RotorThrust:
    r"""Rotor thrust at the hub along the shaft, from a steady curve and the relative wind.

    The thrust :math:`T` enters the equations as a specified input
    ``T_{name}(t)`` (N) applied at ``hub`` along ``shaft`` (:meth:`to_loads`);
    :meth:`specified` computes it at runtime as
    :math:`T = T_{curve}(V_{rel})` with
    :math:`V_{rel} = (V(t)\,e_w - v_{hub})\cdot s`.

    Parameters
    ----------
    name : str
    hub : sympy.physics.mechanics.Point
    shaft : sympy.physics.vector.Vector
        Unit vector along the shaft, pointing downwind (fixed in the nacelle).
    frame : sympy.physics.mechanics.ReferenceFrame
        The inertial frame; the wind blows along ``wind_direction`` in it.
    curve : ThrustCurve
        E.g. :data:`NREL5MW_THRUST`.
    wind : float or callable
        Wind speed at hub height (m/s): a number, or a function of time
        (e.g. ``np.interp`` over a :func:`kaimal_wind` series).
    wind_direction : sympy.physics.vector.Vector, optional
        Unit vector; ``frame.x`` when not given.
    lag : float, optional
        A first-order rotor lag time constant (s): ``T`` then becomes a state
        of its own, :math:`\tau\dot T = T_{curve}(V_{rel}) - T`
        (:meth:`lag_equation`); without it the thrust follows the wind at once.
    """

    def __init__(self, name, hub, shaft, frame, curve, wind, wind_direction=None, lag=None):
        if not isinstance(name, str) or not name:
            raise ModelError(f"RotorThrust needs a non-empty name, got {name!r}")
        what = f"RotorThrust {name!r}"
        if not isinstance(hub, me.Point):
            raise ModelError(f"{what}: hub must be a Point")
        if not isinstance(shaft, me.Vector) or not isinstance(frame, me.ReferenceFrame):
            raise ModelError(f"{what}: shaft must be a Vector and frame a ReferenceFrame")
        if not isinstance(curve, ThrustCurve):
            raise ModelError(f"{what}: curve must be a ThrustCurve, got "
                             f"{type(curve).__name__}")
        if not (callable(wind) or isinstance(wind, (int, float))):
            raise ModelError(f"{what}: wind must be a number (m/s) or a function of t")
        if lag is not None and not (isinstance(lag, (int, float)) and lag > 0):
            raise ModelError(f"{what}: lag must be a positive time constant (s), got {lag!r}")
        self.name, self.hub, self.shaft, self.frame = name, hub, shaft, frame
        self.curve, self.wind, self.lag = curve, wind, lag
        self.wind_direction = frame.x if wind_direction is None else wind_direction
        self.symbol = me.dynamicsymbols(f"T_{name}")

    def wind_speed(self, t):
        """Free wind speed at hub height (m/s) at time ``t``."""
        return float(self.wind(t)) if callable(self.wind) else float(self.wind)

    def to_loads(self):
        """``[(hub, T s)]`` with ``T`` the thrust symbol (an input or, with lag, a state)."""
        return [(self.hub, self.symbol * self.shaft)]

    def _kinematics(self, states, constants):
        exprs = [self.hub.vel(self.frame).dot(self.shaft),
                 self.wind_direction.dot(self.shaft)]
        return state_function(exprs, states, constants, f"RotorThrust {self.name!r}")

    def relative_speed(self, states, constants=None):
        """Callable ``(t, y) -> V_rel`` (m/s)."""
        kin = self._kinematics(states, constants)

        def v_rel(t, y):
            hub_speed, cosine = kin(y)
            return self.wind_speed(t) * cosine - hub_speed
        return v_rel

    def thrust(self, V_rel):
        """Quasi-steady thrust (N) at relative wind speed ``V_rel``."""
        return float(self.curve(V_rel))

    def damping(self, V):
        """Linearized aerodynamic damping :math:`dT/dV` (N s/m) at wind speed ``V``."""
        return float(self.curve.slope(V))

    def expression(self):
        """The thrust (N) as a SymPy expression of the state, for a steady wind (a
        number): :meth:`ThrustCurve.expression` at :math:`V_{rel}`.  Given as the
        input's value (``eom.numeric(specified={rotor.symbol: rotor.expression()})``)
        it is evaluated in the compiled code, not by a Python function of
        ``(t, y)`` as :meth:`specified` gives it."""
        if callable(self.wind):
            raise ModelError(f"RotorThrust {self.name!r}: the wind varies in time (a "
                             "function); its thrust is a function of (t, y): use "
                             "specified()")
        if self.lag is not None:
            raise ModelError(f"RotorThrust {self.name!r}: with lag= the thrust is a state")
        v_rel = (float(self.wind) * self.wind_direction.dot(self.shaft)
                 - self.hub.vel(self.frame).dot(self.shaft))
        return self.curve.expression(v_rel)

    def specified(self, states, constants=None):
        """``{T: callable(t, y)}`` (without lag) for ``eom.numeric(specified=...)``."""
        if self.lag is not None:
            raise ModelError(f"RotorThrust {self.name!r}: with lag= the thrust is a state; "
                             "add lag_equation() to the model instead of specified()")
        v_rel = self.relative_speed(states, constants)
        return {self.symbol: _Thrust(self, v_rel)}

    def lag_equation(self):
        r"""The lag's input and kinematic equation, for a thrust state.

        Returns ``(T_qs, equation)``: the quasi-steady thrust input symbol
        ``Tqs_{name}(t)`` (give it :meth:`quasi_steady`) and
        :math:`\tau\dot T - (T_{qs} - T)`, to be added to the model's kinematic
        differential equations with ``T`` among the coordinates.
        """
        if self.lag is None:
            raise ModelError(f"RotorThrust {self.name!r}: no lag= time constant given")
        t = me.dynamicsymbols._t
        quasi = me.dynamicsymbols(f"Tqs_{self.name}")
        return quasi, self.lag * self.symbol.diff(t) - (quasi - self.symbol)

    def quasi_steady(self, states, constants=None):
        """``{Tqs: callable(t, y)}``: the curve's thrust at the relative wind speed."""
        quasi, _ = self.lag_equation()
        return {quasi: _Thrust(self, self.relative_speed(states, constants))}

    def __repr__(self):
        return f"RotorThrust({self.name!r}, hub={self.hub.name}, lag={self.lag})"


class _Thrust:
    def __init__(self, rotor, v_rel):
        self.rotor, self.v_rel = rotor, v_rel

    def __call__(self, t, y):
        return self.rotor.thrust(self.v_rel(t, y))

