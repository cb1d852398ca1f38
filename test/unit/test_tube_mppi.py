"""Tube MPPI (control/tube_mppi.py): MPPI on the nominal state, iLQR from the real one; it
reaches a goal under seed 000's noise, resets the nominal when the robot leaves the tube, keeps
the robot's limits and stops on bad input."""
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from turtlebot_recon.control import BLOCKED, FOLLOWING, ROTATING, ControlInput
from turtlebot_recon.control.footprint import BodyCheck
from turtlebot_recon.control.mppi import MppiSettings
from turtlebot_recon.control.tube_mppi import TubeMppiController, TubeMppiSettings
from turtlebot_recon.robot import load_robot

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_control import (DT, EXPERIMENT_MPPI, EXPERIMENT_TRACKING, GOAL, RES, UNICYCLE,  # noqa: E402
                           WAYPOINT_NOISE, drive, jerk)

# seed 000's idealised unicycle and MPPI settings, as bench-control's, with fewer samples
UNICYCLE_MPPI = replace(EXPERIMENT_MPPI, batch_size=300)
WIDE_TUBE = TubeMppiSettings(tube_radius_m=0.5, tube_yaw_rad=1.5)
SMALL_MPPI = MppiSettings(batch_size=300)     # the waffle_pi's defaults, fewer samples


def empty(size_m=16.0, origin=(-6.5, -6.5)):
    n = int(round(size_m / RES))
    return np.zeros((n, n), np.int8), origin


def control_input(occ, origin, pose, velocity, path, now_s=0.0):
    return ControlInput(now_s, tuple(pose), tuple(velocity), np.asarray(path, float), None, occ,
                        np.zeros(occ.shape, np.uint8), RES, origin)


def seed_000_trip(tube, seed):
    """bench-control's closed loop (seed 000's noisy unicycle, (0, 0) -> (3, 3), 50 steps of
    0.1 s) with this Tube MPPI: the commands sent and the true states."""
    occ, origin = empty()
    controller = TubeMppiController(replace(tube, mppi=UNICYCLE_MPPI), UNICYCLE, EXPERIMENT_TRACKING)
    return drive(controller, (0.0, 0.0, 0.0), lambda x: np.array([x[:2], GOAL]), 50, WAYPOINT_NOISE,
                 np.random.default_rng(seed), occ, origin)


def test_reaches_the_goal_under_seed_000s_noise():
    """Seed 000's noisy unicycle, (0, 0) -> (3, 3) in 50 steps of 0.1 s: control noise of
    variance 0.5 (v) and 4 (w), state noise U[-0.06, 0.06] (x, y), U[-0.3, 0.3] (yaw). Fixed
    seeds; each run ends within 0.3 m of the goal."""
    for seed in (0, 1, 2):
        r = seed_000_trip(WIDE_TUBE, seed)
        u = r["commands"]
        assert np.isfinite(u).all() and (np.abs(u[:, 0]) <= 2.0).all() and (np.abs(u[:, 1]) <= 3.0).all()
        assert np.hypot(*(r["states"][-1, :2] - GOAL)) < 0.3, seed


def test_the_change_cost_filters_the_command():
    """Under seed 000's noise the iLQR feedback answers each step's disturbance; a cost on the
    change of the command from the last one sent (r_change_*) cuts the commands' jerk (mean
    |second difference|) by more than half on the same noise, and the robot still arrives."""
    stiff = replace(WIDE_TUBE, q_xy_per_m2=20.0, r_linear_s2_per_m2=1.0, r_angular_s2_per_rad2=0.05,
                    qf_xy_per_m2=200.0, r_change_linear_s2_per_m2=0.0, r_change_angular_s2_per_rad2=0.0)
    plain = seed_000_trip(stiff, 7)
    smooth = seed_000_trip(replace(stiff, r_change_linear_s2_per_m2=10.0, r_change_angular_s2_per_rad2=2.0), 7)
    assert (jerk(smooth["commands"]) < 0.5 * jerk(plain["commands"])).all()
    assert np.hypot(*(smooth["states"][-1, :2] - GOAL)) < 0.4


def test_the_nominal_restarts_when_the_robot_leaves_the_tube():
    occ, origin = empty()
    controller = TubeMppiController(replace(WIDE_TUBE, mppi=UNICYCLE_MPPI), UNICYCLE, EXPERIMENT_TRACKING)
    path = [[0.0, 0.0], [3.0, 0.0]]
    x = np.zeros(3)
    for k in range(3):                         # noise free: the robot stays on the nominal
        out = controller.compute(control_input(occ, origin, x, (0, 0), path, k * DT))
        v, w = out.linear_mps, out.angular_radps
        x = x + DT * np.array([v * math.cos(x[2]), v * math.sin(x[2]), w])
        assert controller.resets == 0
        z0 = controller.nominal_trajectory[0]
    assert np.hypot(*(controller.nominal_trajectory[0, :2] - controller.trajectory[0, :2])) < 0.05
    pushed = x + np.array([0.0, 0.8, 0.0])     # 0.8 m sideways: beyond the 0.5 m tube
    out = controller.compute(control_input(occ, origin, pushed, (v, w), path, 3 * DT))
    assert controller.resets == 1
    np.testing.assert_allclose(controller.nominal_trajectory[0], pushed)   # z <- x
    assert np.hypot(*(z0[:2] - pushed[:2])) > 0.5
    # inside the tube (a 0.3 m push) the nominal stays where MPPI planned it
    x = controller.trajectory[1]
    out = controller.compute(control_input(occ, origin, x + [0.3, 0.0, 0.0], (v, w), path, 4 * DT))
    assert controller.resets == 1 and out.status in (FOLLOWING, ROTATING)
    assert np.hypot(*(controller.nominal_trajectory[0, :2] - controller.trajectory[0, :2])) > 0.25


