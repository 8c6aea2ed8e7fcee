"""Saved files from elsewhere: ``kd.load`` runs no code and always ends.

Every known attack on the reader, written as a file with a valid checksum
(anyone can recompute it), is refused with a ``SavedFileError`` that names
the file (and the node and attribute), or is loaded exactly as stored,
without running anything; then the same over a seeded mutation loop of real
saved files.  Loads that could hang run in a child process watched by the
test, so that a hang fails the test instead of stalling the run."""

import copy
import hashlib
import json
import os
import queue
import random
import re
import subprocess
import sys
import threading
import warnings
import zipfile
from pathlib import Path

import pytest
import sympy as sm

import kanedyn as kd
from kanedyn.io import load_data, save_data

SRC = str(Path(__file__).resolve().parents[1] / "src")
#: seconds one load may take in the watched child before the test fails (a
#: hang detector, not a timing: real loads take 0.01 to 0.2 s)
BOUND = 60.0
BIG = "9" * 999  # digits of an integer within the reader's limit (1000)


def _payload(marker):
    """Text that creates ``marker`` if anything ever runs it as Python."""
    return f"__import__('pathlib').Path({str(marker)!r}).touch() or 1"


_CHILD = r"""
import json, sys
from kanedyn.io import SavedFileError, load_data
for line in sys.stdin:
    path, fmt = json.loads(line)
    try:
        obj, _ = load_data(path, format=fmt)
    except SavedFileError as exc:
        out = ["refused", str(exc)]
    except BaseException as exc:
        out = ["crashed", f"{type(exc).__name__}: {exc}"[:2000]]
    else:
        out = ["loaded", type(obj).__name__]
    print(json.dumps(out), flush=True)
"""


def _load_all(cases):
    """``[(outcome, detail)]`` of loading each ``(label, path, format)`` in one
    child process; fails the test, naming the case, when a load does not end
    within :data:`BOUND` seconds."""
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    child = subprocess.Popen([sys.executable, "-c", _CHILD], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True, env=env)
    lines = queue.Queue()

    def read():
        for line in child.stdout:
            lines.put(line)
        lines.put(None)  # the child ended
    threading.Thread(target=read, daemon=True).start()
    out = []
    try:
        for label, path, fmt in cases:
            child.stdin.write(json.dumps([str(path), fmt]) + "\n")
            child.stdin.flush()
            try:
                line = lines.get(timeout=BOUND)
            except queue.Empty:
                pytest.fail(f"loading {label} ({path}) did not end within {BOUND} s")
            if line is None:
                pytest.fail(f"the child process died loading {label} ({path})")
            out.append(tuple(json.loads(line)))
    finally:
        child.kill()
        child.wait()
    return out


# ------------------------------------------------------ code in setters
@pytest.mark.parametrize("cls, attribute", [
    ("particle.Particle", "mass"), ("particle.Particle", "potential_energy"),
    ("rigidbody.RigidBody", "mass"), ("rigidbody.RigidBody", "potential_energy"),
    ("rigidbody.RigidBody", "masscenter"), ("particle.Particle", "__class__")])
def test_no_setter_runs(tmp_path, cls, attribute, saved_archive):
    """A body whose saved state names a property (whose setter sympifies text,
    running it as Python) is refused before anything is set."""
    marker = tmp_path / "ran"
    path = saved_archive(tmp_path / "setter.kdeom", [
        ["object", f"sympy.physics.mechanics.{cls}", [[attribute, 1]]],
        ["str", _payload(marker)]])
    with pytest.raises(kd.SavedFileError, match=rf"setter\.kdeom: node 0: "
                       rf"{cls.split('.')[1]} has no attribute '{attribute}' that a saved "
                       "file may hold"):
        kd.load(path)
    assert not marker.exists()


def test_text_where_sympy_belongs_is_refused_by_attribute(tmp_path, saved_archive):
    """Text in a body's own mass slot (which its ``mass`` property returns as
    it is, to code that converts it) is refused naming file, node, class and
    attribute."""
    marker = tmp_path / "ran"
    path = saved_archive(tmp_path / "typed.kdeom", [
        ["object", "sympy.physics.mechanics.particle.Particle", [["_mass", 1]]],
        ["str", _payload(marker)]])
    with pytest.raises(kd.SavedFileError, match=r"typed\.kdeom: node 0: Particle attribute "
                                                "'_mass' is a str, not a SymPy expression"):
        kd.load(path)
    assert not marker.exists()


