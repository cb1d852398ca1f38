"""Robot specifications (DESIGN §5): geometry, limits and sensors, loaded from config/robots/.

All lengths in metres, angles in radians, rates in hertz; poses of sensors are relative to
``base_footprint`` (REP-105), x forward, y left, z up (REP-103).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

from .config import ConfigError, from_dict, load_yaml, positive, require
from .paths import SHARE_DIR

CONFIG_DIR = SHARE_DIR / "config" / "robots"


@dataclass(frozen=True)
class LidarSpec:
    frame_id: str = "base_scan"
    x_m: float = 0.0
    y_m: float = 0.0
    z_m: float = 0.17
    beams: int = 360
    angle_min_rad: float = 0.0
    angle_max_rad: float = 2 * math.pi - 2 * math.pi / 360
    range_min_m: float = 0.12
    range_max_m: float = 3.5
    rate_hz: float = 5.0
    noise_std_m: float = 0.01       # Gaussian range noise: std = max(noise_std_m, noise_frac * r)
    noise_frac: float = 0.01
    dropout_prob: float = 0.01      # chance that a valid return is reported invalid
    invalid_value: float = 0.0      # what the driver reports for "no return": 0.0, .inf or .nan

    def validate(self, src: str) -> None:
        positive(src, self, "range_min_m", "range_max_m", "rate_hz", "beams")
        require(self.range_min_m < self.range_max_m, src, "range_min_m", "must be < range_max_m")
        require(self.angle_min_rad < self.angle_max_rad, src, "angle_min_rad", "must be < angle_max_rad")
        require(0.0 <= self.dropout_prob < 1.0, src, "dropout_prob", "must be in [0, 1)")
        require(self.noise_std_m >= 0 and self.noise_frac >= 0, src, "noise_std_m", "must be >= 0")
        require(self.invalid_value == 0.0 or not math.isfinite(self.invalid_value), src,
                "invalid_value", "must be 0.0, .inf or .nan (what real drivers report)")

    @property
    def angle_increment_rad(self) -> float:
        return (self.angle_max_rad - self.angle_min_rad) / max(self.beams - 1, 1)


@dataclass(frozen=True)
class CameraSpec:
    frame_id: str = "camera_link"
    optical_frame_id: str = "camera_optical"
    x_m: float = 0.07
    y_m: float = 0.0
    z_m: float = 0.1
    width_px: int = 640
    height_px: int = 480
    hfov_rad: float = math.radians(62.2)
    near_m: float = 0.05
    far_m: float = 12.0

    def validate(self, src: str) -> None:
        positive(src, self, "width_px", "height_px", "hfov_rad", "near_m", "far_m")
        require(self.hfov_rad < math.pi, src, "hfov_rad", "must be < pi")

    @property
    def fx_px(self) -> float:
        return 0.5 * self.width_px / math.tan(0.5 * self.hfov_rad)

    @property
    def vfov_rad(self) -> float:
        return 2.0 * math.atan(0.5 * self.height_px / self.fx_px)


@dataclass(frozen=True)
class DepthCameraSpec:
    """A depth camera registered to the RGB camera (the TurtleBot 2's Astra/Kinect with
    turtlebot_bringup's depth_registration): the RGB camera's mount and field of view, its own
    resolution, range and noise. Pixels report the z-depth along the optical axis (REP 118)."""
    optical_frame_id: str = "camera_depth_optical"   # a child of the RGB camera's frame_id
    width_px: int = 160
    height_px: int = 120
    range_min_m: float = 0.45        # nearer or farther: no return (NaN)
    range_max_m: float = 4.0
    noise_std_m: float = 0.0012      # axial noise std sigma(z) = noise_std_m + noise_quad_per_m * z^2
    noise_quad_per_m: float = 0.0019

    def validate(self, src: str) -> None:
        positive(src, self, "width_px", "height_px", "range_min_m", "range_max_m")
        require(self.range_min_m < self.range_max_m, src, "range_min_m", "must be < range_max_m")
        require(self.noise_std_m >= 0 and self.noise_quad_per_m >= 0, src, "noise_std_m",
                "must be >= 0 (and noise_quad_per_m too)")

    def fx_px(self, hfov_rad: float) -> float:
        return 0.5 * self.width_px / math.tan(0.5 * hfov_rad)


@dataclass(frozen=True)
class RobotSpec:
    name: str
    wheel_radius_m: float
    wheel_separation_m: float
    max_linear_mps: float
    max_angular_radps: float
    max_linear_accel_mps2: float
    max_angular_accel_radps2: float
    radius_m: float                      # circumscribed radius of the footprint about base_footprint
    footprint_length_m: float = 0.0      # 0 = round body of radius_m; else a box (x extent)
    footprint_width_m: float = 0.0       # box y extent
    footprint_offset_x_m: float = 0.0    # box centre ahead of base_footprint
    body_height_m: float = 0.2
    odom_rate_hz: float = 30.0
    imu_rate_hz: float = 50.0
    gyro_noise_std_radps: float = 0.002
    bumpers: bool = False                # Kobuki left/centre/right bumpers
    lidar: LidarSpec = field(default_factory=LidarSpec)
    camera: Optional[CameraSpec] = None
    depth_camera: Optional[DepthCameraSpec] = None   # registered to ``camera``: needs one

    def validate(self, src: str) -> None:
        positive(src, self, "wheel_radius_m", "wheel_separation_m", "max_linear_mps",
                 "max_angular_radps", "max_linear_accel_mps2", "max_angular_accel_radps2",
                 "radius_m", "body_height_m", "odom_rate_hz", "imu_rate_hz")
        require((self.footprint_length_m > 0) == (self.footprint_width_m > 0), src,
                "footprint_length_m", "give both footprint_length_m and footprint_width_m, or neither")
        require(self.depth_camera is None or self.camera is not None, src, "depth_camera",
                "is registered to the RGB camera: give a camera block too")

    @property
    def is_round(self) -> bool:
        return self.footprint_length_m <= 0.0


def footprint_args(robot: RobotSpec) -> dict:
    """The body as the native code takes it (footprint.hpp's Footprint: a round robot has
    length 0): footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m."""
    if robot.is_round:
        return dict(footprint_length_m=0.0, footprint_width_m=0.0, footprint_offset_x_m=0.0,
                    radius_m=robot.radius_m)
    return dict(footprint_length_m=robot.footprint_length_m,
                footprint_width_m=robot.footprint_width_m,
                footprint_offset_x_m=robot.footprint_offset_x_m, radius_m=robot.radius_m)


def robot_path(name_or_path: str) -> Path:
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml"):
        return p
    return CONFIG_DIR / f"{name_or_path}.yaml"


def load_robot(name_or_path: str) -> RobotSpec:
    """Load a robot by name (``turtlebot3_burger``, ...) or from a YAML path."""
    path = robot_path(name_or_path)
    if not path.exists():
        known = sorted(q.stem for q in CONFIG_DIR.glob("*.yaml"))
        raise ConfigError(f"robot '{name_or_path}': no file {path}; known robots: {known}")
    return from_dict(RobotSpec, load_yaml(path), str(path))
