"""Packaging: the extras, the conda recipe against pyproject.toml, and the sdist and
wheel of ``python -m build`` (every file of the package inside; the wheel installed
into a fresh virtual environment runs ``kanedyn demo``).

The build and the installation fetch their requirements (setuptools; kanedyn's
dependencies) from the package index the machine's pip is set up with.
"""

import os
import re
import shutil
import subprocess
import sys
import tarfile
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
PROJECT = PYPROJECT["project"]
EXTRAS = PROJECT["optional-dependencies"]
#: extras of tools for working on kanedyn, not features of it
TOOLS = {"test", "docs", "bench"}
#: a PyPI distribution -> its conda-forge package, where the names differ
CONDA_NAMES = {"matplotlib": "matplotlib-base"}


def _name(requirement):
    """``(name, version specifier)`` of a requirement, without extras and markers."""
    match = re.fullmatch(r"\s*([A-Za-z0-9_.-]+)(\[[^]]*\])?\s*([^;]*?)\s*(;.*)?",
                         requirement)
    assert match, requirement
    return match.group(1).lower(), match.group(3).replace(" ", "")


def test_all_extra_lists_every_feature():
    (everything,) = EXTRAS["all"]
    name, _ = _name(everything)
    assert name == "kanedyn"
    listed = set(everything.split("[", 1)[1].rstrip("]").split(","))
    assert listed == set(EXTRAS) - TOOLS - {"all"}


def test_test_extra_has_what_every_feature_needs():
    """The tests exercise every optional feature: the test extra brings them all."""
    test = {_name(r) for r in EXTRAS["test"]}
    for extra in set(EXTRAS) - TOOLS - {"all"}:
        assert {_name(r) for r in EXTRAS[extra]} <= test, extra
    assert ("build", ">=1.0") in test  # the packaging test below builds


def _recipe():
    """The recipe's version and requirement lists (its few Jinja lines read here)."""
    text = (ROOT / "recipe" / "meta.yaml").read_text(encoding="utf-8")
    sets = dict(re.findall(r'{%\s*set\s+(\w+)\s*=\s*"([^"]*)"\s*%}', text))
    text = re.sub(r"{%.*?%}", "", text)
    text = re.sub(r"{{\s*(\w+)(\|lower)?\s*}}", lambda m: sets.get(m.group(1), m.group(1)),
                  text)  # conda-build's own variables ({{ PYTHON }}) by their names
    yaml = pytest.importorskip("yaml", reason="reading the recipe needs PyYAML")
    return yaml.safe_load(text)


def test_conda_recipe_matches_pyproject():
    recipe = _recipe()
    assert recipe["package"] == {"name": "kanedyn", "version": PROJECT["version"]}
    run = [tuple(r.split(None, 1)) for r in recipe["requirements"]["run"]]
    python = PROJECT["requires-python"]
    expected = [("python", python)] + [
        (CONDA_NAMES.get(name, name), version)
        for name, version in map(_name, PROJECT["dependencies"])]
    assert run == expected
    constrained = [tuple(r.split(None, 1)) for r in recipe["requirements"]["run_constrained"]]
    assert constrained == [_name(r) for r in EXTRAS["notebook"]]
    (script,) = PROJECT["scripts"].items()
    assert recipe["build"]["entry_points"] == [f"{script[0]} = {script[1]}"]
    assert "kanedyn --help" in recipe["test"]["commands"]
    assert "kanedyn" in recipe["test"]["imports"]


# ------------------------------------------------------------ sdist and wheel
def _package_files():
    """Every file of the package in the checkout (sources and data), relative."""
    package = ROOT / "src" / "kanedyn"
    return {str(p.relative_to(ROOT / "src")) for p in package.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """sdist and wheel of a copy of the checkout (the build writes beside its sources)."""
    tmp = tmp_path_factory.mktemp("packaging")
    project = tmp / "project"
    project.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, project / name)
    shutil.copytree(ROOT / "src", project / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info"))
    pytest.importorskip("build", reason="building needs the build package (the test extra)")
    done = subprocess.run([sys.executable, "-m", "build", "--outdir", str(tmp / "dist"),
                           str(project)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    (sdist,) = (tmp / "dist").glob("kanedyn-*.tar.gz")
    (wheel,) = (tmp / "dist").glob("kanedyn-*.whl")
    return tmp, sdist, wheel


@pytest.mark.slow
def test_sdist_and_wheel_contain_every_package_file(built):
    _, sdist, wheel = built
    files = _package_files()
    data = {f for f in files if not f.endswith(".py")}
    # what the code reads at run time is among them
    assert {"kanedyn/io/_vendor/three/three.module.js", "kanedyn/io/_viewer.js",
            "kanedyn/io/_viewer_widget.js", "kanedyn/io/_viewer_page.js",
            "kanedyn/modeling/vehicle/pulses/frontal_48kmh.csv"} <= data
    inside_wheel = set(zipfile.ZipFile(wheel).namelist())
    assert files <= inside_wheel, sorted(files - inside_wheel)
    with tarfile.open(sdist) as archive:
        top = f"kanedyn-{PROJECT['version']}/"
        inside_sdist = {n[len(top):] for n in archive.getnames()}
    assert {f"src/{f}" for f in files} | {"pyproject.toml", "README.md"} <= inside_sdist
    metadata = zipfile.ZipFile(wheel).read(
        f"kanedyn-{PROJECT['version']}.dist-info/METADATA").decode()
    assert "Provides-Extra: all" in metadata and "Provides-Extra: notebook" in metadata


@pytest.mark.slow
def test_wheel_in_a_fresh_environment_runs_the_demo(built):
    tmp, _, wheel = built
    venv = tmp / "venv"
    # without a pip of its own (installing one took 5.2 s of CPU, measured): this
    # interpreter's pip installs into it (``pip --python``, pip >= 22.3)
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True,
                   timeout=300)
    python = venv / "bin" / "python"
    # this process's environment less its Python paths (a PYTHONPATH to the checkout
    # would make pip take kanedyn for installed); pip's settings and proxies kept
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env.update(PATH=f"{venv / 'bin'}:{os.environ.get('PATH', '/usr/bin:/bin')}",
               KANEDYN_CACHE_DIR=str(tmp / "cache"), MPLBACKEND="Agg")
    # --no-compile: pip byte-compiles none of the installed packages (sympy's and
    # scipy's thousands of modules: 27.8 s of CPU against 7.7 s, measured); the
    # modules the demo imports are compiled when imported, and pip's compiling
    # never failed an installation (it only warns)
    done = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install",
                           "-q", "--no-compile", str(wheel)],
                          capture_output=True, text=True, timeout=900, env=env, cwd=tmp)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    where = subprocess.run([str(python), "-c", "import kanedyn; print(kanedyn.__file__)"],
                           capture_output=True, text=True, cwd=tmp, env=env)
    assert where.stdout.startswith(str(venv)), where.stderr  # the wheel's copy
    out = tmp / "demo"
    done = subprocess.run([str(venv / "bin" / "kanedyn"), "demo", "--out", str(out),
                           "--quiet"], capture_output=True, text=True, timeout=900, env=env,
                          cwd=tmp)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "published (Meijaard et al. 2007)" in done.stdout
    assert {p.name for p in out.iterdir()} == {"bicycle_eigenvalues.png", "bicycle_ride.png",
                                               "bicycle_ride.csv"}
