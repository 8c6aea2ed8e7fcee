"""Saved equations of motion: ``eom.save(path)`` and ``kd.load(path)``.

The file is a zip archive of two JSON members:

``manifest.json``
    ``format`` (``"kanedyn-equations"``), ``format_version``, the versions of
    kanedyn and SymPy that wrote it, the root node, the number of nodes and
    the SHA-256 of ``nodes.json``.
``nodes.json``
    The object graph of the :class:`~kanedyn.EquationsOfMotion` as a list of
    nodes, each a JSON list ``[kind, ...]`` whose references to other objects
    are indices into the list (shared objects and cycles are kept).

Loading is safe for files from elsewhere: **no text is ever evaluated or
parsed as code** (no ``eval``, ``sympify`` of strings, ``srepr``, or
pickle).  SymPy expressions are stored as trees: a class name from a fixed
allow-list (``Add``, ``Mul``, ``Pow``, ``sin``, ...) and its arguments, rebuilt
by calling that class on already rebuilt SymPy objects; symbols are rebuilt
from their names and assumptions, numbers from integers.  Other objects
(frames, points, bodies, kanedyn's own model description and straight-line
program) are rebuilt as empty instances of a class from an allow-list (by
module: kanedyn's engine, modeling and formulations layers,
``sympy.physics.vector`` and ``sympy.physics.mechanics``) whose attributes
are then set: no constructor or ``__setstate__`` runs.  Numerical models
(which carry generated code) are never part of a file; build them again with
:meth:`~kanedyn.EquationsOfMotion.numeric`.  Dummy symbols (the program's
intermediates) are created afresh on loading, so loaded equations never
collide with symbols of the loading session.

A file that is not such an archive, has another format or a newer version,
was changed after writing (checksum), or holds an unknown class or a
malformed node raises :class:`SavedFileError` naming the file and the fault.
"""

from __future__ import annotations

import base64
import functools
import hashlib
import importlib
import json
import random
import sys
import types
import zipfile
from pathlib import Path

import numpy as np

from .._errors import KanedynError
from .._version import __version__

__all__ = ["SavedFileError", "save_equations", "load", "save_data", "load_data", "FORMAT",
           "FORMAT_VERSION"]

FORMAT = "kanedyn-equations"
FORMAT_VERSION = 1

@functools.cache
def _sympy_tables():
    """SymPy's classes and singletons a file may name (SymPy imported on first use:
    a file of numbers, such as a cached numerical model, is read without it).

    Returns ``(expressions, unevaluated, singletons, singleton_names)``:
    expression classes rebuilt as ``cls(*args)`` by name; those rebuilt exactly
    as stored (``evaluate=False``); named singletons; their names by ``id``.
    """
    import sympy as sm
    expressions = {cls.__name__: cls for cls in (
        sm.Add, sm.Mul, sm.Pow, sm.sin, sm.cos, sm.tan, sm.cot, sm.asin, sm.acos, sm.atan,
        sm.atan2, sm.sinh, sm.cosh, sm.tanh, sm.exp, sm.log, sm.Abs, sm.sign, sm.Heaviside,
        sm.Max, sm.Min, sm.Piecewise, sm.functions.elementary.piecewise.ExprCondPair,
        sm.re, sm.im, sm.floor, sm.ceiling, sm.Tuple, sm.Derivative,
        sm.StrictGreaterThan, sm.StrictLessThan, sm.GreaterThan, sm.LessThan, sm.Eq, sm.Ne,
        sm.And, sm.Or, sm.Not)}
    singletons = {name: getattr(sm.S, name) for name in (
        "Zero", "One", "NegativeOne", "Half", "Pi", "Exp1", "ImaginaryUnit", "Infinity",
        "NegativeInfinity", "ComplexInfinity", "NaN", "true", "false", "EulerGamma")}
    return (expressions, (sm.Add, sm.Mul, sm.Pow), singletons,
            {id(v): k for k, v in singletons.items()})


class _LazySymPy:
    """The ``sympy`` module, imported on first attribute access."""

    def __getattr__(self, name):
        import sympy
        return getattr(sympy, name)


sm = _LazySymPy()
#: modules whose classes may be rebuilt attribute by attribute
_OBJECT_MODULES = ("kanedyn.engine.", "kanedyn.modeling.", "kanedyn.formulations.",
                   "sympy.physics.vector.", "sympy.physics.mechanics.")
