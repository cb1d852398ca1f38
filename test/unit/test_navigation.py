"""Navigation core: plan on the costmap, follow, replan on map change, fail with a reason."""
import math

import numpy as np
import pytest

from turtlebot_recon.planning.navigation import Navigation, NavigationSettings
from turtlebot_recon.robot import load_robot

RES = 0.05


def room(width_cells=80, height_cells=60):
    """A walled room; the map origin is (0, 0), so the free area is [0.05, 3.95] x [0.05, 2.95]."""
    occ = np.zeros((height_cells, width_cells), np.int8)
    occ[0, :] = occ[-1, :] = 100
    occ[:, 0] = occ[:, -1] = 100
    return occ


def drive(nav, pose, seconds, dt=0.1):
    """Integrate a unicycle under the navigator's commands; returns the final pose."""
    x, y, yaw = pose
    for k in range(int(seconds / dt)):
        v, w = nav.step(k * dt, (x, y, yaw), (0.0, 0.0))
        x += v * dt * math.cos(yaw)
        y += v * dt * math.sin(yaw)
        yaw += w * dt
        if nav.status != "active":
            break
    return x, y, yaw


@pytest.fixture
def nav():
    n = Navigation(NavigationSettings(), load_robot("turtlebot3_burger"))
    n.update_map(room(), RES, (0.0, 0.0))
    return n


def test_reaches_a_goal_across_the_room(nav):
    nav.set_goal(3.0, 2.0)
    x, y, _ = drive(nav, (1.0, 1.0, 0.0), 40.0)
    assert nav.status == "succeeded", nav.reason
    assert math.hypot(x - 3.0, y - 2.0) <= 0.1 + 1e-9       # the follower's xy tolerance


def test_goal_in_a_wall_fails_with_a_reason(nav):
    nav.set_goal(10.0, 1.0)                                   # off the map
    drive(nav, (1.0, 1.0, 0.0), 1.0)
    assert nav.status == "failed" and "goal (10.00, 1.00)" in nav.reason


def test_goal_behind_a_closed_wall_is_unreachable(nav):
    occ = room()
    occ[:, 40] = 100                                          # a wall across the room at x = 2.0
    nav.update_map(occ, RES, (0.0, 0.0))
    nav.set_goal(3.0, 1.5)
    drive(nav, (1.0, 1.5, 0.0), 1.0)
    assert nav.status == "failed" and "unreachable" in nav.reason


def test_map_change_along_the_path_triggers_a_replan(nav):
    nav.set_goal(3.5, 1.5)
    nav.step(0.0, (0.5, 1.5, 0.0), (0.0, 0.0))
    assert len(nav.dense_xy) > 10 and not nav._need_plan
    occ = room()
    occ[20:40, 40] = 100                                      # a wall appears across the straight path
    nav.update_map(occ, RES, (0.0, 0.0))
    assert nav._need_plan
    nav.step(0.1, (0.5, 1.5, 0.0), (0.0, 0.0))
    cells = [(int(y / RES), int(x / RES)) for x, y in nav.dense_xy]
    assert all(nav.map.costmap[c] < 253 for c in cells)      # the new plan goes around it


def test_cancel_and_bad_goals(nav):
    nav.set_goal(3.0, 2.0)
    nav.cancel()
    assert nav.status == "idle" and nav.step(0.0, (1.0, 1.0, 0.0), (0, 0)) == (0.0, 0.0)
    nav.set_goal(float("nan"), 1.0)
    assert nav.status == "failed" and "not finite" in nav.reason


def test_blocked_counts_once_per_map(nav, monkeypatch):
    """The map comes at ~1 Hz, the controller at 10 Hz: replans on one map meet the same
    obstacle (maybe only a stale unknown cell ahead). The goal fails when the follower reports
    blocked on more than max_blocked_replans (3) maps in a row, not after 4 control periods."""
    from turtlebot_recon.control import ControlOutput
    monkeypatch.setattr(nav.controller, "compute",
                        lambda inp: ControlOutput(0.0, 0.0, "blocked", detail="unknown cell ahead"))
    nav.set_goal(3.0, 2.0)
    t = 0.0
    for maps in range(1, 5):
        for _ in range(10):                       # 1 s of control on this map
            assert nav.step(t, (1.0, 1.0, 0.0), (0.0, 0.0)) == (0.0, 0.0)
            t += 0.1
        if maps < 4:
            assert nav.status == "active", f"failed on map {maps}: {nav.reason}"
            nav.update_map(room(), RES, (0.0, 0.0))
    assert nav.status == "failed" and "blocked on 4 maps in a row" in nav.reason and "unknown cell ahead" in nav.reason


def test_the_first_leg_starts_where_the_robot_is_not_at_its_cell_centre():
    # a 0.2 m pillar at (2.0, 1.5); the waffle_pi stands on cost 221 at the edge of its band,
    # 2 cm off its cell's centre, facing the plan's first waypoint. A shortcut checked from the
    # cell's centre made a first leg whose line from the robot clipped an inscribed cell: every
    # look-ahead point was "blocked", and the same plan came back each time. The first leg now
    # goes to the next cell of the plan, from where the robot is: it drives, and arrives.
    occ = room()
    occ[28:32, 38:42] = 100
    nav = Navigation(NavigationSettings(), load_robot("turtlebot3_waffle_pi"))
    nav.update_map(occ, RES, (0.0, 0.0))
    pose = (2.101, 1.903, -0.115)
    assert nav.map.costmap[int(pose[1] / RES), int(pose[0] / RES)] == 221
    nav.set_goal(3.3, 1.52)
    assert nav.step(0.0, pose, (0.0, 0.0)) != (0.0, 0.0)
    x, y, _ = drive(nav, pose, 40.0)
    assert nav.status == "succeeded", nav.reason
    assert math.hypot(x - 3.3, y - 1.52) <= 0.1 + 0.03          # tolerance + one period of travel
