"""Frontiers: detection, clustering, goal points, viewpoints, reachability, extension and
information gain.

Maps are drawn by hand (int8 ROS occupancy, row 0 = smallest y) and the expected cells and
numbers are worked out in the comments. ``visible_unknown`` (C++) is checked against a
plain-Python ray caster written here with the same beam end points and Bresenham lines, on
random maps with fixed seeds, and against hand counts.
"""
import math
from functools import partial

import numpy as np
import pytest

from turtlebot_recon import _native
from turtlebot_recon.config import ConfigError, from_dict
# max_cost=252 below: a goal may stand on any cell below the inscribed band (the hand-derived
# goal cells of those tests); the default 128 keeps goals 0.135 m further off walls.
from turtlebot_recon.exploration import (Frontier, FrontierSettings, cluster, detect,
                                         find_frontier_cells)
from turtlebot_recon.exploration.goals import GoalBook
from turtlebot_recon.exploration.viewpoints import Looks
from turtlebot_recon.mapping.map_io import FREE_THRESH
from turtlebot_recon.geometry import cell_to_xy
from turtlebot_recon.planning import CostmapSettings, PlannerSettings, dijkstra, make_costmap, nearest_accessible
from turtlebot_recon.robot import load_robot

from conftest import ray_cells

# the binding takes every argument: the frontier gain's own (FrontierSettings) unless a test gives its own
visible_unknown = partial(_native.visible_unknown, beams=FrontierSettings().gain_beams,
                          free_threshold=FREE_THRESH)

RES = 0.05
UNKNOWN, FREE, WALL = -1, 0, 100


# ---------------------------------------------------------------- references and factories

def reference_visible_unknown(occ, cell, radius, beams, free_threshold=25):
    """Distinct unknown cells on `beams` rays from `cell`, each stopped beyond `radius`
    (cells, centre to centre), at the grid's edge or on an occupied cell other than `cell`."""
    seen = set()
    for ray in ray_cells(tuple(cell), radius, beams, occ.shape):
        for r, c, is_origin in ray:
            v = occ[r, c]
            if v < 0:
                seen.add((r, c))
            elif v > free_threshold and not is_origin:
                break
    return len(seen)


def walled_room(occ, rows, cols, gap_cols=None):
    """Free interior rows[0]..rows[1], cols[0]..cols[1] inside 1-cell walls (in place); the top
    wall's cells in gap_cols stay unknown: the frontier."""
    (r0, r1), (c0, c1) = rows, cols
    occ[r0 - 1:r1 + 2, c0 - 1:c1 + 2] = WALL
    occ[r0:r1 + 1, c0:c1 + 1] = FREE
    if gap_cols is not None:
        occ[r1 + 1, gap_cols[0]:gap_cols[1] + 1] = UNKNOWN
    return occ


def gap_room():
    """30 x 40 cells, unknown outside a room with free interior rows 3..19, cols 3..29; its
    top wall (row 20) has a 10-cell gap, cols 10..19, left unknown: the only frontier."""
    return walled_room(np.full((30, 40), UNKNOWN, np.int8), (3, 19), (3, 29), gap_cols=(10, 19))


def two_rooms(door_rows):
    """30 x 60 cells: room A (cols 3..27) and room B (cols 31..56), rows 3..19, split by a
    wall 3 cells thick (cols 28..30) with a door over `door_rows` (inclusive); each room's
    top wall has a 10-cell (0.5 m) unknown gap: A cols 10..19, B cols 40..49."""
    occ = np.full((30, 60), UNKNOWN, np.int8)
    walled_room(occ, (3, 19), (3, 27), gap_cols=(10, 19))
    walled_room(occ, (3, 19), (31, 56), gap_cols=(40, 49))
    occ[3:20, 28:31] = WALL
    occ[door_rows[0]:door_rows[1] + 1, 28:31] = FREE
    return occ


@pytest.fixture(scope="module")
def burger_costmap_settings():
    # Inscribed radius 0.105 m + one cell diagonal = 3.5 cells: a cell 1 to 3 cells from a wall
    # is inscribed (253).
    return CostmapSettings.for_robot(load_robot("turtlebot3_burger"))


def cells_of(clusters):
    return [sorted(map(tuple, c.tolist())) for c in clusters]


# ---------------------------------------------------------------- detection

def test_frontier_cells_are_the_unknown_cells_next_to_free_ones():
    # Row 4 at the top (printed first):      Unknown cells with a free 8-neighbour:
    #   row 4   ?  ?  ?  ?  ?                 row 3: cols 0..2 (above free row 2), col 3
    #   row 3   ?  ?  ?  ?  ?                        (diagonal to free (2, 2)); not col 4
    #   row 2   .  .  .  ?  ?                 col 3: rows 1 and 2 (next to free col 2)
    #   row 1   .  .  .  ?  ?                 not (0, 4) (neighbours: wall, unknown), not
    #   row 0   .  .  .  #  ?                 row 4 (neighbours: unknown only)
    occ = np.full((5, 5), UNKNOWN, np.int8)
    occ[0:3, 0:3] = FREE
    occ[0, 3] = WALL
    mask = find_frontier_cells(occ, free_threshold=25)
    assert mask.dtype == bool
    assert sorted(map(tuple, np.argwhere(mask).tolist())) == [
        (1, 3), (2, 3), (3, 0), (3, 1), (3, 2), (3, 3)]


