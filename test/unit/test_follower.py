"""Pure pursuit follower (control/follower.py): carrot, curvature, speed limits, turning in place,
goal handling, progress along the path, seed 003's look-ahead collision check, closed loop.

Robot: TurtleBot3 waffle_pi (v_max 0.26 m/s, w_max 1.82 rad/s, a 2.5 m/s^2) unless stated.
Costmaps are 5 cm grids with origin (-1, -1): column c spans x in [-1 + 0.05 c, -1 + 0.05 (c + 1)).
Default settings: L_d in [0.3, 0.9] m = 1.5 s x |v|, rotate beyond 1.047 rad at
w = clamp(1.5 err, 0.2, 0.8), xy / yaw tolerance 0.1, horizon 1.5 s, stop distance 0.1 m.
"""
import dataclasses
import math

import numpy as np
import pytest

from turtlebot_recon.config import ConfigError, from_dict
from turtlebot_recon.control import (STATUSES, ControlInput, ControlOutput, Controller,
                                     FollowerSettings, PurePursuit)
from turtlebot_recon.planning import CostmapSettings, make_costmap
from turtlebot_recon.robot import load_robot

RES = 0.05
ORIGIN = (-1.0, -1.0)
FREE, INSCRIBED, LETHAL, UNKNOWN = 0, 253, 254, 255
WAFFLE = load_robot("turtlebot3_waffle_pi")
V_MAX, W_MAX = WAFFLE.max_linear_mps, WAFFLE.max_angular_radps


# ---------------------------------------------------------------- factories

def empty_costmap(size=80, value=FREE):
    """size x size cells of ``value``: x, y in [-1, -1 + 0.05 size)."""
    return np.full((size, size), value, np.uint8)


def with_band(costmap, x_from, x_to, value):
    """Set every cell whose column lies in [x_from, x_to) to ``value`` (a wall across +x)."""
    out = costmap.copy()
    c0, c1 = (int(round((x - ORIGIN[0]) / RES)) for x in (x_from, x_to))
    out[:, c0:c1] = value
    return out


def occupancy_of(costmap):
    """The occupancy a costmap stands for: lethal cells are obstacles (100), unknown ones -1."""
    costmap = np.asarray(costmap)
    occ = np.zeros(costmap.shape, np.int8)
    occ[costmap == LETHAL] = 100
    occ[costmap == UNKNOWN] = -1
    return occ


def make_input(pose, path, velocity=(0.0, 0.0), goal_yaw=None, costmap=None, now_s=0.0,
               resolution=RES, origin=ORIGIN, occupancy=None):
    """A ControlInput; the occupancy defaults to the costmap's obstacles and unknown cells."""
    costmap = empty_costmap() if costmap is None else costmap
    return ControlInput(now_s=now_s, pose=tuple(pose), velocity=tuple(velocity),
                        path=np.asarray(path, dtype=float), goal_yaw=goal_yaw,
                        occupancy=occupancy_of(costmap) if occupancy is None else occupancy,
                        costmap=costmap, resolution=resolution, origin=origin)


def follower(robot=WAFFLE, **settings):
    return PurePursuit(FollowerSettings(**settings), robot)


def drive(ctrl, path, costmap, pose, seconds, robot=WAFFLE, goal_yaw=None, origin=ORIGIN,
          on_step=None):
    """Close the loop at 10 Hz on a unicycle whose speeds follow the command within the robot's
    accelerations (10 Euler substeps per period). Returns [(t, pose, output)], ending at the
    first "arrived" or "blocked"; ``on_step(t, costmap) -> costmap`` may change the map."""
    dt, sub = 0.1, 10
    x, y, yaw = pose
    v = w = 0.0
    trace = []
    for k in range(int(round(seconds / dt))):
        t = k * dt
        if on_step is not None:
            costmap = on_step(t, costmap)
        out = ctrl.compute(make_input((x, y, yaw), path, (v, w), goal_yaw, costmap, t,
                                      origin=origin))
        trace.append((t, (x, y, yaw), out))
        if out.status in ("arrived", "blocked"):
            break
        for _ in range(sub):
            h = dt / sub
            v += np.clip(out.linear_mps - v, -robot.max_linear_accel_mps2 * h,
                         robot.max_linear_accel_mps2 * h)
            w += np.clip(out.angular_radps - w, -robot.max_angular_accel_radps2 * h,
                         robot.max_angular_accel_radps2 * h)
            x, y, yaw = x + v * math.cos(yaw) * h, y + v * math.sin(yaw) * h, yaw + w * h
    return trace


