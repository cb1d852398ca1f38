"""The live SLAM node's policy (ROS-free): what scripts/slam does with each scan, gyro sample, tag
and clock reading, as calls that take plain data and ``now`` and return what the node is to do
(publish the path, clear its TF buffer, log). The node adds the TF lookups, the messages, the
topics and a lock: its subscribers run on threads of their own.

- Scan / gyro synchronisation (``GyroQueue``): while the IMU talks, a scan waits until the gyro
  samples up to its stamp are in (they often come just after the scan), so that the heading of
  the step is the gyro's. A scan goes at once when the IMU has been silent for ``IMU_SILENT_S``
  before its stamp (no IMU, or one that stopped), and the oldest goes when more than
  ``MAX_PENDING`` wait (an IMU that stalls).
- Tag range gate (``tag_in_base``, ``tag_plausible``): a detection (camera frame) is moved into
  the base frame with its covariance; one that is not finite, or farther than
  ``MAX_TAG_RANGE_M``, is absurd for our cameras and ignored.
- Clock-jump reset (``ClockWatch``, ``LiveSlam.clock``): the clock going back more than
  ``TIME_JUMP_BACK_S`` (a restarted simulation, a looping bag played with --clock) clears the
  state: the session forgets the core's graph, the waiting scans, the odometry and map -> odom;
  the node its TF buffer.

``LiveSlam`` (mode mapping: ``slam.Slam``'s graph) and ``LiveLocalization`` (mode localization:
``localization.Localizer`` in a saved map) put these in front of the core, keep what the node
publishes (``map_to_odom``, the path) and write what ``~save`` asks for.
"""
from __future__ import annotations

import math
import os
from abc import ABC, abstractmethod
from collections import deque
from dataclasses import dataclass
from typing import Any, Deque, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..evaluation.trajectory_metrics import write_tum
from .localization import Localizer
from .slam import Slam

TIME_JUMP_BACK_S = 1.0         # the clock going back this far is a new run, not jitter
IMU_SILENT_S = 0.5             # no IMU sample this long before a scan: the IMU is off, don't wait
MAX_PENDING = 3                # scans waiting for the gyro at most (a stalled IMU)
SILENT_SCANS = 5               # scans in a row without the IMU before the node says so
MAX_TAG_RANGE_M = 8.0          # a tag reported farther than this is absurd for our cameras


class ClockWatch:
    """Whether the clock jumped back since the last reading (more than ``jump_back_s``)."""

    def __init__(self, jump_back_s: float = TIME_JUMP_BACK_S):
        self.jump_back_s = jump_back_s
        self.last_s = -math.inf

    def jumped_back(self, now_s: float) -> bool:
        jumped = now_s < self.last_s - self.jump_back_s
        self.last_s = now_s
        return jumped


class GyroQueue:
    """Scans waiting for the gyro samples up to their stamp (see the module). ``add_scan`` and
    ``add_imu`` return the scans to process now, oldest first, as (stamp, what was queued)."""

    def __init__(self, imu_silent_s: float = IMU_SILENT_S, max_pending: int = MAX_PENDING):
        self.imu_silent_s = imu_silent_s
        self.max_pending = max_pending
        self.pending: Deque[Tuple[float, Any]] = deque()
        self.imu_stamp = -math.inf           # the newest IMU sample's stamp
        self.silent_scans = 0                # scans in a row that found the IMU silent (went at once)

    def add_scan(self, stamp_s: float, scan: Any) -> List[Tuple[float, Any]]:
        self.pending.append((stamp_s, scan))
        silent = self.imu_stamp < stamp_s - self.imu_silent_s
        self.silent_scans = self.silent_scans + 1 if silent else 0
        return self._ready(force=silent)

    @property
    def silent(self) -> bool:
        """The IMU silent for SILENT_SCANS scans in a row (not just slow to start): say so."""
        return self.silent_scans >= SILENT_SCANS

    def silence_line(self) -> str:
        """The node's line while the IMU is ``silent`` (none, or one that stopped)."""
        last = "none yet" if self.imu_stamp == -math.inf else f"the last at {self.imu_stamp:.2f} s"
        return (f"no IMU sample in the {self.imu_silent_s:g} s before each of the last {self.silent_scans} "
                f"scans ({last}): headings from the wheels alone")

    def add_imu(self, stamp_s: float) -> List[Tuple[float, Any]]:
        self.imu_stamp = stamp_s
        return self._ready(force=False)

    def clear(self) -> None:
        self.pending.clear()
        self.imu_stamp = -math.inf

    def _ready(self, force: bool) -> List[Tuple[float, Any]]:
        out = []
        while self.pending and (force or self.pending[0][0] <= self.imu_stamp or len(self.pending) > self.max_pending):
            out.append(self.pending.popleft())
        return out


