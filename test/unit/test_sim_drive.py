"""Differential drive: distance, limits, timeout, bad commands, walls, bumpers, odometry noise."""
import math

import numpy as np
import pytest

from conftest import drive
from turtlebot_recon.geometry import wrap_angle
from turtlebot_recon.robot import load_robot
from turtlebot_recon.sim.drive import DiffDrive, WheelOdometry


def drive_distance(sim, distance_m, speed):
    """Command ``speed`` until ground truth has covered the distance the ramp-up predicts."""
    a = sim.robot.max_linear_accel_mps2
    ramp_t = speed / a
    hold_t = (distance_m - 0.5 * a * ramp_t ** 2) / speed
    drive(sim, speed, 0.0, ramp_t + hold_t)
    drive(sim, 0.0, 0.0, 1.0)   # stop (decelerating adds speed^2 / 2a)


@pytest.mark.parametrize("robot", ["turtlebot3_burger", "turtlebot2"])
def test_one_metre_command_gives_one_metre(room_world, make_sim, robot):
    sim = make_sim(room_world, robot)
    drive_distance(sim, 1.0, 0.2)
    a = sim.robot.max_linear_accel_mps2
    expected = 1.0 + 0.2 ** 2 / (2 * a)          # plus the braking distance
    assert sim.pose[0] - 1.0 == pytest.approx(expected, abs=0.01)
    assert abs(sim.pose[1] - 1.5) < 1e-9 and abs(sim.pose[2]) < 1e-9
    assert sim.odom.x == pytest.approx(sim.pose[0] - 1.0, abs=1e-9)   # no slip configured
    assert sim.collisions == 0


def test_limits_timeout_and_bad_commands(room_world, make_sim):
    sim = make_sim(room_world, "turtlebot3_burger")
    assert "clamped" in sim.set_command(5.0, 0.0)
    assert sim.drive.command.linear_mps == sim.robot.max_linear_mps
    assert "not finite" in sim.set_command(float("nan"), 0.0)
    assert sim.drive.command.linear_mps == 0.0
    assert "not finite" in sim.set_command(0.1, float("inf"))
    # one command, then silence: the base stops 0.5 s later (plus deceleration)
    sim.set_command(0.2, 0.0)
    for _ in range(200):
        sim.step()
    assert sim.twist == (0.0, 0.0)
    assert 0.08 < sim.pose[0] - 1.0 < 0.13      # ~0.5 s at up to 0.2 m/s


def test_acceleration_limit():
    robot = load_robot("turtlebot2")
    d = DiffDrive(robot, cmd_timeout_s=0.5)
    d.set_command(0.7, 0.0, 0.0)
    v, _ = d.step(0.0, 0.1)
    assert v == pytest.approx(robot.max_linear_accel_mps2 * 0.1)


@pytest.mark.parametrize("robot", ["turtlebot3_burger", "turtlebot3_waffle_pi", "turtlebot2"])
def test_walls_stop_the_robot_and_count_contacts(room_world, make_sim, robot):
    sim = make_sim(room_world, robot)
    drive(sim, 0.2, 0.0, 25.0)                   # 5 m of commands toward the wall at x = 4.1
    spec = sim.robot
    front = spec.footprint_offset_x_m + 0.5 * spec.footprint_length_m if not spec.is_round else spec.radius_m
    assert sim.pose[0] + front <= 4.1 + 1e-3     # never through the wall
    assert sim.pose[0] + front > 4.1 - 0.01      # but right up against it
    assert sim.collisions == 1                   # one contact episode, however long it pushes
    if spec.bumpers:
        assert [(e.side, e.pressed) for e in sim.bumper_events] == [(1, True)]   # centre pressed
        drive(sim, -0.1, 0.0, 1.0)
        assert [(e.side, e.pressed) for e in sim.bumper_events][-1] == (1, False)
    else:
        assert sim.bumper_events == []


def test_side_bumper(room_world, make_sim):
    sim = make_sim(room_world, "turtlebot2")
    sim.set_pose(3.5, 1.5, math.radians(-50))    # wall at x = 4.1 is on the robot's left front
    drive(sim, 0.2, 0.0, 15.0)
    assert sim.bumper_events and sim.bumper_events[0].side == 0 and sim.bumper_events[0].pressed


def test_odometry_drift_matches_configured_slip():
    # Straight D = 2 m in 1 cm steps; each wheel's travel error has variance k^2 * D.
    # x = (dl + dr) / 2      ->  var = k^2 * D / 2,   std = k * sqrt(D / 2)  = 0.002 m
    # yaw = (dr - dl) / L    ->  var = 2 k^2 D / L^2, std = k * sqrt(2 D) / L = 0.025 rad
    # (the heading error also shortens x by ~D * yaw^2 / 6 ~ 2e-4 m: negligible here)
    k, L, D, n = 0.002, 0.16, 2.0, 400
    rng = np.random.default_rng(7)
    ends = []
    for _ in range(n):
        odo = WheelOdometry(L, k, rng)
        for _ in range(200):
            odo.update(0.01, 0.0, 0.05)
        ends.append((odo.x, odo.yaw))
    ends = np.array(ends)
    x_std_expected = k * math.sqrt(D / 2)
    yaw_std_expected = k * math.sqrt(2 * D) / L
    assert abs(np.mean(ends[:, 0]) - D) < 0.0006
    assert np.std(ends[:, 0]) == pytest.approx(x_std_expected, rel=0.12)
    assert np.std(ends[:, 1]) == pytest.approx(yaw_std_expected, rel=0.12)


