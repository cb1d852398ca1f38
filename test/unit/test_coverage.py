"""Reachable free space F and coverage (DESIGN §6) on hand-made worlds, and the C++ line of
sight ``_native.visible_cells`` against a plain-Python reference. Expected numbers are worked
out in the comments; every world is 0.05 m per cell."""
import math
from dataclasses import replace
from functools import partial

import numpy as np
import pytest

from turtlebot_recon import _native
from turtlebot_recon.evaluation import CoverageTracker, reachable_cells, reachable_free_space
from turtlebot_recon.evaluation import coverage as coverage_module
from turtlebot_recon.evaluation.coverage import free_at, lattice_points, map_values_at
from turtlebot_recon.evaluation.metrics import map_cells_in_world
from turtlebot_recon.robot import load_robot
from turtlebot_recon.sim import load_world

from conftest import ray_cells, room, write_world

# the binding takes every argument: F's own beam count unless a test gives its own
visible_cells = partial(_native.visible_cells, beams=coverage_module.LIDAR_BEAMS)

RES = 0.05
BURGER = load_robot("turtlebot3_burger")


# ---------------------------------------------------------------- visible_cells (C++)

def reference_visible_cells(blocking, points, radius, beams):
    """Union over the points of the cells on `beams` rays, each ray stopped beyond `radius`
    (centre to centre), at the grid's edge or on a blocking cell other than the point's own;
    blocking cells are never seen."""
    seen = np.zeros(blocking.shape, bool)
    for point in points:
        for ray in ray_cells(tuple(point), radius, beams, blocking.shape):
            for r, c, is_origin in ray:
                if blocking[r, c]:
                    if not is_origin:
                        break
                else:
                    seen[r, c] = True
    return seen


def test_visible_cells_matches_the_reference_on_random_maps():
    rng = np.random.default_rng(11)
    for trial in range(12):
        rows, cols = rng.integers(1, 40, size=2)
        blocking = (rng.random((rows, cols)) < rng.uniform(0.0, 0.3)).astype(np.uint8)
        n = int(rng.integers(0, 5))
        points = np.stack([rng.integers(0, rows, n), rng.integers(0, cols, n)], axis=1)
        points = points.astype(np.int32).reshape(-1, 2)   # some points land on blocking cells
        for radius in (0.0, 1.0, 2.5, 7.3, 15.0):
            for beams in (1, 7, 360):
                got = visible_cells(blocking, points, radius, beams=beams)
                want = reference_visible_cells(blocking, points.tolist(), radius, beams)
                assert got.dtype == np.bool_ and got.shape == (rows, cols)
                assert np.array_equal(got, want), (trial, radius, beams)
                assert not (got & (blocking != 0)).any()


def test_visible_cells_open_disc_and_blocking_viewpoint():
    # Open grid, one viewpoint: the disc of radius 10 cells, 317 lattice points (Gauss's circle
    # problem, N(10)); 360 beams leave no gap at 10 cells (test_frontiers' visible_unknown).
    blocking = np.zeros((41, 41), np.uint8)
    centre = np.array([[20, 20]], np.int32)
    seen = visible_cells(blocking, centre, 10.0)
    assert seen.sum() == 317
    rr, cc = np.mgrid[-20:21, -20:21]
    assert np.array_equal(seen, rr ** 2 + cc ** 2 <= 100)
    # A blocking viewpoint sees around itself but not its own cell: 316.
    blocking[20, 20] = 1
    seen = visible_cells(blocking, centre, 10.0)
    assert seen.sum() == 316 and not seen[20, 20]


