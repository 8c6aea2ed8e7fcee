r"""Quasi-steady blade-element momentum (BEM) theory of a rotor's annuli.

``BladeElementMomentum``  a rotor of rigid blades in the plane normal to its
                          shaft: its annuli's induction solved from the local
                          inflow, loads per unit length, steady thrust, torque
                          and the coefficients :math:`C_P(\lambda,\theta)`,
                          :math:`C_T(\lambda,\theta)`
``AnnulusSolution``       the solved annuli (inflow angle, inductions, loads)

Each annulus at radius :math:`r` sees the axial inflow :math:`V_x` (along the
shaft, downwind) and the tangential one :math:`V_y` (against the blade's
motion).  With the inflow angle :math:`\varphi`, the angle of attack
:math:`\alpha = \varphi - (\beta + \theta)` (twist and pitch), the airfoil's
:math:`C_l(\alpha)`, :math:`C_d(\alpha)` (linear in the tables), the normal
and tangential coefficients :math:`c_n = C_l\cos\varphi + C_d\sin\varphi`,
:math:`c_t = C_l\sin\varphi - C_d\cos\varphi`, the local solidity
:math:`\sigma' = Bc/(2\pi r)` and Prandtl's tip and hub losses

.. math:: F = \tfrac{2}{\pi}\arccos e^{-\frac{B}{2}\frac{R - r}{r|\sin\varphi|}}
          \cdot \tfrac{2}{\pi}\arccos e^{-\frac{B}{2}\frac{r - R_h}{R_h|\sin\varphi|}},

the inductions are :math:`a = k/(1 + k)` and :math:`a' = k'/(1 - k')` with
:math:`k = \sigma' c_n/(4F\sin^2\varphi)`, :math:`k' = \sigma' c_t/(4F\sin\varphi
\cos\varphi)`; above :math:`k = 2/3` (:math:`a = 0.4`) the axial induction
follows Buhl's empirical thrust curve (the high-induction correction), and for
:math:`\varphi < 0` the propeller-brake branch :math:`a = k/(k - 1)`.  The
inflow angle is the root of the one-equation residual (Ning 2014, *Wind
Energy* 17, 1327)

.. math:: R(\varphi) = \frac{\sin\varphi}{1 - a} - \frac{V_x}{V_y}\cos\varphi\,(1 - k'),

bracketed (after a neighbourhood of a guess, if given) first on
:math:`(0, \pi/2]`, then on :math:`[-\pi/4, 0)`, then on :math:`[\pi/2, \pi)`,
and found by a safeguarded Newton iteration (regula falsi, Illinois, where
Newton's point leaves the bracket) on all annuli at once, each step evaluating
two points :math:`0.8\cdot10^{-10}` rad apart (their sign change ends it); from
a guess, Newton's first step takes the slope at the guess.  Those steps run in a
compiled kernel (``numerics/backends/_bem_kernel.py``), an annulus at a time,
where a C compiler is found, and in NumPy otherwise: the same angles.
The loads per unit length are
:math:`N' = \tfrac12\rho W^2 c\,c_n` (along the shaft) and
:math:`T' = \tfrac12\rho W^2 c\,c_t` (along the blade's motion), with
:math:`W^2 = V_x^2(1 - a)^2 + V_y^2(1 + a')^2`; thrust and torque integrate
them over :math:`R_h \le r \le R` by the trapezoidal rule with zero load at
both ends.  Drag enters the inductions and the loads (as in CCBlade's default).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._errors import ModelError
from ._aerodyn_tables import AirfoilPolar, BladeTable

__all__ = ["BladeElementMomentum", "AnnulusSolution"]

_EPS = 1e-6          # rad, the brackets keep this far from phi = 0 and pi
_TOLERANCE = 1e-10   # rad, on the inflow angle
_MAX_ITERATIONS = 100
_HALF_GAP = 0.4 * _TOLERANCE   # rad, each evaluation's two points this far either side


@dataclass(frozen=True)
class AnnulusSolution:
    """The annuli's solved state; every field has the shape of the inflows, (..., n).

    Attributes
    ----------
    inflow_angle : ndarray
        :math:`\\varphi`, rad.
    angle_of_attack : ndarray
        rad.
    axial_induction, tangential_induction : ndarray
        :math:`a`, :math:`a'`.
    normal_load, tangential_load : ndarray
        :math:`N'`, :math:`T'`, N/m.
    """

    inflow_angle: np.ndarray
    angle_of_attack: np.ndarray
    axial_induction: np.ndarray
    tangential_induction: np.ndarray
    normal_load: np.ndarray
    tangential_load: np.ndarray


class BladeElementMomentum:
    r"""A rotor of rigid blades whose annuli are solved by blade-element momentum theory.

    Parameters
    ----------
    blade : BladeTable
        Stations from the root (span 0 at ``hub_radius``).  Stations closer
        than 1 mm to the tip are dropped (their load is zero by the tip loss).
    polars : sequence of AirfoilPolar
        The airfoils that ``blade.airfoil`` numbers (1-based).
    hub_radius, tip_radius : float
        :math:`R_h`, :math:`R`, m.
    blades : int
        :math:`B`.
    air_density : float
        :math:`\rho`, kg/m^3.
    tip_loss, hub_loss : bool
        Prandtl's factors (both on by default).

    Attributes
    ----------
    radius, chord, twist : ndarray, shape (n,)
        m, m, rad of the annuli.
    weights : ndarray, shape (n,)
        m, trapezoidal-rule weights: :math:`\int f\,dr \approx \sum_i w_i f_i`.
    """

    def __init__(self, blade, polars, hub_radius, tip_radius, blades, air_density,
                 tip_loss=True, hub_loss=True):
        if not isinstance(blade, BladeTable):
            raise ModelError(f"BladeElementMomentum: blade must be a BladeTable, got "
                             f"{type(blade).__name__}")
        polars = list(polars)
        if not polars or not all(isinstance(p, AirfoilPolar) for p in polars):
            raise ModelError("BladeElementMomentum: polars must be a non-empty sequence of "
                             "AirfoilPolar")
        for key, value in (("hub_radius", hub_radius), ("tip_radius", tip_radius),
                           ("air_density", air_density)):
            if isinstance(value, bool) or not (isinstance(value, (int, float)) and value > 0):
                raise ModelError(f"BladeElementMomentum: {key} must be a positive number, "
                                 f"got {value!r}")
        if not (isinstance(blades, int) and blades >= 1):
            raise ModelError(f"BladeElementMomentum: blades must be a positive int, got "
                             f"{blades!r}")
        if tip_radius <= hub_radius:
            raise ModelError("BladeElementMomentum: tip_radius must exceed hub_radius")
        if blade.airfoil.max() > len(polars):
            raise ModelError(f"BladeElementMomentum: the blade names airfoil "
                             f"{blade.airfoil.max()} but {len(polars)} polars are given")
        r = hub_radius + np.asarray(blade.span, float)
        keep = (r > hub_radius) & (r < tip_radius - 1e-3)
        if not keep.any():
            raise ModelError("BladeElementMomentum: no blade station lies between the hub "
                             "and the tip")
        self.radius = r[keep]
        self.chord = np.asarray(blade.chord, float)[keep]
        self.twist = np.radians(np.asarray(blade.twist, float)[keep])
        self.hub_radius, self.tip_radius = float(hub_radius), float(tip_radius)
        self.blades, self.air_density = blades, float(air_density)
        self.tip_loss, self.hub_loss = bool(tip_loss), bool(hub_loss)
        self.polars = tuple(polars)
        ends = np.concatenate([[hub_radius], self.radius, [tip_radius]])
        steps = np.diff(ends)
        self.weights = (steps[:-1] + steps[1:]) / 2
        self.solidity = blades * self.chord / (2 * np.pi * self.radius)
        # every annulus's polar on the union of the tables' angles (exactly the same
        # piecewise-linear functions), so one search serves all annuli
        grid = np.unique(np.concatenate([p.angle_of_attack for p in polars]))
        self._alpha = np.radians(grid)
        ids = np.asarray(blade.airfoil)[keep] - 1
        self._lift = np.array([np.interp(grid, polars[i].angle_of_attack, polars[i].lift)
                               for i in ids])
        self._drag = np.array([np.interp(grid, polars[i].angle_of_attack, polars[i].drag)
                               for i in ids])
        # the same tables for the solver's lookups: C_l + i C_d and its slope per rad on
        # each interval, flattened, one row of grid.size per annulus
        table = self._lift + 1j * self._drag
        slope = np.diff(table, axis=1) / np.diff(self._alpha)
        self._table = table.ravel()
        self._slope = np.concatenate([slope, slope[:, -1:]], axis=1).ravel()
        self._row = np.arange(self.radius.size) * grid.size
        # Prandtl's exponents times |sin(phi)|, negated
        self._tip_exponent = -(blades / 2 * (self.tip_radius - self.radius) / self.radius)
        self._hub_exponent = -(blades / 2 * (self.radius - self.hub_radius) / self.hub_radius)
        # the compiled kernel's tables (flat, C order: slopes of G per annulus, as above)
        slopes = self._slope.reshape(self.radius.size, grid.size)
        self._polars = tuple(np.ascontiguousarray(v, dtype=float).ravel() for v in (
            self.solidity, self._tip_exponent, self._hub_exponent, self._alpha, self._lift,
            self._drag, slopes.real, slopes.imag))

    # ------------------------------------------------------------------ annuli
    def airfoil_coefficients(self, angle_of_attack):
        r"""``(C_l, C_d)`` of each annulus's airfoil at ``angle_of_attack`` (rad, (..., n))."""
        value = self._coefficients(np.asarray(angle_of_attack, float))
        return value.real, value.imag

    def _coefficients(self, alpha):
        """:math:`C_l + i C_d` at ``alpha`` (rad, (..., n)): linear between the grid's
        angles, the value at the interval's start plus its slope times the offset."""
        alpha = np.mod(alpha + np.pi, 2 * np.pi) - np.pi
        grid = self._alpha
        i = np.minimum(np.maximum(np.searchsorted(grid, alpha) - 1, 0), grid.size - 2)
        j = i + self._row
        return self._table.take(j) + self._slope.take(j) * (alpha - grid.take(i))

    def _state(self, phi, ratio, theta):
        """Inductions, loss factor and coefficients at inflow angle ``phi`` (all (..., n))."""
        s, c = np.sin(phi), np.cos(phi)
        coefficients = self._coefficients(phi - theta)
        cl, cd = coefficients.real, coefficients.imag
        cn, ct = cl * c + cd * s, cl * s - cd * c
        F = 1.0
        if self.tip_loss or self.hub_loss:
            inverse = 1 / np.maximum(np.abs(s), 1e-12)
            if self.tip_loss:
                F = 2 / np.pi * np.arccos(np.exp(self._tip_exponent * inverse))
            if self.hub_loss:
                F = F * (2 / np.pi) * np.arccos(np.exp(self._hub_exponent * inverse))
            F = np.maximum(F, 1e-12)
        four_fs = 4 * F * s
        k = self.solidity * cn / (four_fs * s)
        kp = self.solidity * ct / (four_fs * c)
        a = k / (1 + k)
        high = k > 2 / 3
        if high.any():
            # Buhl's empirical thrust above a = 0.4 (k = 2/3)
            g1 = 2 * F * k - (10 / 9 - F)
            g2 = np.maximum(2 * F * k - F * (4 / 3 - F), 0.0)
            g3 = 2 * F * k - (25 / 9 - 2 * F)
            near = np.abs(g3) < 1e-6
            buhl = np.where(near, 1 - 1 / (2 * np.sqrt(np.maximum(g2, 1e-12))),
                            (g1 - np.sqrt(g2)) / np.where(near, 1.0, g3))
            a = np.where(high, buhl, a)
        windmill = phi > 0
        if windmill.all():
            residual = s / (1 - a) - ratio * c * (1 - kp)
        else:
            brake = np.where(k > 1, k / np.where(k > 1, k - 1, 1.0), 0.0)
            a = np.where(windmill, a, brake)
            residual = np.where(windmill, s / (1 - a), s * (1 - k)) - ratio * c * (1 - kp)
        return residual, a, kp, cn, ct

    def solve(self, axial_speed, tangential_speed, pitch, guess=None):
        r"""Solve every annulus for its inflow angle, inductions and loads.

        Parameters
        ----------
        axial_speed : array_like, shape (..., n) or broadcastable
            :math:`V_x`, m/s: the air's speed through the annulus along the
            shaft (downwind), relative to the blade element.
        tangential_speed : array_like, broadcastable to the same
            :math:`V_y`, m/s: the element's speed in the rotor plane along its
            motion, relative to the air (:math:`\Omega r` on a still rotor);
            must be positive.
        pitch : array_like
            Collective pitch, rad (broadcast, e.g. shape (..., 1)).
        guess : ndarray, optional
            Inflow angles (rad, the inflows' shape) near the solution, e.g. the
            last solve's: a bracket of +-0.05 rad around each is tried first
            (fewer iterations, the same root where it brackets one).

        Returns
        -------
        AnnulusSolution
        """
        Vx, Vy = np.broadcast_arrays(np.asarray(axial_speed, float),
                                     np.asarray(tangential_speed, float))
        Vx, Vy = np.broadcast_arrays(Vx, Vy, self.radius)[:2]
        if np.any(~(Vy > 0)):
            raise ModelError("BladeElementMomentum.solve: tangential_speed must be positive "
                             "(a rotor turning forward); got "
                             f"{np.min(Vy):g} m/s")
        theta = self.twist + np.asarray(pitch, float)
        ratio = Vx / Vy
        if guess is not None and np.shape(guess) != Vx.shape:
            guess = None   # not one angle per inflow: solved without it
        compiled = _compiled_kernel()
        solve = self._numpy_solve if compiled is None else self._compiled_solve
        phi, a, kp, cn, ct = solve(ratio, theta, guess)
        a = np.where(Vx == 0, 0.0, a)
        ap = kp / (1 - kp)
        w2 = (Vx * (1 - a)) ** 2 + (Vy * (1 + ap)) ** 2
        q = 0.5 * self.air_density * w2 * self.chord
        return AnnulusSolution(phi, phi - theta, a, ap, q * cn, q * ct)

    def _numpy_solve(self, ratio, theta, guess):
        """``(phi, a, kp, cn, ct)`` of every inflow, all annuli at once in NumPy."""
        last = {}

        def residual(points):   # points: (k, *shape), several angles per annulus at once
            last["state"] = self._state(points, ratio, theta)
            return last["state"][0]

        phi, pick = _safeguarded_newton(residual, *_bracket(residual, ratio.shape, guess))
        # the solver's last evaluation holds its answer: each angle's state from the
        # point picked
        return (phi, *(np.where(pick, v[1], v[0]) for v in last["state"][1:]))

    def _compiled_solve(self, ratio, theta, guess):
        """``(phi, a, kp, cn, ct)`` of every inflow, by the compiled kernel
        (``numerics/backends/_bem_kernel.py``): the same steps, an annulus at a
        time."""
        shape = ratio.shape

        def flat(values, dtype=float):
            return np.ascontiguousarray(np.broadcast_to(values, shape), dtype=dtype).ravel()
        out = [np.empty(ratio.size) for _ in range(5)]
        flags = self.tip_loss | 2 * self.hub_loss | 4 * (guess is not None)
        guesses = flat(guess) if guess is not None else out[0]   # read only with a guess
        annulus = flat(np.arange(self.radius.size), np.int32)
        lost = _compiled_kernel().solve(*out, flat(ratio), flat(theta), guesses, annulus,
                                        *self._polars, flags)
        if lost:
            raise ModelError("BladeElementMomentum: no bracket of the inflow angle found "
                             f"for {lost} annuli")
        return tuple(v.reshape(shape) for v in out)

    # ---------------------------------------------------------------- rotor
    def steady_loads(self, wind_speed, rotor_speed, pitch):
        r"""Thrust (N) and torque (N m) of the rotor in a uniform steady axial wind.

        Parameters
        ----------
        wind_speed : float or ndarray
            m/s, along the shaft.
        rotor_speed : float or ndarray
            rad/s.
        pitch : float or ndarray
            rad.

        Returns
        -------
        (ndarray, ndarray)
            Thrust and aerodynamic torque, the inputs' broadcast shape.
        """
        V, W, P = np.broadcast_arrays(*(np.asarray(x, float)[..., None]
                                        for x in (wind_speed, rotor_speed, pitch)))
        sol = self.solve(V, W * self.radius, P)
        thrust = self.blades * np.sum(sol.normal_load * self.weights, axis=-1)
        torque = self.blades * np.sum(sol.tangential_load * self.radius * self.weights,
                                      axis=-1)
        return thrust, torque

    def coefficients(self, tip_speed_ratio, pitch):
        r""":math:`(C_P, C_T)` at tip-speed ratio :math:`\lambda = \Omega R/V` and pitch (rad).

        Dimensionless (computed at 1 m/s: quasi-steady BEM scales with
        :math:`V^2`), :math:`C_P = Q\Omega/(\tfrac12\rho\pi R^2V^3)`,
        :math:`C_T = T/(\tfrac12\rho\pi R^2V^2)`; arrays broadcast.
        """
        lam = np.asarray(tip_speed_ratio, float)
        speed = lam / self.tip_radius
        thrust, torque = self.steady_loads(1.0, speed, pitch)
        q = 0.5 * self.air_density * np.pi * self.tip_radius ** 2
        return torque * speed / q, thrust / q

    def torque_coefficient(self, tip_speed_ratio, pitch):
        r""":math:`C_Q = C_P/\lambda`."""
        cp, _ = self.coefficients(tip_speed_ratio, pitch)
        return cp / np.asarray(tip_speed_ratio, float)

    def __repr__(self):
        return (f"BladeElementMomentum({self.blades} blades, R={self.tip_radius} m, "
                f"{self.radius.size} annuli)")