# --------------------------------------------- constructors that compute
def _shared_tree(nodes, depth, variant=""):
    """Append ``a_k = a_(k-1) * a_(k-1)`` (``a_0 = x + y``): ``depth`` nodes whose
    tree, walked without sharing, has 2**depth leaves; returns ``a_depth``."""
    nodes += [["symbol", f"x{variant}", {}], ["symbol", f"y{variant}", {}]]
    nodes.append(["expr", "Add", [len(nodes) - 2, len(nodes) - 1]])
    for _ in range(depth):
        nodes.append(["expr", "Mul", [len(nodes) - 1, len(nodes) - 1]])
    return len(nodes) - 1


def _power(nodes, last=9):
    """Append ``9**(9...9last)`` (999 digits), unevaluated; returns its index."""
    nodes += [["integer", "9"], ["integer", BIG[:-1] + str(last)]]
    nodes.append(["expr", "Pow", [len(nodes) - 2, len(nodes) - 1]])
    return len(nodes) - 1


def _add(nodes, *new):
    """Append nodes; the index of the last."""
    nodes.extend(new)
    return len(nodes) - 1


def _relation(nodes, name, last=9):
    """Append ``name(9**(9...9last), 9)``; its index."""
    big = _power(nodes, last)
    return _add(nodes, ["expr", name, [big, big - 2]])


def _tuple_tree(nodes, depth):
    """Append nested tuples ``t_k = (t_(k-1), t_(k-1))``: hashing ``t_depth``
    walks 2**depth tuples (a tuple's hash is not cached); its index."""
    top = _add(nodes, ["int", "1"], ["tuple", [len(nodes)]])
    for _ in range(depth):
        top = _add(nodes, ["tuple", [top, top]])
    return top


def _rooted(make):
    """The nodes of a file whose root (node 0) is ``make(nodes)``."""
    nodes = [None]
    nodes[0] = make(nodes)
    return nodes


def _with_power(name):
    return lambda n: ["expr", name, [_power(n), len(n) - 3]]


def _derivative(order):
    def make(n):
        top = _shared_tree(n, 80)
        variable = top - 81 if order else top - 80  # x, or the sum x + y
        count = _add(n, ["integer", str(order or 1)])
        return ["expr", "Derivative", [top, _add(n, ["expr", "Tuple", [variable, count]])]]
    return make


EVALUATING = {
    # label: (root of the file, expected outcome, the class loaded or the message)
    "Max of a huge power": (_with_power("Max"), "loaded", "Max"),
    "Min of a huge power": (_with_power("Min"), "loaded", "Min"),
    "Max of a 4000-digit integer": (lambda n: ["expr", "Max", [
        _add(n, ["integer", "9" * 4000]), _add(n, ["integer", "9"])]],
        "refused", "an integer of at most 1000 digits"),
    "Eq of a huge power": (_with_power("Equality"), "loaded", "Equality"),
    "Not of a relation": (lambda n: ["expr", "Not", [_relation(n, "StrictGreaterThan")]],
                          "loaded", "Not"),
    "And of relations": (lambda n: ["expr", "And", [_relation(n, "StrictGreaterThan"),
                                                     _relation(n, "LessThan")]],
                         "loaded", "And"),
    "Piecewise on a relation": (lambda n: ["expr", "Piecewise", [_add(n, [
        "expr", "ExprCondPair", [_power(n), _relation(n, "GreaterThan")]])]],
        "loaded", "Piecewise"),
    "sin of a huge rational": (lambda n: ["expr", "sin", [_add(n, ["rational", BIG, "7"])]],
                               "loaded", "sin"),
    "a huge sum of products": (lambda n: ["expr", "Add", [_power(n), _add(n, [
        "expr", "Mul", [len(n) - 1, len(n) - 3]])]], "loaded", "Add"),
    "Derivative of a shared tree": (_derivative(2), "loaded", "Derivative"),
    "Derivative by an expression": (_derivative(0), "refused", "argument 1 of Derivative "
                                    r"is a Tuple, not a \(variable, order\) pair"),
    "Max of a shared tree": (lambda n: ["expr", "Max", [_shared_tree(n, 80), len(n) - 82]],
                             "loaded", "Max"),
    "a shared tuple tree as a dict key": (lambda n: ["dict", [[_tuple_tree(n, 80), 0]]],
                                          "refused", "a tuple of more than 64 items used "
                                                     "as a key"),
    "a shared tuple tree in a set": (lambda n: ["frozenset", [_tuple_tree(n, 80)]],
                                     "refused", "a tuple of more than 64 items used as a key"),
    "a Vector as a dict key": (lambda n: ["dict", [[_add(n, [
        "object", "sympy.physics.vector.vector.Vector", [["args", len(n) + 1]]]),
        _add(n, ["list", []])]]], "refused", "a Vector used as a dict key or set member"),
}