def cost_at(costmap, x, y, origin=ORIGIN):
    row, col = (int(math.floor((v - o) / RES)) for v, o in ((y, origin[1]), (x, origin[0])))
    return int(costmap[row, col])


def check_output(out, robot=WAFFLE):
    assert isinstance(out, ControlOutput) and out.status in STATUSES
    assert math.isfinite(out.linear_mps) and math.isfinite(out.angular_radps)
    assert 0.0 <= out.linear_mps <= robot.max_linear_mps
    assert abs(out.angular_radps) <= robot.max_angular_radps
    if out.lookahead is not None:
        assert all(math.isfinite(v) for v in out.lookahead)


# ---------------------------------------------------------------- settings and contract

def test_bad_settings_are_rejected():
    with pytest.raises(ConfigError, match="lookahead_max_m"):
        from_dict(FollowerSettings, {"lookahead_min_m": 1.0, "lookahead_max_m": 0.5}, "src")
    with pytest.raises(ConfigError, match="rotate_speed_min_radps"):
        from_dict(FollowerSettings, {"rotate_speed_min_radps": 1.0}, "src")
    with pytest.raises(ConfigError, match="near_obstacle_speed_fraction"):
        from_dict(FollowerSettings, {"near_obstacle_speed_fraction": 1.5}, "src")
    with pytest.raises(ConfigError, match="collision_horizon_s"):
        from_dict(FollowerSettings, {"collision_horizon_s": 0.0}, "src")


def test_pure_pursuit_is_a_controller():
    assert isinstance(follower(), Controller)


# ---------------------------------------------------------------- carrot, curvature, speed

def test_straight_path_full_speed_no_turn():
    # measured v 0.26 -> L_d = 1.5 x 0.26 = 0.39 m: carrot (0.39, 0), alpha = 0 -> w = 0;
    # 2.5 m from the goal sqrt(2 x 2.5 x 2.5) = 3.5 m/s does not bind -> v = v_max
    out = follower().compute(make_input((0.0, 0.0, 0.0), [(0, 0), (2.5, 0)], velocity=(V_MAX, 0)))
    assert out.status == "following"
    assert out.linear_mps == pytest.approx(V_MAX)
    assert out.angular_radps == pytest.approx(0.0, abs=1e-12)
    assert out.lookahead == pytest.approx((0.39, 0.0))


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_turn_curvature_from_hand_computed_carrot(side):
    # standing still: L_d = 0.3 m. Path (0,0) -> (0.2,0) -> (0.2, 1.0 side): the carrot is 0.1 m up
    # the second leg, (0.2, 0.1 side). D = sqrt(0.2^2 + 0.1^2) = 0.2236, sin(alpha) = 0.1 / D,
    # kappa = 2 sin(alpha) / D = 2 x 0.1 / 0.05 = 4.0 /m. w_max / kappa = 0.455 > 0.26, so
    # v = 0.26 and w = 4.0 x 0.26 = 1.04 rad/s, counter-clockwise (+) for a left turn.
    out = follower().compute(make_input((0.0, 0.0, 0.0), [(0, 0), (0.2, 0), (0.2, side)]))
    assert out.status == "following"
    assert out.lookahead == pytest.approx((0.2, 0.1 * side))
    assert out.linear_mps == pytest.approx(V_MAX)
    assert out.angular_radps == pytest.approx(side * 4.0 * V_MAX)


def test_sharp_curvature_slows_down():
    # same carrot, kappa = 4.0 /m, on a robot with w_max 0.5 rad/s: v = 0.5 / 4 = 0.125, w = 0.5
    slow_turner = dataclasses.replace(WAFFLE, max_angular_radps=0.5)
    out = follower(slow_turner).compute(make_input((0.0, 0.0, 0.0), [(0, 0), (0.2, 0), (0.2, 1)]))
    assert out.linear_mps == pytest.approx(0.125)
    assert out.angular_radps == pytest.approx(0.5)


def test_lookahead_scales_with_speed_between_limits():
    path = [(0, 0), (3.0, 0)]
    # 0.1 m/s -> 0.15 m, below the minimum 0.3; 0.4 m/s -> 0.6 m; 1.0 m/s -> 1.5, above the max 0.9
    for v_meas, expected in [(0.1, 0.3), (0.4, 0.6), (1.0, 0.9), (-0.4, 0.6)]:
        out = follower().compute(make_input((0.0, 0.0, 0.0), path, velocity=(v_meas, 0)))
        assert out.lookahead == pytest.approx((expected, 0.0))


