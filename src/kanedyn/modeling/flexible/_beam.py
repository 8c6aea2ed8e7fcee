r"""Three-dimensional beam elements: stiffness, mass and geometric stiffness.

A two-node element of length :math:`L` along its local :math:`x` axis has 12
degrees of freedom, ordered per node as
:math:`(u, v, w, \theta_x, \theta_y, \theta_z)` in local components: axial
displacement, the two transverse displacements, twist and the two section
rotations.  Bending in the :math:`x`-:math:`y` plane (deflection :math:`v`,
rotation :math:`\theta_z = v'` for Euler–Bernoulli) is resisted by
:math:`EI_z`; bending in the :math:`x`-:math:`z` plane (deflection
:math:`w`, rotation :math:`\theta_y = -w'`) by :math:`EI_y`.

Axial displacement and twist use linear shape functions; each bending plane
uses the cubic interpolation of the Timoshenko beam with the shear parameter

.. math::

    \Phi = \frac{12\,EI}{\kappa G A\,L^2},

which for :math:`\Phi = 0` (no shear stiffness given: Euler–Bernoulli) is the
Hermite cubic.  With section properties that vary along the element (linear
between stations), the matrices are integrated exactly by Gauss–Legendre
quadrature on each piece between breakpoints:

.. math::

    K = \int_0^L \bigl(EI\,\psi'^T\psi' + \kappa GA\,\gamma^T\gamma\bigr)\,dx ,\qquad
    M = \int_0^L \bigl(\rho A\,N_w^T N_w + \rho I\,N_\psi^T N_\psi\bigr)\,dx ,\qquad
    K_G = \int_0^L N_w'^T N_w'\,dx ,

with :math:`\gamma = N_w' - N_\psi` the shear strain.  :math:`K_G` is the
geometric stiffness per unit axial force (:math:`N = 1` N): the transverse
displacement :math:`d` of an element shortens its projection on the axis by
:math:`\tfrac12 d^T K_G d` (second-order foreshortening).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._errors import ModelError

__all__ = ["BeamElement", "beam_element", "beam_element_matrices", "element_axes",
           "element_transformation", "PLANES", "PARTS"]

#: the stiffness parts of an element, in the order used to name modes
PARTS = ("axial", "torsion", "bending_xy", "bending_xz")

#: per bending plane: local dof indices (w1, psi1, w2, psi2), signs that turn
#: the plane's slope psi into the local rotation, stiffness, rotary inertia and
#: shear stiffness property names
PLANES = {
    "bending_xy": ((1, 5, 7, 11), (1.0, 1.0, 1.0, 1.0), "EI_z", "rotary_inertia_z",
                   "shear_stiffness_y"),
    "bending_xz": ((2, 4, 8, 10), (1.0, -1.0, 1.0, -1.0), "EI_y", "rotary_inertia_y",
                   "shear_stiffness_z"),
}
_AXIAL = (0, 6)
_TORSION = (3, 9)

# 4-point Gauss-Legendre on [0, 1]: exact for polynomials of degree 7
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(4)
_GAUSS_X = 0.5 * (_GAUSS_X + 1.0)
_GAUSS_W = 0.5 * _GAUSS_W


@dataclass(frozen=True, eq=False)
class BeamElement:
    """The matrices of one beam element in its local axes.

    Attributes
    ----------
    length : float
        Element length, m.
    stiffness : ndarray, shape (12, 12)
        Stiffness matrix, N/m, N, N m (local dof order
        ``u, v, w, theta_x, theta_y, theta_z`` at each node).
    mass : ndarray, shape (12, 12)
        Consistent mass matrix, kg, kg m, kg m^2.
    geometric_stiffness : ndarray, shape (12, 12)
        Geometric stiffness per unit axial force (N = 1 N), 1/m, 1, m: the
        foreshortening of the element for displacements ``d`` is
        ``0.5 * d @ geometric_stiffness @ d`` (m).
    stiffness_parts : dict of str to ndarray, shape (12, 12)
        The stiffness split into ``axial``, ``torsion``, ``bending_xy`` and
        ``bending_xz`` (their sum is ``stiffness``); used to name modes.
    shear_parameters : dict of str to float
        :math:`\\Phi` of each bending plane (0 for Euler–Bernoulli).
    """

    length: float
    stiffness: np.ndarray
    mass: np.ndarray
    geometric_stiffness: np.ndarray
    stiffness_parts: dict
    shear_parameters: dict


def _bending_shapes(xi, length, phi):
    """Shape functions of one bending plane at ``xi`` (k,), dofs (w1, psi1, w2, psi2).

    Returns ``(N_w, dN_w, N_psi, dN_psi)``, each (k, 4); derivatives with respect
    to the arc length x (1/m).
    """
    L = length
    mu = 1.0 / (1.0 + phi)
    x, x2, x3 = xi, xi ** 2, xi ** 3
    one = np.ones_like(xi)
    Nw = mu * np.stack([1 - 3 * x2 + 2 * x3 + phi * (1 - x),
                        L * (x - 2 * x2 + x3 + 0.5 * phi * (x - x2)),
                        3 * x2 - 2 * x3 + phi * x,
                        L * (-x2 + x3 + 0.5 * phi * (x2 - x))], axis=1)
    dNw = mu * np.stack([(-6 * x + 6 * x2 - phi * one) / L,
                         1 - 4 * x + 3 * x2 + 0.5 * phi * (1 - 2 * x),
                         (6 * x - 6 * x2 + phi * one) / L,
                         -2 * x + 3 * x2 + 0.5 * phi * (2 * x - 1)], axis=1)
    Np = mu * np.stack([6 * (x2 - x) / L,
                        1 - 4 * x + 3 * x2 + phi * (1 - x),
                        6 * (x - x2) / L,
                        -2 * x + 3 * x2 + phi * x], axis=1)
    dNp = mu * np.stack([6 * (2 * x - 1) / L ** 2,
                         (-4 + 6 * x - phi * one) / L,
                         6 * (1 - 2 * x) / L ** 2,
                         (-2 + 6 * x + phi * one) / L], axis=1)
    return Nw, dNw, Np, dNp


def _quadrature(breaks):
    """Gauss points and weights on [0, 1] split at ``breaks`` (sorted, inside (0, 1))."""
    edges = np.concatenate([[0.0], np.asarray(breaks, float), [1.0]])
    xs, ws = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        if b > a:
            xs.append(a + (b - a) * _GAUSS_X)
            ws.append((b - a) * _GAUSS_W)
    return np.concatenate(xs), np.concatenate(ws)


def _place(target, block, dofs, signs=None):
    signs = np.ones(len(dofs)) if signs is None else np.asarray(signs)
    target[np.ix_(dofs, dofs)] += block * np.outer(signs, signs)


def beam_element(length, section, breaks=()):
    """Matrices of a beam element whose section properties vary along it.

    Parameters
    ----------
    length : float
        Element length, m (positive).
    section : callable
        ``section(xi)`` with ``xi`` an array (k,) of positions along the
        element as fractions of its length returns a mapping of property name
        to array (k,): ``mass_per_length`` (kg/m), ``EA`` (N), ``GJ`` (N m^2),
        ``EI_y``, ``EI_z`` (N m^2), ``rotary_inertia_y``, ``rotary_inertia_z``,
        ``polar_inertia`` (kg m, per unit length) and, for Timoshenko planes,
        ``shear_stiffness_y``, ``shear_stiffness_z`` (kappa G A, N; absent or
        ``None`` for Euler–Bernoulli).
    breaks : sequence of float
        Fractions of the length in (0, 1) where the properties' interpolation
        has a kink (stations inside the element); the quadrature is split
        there so that piecewise-linear properties are integrated exactly.

    Returns
    -------
    BeamElement
    """
    if not length > 0:
        raise ModelError(f"beam element length must be positive, got {length!r}")
    L = float(length)
    xi, w = _quadrature(breaks)
    p = section(xi)
    dx = w * L

    def prop(name):
        value = p.get(name)
        return None if value is None else np.broadcast_to(np.asarray(value, float), xi.shape)

    parts = {name: np.zeros((12, 12)) for name in PARTS}
    mass = np.zeros((12, 12))
    geometric = np.zeros((12, 12))
    phis = {}

    # axial and torsion: linear shape functions
    N = np.stack([1 - xi, xi], axis=1)
    dN = np.tile([-1.0 / L, 1.0 / L], (len(xi), 1))
    for dofs, stiff, inertia, part in ((_AXIAL, prop("EA"), prop("mass_per_length"), "axial"),
                                       (_TORSION, prop("GJ"), prop("polar_inertia"),
                                        "torsion")):
        _place(parts[part], np.einsum("q,qi,qj->ij", stiff * dx, dN, dN), dofs)
        if inertia is not None:
            _place(mass, np.einsum("q,qi,qj->ij", inertia * dx, N, N), dofs)

    rho_a = prop("mass_per_length")
    for part, (dofs, signs, ei_name, rot_name, shear_name) in PLANES.items():
        ei = prop(ei_name)
        shear = prop(shear_name)
        if shear is None:
            phi = 0.0
        else:
            phi = 12.0 * np.dot(ei, w) / (np.dot(shear, w) * L ** 2)
        phis[part] = float(phi)
        Nw, dNw, Np, dNp = _bending_shapes(xi, L, phi)
        k = np.einsum("q,qi,qj->ij", ei * dx, dNp, dNp)
        if shear is not None:
            gamma = dNw - Np
            k = k + np.einsum("q,qi,qj->ij", shear * dx, gamma, gamma)
        _place(parts[part], k, dofs, signs)
        m = np.einsum("q,qi,qj->ij", rho_a * dx, Nw, Nw)
        rot = prop(rot_name)
        if rot is not None:
            m = m + np.einsum("q,qi,qj->ij", rot * dx, Np, Np)
        _place(mass, m, dofs, signs)
        _place(geometric, np.einsum("q,qi,qj->ij", dx, dNw, dNw), dofs, signs)

    stiffness = sum(parts.values())
    return BeamElement(L, stiffness, mass, geometric, parts, phis)


def beam_element_matrices(length, *, mass_per_length, EA, GJ, EI_y, EI_z,
                          rotary_inertia_y=None, rotary_inertia_z=None, polar_inertia=None,
                          shear_stiffness_y=None, shear_stiffness_z=None):
    """Matrices of a beam element from properties at its two ends.

    Each property is a number (uniform along the element) or a pair
    ``(start, end)`` varying linearly.  ``polar_inertia`` defaults to
    ``rotary_inertia_y + rotary_inertia_z`` (perpendicular-axis theorem of the
    section) when those are given, else the twist carries no inertia.

    Parameters
    ----------
    length : float
        Element length, m.
    mass_per_length : float or (float, float)
        kg/m.
    EA : float or (float, float)
        Axial stiffness, N.
    GJ : float or (float, float)
        Torsional stiffness, N m^2.
    EI_y, EI_z : float or (float, float)
        Bending stiffness about the local y axis (bending in the x-z plane) and
        about the local z axis (bending in the x-y plane), N m^2.
    rotary_inertia_y, rotary_inertia_z, polar_inertia : float or (float, float), optional
        Mass moments of inertia per unit length of the section about the local
        y, z and x axes, kg m.
    shear_stiffness_y, shear_stiffness_z : float or (float, float), optional
        Shear stiffness kappa G A for shear along local y and z, N; given,
        the plane is a Timoshenko beam.

    Returns
    -------
    BeamElement

    Examples
    --------
    >>> e = beam_element_matrices(2.0, mass_per_length=3.0, EA=1e6, GJ=1e3,
    ...                           EI_y=1e4, EI_z=1e4)
    >>> print(round(float(e.stiffness[1, 1]) * 2.0 ** 3 / 1e4, 12))   # 12 EI / L^3
    12.0
    >>> print(round(float(e.mass[0, 0]) * 6 / (3.0 * 2.0), 12))        # 2 rho A L / 6
    2.0
    """
    values = dict(mass_per_length=mass_per_length, EA=EA, GJ=GJ, EI_y=EI_y, EI_z=EI_z,
                  rotary_inertia_y=rotary_inertia_y, rotary_inertia_z=rotary_inertia_z,
                  polar_inertia=polar_inertia, shear_stiffness_y=shear_stiffness_y,
                  shear_stiffness_z=shear_stiffness_z)
    if polar_inertia is None and rotary_inertia_y is not None and rotary_inertia_z is not None:
        ry, rz = np.broadcast_arrays(np.asarray(rotary_inertia_y, float),
                                     np.asarray(rotary_inertia_z, float))
        values["polar_inertia"] = ry + rz

    def section(xi):
        out = {}
        for name, value in values.items():
            if value is None:
                continue
            a = np.asarray(value, float)
            out[name] = (np.full_like(xi, float(a)) if a.ndim == 0
                         else a[0] + (a[1] - a[0]) * xi)
        return out

    return beam_element(length, section)


def element_axes(axis, reference):
    """Local axes of an element: rows ``x, y, z`` in body-frame components.

    ``x`` is the unit element axis; ``y`` the part of ``reference``
    perpendicular to it, normalized; ``z = x × y``.

    Parameters
    ----------
    axis : array_like, shape (3,)
        The element's axis (any length).
    reference : array_like, shape (3,)
        A vector not parallel to ``axis`` that fixes the local y axis.

    Returns
    -------
    ndarray, shape (3, 3)
        Rotation matrix ``R`` with local components ``v_local = R @ v_body``.
    """
    x = np.asarray(axis, float)
    x = x / np.linalg.norm(x)
    r = np.asarray(reference, float)
    y = r - np.dot(r, x) * x
    norm = np.linalg.norm(y)
    if norm < 1e-9 * np.linalg.norm(r):
        raise ModelError(f"the reference vector {tuple(r)} is parallel to the element axis "
                         f"{tuple(x)}: it cannot fix the local y axis")
    y = y / norm
    return np.vstack([x, y, np.cross(x, y)])


def element_transformation(rotation):
    """The 12 x 12 block-diagonal transformation ``local = T @ global`` of an element."""
    T = np.zeros((12, 12))
    for k in range(4):
        T[3 * k:3 * k + 3, 3 * k:3 * k + 3] = rotation
    return T