def test_noisy_odometry_drifts_but_ground_truth_does_not(room_world, make_sim):
    a = make_sim(room_world, "turtlebot3_burger", odom_slip_std_sqrt_m=0.05, seed=1)
    b = make_sim(room_world, "turtlebot3_burger", odom_slip_std_sqrt_m=0.05, seed=1)
    for sim in (a, b):
        drive(sim, 0.2, 0.5, 10.0)
    assert np.array_equal(a.pose, b.pose) and a.odom.x == b.odom.x      # same seed, same run
    err = math.hypot(a.odom.x - (a.pose[0] - 1.0), a.odom.y - (a.pose[1] - 1.5))
    assert err > 1e-3


def test_an_added_box_stops_the_robot_is_scanned_and_refuses_to_overlap_it(room_world, make_sim):
    sim = make_sim(room_world)                   # burger at (1.0, 1.5) facing +x
    forward = sim.true_ranges()[0]               # beam 0 looks along +x: the wall at x = 4.1
    assert forward == pytest.approx(4.1 - (1.0 + sim.robot.lidar.x_m), abs=0.05)
    sim.add_box(2.0, 1.0, 2.2, 2.0)              # a door closing across the way
    assert sim.true_ranges()[0] == pytest.approx(2.0 - (1.0 + sim.robot.lidar.x_m), abs=0.01)
    assert not sim.world.is_free(2.1, 1.5) and sim.world.is_free(1.9, 1.5)
    drive(sim, 0.2, 0.0, 10.0)                   # 2 m of commands toward it
    assert 2.0 - 0.01 < sim.pose[0] + sim.robot.radius_m <= 2.0 + 1e-3
    assert sim.collisions == 1
    with pytest.raises(ValueError, match="overlaps the robot"):
        sim.add_box(sim.pose[0] - 0.05, 1.4, sim.pose[0] + 0.05, 1.6)
    with pytest.raises(ValueError, match="finite"):
        sim.add_box(math.nan, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="thinner"):
        sim.add_box(3.0, 0.5, 3.0, 1.0)
    assert sim.world.is_free(sim.pose[0], 1.5)   # the refused boxes changed nothing


def test_sensor_and_clock_schedules(room_world, make_sim):
    """step() names what is due: the burger's scan at 5 Hz, odometry at 30 Hz (every 3rd 10 ms
    step), IMU at 50 Hz, ground truth at 10 Hz, /clock at clock_rate_hz (25 Hz: every 4th)."""
    sim = make_sim(room_world, clock_rate_hz=25.0)
    counts = {}
    for _ in range(100):                                   # 1 s of sim time
        for name in sim.step():
            counts[name] = counts.get(name, 0) + 1
    assert counts == {"scan": 5, "odom": 33, "imu": 50, "ground_truth": 10, "clock": 25}


def test_odometry_heading_follows_the_gyro_as_the_turtlebots_drivers_publish_it(room_world, make_sim):
    """With slip, odom_heading gyro (the default) keeps odometry's heading on the gyro's (a few
    mrad after turning back and forth: a perfect gyro's noise), while the wheels' distance still
    drifts; wheel-only heading wanders by centiradians over the same turns."""
    errors = {}
    for heading in ("gyro", "wheels"):
        sim = make_sim(room_world, "turtlebot3_burger", odom_slip_std_sqrt_m=0.05, odom_heading=heading, seed=3,
                       gyro_scale_error=0.0, gyro_bias_radps=0.0)
        worst = 0.0
        for k in range(1200):                        # 12 s: turn left and right in place, 2 s each
            sim.set_command(0.0, 1.5 if (k // 200) % 2 == 0 else -1.5)
            sim.step()
            worst = max(worst, abs(wrap_angle(sim.odom.yaw - wrap_angle(sim.pose[2] - sim.world.start[2]))))
        errors[heading] = worst
    assert errors["gyro"] < 0.005, errors
    assert errors["wheels"] > 4 * errors["gyro"], errors


def test_the_gyros_scale_error_and_bias_turn_into_heading_drift(room_world, make_sim):
    """Odometry's heading from the gyro carries the gyro's own errors: after turning 6 rad one
    way in place the heading is off by the scale error's share of the turn plus the bias's."""
    sim = make_sim(room_world, "turtlebot3_burger", odom_slip_std_sqrt_m=0.01, seed=3,
                   gyro_scale_error=0.02, gyro_bias_radps=0.001)
    turned = 0.0
    for _ in range(400):                                   # 4 s at 1.5 rad/s
        sim.set_command(0.0, 1.5)
        yaw0 = sim.pose[2]
        sim.step()
        turned += wrap_angle(sim.pose[2] - yaw0)
    assert turned > 5.0
    error = wrap_angle(sim.odom.yaw - wrap_angle(sim.pose[2] - sim.world.start[2]))
    assert abs(error - (0.02 * turned + 0.001 * 4.0)) < 0.01, (error, turned)