def test_free_threshold_is_inclusive():
    # One known cell in the middle of an unknown 3 x 3 grid: it is free at 25 (its 8
    # neighbours are frontier cells), not free at 26 (no frontier at all).
    occ = np.full((3, 3), UNKNOWN, np.int8)
    occ[1, 1] = 25
    assert find_frontier_cells(occ, 25).sum() == 8
    occ[1, 1] = 26
    assert find_frontier_cells(occ, 25).sum() == 0
    assert find_frontier_cells(occ, 26).sum() == 8


def test_walls_and_fully_known_maps_have_no_frontier():
    occ = np.zeros((6, 6), np.int8)
    assert not find_frontier_cells(occ, 25).any()
    occ[:, 3:] = UNKNOWN
    occ[:, 3] = WALL      # unknown cells behind a wall touch only the wall
    assert not find_frontier_cells(occ, 25).any()


def test_a_slit_narrower_than_the_opening_in_a_wall_line_shows_no_frontier(burger_costmap_settings):
    # A room (free rows 3..19) under a wall 2 cells thick (rows 20, 21), unknown beyond. The
    # wall has a slit 1 cell wide (col 10: a face cell that grazing rays cleared), one 2
    # cells wide (cols 20, 21) and one 3 cells wide (cols 30..32), and a stray free cell
    # lies in the unknown at (25, 40) beside the wall's far side.
    occ = np.full((30, 50), UNKNOWN, np.int8)
    occ[2:22, 2:48] = WALL
    occ[3:20, 3:47] = FREE
    occ[20:22, 10] = FREE
    occ[20:22, 20:22] = FREE
    occ[20:22, 30:33] = FREE
    occ[22, 40] = WALL
    occ[23, 40] = FREE
    cols = lambda mask: sorted({c for r, c in np.argwhere(mask).tolist()})
    # seed 004's rule: a frontier behind each slit and around the stray cell
    assert cols(find_frontier_cells(occ, 25)) == [9, 10, 11, 19, 20, 21, 22, 29, 30, 31, 32, 33,
                                                   39, 40, 41]
    # only free cells in an all-free 3 x 3 square count: the 3-cell slit keeps its frontier
    assert cols(find_frontier_cells(occ, 25, opening_cells=3)) == [29, 30, 31, 32, 33]
    assert FrontierSettings().min_opening_cells == 3
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    (f,) = detect(occ, RES, (0.0, 0.0), costmap, (10, 25), FrontierSettings())
    assert cols(np.isin(np.arange(occ.size).reshape(occ.shape),
                        np.ravel_multi_index(f.cells.T, occ.shape))) == [29, 30, 31, 32, 33]
    assert len(detect(occ, RES, (0.0, 0.0), costmap, (10, 25),
                      FrontierSettings(min_opening_cells=1))) == 4


# ---------------------------------------------------------------- clustering

def test_cluster_drops_clusters_smaller_than_min_size():
    # Four separate groups of 1, 2, 3 and 5 cells (2 cells apart, so not 8-connected).
    mask = np.zeros((3, 20), bool)
    mask[0, 0] = True                # 1
    mask[0, 3:5] = True              # 2
    mask[0, 7:10] = True             # 3
    mask[0, 12:17] = True            # 5
    assert [len(c) for c in cluster(mask, 1)] == [1, 2, 3, 5]
    kept = cluster(mask, 3)
    assert [len(c) for c in kept] == [3, 5]
    assert cells_of(kept) == [[(0, 7), (0, 8), (0, 9)], [(0, c) for c in range(12, 17)]]
    assert cluster(mask, 6) == []
    assert all(c.dtype == np.int32 and c.shape[1] == 2 for c in kept)


def test_cluster_joins_diagonal_cells():
    # (0,0), (1,1), (2,2): three clusters under 4-connectivity, one under 8-connectivity.
    mask = np.eye(3, dtype=bool)
    clusters = cluster(mask, 1)
    assert len(clusters) == 1
    assert cells_of(clusters) == [[(0, 0), (1, 1), (2, 2)]]


def test_two_rooms_give_two_clusters():
    # Each room's gap is its own frontier: A = row 20, cols 10..19; B = row 20, cols 40..49
    # (10 cells each; the unknown row 21 above touches no free cell).
    occ = two_rooms(door_rows=(8, 13))
    clusters = cluster(find_frontier_cells(occ, 25), 3)
    assert cells_of(clusters) == [[(20, c) for c in range(10, 20)],
                                  [(20, c) for c in range(40, 50)]]


# ---------------------------------------------------------------- detect: goals

