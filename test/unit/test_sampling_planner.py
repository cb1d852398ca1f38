"""OMPL's planners for the oriented footprint (planning.sampling, sampling_planner.hpp).

Each returned path is checked here independently of the C++: the follower's drive (turn in
place at each vertex to the next segment's direction, drive straight along it) keeps the body
``margin_m`` off every obstacle cell's square (``footprint_clear``, every centimetre), and each
turn happens where the body stays ``turn_margin_m`` off them. Maps at 0.05 m, origin (0, 0).
"""
import math

import numpy as np
import pytest

from turtlebot_recon.planning import LatticeSettings, PlanningError, footprint_clear, plan_lattice
from turtlebot_recon.planning.sampling import OMPL_PLANNERS, plan_sampling
from turtlebot_recon.robot import load_robot

RES = 0.05
ORIGIN = (0.0, 0.0)
WAFFLE = load_robot("turtlebot3_waffle_pi")
BURGER = load_robot("turtlebot3_burger")
BUDGET_S = 0.5


def walled(rows, cols):
    occ = np.zeros((rows, cols), np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    return occ


def l_corridor():
    """A 0.8 m (16-cell) corridor east along rows 4-19 from column 4 to 60, then north along
    columns 45-60 up to row 55: a box robot turns only near the corner."""
    occ = np.full((60, 64), 100, np.int8)
    occ[4:20, 4:61] = 0
    occ[4:56, 45:61] = 0
    return occ


def followed_poses(poses, reversed_, step_m=0.01):
    """The poses the follower passes: each segment driven at its direction (facing back where
    it is driven backward), with the turns at the vertices (from the previous heading, or the
    start's yaw, to the next; at the goal to its yaw) every 2 degrees."""
    out = []
    yaw = poses[0, 2]
    for a, b, back in zip(poses[:-1], poses[1:], reversed_[1:]):
        d = math.hypot(b[0] - a[0], b[1] - a[1])
        heading = math.atan2(b[1] - a[1], b[0] - a[0]) + (math.pi if back else 0.0) if d > 1e-9 else b[2]
        turn = math.remainder(heading - yaw, 2 * math.pi)
        for t in np.linspace(0.0, 1.0, max(2, int(abs(turn) / math.radians(2)) + 1)):
            out.append((a[0], a[1], yaw + t * turn))
        for t in np.linspace(0.0, 1.0, max(2, int(d / step_m) + 1)):
            out.append((a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), heading))
        yaw = heading
    turn = math.remainder(poses[-1, 2] - yaw, 2 * math.pi)
    for t in np.linspace(0.0, 1.0, max(2, int(abs(turn) / math.radians(2)) + 1)):
        out.append((poses[-1, 0], poses[-1, 1], yaw + t * turn))
    return np.array(out)


def check_path(occ, robot, path, start, goal):
    assert np.allclose(path.poses[0], start)
    assert np.allclose(path.poses[-1, :2], goal[:2])
    settings = LatticeSettings()
    # turns only where the body keeps turn_margin_m off obstacles, drives margin_m
    clear = footprint_clear(occ, RES, ORIGIN, robot, followed_poses(path.poses, path.reversed),
                            LatticeSettings(margin_m=settings.turn_margin_m))
    assert clear.all(), "the follower's drive along the path meets an obstacle"
    length = np.hypot(*np.diff(path.poses[:, :2], axis=0).T).sum()
    assert path.length_m == pytest.approx(length, rel=1e-9)


@pytest.mark.parametrize("planner", OMPL_PLANNERS)
@pytest.mark.parametrize("robot", [WAFFLE, BURGER], ids=lambda r: r.name)
def test_each_planner_rounds_a_corridor_corner(planner, robot):
    occ = l_corridor()
    start, goal = (0.45, 0.6, 0.0), (2.65, 2.5)
    path = plan_sampling(occ, RES, ORIGIN, robot, start, goal, planner, BUDGET_S)
    check_path(occ, robot, path, start, goal)
    # around the corner, not through the wall: at least the two legs' straight-line lengths
    lattice = plan_lattice(occ, RES, ORIGIN, robot, start, goal, LatticeSettings())
    assert path.length_m >= math.hypot(2.65 - 0.45, 2.5 - 0.6)
    assert path.length_m <= 1.5 * lattice.length_m
    assert len(path.poses) >= 3           # a turn somewhere: no straight line gets there


@pytest.mark.parametrize("planner", OMPL_PLANNERS)
def test_walled_off_goal_is_no_path_within_the_budget(planner):
    occ = walled(40, 80)
    occ[:, 40:42] = 100                    # two rooms, no door
    with pytest.raises(PlanningError, match="no path within"):
        plan_sampling(occ, RES, ORIGIN, BURGER, (0.5, 1.0, 0.0), (3.5, 1.0), planner, 0.1)


def test_a_goal_yaw_is_kept_and_the_goal_reached_driving_forward():
    occ = walled(40, 80)
    start, goal = (0.5, 1.0, 0.0), (3.0, 1.0, math.pi / 2)
    path = plan_sampling(occ, RES, ORIGIN, WAFFLE, start, goal, "rrtconnect", BUDGET_S)
    check_path(occ, WAFFLE, path, start, goal)
    assert path.poses[-1, 2] == pytest.approx(math.pi / 2)
    # in an open room the simplified path is the straight line, turning at the goal
    assert path.length_m == pytest.approx(2.5, abs=0.05)


