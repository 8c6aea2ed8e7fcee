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

Loading runs no code from the file and always ends.  **No text is ever
evaluated or parsed as code** (no ``eval``, ``sympify`` of strings,
``srepr``, or pickle), and nothing is built but through an allow-list, with
every argument checked by type before it is used:

- numbers, text, lists, tuples, dicts, sets, NumPy arrays (of five dtypes)
  and random-number states are read as such;
- SymPy expressions are trees of classes from a fixed allow-list (``Add``,
  ``Mul``, ``Pow``, ``sin``, ``Max``, ``Piecewise``, ``Derivative``, ...),
  each rebuilt exactly as stored on arguments checked by kind, so that no
  constructor computes (``evaluate=False``, or ``Basic.__new__`` where even
  that would compute: see :mod:`._saved_sympy`); symbols from their names
  and SymPy's assumption names, numbers from bounded integers;
- SymPy's ``Force``, ``Torque`` and ``Inertia`` through their constructors
  on fields checked by type;
- every other object (frames, points, bodies, vectors, dyadics; kanedyn's
  model description, straight-line program, symbol table, equations) by an
  explicit schema per class: created empty, each attribute written where it
  lives (instance dict or slot: no setter, property or descriptor runs),
  an attribute the schema does not name or a value of another type refused
  (see :mod:`._saved_schema`, which says why those classes cannot be
  rebuilt through their constructors);
- two bound methods (lazy derivatives of inputs), and partials of one of
  them with checked arguments.