#: bound methods a saved object may hold (lazy derivatives of inputs)
_METHODS = {("kanedyn.engine._program", "Program", "declare"),
            ("kanedyn.engine._symbols", "SymbolTable", "_specified")}
_ARRAY_TYPES = {"float64", "int64", "int32", "complex128", "bool"}


class SavedFileError(KanedynError, ValueError):
    """A saved-equations file cannot be read: not one, damaged, or unsupported."""


# ----------------------------------------------------------------- writing
class _Encoder:
    def __init__(self):
        self.nodes = []
        self._by_id = {}  # id(object) -> index (objects kept alive by the graph)
        self._by_value = {}  # (kind, value) -> index for scalars and SymPy atoms
        self._keep = []

    def _add(self, node):
        self.nodes.append(node)
        return len(self.nodes) - 1

    def ref(self, obj, where):
        if obj is None or isinstance(obj, (bool, int, float, str)):
            key = (type(obj).__name__, obj if not isinstance(obj, float) else obj.hex())
            found = self._by_value.get(key)
            if found is None:
                found = self._by_value[key] = self._add(self._scalar(obj))
            return found
        found = self._by_id.get(id(obj))
        if found is not None:
            return found
        if isinstance(obj, sm.Basic) and not isinstance(obj, sm.MatrixBase):
            found = self._by_value.get(("basic", obj))
            if found is not None:
                self._by_id[id(obj)] = found
                self._keep.append(obj)
                return found
        index = self._add(None)  # reserved first: cycles refer to it
        self._by_id[id(obj)] = index
        self._keep.append(obj)
        self.nodes[index] = self._node(obj, where)
        if isinstance(obj, sm.Basic) and not isinstance(obj, sm.MatrixBase):
            self._by_value[("basic", obj)] = index
        return index

    @staticmethod
    def _scalar(obj):
        if obj is None:
            return ["none"]
        if isinstance(obj, bool):
            return ["bool", obj]
        if isinstance(obj, int):
            return ["int", str(obj)]
        if isinstance(obj, float):
            return ["float", obj.hex()]
        return ["str", obj]

    def _refs(self, items, where):
        return [self.ref(v, where) for v in items]

    def _node(self, obj, where):
        if isinstance(obj, complex):
            return ["complex", obj.real.hex(), obj.imag.hex()]
        if isinstance(obj, tuple) and hasattr(type(obj), "_fields"):
            return ["namedtuple", _class_name(type(obj), where), self._refs(obj, where)]
        if type(obj) is tuple:
            return ["tuple", self._refs(obj, where)]
        if type(obj) is list:
            return ["list", self._refs(obj, where)]
        if type(obj) is dict:
            return ["dict", [[self.ref(k, where), self.ref(v, _item(where, k))]
                             for k, v in obj.items()]]
        if type(obj) in (set, frozenset):
            return [type(obj).__name__, self._refs(obj, where)]
        if isinstance(obj, np.ndarray):
            if obj.dtype.name not in _ARRAY_TYPES:
                raise SavedFileError(f"cannot save {where}: an array of {obj.dtype}")
            data = np.ascontiguousarray(obj).astype(obj.dtype.newbyteorder("<"))
            return ["array", obj.dtype.name, list(obj.shape),
                    base64.b64encode(data.tobytes()).decode("ascii")]
        if isinstance(obj, (np.floating, np.integer, np.bool_)):
            return self._scalar(obj.item())
        if isinstance(obj, random.Random):
            version, internal, gauss = obj.getstate()
            return ["random", version, [str(v) for v in internal], gauss]
        if isinstance(obj, sm.MatrixBase):
            kind = "immutable" if isinstance(obj, sm.ImmutableMatrix) else "mutable"
            return ["matrix", kind, obj.rows, obj.cols, self._refs(list(obj), where)]
        if isinstance(obj, sm.Basic):
            return self._basic(obj, where)
        if isinstance(obj, sm.core.function.UndefinedFunction):
            return ["function", str(obj.__name__), self._assumptions(
                obj._explicit_class_assumptions), self.ref(dict(obj._kwargs), where)]
        if isinstance(obj, types.MethodType):
            owner = type(obj.__self__)
            key = (owner.__module__, owner.__qualname__, obj.__name__)
            if key not in _METHODS:
                raise SavedFileError(f"cannot save {where}: it holds the method "
                                     f"{owner.__qualname__}.{obj.__name__}")
            return ["method", self.ref(obj.__self__, where), obj.__name__]
        if isinstance(obj, functools.partial):
            return ["partial", self.ref(obj.func, where), self._refs(obj.args, where),
                    self.ref(dict(obj.keywords), where)]
        if isinstance(obj, (types.FunctionType, types.BuiltinFunctionType, type)):
            raise SavedFileError(f"cannot save {where}: it holds the function or class "
                                 f"{obj!r}, which a saved file cannot carry")
        return self._object(obj, where)

    @staticmethod
    def _assumptions(values):
        return {str(k): bool(v) for k, v in values.items() if v is not None}

    def _basic(self, obj, where):
        name = _sympy_tables()[3].get(id(obj))
        if name is not None:
            return ["singleton", name]
        if isinstance(obj, sm.Integer):
            return ["integer", str(int(obj))]
        if isinstance(obj, sm.Rational):
            return ["rational", str(obj.p), str(obj.q)]
        if isinstance(obj, sm.Float):
            sign, man, exp, bc = obj._mpf_
            return ["real", sign, str(man), str(exp), bc, obj._prec]
        if type(obj).__name__ == "CoordinateSym":
            frame, index = obj._id
            return ["coordinate", obj.name, self.ref(frame, where), index]
        if isinstance(obj, sm.Dummy):
            return ["dummy", obj.name, self._assumptions(obj._assumptions_orig)]
        if type(obj) is sm.Symbol:
            return ["symbol", obj.name, self._assumptions(obj._assumptions_orig)]
        if isinstance(obj, sm.core.function.AppliedUndef):
            return ["apply", self.ref(obj.func, where), self._refs(obj.args, where)]
        cls = type(obj)
        if _sympy_tables()[0].get(cls.__name__) is not cls:
            raise SavedFileError(f"cannot save {where}: SymPy class {cls.__name__} is not "
                                 "among those a saved file may hold")
        return ["expr", cls.__name__, self._refs(obj.args, where)]

    def _object(self, obj, where):
        cls = type(obj)
        name = _class_name(cls, where)
        state = None
        if "__getstate__" in vars(cls) and name.startswith("kanedyn."):
            state = obj.__getstate__()  # e.g. the equations without their cached views
        if not isinstance(state, dict):
            state = dict(getattr(obj, "__dict__", {}))
        for klass in cls.__mro__:
            for slot in vars(klass).get("__slots__", ()):
                if slot not in ("__dict__", "__weakref__") and hasattr(obj, slot):
                    state[slot] = getattr(obj, slot)
        return ["object", name, [[str(k), self.ref(v, f"{where}.{k}")]
                                 for k, v in state.items()]]


