"""Angles, planar poses and grid cells: the one place that converts metres to cells, wraps
angles and composes SE(2) poses.

Grids are in nav_msgs/OccupancyGrid order: row 0 holds the smallest y, cell (row, col) is the
square ``origin + [col, col + 1) x [row, row + 1)`` cells, unrotated (``origin`` is (x, y[, yaw])
in metres; a yaw, if given, is ignored as map_server and the costmaps do). REP-103: metres and
radians, counter-clockwise positive.
"""
from __future__ import annotations

import math
from typing import Sequence, Tuple

import numpy as np


def wrap_angle(a):
    """An angle (rad), or an array of them, wrapped into [-pi, pi) (pi itself -> -pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def compose(a, b) -> np.ndarray:
    """The pose ``a ⊕ b`` (x, y, yaw): ``b`` given in ``a``'s frame, brought into ``a``'s parent.
    Either argument may be an (n, 3) array (broadcast)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([a[..., 0] + c * b[..., 0] - s * b[..., 1],
                     a[..., 1] + s * b[..., 0] + c * b[..., 1],
                     wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a) -> np.ndarray:
    """The pose ``⊖a``: ``compose(a, inverse(a))`` is the identity."""
    a = np.asarray(a, float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([-c * a[..., 0] - s * a[..., 1], s * a[..., 0] - c * a[..., 1],
                     wrap_angle(-a[..., 2])], axis=-1)


def between(a, b) -> np.ndarray:
    """``b`` seen from ``a`` (``⊖a ⊕ b``, GTSAM's ``a.between(b)``)."""
    return compose(inverse(a), b)


def transform_points(pose, xy) -> np.ndarray:
    """(n, 2) points given in the frame at ``pose`` (x, y, yaw), brought into its parent."""
    xy = np.asarray(xy, float).reshape(-1, 2)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.column_stack([pose[0] + c * xy[:, 0] - s * xy[:, 1], pose[1] + s * xy[:, 0] + c * xy[:, 1]])


def yaw_from_quaternion(qx, qy, qz, qw):
    """Yaw (rad) of a unit quaternion (x, y, z, w); numbers or arrays."""
    return np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def xy_to_cell(xy: Sequence[float], resolution: float, origin: Sequence[float]) -> Tuple[int, int]:
    """(x, y) m -> the (row, col) of the cell that holds it (may lie outside the grid)."""
    return (int(math.floor((xy[1] - origin[1]) / resolution)),
            int(math.floor((xy[0] - origin[0]) / resolution)))


def cell_to_xy(cell: Sequence[int], resolution: float, origin: Sequence[float]) -> Tuple[float, float]:
    """(row, col) -> (x, y) m of the cell's centre."""
    return (float(origin[0] + (cell[1] + 0.5) * resolution),
            float(origin[1] + (cell[0] + 0.5) * resolution))


def points_to_cells(xy: np.ndarray, resolution: float, origin: Sequence[float]) -> Tuple[np.ndarray, np.ndarray]:
    """Points (..., 2) as (x, y) m -> (rows, cols), int64 arrays of shape (...), of their cells
    (may lie outside the grid)."""
    xy = np.asarray(xy, dtype=float)
    return (np.floor((xy[..., 1] - origin[1]) / resolution).astype(np.int64),
            np.floor((xy[..., 0] - origin[0]) / resolution).astype(np.int64))


def cells_to_points(cells: np.ndarray, resolution: float, origin: Sequence[float]) -> np.ndarray:
    """Cells (..., 2) as (row, col) -> float array (..., 2) of their centres (x, y) m."""
    cells = np.asarray(cells, dtype=float)
    return np.stack([origin[0] + (cells[..., 1] + 0.5) * resolution,
                     origin[1] + (cells[..., 0] + 0.5) * resolution], axis=-1)


def inside(rows, cols, shape: Sequence[int]):
    """Whether (rows, cols) (scalars or arrays) lie in a grid of ``shape``."""
    return (rows >= 0) & (rows < shape[0]) & (cols >= 0) & (cols < shape[1])
