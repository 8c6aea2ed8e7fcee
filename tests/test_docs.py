"""The documentation builds without a warning: Sphinx with ``-W`` (warnings as
errors) over docs/ (the markdown pages and the API reference generated from the
docstrings of every public name).  A docstring whose numpydoc sections, maths
or references do not parse fails here, naming the object."""

import shutil
import inspect
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


@pytest.mark.slow
def test_sphinx_builds_without_warnings(tmp_path):
    pytest.importorskip("sphinx", reason="the docs need the 'docs' extra: "
                        "pip install -e '.[docs]'")
    pytest.importorskip("myst_parser", reason="pip install -e '.[docs]'")
    pytest.importorskip("furo", reason="pip install -e '.[docs]'")
    out = tmp_path / "html"
    # -E: read every page again (no environment kept from an earlier build)
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-E", "-q",
                           "-b", "html", "-d", str(tmp_path / "doctrees"), str(DOCS),
                           str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"sphinx-build failed:\n{proc.stderr[-6000:]}"
    api = (out / "api" / "kanedyn.html").read_text()
    import kanedyn as kd
    for name in kd.__all__:       # every public name has its entry (new ones too)
        if not inspect.ismodule(getattr(kd, name)):    # modules have their own page
            assert f'id="kanedyn.{name}"' in api, f"kd.{name} missing from the API page"
    for page in (n for n in kd.__all__ if inspect.ismodule(getattr(kd, n))):
        module = getattr(kd, page)   # kd.models, kd.schemes, kd.offshore, ...: a page each
        text = (out / "api" / f"{page}.html").read_text()
        for name in module.__all__:
            assert f'id="{module.__name__}.{name}"' in text, f"{module.__name__}.{name}"
    for page in ("linearization", "gallery", "readme", "contacts"):
        assert (out / f"{page}.html").exists(), page
    shutil.rmtree(out)
