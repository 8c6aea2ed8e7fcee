"""The out-parallel manipulator's platform trajectory from a CSV file of poses: a
round trip through the file against the analytic quintic and sinusoid, the
spline's convergence order, and malformed files refused by file, line and column."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kanedyn import KanedynError
from kanedyn.analysis import PoseTable, inverse_study, quaternion_to_xyz, read_pose_csv
from kanedyn.models import build, quintic_pose, sinusoid_pose
from kanedyn.models._parallel import _rotation_xyz

HOME = np.array([0.0, 0.0, 0.8, 0.0, 0.0, 0.0])
OFFSET = np.array([0.05] * 3 + [np.radians(10.0)] * 3)      # as trajectory_offsets
T_END = 2.0


def _quintic(t):
    return quintic_pose(t, HOME, HOME + OFFSET, T_END)


def _sinusoid(t):
    return sinusoid_pose(t, HOME, OFFSET, 1.0 / T_END, 2 * np.pi * np.arange(6) / 6)


# largest fourth derivative of a pose component (m/s^4 or rad/s^4): the quintic's
# s'''' = (720 tau - 360)/T^4, the sinusoid's a (2 pi f)^4
M4 = {"quintic": 360 / T_END ** 4 * OFFSET.max(),
      "sinusoid": OFFSET.max() * (2 * np.pi / T_END) ** 4}


def _write(path, t, pose, quaternion=False):
    if quaternion:
        xyzw = Rotation.from_matrix(_rotation_xyz(*pose[:, 3:].T)).as_quat()
        head, cols = "t,x,y,z,qw,qx,qy,qz", np.column_stack([xyzw[:, 3], xyzw[:, :3]])
    else:
        head, cols = "t,x,y,z,roll,pitch,yaw", pose[:, 3:]
    rows = np.column_stack([t, pose[:, :3], cols])
    path.write_text(head + "\n" + "\n".join(",".join(repr(float(v)) for v in r)
                                            for r in rows) + "\n")
    return path


def test_quaternion_to_xyz_inverts_the_models_rotation():
    angles = np.random.default_rng(3).uniform(-1.2, 1.2, (20, 3))
    xyzw = Rotation.from_matrix(_rotation_xyz(*angles.T)).as_quat()
    got = quaternion_to_xyz(np.column_stack([xyzw[:, 3], xyzw[:, :3]]))
    np.testing.assert_allclose(got, angles, atol=1e-13)


@pytest.mark.parametrize("name, quaternion", [("quintic", False), ("sinusoid", True)])
def test_pose_csv_round_trip_against_the_analytic_path(tmp_path, name, quaternion):
    """Sampled every h = 0.02 s, splined back: within h^4 M4/20, h^3 M4/4, h^2 M4."""
    exact = _quintic if name == "quintic" else _sinusoid
    rows = np.linspace(0.0, T_END, 101)
    h = rows[1] - rows[0]
    table = read_pose_csv(_write(tmp_path / "p.csv", rows, exact(rows)[0], quaternion))
    assert table.orientation == ("quaternion" if quaternion else "xyz angles")
    t = np.linspace(0.0, T_END, 401)
    got, ref = table(t), exact(t)
    for k, (g, r) in enumerate(zip(got, ref)):
        tol = (h ** 4 * M4[name] / 20, h ** 3 * M4[name] / 4, h ** 2 * M4[name])[k]
        assert np.max(np.abs(g - r)) < tol, (k, np.max(np.abs(g - r)), tol)


def test_spline_converges_at_orders_4_3_2(tmp_path):
    t = np.linspace(0.0, T_END, 301)
    errors = []
    for n in (51, 101):
        rows = np.linspace(0.0, T_END, n)
        table = PoseTable(t=rows, pose=_sinusoid(rows)[0], source="x", orientation="x")
        errors.append([np.max(np.abs(g - r)) for g, r in zip(table(t), _sinusoid(t))])
    ratio = np.array(errors[0]) / np.array(errors[1])
    np.testing.assert_allclose(np.log2(ratio), [4, 3, 2], atol=0.35)


@pytest.fixture(scope="module")
def machine():
    definition = build("out-parallel-6dof")
    return definition, definition.numeric(definition.derive())


def test_forces_from_a_pose_file_match_the_analytic_quintic(tmp_path, machine):
    definition, model = machine
    rows = np.linspace(0.0, T_END, 101)
    table = read_pose_csv(_write(tmp_path / "p.csv", rows, _quintic(rows)[0]))
    ref = inverse_study(definition, "quintic", t_end=T_END, points=41, model=model)
    got = inverse_study(definition, points=41, model=model, poses=table)
    np.testing.assert_array_equal(got.t, ref.t)
    assert got.trajectory == "pose file p.csv"
    # acceleration error <= h^2 M4 = 1.6e-3 m/s^2 (or rad/s^2) in each pose axis; a
    # carriage's acceleration error is at most ~4 times that (strut leverage), and it
    # moves ~300 kg (237 kg reflected drive train + carriage, struts, platform share):
    # 300 * 4 * 1.6e-3 = 1.9 N (measured 0.28 N, of peak forces 170 N)
    assert np.max(np.abs(got.forces - ref.forces)) < 1.9
    np.testing.assert_allclose(got.q, ref.q, atol=1e-7)


@pytest.mark.parametrize("text, message", [
    ("t,x,y,z,roll,pitch\n", r"p.csv, line 1: the header must be t,x,y,z,roll,pitch,yaw or "
                             r"t,x,y,z,qw,qx,qy,qz"),
    ("t,x,y,z,roll,pitch,yaw\n0,0,0,.8,0,0,0\n1,0,0,.8,0,x,0\n",
     r"p.csv, line 3, column pitch: 'x' is not a finite number"),
    ("t,x,y,z,roll,pitch,yaw\n0,0,0,.8,0,0,0\n1,0,0,.8,0,0,0\n1,0,0,.8,0,0,0\n",
     r"p.csv, line 4: t = 1 s is not after the previous row's 1 s"),
    ("t,x,y,z,roll,pitch,yaw\n0,0,0,.8,0,0,0\n1,0,0,.8,0,0\n",
     r"p.csv, line 3: 6 values, expected 7"),
    ("t,x,y,z,roll,pitch,yaw\n0,0,0,.8,0,0,0\n1,0,0,.8,0,0,0\n2,0,0,.8,0,0,0\n",
     r"p.csv: needs at least four rows of poses for a cubic spline, has 3"),
    ("t,x,y,z,qw,qx,qy,qz\n0,0,0,.8,1,0,0,0\n\n1,0,0,.8,1,0,0,0\n2,0,0,.8,1,0.1,0,0\n"
     "3,0,0,.8,1,0,0,0\n",
     r"p.csv, line 5, columns qw,qx,qy,qz: the quaternion's norm is 1.00498756, not 1"),
])
def test_malformed_pose_files_are_refused_naming_line_and_column(tmp_path, text, message):
    path = tmp_path / "p.csv"
    path.write_text(text)
    with pytest.raises(KanedynError, match=message):
        read_pose_csv(path)


def test_a_pose_table_refuses_times_outside_it(tmp_path):
    rows = np.linspace(0.0, 1.0, 5)
    table = PoseTable(t=rows, pose=_quintic(rows)[0], source="p.csv", orientation="x")
    with pytest.raises(KanedynError, match=r"p.csv: the pose table covers t = 0 .. 1 s; "
                                           r"asked for 0 .. 1.5 s"):
        table([0.0, 1.5])
