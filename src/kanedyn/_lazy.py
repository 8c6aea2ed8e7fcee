"""Names of a package imported when first used (a module-level ``__getattr__``),
and old spellings of names that moved to another module."""

import importlib
import warnings

__all__ = ["lazy_attributes"]


def lazy_attributes(package, table, namespace, names, moved=None):
    """``__getattr__`` and ``__dir__`` for a package whose names load on first use.

    Parameters
    ----------
    package : str
        The module's ``__name__`` (a package's, or a module's such as
        ``kanedyn.offshore``).
    table : mapping
        ``{public name: module}``, the module relative to the package that holds
        the module (``"._base"``, or ``".modeling.offshore"`` from
        ``kanedyn/offshore.py``), or ``"."`` for a subpackage of that name.
    namespace : dict
        The module's ``globals()``: a loaded name is stored there, so later
        lookups do not come back here.
    names : sequence of str
        The module's ``__all__``: what ``dir()`` lists, with the dunder names.
    moved : mapping, optional
        ``{old name: module}`` of names of this package that now live in one of
        its modules (``{"AiryWave": "offshore"}``: the package's ``AiryWave`` is
        ``kanedyn.offshore.AiryWave``).  The old spelling still gives the same
        object; its first use warns, once per name, with a ``DeprecationWarning``
        attributed to the caller's line that names the new spelling.  It is never
        stored in ``namespace`` (each use comes back here), so ``dir()`` does
        not list it.

    Returns
    -------
    (callable, callable)
        The module's ``__getattr__`` and ``__dir__``.
    """
    anchor = namespace.get("__package__") or package
    moved = dict(moved or {})
    warned = set()

    def __getattr__(name):
        module = table.get(name)
        if module is not None:
            if module == ".":
                value = importlib.import_module(f".{name}", anchor)
            else:
                value = getattr(importlib.import_module(module, anchor), name)
            namespace[name] = value
            return value
        if name in moved:
            home = importlib.import_module(f".{moved[name]}", anchor)
            value = getattr(home, name)
            if name not in warned:
                # stacklevel 2: the caller's line, so that Python shows it where a
                # user's script or notebook runs it, and pytest's filter
                # "error::DeprecationWarning:kanedyn.*" fails kanedyn's own uses
                short = home.__name__.replace(package, "kd", 1)
                warnings.warn(f"{package}.{name} has moved to {home.__name__}.{name} "
                              f"({short}.{name}); the old spelling is deprecated",
                              DeprecationWarning, stacklevel=2)
                warned.add(name)     # after the warning: one made an error warns again
            return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        return sorted(set(names) | {n for n in namespace if n.startswith("__")
                                    and n.endswith("__")})

    return __getattr__, __dir__