def test_constructors_that_compute_are_never_asked_to(tmp_path, saved_archive):
    """Each construct whose SymPy constructor (or hash) would compute without
    bound on these arguments (``Max`` of a 10**999-digit power, ``Derivative``
    walking a tree of 2**80 leaves, a tuple whose hash does the same) is
    loaded as stored or refused, at once; loaded in a watched child."""
    cases = [(label, saved_archive(tmp_path / f"{i}.kdeom", _rooted(make)), "kanedyn-equations")
             for i, (label, (make, _, _)) in enumerate(EVALUATING.items())]
    for (label, (_, outcome, detail)), got in zip(EVALUATING.items(), _load_all(cases)):
        assert got[0] == outcome, (label, got)
        assert (got[1] == detail if outcome == "loaded" else re.search(detail, got[1])), (
            label, got)
    # known to end (above): what was loaded is the expression as stored
    value = load_data(cases[0][1])[0]
    assert type(value) is sm.Max
    assert set(value.args) == {sm.Integer(9), sm.Pow(9, int(BIG), evaluate=False)}


def _argument(nodes, kind, k):
    """Append an argument of the kind a rule names (see
    ``kanedyn.io._saved_sympy``) that would make evaluating it run without
    bound: a huge power, a 2**80-fold shared tree, a relation of them."""
    if kind == "an expression":  # k tells them apart (Max, And take distinct ones)
        return _power(nodes, k) if k % 2 == 0 else _shared_tree(nodes, 80, k)
    if kind == "a condition":
        return _relation(nodes, "StrictGreaterThan" if k % 2 == 0 else "LessThan", k)
    if kind == "an (expression, condition) pair":
        return _add(nodes, ["expr", "ExprCondPair", [_argument(nodes, "an expression", k),
                                                     _argument(nodes, "a condition", k)]])
    if kind == "a (variable, order) pair":
        return _add(nodes, ["symbol", "t", {}], ["integer", "3"],
                    ["expr", "Tuple", [len(nodes), len(nodes) + 1]])
    return _argument(nodes, "an expression", k)  # any SymPy object


def test_every_allowed_class_is_rebuilt_without_computing(tmp_path, saved_archive):
    """The audit of the allow-list: every SymPy class a file may name, given
    as many arguments as it takes (two more where it takes any number) of the
    kinds it takes, each one that evaluating would take without bound on, is
    loaded as stored (in a watched child)."""
    from kanedyn.io._saved_sympy import expression_rules
    cases, wanted = [], []
    for name, rule in sorted(expression_rules().items()):
        nodes = [None]
        count = rule.high if rule.high is not None else max(rule.low, 2) + 2
        kinds = [rule.kinds[i] if i < len(rule.kinds) else rule.rest for i in range(count)]
        nodes[0] = ["expr", name, [_argument(nodes, kind.text, k)
                                   for k, kind in enumerate(kinds)]]
        cases.append((name, saved_archive(tmp_path / f"{name}.kdeom", nodes),
                      "kanedyn-equations"))
        wanted.append(("loaded", rule.cls.__name__))
    assert len(cases) == len(expression_rules()) >= 38
    assert _load_all(cases) == wanted


