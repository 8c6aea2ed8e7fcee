"""The README's and the docs' code blocks work as printed.

The README's ```python blocks run in order in one namespace, as a reader
pasting them into one session would (each later block continues the double
pendulum of the first), in a temporary directory; the numbers they leave
behind are checked against closed forms.  Its ```bash blocks are run too,
each line as a command, unless the line before the block is a marker
``<!-- readme-test: skip (REASON) -->``: the two install lines at the top are
skipped that way (they install the package; CI runs the second one itself).
Only ``kanedyn`` commands may run here (nothing else is run from text).
"""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SKIP = re.compile(r"<!-- readme-test: skip \((.+?)\) -->\n$")


def readme():
    return (ROOT / "README.md").read_text()


def blocks(text, language):
    """``[(code, skip reason or None)]`` of the fenced blocks of ``language``."""
    out = []
    for match in re.finditer(rf"```{language}\n(.*?)```", text, re.S):
        before = text[:match.start()]
        marker = SKIP.search(before[before.rfind("\n", 0, len(before) - 1) + 1:])
        out.append((match.group(1), marker.group(1) if marker else None))
    return out


def run_python_blocks(text, source, tmp_path, monkeypatch):
    """Run every ```python block of ``text`` in order in one namespace; the
    namespace after each block."""
    monkeypatch.chdir(tmp_path)
    namespace, after = {}, []
    for k, (code, skip) in enumerate(blocks(text, "python")):
        assert skip is None, f"{source}: python block {k} is marked as skipped"
        exec(compile(code, f"{source} (python block {k})", "exec"), namespace)
        after.append(dict(namespace))
    return after


@pytest.mark.slow
def test_readme_python_blocks_run(tmp_path, monkeypatch):
    after = run_python_blocks(readme(), "README.md", tmp_path, monkeypatch)
    assert len(after) == 5
    first = after[0]                                   # the double pendulum
    assert first["res"].success and first["res"].energy_drift() < 1e-8
    assert (tmp_path / "double_pendulum.png").exists()

    api = after[1]                                     # more of the API
    values = {api["m"]: 1.0, api["l"]: 0.5, api["g"]: 9.81}
    A = np.array(api["A"].subs(values), dtype=float)   # the symbolic linearization
    omega = np.sort(np.abs(np.linalg.eigvals(A).imag))
    # two uniform rods, absolute angles: omega^2 = (3 -+ 6/sqrt(7)) g/l
    exact = np.sqrt(np.array([3 - 6 / 7 ** 0.5, 3 + 6 / 7 ** 0.5]) * 9.81 / 0.5)
    np.testing.assert_allclose(omega[::2], exact, rtol=1e-10)
    np.testing.assert_allclose(omega[1::2], exact, rtol=1e-10)
    Y, Ydot = api["Y"], api["Ydot"]
    np.testing.assert_allclose(Ydot[7], api["model"].rhs(0.0, Y[7]), rtol=1e-9, atol=1e-9)
    assert (tmp_path / "run.csv").exists() and (tmp_path / "run.npz").exists()
    T, q = api["res"]["T"], api["res"]["q"]            # rod tension, pendulum of l = 1 m
    u = api["res"]["u"]
    np.testing.assert_allclose(T, 1.0 * (9.81 * np.cos(q) + 1.0 * u ** 2), atol=1e-6)

    contact = after[2]                                 # the thrown ball
    res = contact["res"]
    assert res.success and len(res.impacts) > 3
    assert res.mode_history[-1][3] == "stick"
    assert res.contact_forces["floor"]["normal"][-1] == pytest.approx(0.1 * 9.81, rel=1e-6)
    assert np.max(np.abs(res.energy_balance())) < 1e-9

    rod = after[3]                                     # tension by a vector constraint
    res = rod["res"]
    expected = 1.5 * (9.81 * np.cos(res["theta"]) + 0.8 * res["u"] ** 2)
    np.testing.assert_allclose(res["T"], expected, rtol=1e-6, atol=1e-6)

    loop = after[4]                                    # the four-bar by Lagrange-Baumgarte
    assert loop["res"].success
    crank = loop["kane_model"]
    ref = __import__("kanedyn").simulate(crank, (0, 2), loop["y0"], rtol=1e-10, atol=1e-10)
    assert abs(loop["res"]["q1"][-1] - ref["q1"][-1]) < 1e-4


@pytest.mark.slow
def test_readme_bash_blocks(tmp_path):
    """Every ```bash block runs, or says why not; only kanedyn commands."""
    found = blocks(readme(), "bash")
    assert len(found) >= 3
    skipped = [code for code, skip in found if skip]
    assert any("kanedyn demo" in code for code in skipped)
    ran = 0
    for code, skip in found:
        if skip:
            continue
        for line in code.strip().splitlines():
            words = shlex.split(line)
            assert words[0] == "kanedyn", f"README bash block runs {line!r}, not kanedyn"
            proc = subprocess.run([sys.executable, "-m", "kanedyn.cli", *words[1:]],
                                  cwd=tmp_path, capture_output=True, text=True, timeout=600)
            assert proc.returncode == 0, f"{line}: {proc.stderr[-2000:]}"
            ran += 1
    assert ran >= 2
    assert (tmp_path / "pendulum-run" / "summary.json").exists()


def test_ci_runs_the_readme_test_command():
    commands = [code.strip() for code, _ in blocks(readme(), "bash")]
    assert len(commands) >= 2 and "kanedyn demo" in commands[0]
    ci = (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert ci == commands[1]


def test_contacts_doc_example_runs(tmp_path, monkeypatch):
    text = (ROOT / "docs" / "contacts.md").read_text()
    ns = run_python_blocks(text, "docs/contacts.md", tmp_path, monkeypatch)[0]
    res, exact = ns["res"], ns["exact"]
    speed = np.linalg.norm(res.y[3:], axis=0)
    assert np.max(np.abs(speed / exact - 1)) < 1e-8
    assert (tmp_path / "sphere_slug.png").exists()


@pytest.mark.slow
def test_linearization_page_examples(tmp_path, monkeypatch):
    """docs/linearization.md: the pendulum's frequency, the cart's B and the
    bicycle's eigenvalues against the published benchmark (Meijaard et al. 2007)."""
    text = (ROOT / "docs" / "linearization.md").read_text()
    pendulum, cart, bicycle = run_python_blocks(text, "docs/linearization.md", tmp_path,
                                                monkeypatch)
    assert str(pendulum["omega"]) == "sqrt(g)/sqrt(l)"
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(pendulum["A"]).real),
                               [-(9.81 / 0.8) ** 0.5, (9.81 / 0.8) ** 0.5], rtol=1e-12)
    np.testing.assert_allclose(cart["B"].ravel(), [0, 0, 1 / 2.0, -1 / (2.0 * 0.6)],
                               atol=1e-12)
    published = np.array([-14.07838969279820, -0.77534188219585 - 4.46486771378823j,
                          -0.77534188219585 + 4.46486771378823j, -0.32286642900409])
    got = np.sort_complex(bicycle["ev"])
    assert got.size == 4
    np.testing.assert_allclose(got, np.sort_complex(published), atol=1e-9)
