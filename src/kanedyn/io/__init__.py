"""Input and output: the 3D animation as one HTML file, saved equations of motion.

``_viewer``   the scene: poses of bodies, shapes, surfaces, flexible members and
              traced points at every frame, from the model's own kinematics
``_up``       which direction is drawn upwards: the user's, the model's gravity or
              its weights
``_meshes``   STL and OBJ files read into triangle meshes
``_page``     the self-contained page (three.js inlined from ``_vendor/three``)
              and :func:`animate`; the viewer's script is ``_viewer.js`` (the scene,
              shared) and ``_viewer_page.js`` or ``_viewer_widget.js`` (the start)
``_widget``   the animation as a live notebook widget (anywidget): :func:`widget`
``_interact`` sliders over a model's constants that re-run it and redraw the
              widget: :func:`interact`
``_saved``    ``eom.save(path)`` and :func:`load`: equations of motion in a zip of
              JSON whose SymPy expressions are stored as trees; reading runs
              nothing from the file and is bounded in size and time
``_saved_sympy``  the SymPy classes a saved file may name, each rebuilt on
              arguments checked by kind without computing
``_saved_schema`` the other objects a saved file may hold: per class, its
              attributes and their types (or its constructor's fields)
``fmu/``      FMU export (FMI 2.0 or 3.0, model exchange and co-simulation) from the
              standalone C export: :func:`export_fmu`
"""

from .._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module (in this package) that defines it; imported on first use
_LAZY = {"read_mesh": "._meshes", "read_obj": "._meshes", "read_stl": "._meshes",
         "animate": "._page", "page_html": "._page", "widget": "._widget",
         "interact": "._interact", "Interactive": "._interact",
         "SavedFileError": "._saved", "load": "._saved", "load_data": "._saved",
         "save_data": "._saved", "save_equations": "._saved", "SAVED_FILE_LIMITS": "._saved",
         "DEFAULT_MAX_FRAMES": "._viewer", "PALETTE": "._viewer",
         "quaternions": "._viewer", "scene_data": "._viewer", "up_direction": "._up",
         "export_fmu": ".fmu"}

__all__ = ["animate", "page_html", "widget", "interact", "Interactive", "scene_data",
           "up_direction", "quaternions", "read_mesh", "read_obj", "read_stl", "PALETTE",
           "DEFAULT_MAX_FRAMES", "load", "save_equations", "SavedFileError", "save_data",
           "load_data", "SAVED_FILE_LIMITS", "export_fmu"]

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__)