# ------------------------------------------------------------- nesting
def test_deep_nesting_is_refused_not_a_recursion_error(tmp_path, saved_archive):
    chain = [["list", [i + 1]] for i in range(20000)] + [["none"]]
    with pytest.raises(kd.SavedFileError, match=r"deep\.kdeom: node 4999: the objects are "
                                                "nested more than 5000 deep"):
        load_data(saved_archive(tmp_path / "deep.kdeom", chain))
    text = b"[" + b"[" * 200000 + b"]" * 200000 + b"]"
    path = tmp_path / "json.kdeom"
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("manifest.json", json.dumps({
            "format": "kanedyn-equations", "format_version": 1, "root": 0, "nodes": 1,
            "sha256": hashlib.sha256(text).hexdigest()}))
        z.writestr("nodes.json", text)
    with pytest.raises(kd.SavedFileError, match=r"json\.kdeom: .*nested too deeply"):
        load_data(path)


@pytest.mark.parametrize("nodes, node", [
    ([["tuple", [0]]], 0),
    ([["list", [1]], ["expr", "sin", [2]], ["expr", "cos", [1]]], 2)])
def test_a_cycle_through_an_immutable_node_is_refused(tmp_path, nodes, node, saved_archive):
    with pytest.raises(kd.SavedFileError, match=rf"cycle\.kdeom: node {node}: it refers back "
                                                "to node"):
        load_data(saved_archive(tmp_path / "cycle.kdeom", nodes))


# ------------------------------------------------------------ the archive
def _claim(path, name, size):
    """Rewrite the uncompressed size that the archive's headers claim for ``name``."""
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as z:
        local = z.getinfo(name).header_offset
    central = data.find(b"PK\x01\x02")
    while data[central + 46:central + 46 + len(name)] != name.encode():
        central = data.find(b"PK\x01\x02", central + 4)
    for at in (local + 22, central + 24):
        data[at:at + 4] = size.to_bytes(4, "little")
    path.write_bytes(bytes(data))
    return path


def test_sizes_claimed_by_the_headers_are_not_trusted(tmp_path):
    """A member whose headers claim fewer bytes than it holds is read only that
    far and fails its CRC; the reader counts what it reads, in chunks, and stops
    at its own limit whatever the headers say.  (A member whose headers tell the
    truth about a bomb is refused unread: the catalogue's zip-bomb case.)"""
    path = kd.models.build("pendulum").derive().save(tmp_path / "claims.kdeom")
    _claim(path, "nodes.json", 1000)
    with pytest.raises(kd.SavedFileError, match=r"claims\.kdeom: not a kanedyn equations "
                                                "file .*CRC"):
        kd.load(path)


# ------------------------------------------------- the derivation cache
def test_a_planted_cache_entry_runs_nothing(tmp_path, monkeypatch, saved_archive):
    """An entry planted in the derivation cache is read by the same reader: a
    setter payload is refused, and an entry carrying C source (which building
    its module would compile and load, running its constructor) is refused
    before anything is built; each is reported, removed and derived again."""
    from kanedyn.models._base import CACHE_FORMAT, _cache_path, _read_cache
    from kanedyn.numerics import compiler_command
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path / "cache"))
    marker = tmp_path / "ran"
    c_code = ("#include <stdlib.h>\n__attribute__((constructor)) static void planted(void)"
              f" {{ system(\"touch {marker}\"); }}\n")
    fields = {"backend": "c", "scheme": "elimination", "p": [], "inputs": [], "c_key": str(marker),
              "c_source": c_code, "sources": None, "body_parameters": [],
              "c_lanes_later": False}
    plain = []
    for key, value in fields.items():
        for v in (key, value):
            kind = ({str: "str", bool: "bool", type(None): "none", list: "list"}[type(v)])
            plain.append([kind] + ([] if v is None else [[]] if kind == "list" else [v]))
    code_entry = [["dict", [[i + 1, i + 2] for i in range(0, len(plain), 2)]]] + plain
    setter_entry = [["dict", [[1, 2]]], ["str", "bodies"],
                    ["object", "sympy.physics.mechanics.particle.Particle", [["mass", 3]]],
                    ["str", _payload(marker)]]
    entries = [("setter", setter_entry, "Particle has no attribute 'mass'")]
    if compiler_command() is not None:
        entries.append(("code", code_entry, "carrying source code"))
    for label, nodes, message in entries:
        path = _cache_path(f"{label:0<24}")
        path.parent.mkdir(parents=True, exist_ok=True)
        saved_archive(path, nodes, fmt=CACHE_FORMAT, definition={"name": "planted"})
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert _read_cache(f"{label:0<24}") is None
        assert any(message in str(w.message) and "derived again" in str(w.message)
                   for w in caught), [str(w.message) for w in caught]
        assert not path.exists()
    assert not marker.exists()


