"""Names of a package imported when first used (a module-level ``__getattr__``)."""

import importlib

__all__ = ["lazy_attributes"]


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
