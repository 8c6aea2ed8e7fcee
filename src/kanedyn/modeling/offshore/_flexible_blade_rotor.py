r"""Quasi-steady blade-element momentum loads on the nodes of flexible blades.

``FlexibleBladeElementRotor``  the aerodynamic force on every blade element of a
                               rotor of :class:`~kanedyn.FlexibleBody` blades,
                               applied at the element's node as it deflects

Blade :math:`k` is a flexible body whose frame :math:`B_k` and origin (its root)
move with the rotor; its member has a node at each annulus radius of the
:class:`~kanedyn.offshore.BladeElementMomentum` (span from the root, the root at
the hub radius).  Node :math:`i` sits at :math:`p_i = r_{root} + B_k(x_i +
\Phi_i\eta + \tfrac12 G_i\eta\eta)` from the hub and moves at

.. math:: v_i = v_{root} + \omega_{B_k}\times B_k(x_i + \Phi_i\eta + \tfrac12 G_i\eta\eta)
          + B_k(\Phi_i + G_i\eta)\dot\eta ,

its rigid motion (the hub's, the nacelle's rotation, the spin, the pitch rate)
and its elastic velocity.  The air's velocity relative to it is
:math:`U = V(t)\,d - v_i`; with :math:`e_r` the undeflected blade's span
direction and :math:`e_t = S_x\times e_r` its direction of motion,
:math:`V_x = U\cdot S_x` and :math:`V_y = -U\cdot e_t` are the annulus's axial
and tangential inflow (the undeflected directions: no elastic twist, the
deflected slope not turned into the inflow).  The loads per unit length,
times the annulus's trapezoidal weight, act at the node: :math:`N'w_i` along
:math:`S_x`, :math:`T'w_i` along :math:`e_t`.

They enter the equations as two specified inputs per node and blade
(``F{name}_n_{k}_{i}(t)`` and ``F{name}_t_{k}_{i}(t)``, N);
:meth:`FlexibleBladeElementRotor.specified` computes them from ``(t, y)`` by one
solve of every annulus of every blade per state, shared by all the inputs and
warm-started from the last solution; a caller that reads many states at once
(the energy balance's quadrature points) has them solved together
(:func:`~kanedyn.modeling.offshore._blade_element_rotor.warm_started_inputs`).
With undeflected, still blades the loads add up to
:class:`~kanedyn.offshore.BladeElementRotor`'s force and moment.
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ..._errors import ModelError
from ..flexible import FlexibleBody
from ._blade_element_momentum import BladeElementMomentum
from ._blade_element_rotor import _cross, warm_started_inputs
from ._mooring import _state_symbols, state_function

__all__ = ["FlexibleBladeElementRotor"]


class FlexibleBladeElementRotor:
    r"""Quasi-steady BEM loads on the nodes of flexible blades, as specified inputs.

    Parameters
    ----------
    name : str
    bem : BladeElementMomentum
        The annuli (radii from the shaft, chords, twists, polars, losses).
    blades : sequence of FlexibleBody
        One per blade of ``bem`` (``bem.blades``), their origins at the blade
        roots, the members' span along a body axis.
    nodes : sequence of int
        The member's node at each annulus (``bem.radius.size`` of them): its
        distance from the root plus the hub radius is the annulus radius.
    hub : sympy.physics.mechanics.Point
        The hub centre, on the shaft.
    shaft_frame : sympy.physics.mechanics.ReferenceFrame
        :math:`S`, its x axis along the shaft, downwind.
    radial : sequence of sympy.physics.vector.Vector
        Each blade's undeflected span direction (a unit vector normal to the
        shaft, turning with the rotor).
    frame : sympy.physics.mechanics.ReferenceFrame
        The inertial frame.
    pitch : sympy.Expr or float
        Collective pitch, rad (the annuli's twist is added to it).
    wind : float or callable
        Free wind speed, m/s: a number or a function of time.
    wind_direction : sympy.physics.vector.Vector, optional
        Unit vector of the wind, ``frame.x`` when not given.

    Attributes
    ----------
    normal_symbols, tangential_symbols : tuple of tuple of sympy.Function
        Per blade, per annulus: the force along :math:`S_x` and along
        :math:`e_t`, N.
    """

    def __init__(self, name, bem, blades, nodes, hub, shaft_frame, radial, frame, pitch,
                 wind, wind_direction=None):
        what = f"FlexibleBladeElementRotor {name!r}"
        if not isinstance(name, str) or not name:
            raise ModelError(f"FlexibleBladeElementRotor needs a non-empty name, got {name!r}")
        if not isinstance(bem, BladeElementMomentum):
            raise ModelError(f"{what}: bem must be a BladeElementMomentum, got "
                             f"{type(bem).__name__}")
        blades, radial, nodes = list(blades), list(radial), [int(k) for k in nodes]
        if len(blades) != bem.blades or len(radial) != bem.blades:
            raise ModelError(f"{what}: the rotor has {bem.blades} blades; got {len(blades)} "
                             f"flexible bodies and {len(radial)} span directions")
        if not all(isinstance(b, FlexibleBody) for b in blades):
            raise ModelError(f"{what}: blades must be FlexibleBody objects")
        if len(nodes) != bem.radius.size:
            raise ModelError(f"{what}: {bem.radius.size} annuli need as many nodes, got "
                             f"{len(nodes)}")
        for blade in blades:
            member = blade.member
            span = np.linalg.norm(member.nodes[nodes] - member.nodes[member.reference_node],
                                  axis=1)
            off = np.abs(span + bem.hub_radius - bem.radius)
            if np.max(off) > 1e-6 * bem.tip_radius:
                i = int(np.argmax(off))
                raise ModelError(f"{what}: node {nodes[i]} of blade {blade.name!r} is "
                                 f"{span[i] + bem.hub_radius:g} m from the shaft, annulus {i} "
                                 f"at {bem.radius[i]:g} m")
        if not (callable(wind) or (isinstance(wind, (int, float))
                                   and not isinstance(wind, bool) and wind > 0)):
            raise ModelError(f"{what}: wind must be a positive number (m/s) or a function "
                             f"of t, got {wind!r}")
        self.name, self.bem, self.blades, self.nodes = name, bem, blades, nodes
        self.hub, self.shaft_frame, self.radial, self.frame = hub, shaft_frame, radial, frame
        self.pitch, self.wind = pitch, wind
        self.wind_direction = frame.x if wind_direction is None else wind_direction
        # each blade's annulus nodes: undeflected offsets from the root, modes and
        # second-order shapes (constants of every solve), by the blade's identity
        self._node_shapes = {id(blade): _node_shapes(blade, nodes) for blade in blades}
        # and stacked over the blades, for the inflow of all of them at once (None
        # where the blades differ in modes or stiffening)
        self._stacked_shapes = _stacked([self._node_shapes[id(b)] for b in blades])
        self._kinematics = {}   # kinematics(states, constants), by its arguments
        t = me.dynamicsymbols._t
        n = len(nodes)
        self.normal_symbols = tuple(tuple(sm.Function(f"F{name}_n_{k + 1}_{i + 1}")(t)
                                          for i in range(n)) for k in range(len(blades)))
        self.tangential_symbols = tuple(tuple(sm.Function(f"F{name}_t_{k + 1}_{i + 1}")(t)
                                              for i in range(n)) for k in range(len(blades)))

    def to_loads(self):
        """``[(node point, F_n S_x + F_t e_t), ...]`` for every node of every blade."""
        S = self.shaft_frame
        loads = []
        for blade, e_r, normal, tangential in zip(self.blades, self.radial,
                                                  self.normal_symbols, self.tangential_symbols):
            e_t = S.x.cross(e_r)
            loads += [(blade.node_point(k), fn * S.x + ft * e_t)
                      for k, fn, ft in zip(self.nodes, normal, tangential)]
        return loads

    # ------------------------------------------------------------------ numbers
    def kinematics(self, states, constants=None):
        r"""Callable ``y -> (roots, velocities, rates, rotations, etas, zetas, d, pitch)``.

        Per blade (leading axis): the root's position from the hub and its
        velocity, the blade frame's angular velocity (:math:`S` components,
        shape (B, 3) each), the rotation :math:`S \leftarrow B_k` (B, 3, 3),
        the modal coordinates and speeds (B, m); the wind's direction (3,) and
        the pitch.  Made once for the same states and constants (the model's
        inputs and a caller's take the same function: its code generation took
        1.5 s of CPU for the 5-MW blades).
        """
        key = (tuple(_state_symbols(states)),
               tuple(sorted(dict(constants or {}).items(), key=lambda item: str(item[0]))))
        try:
            found = self._kinematics.get(key)
        except TypeError:       # a constant's value that cannot be a key: not kept
            return self._make_kinematics(states, constants)
        if found is None:
            found = self._make_kinematics(states, constants)
            if len(self._kinematics) >= 4:  # bounded: the oldest goes
                self._kinematics.pop(next(iter(self._kinematics)))
            self._kinematics[key] = found
        return found

    def _make_kinematics(self, states, constants):
        S, N = self.shaft_frame, self.frame
        exprs = []
        for blade in self.blades:
            B, root = blade.frame, blade.origin
            exprs += [root.pos_from(self.hub).dot(e) for e in S]
            exprs += [root.vel(N).dot(e) for e in S]
            exprs += [B.ang_vel_in(N).dot(e) for e in S]
            exprs += list(S.dcm(B))
            exprs += list(blade.q) + list(blade.u)
        exprs += [self.wind_direction.dot(e) for e in S] + [sm.sympify(self.pitch)]
        evaluate = state_function(exprs, states, constants,
                                  f"FlexibleBladeElementRotor {self.name!r}")
        m = [len(b.q) for b in self.blades]
        size = [18 + 2 * k for k in m]

        def split(y):
            values = evaluate(y)
            out, start = [], 0
            for k, n in zip(m, size):
                v = values[start:start + n]
                out.append((v[0:3], v[3:6], v[6:9], v[9:18].reshape(3, 3), v[18:18 + k],
                            v[18 + k:18 + 2 * k]))
                start += n
            return out, values[start:start + 3], values[start + 3]
        return split

    def node_motion(self, blade, root, root_velocity, rate, rotation, eta, zeta):
        r"""Positions from the hub and velocities of the annuli's nodes, :math:`S` comps, (n, 3)."""
        x, Phi, G = self._node_shapes[id(blade)]
        local = x + Phi @ eta
        slope = Phi
        if G is not None:
            local = local + 0.5 * np.einsum("naij,i,j->na", G, eta, eta)
            slope = Phi + np.einsum("naij,j->nai", G, eta)
        arm = local @ rotation.T
        position = root + arm
        velocity = root_velocity + _cross(rate, arm) + (slope @ zeta) @ rotation.T
        return position, velocity

    def node_loads(self, state, direction, pitch, wind_speed, guess=None):
        r"""Forces on the nodes along :math:`S_x` and :math:`e_t` (N), and the annuli solved.

        Parameters
        ----------
        state : list
            Per blade the first six items of :meth:`kinematics`.
        direction : array_like, shape (3,)
            The wind's direction, :math:`S` components.
        pitch, wind_speed : float
            rad, m/s.
        guess : ndarray, shape (B, n), optional
            Inflow angles to start from.

        Returns
        -------
        (ndarray, ndarray, AnnulusSolution)
            Normal and tangential forces, shape (B, n) each, and the solution.
        """
        solution = self.bem.solve(*self._inflow(state, direction, wind_speed), pitch, guess)
        w = self.bem.weights
        return solution.normal_load * w, solution.tangential_load * w, solution

    def _inflow(self, state, direction, wind_speed):
        """The annuli's axial and tangential inflow (m/s, shape (B, n) each) at the
        blades' ``state`` (:meth:`node_loads`): every blade at once where their
        nodes' shapes stack (:meth:`node_motion`'s sums over a leading axis), else
        a blade at a time."""
        if self._stacked_shapes is not None:
            return self._stacked_inflow(state, direction, wind_speed)
        axial, tangential = [], []
        x_axis = np.array([1.0, 0.0, 0.0])
        for blade, kin in zip(self.blades, state):
            root = kin[0]
            position, velocity = self.node_motion(blade, *kin)
            e_r = root / np.linalg.norm(root)
            e_t = _cross(x_axis, e_r)
            air = wind_speed * np.asarray(direction, float) - velocity
            axial.append(air[:, 0])
            tangential.append(-air @ e_t)
        return np.array(axial), np.array(tangential)

    def _stacked_inflow(self, state, direction, wind_speed):
        """:meth:`_inflow` of every blade at once (leading axis: the blade)."""
        x, Phi, G = self._stacked_shapes
        root, root_velocity, rate, rotation, eta, zeta = (np.array(v) for v in zip(*state))
        eta_, zeta_ = eta[:, None, :, None], zeta[:, None, :, None]   # (B, 1, m, 1)
        local = x + (Phi @ eta_)[..., 0]
        slope = Phi
        if G is not None:   # G eta (B, n, 3, m): the slope's part and, times eta, the offset's
            g = (G @ eta_[:, :, None])[..., 0]
            local = local + 0.5 * (g @ eta_)[..., 0]
            slope = Phi + g
        turn = rotation.transpose(0, 2, 1)  # components S <- B_k, row vectors on the left
        arm = local @ turn
        elastic = (slope @ zeta_)[..., 0] @ turn
        velocity = root_velocity[:, None] + _cross(rate[:, None], arm) + elastic
        e_r = root / np.linalg.norm(root, axis=1, keepdims=True)
        e_t = _cross(np.array([1.0, 0.0, 0.0]), e_r)
        air = wind_speed * np.asarray(direction, float) - velocity
        return air[..., 0], -(air @ e_t[:, :, None])[..., 0]

    def wind_speed(self, t):
        """Free wind speed (m/s) at time ``t``."""
        return float(self.wind(t)) if callable(self.wind) else float(self.wind)

    def specified(self, states, constants=None):
        """``{input symbol: callable(t, y)}``, as :meth:`BladeElementRotor.specified`."""
        kinematics = self.kinematics(states, constants)

        def solve(t, y, guess):
            state, direction, pitch = kinematics(y)
            normal, tangential, solution = self.node_loads(state, direction, pitch,
                                                           self.wind_speed(t), guess=guess)
            return np.concatenate([normal.ravel(), tangential.ravel()]), solution.inflow_angle

        def solve_many(ts, Y):
            # each state's inflow as solve's; then every annulus of every state at
            # once, started from the first state's angles (solved alone: half the
            # iterations of a start from Ning's intervals)
            axial, tangential, pitches = [], [], []
            for t, y in zip(ts, Y.T):
                state, direction, pitch = kinematics(y)
                inflow = self._inflow(state, direction, self.wind_speed(t))
                axial.append(inflow[0])
                tangential.append(inflow[1])
                pitches.append(pitch)
            axial, tangential = np.array(axial), np.array(tangential)
            pitches = np.reshape(pitches, (-1, 1, 1))
            first = self.bem.solve(axial[:1], tangential[:1], pitches[:1])
            solution = self.bem.solve(axial, tangential, pitches,
                                      np.broadcast_to(first.inflow_angle, axial.shape))
            w = self.bem.weights
            return np.concatenate([(solution.normal_load * w).reshape(len(axial), -1),
                                   (solution.tangential_load * w).reshape(len(axial), -1)],
                                  axis=1)
        symbols = [s for row in self.normal_symbols for s in row]
        symbols += [s for row in self.tangential_symbols for s in row]
        return warm_started_inputs(symbols, solve, solve_many)

    def __repr__(self):
        return (f"FlexibleBladeElementRotor({self.name!r}, {len(self.blades)} flexible blades, "
                f"{len(self.nodes)} annuli)")


def _stacked(shapes):
    """``(x, Phi, G)`` of :func:`_node_shapes` stacked over the blades (leading
    axis), or ``None`` where the blades' shapes differ in size or stiffening."""
    if len({tuple(a.shape if a is not None else None for a in s) for s in shapes}) != 1:
        return None
    return tuple(None if parts[0] is None else np.stack(parts) for parts in zip(*shapes))


def _node_shapes(blade, nodes):
    """``(x, Phi, G)`` of ``blade``'s nodes ``nodes``: their undeflected offsets
    from the root (m, shape (n, 3)), their translation per mode (shape (n, 3, m))
    and, for a blade with geometric stiffening, their second-order shapes
    (shape (n, 3, m, m); else ``None``), member-frame components."""
    member = blade.member
    x = member.nodes[nodes] - member.nodes[member.reference_node]
    Phi = np.stack([member.node_modes(k)[0] for k in nodes])
    stiffened = blade.stiffening and member.second_order is not None
    return x, Phi, member.second_order[nodes] if stiffened else None
