"""The layer order, read from the import graph of the package's source.

Layers, lowest first (``docs/architecture.md``): foundation (``_errors``, ``_html``,
``_lazy``, ``_progress``, ``_number_text``, ``_fork``, ...), ``engine``, ``modeling``,
``formulations``, ``numerics``, ``simulation``, ``optimization``, ``models``, ``analysis``,
``io``, ``cli``; then
the public face (``kanedyn/__init__.py`` and the modules beside it: ``schemes``, ``visuals``
and the domain modules ``offshore``, ``vehicle``, ``flexible``, ``studies``).  A module
imports only from its own layer or lower ones, and another layer only through
that layer's package (its ``__init__``) or a sub-package's.  The only imports
that run upward are the facade methods of frozen results listed in
:data:`FACADES`, each imported inside the method when it is called.
"""

import ast
import functools
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "kanedyn"
ORDER = ["foundation", "engine", "modeling", "formulations", "numerics", "simulation",
         "optimization", "models", "analysis", "io", "cli", "public"]
FOUNDATION = {"_errors", "_progress", "_number_text", "_version", "_html", "_lazy",
              "_expressions", "_fork", "_signals", "_trusted_files", "_output_files",
              "_input_files"}
PUBLIC = {"__init__", "schemes", "visuals", "offshore", "vehicle", "flexible", "studies"}

#: (importing module, imported layer): the method that needs it
FACADES = {
    ("formulations._eom", "numerics"):
        "EquationsOfMotion.numeric, .linearize and .scheme: the public API puts them on "
        "the frozen equations",
    ("simulation._results", "analysis"): "SimulationResult.plot and .plot_deflection",
    ("simulation._results", "io"):
        "SimulationResult.animate and .widget: the public API puts the 3D animation (a "
        "page, a notebook widget) on the result",
    ("formulations._eom", "io"):
        "EquationsOfMotion.save: the public API puts saving on the frozen equations "
        "(the file format lives in io/_saved.py)",
    ("numerics._model", "io"):
        "NumericModel.export_fmu: the public API puts FMU export on the numerical model "
        "(the FMU's files and build live in io/fmu/)",
    ("modeling.offshore._blade_element_momentum", "numerics"):
        "BladeElementMomentum's solve: its compiled kernel (numerics/backends/"
        "_bem_kernel.py) is built by numerics' compiler on the first solve (NumPy's "
        "steps without a compiler)",
    ("models._base", "io"):
        "the derivation cache stores numerical models in the saved-file format "
        "(io/_saved.py: a zip of JSON, nothing evaluated on loading)",
}


def _layer(parts):
    """Layer of a module given as its dotted path inside the package."""
    if len(parts) == 1 and not (PACKAGE / parts[0]).is_dir():
        if parts[0] in FOUNDATION:
            return "foundation"
        if parts[0] in PUBLIC:
            return "public"
        raise AssertionError(f"kanedyn/{parts[0]}.py belongs to no layer")
    return parts[0]


@functools.lru_cache(maxsize=None)
def _imports():
    """``(module, lineno, target parts, inside a function)`` for every package import
    (the sources parsed once per process: 3.5 s, for the nine tests that read them)."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).with_suffix("")
        parts = list(rel.parts)
        package = parts[:-1]
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts) or "__init__"
        tree = ast.parse(path.read_text())
        functions = [n for n in ast.walk(tree)
                     if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
        nested = {id(n) for f in functions for n in ast.walk(f)}
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom) or not node.level:
                continue
            base = package[:len(package) - (node.level - 1)]
            target = base + (node.module.split(".") if node.module else [])
            if not target:  # "from . import x" at the top: x are modules
                for alias in node.names:
                    found.append((module, node.lineno, [alias.name], id(node) in nested))
            else:
                found.append((module, node.lineno, target, id(node) in nested))
    return tuple(found)


def _module_layer(module):
    parts = module.split(".")
    return _layer(parts)


def test_every_module_has_a_layer():
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
        assert _layer(parts) in ORDER, path


def test_no_import_runs_to_a_higher_layer():
    upward = []
    for module, line, target, inside in _imports():
        source = _module_layer(module)
        layer = _layer(target)
        if ORDER.index(layer) <= ORDER.index(source):
            continue
        if inside and (module, layer) in FACADES:
            continue
        upward.append(f"kanedyn.{module} (line {line}, {source}) imports "
                      f"kanedyn.{'.'.join(target)} ({layer})")
    assert not upward, "imports into higher layers:\n" + "\n".join(upward)


def test_other_layers_are_entered_through_their_packages():
    """``from ..numerics import X`` or ``from ..numerics.schemes import X``, never a
    private module of another layer."""
    private = []
    for module, line, target, _ in _imports():
        source = _module_layer(module)
        layer = _layer(target)
        if layer == source or layer == "foundation":
            continue
        if any(part.startswith("_") for part in target[1:]):
            private.append(f"kanedyn.{module} (line {line}) imports kanedyn.{'.'.join(target)}")
    assert not private, "private modules of other layers imported:\n" + "\n".join(private)


@pytest.mark.parametrize("facade", sorted(FACADES))
def test_every_facade_is_still_needed(facade):
    """An entry of FACADES that no import uses any more must go."""
    used = {(m, _layer(t)) for m, _, t, inside in _imports() if inside}
    assert facade in used, f"{facade} is listed in FACADES but no longer imported"


def test_layer_packages_declare_what_they_export():
    for layer in ORDER:
        init = PACKAGE / layer / "__init__.py"
        if not init.exists():
            continue
        tree = ast.parse(init.read_text())
        names = [n for n in tree.body if isinstance(n, ast.Assign)
                 and any(getattr(t, "id", "") == "__all__" for t in n.targets)]
        assert names, f"kanedyn/{layer}/__init__.py has no __all__"
        assert ast.get_docstring(tree), f"kanedyn/{layer}/__init__.py has no docstring"