# ----------------------------------------------------------------- fuzz
_KINDS = ["none", "bool", "int", "float", "str", "complex", "tuple", "list", "dict", "set",
          "frozenset", "namedtuple", "array", "random", "singleton", "integer", "rational",
          "real", "symbol", "dummy", "coordinate", "function", "apply", "expr", "matrix",
          "object", "method", "partial", "get", "eval", ""]
_CLASSES = ["os.system", "builtins.eval", "subprocess.Popen", "sympy.core.sympify.sympify",
            "kanedyn.numerics._model.NumericModel", "sympy.physics.mechanics.particle.Particle",
            "sympy.physics.mechanics.rigidbody.RigidBody", "sympy.physics.vector.vector.Vector",
            "sympy.physics.mechanics.loads.Force", "kanedyn.engine._program.Program",
            "Max", "Min", "Piecewise", "ExprCondPair", "And", "Or", "Not", "Derivative",
            "Eq", "StrictGreaterThan", "Function", "Lambda", "Symbol", "Integer", "sympify",
            "__import__", "Tuple", "Pow", "Add"]
#: properties of SymPy's bodies (``mass`` and ``potential_energy`` sympify text)
_BODY_SETTERS = ["mass", "potential_energy", "masscenter", "point", "frame", "inertia",
                 "central_inertia"]
_SETTERS = _BODY_SETTERS + ["__class__", "__dict__", "__init__", "__setstate__",
            "__reduce__", "_mass", "name", "args", "_potential_energy", "_defs"]
_SYMPY_KINDS = {"symbol", "dummy", "integer", "rational", "real", "singleton", "expr",
                "apply", "coordinate", "function"}
_REF_FIELDS = {"tuple": 1, "list": 1, "set": 1, "frozenset": 1, "expr": 2, "apply": 2,
               "namedtuple": 2, "matrix": 4}


def _children(node):
    """The positions ``(field, item)`` of the references in ``node`` (none in
    a node that earlier mutations left malformed)."""
    kind = node[0] if isinstance(node, list) and node and isinstance(node[0], str) else None
    field = _REF_FIELDS.get(kind, 1 + (kind == "object"))
    if kind is None or len(node) <= field or not isinstance(node[field], list):
        return []
    if kind in _REF_FIELDS:
        return [(field, i) for i in range(len(node[field]))]
    if kind not in ("dict", "object"):
        return []
    pairs = [i for i, p in enumerate(node[field]) if isinstance(p, list) and len(p) == 2]
    return [(field, (i, 1)) for i in pairs] + (
        [(field, (i, 0)) for i in pairs] if kind == "dict" else [])


def _set_ref(node, position, value):
    field, item = position
    if isinstance(item, tuple):
        node[field][item[0]][item[1]] = value
    else:
        node[field][item] = value


def _pick(rng, nodes, kinds=None):
    found = [i for i, n in enumerate(nodes) if isinstance(n, list) and n
             and (kinds is None or isinstance(n[0], str) and n[0] in kinds)]
    return rng.choice(found) if found else None


def _point_at(rng, nodes, target):
    """Make a random reference of a random container point at ``target``."""
    holders = [i for i, n in enumerate(nodes) if _children(n)]
    i = rng.choice(holders)
    _set_ref(nodes[i], rng.choice(_children(nodes[i])), target)


