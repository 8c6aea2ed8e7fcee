"""Flexible members: finite-element models, their reduction, mode shapes (``kd.flexible``).

What a :class:`kanedyn.FlexibleBody` is made of (the body itself stays at
``kd.FlexibleBody``); ``docs/flexible.md`` describes each::

    BeamMember        a member of 3D beam elements from a table of section properties
    FEMember          a member from mass and stiffness matrices (Matrix Market files)
    NodeMass          a rigid mass attached to a node of a member
    ReducedMember     a member reduced to a few modal coordinates (Craig-Bampton,
                      Guyan, free-free): what a flexible body takes
    plot_mode_shapes  the mode shapes of a reduced member (Matplotlib)

These names were at ``kd.`` before: that spelling still gives the same object,
with a DeprecationWarning naming the new one.
"""

from ._lazy import NAMESPACES as _NAMESPACES
from ._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module that defines it (relative to ``kanedyn``); imported on first use
_LAZY = {
    "BeamMember": ".modeling.flexible",
    "FEMember": ".modeling.flexible",
    "NodeMass": ".modeling.flexible",
    "ReducedMember": ".modeling.flexible",
    "plot_mode_shapes": ".analysis",
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__,
                                        neighbours=_NAMESPACES)
