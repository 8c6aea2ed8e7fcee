r"""A platform trajectory read from a CSV file of poses over time, splined.

Two headers are accepted (times in s, positions in m, angles in rad):

- ``t,x,y,z,roll,pitch,yaw``: the platform's position and its body-fixed
  X-Y-Z angles, the convention of the parallel models' pose
  (:func:`kanedyn.models.out_parallel_ik`, ``phi_x, phi_y, phi_z``):
  :math:`R = R_x(\text{roll})\,R_y(\text{pitch})\,R_z(\text{yaw})`, the
  platform's axes in ground components.  (Not the aerospace Z-Y-X yaw-pitch-roll.)
- ``t,x,y,z,qw,qx,qy,qz``: the orientation as a unit quaternion (scalar
  first; norm within ``1e-6`` of 1, checked row by row), converted to those
  X-Y-Z angles on reading.

Angles are unwrapped (a jump by about 2π between rows is taken as the same
orientation) and every column is interpolated by a not-a-knot cubic spline
(C2: continuous pose, rate and acceleration), which gives the pose, its rate
and its acceleration the inverse dynamics needs.  Splining the model's own
angles (rather than slerp/squad of the quaternions) is chosen because the
model's coordinates *are* those angles and the inverse dynamics needs their
second derivatives: squad is only C1 at the rows, so its accelerations jump.
The spline's error for a smooth motion sampled every :math:`h` is
:math:`O(h^4)` in the pose, :math:`O(h^3)` in the rate and :math:`O(h^2)`
in the acceleration.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .._errors import KanedynError
from ._csv_table import read_numeric_csv

__all__ = ["PoseTable", "read_pose_csv", "POSE_HEADERS", "quaternion_to_xyz"]

#: The two accepted headers of a pose file: X-Y-Z angles, or a quaternion.
POSE_HEADERS = (("t", "x", "y", "z", "roll", "pitch", "yaw"),
                ("t", "x", "y", "z", "qw", "qx", "qy", "qz"))

_NORM_TOLERANCE = 1e-6


def quaternion_to_xyz(quaternion):
    r"""Body-fixed X-Y-Z angles of unit quaternions (scalar first).

    Parameters
    ----------
    quaternion : array_like, shape (N, 4)
        ``qw, qx, qy, qz`` (unit norm).

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        ``phi_x, phi_y, phi_z`` (rad) with :math:`R = R_x R_y R_z`;
        ``phi_y`` in :math:`[-\pi/2, \pi/2]`.
    """
    w, x, y, z = np.asarray(quaternion, float).T
    r02 = 2 * (x * z + w * y)
    r12 = 2 * (y * z - w * x)
    r22 = 1 - 2 * (x * x + y * y)
    r01 = 2 * (x * y - w * z)
    r00 = 1 - 2 * (y * y + z * z)
    return np.column_stack([np.arctan2(-r12, r22), np.arcsin(np.clip(r02, -1, 1)),
                            np.arctan2(-r01, r00)])


@dataclass(frozen=True)
class PoseTable:
    """A platform trajectory from a pose file, interpolated by cubic splines.

    Attributes
    ----------
    t : numpy.ndarray, shape (N,)
        Strictly increasing times, s.
    pose : numpy.ndarray, shape (N, 6)
        ``x, y, z`` (m) and body-fixed X-Y-Z angles ``phi_x, phi_y, phi_z``
        (rad, unwrapped) at those times.
    source : str
        The file it was read from.
    orientation : str
        ``"xyz angles"`` or ``"quaternion"``: how the file gave the orientation.
    """

    t: np.ndarray
    pose: np.ndarray
    source: str
    orientation: str

    def __call__(self, times):
        """Pose, rate and acceleration at ``times`` (s): three arrays of shape (k, 6).

        Units m, m/s, m/s² and rad, rad/s, rad/s².  Refused outside the
        table's times (no extrapolation).
        """
        times = np.atleast_1d(np.asarray(times, float))
        self.check_covers(float(np.min(times)), float(np.max(times)))
        spline = self._spline
        return spline(times), spline(times, 1), spline(times, 2)

    @cached_property
    def _spline(self):
        from scipy.interpolate import CubicSpline
        return CubicSpline(self.t, self.pose, axis=0, bc_type="not-a-knot")

    def check_covers(self, t0, t1):
        """Raise when the table does not cover ``[t0, t1]`` (s)."""
        if self.t[0] > t0 or self.t[-1] < t1:
            raise KanedynError(f"{self.source}: the pose table covers t = {self.t[0]:g} .. "
                               f"{self.t[-1]:g} s; asked for {t0:g} .. {t1:g} s")


def read_pose_csv(path):
    """Read a pose file (see the module's description); every number checked.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    PoseTable

    Raises
    ------
    KanedynError
        Naming the file and line (and column) of a wrong header, a value
        that is not a finite number, a time not after the one before, or a
        quaternion whose norm is not 1; fewer than four rows (a cubic spline
        needs four).
    """
    index, data, lines = read_numeric_csv(path, POSE_HEADERS, "pose")
    if len(data) < 4:
        raise KanedynError(f"{path}: needs at least four rows of poses for a cubic spline, "
                           f"has {len(data)}")
    if index == 0:
        angles, orientation = data[:, 4:7], "xyz angles"
    else:
        norm = np.linalg.norm(data[:, 4:8], axis=1)
        bad = np.flatnonzero(np.abs(norm - 1) > _NORM_TOLERANCE)
        if bad.size:
            i = bad[0]
            raise KanedynError(f"{path}, line {lines[i]}, columns qw,qx,qy,qz: the "
                               f"quaternion's norm is {norm[i]:.9g}, not 1 (within "
                               f"{_NORM_TOLERANCE:g})")
        angles, orientation = quaternion_to_xyz(data[:, 4:8]), "quaternion"
    pose = np.column_stack([data[:, 1:4], np.unwrap(angles, axis=0)])
    return PoseTable(t=data[:, 0], pose=pose, source=str(path), orientation=orientation)
