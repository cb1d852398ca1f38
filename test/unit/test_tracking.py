"""The path tracker every controller shares (control/tracking.py): progress along the path, the
goal latch, the turn-in-place law and its gate, and that the controllers take them (and their
parameters, navigator.yaml's one ``tracking`` block) from it.

Grids: 5 cm cells, origin (-1, -1), 4 m a side; robot: the waffle_pi (w_max 1.82 rad/s).
Defaults: window 1 m, xy / yaw tolerance 0.1, |w| = clamp(1.5 |err|, 0.2, 0.8).
"""
import dataclasses
import math

import numpy as np
import pytest

from turtlebot_recon.config import ConfigError, from_dict
from turtlebot_recon.control import (ARRIVED, BLOCKED, ROTATING, ControlInput, TrackingSettings,
                                     make_controller)
from turtlebot_recon.control.footprint import BodyCheck
from turtlebot_recon.control.tracking import PathTracker, clean_path, finite
from turtlebot_recon.planning.navigation import NavigationSettings
from turtlebot_recon.robot import load_robot

RES, ORIGIN, SIZE = 0.05, (-1.0, -1.0), 80
WAFFLE = load_robot("turtlebot3_waffle_pi")


def make_input(pose, path, goal_yaw=None, occupancy=None):
    occ = np.zeros((SIZE, SIZE), np.int8) if occupancy is None else occupancy
    return ControlInput(now_s=0.0, pose=tuple(pose), velocity=(0.0, 0.0),
                        path=np.asarray(path, float), goal_yaw=goal_yaw, occupancy=occ,
                        costmap=np.zeros(occ.shape, np.uint8), resolution=RES, origin=ORIGIN)


def tracker(robot=WAFFLE, **settings):
    return PathTracker(TrackingSettings(**settings), robot, BodyCheck(robot, 0.005))


def boxed_in():
    """Occupancy with walls along x whose edges lie 0.175 m either side of y = 1.025 (rows 36
    and 44): the waffle's 0.306 m wide box fits there facing +x but cannot turn in place."""
    occ = np.zeros((SIZE, SIZE), np.int8)
    occ[36, :] = occ[44, :] = 100
    return occ


@pytest.mark.parametrize("err, w", [(0.1, 0.2), (-0.1, -0.2), (0.4, 0.6), (-0.4, -0.6),
                                    (1.0, 0.8), (-3.0, -0.8)])
def test_turn_rate_is_proportional_between_the_least_and_the_most(err, w):
    assert tracker().turn_rate(err) == pytest.approx(w)


def test_turn_rate_is_capped_by_the_robot():
    slow = dataclasses.replace(WAFFLE, max_angular_radps=0.5)
    assert tracker(slow).turn_rate(2.0) == pytest.approx(0.5)
    assert tracker(rotate_gain_per_s=3.0, rotate_speed_max_radps=1.5).turn_rate(0.4) == pytest.approx(1.2)


def test_turn_is_gated_by_the_bodys_sweep():
    t = tracker()
    free = t.turn(make_input((0.0, 0.0, 0.0), [(0, 0), (1, 0)]), (0.0, 0.0, 0.0), 1.0, (1.0, 0.0), "x")
    assert (free.linear_mps, free.angular_radps, free.status) == (0.0, pytest.approx(0.8), ROTATING)
    inp = make_input((0.0, 1.025, 0.0), [(0, 1.025), (1, 1.025)], occupancy=boxed_in())
    assert BodyCheck(WAFFLE, 0.005).clear(inp, [(0.0, 1.025, 0.0)]).all()
    out = t.turn(inp, (0.0, 1.025, 0.0), 1.0, (1.0, 1.025), "the goal's heading")
    assert (out.linear_mps, out.angular_radps, out.status) == (0.0, 0.0, BLOCKED)
    assert "the goal's heading" in out.detail and "\n" not in out.detail


def test_the_goal_latch_holds_until_a_new_path():
    t = tracker()
    path = [(0.0, 0.0), (2.0, 0.0)]
    t.follow(path)
    assert not t.at_goal(0.3, 0.3)
    assert not t.at_goal(0.05, 0.5)          # near the end in a line, not along the path
    assert t.at_goal(0.08, 0.08)
    assert t.at_goal(0.5, 0.5)               # latched: pushed off, still there
    t.follow(path)                           # the same path again: still latched
    assert t.at_goal(0.5, 0.5)
    t.follow([(0.0, 0.0), (2.0, 0.5)])       # a new path: progress and latch start over
    assert t.progress_m is None and not t.at_goal(0.5, 0.5)


def test_progress_goes_forward_only_within_its_window():
    t = tracker()
    # a U-turn: out along y = 0, back along y = 0.3
    track = t.follow([(0.0, 0.0), (3.0, 0.0), (3.0, 0.3), (0.0, 0.3)])
    assert t.advance(np.array([0.5, 0.25])) == pytest.approx(6.3 - 0.5)   # located whole: the near leg
    t.follow([(0.0, 0.0), (3.0, 0.01)])      # (a new path)
    t.follow([(0.0, 0.0), (3.0, 0.0), (3.0, 0.3), (0.0, 0.3)])
    assert t.advance(np.array([0.5, 0.0])) == pytest.approx(0.5)
    # beside the return leg, still on the first: the window (1 m) keeps it there
    assert t.advance(np.array([1.0, 0.2])) == pytest.approx(1.0)
    assert t.advance(np.array([0.8, 0.0])) == pytest.approx(1.0)          # never back
    assert track.length == pytest.approx(6.3)


