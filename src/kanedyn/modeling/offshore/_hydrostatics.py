r"""Hydrostatics of a floating axisymmetric member (a spar): buoyancy and restoring.

The member stands vertical at rest with its origin on the still water level
(SWL) and its axis up.  From its stations ``(s, D)`` (:mod:`._member`):
displaced volume :math:`V = \int_{s_b}^0 A\,ds`, centre of buoyancy
:math:`z_B = \int s A\,ds / V`, waterplane area :math:`A_{wp} = \pi D_0^2/4`
and second moment :math:`I_{wp} = \pi D_0^4/64` (:math:`D_0 = D(0)`), and
about the origin

.. math:: C_{33} = \rho g A_{wp},\qquad C_{44} = C_{55} = \rho g (I_{wp} + V z_B).

This is the *buoyancy part* only: the weight term :math:`-m g z_G` comes from
the gravity loads on the bodies of the multibody model (a body's weight at
its mass centre gives exactly that restoring moment when it tilts); do not
add it here as well.

Two forms reduce to loads (:meth:`Hydrostatics.to_loads`):

``"linear"``       the constant buoyancy :math:`\rho g V` up at the origin, and
                   :math:`-C\delta` with :math:`\delta` the displacement of the
                   origin and the small rotation
                   :math:`\theta = \tfrac12\sum_j e_j^0 \times e_j` of the body
                   from rest (a force at the origin, a moment on the body)
``"large_angle"``  the exact buoyancy of the tilted member while the water
                   plane cuts only the constant-diameter section at the SWL:
                   :math:`V = V_f + \pi R^2 L`, :math:`L = s_0 - s_a`,
                   :math:`s_0 = -z_O/c`, :math:`c = e\cdot z`, and the moment
                   about the origin
                   :math:`\rho g\,[M_f + \pi R^2((s_0^2 - s_a^2)/2 + R^2\tan^2\alpha/8)
                   + \pi R^4/4]\;(e \times z)`
"""

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ..._errors import ModelError
from ..._expressions import as_expression
from ._member import MemberGeometry, rest_placement
from ._waves import G_STANDARD

__all__ = ["Hydrostatics", "HYDROSTATIC_FORMS"]

HYDROSTATIC_FORMS = ("linear", "large_angle")


