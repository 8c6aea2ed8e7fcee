"""Shapes that draw bodies in the 3D animation (:meth:`SimulationResult.animate`).

``kd.visuals.Box``, ``Cylinder``, ``Sphere`` and ``Mesh`` (STL or OBJ file)
attach to a body; see :mod:`kanedyn.modeling.visuals` and ``docs/viewer.md``.
"""

from .modeling.visuals import Box, Cylinder, Mesh, Shape, Sphere

__all__ = ["Shape", "Box", "Cylinder", "Sphere", "Mesh"]