def test_detect_gap_room_fields(burger_costmap_settings):
    occ = gap_room()
    origin = (-1.0, 2.0, 0.0)
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    robot = (10, 14)
    frontiers = detect(occ, RES, origin, costmap, robot, FrontierSettings(max_cost=252))
    assert len(frontiers) == 1
    f = frontiers[0]
    assert isinstance(f, Frontier)
    assert f.id == 0
    assert sorted(map(tuple, f.cells.tolist())) == [(20, c) for c in range(10, 20)]
    assert f.size == 10
    assert f.length_m == pytest.approx(0.5)            # 10 cells x 0.05 m
    # Centroid: row 20, mean col 14.5 -> x = -1 + 15 x 0.05 = -0.25, y = 2 + 20.5 x 0.05.
    assert f.centroid == pytest.approx((-0.25, 3.025))
    # Frontier cell nearest to the robot (10, 14): (20, 14) -> x = -1 + 14.5 x 0.05.
    assert f.closest == pytest.approx((-0.275, 3.025))
    # Representative: (20, 14) and (20, 15) are both 0.5 from the centroid; raster order
    # picks (20, 14). Its nearest known cell below 253 is (19, 14), one cell down (nearest
    # wall cell (20, 9), sqrt(26) = 5.1 cells = 0.255 m > 0.105 m inscribed radius).
    assert f.goal_cell == (19, 14)
    assert f.goal == pytest.approx((-0.275, 2.975))
    assert costmap[f.goal_cell] <= 252
    # The same cell as seed 001's nearest accessible point when that one is reachable.
    assert nearest_accessible(costmap, (20, 14), max_cost=252, max_radius_m=1.0,
                              resolution=RES) == f.goal_cell
    assert f.reachable
    with pytest.raises(ValueError):     # frozen, and the cells with it
        f.cells[0, 0] = 0


def test_path_cost_is_the_dijkstra_field_and_gain_the_ray_count(burger_costmap_settings):
    occ = two_rooms(door_rows=(6, 17))     # a 12-cell (0.6 m) door: both rooms reachable
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    robot = (10, 14)
    field = dijkstra(costmap, robot, resolution=RES)
    frontiers = detect(occ, RES, (0.0, 0.0), costmap, robot, FrontierSettings())
    assert [f.reachable for f in frontiers] == [True, True]
    for f in frontiers:
        assert f.path_cost_m == float(field[f.goal_cell])
        # 3.5 m / 0.05 m = 70 cells, 180 beams (the settings' defaults).
        expected = visible_unknown(occ, np.array([f.goal_cell], np.int32), 70.0,
                                           beams=180, free_threshold=25)[0]
        assert f.gain == expected > 0
    # Room B's goal is through the door: farther by path than by straight line.
    a, b = frontiers
    assert b.path_cost_m > a.path_cost_m
    assert b.path_cost_m > math.dist(b.goal, (14.5 * RES, 10.5 * RES))
    # A caller's own field (here: a uniform 2x) is used as given, not recomputed.
    again = detect(occ, RES, (0.0, 0.0), costmap, robot, FrontierSettings(), cost_to_come=2 * field)
    assert [g.path_cost_m for g in again] == [2 * f.path_cost_m for f in frontiers]


def test_frontier_behind_a_gap_narrower_than_the_robot_is_seen_through_it_last(
        burger_costmap_settings):
    # Door of 2 cells (0.1 m) for a robot 0.21 m wide: every door cell is 1 cell from a door
    # post, inside the 3.5-cell inscribed radius, so room B is cut off.
    occ = two_rooms(door_rows=(10, 11))
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    assert (costmap[10:12, 28:31] >= 253).all()
    a, b = detect(occ, RES, (0.0, 0.0), costmap, (10, 14), FrontierSettings(max_cost=252))
    # Measured along cells the robot could stand on, room A is only reached through the
    # door: B's snap finds nothing, and while A's frontier can be driven to, B has no goal
    # (reported, unreachable, at the nearest cell it could stand on beside its
    # representative (20, 44): (19, 44), 5.1 cells = 0.255 m from the wall cell (20, 39)).
    assert a.reachable and math.isfinite(a.path_cost_m)
    assert not b.reachable and b.path_cost_m == math.inf and b.goal_cell == (19, 44)
    # Room A mapped (its gap turns out to be wall): B is looked at through the door. The ray
    # (20, 40) -> (8, 24) (3 rows per 4 cols) crosses the wall's cols 28..30 on rows 11 and
    # 10, the door; B's goal is that viewpoint (the nearer cells of room A see no gap cell
    # through it), reached the long way round the door post's band: 0.78 m.
    occ[20, 10:20] = WALL
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    (b,) = detect(occ, RES, (0.0, 0.0), costmap, (10, 14), FrontierSettings(max_cost=252))
    field = dijkstra(costmap, (10, 14), resolution=RES)
    assert b.goal_cell == (8, 24) and b.reachable
    assert b.path_cost_m == float(field[8, 24]) == pytest.approx(0.785, abs=1e-3)
    assert costmap[b.goal_cell] <= 252
    # Close the door: no cell the robot reaches sees B's gap, and B is given up.
    occ[10:12, 28:31] = WALL
    (b,) = detect(occ, RES, (0.0, 0.0), make_costmap(occ, RES, burger_costmap_settings),
                  (10, 14), FrontierSettings(max_cost=252))
    assert not b.reachable and b.path_cost_m == math.inf and b.goal_cell == (19, 44)
    # Widen the door to 12 cells (0.6 m): B's snap reaches it, on its own side.
    wide = two_rooms(door_rows=(6, 17))
    _, b_wide = detect(wide, RES, (0.0, 0.0), make_costmap(wide, RES, burger_costmap_settings),
                       (10, 14), FrontierSettings(max_cost=252))
    assert b_wide.reachable and b_wide.goal_cell == (19, 44)


