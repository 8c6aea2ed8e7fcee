"""First use: lazy imports and the derivation cache (counted, never timed)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _run(code, cache=None):
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("KANEDYN_CACHE_DIR", None)
    if cache is not None:
        env["XDG_CACHE_HOME"] = str(cache)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_import_kanedyn_imports_no_plotting_or_scipy():
    out = _run("import sys, json, kanedyn\n"
               "print(json.dumps(sorted(m for m in ('matplotlib', 'scipy', 'sympy', 'tqdm')"
               " if m in sys.modules)))")
    assert out == []


def test_command_line_help_and_list_import_no_sympy_scipy_or_plotting():
    """``kanedyn --help`` and ``kanedyn list`` start without the heavy modules
    (every sub-command imports what it runs when it runs)."""
    for argv in (["--help"], ["list"], ["study", "--help"]):
        out = _run("import sys, json, contextlib, io\n"
                   "from kanedyn.cli import main\n"
                   "with contextlib.redirect_stdout(io.StringIO()):\n"
                   "    try:\n"
                   f"        main({argv!r})\n"
                   "    except SystemExit:\n"
                   "        pass\n"
                   "print(json.dumps(sorted(m for m in ('matplotlib', 'scipy', 'sympy')"
                   " if m in sys.modules)))")
        assert out == [], argv


def test_lazy_names_are_the_public_api():
    out = _run("import json, kanedyn as kd\n"
               "missing = [n for n in kd.__all__ if not hasattr(kd, n)]\n"
               "from kanedyn import simulate, NumericModel\n"
               "print(json.dumps([missing, simulate.__module__, "
               "kd.models.chain3d.__name__]))")
    assert out[0] == []
    assert out[1].startswith("kanedyn.simulation") and out[2] == "chain3d"


def test_registry_titles_match_the_builders():
    from kanedyn.models import REGISTRY
    for name, (builder, _) in REGISTRY.items():
        assert builder.title == builder.function().title, name


_CHAIN = """
import json, sys
import kanedyn as kd
from kanedyn.models._base import DERIVE_STATS
from kanedyn.numerics import COMPILE_STATS
d = kd.models.build("chain3d", n=3, style="positions")
m = d.numeric(backend="c", constants={{"m": {mass}}})
f = m.rhs(0.0, d.initial(m))
kd.numerics.finish_compiling()  # a module from the quick compiler: the optimized one too
print(json.dumps([DERIVE_STATS["derivations"], COMPILE_STATS["compiles"], list(f)]))
"""


@pytest.fixture(scope="module")
def chain_cached(tmp_path_factory):
    """``(first, copy)``: the report of a first process of ``_CHAIN`` (m = 1, the cache
    empty) and ``copy(folder)``, which copies the cache it filled to
    ``folder/kanedyn`` (``folder`` as ``XDG_CACHE_HOME``), for a test to read or
    change.  The tests below start from it instead of each running that first
    process (a derivation and a build) again."""
    from kanedyn.numerics import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    shared = tmp_path_factory.mktemp("chain-cached")
    first = _run(_CHAIN.format(mass=1.0), shared)

    def copy(folder):
        shutil.copytree(shared / "kanedyn", folder / "kanedyn", symlinks=True)
    return first, copy


@pytest.mark.slow
def test_second_process_and_new_constants_reuse_the_cache(chain_cached, tmp_path):
    (derived, compiled, f1), copy = chain_cached
    assert (derived, compiled) == (1, 1)
    copy(tmp_path)
    derived, compiled, again = _run(_CHAIN.format(mass=1.0), tmp_path)
    assert (derived, compiled) == (0, 0)
    assert again == f1
    derived, compiled, f2 = _run(_CHAIN.format(mass=2.0), tmp_path)
    assert (derived, compiled) == (0, 0)
    # an independent evaluation: a fresh derivation with the numpy backend
    import kanedyn as kd
    d = kd.models.build("chain3d", n=3, style="positions")
    ref = d.numeric(d.derive(), constants={"m": 2.0})
    assert f2 == pytest.approx(list(ref.rhs(0.0, d.initial(ref))), rel=1e-12, abs=1e-12)
    assert f2 != pytest.approx(f1)


_COLD = """
import json, sys
import kanedyn as kd
d = kd.models.build("chain3d", n=3, style="positions")
m = d.numeric(backend="c")
f = m.rhs(0.0, d.initial(m))
kd.numerics.finish_compiling()
print(json.dumps([sorted(x for x in {modules!r} if x in sys.modules), list(f)]))
"""


@pytest.mark.slow
def test_a_cold_start_imports_only_what_a_rigid_model_needs(tmp_path):
    """A first process (nothing cached) derives and compiles a model of rigid
    bodies without SymPy's C printer and code generation modules (every
    statement is printed by the backend itself) or the finite elements of
    flexible members (and NumPy's polynomials they import); asked for, each is
    there, and the numbers are the numpy backend's."""
    from kanedyn.numerics import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    modules = ("sympy.printing.c", "sympy.codegen", "numpy.polynomial",
               "kanedyn.numerics.backends._c_printer", "kanedyn.modeling.flexible._beam",
               "kanedyn.modeling.flexible._member")
    found, f = _run(_COLD.format(modules=modules), tmp_path)
    assert found == []
    out = _run("import json, sys\n"
               "from kanedyn.modeling.flexible import BeamMember\n"
               "from kanedyn.numerics.backends._c import _CPrinter\n"
               "_CPrinter({}).doprint(1)\n"
               f"print(json.dumps(sorted(x for x in {modules!r} if x in sys.modules)))")
    assert out == sorted(modules)
    import kanedyn as kd
    d = kd.models.build("chain3d", n=3, style="positions")
    ref = d.numeric(d.derive())
    assert f == pytest.approx(list(ref.rhs(0.0, d.initial(ref))), rel=1e-12, abs=1e-12)


_WARM = """
import json, sys
import kanedyn as kd
from kanedyn.models._base import DERIVE_STATS
from kanedyn.numerics import COMPILE_STATS
d = kd.models.build("chain3d", n=3, style="positions")  # the default: lazy when cached
m = d.numeric(backend="c")
f = m.rhs(0.0, d.initial(m))
after_rhs = "sympy" in sys.modules
run = kd.simulate(m, (0.0, 0.5), d.initial(m))
kd.numerics.finish_compiling()
print(json.dumps([DERIVE_STATS["derivations"], COMPILE_STATS["compiles"],
                  list(f) + list(run.y[:, -1]) + [run.method],
                  sorted(x for x in ("sympy", "scipy", "matplotlib") if x in sys.modules),
                  after_rhs, type(d).__name__]))
"""


@pytest.mark.slow
def test_second_process_starts_without_sympy_or_scipy(tmp_path):
    """A model in the derivation cache, from the default ``kd.models.build``, is
    read, evaluated and simulated on the compiled loop with neither SymPy nor
    SciPy imported (its body parameters are read only when constants change):
    the same numbers as the first process's, which derived it."""
    from kanedyn.numerics import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    first = _run(_WARM, tmp_path)
    assert first[:2] == [1, 1] and "sympy" in first[3]
    assert first[5] == "ModelDefinition"  # nothing in the cache: built by build()
    second = _run(_WARM, tmp_path)
    assert second[:2] == [0, 0] and second[2] == first[2]
    assert second[3] == [] and second[4] is False
    assert second[5] == "PendingDefinition"


@pytest.mark.slow
def test_command_line_run_on_the_compiled_loop_imports_no_scipy(tmp_path):
    """``kanedyn run`` with the default integrator on the C backend neither checks
    the method against SciPy's table nor integrates with SciPy."""
    from kanedyn.numerics import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    out = _run("import sys, json, contextlib, io\n"
               "from kanedyn.cli import main\n"
               "with contextlib.redirect_stdout(io.StringIO()):\n"
               f"    code = main(['run', 'pendulum', '--out', {str(tmp_path / 'run')!r}, "
               "'--quiet', '--backend', 'c'])\n"
               "print(json.dumps([code, 'scipy' in sys.modules]))", tmp_path)
    assert out == [0, False]


@pytest.mark.slow
def test_cached_model_derives_its_equations_when_asked(chain_cached, tmp_path):
    chain_cached[1](tmp_path)
    out = _run("import json, pickle, kanedyn as kd\n"
               "from kanedyn.models._base import DERIVE_STATS\n"
               "d = kd.models.build('chain3d', n=3, style='positions')\n"
               "m = d.numeric(backend='c')\n"
               "before = DERIVE_STATS['derivations']\n"
               "m2 = pickle.loads(pickle.dumps(m))\n"
               "pickled = DERIVE_STATS['derivations']\n"
               "A = m.linearize(d.initial(m) + 0.1)[0]\n"
               "print(json.dumps([before, pickled, DERIVE_STATS['derivations'], "
               "list(m2.rhs(0.0, d.initial(m2)) - m.rhs(0.0, d.initial(m))), A.tolist()]))",
               tmp_path)
    # pickling a built-in model carries its name, not its source: no derivation
    # (test_pickling.py); its linearization needs the equations: derived then
    assert out[:3] == [0, 0, 1]
    assert max(abs(x) for x in out[3]) == 0.0
    import kanedyn as kd
    d = kd.models.build("chain3d", n=3, style="positions", lazy=False)
    m = d.numeric(d.derive())
    np.testing.assert_allclose(out[4], m.linearize(d.initial(m) + 0.1)[0], rtol=1e-10,
                               atol=1e-10)


@pytest.mark.slow
def test_cache_entry_is_json_and_a_tampered_one_is_rebuilt_not_run(chain_cached, tmp_path):
    import zipfile
    (_, _, f1), copy = chain_cached
    copy(tmp_path)
    entries = list((tmp_path / "kanedyn" / "derived").glob("*.kdnum"))
    assert len(entries) == 1 and not list((tmp_path / "kanedyn" / "derived").glob("*.pkl"))
    with zipfile.ZipFile(entries[0]) as archive:
        manifest = json.loads(archive.read("manifest.json"))
        nodes = archive.read("nodes.json")
    assert manifest["format"] == "kanedyn-derived-model"
    assert manifest["definition"]["name"] == "chain3d"
    json.loads(nodes)  # plain JSON, no pickle
    # a changed entry (a pickle payload in place of the nodes): refused, derived again
    payload = b"cos\nsystem\n(S'touch " + str(tmp_path / "ran").encode() + b"'\ntR."
    with zipfile.ZipFile(entries[0], "w") as archive:
        archive.writestr("manifest.json", json.dumps(manifest))
        archive.writestr("nodes.json", payload)
    env = dict(os.environ, PYTHONPATH=SRC, XDG_CACHE_HOME=str(tmp_path))
    env.pop("KANEDYN_CACHE_DIR", None)
    proc = subprocess.run([sys.executable, "-c", _CHAIN.format(mass=1.0)],
                          capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr
    derived, compiled, again = json.loads(proc.stdout.strip().splitlines()[-1])
    assert "cannot be used" in proc.stderr and "checksum" in proc.stderr
    assert (derived, compiled) == (1, 0)  # derived again; the module is still cached
    assert again == f1
    assert not (tmp_path / "ran").exists()
    # and stored again, usable by the next process
    assert _run(_CHAIN.format(mass=1.0), tmp_path)[:2] == [0, 0]


@pytest.mark.slow
def test_an_entry_whose_module_is_gone_is_a_miss(chain_cached, tmp_path):
    """A derivation-cache entry whose module the compile cache no longer holds
    (removed, or built with other compiler flags, as ``-mavx`` on another CPU)
    is derived again without a warning, and written again for the next
    process."""
    (derived, compiled, f1), copy = chain_cached
    assert (derived, compiled) == (1, 1)
    copy(tmp_path)
    cache = tmp_path / "kanedyn"
    for module in cache.glob("_kd_*"):
        module.unlink()
    env = dict(os.environ, PYTHONPATH=SRC, XDG_CACHE_HOME=str(tmp_path))
    env.pop("KANEDYN_CACHE_DIR", None)
    proc = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-c",
                           _CHAIN.format(mass=1.0)], capture_output=True, text=True, env=env,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "cannot be used" not in proc.stderr
    derived, compiled, again = json.loads(proc.stdout.strip().splitlines()[-1])
    assert derived == 1 and again == f1
    assert _run(_CHAIN.format(mass=1.0), tmp_path)[:2] == [0, 0]


def test_a_chain_forms_only_the_partial_velocities_it_needs():
    """The composite pass reads one speed's partials per body (the speed's
    own body), not all n x n; inverse functions form theirs in a workspace,
    never in the equations' program."""
    import numpy as np

    import kanedyn as kd
    definition = kd.models.build("chain3d", n=6, style="positions")
    eom = definition.derive()
    formed = sum(len(t.partial_velocities._formed) + len(t.partial_angular_velocities._formed)
                 for t in eom._body_terms)
    assert 0 < formed <= 2 * 6
    size = len(eom._program)
    model = definition.numeric(eom)
    q, u, ud = np.random.default_rng(1).normal(size=(3, 6))
    tau = model.inverse_dynamics(0.0, q, u, ud)
    parts = model.inverse_parts(0.0, q, u, ud)
    assert np.max(np.abs(parts.total - tau)) <= 1e-12 * np.max(np.abs(tau))
    assert len(eom._program) == size


def test_cache_key_reads_sympys_version_without_importing_it(monkeypatch):
    """The derivation cache's key names SymPy's version, read from its release
    file in a process that has not imported SymPy (a warm start imports none):
    the same as the imported module's."""
    import sympy

    from kanedyn.models import _base
    monkeypatch.delitem(sys.modules, "sympy")
    read = _base._sympy_version()
    assert "sympy" not in sys.modules
    assert read == sympy.__version__


def test_the_first_use_trace_sees_every_stage_and_compiler_run(monkeypatch):
    """``benchmarks/trace_first_use.py`` (the breakdown in docs/benchmarks.md)
    reads kanedyn's internals: every stage in order, and one compiler run per
    generated unit (the runtime's prefetched) and the link, each ended (here
    without the quick compiler; with it, test_quick_compile.py)."""
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from trace_first_use import trace
    marks, runs = trace(2, quick=False)
    stages = [stage for _, stage in marks]
    units = [stage for stage in stages if stage.startswith("unit")]
    assert [stage for stage in stages if not stage.startswith("unit")] == [
        "import numpy", "import sympy", "import kanedyn, sympy.physics.mechanics",
        "model defined", "derivation starts", "derivation ends", "code generation starts",
        "code generation ends", "module loaded", "first rhs"]
    assert [at for at, _ in marks] == sorted(at for at, _ in marks)
    assert len(runs) == len(units) + 1 and runs[-1][2] == "link"
    assert sum(what.startswith("prefetched") for _, _, what in runs) == 1
    assert all(end is not None and end >= start for start, end, _ in runs)
    assert "kd_eval_energy" in " ".join(units)
