"""DWA (include/turtlebot_recon/dwa.hpp, control/dwa.py): the obvious command in hand-built
cases, the dynamic window, bad input, and closed loop with the oriented footprint."""
import math

import numpy as np
import pytest

from conftest import corridor_ahead, drive_controller, walled_room
from turtlebot_recon import _native
from turtlebot_recon.control import (BLOCKED, ControlInput, DwaController, DwaSettings,
                                     make_controller)
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH
from turtlebot_recon.robot import footprint_args, load_robot

RES = 0.05
WAFFLE = load_robot("turtlebot3_waffle_pi")
BURGER = load_robot("turtlebot3_burger")


class NativeDwa(_native.Dwa):
    """The bound sampler, whose plan takes every argument: no goal radius, the goal far away and
    no path ahead unless a test gives its own."""

    def plan(self, *step, goal_radius_m=0.0, goal_distance_m=math.inf, path_ahead=np.zeros((0, 3))):
        return super().plan(*step, goal_radius_m=goal_radius_m, goal_distance_m=goal_distance_m,
                            path_ahead=path_ahead)


def native_dwa(robot=WAFFLE, **kw):
    """The sampler with config/dwa.yaml's values (DwaSettings, as DwaController passes them),
    forward only, ``kw`` changed."""
    s = DwaSettings()
    args = dict(min_linear_mps=0.0, outline_spacing_m=s.outline_spacing_m, linear_samples=s.linear_samples,
                angular_samples=s.angular_samples, horizon_s=s.horizon_s, dt_s=s.dt_s,
                margin_m=s.collision_margin_m, clearance_max_m=s.clearance_max_m,
                unknown_is_obstacle=s.unknown_is_collision, occupied_threshold=OCCUPIED_THRESH,
                heading_weight=s.heading_weight, clearance_weight=s.clearance_weight,
                velocity_weight=s.velocity_weight)
    return NativeDwa(max_linear_mps=robot.max_linear_mps, max_angular_radps=robot.max_angular_radps,
                     linear_accel_mps2=robot.max_linear_accel_mps2,
                     angular_accel_radps2=robot.max_angular_accel_radps2, **footprint_args(robot),
                     **{**args, **kw})


