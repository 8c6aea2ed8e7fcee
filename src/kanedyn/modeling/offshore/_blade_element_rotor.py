r"""Quasi-steady blade-element momentum loads on a spinning rotor, from the bodies' motion.

``BladeElementRotor``  the aerodynamic force and moment on a rotor of rigid
                       blades, its annuli solved by
                       :class:`~kanedyn.offshore.BladeElementMomentum` at the
                       relative wind each blade element sees

Blade :math:`k` of :math:`B` lies along :math:`e_r = \cos\theta_k S_z -
\sin\theta_k S_y`, :math:`\theta_k = \psi + 2\pi k/B`, in the plane normal to
the shaft :math:`S_x` (no precone), and moves along :math:`e_t = S_x\times e_r`.
The element at radius :math:`r` is at :math:`p = r e_r` from the hub and moves
at :math:`v_p = v_{hub} + (\omega_S + \Omega S_x)\times p`; the air's velocity
relative to it is :math:`U = V(t)\,d - v_p` (a uniform wind of speed :math:`V`
along :math:`d`), so :math:`V_x = U\cdot S_x` and :math:`V_y = -U\cdot e_t`.
The platform's and tower's motion enters every element's inflow: a hub moving
downwind lowers :math:`V_x` and the thrust (aerodynamic damping), a pitching
nacelle loads the upper and lower blades unequally (hub moments).

The loads enter the equations as six specified inputs, the force's and the
moment's :math:`S` components at the hub (the moment acts on the rotor's
frame: its :math:`S_x` part turns the rotor, the rest reaches the nacelle);
:meth:`BladeElementRotor.specified` computes them from ``(t, y)`` by solving
every annulus of every blade (one solve per state, shared by the six inputs,
warm-started from the last solution).
"""

from __future__ import annotations

import contextlib

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ..._errors import ModelError
from ._blade_element_momentum import BladeElementMomentum
from ._mooring import state_function

__all__ = ["BladeElementRotor", "warm_started_inputs"]


