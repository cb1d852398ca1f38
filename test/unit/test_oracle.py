"""The omniscient reference route (turtlebot_recon.evaluation.oracle) on a hand-made world of
two rooms joined by a door, and the known-free prefix its driver steers by."""
import math

import numpy as np
import pytest

from turtlebot_recon.config import ConfigError
from turtlebot_recon.evaluation import CoverageTracker, world_to_map
from turtlebot_recon.evaluation.oracle import Oracle, OracleSettings, farthest_known_free
from turtlebot_recon.robot import load_robot
from turtlebot_recon.sim import load_world

from conftest import write_world

RES = 0.05
LIDAR_M = 3.5


@pytest.fixture(scope="module")
def two_rooms(tmp_path_factory):
    """Rooms A (x 0.1..4.0) and B (x 4.2..8.2), y 0.1..3.1, the wall between them 0.2 m thick
    with a 1 m door at y 1.1..2.1; start (1.0, 1.6) in A, 7.2 m from B's far wall."""
    free = np.zeros((64, 166), bool)
    free[2:62, 2:80] = True              # A: columns 2..79  -> x 0.1..4.0
    free[2:62, 84:164] = True            # B: columns 84..163 -> x 4.2..8.2
    free[22:42, 80:84] = True            # the door: rows 22..41 -> y 1.1..2.1
    path = write_world(tmp_path_factory.mktemp("oracle"), "two_rooms", free, start=[1.0, 1.6, 0.0])
    return load_world(path)


@pytest.fixture(scope="module")
def oracle(two_rooms):
    return Oracle(two_rooms, load_robot("turtlebot3_burger"), LIDAR_M, OracleSettings(restarts=2))


def test_route_sees_the_target_through_the_door(oracle):
    route = oracle.route()
    # B's far corners (8.2, 0.1 / 3.1) are 3.0 m (the model's range, 3.5 - 0.5 m) from x ~ 5.7
    # on the door's line: the route must pass the door (x 4.1) and go ~1.6 m into B; from the
    # start that is >= 4.7 m. A detour to A's corners first would add >= 2 m.
    assert math.isfinite(route.distance_m)
    assert 4.0 <= route.distance_m <= 5.5
    assert route.seen >= 0.99
    assert (route.points[:, 0] > 4.2).any()                       # it goes into B
    for x, y in route.points:                                     # viewpoints keep off walls
        assert oracle.costmap[oracle.world.cell(x, y)] <= OracleSettings().max_cost


def test_restarts_never_lengthen_the_route(two_rooms):
    robot = load_robot("turtlebot3_burger")
    plain = Oracle(two_rooms, robot, LIDAR_M, OracleSettings(restarts=0)).route()
    tried = Oracle(two_rooms, robot, LIDAR_M, OracleSettings(restarts=3)).route()
    assert tried.distance_m <= plain.distance_m + 1e-9


def test_nothing_left_to_see_gives_an_empty_route(oracle):
    route = oracle.route(covered=np.ones(oracle.F_cells.size, bool))
    assert len(route.points) == 0 and route.distance_m == 0.0 and route.seen == 1.0


def test_a_replan_covers_only_what_is_still_unseen(oracle):
    # room A seen already, the robot at the door: the route only needs B, and is shorter than
    # the one from the start
    tracker = CoverageTracker(oracle.world, oracle.F.reshape(oracle.world.free.shape))
    x = oracle.world.origin[0] + (np.nonzero(oracle.F.reshape(oracle.world.free.shape))[1] + 0.5) * RES
    covered = x < 4.1
    assert covered.size == tracker.cells
    route = oracle.route(start_xy=(4.1, 1.6), covered=covered, target=0.99)
    assert math.isfinite(route.distance_m) and route.distance_m < oracle.route().distance_m - 2.0
    assert (route.points[:, 0] > 4.2).all()


def test_path_runs_on_the_true_costmap(oracle):
    path = oracle.path((1.0, 1.6), (6.0, 1.6))
    assert np.hypot(*(path[0] - (1.0, 1.6))) < RES and np.hypot(*(path[-1] - (6.0, 1.6))) < RES
    assert all(oracle.costmap[oracle.world.cell(x, y)] < 253 for x, y in path)
    assert oracle.path((1.0, 1.6), (4.1, -5.0)).shape == (0, 2)    # off the map: no path


def test_a_start_in_the_inscribed_band_snaps_to_the_nearest_passable_cell(oracle):
    near_wall = (0.14, 1.6)                                          # 0.04 m from A's left wall
    assert oracle.costmap[oracle.world.cell(*near_wall)] >= 253
    r, c = oracle.cell(*near_wall)
    assert oracle.costmap[r, c] < 253
    assert math.isfinite(oracle.route(start_xy=near_wall).distance_m)


def test_settings_are_validated(two_rooms):
    robot = load_robot("turtlebot3_burger")
    for bad in ({"target": 1.5}, {"target": 0.0}, {"lattice_m": -1.0}, {"max_cost": 300},
                {"restarts": -1}, {"range_margin_m": -0.1}):
        with pytest.raises(ConfigError):
            Oracle(two_rooms, robot, LIDAR_M, OracleSettings(**bad))


