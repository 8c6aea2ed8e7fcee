"""Constraint schemes: how equations with constraints become accelerations.

See :mod:`kanedyn.numerics.schemes` for the equations of each scheme; pick one
by name in :func:`kanedyn.formulate` (``method="lagrange-baumgarte"``, ...) or
pass an instance to ``eom.numeric(scheme=...)``.
"""

from ._lazy import NAMESPACES as _NAMESPACES
from ._lazy import lazy_attributes as _lazy_attributes
from .numerics.schemes import (SCHEMES, AccelerationSystem, AugmentedLagrangian,
                               AugmentedLagrangianIndex3, Baumgarte, Elimination, IndexOne,
                               NullSpace, OrthogonalComplement, Partitioning, Penalty,
                               Projection, Scheme, UdwadiaKalaba, as_scheme, stabilization)

__all__ = ["Scheme", "Elimination", "IndexOne", "Baumgarte", "Projection", "Penalty",
           "AugmentedLagrangian", "UdwadiaKalaba", "Partitioning", "NullSpace",
           "AugmentedLagrangianIndex3", "OrthogonalComplement", "SCHEMES", "as_scheme",
           "stabilization", "AccelerationSystem"]

# every name is loaded above; a missing one is named where it is
__getattr__, __dir__ = _lazy_attributes(__name__, {}, globals(), __all__,
                                        neighbours=_NAMESPACES)
