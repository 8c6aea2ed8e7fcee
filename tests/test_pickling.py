"""Numerical models pickle: in another interpreter (and, for C, another cache
directory, so the module is rebuilt from the carried source) they give the
same right-hand side; a lambda input is named when it cannot be pickled."""

import json
import os
import pickle
import shutil
import subprocess
import sys

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.numerics.backends._c import compiler_command

_SCRIPT = """
import json, pickle, sys
import numpy as np
model = pickle.loads(open(sys.argv[1], 'rb').read())
y = np.array(json.loads(sys.argv[2]))
print(json.dumps([float(v).hex() for v in model.rhs(0.25, y)]))
"""


def _rhs_elsewhere(tmp_path, model, y, env=None):
    path = tmp_path / "model.pkl"
    path.write_bytes(pickle.dumps(model))
    out = subprocess.run([sys.executable, "-c", _SCRIPT, str(path), json.dumps(y.tolist())],
                         capture_output=True, text=True, check=True,
                         env=dict(os.environ, **(env or {})))
    return np.array([float.fromhex(v) for v in json.loads(out.stdout)])


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_unpickled_model_in_another_process(tmp_path, backend):
    if backend == "c" and compiler_command() is None:
        pytest.skip("no C compiler")
    d = kd.models.build("whipple-bicycle")  # constraints, dependent coordinates
    model = d.numeric(backend=backend)
    y = model.consistent_state(0.0, d.initial(model))
    env = {"KANEDYN_CACHE_DIR": str(tmp_path / "empty-cache")} if backend == "c" else None
    elsewhere = _rhs_elsewhere(tmp_path, model, y, env)
    here = model.rhs(0.25, y)
    if backend == "numpy":
        np.testing.assert_array_equal(elsewhere, here)  # bit for bit
    else:
        np.testing.assert_allclose(elsewhere, here, rtol=1e-15, atol=1e-15)
        assert any((tmp_path / "empty-cache").iterdir())  # rebuilt from the carried source


def test_unpicklable_input_is_named():
    d = kd.models.build("n-link-pendulum-on-cart", n=1)
    eom = d.derive()
    (force,) = eom.specified
    model = d.numeric(eom, specified={force: lambda t: np.sin(t)})
    with pytest.raises(pickle.PicklingError, match=r"specified input F\(t\).*module level"):
        pickle.dumps(model)


def test_module_level_input_pickles():
    d = kd.models.build("n-link-pendulum-on-cart", n=1)
    eom = d.derive()
    model = d.numeric(eom, specified={eom.specified[0]: np.sin})
    clone = pickle.loads(pickle.dumps(model))
    y = np.array([0.1, 0.2, 0.3, 0.4])
    np.testing.assert_array_equal(clone.rhs(0.7, y), model.rhs(0.7, y))


def test_with_constants_updates_contact_coefficients():
    """Friction and restitution coefficients follow with_constants (a sweep
    over mu changes the contacts' numbers, not only the generated code's)."""
    d = kd.models.build("falling-rod")
    eom = d.derive()
    model = d.numeric(eom)
    changed = pickle.loads(pickle.dumps(model.with_constants({"mu": 0.1, "e": 0.2})))
    fresh = d.numeric(eom, constants={"mu": 0.1, "e": 0.2})
    assert changed._data["contacts"] == fresh._data["contacts"]
    assert changed._data["contacts"] != model._data["contacts"]


_CACHED = """
import json, pickle, sys
import numpy as np
import kanedyn as kd
from kanedyn.models._base import DERIVE_STATS
d = kd.models.build("chain3d", n=4, style="positions")
model = d.numeric(backend="c").with_constants({"m": 1.5})
open(sys.argv[1], "wb").write(pickle.dumps(model))
y = d.initial(model) + 0.1
print(json.dumps([DERIVE_STATS["derivations"], type(d).__name__,
                  [float(v).hex() for v in model.rhs(0.25, y)], list(y)]))
"""

_UNPICKLED = """
import json, pickle, sys
import numpy as np
from kanedyn.models._base import DERIVE_STATS
import kanedyn as kd
model = pickle.loads(open(sys.argv[1], "rb").read())
f = model.rhs(0.25, np.array(json.loads(sys.argv[2])))
kd.numerics.finish_compiling()
print(json.dumps([DERIVE_STATS["derivations"], model.constants["m"],
                  [float(v).hex() for v in f]]))
"""


def _run(code, folder, *args):
    """``code`` in another interpreter with the cache ``folder``: its last line, read
    as JSON."""
    out = subprocess.run([sys.executable, "-c", code, *args], capture_output=True,
                         text=True, env=dict(os.environ, KANEDYN_CACHE_DIR=str(folder)))
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def pickled_from_the_cache(tmp_path_factory, generic_runtime_object):
    """``(cache, path, first, second)``: chain3d pickled by a first process (the cache
    without a derivation or a module, the generic runtime's object in it: derived
    and built) and by a second (read from the cache), whose pickle is at ``path``;
    ``first`` and ``second`` their reports.  Shared by the tests below, which copy
    the cache before they change it."""
    if compiler_command() is None:
        pytest.skip("no C compiler")
    tmp = tmp_path_factory.mktemp("pickled")
    cache, path = tmp / "cache", tmp / "model.pkl"
    generic_runtime_object(cache)
    first = _run(_CACHED + "kd.numerics.finish_compiling()\n", cache, str(path))
    second = _run(_CACHED, cache, str(path))
    return cache, path, first, second


@pytest.mark.slow
def test_a_built_in_model_from_the_cache_pickles_without_being_derived(
        pickled_from_the_cache, tmp_path):
    """Read from the derivation cache, a built-in model pickles as its name and
    options (no derivation, no source); unpickled where the cache holds its module
    it is not derived either, and where the cache is empty it is derived and built
    there: the same right-hand side, its new constants kept."""
    cache, path, first, (derivations, kind, f, y) = pickled_from_the_cache
    empty = tmp_path / "empty"
    assert first[0] == 1 and first[1] == "ModelDefinition"  # derived: the cache was empty
    assert (derivations, kind) == (0, "PendingDefinition")  # from the cache, not derived
    assert f == first[2]
    assert b"c_source" in path.read_bytes() and b"int kd_" not in path.read_bytes()
    assert _run(_UNPICKLED, cache, str(path), json.dumps(y)) == [0, 1.5, f]
    assert _run(_UNPICKLED, empty, str(path), json.dumps(y)) == [1, 1.5, f]
    assert any(empty.iterdir())  # its module built there


_OTHER_VERSION = """
import pickle, sys
import kanedyn as kd
from kanedyn.numerics import NumericModel
state = pickle.loads(open(sys.argv[1], "rb").read()).__getstate__()
state["c_key"] += " (pickled by another version)"
try:
    NumericModel.__new__(NumericModel).__setstate__(state)
except kd.ModelError as exc:
    print(exc)
"""


@pytest.mark.slow
def test_a_pickled_built_in_model_that_derives_differently_here_is_refused(
        pickled_from_the_cache, tmp_path):
    """Unpickled where the cache lacks its module, a built-in model is derived
    there; if that gives another module than the pickled one names, it is refused
    with a message naming the model (not built from the other code).  (The pickle
    of the second process of ``pickled_from_the_cache``, in a copy of its cache.)"""
    shared, path, _, _ = pickled_from_the_cache
    cache = tmp_path / "cache"
    shutil.copytree(shared, cache)
    env = dict(os.environ, KANEDYN_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", _OTHER_VERSION, str(path)], env=env,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "'chain3d'" in out.stdout and "another version of kanedyn" in out.stdout
