"""eom.save / kd.load: round trips of built-in models (same numbers, same
simulations, same explicit matrices), loading in another interpreter, and
files that are damaged, tampered with or of another format."""

import hashlib
import json
import subprocess
import sys
import zipfile
from collections import Counter

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.io._saved import FORMAT_VERSION

CASES = {"chain": ("chain3d", {"n": 3}), "bicycle": ("whipple-bicycle", {}),
         "contact": ("falling-rod", {}), "flexible": ("spin-up-beam", {})}


def _state(definition, model):
    y = definition.initial(model)
    return model.consistent_state(0.0, y) if model.n_q_dep else y


@pytest.fixture(scope="module")
def saved(tmp_path_factory, bicycle):
    """``{label: (definition, eom, saved path)}`` of CASES (the bicycle's equations
    from the session's fixture: derived once for every file that uses them)."""
    out = {}
    for label, (name, options) in CASES.items():
        if label == "bicycle":
            d, eom, _ = bicycle
        else:
            d = kd.models.build(name, **options)
            eom = d.derive()
        path = eom.save(tmp_path_factory.mktemp(label) / f"{name}.kdeom")
        out[label] = (d, eom, path)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("label", list(CASES))
def test_round_trip_same_numbers_and_simulation(saved, label):
    d, eom, path = saved[label]
    loaded = kd.load(path)
    assert isinstance(loaded, kd.EquationsOfMotion)
    assert loaded.state_names == eom.state_names and loaded.method == eom.method
    assert [str(s) for s in loaded.constants] == [str(s) for s in eom.constants]
    a, b = d.numeric(eom), d.numeric(loaded)
    rng = np.random.default_rng(3)
    y0 = _state(d, a)
    for y in (y0, y0 + rng.uniform(-0.05, 0.05, y0.size)):
        np.testing.assert_array_equal(a.mass_matrix(0.2, y), b.mass_matrix(0.2, y))
        np.testing.assert_array_equal(a.forcing(0.2, y), b.forcing(0.2, y))
        np.testing.assert_array_equal(a.rhs(0.2, y), b.rhs(0.2, y))
    t_end = min(d.t_end, 0.5)
    ra = kd.simulate(a, (0.0, t_end), y0, rtol=1e-8, atol=1e-8)
    rb = kd.simulate(b, (0.0, t_end), y0, rtol=1e-8, atol=1e-8)
    assert ra.success and rb.success
    np.testing.assert_array_equal(ra.t, rb.t)
    np.testing.assert_array_equal(ra.y, rb.y)


def test_explicit_matrices_survive(saved):
    """The explicit SymPy views of the loaded equations equal the original's
    (symbols are rebuilt by name and assumptions, so they are the same)."""
    d, eom, path = saved["chain"]
    loaded = kd.load(path)
    assert loaded.mass_matrix == eom.mass_matrix
    assert loaded.forcing == eom.forcing


@pytest.mark.slow
def test_load_in_another_interpreter(saved):
    d, eom, path = saved["bicycle"]
    model = d.numeric(eom)
    y = _state(d, model)
    code = ("import json, sys, numpy as np, kanedyn as kd\n"
            "eom = kd.load(sys.argv[1])\n"
            "c = dict(zip([str(s) for s in eom.constants], json.loads(sys.argv[2])))\n"
            "m = eom.numeric(constants=c)\n"
            "print(json.dumps([float(v).hex() for v in m.rhs(0.2, np.array(json.loads("
            "sys.argv[3])))]))\n")
    values = [d.constants[s] for s in eom.constants]
    out = subprocess.run([sys.executable, "-c", code, str(path), json.dumps(values),
                          json.dumps(y.tolist())], capture_output=True, text=True, check=True)
    got = np.array([float.fromhex(v) for v in json.loads(out.stdout)])
    np.testing.assert_array_equal(got, model.rhs(0.2, y))


def test_loaded_dummies_are_fresh(saved):
    """Intermediates are new dummy symbols: loading twice gives programs that
    share none (no collision with symbols made in this session)."""
    _, eom, path = saved["contact"]
    first, second = kd.load(path), kd.load(path)
    assert not set(first._program._order) & set(second._program._order)
    assert not set(first._program._order) & set(eom._program._order)


def _signature(path):
    """The nodes of a saved file as a multiset of kinds and names (node order,
    and the order of sets of dummy symbols, differ from one save to another)."""
    with zipfile.ZipFile(path) as z:
        nodes = json.loads(z.read("nodes.json"))
    return Counter((n[0], n[1] if n[0] in ("object", "namedtuple", "expr", "symbol", "dummy",
                                            "str", "singleton") else len(n))
                   for n in nodes)


@pytest.mark.slow
def test_every_built_in_model_round_trips(saved, tmp_path):
    """Each built-in model's equations, saved, loaded and saved again, give a
    file of the same nodes: every class and attribute a derivation stores is
    one the reader's schemas accept, and is rebuilt as it was."""
    # the equations of the models of CASES built with their default options are
    # those of the fixture (the same builder, the same options): not derived again
    derived = {name: saved[label][1] for label, (name, options) in CASES.items()
               if not options}
    for name in kd.models.REGISTRY:
        eom = derived[name] if name in derived else kd.models.build(name).derive()
        first = eom.save(tmp_path / f"{name}.kdeom")
        loaded = kd.load(first)
        assert loaded.state_names == eom.state_names, name
        again = loaded.save(tmp_path / f"{name}-again.kdeom")
        assert _signature(again) == _signature(first), name