def test_visible_cells_wall_hides_what_is_behind_it():
    # A full wall column 3 cells right of the viewpoint: every ray going right crosses column
    # dc = 3 (Bresenham moves at most one column per step) and stops there, unseen. Seen: the
    # disc cells with dc <= 2. Per dc the rows |dr| <= floor(sqrt(100 - dc^2)) number
    # 2 * 10 + 1 = 21 for dc = 0 and 2 * 9 + 1 = 19 for |dc| in 1..4 (sqrt 99, 96, 91, 84),
    # 2 * 8 + 1 = 17 for |dc| = 5, 6 (sqrt 75, 64), 15 (7, sqrt 51), 13 (6, sqrt 36),
    # 9 (4, sqrt 19), 1 (dc = 10). Left half dc = -10..-1: 4 * 19 + 2 * 17 + 15 + 13 + 9 + 1
    # = 148; dc = 0..2: 21 + 19 + 19 = 59. Total 207.
    blocking = np.zeros((41, 41), np.uint8)
    blocking[:, 23] = 1
    seen = visible_cells(blocking, np.array([[20, 20]], np.int32), 10.0)
    assert seen.sum() == 207
    assert not seen[:, 23:].any()


def test_visible_cells_union_of_viewpoints_and_empty_query():
    blocking = np.zeros((30, 30), np.uint8)
    a = visible_cells(blocking, np.array([[5, 5]], np.int32), 4.0)
    b = visible_cells(blocking, np.array([[20, 22]], np.int32), 4.0)
    both = visible_cells(blocking, np.array([[5, 5], [20, 22]], np.int32), 4.0)
    assert np.array_equal(both, a | b)
    assert not visible_cells(blocking, np.zeros((0, 2), np.int32), 4.0).any()


def test_visible_cells_rejects_bad_input():
    blocking = np.zeros((10, 10), np.uint8)
    with pytest.raises(ValueError, match="visible_cells: point 1 .* outside"):
        visible_cells(blocking, np.array([[1, 1], [10, 0]], np.int32), 3.0)
    with pytest.raises(ValueError, match="visible_cells: beams"):
        visible_cells(blocking, np.array([[1, 1]], np.int32), 3.0, beams=0)
    with pytest.raises(ValueError, match="visible_cells: blocking must be a 2-D"):
        visible_cells(np.zeros(10, np.uint8), np.array([[1, 1]], np.int32), 3.0)


# ---------------------------------------------------------------- reachable free space F

def carve(free, x0, y0, x1, y1):
    """Make the cells with centres in [x0, x1] x [y0, y1] (m) free, in place."""
    rows, cols = free.shape
    xs, ys = (np.arange(cols) + 0.5) * RES, (np.arange(rows) + 0.5) * RES
    free[np.ix_((ys > y0) & (ys < y1), (xs > x0) & (xs < x1))] = True
    return free


def test_a_room_is_all_in_f(room_world):
    # 4 x 3 m room: 80 x 60 = 4800 free cells, every one in sight of some viewpoint.
    world = load_world(room_world)
    f = reachable_free_space(world, BURGER, 3.5)
    assert f.sum() == 4800
    assert np.array_equal(f, world.free)
    # The centre reaches the free cells more than 0.105 m from the walls: cell k (0-based from
    # a wall) has clearance (k + 0.5) * 0.05, > 0.105 from k = 2, so (80 - 4) x (60 - 4).
    assert reachable_cells(world, BURGER).sum() == 76 * 56


def pocket_world(tmp_path, baffle):
    """A 4 x 3 m room (x 0.1..4.1, y 0.1..3.1, cols 2..81, rows 2..61) and, east of a 0.3 m
    wall (x 4.1..4.4, cols 82..87), a 0.6 x 3 m pocket (x 4.4..5.0, cols 88..99) joined by a
    slot through the wall 0.15 m high (y 1.55..1.7, rows 31..33). With ``baffle``, a wall
    0.1 m thick (x 4.55..4.65, cols 91, 92) spans y 1.0..2.2 (rows 20..43) behind the slot,
    leaving a 3-cell channel (cols 88..90) between it and the wall."""
    free = np.zeros((64, 102), bool)
    carve(free, 0.1, 0.1, 4.1, 3.1)
    carve(free, 4.4, 0.1, 5.0, 3.1)
    carve(free, 4.0, 1.55, 4.5, 1.7)
    if baffle:
        carve_solid = ~carve(np.zeros_like(free), 4.55, 1.0, 4.65, 2.2)
        free &= carve_solid
    return load_world(write_world(tmp_path, "pocket", free, start=[1.0, 1.5, 0.0]))


