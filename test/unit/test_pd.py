"""Seed 003's PD follower (control/pd.py): turn in place to each segment, drive it with two PD
loops, stop at its end; the look-ahead collision check with the oriented footprint."""
import math

import numpy as np
import pytest

from conftest import corridor_ahead, drive_controller, walled_room
from turtlebot_recon import _native
from turtlebot_recon.config import ConfigError, from_dict
from turtlebot_recon.control import (BLOCKED, ROTATING, ControlInput, PdController, PdSettings,
                                     make_controller)
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH
from turtlebot_recon.robot import footprint_args, load_robot

RES = 0.05
WAFFLE = load_robot("turtlebot3_waffle_pi")
BURGER = load_robot("turtlebot3_burger")


def body_clearance(robot, occ, poses, res=RES):
    return _native.footprint_clearance(occ, res, (0.0, 0.0), np.asarray(poses, float).reshape(-1, 3),
                                       **footprint_args(robot), max_m=0.1, occupied_threshold=OCCUPIED_THRESH,
                                       unknown_is_obstacle=False)


def step(ctl, pose, path, velocity=(0.0, 0.0), occ=None, now=0.0):
    occ = walled_room() if occ is None else occ
    return ctl.compute(ControlInput(now, pose, velocity, np.asarray(path, float), None, occ,
                                    np.zeros(occ.shape, np.uint8), RES, (0.0, 0.0)))


def test_turns_in_place_first_then_drives_with_the_pd_loops():
    ctl = PdController(PdSettings(), BURGER)
    # the segment points 90 deg left: turn in place, w = kp e = 1 x 1.57 (no derivative yet)
    out = step(ctl, (1.0, 1.0, 0.0), [(1.0, 1.0), (1.0, 2.5)])
    assert out.status == ROTATING and out.linear_mps == 0.0
    assert out.angular_radps == pytest.approx(math.atan2(0.3, 0.0))
    # facing it (error 0 < 0.1 rad): v = kp d = 1 x 1.5 m -> the robot's 0.22 m/s, within one
    # period's acceleration of the measured 0.2 m/s (0.2 + 2.5 x 0.1)
    ctl.reset()
    out = step(ctl, (1.0, 1.0, math.pi / 2), [(1.0, 1.0), (1.0, 2.5)], velocity=(0.2, 0.0))
    assert out.status == "following" and out.linear_mps == pytest.approx(0.22)
    assert out.angular_radps == pytest.approx(0.0, abs=1e-9)
    # near the end: v = kp d + kd dd/dt; 0.3 m left after 0.4 m left 0.1 s before:
    # 1 x 0.3 + 0.3 x (-1.0) = 0.0
    ctl.reset()
    step(ctl, (1.0, 2.1, math.pi / 2), [(1.0, 1.0), (1.0, 2.5)], velocity=(0.2, 0.0), now=0.0)
    out = step(ctl, (1.0, 2.2, math.pi / 2), [(1.0, 1.0), (1.0, 2.5)], velocity=(0.2, 0.0), now=0.1)
    assert out.linear_mps == pytest.approx(0.0, abs=1e-9)


def test_bad_input_stops_and_says_why():
    ctl = PdController(PdSettings(), BURGER)
    for pose in [(math.nan, 1.0, 0.0), (1.0, 1.0, math.inf)]:
        out = step(ctl, pose, [(1.0, 1.0), (2.0, 1.0)])
        assert (out.linear_mps, out.angular_radps, out.status) == (0.0, 0.0, BLOCKED)
        assert "not finite" in out.detail
    out = step(ctl, (1.0, 1.0, 0.0), np.zeros((0, 2)))
    assert (out.linear_mps, out.angular_radps, out.status) == (0.0, 0.0, "no_path")
    # a NaN velocity only loses the acceleration cap's reference: a finite command
    out = step(ctl, (1.0, 1.0, 0.0), [(1.0, 1.0), (2.0, 1.0)], velocity=(math.nan, math.nan))
    assert math.isfinite(out.linear_mps) and math.isfinite(out.angular_radps)
    with pytest.raises(ConfigError, match="pd/heading_abort_rad: must be >= heading_tolerance_rad"):
        from_dict(PdSettings, {"heading_abort_rad": 0.05}, "pd")


def test_reaches_a_goal_round_corners_on_an_empty_map_within_the_limits():
    occ = walled_room()
    path = [(0.6, 0.6), (2.0, 0.6), (2.0, 2.2), (3.2, 2.2)]
    poses, outs = drive_controller(make_controller("pd", None, WAFFLE), WAFFLE, occ, path,
                                   (0.6, 0.6, 1.0), 60.0, goal_yaw=math.pi)
    assert outs[-1].status == "arrived", outs[-1].detail
    assert math.dist(poses[-1][:2], (3.2, 2.2)) < 0.1 + 0.03
    assert abs(math.remainder(poses[-1][2] - math.pi, 2 * math.pi)) < 0.1 + 0.05
    v = np.array([o.linear_mps for o in outs])
    w = np.array([o.angular_radps for o in outs])
    assert np.isfinite(v).all() and np.isfinite(w).all()
    assert (v >= 0).all() and v.max() <= WAFFLE.max_linear_mps + 1e-12
    assert np.abs(w).max() <= WAFFLE.max_angular_radps + 1e-12
    # it passes each corner within a few centimetres (it stops on it and turns there)
    for corner in path[1:3]:
        assert np.hypot(poses[:, 0] - corner[0], poses[:, 1] - corner[1]).min() < 0.04
    assert body_clearance(WAFFLE, occ, poses).min() >= 0.005


def test_refuses_to_drive_into_a_wall():
    occ = walled_room()
    occ[:, 40:42] = 100                                 # wall x in [2.0, 2.1) across the room
    poses, outs = drive_controller(PdController(PdSettings(), BURGER), BURGER, occ,
                                   [(0.6, 1.5), (3.5, 1.5)], (0.6, 1.5, 0.0), 40.0)
    assert outs[-1].status == BLOCKED and "obstacle" in outs[-1].detail
    assert poses[:, 0].max() + BURGER.radius_m < 2.0
    assert body_clearance(BURGER, occ, poses).min() >= 0.005


@pytest.mark.parametrize("width_m, fits", [(0.40, True), (0.29, False)])
def test_waffle_drives_down_a_040_corridor_and_refuses_a_029_one(width_m, fits):
    res = 0.01
    occ = corridor_ahead(width_m, res)
    poses, outs = drive_controller(PdController(PdSettings(), WAFFLE), WAFFLE, occ,
                                   [(0.3, 1.0), (2.8, 1.0)], (0.3, 1.0, 0.0), 30.0, res=res)
    assert body_clearance(WAFFLE, occ, poses, res).min() >= 0.005 - 1e-9
    if fits:
        assert outs[-1].status == "arrived", outs[-1].detail
        assert np.abs(poses[:, 1] - 1.0).max() < 0.01
    else:
        assert outs[-1].status == BLOCKED and outs[-1].detail
        assert poses[:, 0].max() < 0.6
