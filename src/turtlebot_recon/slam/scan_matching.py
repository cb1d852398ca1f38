"""Scan matching, the SLAM front end: a lidar scan laid on a local submap of earlier scans.

The work is done in C++ (``_native.ScanMatcher``, include/turtlebot_recon/scan_matcher.hpp):
Olson's correlative search over a window around the guess (ICRA 2009), then Censi's
point-to-line ICP (ICRA 2008), a covariance from the ICP Hessian and a corridor check on its
translational block. This module holds the settings, turns a LaserScan's numbers into points
and returns plain dataclasses.

Frames: ``points`` are in the scan's own (sensor) frame; ``reference`` and the returned pose
are in the reference (map) frame. The covariance is GTSAM's Pose2 convention: (x, y, yaw) of a
right perturbation, i.e. in the matched pose's own frame, ready for a ``BetweenFactorPose2`` or
``PriorFactorPose2`` noise model.

Bad input: a non-finite number in ``points``, ``reference`` or ``guess`` and wrong shapes raise
ValueError naming the argument (a caller that feeds NaN has a bug; ``scan_points`` already drops
invalid beams). No match is an ordinary outcome: too few points on either side, too few
point-to-line pairs, or an ICP that slides away from the correlative search's pose (wrong
pairs: a wrong reference); ``match`` then returns None and ``last_failure`` says why.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Optional

import numpy as np

from .. import _native
from ..config import positive, require


@dataclass(frozen=True)
class MatcherSettings:
    search_xy_m: float = 0.3            # m, half-width of the coarse search window in x and y
    search_yaw_rad: float = 0.3         # rad, half-width of the coarse window in yaw
    grid_resolution_m: float = 0.05     # m, cell of the lookup grid = translation step of the search
    coarse_resolution_m: float = 0.2    # m, side of the translation blocks the search bounds at once
                                        # (Olson's low-resolution grid; a multiple of grid_resolution_m)
    coarse_yaw_step_rad: float = 0.015  # rad, yaw step of the search (0.05 m of arc at 3.5 m)
    sigma_m: float = 0.03               # m, lidar range noise std (LDS-01: 1 cm to 3.5 % at 3.5 m);
                                        # blurs the lookup grid (>= one cell), floors the covariance
    icp_iterations: int = 15            # most Gauss-Newton iterations of the ICP
    max_correspondence_m: float = 0.15  # m, a scan point pairs with a reference line this near
    normal_radius_m: float = 0.1        # m, reference points of the cells within this fit the
                                        # line a scan point is matched to (a wider disc takes in a
                                        # door jamb's or a corner's other face: 0.15 pushed scans
                                        # 2-3 mm forward per keyframe in a corridor)
    huber_m: float = 0.03               # m, Huber kernel width: larger residuals weigh k / |r|
    inlier_m: float = 0.05              # m, residual up to which a scan point counts in the score
    min_points: int = 30                # fewer scan points, reference points or point-to-line
                                        # pairs: no match (None)
    degeneracy_ratio: float = 0.03      # smallest / largest eigenvalue of the translational
                                        # information below this: degenerate (a corridor)
    degenerate_std_m: float = 1.0       # m, std put on the degenerate direction: odometry rules it
    max_range_m: float = 20.0           # m, scan points farther from the sensor are not matched: it
                                        # bounds the reference's grid whatever a log's laser reports
                                        # (SICK logs: 80 m; C++ refuses a value whose grid is too big)

    def __post_init__(self):
        self.validate("MatcherSettings")

    def validate(self, src: str) -> None:
        positive(src, self, "search_xy_m", "grid_resolution_m", "coarse_resolution_m",
                 "coarse_yaw_step_rad", "sigma_m", "max_correspondence_m", "normal_radius_m",
                 "huber_m", "inlier_m", "degenerate_std_m", "max_range_m")
        require(isinstance(self.search_yaw_rad, (int, float))
                and 0.0 <= self.search_yaw_rad <= math.pi, src, "search_yaw_rad",
                f"must be in [0, pi] rad, got {self.search_yaw_rad!r}")
        require(self.coarse_resolution_m >= self.grid_resolution_m, src, "coarse_resolution_m",
                f"must be >= grid_resolution_m ({self.grid_resolution_m}), got "
                f"{self.coarse_resolution_m}")
        require(isinstance(self.icp_iterations, int) and self.icp_iterations >= 1, src,
                "icp_iterations", f"must be an integer >= 1, got {self.icp_iterations!r}")
        require(isinstance(self.min_points, int) and self.min_points >= 3, src, "min_points",
                f"must be an integer >= 3 (three unknowns), got {self.min_points!r}")
        require(isinstance(self.degeneracy_ratio, (int, float)) and 0.0 <= self.degeneracy_ratio < 1.0,
                src, "degeneracy_ratio", f"must be in [0, 1), got {self.degeneracy_ratio!r}")


@dataclass(frozen=True)
class MatchResult:
    pose: np.ndarray          # (3,) x m, y m, yaw rad of the scan frame in the reference frame
    covariance: np.ndarray    # (3, 3) of (x, y, yaw), body frame (GTSAM Pose2): m^2, m rad, rad^2
    score: float              # [0, 1]: fraction of scan points within inlier_m of the reference
    response: float           # [0, 1]: Olson's normalised correlative response at the coarse pose
    degenerate: bool          # the scan does not fix the pose along degenerate_direction
    degenerate_direction: Optional[np.ndarray]   # (2,) unit, reference frame; None unless degenerate
    points_used: int          # point-to-line correspondences at the solution


def scan_points(ranges, angle_min: float, angle_increment: float, range_min: float,
                range_max: float) -> np.ndarray:
    """(n, 2) float64 points (m) in the sensor frame from a LaserScan's numbers; beam i points
    along angle_min + i * angle_increment (rad). NaN, inf, 0.0 (no return) and beams outside
    [range_min, range_max] are dropped."""
    r = np.asarray(ranges, dtype=np.float64).ravel()
    angles = angle_min + angle_increment * np.arange(r.size)
    with np.errstate(invalid="ignore"):
        keep = np.isfinite(r) & (r >= range_min) & (r <= range_max) & (r > 0.0)
    r, angles = r[keep], angles[keep]
    return np.stack([r * np.cos(angles), r * np.sin(angles)], axis=1)


class ScanMatcher:
    """One matcher; its C++ buffers are reused across calls (one call at a time runs, others
    wait: safe from several threads, the GIL released while it works)."""

    def __init__(self, settings: MatcherSettings = MatcherSettings()):
        self.settings = settings
        self._native = _native.ScanMatcher(**asdict(settings))
        self.last_failure: Optional[str] = None

    def match(self, points: np.ndarray, reference: np.ndarray, guess,
              views: Optional[np.ndarray] = None) -> Optional[MatchResult]:
        """Pose of the scan ``points`` ((n, 2), its own frame) on ``reference`` ((m, 2), map
        frame), searched around ``guess`` (x, y, yaw; m, m, rad). ``views`` ((m, 2), map frame,
        or None): where each reference point was seen from; with them a surface's two faces are
        told apart (a scan point pairs with the face its ray meets, the scan seen from its
        frame's origin), so a thin wall seen from both sides does not pull scans into its middle.
        None when there is no match (see the module's docstring); ``last_failure`` then says
        why (None after a match). ValueError for a non-finite number or a wrong shape."""
        r = self._native.match(np.asarray(points, dtype=np.float64),
                               np.asarray(reference, dtype=np.float64), guess,
                               None if views is None else np.asarray(views, dtype=np.float64))
        if not r.ok:
            self.last_failure = r.failure
            return None
        self.last_failure = None
        return MatchResult(
            pose=np.array(r.pose), covariance=r.covariance, score=r.score, response=r.response,
            degenerate=r.degenerate,
            degenerate_direction=np.array(r.degenerate_direction) if r.degenerate else None,
            points_used=r.points_used)
