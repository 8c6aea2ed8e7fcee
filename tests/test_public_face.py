"""The public face: ``kd.`` holds the general library and each domain family its
module (``kd.offshore``, ``kd.vehicle``, ``kd.flexible``, ``kd.studies``).

- Every public name (of ``kd.__all__`` and of every module listed there) is
  documented: it has a docstring of its own (a ``#:`` comment for a table or
  constant), is on the API reference pages (``docs/conf.py`` writes one page per
  module of ``kd.__all__``; ``tests/test_docs.py`` builds them), and the guide
  (``docs/*.md``, ``README.md``) names it in code.  Each object has exactly one
  public spelling.
- Each name that moved from ``kd.`` still works under its old spelling: the same
  object, one ``DeprecationWarning`` per name naming the new spelling, attributed
  to the caller's line.  A public name asked of a module that lacks it is named
  where it is, without loading the library.
- The docs, README, examples, benchmarks, the library and the tests (except the
  tests of the old spellings, here) use no old spelling.
"""

import ast
import importlib
import inspect
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import kanedyn as kd
from kanedyn._lazy import NAMESPACES

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"

#: the domain modules; kd.models, kd.schemes and kd.visuals are modules of kd.__all__ too
DOMAINS = ("offshore", "vehicle", "flexible", "studies")

#: every name that was at ``kd.`` before it moved, and its module now: a record of
#: the past (the 37 of 109), so that dropping an old spelling fails here
OLD_SPELLINGS = {
    **dict.fromkeys(["AiryWave", "IrregularSea", "jonswap_spectrum", "jonswap_gamma",
                     "wave_number", "MorisonCylinder", "Hydrostatics", "LinearMooring",
                     "CatenaryLine", "CatenaryMooring", "RotorThrust", "ThrustCurve",
                     "NREL5MW_THRUST", "kaimal_wind"], "offshore"),
    **dict.fromkeys(["CrashPulse", "HalfSinePulse", "HaversinePulse", "TrapezoidPulse",
                     "pulse_from_delta_v", "read_pulse_csv", "cfc_filter",
                     "example_pulse"], "vehicle"),
    **dict.fromkeys(["ReducedMember", "BeamMember", "FEMember", "NodeMass",
                     "plot_mode_shapes"], "flexible"),
    **dict.fromkeys(["run_study", "StudyResult", "STUDIES", "seatbelt_lock_map",
                     "SeatbeltLockMap", "regulatory_check", "RegulatoryCheck",
                     "seatbelt_study_model", "inverse_study", "InverseStudy"], "studies"),
}


def _modules():
    """The public modules: ``kd`` and every module of ``kd.__all__``."""
    return [kd] + [getattr(kd, name) for name in kd.__all__
                   if inspect.ismodule(getattr(kd, name))]


def _spelling(module, name):
    return "kd." + f"{module.__name__}.{name}".split(".", 1)[1]


def _guide():
    """The code of the guide: fenced blocks and inline code spans of README.md and
    docs/*.md."""
    code = []
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = path.read_text()
        code += re.findall(r"```.*?```", text, re.S)
        code += re.findall(r"`[^`]+`", re.sub(r"```.*?```", "", text, flags=re.S))
    return "\n".join(code)


def _data_comment(obj, name):
    """The ``#:`` comment above ``name = ...`` in the module that defines it, or ""."""
    for modname, module in sorted(sys.modules.items()):
        if not modname.startswith("kanedyn.") or vars(module).get(name) is not obj:
            continue
        lines = Path(module.__file__).read_text().splitlines()
        for node in ast.parse("\n".join(lines)).body:
            targets = (node.targets if isinstance(node, ast.Assign)
                       else [node.target] if isinstance(node, ast.AnnAssign) else [])
            if any(getattr(t, "id", None) == name for t in targets):
                comment = []
                for line in reversed(lines[:node.lineno - 1]):
                    if not line.startswith("#:"):
                        break
                    comment.insert(0, line[2:].strip())
                return " ".join(comment)
    return ""


