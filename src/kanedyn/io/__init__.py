"""Input and output: the 3D animation as one HTML file.

``_viewer``   the scene: poses of bodies, shapes, surfaces, flexible members and
              traced points at every frame, from the model's own kinematics
``_meshes``   STL and OBJ files read into triangle meshes
``_page``     the self-contained page (three.js inlined from ``_vendor/three``)
              and :func:`animate`
"""

from ._meshes import read_mesh, read_obj, read_stl
from ._page import animate, page_html
from ._viewer import DEFAULT_MAX_FRAMES, PALETTE, quaternions, scene_data

__all__ = ["animate", "page_html", "scene_data", "quaternions", "read_mesh", "read_obj",
           "read_stl", "PALETTE", "DEFAULT_MAX_FRAMES"]
