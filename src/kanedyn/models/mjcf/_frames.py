"""Orientations of MJCF frames as rotation matrices (numbers only).

MuJoCo writes an orientation in one of five ways, read here as it documents
them: ``quat`` (w, x, y, z; normalised), ``axisangle`` (axis, angle),
``euler`` (three angles about the axes of the compiler's ``eulerseq``: a
lower-case letter turns about the rotating axis, an upper-case one about the
fixed axis), ``xyaxes`` (the frame's x axis and a vector in its x-y plane) and
``zaxis`` (the frame's z axis, reached by the smallest rotation from z).  A
rotation matrix ``R`` here maps the components of a vector in the child frame
to those in the parent frame.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["quat_matrix", "matrix_quat", "axis_angle_matrix", "euler_matrix",
           "xyaxes_matrix", "zaxis_matrix", "ORIENTATIONS"]

#: the attributes that give an orientation, in MuJoCo's spelling
ORIENTATIONS = ("quat", "axisangle", "euler", "xyaxes", "zaxis")


def quat_matrix(quat):
    """Rotation matrix (3, 3) of a quaternion (w, x, y, z), normalised first."""
    w, x, y, z = np.asarray(quat, dtype=float) / np.linalg.norm(quat)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def matrix_quat(R):
    """Unit quaternion (w, x, y, z), w >= 0, of a rotation matrix (3, 3)."""
    R = np.asarray(R, dtype=float)
    trace = np.trace(R)
    if trace > 0:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s,
             (R[1, 0] - R[0, 1]) / s]
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(1.0 + R[i, i] - R[j, j] - R[k, k])
        q = [0.0] * 4
        q[0] = (R[k, j] - R[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (R[j, i] + R[i, j]) / s
        q[1 + k] = (R[k, i] + R[i, k]) / s
    q = np.array(q)
    return q if q[0] >= 0 else -q


def axis_angle_matrix(axis, angle):
    """Rotation by ``angle`` (rad) about the unit vector ``axis`` (Rodrigues)."""
    n = np.asarray(axis, dtype=float)
    K = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def euler_matrix(angles, sequence):
    """Rotation of three angles (rad) about the axes named by ``sequence`` (e.g.
    ``"xyz"``): lower case about the rotating axis (the rotation multiplies on
    the right), upper case about the fixed axis (on the left)."""
    R = np.eye(3)
    for angle, letter in zip(angles, sequence):
        step = axis_angle_matrix(np.eye(3)["xyz".index(letter.lower())], angle)
        R = R @ step if letter.islower() else step @ R
    return R


def xyaxes_matrix(x, y):
    """The frame whose x axis is along ``x`` and whose x-y plane holds ``y``;
    None when they are parallel or zero."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    nx = np.linalg.norm(x)
    if nx < 1e-12:
        return None
    x = x / nx
    y = y - (x @ y) * x
    ny = np.linalg.norm(y)
    if ny < 1e-12:
        return None
    y = y / ny
    return np.column_stack([x, y, np.cross(x, y)])


def zaxis_matrix(z):
    """The smallest rotation taking (0, 0, 1) to the direction of ``z``; None
    when ``z`` is zero.  Opposite to (0, 0, 1) it is the half turn about x."""
    z = np.asarray(z, dtype=float)
    nz = np.linalg.norm(z)
    if nz < 1e-12:
        return None
    z = z / nz
    axis = np.cross([0.0, 0.0, 1.0], z)
    s = np.linalg.norm(axis)
    if s < 1e-14:
        return np.eye(3) if z[2] > 0 else axis_angle_matrix([1.0, 0.0, 0.0], math.pi)
    return axis_angle_matrix(axis / s, math.atan2(s, z[2]))
