"""Sphinx configuration: the markdown pages of docs/ (MyST) and an API reference
generated from the docstrings.

The API pages are listed from ``kanedyn.__all__`` and the ``__all__`` of every
module in it (``kd.models``, ``kd.schemes``, ``kd.offshore``, ...) when the build
starts (``api/*.rst`` are written here: build products, ignored by git), so a
public name added to the package appears in the reference without editing the
docs.  Build: ``sphinx-build -W --keep-going -b html docs docs/_build/html``
(``tests/test_docs.py`` runs it with warnings as errors).
"""

import inspect
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

import kanedyn  # noqa: E402
from sphinx.pycode import ModuleAnalyzer  # noqa: E402

project = "kanedyn"
author = "the kanedyn developers"
copyright = "the kanedyn developers"
release = version = kanedyn.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]

html_theme = "furo"
html_title = f"kanedyn {release}"

# MyST: `$...$` maths in the pages, anchors for the headings (links like page.md#heading).
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

# Docstrings are numpydoc-style; napoleon reads them.
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_ivar = True          # "Attributes" as fields: no second description of a member
napoleon_use_rtype = False
napoleon_preprocess_types = False

autosummary_generate = False      # the tables link to the descriptions on the same page
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_class_signature = "separated"



def _data_docstring(app, what, name, obj, options, lines):
    """A table or constant re-exported by a package (``kd.FORMULATIONS`` is
    ``kanedyn.formulations._registry.FORMULATIONS``) has its ``#:`` comment in
    the module that defines it, which autodoc does not read; without this hook
    autodoc would show the docstring of ``dict`` or ``tuple`` instead.  A name
    with no ``#:`` comment anywhere keeps that text, and its warnings then point
    at the missing comment."""
    if what != "data" or not name.startswith("kanedyn."):
        return
    short = name.rsplit(".", 1)[1]
    for modname, module in sorted(sys.modules.items()):
        # vars, not getattr: no name is loaded here, and no old spelling warns
        if not modname.startswith("kanedyn") or vars(module).get(short) is not obj:
            continue
        try:
            comment = ModuleAnalyzer.for_module(modname).find_attr_docs().get(("", short))
        except Exception:  # a module without source (compiled): nothing to read
            continue
        if comment:
            lines[:] = list(comment)
            return


def setup(app):
    app.connect("autodoc-process-docstring", _data_docstring)


def _kind(obj):
    if inspect.ismodule(obj):
        return "modules"
    if inspect.isclass(obj) and issubclass(obj, (BaseException, Warning)):
        return "exceptions"
    if inspect.isclass(obj):
        return "classes"
    if callable(obj):
        return "functions"
    return "data"


TITLES = {"functions": "Functions", "classes": "Classes",
          "exceptions": "Exceptions and warnings", "data": "Constants and tables"}
DIRECTIVES = {"functions": "autofunction", "classes": "autoclass",
              "exceptions": "autoexception", "data": "autodata"}
GENERATED = "Written by docs/conf.py from the package's ``__all__`` at each build; do not edit."


def _module_page(module, title):
    """reST of one page: a summary table of ``module.__all__`` by kind, then the
    description of each name.  One page per module, not one per name: furo draws
    the whole navigation tree on every page, so a hundred small pages would take
    most of the build time."""
    groups = {kind: [] for kind in TITLES}
    for name in module.__all__:
        kind = _kind(getattr(module, name))
        if kind != "modules":          # kd.models and kd.schemes have their own pages
            groups[kind].append(name)
    lines = [f".. {GENERATED}", "", title, "=" * len(title), "",
             f".. automodule:: {module.__name__}", "   :no-members:", "",
             f".. currentmodule:: {module.__name__}", ""]
    for kind, names in groups.items():
        if names:
            lines += [f"**{TITLES[kind]}**", "", ".. autosummary::", "   :nosignatures:", ""]
            lines += [f"   {name}" for name in names] + [""]
    for kind, names in groups.items():
        if not names:
            continue
        lines += [TITLES[kind], "-" * len(TITLES[kind]), ""]
        for name in names:
            lines += [f".. {DIRECTIVES[kind]}:: {name}"]
            lines += {"data": ["   :no-value:"],
                      "functions": []}.get(kind, ["   :members:", "   :show-inheritance:"])
            lines += [""]
    return lines


def _write(path, lines):
    text = "\n".join(lines) + "\n"
    if not path.exists() or path.read_text() != text:   # unchanged: nothing to re-read
        path.parent.mkdir(exist_ok=True)
        path.write_text(text)


def write_api_pages():
    pages = {"kanedyn": (kanedyn, "kanedyn (``import kanedyn as kd``)")}
    for name in kanedyn.__all__:   # kd.models, kd.schemes, kd.visuals, ...: a page each
        module = getattr(kanedyn, name)
        if inspect.ismodule(module):
            summary = (module.__doc__ or "").strip().splitlines()[0].rstrip(".")
            summary = re.sub(r"\s*\(.*\)$", "", summary)   # no roles in a title
            pages[name] = (module, f"{module.__name__} (``kd.{name}``): {summary}")
    for stem, (module, title) in pages.items():
        _write(HERE / "api" / f"{stem}.rst", _module_page(module, title))
    _write(HERE / "api" / "index.rst",
           [f".. {GENERATED}", "", "API reference", "=============", "",
            "Every public name of ``import kanedyn as kd`` and of its modules "
            "(``kd.models``, ``kd.schemes``, ...), from their docstrings.", "",
            ".. toctree::", "   :maxdepth: 1",
            ""] + [f"   {stem}" for stem in pages])


write_api_pages()