def _item(where, key):
    """Where a dict entry is, for messages (SymPy keys are not printed: slow)."""
    return f"{where}[{key if isinstance(key, str) else type(key).__name__}]"


def _class_name(cls, where):
    name = f"{cls.__module__}.{cls.__qualname__}"
    if not name.startswith(_OBJECT_MODULES) or "<" in name:
        raise SavedFileError(f"cannot save {where}: it holds a {name}, which a saved file "
                             "cannot carry")
    return name


def save_equations(eom, path):
    """Write equations of motion to ``path`` (see the module notes for the format).

    Parameters
    ----------
    eom : EquationsOfMotion
    path : str or os.PathLike
        The file to write (conventionally ``*.kdeom``); replaced if it exists.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    return save_data(eom, path, what="the equations", summary=repr(eom))


def save_data(obj, path, what="the data", format=FORMAT, **fields):
    """Write ``obj`` (any object a saved file may carry) as a zip of JSON.

    The same archive as :func:`save_equations` (``manifest.json`` and the
    checksummed ``nodes.json``); ``format`` names the kind of content and
    ``fields`` are extra JSON values put in the manifest.  Used for the
    equations of motion and by the derivation cache of the built-in models.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    SavedFileError
        ``obj`` holds something a saved file cannot carry, or the file
        cannot be written.
    """
    path = Path(path)
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 20000))
    try:
        encoder = _Encoder()
        root = encoder.ref(obj, what)
    finally:
        sys.setrecursionlimit(limit)
    nodes = json.dumps(encoder.nodes, separators=(",", ":")).encode("utf-8")
    manifest = {"format": format, "format_version": FORMAT_VERSION,
                "kanedyn_version": __version__, "sympy_version": sm.__version__,
                "root": root, "nodes": len(encoder.nodes),
                "sha256": hashlib.sha256(nodes).hexdigest(), **fields}
    try:
        with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            archive.writestr("manifest.json", json.dumps(manifest, indent=1))
            archive.writestr("nodes.json", nodes)
    except OSError as exc:
        raise SavedFileError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path


# ----------------------------------------------------------------- reading
class _Decoder:
    def __init__(self, nodes, path):
        self.nodes = nodes
        self.path = path
        self.values = {}

    def fail(self, index, text):
        raise SavedFileError(f"{self.path}: node {index}: {text}; the file is damaged or "
                             "was not written by kanedyn")

    def get(self, index):
        if type(index) is not int or not 0 <= index < len(self.nodes):
            raise SavedFileError(f"{self.path}: a reference {index!r} points outside the "
                                 f"{len(self.nodes)} nodes; the file is damaged")
        if index in self.values:
            return self.values[index]
        node = self.nodes[index]
        if not isinstance(node, list) or not node or not isinstance(node[0], str):
            self.fail(index, f"not a node: {str(node)[:60]}")
        handler = _KINDS.get(node[0])
        if handler is None:
            self.fail(index, f"unknown kind {node[0]!r}")
        handler = getattr(self, handler)
        try:
            return handler(index, *node[1:])
        except SavedFileError:
            raise
        except (TypeError, ValueError, KeyError, AttributeError, IndexError) as exc:
            self.fail(index, f"a malformed {node[0]!r} node ({type(exc).__name__}: {exc})")

    def _set(self, index, value):
        self.values[index] = value
        return value

    def _all(self, refs):
        if not isinstance(refs, list):
            raise TypeError("a list of references expected")
        return [self.get(r) for r in refs]

    def _basics(self, index, refs):
        out = self._all(refs)
        for v in out:
            if not isinstance(v, sm.Basic):
                self.fail(index, f"a SymPy argument that is a {type(v).__name__}")
        return out

    @staticmethod
    def _text(value):
        if not isinstance(value, str):
            raise TypeError("a string expected")
        return value

    @staticmethod
    def _integer(text):
        if not isinstance(text, str) or len(text) > 5000:
            raise TypeError("an integer as text expected")
        return int(text)  # digits only: int() of a str parses no code

    # scalars and containers
    def _none(self, index):
        return self._set(index, None)

    def _bool(self, index, value):
        if not isinstance(value, bool):
            raise TypeError("a boolean expected")
        return self._set(index, value)

    def _int(self, index, text):
        return self._set(index, self._integer(text))

    def _float(self, index, text):
        return self._set(index, float.fromhex(self._text(text)))

    def _str(self, index, text):
        return self._set(index, self._text(text))

    def _complex(self, index, re, im):
        return self._set(index, complex(float.fromhex(self._text(re)),
                                        float.fromhex(self._text(im))))

    def _tuple(self, index, refs):
        return self._set(index, tuple(self._all(refs)))

    def _list(self, index, refs):
        out = self._set(index, [])
        out.extend(self._all(refs))
        return out

    def _dict(self, index, pairs):
        out = self._set(index, {})
        for pair in pairs:
            key, value = pair
            out[self.get(key)] = self.get(value)
        return out

    def _set_(self, index, refs):
        return self._set(index, set(self._all(refs)))

    def _frozenset(self, index, refs):
        return self._set(index, frozenset(self._all(refs)))

    def _namedtuple(self, index, name, refs):
        cls = self._class(index, name)
        if not (issubclass(cls, tuple) and hasattr(cls, "_fields")):
            self.fail(index, f"{name} is not a named tuple")
        return self._set(index, cls(*self._all(refs)))

    def _array(self, index, dtype, shape, data):
        if dtype not in _ARRAY_TYPES:
            self.fail(index, f"an array of type {dtype!r}")
        raw = base64.b64decode(self._text(data), validate=True)
        shape = tuple(self._integer(str(n)) for n in shape)
        value = np.frombuffer(raw, dtype=np.dtype(dtype).newbyteorder("<"))
        return self._set(index, value.astype(dtype).reshape(shape).copy())

    def _random(self, index, version, internal, gauss):
        rng = random.Random()
        rng.setstate((version, tuple(self._integer(v) for v in internal), gauss))
        return self._set(index, rng)

    # SymPy
    def _singleton(self, index, name):
        if name not in _sympy_tables()[2]:
            self.fail(index, f"unknown SymPy constant {name!r}")
        return self._set(index, _sympy_tables()[2][name])

    def _integer_(self, index, text):
        return self._set(index, sm.Integer(self._integer(text)))

    def _rational(self, index, p, q):
        return self._set(index, sm.Rational(self._integer(p), self._integer(q)))

    def _real(self, index, sign, man, exp, bc, prec):
        mpf = (int(sign), self._integer(man), self._integer(exp), int(bc))
        return self._set(index, sm.Float._new(mpf, int(prec)))

    def _symbol(self, index, name, assumptions):
        return self._set(index, sm.Symbol(self._text(name), **self._flags(assumptions)))

    def _dummy(self, index, name, assumptions):
        return self._set(index, sm.Dummy(self._text(name), **self._flags(assumptions)))

    @staticmethod
    def _flags(assumptions):
        if not isinstance(assumptions, dict) or not all(
                isinstance(k, str) and isinstance(v, bool) for k, v in assumptions.items()):
            raise TypeError("assumptions must map names to booleans")
        return assumptions

    def _coordinate(self, index, name, frame, axis):
        from sympy.physics.vector.frame import CoordinateSym
        return self._set(index, CoordinateSym(self._text(name), self.get(frame), axis))

    def _function(self, index, name, assumptions, kwargs):
        kwargs = self.get(kwargs)
        if kwargs:
            self.fail(index, "an undefined function with keyword data")
        return self._set(index, sm.Function(self._text(name), **self._flags(assumptions)))

    def _apply(self, index, func, refs):
        func = self.get(func)
        if not isinstance(func, sm.core.function.UndefinedFunction):
            self.fail(index, "an application of something that is not an undefined function")
        return self._set(index, func(*self._basics(index, refs)))

    def _expr(self, index, name, refs):
        cls = _sympy_tables()[0].get(name)
        if cls is None:
            self.fail(index, f"the SymPy class {name!r} is not allowed")
        args = self._basics(index, refs)
        if cls in _sympy_tables()[1] or issubclass(cls, sm.Function):
            value = cls(*args, evaluate=False)
        elif cls is sm.Derivative:
            value = sm.Derivative(*args, evaluate=False)
        else:
            value = cls(*args)
        return self._set(index, value)

    def _matrix(self, index, kind, rows, cols, refs):
        entries = self._basics(index, refs)
        cls = sm.ImmutableMatrix if kind == "immutable" else sm.Matrix
        return self._set(index, cls(int(rows), int(cols), entries))

    # objects
    def _class(self, index, name):
        name = self._text(name)
        if not name.startswith(_OBJECT_MODULES):
            self.fail(index, f"the class {name} is not allowed")
        module, _, qualname = name.rpartition(".")
        while module and module not in sys.modules:
            try:
                importlib.import_module(module)
                break
            except ImportError:
                module, _, outer = module.rpartition(".")
                qualname = f"{outer}.{qualname}"
        if not module.startswith(_OBJECT_MODULES):
            self.fail(index, f"the class {name} is not allowed")
        value = sys.modules.get(module)
        for part in qualname.split("."):
            value = getattr(value, part, None)
        if not isinstance(value, type) or value.__module__ != module:
            self.fail(index, f"no class {name} in this version of kanedyn and SymPy")
        return value

    def _object(self, index, name, attributes):
        cls = self._class(index, name)
        obj = self._set(index, object.__new__(cls))
        for pair in attributes:
            key, value = pair
            object.__setattr__(obj, self._text(key), self.get(value))
        return obj

    def _method(self, index, owner, name):
        owner = self.get(owner)
        cls = type(owner)
        if (cls.__module__, cls.__qualname__, name) not in _METHODS:
            self.fail(index, f"the method {cls.__qualname__}.{name} is not allowed")
        return self._set(index, getattr(owner, name))

    def _partial(self, index, func, refs, keywords):
        func = self.get(func)
        if not isinstance(func, types.MethodType):
            self.fail(index, "a partial of something that is not an allowed method")
        args, keywords = self._all(refs), self.get(keywords)
        if any(isinstance(value, (str, bytes)) for value in (*args, *keywords.values())):
            # the allowed methods take SymPy objects and numbers; text handed to them
            # could reach SymPy's parser, which runs it as Python
            self.fail(index, "a partial with text among its arguments")
        return self._set(index, functools.partial(func, *args, **keywords))


#: node kind -> the decoder's method that rebuilds it (nothing else is called)
_KINDS = {kind: "_" + kind for kind in (
    "none", "bool", "int", "float", "str", "complex", "tuple", "list", "dict", "frozenset",
    "namedtuple", "array", "random", "singleton", "rational", "real", "symbol", "dummy",
    "coordinate", "function", "apply", "expr", "matrix", "object", "method", "partial")}
_KINDS.update({"set": "_set_", "integer": "_integer_"})


def load(path):
    """Equations of motion saved by :meth:`EquationsOfMotion.save`.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    EquationsOfMotion

    Raises
    ------
    SavedFileError
        The file is missing, not a saved-equations archive, of another format
        version, changed after it was written, or holds something a saved file
        may not (the message names the file and the fault).
    """
    from ..formulations import EquationsOfMotion
    eom, _ = load_data(path)
    if not isinstance(eom, EquationsOfMotion):
        raise SavedFileError(f"{path}: holds a {type(eom).__name__}, not equations of motion")
    return eom


def load_data(path, format=FORMAT):
    """The object and the manifest of a file written by :func:`save_data`.

    Parameters
    ----------
    path : str or os.PathLike
    format : str
        The content the file must announce in its manifest.

    Returns
    -------
    (object, dict)
        The rebuilt object (nothing in the file is evaluated: see the module
        notes) and the manifest.

    Raises
    ------
    SavedFileError
        As :func:`load`: the message names the file and the fault.
    """
    path = Path(path)
    kind = "kanedyn equations file" if format == FORMAT else f"{format} file"
    try:
        with zipfile.ZipFile(path) as archive:
            names = set(archive.namelist())
            if not {"manifest.json", "nodes.json"} <= names:
                raise SavedFileError(f"{path}: not a {kind} (it lacks "
                                     "manifest.json or nodes.json)")
            manifest_text = archive.read("manifest.json")
            nodes_text = archive.read("nodes.json")
    except FileNotFoundError:
        raise SavedFileError(f"{path}: no such file") from None
    except (zipfile.BadZipFile, OSError) as exc:
        raise SavedFileError(f"{path}: not a {kind} ({exc})") from None
    try:
        manifest = json.loads(manifest_text)
    except ValueError as exc:
        raise SavedFileError(f"{path}: its manifest.json is not JSON ({exc})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != format:
        raise SavedFileError(f"{path}: not a {kind} (format "
                             f"{manifest.get('format') if isinstance(manifest, dict) else None!r})")
    version = manifest.get("format_version")
    if version != FORMAT_VERSION:
        raise SavedFileError(f"{path}: format version {version!r}, written by kanedyn "
                             f"{manifest.get('kanedyn_version')}; this kanedyn "
                             f"({__version__}) reads version {FORMAT_VERSION}")
    if hashlib.sha256(nodes_text).hexdigest() != manifest.get("sha256"):
        raise SavedFileError(f"{path}: nodes.json does not match the checksum in its "
                             "manifest: the file was changed or damaged after it was written")
    try:
        nodes = json.loads(nodes_text)
    except ValueError as exc:
        raise SavedFileError(f"{path}: nodes.json is not JSON ({exc})") from None
    if not isinstance(nodes, list) or len(nodes) != manifest.get("nodes"):
        raise SavedFileError(f"{path}: nodes.json does not hold the {manifest.get('nodes')} "
                             "nodes its manifest announces")
    decoder = _Decoder(nodes, path)
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 20000))
    try:
        obj = decoder.get(manifest.get("root"))
    finally:
        sys.setrecursionlimit(limit)
    return obj, manifest
