"""A built-in model's definition that is built when first needed.

:func:`kanedyn.models.build` returns a :class:`PendingDefinition` when the
model's compiled numerical model is in the derivation cache: a
:class:`~kanedyn.models.ModelDefinition` whose fields (SymPy objects and all)
are filled by its builder the first time one of them is read, so that a
second process asking for ``build(name).numeric(backend="c")`` imports no
SymPy.
"""

from __future__ import annotations

import threading
from dataclasses import fields

import numpy as np

from ._base import DeriveAgain, ModelDefinition, _cache_path, _cacheable, _read_cache

__all__ = ["PendingDefinition", "build_now"]

#: the names of a ModelDefinition's fields (reading one builds the definition)
_FIELDS = frozenset(f.name for f in fields(ModelDefinition))
#: one definition is filled by one thread (a second would overwrite the first's
#: SymPy objects while it uses them)
_FILLING = threading.RLock()


class PendingDefinition(ModelDefinition):
    """A :class:`ModelDefinition` of a built-in model, built when first needed.

    What :func:`kanedyn.models.build` returns when the model's C numerical
    model (with the same options) is in the derivation cache.  It is a
    :class:`ModelDefinition` (``isinstance`` holds) and behaves as the one
    its builder returns: reading any field (``kane_args``, ``constants``,
    ``symbols``, ...), calling a method that reads one (``derive``,
    ``shapes``, ``repr``, ``dataclasses.replace``, ...) builds the definition
    once, fills this object with its fields, and from then on it is that
    :class:`ModelDefinition` (its class too).  Until then:

    - :meth:`numeric` with the C backend and no ``eom`` or ``specified``
      reads the numerical model from the cache (new ``constants`` by name are
      run-time values) without building anything;
    - :meth:`initial` with overrides by name, ``name`` and ``title`` are read
      from the cache entry once :meth:`numeric` has read it;
    - pickling stores the model's name and options (unpickled:
      ``kanedyn.models.build(name, **options)`` in that process).

    Parameters
    ----------
    name : str
        The registry name (:data:`kanedyn.models.REGISTRY`).
    options : dict
        The model options, already checked against the registry.
    builder : callable
        ``builder(**options) -> ModelDefinition``.
    """

    def __init__(self, name, options, builder):  # noqa: D107  (not the dataclass's)
        setattr_ = object.__setattr__
        setattr_(self, "_registry_name", name)
        setattr_(self, "_options", dict(options))
        setattr_(self, "_builder", builder)
        setattr_(self, "_origin", (name, tuple(sorted(options.items()))))
        setattr_(self, "_light", None)  # from a cache entry: name, title, constants, initial

    def __getattribute__(self, attribute):
        if attribute in _FIELDS:
            light = object.__getattribute__(self, "_light")
            if light is not None and attribute in ("name", "title"):
                return light[attribute]
            return getattr(_filled(self), attribute)
        return object.__getattribute__(self, attribute)

    def __repr__(self):
        return repr(_filled(self))

    def __eq__(self, other):
        return _filled(self) == other

    __hash__ = ModelDefinition.__hash__

    def __reduce__(self):
        return _unpickle, (self._registry_name, self._options)

    def in_cache(self):
        """True when the derivation cache holds this model's C numerical model
        (its options were checked when the entry was written)."""
        key = _cacheable(self._origin, None, {"backend": "c"})
        return key is not None and _cache_path(key).exists()

    def numeric(self, eom=None, constants=None, specified=None, **options):
        """As :meth:`ModelDefinition.numeric`; from the derivation cache without
        building the definition when the model is there."""
        if eom is None and specified is None \
                and all(isinstance(k, str) for k in (constants or {})):
            key = _cacheable(self._origin, constants, options)
            found = _read_cache(key) if key is not None else None
            if found is not None:
                model, light = found
                if set(constants or {}) <= set(light["constants"]):
                    object.__setattr__(self, "_light", light)
                    model._rederive = DeriveAgain(self, options, self._origin)
                    if constants:
                        model = model.with_constants({k: float(v)
                                                      for k, v in constants.items()})
                    return model
        return _filled(self).numeric(eom, constants=constants, specified=specified,
                                    **options)

    def initial(self, model, overrides=None):
        """As :meth:`ModelDefinition.initial`; from the cache entry's initial
        state while the definition is not built."""
        light = self._light
        if light is not None and all(isinstance(k, str) for k in (overrides or {})):
            y = np.zeros(model.n_states)
            values = dict(light["initial"])
            values.update(overrides or {})
            for key, value in values.items():
                y[model.index(key)] = float(value)
            return y
        return _filled(self).initial(model, overrides)


def _filled(definition):
    """``definition``, built if it was a :class:`PendingDefinition`: its
    builder's definition's fields taken, and its class (a method of a
    pending definition that builds it calls this, not a method: the object's
    class changes under it)."""
    with _FILLING:
        if type(definition) is PendingDefinition:
            state = object.__getattribute__(definition, "__dict__")
            built = build_now(state["_registry_name"], state["_options"], state["_builder"])
            state.clear()
            state.update(vars(built))  # its fields, and _origin
            object.__setattr__(definition, "__class__", type(built))
    return definition


def build_now(name, options, builder):
    """``builder(**options)``: the definition of the built-in model ``name``,
    marked as such for the derivation cache."""
    built = builder(**options)
    object.__setattr__(built, "_origin", (name, tuple(sorted(options.items()))))
    return built


def _unpickle(name, options):
    """A pickled :class:`PendingDefinition` in this process: the model built
    again (pending when this process's cache holds it)."""
    from . import build
    return build(name, **options)
