"""The model definition shared by all built-in models."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sm

from .._errors import ModelError
from ..engine import name_of

__all__ = ["ModelDefinition", "DERIVE_STATS"]

#: what this process did (read by tests): ``derivations``, models derived
DERIVE_STATS = {"derivations": 0}


@dataclass(frozen=True)
class ModelDefinition:
    """A ready-to-derive model: SymPy objects, parameter values, initial state.

    Every call of a model builder creates fresh SymPy objects, so two
    definitions never share cached velocities.

    Attributes
    ----------
    name : str
        Registry name (``kanedyn list``).
    title : str
        One-line description.
    kane_args : dict
        Keyword arguments of :func:`kanedyn.kane`.
    constants : dict
        ``{Symbol: value}`` default parameters (SI units).
    initial_state : dict
        ``{dynamic symbol: value}`` for the independent coordinates and
        speeds (dependent ones are completed from the constraints), plus
        starting guesses for dependent coordinates.
    t_end : float
        Default simulation length, s.
    specified : dict
        Values for specified inputs (numbers, SymPy expressions in t, callables).
    symbols : dict
        Named handles to symbols and objects (for tests and examples).
    description : str
        Longer text: what the model is and what it validates.
    units : dict
        ``{coordinate or speed: unit}`` for those whose unit the kinematics do
        not tell (see :func:`kanedyn.modeling.state_units`); plots label their
        axes with them.
    shape_specs : tuple
        Shapes that draw the bodies in the 3D viewer, as data:
        ``(kind, body, {option: value})`` with ``kind`` one of ``"Box"``,
        ``"Cylinder"``, ``"Sphere"``, ``"Mesh"`` (:mod:`kanedyn.visuals`) and
        option values numbers or SymPy expressions in the constants; see
        :meth:`shapes`.
    constant_units : dict
        ``{Symbol: unit text}`` of constants whose unit is declared (shown by
        ``kanedyn list MODEL``); the others are in SI units too.
    actuators : tuple
        The model's declared actuators (:class:`~kanedyn.JointActuator`,
        :class:`~kanedyn.LinearActuator`, with their transmissions), built on
        the definition's own symbols, points and frames; not among its loads.
        ``kd.ActuatorMap(model, definition.actuators)`` gives the actuator
        forces of a motion.  Empty when the model declares none.
    body_groups : dict
        ``{group name: tuple of body names}``: bodies grouped for reports
        (e.g. ``platform``, ``struts``, ``carriages``); empty when none.
    report : callable or None
        ``report(result, definition) -> object``: a model-specific report of a
        run (e.g. the seat-belt sensor's lock times), with ``text()`` (one
        line) and ``as_dict()`` (JSON-ready); ``kanedyn run`` prints it and
        writes it to ``summary.json`` under ``"report"``.  None: no report.
    """

    name: str
    title: str
    kane_args: dict
    constants: dict
    initial_state: dict
    t_end: float
    specified: dict = field(default_factory=dict)
    symbols: dict = field(default_factory=dict)
    description: str = ""
    units: dict = field(default_factory=dict)
    shape_specs: tuple = ()
    constant_units: dict = field(default_factory=dict)
    actuators: tuple = ()
    body_groups: dict = field(default_factory=dict)
    report: object = None

    def derive(self, progress=False, method="kane"):
        """Equations of motion (:func:`kanedyn.formulate`), labelled with the
        model's name, title and declared units."""
        from ..formulations import formulate
        DERIVE_STATS["derivations"] += 1
        eom = formulate(method=method, progress=progress, **self.kane_args)
        return eom._label(name=self.name, title=self.title, units=self.units or None)

    def numeric(self, eom=None, constants=None, specified=None, **options):
        """Numerical model with the default constants, updated by ``constants``.

        A built-in model (from :func:`kanedyn.models.build`) with the C backend
        and no ``eom`` or ``specified`` given is kept in a derivation cache
        beside the compiled modules, keyed by its name and options: a second
        process (or a second call) with the same model skips the derivation
        and the code generation; new ``constants`` are run-time values
        (:meth:`NumericModel.with_constants`), never a new derivation or build.
        The symbolic equations of a model from the cache are derived again
        only when they are asked for (linearization, pickling).
        """
        if eom is None and specified is None:
            cached = _derivation_cache(self, constants, options)
            if cached is not None:
                return cached
        eom = eom if eom is not None else self.derive()
        if eom.name is None:
            eom._label(name=self.name, title=self.title, units=self.units or None)
        values = dict(self.constants)
        values.update(self._constant_overrides(constants or {}))
        inputs = dict(self.specified)
        inputs.update(specified or {})
        return eom.numeric(constants=values, specified=inputs, **options)

    def _constant_overrides(self, overrides):
        out = {}
        by_name = {str(s): s for s in self.constants}
        for key, value in overrides.items():
            sym = by_name.get(key) if isinstance(key, str) else key
            if sym not in self.constants:
                raise ModelError(f"{key} is not a parameter of model {self.name}; "
                                 f"parameters: {', '.join(sorted(by_name))}")
            out[sym] = value
        return out

    def shapes(self, constants=None):
        """Shapes drawing the bodies in the 3D viewer (``res.animate(visuals=...)``).

        Parameters
        ----------
        constants : dict, optional
            ``{Symbol or name: value}`` overriding the default constants (the
            same as for :meth:`numeric`), so that sizes follow the parameters.

        Returns
        -------
        list of kanedyn.visuals.Shape
            Empty when the model declares none (the viewer then draws its
            default shapes).
        """
        from ..modeling import visuals
        values = dict(self.constants)
        values.update(self._constant_overrides(constants or {}))
        out = []
        for kind, body, options in self.shape_specs:
            opts = {}
            for key, value in options.items():
                if isinstance(value, sm.Basic):
                    number = sm.sympify(value.xreplace(values))
                    if not number.is_number:
                        raise ModelError(f"model {self.name}: {kind} of body {body.name}: "
                                         f"{key} = {value} depends on more than constants")
                    value = float(number)
                opts[key] = value
            out.append(getattr(visuals, kind)(body, **opts))
        return out

    def initial(self, model, overrides=None):
        """Initial state array for ``model`` (independent values as given)."""
        y = np.zeros(model.n_states)
        values = dict(self.initial_state)
        for key, value in (overrides or {}).items():
            values[key] = value
        for key, value in values.items():
            y[model.index(key if isinstance(key, str) else name_of(key))] = float(value)
        return y

    def parameter_table(self):
        """``[(name, value)]`` of the default constants, sorted by name."""
        return sorted(((str(k), v) for k, v in self.constants.items()), key=lambda x: x[0])


