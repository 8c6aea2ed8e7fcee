r"""Linear (Airy) waves: regular waves, irregular seas from a JONSWAP spectrum.

Axes: ``x`` and ``y`` horizontal, ``z`` up, ``z = 0`` at the still water level
(SWL), the sea bed at ``z = -depth``.  A wave field is a sum of components

.. math:: \eta(x, y, t) = \sum_i a_i \cos\theta_i,\qquad
          \theta_i = k_i (x\cos\beta + y\sin\beta) - \omega_i t + \varphi_i

whose wave numbers solve the finite-depth dispersion relation
:math:`\omega^2 = g k \tanh(k h)` (:func:`wave_number`, SciPy's ``brentq``).
The particle velocity and acceleration of each component are those of linear
potential theory,

.. math:: u_h = \omega a \frac{\cosh k(z+h)}{\sinh kh}\cos\theta,\quad
          w = \omega a \frac{\sinh k(z+h)}{\sinh kh}\sin\theta,\quad
          \dot u_h = \omega^2 a \frac{\cosh k(z+h)}{\sinh kh}\sin\theta,\quad
          \dot w = -\omega^2 a \frac{\sinh k(z+h)}{\sinh kh}\cos\theta

(local accelerations :math:`\partial u/\partial t`; the convective terms are
second order and left out).  Above the SWL linear theory says nothing; the
``stretching`` option chooses what is used there:

``"none"``     the formulae up to ``z = 0``; zero (dry) above the SWL
``"vertical"`` below the SWL the formulae; from the SWL up to the surface the
               values at ``z = 0``; zero above the surface
``"wheeler"``  Wheeler stretching: at ``-h <= z <= eta`` the formulae at
               :math:`z' = h (z - \eta)/(h + \eta)` (:math:`z - \eta` in deep
               water); zero above the surface
"""

import math

import numpy as np

from ..._errors import ModelError

__all__ = ["G_STANDARD", "wave_number", "jonswap_spectrum", "jonswap_gamma", "AiryWave",
           "IrregularSea", "STRETCHING"]

G_STANDARD = 9.80665
"""Standard gravity, m/s^2."""

STRETCHING = ("none", "vertical", "wheeler")


def _positive(value, name, owner, allow_inf=False):
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: {name} must be a number, got {value!r}") from None
    if not value > 0 or (math.isinf(value) and not allow_inf) or math.isnan(value):
        raise ModelError(f"{owner}: {name} must be positive and finite"
                         f"{' (or inf)' if allow_inf else ''}, got {value!r}")
    return value


def wave_number(omega, depth, g=G_STANDARD):
    r"""Wave number solving :math:`\omega^2 = g k \tanh(k h)`.

    The root lies in :math:`[k_0, k_0/\tanh(k_0 h)]` with :math:`k_0 =
    \omega^2/g` (the left side grows with ``k``); SciPy's ``brentq`` finds it.

    Parameters
    ----------
    omega : float or array_like
        Angular frequency, rad/s (positive).
    depth : float
        Water depth ``h``, m (``numpy.inf`` for deep water: ``k = omega^2/g``).
    g : float
        Gravity, m/s^2.

    Returns
    -------
    float or numpy.ndarray
        Wave number(s) ``k``, rad/m, of the shape of ``omega``.
    """
    depth = _positive(depth, "depth", "wave_number", allow_inf=True)
    g = _positive(g, "g", "wave_number")
    w = np.asarray(omega, dtype=float)
    if np.any(~(w > 0)) or np.any(~np.isfinite(w)):
        raise ModelError(f"wave_number: omega must be positive and finite, got {omega!r}")
    k0 = w ** 2 / g
    if math.isinf(depth):
        return k0 if w.ndim else float(k0)
    from scipy.optimize import brentq  # imported when first needed (start-up time)
    out = np.empty_like(k0)
    for i, (w_i, k_i) in enumerate(zip(w.ravel(), k0.ravel())):
        hi = k_i / math.tanh(k_i * depth)

        def residual(k, w_i=w_i):
            return g * k * math.tanh(k * depth) - w_i ** 2

        if residual(k_i) >= 0:  # deep water to machine precision
            out.flat[i] = k_i
        elif residual(hi) <= 0:
            out.flat[i] = hi
        else:
            out.flat[i] = brentq(residual, k_i, hi, xtol=1e-300,
                                 rtol=4 * np.finfo(float).eps, maxiter=200)
    return out if w.ndim else float(out)


