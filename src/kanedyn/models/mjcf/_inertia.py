r"""Masses and inertias of MJCF bodies, from ``<inertial>`` or inferred from geoms.

A geom's mass is its ``mass`` attribute, else ``density`` (1000 kg/m^3 by
default) times its volume; its central inertia is that of the solid of uniform
density, in closed form (half-sizes :math:`a, b, c`, radius :math:`r`,
half-length :math:`h` as MuJoCo's ``size`` gives them):

=========  ======================  =========================================
shape      volume                  central moments (axis of symmetry z)
=========  ======================  =========================================
sphere     :math:`4\pi r^3/3`       :math:`2mr^2/5`
ellipsoid  :math:`4\pi abc/3`       :math:`m(b^2+c^2)/5`, ...
box        :math:`8abc`             :math:`m(b^2+c^2)/3`, ...
cylinder   :math:`2\pi r^2h`        :math:`m(r^2/4+h^2/3)`; :math:`mr^2/2`
capsule    :math:`2\pi r^2h+4\pi r^3/3`  cylinder :math:`m_c` and two
                                    hemispheres :math:`m_s`:
                                    :math:`m_c(r^2/4+h^2/3)+m_s(2r^2/5+h^2+3hr/4)`;
                                    :math:`m_cr^2/2+2m_sr^2/5`
=========  ======================  =========================================

A mesh geom's volume (or, for ``inertia="shell"``, area), mass centre and
inertia come from its triangles (:mod:`._meshes`), placed by the geom's pose.

A body's mass, mass centre and central inertia (in the body's frame) are those
of its geoms combined (parallel-axis theorem), when the compiler's
``inertiafromgeom`` says so (``auto``, MuJoCo's default: when the body has no
``<inertial>``); geoms outside ``inertiagrouprange`` do not count.  Then, as
MuJoCo's compiler does: ``boundmass`` and ``boundinertia`` raise masses and
principal moments to their bounds, ``balanceinertia`` replaces principal
moments that break the triangle inequality by their mean, and ``settotalmass``
scales every mass and inertia so that the bodies' masses sum to it.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["geom_mass_properties", "body_mass_properties", "combine", "INERTIA_SHAPES",
           "NotInferable"]


class NotInferable(Exception):
    """A geom whose mass and inertia are not inferred here (``args[0]``: the geom)."""

#: the geom types whose mass and inertia are inferred (a mesh's from its triangles,
#: :mod:`._meshes`)
INERTIA_SHAPES = ("sphere", "ellipsoid", "box", "cylinder", "capsule", "mesh")


def _volume_and_unit_moments(kind, size):
    """Volume (m^3) and the central principal moments per unit mass (m^2)."""
    if kind == "sphere":
        r = size[0]
        return 4 * math.pi * r ** 3 / 3, np.full(3, 2 * r * r / 5)
    if kind == "ellipsoid":
        a, b, c = size
        return 4 * math.pi * a * b * c / 3, np.array([b * b + c * c, a * a + c * c,
                                                      a * a + b * b]) / 5
    if kind == "box":
        a, b, c = size
        return 8 * a * b * c, np.array([b * b + c * c, a * a + c * c, a * a + b * b]) / 3
    if kind == "cylinder":
        r, h = size[:2]
        side = r * r / 4 + h * h / 3
        return 2 * math.pi * r * r * h, np.array([side, side, r * r / 2])
    if kind == "capsule":
        r, h = size[:2]
        v_c, v_s = 2 * math.pi * r * r * h, 4 * math.pi * r ** 3 / 3
        volume = v_c + v_s
        fc, fs = v_c / volume, v_s / volume  # mass fractions
        side = fc * (r * r / 4 + h * h / 3) + fs * (2 * r * r / 5 + h * h + 3 * h * r / 4)
        return volume, np.array([side, side, fc * r * r / 2 + fs * 2 * r * r / 5])
    raise ValueError(kind)


def geom_mass_properties(geom, meshes=None):
    """``(mass, centre (3,), central inertia (3, 3))`` of a geom, in its body's frame
    (a mesh geom's from ``meshes``, a :class:`~._meshes.MeshLibrary`)."""
    R, pos = geom.R, np.asarray(geom.pos, dtype=float)
    if geom.type == "mesh":
        volume, centre, unit = meshes.properties(geom.mesh)
        mass = geom.mass if geom.mass is not None else geom.density * volume
        return mass, pos + R @ centre, R @ (mass * unit) @ R.T
    volume, unit = _volume_and_unit_moments(geom.type, geom.size)
    mass = geom.mass if geom.mass is not None else geom.density * volume
    return mass, pos, R @ np.diag(mass * unit) @ R.T


def combine(parts):
    """Mass, mass centre (3,) and central inertia (3, 3) of ``[(m, c, J)]``."""
    mass = sum(p[0] for p in parts)
    centre = sum(m * c for m, c, _ in parts) / mass if mass > 0 else np.zeros(3)
    inertia = np.zeros((3, 3))
    for m, c, J in parts:
        d = c - centre
        inertia = inertia + J + m * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, centre, inertia


def body_mass_properties(body, compiler, meshes=None):
    """``(mass, centre, inertia, counted geoms)`` of one body as MuJoCo compiles it,
    before ``settotalmass``; raises :class:`NotInferable` of a geom that cannot count."""
    use_geoms = compiler.inertiafromgeom == "true" or (
        compiler.inertiafromgeom == "auto" and body.inertial is None)
    if not use_geoms:
        if body.inertial is None:
            return 0.0, np.zeros(3), np.zeros((3, 3)), []
        return (body.inertial.mass, np.asarray(body.inertial.pos, dtype=float),
                body.inertial.inertia, [])
    lo, hi = compiler.inertiagrouprange
    parts, counted = [], []
    for geom in body.geoms:
        if not lo <= geom.group <= hi or geom.type in ("plane", "hfield"):
            continue
        if geom.type not in INERTIA_SHAPES or geom.shellinertia:
            raise NotInferable(geom)
        parts.append(geom_mass_properties(geom, meshes))
        counted.append(geom)
    if not parts:
        return 0.0, np.zeros(3), np.zeros((3, 3)), []
    return (*combine(parts), counted)


def bound(mass, inertia, compiler):
    """``boundmass``, ``boundinertia`` and ``balanceinertia`` applied to a body."""
    mass = max(mass, compiler.boundmass)
    if compiler.boundinertia > 0 or compiler.balanceinertia:
        moments, axes = np.linalg.eigh(inertia)
        moments = np.maximum(moments, compiler.boundinertia)
        if compiler.balanceinertia and moments[0] + moments[1] < moments[2]:
            moments[:] = moments.mean()
        inertia = axes @ np.diag(moments) @ axes.T
    return mass, inertia