def test_a_frontier_in_a_tight_spot_gets_a_goal_across_the_wall_band(burger_costmap_settings):
    # Room A's top-wall gap (unknown, cols 10..19): the free cells just below it lie in the
    # wall band, above max_cost 128 (0.135 m beyond the inscribed band) but below inscribed.
    # The goal must stand on a cell <= max_cost, further into the room; the walk from the
    # frontier to it crosses the band (a walk confined to cells <= max_cost found no goal).
    occ = two_rooms(door_rows=(10, 11))
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    settings = FrontierSettings(max_cost=128)
    a, _ = detect(occ, RES, (0.0, 0.0), costmap, (10, 14), settings)
    assert a.reachable and costmap[a.goal_cell] <= 128
    # the band the walk crosses: cells between the gap and the goal above max_cost
    r, c = a.goal_cell
    assert (costmap[r + 1:20, c] > 128).any() and (costmap[r + 1:20, c] < 253).all()


def test_a_corridor_without_cheap_cells_still_gets_a_goal(burger_costmap_settings):
    # Walls on rows 10 and 18, free rows 11..17 (7 cells) to col 39, unknown beyond: the
    # middle row is 4 cells = 0.2 m from the wall cells' centres, 0.0243 m past the 0.1757 m
    # inscribed band (0.105 m + one cell diagonal): cost floor(252 exp(-5 * 0.0243)) = 223. No
    # cell is <= max_cost 128, so the goal takes the cheapest band a robot can pass (< 253).
    occ = np.full((29, 60), UNKNOWN, np.int8)
    occ[10, :40] = occ[18, :40] = WALL
    occ[11:18, :40] = FREE
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    assert costmap[14, 20] == 223 and (costmap[11:18, 20] >= 223).all()
    [f] = [f for f in detect(occ, RES, (0.0, 0.0), costmap, (14, 5), FrontierSettings(max_cost=128))
           if f.size >= 5]
    assert f.reachable and f.goal_cell[0] == 14 and 128 < costmap[f.goal_cell] < 253


def test_a_corridor_goal_takes_its_centre_line_not_the_band_edge(burger_costmap_settings):
    # Walls on rows 10 and 22 (free rows 11..21, 0.55 m): the centre row 16 is 0.3 m from the
    # wall cells (cost 135), rows 15/17 cost 173, nothing <= max_cost 128. The corridor's end
    # is ragged (rows 11..15 free to col 42, the rest to col 40), so the frontier's own middle
    # lies off the centre line, near the top wall. The goal goes to the cheapest reachable
    # cost near it, the centre row, where one wall cell more does not make it impassable.
    occ = np.full((33, 60), UNKNOWN, np.int8)
    occ[10, :43] = occ[22, :41] = WALL
    occ[11:22, :41] = FREE
    occ[11:16, 41:43] = FREE
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    assert costmap[16, 20] == 135 and (costmap[11:22, 20] >= 135).all()
    [f] = [f for f in detect(occ, RES, (0.0, 0.0), costmap, (16, 5), FrontierSettings(max_cost=128))
           if f.size >= 5]
    assert f.reachable and f.goal_cell[0] == 16 and costmap[f.goal_cell] == 135
    assert abs(f.goal_cell[1] - 40) <= 2          # at the frontier, not back down the corridor


def test_snap_searches_past_an_unconnected_nearest_cell(burger_costmap_settings):
    # In the gap room the nearest accessible cell to the representative (20, 14) is (19, 14).
    # Cut it off in the caller's field: the goal moves to the nearest accessible AND reachable
    # cell. At distance 1 the other cells are unknown ((20, 13), (20, 15), (21, 14)); at
    # sqrt(2) the known ones are (19, 13) and (19, 15), and the tie goes to the smaller column.
    occ = gap_room()
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    field = dijkstra(costmap, (10, 14), resolution=RES)
    field[19, 14] = np.inf
    (f,) = detect(occ, RES, (0.0, 0.0), costmap, (10, 14), FrontierSettings(max_cost=252), cost_to_come=field)
    assert f.goal_cell == (19, 13)
    assert f.reachable and f.path_cost_m == float(field[19, 13])


def test_no_accessible_cell_within_the_snap_radius(burger_costmap_settings):
    # A snap radius of 0.01 m (0.2 cells) holds only the representative (20, 14), an unknown
    # cell: the snap finds no goal cell, and the goal is the nearest cell that sees the gap
    # (row 20, cols 10..19). Row 19 below the gap is 1 cell from it; of its cells, (19, 12)
    # and (19, 17) lie 3.2 cells (0.158 m) from the wall ends (20, 9), (20, 20): inscribed;
    # cols 13..16 pass. Of those, 14 and 15 are nearest the gap's centroid (20, 14.5) and the
    # raster order takes (19, 14).
    occ = gap_room()
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    settings = FrontierSettings(snap_radius_m=0.01, max_cost=252)   # 0.2 cells: only the target
    (f,) = detect(occ, RES, (0.0, 0.0), costmap, (10, 14), settings)
    assert f.goal_cell == (19, 14) and f.reachable
    # Nothing reachable (a robot whose field is empty): reported at the representative.
    cut_off = np.full(occ.shape, np.inf, np.float32)
    (f,) = detect(occ, RES, (0.0, 0.0), costmap, (10, 14), settings, cost_to_come=cut_off)
    assert f.goal_cell == (20, 14)
    assert not f.reachable and f.path_cost_m == math.inf


