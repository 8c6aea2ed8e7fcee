"""Names of a package imported when first used (a module-level ``__getattr__``),
old spellings of names that moved to another module, and, for a name that a
public namespace lacks, the namespace that has it."""

import importlib
import sys
import warnings

__all__ = ["lazy_attributes", "NAMESPACES"]

#: the public namespaces (``kd`` and the modules of ``kd.__all__``), searched in this
#: order for a public name that one of them lacks (``kd.offshore.HalfSinePulse``:
#: "it is kanedyn.vehicle.HalfSinePulse"); all but the last two load their names on
#: first use, so only a name found in none of them imports NumPy and SymPy
NAMESPACES = ("kanedyn", "kanedyn.models", "kanedyn.offshore", "kanedyn.vehicle",
              "kanedyn.flexible", "kanedyn.studies", "kanedyn.schemes", "kanedyn.visuals")


def lazy_attributes(package, table, namespace, names, moved=None, neighbours=()):
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
    neighbours : sequence of str, optional
        Modules (absolute names, e.g. :data:`NAMESPACES`) whose ``__all__`` is
        searched for a public name this module lacks: the AttributeError then
        names where it is.

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
        raise AttributeError(f"module {package!r} has no attribute {name!r}"
                             + _elsewhere(package, name, neighbours),
                             name=name, obj=sys.modules.get(package))

    def __dir__():
        return sorted(set(names) | {n for n in namespace if n.startswith("__")
                                    and n.endswith("__")})

    return __getattr__, __dir__


def _elsewhere(package, name, neighbours):
    """``"; it is <module>.<name>"`` for the first of ``neighbours`` that exports
    ``name`` (a public name: private ones are never looked for), else ``""``."""
    if name.startswith("_"):
        return ""
    for other in neighbours:
        if other != package and name in getattr(importlib.import_module(other), "__all__", ()):
            return f"; it is {other}.{name}"
    return ""