def test_decelerates_to_the_goal_with_the_robot_acceleration():
    gentle = dataclasses.replace(WAFFLE, max_linear_accel_mps2=0.1)
    path = [(0, 0), (1.0, 0)]
    # 0.2 m left: v = sqrt(2 x 0.1 x 0.2) = 0.2 m/s < 0.26; the carrot is the goal, alpha = 0
    out = follower(gentle).compute(make_input((0.8, 0.0, 0.0), path, velocity=(0.2, 0)))
    assert out.status == "following"
    assert out.linear_mps == pytest.approx(math.sqrt(2 * 0.1 * 0.2))
    assert out.lookahead == pytest.approx((1.0, 0.0))
    # 0.12 m left, just outside the 0.1 m tolerance: sqrt(2 x 0.1 x 0.12) = 0.155
    out = follower(gentle).compute(make_input((0.88, 0.0, 0.0), path, velocity=(0.2, 0)))
    assert out.linear_mps == pytest.approx(math.sqrt(2 * 0.1 * 0.12))
    # 0.5 m left: sqrt(0.1) = 0.316 > v_max -> 0.26
    out = follower(gentle).compute(make_input((0.5, 0.0, 0.0), path, velocity=(0.2, 0)))
    assert out.linear_mps == pytest.approx(V_MAX)


def test_slows_down_on_costly_cells():
    # cost 126 everywhere (no collision cell): v = 0.26 x (1 - (1 - 0.5) x 126 / 252) = 0.195
    out = follower().compute(make_input((0.0, 0.0, 0.0), [(0, 0), (2.5, 0)],
                                        costmap=empty_costmap(value=126)))
    assert out.status == "following"
    assert out.linear_mps == pytest.approx(0.195)


# ---------------------------------------------------------------- turning in place, goal

@pytest.mark.parametrize("goal, sign", [((0.0, 1.5), 1.0), ((0.0, -1.5), -1.0)])
def test_rotates_in_place_beyond_the_threshold(goal, sign):
    # carrot 90 deg off the heading > 60 deg: v = 0, w = sign x min(1.5 x pi/2, 0.8, 1.82) = 0.8
    out = follower().compute(make_input((0.0, 0.0, 0.0), [(0, 0), goal]))
    assert out.status == "rotating"
    assert out.linear_mps == 0.0
    assert out.angular_radps == pytest.approx(sign * 0.8)


@pytest.mark.parametrize("bearing_deg, status", [(50.0, "following"), (70.0, "rotating")])
def test_rotate_threshold_is_60_degrees(bearing_deg, status):
    b = math.radians(bearing_deg)
    path = [(0, 0), (2 * math.cos(b), 2 * math.sin(b))]
    out = follower().compute(make_input((0.0, 0.0, 0.0), path))
    assert out.status == status
    assert out.angular_radps > 0        # both turn left (counter-clockwise)


def test_arrival_within_xy_tolerance():
    path = [(0, 0), (1.0, 0)]
    out = follower().compute(make_input((0.95, 0.03, 0.3), path))   # 0.058 m from the goal
    assert (out.status, out.linear_mps, out.angular_radps) == ("arrived", 0.0, 0.0)
    out = follower().compute(make_input((0.85, 0.0, 0.0), path))    # 0.15 m: not yet
    assert out.status == "following" and out.linear_mps > 0


def test_arrival_needs_progress_along_a_closed_loop():
    # the goal (0, 0.05) is 0.05 m from the start, but the whole loop lies ahead
    loop = [(0, 0), (1, 0), (1, 1), (0, 1), (0, 0.05)]
    out = follower().compute(make_input((0.0, 0.0, 0.0), loop))
    assert out.status == "following"


def test_turns_to_the_goal_yaw_then_arrives():
    ctrl = follower()
    path = [(0, 0), (1.0, 0)]
    # at the goal, yaw error +pi/2: w = min(1.5 x 1.571, 0.8) = +0.8
    out = ctrl.compute(make_input((1.0, 0.0, 0.0), path, goal_yaw=math.pi / 2))
    assert (out.status, out.linear_mps, out.angular_radps) == ("rotating", 0.0, pytest.approx(0.8))
    # error -0.3: w = -1.5 x 0.3 = -0.45; error 0.12: 1.5 x 0.12 = 0.18 -> the 0.2 floor
    out = ctrl.compute(make_input((1.0, 0.0, 0.3), path, goal_yaw=0.0))
    assert out.angular_radps == pytest.approx(-0.45)
    out = ctrl.compute(make_input((1.0, 0.0, -0.12), path, goal_yaw=0.0))
    assert out.angular_radps == pytest.approx(0.2)
    # the xy tolerance is latched: drifting to 0.12 m while turning does not restart following
    out = ctrl.compute(make_input((0.88, 0.0, 1.0), path, goal_yaw=math.pi / 2))
    assert out.status == "rotating" and out.linear_mps == 0.0
    # within 0.1 rad (also across the +-pi wrap): arrived
    out = ctrl.compute(make_input((1.0, 0.0, 1.5), path, goal_yaw=math.pi / 2))
    assert out.status == "arrived"
    out = follower().compute(make_input((1.0, 0.0, -3.1), path, goal_yaw=3.1))   # 0.083 rad apart
    assert out.status == "arrived"


