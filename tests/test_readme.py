"""The README's instructions work as printed."""

import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def readme():
    return (ROOT / "README.md").read_text()


def test_readme_example_runs(tmp_path, monkeypatch):
    block = re.findall(r"```python\n(.*?)```", readme(), re.S)[0]
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(compile(block, "README.md", "exec"), namespace)
    res = namespace["res"]
    assert res.success
    assert res.energy_drift() < 1e-8
    assert (tmp_path / "double_pendulum.png").exists()


def test_ci_runs_the_readme_test_command():
    commands = re.findall(r"```bash\n(.*?)\n```", readme(), re.S)
    assert len(commands) >= 2 and "kanedyn demo" in commands[0]
    ci = (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert ci == commands[1]


def test_contacts_doc_example_runs(tmp_path, monkeypatch):
    text = (ROOT / "docs" / "contacts.md").read_text()
    block = re.findall(r"```python\n(.*?)```", text, re.S)[0]
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(compile(block, "docs/contacts.md", "exec"), namespace)
    res, exact = namespace["res"], namespace["exact"]
    speed = np.linalg.norm(res.y[3:], axis=0)
    assert np.max(np.abs(speed / exact - 1)) < 1e-8
    assert (tmp_path / "sphere_slug.png").exists()