def columns_beyond(world, x_m):
    xs = world.origin[0] + (np.arange(world.free.shape[1]) + 0.5) * RES
    return world.free & (xs > x_m)[None, :]


def test_pocket_behind_a_narrow_gap_and_baffle_is_excluded(tmp_path):
    # The slot's middle row has clearance 2 cells - half a cell = 0.075 m < 0.105: the burger
    # cannot pass. A ray through the slot (6 columns within 3 rows: slope <= 2/5) gains at most
    # 2 more rows over the 3-column channel, so at the baffle (col 91) it is on rows 29..35,
    # all baffle: the pocket beyond it (x > 4.65, cols 93..99, rows 2..61: 7 x 60 = 420 free
    # cells, 8-connected to the room) is out of sight.
    world = pocket_world(tmp_path, baffle=True)
    pocket, far = columns_beyond(world, 4.4), columns_beyond(world, 4.65)
    assert far.sum() == 420
    f = reachable_free_space(world, BURGER, 3.5)
    assert not (reachable_cells(world, BURGER) & pocket).any()
    assert not (f & far).any()
    assert np.array_equal(f[:, :82], world.free[:, :82])        # the room: all of it
    # A robot of radius 0.05 m fits through the slot and the channel (middle cells 0.075 m
    # clear), and drives round the baffle: the whole pocket is in F.
    f_small = reachable_free_space(world, replace(BURGER, radius_m=0.05), 3.5)
    assert np.array_equal(f_small & pocket, pocket)


def test_pocket_seen_through_a_narrow_gap_counts_where_visible(tmp_path):
    # No baffle: the burger cannot enter, but sees straight through the slot. The pocket cell
    # behind it (row 32, col 88: x 4.425, y 1.625) is in F; the pocket's corners (rows 2 and
    # 61, col 99) are 30 rows off the slot over 12 columns, a slope the slot (<= 2/5) never
    # lets through.
    world = pocket_world(tmp_path, baffle=False)
    f = reachable_free_space(world, BURGER, 3.5)
    pocket = columns_beyond(world, 4.4)
    assert world.free[32, 88] and f[32, 88]
    assert world.free[2, 99] and not f[2, 99]
    assert world.free[61, 99] and not f[61, 99]
    assert 0 < (f & pocket).sum() < pocket.sum()
    assert not (reachable_cells(world, BURGER) & pocket).any()


def test_cells_beyond_sensor_range_are_excluded(tmp_path):
    # A 2 x 2 m room (x, y 0.1..2.1, cols and rows 2..41), a 0.1 m wall (cols 42, 43) and
    # through it a dead-end corridor 0.15 m wide (rows 21..23, y 1.05..1.2) to x = 5.1 (col
    # 101). The burger cannot enter: its disc, 0.105 m, keeps the lattice's margin_m (0.02 m)
    # off every obstacle cell's square, 0.125 m, and the middle row has 0.075 m. Cell (22, 40)
    # is 1.5 cells in x and y from the nearest corners of (20, 42) and (24, 42), 0.106 m;
    # (22, 39) is sqrt(0.125^2 + 0.075^2) = 0.146 m from them: the reachable cells end at col
    # 39. F's viewpoint in the block of cols 35..39, rows 20..24 is its centre (22, 37), x =
    # 1.875: with a 1.0 m range (20 cells) it sees the corridor's axis to col 57, so cols
    # 58..101, 44 x 3 = 132 cells, are out of F. With a 5 m range the whole corridor (cols
    # 42..101, 60 x 3 = 180 cells) is in sight along its axis.
    free = np.zeros((44, 104), bool)
    carve(free, 0.1, 0.1, 2.1, 2.1)
    carve(free, 2.0, 1.05, 5.1, 1.2)
    world = load_world(write_world(tmp_path, "corridor", free, start=[1.0, 1.0, 0.0]))
    reach_cols = np.nonzero(reachable_cells(world, BURGER))[1]
    assert reach_cols.max() == 39
    corridor = world.free.copy()
    corridor[:, :42] = False
    assert corridor.sum() == 180
    beyond = corridor.copy()
    beyond[:, :58] = False
    assert beyond.sum() == 132
    near = reachable_free_space(world, BURGER, 1.0)
    assert not (near & beyond).any()
    assert near[22, 42:58].all()                     # its mouth is in range and in sight
    assert np.array_equal(near[:, :42], world.free[:, :42])   # the room itself
    far = reachable_free_space(world, BURGER, 5.0)
    assert np.array_equal(far & corridor, corridor)


