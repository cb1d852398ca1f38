"""The SLAM pipeline over a recorded log (``make slam-log``): a rosbag or a CARMEN log in, the
optimised keyframe trajectory, the odometry, the map and the graph out, as fast as the CPU
allows.

Each scan needs the odometry pose at its stamp: a CARMEN laser line carries it; for a bag it is
interpolated between the two /odom messages around the stamp (a scan outside them waits for
the next one, or is dropped at the end). The lidar's mounting comes from the CARMEN line (laser
pose against robot pose) or, for a bag, from the robot's YAML. Time going backwards (a looping
bag) starts a new run: the state is cleared and said so.
"""
from __future__ import annotations

import bisect
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from ..evaluation.trajectory_metrics import write_tum
from ..geometry import between, compose, transform_points, wrap_angle
from ..mapping.grid import GridSettings, make_grid
from ..mapping.map_io import save_map
from .logs import ImuRecord, LaserRecord, OdomRecord, TimeJump, read_log
from .scan_matching import scan_points
from .slam import Slam, SlamSettings


@dataclass
class OfflineResult:
    keyframes: int
    scans: int
    scans_dropped: int
    log_seconds: float
    wall_seconds: float
    resets: int
    stats: dict = field(default_factory=dict)
    log_summary: str = ""

    @property
    def speedup(self) -> float:
        return self.log_seconds / self.wall_seconds if self.wall_seconds > 0 else math.inf


class _OdometryTrack:
    """Odometry poses by time, interpolated at a scan's stamp."""

    def __init__(self):
        self.t: list = []
        self.p: list = []

    def add(self, r: OdomRecord) -> None:
        if self.t and r.stamp_s <= self.t[-1]:
            return
        self.t.append(r.stamp_s)
        self.p.append((r.x, r.y, r.yaw))

    def at(self, t: float) -> Optional[np.ndarray]:
        i = bisect.bisect_left(self.t, t)
        if i == len(self.t) or (i == 0 and self.t[0] != t):
            return None
        if self.t[i] == t:
            return np.array(self.p[i])
        a, b = np.array(self.p[i - 1]), np.array(self.p[i])
        f = (t - self.t[i - 1]) / (self.t[i] - self.t[i - 1])
        return np.array([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * wrap_angle(b[2] - a[2])])


def run_log(path, output_dir, settings: SlamSettings = SlamSettings(), wheel_separation_m: float = 0.16,
            lidar_offset=(0.0, 0.0, 0.0), grid: GridSettings = GridSettings(), log=print) -> OfflineResult:
    """SLAM over the log at ``path``; writes trajectory.tum, odometry.tum, map.pgm/.yaml and
    graph.g2o into ``output_dir``."""
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    reader = read_log(path)
    slam = Slam(settings, wheel_separation_m)
    odom = _OdometryTrack()
    pending: list = []                 # bag scans waiting for odometry after their stamp
    scans: dict = {}                   # keyframe stamp -> (ranges, layout), for the map
    odometry_rows: list = []
    dropped = 0
    first = last = None
    t0 = time.perf_counter()

    def use(rec: LaserRecord, pose, offset) -> None:
        pts = scan_points(rec.ranges, rec.angle_min, rec.angle_increment, rec.range_min, rec.range_max)
        base = transform_points(offset, pts)
        odometry_rows.append((rec.stamp_s, *pose))
        if slam.add_scan(rec.stamp_s, base, pose):
            scans[rec.stamp_s] = (rec, offset)

    for rec in reader:
        if isinstance(rec, TimeJump):
            slam.reset(f"time went back from {rec.previous_s:.3f} s to {rec.stamp_s:.3f} s in the log")
            odom, pending, scans, odometry_rows = _OdometryTrack(), [], {}, []
            continue
        stamp = getattr(rec, "stamp_s", None)
        if stamp is not None:
            first = stamp if first is None else first
            last = stamp
        if isinstance(rec, ImuRecord):
            slam.add_imu(rec.stamp_s, rec.yaw_rate)
        elif isinstance(rec, OdomRecord):
            odom.add(rec)
            while pending and odom.t and pending[0].stamp_s <= odom.t[-1]:
                r = pending.pop(0)
                p = odom.at(r.stamp_s)
                if p is None:
                    dropped += 1
                else:
                    use(r, p, tuple(lidar_offset))
        elif isinstance(rec, LaserRecord):
            if rec.odom_pose is not None:
                offset = tuple(between(rec.odom_pose, rec.laser_pose)) if rec.laser_pose is not None \
                    else tuple(lidar_offset)
                use(rec, np.asarray(rec.odom_pose, float), offset)
            else:
                pending.append(rec)
        for line in slam.take_events():
            log(f"slam: {line}")
    dropped += len(pending)
    wall = time.perf_counter() - t0

    if not slam.keyframes:
        raise ValueError(f"{path}: no scan with odometry in the log ({reader.summary()})")
    stamps = np.array([k.stamp_s for k in slam.keyframes])
    write_tum(out / "trajectory.tum", np.column_stack([stamps, slam.estimates]))
    write_tum(out / "odometry.tum", np.array(odometry_rows, float).reshape(-1, 4))
    slam.graph.save_g2o(str(out / "graph.g2o"))
    g = make_grid(grid)
    layouts: dict = {}        # the keyframes' scans by beam layout (one lidar: one C++ call)
    for i, t in enumerate(stamps):
        rec = scans[t][0]
        layouts.setdefault((len(rec.ranges), rec.angle_min, rec.angle_increment, rec.range_min, rec.range_max),
                           []).append(i)
    for (_, amin, inc, rmin, rmax), idx in layouts.items():
        sensor = compose(slam.estimates[idx], np.array([scans[stamps[i]][1] for i in idx]))
        ranges = np.stack([np.asarray(scans[stamps[i]][0].ranges, np.float32) for i in idx])
        g.insert_scans(sensor, ranges, amin, inc, rmin, rmax, no_return_clear_m=grid.no_return_clear_m,
                       range_cap_m=grid.range_cap_m)
    save_map(out / "map", g.occupancy(), g.resolution, (g.origin_x, g.origin_y))
    return OfflineResult(keyframes=len(slam.keyframes), scans=len(odometry_rows), scans_dropped=dropped,
                         log_seconds=(last - first) if first is not None else 0.0, wall_seconds=wall,
                         resets=slam.counts["resets"], stats=slam.stats(), log_summary=reader.summary())
