r"""Morison strip theory on a slender cylinder fixed in a rigid body.

The wetted part of the member is cut into ``n_strips`` strips of equal length.
On strip ``i`` (volume :math:`V_i = \int A\,ds`, projected area
:math:`S_i = \int D\,ds`) the force, normal to the member's axis ``e``, is

.. math:: \mathbf F_i = (1 + C_a)\,\rho V_i\,\mathbf a_{f,n}
          + \tfrac12 \rho C_d S_i\,|\mathbf v_{r,n}|\,\mathbf v_{r,n}
          - C_a \rho V_i\,\mathbf a_{b,n}

with :math:`(\cdot)_n = (\cdot) - ((\cdot)\cdot e)e`, the fluid acceleration
:math:`\mathbf a_f` (Froude-Krylov and diffraction parts), the relative
velocity :math:`\mathbf v_r = \mathbf v_f - \mathbf v_b` of the fluid past the
strip and the body acceleration :math:`\mathbf a_b` of the strip point.

The first two terms are loads (:meth:`MorisonCylinder.to_loads`); the third is
proportional to the body's acceleration and belongs to the mass matrix
(:meth:`MorisonCylinder.added_mass_terms`, :meth:`MorisonCylinder.added_mass_matrix`).

The fluid kinematics are *specified inputs* (:meth:`MorisonCylinder.specified`):
evaluated at the strip's undisplaced (rest) position, the usual first-order
choice for small body motions.  Per strip they are the area-weighted mean of
the fluid acceleration and the diameter-weighted mean of the fluid velocity
over the strip (Gauss-Legendre points), so the inertia force of a fixed
member is the exact depth integral, whatever the strip count.
"""

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ..._errors import ModelError
from .._inertial_elements import AddedMass
from ._member import MemberGeometry, rest_placement
from ._waves import _LinearWaves

__all__ = ["MorisonCylinder", "AddedMassStrip"]


class AddedMassStrip:
    """Added mass of one strip: ``mass`` (kg) acting normal to ``axis`` at ``point``.

    Attributes
    ----------
    point : sympy.physics.mechanics.Point
        The strip point, fixed in ``body_frame``.
    mass : float
        :math:`C_a \\rho V_i`, kg.
    axis : sympy.physics.vector.Vector
        Member axis (unit, fixed in ``body_frame``); the added mass acts on the
        velocity components normal to it.
    body_frame, frame : sympy.physics.mechanics.ReferenceFrame
    """

    __slots__ = ("point", "mass", "axis", "body_frame", "frame")

    def __init__(self, point, mass, axis, body_frame, frame):
        self.point, self.mass, self.axis = point, mass, axis
        self.body_frame, self.frame = body_frame, frame

    def __repr__(self):
        return f"AddedMassStrip({self.point}, mass={self.mass:.6g})"