def _own_docstring(obj, name):
    if inspect.ismodule(obj) or inspect.isroutine(obj):
        return (obj.__doc__ or "").strip()
    if inspect.isclass(obj):
        doc = (vars(obj).get("__doc__") or "").strip()
        return "" if doc.startswith(f"{obj.__name__}(") else doc   # a dataclass's signature
    return _data_comment(obj, name)


# ------------------------------------------------------------ the namespaces
@pytest.mark.parametrize("name", DOMAINS)
def test_each_domain_is_an_importable_module_of_the_public_face(name):
    module = importlib.import_module(f"kanedyn.{name}")
    assert name in kd.__all__ and getattr(kd, name) is module
    assert Path(module.__file__).parent == SRC / "kanedyn"      # the public-face layer
    assert module.__all__ and all(hasattr(module, n) for n in module.__all__)
    # its docstring lists what it holds
    missing = [n for n in module.__all__ if not re.search(rf"\b{n}\b", module.__doc__)]
    assert not missing, f"kanedyn.{name}'s docstring does not list {missing}"


def test_the_package_docstring_lists_every_module():
    modules = [n for n in kd.__all__ if inspect.ismodule(getattr(kd, n))]
    assert set(DOMAINS) < set(modules)
    assert all(f"kd.{n} " in kd.__doc__ for n in modules), kd.__doc__


@pytest.mark.parametrize("module", _modules(), ids=lambda m: m.__name__)
def test_dir_shows_the_public_names_only(module):
    shown = {n for n in dir(module) if not n.startswith("__")}
    assert shown == set(module.__all__)
    assert len(module.__all__) == len(set(module.__all__))


def test_every_public_object_has_one_spelling():
    spellings = {}
    for module in _modules():
        for name in module.__all__:
            spellings.setdefault(id(getattr(module, name)), []).append(_spelling(module, name))
    twice = [names for names in spellings.values() if len(names) > 1]
    assert not twice, f"public objects with more than one spelling: {twice}"


def test_the_general_library_stays_at_kd():
    """The names other code relies on (DESIGN.md's wave-2 names) and the general
    analyses stay at kd., not in a domain module."""
    for name in ("FlexibleBody", "Inerter", "JointActuator", "LinearActuator", "BallScrew",
                 "VehicleMotion", "sweep", "load", "simulate", "kane", "formulate",
                 "check_newton_euler", "frequency_response", "ModelError"):
        assert name in kd.__all__, name


# ------------------------------------------------------------ documented
@pytest.mark.parametrize("module", _modules(), ids=lambda m: m.__name__)
def test_every_public_name_has_a_docstring(module):
    missing = [name for name in module.__all__
               if not _own_docstring(getattr(module, name), name)]
    assert not missing, f"{module.__name__}: no docstring (or #: comment) for {missing}"


@pytest.mark.parametrize("module", [m for m in _modules() if m is not kd.models],
                         ids=lambda m: m.__name__)
def test_every_public_name_is_named_in_the_guide(module):
    code = _guide()
    missing = [name for name in module.__all__
               if not re.search(rf"(?<!\w){re.escape(name)}(?!\w)", code)]
    assert not missing, (f"{module.__name__}: not named in the code of README.md or "
                         f"docs/*.md: {missing}")


def test_every_built_in_model_is_named_in_the_guide():
    """kd.models' builders are reached by name (``kd.models.build(name)``,
    ``kanedyn run NAME``): the guide names every registered model; the builders
    themselves are on the API reference page."""
    text = "\n".join(p.read_text() for p in [ROOT / "README.md",
                                              *(ROOT / "docs").glob("*.md")])
    missing = [name for name in kd.models.REGISTRY
               if not re.search(rf"(?<![\w-]){re.escape(name)}(?![\w-])", text)]
    assert not missing, f"built-in models the docs do not name: {missing}"