def test_robot_on_an_inscribed_cell_still_gets_a_field(burger_costmap_settings):
    # (3, 14) is 1 cell above the bottom wall (row 2): inscribed (253), where dijkstra would
    # refuse to start. The field then starts at the nearest passable cell, (6, 14)
    # (4 cells = 0.2 m from the wall; (5, 14) at 0.15 m is still inscribed).
    occ = gap_room()
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    assert (costmap[3:6, 14] == 253).all() and costmap[6, 14] < 253
    (f,) = detect(occ, RES, (0.0, 0.0), costmap, (3, 14), FrontierSettings())
    assert f.reachable
    assert f.path_cost_m == float(dijkstra(costmap, (6, 14), resolution=RES)[f.goal_cell])


def test_extension_into_unknown(burger_costmap_settings):
    # Robot (10, 14) below the representative (20, 14): robot -> point is +row. With a field
    # that crosses unknown space (unknown_cost=0, seed 004's allow_unknown) the goal is the
    # representative itself without extension ...
    occ = gap_room()
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    robot = (10, 14)
    field = dijkstra(costmap, robot, RES, PlannerSettings(unknown_cost=0))

    def goal(occupancy, extend_m, cost_to_come):
        costmap_here = make_costmap(occupancy, RES, burger_costmap_settings)
        (f,) = detect(occupancy, RES, (0.0, 0.0), costmap_here, robot,
                      FrontierSettings(max_cost=252, extend_into_unknown_m=extend_m), cost_to_come=cost_to_come)
        return f.goal_cell, f.reachable

    assert goal(occ, 0.0, field) == ((20, 14), True)
    # ... and 0.25 m = 5 cells further with it: (25, 14), unknown all the way.
    assert goal(occ, 0.25, field) == ((25, 14), True)
    # 1 m = 20 cells would leave the 30-row grid after row 29: it stops there.
    assert goal(occ, 1.0, field) == ((29, 14), True)
    # A wall at (23, 14) stops it after rows 21 and 22.
    walled = occ.copy()
    walled[23, 14] = WALL
    assert goal(walled, 0.25, dijkstra(make_costmap(walled, RES, burger_costmap_settings), robot, RES,
                                       PlannerSettings(unknown_cost=0))) == ((22, 14), True)
    # With the default field (unknown forbidden) the extended point (25, 14) snaps back to
    # the known side: (19, 14) is 6 cells away, (19, 13) and (19, 15) sqrt(37).
    assert goal(occ, 0.25, None) == ((19, 14), True)


# ---------------------------------------------------------------- detect: viewpoints

def slot_room():
    """60 x 60 cells in 1-cell walls; the robot's side is rows 1..29. A wall 2 cells thick
    (rows 30, 31) has a slot 6 cells (0.3 m) wide, cols 27..32, walled on both sides (cols 26
    and 33) up to row 37 and free up to there; everything beyond is unknown. The only
    frontier is row 38, cols 26..33 (8 cells; the end ones touch the slot diagonally)."""
    occ = np.full((60, 60), FREE, np.int8)
    occ[[0, -1], :] = occ[:, [0, -1]] = WALL
    occ[30:32, :] = WALL
    occ[32:, 1:-1] = UNKNOWN
    occ[30:38, [26, 33]] = WALL
    occ[30:38, 27:33] = FREE
    return occ


def slab_room():
    """60 x 70 cells in 1-cell walls: clutter whose inside was never seen. South region S,
    rows 1..29 (the robot's). A slab of unknown cells, rows 30..32, cols 10..45, closed by
    walls at col 9 (rows 30..36) and col 46 (rows 30..32). North of it a strip 3 cells wide
    (rows 33..35, inscribed all along) under a wall block (rows 36..58, cols 1..46), open to
    the east region E (cols 47..68, rows 1..58, joined to S). Two frontiers: the slab's
    south face (row 30, cols 10..45), which S sees, and its north face (row 32), which only
    the rays along the strip reach, from E."""
    occ = np.full((60, 70), FREE, np.int8)
    occ[[0, -1], :] = occ[:, [0, -1]] = WALL
    occ[30:33, 10:46] = UNKNOWN
    occ[30:37, 9] = WALL
    occ[30:33, 46] = WALL
    occ[36:, 1:47] = WALL
    return occ


def reached(*cells):
    """GoalBook.tried after reaching the centres of ``cells`` (attempt radius 0.4 m)."""
    book = GoalBook()
    for i, cell in enumerate(cells):
        book.succeeded(cell_to_xy(cell, RES, (0.0, 0.0)), float(i))
    return book.tried(now_s=len(cells))