def test_the_box_backs_into_a_dead_end_it_cannot_turn_in():
    """A 0.45 m corridor with a closed end: the waffle_pi (0.306 m wide box, 0.257 m turning
    disc) cannot turn anywhere in it, so it reaches a goal facing back out of it only by
    backing in (the lattice's backward moves, reverse_speed_mps); forward only, there is no
    way. The burger (0.105 m disc) turns anywhere and drives in forward."""
    occ = np.full((40, 80), 100, np.int8)
    occ[5:35, 5:30] = 0                    # a 1.5 x 1.25 m room
    occ[16:25, 30:75] = 0                  # a 0.45 m corridor east from it, closed at its end
    start, goal = (0.75, 1.0, 0.0), (3.2, 1.0, math.pi)
    with pytest.raises(PlanningError):
        plan_sampling(occ, RES, ORIGIN, WAFFLE, start, goal, "rrtconnect", 0.3,
                      settings=LatticeSettings(reverse_speed_mps=0.0))
    path = plan_sampling(occ, RES, ORIGIN, WAFFLE, start, goal, "rrtconnect", BUDGET_S)
    check_path(occ, WAFFLE, path, start, goal)
    assert path.reversed.any() and path.reversed_m >= 3.2 - 1.5
    path = plan_sampling(occ, RES, ORIGIN, BURGER, start, goal, "rrtconnect", BUDGET_S)
    check_path(occ, BURGER, path, start, goal)
    assert not path.reversed.any() and path.reversed_m == 0.0


@pytest.mark.parametrize("start, goal, what", [
    ((0.05, 0.05, 0.0), (3.0, 1.0), "the start"),       # on the wall
    ((0.5, 1.0, 0.0), (9.0, 1.0), "the goal"),           # off the map
    ((0.5, 1.0, 0.0), (0.06, 1.0), "the goal"),          # the body would overlap the wall
])
def test_blocked_start_or_goal_is_one_line(start, goal, what):
    occ = walled(40, 80)
    with pytest.raises(PlanningError, match=what):
        plan_sampling(occ, RES, ORIGIN, WAFFLE, start, goal, "rrtconnect", 0.1)


def test_unknown_cells_are_not_entered():
    occ = walled(40, 80)
    occ[1:-1, 38:42] = -1                  # an unknown band splits the room
    with pytest.raises(PlanningError, match="no path within"):
        plan_sampling(occ, RES, ORIGIN, BURGER, (0.5, 1.0, 0.0), (3.5, 1.0), "rrtconnect", 0.1)


def test_bad_arguments_raise_value_error():
    occ = walled(40, 80)
    with pytest.raises(ValueError, match="unknown planner 'rrt_sharp'"):
        plan_sampling(occ, RES, ORIGIN, BURGER, (0.5, 1.0, 0.0), (3.0, 1.0), "rrt_sharp", 0.1)
    with pytest.raises(ValueError, match="budget_s"):
        plan_sampling(occ, RES, ORIGIN, BURGER, (0.5, 1.0, 0.0), (3.0, 1.0), "rrtconnect", 0.0)
    with pytest.raises(ValueError, match="finite"):
        plan_sampling(occ, RES, ORIGIN, BURGER, (math.nan, 1.0, 0.0), (3.0, 1.0), "rrtconnect", 0.1)


@pytest.mark.parametrize("robot", [WAFFLE, BURGER], ids=lambda r: r.name)
def test_astars_cells_shortened_for_the_footprint_round_the_corner_clear(robot):
    from turtlebot_recon import geometry
    from turtlebot_recon.planning import PlannerSettings, footprint_costmap, plan
    from turtlebot_recon.planning.sampling import shortcut_turn_drive
    occ = l_corridor()
    start, goal = (0.45, 0.6, 0.0), (2.65, 2.5)
    costmap = footprint_costmap(occ, RES, robot, LatticeSettings())
    cells = plan(costmap, geometry.xy_to_cell(start, RES, ORIGIN), geometry.xy_to_cell(goal, RES, ORIGIN),
                 PlannerSettings(visit_sensitivity=0.0, shortcut=False), resolution=RES)
    pts = geometry.cells_to_points(cells, RES, ORIGIN)
    pts[0], pts[-1] = start[:2], goal
    path = shortcut_turn_drive(occ, RES, ORIGIN, robot, pts, start[2])
    check_path(occ, robot, path, start, goal)
    # a handful of straight legs, not A*'s cell steps, and no longer than the steps
    assert 3 <= len(path.poses) <= 6 < len(pts)
    assert path.length_m <= np.hypot(*np.diff(pts, axis=0).T).sum() + 1e-9


def test_a_path_through_a_wall_is_no_followable_path():
    from turtlebot_recon.planning.sampling import shortcut_turn_drive
    occ = walled(40, 80)
    occ[:, 40:42] = 100                    # a wall across the room
    pts = np.array([(0.5, 1.0), (1.9, 1.0), (2.2, 1.0), (3.5, 1.0)])
    with pytest.raises(PlanningError, match="reaches no later point of the path"):
        shortcut_turn_drive(occ, RES, ORIGIN, BURGER, pts, 0.0)
    with pytest.raises(PlanningError, match="the start is off the map"):
        shortcut_turn_drive(occ, RES, ORIGIN, BURGER, np.array([(2.05, 1.0), (3.5, 1.0)]), 0.0)
    with pytest.raises(ValueError, match="points must be finite"):
        shortcut_turn_drive(occ, RES, ORIGIN, BURGER, np.array([(0.5, 1.0), (np.nan, 1.0)]), 0.0)
