"""The mapper's core (ROS-free): scans, bumpers and motion into the occupancy and visit grids.

The node supplies plain data (ranges, the sensor pose in the map frame, times); everything a
real driver can send wrong is sorted here into a skipped scan or a skipped beam and counted,
so one diagnostics line says what was ignored and why.
"""
from __future__ import annotations

import math
from collections import Counter, deque
from dataclasses import dataclass, field

import numpy as np

from ..config import positive, require
from ..geometry import between, compose, wrap_angle
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
    # With SLAM (its keyframe poses on slam_path): the map is drawn again from the keyframes'
    # scans at their optimised poses once any of them has moved this far since the last drawing
    rerender_shift_m: float = 0.05       # m (one cell)
    rerender_shift_rad: float = 0.02     # rad (~1 degree: 7 cm at the lidar's 3.5 m)
    scan_memory_s: float = 30.0          # scans kept this long for a keyframe to claim
    grid: GridSettings = field(default_factory=GridSettings)

    def validate(self, src: str) -> None:
        positive(src, self, "publish_rate_hz", "tf_timeout_s", "rerender_shift_m", "rerender_shift_rad",
                 "scan_memory_s")
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
        self.recent = deque()        # (scan, sensor pose) of the last scan_memory_s, oldest first
        self.keyframe_scans = {}     # stamp key -> Scan, the scans SLAM made keyframes of
        self.drawn = {}              # stamp key -> base pose the keyframe was last drawn at
        self.bumps = []              # (side, base pose): re-marked on every drawing
        self.rerenders = 0

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
        self.recent.append((scan, tuple(sensor_pose)))
        while self.recent and self.recent[0][0].stamp_s < scan.stamp_s - self.settings.scan_memory_s:
            self.recent.popleft()

    # ------------------------------------------------------------- SLAM keyframes
    def needs_redraw(self, stamps, base_poses) -> bool:
        """Whether SLAM's keyframes (scan stamps, optimised base poses in the map frame) moved
        far enough from where the map last drew them to draw it again. Keyframes new to the
        mapper claim their scans from the recent ones (a keyframe whose scan is gone, or was
        never inserted, is left out and counted)."""
        moved = False
        for stamp, pose in zip(stamps, np.asarray(base_poses, float).reshape(-1, 3)):
            key = round(float(stamp) * 1e6)
            if key not in self.keyframe_scans:
                scan = next((sc for sc, _ in reversed(self.recent) if round(sc.stamp_s * 1e6) == key), None)
                if scan is None:
                    if key not in self.drawn:
                        self.skipped["keyframe_scan_missing"] += 1
                        self.drawn[key] = None
                    continue
                self.keyframe_scans[key] = scan
            old = self.drawn.get(key)
            if old is None:
                self.drawn[key] = tuple(pose)
                continue   # drawn already, incrementally, at (nearly) this pose
            d = between(old, pose)
            if math.hypot(d[0], d[1]) > self.settings.rerender_shift_m or abs(d[2]) > self.settings.rerender_shift_rad:
                moved = True
        return moved

    def redraw(self, stamps, base_poses, sensor_offset: tuple):
        """A new grid drawn from the keyframes' scans at ``base_poses`` ⊕ ``sensor_offset`` (the
        lidar in the base frame), with the robot's track (visits, the floor under the body) and
        the bumper presses. Built apart from the live grid, so the map keeps being published
        meanwhile; ``swap`` installs it."""
        g = self.settings.grid
        grid = make_grid(g)
        poses = np.asarray(base_poses, float).reshape(-1, 3)
        keys = [round(float(t) * 1e6) for t in stamps]
        have = [i for i, k in enumerate(keys) if k in self.keyframe_scans]
        groups = {}   # one insert_scans call per beam layout (one lidar: one group)
        for i in have:
            sc = self.keyframe_scans[keys[i]]
            layout = (len(sc.ranges), sc.angle_min, sc.angle_increment, sc.range_min, sc.range_max)
            groups.setdefault(layout, []).append(i)
        for (n, amin, inc, rmin, rmax), idx in groups.items():
            sensor = compose(poses[idx], sensor_offset)
            ranges = np.stack([np.asarray(self.keyframe_scans[keys[i]].ranges, np.float32) for i in idx])
            grid.insert_scans(sensor, ranges, amin, inc, rmin, rmax,
                              no_return_clear_m=g.no_return_clear_m, range_cap_m=g.range_cap_m)
        for i in range(len(poses)):
            # the track, every half cell between consecutive keyframes: visits and the floor
            a, b = poses[max(i - 1, 0)], poses[i]
            steps = max(1, int(math.ceil(math.hypot(b[0] - a[0], b[1] - a[1]) / (0.5 * g.resolution))))
            for f in np.linspace(0.0, 1.0, steps + 1)[1:]:
                p = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * wrap_angle(b[2] - a[2]))
                grid.add_visit(p[0], p[1], g.visit_min_speed_mps, g.visit_min_speed_mps)
                self._free_body(grid, p)
        for side, pose in self.bumps:
            grid.mark_bumper(pose[0], pose[1], pose[2], BUMPER_ANGLE_RAD[side], self.robot_radius_m, g.bumper_cells)
        self.drawn.update({keys[i]: tuple(poses[i]) for i in have})
        return grid

    def swap(self, grid, since_stamp_s: float) -> None:
        """Make ``grid`` (from ``redraw``) the live one; the scans inserted after
        ``since_stamp_s`` (while it was drawn) go into it too."""
        old, self.grid = self.grid, grid
        self.rerenders += 1
        g = self.settings.grid
        for scan, pose in self.recent:
            if scan.stamp_s > since_stamp_s:
                self.grid.insert_scan(pose[0], pose[1], pose[2], np.asarray(scan.ranges, np.float32),
                                      scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max,
                                      no_return_clear_m=g.no_return_clear_m, range_cap_m=g.range_cap_m)
        del old

    def bumper(self, side: int, base_pose: tuple) -> None:
        """A bumper press at ``base_pose``: mark the cells along that bumper occupied."""
        if side not in BUMPER_ANGLE_RAD:
            self.skipped["bad_bumper"] += 1
            return
        self.grid.mark_bumper(base_pose[0], base_pose[1], base_pose[2], BUMPER_ANGLE_RAD[side],
                              self.robot_radius_m, self.settings.grid.bumper_cells)
        self.bumps.append((side, tuple(base_pose)))

    def motion(self, base_pose: tuple, speed_mps: float) -> None:
        self.grid.add_visit(base_pose[0], base_pose[1], abs(speed_mps), self.settings.grid.visit_min_speed_mps)
        # The lidar never sees the floor under the body (inside its minimum range): those
        # cells would stay unknown and make a frontier at the robot's own feet (a nearest-
        # frontier explorer then "reaches" it forever). The robot stands there: free.
        self._free_body(self.grid, base_pose)

    def _free_body(self, grid, base_pose) -> None:
        ahead, radius = self.body_disc
        grid.free_unknown_disc(base_pose[0] + ahead * math.cos(base_pose[2]),
                               base_pose[1] + ahead * math.sin(base_pose[2]), radius)

    def diagnostics(self) -> str:
        beams = ", ".join(f"{k} {v}" for k, v in sorted(self.beams.items()) if v)
        skipped = ", ".join(f"{k} {v}" for k, v in sorted(self.skipped.items())) or "none"
        redrawn = f"; redrawn {self.rerenders} times from {len(self.keyframe_scans)} keyframes" \
            if self.keyframe_scans else ""
        return (f"{self.scans} scans inserted ({beams}); skipped: {skipped}; "
                f"grid {self.grid.cols}x{self.grid.rows} cells{redrawn}")