_UNSET = object()
_KERNEL = {"module": _UNSET}   # the compiled kernel, once looked for


def _compiled_kernel():
    """The compiled solve (``numerics/backends/_bem_kernel.py``, built on the first
    solve), or ``None`` without a C compiler (NumPy solves then: the same steps)."""
    if _KERNEL["module"] is _UNSET:
        # up into numerics, whose compiler builds it (FACADES, tests/test_architecture.py)
        from ...numerics.backends import CompilerError, bem_kernel
        try:
            _KERNEL["module"] = bem_kernel()
        except CompilerError:
            _KERNEL["module"] = None
    return _KERNEL["module"]


def _bracket(residual, shape, guess=None):
    """Per annulus, the first of Ning's three intervals whose ends' residuals differ in
    sign, and Newton's first point (nan where none); with a guess, first the guess's
    neighbourhood within the guess's interval, evaluated in the same call as two
    points 2 ``_HALF_GAP`` apart at the guess: the slope between them gives Newton's
    first point, and the three parts of the neighbourhood between the four points
    the bracket (an integration's next guess is near its root: two or three
    evaluations in all, not five)."""
    intervals = [(_EPS, np.pi / 2), (-np.pi / 4, -_EPS), (np.pi / 2, np.pi - _EPS)]
    lo, hi = np.full(shape, np.nan), np.full(shape, np.nan)
    flo, fhi = np.full(shape, np.nan), np.full(shape, np.nan)
    newton = np.full(shape, np.nan)
    if guess is not None and np.shape(guess) == shape:
        g = np.asarray(guess, float)
        # stay on the guess's side of 0 and pi/2: the branches differ there
        edges = np.where(g > np.pi / 2, np.pi / 2, np.where(g > 0, _EPS, -np.pi / 4))
        tops = np.where(g > np.pi / 2, np.pi - _EPS, np.where(g > 0, np.pi / 2, -_EPS))
        a, b = np.maximum(g - 0.05, edges), np.minimum(g + 0.05, tops)
        c = np.minimum(np.maximum(g - _HALF_GAP, a), b)
        d = np.minimum(np.maximum(g + _HALF_GAP, a), b)
        fa, fb, fc, fd = residual(np.stack([a, b, c, d]))   # all four in one evaluation
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = c - fc * (d - c) / (fd - fc)
        # the part of (a, b) holding the root, of the three between the four points
        for x0, x1, f0, f1 in ((a, c, fa, fc), (c, d, fc, fd), (d, b, fd, fb)):
            fresh = np.isnan(lo) & (f0 * f1 <= 0)
            lo[fresh], hi[fresh] = x0[fresh], x1[fresh]
            flo[fresh], fhi[fresh] = f0[fresh], f1[fresh]
        newton[np.isnan(lo)] = np.nan   # the guess's neighbourhood holds no root there
    for a, b in intervals:
        a, b = np.broadcast_to(a, shape), np.broadcast_to(b, shape)
        fresh = np.isnan(lo)
        if not fresh.any():
            break
        fa, fb = residual(np.stack([a, b]))     # both ends in one evaluation
        fresh &= fa * fb <= 0
        lo[fresh], hi[fresh] = a[fresh], b[fresh]
        flo[fresh], fhi[fresh] = fa[fresh], fb[fresh]
    if np.isnan(lo).any():
        raise ModelError("BladeElementMomentum: no bracket of the inflow angle found for "
                         f"{int(np.isnan(lo).sum())} annuli")
    return lo, hi, flo, fhi, newton


