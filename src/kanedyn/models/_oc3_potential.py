r"""The OC3 platform's springs: their potentials, and loads that are exactly their gradients.

The published hydrostatic and mooring matrices act through
:class:`~kanedyn.MatrixSpringDamper` (:math:`-Kx` with :math:`\theta = \sin\varphi\,n`),
which is the gradient of no potential at second order in 3-D rotations, and the
published mooring stiffness is not even symmetric.  The model keeps those loads
(its dynamics are the published matrices'), but writes each as two loads:

* the **held part**, the force at the platform's point and the torque on its
  frame whose power is exactly :math:`-\dot V` for the potential :math:`V` the
  model declares (:func:`gradient_loads`); the energy balance leaves it out,
  since :math:`V` holds its work;
* the **remainder**, the published element's loads less the held part (zero
  to first order; for the asymmetric mooring the work of the asymmetry): a
  work term of the energy balance.

The potentials are functions of the displacement :math:`d` of the platform's
point (``N`` components, m) and of :math:`R` = ``N.dcm(B)``, so that their
gradients are taken in those variables (:func:`gradient_loads`).
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

__all__ = ["gradient_loads", "restoring_energy", "coupled_energy", "split_loads"]


def _rotation_energy(K_rr, R):
    r""":math:`\tfrac12\mathrm{tr}(K'(I - R))`, :math:`K' = \mathrm{tr}(C)I - 2C`.

    The potential whose torque is :math:`-\mathrm{vee}(\mathrm{skew}(R K'))`:
    :math:`-C\theta` to first order, and exactly the moment
    :math:`-C\,\sin\varphi\,n` of :class:`~kanedyn.MatrixSpringDamper` for rotations
    about one axis of ``C``'s principal axes (planar motions).
    """
    C = np.asarray(K_rr, float)
    Kp = np.trace(C) * np.eye(3) - 2 * C
    return sm.Add(*[sm.Float(Kp[i, j]) * ((1 if i == j else 0) - R[j, i])
                    for i in range(3) for j in range(3) if Kp[i, j] != 0]) / 2


def restoring_energy(K, d, R):
    """Potential (J) of a 6 x 6 matrix spring without translation-rotation coupling.

    Parameters
    ----------
    K : array_like, shape (6, 6)
        Stiffness, N/m, N m/rad blocks (the coupling blocks are ignored).
    d : sequence of 3 sympy.Expr
        The displacement, ``N`` components, m.
    R : sympy.Matrix, shape (3, 3)
        ``N.dcm(B)``: the body frame's unit vectors in ``N`` components, columns.
    """
    K = np.asarray(K, float)
    trans = sm.Add(*[sm.Float(K[i, j]) * d[i] * d[j] / 2 for i in range(3)
                     for j in range(3) if K[i, j] != 0])
    return trans + _rotation_energy(K[3:, 3:], R)


def coupled_energy(K, d, R):
    r"""Potential (J) of the linear mooring: diagonal blocks exactly, the coupling symmetrized.

    The coupling term :math:`d^T\bar K_{tr}\theta` (:math:`\bar K` the symmetric
    part, :math:`\theta = \tfrac12\mathrm{vee}(R - R^T)`) is the potential of
    the published element's loads to first order in the rotation only.
    ``K``, ``d``, ``R`` as in :func:`restoring_energy`.
    """
    K = np.array(np.asarray(K, dtype=float))
    Ks = (K + K.T) / 2
    Kd = Ks.copy()
    Kd[:3, 3:] = Kd[3:, :3] = 0
    theta = [(R[2, 1] - R[1, 2]) / 2, (R[0, 2] - R[2, 0]) / 2, (R[1, 0] - R[0, 1]) / 2]
    coupling = sm.Add(*[sm.Float(Ks[i, 3 + j]) * d[i] * theta[j] for i in range(3)
                        for j in range(3) if Ks[i, 3 + j] != 0])
    return restoring_energy(Kd, d, R) + coupling


def gradient_loads(energy, P, O, B, N):
    r"""The force at ``P`` and torque on ``B`` whose power is exactly :math:`-\dot V`.

    With :math:`V = V(d, R)` (:math:`d` = ``P.pos_from(O)`` in ``N``
    components, :math:`R` = ``N.dcm(B)``), :math:`\dot R = [\omega]_\times R`
    gives :math:`\dot V = \partial_d V\cdot\dot d + \omega\cdot
    \mathrm{vee}(A^T - A)`, :math:`A = R\,(\partial_R V)^T`; the loads are

    .. math:: F = -\partial_d V,\qquad M = \mathrm{vee}(A - A^T).

    Parameters
    ----------
    energy : callable
        ``energy(d, R) -> sympy.Expr``, J; ``d`` three expressions (m),
        ``R`` a 3 x 3 matrix.
    P, O : sympy.physics.mechanics.Point
        The body's point and its reference, fixed in ``N``.
    B, N : sympy.physics.mechanics.ReferenceFrame
        The body's frame and the inertial frame.

    Returns
    -------
    loads : list
        ``[(P, force), (B, torque)]``, N and N m.
    energy : sympy.Expr
        :math:`V` in the model's coordinates, J.
    """
    d_sym = sm.symbols("d_0:3", cls=sm.Dummy)
    R_sym = sm.Matrix(3, 3, sm.symbols("R_0:9", cls=sm.Dummy))
    V = energy(list(d_sym), R_sym)
    d = P.pos_from(O)
    actual = {s: d.dot(e) for s, e in zip(d_sym, (N.x, N.y, N.z))}
    R = N.dcm(B)
    actual.update({R_sym[i, j]: R[i, j] for i in range(3) for j in range(3)})
    G = R_sym.applyfunc(lambda r: V.diff(r))
    A = (R_sym * G.T).xreplace(actual)
    force = [-V.diff(s).xreplace(actual) for s in d_sym]
    torque = [A[2, 1] - A[1, 2], A[0, 2] - A[2, 0], A[1, 0] - A[0, 1]]
    e = (N.x, N.y, N.z)
    return ([(P, sum((f * ei for f, ei in zip(force, e)), me.Vector(0))),
             (B, sum((m * ei for m, ei in zip(torque, e)), me.Vector(0)))],
            V.xreplace(actual))


def split_loads(published, held):
    """The published element's loads less ``held`` (matched by point or frame).

    Parameters
    ----------
    published, held : list of (Point or ReferenceFrame, Vector)

    Returns
    -------
    list of (Point or ReferenceFrame, Vector)
        One load per point or frame of ``published`` or ``held``, in order of
        first appearance.
    """
    where, total = [], {}
    for sign, loads in ((1, published), (-1, held)):
        for location, vector in loads:
            if location not in total:
                where.append(location)
                total[location] = me.Vector(0)
            total[location] += sign * vector
    return [(location, total[location]) for location in where]