def _mutate(rng, nodes, payload, op=None):
    """Apply mutation ``op`` (0 to 13; drawn when ``None``) to ``nodes``."""
    op = rng.randrange(14) if op is None else op
    if op == 0:  # another kind
        nodes[_pick(rng, nodes)][0] = rng.choice(_KINDS)
    elif op == 1:  # another class name
        i = _pick(rng, nodes, {"object", "namedtuple", "expr"})
        if i is not None:
            nodes[i][1] = rng.choice(_CLASSES)
    elif op == 2:  # a huge number
        i = _pick(rng, nodes, {"int", "integer", "rational", "real"})
        if i is not None:
            digits = ("-" if rng.random() < 0.3 else "") + "9" * rng.choice(
                [999, 1000, 1001, 4300, 20000])
            nodes[i][rng.randrange(1, 3 if nodes[i][0] == "rational" else 2)] = digits
    elif op == 3:  # a deep nest
        depth = rng.choice([10, 4999, 5001, 6000])
        kind = rng.choice(["list", "tuple", "expr"])
        start = len(nodes)
        for k in range(depth):
            nodes.append(["expr", "sin", [start + k + 1]] if kind == "expr"
                         else [kind, [start + k + 1]])
        nodes.append(["symbol", "x", {}])
        _point_at(rng, nodes, start)
    elif op == 4:  # text where SymPy belongs
        i = _pick(rng, nodes, _SYMPY_KINDS)
        if i is not None:
            nodes[i] = ["str", payload]
    elif op == 5:  # an attribute named as a property, holding code as text
        objects = [i for i, n in enumerate(nodes) if n and n[0] == "object"]
        bodies = [i for i in objects if "mechanics" in str(nodes[i][1])]
        if objects:
            body = bool(bodies) and rng.random() < 0.7
            i = rng.choice(bodies if body else objects)
            nodes.append(["str", payload])
            attributes = nodes[i][2]
            entry = [rng.choice(_BODY_SETTERS if body else _SETTERS), len(nodes) - 1]
            if attributes and rng.random() < 0.5:
                attributes[rng.randrange(len(attributes))] = entry
            else:
                attributes.append(entry)
    elif op == 6:  # a reference out of range or of the wrong type
        i = _pick(rng, nodes, set(_REF_FIELDS) | {"dict", "object"})
        if i is not None and _children(nodes[i]):
            _set_ref(nodes[i], rng.choice(_children(nodes[i])),
                     rng.choice([-1, len(nodes), 10 ** 20, True, 1.5, "0", None, [0]]))
    elif op == 7:  # a reference to the node itself
        i = _pick(rng, nodes, set(_REF_FIELDS) | {"dict", "object"})
        if i is not None and _children(nodes[i]):
            _set_ref(nodes[i], rng.choice(_children(nodes[i])), i)
    elif op == 8:  # a class that computes on construction, on a huge power
        i = _pick(rng, nodes, {"expr"})
        if i is not None:
            nodes[i][1] = rng.choice(["Max", "Min", "And", "Or", "Piecewise", "Derivative",
                                      "StrictGreaterThan", "Eq", "Not", "ExprCondPair"])
            nodes[i][2].append(_power(nodes))
    elif op == 9:  # a tree shared 2**80-fold
        top = _shared_tree(nodes, 80)
        if rng.random() < 0.5:
            nodes.append(["expr", rng.choice(["Max", "Derivative", "Piecewise"]),
                          [top, top - 81]])
            top = len(nodes) - 1
        _point_at(rng, nodes, top)
    elif op == 10:  # a tuple tree as a key
        top = _tuple_tree(nodes, 80)
        i = _pick(rng, nodes, {"dict"})
        if i is not None and nodes[i][1]:
            nodes[i][1][0][0] = top
        else:
            nodes.append(["frozenset", [top]])
            _point_at(rng, nodes, len(nodes) - 1)
    elif op == 11:  # assumptions that are not
        i = _pick(rng, nodes, {"symbol", "dummy", "function"})
        if i is not None:
            nodes[i][2] = rng.choice([{"__class__": True}, {"_imp_": True}, {"real": "yes"},
                                      {"evalf": False}, [payload], payload])
    elif op == 12:  # junk in place of a node or a field
        i = _pick(rng, nodes)
        junk = rng.choice([{}, [], 5, "x", None, [[0]], ["list", 5], ["object", 5, 5],
                           ["array", "object", [1], "AA=="], ["array", "float64", [10 ** 9], ""],
                           ["random", 3, ["1"] * 3, None], ["method", 0, "__init__"],
                           ["method", 0, "copy"], ["partial", 0, [payload], 0],
                           ["real", 0, "5", "0", 99999, 53], ["matrix", "mutable", 2, 2, [0]]])
        nodes[i] = copy.deepcopy(junk)
    else:  # a method or partial pointed elsewhere
        i = _pick(rng, nodes, {"method", "partial"})
        if i is not None:
            if nodes[i][0] == "method":
                nodes[i][2] = rng.choice(["__init__", "copy", "declare", "_specified",
                                          "__reduce__", "let", "__class__"])
            else:
                nodes[i][1] = _pick(rng, nodes)