def corridor(width_cells=8, cols=200):
    """A corridor along +x, ``width_cells`` cells wide, centred on y = 1 m (8: y in [0.8, 1.2))."""
    occ = np.full((40, cols), 100, np.int8)
    occ[20 - width_cells // 2:20 + width_cells // 2, :] = 0
    return occ


def body_clearance(robot, occ, poses, res):
    """The exact check (footprint.hpp): metres from the body to the nearest obstacle, <= 0.1."""
    return _native.footprint_clearance(occ, res, (0.0, 0.0), np.asarray(poses, float).reshape(-1, 3),
                                       **footprint_args(robot), max_m=0.1, occupied_threshold=OCCUPIED_THRESH,
                                       unknown_is_obstacle=False)


def test_straight_corridor_goes_forward_at_the_top_of_the_window():
    # Standing in a 0.40 m corridor facing along it, target 1 m ahead: the window is
    # v in [0, a T] = [0, 2.5 x 0.1] = [0, 0.25] m/s, w in [-0.32, 0.32] rad/s; the best arc is
    # the fastest, the straightest there is (20 samples over w: +-0.32 / 19 = +-0.0168 rad/s).
    dwa = native_dwa()
    r = dwa.plan(corridor(), RES, (0.0, 0.0), (2.0, 1.0, 0.0), (0.0, 0.0), 0.1, (3.0, 1.0), (9.0, 1.0))
    assert r["window"] == pytest.approx((0.0, 0.25, -0.32, 0.32))
    b = r["best"]
    assert r["v"][b] == pytest.approx(0.25) and abs(r["w"][b]) == pytest.approx(0.32 / 19)
    # at full speed the top of the window is the robot's limit
    r = dwa.plan(corridor(), RES, (0.0, 0.0), (2.0, 1.0, 0.0), (0.26, 0.0), 0.1, (3.0, 1.0), (9.0, 1.0))
    assert r["window"][:2] == pytest.approx((0.01, 0.26)) and r["v"][r["best"]] == pytest.approx(0.26)
    assert len(r["v"]) == 400 and r["trajectory"].shape[1] == 3
    assert r["trajectory"][-1, 0] == pytest.approx(2.0 + 0.26 * 2.0, abs=0.01)   # 2 s at 0.26


def test_window_respects_the_accelerations_and_the_limits():
    dwa = native_dwa(linear_samples=5, angular_samples=7)
    occ = np.zeros((100, 100), np.int8)
    r = dwa.plan(occ, RES, (0.0, 0.0), (2.5, 2.5, 0.0), (0.1, 1.8), 0.05, (3.5, 2.5), (4.0, 2.5))
    v_lo, v_hi, w_lo, w_hi = r["window"]
    # v 0.1 +- 2.5 x 0.05 = [-0.025 -> 0, 0.225]; w 1.8 +- 3.2 x 0.05 = [1.64, 1.96 -> 1.82]
    assert (v_lo, v_hi, w_lo, w_hi) == pytest.approx((0.0, 0.225, 1.64, 1.82))
    assert r["v"].min() >= 0.0 and r["v"].max() <= 0.225 + 1e-12
    assert r["w"].min() >= 1.64 - 1e-12 and r["w"].max() <= 1.82 + 1e-12
    assert len(np.unique(r["v"])) == 5 and len(np.unique(r["w"])) == 7


def test_wall_ahead_turns_away_or_stops():
    # A wall 0.25 m in front of the burger's disc (x = 2.35): driving straight on collides
    # within the horizon, so straight arcs are inadmissible; the best arc turns or is slow
    # enough to stay clear for 2 s.
    occ = np.zeros((80, 80), np.int8)
    occ[:, 48:] = 100                                   # wall at x >= 2.4
    dwa = native_dwa(BURGER)
    r = dwa.plan(occ, RES, (0.0, 0.0), (2.0, 2.0, 0.0), (0.2, 0.0), 0.1, (3.0, 2.0), (3.0, 2.0))
    straight = np.flatnonzero((np.abs(r["w"]) < 0.2) & (r["v"] > 0.15))
    assert not r["admissible"][straight].any()
    b = r["best"]
    end = r["trajectory"][-1]
    assert b < 0 or end[0] + BURGER.radius_m < 2.4      # its body never reaches the wall
    assert body_clearance(BURGER, occ, r["trajectory"], RES).min() > 0.0


def test_every_arc_in_collision_is_blocked_with_one_line():
    # The waffle's box (x in [-0.2045, 0.0765], y in [-0.153, 0.153] about base_footprint) in a
    # pocket a few millimetres larger (1 cm cells): every arc of the window brings it nearer a
    # wall than it stands (turning in place swings its corners), so none is admissible.
    res = 0.01
    occ = np.full((200, 200), 100, np.int8)
    occ[84:116, 79:108] = 0                             # x in [0.79, 1.08), y in [0.84, 1.16)
    ctl = DwaController(DwaSettings(), WAFFLE)
    out = ctl.compute(ControlInput(0.0, (1.0, 1.0, 0.0), (0.0, 0.0), np.array([[1.0, 1.0], [3.0, 1.0]]),
                                   None, occ, np.zeros(occ.shape, np.uint8), res, (0.0, 0.0)))
    assert ctl.last_plan["best"] == -1 and not ctl.last_plan["admissible"].any()
    assert out.status == BLOCKED and (out.linear_mps, out.angular_radps) == (0.0, 0.0)
    assert out.detail.startswith("no admissible arc: all 400") and "\n" not in out.detail


@pytest.mark.parametrize("pose, velocity, why", [
    ((math.nan, 1.0, 0.0), (0.0, 0.0), "pose is not finite"),
    ((1.0, 1.0, math.inf), (0.0, 0.0), "pose is not finite"),
    ((1.0, 1.0, 0.0), (math.nan, 0.0), "velocity is not finite"),
])
def test_a_nan_pose_or_velocity_gives_a_zero_command(pose, velocity, why):
    occ = walled_room()
    ctl = DwaController(DwaSettings(), BURGER)
    out = ctl.compute(ControlInput(0.0, pose, velocity, np.array([[1.0, 1.0], [3.0, 2.0]]), None,
                                   occ, np.zeros(occ.shape, np.uint8), RES, (0.0, 0.0)))
    assert (out.linear_mps, out.angular_radps, out.status) == (0.0, 0.0, BLOCKED) and why in out.detail


def test_empty_path_and_bad_arguments():
    occ = walled_room()
    ctl = make_controller("dwa", None, BURGER)
    out = ctl.compute(ControlInput(0.0, (1.0, 1.0, 0.0), (0.0, 0.0), np.zeros((0, 2)), None, occ,
                                   np.zeros(occ.shape, np.uint8), RES, (0.0, 0.0)))
    assert (out.linear_mps, out.angular_radps, out.status) == (0.0, 0.0, "no_path")
    with pytest.raises(ValueError, match="Dwa: dwa: horizon_s must be > 0"):
        native_dwa(horizon_s=0.0)
    with pytest.raises(ValueError, match="Dwa.plan: occupancy must be a 2-D"):
        native_dwa().plan(np.zeros(5, np.int8), RES, (0, 0), (0, 0, 0), (0, 0), 0.1, (1, 0), (1, 0))
    with pytest.raises(ValueError, match="Dwa.plan: pose and origin must be finite"):
        native_dwa().plan(occ, RES, (0, 0), (math.nan, 0, 0), (0, 0), 0.1, (1, 0), (1, 0))


def test_reaches_a_goal_on_an_empty_map_within_the_limits():
    occ = walled_room()
    ctl = DwaController(DwaSettings(), WAFFLE)
    poses, outs = drive_controller(ctl, WAFFLE, occ, [(0.6, 0.6), (3.0, 2.2)], (0.6, 0.6, -1.0), 40.0)
    assert outs[-1].status == "arrived", outs[-1].detail
    assert math.dist(poses[-1][:2], (3.0, 2.2)) < 0.1 + 0.03
    v = np.array([o.linear_mps for o in outs])
    w = np.array([o.angular_radps for o in outs])
    assert np.isfinite(v).all() and np.isfinite(w).all()
    assert (v >= 0).all() and v.max() <= WAFFLE.max_linear_mps + 1e-12
    assert np.abs(w).max() <= WAFFLE.max_angular_radps + 1e-12
    assert body_clearance(WAFFLE, occ, poses, RES).min() >= 0.005


def test_refuses_to_drive_into_a_wall():
    # The path runs through a wall the map shows (a stale plan): the robot stops before it.
    occ = walled_room()
    occ[:, 40:42] = 100                                 # wall x in [2.0, 2.1)
    ctl = DwaController(DwaSettings(), BURGER)
    poses, outs = drive_controller(ctl, BURGER, occ, [(0.6, 1.5), (3.5, 1.5)], (0.6, 1.5, 0.0), 40.0)
    assert outs[-1].status == BLOCKED and outs[-1].detail
    assert poses[:, 0].max() + BURGER.radius_m < 2.0
    assert body_clearance(BURGER, occ, poses, RES).min() >= 0.005


@pytest.mark.parametrize("width_m, fits", [(0.40, True), (0.29, False)])
def test_waffle_drives_down_a_040_corridor_and_refuses_a_029_one(width_m, fits):
    # The waffle_pi's box is 0.306 m wide: 0.047 m either side in 0.40 m; 0.29 m is narrower
    # than the box (its turning disc, 0.514 m across, fits neither). 1 cm cells.
    res = 0.01
    occ = corridor_ahead(width_m, res)
    ctl = DwaController(DwaSettings(), WAFFLE)
    poses, outs = drive_controller(ctl, WAFFLE, occ, [(0.3, 1.0), (2.8, 1.0)], (0.3, 1.0, 0.0), 30.0,
                                   res=res)
    assert body_clearance(WAFFLE, occ, poses, res).min() >= 0.005 - 1e-9
    if fits:
        assert outs[-1].status == "arrived", outs[-1].detail
        assert np.abs(poses[:, 1] - 1.0).max() < 0.03    # straight down the middle
    else:
        assert outs[-1].status == BLOCKED and outs[-1].detail
        assert poses[:, 0].max() < 0.6                   # never entered