def test_lattice_keeps_a_viewpoint_in_every_block():
    # A reachable band 2 cells high (rows 6, 7), 20 cells long: a fixed lattice on rows
    # 0, 5, 10 would miss it; one viewpoint per 5 x 5 block gives 4 (cols 0-4, ..., 15-19),
    # each the band cell nearest its block centre (row 7 is 1 from the centre row 7, col
    # 2 + 5 k).
    reach = np.zeros((15, 20), bool)
    reach[6:8, :] = True
    pts = lattice_points(reach, 5)
    assert pts.tolist() == [[7, 2], [7, 7], [7, 12], [7, 17]]
    assert lattice_points(np.zeros((3, 3), bool), 5).shape == (0, 2)


def test_start_too_close_to_a_wall_uses_the_nearest_roomy_cell(tmp_path):
    # Start at x = 0.125 (cell k = 0 from the west wall, clearance 0.025 m). For the burger the
    # nearest roomy cell is k = 2 (clearance 0.125 > 0.105), 0.1 m away (<= 0.105): its
    # component, the room's 36 x 36 roomy cells (2 m = 40 cells, less 2 per side), is used.
    world = load_world(write_world(tmp_path, "tight", room(2.0, 2.0), start=[0.125, 1.0, 0.0]))
    assert reachable_cells(world, BURGER).sum() == 36 * 36
    # A corridor 0.3 m wide has no cell with more than 0.15 m of clearance: no robot of radius
    # 0.2 m fits anywhere.
    narrow = load_world(write_world(tmp_path, "narrow", room(2.0, 0.3), start=[1.0, 0.25, 0.0]))
    with pytest.raises(ValueError, match="start"):
        reachable_cells(narrow, replace(BURGER, radius_m=0.2))


# ---------------------------------------------------------------- coverage tracker

def world_grid_as_robot_map(world, map_origin, shape, map_to_world, known=None):
    """The perfect robot map: each map cell's centre transformed to the world and looked up in
    the true free grid (0 free, 100 solid); cells where ``known`` (world x, y -> bool) is False
    stay unknown (-1)."""
    wx, wy = map_cells_in_world(shape, RES, map_origin, map_to_world)
    rows = np.floor((wy - world.origin[1]) / RES).astype(int)
    cols = np.floor((wx - world.origin[0]) / RES).astype(int)
    inside = (rows >= 0) & (rows < world.free.shape[0]) & (cols >= 0) & (cols < world.free.shape[1])
    occ = np.full(shape, 100, np.int8)
    occ[inside] = np.where(world.free[rows[inside], cols[inside]], 0, 100)
    if known is not None:
        occ[~known(wx, wy)] = -1
    return occ