# ------------------------------------------------------------ the old spellings
def test_old_spellings_are_recorded_and_listed_in_their_modules():
    for name, home in OLD_SPELLINGS.items():
        assert name not in kd.__all__, name
        assert name in getattr(kd, home).__all__, f"{name} is not in kd.{home}"
    assert kd._MOVED == OLD_SPELLINGS


_OLD_USE = """
import json, sys, warnings
warnings.simplefilter("always")       # shows what the package emits, not Python's dedup
import kanedyn as kd
from kanedyn import offshore, vehicle, flexible, studies
heavy = sorted(m for m in ("sympy", "scipy", "matplotlib") if m in sys.modules)
names = dir(offshore) + dir(vehicle) + dir(flexible) + dir(studies)
out = {"heavy": heavy, "names": {}}
old = json.loads(sys.argv[1])
# a use inside kanedyn (the pytest filter "error::DeprecationWarning:kanedyn.*"):
# an error, which does not count as the one warning
warnings.filterwarnings("error", category=DeprecationWarning, module="kanedyn")
try:
    exec("kd.AiryWave", {"__name__": "kanedyn.somewhere", "kd": kd})
    out["inside"] = "no error"
except DeprecationWarning as error:
    out["inside"] = str(error)
warnings.resetwarnings()
warnings.simplefilter("always")
for name, home in old.items():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        first = getattr(kd, name)
        again = getattr(kd, name)
        exec(f"from kanedyn import {name} as third", globals())
    new = getattr(getattr(kd, home), name)
    out["names"][name] = {
        "same": first is new and again is new and third is new,
        "warnings": [[w.category.__name__, str(w.message), w.filename] for w in caught]}
out["dir"] = sorted(set(old) & set(dir(kd)))
print(json.dumps(out))
"""


def test_each_old_spelling_gives_the_same_object_and_warns_once(tmp_path):
    """In a fresh process (the warnings are once per process): ``kd.X`` twice and
    ``from kanedyn import X`` give the object of ``kd.<module>.X`` and one
    DeprecationWarning naming the new spelling, on the caller's line."""
    script = tmp_path / "old_spellings.py"
    script.write_text(_OLD_USE)
    env = dict(os.environ, PYTHONPATH=str(SRC), PYTHONWARNINGS="")
    proc = subprocess.run([sys.executable, str(script), json.dumps(OLD_SPELLINGS)],
                          capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.splitlines()[-1])
    assert out["heavy"] == [], "importing the domain modules imports " + str(out["heavy"])
    assert out["dir"] == []
    assert "kanedyn.offshore.AiryWave" in out["inside"]
    for name, home in OLD_SPELLINGS.items():
        seen = out["names"][name]
        assert seen["same"], name
        assert len(seen["warnings"]) == 1, (name, seen["warnings"])
        category, message, filename = seen["warnings"][0]
        assert category == "DeprecationWarning", (name, category)
        assert f"kanedyn.{home}.{name}" in message and f"kd.{home}.{name}" in message
        assert message.startswith(f"kanedyn.{name} has moved"), message
        assert filename == str(script), (name, filename)     # the caller's line


def test_a_name_that_never_was_public_is_no_alias():
    with pytest.raises(AttributeError, match="'kanedyn' has no attribute 'cfc_response'"):
        kd.cfc_response        # in kanedyn.modeling.vehicle, never at kd.


def _homes():
    """``{public name: the first public module that exports it}``, in the order the
    AttributeError of a missing name searches them."""
    homes = {}
    for space in NAMESPACES:
        for name in importlib.import_module(space).__all__:
            homes.setdefault(name, space)
    return homes


def test_the_namespaces_searched_are_the_public_modules():
    assert set(NAMESPACES) == {m.__name__ for m in _modules()}


