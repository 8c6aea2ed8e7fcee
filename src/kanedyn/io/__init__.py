"""Input and output: the 3D animation as one HTML file, saved equations of motion.

``_viewer``   the scene: poses of bodies, shapes, surfaces, flexible members and
              traced points at every frame, from the model's own kinematics
``_meshes``   STL and OBJ files read into triangle meshes
``_page``     the self-contained page (three.js inlined from ``_vendor/three``)
              and :func:`animate`
``_saved``    ``eom.save(path)`` and :func:`load`: equations of motion in a zip of
              JSON whose SymPy expressions are stored as trees (nothing is
              evaluated on loading)
"""

from ._meshes import read_mesh, read_obj, read_stl
from ._page import animate, page_html
from ._saved import SavedFileError, load, load_data, save_data, save_equations
from ._viewer import DEFAULT_MAX_FRAMES, PALETTE, quaternions, scene_data

__all__ = ["animate", "page_html", "scene_data", "quaternions", "read_mesh", "read_obj",
           "read_stl", "PALETTE", "DEFAULT_MAX_FRAMES", "load", "save_equations",
           "SavedFileError", "save_data", "load_data"]
