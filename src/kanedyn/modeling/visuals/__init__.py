"""Shapes that draw bodies in the 3D viewer (``kd.visuals``).

``_shapes``   :class:`Box`, :class:`Cylinder`, :class:`Sphere`, :class:`Mesh`
              attached to a body, and their base :class:`Shape`
"""

from ._shapes import Box, Cylinder, Mesh, Shape, Sphere

__all__ = ["Shape", "Box", "Cylinder", "Sphere", "Mesh"]