def jonswap_gamma(Hs, Tp):
    r"""The peak enhancement factor IEC 61400-3 (and DNV-RP-C205) recommend.

    :math:`\gamma = 5` for :math:`T_p/\sqrt{H_s} \le 3.6`,
    :math:`\exp(5.75 - 1.15\,T_p/\sqrt{H_s})` up to 5, and 1 above (``Hs`` in m,
    ``Tp`` in s).
    """
    Hs = _positive(Hs, "Hs", "jonswap_gamma")
    Tp = _positive(Tp, "Tp", "jonswap_gamma")
    ratio = Tp / math.sqrt(Hs)
    if ratio <= 3.6:
        return 5.0
    if ratio < 5.0:
        return math.exp(5.75 - 1.15 * ratio)
    return 1.0


def jonswap_spectrum(omega, Hs, Tp, gamma):
    r"""JONSWAP wave spectrum :math:`S(\omega)` in m^2 s/rad.

    The form of IEC 61400-3 and DNV-RP-C205:

    .. math:: S(\omega) = (1 - 0.287\ln\gamma)\,\frac{5}{16} H_s^2 \omega_p^4
              \omega^{-5} \exp\!\left[-\frac54\left(\frac{\omega}{\omega_p}\right)^{-4}\right]
              \gamma^{\exp\left[-\frac{(\omega-\omega_p)^2}{2\sigma^2\omega_p^2}\right]}

    with :math:`\omega_p = 2\pi/T_p`, :math:`\sigma = 0.07` for
    :math:`\omega \le \omega_p` and 0.09 above.  With :math:`\gamma = 1` it is
    the Pierson-Moskowitz spectrum, whose zeroth moment is exactly
    :math:`H_s^2/16`; the factor :math:`1 - 0.287\ln\gamma` makes it so only
    approximately for other :math:`\gamma` (within 2 % for
    :math:`1 \le \gamma \le 7`, 0.3 % at 3.3).

    Parameters
    ----------
    omega : float or array_like
        Angular frequency, rad/s (``omega <= 0`` gives 0).
    Hs, Tp : float
        Significant wave height (m) and peak period (s).
    gamma : float
        Peak enhancement factor (1 to 7; :func:`jonswap_gamma` gives IEC's value).

    Returns
    -------
    float or numpy.ndarray
    """
    Hs = _positive(Hs, "Hs", "jonswap_spectrum")
    Tp = _positive(Tp, "Tp", "jonswap_spectrum")
    gamma = _positive(gamma, "gamma", "jonswap_spectrum")
    if not 1.0 <= gamma <= 7.0:
        raise ModelError(f"jonswap_spectrum: gamma must lie in [1, 7] (the range of the "
                         f"standard form), got {gamma!r}")
    w = np.asarray(omega, dtype=float)
    wp = 2 * math.pi / Tp
    out = np.zeros_like(w)
    pos = w > 0
    x = w[pos] / wp
    sigma = np.where(x <= 1.0, 0.07, 0.09)
    pm = 5.0 / 16.0 * Hs ** 2 / wp * x ** -5 * np.exp(-1.25 * x ** -4)
    out[pos] = (1 - 0.287 * math.log(gamma)) * pm * gamma ** np.exp(
        -((x - 1.0) ** 2) / (2 * sigma ** 2))
    return out if w.ndim else float(out)