class Hydrostatics:
    """Buoyancy and hydrostatic restoring of a vertical axisymmetric member.

    Parameters
    ----------
    name : str
    body_frame : sympy.physics.mechanics.ReferenceFrame
    origin : sympy.physics.mechanics.Point
        Point of the body on the axis, on the SWL at rest (the reference point
        of the restoring matrix).
    axis : sympy.physics.vector.Vector
        Unit vector along the member, constant in ``body_frame``, up at rest.
    stations : sequence of (s, D)
        Diameter ``D`` (m) at ``s`` (m) from ``origin`` along ``axis``.
    frame : sympy.physics.mechanics.ReferenceFrame
        Inertial frame, z up.
    fixed_point : sympy.physics.mechanics.Point
        Point fixed in ``frame`` on the SWL.
    rest_configuration : dict
        ``{coordinate: value}`` of the undisplaced configuration.
    rho : float
        Water density, kg/m^3.
    form : {"linear", "large_angle"}
    g : float, optional
        Gravity, m/s^2 (default 9.80665).
    """

    def __init__(self, name, body_frame, origin, axis, stations, frame, fixed_point,
                 rest_configuration, rho, form, g=G_STANDARD):
        owner = f"Hydrostatics {name!r}"
        if not isinstance(name, str) or not name:
            raise ModelError(f"{owner}: name must be a non-empty str")
        if form not in HYDROSTATIC_FORMS:
            raise ModelError(f"{owner}: form must be one of {HYDROSTATIC_FORMS}, got {form!r}")
        for label, value in (("rho", rho), ("g", g)):
            if not isinstance(value, (int, float)) or not value > 0:
                raise ModelError(f"{owner}: {label} must be a positive number, got {value!r}")
        self.name, self.form, self.rho, self.g = name, form, float(rho), float(g)
        self.geometry = MemberGeometry(stations, owner)
        self.r0, self.e0, _ = rest_placement(owner, origin, axis, body_frame, frame,
                                             fixed_point, rest_configuration)
        if abs(self.e0[2] - 1) > 1e-9:
            raise ModelError(f"{owner}: the axis must point up (along {frame}.z) at rest, "
                             f"got {self.e0}")
        if abs(self.r0[2]) > 1e-9:
            raise ModelError(f"{owner}: the origin must lie on the SWL at rest (z = 0), "
                             f"got z = {self.r0[2]}")
        s = self.geometry.s
        if not s[0] < 0 < s[-1]:
            raise ModelError(f"{owner}: the member must pierce the SWL (stations from "
                             f"below s = 0 to above), got s in [{s[0]}, {s[-1]}]")
        self.body_frame, self.origin, self.axis = body_frame, origin, axis
        self.frame, self.fixed_point = frame, fixed_point
        rest = {as_expression(k, f"{owner}: rest_configuration key"):
                as_expression(v, f"{owner}: rest_configuration[{k}]")
                for k, v in rest_configuration.items()}
        self._dcm0 = np.array(frame.dcm(body_frame).xreplace(rest), dtype=float)
        V, M1, _ = self.geometry.integrals(s[0], 0.0)
        self.volume, self.z_buoyancy = V, M1 / V
        D0 = float(self.geometry.diameter(0.0))
        self.waterplane_area = np.pi * D0 ** 2 / 4
        self.waterplane_inertia = np.pi * D0 ** 4 / 64
        # the constant-diameter section the SWL cuts (large-angle form)
        k = int(np.searchsorted(s, 0.0, side="left")) - 1  # s[k] < 0 <= s[k+1]
        self._section = (float(s[k]), float(s[k + 1]), D0 / 2)
        self._full = self.geometry.integrals(s[0], s[k])[:2] if k > 0 else (0.0, 0.0)
        if form == "large_angle" and abs(self.geometry.D[k] - self.geometry.D[k + 1]) > 0:
            raise ModelError(f"{owner}: the large-angle form needs a constant-diameter "
                             f"section at the SWL; stations {s[k]} and {s[k + 1]} differ")

    # ----------------------------------------------------------- coefficients
    @property
    def buoyancy(self):
        """Buoyancy at rest :math:`\\rho g V`, N."""
        return self.rho * self.g * self.volume

    def stiffness_matrix(self):
        """Hydrostatic restoring matrix about the origin (buoyancy part), shape (6, 6).

        Units N/m, N m/rad; entries C33, C44, C55 (0-based 2, 3, 4).
        """
        C = np.zeros((6, 6))
        C[2, 2] = self.rho * self.g * self.waterplane_area
        C[3, 3] = C[4, 4] = self.rho * self.g * (self.waterplane_inertia
                                                 + self.volume * self.z_buoyancy)
        return C

    def submerged(self, z_origin, cos_tilt):
        """Numeric large-angle volume (m^3) and first moment along the axis (m^4).

        Parameters
        ----------
        z_origin : float
            Elevation of the origin, m.
        cos_tilt : float
            Cosine of the angle between the axis and the vertical.

        Raises
        ------
        ModelError
            When the water plane leaves the section at the SWL.
        """
        s_a, s_b, R = self._section
        c = float(cos_tilt)
        s0 = -float(z_origin) / c
        tan = np.sqrt(max(1 - c * c, 0.0)) / c
        if not (s_a <= s0 - R * tan and s0 + R * tan <= s_b):
            raise ModelError(f"Hydrostatics {self.name!r}: the water plane leaves the "
                             f"section [{s_a}, {s_b}] (s0 = {s0}, R tan = {R * tan})")
        Vf, Mf = self._full
        A = np.pi * R ** 2
        return Vf + A * (s0 - s_a), Mf + A * ((s0 ** 2 - s_a ** 2) / 2 + R ** 2 * tan ** 2 / 8)

    # ------------------------------------------------------------------ loads
    def small_rotation(self):
        """Small rotation of the body from rest, a Vector in ``frame`` (rad)."""
        N = self.frame
        rest = [sum((float(self._dcm0[i, j]) * b for i, b in enumerate((N.x, N.y, N.z))),
                    me.Vector(0)) for j in range(3)]
        now = (self.body_frame.x, self.body_frame.y, self.body_frame.z)
        return sum((r.cross(v) for r, v in zip(rest, now)), me.Vector(0)) / 2

    def to_loads(self):
        """``[(origin, force), (body_frame, moment)]`` of the chosen form."""
        N = self.frame
        rg = self.rho * self.g
        pos = self.origin.pos_from(self.fixed_point)
        if self.form == "linear":
            d = pos - sum((float(c) * b for c, b in zip(self.r0, (N.x, N.y, N.z))),
                          me.Vector(0))
            theta = self.small_rotation()
            delta = sm.Matrix([d.dot(N.x), d.dot(N.y), d.dot(N.z), theta.dot(N.x),
                               theta.dot(N.y), theta.dot(N.z)])
            C = self.stiffness_matrix()
            f = -sm.Matrix(C) * delta
            force = f[0] * N.x + f[1] * N.y + (self.buoyancy + f[2]) * N.z
            moment = f[3] * N.x + f[4] * N.y + f[5] * N.z
            return [(self.origin, force), (self.body_frame, moment)]
        s_a, _, R = self._section
        e = self.axis
        c = e.dot(N.z)
        s0 = -pos.dot(N.z) / c
        tan2 = (1 - c ** 2) / c ** 2
        Vf, Mf = self._full
        A = sm.pi * R ** 2
        volume = Vf + A * (s0 - s_a)
        moment_arm = Mf + A * ((s0 ** 2 - s_a ** 2) / 2 + R ** 2 * tan2 / 8) + sm.pi * R ** 4 / 4
        return [(self.origin, rg * volume * N.z),
                (self.body_frame, rg * moment_arm * e.cross(N.z))]

    def __repr__(self):
        return f"Hydrostatics({self.name!r}, form={self.form!r}, V={self.volume:.6g} m^3)"