def _safeguarded_newton(residual, lo, hi, flo, fhi, newton):
    """Safeguarded Newton on arrays of brackets (their ends' residuals ``flo``,
    ``fhi``), from Newton's points ``newton`` (nan: none), to _TOLERANCE; returns
    the angles and, for each, which point of the residual's last evaluation holds it
    (``True``: the second, ``False``: the first).

    Each step evaluates the residual at two points around the new point ``x``,
    ``x -+ _HALF_GAP`` (0.4 _TOLERANCE), in one call (the evaluation's cost is mostly
    per call, not per angle).  Where the two differ in sign the root lies between them and the
    annulus is done, at the one with the smaller residual (within 0.8 _TOLERANCE of the
    root).  Elsewhere the point beyond which the root lies replaces the bracket's end on
    its side, and the next ``x`` is Newton's, with the slope between the two points,
    where it falls inside the bracket, else regula falsi's with the Illinois
    modification (an end kept twice in a row has its residual halved)."""
    side = np.zeros(lo.shape, int)
    done = np.zeros(lo.shape, bool)
    x = lo
    h = _HALF_GAP
    for _ in range(_MAX_ITERATIONS):
        step = fhi - flo
        if step.all():
            falsi = (lo * fhi - hi * flo) / step
        else:
            falsi = np.where(step != 0, (lo * fhi - hi * flo) / np.where(step != 0, step, 1.0),
                             (lo + hi) / 2)
        inside = (newton > lo) & (newton < hi)      # False where nan
        new = np.where(inside, newton, np.minimum(np.maximum(falsi, lo), hi))  # lo <= hi
        x = np.where(done, x, new)
        below, above = np.maximum(x - h, lo), np.minimum(x + h, hi)
        fbelow, fabove = residual(np.stack([below, above]))
        done = done | (fbelow * fabove <= 0)
        if done.all():
            break
        left = flo * fabove > 0                # root in (above, hi): above replaces lo
        right = ~(left | done)                 # root in (lo, below): below replaces hi
        left &= ~done                          # a bracket that is done stays as it is
        lo, flo = np.where(left, above, lo), np.where(left, fabove, flo)
        hi, fhi = np.where(right, below, hi), np.where(right, fbelow, fhi)
        # Illinois: an end kept twice in a row has its residual halved (for regula falsi)
        fhi = np.where(left & (side == 1), fhi / 2, fhi)
        flo = np.where(right & (side == -1), flo / 2, flo)
        side = np.where(left, 1, -1)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = below - fbelow * (above - below) / (fabove - fbelow)
    pick = np.abs(fabove) < np.abs(fbelow)
    return np.where(pick, above, below), pick