# ---------------------------------------------------------------- progress along the path

def test_progress_never_goes_backwards_nor_jumps_a_u_turn():
    # U: leg 1 (0,0) -> (2,0), bend up to (2,0.6), leg 2 back to (0,0.6); arc lengths
    # leg 1 s in [0, 2], bend [2, 2.6], leg 2 [2.6, 4.6] at x = 2 - (s - 2.6). L_d = 0.3 (v = 0).
    path = [(0, 0), (2, 0), (2, 0.6), (0, 0.6)]
    ctrl = follower()
    assert ctrl.compute(make_input((0.0, 0.0, 0.0), path)).lookahead == pytest.approx((0.3, 0.0))
    # 0.35 m from leg 1, 0.25 m from leg 2: the search window s in [0, 1] holds leg 1 only, so the
    # closest point is (0.5, 0), the carrot (0.8, 0) -- not (0.2, 0.6) on leg 2
    out = ctrl.compute(make_input((0.5, 0.35, 0.0), path))
    assert out.lookahead == pytest.approx((0.8, 0.0))
    for pose in [(1.5, 0.0, 0.0), (2.0, 0.3, math.pi / 2), (1.4, 0.6, math.pi)]:
        ctrl.compute(make_input(pose, path))             # progress s = 1.5, 2.3, 3.2
    # back near leg 1 (0.25 m) rather than leg 2 (0.35 m): progress stays on leg 2,
    # closest (1.0, 0.6) at s = 3.6, carrot s = 3.9 -> (0.7, 0.6), not (1.3, 0) on leg 1
    out = ctrl.compute(make_input((1.0, 0.25, math.pi), path))
    assert out.lookahead == pytest.approx((0.7, 0.6))
    # a new path restarts progress (searched whole once); reset() forgets it too
    out = ctrl.compute(make_input((1.0, 0.25, math.pi), [(1.0, 0.25), (0.0, 0.25)]))
    assert out.lookahead == pytest.approx((0.7, 0.25))
    ctrl.reset()
    out = ctrl.compute(make_input((1.0, 0.05, math.pi), path))   # whole search: leg 1 at x = 1.0
    assert out.lookahead == pytest.approx((1.3, 0.0))


# ---------------------------------------------------------------- look-ahead collision check

def test_stops_blocked_before_a_wall_across_the_path():
    # The body, not the centre, is checked (box changes these numbers): the waffle_pi's box
    # reaches 0.0765 m ahead. A wall from x = 0.30; the robot at x = 0.15: a look-ahead pose s
    # along collides when 0.30 - (0.15 + s + 0.0765) < 0.005 (the margin), i.e. s > 0.0685: the
    # first such pose (every 0.0025 m) is s = 0.07, so 0.0675 m is free < 0.1 m stop distance
    # -> blocked.
    # The graded band before the wall (cost 253) is no collision: only the occupancy is.
    costmap = with_band(empty_costmap(), 0.10, 0.30, INSCRIBED)
    costmap = with_band(costmap, 0.30, 0.40, LETHAL)
    out = follower().compute(make_input((0.15, 0.0, 0.0), [(0.15, 0), (2.5, 0)],
                                        velocity=(V_MAX, 0), costmap=costmap))
    assert (out.status, out.linear_mps, out.angular_radps) == ("blocked", 0.0, 0.0)
    assert "obstacle" in out.detail
    out = follower().compute(make_input((0.01, 0.0, 0.0), [(0.01, 0), (2.5, 0)],
                                        velocity=(V_MAX, 0), costmap=costmap))
    assert out.status == "following"          # 0.2075 m free: slowed, not stopped