def test_every_class_a_file_may_hold_exists_and_is_filled_past_its_descriptors():
    """Each class of the reader's tables is found in this version of kanedyn
    and SymPy, and every attribute its schema names is stored in the instance
    (dict or slot), never through a property, setter or other descriptor."""
    from kanedyn.io import _saved_schema as schema
    for path in (*schema.OBJECTS, *schema.NAMED_TUPLES):
        assert isinstance(schema.resolve(path), type), path
    for path in schema.OBJECTS:
        assert set(schema.storage(path)) == set(schema.OBJECTS[path])
    for (path, name) in schema.METHODS:
        assert callable(vars(schema.resolve(path))[name])


# --------------------------------------------------------------- bad files
def _rewrite(path, out, nodes=None, manifest=None, fix_checksum=True):
    with zipfile.ZipFile(path) as z:
        m = json.loads(z.read("manifest.json"))
        n = json.loads(z.read("nodes.json"))
    if nodes is not None:
        n = nodes(n)
    if manifest is not None:
        m = manifest(m)
    text = json.dumps(n).encode()
    if fix_checksum:
        m["sha256"] = hashlib.sha256(text).hexdigest()
        m["nodes"] = len(n)
    with zipfile.ZipFile(out, "w") as z:
        z.writestr("manifest.json", json.dumps(m))
        z.writestr("nodes.json", text)
    return out


def test_not_a_file_of_ours(tmp_path):
    bad = tmp_path / "model.kdeom"
    bad.write_text("hello")
    with pytest.raises(kd.SavedFileError, match=r"model\.kdeom: not a kanedyn"):
        kd.load(bad)
    with pytest.raises(kd.SavedFileError, match="no such file"):
        kd.load(tmp_path / "missing.kdeom")


def test_changed_after_writing(saved, tmp_path):
    _, _, path = saved["contact"]

    def edit(nodes):
        nodes[5] = ["str", "changed"]
        return nodes
    bad = _rewrite(path, tmp_path / "edited.kdeom", nodes=edit, fix_checksum=False)
    with pytest.raises(kd.SavedFileError, match=r"edited\.kdeom: .*checksum"):
        kd.load(bad)


def test_other_format_version(saved, tmp_path):
    _, _, path = saved["contact"]
    bad = _rewrite(path, tmp_path / "future.kdeom",
                   manifest=lambda m: dict(m, format_version=FORMAT_VERSION + 1))
    with pytest.raises(kd.SavedFileError, match=r"future\.kdeom: format version"):
        kd.load(bad)


@pytest.mark.parametrize("node, message", [
    (["object", "os.system", []], "class os.system is not allowed"),
    (["object", "kanedyn.numerics._model.NumericModel", []], "is not allowed"),
    (["expr", "eval", []], "SymPy class 'eval' is not allowed"),
    (["expr", "sin", [999999]], "points outside"),
    (["nonsense"], "unknown kind"),
    (["get", 0], "unknown kind"),
    (["method", 0, "__init__"], "not allowed"),
    (["expr", "sin", ["previous"]], "argument 0 of sin is a str, not an expression"),
])
def test_tampered_nodes_are_refused(saved, tmp_path, node, message):
    """A file rewritten with a valid checksum but a forbidden node: the loader
    names the file and the node and runs nothing."""
    _, _, path = saved["contact"]
    with zipfile.ZipFile(path) as z:
        root = json.loads(z.read("manifest.json"))["root"]

    def edit(nodes):
        if node[-1] == ["previous"]:  # a SymPy function of a string
            nodes.append(["str", "__import__('os').getcwd()"])
            nodes.append(node[:-1] + [[len(nodes) - 1]])
        else:
            nodes.append(node)
        # the root object's first attribute now points at the new node
        nodes[root][2][0][1] = len(nodes) - 1
        return nodes
    bad = _rewrite(path, tmp_path / "tampered.kdeom", nodes=edit)
    with pytest.raises(kd.SavedFileError, match=r"tampered\.kdeom: .*" + message):
        kd.load(bad)


def test_a_partial_holding_text_is_refused(saved, tmp_path):
    """A lazy derivative (a partial of an allowed method) whose argument is text,
    in a file with a valid checksum: refused on loading, so the text can never
    reach SymPy's parser (which runs it as Python)."""
    _, _, path = saved["contact"]
    marker = tmp_path / "ran"
    with zipfile.ZipFile(path) as z:
        root = json.loads(z.read("manifest.json"))["root"]

    def edit(owner, method):
        def rewrite(nodes):
            found = next(i for i, node in enumerate(nodes)
                         if node[0] == "object" and node[1].endswith(owner))
            nodes += [["method", found, method],
                      ["str", f"__import__('pathlib').Path({str(marker)!r}).touch()"],
                      ["int", "1"], ["dict", []]]
            n = len(nodes)
            nodes.append(["partial", n - 4, [n - 3, n - 2], n - 1])
            nodes[root][2][0][1] = len(nodes) - 1
            return nodes
        return rewrite
    for owner, method, message in (
            ("_symbols.SymbolTable", "_specified", r"a partial of SymbolTable\._specified "
             "whose argument 0 is a str, not a SymPy expression"),
            ("_program.Program", "declare", r"a partial of Program\.declare, which a file "
             "may hold as a method only")):
        bad = _rewrite(path, tmp_path / "tampered.kdeom", nodes=edit(owner, method))
        with pytest.raises(kd.SavedFileError, match=r"tampered\.kdeom: node \d+: " + message):
            kd.load(bad)
    assert not marker.exists()


def test_unsavable_content_is_named(tmp_path):
    """Equations holding something a file cannot carry say what and where."""
    d = kd.models.build("pendulum")
    eom = d.derive()
    object.__setattr__(eom, "_extra", lambda t: t)
    with pytest.raises(kd.SavedFileError, match=r"cannot save the equations\._extra: "
                                                "EquationsOfMotion has no attribute '_extra'"):
        eom.save(tmp_path / "x.kdeom")