#: mutated files per base: rigid bodies and a potential, contacts, vector
#: constraints, a flexible body (arrays; a larger file), derivation-cache data
CASES = {"pendulum": 160, "falling-rod": 120, "rod-bead": 120, "spin-up-beam": 30,
         "cache-like": 80}


@pytest.fixture(scope="module")
def real_files(tmp_path_factory):
    """Saved equations of models of each kind, and a file shaped like a
    derivation-cache entry: ``[(name, nodes, root, format)]``."""
    import numpy as np

    from kanedyn.modeling._physical import BodyValues
    out = []
    folder = tmp_path_factory.mktemp("real")
    for name in CASES:
        if name != "cache-like":
            path = kd.models.build(name).derive().save(folder / f"{name}.kdeom")
            out.append((name, path, "kanedyn-equations"))
    numbers = {"backend": "c", "scheme": "elimination", "p": [1.0, 9.81], "n_q": 1,
               "state_names": ("q", "u"), "constants": {"m": 1.0},
               "bodies": [BodyValues("bob", "particle", 1.0, np.array([0.0, 1.0, 2.0]))]}
    out.append(("cache-like", save_data(numbers, folder / "numbers.kdnum",
                                              format="kanedyn-derived-model"),
                "kanedyn-derived-model"))
    files = []
    for name, path, fmt in out:
        with zipfile.ZipFile(path) as z:
            manifest = json.loads(z.read("manifest.json"))
            files.append((name, json.loads(z.read("nodes.json")), manifest["root"], fmt))
    return files


@pytest.mark.slow
def test_fuzz_no_code_runs_and_every_load_ends(real_files, tmp_path, saved_archive):
    """A seeded mutation loop over real saved files (kinds and class names
    swapped, huge integers, deep nests, code as text where SymPy objects
    belong, attributes named as property setters, references out of range and
    back to themselves, classes that compute on construction over huge powers,
    trees and tuples shared 2**80-fold, junk nodes, retargeted methods): each
    load, in a watched child, returns or raises SavedFileError, and the
    marker that every payload would create is never written."""
    marker = tmp_path / "ran"
    payload = _payload(marker)
    rng = random.Random(33)
    cases = []
    for name, nodes, root, fmt in real_files:
        for k in range(CASES[name]):
            mutated = copy.deepcopy(nodes)
            if k < 14:  # each mutation alone once, then one to three at random
                _mutate(rng, mutated, payload, op=k)
            for _ in range(0 if k < 14 else rng.choice([1, 1, 2, 3])):
                _mutate(rng, mutated, payload)
            path = saved_archive(tmp_path / f"{name}-{k}.kd", mutated, root=root, fmt=fmt)
            cases.append((f"{name} mutation {k}", path, fmt))
    raw = (tmp_path / f"{real_files[0][0]}-0.kd").read_bytes()
    for k, cut in enumerate((10, len(raw) // 2, len(raw) - 5)):
        (tmp_path / f"cut-{k}.kd").write_bytes(raw[:cut])
        cases.append((f"truncated at {cut}", tmp_path / f"cut-{k}.kd", "kanedyn-equations"))
    results = _load_all(cases)
    crashed = [(label, detail) for (label, _, _), (outcome, detail) in zip(cases, results)
               if outcome == "crashed"]
    assert not crashed, crashed[:5]
    assert not marker.exists()
    refused = [detail for outcome, detail in results if outcome == "refused"]
    assert len(refused) > len(cases) // 2  # the mutations reach the checks
    assert all(str(tmp_path) in detail for detail in refused)  # the file is named
