"""The driven path: poses of the base in the map frame, kept as the robot moves (ROS-free).

``scripts/trajectory`` samples TF map_frame -> base_frame and publishes this as a
nav_msgs/Path, as hector_trajectory_server does for hector_slam. A pose is kept when it is
``min_step_m`` from the last kept one, so a robot standing still (or odometry jitter) adds
nothing; past ``max_poses`` every second older pose is dropped, so the message stays small
and the whole path keeps its shape.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .config import positive, require


@dataclass(frozen=True)
class TrajectorySettings:
    """config/trajectory.yaml."""
    map_frame: str = "odom"              # the path's frame; odom until SLAM provides map -> odom
    base_frame: str = "base_footprint"
    sample_rate_hz: float = 5.0          # TF lookups per second (ROS time)
    publish_period_wall_s: float = 1.0   # s (wall) between publications of a changed path
    min_step_m: float = 0.05             # m from the last kept pose before a new one is kept
    max_poses: int = 2000                # then every second older pose is dropped

    def validate(self, src: str) -> None:
        positive(src, self, "sample_rate_hz", "publish_period_wall_s", "min_step_m")
        require(isinstance(self.max_poses, int) and self.max_poses >= 2, src, "max_poses",
                f"must be an integer >= 2, got {self.max_poses!r}")


class Trajectory:
    """Poses (t_s, x_m, y_m, yaw_rad) of the base, oldest first, and the length driven."""

    def __init__(self, settings: TrajectorySettings):
        self.s = settings
        self.poses: list[tuple] = []
        self.length_m = 0.0     # sum of the steps between kept poses (before any thinning)
        self.version = 0        # +1 on every change, so a publisher sends only what is new
        self.resets = 0         # times the clock went back (simulator restart, bag loop)

    def add(self, t_s: float, x: float, y: float, yaw: float) -> bool:
        """Keep the pose if it is the first or ``min_step_m`` from the last kept one; True if
        kept. A time before the last kept pose starts a new path. Raises ValueError on a
        non-finite value (the caller logs it and goes on)."""
        if not all(math.isfinite(v) for v in (t_s, x, y, yaw)):
            raise ValueError(f"non-finite pose t={t_s} x={x} y={y} yaw={yaw}")
        if self.poses and t_s < self.poses[-1][0]:
            self.poses, self.length_m = [], 0.0
            self.resets += 1
        if self.poses:
            step = math.hypot(x - self.poses[-1][1], y - self.poses[-1][2])
            if step < self.s.min_step_m:
                return False
            self.length_m += step
        self.poses.append((t_s, x, y, yaw))
        if len(self.poses) > self.s.max_poses:
            self.poses = self.poses[:-1:2] + [self.poses[-1]]   # every second older one, and the newest
        self.version += 1
        return True
