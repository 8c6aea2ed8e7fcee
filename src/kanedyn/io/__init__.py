"""Reading and writing: saved equations of motion (phase 9: also URDF, the viewer).

Modules
-------
_saved
    ``eom.save(path)`` and :func:`load`: equations of motion in a zip of JSON
    whose SymPy expressions are stored as trees (nothing is evaluated on
    loading).
"""

from ._saved import SavedFileError, load, save_equations

__all__ = ["load", "save_equations", "SavedFileError"]