def test_slows_when_the_arc_clips_an_obstacle_late():
    # A wall from x = 0.40, the robot at x = 0.01 going 0.26 m/s: its 1.5 s look-ahead (0.39 m)
    # collides from s > 0.40 - 0.01 - 0.0765 - 0.005 = 0.3085, first pose s = 0.31: 0.3075 m
    # free, v = 0.3075 / 1.5 = 0.205 m/s. (box changes these numbers: the centre met the old
    # inscribed band 0.1 m sooner.)
    costmap = with_band(empty_costmap(), 0.40, 0.60, LETHAL)
    out = follower().compute(make_input((0.01, 0.0, 0.0), [(0.01, 0), (2.5, 0)],
                                        velocity=(V_MAX, 0), costmap=costmap))
    assert out.status == "following"
    assert out.linear_mps == pytest.approx(0.3075 / 1.5)
    # a wall from x = 0.50 lies beyond the arc (collides from s > 0.4085 > 0.39): full speed
    costmap = with_band(empty_costmap(), 0.50, 0.60, LETHAL)
    out = follower().compute(make_input((0.01, 0.0, 0.0), [(0.01, 0), (2.5, 0)],
                                        velocity=(V_MAX, 0), costmap=costmap))
    assert out.linear_mps == pytest.approx(V_MAX)


def test_the_arc_follows_the_curvature():
    # The burger (round: no tight corner here, see below; v_max 0.22, w_max 2.84). Path (0,0)
    # -> (0.4,0.2) -> (0.4,2): standing still, L_d = 0.3 m puts the carrot on the first leg at
    # (0.268, 0.134): alpha = 0.4636, kappa = 2 sin(alpha) / 0.3 = 2.98 /m (radius 0.335 m);
    # v = 0.22 (2.84 / 2.98 does not bind), w = 2.98 x 0.22; the 1.5 s look-ahead (0.33 m)
    # turns 0.98 rad and ends at (0.278, 0.148). A block at x in [0.40, 0.55), y in
    # [-0.25, -0.05) lies 0.232 m from that end, and further from the rest of the arc, beyond
    # the body (0.105 m) and its margin: full speed. Driving straight instead, the body comes
    # within the margin of the block's corner (0.40, -0.05) once 0.4 - s < 0.098 m, at s = 0.30 m
    # < 0.33 m: slowed. The disc clears the block by more than 0.1 m all along the path (its
    # nearest approach, 0.224 m, is the first leg's): no corner is tight, the arc is cut.
    # (box changes this test: the old one checked the centre against a band at x >= 0.3.)
    burger = load_robot("turtlebot3_burger")
    path = [(0, 0), (0.4, 0.2), (0.4, 2.0)]
    costmap = empty_costmap()
    costmap[15:19, 28:31] = LETHAL
    out = follower(burger).compute(make_input((0.0, 0.0, 0.0), path, costmap=costmap))
    assert out.status == "following" and out.linear_mps == pytest.approx(burger.max_linear_mps)
    kappa = 2 * math.sin(math.atan2(1, 2)) / 0.3
    assert out.angular_radps == pytest.approx(kappa * burger.max_linear_mps)
    out = follower(burger).compute(make_input((0.0, 0.0, 0.0), [(0, 0), (2.0, 0)],
                                              costmap=costmap, velocity=(burger.max_linear_mps, 0)))
    assert out.status == "following" and out.linear_mps < burger.max_linear_mps


def test_the_arc_is_not_checked_past_the_goal():
    # goal 0.25 m ahead, an inscribed band from x = 0.30: the 0.39 m arc would reach it
    # (v = 0.275 / 1.5 = 0.18), but it is cut where it comes within 0.1 m of the goal (x = 0.15)
    costmap = with_band(empty_costmap(), 0.30, 0.40, INSCRIBED)
    out = follower().compute(make_input((0.0, 0.0, 0.0), [(0, 0), (0.25, 0)],
                                        velocity=(V_MAX, 0), costmap=costmap))
    assert out.status == "following" and out.linear_mps == pytest.approx(V_MAX)


def test_unknown_space_collides_only_if_configured():
    costmap = with_band(empty_costmap(), 0.30, 0.60, UNKNOWN)
    inp = make_input((0.01, 0.0, 0.0), [(0.01, 0), (2.5, 0)], velocity=(V_MAX, 0), costmap=costmap)
    assert follower().compute(inp).linear_mps == pytest.approx(0.29 / 1.5, abs=0.025 / 1.5)
    assert follower(unknown_is_collision=False).compute(inp).linear_mps == pytest.approx(V_MAX)
    # off the grid reads as unknown: the grid ends at x = 3.0. From x = 2.81, 0.19 m of arc is
    # free: v = 0.19 / 1.5 = 0.127; from x = 2.95, 0.05 m < 0.1 m: blocked
    path = [(2.0, 0), (4.0, 0)]
    inp = make_input((2.81, 0.0, 0.0), path, velocity=(V_MAX, 0))
    assert follower().compute(inp).linear_mps == pytest.approx(0.19 / 1.5, abs=0.025 / 1.5)
    assert follower(unknown_is_collision=False).compute(inp).linear_mps == pytest.approx(V_MAX)
    inp = make_input((2.95, 0.0, 0.0), path, velocity=(V_MAX, 0))
    assert follower().compute(inp).status == "blocked"


