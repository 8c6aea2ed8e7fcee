"""``kd.models.build`` of a model in the derivation cache: a PendingDefinition,
compared with the definition built at once (``lazy=False``) in every public use."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.models import ModelDefinition, PendingDefinition
from kanedyn.models._base import DERIVE_STATS

OPTIONS = {"n": 2, "style": "positions"}


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """A cache directory holding chain3d (n = 2)'s compiled numerical model."""
    from kanedyn.numerics import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    path = tmp_path_factory.mktemp("cache")
    path.chmod(0o700)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("KANEDYN_CACHE_DIR", str(path))
        first = kd.models.build("chain3d", **OPTIONS)
        assert type(first) is ModelDefinition  # not in the cache: built by build()
        first.numeric(backend="c")
        # the entry is written once its module is cached (started at once)
        kd.numerics.finish_compiling(start_waiting=False)
    return path


@pytest.fixture()
def pending(cache, monkeypatch):
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(cache))
    definition = kd.models.build("chain3d", **OPTIONS)
    assert type(definition) is PendingDefinition
    return definition


def _state(n, seed=3):
    return np.random.default_rng(seed).normal(size=2 * n)


def test_cached_model_is_read_without_building_and_equals_the_eager_path(pending):
    """The numerical model from the cache (nothing derived, nothing built) gives
    the accelerations of the eagerly built and freshly derived model (numpy
    backend), and the same initial state."""
    before = DERIVE_STATS["derivations"]
    model = pending.numeric(backend="c", constants={"m": 1.5})
    y0 = pending.initial(model)
    assert type(pending) is PendingDefinition  # not built by any of that
    assert DERIVE_STATS["derivations"] == before
    assert pending.name == "chain3d" and pending.title.startswith("3D chain of 2 links")
    eager = kd.models.build("chain3d", lazy=False, **OPTIONS)
    reference = eager.numeric(eager.derive(), constants={"m": 1.5})
    assert np.array_equal(y0, eager.initial(reference))
    y = _state(2)
    assert np.allclose(model.rhs(0.0, y), reference.rhs(0.0, y), rtol=1e-12, atol=1e-12)


def test_reading_a_field_builds_it_into_the_builders_definition(pending):
    """A field read builds the definition once; the object is then a plain
    ModelDefinition whose fields and equations match the eager one's."""
    eager = kd.models.build("chain3d", lazy=False, **OPTIONS)
    assert isinstance(pending, ModelDefinition)
    assert pending.state_names == eager.state_names  # reads kane_args
    assert type(pending) is ModelDefinition
    assert repr(pending) == repr(eager)
    assert pending.constants.keys() == eager.constants.keys()
    eom, reference = pending.derive(), eager.derive()
    y = _state(2, seed=5)
    assert np.allclose(pending.numeric(eom).rhs(0.0, y), eager.numeric(reference).rhs(0.0, y),
                       rtol=1e-12, atol=1e-12)
    # kd.kane on its SymPy objects, as a user passes them
    assert kd.kane(**pending.kane_args).mass_matrix.shape == (2, 2)


def test_dataclasses_replace_on_a_pending_definition(pending):
    """``dataclasses.replace`` (as kanedyn's own analyses use it) gives a
    ModelDefinition with the change and the other fields of the built model."""
    changed = dataclasses.replace(pending, t_end=7.5)
    assert type(changed) is ModelDefinition and changed.t_end == 7.5
    eager = kd.models.build("chain3d", lazy=False, **OPTIONS)
    assert pending.t_end == eager.t_end != 7.5
    assert changed.state_names == eager.state_names
    assert changed.kane_args is pending.kane_args


def test_pickling_a_pending_definition_builds_it_again(pending):
    """A pickled PendingDefinition is its name and options: unpickled, the same
    model (pending again while this process's cache holds it), unbuilt until used."""
    text = pickle.dumps(pending)
    assert type(pending) is PendingDefinition  # pickling does not build it
    again = pickle.loads(text)
    assert type(again) is PendingDefinition
    assert again.state_names == kd.models.build("chain3d", lazy=False, **OPTIONS).state_names


def test_option_errors_come_from_build_with_the_model_in_the_cache(cache, monkeypatch):
    """Options the cache holds no entry for are checked by the builder in
    ``build`` itself, as with ``lazy=False``; so are option names and ``lazy``."""
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(cache))
    with pytest.raises(kd.ModelError, match=r"chain3d: style must be 'v2pt' or 'positions', "
                                            r"not 'bogus'"):
        kd.models.build("chain3d", n=2, style="bogus")
    with pytest.raises(kd.ModelError, match=r"n \(the number of links\) must be at least 1"):
        kd.models.build("chain3d", n=0, style="positions")
    with pytest.raises(kd.ModelError, match=r"model chain3d has no option\(s\) \['links'\]"):
        kd.models.build("chain3d", links=2)
    with pytest.raises(kd.ModelError, match=r"lazy must be True or False, not 'yes'"):
        kd.models.build("chain3d", lazy="yes", **OPTIONS)


def test_lazy_false_always_builds(cache, monkeypatch):
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(cache))
    assert type(kd.models.build("chain3d", lazy=False, **OPTIONS)) is ModelDefinition
    assert type(kd.models.build("chain3d", **OPTIONS)) is PendingDefinition


def test_command_line_derive_of_a_cached_model_prints_what_the_eager_path_prints(
        cache, monkeypatch, capsys, tmp_path):
    """``kanedyn derive`` (which builds through ``kd.models.build``) with the
    model in the cache prints the equations it prints with an empty cache."""
    from kanedyn.cli import main
    argv = ["derive", "chain3d", "--set", "n=2", "--set", "style=positions", "--quiet"]
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(cache))
    assert main(argv) == 0
    warm = capsys.readouterr().out
    empty = tmp_path / "empty"
    empty.mkdir(mode=0o700)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(empty))
    assert main(argv) == 0

    def equations(text):  # without the line that says how long the derivation took
        return [line for line in text.splitlines() if "derived in" not in line]
    assert equations(warm) == equations(capsys.readouterr().out)
    assert any(line.startswith("mass_matrix") for line in equations(warm))


def test_a_model_that_cannot_be_stored_leaves_no_part_of_its_entry(tmp_path, monkeypatch):
    """An entry's body parameters are written first, its numerical model
    last (the entry is complete once that exists): a model whose data cannot
    be saved (as one holding a Python function) leaves neither part; one
    that can leaves both."""
    from kanedyn.models import _base
    from kanedyn.numerics import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    tmp_path.chmod(0o700)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    definition = kd.models.build("pendulum", lazy=False)
    model = definition.numeric(backend="c")
    _base._write_cache("stored", definition, model)
    assert _base._cache_path("stored").exists()
    assert _base._cache_path("stored", "kdbody").exists()
    monkeypatch.setattr(model, "_data", {**model._data, "held": lambda t: t})
    _base._write_cache("unstorable", definition, model)
    assert not _base._cache_path("unstorable").exists()
    assert not _base._cache_path("unstorable", "kdbody").exists()