class _LinearWaves:
    """A sum of linear wave components travelling in one direction."""

    def __init__(self, owner, amplitudes, omegas, phases, depth, direction, g, stretching):
        self._owner = owner
        self.depth = _positive(depth, "depth", owner, allow_inf=True)
        self.g = _positive(g, "g", owner)
        if stretching not in STRETCHING:
            raise ModelError(f"{owner}: stretching must be one of {STRETCHING}, got "
                             f"{stretching!r}")
        self.stretching = stretching
        self.direction = float(direction)
        self.amplitudes = np.asarray(amplitudes, dtype=float).ravel()
        self.omegas = np.asarray(omegas, dtype=float).ravel()
        self.phases = np.asarray(phases, dtype=float).ravel()
        self.wave_numbers = np.atleast_1d(wave_number(self.omegas, self.depth, self.g))

    # ------------------------------------------------------------------ helpers
    def _theta(self, x, y, t):
        c, s = math.cos(self.direction), math.sin(self.direction)
        horiz = np.asarray(x, dtype=float) * c + np.asarray(y, dtype=float) * s
        return (horiz[..., None] * self.wave_numbers - self.omegas * t + self.phases)

    def _profiles(self, z):
        """``cosh k(z+h)/sinh kh`` and ``sinh k(z+h)/sinh kh``, shape (..., m)."""
        k = self.wave_numbers
        z = np.asarray(z, dtype=float)[..., None]
        if math.isinf(self.depth):
            e = np.exp(k * z)
            return e, e
        h = self.depth
        den = -np.expm1(-2 * k * h)
        a, b = np.exp(k * z), np.exp(-k * (z + 2 * h))
        return (a + b) / den, (a - b) / den

    # ------------------------------------------------------------------ public
    def elevation(self, x, t, y=0.0):
        """Surface elevation ``eta`` (m) at horizontal position(s) ``(x, y)`` (m), time t (s)."""
        return np.cos(self._theta(x, y, t)) @ self.amplitudes

    def potential(self, x, z, t, y=0.0):
        r"""Velocity potential (m^2/s) of linear theory, :math:`z \le 0` (no stretching).

        :math:`\phi = \sum (g a/\omega)\,\cosh k(z+h)/\cosh kh\,\sin\theta`.
        """
        ch, _ = self._profiles(z)
        k, h = self.wave_numbers, self.depth
        tanh = np.ones_like(k) if math.isinf(h) else np.tanh(k * h)
        # cosh k(z+h)/cosh kh = tanh kh * cosh k(z+h)/sinh kh
        coef = self.g * self.amplitudes / self.omegas * tanh
        return (ch * np.sin(self._theta(x, y, t))) @ coef

    def kinematics(self, x, z, t, y=0.0):
        """Particle velocity and acceleration at points ``(x, y, z)`` (m) at time ``t`` (s).

        Parameters
        ----------
        x, z, y : float or array_like, broadcastable to one shape ``S``
        t : float

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            Velocity (m/s) and acceleration (m/s^2), shape ``S + (3,)``: x, y, z
            components; zero where the point is dry (see ``stretching``).
        """
        x, y, z = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float),
                                      np.asarray(z, float))
        if self.stretching != "wheeler":
            return self._fixed_point_kinematics(x, y, z, t)
        theta = self._theta(x, y, t)
        cos, sin = np.cos(theta), np.sin(theta)
        if self.stretching == "none":
            wet = z <= 0
            z_eval = np.minimum(z, 0.0)
        else:
            eta = cos @ self.amplitudes
            wet = z <= eta
            if self.stretching == "vertical":
                z_eval = np.minimum(z, 0.0)
            elif math.isinf(self.depth):
                z_eval = np.minimum(z - eta, 0.0)
            else:
                h = self.depth
                z_eval = np.minimum(h * (z - eta) / (h + eta), 0.0)
        ch, sh = self._profiles(z_eval)
        wa = self.omegas * self.amplitudes
        w2a = self.omegas * wa
        u_h = (ch * cos) @ wa
        w = (sh * sin) @ wa
        a_h = (ch * sin) @ w2a
        a_z = -(sh * cos) @ w2a
        c, s = math.cos(self.direction), math.sin(self.direction)
        vel = np.stack([u_h * c, u_h * s, w], axis=-1) * wet[..., None]
        acc = np.stack([a_h * c, a_h * s, a_z], axis=-1) * wet[..., None]
        return vel, acc

    def _fixed_point_kinematics(self, x, y, z, t):
        """:meth:`kinematics` without stretching to the surface (the depth profile
        does not depend on t): with ``theta = base - omega t``, every per-point,
        per-component factor is computed once for the points (the last set seen
        is kept: Morison strips ask at the same points every time) and a call
        is eight matrix-vector products with ``cos(omega t)``, ``sin(omega t)``."""
        C, S, A, B, D, E = self._fixed_factors(x, y, z)
        ct, st = np.cos(self.omegas * t), np.sin(self.omegas * t)
        wa = self.omegas * self.amplitudes
        w2a = self.omegas * wa
        # cos(theta) = C ct + S st, sin(theta) = S ct - C st
        u_h = A @ (wa * ct) + B @ (wa * st)
        w = D @ (wa * ct) - E @ (wa * st)
        a_h = B @ (w2a * ct) - A @ (w2a * st)
        a_z = -(E @ (w2a * ct) + D @ (w2a * st))
        if self.stretching == "none":
            wet = z <= 0
        else:  # vertical: wet up to the surface
            wet = z <= C @ (self.amplitudes * ct) + S @ (self.amplitudes * st)
        c, s = math.cos(self.direction), math.sin(self.direction)
        vel = np.stack([u_h * c, u_h * s, w], axis=-1) * wet[..., None]
        acc = np.stack([a_h * c, a_h * s, a_z], axis=-1) * wet[..., None]
        return vel, acc

    def _fixed_factors(self, x, y, z):
        """The per-point, per-component factors of :meth:`_fixed_point_kinematics`
        (cached for the last points asked for)."""
        key = (x.shape, x.tobytes(), y.tobytes(), z.tobytes())
        if getattr(self, "_fixed_key", None) != key:
            c, s = math.cos(self.direction), math.sin(self.direction)
            base = (x * c + y * s)[..., None] * self.wave_numbers + self.phases
            C, S = np.cos(base), np.sin(base)
            ch, sh = self._profiles(np.minimum(z, 0.0))
            self._fixed = (C, S, ch * C, ch * S, sh * S, sh * C)
            self._fixed_key = key
        return self._fixed

    def kinematics_series(self, x, z, times, y=0.0):
        """:meth:`kinematics` at each of ``times`` (s): velocity and acceleration,
        shape ``(len(times),) + S + (3,)``.  Without Wheeler stretching (the
        depth profile then does not depend on the time) in matrix products over
        blocks of times, the way to sample the kinematics for input records
        (:func:`kanedyn.simulate_many`); with it, time by time."""
        times = np.asarray(times, dtype=float).ravel()
        x, y, z = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float),
                                      np.asarray(z, float))
        if self.stretching == "wheeler":
            pairs = [self.kinematics(x, z, t, y) for t in times]
            shape = (len(times),) + x.shape + (3,)
            return (np.stack([v for v, _ in pairs]).reshape(shape),
                    np.stack([a for _, a in pairs]).reshape(shape))
        C, S, A, B, D, E = self._fixed_factors(x, y, z)
        m, w = self.omegas.size, self.omegas
        flat = [F.reshape(-1, m) for F in (C, S, A, B, D, E)]
        C, S, A, B, D, E = flat
        # with theta = base - omega t: u_h, w, du_h/dt, dw/dt are the rows of
        # F1 (omega a cos omega t) + or - F2 (omega a sin omega t)
        F1 = np.concatenate([A, D, B * w, E * w]).T
        F2 = np.concatenate([B, E, A * w, D * w]).T
        P = A.shape[0]
        c, s = math.cos(self.direction), math.sin(self.direction)
        vel = np.empty((len(times), P, 3))
        acc = np.empty_like(vel)
        wa = w * self.amplitudes
        for start in range(0, len(times), 2048):  # blocks of (times x components)
            block = slice(start, start + 2048)
            phase = np.multiply.outer(times[block], w)
            ct, st = np.cos(phase), np.sin(phase)
            X1, X2 = (ct * wa) @ F1, (st * wa) @ F2
            u_h, v_z = X1[:, :P] + X2[:, :P], X1[:, P:2 * P] - X2[:, P:2 * P]
            a_h, a_z = X1[:, 2 * P:3 * P] - X2[:, 2 * P:3 * P], -(X1[:, 3 * P:] + X2[:, 3 * P:])
            if self.stretching == "none":
                wet = z.reshape(-1) <= 0
            else:  # vertical: wet up to the surface
                wet = z.reshape(-1) <= (ct * self.amplitudes) @ C.T + (st * self.amplitudes) @ S.T
            vel[block] = np.stack([u_h * c, u_h * s, v_z], axis=-1) * wet[..., None]
            acc[block] = np.stack([a_h * c, a_h * s, a_z], axis=-1) * wet[..., None]
        shape = (len(times),) + x.shape + (3,)
        return vel.reshape(shape), acc.reshape(shape)

    def elevation_series(self, x, times, y=0.0):
        """:meth:`elevation` at each of ``times`` (s), shape ``(len(times),) + S``."""
        return np.stack([self.elevation(x, t, y) for t in np.asarray(times, float).ravel()])

    def velocity(self, x, z, t, y=0.0):
        """Particle velocity (m/s), shape ``S + (3,)`` (see :meth:`kinematics`)."""
        return self.kinematics(x, z, t, y)[0]

    def acceleration(self, x, z, t, y=0.0):
        """Particle acceleration (m/s^2), shape ``S + (3,)`` (see :meth:`kinematics`)."""
        return self.kinematics(x, z, t, y)[1]

    @property
    def crest_bound(self):
        """An upper bound of the elevation, ``sum(a_i)`` (m)."""
        return float(np.sum(np.abs(self.amplitudes)))


