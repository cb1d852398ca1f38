"""geometry.py: wrap_angle and the metre <-> cell conversions every module uses.

Grid used by most cases: resolution 0.5 m (exact in binary, so every expected number below is
exact), origin (-2.0, 1.0): column c spans x in [-2 + 0.5 c, -2 + 0.5 (c + 1)), row r spans
y in [1 + 0.5 r, 1 + 0.5 (r + 1)).
"""
import math

import numpy as np
import pytest

from turtlebot_recon.geometry import (cell_to_xy, cells_to_points, inside, points_to_cells,
                                      wrap_angle, xy_to_cell)

RES = 0.5
ORIGIN = (-2.0, 1.0)


# ---------------------------------------------------------------- wrap_angle

@pytest.mark.parametrize("a, expected", [
    (0.0, 0.0),                        # (0 + pi) % 2pi - pi = pi - pi, exactly
    (math.pi, -math.pi),               # the half-open end: +pi is -pi
    (-math.pi, -math.pi),
    (1.5 * math.pi, -0.5 * math.pi),   # 270 deg left = 90 deg right
    (-1.5 * math.pi, 0.5 * math.pi),
    (2.0 * math.pi + 0.5, 0.5),        # a whole turn more
    (-7.0 * math.pi + 0.25, -math.pi + 0.25),   # -7 pi = -pi (mod 2 pi)
])
def test_wrap_angle_into_minus_pi_to_pi(a, expected):
    assert wrap_angle(a) == pytest.approx(expected, abs=1e-12)
    assert -math.pi <= wrap_angle(a) < math.pi


def test_wrap_angle_on_arrays_is_the_scalar_result():
    a = np.array([-4.0, -math.pi, 0.3, math.pi, 7.0])
    assert np.array_equal(wrap_angle(a), [wrap_angle(float(v)) for v in a])


# ---------------------------------------------------------------- metres -> cells

@pytest.mark.parametrize("xy, cell", [
    ((-2.0, 1.0), (0, 0)),     # the origin is cell (0, 0)'s lower-left corner
    ((-1.75, 1.25), (0, 0)),   # its centre
    ((-1.5, 1.49), (0, 1)),    # x = -1.5 is column 1's left edge: (-1.5 + 2) / 0.5 = 1
    ((-1.0, 2.25), (2, 2)),    # (1.0 / 0.5, 1.25 / 0.5) = (2, 2.5) -> (2, 2)
    ((-2.1, 0.9), (-1, -1)),   # -0.1 / 0.5 = -0.2 floors to -1 (truncation would give 0)
    ((-3.0, -0.01), (-3, -2)),  # y: -1.01 / 0.5 = -2.02 -> -3; x: -1.0 / 0.5 = -2 exactly
])
def test_xy_to_cell_floors_toward_minus_infinity(xy, cell):
    assert xy_to_cell(xy, RES, ORIGIN) == cell
    assert all(type(v) is int for v in xy_to_cell(xy, RES, ORIGIN))


def test_origin_yaw_is_ignored():
    assert xy_to_cell((-1.0, 2.25), RES, (-2.0, 1.0, 0.3)) == (2, 2)
    assert cell_to_xy((2, 3), RES, (-2.0, 1.0, 0.3)) == (-0.25, 2.25)


def test_points_to_cells_matches_xy_to_cell_and_keeps_the_shape():
    xy = np.array([[(-2.0, 1.0), (-1.5, 1.49), (-1.0, 2.25)],
                   [(-2.1, 0.9), (-3.0, -0.01), (-1.75, 1.25)]])    # (2, 3, 2)
    rows, cols = points_to_cells(xy, RES, ORIGIN)
    assert rows.shape == cols.shape == (2, 3) and rows.dtype == cols.dtype == np.int64
    assert rows.tolist() == [[0, 0, 2], [-1, -3, 0]]
    assert cols.tolist() == [[0, 1, 2], [-1, -2, 0]]


# ---------------------------------------------------------------- cells -> metres

@pytest.mark.parametrize("cell, xy", [
    ((0, 0), (-1.75, 1.25)),   # (-2 + 0.5 * 0.5, 1 + 0.5 * 0.5)
    ((2, 3), (-0.25, 2.25)),   # (-2 + 3.5 * 0.5, 1 + 2.5 * 0.5)
    ((-1, -2), (-2.75, 0.75)),  # (-2 - 1.5 * 0.5, 1 - 0.5 * 0.5)
])
def test_cell_to_xy_is_the_cell_centre(cell, xy):
    assert cell_to_xy(cell, RES, ORIGIN) == xy
    assert all(type(v) is float for v in cell_to_xy(cell, RES, ORIGIN))


def test_cells_to_points_matches_cell_to_xy_and_keeps_the_shape():
    cells = np.array([[(0, 0), (2, 3)], [(-1, -2), (0, 0)]])         # (2, 2, 2)
    pts = cells_to_points(cells, RES, ORIGIN)
    assert pts.shape == (2, 2, 2) and pts.dtype == float
    assert pts.tolist() == [[[-1.75, 1.25], [-0.25, 2.25]], [[-2.75, 0.75], [-1.75, 1.25]]]
    assert cells_to_points(np.zeros((0, 2), int), RES, ORIGIN).shape == (0, 2)


def test_round_trip_cell_to_xy_to_cell():
    # a realistic grid: 5 cm cells, an origin off the cell lattice; a centre is half a cell
    # from every edge, so floor brings it back to its own cell despite rounding
    res, origin = 0.05, (-10.025, 3.3)
    rows, cols = np.mgrid[-40:41:7, -40:41:9]
    cells = np.stack([rows.ravel(), cols.ravel()], axis=1)
    for cell in cells:
        assert xy_to_cell(cell_to_xy(cell, res, origin), res, origin) == tuple(cell)
    back = points_to_cells(cells_to_points(cells, res, origin), res, origin)
    assert np.array_equal(np.stack(back, axis=1), cells)


# ---------------------------------------------------------------- inside

def test_inside_a_grid_of_shape():
    shape = (3, 4)                 # rows 0..2, cols 0..3
    assert inside(0, 0, shape) and inside(2, 3, shape)
    assert not inside(-1, 0, shape) and not inside(3, 0, shape)
    assert not inside(0, -1, shape) and not inside(0, 4, shape)
    rows, cols = np.array([0, 2, 3, -1, 1]), np.array([3, 0, 0, 1, 4])
    assert inside(rows, cols, shape).tolist() == [True, True, False, False, False]