def test_the_ancillary_pulls_back_toward_the_nominal():
    """0.3 m left of a nominal that drives along +x, iLQR steers right (w < 0)."""
    occ, origin = empty()
    controller = TubeMppiController(replace(WIDE_TUBE, mppi=UNICYCLE_MPPI), UNICYCLE, EXPERIMENT_TRACKING)
    path = [[0.0, 0.0], [5.0, 0.0]]
    x = np.zeros(3)
    for k in range(5):
        out = controller.compute(control_input(occ, origin, x, (0, 0), path, k * DT))
        v, w = out.linear_mps, out.angular_radps
        x = x + DT * np.array([v * math.cos(x[2]), v * math.sin(x[2]), w])
    z = controller._z.copy()
    out = controller.compute(control_input(occ, origin, z + [0.0, 0.3, 0.0], (v, w), path, 5 * DT))
    assert controller.resets == 0 and out.angular_radps < -0.2
    # the predicted trajectory converges onto the nominal's (to 0.12 of the offset within the
    # horizon with the default change cost, which slows the pull; without it, to < 0.1)
    err = np.hypot(*(controller.trajectory[:, :2] - controller.nominal_trajectory[:, :2]).T)
    assert err[-1] < 0.2 * err[0]


@pytest.mark.parametrize("pose, velocity, detail", [
    ((math.nan, 0.0, 0.0), (0.0, 0.0), "the pose is not finite"),
    ((1.0, 1.0, 0.0), (math.inf, 0.0), "the measured velocity is not finite"),
])
def test_non_finite_input_stops_the_robot_with_a_reason(pose, velocity, detail):
    occ, origin = empty(8.0, (-2.0, -2.0))
    robot = load_robot("turtlebot3_waffle_pi")
    controller = TubeMppiController(replace(TubeMppiSettings(), mppi=SMALL_MPPI), robot)
    out = controller.compute(control_input(occ, origin, pose, velocity, [[1.0, 1.0], [3.0, 1.0]]))
    assert (out.linear_mps, out.angular_radps, out.status) == (0.0, 0.0, BLOCKED)
    assert detail in out.detail


def test_the_waffle_keeps_its_limits_and_refuses_a_wall():
    """A wall across the map 1.2 m ahead with the path through it: the commands keep the
    waffle_pi's limits and the body never touches the wall (it drives up to it and stays
    short of it, blocked or hovering: MPPI's stall rule decides which)."""
    robot = load_robot("turtlebot3_waffle_pi")
    occ, origin = empty(8.0, (-2.0, -4.0))
    col = int(round((2.2 - origin[0]) / RES))
    occ[:, col:col + 4] = 100                   # a wall at x = 2.2 m
    controller = TubeMppiController(replace(TubeMppiSettings(), mppi=SMALL_MPPI), robot)
    body = BodyCheck(robot, 0.0)
    path = [[1.0, 0.0], [4.0, 0.0]]
    x, u = np.array([1.0, 0.0, 0.0]), (0.0, 0.0)
    for k in range(60):
        inp = control_input(occ, origin, x, u, path, k * 0.1)
        out = controller.compute(inp)
        v, w = out.linear_mps, out.angular_radps
        assert SMALL_MPPI.min_linear_mps - 1e-9 <= v <= robot.max_linear_mps + 1e-9
        assert abs(w) <= robot.max_angular_radps + 1e-9
        assert abs(v - u[0]) <= robot.max_linear_accel_mps2 * 0.1 + 1e-9
        assert abs(w - u[1]) <= robot.max_angular_accel_radps2 * 0.1 + 1e-9
        for _ in range(2):                       # 0.1 s period, two 0.05 s Euler steps
            x = x + 0.05 * np.array([v * math.cos(x[2]), v * math.sin(x[2]), w])
        assert body.clearance(inp, [x], 0.1)[0] > 0.0
        u = (v, w)
    assert x[0] > 1.4                             # it did drive toward the wall


@pytest.mark.parametrize("cls", ["mppi", "tube_mppi"])
def test_a_new_goal_while_driving_carries_the_speed_on(cls):
    """A new goal resets the controller (the navigator's set_goal): its warm start now holds
    the speed the robot has, so the waffle_pi driving at 0.26 m/s along a straight line does
    not ease off for a goal further on (with a warm start at rest the command dipped to
    0.17 m/s and took a second to come back); from rest the start is the same as before."""
    from turtlebot_recon.control import make_controller
    waffle = load_robot("turtlebot3_waffle_pi")
    occ, origin = empty()
    controller = make_controller(cls, None, waffle)
    pose, velocity, path = np.array([-5.0, 0.0, 0.0]), (0.0, 0.0), [[-5.0, 0.0], [5.0, 0.0]]
    speeds = []
    for k in range(40):
        if k == 25:
            controller.reset()
            path = [[pose[0], pose[1]], [5.0, 0.3]]
        out = controller.compute(control_input(occ, origin, pose, velocity, path, now_s=0.1 * k))
        v, w = out.linear_mps, out.angular_radps
        pose = pose + np.array([v * math.cos(pose[2]), v * math.sin(pose[2]), w]) * 0.1
        velocity = (v, w)
        speeds.append(v)
    assert min(speeds[20:25]) > 0.25                 # cruising before the new goal
    assert min(speeds[25:40]) > 0.24                 # and after it