class _StripKinematics:
    """Fluid kinematics of all strips at one time, computed once per time."""

    def __init__(self, waves, current, points, weights_a, weights_v, strip_of, n, wet_rows,
                 z_lo, z_hi, xy_mid):
        self.waves, self.current = waves, current
        self.points, self.weights_a, self.weights_v = points, weights_a, weights_v
        self.strip_of, self.n = strip_of, n
        self.wet_rows, self.z_lo, self.z_hi, self.xy_mid = wet_rows, z_lo, z_hi, xy_mid
        self._t = None
        self._values = self._flat = None

    def series(self, times, waves):
        """``(velocity (T, n, 3), acceleration (T, n, 3), wetted fraction (T, n))`` at
        ``times`` (T,) under ``waves`` (these strips', or another field's)."""
        T = len(times)
        vel = np.zeros((T, self.n, 3))
        acc = np.zeros((T, self.n, 3))
        if waves is not None:
            v, a = waves.kinematics_series(self.points[:, 0], self.points[:, 2], times,
                                           self.points[:, 1])
            for out, values, weights in ((vel, v, self.weights_v), (acc, a, self.weights_a)):
                sums = np.zeros((self.n, len(weights)))  # strip <- its points, weighted
                sums[self.strip_of, np.arange(len(weights))] = weights
                out += np.tensordot(values, sums, axes=([1], [1])).transpose(0, 2, 1)
        if self.current is not None:
            vel += self.current
        wet = np.ones((T, self.n))
        if self.wet_rows.size:
            if waves is None or waves.stretching == "none":
                eta = np.zeros((T, self.wet_rows.size))
            else:
                xy = self.xy_mid[self.wet_rows]
                eta = waves.elevation_series(xy[:, 0], times, xy[:, 1])
            lo, hi = self.z_lo[self.wet_rows], self.z_hi[self.wet_rows]
            wet[:, self.wet_rows] = np.clip((eta - lo) / (hi - lo), 0.0, 1.0)
        return vel, acc, wet

    def __call__(self, t):
        t = float(t)
        if t != self._t and (self._values is None or self.waves is not None):
            # (without waves the kinematics do not depend on t: made once)
            vel = np.zeros((self.n, 3))
            acc = np.zeros((self.n, 3))
            if self.waves is not None:
                v, a = self.waves.kinematics(self.points[:, 0], self.points[:, 2], t,
                                             self.points[:, 1])
                np.add.at(acc, self.strip_of, a * self.weights_a[:, None])
                np.add.at(vel, self.strip_of, v * self.weights_v[:, None])
            if self.current is not None:
                vel += self.current
            wet = np.ones(self.n)
            if self.wet_rows.size:
                if self.waves is None or self.waves.stretching == "none":
                    eta = np.zeros(self.wet_rows.size)
                else:
                    xy = self.xy_mid[self.wet_rows]
                    eta = self.waves.elevation(xy[:, 0], t, xy[:, 1])
                lo, hi = self.z_lo[self.wet_rows], self.z_hi[self.wet_rows]
                wet[self.wet_rows] = np.clip((eta - lo) / (hi - lo), 0.0, 1.0)
            self._t, self._values = t, (vel, acc, wet)
            self._flat = np.concatenate([vel.ravel(), acc.ravel(), wet])
        return self._values

    def flat(self, t):
        """The kinematics at ``t`` in one array: the velocities and the
        accelerations strip by strip (x, y, z each), then the wetted fractions."""
        self(t)
        return self._flat


class _Pick:
    """One component of the strip kinematics as a callable of t (picklable)."""

    __slots__ = ("cache", "kind", "row", "col")

    def __init__(self, cache, kind, row, col):
        self.cache, self.kind, self.row, self.col = cache, kind, row, col

    def __call__(self, t):
        values = self.cache(t)[self.kind]
        return float(values[self.row] if self.col is None else values[self.row, self.col])

    @property
    def input_source(self):
        """The strips' kinematics in one array (:meth:`_StripKinematics.flat`): a
        model reads all the strips' inputs with one call of it."""
        return self.cache.flat

    @property
    def input_index(self):
        """This component's index in :attr:`input_source`'s array."""
        n = self.cache.n
        if self.kind == 2:
            return (6 * n + self.row,)
        return (3 * n * self.kind + 3 * self.row + self.col,)


