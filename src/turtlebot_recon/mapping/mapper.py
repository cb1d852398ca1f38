"""The mapper's core (ROS-free): scans, bumpers and motion into the occupancy and visit grids.

The node supplies plain data (ranges, the sensor pose in the map frame, times); everything a
real driver can send wrong is sorted here into a skipped scan or a skipped beam and counted,
so one diagnostics line says what was ignored and why.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from ..config import positive, require
from .grid import GridSettings, make_grid

# Kobuki bumpers (kobuki_msgs/BumperEvent LEFT=0, CENTER=1, RIGHT=2): body angle of each centre.
BUMPER_ANGLE_RAD = {0: math.pi / 3, 1: 0.0, 2: -math.pi / 3}
TIME_JUMP_BACK_S = 1.0   # the clock going back this far means a restarted simulation or bag


@dataclass(frozen=True)
class MapperSettings:
    """mapper node parameters (config/mapper.yaml)."""
    map_frame: str = "odom"              # the frame the map is built in (odom until SLAM exists)
    base_frame: str = "base_footprint"
    robot: str = "turtlebot3_waffle_pi"  # for the bumper geometry (config/robots/)
    publish_rate_hz: float = 1.0         # /map and /visit_map
    tf_timeout_s: float = 0.2            # wait this long for the scan's transform
    map_file: str = ""                   # base path of the PGM/YAML pair ('' = ~/.ros/map)
    save_on_shutdown: bool = True
    grid: GridSettings = field(default_factory=GridSettings)

    def validate(self, src: str) -> None:
        positive(src, self, "publish_rate_hz", "tf_timeout_s")
        require(self.map_frame != self.base_frame, src, "map_frame", "must differ from base_frame")


@dataclass(frozen=True)
class Scan:
    """A LaserScan's content, in plain numbers."""
    ranges: np.ndarray        # float32, m
    angle_min: float          # rad
    angle_max: float
    angle_increment: float
    range_min: float          # m
    range_max: float
    stamp_s: float


class Mapper:
    def __init__(self, settings: MapperSettings, robot_radius_m: float,
                 body_disc: tuple | None = None):
        self.settings = settings
        self.robot_radius_m = robot_radius_m     # the bumpers' circle
        # (centre ahead of base_footprint m, radius m): a disc inside the body; default the
        # round body of robot_radius_m
        self.body_disc = (0.0, robot_radius_m) if body_disc is None else body_disc
        self.grid = make_grid(settings.grid)
        self.skipped = Counter()     # whole scans ignored, by reason
        self.beams = Counter()       # beams by class (valid, no_return, capped, too_close, nan)
        self.scans = 0
        self.last_clock_s = -math.inf

    def check_scan(self, scan: Scan) -> str | None:
        """Why a scan cannot be used (a reason key), or None. Counts the reason."""
        reason = None
        n = len(scan.ranges)
        if n == 0:
            reason = "empty"
        elif not all(map(math.isfinite, (scan.angle_min, scan.angle_max, scan.angle_increment,
                                         scan.range_min, scan.range_max))) \
                or scan.angle_increment == 0.0 or scan.range_max <= scan.range_min:
            reason = "bad_header"
        else:
            expected = round((scan.angle_max - scan.angle_min) / scan.angle_increment) + 1
            if abs(n - expected) > 1:   # drivers differ by one on whether angle_max is inclusive
                reason = "length_mismatch"
        if reason:
            self.skipped[reason] += 1
        return reason

    def time_jumped_back(self, now_s: float) -> bool:
        """True (once) when the clock went backwards, e.g. a restarted simulation or bag.

        ``now_s`` is the node's clock, not a message stamp: a stale scan is not a clock jump.
        """
        jumped = now_s < self.last_clock_s - TIME_JUMP_BACK_S
        self.last_clock_s = now_s
        if jumped:
            self.skipped["time_jump_back"] += 1
        return jumped

    def insert(self, scan: Scan, sensor_pose: tuple) -> None:
        """Insert a checked scan taken from ``sensor_pose`` = (x, y, yaw) in the map frame."""
        g = self.settings.grid
        stats = self.grid.insert_scan(
            sensor_pose[0], sensor_pose[1], sensor_pose[2], np.asarray(scan.ranges, np.float32),
            scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max,
            no_return_clear_m=g.no_return_clear_m, range_cap_m=g.range_cap_m)
        for key in ("valid", "no_return", "capped", "too_close", "nan"):
            if getattr(stats, key):
                self.beams[key] += getattr(stats, key)
        self.scans += 1

    def bumper(self, side: int, base_pose: tuple) -> None:
        """A bumper press at ``base_pose``: mark the cells along that bumper occupied."""
        if side not in BUMPER_ANGLE_RAD:
            self.skipped["bad_bumper"] += 1
            return
        self.grid.mark_bumper(base_pose[0], base_pose[1], base_pose[2], BUMPER_ANGLE_RAD[side],
                              self.robot_radius_m, self.settings.grid.bumper_cells)

    def motion(self, base_pose: tuple, speed_mps: float) -> None:
        self.grid.add_visit(base_pose[0], base_pose[1], abs(speed_mps), self.settings.grid.visit_min_speed_mps)
        # The lidar never sees the floor under the body (inside its minimum range): those
        # cells would stay unknown and make a frontier at the robot's own feet (a nearest-
        # frontier explorer then "reaches" it forever). The robot stands there: free.
        ahead, radius = self.body_disc
        self.grid.free_unknown_disc(base_pose[0] + ahead * math.cos(base_pose[2]),
                                    base_pose[1] + ahead * math.sin(base_pose[2]), radius)

    def diagnostics(self) -> str:
        beams = ", ".join(f"{k} {v}" for k, v in sorted(self.beams.items()) if v)
        skipped = ", ".join(f"{k} {v}" for k, v in sorted(self.skipped.items())) or "none"
        return (f"{self.scans} scans inserted ({beams}); skipped: {skipped}; "
                f"grid {self.grid.cols}x{self.grid.rows} cells")
