r"""The multiblade coordinate transformation (Coleman; MBC3 of Bir 2008) of a linear state matrix.

The coordinates :math:`q_b` of blade :math:`b = 1 \dots N` (the same coordinate
on each blade, in the rotating frame), at the azimuths
:math:`\psi_b = \psi + 2\pi (b-1)/N`, are written through the non-rotating
(multiblade) coordinates

.. math::

    q_b = q_0 + \sum_{k=1}^{K} \left(q_{c,k}\cos k\psi_b + q_{s,k}\sin k\psi_b\right)
          + q_d\,(-1)^{b-1},

:math:`K = \lfloor (N-1)/2 \rfloor`, the differential coordinate :math:`q_d`
only for even :math:`N`: :math:`q = T(\psi)\,z`.  With the rotor turning at
the constant rate :math:`\Omega = \dot\psi` the blade speeds are
:math:`\dot q = T\dot z + \Omega T' z`, so a state :math:`x = [q; u]` with
:math:`u = \dot q` on the blade coordinates becomes :math:`x = \mathcal T z`,

.. math::

    \mathcal T = \begin{bmatrix} T & 0 \\ \Omega T' & T \end{bmatrix},\qquad
    \dot z = \mathcal T^{-1}\left(A\,\mathcal T - \Omega\,\frac{d\mathcal T}{d\psi}\right) z,

the identity on every other state.  For an isotropic rotor in a steady motion
the transformed matrix does not depend on :math:`\psi`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["multiblade_basis", "multiblade_names", "to_multiblade"]


def multiblade_basis(n_blades, psi):
    r"""The matrix :math:`T(\psi)` and its first two derivatives in :math:`\psi`.

    Parameters
    ----------
    n_blades : int
        :math:`N \ge 3`.
    psi : float
        Azimuth of blade 1, rad.

    Returns
    -------
    T, dT, ddT : ndarray, shape (N, N)
        Rows: blades; columns: the collective, the cosine and sine pairs of
        orders 1 to K, then (even N) the differential coordinate.
    """
    azimuths = psi + 2 * np.pi * np.arange(n_blades) / n_blades
    orders = np.arange(1, (n_blades - 1) // 2 + 1)
    angle = np.outer(azimuths, orders)
    c, s = np.cos(angle), np.sin(angle)
    columns = [np.ones(n_blades)]
    d_columns = [np.zeros(n_blades)]
    dd_columns = [np.zeros(n_blades)]
    for j, k in enumerate(orders):
        columns += [c[:, j], s[:, j]]
        d_columns += [-k * s[:, j], k * c[:, j]]
        dd_columns += [-k * k * c[:, j], -k * k * s[:, j]]
    if n_blades % 2 == 0:
        columns.append((-1.0) ** np.arange(n_blades))
        d_columns.append(np.zeros(n_blades))
        dd_columns.append(np.zeros(n_blades))
    return tuple(np.column_stack(cols) for cols in (columns, d_columns, dd_columns))


def multiblade_names(name, n_blades):
    """Names of the multiblade coordinates of the blade coordinate ``name`` (blade 1's).

    ``"<name> collective"``, ``"<name> cos"`` and ``"<name> sin"`` (order 1),
    ``"<name> cos2"`` ... (higher orders), ``"<name> differential"`` (even N).
    """
    names = [f"{name} collective"]
    for k in range(1, (n_blades - 1) // 2 + 1):
        suffix = "" if k == 1 else str(k)
        names += [f"{name} cos{suffix}", f"{name} sin{suffix}"]
    if n_blades % 2 == 0:
        names.append(f"{name} differential")
    return names


def to_multiblade(A, blade_coordinates, blade_speeds, psi, rate):
    r"""The state matrix in multiblade coordinates (see the module text).

    :math:`\mathcal T^{-1}(A\,\mathcal T - \Omega\,d\mathcal T/d\psi)`.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix with the blade coordinates in the rotating frame.
    blade_coordinates, blade_speeds : ndarray of int, shape (N, m)
        Positions in the state of each blade's m coordinates and of their
        rates (``blade_speeds[b, j]`` is the time derivative of
        ``blade_coordinates[b, j]``).
    psi : float
        Azimuth of blade 1, rad.
    rate : float
        :math:`\Omega = \dot\psi`, rad/s.

    Returns
    -------
    ndarray, shape (n, n)
        The multiblade coordinates of blade coordinate j take the places of
        ``blade_coordinates[:, j]`` (collective, cos, sin, ...), their rates
        those of ``blade_speeds[:, j]``.
    """
    n_blades = blade_coordinates.shape[0]
    T, dT, ddT = multiblade_basis(n_blades, psi)
    transform = np.eye(len(A))
    derivative = np.zeros_like(transform)   # d(transform)/d(psi)
    for q, u in zip(blade_coordinates.T, blade_speeds.T):
        for rows, cols, block, d_block in ((q, q, T, dT), (u, u, T, dT),
                                           (u, q, rate * dT, rate * ddT)):
            transform[np.ix_(rows, cols)] = block
            derivative[np.ix_(rows, cols)] = d_block
    return np.linalg.solve(transform, A @ transform - rate * derivative)
