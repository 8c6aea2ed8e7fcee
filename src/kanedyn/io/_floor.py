r"""The height of the ground grid: below everything drawn, at every frame.

The grid is placed at the lowest height, along the up direction :math:`u`, that
any drawn thing reaches over all the frames of the scene (not a sample of them).
A shape's lowest height at a frame is its centre's height minus its support in
the direction :math:`u` (the largest :math:`x \cdot u` over the shape's points
:math:`x` taken from its centre):

* box of half lengths :math:`e`: :math:`\sum_i e_i |v_i|`;
* ellipsoid of semi-axes :math:`a`: :math:`\sqrt{\sum_i (a_i v_i)^2}`;
* cylinder of radius :math:`r`, length :math:`L` along its y:
  :math:`\tfrac L2 |v_y| + r \sqrt{1 - v_y^2}`;
* mesh: the box of its (scaled) vertices, so at most that box's slack lower
  than the mesh itself,

with :math:`v` the up direction in the shape's own axes at that frame.
"""

from __future__ import annotations

import base64

import numpy as np

__all__ = ["lowest_height", "shape_support"]


def _mesh_box(shape):
    """``(centre, half lengths)`` of a mesh shape's scaled vertices."""
    vertices = np.frombuffer(base64.b64decode(shape["vertices"]), "<f4").reshape(-1, 3)
    vertices = vertices.astype(float) * np.asarray(shape["scale"], float)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    return 0.5 * (lo + hi), 0.5 * (hi - lo)


def shape_support(shape, v):
    """``(k,)`` support of a shape (page data) in directions ``v`` (k, 3), own axes.

    The support is measured from the shape's placed origin (its ``offset``).
    """
    kind = shape["kind"]
    if kind == "box":
        return np.abs(v) @ (0.5 * np.asarray(shape["lengths"], float))
    if kind == "sphere":
        return np.sqrt(((v * np.asarray(shape["semi_axes"], float)) ** 2).sum(axis=1))
    if kind == "cylinder":
        vy = np.clip(np.abs(v[:, 1]), 0.0, 1.0)
        return 0.5 * shape["length"] * vy + shape["radius"] * np.sqrt(1.0 - vy ** 2)
    if kind == "mesh":
        centre, half = _mesh_box(shape)
        return v @ centre + np.abs(v) @ half
    raise ValueError(f"unknown shape kind {kind!r}")


def _matrices(quaternion):
    """Rotation matrices of unit quaternions ``(x, y, z, w)``, shape (..., 3, 3)."""
    x, y, z, w = np.moveaxis(np.asarray(quaternion, float), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def lowest_height(up, position, rotation, shapes):
    """The lowest height along ``up`` of shapes on a body, over its frames.

    Parameters
    ----------
    up : array_like, shape (3,)
        Unit up direction, inertial components.
    position : ndarray, shape (k, 3)
        The body's reference point at each frame.
    rotation : ndarray, shape (k, 3, 3)
        Body-frame to inertial rotation matrices at each frame.
    shapes : list of dict
        The body's shapes as page data (``kind``, ``offset``, ``quaternion``...).

    Returns
    -------
    float
        ``inf`` when there is no shape.
    """
    up = np.asarray(up, float)
    w = np.einsum("kab,a->kb", rotation, up)  # up in body components at each frame
    low = np.inf
    for shape in shapes:
        R = _matrices(shape["quaternion"])
        centre = position @ up + w @ np.asarray(shape["offset"], float)
        low = min(low, float(np.min(centre - shape_support(shape, w @ R))))
    return low