def test_farthest_known_free_is_the_end_of_the_free_prefix():
    occ = np.full((10, 10), -1, np.int8)
    occ[5, :6] = 0                                   # free cells x in [0, 0.3) on row 5
    pts = np.column_stack([np.arange(10) * RES + 0.025, np.full(10, 5 * RES + 0.025)])
    assert farthest_known_free(pts, occ, RES, (0.0, 0.0)) == 5
    occ[5, 8] = 0                                    # free again further on: still the prefix
    assert farthest_known_free(pts, occ, RES, (0.0, 0.0)) == 5
    assert farthest_known_free(pts[6:], occ, RES, (0.0, 0.0)) is None      # starts unknown
    assert farthest_known_free(pts + (0.0, 10.0), occ, RES, (0.0, 0.0)) is None   # off the map
    occ[5, :] = 0
    assert farthest_known_free(pts, occ, RES, (0.0, 0.0)) == 9


def test_world_to_map_is_the_inverse_of_the_start_pose():
    start = (2.0, -1.0, math.pi / 2)
    got = world_to_map(np.array([[2.0, -1.0], [2.0, 0.0], [1.0, -1.0]]), start)
    assert np.allclose(got, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


@pytest.fixture(scope="module")
def rock_room(tmp_path_factory):
    """A 3.5 x 5 m room (x 0.1..3.6, y 0.1..5.1) with ten 0.4 m rocks in two columns (x
    1.5..1.9, 2.35..2.75) leaving 0.45-0.6 m gaps between them and to the walls; in its east
    wall (x 3.6..3.8) a 0.2 m slot (y 2.5..2.7) no robot passes, and beyond it a hall (x
    3.8..8.3, y 0.1..5.1) that only the lidar reaches. Start (0.8, 2.6)."""
    free = np.zeros((104, 168), bool)
    free[2:102, 2:72] = True
    free[2:102, 76:166] = True
    free[50:54, 72:76] = True
    for c0 in (30, 47):
        for r0 in (11, 30, 47, 67, 84):
            free[r0:r0 + 8, c0:c0 + 8] = False
    path = write_world(tmp_path_factory.mktemp("rocks"), "rock_room", free, start=[0.8, 2.6, 0.0])
    return load_world(path)


@pytest.mark.parametrize("robot_name", ["turtlebot3_burger", "turtlebot3_waffle_pi"])
def test_a_route_is_finite_wherever_f_is(rock_room, robot_name):
    # The hall is seen only through the slot, much of it 3.0-3.5 m from every pose the robot
    # reaches: within the lidar's range (F) but not the model's (3.5 - 0.5 m). Counted only at
    # the model's range those cells were never seen and the route was infinite (85.7 % and
    # 89.3 % of F seen, the burger and the waffle_pi). Every F cell must be seen from some
    # candidate, and the route reach the target.
    oracle = Oracle(rock_room, load_robot(robot_name), LIDAR_M, OracleSettings(restarts=0))
    union = np.zeros(oracle.F.size, bool)
    for c in oracle.cells:
        union[oracle.sight(c)] = True
    assert np.array_equal(union, oracle.F)
    hall = oracle.F.reshape(rock_room.free.shape)[:, 76:]
    assert hall.sum() > 0.05 * oracle.F_cells.size           # the hall weighs in F
    route = oracle.route()
    assert math.isfinite(route.distance_m) and route.distance_m < 15.0
    assert route.seen >= 0.99


def test_cells_seen_only_from_inside_a_narrow_passage_get_a_viewpoint_there(tmp_path):
    # A 3 x 3 m room (x, y 0.1..3.1) and off it a 0.45 m passage east (y 1.3..1.75, to x 5.1)
    # that turns north at its end (x 4.65..5.1, to y 3.6). In a 0.45 m passage the burger's
    # cost is over max_cost (128) everywhere, so no costed viewpoint lies in it, and the
    # northern leg is out of sight from the room: only F's own viewpoints in the passage see
    # it. They must be candidates, and the route must see the target.
    free = np.zeros((80, 110), bool)
    free[2:62, 2:62] = True
    free[26:35, 62:102] = True
    free[26:72, 93:102] = True
    world = load_world(write_world(tmp_path, "passage", free, start=[1.0, 1.5, 0.0]))
    oracle = Oracle(world, load_robot("turtlebot3_burger"), LIDAR_M, OracleSettings(restarts=0))
    north = oracle.F.reshape(world.free.shape)[40:72, 93:102]
    assert north.sum() > 0.05 * oracle.F_cells.size
    assert any(oracle.costmap[r, c] > OracleSettings().max_cost for r, c in oracle.cells)
    union = np.zeros(oracle.F.size, bool)
    for c in oracle.cells:
        union[oracle.sight(c)] = True
    assert np.array_equal(union, oracle.F)
    route = oracle.route()
    assert math.isfinite(route.distance_m) and route.seen >= 0.99
