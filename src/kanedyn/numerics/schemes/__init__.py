r"""How a numerical model turns its equations into accelerations: constraint schemes.

Every formulation evaluates the same terms at a state: the unreduced mass
matrix :math:`M` (o x o) and forcing :math:`f`, and the constraints at the
acceleration level, :math:`K\dot u + f_a = 0` (m rows).  With the constraint
forces :math:`K^T\lambda` the equations are the index-1 system

.. math::

    M\dot u = f + K^T\lambda,\qquad K\dot u + f_a = 0 .

The schemes below differ in how they solve it and in what they do about the
drift of the position- and velocity-level constraints :math:`h(q) = 0`,
:math:`c(q, u) = 0` that the integration leaves:

=============================  =====================================================
``Elimination``                dependent speeds eliminated with a fixed partition
                               (Kane's method); drift projected onto the constraints
                               by solving for the dependent variables
``IndexOne``                   the index-1 system solved for :math:`\dot u, \lambda`
                               together; no stabilization
``Baumgarte``                  index 1 with :math:`K\dot u + f_a = -2\alpha c -
                               \beta^2 P^+ h` (Baumgarte 1972)
``Projection``                 index 1; drift removed by projecting the state onto
                               the constraints (least change of all coordinates,
                               mass-weighted change of all speeds)
``Penalty``                    :math:`(M + \alpha K^TK)\dot u = f - \alpha K^T(f_a +
                               2\xi\omega c + \omega^2 P^+h)` (Bayo et al. 1988)
``AugmentedLagrangian``        the penalty system iterated on :math:`\lambda`
                               until the constraints hold (Bayo & Ledesma 1996)
``UdwadiaKalaba``              :math:`\dot u = a + M^{-1/2}(KM^{-1/2})^+(b - Ka)`,
                               :math:`a = M^{-1}f` (Udwadia & Kalaba 1992)
``Partitioning``               independent and dependent variables chosen at every
                               evaluation by pivoted QR of the constraint Jacobian
                               (Wehage & Haug 1982); dependent ones solved from the
                               independent ones after drift
``NullSpace``                  Maggi's equations: :math:`N^TMN z = N^T(f - M\dot
                               u_p)` with an orthonormal basis :math:`N` of the null
                               space of :math:`K`
``AugmentedLagrangianIndex3``  index-3 augmented Lagrangian with mass-orthogonal
                               projections, trapezoidal rule with a fixed step
                               (Bayo & Ledesma 1996): its own integrator, which
                               passes singular configurations (see
                               :mod:`kanedyn.simulation._index3`)
=============================  =====================================================

:math:`P^+h` maps the configuration-constraint residual onto the velocity
constraint rows (:math:`\dot h = P c` on the constraint manifold); see
:func:`stabilization`.

A scheme is a small frozen object: ``formulate(..., method="lagrange-baumgarte")``
picks one by name, ``eom.numeric(scheme=kd.schemes.Baumgarte(alpha=20.0))``
chooses another for the same equations.  Its ``acceleration_system()`` (an
:class:`AccelerationSystem`: stabilization gains, penalty factor) states the
equations its accelerations satisfy, from which
:meth:`kanedyn.NumericModel.jacobians` differentiates them.
"""

from ..._errors import ModelError
from ._base import (AccelerationSystem, Scheme, al_solve, complement_solve, kkt_solve,
                    penalty_weight, rate_matrix, stabilization)
from ._elimination import Elimination
from ._index_one import Baumgarte, IndexOne, Projection
from ._orthogonal_complement import OrthogonalComplement
from ._partitioning import NullSpace, Partitioning
from ._penalty import AugmentedLagrangian, AugmentedLagrangianIndex3, Penalty
from ._udwadia_kalaba import UdwadiaKalaba

__all__ = ["Scheme", "Elimination", "IndexOne", "Baumgarte", "Projection", "Penalty",
           "AugmentedLagrangian", "AugmentedLagrangianIndex3", "UdwadiaKalaba", "Partitioning",
           "NullSpace", "OrthogonalComplement", "SCHEMES", "as_scheme", "stabilization",
           "complement_solve", "al_solve", "kkt_solve", "penalty_weight", "AccelerationSystem",
           "rate_matrix"]

#: name -> scheme class
SCHEMES = {cls.name: cls for cls in (Elimination, IndexOne, Baumgarte, Projection,
                                     Penalty, AugmentedLagrangian, UdwadiaKalaba,
                                     Partitioning, NullSpace, AugmentedLagrangianIndex3,
                                     OrthogonalComplement)}


def as_scheme(scheme):
    """A :class:`Scheme` from an instance or a name of :data:`SCHEMES`."""
    if isinstance(scheme, Scheme):
        return scheme
    try:
        return SCHEMES[scheme]()
    except (KeyError, TypeError):
        raise ModelError(f"unknown constraint scheme {scheme!r}; available: "
                         f"{', '.join(SCHEMES)}") from None