def test_arrive_turns_to_the_goals_heading_then_arrives():
    t = tracker()
    pose = (1.0, 1.0, 0.0)
    assert t.arrive(make_input(pose, [(0, 1), (1, 1)]), pose, (1.0, 1.0)).status == ARRIVED
    out = t.arrive(make_input(pose, [(0, 1), (1, 1)], goal_yaw=0.5), pose, (1.0, 1.0))
    assert out.status == ROTATING and out.angular_radps == pytest.approx(0.75)
    out = t.arrive(make_input(pose, [(0, 1), (1, 1)], goal_yaw=0.05), pose, (1.0, 1.0))
    assert out.status == ARRIVED and out.angular_radps == 0.0
    # another law (PD's): the rate the controller gives
    out = t.arrive(make_input(pose, [(0, 1), (1, 1)], goal_yaw=-1.0), pose, (1.0, 1.0), lambda e: 2 * e)
    assert out.angular_radps == pytest.approx(-2.0)


def test_path_and_number_reading():
    assert clean_path([(0, 0), (0, 0), (1, 0), (np.nan, 1), (2, 0)]).tolist() == [[0, 0], [1, 0], [2, 0]]
    assert clean_path([(0, 0)]) is None and clean_path("no") is None
    assert finite((1, 2, 3, 4), 3) == (1.0, 2.0, 3.0)
    assert finite((1, math.inf), 2) is None and finite((1,), 2) is None and finite(None, 1) is None


def test_settings_are_checked():
    with pytest.raises(ConfigError, match="rotate_speed_min_radps"):
        from_dict(TrackingSettings, {"rotate_speed_min_radps": 1.0}, "tracking")
    with pytest.raises(ConfigError, match="rotate_threshold_rad"):
        from_dict(TrackingSettings, {"rotate_threshold_rad": 4.0}, "tracking")


# ------------------------------------------------------------------ the controllers use it

GOAL_STEP = dict(pose=(1.0, 1.025, 0.0), path=[(0.0, 1.025), (1.0, 1.025)], goal_yaw=1.0)


@pytest.mark.parametrize("name", ["pure_pursuit", "dwa", "mppi", "tube_mppi"])
def test_controllers_turn_at_the_goal_by_the_shared_law_and_block(name):
    """At the goal, 1 rad off its heading: each turns at the tracking block's rate (0.8 by
    default, 0.5 with rotate_speed_max_radps 0.5), stays latched when pushed 0.3 m off, and
    reports the turn blocked where the body cannot sweep."""
    for top in (0.8, 0.5):
        ctl = make_controller(name, None, WAFFLE, TrackingSettings(rotate_speed_max_radps=top))
        out = ctl.compute(make_input(**GOAL_STEP))
        assert (out.linear_mps, out.status) == (0.0, ROTATING) and out.angular_radps == pytest.approx(top)
        out = ctl.compute(make_input((1.3, 1.025, 1.0), GOAL_STEP["path"], goal_yaw=1.0))
        assert out.status == ARRIVED                   # latched: only the heading counts
    ctl = make_controller(name, None, WAFFLE, None)
    out = ctl.compute(make_input(**GOAL_STEP, occupancy=boxed_in()))
    assert (out.linear_mps, out.angular_radps, out.status) == (0.0, 0.0, BLOCKED), out


def test_pd_turns_at_the_goal_by_its_own_loop():
    """PD shares the latch, the gate and the least rate, and turns at its loop's rate
    (angular_kp_per_s x error, up to the robot's maximum, not the tracking's)."""
    ctl = make_controller("pd", None, WAFFLE, TrackingSettings(rotate_speed_min_radps=0.3))
    out = ctl.compute(make_input(**GOAL_STEP))
    assert out.status == ROTATING and out.angular_radps == pytest.approx(1.0)
    out = ctl.compute(make_input((1.0, 1.025, 0.95), GOAL_STEP["path"], goal_yaw=1.0))
    assert out.status == ARRIVED                       # within yaw_goal_tolerance_rad
    out = ctl.compute(make_input((1.3, 1.025, 0.95), GOAL_STEP["path"], goal_yaw=1.0))
    assert out.status == ARRIVED                       # latched
    ctl = make_controller("pd", None, WAFFLE, TrackingSettings(rotate_speed_min_radps=0.3,
                                                                yaw_goal_tolerance_rad=0.05))
    out = ctl.compute(make_input((1.0, 1.025, 0.9), GOAL_STEP["path"], goal_yaw=1.0))
    assert out.status == ROTATING and out.angular_radps == pytest.approx(0.3)   # the floor


def test_the_navigator_passes_its_one_tracking_block():
    from turtlebot_recon.planning.navigation import Navigation
    tracking = TrackingSettings(xy_goal_tolerance_m=0.2, rotate_gain_per_s=1.0)
    for name in ("pure_pursuit", "dwa", "pd", "mppi", "tube_mppi"):
        nav = Navigation(NavigationSettings(robot="turtlebot3_waffle_pi", controller=name,
                                            tracking=tracking), WAFFLE)
        assert nav.controller.tracker.settings is tracking
        if nav.takeover is not None:
            assert nav.takeover.tracker.settings is tracking