def test_perfect_map_covers_f_and_half_a_map_covers_half(room_world):
    world = load_world(room_world)          # start (1.0, 1.5, 0): map frame = world - (1, 1.5)
    f = reachable_free_space(world, BURGER, 3.5)
    tracker = CoverageTracker(world, f)
    assert tracker.cells == 4800 and tracker.area_m2 == pytest.approx(12.0)
    occ = world.occupancy()      # world grid, shifted origin
    origin = (world.origin[0] - 1.0, world.origin[1] - 1.5)
    assert tracker.update(0.0, occ, RES, origin) == 1.0
    # Free cells x < 2.1 (cols 2..41 of 84): 40 of the room's 80 columns: 2400 / 4800 = 0.5.
    half = occ.copy()
    half[:, 42:] = -1
    assert tracker.update(1.0, half, RES, origin) == 0.5
    # The same half as a cropped map: cells outside the robot's map are not covered.
    assert tracker.update(2.0, occ[:, :42], RES, origin) == 0.5
    # ... and the other half, the map's origin moved 42 cells east: F cells west of it (negative
    # map indices) are not covered either, not wrapped round.
    assert tracker.update(2.5, occ[:, 42:], RES, (origin[0] + 42 * RES, origin[1])) == 0.5
    # Likewise in y: the map's rows from 32 (y >= 1.6) hold free rows 32..61, 30 of 60.
    assert tracker.update(2.75, occ[32:, :], RES, (origin[0], origin[1] + 32 * RES)) == 0.5
    # "Free" is 0..25: 25 counts; 26 only on the walls' faces (known counts there: the ring
    # of 80 x 60 - 78 x 58 = 276 cells beside the walls, 0.0575); unknown nowhere.
    assert tracker.update(3.0, np.full_like(occ, 25), RES, origin) == 1.0
    assert tracker.update(4.0, np.full_like(occ, 26), RES, origin) == 276 / 4800
    assert tracker.update(5.0, np.full_like(occ, -1), RES, origin) == 0.0
    t, frac = tracker.series
    assert t.tolist() == [0.0, 1.0, 2.0, 2.5, 2.75, 3.0, 4.0, 5.0]
    assert frac.tolist() == [1.0, 0.5, 0.5, 0.5, 0.5, 1.0, 276 / 4800, 0.0]
    assert tracker.final == 0.0


def test_rotated_start_pose(tmp_path):
    # Start (1.0, 1.5, pi/2): the map's +x is the world's +y. A world point maps to
    # mx = wy - 1.5, my = -(wx - 1.0). Map 100 rows x 80 cols from origin (-2, -4) m holds the
    # room (wx 0..4.2 -> my -3.2..1; wy 0..3.2 -> mx -1.5..1.7), its cell centres landing on
    # world cell centres (mx + 1.5 = -0.5 + (j + 0.5) 0.05, 1 - my = 5 - (i + 0.5) 0.05).
    start = (1.0, 1.5, math.pi / 2)
    world = load_world(write_world(tmp_path, "room", room(4.0, 3.0), start=list(start)))
    f = reachable_free_space(world, BURGER, 3.5)
    tracker = CoverageTracker(world, f, map_to_world=start)
    origin, shape = (-2.0, -4.0), (100, 80)
    occ = world_grid_as_robot_map(world, origin, shape, start)
    assert tracker.update(0.0, occ, RES, origin) == 1.0
    # Known only where wx < 2.1: 40 of 80 free columns, 0.5.
    half = world_grid_as_robot_map(world, origin, shape, start, known=lambda x, y: x < 2.1)
    assert tracker.update(1.0, half, RES, origin) == 0.5
    # Ignoring the yaw puts the map on the wrong cells: far from full coverage.
    wrong = CoverageTracker(world, f, map_to_world=(1.0, 1.5, 0.0))
    assert wrong.update(0.0, occ, RES, origin) < 0.8
    # The default transform is the world's start pose.
    assert CoverageTracker(world, f).update(0.0, occ, RES, origin) == 1.0


def test_a_perfect_map_on_a_grid_shifted_half_a_cell_covers_f(tmp_path, monkeypatch):
    # Start (1.025, 1.525, 0) lies on a world cell centre, so the robot's cell boundaries run
    # through the world's cell centres. The perfect robot map marks a cell free only if all
    # four world cells it overlaps are free. A wall-face F cell's centre is a corner of four
    # robot cells, two of which straddle the wall; its corner samples find the free ones.
    start = (1.025, 1.525, 0.0)
    world = load_world(write_world(tmp_path, "room", room(4.0, 3.0), start=list(start)))
    f = reachable_free_space(world, BURGER, 3.5)
    origin = (world.origin[0] - start[0] - RES / 2, world.origin[1] - start[1] - RES / 2)
    rows, cols = world.free.shape
    all_free = np.zeros((rows + 1, cols + 1), bool)        # robot cell (i, j) overlaps world
    padded = np.zeros((rows + 2, cols + 2), bool)          # cells i-1..i, j-1..j
    padded[1:-1, 1:-1] = world.free
    all_free[:] = padded[:-1, :-1] & padded[1:, :-1] & padded[:-1, 1:] & padded[1:, 1:]
    occ = np.where(all_free, 0, 100).astype(np.int8)
    assert CoverageTracker(world, f).update(0.0, occ, RES, origin) == 1.0
    # Read as free only, the faces need the corner samples: a wall-face cell's centre picks a
    # robot cell that straddles the wall (occupied) on the room's east and north faces.
    free_only = CoverageTracker(world, f)
    free_only.face[:] = False
    assert free_only.update(0.0, occ, RES, origin) == 1.0
    monkeypatch.setattr(coverage_module, "SAMPLE_OFFSETS", ((0.0, 0.0),))
    centres = CoverageTracker(world, f)
    assert centres.update(0.0, occ, RES, origin) == 1.0        # the wall-face rule: known
    centres.face[:] = False
    assert centres.update(0.0, occ, RES, origin) < 0.97