Numerical models (which carry generated code) are never part of a file;
build them again with :meth:`~kanedyn.EquationsOfMotion.numeric`.  Dummy
symbols (the program's intermediates) are created afresh on loading, so
loaded equations never collide with symbols of the loading session.

Reading is bounded (:data:`SAVED_FILE_LIMITS`): the archive's size, the
uncompressed size of each member (read in chunks, the sizes its headers
claim not trusted), the number of nodes and of JSON containers, the nesting
depth of the graph (rebuilt without recursion), the digits of an integer,
and the time the whole read may take (``timeout``).

A file that is not such an archive, has another format or a newer version,
does not match its checksum, exceeds a limit, or holds an unknown class, a
malformed node or a value of the wrong type raises :class:`SavedFileError`
naming the file, and the node and attribute where there is one.  The
checksum detects damage, not tampering: anyone can recompute it, so it
proves nothing about who wrote a file; the allow-lists and checks above are
what make a file from elsewhere safe to read.
"""

from __future__ import annotations

import base64
import contextlib
import functools
import hashlib
import json
import os
import random
import sys
import time
import types
import zipfile
from pathlib import Path

import numpy as np

from .._errors import KanedynError
from .._output_files import replacing
from .._version import __version__
from . import _saved_schema as schema
from ._saved_sympy import (ASSUMPTIONS, SINGLETONS, Refused, described,
                           expression_rules)

__all__ = ["SavedFileError", "save_equations", "load", "save_data", "load_data", "FORMAT",
           "FORMAT_VERSION", "SAVED_FILE_LIMITS"]

FORMAT = "kanedyn-equations"
FORMAT_VERSION = 1

#: What reading a file may take at most; a file beyond any limit is refused
#: (raise one to read a larger file you trust).  For scale: the largest
#: built-in model's equations, the Stewart platform's, are a 0.1 MB archive of
#: 0.5 MB and 12,000 nodes; a 20-link 3D chain's are 1.2 MB.
SAVED_FILE_LIMITS = {
    "file_bytes": 32 << 20,      # the archive on disk
    "member_bytes": 32 << 20,    # nodes.json, uncompressed
    "manifest_bytes": 1 << 20,   # manifest.json, uncompressed
    "members": 16,               # entries of the archive
    "nodes": 1_000_000,
    "containers": 4_000_000,     # JSON arrays and objects in nodes.json
    "depth": 5_000,              # nesting of the object graph
    "digits": 1_000,             # decimal digits of an integer
    "timeout": 60.0,             # seconds for the whole read (``timeout=``)
}

_ARRAY_TYPES = {"float64", "int64", "int32", "complex128", "bool"}
_FRAME = frozenset({"sympy.physics.vector.frame.ReferenceFrame"})


@functools.cache
def _singletons():
    """``({name: singleton}, {id(singleton): name})``."""
    import sympy
    values = {name: getattr(sympy.S, name) for name in SINGLETONS}
    return values, {id(v): k for k, v in values.items()}


class _LazySymPy:
    """The ``sympy`` module, imported on first attribute access (a file of
    numbers, such as a cached numerical model, is read without it)."""

    def __getattr__(self, name):
        import sympy
        return getattr(sympy, name)


sm = _LazySymPy()


class SavedFileError(KanedynError, ValueError):
    """A saved-equations file cannot be read: not one, damaged, or unsupported."""


# ----------------------------------------------------------------- writing
class _Encoder:
    def __init__(self):
        self.nodes = []
        self._by_id = {}  # id(object) -> index (objects kept alive by the graph)
        self._by_value = {}  # (kind, value) -> index for scalars and SymPy atoms
        self._keep = []
        self._checked = set()  # containers whose types were checked (see Spec.problem)

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
            return self._named_tuple(obj, where)
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
            if (schema.class_path(owner), obj.__name__) not in schema.METHODS:
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
        name = _singletons()[1].get(id(obj))
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
        rule = expression_rules().get(cls.__name__)
        if rule is None or rule.cls is not cls:
            raise SavedFileError(f"cannot save {where}: SymPy class {cls.__name__} is not "
                                 "among those a saved file may hold")
        try:
            rule.check(obj.args)  # what loading checks: a file written can be read
        except Refused as exc:
            raise SavedFileError(f"cannot save {where}: {exc}") from None
        return ["expr", cls.__name__, self._refs(obj.args, where)]

    def _named_tuple(self, obj, where):
        name = _class_name(type(obj), where, schema.NAMED_TUPLES)
        for field, value, spec in zip(obj._fields, obj, schema.NAMED_TUPLES[name]):
            problem = spec.problem(value, set())
            if problem is not None:
                raise SavedFileError(f"cannot save {where}: its {type(obj).__name__} field "
                                     f"{field!r} {problem}")
        return ["namedtuple", name, self._refs(obj, where)]

    def _object(self, obj, where):
        cls = type(obj)
        name = _class_name(cls, where, schema.OBJECTS)
        specs = schema.OBJECTS[name]
        state = None
        if "__getstate__" in vars(cls) and name.startswith("kanedyn."):
            state = obj.__getstate__()  # e.g. the equations without their cached views
        if not isinstance(state, dict):
            state = dict(getattr(obj, "__dict__", {}))
        for klass in cls.__mro__:
            for slot in vars(klass).get("__slots__", ()):
                if slot not in ("__dict__", "__weakref__") and hasattr(obj, slot):
                    state[slot] = getattr(obj, slot)
        for key, value in state.items():  # what loading checks: a file written can be read
            spec = specs.get(key)
            if spec is None:
                raise SavedFileError(f"cannot save {where}.{key}: {cls.__name__} has no "
                                     f"attribute {key!r} that a saved file may hold")
            problem = spec.problem(value, self._checked)
            if problem is not None:
                raise SavedFileError(f"cannot save {where}.{key}: it {problem}")
        return ["object", name, [[str(k), self.ref(v, f"{where}.{k}")]
                                 for k, v in state.items()]]


def _item(where, key):
    """Where a dict entry is, for messages (SymPy keys are not printed: slow)."""
    return f"{where}[{key if isinstance(key, str) else type(key).__name__}]"


def _class_name(cls, where, table):
    """The name by which a file names ``cls``, which must be in ``table``."""
    name = schema.class_path(cls)
    if name not in table:
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


def save_data(obj, path, what="the data", format=FORMAT, permissions=None, **fields):
    """Write ``obj`` (any object a saved file may carry) as a zip of JSON.

    The same archive as :func:`save_equations` (``manifest.json`` and the
    checksummed ``nodes.json``); ``format`` names the kind of content and
    ``fields`` are extra JSON values put in the manifest.  Used for the
    equations of motion and by the derivation cache of the built-in models
    (which asks for ``permissions=0o600``; default: those of a new file).

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    SavedFileError
        ``obj`` holds something a saved file cannot carry.
    OutputFileError
        The file cannot be written (see :func:`kanedyn._output_files.replacing`:
        nothing is left behind, an earlier file is as it was).
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
    with replacing(path, "wb", permissions=permissions) as handle, \
            zipfile.ZipFile(handle, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("manifest.json", json.dumps(manifest, indent=1))
        archive.writestr("nodes.json", nodes)
    return path


# ----------------------------------------------------------------- reading
_NO_SHELL = object()
_CAUGHT = (TypeError, ValueError, KeyError, AttributeError, IndexError, ArithmeticError,
           Refused)


class _Decoder:
    """Rebuilds the node graph without recursion (an explicit stack, its depth
    bounded), each node from its children; objects that may sit in cycles
    (lists, dicts, sets, schema objects) exist as empty shells before their
    children.  Schema values are checked once everything is built."""

    def __init__(self, nodes, path, deadline, timeout):
        self.nodes = nodes
        self.path = path
        self.deadline = deadline
        self.timeout = timeout
        self.values = {}  # index -> value, or the shell being filled
        self._open = set()  # indices whose children are being rebuilt
        self._interned = {}  # SymPy nodes by content: equal trees are one object
        self._checks = []  # (index, class name, specs, attributes, values) per object
        self._handlers = {kind: getattr(self, name) for kind, name in _KINDS.items()}
        self._key_types = {type(None), bool, int, float, str, complex, frozenset}
        self._started = 0  # nodes started: the clock is read every 64

    def fail(self, index, text):
        raise SavedFileError(f"{self.path}: node {index}: {text}")

    def _tick(self):
        if time.monotonic() > self.deadline:
            raise SavedFileError(f"{self.path}: reading took longer than its time limit "
                                 f"({self.timeout:g} s); the file is refused")

    # ------------------------------------------------------------- the walk
    def decode(self, root):
        root = self._ref(-1, root)
        values, opened, deepest = self.values, self._open, SAVED_FILE_LIMITS["depth"]
        stack = [frame for frame in [self._start(root)] if frame is not None]
        while stack:
            frame = stack[-1]
            index, refs, position = frame[0], frame[1], frame[2]
            while position < len(refs):
                child = refs[position]
                position += 1
                if child in values:
                    continue
                if child in opened:
                    self.fail(index, f"it refers back to node {child} through a "
                                     f"{self.nodes[child][0]!r}, which cannot hold a cycle")
                if len(stack) >= deepest:
                    self.fail(index, f"the objects are nested more than {deepest} deep")
                started = self._start(child)
                if started is not None:
                    frame[2] = position
                    stack.append(started)
                    break
            else:
                stack.pop()
                try:
                    value = frame[3]([values[r] for r in refs])
                except SavedFileError:
                    raise
                except _CAUGHT as exc:
                    self._malformed(index, exc)
                values[index] = value
                opened.discard(index)
        self._check_schemas()
        return values[root]

    def _malformed(self, index, exc):
        if isinstance(exc, Refused):
            self.fail(index, str(exc))
        self.fail(index, f"a malformed {self.nodes[index][0]!r} node "
                         f"({type(exc).__name__}: {str(exc)[:300]})")

    def _start(self, index):
        """``[index, child indices, next child, finish]`` of a node (its shell,
        if it has one, registered first), or ``None`` for a node without
        children, whose value is registered at once."""
        self._started += 1
        if not self._started % 64:
            self._tick()
        node = self.nodes[index]
        if type(node) is not list or not node or type(node[0]) is not str:
            self.fail(index, f"not a node but {described(node)}")
        handler = self._handlers.get(node[0])
        if handler is None:
            self.fail(index, f"unknown kind {node[0][:40]!r}")
        try:
            shell, refs, finish = handler(index, *node[1:])
        except SavedFileError:
            raise
        except _CAUGHT as exc:
            self._malformed(index, exc)
        if finish is None:  # see _done
            self.values[index] = shell
            return None
        if shell is not _NO_SHELL:
            self.values[index] = shell
        self._open.add(index)
        return [index, refs, 0, finish]

    def _ref(self, index, ref):
        if type(ref) is not int or not 0 <= ref < len(self.nodes):
            where = "the root" if index < 0 else f"node {index}"
            raise SavedFileError(f"{self.path}: {where}: a reference {str(ref)[:40]} points "
                                 f"outside the {len(self.nodes)} nodes; the file is damaged")
        return ref

    def _refs(self, index, refs):
        if type(refs) is not list:
            raise TypeError("a list of references expected")
        count = len(self.nodes)
        for r in refs:
            if type(r) is not int or not 0 <= r < count:
                self._ref(index, r)  # raises, naming it
        return refs

    @staticmethod
    def _done(value):
        """A node without children whose value is ``value`` (no ``finish``)."""
        return value, (), None

    @staticmethod
    def _text(value):
        if type(value) is not str:
            raise TypeError("a string expected")
        return value

    @staticmethod
    def _whole(value, low=None, high=None):
        """A JSON integer (not a boolean) within ``[low, high]``."""
        if type(value) is not int or (low is not None and value < low) or (
                high is not None and value > high):
            raise ValueError(f"a whole number in [{low}, {high}] expected, got "
                             f"{str(value)[:40]}")
        return value

    @staticmethod
    def _integer(text):
        """An integer written as decimal digits (at most ``SAVED_FILE_LIMITS["digits"]``)."""
        digits = text[1:] if type(text) is str and text[:1] == "-" else text
        if type(digits) is not str or not 0 < len(digits) <= SAVED_FILE_LIMITS["digits"] \
                or not (digits.isascii() and digits.isdigit()):
            raise ValueError(f"an integer of at most {SAVED_FILE_LIMITS['digits']} digits expected")
        return int(text)  # digits only: int() of a str parses no code

    def _key(self, index, value, sizes):
        """Refuse a dict key or set member whose hash or equality could run
        without bound or run code: allowed are numbers, text, SymPy objects
        (hash computed once, equality structural), frozensets, objects
        compared by identity, and small tuples of these."""
        cls = type(value)
        if cls in self._key_types:
            return 1
        classes = schema.sympy_classes()
        if schema.is_sympy(value) or (classes is not None and isinstance(value, classes[3])):
            self._key_types.add(cls)  # SymPy objects, undefined functions: hashed once
            return 1
        if cls is tuple:
            size = sizes.get(id(value))
            if size is None:
                size = 1 + sum(self._key(index, v, sizes) for v in value)
                if size > 64:
                    self.fail(index, "a tuple of more than 64 items used as a key")
                sizes[id(value)] = size
            return size
        if cls.__hash__ is object.__hash__ and cls.__eq__ is object.__eq__ and (
                schema.class_path(cls) in schema.OBJECTS):
            self._key_types.add(cls)
            return 1
        self.fail(index, f"{described(value)} used as a dict key or set member")

    # -------------------------------------------------- scalars, containers
    def _none(self, index):
        return self._done(None)

    def _bool(self, index, value):
        if type(value) is not bool:
            raise TypeError("a boolean expected")
        return self._done(value)

    def _int(self, index, text):
        return self._done(self._integer(text))

    def _float(self, index, text):
        return self._done(float.fromhex(self._text(text)))

    def _str(self, index, text):
        return self._done(self._text(text))

    def _complex(self, index, re, im):
        return self._done(complex(float.fromhex(self._text(re)), float.fromhex(self._text(im))))

    def _tuple(self, index, refs):
        return _NO_SHELL, self._refs(index, refs), tuple

    def _list(self, index, refs):
        shell = []

        def finish(values):
            shell.extend(values)
            return shell
        return shell, self._refs(index, refs), finish

    def _dict(self, index, pairs):
        if type(pairs) is not list or not all(type(p) is list and len(p) == 2 for p in pairs):
            raise TypeError("a list of [key, value] pairs expected")
        shell = {}
        sizes = {}

        def finish(values):
            keys, items = values[0::2], values[1::2]
            for key in keys:
                self._key(index, key, sizes)
            shell.update(zip(keys, items))
            return shell
        return shell, self._refs(index, [r for pair in pairs for r in pair]), finish

    def _set_(self, index, refs):
        shell = set()

        def finish(values):
            sizes = {}
            for v in values:
                self._key(index, v, sizes)
            shell.update(values)
            return shell
        return shell, self._refs(index, refs), finish

    def _frozenset(self, index, refs):
        def finish(values):
            sizes = {}
            for v in values:
                self._key(index, v, sizes)
            return frozenset(values)
        return _NO_SHELL, self._refs(index, refs), finish

    def _array(self, index, dtype, shape, data):
        if dtype not in _ARRAY_TYPES:
            self.fail(index, f"an array of type {str(dtype)[:40]!r}")
        if type(shape) is not list or len(shape) > 32:
            raise TypeError("a shape of at most 32 dimensions expected")
        shape = tuple(self._whole(n, 0) for n in shape)
        raw = base64.b64decode(self._text(data), validate=True)
        value = np.frombuffer(raw, dtype=np.dtype(dtype).newbyteorder("<"))
        if value.size != int(np.prod(shape, dtype=object)):
            raise ValueError(f"{value.size} values for the shape {shape}")
        return self._done(value.astype(dtype).reshape(shape))

    def _random(self, index, version, internal, gauss):
        if version != 3 or type(internal) is not list or len(internal) != 625:
            raise ValueError("the state of a Mersenne Twister (version 3) expected")
        if gauss is not None and type(gauss) is not float:
            raise TypeError("a float or null expected")
        state = tuple(self._integer(v) for v in internal)
        if not all(0 <= v < 2 ** 32 for v in state[:624]) or not 0 <= state[624] <= 624:
            raise ValueError("a word of the state is out of range")
        rng = random.Random(0)
        rng.setstate((3, state, gauss))
        return self._done(rng)

    # ------------------------------------------------------------- SymPy
    def _intern(self, key, make):
        """One object per SymPy content (equal trees are identical, so that
        comparing two never walks a whole tree)."""
        found = self._interned.get(key)
        if found is None:
            found = self._interned[key] = make()
        return found

    def _singleton(self, index, name):
        values = _singletons()[0]
        if type(name) is not str or name not in values:
            self.fail(index, f"unknown SymPy constant {str(name)[:40]!r}")
        return self._done(values[name])

    def _integer_(self, index, text):
        value = self._integer(text)
        return self._done(self._intern(("integer", value), lambda: sm.Integer(value)))

    def _rational(self, index, p, q):
        import math
        p, q = self._integer(p), self._integer(q)
        if q < 2 or math.gcd(p, q) != 1:
            raise ValueError("a fraction in lowest terms with a denominator >= 2 expected")
        return self._done(self._intern(("rational", p, q), lambda: sm.Rational(p, q)))

    def _real(self, index, sign, man, exp, bc, prec):
        bits = 4 * SAVED_FILE_LIMITS["digits"]
        if sign not in (0, 1) or type(sign) is not int:
            raise ValueError("a sign of 0 or 1 expected")
        man, exp = self._integer(man), self._integer(exp)
        bc, prec = self._whole(bc, -2, bits), self._whole(prec, 1, bits)
        if man < 0 or (man and bc != man.bit_length()):
            raise ValueError("the mantissa does not match its bit count")
        if abs(exp) > 1 << 20:  # 2**(2**20) is about 1e315652
            raise ValueError("a binary exponent beyond 2**20")
        mpf = (sign, man, exp, bc)
        return self._done(self._intern(  # zero=False: a Float 0.0 stays one (not 0)
            ("real", mpf, prec), lambda: sm.Float._new(mpf, prec, zero=False)))

    def _flags(self, assumptions):
        if type(assumptions) is not dict or not all(
                type(k) is str and type(v) is bool for k, v in assumptions.items()):
            raise TypeError("assumptions must map names to booleans")
        unknown = [k for k in assumptions if k not in ASSUMPTIONS]
        if unknown:
            raise ValueError(f"{unknown[0][:40]!r} is not a SymPy assumption")
        return assumptions

    def _symbol(self, index, name, assumptions):
        name, flags = self._text(name), self._flags(assumptions)
        key = ("symbol", name, frozenset(flags.items()))
        return self._done(self._intern(key, lambda: sm.Symbol(name, **flags)))

    def _dummy(self, index, name, assumptions):
        return self._done(sm.Dummy(self._text(name), **self._flags(assumptions)))

    def _coordinate(self, index, name, frame, axis):
        from sympy.physics.vector.frame import CoordinateSym
        name, axis = self._text(name), self._whole(axis, 0, 2)

        def finish(values):
            if not schema.is_kind(values[0], _FRAME):
                raise Refused("the frame of a coordinate symbol is not a ReferenceFrame")
            key = ("coordinate", name, id(values[0]), axis)
            return self._intern(key, lambda: CoordinateSym(name, values[0], axis))
        return _NO_SHELL, [self._ref(index, frame)], finish

    def _function(self, index, name, assumptions, kwargs):
        name, flags = self._text(name), self._flags(assumptions)

        def finish(values):
            if type(values[0]) is not dict or values[0]:
                raise Refused("an undefined function with keyword data")
            key = ("function", name, frozenset(flags.items()))
            return self._intern(key, lambda: sm.Function(name, **flags))
        return _NO_SHELL, [self._ref(index, kwargs)], finish

    def _apply(self, index, func, refs):
        def finish(values):
            func, args = values[0], values[1:]
            if not isinstance(func, sm.core.function.UndefinedFunction):
                raise Refused("an application of something that is not an undefined function")
            self._sympy_arguments(args)
            return self._intern(("apply", id(func), *map(id, args)),
                                lambda: func(*args, evaluate=False))
        return _NO_SHELL, [self._ref(index, func)] + self._refs(index, refs), finish

    @staticmethod
    def _sympy_arguments(args):
        _, matrix, expr, _ = schema.sympy_classes() or (None, (), (), None)
        for a in args:
            if not isinstance(a, expr) or isinstance(a, matrix):
                raise Refused(f"a SymPy argument that is {described(a)}")

    def _expr(self, index, name, refs):
        name = self._text(name)
        rule = expression_rules().get(name)
        if rule is None:
            self.fail(index, f"the SymPy class {name[:40]!r} is not allowed")

        def build(args):
            rule.check(args)
            return rule.build(rule.cls, args)

        def finish(args):
            return self._intern(("expr", name, *map(id, args)), lambda: build(args))
        return _NO_SHELL, self._refs(index, refs), finish

    def _matrix(self, index, kind, rows, cols, refs):
        if kind not in ("immutable", "mutable"):
            raise ValueError("a matrix is 'immutable' or 'mutable'")
        refs, most = self._refs(index, refs), SAVED_FILE_LIMITS["nodes"]
        rows, cols = self._whole(rows, 0, most), self._whole(cols, 0, most)
        if rows * cols != len(refs):
            raise ValueError(f"{len(refs)} entries for a {rows} x {cols} matrix")

        def finish(entries):
            self._sympy_arguments(entries)
            cls = sm.ImmutableMatrix if kind == "immutable" else sm.Matrix
            return cls(rows, cols, entries)
        return _NO_SHELL, refs, finish

    # ------------------------------------------------------------ objects
    def _named_path(self, index, name, table):
        name = self._text(name)
        if name not in table:
            self.fail(index, f"the class {name[:80]} is not allowed")
        cls = schema.resolve(name)
        if cls is None:
            self.fail(index, f"no class {name} in this version of kanedyn and SymPy")
        return name, cls

    def _namedtuple(self, index, name, refs):
        name, cls = self._named_path(index, name, schema.NAMED_TUPLES)
        specs = schema.NAMED_TUPLES[name]

        def finish(values):
            if len(values) != len(specs):
                raise Refused(f"{cls.__name__} has {len(specs)} fields, got {len(values)}")
            for field, value, spec in zip(cls._fields, values, specs):
                problem = spec.problem(value, set())
                if problem is not None:
                    raise Refused(f"{cls.__name__} field {field!r} {problem}")
            return cls(*values)
        return _NO_SHELL, self._refs(index, refs), finish

    def _object(self, index, name, attributes):
        name, cls = self._named_path(index, name, schema.OBJECTS)
        specs, where = schema.OBJECTS[name], schema.storage(name)
        if type(attributes) is not list or not all(
                type(p) is list and len(p) == 2 and type(p[0]) is str for p in attributes):
            raise TypeError("a list of [name, reference] pairs expected")
        keys = [p[0] for p in attributes]
        for key in keys:
            if key not in specs:
                self.fail(index, f"{cls.__name__} has no attribute {key[:80]!r} that a "
                                 "saved file may hold")
        if len(set(keys)) != len(keys):
            self.fail(index, f"{cls.__name__} with an attribute given twice")
        obj = object.__new__(cls)
        state = None if all(where[k] is not None for k in keys) else \
            object.__getattribute__(obj, "__dict__")

        def finish(values):
            for key, value in zip(keys, values):
                slot = where[key]
                if slot is None:
                    state[key] = value
                else:
                    slot.__set__(obj, value)  # a member descriptor: stores, runs nothing
            self._checks.append((index, cls.__name__, specs, keys, values))
            return obj
        return obj, self._refs(index, [p[1] for p in attributes]), finish

    def _check_schemas(self):
        memo = set()
        for i, (index, cls, specs, keys, values) in enumerate(self._checks):
            if not i % 64:
                self._tick()
            for key, value in zip(keys, values):
                problem = specs[key].problem(value, memo)
                if problem is not None:
                    self.fail(index, f"{cls} attribute {key!r} {problem}")

    def _method_of(self, owner, name):
        path = schema.class_path(type(owner))
        if (path, name) not in schema.METHODS:
            raise Refused(f"the method {type(owner).__qualname__}.{str(name)[:40]} is not "
                          "allowed")
        return types.MethodType(vars(type(owner))[name], owner), schema.METHODS[path, name]

    def _method(self, index, owner, name):
        name = self._text(name)
        return _NO_SHELL, [self._ref(index, owner)], lambda v: self._method_of(v[0], name)[0]

    def _partial(self, index, func, refs, keywords):
        refs = self._refs(index, refs)

        def finish(values):
            func, args, keywords = values[0], values[1:-1], values[-1]
            if type(func) is not types.MethodType:
                raise Refused("a partial of something that is not an allowed method")
            method, specs = self._method_of(func.__self__, func.__name__)
            owner = type(func.__self__).__name__
            if specs is None:
                raise Refused(f"a partial of {owner}.{func.__name__}, which a file may hold "
                              "as a method only")
            if type(keywords) is not dict or keywords or len(args) != len(specs):
                raise Refused(f"a partial of {owner}.{func.__name__} with {len(args)} "
                              f"arguments and {len(keywords)} keywords (it takes "
                              f"{len(specs)} arguments)")
            for i, (arg, spec) in enumerate(zip(args, specs)):
                problem = spec.problem(arg, set())
                if problem is not None:  # text could reach SymPy's parser
                    raise Refused(f"a partial of {owner}.{func.__name__} whose argument {i} "
                                  f"{problem}")
            return functools.partial(method, *args)
        return _NO_SHELL, [self._ref(index, func), *refs, self._ref(index, keywords)], finish


#: node kind -> the decoder's method that reads it (nothing else is called)
_KINDS = {kind: "_" + kind for kind in (
    "none", "bool", "int", "float", "str", "complex", "tuple", "list", "dict", "frozenset",
    "namedtuple", "array", "random", "singleton", "rational", "real", "symbol", "dummy",
    "coordinate", "function", "apply", "expr", "matrix", "object", "method", "partial")}
_KINDS.update({"set": "_set_", "integer": "_integer_"})


def load(path, timeout=None):
    """Equations of motion saved by :meth:`EquationsOfMotion.save`.

    Reading runs nothing from the file and always ends (see the module notes:
    allow-lists, type checks, size and time limits).

    Parameters
    ----------
    path : str or os.PathLike
    timeout : float, optional
        Seconds the whole read may take (default ``SAVED_FILE_LIMITS["timeout"]``, 60 s).

    Returns
    -------
    EquationsOfMotion

    Raises
    ------
    SavedFileError
        The file is missing, not a saved-equations archive, of another format
        version, damaged (its checksum, which detects accidents, not
        tampering), beyond a size or time limit, or holds something a saved
        file may not (the message names the file, and the node and attribute).
    """
    from ..formulations import EquationsOfMotion
    eom, _ = load_data(path, timeout=timeout)
    if not isinstance(eom, EquationsOfMotion):
        raise SavedFileError(f"{path}: holds a {type(eom).__name__}, not equations of motion")
    return eom


def _read_member(archive, name, limit, path, deadline):
    """The bytes of member ``name``, read in chunks and refused beyond
    ``limit`` (whatever size the archive's headers claim)."""
    info = archive.getinfo(name)
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise SavedFileError(f"{path}: {name} is compressed by a method kanedyn does not "
                             "write")
    if info.file_size > limit:
        raise SavedFileError(f"{path}: {name} is {info.file_size} bytes uncompressed, more "
                             f"than the {limit} a saved file may hold")
    chunks, size = [], 0
    with archive.open(info) as member:
        while True:
            chunk = member.read(1 << 20)
            if not chunk:
                break
            size += len(chunk)
            if size > limit:
                raise SavedFileError(f"{path}: {name} holds more than the {limit} bytes "
                                     "a saved file may hold")
            if time.monotonic() > deadline:
                raise SavedFileError(f"{path}: reading took longer than its time limit")
            chunks.append(chunk)
    return b"".join(chunks)


def _members(path, kind, deadline, opened=None):
    """``(manifest bytes, nodes bytes)`` of the archive (read from the binary
    file ``opened`` where given), within the limits."""
    try:
        size = path.stat().st_size if opened is None else os.fstat(opened.fileno()).st_size
        if size > SAVED_FILE_LIMITS["file_bytes"]:
            raise SavedFileError(f"{path}: {size} bytes, more than the "
                                 f"{SAVED_FILE_LIMITS['file_bytes']} a saved file may have")
        with path.open("rb") if opened is None else contextlib.nullcontext(opened) as handle:
            end = getattr(zipfile, "_EndRecData", lambda _: None)(handle)
            if end is not None and end[zipfile._ECD_ENTRIES_TOTAL] > SAVED_FILE_LIMITS["members"]:
                raise SavedFileError(f"{path}: not a {kind} (it has "
                                     f"{end[zipfile._ECD_ENTRIES_TOTAL]} members)")
            with zipfile.ZipFile(handle) as archive:
                names = set(archive.namelist())
                if not {"manifest.json", "nodes.json"} <= names:
                    raise SavedFileError(f"{path}: not a {kind} (it lacks "
                                         "manifest.json or nodes.json)")
                return tuple(_read_member(archive, name, SAVED_FILE_LIMITS[limit], path,
                                          deadline)
                             for name, limit in (("manifest.json", "manifest_bytes"),
                                                 ("nodes.json", "member_bytes")))
    except FileNotFoundError:
        raise SavedFileError(f"{path}: no such file") from None
    except (zipfile.BadZipFile, OSError, EOFError, RuntimeError, NotImplementedError,
            ValueError) as exc:
        if isinstance(exc, SavedFileError):
            raise
        raise SavedFileError(f"{path}: not a {kind} ({exc})") from None


def _json(text, path, member):
    try:
        return json.loads(text)
    except RecursionError:
        raise SavedFileError(f"{path}: {member} is nested too deeply") from None
    except ValueError as exc:
        raise SavedFileError(f"{path}: {member} is not JSON ({str(exc)[:200]})") from None


def load_data(path, format=FORMAT, timeout=None, opened=None):
    """The object and the manifest of a file written by :func:`save_data`.

    Parameters
    ----------
    path : str or os.PathLike
    format : str
        The content the file must announce in its manifest.
    timeout : float, optional
        Seconds the whole read may take (default ``SAVED_FILE_LIMITS["timeout"]``).
    opened : binary file, optional
        The file ``path`` already open, read instead of opening ``path`` again
        (the derivation cache reads the descriptor it checked the owner of).

    Returns
    -------
    (object, dict)
        The rebuilt object (nothing in the file is evaluated or run: see the
        module notes) and the manifest.

    Raises
    ------
    SavedFileError
        As :func:`load`: the message names the file and the fault.
    """
    path = Path(path)
    timeout = SAVED_FILE_LIMITS["timeout"] if timeout is None else float(timeout)
    deadline = time.monotonic() + timeout
    kind = "kanedyn equations file" if format == FORMAT else f"{format} file"
    manifest_text, nodes_text = _members(path, kind, deadline, opened)
    manifest = _json(manifest_text, path, "manifest.json")
    if not isinstance(manifest, dict) or manifest.get("format") != format:
        found = manifest.get("format") if isinstance(manifest, dict) else None
        raise SavedFileError(f"{path}: not a {kind} (format {str(found)[:80]!r})")
    version = manifest.get("format_version")
    if version != FORMAT_VERSION:
        raise SavedFileError(f"{path}: format version {str(version)[:20]}, written by kanedyn "
                             f"{str(manifest.get('kanedyn_version'))[:20]}; this kanedyn "
                             f"({__version__}) reads version {FORMAT_VERSION}")
    # damage, not tampering: anyone who changes the nodes can recompute it
    if hashlib.sha256(nodes_text).hexdigest() != manifest.get("sha256"):
        raise SavedFileError(f"{path}: nodes.json does not match the checksum in its "
                             "manifest: the file was changed or damaged after it was written")
    containers = nodes_text.count(b"[") + nodes_text.count(b"{")
    if containers > SAVED_FILE_LIMITS["containers"]:
        raise SavedFileError(f"{path}: nodes.json holds {containers} lists, more than the "
                             f"{SAVED_FILE_LIMITS['containers']} a saved file may hold")
    nodes = _json(nodes_text, path, "nodes.json")
    del nodes_text
    count = manifest.get("nodes")
    if not isinstance(nodes, list) or len(nodes) != count:
        raise SavedFileError(f"{path}: nodes.json does not hold the {str(count)[:20]} "
                             "nodes its manifest announces")
    if len(nodes) > SAVED_FILE_LIMITS["nodes"]:
        raise SavedFileError(f"{path}: {len(nodes)} nodes, more than the "
                             f"{SAVED_FILE_LIMITS['nodes']} a saved file may hold")
    return _Decoder(nodes, path, deadline, timeout).decode(manifest.get("root")), manifest