def gravity_potential(masses_heights):
    """Sum of ``m * g * h`` terms (helper for model potentials)."""
    return sm.Add(*[m * g * h for m, g, h in masses_heights])


# --------------------------------------------------------------- derivation cache
_SOURCE_STAMP = []  # this process's stamp of kanedyn's own source files


def _source_stamp():
    """Digest of the names, sizes and modification times of kanedyn's sources
    (a changed model or code generator is a new cache entry)."""
    if not _SOURCE_STAMP:
        import hashlib
        from pathlib import Path
        root = Path(__file__).resolve().parents[1]
        digest = hashlib.sha256()
        for path in sorted(root.rglob("*.py")):
            stat = path.stat()
            digest.update(f"{path.relative_to(root)}:{stat.st_size}:{stat.st_mtime_ns}\n"
                          .encode())
        _SOURCE_STAMP.append(digest.hexdigest())
    return _SOURCE_STAMP[0]


def _derivation_cache(definition, constants, options):
    """The numerical model from the derivation cache (built and stored on a miss),
    or ``None`` when the model or its options are not cacheable."""
    origin = getattr(definition, "_origin", None)
    if origin is None or options.get("backend") != "c" or set(options) - {"backend"}:
        return None
    overrides = definition._constant_overrides(constants or {})
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool)
               for v in overrides.values()):
        return None
    import hashlib
    import pickle
    import sys

    from .. import _version
    from ..numerics import cache_dir, compiler_command
    if compiler_command() is None:
        return None
    key = hashlib.sha256(repr((origin, _version.__version__, sys.version, sm.__version__,
                               np.__version__, _source_stamp())).encode()).hexdigest()[:24]
    path = cache_dir() / "derived" / f"{key}.pkl"

    def derive_again():
        return definition.numeric(definition.derive(), **options)

    model = None
    try:
        # the cache directory is the user's own, like the compiled modules in it
        model = pickle.loads(path.read_bytes())  # noqa: S301
        model._rederive = derive_again
    except Exception:  # noqa: BLE001  missing, stale or unreadable: derive it
        model = None
    if model is None:
        model = definition.numeric(definition.derive(), **options)
        _store(path, model)
    if overrides:
        model = model.with_constants({str(k): float(v) for k, v in overrides.items()})
    return model


def _store(path, model):
    """Write ``model`` (without its C source: its module is in the cache) atomically."""
    import os
    import pickle
    import tempfile
    data = dict(model._data)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path.parent, delete=False) as handle:
            pickle.dump(_Cached(data), handle)
        os.replace(handle.name, path)
    except (OSError, pickle.PicklingError, TypeError, AttributeError):
        pass  # a cache that cannot be written only costs time


class _Cached:
    """A numerical model's data, rebuilt into the model on unpickling."""

    def __init__(self, data):
        self.data = data

    def __reduce__(self):
        return (_rebuild, (self.data,))


def _rebuild(data):
    from ..numerics import NumericModel
    model = NumericModel.__new__(NumericModel)
    model._data = data
    model._compile()
    return model