def test_time_to_thresholds(room_world):
    # Maps knowing the first k of the room's 80 free columns cover k / 80:
    # k = 20 -> 0.25, 72 -> 0.9, 76 -> 0.95, 79 -> 0.9875 (< 0.99), 80 -> 1.0.
    world = load_world(room_world)
    f = reachable_free_space(world, BURGER, 3.5)
    tracker = CoverageTracker(world, f)
    assert tracker.final is None and tracker.time_to(0.9) is None
    origin = (world.origin[0] - 1.0, world.origin[1] - 1.5)
    occ = world.occupancy()

    def known(k):
        m = occ.copy()
        m[:, 2 + k:] = -1
        return m

    for t, k in ((0.0, 20), (10.0, 72), (20.0, 76), (25.0, 72), (30.0, 79)):
        tracker.update(t, known(k), RES, origin)
    assert tracker.time_to(0.25) == 0.0
    assert tracker.time_to(0.9) == 10.0
    assert tracker.time_to(0.95) == 20.0          # the first time, not the later dip
    assert tracker.time_to(0.99) is None          # 0.9875 only
    assert tracker.summary() == {"coverage_final": 0.9875, "time_to_90_s": 10.0,
                                 "time_to_95_s": 20.0, "time_to_99_s": None}
    tracker.update(40.0, known(80), RES, origin)
    assert tracker.time_to(0.99) == 40.0 and tracker.final == 1.0


def test_map_values_at_samples_the_cell_under_each_point():
    # A 2 x 3 map at 0.05 m from (-0.1, 0.2): point (x, y) lies in row floor((y - 0.2) / 0.05),
    # col floor((x + 0.1) / 0.05). (-0.075, 0.225) -> (0, 0); (0.04, 0.29) -> (1, 2);
    # (-0.04, 0.26) -> (1, 1); off the map: x = -0.11 (col -1), y = 0.31 (row 2) -> ``outside``.
    occ = np.array([[0, 25, 26], [-1, 65, 100]], np.int8)
    mx = np.array([[-0.075, 0.04], [-0.04, -0.11]])
    my = np.array([[0.225, 0.29], [0.26, 0.225]])
    v = map_values_at(mx, my, occ, RES, (-0.1, 0.2))
    assert v.shape == (2, 2) and v.tolist() == [[0, 100], [65, -1]]
    assert map_values_at(np.array([0.0]), np.array([0.31]), occ, RES, (-0.1, 0.2), outside=-7).tolist() == [-7]
    # free_at: 0..25 free; unknown, 26.. and off the map not.
    xs, ys = (np.arange(3) + 0.5) * RES - 0.1, np.full(3, 0.225)
    assert free_at(xs, ys, occ, RES, (-0.1, 0.2)).tolist() == [True, True, False]
    assert free_at(xs, ys + RES, occ, RES, (-0.1, 0.2)).tolist() == [False, False, False]


