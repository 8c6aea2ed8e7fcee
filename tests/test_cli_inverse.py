"""``kanedyn inverse``: CSV, plots, printed table; errors as one line, exit 2."""

import csv

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.cli import main


def _read(path):
    with path.open() as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


@pytest.mark.slow
def test_inverse_3rrr_writes_files_and_table(tmp_path, capsys):
    out = tmp_path / "inv"
    argv = ["inverse", "3rrr", "--set", "gravity=true", "--set", "m_p=2.0", "--t-end", "1",
            "--points", "21", "--out", str(out), "--quiet", "--forward-check"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    for name in ("forces.csv", "causes.csv", "groups.csv", "forces.png", "causes.png",
                 "groups.png", "power.png"):
        assert (out / name).stat().st_size > 0, name
    assert "motor1" in text and "N m" in text and "power-balance residual" in text
    assert "forward check: largest platform-pose error" in text
    header, data = _read(out / "forces.csv")
    assert header[:4] == ["t [s]", "x [m]", "y [m]", "phi [rad]"]
    assert data.shape == (21, len(header))
    # the same numbers as the library call, with the constant given
    study = kd.inverse_study(kd.models.build("3rrr", gravity=True), t_end=1.0, points=21,
                             constants={"m_p": 2.0})
    forces = data[:, [header.index(f"motor{i} [N m]") for i in (1, 2, 3)]]
    np.testing.assert_allclose(forces, study.forces.T, rtol=1e-12, atol=1e-12)
    # each part file sums to the forces; the power residual column is round-off
    for name in ("causes.csv", "groups.csv"):
        head, parts = _read(out / name)
        for i in (1, 2, 3):
            cols = [j for j, h in enumerate(head) if h.startswith(f"motor{i}:")]
            np.testing.assert_allclose(parts[:, cols].sum(axis=1), forces[:, i - 1],
                                       atol=1e-10)
    power = data[:, header.index("actuator power [W]")]
    residual = data[:, header.index("power residual [W]")]
    assert np.max(np.abs(residual)) < 1e-9 * np.max(np.abs(power))
    # the printed peak of motor1 is that of the CSV
    line = next(s for s in text.splitlines() if s.startswith("motor1"))
    assert float(line.split()[1]) == pytest.approx(np.max(np.abs(forces[:, 0])), rel=1e-3)


def test_inverse_sinusoid(tmp_path, capsys):
    assert main(["inverse", "3rrr", "--trajectory", "sinusoid", "--points", "11",
                 "--out", str(tmp_path), "--quiet"]) == 0
    header, data = _read(tmp_path / "forces.csv")
    assert np.ptp(data[:, header.index("phi [rad]")]) > 0.1  # +-5 degrees


@pytest.mark.parametrize("argv, message", [
    (["inverse", "pendulum"], "pendulum has no actuators"),
    (["inverse", "3rrr", "--set", "theta1=0.3"], "--set theta1: not an option or parameter"),
    (["inverse", "3rrr", "--trajectory", "spiral"], "invalid choice"),
    (["inverse", "3rrr", "--t-end", "-1"], "must be a finite number > 0"),
    (["inverse", "3rrr", "--points", "1"], "at least 2"),
])
def test_inverse_bad_input(tmp_path, capsys, argv, message):
    assert main(argv + ["--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o" / "forces.csv").exists()
