"""Shapes that draw bodies in the 3D animation (:meth:`SimulationResult.animate`).

``kd.visuals.Box``, ``Cylinder``, ``Sphere`` and ``Mesh`` (STL or OBJ file)
attach to a body; see :mod:`kanedyn.modeling.visuals` and ``docs/viewer.md``.
"""

from ._lazy import NAMESPACES as _NAMESPACES
from ._lazy import lazy_attributes as _lazy_attributes
from .modeling.visuals import Box, Cylinder, Mesh, Shape, Sphere

__all__ = ["Shape", "Box", "Cylinder", "Sphere", "Mesh"]

# every name is loaded above; a missing one is named where it is
__getattr__, __dir__ = _lazy_attributes(__name__, {}, globals(), __all__,
                                        neighbours=_NAMESPACES)