def test_seen_counts_known_and_occupied_f_cells(room_world):
    # The room's F: 80 x 60 = 4800 cells, free columns 2..81 of the world grid. A perfect map
    # (the world grid, origin shifted by the start (1, 1.5)) knows all of F, none occupied.
    world = load_world(room_world)
    tracker = CoverageTracker(world, reachable_free_space(world, BURGER, 3.5))
    occ = world.occupancy()
    origin = (world.origin[0] - 1.0, world.origin[1] - 1.5)
    assert tracker.seen(occ, RES, origin) == (1.0, 0.0)
    # Column 42 marked occupied (60 cells: seen, not free), column 43 unknown (60 cells):
    # known (4800 - 60) / 4800 = 0.9875, occupied 60 / 4800 = 0.0125.
    occ[:, 42], occ[:, 43] = 100, -1
    known, occupied = tracker.seen(occ, RES, origin)
    assert known == pytest.approx(0.9875) and occupied == pytest.approx(0.0125)
    # A map that holds none of F: nothing seen.
    assert tracker.seen(occ, RES, (100.0, 100.0)) == (0.0, 0.0)


def test_tracker_rejects_an_empty_or_misshapen_f(room_world):
    world = load_world(room_world)
    with pytest.raises(ValueError, match="empty"):
        CoverageTracker(world, np.zeros_like(world.free))
    with pytest.raises(ValueError, match="shape"):
        CoverageTracker(world, np.ones((3, 3), bool))


def test_a_map_laid_off_the_start_frame_is_covered_once_aligned(room_world):
    """The perfect map drawn in a frame turned 0.1 rad and shifted (0.3, -0.2) m from the start
    frame (a SLAM map's gauge): read in the start frame it covers far from all of F; with the
    rigid motion that takes its frame onto the start frame (``alignment``), all of it."""
    world = load_world(room_world)                      # start (1.0, 1.5, 0)
    f = reachable_free_space(world, BURGER, 3.5)
    tracker = CoverageTracker(world, f)
    offset = (0.3, -0.2, 0.1)                            # the map frame, in the start frame
    map_to_world = (1.0 + 0.3, 1.5 - 0.2, 0.1)           # start (+) offset (start yaw 0)
    origin, shape = (-3.0, -3.0), (140, 160)
    occ = world_grid_as_robot_map(world, origin, shape, map_to_world)
    assert tracker.covered(occ, RES, origin).mean() < 0.95    # the faces read known either way
    assert tracker.covered(occ, RES, origin, alignment=offset).mean() > 0.99


# ---------------------------------------------------------------- the robot's footprint (DESIGN §6)

def footprint_world(tmp_path):
    """Room A (x, y 0.1..3.1, the start at (1.0, 1.5)); east of it, through a 0.2 m wall, a
    0.4 m door (y 1.3..1.7) into room B (x 3.3..8.3, y 0.1..3.1), whose east end lies 3.7-5 m
    beyond the door; north of A, through its wall, a 0.4 m corridor (x 0.6..1.0) to y 4.3,
    turning east at y 3.9..4.3 to room C (x 4.5..6.0, y 3.5..5.3)."""
    free = np.zeros((110, 170), bool)
    carve(free, 0.1, 0.1, 3.1, 3.1)
    carve(free, 3.0, 1.3, 3.4, 1.7)
    carve(free, 3.3, 0.1, 8.3, 3.1)
    carve(free, 0.6, 3.0, 1.0, 4.3)
    carve(free, 0.6, 3.9, 4.5, 4.3)
    carve(free, 4.5, 3.5, 6.0, 5.3)
    return load_world(write_world(tmp_path, "footprint", free, start=[1.0, 1.5, 0.0]))


