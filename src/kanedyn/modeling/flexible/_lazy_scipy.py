"""SciPy modules imported on first use (``import kanedyn`` and models without
flexible bodies do not pay for ``scipy.sparse``, ``scipy.linalg``, ``scipy.io``)."""

from __future__ import annotations

import importlib

__all__ = ["LazyModule", "sp", "spla", "sla", "sio"]


class LazyModule:
    """Stands for the module ``name``; imports it when an attribute is first read."""

    def __init__(self, name):
        self._name = name

    def __getattr__(self, attr):
        module = importlib.import_module(self._name)
        return getattr(module, attr)

    def __repr__(self):
        return f"<module {self._name} (imported on first use)>"


sp = LazyModule("scipy.sparse")
spla = LazyModule("scipy.sparse.linalg")
sla = LazyModule("scipy.linalg")
sio = LazyModule("scipy.io")