def test_facing_a_wall_turns_toward_the_plan_first():
    # A wall from y = 0.20; the plan runs along y = 0, the robot on it heads 0.6 rad toward the
    # wall. Its front-left corner stands 0.0765 sin 0.6 + 0.153 cos 0.6 = 0.169 m up, 0.031 m
    # from the wall, and rises sin 0.6 = 0.56 m per metre driven: every arc toward the plan
    # comes within the 0.005 m margin in under 0.1 m, down to a one-cell carrot. Turning right in place
    # only lowers that corner (the sweep is clear, though the 0.257 m disc does not fit): it
    # turns toward the plan instead of reporting "blocked"; once facing along it, it follows.
    costmap = empty_costmap()
    costmap[24:, :] = LETHAL                        # rows from y = -1 + 24 * 0.05 = 0.20
    path = [(0.0, 0.0), (2.0, 0.0)]
    out = follower().compute(make_input((0.0, 0.0, 0.6), path, costmap=costmap))
    assert out.status == "rotating" and out.linear_mps == 0.0 and out.angular_radps < 0.0
    out = follower().compute(make_input((0.0, 0.0, 0.0), path, costmap=costmap))
    assert out.status == "following" and out.linear_mps > 0.0


def test_on_an_obstacle_blocked_near_one_may_leave():
    costmap = with_band(empty_costmap(), -0.50, -0.20, LETHAL)
    out = follower().compute(make_input((-0.3, 0.0, 0.0), [(-0.3, 0), (2.0, 0)], costmap=costmap))
    assert out.status == "blocked"                                      # standing on lethal
    # (box changes this test: the old one escaped the inscribed band.) The box's back, 0.2045 m
    # behind x = 0.0085, lies 0.004 m from the wall ending at x = -0.20: nearer than the 0.005 m
    # margin. Driving away (+x) only widens that: allowed; the graded cost 253 under the robot
    # only slows it (x 0.5).
    costmap = with_band(costmap, -0.20, 0.10, INSCRIBED)
    out = follower().compute(make_input((0.0085, 0.0, 0.0), [(0.0085, 0), (2.0, 0)],
                                        costmap=costmap))
    assert out.status == "following" and out.linear_mps == pytest.approx(0.5 * V_MAX)
    # facing a wall 0.0085 m from its front (x = 0.10, front at 0.015 + 0.0765): 0.0035 m to the
    # margin < 0.1 m -> blocked
    ahead = with_band(empty_costmap(), 0.10, 0.30, LETHAL)
    out = follower().compute(make_input((0.015, 0.0, 0.0), [(0.015, 0), (2.0, 0)], costmap=ahead))
    assert out.status == "blocked"


def test_blocked_when_the_box_not_the_centre_would_hit_a_corner():
    # A block's corner beside the path: y from 0.10, x from 0.30. The centre drives along
    # y = 0, 0.10 m from it, and never meets it; the box, 0.153 m to each side, does: from
    # x = 0.30 - 0.005 - 0.0765 = 0.2185. From x = 0.15 under 0.07 m is free: blocked, and the
    # detail names the body. The same block 0.20 m off (0.047 m beside the box) is passed.
    costmap = empty_costmap()
    costmap[22:30, 26:36] = LETHAL                    # y in [0.10, 0.50), x in [0.30, 0.80)
    path = [(0.15, 0.0), (2.0, 0.0)]
    centres = np.arange(0.15, 2.0, 0.01)
    assert all(cost_at(costmap, x, 0.0) == FREE for x in centres)   # the centre's cells are free
    out = follower().compute(make_input((0.15, 0.0, 0.0), path, velocity=(V_MAX, 0),
                                        costmap=costmap))
    assert out.status == "blocked" and "body" in out.detail
    costmap = empty_costmap()
    costmap[24:30, 26:36] = LETHAL                    # y from 0.20: 0.047 m beside the box
    out = follower().compute(make_input((0.15, 0.0, 0.0), path, velocity=(V_MAX, 0),
                                        costmap=costmap))
    assert out.status == "following" and out.linear_mps == pytest.approx(V_MAX)