class BladeElementRotor:
    r"""Quasi-steady BEM force and moment on a spinning rotor, as six specified inputs.

    Parameters
    ----------
    name : str
    bem : BladeElementMomentum
        The rotor's blades, airfoils and annuli.
    hub : sympy.physics.mechanics.Point
        The hub centre, its velocity in ``frame`` known in the speeds.
    shaft_frame : sympy.physics.mechanics.ReferenceFrame
        :math:`S`, its x axis along the shaft, downwind; its angular velocity
        in ``frame`` known in the speeds.
    rotor_frame : sympy.physics.mechanics.ReferenceFrame
        The spinning rotor's frame (the moment acts on it).
    frame : sympy.physics.mechanics.ReferenceFrame
        The inertial frame.
    azimuth, rotor_speed : sympy.Expr
        :math:`\psi` (rad) and :math:`\Omega` (rad/s), the rotor's angle and
        speed about :math:`S_x` relative to :math:`S`.
    pitch : sympy.Expr or float
        Collective pitch, rad: an expression of the states, or a number.
    wind : float or callable
        Free wind speed, m/s: a number or a function of time.
    wind_direction : sympy.physics.vector.Vector, optional
        Unit vector of the wind, ``frame.x`` when not given.

    Attributes
    ----------
    force_symbols, moment_symbols : tuple of sympy.Function
        ``F{name}_x(t)`` ... and ``M{name}_x(t)`` ..., N and N m, :math:`S`
        components.
    """

    def __init__(self, name, bem, hub, shaft_frame, rotor_frame, frame, azimuth, rotor_speed,
                 pitch, wind, wind_direction=None):
        if not isinstance(name, str) or not name:
            raise ModelError(f"BladeElementRotor needs a non-empty name, got {name!r}")
        what = f"BladeElementRotor {name!r}"
        if not isinstance(bem, BladeElementMomentum):
            raise ModelError(f"{what}: bem must be a BladeElementMomentum, got "
                             f"{type(bem).__name__}")
        if not isinstance(hub, me.Point):
            raise ModelError(f"{what}: hub must be a Point")
        for key, value in (("shaft_frame", shaft_frame), ("rotor_frame", rotor_frame),
                           ("frame", frame)):
            if not isinstance(value, me.ReferenceFrame):
                raise ModelError(f"{what}: {key} must be a ReferenceFrame")
        if not (callable(wind) or (isinstance(wind, (int, float))
                                   and not isinstance(wind, bool) and wind > 0)):
            raise ModelError(f"{what}: wind must be a positive number (m/s) or a function "
                             f"of t, got {wind!r}")
        self.name, self.bem, self.hub, self.frame = name, bem, hub, frame
        self.shaft_frame, self.rotor_frame = shaft_frame, rotor_frame
        self.azimuth, self.rotor_speed = azimuth, rotor_speed
        self.pitch, self.wind = pitch, wind
        self.wind_direction = frame.x if wind_direction is None else wind_direction
        t = me.dynamicsymbols._t
        self.force_symbols = tuple(sm.Function(f"F{name}_{c}")(t) for c in "xyz")
        self.moment_symbols = tuple(sm.Function(f"M{name}_{c}")(t) for c in "xyz")

    def _axes(self):
        S = self.shaft_frame
        return S.x, S.y, S.z

    def to_loads(self):
        """``[(hub, F), (rotor_frame, M)]`` with ``F``, ``M`` of the input symbols."""
        axes = self._axes()
        force = sum((f * e for f, e in zip(self.force_symbols, axes)), me.Vector(0))
        moment = sum((m * e for m, e in zip(self.moment_symbols, axes)), me.Vector(0))
        return [(self.hub, force), (self.rotor_frame, moment)]

    def kinematics(self, states, constants=None):
        r"""Callable ``y -> (v_hub, omega_S, d, psi, Omega, pitch)`` in :math:`S` components."""
        axes = self._axes()
        velocity = self.hub.vel(self.frame)
        rate = self.shaft_frame.ang_vel_in(self.frame)
        exprs = ([velocity.dot(e) for e in axes] + [rate.dot(e) for e in axes]
                 + [self.wind_direction.dot(e) for e in axes]
                 + [self.azimuth, self.rotor_speed, sm.sympify(self.pitch)])
        evaluate = state_function(exprs, states, constants, f"BladeElementRotor {self.name!r}")

        def split(y):
            k = evaluate(y)
            return k[0:3], k[3:6], k[6:9], k[9], k[10], k[11]
        return split

    def wind_speed(self, t):
        """Free wind speed (m/s) at time ``t``."""
        return float(self.wind(t)) if callable(self.wind) else float(self.wind)

    def wrench(self, velocity, rate, direction, azimuth, rotor_speed, pitch, wind_speed,
               guess=None):
        r"""Aerodynamic force and moment about the hub, and the annuli solved.

        Parameters
        ----------
        velocity, rate, direction : array_like, shape (3,)
            The hub's velocity (m/s), the shaft frame's angular velocity
            (rad/s) and the wind's direction, in :math:`S` components.
        azimuth, rotor_speed, pitch : float
            rad, rad/s, rad.
        wind_speed : float
            m/s.
        guess : ndarray, shape (B, n), optional
            Inflow angles to start from.

        Returns
        -------
        (ndarray, ndarray, AnnulusSolution)
            Force (N) and moment (N m) in :math:`S` components, shape (3,), and
            the solution, shape (B, n).
        """
        bem = self.bem
        theta = azimuth + 2 * np.pi * np.arange(bem.blades)[:, None] / bem.blades
        zeros = np.zeros_like(theta)
        e_r = np.stack([zeros, -np.sin(theta), np.cos(theta)], axis=-1)      # (B, 1, 3)
        e_t = np.stack([zeros, -np.cos(theta), -np.sin(theta)], axis=-1)
        p = bem.radius[:, None] * e_r                                         # (B, n, 3)
        spin = np.asarray(rate, float) + np.array([rotor_speed, 0.0, 0.0])
        air = wind_speed * np.asarray(direction, float) - np.asarray(velocity, float) \
            - _cross(spin, p)
        solution = bem.solve(air[..., 0], -np.sum(air * e_t, axis=-1), pitch, guess)
        element = (solution.normal_load[..., None] * np.array([1.0, 0.0, 0.0])
                   + solution.tangential_load[..., None] * e_t) * bem.weights[:, None]
        force = element.sum(axis=(0, 1))
        moment = _cross(p, element).sum(axis=(0, 1))
        return force, moment, solution

    def specified(self, states, constants=None):
        """``{input symbol: callable(t, y)}`` for ``eom.numeric(specified=...)``.

        Parameters
        ----------
        states : EquationsOfMotion or sequence of dynamic symbols
            The order of ``y``.
        constants : dict, optional
            Values of constants in the kinematics.
        """
        kinematics = self.kinematics(states, constants)

        def solve(t, y, guess):
            force, moment, solution = self.wrench(*kinematics(y), self.wind_speed(t),
                                                  guess=guess)
            return np.concatenate([force, moment]), solution.inflow_angle
        return warm_started_inputs(self.force_symbols + self.moment_symbols, solve)

    def __repr__(self):
        return f"BladeElementRotor({self.name!r}, {self.bem!r})"


