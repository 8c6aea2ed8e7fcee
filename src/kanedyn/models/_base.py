"""The model definition shared by all built-in models."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field

import numpy as np

from .._errors import ModelError

__all__ = ["ModelDefinition", "DERIVE_STATS", "DeriveAgain"]

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
        option values numbers or SymPy expressions in the constants (an offset a
        tuple of them); see
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
    animation_inputs : dict
        ``{specified symbol: function of t}`` for inputs that the bodies'
        positions need but the equations of motion do not (the seat-belt
        sensor's vehicle displacement: only its accelerations drive the
        model); ``SimulationResult.animate(inputs=...)`` takes them, and
        ``kanedyn run --animate`` passes them.  Empty when none.
    load_names : tuple of str or None
        A name for each load of ``kane_args["loads"]``, in their order, for the
        terms of the energy balance (:func:`kanedyn.analysis.energy_balance`;
        loads that share a name are one term); empty, or an entry ``None``:
        named there by where they act and the symbols they hold.
    potential_loads : tuple of int
        The indices of the loads of ``kane_args["loads"]`` whose work the
        declared ``potential_energy`` holds exactly (weights, springs: each
        load's power is minus the rate of its part of the potential); the
        energy balance leaves them out (counted as work as well, they would be
        counted twice).  Empty: none (every load's work is a term).
    gravity : tuple of 3 float or None
        The gravitational acceleration in the inertial frame's components,
        m/s^2, where the model declares it; the 3D viewer draws up against
        it (:func:`kanedyn.io.up_direction`).  None: not declared (the
        viewer then looks for the bodies' weights among the loads).
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
    animation_inputs: dict = field(default_factory=dict)
    gravity: tuple = None
    load_names: tuple = ()
    potential_loads: tuple = ()

    def _labels(self):
        return dict(name=self.name, title=self.title, units=self.units or None,
                    gravity=None if self.gravity is None
                    else tuple(float(g) for g in self.gravity))

    @property
    def state_names(self):
        """Names of the coordinates and speeds, independent then dependent (the
        order of ``EquationsOfMotion.state_names``), read from ``kane_args``
        without deriving."""
        from ..engine import name_of
        args = self.kane_args

        def names(*keys):
            return [name_of(s) for key in keys for s in args.get(key) or ()]
        return tuple(names("q_ind") + names("q_dep", "q_dependent")
                     + names("u_ind") + names("u_dep", "u_dependent"))

    def derive(self, progress=False, method="kane"):
        """Equations of motion (:func:`kanedyn.formulate`), labelled with the
        model's name, title and declared units."""
        from ..formulations import formulate
        DERIVE_STATS["derivations"] += 1
        eom = formulate(method=method, progress=progress, **self.kane_args)
        return eom._label(**self._labels())

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

        A definition made otherwise (a user's ``ModelDefinition``, one read
        from URDF or MJCF) is kept there too, keyed by a digest of its
        description (:func:`kanedyn.models._fingerprint.description_fingerprint`:
        every expression, frame, point, body, load and constant reachable from
        its fields), so that the same description built again in a second
        process skips the derivation; one holding anything the digest does not
        cover (a callable, kanedyn's contacts or force elements) is derived
        every time.
        """
        if eom is None and specified is None:
            cached = _derivation_cache(self, constants, options)
            if cached is not None:
                return cached
        if eom is None and options.get("backend") == "c":
            self.prefetch_runtime()
        eom = eom if eom is not None else self.derive()
        if eom.name is None:
            eom._label(**self._labels())
        values = dict(self.constants)
        values.update(self._constant_overrides(constants or {}))
        inputs = dict(self.specified)
        inputs.update(specified or {})
        return eom.numeric(constants=values, specified=inputs, **options)

    def prefetch_runtime(self):
        """Start compiling the C runtime of this model's sizes, so that it
        compiles while the equations are derived: for a caller that derives
        the model (:meth:`derive`) and then asks for ``backend="c"``
        (:meth:`numeric` does it itself when it derives).  See
        :func:`kanedyn.numerics.prefetch_runtime`; nothing happens without a
        compiler, or where the derivation decides the sizes (contacts,
        auxiliary speeds, specified inputs)."""
        args = self.kane_args
        if self.specified or args.get("contacts") or args.get("u_auxiliary"):
            return

        def count(*names):
            return sum(len(args.get(name) or ()) for name in names)

        from ..numerics import prefetch_runtime
        prefetch_runtime({"n_q": count("q_ind", "q_dep", "q_dependent"),
                          "n_u": count("u_ind", "u_dep", "u_dependent"),
                          "n_q_dep": count("q_dep", "q_dependent"),
                          "n_u_dep": count("u_dep", "u_dependent"),
                          "n_p": len(self.constants), "n_r": 0})

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
        import sympy as sm

        from ..modeling import visuals
        values = dict(self.constants)
        values.update(self._constant_overrides(constants or {}))
        out = []
        for kind, body, options in self.shape_specs:
            def number(key, value):
                if not isinstance(value, sm.Basic):
                    return value
                found = sm.sympify(value.xreplace(values), strict=True)
                if not found.is_number:
                    raise ModelError(f"model {self.name}: {kind} of body {body.name}: "
                                     f"{key} = {value} depends on more than constants")
                return float(found)
            opts = {key: (tuple(number(key, v) for v in value)
                          if isinstance(value, tuple) else number(key, value))
                    for key, value in options.items()}
            out.append(getattr(visuals, kind)(body, **opts))
        return out

    def initial(self, model, overrides=None):
        """Initial state array for ``model`` (independent values as given)."""
        from ..engine import name_of
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
    import sympy as sm
    return sm.Add(*[m * g * h for m, g, h in masses_heights])


# --------------------------------------------------------------- derivation cache
_SOURCE_STAMP = []  # this process's stamp of kanedyn's own source files


def _source_stamp():
    """Digest of the names, sizes and modification times of kanedyn's sources
    (a changed model or code generator is a new cache entry)."""
    if not _SOURCE_STAMP:
        import hashlib
        import os
        digest = hashlib.sha256()
        root = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
        for parts, entry in sorted(_python_files(root, ())):
            stat = entry.stat()
            digest.update(f"{'/'.join(parts)}:{stat.st_size}:{stat.st_mtime_ns}\n".encode())
        _SOURCE_STAMP.append(digest.hexdigest())
    return _SOURCE_STAMP[0]


def _python_files(folder, parts):
    """``[(path parts below the package, directory entry)]`` of the ``.py`` files
    in ``folder`` and its subfolders (``os.scandir``: a warm start reads some 270
    of them, 1 ms where ``Path.rglob`` took 4 ms)."""
    import os
    found = []
    with os.scandir(folder) as entries:
        for entry in entries:
            if entry.is_dir():
                if entry.name != "__pycache__":
                    found.extend(_python_files(entry.path, parts + (entry.name,)))
            elif entry.name.endswith(".py"):
                found.append((parts + (entry.name,), entry))
    return found


#: the content of a derivation-cache entry (a saved-data archive, see kanedyn.io)
CACHE_FORMAT = "kanedyn-derived-model"


def _cacheable(origin, constants, options):
    """The cache key of a built-in model's numerical model, or ``None`` when the
    model or its options are not cacheable (only ``backend="c"``, plain numbers
    as constants, a compiler present)."""
    if origin is None or options.get("backend") != "c" or set(options) - {"backend"}:
        return None
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool)
               for v in (constants or {}).values()):
        return None
    import hashlib
    import sys

    from .. import _version
    from ..numerics import compiler_command
    if compiler_command() is None:
        return None
    return hashlib.sha256(repr((origin, _version.__version__, sys.version,
                                _sympy_version(), np.__version__,
                                _source_stamp())).encode()).hexdigest()[:24]


def _sympy_version():
    """SymPy's version, without importing SymPy (a cached model needs none):
    the imported module's, else the ``__version__ = "..."`` line of its
    ``release.py`` (read as text, never run; reading the installed package's
    metadata instead took 0.02-0.03 s, a fifth of a warm start)."""
    import sys
    module = sys.modules.get("sympy")
    if module is not None:
        return module.__version__
    import importlib.util
    import os
    import re
    spec = importlib.util.find_spec("sympy")
    try:
        with open(os.path.join(os.path.dirname(spec.origin), "release.py"),
                  encoding="utf-8") as release:
            found = re.search(r"^__version__\s*=\s*['\"]([^'\"]+)['\"]", release.read(), re.M)
    except (AttributeError, TypeError, OSError):
        found = None
    if found is not None:
        return found.group(1)
    from importlib.metadata import version
    return version("sympy")


def _cache_path(key, part="kdnum"):
    """The cache entry ``key``: ``kdnum`` the numerical model without its body
    parameters (read with no SymPy), ``kdbody`` those (SymPy expressions); in
    the cache directory this process trusts
    (:func:`~kanedyn.numerics.backends.trusted_cache_dir`)."""
    from ..numerics.backends import trusted_cache_dir
    return trusted_cache_dir() / "derived" / f"{key}.{part}"


def _load_entry(path):
    """``load_data`` of the derivation-cache file ``path`` once it and its
    folder are found to be this user's or root's and writable by no one else
    (:mod:`kanedyn._trusted_files`; else a :class:`~kanedyn.io.SavedFileError`
    naming the owner and mode: nothing another user wrote is decoded), read
    from the descriptor it was checked on."""
    from .._trusted_files import open_entry
    from ..io import SavedFileError, load_data
    opened, problem = open_entry(path)  # missing: load_data says so
    if problem is not None:
        raise SavedFileError(f"{problem}: not read (the cache reads only files of this "
                             "user or root that no one else can write)")
    with opened or contextlib.nullcontext():
        return load_data(path, format=CACHE_FORMAT, opened=opened)


def _read_body_parameters(key):
    """The body parameters stored beside the cache entry ``key``."""
    return _load_entry(_cache_path(key, "kdbody"))[0]


def _read_cache(key):
    """``(model, manifest)`` from the cache entry ``key``, or ``None`` when there is
    none or it cannot be used.  The entry is a zip of JSON read by
    :func:`kanedyn.io.load_data` (nothing in it is evaluated or run); an entry
    that is damaged, changed, or carries source code (which would be compiled)
    is reported with a warning, removed and rebuilt; one whose module the compile
    cache does not hold is a miss (``None``, no warning)."""
    import os
    path = _cache_path(key)
    if not os.path.lexists(path):
        return None
    import warnings

    from ..io import SavedFileError
    from ..numerics import NumericModel
    from ..numerics.schemes import SCHEMES
    try:
        data, manifest = _load_entry(path)
        if not isinstance(data, dict) or data.get("backend") != "c" \
                or data.get("scheme") not in SCHEMES \
                or not isinstance(manifest.get("definition"), dict):
            raise SavedFileError(f"{path}: not a derived numerical model")
        if data.get("c_source") is not None or data.get("sources") is not None:
            # an entry names its module by key and never carries code: code in one
            # would be compiled and run
            raise SavedFileError(f"{path}: a derivation cache entry carrying source code")
        data["scheme"] = SCHEMES[data["scheme"]]()
        if data.get("body_parameters") is None:  # beside it: read when first needed
            if not _cache_path(key, "kdbody").exists():
                raise SavedFileError(f"{path}: its body parameters are missing")
            data["body_parameters"] = lambda: _read_body_parameters(key)
        from ..numerics import cached_module
        module = cached_module(data["c_key"])
        if module is None:
            # its module is not in the compile cache (removed, or made with other
            # compiler flags, which are part of a module's key: -mavx where the CPU
            # runs AVX): a miss, derived again (and the entry written again when the
            # module is built; without a compiler that says what is missing)
            return None
        model = NumericModel(data, module)
    except Exception as exc:  # noqa: BLE001  damaged, stale or unloadable: derive again
        warnings.warn(f"derivation cache entry {path} cannot be used ({exc}); it is "
                      "removed and the model derived again", RuntimeWarning, stacklevel=4)
        try:
            path.unlink()
        except OSError:
            pass
        return None
    return model, manifest["definition"]


def _write_cache(key, definition, model):
    """Store ``model`` (its data, without C source: the module is in the cache by
    its own key) and what :class:`~kanedyn.models.PendingDefinition` needs of
    ``definition``, atomically; a model that cannot be stored only costs time
    next time."""
    from .._trusted_files import untrusted_entry
    from ..engine import name_of
    from ..io import SavedFileError, save_data
    from ..numerics.schemes import SCHEMES
    data = dict(model._data)
    scheme = data["scheme"]
    if data["backend"] != "c" or SCHEMES.get(scheme.name) is not type(scheme) \
            or scheme != type(scheme)():
        return  # a scheme with options: not cached
    data["scheme"] = scheme.name
    data["c_source"] = None
    light = {"name": definition.name, "title": definition.title,
             "constants": sorted(str(s) for s in definition.constants),
             "initial": [[name_of(k), float(v)] for k, v in definition.initial_state.items()]}
    body_parameters = model._body_parameters()
    data["body_parameters"] = None  # beside the entry: SymPy, read when first needed
    # the body parameters first: an entry is complete once its .kdnum exists
    for part, value, manifest in (("kdbody", body_parameters, {}),
                                  ("kdnum", data, {"definition": light})):
        path = _cache_path(key, part)
        try:
            path.parent.mkdir(mode=0o700, exist_ok=True)
            if untrusted_entry(path.parent) is not None:
                return  # another user's folder: nothing is written there
            save_data(value, path, what=f"the numerical model of {definition.name}",
                      format=CACHE_FORMAT, permissions=0o600, **manifest)
        except (OSError, SavedFileError, TypeError, ValueError):
            # nothing is left of an entry not written (save_data writes a
            # part whole or not at all; the body parameters go with a model
            # that cannot be stored, such as one holding a Python input)
            if part == "kdnum":
                _cache_path(key, "kdbody").unlink(missing_ok=True)
            return


class DeriveAgain:
    """The numerical model derived again: what a model read from the derivation
    cache calls when its equations are first needed
    (``definition.numeric(definition.derive(), **options)``).

    Parameters
    ----------
    definition : ModelDefinition or None
        The model's definition; ``None`` in a process that unpickled this
        (a built-in model is then built again there).
    options : dict
        The options of :meth:`ModelDefinition.numeric` (not the constants).
    origin : tuple
        ``(registry name, options)`` of a built-in model, or ``("description",
        fingerprint)`` of a user's model.

    A built-in model's (:attr:`portable`) pickles as its name and options, no
    SymPy: a pickled :class:`~kanedyn.numerics.NumericModel` read from the cache
    carries this instead of its C source, so that neither the process that
    pickles it nor one whose cache holds its module derives it.
    """

    def __init__(self, definition, options, origin):
        self.definition, self.options, self.origin = definition, dict(options), origin

    @property
    def portable(self):
        """Whether this pickles without the definition (a built-in model)."""
        return self.origin[0] != "description"

    def __call__(self):
        definition, origin = self.definition, self.origin
        if definition is None:
            from . import build
            definition = build(origin[0], **dict(origin[1]))
        elif not self.portable:
            from ._fingerprint import description_fingerprint
            if description_fingerprint(definition) != origin[1]:
                raise ModelError(f"model {definition.name}: its description changed after "
                                 "its numerical model was read from the derivation cache; "
                                 "its equations cannot be derived for that model (make a "
                                 "new numerical model with numeric())")
        return definition.numeric(definition.derive(), **self.options)

    def __reduce__(self):
        if not self.portable:
            import pickle
            raise pickle.PicklingError("a user's model read from the derivation cache "
                                       "pickles with its C source, not its definition")
        return DeriveAgain, (None, self.options, self.origin)


def _derivation_cache(definition, constants, options):
    """The numerical model from the derivation cache (built and stored on a miss),
    or ``None`` when the model or its options are not cacheable."""
    overrides = definition._constant_overrides(constants or {})
    origin = getattr(definition, "_origin", None)
    if origin is None and options.get("backend") == "c":  # a user's model: its description
        from ._fingerprint import description_fingerprint
        fingerprint = description_fingerprint(definition)
        origin = None if fingerprint is None else ("description", fingerprint)
    key = _cacheable(origin, overrides, options)
    if key is None:
        return None

    found = _read_cache(key)
    if found is not None:
        model = found[0]
        model._rederive = DeriveAgain(definition, options, origin)
    else:
        definition.prefetch_runtime()
        model = definition.numeric(definition.derive(), **options)
        # the entry names a module by its key: written once that module is in the
        # cache (now, or when the optimized build of a quick module is: never if
        # that build fails or the process ends first)
        model._when_cached(lambda: _write_cache(key, definition, model))
    if overrides:
        model = model.with_constants({str(k): float(v) for k, v in overrides.items()})
    return model