class MorisonCylinder:
    r"""Morison loads on a slender axisymmetric member of a rigid body.

    Parameters
    ----------
    name : str
        Prefix of the specified-input symbols (``<name>_vx3``, ...).
    body_frame : sympy.physics.mechanics.ReferenceFrame
        Frame of the rigid body carrying the member.
    origin : sympy.physics.mechanics.Point
        A point of the body on the member's axis; its velocity in ``frame``
        must be known (set or computable from positions).
    axis : sympy.physics.vector.Vector
        Unit vector along the member, constant in ``body_frame``.
    stations : sequence of (s, D)
        Diameter ``D`` (m) at axial coordinate ``s`` (m) from ``origin`` along
        ``axis``, linear between stations.
    frame : sympy.physics.mechanics.ReferenceFrame
        The inertial frame; its x, y, z are the wave field's axes (z up).
    fixed_point : sympy.physics.mechanics.Point
        A point fixed in ``frame`` at the wave field's origin (on the SWL).
    rest_configuration : dict
        ``{coordinate: value}`` making the member's position numeric: the
        undisplaced configuration at which the fluid kinematics are evaluated.
    rho : float
        Water density, kg/m^3.
    Ca, Cd : float
        Added-mass and drag coefficients (the inertia coefficient is ``1 + Ca``).
    waves : AiryWave or IrregularSea, optional
        The wave field (none: still water or current only).
    current : sequence of 3 floats, optional
        A uniform steady current in ``frame`` components, m/s.
    n_strips : int
        Number of strips of equal length over the wetted part of the member.
    z_top : float, optional
        Highest rest elevation (m) the strips reach; default 0 (the SWL).  Above
        0, strips crossing or above the SWL get a wetted fraction (a specified
        input) from the local surface elevation, so that with ``"vertical"`` or
        ``"wheeler"`` stretching the splash zone is wetted as the waves pass.
    quadrature_order : int, optional
        Gauss-Legendre points per station interval within a strip (default 4).

    Notes
    -----
    Simplifications: the kinematics at the rest position (no relative-position
    correction), no axial (end-pressure) Froude-Krylov force, no convective
    fluid acceleration, the added mass of the strips wetted at rest only.
    """

    def __init__(self, name, body_frame, origin, axis, stations, frame, fixed_point,
                 rest_configuration, rho, Ca, Cd, n_strips, waves=None, current=None,
                 z_top=0.0, quadrature_order=4):
        owner = f"MorisonCylinder {name!r}"
        if not isinstance(name, str) or not name.isidentifier():
            raise ModelError(f"{owner}: name must be an identifier (it prefixes symbols)")
        self.name = name
        self.geometry = MemberGeometry(stations, owner)
        self.r0, self.e0, self._axis_b = rest_placement(owner, origin, axis, body_frame,
                                                        frame, fixed_point,
                                                        rest_configuration)
        self.body_frame, self.origin, self.axis, self.frame = body_frame, origin, axis, frame
        for label, value in (("rho", rho), ("Ca", Ca), ("Cd", Cd)):
            if not isinstance(value, (int, float)) or value < 0 or (label == "rho"
                                                                    and value == 0):
                raise ModelError(f"{owner}: {label} must be a non-negative number "
                                 f"(rho positive), got {value!r}")
        self.rho, self.Ca, self.Cd = float(rho), float(Ca), float(Cd)
        if not isinstance(n_strips, (int, np.integer)) or n_strips < 1:
            raise ModelError(f"{owner}: n_strips must be a positive int, got {n_strips!r}")
        if waves is not None and not isinstance(waves, _LinearWaves):
            raise ModelError(f"{owner}: waves must be an AiryWave or IrregularSea, got "
                             f"{type(waves).__name__}")
        self.waves = waves
        self.current = None if current is None else np.asarray(current, float).reshape(3)
        if abs(self.e0[2]) < 1e-12:
            raise ModelError(f"{owner}: the member is horizontal at rest; only members "
                             "crossing the water depth (vertical or inclined) are handled")
        # the wetted interval of s at rest: z(s) = r0_z + s e0_z <= z_top
        s_lo, s_hi = self.geometry.s[0], self.geometry.s[-1]
        s_cut = (float(z_top) - self.r0[2]) / self.e0[2]
        if self.e0[2] > 0:
            s_hi = min(s_hi, s_cut)
        else:
            s_lo = max(s_lo, s_cut)
        if not s_hi > s_lo:
            raise ModelError(f"{owner}: no part of the member lies below z_top={z_top}")
        self.s_range = (s_lo, s_hi)
        edges = np.linspace(s_lo, s_hi, n_strips + 1)
        self.n_strips = int(n_strips)
        pts, wa, wv, strip_of, am_s, am_w = [], [], [], [], [], []
        self.volumes, self.projected, self.s_points = [], [], []
        for i, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
            s, w = self.geometry.quadrature(a, b, quadrature_order)
            A, D = self.geometry.area(s), self.geometry.diameter(s)
            V, S = float(w @ A), float(w @ D)
            self.volumes.append(V)
            self.projected.append(S)
            self.s_points.append(float(w @ (A * s)) / V)  # area centroid of the strip
            pts.append(self.r0 + s[:, None] * self.e0)
            wa.append(w * A / V)
            wv.append(w * D / S)
            strip_of.append(np.full(s.size, i))
            am_s.append(s)
            am_w.append(w * A)
        self._am_s, self._am_w = np.concatenate(am_s), np.concatenate(am_w)
        z_edges = self.r0[2] + edges * self.e0[2]
        z_lo, z_hi = np.minimum(z_edges[:-1], z_edges[1:]), np.maximum(z_edges[:-1],
                                                                       z_edges[1:])
        wet_rows = np.nonzero(z_hi > 0)[0]
        s_mid = (edges[:-1] + edges[1:]) / 2
        xy_mid = (self.r0 + s_mid[:, None] * self.e0)[:, :2]
        self._cache = _StripKinematics(waves, self.current, np.concatenate(pts),
                                       np.concatenate(wa), np.concatenate(wv),
                                       np.concatenate(strip_of), self.n_strips, wet_rows,
                                       z_lo, z_hi, xy_mid)
        t = me.dynamicsymbols._t
        self._v = [[sm.Function(f"{name}_v{c}{i}")(t) for c in "xyz"]
                   for i in range(self.n_strips)]
        self._a = [[sm.Function(f"{name}_a{c}{i}")(t) for c in "xyz"]
                   for i in range(self.n_strips)]
        self._wet = {int(i): sm.Function(f"{name}_wet{i}")(t) for i in wet_rows}
        self.points = []
        for i, s in enumerate(self.s_points):
            p = origin.locatenew(f"{name}_strip{i}", s * axis)
            p.v2pt_theory(origin, frame, body_frame)
            self.points.append(p)

    # ------------------------------------------------------------------ loads
    def strip_force(self, i):
        """Inertia (fluid part) and drag force on strip ``i``, a Vector in N."""
        N, e = self.frame, self.axis

        def normal(v):
            return v - v.dot(e) * e

        a_f = sum((c * d for c, d in zip(self._a[i], (N.x, N.y, N.z))), me.Vector(0))
        v_f = sum((c * d for c, d in zip(self._v[i], (N.x, N.y, N.z))), me.Vector(0))
        v_rel = normal(v_f - self.points[i].vel(N))
        force = (1 + self.Ca) * self.rho * self.volumes[i] * normal(a_f)
        if self.Cd:
            speed = sm.sqrt(v_rel.dot(v_rel))
            force += sm.Rational(1, 2) * self.rho * self.Cd * self.projected[i] * speed * v_rel
        wet = self._wet.get(i)
        return force if wet is None else wet * force

    def to_loads(self, at="strips"):
        """The loads of the member (without the added-mass term).

        Parameters
        ----------
        at : {"strips", "origin"}
            ``"strips"``: one force per strip at its point (area centroid of the
            strip, fixed in the body); ``"origin"``: their sum at ``origin``
            and their moment about it on ``body_frame`` (the same generalized
            forces for a rigid body, two loads instead of ``n_strips``).

        Returns
        -------
        list of (Point, Vector) and (ReferenceFrame, Vector)
        """
        forces = [self.strip_force(i) for i in range(self.n_strips)]
        if at == "strips":
            return list(zip(self.points, forces))
        if at == "origin":
            total = sum(forces, me.Vector(0))
            moment = sum((self.points[i].pos_from(self.origin).cross(f)
                          for i, f in enumerate(forces)), me.Vector(0))
            return [(self.origin, total), (self.body_frame, moment)]
        raise ModelError(f"MorisonCylinder {self.name!r}: at must be 'strips' or 'origin', "
                         f"got {at!r}")

    def specified(self):
        """``{symbol: callable of t}`` of the fluid kinematics (and wetted fractions).

        Merge into ``eom.numeric(specified=...)``.  One evaluation of the wave
        field per time serves all the callables.
        """
        out = {}
        for i in range(self.n_strips):
            for j in range(3):
                out[self._v[i][j]] = _Pick(self._cache, 0, i, j)
                out[self._a[i][j]] = _Pick(self._cache, 1, i, j)
        for i, sym in self._wet.items():
            out[sym] = _Pick(self._cache, 2, i, None)
        return out

    def input_series(self, times, waves=None):
        """``{symbol: values at times}`` of the inputs of :meth:`specified`, computed
        for all ``times`` (s) at once: records for :func:`kanedyn.simulate_many`
        (``inputs=``, ``input_times=times``).

        ``waves``: another wave field on the same strips (e.g.
        ``IrregularSea.with_seed``), default this cylinder's.
        """
        times = np.asarray(times, dtype=float).ravel()
        vel, acc, wet = self._cache.series(times, self.waves if waves is None else waves)
        out = {}
        for i in range(self.n_strips):
            for j in range(3):
                out[self._v[i][j]] = vel[:, i, j]
                out[self._a[i][j]] = acc[:, i, j]
        for i, sym in self._wet.items():
            out[sym] = wet[:, i]
        return out

    def strip_kinematics(self, t):
        """``(velocity (n, 3), acceleration (n, 3), wetted fraction (n,))`` at time t."""
        vel, acc, wet = self._cache(t)
        return vel.copy(), acc.copy(), wet.copy()

    # ------------------------------------------------------------- added mass
    def added_mass_terms(self):
        """Per strip, the added mass :math:`C_a\\rho V_i` normal to the axis.

        The acceleration-proportional force :math:`-C_a\\rho V_i \\mathbf a_{b,n}`
        must enter the mass matrix: give these to the generalized-inertia
        elements (``kd.AddedMass``), or lump them with :meth:`added_mass_matrix`.

        Returns
        -------
        list of AddedMassStrip
        """
        return [AddedMassStrip(p, self.Ca * self.rho * V, self.axis, self.body_frame,
                               self.frame) for p, V in zip(self.points, self.volumes)]

    def added_mass_matrix(self):
        r"""The member's added mass as one 6 x 6 matrix about ``origin`` (body components).

        With :math:`w = (v_O, \omega)` in ``body_frame`` components and section
        velocities :math:`v(s) = v_O - [r(s)]_\times \omega`, the kinetic energy
        :math:`\int \tfrac12 C_a \rho A |P v|^2 ds` (:math:`P = I - ee^T`) equals
        :math:`\tfrac12 w^T M w` with :math:`M = \int C_a\rho A\, G^T P G\,ds`,
        :math:`G = [I, -[r]_\times]`: exact for a rigid body (integrated over the
        wetted length by the strips' Gauss points, not lumped at the strip points).

        Returns
        -------
        numpy.ndarray, shape (6, 6)
            kg, kg m, kg m^2 blocks (translations first).
        """
        e = np.array([float(c) for c in self._axis_b])
        P = np.eye(3) - np.outer(e, e)
        M = np.zeros((6, 6))
        for s, wA in zip(self._am_s, self._am_w):
            r = s * e
            rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
            G = np.hstack([np.eye(3), -rx])
            M += self.Ca * self.rho * wA * G.T @ P @ G
        return M

    def inertia_elements(self):
        """The member's added mass as an inertial element for ``bodies=[...]``.

        Returns
        -------
        list of AddedMass
            One :class:`kanedyn.AddedMass` named ``<name>_added_mass`` with
            :meth:`added_mass_matrix` about ``origin`` (empty when ``Ca`` is 0).
        """
        if self.Ca == 0:
            return []
        return [AddedMass(f"{self.name}_added_mass", self.origin, self.body_frame,
                          self.added_mass_matrix(), self.frame)]

    def __repr__(self):
        return (f"MorisonCylinder({self.name!r}, n_strips={self.n_strips}, Ca={self.Ca}, "
                f"Cd={self.Cd})")