def test_turning_in_place_blocked_where_the_box_would_hit():
    # A 0.40 m corridor (walls y <= -0.20 and y >= 0.20): the box (0.153 m to each side) fits
    # facing along it, the 0.257 m turning disc does not, and turning round would swing its back
    # (0.2045 m behind) into a wall. A path back the other way: "blocked", not "rotating". In a
    # 0.6 m corridor the disc fits: it turns.
    costmap = empty_costmap()
    costmap[:16, :] = LETHAL                          # y < -0.20
    costmap[24:, :] = LETHAL                          # y >= 0.20
    back = [(1.0, 0.0), (0.0, 0.0)]
    out = follower().compute(make_input((1.0, 0.0, 0.0), back, costmap=costmap))
    assert (out.status, out.linear_mps, out.angular_radps) == ("blocked", 0.0, 0.0)
    assert "turning" in out.detail
    wide = empty_costmap()
    wide[:14, :] = LETHAL                             # y < -0.30
    wide[26:, :] = LETHAL                             # y >= 0.30
    out = follower().compute(make_input((1.0, 0.0, 0.0), back, costmap=wide))
    assert out.status == "rotating"


def test_stops_on_a_tight_corner_and_turns_in_place():
    # A 0.45 m corridor east along y = 0 turning north at x = 1.0 into another 0.45 m one, in a
    # 0.6 m square corner (walls 0.3 m from (1.0, 0)): the disc does not clear the walls by 0.1 m
    # there, so the robot does not cut it: it stops on it (within 0.01 m + one period's
    # rounding), turns in place to north, and drives on along x = 1.0.
    occ = np.full((80, 80), 100, np.int8)
    occ[16:25, 10:45] = 0          # east: x in [-0.5, 1.25), y in [-0.2, 0.25), 9 cells
    occ[14:27, 34:46] = 0          # the corner square: x in [0.7, 1.3), y in [-0.3, 0.35)
    occ[14:75, 36:45] = 0          # north: x in [0.8, 1.25)
    costmap = np.where(occ > 0, LETHAL, FREE).astype(np.uint8)
    path = [(0.0, 0.025), (1.025, 0.025), (1.025, 2.0)]
    trace = drive(follower(), path, costmap, (0.0, 0.025, 0.0), 30.0)
    statuses = [o.status for _, _, o in trace]
    assert statuses[-1] == "arrived"
    turning = [(p, o) for _, p, o in trace if o.status == "rotating"]
    assert turning and all(math.hypot(p[0] - 1.025, p[1] - 0.025) < 0.02 for p, _ in turning)


# ---------------------------------------------------------------- degenerate inputs

@pytest.mark.parametrize("path, status", [
    (np.zeros((0, 2)), "no_path"),
    ([(0.3, 0.4)], "no_path"),
    ([(0.0, 0.0), (math.nan, 1.0)], "no_path"),
    ([(0.0, 0.0), (0.0, 0.0)], "arrived"),                 # start = goal at the robot
    ([(0.5, 0.0), (0.5, 0.0)], "following"),               # a path to one point ahead
    ([(0.0, 0.0), (0.5, 0.0), (0.5, 0.0), (1.0, 0.0)], "following"),   # a repeated waypoint
    ([(0.0, 0.0), (math.inf, 0.0), (1.0, 0.0)], "following"),          # a bad waypoint dropped
])
def test_degenerate_paths(path, status):
    out = follower().compute(make_input((0.0, 0.0, 0.0), path))
    check_output(out)
    assert out.status == status
    if status != "following":
        assert (out.linear_mps, out.angular_radps) == (0.0, 0.0)


@pytest.mark.parametrize("change", [
    dict(pose=(math.nan, 0.0, 0.0)), dict(pose=(0.0, 0.0, math.inf)),
    dict(costmap=np.zeros((0, 0), np.uint8)), dict(resolution=0.0), dict(resolution=math.nan),
    dict(origin=(math.nan, 0.0)),
])
def test_unusable_pose_or_map_stops(change):
    args = dict(pose=(0.0, 0.0, 0.0), path=[(0, 0), (1, 0)])
    args.update(change)
    out = follower().compute(make_input(**args))
    check_output(out)
    assert (out.status, out.linear_mps, out.angular_radps) == ("blocked", 0.0, 0.0)