def sees(occ, viewpoint, cells, radius=70.0):
    """Whether a ray of visible_cells from ``viewpoint`` over free cells reaches one of
    ``cells`` (made transparent here, as frontier cells are)."""
    blocking = (occ != FREE).astype(np.uint8)
    blocking[tuple(np.asarray(cells).T)] = 0
    seen = _native.visible_cells(blocking, np.array([viewpoint], np.int32), radius, beams=180)
    return bool(seen[tuple(np.asarray(cells).T)].any())


def test_a_frontier_seen_through_a_slot_narrower_than_the_robot_gets_a_viewpoint(
        burger_costmap_settings):
    # The slot (0.3 m) is narrower than the burger's inscribed band (2 x 0.176 m): all of it
    # is inscribed, and the snap's walk from the frontier (over passable or unknown cells,
    # 1 m) finds no cell the robot reaches. The robot's side sees up the slot: the goal is
    # the nearest cell that does with cost <= 128, on row 24 (cost 113; row 25 costs 141),
    # 14 rows below the frontier. Its cols 26..33 are all 14 cells from a frontier cell; 29
    # and 30 are nearest the frontier's centroid (38, 29.5), and the raster order takes 29.
    occ = slot_room()
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    assert (costmap[30:38, 27:33] == 253).all()
    assert costmap[24, 29] == 113 and costmap[25, 29] == 141
    (f,) = detect(occ, RES, (0.0, 0.0), costmap, (10, 30), FrontierSettings())
    assert f.goal_cell == (24, 29) and f.reachable
    assert f.path_cost_m == float(dijkstra(costmap, (10, 30), resolution=RES)[24, 29])
    assert sees(occ, f.goal_cell, f.cells)
    # A wall across the slot (row 34): nothing the robot reaches sees the frontier any more.
    # It is given up: reported (at its representative: no cell on its side either), not used.
    occ[34, 27:33] = WALL
    (f,) = detect(occ, RES, (0.0, 0.0), make_costmap(occ, RES, burger_costmap_settings),
                  (10, 30), FrontierSettings())
    assert not f.reachable and f.path_cost_m == math.inf and f.goal_cell == (38, 29)


def test_a_frontier_a_reached_goal_did_not_reveal_gets_another_viewpoint(burger_costmap_settings):
    occ = slab_room()
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    robot = (10, 35)
    # Both faces snap to (29, 27): the north face's walk runs 3 cells through the unknown
    # slab (the strip beside it is inscribed), the south face's is 1 cell. From (29, 27) the
    # slab hides the north face: a robot standing there does not reveal it.
    south, north = detect(occ, RES, (0.0, 0.0), costmap, robot, FrontierSettings())
    assert (south.cells[:, 0] == 30).all() and (north.cells[:, 0] == 32).all()
    assert south.goal_cell == north.goal_cell == (29, 27) and north.reachable
    assert sees(occ, (29, 27), south.cells) and not sees(occ, (29, 27), north.cells)
    # Reached once and both faces are still there. The south face's cells were in view of
    # (29, 27): looking again from there shows nothing new, and no other viewpoint sees
    # cells it did not, so it is given up. The north face was hidden: its next goal is the
    # nearest cell that sees it from outside the tried disc, (36, 53) in E, looking along
    # the strip (7 cols from the wall block at col 46: cost 105 <= 128).
    south, north = detect(occ, RES, (0.0, 0.0), costmap, robot, FrontierSettings(),
                          tried=reached((29, 27)))
    assert not south.reachable and south.goal_cell == (29, 27)
    assert north.reachable and north.goal_cell == (36, 53) and costmap[36, 53] == 105
    assert sees(occ, (36, 53), north.cells)
    assert north.path_cost_m == float(dijkstra(costmap, robot, resolution=RES)[36, 53])
    # Reached too, and the north face still stands: nothing untried sees what the two did
    # not, so it is given up as well: nothing reachable is left to see.
    south, north = detect(occ, RES, (0.0, 0.0), costmap, robot, FrontierSettings(),
                          tried=reached((29, 27), (36, 53)))
    assert not south.reachable and not north.reachable


@pytest.mark.parametrize("max_cost", [128, 252])
def test_viewpoints_run_out(burger_costmap_settings, max_cost):
    # Reach each viewpoint of the slot's frontier in turn on an unchanging map (the worst
    # case: nothing is ever revealed). Every new one lies outside the discs of those before
    # and sees frontier cells; after a few the frontier is given up instead of sending the
    # robot round every cell that sees it.
    occ = slot_room()
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    goals = []
    for _ in range(10):
        (f,) = detect(occ, RES, (0.0, 0.0), costmap, (10, 30), FrontierSettings(max_cost=max_cost),
                      tried=reached(*goals))
        if not f.reachable:
            break
        assert all(math.dist(f.goal_cell, g) * RES > 0.4 for g in goals)
        assert sees(occ, f.goal_cell, f.cells)
        goals.append(f.goal_cell)
    assert not f.reachable
    # max_cost 128: (24, 29), whose rays reach 7 of the 8 cells, all but (38, 26); then
    # (23, 37), which sees (38, 26) past the slot's left wall; then all 8 are spent. 252:
    # (28, 29), 4 rows nearer the slot, reaches all 8 at once.
    assert goals == {128: [(24, 29), (23, 37)], 252: [(28, 29)]}[max_cost]


