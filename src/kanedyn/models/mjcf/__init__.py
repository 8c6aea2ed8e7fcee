"""MJCF (MuJoCo XML) import: ``kd.models.from_mjcf(path)``.

Modules, in the order the data flows:

``_xml``      the XML read safely (no entities), with file and line of every element;
              ``<include>`` files expanded; numbers read strictly
``_frames``   MJCF orientations (quat, axisangle, euler, xyaxes, zaxis) as matrices
``_parse``    compiler and option settings, default classes, the body tree with its
              joints, geoms, sites and inertials, actuators, equality constraints
``_meshes``   mesh assets: their triangles (STL, OBJ, .msh, inline) and their volume,
              mass centre and inertia in MuJoCo's inertia modes
``_inertia``  masses and inertias of bodies, inferred from geoms as MuJoCo does
``_actuation`` tendons (fixed, and spatial through sites) and actuators, with their
              activations as first-order states
``_build``    the :class:`~kanedyn.models.ModelDefinition`: coordinates, bodies,
              passive forces, fluid forces, loop-closure constraints; geoms and
              sites as data
``_ground``   the geoms that may touch a ground plane (``from_mjcf(ground=...)``)
``_shapes``   viewer shapes of the geoms (``MJCFDefinition.shapes``)
"""

from ._build import (MJCFActuator, MJCFDefinition, MJCFGeom, MJCFJoint, MJCFSite,
                     euler_angles, from_mjcf)
from ._xml import MJCFError

__all__ = ["from_mjcf", "MJCFDefinition", "MJCFError", "MJCFJoint", "MJCFActuator",
           "MJCFSite", "MJCFGeom", "euler_angles"]