def test_never_nan_on_random_inputs():
    rng = np.random.default_rng(5)
    ctrl = follower()
    costmap = empty_costmap()
    costmap[rng.random(costmap.shape) < 0.03] = LETHAL
    for k in range(500):
        n = int(rng.integers(0, 6))
        path = np.round(rng.uniform(-1, 3, (n, 2)), 1)            # repeats and zero lengths happen
        velocity = (float(rng.choice([0.0, 0.2, -0.1, math.nan, math.inf])), 0.0)
        goal_yaw = rng.choice([None, 0.0, math.pi, -math.pi, math.nan])
        pose = (*np.round(rng.uniform(-1, 3, 2), 1), float(rng.uniform(-4, 4)))
        out = ctrl.compute(make_input(pose, path, velocity, goal_yaw, costmap, now_s=0.1 * k))
        check_output(out)


# ---------------------------------------------------------------- closed loop

def l_corridor():
    """1 m wide L-shaped corridor: x in [0, 4] x y in [0, 1], then x in [3, 4] x y in [0, 4];
    walls everywhere else; inflated for the waffle_pi (inscribed 0.257 + 0.071 m, inflation 0.607 + 0.071 m)."""
    origin = (-0.5, -0.5)
    n = 110
    centres = origin[0] + (np.arange(n) + 0.5) * RES
    x, y = np.meshgrid(centres, centres)                     # row 0 = smallest y
    free = ((x >= 0) & (x <= 4) & (y >= 0) & (y <= 1)) | ((x >= 3) & (x <= 4) & (y >= 0) & (y <= 4))
    occupancy = np.where(free, 0, 100).astype(np.int8)
    return make_costmap(occupancy, RES, CostmapSettings.for_robot(WAFFLE)), origin


def test_closed_loop_l_shaped_corridor():
    costmap, origin = l_corridor()
    path = [(0.5, 0.5), (3.5, 0.5), (3.5, 3.5)]
    trace = drive(follower(), path, costmap, (0.5, 0.5, 0.0), 45.0, goal_yaw=math.pi, origin=origin)
    t_end, (x, y, yaw), out = trace[-1]
    assert out.status == "arrived"
    assert math.hypot(x - 3.5, y - 3.5) <= 0.1 + 0.03          # tolerance + one period of travel
    assert abs(math.remainder(yaw - math.pi, 2 * math.pi)) <= 0.1 + 0.03
    # 6 m of path at 0.21 m/s (0.5 m from the walls: cost floor(252 exp(-5 (0.5 - 0.328))) = 106,
    # speed x (1 - 0.5 x 106 / 252) = 0.79 of 0.26 m/s) = 29 s, less the cut corner, plus the
    # final 90 deg turn at <= 0.8 rad/s (~2 s): it takes ~31 s
    assert t_end < 33.0
    for _, (px, py, _), _ in trace:
        assert cost_at(costmap, px, py, origin) < INSCRIBED     # never touches a wall
        cross_track = min(abs(py - 0.5) if px <= 3.5 else math.hypot(px - 3.5, py - 0.5),
                          abs(px - 3.5) if py >= 0.5 else math.hypot(px - 3.5, py - 0.5))
        assert cross_track < 0.1                                # the corner cut is ~0.07 m
    assert {o.status for _, _, o in trace} == {"following", "rotating", "arrived"}


def test_closed_loop_wall_appears_ahead():
    # driving +x; at t = 1 s (x ~ 0.25) a wall appears at x in [1.0, 1.1) with its inscribed band
    # x in [0.85, 1.0). Once the 0.39 m arc reaches the band (x ~ 0.46) v = free arc / 1.5 s
    # falls with the gap (an exponential approach) until less than 0.1 m is free: "blocked",
    # short of the band, never in it
    def wall(t, costmap):
        if t >= 1.0:
            costmap = with_band(with_band(costmap, 0.85, 1.0, INSCRIBED), 1.0, 1.1, LETHAL)
        return costmap

    trace = drive(follower(), [(0, 0), (2.5, 0)], empty_costmap(), (0.0, 0.0, 0.0), 30.0,
                  on_step=wall)
    t_end, (x, _, _), out = trace[-1]
    assert out.status == "blocked"
    assert all(p[0] < 0.85 for _, p, _ in trace)
    assert 0.85 - x < 0.1 + 0.05          # it closed in to about the stop distance
    speeds = [o.linear_mps for _, _, o in trace]
    assert speeds == sorted(speeds, reverse=True)                     # never speeds up again
    assert sum(0.0 < v < V_MAX for v in speeds) >= 10                 # slowed before stopping