@pytest.mark.parametrize("module", _modules(), ids=lambda m: m.__name__)
def test_a_name_asked_of_the_wrong_module_names_its_home(module):
    """``kd.offshore.HalfSinePulse``: "module 'kanedyn.offshore' has no attribute
    'HalfSinePulse'; it is kanedyn.vehicle.HalfSinePulse", for every public name of
    every other public module (an old spelling at kd. still works instead)."""
    space = module.__name__
    asked = 0
    for name, home in _homes().items():
        if home == space or name in vars(module) or (module is kd and name in kd._MOVED):
            continue
        with pytest.raises(AttributeError, match=rf"^module '{re.escape(space)}' has no "
                           rf"attribute '{name}'; it is {re.escape(home)}\.{name}$"):
            getattr(module, name)
        asked += 1
    assert asked > 20
    # a name public nowhere, and a private one, are only said to be missing
    for name in ("NoSuchThing", "_LAZY_TABLE"):
        with pytest.raises(AttributeError, match=rf"^module '{re.escape(space)}' has no "
                           rf"attribute '{name}'$"):
            getattr(module, name)


def test_the_wrong_module_is_named_without_loading_the_library():
    code = ("import json, sys, kanedyn as kd\n"
            "try:\n    kd.offshore.HalfSinePulse\n"
            "except AttributeError as exc:\n    message = str(exc)\n"
            "print(json.dumps([message, sorted(m for m in ('numpy', 'scipy', 'sympy') "
            "if m in sys.modules)]))")
    env = dict(os.environ, PYTHONPATH=str(SRC))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=120, check=True).stdout
    assert json.loads(out) == ["module 'kanedyn.offshore' has no attribute 'HalfSinePulse'; "
                               "it is kanedyn.vehicle.HalfSinePulse", []]


# ------------------------------------------------------------ no old spelling in use
_OLD = "|".join(sorted(OLD_SPELLINGS, key=len, reverse=True))
_ATTRIBUTE = re.compile(rf"(?<![\w.])(?:kd|kanedyn)\.(?:{_OLD})\b")
_IMPORT = re.compile(r"from\s+kanedyn\s+import\s+(\([^)]*\)|[^\n]*)")


def old_spellings_in(text):
    """The old spellings ``kd.X``, ``kanedyn.X`` and ``from kanedyn import X`` in a text."""
    found = _ATTRIBUTE.findall(text)
    for names in _IMPORT.findall(text):
        for item in re.split(r"[,\s()]+", names.split("#")[0]):
            if item in OLD_SPELLINGS:
                found.append(f"from kanedyn import {item}")
    return found


def _scanned_files():
    yield ROOT / "README.md"
    for folder, pattern in (("docs", "*.md"), ("docs", "*.py"), ("examples", "**/*.py"),
                            ("benchmarks", "**/*.py"), ("src", "**/*.py"),
                            ("tests", "**/*.py")):
        for path in sorted((ROOT / folder).glob(pattern)):
            if "_build" not in path.parts and path != Path(__file__):
                yield path


def test_the_scan_finds_old_spellings():
    text = ("x = kd.AiryWave(1, 2)\n`kanedyn.cfc_filter`\n"
            "from kanedyn import (ModelError,\n    read_pulse_csv)\n"
            "kd.offshore.AiryWave, kd.models.build, kd.vehicle.cfc_filter\n")
    assert old_spellings_in(text) == ["kd.AiryWave", "kanedyn.cfc_filter",
                                      "from kanedyn import read_pulse_csv"]


def test_no_old_spelling_in_docs_examples_or_code():
    found = [f"{path.relative_to(ROOT)}: {spelling}" for path in _scanned_files()
             for spelling in old_spellings_in(path.read_text())]
    assert not found, ("old spellings (use kd.offshore.X, kd.vehicle.X, kd.flexible.X, "
                       "kd.studies.X):\n" + "\n".join(found))