class AiryWave(_LinearWaves):
    r"""A regular linear (Airy) wave of height ``H`` and period ``T``.

    :math:`\eta = (H/2)\cos(k(x\cos\beta + y\sin\beta) - \omega t + \varphi)`
    with :math:`\omega = 2\pi/T` and ``k`` from the dispersion relation.

    Parameters
    ----------
    height : float
        Wave height ``H`` (crest to trough), m.
    period : float
        Wave period ``T``, s.
    depth : float
        Water depth, m (``numpy.inf``: deep water).
    direction : float, optional
        Heading ``beta`` of propagation from the x axis, rad (default 0: along +x).
    phase : float, optional
        Phase ``varphi``, rad (default 0: a crest at x = 0 at t = 0).
    g : float, optional
        Gravity, m/s^2 (default standard gravity 9.80665).
    stretching : {"none", "vertical", "wheeler"}, optional
        Kinematics above the SWL (module docstring); default "none".
    """

    def __init__(self, height, period, depth, direction=0.0, phase=0.0, g=G_STANDARD,
                 stretching="none"):
        self.height = _positive(height, "height", "AiryWave")
        self.period = _positive(period, "period", "AiryWave")
        omega = 2 * math.pi / self.period
        super().__init__("AiryWave", [self.height / 2], [omega], [phase], depth, direction,
                         g, stretching)

    @property
    def omega(self):
        """Angular frequency, rad/s."""
        return float(self.omegas[0])

    @property
    def k(self):
        """Wave number, rad/m."""
        return float(self.wave_numbers[0])

    @property
    def wavelength(self):
        """Wave length, m."""
        return 2 * math.pi / self.k

    def __repr__(self):
        return (f"AiryWave(height={self.height}, period={self.period}, depth={self.depth}, "
                f"stretching={self.stretching!r})")