def pocket_hall():
    """40 x 100 cells: a hall (free rows 3..29, cols 3..96) inside thick walls (rows 30..39
    wall), unknown below row 2. Two frontiers on the hall's north side: a pocket of 3
    unknown cells in the wall's face (row 30, cols 10..12), walled on every other side (a
    wall face the map drew a cell off: no ray of the lidar ever reveals it), and the same
    pocket at cols 85..87, 3.7 m east."""
    occ = np.full((40, 100), UNKNOWN, np.int8)
    occ[2:, :] = WALL
    occ[3:30, 3:97] = FREE
    occ[30, 10:13] = UNKNOWN
    occ[30, 85:88] = UNKNOWN
    return occ


def look_from(looks, occ, origin, *cells):
    """``Looks.look`` from the centre of each cell in turn (the last stays pending)."""
    for cell in cells:
        looks.look(occ, find_frontier_cells(occ), RES, origin, cell_to_xy(cell, RES, origin))


def test_a_frontier_the_lidar_looked_at_from_two_places_and_did_not_reveal_is_spent(
        burger_costmap_settings):
    occ = pocket_hall()
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    s = FrontierSettings()
    assert (s.look_range_m, s.look_spacing_m, s.looks_to_spend) == (2.5, 0.25, 2)
    looks = Looks(s.look_range_m, s.look_spacing_m, s.looks_to_spend, s.gain_beams, FREE_THRESH)

    def frontiers():
        return detect(occ, RES, (0.0, 0.0), costmap, (15, 11), s,
                      spent=looks.spent(occ.shape, RES, (0.0, 0.0)))

    assert [f.centroid[0] for f in frontiers()] == pytest.approx([0.575, 4.325])
    # (15, 11) is 0.75 m below the west pocket. A place's look is cast once the next place is
    # known (the map then holds its scans), and only 0.25 m or more from the last place cast:
    # (15, 11) is cast, (15, 13), (15, 14), (15, 15) are not (0.1-0.2 m from it). One look:
    # the pocket could lie between two beams; it stays.
    look_from(looks, occ, (0.0, 0.0), (15, 11), (15, 13), (15, 14), (15, 15), (15, 16))
    assert len(frontiers()) == 2
    # (15, 16), 0.25 m from (15, 11), is cast at the next place: two looks, and the west pocket
    # is no frontier. The east one, 3.7 m off, beyond look_range_m (the mapper clears open
    # space to 3.5 m), stays.
    look_from(looks, occ, (0.0, 0.0), (15, 17))
    (east,) = frontiers()
    assert east.centroid[0] == pytest.approx(4.325) and east.reachable
    # The count is kept in map-frame cells: the grid grown by 10 columns west and 5 rows south
    # (origin 0.5 m west, 0.25 m south) spends the same cells.
    grown = np.full((45, 110), UNKNOWN, np.int8)
    grown[5:, 10:] = occ
    spent = looks.spent(grown.shape, RES, (-0.5, -0.25))
    assert sorted(map(tuple, np.argwhere(spent).tolist())) == [(35, 20), (35, 21), (35, 22)]
    # looks_to_spend 0 turns the rule off
    off = Looks(s.look_range_m, s.look_spacing_m, 0, s.gain_beams, FREE_THRESH)
    look_from(off, occ, (0.0, 0.0), (15, 11), (15, 17), (15, 23), (15, 29))
    assert not off.spent(occ.shape, RES, (0.0, 0.0)).any()


def test_a_frontier_cell_a_wall_hides_is_not_looked_at():
    # The west pocket, looked at from a room beyond a wall: rays stop at the wall, nothing spent
    occ = pocket_hall()
    occ[3:30, 20] = WALL
    s = FrontierSettings()
    looks = Looks(s.look_range_m, s.look_spacing_m, s.looks_to_spend, s.gain_beams, FREE_THRESH)
    look_from(looks, occ, (0.0, 0.0), (25, 25), (25, 31), (25, 37))
    assert looks.counts == {}


def test_no_frontiers_and_bad_input(burger_costmap_settings):
    occ = np.zeros((10, 10), np.int8)
    occ[0, :] = WALL
    costmap = make_costmap(occ, RES, burger_costmap_settings)
    assert detect(occ, RES, (0.0, 0.0), costmap, (5, 5), FrontierSettings()) == []
    with pytest.raises(ValueError, match="costmap has shape"):
        detect(occ, RES, (0.0, 0.0), costmap[:5], (5, 5), FrontierSettings())
    with pytest.raises(ValueError, match="resolution"):
        detect(occ, 0.0, (0.0, 0.0), costmap, (5, 5), FrontierSettings())


def test_settings_validation():
    assert from_dict(FrontierSettings, {}, "test") == FrontierSettings()
    for bad in ({"min_size_cells": 0}, {"min_opening_cells": 0}, {"max_cost": 253}, {"sensor_range_m": 0.0},
                {"extend_into_unknown_m": -0.1}, {"gain_beams": 0},
                {"snap_radius_m": -1.0}, {"look_range_m": 0.0}, {"look_spacing_m": -1.0},
                {"looks_to_spend": -1}):
        with pytest.raises(ConfigError, match=next(iter(bad))):
            from_dict(FrontierSettings, bad, "test")


