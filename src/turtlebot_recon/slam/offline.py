"""The SLAM pipeline over a recorded log (``make slam-log``): a log reader's records in (a
CARMEN log's ``slam.logs.CarmenReader``, a rosbag's ``ros.bags.BagReader``: anything that yields
the records of ``slam.logs`` and has ``path`` and ``summary()``), the trajectory (the pose at
every scan), the optimised keyframes, the odometry, the map and the graph out, as fast as the CPU
allows.

trajectory.tum holds a pose for every scan, as the relations metric (Kümmerle et al. 2009) asks
for poses at scan stamps: a keyframe's optimised pose at its own stamp, and between two
keyframes the odometry carried by the map -> odom correction of the two, blended by time
(``scan_trajectory``). Interpolating the keyframes linearly instead put the Intel Lab log's
scans 4.2 cm (mean; p90 10.6 cm, 5 deg) off that: keyframes come every 0.25 m or 15 deg, and the
robot stops and turns between them. keyframes.tum holds the keyframes alone.

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
from ..geometry import between, compose, inverse, transform_points, wrap_angle
from ..mapping.grid import GridSettings, make_grid
from ..mapping.map_io import load_map_as, save_map
from .logs import ImuRecord, LaserRecord, OdomRecord, TimeJump
from .scan_matching import scan_points
from .localization import LocalizationSettings, Localizer
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
    stopped: str = ""          # where and why the run stopped before the log's end ('' = it did not)

    @property
    def speedup(self) -> float:
        return self.log_seconds / self.wall_seconds if self.wall_seconds > 0 else math.inf


@dataclass
class _Progress:
    """How far ``_feed`` got: kept as it goes, so that a run stopped by an exception still
    says where."""
    first_s: Optional[float] = None    # first and last stamps of the log's records
    last_s: Optional[float] = None
    scans: int = 0                     # scans handed on with their odometry
    dropped: int = 0                   # scans dropped for want of odometry

    @property
    def log_seconds(self) -> float:
        return (self.last_s - self.first_s) if self.first_s is not None else 0.0


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


def _feed(reader, lidar_offset, on_scan, on_imu, on_reset, log, events, progress: _Progress) -> None:
    """Every scan of the log with the odometry pose at its stamp and the lidar's mounting:
    ``on_scan(rec, pose, offset)``; gyro samples to ``on_imu``; a jump back in time clears the
    state (``on_reset(why)``). ``events()`` gives the core's lines to log after each record.
    ``progress`` is kept up to date as it goes."""
    odom, pending = _OdometryTrack(), []   # bag scans waiting for odometry after their stamp

    def scan(rec, pose, offset) -> None:
        progress.scans += 1
        on_scan(rec, pose, offset)

    for rec in reader:
        if isinstance(rec, TimeJump):
            on_reset(f"time went back from {rec.previous_s:.3f} s to {rec.stamp_s:.3f} s in the log")
            odom, pending = _OdometryTrack(), []
            continue
        stamp = getattr(rec, "stamp_s", None)
        if stamp is not None:
            progress.first_s = stamp if progress.first_s is None else progress.first_s
            progress.last_s = stamp
        if isinstance(rec, ImuRecord):
            on_imu(rec.stamp_s, rec.yaw_rate)
        elif isinstance(rec, OdomRecord):
            odom.add(rec)
            while pending and odom.t and pending[0].stamp_s <= odom.t[-1]:
                r = pending.pop(0)
                p = odom.at(r.stamp_s)
                if p is None:
                    progress.dropped += 1
                else:
                    scan(r, p, tuple(lidar_offset))
        elif isinstance(rec, LaserRecord):
            if rec.odom_pose is not None:
                offset = tuple(between(rec.odom_pose, rec.laser_pose)) if rec.laser_pose is not None \
                    else tuple(lidar_offset)
                scan(rec, np.asarray(rec.odom_pose, float), offset)
            else:
                pending.append(rec)
        for line in events():
            log(f"slam: {line}")
    progress.dropped += len(pending)


def _base_points(rec: LaserRecord, offset) -> np.ndarray:
    pts = scan_points(rec.ranges, rec.angle_min, rec.angle_increment, rec.range_min, rec.range_max)
    return transform_points(offset, pts)


JUMP_GAP_M = 0.5     # a scan's pose carried from the two keyframes around it this far apart (m, or
                     # rad in yaw): an odometry jump between them, the nearer keyframe's is taken


def scan_trajectory(key_rows, key_poses, odometry) -> np.ndarray:
    """(n, 4) ``t, x, y, yaw``, sorted by stamp: the map pose of each of the ``odometry`` rows
    (``t, x, y, yaw``: the odometry at every scan, in the order the scans came) from the
    keyframes' optimised ``key_poses``, keyframe k being the scan of row ``key_rows[k]``
    (ascending). A scan between keyframes a and b is carried from each by the odometry since (or
    until) it, ``pose_a = est_a (+) (odom_a^-1 (+) odom)``, and the two are blended by its place
    between them in the scan order (not by stamp: a log's stamps can go back), so a
    keyframe's own scan lies on its pose and the odometry's drift over the step is spread along
    it. Before the first keyframe and after the last, that keyframe's; across an odometry jump
    (the two more than JUMP_GAP_M apart) the nearer keyframe's."""
    odo = np.asarray(odometry, float).reshape(-1, 4)
    rows = np.asarray(key_rows, int)
    kp = np.asarray(key_poses, float).reshape(-1, 3)
    if not len(odo) or not len(rows):
        return np.zeros((0, 4))
    i = np.arange(len(odo))
    b = np.clip(np.searchsorted(rows, i, side="left"), 0, len(rows) - 1)
    a = np.clip(np.searchsorted(rows, i, side="right") - 1, 0, len(rows) - 1)
    kodo = odo[rows, 1:4]
    pa = compose(kp[a], between(kodo[a], odo[:, 1:4]))
    pb = compose(kp[b], between(kodo[b], odo[:, 1:4]))
    span = rows[b] - rows[a]
    f = np.where(span > 0, np.clip((i - rows[a]) / np.maximum(span, 1), 0.0, 1.0), 0.0)
    d = np.column_stack([pb[:, :2] - pa[:, :2], wrap_angle(pb[:, 2] - pa[:, 2])])
    f = np.where(np.max(np.abs(d), axis=1) > JUMP_GAP_M, np.round(f), f)
    pose = pa + f[:, None] * d
    pose[:, 2] = wrap_angle(pose[:, 2])
    order = np.argsort(odo[:, 0], kind="stable")
    return np.column_stack([odo[:, 0], pose])[order]


def run_log(reader, output_dir, settings: SlamSettings = SlamSettings(), wheel_separation_m: float = 0.16,
            lidar_offset=(0.0, 0.0, 0.0), grid: GridSettings = GridSettings(), log=print) -> OfflineResult:
    """SLAM over the records of ``reader``; writes trajectory.tum (every scan), keyframes.tum,
    odometry.tum, map.pgm/.yaml and graph.g2o into ``output_dir``. Whatever stops the run before the log's end (an
    exception anywhere in the pipeline), what it has is written and ``stopped`` says where and
    why. ValueError when the log gave no keyframe at all (odometry.tum is written then)."""
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    slam = Slam(settings, wheel_separation_m)
    scans: dict = {}                   # id(keyframe) -> (its record, the lidar's offset), for the map
    odometry_rows: list = []
    progress = _Progress()
    t0 = time.perf_counter()

    def use(rec: LaserRecord, pose, offset) -> None:
        odometry_rows.append((rec.stamp_s, *pose))
        # a log whose laser pose is its odometry pose does not say where the laser sits
        mount_known = rec.laser_pose is None or any(abs(v) > 1e-9 for v in offset)
        if slam.add_scan(rec.stamp_s, _base_points(rec, offset), pose, mount_known):
            scans[id(slam.keyframes[-1])] = (rec, offset, len(odometry_rows) - 1)

    def reset(why: str) -> None:
        slam.reset(why)
        scans.clear()
        odometry_rows.clear()

    stopped = ""
    try:
        _feed(reader, lidar_offset, use, slam.add_imu, reset, log, slam.take_events, progress)
    except Exception as exc:   # noqa: BLE001  whatever it is, what the run has is written below
        where = f"scan {progress.scans}" + (f" (stamp {progress.last_s:.3f} s)" if progress.last_s is not None else "")
        stopped = f"stopped at {where}, keyframe {len(slam.keyframes)}: {type(exc).__name__}: {' '.join(str(exc).split())}"
    wall = time.perf_counter() - t0
    write_tum(out / "odometry.tum", np.array(odometry_rows, float).reshape(-1, 4))
    if not slam.keyframes:
        raise ValueError(f"{reader.path}: no scan with odometry in the log ({reader.summary()})"
                         + (f"; {stopped}" if stopped else ""))
    _write_slam(out, slam, scans, grid, odometry_rows)
    return OfflineResult(keyframes=len(slam.keyframes), scans=len(odometry_rows), scans_dropped=progress.dropped,
                         log_seconds=progress.log_seconds, wall_seconds=wall, resets=slam.counts["resets"],
                         stats=slam.stats(), log_summary=reader.summary(), stopped=stopped)


def _write_slam(out: Path, slam: Slam, scans: dict, grid: GridSettings, odometry_rows: list) -> None:
    """trajectory.tum (every scan), keyframes.tum, graph.g2o and the map (the keyframes' scans
    at their estimates)."""
    stamps = np.array([k.stamp_s for k in slam.keyframes])
    write_tum(out / "keyframes.tum", np.column_stack([stamps, slam.estimates]))
    # the keyframes whose scan is known (not the one a run stopped in the middle of)
    kept = [i for i, kf in enumerate(slam.keyframes) if id(kf) in scans]
    write_tum(out / "trajectory.tum", scan_trajectory([scans[id(slam.keyframes[i])][2] for i in kept],
                                                      slam.estimates[kept], odometry_rows))
    slam.graph.save_g2o(str(out / "graph.g2o"))
    g = make_grid(grid)
    layouts: dict = {}        # the keyframes' scans by beam layout (one lidar: one C++ call)
    for i, kf in enumerate(slam.keyframes):
        if id(kf) not in scans:   # the keyframe a run stopped in the middle of
            continue
        rec = scans[id(kf)][0]
        layouts.setdefault((len(rec.ranges), rec.angle_min, rec.angle_increment, rec.range_min, rec.range_max),
                           []).append(i)
    for (_, amin, inc, rmin, rmax), idx in layouts.items():
        kfs = [slam.keyframes[i] for i in idx]
        sensor = compose(slam.estimates[idx], np.array([scans[id(k)][1] for k in kfs]))
        ranges = np.stack([np.asarray(scans[id(k)][0].ranges, np.float32) for k in kfs])
        g.insert_scans(sensor, ranges, amin, inc, rmin, rmax, no_return_clear_m=grid.no_return_clear_m,
                       range_cap_m=grid.range_cap_m)
    save_map(out / "map", g.occupancy(), g.resolution, (g.origin_x, g.origin_y))


def localize_log(reader, map_file, output_dir, settings: LocalizationSettings = LocalizationSettings(),
                 wheel_separation_m: float = 0.16, lidar_offset=(0.0, 0.0, 0.0), initial_pose=(0.0, 0.0, 0.0),
                 log=print) -> OfflineResult:
    """mode localization over the records of ``reader``: tracks the robot in ``map_file`` (a
    map_server YAML) from ``initial_pose``; writes trajectory.tum (the pose at every match) and
    odometry.tum into ``output_dir``. ``stats`` holds the localiser's counts."""
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    occupancy, resolution, origin = load_map_as(map_file, "map")
    loc = Localizer(settings, occupancy, resolution, origin, wheel_separation_m)
    loc.set_pose(initial_pose)
    matched, odometry_rows = [], []
    t0 = time.perf_counter()

    def use(rec: LaserRecord, pose, offset) -> None:
        odometry_rows.append((rec.stamp_s, *pose))
        if loc.add_scan(rec.stamp_s, _base_points(rec, offset), pose):
            matched.append((rec.stamp_s, *loc.pose))

    progress = _Progress()
    _feed(reader, lidar_offset, use, lambda *_: None, loc.reset, log, loc.take_events, progress)
    wall = time.perf_counter() - t0
    if not matched:
        raise ValueError(f"{reader.path}: no scan with odometry in the log ({reader.summary()})")
    write_tum(out / "trajectory.tum", np.array(matched, float))
    write_tum(out / "odometry.tum", np.array(odometry_rows, float).reshape(-1, 4))
    return OfflineResult(keyframes=len(matched), scans=len(odometry_rows), scans_dropped=progress.dropped,
                         log_seconds=progress.log_seconds, wall_seconds=wall, resets=0, stats=loc.stats(),
                         log_summary=reader.summary())
