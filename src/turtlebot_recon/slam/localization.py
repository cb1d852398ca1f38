"""Localisation in a saved map (ROS-free): seed 003's scan-to-map alignment, done properly.

Seed 003 aligned each scan to the map by least squares from odometry's guess alone and lost
the robot at 12 % odometry noise. Here the map is a saved occupancy grid (map_server's PGM/YAML,
e.g. the one a SLAM run wrote) and the robot's map pose is an extended Kalman filter over
(x, y, yaw):

* prediction: wheel odometry's step since the last update, its covariance from the wheel-slip
  model SLAM uses (``odometry_covariance``);
* correction: every ``update_distance_m`` / ``update_angle_rad`` of travel the scan is matched
  to the map by the SLAM front end (C++: Olson's correlative search around the prediction, then
  point-to-line ICP, the Hessian covariance, inflated along a corridor's degenerate direction)
  and fused when it agrees with the prediction (Mahalanobis gate over both covariances);
* recovery: after ``lost_after`` updates in a row without a fused match the filter widens its
  search (the loop-closure window) and takes the first match scoring ``relocalise_min_score``.

The map is matched through its surface, not its cells: a point at the middle of every face
between an occupied and a free cell. A wall drawn on cell boundaries (the simulator's) lies
exactly on those faces; occupied cells' centres would sit half a cell inside it and pull every
pose half a cell away from each wall it sees. Faces turned away from the robot are left out (a
lidar cannot see them): a thin wall's two faces, 10 cm apart, would otherwise fit no line.

Frames: poses are the base's in the map frame, the odometry in the odom frame; ``map_to_odom``
is what the node publishes. Units: m, rad.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..config import positive, require
from ..geometry import between, compose, inverse, wrap_angle
from ..mapping.map_io import OCCUPIED_THRESH
from .scan_matching import MatcherSettings, ScanMatcher
from .slam import MAX_PLAUSIBLE_SPEED_MPS, MAX_PLAUSIBLE_TURN_RADPS, SlamSettings, odometry_covariance


@dataclass(frozen=True)
class LocalizationSettings:
    """mode:=localization parameters (config/slam.yaml, block localization). Units in names."""
    update_distance_m: float = 0.1        # match the scan to the map after this much travel ...
    update_angle_rad: float = 0.1         # ... or this much turning (and at the first scan)
    initial_std_m: float = 0.1            # std of the initial pose (m) ...
    initial_std_rad: float = 0.1          # ... and of its heading (rad)
    reference_radius_m: float = 4.5       # map surface points within this of the prediction are
                                          # matched (the lidar's range + the search window)
    match_min_score: float = 0.5          # matches scoring lower are not used
    match_gate_chi2: float = 16.3         # matches farther than this (Mahalanobis^2 over both
                                          # covariances, 99.9 % for 3 dof) from the prediction
                                          # are not used
    lost_after: int = 5                   # updates in a row without a fused match: search wider
    relocalise_min_score: float = 0.7     # a wide-window match is taken from this score
    relocalise_search_xy_m: float = 1.0   # the wide window: half-width (m) ...
    relocalise_search_yaw_rad: float = 0.5  # ... and in yaw (rad)
    matcher: MatcherSettings = field(default_factory=MatcherSettings)

    def validate(self, src: str) -> None:
        positive(src, self, "update_distance_m", "update_angle_rad", "initial_std_m", "initial_std_rad",
                 "reference_radius_m", "match_gate_chi2", "lost_after", "relocalise_search_xy_m",
                 "relocalise_search_yaw_rad")
        for key in ("match_min_score", "relocalise_min_score"):
            require(0.0 <= getattr(self, key) <= 1.0, src, key, "must be in [0, 1]")


def surface_points(occupancy: np.ndarray, resolution: float, origin) -> tuple:
    """The middle of every face between an obstacle cell (>= OCCUPIED_THRESH) and a free
    one (0 .. threshold): ((n, 2) map-frame points (m), (n, 2) unit normals pointing from the
    obstacle into the free cell). Row 0 at the smallest y."""
    occ = np.asarray(occupancy)
    rows, cols = occ.shape
    wall = occ >= OCCUPIED_THRESH
    free = np.pad((occ >= 0) & ~wall, 1, constant_values=False)
    points, normals = [], []
    for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        # obstacle cells whose neighbour (r + dr, c + dc) is free: a point on their shared edge
        r, c = np.nonzero(wall & free[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols])
        points.append(np.column_stack([origin[0] + (c + 0.5 + 0.5 * dc) * resolution,
                                       origin[1] + (r + 0.5 + 0.5 * dr) * resolution]))
        normals.append(np.tile((float(dc), float(dr)), (len(r), 1)))
    return np.vstack(points), np.vstack(normals)


def _rotation3(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class Localizer:
    """An EKF over the base's map pose, corrected by scan-to-map matches. Feed ``add_scan``
    with every scan (points in the base frame) and the odometry pose at its stamp."""

    def __init__(self, settings: LocalizationSettings, occupancy: np.ndarray, resolution: float, origin,
                 wheel_separation_m: float, odometry: SlamSettings = SlamSettings()):
        settings.validate("localization")
        self.s = settings
        self.odometry = odometry           # the wheel-slip figures of the odometry model
        self.separation = wheel_separation_m
        self.surface, self.normals = surface_points(occupancy, resolution, origin)
        if len(self.surface) < settings.matcher.min_points:
            raise ValueError(f"localization: the map has {len(self.surface)} wall faces next to free cells; "
                             f"at least {settings.matcher.min_points} are needed to match scans")
        self.matcher = ScanMatcher(settings.matcher)
        self.wide_matcher = ScanMatcher(dataclasses.replace(
            settings.matcher, search_xy_m=settings.relocalise_search_xy_m,
            search_yaw_rad=settings.relocalise_search_yaw_rad))
        self.pose = np.zeros(3)            # the base in the map at the last update
        self.start = np.zeros(3)           # the last pose set from outside (reset returns to it)
        self.cov = np.diag([settings.initial_std_m ** 2] * 2 + [settings.initial_std_rad ** 2])
        self.odom: Optional[np.ndarray] = None    # the odometry pose at the last update ...
        self.stamp = -math.inf                    # ... and its time (s)
        self.misses = 0                    # updates in a row without a fused match
        self.counts = dict(updates=0, fused=0, no_match=0, low_score=0, gated=0, relocalised=0, odom_jumps=0)
        self.match_ms: list[float] = []
        self.events: list[str] = []

    # ------------------------------------------------------------------ inputs
    def set_pose(self, pose, std_m: Optional[float] = None, std_rad: Optional[float] = None) -> None:
        """Put the robot at ``pose`` (map frame), e.g. from rviz's 2D Pose Estimate; the next
        scan is matched at once."""
        pose = np.asarray(pose, float)
        if pose.shape != (3,) or not np.isfinite(pose).all():
            self.events.append(f"initial pose {pose.tolist()} refused: not three finite numbers")
            return
        self.pose, self.start = pose.copy(), pose.copy()
        self.cov = np.diag([(std_m or self.s.initial_std_m) ** 2] * 2 + [(std_rad or self.s.initial_std_rad) ** 2])
        self.odom = None
        self.misses = 0

    def reset(self, why: str) -> None:
        """Back to the last pose set (time went backwards: a looping bag, a restarted simulation)."""
        self.set_pose(self.start)
        self.events.append(f"state cleared: {why}; back at ({self.start[0]:.2f}, {self.start[1]:.2f}, "
                           f"{self.start[2]:.2f})")

    def add_scan(self, stamp_s: float, points_base: np.ndarray, odom_pose) -> bool:
        """Returns whether the scan was matched (an update: fused or not)."""
        odom = np.asarray(odom_pose, float)
        if not np.isfinite(odom).all():
            self.events.append(f"odometry pose not finite {odom.tolist()}: scan at {stamp_s:.2f} s skipped")
            return False
        if self.odom is not None:
            step = between(self.odom, odom)
            if math.hypot(step[0], step[1]) < self.s.update_distance_m and abs(step[2]) < self.s.update_angle_rad:
                return False
            dt = max(stamp_s - self.stamp, 1e-3)
            if math.hypot(step[0], step[1]) > MAX_PLAUSIBLE_SPEED_MPS * dt + 0.05 \
                    or abs(step[2]) > MAX_PLAUSIBLE_TURN_RADPS * dt + 0.1:
                # a teleport or a base restart between updates: odometry says nothing; search wide
                self.counts["odom_jumps"] += 1
                self.events.append(f"odometry jumped by ({step[0]:.2f}, {step[1]:.2f}, {step[2]:.2f}) at "
                                   f"{stamp_s:.2f} s: searching the map around the last pose")
                step = np.zeros(3)
                self.misses = max(self.misses, self.s.lost_after)
            self._predict(step)
        self.odom, self.stamp = odom.copy(), float(stamp_s)
        self._correct(np.asarray(points_base, float).reshape(-1, 2), stamp_s)
        return True

    # ------------------------------------------------------------------ outputs
    def map_to_odom(self) -> np.ndarray:
        if self.odom is None:
            return np.zeros(3)
        return compose(self.pose, inverse(self.odom))

    def stats(self) -> dict:
        out = dict(self.counts)
        if self.match_ms:
            out["scan_match_ms_median"] = float(np.median(self.match_ms))
        out["pose_std_m"] = float(math.sqrt(max(np.linalg.eigvalsh(self.cov[:2, :2]).max(), 0.0)))
        return out

    def take_events(self) -> list:
        events, self.events = self.events, []
        return events

    # ------------------------------------------------------------------ internals
    def _predict(self, step: np.ndarray) -> None:
        """x' = x (+) step; the covariance through the Jacobians of the composition (map frame)."""
        yaw = self.pose[2]
        c, s = math.cos(yaw), math.sin(yaw)
        F = np.array([[1.0, 0.0, -s * step[0] - c * step[1]],
                      [0.0, 1.0, c * step[0] - s * step[1]],
                      [0.0, 0.0, 1.0]])
        G = _rotation3(yaw)
        Q = odometry_covariance(step, self.separation, self.odometry)
        self.pose = compose(self.pose, step)
        self.cov = F @ self.cov @ F.T + G @ Q @ G.T

    def _correct(self, points: np.ndarray, stamp_s: float) -> None:
        self.counts["updates"] += 1
        to_robot = self.pose[:2] - self.surface
        near = (np.hypot(*to_robot.T) <= self.s.reference_radius_m) & (np.sum(to_robot * self.normals, axis=1) > 0.0)
        reference = self.surface[near]
        lost = self.misses >= self.s.lost_after
        matcher = self.wide_matcher if lost else self.matcher
        t0 = time.perf_counter()
        match = matcher.match(points, reference, self.pose) \
            if len(points) >= self.s.matcher.min_points and len(reference) >= self.s.matcher.min_points else None
        self.match_ms.append(1e3 * (time.perf_counter() - t0))
        if match is None:
            self._miss("no_match", matcher.last_failure or "too few points")
            return
        if match.score < (self.s.relocalise_min_score if lost else self.s.match_min_score):
            self._miss("low_score", f"score {match.score:.2f}")
            return
        R = _rotation3(match.pose[2])
        meas_cov = R @ match.covariance @ R.T          # body frame -> map frame
        innovation = match.pose - self.pose
        innovation[2] = wrap_angle(innovation[2])
        S = self.cov + meas_cov
        if lost:
            # the prediction is not trusted any more: the match replaces it
            self.pose, self.cov = match.pose.copy(), meas_cov
            self.counts["relocalised"] += 1
            self.events.append(f"relocalised at ({match.pose[0]:.2f}, {match.pose[1]:.2f}, {match.pose[2]:.2f}) "
                               f"at {stamp_s:.2f} s (match score {match.score:.2f})")
            self.misses = 0
            return
        d2 = float(innovation @ np.linalg.solve(S, innovation))
        if d2 > self.s.match_gate_chi2:
            self._miss("gated", f"{math.hypot(*innovation[:2]):.2f} m / {innovation[2]:.2f} rad from the "
                                f"prediction, Mahalanobis^2 {d2:.1f}")
            return
        K = self.cov @ np.linalg.inv(S)
        self.pose = self.pose + K @ innovation
        self.pose[2] = wrap_angle(self.pose[2])
        self.cov = (np.eye(3) - K) @ self.cov
        self.cov = 0.5 * (self.cov + self.cov.T)
        self.counts["fused"] += 1
        self.misses = 0

    def _miss(self, kind: str, detail: str) -> None:
        self.counts[kind] += 1
        self.misses += 1
        if self.misses == self.s.lost_after:
            self.events.append(f"no usable map match for {self.misses} updates in a row (last: {kind}, {detail}): "
                               f"searching {self.s.relocalise_search_xy_m} m / {self.s.relocalise_search_yaw_rad} rad wide")
