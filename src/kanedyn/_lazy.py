"""Names of a package imported when first used (a module-level ``__getattr__``),
and SymPy's unit system loaded when first used."""

import importlib
import importlib.machinery
import sys
import threading
import types

__all__ = ["defer_sympy_units", "lazy_attributes"]


def lazy_attributes(package, table, namespace, names):
    """``__getattr__`` and ``__dir__`` for a package whose names load on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    table : mapping
        ``{public name: module}``, the module relative to ``package``
        (``"._base"``), or ``"."`` for a subpackage of that name.
    namespace : dict
        The package's ``globals()``: a loaded name is stored there, so later
        lookups do not come back here.
    names : sequence of str
        The package's ``__all__``.

    Returns
    -------
    (callable, callable)
        The package's ``__getattr__`` and ``__dir__``.
    """

    def __getattr__(name):
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        if module == ".":
            value = importlib.import_module(f".{name}", package)
        else:
            value = getattr(importlib.import_module(module, package), name)
        namespace[name] = value
        return value

    def __dir__():
        return sorted(set(namespace) | set(names))

    return __getattr__, __dir__


class _LoadedOnUse(types.ModuleType):
    """A module executed when one of its attributes is first read.

    Like :class:`importlib.util.LazyLoader`'s modules, but safe under threads
    on Python 3.11 (another thread waits for the module to finish instead of
    seeing it half-made); reads by the loading thread itself, while the
    module executes, see the module as it stands."""

    def __getattribute__(self, name):
        with _LOADING_LOCK:
            if type(self) is _LoadedOnUse and not _LOADING:
                _LOADING.append(self)
                try:
                    spec = types.ModuleType.__getattribute__(self, "__spec__")
                    spec.loader.exec_module(self)
                    self.__class__ = types.ModuleType
                finally:
                    _LOADING.clear()
        return types.ModuleType.__getattribute__(self, name)


_LOADING_LOCK = threading.RLock()
_LOADING = []  # the module being executed (one at a time, under the lock)


class _DeferredLoader:
    """Loader of a module whose execution waits for its first use
    (:class:`_LoadedOnUse`); the module's spec keeps the real loader."""

    def __init__(self, loader):
        self.loader = loader

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module):
        module.__spec__.loader = module.__loader__ = self.loader
        module.__class__ = _LoadedOnUse


class _SymPyUnitsFinder:
    """Finder of ``sympy.physics.units`` whose module executes on first use.

    ``sympy.physics`` imports its unit system (0.1-0.2 s, a third of SymPy's
    own import) whenever any of its subpackages is imported; kanedyn's models
    use ``sympy.physics.mechanics`` and never units.  The module this finder
    makes is SymPy's own, executed the first time one of its attributes is
    read (``import sympy.physics.units`` and ``from sympy.physics.units
    import ...`` read one at once).  It acts once and leaves ``sys.meta_path``.
    """

    NAME = "sympy.physics.units"

    @classmethod
    def find_spec(cls, name, path=None, target=None):
        if name != cls.NAME:
            return None
        cls.remove()
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is None or not hasattr(spec.loader, "exec_module"):
            return spec
        spec.loader = _DeferredLoader(spec.loader)
        return spec

    @classmethod
    def remove(cls):
        if cls in sys.meta_path:
            sys.meta_path.remove(cls)


def defer_sympy_units():
    """Execute ``sympy.physics.units`` when first used rather than with
    ``sympy.physics`` (see :class:`_SymPyUnitsFinder`); nothing when SymPy's
    physics is imported already."""
    if "sympy.physics" not in sys.modules and _SymPyUnitsFinder not in sys.meta_path:
        sys.meta_path.insert(0, _SymPyUnitsFinder)