class IrregularSea(_LinearWaves):
    r"""A long-crested irregular sea from a JONSWAP spectrum, seeded and reproducible.

    The band ``[omega_min, omega_max]`` is cut into ``n_components`` equal
    intervals :math:`\Delta\omega`; component ``i`` sits at the interval's
    midpoint with amplitude :math:`a_i = \sqrt{2 S(\omega_i)\Delta\omega}` and a
    phase drawn uniformly from :math:`[0, 2\pi)` by
    ``numpy.random.default_rng(seed)``: the same seed gives the same sea.  The
    series repeats after :math:`2\pi/\Delta\omega`; its variance is
    :math:`\sum a_i^2/2`, the spectrum's zeroth moment over the band
    (:attr:`variance`).

    Parameters
    ----------
    Hs, Tp, gamma : float
        Significant wave height (m), peak period (s), peak enhancement factor
        (:func:`jonswap_spectrum`; :func:`jonswap_gamma` gives IEC's value).
    depth : float
        Water depth, m (``numpy.inf``: deep water).
    n_components : int
        Number of frequency components.
    seed : int
        Seed of the random phases.
    omega_min, omega_max : float, optional
        Frequency band, rad/s; default ``0.5 omega_p`` to ``6 omega_p`` (the
        band holds all but about 0.1 % of the variance of a Pierson-Moskowitz
        spectrum; :attr:`variance` says what the band holds).
    direction : float, optional
        Heading of propagation from the x axis, rad (default 0).
    g : float, optional
        Gravity, m/s^2 (default 9.80665).
    stretching : {"none", "vertical", "wheeler"}, optional
        Kinematics above the SWL (module docstring); default "none".
    """

    def __init__(self, Hs, Tp, gamma, depth, n_components, seed, omega_min=None,
                 omega_max=None, direction=0.0, g=G_STANDARD, stretching="none"):
        self.Hs = _positive(Hs, "Hs", "IrregularSea")
        self.Tp = _positive(Tp, "Tp", "IrregularSea")
        self.gamma = float(gamma)
        if not isinstance(n_components, (int, np.integer)) or n_components < 1:
            raise ModelError(f"IrregularSea: n_components must be a positive int, got "
                             f"{n_components!r}")
        if not isinstance(seed, (int, np.integer)):
            raise ModelError(f"IrregularSea: seed must be an int (reproducible phases), "
                             f"got {seed!r}")
        wp = 2 * math.pi / self.Tp
        lo = 0.5 * wp if omega_min is None else _positive(omega_min, "omega_min",
                                                         "IrregularSea")
        hi = 6.0 * wp if omega_max is None else _positive(omega_max, "omega_max",
                                                         "IrregularSea")
        if not hi > lo:
            raise ModelError(f"IrregularSea: omega_max ({hi}) must exceed omega_min ({lo})")
        self.seed, self.n_components = int(seed), int(n_components)
        self.band = (lo, hi)
        self.d_omega = (hi - lo) / n_components
        omegas = lo + (np.arange(n_components) + 0.5) * self.d_omega
        spectrum = jonswap_spectrum(omegas, self.Hs, self.Tp, self.gamma)
        amplitudes = np.sqrt(2 * spectrum * self.d_omega)
        phases = np.random.default_rng(self.seed).uniform(0.0, 2 * math.pi, n_components)
        super().__init__("IrregularSea", amplitudes, omegas, phases, depth, direction, g,
                         stretching)

    def with_seed(self, seed):
        """The same sea (spectrum, band, components, depth, heading, stretching) with
        the phases of another ``seed``."""
        return IrregularSea(self.Hs, self.Tp, self.gamma, self.depth, self.n_components, seed,
                            omega_min=self.band[0], omega_max=self.band[1],
                            direction=self.direction, g=self.g, stretching=self.stretching)

    @property
    def variance(self):
        """Variance of the elevation of the discretized sea, m^2."""
        return float(np.sum(self.amplitudes ** 2) / 2)

    @property
    def repeat_period(self):
        """The time after which the series repeats, ``2 pi / d_omega`` (s)."""
        return 2 * math.pi / self.d_omega

    def __repr__(self):
        return (f"IrregularSea(Hs={self.Hs}, Tp={self.Tp}, gamma={self.gamma}, "
                f"depth={self.depth}, n_components={self.n_components}, seed={self.seed})")