def test_a_box_robots_f_follows_its_box_and_its_turning_disc(tmp_path):
    world = footprint_world(tmp_path)
    xs = world.origin[0] + (np.arange(world.free.shape[1]) + 0.5) * RES
    ys = world.origin[1] + (np.arange(world.free.shape[0]) + 0.5) * RES
    room_b_east = world.free & (xs > 6.8)[None, :] & (ys < 3.1)[:, None]    # 3.4+ m past the door
    room_c = world.free & (xs > 4.5)[None, :] & (ys > 3.5)[:, None]
    assert room_b_east.sum() == 30 * 60 and room_c.sum() == 30 * 36
    waffle = load_robot("turtlebot3_waffle_pi")
    # The waffle_pi's box (0.306 m wide, 0.02 m margin each side) drives straight through the
    # 0.4 m door and turns in room B: it sees B's east end, 3.4-5 m from the door.
    f = reachable_free_space(world, waffle, 3.5)
    assert np.array_equal(f & room_b_east, room_b_east)
    # A disc as large as its turning disc (0.257 m) does not pass the door: the disc model
    # lost B's east end.
    disc = replace(waffle, footprint_length_m=0.0, footprint_width_m=0.0, footprint_offset_x_m=0.0)
    assert not (reachable_free_space(world, disc, 3.5) & room_b_east).any()
    # At the corridor's bend the box cannot turn (its turning disc needs 0.53 m): it never
    # reaches the east leg, and room C, 3.5 m on from the bend, is out of its sight. The
    # burger's disc turns there and sees all of C.
    assert not (reachable_cells(world, waffle) & (ys > 3.9)[:, None] & (xs > 1.2)[None, :]).any()
    assert not (f & room_c).any()
    assert np.array_equal(reachable_free_space(world, BURGER, 3.5) & room_c, room_c)


def test_coarse_to_fine_viewpoints_give_the_f_of_all_viewpoints(tmp_path):
    # visible_free_space casts from a subset of the viewpoints (those that can still add a
    # cell); on a room strewn with random blocks F must equal the union over all of them.
    rng = np.random.default_rng(3)
    free = room(8.0, 6.0)
    for _ in range(60):
        r, c = rng.integers(4, free.shape[0] - 8), rng.integers(4, free.shape[1] - 8)
        free[r:r + rng.integers(1, 8), c:c + rng.integers(1, 8)] = False
    world = load_world(write_world(tmp_path, "blocks", free, start=[0.5, 0.5, 0.0]))
    for sensor_m in (1.0, 3.5):
        reach = reachable_cells(world, BURGER)
        points = lattice_points(reach, 5)
        every = visible_cells(world.solid.astype(np.uint8), points, sensor_m / RES) & world.free
        got = coverage_module.visible_free_space(world, reach, sensor_m)
        assert got.sum() > 0.5 * world.free.sum()
        assert np.array_equal(got, every)


# ---------------------------------------------------------------- the wall-face rule (DESIGN §6)

def test_wall_face_cells_count_when_known_the_others_when_free(room_world):
    # The 4 x 3 m room's F: 80 x 60 = 4800 cells; its wall faces, the cells within one cell of
    # a wall, are the outer ring: 4800 - 78 x 58 = 276; the next ring 78 x 58 - 76 x 56 = 268.
    world = load_world(room_world)
    tracker = CoverageTracker(world, reachable_free_space(world, BURGER, 3.5))
    assert tracker.face.sum() == 276
    assert coverage_module.wall_face(world).sum() == 276
    occ = world.occupancy()
    origin = (world.origin[0] - 1.0, world.origin[1] - 1.5)
    ring = np.zeros(occ.shape, bool)
    ring[2:62, 2:82] = True
    ring[3:61, 3:81] = False
    second = np.zeros(occ.shape, bool)
    second[3:61, 3:81] = True
    second[4:60, 4:80] = False
    # Walls drawn a cell thick towards the room (the faces read occupied): still all covered.
    thick = occ.copy()
    thick[ring] = 100
    assert tracker.update(0.0, thick, RES, origin) == 1.0
    # Faces never observed (unknown): not covered.
    blind = occ.copy()
    blind[ring] = -1
    assert tracker.update(1.0, blind, RES, origin) == (4800 - 276) / 4800
    # Walls drawn two cells thick: the second ring is not on a face, and reads occupied.
    thicker = thick.copy()
    thicker[second] = 100
    assert tracker.update(2.0, thicker, RES, origin) == (4800 - 268) / 4800
    # Away from the walls a cell the map marks occupied is not covered: a column of 58.
    wrong = occ.copy()
    wrong[3:61, 40] = 100
    assert tracker.update(3.0, wrong, RES, origin) == (4800 - 58) / 4800