# ---------------------------------------------------------------- information gain

def test_visible_unknown_matches_the_reference_on_random_maps():
    rng = np.random.default_rng(5)
    values = np.array([UNKNOWN, FREE, 10, 25, 26, 60, WALL], np.int8)
    probs = [0.45, 0.35, 0.05, 0.03, 0.03, 0.03, 0.06]
    for trial in range(12):
        rows, cols = rng.integers(1, 40, size=2)
        occ = rng.choice(values, size=(rows, cols), p=probs).astype(np.int8)
        cells = np.stack([rng.integers(0, rows, 6), rng.integers(0, cols, 6)], axis=1)
        cells = cells.astype(np.int32)
        for radius in (0.0, 1.0, 2.5, 7.3, 15.0):
            for beams in (1, 7, 180):
                got = visible_unknown(occ, cells, radius, beams=beams, free_threshold=25)
                want = [reference_visible_unknown(occ, tuple(c), radius, beams) for c in cells]
                assert got.dtype == np.int32
                assert got.tolist() == want, (trial, radius, beams)


def test_visible_unknown_open_disc():
    # A free cell amid unknown space sees the whole disc of radius 10 cells except itself:
    # the lattice points with dr^2 + dc^2 <= 100 number 317 (Gauss's circle problem, N(10)),
    # so 316 unknown cells (pi r^2 = 314.2). 360 beams leave no gap at 10 cells (arc 0.17
    # cell per beam); 180 beams (arc 0.35 cell) miss a few cells near the rim.
    occ = np.full((41, 41), UNKNOWN, np.int8)
    occ[20, 20] = FREE
    centre = np.array([[20, 20]], np.int32)
    assert visible_unknown(occ, centre, 10.0, beams=360)[0] == 316
    assert 0.95 * 316 <= visible_unknown(occ, centre, 10.0, beams=180)[0] < 316
    # An unknown query cell counts itself: 317.
    occ[20, 20] = UNKNOWN
    assert visible_unknown(occ, centre, 10.0, beams=360)[0] == 317


def test_visible_unknown_wall_blocks_the_view():
    # A full wall column 3 cells to the right of the free query cell: every ray going right
    # crosses column dc = 3 (Bresenham moves at most one column per step) and stops there.
    # Visible: the disc cells with dc <= 2, less the query cell. Per column dc, the rows
    # with dr^2 <= 100 - dc^2 number 2 floor(sqrt(100 - dc^2)) + 1:
    #   dc = -10..2 -> 1, 9, 13, 15, 17, 17, 19, 19, 19, 19, 21, 19, 19 = 207; minus 1 = 206.
    # (dc = 3..10 add 19, 19, 17, 17, 15, 13, 9, 1 = 110: 317 in all, as in the open disc.)
    occ = np.full((41, 41), UNKNOWN, np.int8)
    occ[20, 20] = FREE
    occ[:, 23] = WALL
    centre = np.array([[20, 20]], np.int32)
    assert sum(2 * math.isqrt(100 - dc * dc) + 1 for dc in range(-10, 3)) == 207
    assert visible_unknown(occ, centre, 10.0, beams=360)[0] == 206
    # Without the wall: 316 (test above).
    occ[:, 23] = UNKNOWN
    assert visible_unknown(occ, centre, 10.0, beams=360)[0] == 316


def test_visible_unknown_along_a_corridor():
    # One row: free query at col 0, unknown to the right, radius 5: cols 1..5 -> 5.
    row = np.full((1, 20), UNKNOWN, np.int8)
    row[0, 0] = FREE
    query = np.array([[0, 0]], np.int32)
    assert visible_unknown(row, query, 5.0)[0] == 5
    row[0, 3] = 26          # occupied (> 25): only cols 1, 2 -> 2
    assert visible_unknown(row, query, 5.0)[0] == 2
    row[0, 3] = 25          # free: cols 1, 2, 4, 5 -> 4
    assert visible_unknown(row, query, 5.0)[0] == 4
    assert visible_unknown(row, query, 5.0, free_threshold=20)[0] == 2
    # The query cell never blocks its own rays, even when it is occupied.
    row[0, 0] = WALL
    row[0, 3] = UNKNOWN
    assert visible_unknown(row, query, 5.0)[0] == 5


def test_visible_unknown_arguments():
    occ = np.full((8, 8), UNKNOWN, np.int8)
    cells = np.array([[1, 2], [5, 6]], np.int32)
    got = visible_unknown(occ, cells, 3.0)
    # Any layout is accepted (converted): a Fortran-ordered copy gives the same counts.
    fortran = visible_unknown(np.asfortranarray(occ), np.asfortranarray(cells), 3.0)
    assert fortran.tolist() == got.tolist()
    assert visible_unknown(occ, np.zeros((0, 2), np.int32), 3.0).shape == (0,)
    with pytest.raises(ValueError, match="outside"):
        visible_unknown(occ, np.array([[8, 0]], np.int32), 3.0)
    with pytest.raises(ValueError, match="beams"):
        visible_unknown(occ, cells, 3.0, beams=0)
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        visible_unknown(occ, np.array([1, 2, 3], np.int32), 3.0)
