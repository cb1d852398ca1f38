"""Differential drive and wheel odometry, as a real base does them (ROS-free, no PyBullet).

``DiffDrive`` turns the latest ``/cmd_vel`` into wheel speeds under the robot's speed and
acceleration limits and a command timeout. ``WheelOdometry`` integrates the wheel travel the
encoders would report, with slip noise whose variance grows with the distance each wheel rolls
(std ``slip_std_sqrt_m * sqrt(|d|)``), so odometry drifts like a real robot's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry import wrap_angle
from ..robot import RobotSpec


@dataclass
class Command:
    linear_mps: float = 0.0
    angular_radps: float = 0.0
    stamp_s: float = -math.inf     # sim time it arrived


class DiffDrive:
    """Wheel speeds that track the commanded twist within the robot's limits."""

    def __init__(self, robot: RobotSpec, cmd_timeout_s: float):
        self.robot = robot
        self.cmd_timeout_s = cmd_timeout_s
        self.command = Command()
        self.wheel_mps = np.zeros(2)  # left, right rim speeds (m/s)

    def set_command(self, linear: float, angular: float, now_s: float) -> str | None:
        """Store a command; return a warning line if it was not finite or had to be clamped."""
        if not (math.isfinite(linear) and math.isfinite(angular)):
            self.command = Command(0.0, 0.0, now_s)
            return f"cmd_vel ({linear}, {angular}) is not finite: ignored, stopping"
        v = min(max(linear, -self.robot.max_linear_mps), self.robot.max_linear_mps)
        w = min(max(angular, -self.robot.max_angular_radps), self.robot.max_angular_radps)
        self.command = Command(v, w, now_s)
        if (v, w) != (linear, angular):
            return (f"cmd_vel ({linear:.3g} m/s, {angular:.3g} rad/s) beyond the limits "
                    f"({self.robot.max_linear_mps}, {self.robot.max_angular_radps}): clamped")
        return None

    def target_wheels(self, now_s: float) -> np.ndarray:
        c = self.command
        if now_s - c.stamp_s > self.cmd_timeout_s:
            return np.zeros(2)
        half = 0.5 * self.robot.wheel_separation_m
        return np.array([c.linear_mps - c.angular_radps * half, c.linear_mps + c.angular_radps * half])

    def step(self, now_s: float, dt: float) -> tuple[float, float]:
        """Advance the wheel speeds by dt; return the body twist (v m/s, w rad/s)."""
        target = self.target_wheels(now_s)
        half = 0.5 * self.robot.wheel_separation_m
        # Accelerations of v and w map to per-wheel limits; keep the twist's direction.
        v_t, w_t = 0.5 * (target[0] + target[1]), (target[1] - target[0]) / (2 * half)
        v, w = self.twist
        dv = np.clip(v_t - v, -self.robot.max_linear_accel_mps2 * dt, self.robot.max_linear_accel_mps2 * dt)
        dw = np.clip(w_t - w, -self.robot.max_angular_accel_radps2 * dt, self.robot.max_angular_accel_radps2 * dt)
        v, w = v + dv, w + dw
        self.wheel_mps = np.array([v - w * half, v + w * half])
        return float(v), float(w)

    @property
    def twist(self) -> tuple[float, float]:
        half = 0.5 * self.robot.wheel_separation_m
        return (float(0.5 * (self.wheel_mps[0] + self.wheel_mps[1])),
                float((self.wheel_mps[1] - self.wheel_mps[0]) / (2 * half)))

    def stop(self) -> None:
        """The base was blocked: the wheels stall."""
        self.wheel_mps[:] = 0.0


class WheelOdometry:
    """Pose in the odom frame from wheel travel with slip noise (midpoint integration).

    Given the gyro's heading change (``gyro_turn_rad``), the heading follows it and the wheels
    give only the distance: what the TurtleBots' own drivers publish (the TurtleBot3's OpenCR
    firmware takes odometry's heading from its IMU; kobuki_node's use_imu_heading, on by
    default, from the Kobuki's gyro). Wheel-only heading turns the slip of two short wheel
    paths into heading noise of ~0.01-0.02 rad per scan while turning, which a lidar 3 m away
    turns into 3-6 cm."""

    def __init__(self, wheel_separation_m: float, slip_std_sqrt_m: float, rng: np.random.Generator):
        self.separation = wheel_separation_m
        self.slip = slip_std_sqrt_m
        self.rng = rng
        self.x = self.y = self.yaw = 0.0
        self.v = self.w = 0.0

    def update(self, forward_m: float, turn_rad: float, dt: float, gyro_turn_rad: float | None = None) -> None:
        """Integrate one step of true body motion (forward travel, heading change); the heading
        from ``gyro_turn_rad`` when given."""
        half = 0.5 * self.separation
        wheels = np.array([forward_m - turn_rad * half, forward_m + turn_rad * half])
        if self.slip > 0.0:
            wheels += self.rng.normal(0.0, 1.0, 2) * self.slip * np.sqrt(np.abs(wheels))
        d = 0.5 * (wheels[0] + wheels[1])
        dyaw = (wheels[1] - wheels[0]) / self.separation if gyro_turn_rad is None else gyro_turn_rad
        mid = self.yaw + 0.5 * dyaw
        self.x += d * math.cos(mid)
        self.y += d * math.sin(mid)
        self.yaw = wrap_angle(self.yaw + dyaw)
        self.v, self.w = (d / dt, dyaw / dt) if dt > 0 else (0.0, 0.0)