def tag_in_base(position, covariance, base_from_camera: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """A tag's position (m) and its 3 x 3 covariance in the base frame, from the camera frame's
    ``position`` (x, y, z) and ``covariance`` (the pose's 6 x 6, row-major: position first);
    ``base_from_camera``: the 4 x 4 transform."""
    rotation, translation = base_from_camera[:3, :3], base_from_camera[:3, 3]
    xyz = rotation @ np.asarray(position, float) + translation
    cov = rotation @ np.asarray(covariance, float).reshape(6, 6)[:3, :3] @ rotation.T
    return xyz, cov


def tag_plausible(xyz: np.ndarray, cov: np.ndarray, max_range_m: float = MAX_TAG_RANGE_M) -> bool:
    """Finite, and within ``max_range_m`` of the base (horizontally)."""
    return bool(np.isfinite(xyz).all() and np.isfinite(cov).all()) and math.hypot(xyz[0], xyz[1]) <= max_range_m


def pose_std(covariance: Sequence[float]) -> Tuple[Optional[float], Optional[float]]:
    """(std m, std rad) of a 6 x 6 pose covariance (rviz's 2D Pose Estimate: row-major), the
    larger of x's and y's; None where it gives none (a variance of 0: the localiser's own)."""
    cov = np.asarray(covariance, float).reshape(6, 6)
    std_m = math.sqrt(max(cov[0, 0], cov[1, 1])) if cov[0, 0] > 0 else None
    std_rad = math.sqrt(cov[5, 5]) if cov[5, 5] > 0 else None
    return std_m, std_rad


@dataclass(frozen=True, eq=False)
class PathUpdate:
    """What the node publishes after an update: /slam/path (map-frame poses (x, y, yaw) at their
    scans' stamps), the loop closures (pairs of path indices) and the landmarks
    {family:id: ((x, y) m, 2 x 2 marginal covariance)}."""
    stamps: List[float]
    poses: np.ndarray
    loops: List[Tuple[int, int]]
    landmarks: Dict[str, tuple]


class _Session(ABC):
    """What both modes share: the clock-jump reset, the scans in through the gyro queue, the
    odometry kept for odometry.tum, map -> odom for the node's TF timer, the core's events."""

    def __init__(self, core):
        self.core = core
        self.queue = GyroQueue()
        self.clock_watch = ClockWatch()
        # replaced whole: the node's TF timer reads it without the lock. None until the first
        # update: no map -> odom before the map is anchored, so nothing downstream (the mapper,
        # the explorer) starts the robot moving while odometry alone defines the map frame
        self.map_to_odom: Optional[Tuple[float, float, float]] = None
        self.odom_poses: List[tuple] = []    # (stamp, odom pose) per scan, for odometry.tum

    def clock(self, now_s: float) -> bool:
        """The clock at a scan. True: it jumped back, the state is cleared, the scan is not to
        be used (and the node clears its TF buffer)."""
        if not self.clock_watch.jumped_back(now_s):
            return False
        self.core.reset(f"time jumped back to {now_s:.2f} s")
        self.queue.clear()
        self.map_to_odom = None
        self.odom_poses.clear()
        return True

    def add_scan(self, stamp_s: float, points_base: np.ndarray, odom) -> Optional[PathUpdate]:
        """A scan (points in the base frame) with the odometry pose at its stamp; what to
        publish, or None."""
        self.odom_poses.append((stamp_s, odom))
        return self._update(self.queue.add_scan(stamp_s, (points_base, odom)))

    def take_events(self) -> list:
        return self.core.take_events()

    @abstractmethod
    def _update(self, scans) -> Optional[PathUpdate]:
        """The scans the queue let through, (stamp, (points, odom)) each, into the core; what
        to publish, or None."""

    def _save_odometry(self, out_dir: str) -> None:
        write_tum(os.path.join(out_dir, "odometry.tum"), np.array([(t, *p) for t, p in self.odom_poses]).reshape(-1, 4))


class LiveSlam(_Session):
    """mode mapping: scans, gyro and tags into ``slam.Slam``'s graph."""

    def add_imu(self, stamp_s: float, yaw_rate_radps: float) -> Optional[PathUpdate]:
        self.core.add_imu(stamp_s, yaw_rate_radps)
        return self._update(self.queue.add_imu(stamp_s))

    def add_tag(self, stamp_s: float, name: str, xyz_base: np.ndarray, cov_base: np.ndarray,
                odom_pose) -> Optional[str]:
        """A plausible tag (``tag_in_base``, ``tag_plausible``) with the odometry pose at its
        image's stamp; why it was not used, or None."""
        return self.core.add_tag(stamp_s, name, xyz_base[:2], cov_base[:2, :2], odom_pose)

    def _update(self, scans) -> Optional[PathUpdate]:
        added = False
        for stamp, (points, odom) in scans:
            added |= self.core.add_scan(stamp, points, odom)
        if not added:
            return None
        self.map_to_odom = tuple(float(v) for v in self.core.map_to_odom())
        g = self.core.graph
        landmarks = {name: (xy, g.landmark_marginal(name)) for name, xy in g.landmarks().items()}
        return PathUpdate([k.stamp_s for k in self.core.keyframes], self.core.estimates.copy(), list(g.loops()),
                          landmarks)

    def status_line(self) -> str:
        st = self.core.stats()
        return (f"{st['keyframes']} keyframes ({st['matched']} matched, {st['degenerate']} degenerate), loop "
                f"closures {st['loop_accepted']} of {st['loop_tried']} tried accepted, iSAM2 "
                f"{st.get('isam2_ms_median', float('nan')):.1f} ms median"
                + (f", gyro scale error {100 * st['gyro_scale']:+.2f} % (std {100 * st['gyro_scale_std']:.2f} %), "
                   f"bias {1e3 * st['gyro_bias_radps']:+.3f} mrad/s (std {1e3 * st['gyro_bias_std_radps']:.3f})"
                   if "gyro_scale" in st else ""))

    def save(self, out_dir: str, why: str) -> str:
        """graph.g2o, trajectory.tum (keyframes, optimised) and odometry.tum into ``out_dir``;
        the line to log. OSError when there is nothing to save or it cannot be written."""
        os.makedirs(out_dir, exist_ok=True)
        if self.core.graph is None:
            raise OSError("nothing to save: no keyframe yet")
        self.core.graph.save_g2o(os.path.join(out_dir, "graph.g2o"))
        write_tum(os.path.join(out_dir, "trajectory.tum"),
                  np.column_stack([[k.stamp_s for k in self.core.keyframes], self.core.estimates]))
        self._save_odometry(out_dir)
        return f"graph and trajectories saved ({why}) to {out_dir}; {self.core.stats()}"


class LiveLocalization(_Session):
    """mode localization: scans into ``localization.Localizer``; no gyro and no tags (odometry
    alone between matches; the tracker places tags in the map frame)."""

    def __init__(self, core: Localizer):
        super().__init__(core)
        self.matched: List[tuple] = []       # (stamp, map pose) at every update, for /slam/path

    def set_pose(self, pose, covariance: Sequence[float]) -> None:
        """Put the robot at ``pose`` (map frame) with the std of a 6 x 6 ``covariance``."""
        self.core.set_pose(pose, *pose_std(covariance))

    def _update(self, scans) -> Optional[PathUpdate]:
        added = False
        for stamp, (points, odom) in scans:
            if self.core.add_scan(stamp, points, odom):
                added = True
                self.matched.append((stamp, self.core.pose.copy()))
        if not added:
            return None
        self.map_to_odom = tuple(float(v) for v in self.core.map_to_odom())
        return PathUpdate([t for t, _ in self.matched], np.array([p for _, p in self.matched]), [], {})

    def status_line(self) -> str:
        return f"localisation {self.core.stats()}"

    def save(self, out_dir: str, why: str) -> str:
        """trajectory.tum (the pose at every match) and odometry.tum into ``out_dir``; the line
        to log. OSError as ``LiveSlam.save``."""
        os.makedirs(out_dir, exist_ok=True)
        if not self.matched:
            raise OSError("nothing to save: no scan matched yet")
        write_tum(os.path.join(out_dir, "trajectory.tum"), np.array([(t, *p) for t, p in self.matched]))
        self._save_odometry(out_dir)
        return f"localisation trajectory saved ({why}) to {out_dir}; {self.core.stats()}"