def _cross(a, b):
    """``np.cross(a, b)`` of vectors along the last axis (without its axis handling)."""
    a, b = np.asarray(a), np.asarray(b)
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def warm_started_inputs(symbols, solve, solve_many=None):
    """``{symbol: callable(t, y)}`` sharing one solve per state, each warm-started.

    Parameters
    ----------
    symbols : sequence
        The inputs, in the order of the solve's vector.
    solve : callable
        ``solve(t, y, guess) -> (values, inflow angles)``; ``guess`` the last
        solve's inflow angles (None at first).
    solve_many : callable, optional
        ``solve_many(ts, Y) -> values``, shape (N, len(symbols)): the values at
        the times ``ts`` (s, shape (N,)) and the states that are the columns of
        ``Y`` (shape (n_states, N)), all in one solve (not warm-started from
        state to state: the same roots, to the solver's tolerance).  The
        entries' shared function then offers :meth:`_WarmStarted.solved_at`.
    """
    function = _WarmStarted(solve, solve_many)
    return {s: _Entry(function, i) for i, s in enumerate(symbols)}


class _WarmStarted:
    """The inputs' values at ``(t, y)``: one solve per state, warm-started from the
    last one's inflow angles; the last state's values kept (and, while
    :meth:`solved_at` holds, those of its states)."""

    def __init__(self, solve, solve_many):
        self._solve, self._solve_many = solve, solve_many
        self._key = self._values = self._phi = None
        self._known = {}  # (t, y bytes) -> values, while solved_at holds

    def __call__(self, t, y):
        y = np.asarray(y, dtype=float)
        key = (float(t), y.tobytes())
        known = self._known.get(key)
        if known is not None:
            return known
        if self._key != key:
            self._values, self._phi = self._solve(t, y, self._phi)
            self._key = key
        return self._values

    @contextlib.contextmanager
    def solved_at(self, ts, Y):
        """A context within which the values at the given states are those of
        one solve of them all (``solve_many``; without it each state is solved
        when asked, as outside): for a caller that reads many states at once,
        not along a motion (the energy balance's quadrature points), without
        each solve's per-call cost.

        Parameters
        ----------
        ts : array_like, shape (N,)
            Times, s.
        Y : array_like, shape (n_states, N)
            The states, one per column.
        """
        Y = np.asarray(Y, dtype=float)
        if self._solve_many is None or not Y.size:
            yield
            return
        values = self._solve_many(ts, Y)
        self._known = {(float(t), y.tobytes()): v for t, y, v in zip(ts, Y.T, values)}
        try:
            yield
        finally:
            self._known = {}


class _Entry:
    """One entry of a shared function's vector: callable ``(t, y) -> float``."""

    def __init__(self, function, i):
        self.function, self.i = function, i

    def __call__(self, t, y):
        return float(self.function(t, y)[self.i])

    @property
    def input_source(self):
        """The shared function: a model reads its entries with one call of it."""
        return self.function

    @property
    def input_index(self):
        """This entry's index in :attr:`input_source`'s vector."""
        return (self.i,)
