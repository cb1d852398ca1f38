"""What the path controllers share: the path they track and the turn-in-place law (ROS-free).

``PathTracker`` holds one controller's grip on the global plan, with the parameters of
``TrackingSettings`` (config/navigator.yaml's ``tracking`` block, one for every controller and
for the navigator's own manoeuvres):

- ``follow(path)``   the path as a ``Track`` (finite waypoints, no repeated neighbours); a path
                     other than the last restarts progress and the goal latch;
- ``advance(xy)``    progress: the arc length of the path point closest to the robot, searched
                     over the whole path once, then only forward within ``progress_window_m``
                     of the last progress (never back to a part passed, nor on to the other leg
                     of a U-turn that comes close);
- ``at_goal(d, r)``  the goal latch: within ``xy_goal_tolerance_m`` of the end in a straight
                     line (d) and along the path (r) once, then for good (until a new path):
                     from there only the goal's heading is corrected;
- ``arrive(...)``    at the goal: "arrived" when no heading is wanted or it is within
                     ``yaw_goal_tolerance_rad``, else the turn in place to it;
- ``turn_rate(err)`` the turn-in-place law: |w| = ``rotate_gain_per_s`` |err|, between
                     ``rotate_speed_min_radps`` and ``rotate_speed_max_radps`` (and the robot's
                     max_angular_radps), with the error's sign;
- ``turn(...)``      a turn in place by an angle where ``BodyCheck.turn_clear`` finds it safe
                     ("rotating"), else a zero command, "blocked", one line why.

``rotate_threshold_rad`` is how far off the heading the way on may lie before a controller
turns in place first (each measures "the way on" its own way: the follower's carrot, DWA's
look-ahead point, MPPI's path point ``rotate_lookahead_m`` ahead). ``Grid`` looks up the
occupancy and costmap at map points; ``finite`` reads a pose or a velocity.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from ..config import positive, require
from ..geometry import inside, points_to_cells, wrap_angle
from ..robot import RobotSpec
from .base import ARRIVED, BLOCKED, ROTATING, ControlInput, ControlOutput
from .footprint import BodyCheck

NO_INFORMATION = 255   # planning.costmap's value, repeated: control must not import planning


@dataclass(frozen=True)
class TrackingSettings:
    progress_window_m: float = 1.0       # closest-point search this far past the last progress:
                                         # covers a cut corner, not the other leg of a U-turn
    xy_goal_tolerance_m: float = 0.1     # under the smallest robot radius (0.105 m); seed 003's
                                         # 0.05 m is one 5 cm cell, which odometry noise defeats
    yaw_goal_tolerance_rad: float = 0.1  # seed 003's angle_tolerance (5.7 deg)
    # turning in place: a differential drive turns on the spot for free, a tight arc sweeps
    # a band beside the path
    rotate_threshold_rad: float = 1.047  # 60 deg: beyond it the arc's radius is < D / sqrt(3)
    rotate_speed_max_radps: float = 0.8  # a 5 Hz lidar sweep smears <= 0.16 rad at this rate
                                         # (the supervisor's spin: 0.6)
    rotate_speed_min_radps: float = 0.2  # beats wheel stiction; 0.02 rad per 10 Hz step, far
                                         # below 2 x yaw_goal_tolerance_rad: no chatter
    rotate_gain_per_s: float = 1.5       # w = gain x heading error; gain x 0.1 s << 1: no
                                         # overshoot at a 10 Hz control rate

    def validate(self, src: str) -> None:
        positive(src, self, "progress_window_m", "xy_goal_tolerance_m", "yaw_goal_tolerance_rad",
                 "rotate_threshold_rad", "rotate_speed_max_radps", "rotate_speed_min_radps",
                 "rotate_gain_per_s")
        require(self.rotate_threshold_rad <= math.pi, src, "rotate_threshold_rad", "must be <= pi")
        require(self.rotate_speed_min_radps <= self.rotate_speed_max_radps, src,
                "rotate_speed_min_radps", f"must be <= rotate_speed_max_radps "
                f"({self.rotate_speed_max_radps})")
        require(self.yaw_goal_tolerance_rad < math.pi, src, "yaw_goal_tolerance_rad",
                "must be < pi")


class Track:
    """A polyline with arc-length bookkeeping: point at arc length s, closest point in a window."""

    def __init__(self, points: np.ndarray):
        self.points = points                               # (n, 2), no repeated neighbours
        self.seg = np.diff(points, axis=0)                 # (n - 1, 2)
        self.seg_len = np.hypot(self.seg[:, 0], self.seg[:, 1])
        self.s = np.concatenate(([0.0], np.cumsum(self.seg_len)))
        self.length = float(self.s[-1])

    @property
    def goal(self) -> np.ndarray:
        return self.points[-1]

    def point_at(self, s: float) -> np.ndarray:
        if len(self.seg_len) == 0:
            return self.points[0]
        s = min(max(s, 0.0), self.length)
        i = min(int(np.searchsorted(self.s, s, side="right")) - 1, len(self.seg_len) - 1)
        return self.points[i] + (s - self.s[i]) / self.seg_len[i] * self.seg[i]

    def closest(self, xy: np.ndarray, s_lo: float, s_hi: float) -> float:
        """Arc length of the path point closest to ``xy`` among those with s in [s_lo, s_hi]."""
        if len(self.seg_len) == 0:
            return 0.0
        start, end = self.s[:-1], self.s[1:]
        t = ((xy - self.points[:-1]) * self.seg).sum(axis=1) / self.seg_len
        # the distance along a segment is convex in s: clamping the projection is the window's min
        lo, hi = np.maximum(start, s_lo), np.minimum(end, s_hi)
        inside = lo <= hi
        s_proj = np.clip(start + t, lo, np.where(inside, hi, lo))
        pts = self.points[:-1] + ((s_proj - start) / self.seg_len)[:, None] * self.seg
        d2 = ((pts - xy) ** 2).sum(axis=1)
        d2[~inside] = np.inf
        return float(s_proj[int(np.argmin(d2))])           # ties: the earliest

    def progress(self, xy: np.ndarray, last_m: Optional[float], window_m: float) -> float:
        """The robot's progress along the path: the closest point to ``xy``, searched over the
        whole path the first time (``last_m`` None), then only forward within ``window_m`` of
        the last progress (it never decreases: a U-turn's other leg is never taken)."""
        if last_m is None:
            return self.closest(xy, 0.0, self.length)
        return self.closest(xy, last_m, last_m + window_m)


class Grid:
    """Occupancy and costmap lookups in map coordinates; off the grid reads as unknown."""

    def __init__(self, occupancy: np.ndarray, costmap: np.ndarray, resolution: float,
                 origin: tuple):
        self.occ, self.cost, self.res = occupancy, costmap, resolution
        self.ox, self.oy = float(origin[0]), float(origin[1])

    @staticmethod
    def make(occupancy, costmap, resolution, origin) -> Optional["Grid"]:
        """The grid, or None when the arrays or their geometry are unusable."""
        try:
            occ, cost = np.asarray(occupancy), np.asarray(costmap)
            res, ox, oy = float(resolution), float(origin[0]), float(origin[1])
        except (TypeError, ValueError, IndexError):
            return None
        if occ.ndim != 2 or occ.size == 0 or cost.shape != occ.shape \
                or not (math.isfinite(res) and res > 0) \
                or not (math.isfinite(ox) and math.isfinite(oy)):
            return None
        return Grid(occ.astype(np.int8, copy=False), cost, res, (ox, oy))

    def _cells(self, xs: np.ndarray, ys: np.ndarray) -> tuple:
        rows, cols = points_to_cells(np.stack([xs, ys], axis=-1), self.res, (self.ox, self.oy))
        return rows, cols, inside(rows, cols, self.occ.shape)

    def lookup(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Costs at the finite points (xs, ys) m, map frame (off the grid: NO_INFORMATION)."""
        rows, cols, on_grid = self._cells(xs, ys)
        out = np.full(rows.shape, NO_INFORMATION, dtype=np.int32)
        out[on_grid] = self.cost[rows[on_grid], cols[on_grid]]
        return out

    def occupancy(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Occupancy at the finite points (xs, ys) m (off the grid: -1, unknown)."""
        rows, cols, on_grid = self._cells(xs, ys)
        out = np.full(rows.shape, -1, dtype=np.int32)
        out[on_grid] = self.occ[rows[on_grid], cols[on_grid]]
        return out


def clean_path(path) -> Optional[np.ndarray]:
    """Finite (n, 2) waypoints without repeated neighbours, or None if fewer than 2 were given."""
    try:
        p = np.asarray(path, dtype=float)
    except (TypeError, ValueError):
        return None
    if p.ndim != 2 or p.shape[1] != 2:
        return None
    p = p[np.isfinite(p).all(axis=1)]
    if len(p) < 2:
        return None
    keep = np.ones(len(p), bool)
    keep[1:] = (np.diff(p, axis=0) != 0).any(axis=1)
    return p[keep]          # one point if all were equal: a path to that point


def finite(values, n: int) -> Optional[tuple]:
    """The first ``n`` of ``values`` (a pose, a velocity) as floats if all are finite, else None."""
    try:
        out = tuple(float(v) for v in values[:n])
    except (TypeError, ValueError, IndexError):
        return None
    return out if len(out) == n and all(math.isfinite(v) for v in out) else None


class PathTracker:
    """One controller's progress along its path, its goal latch and its turns in place (the
    module docstring). ``track``: the path followed (None before one or after an unusable one);
    ``progress_m``: the arc length reached (None until located on a new path);
    ``xy_reached``: the goal latch."""

    def __init__(self, settings: TrackingSettings, robot: RobotSpec, body: BodyCheck):
        self.settings = settings
        self.robot = robot
        self.body = body
        self.reset()

    def reset(self) -> None:
        """Forget the path, the progress along it and the goal latch."""
        self.track: Optional[Track] = None
        self.progress_m: Optional[float] = None
        self.xy_reached = False

    def follow(self, path) -> Optional[Track]:
        """The track for ``path``; a path other than the last restarts progress and the goal
        latch; None (all forgotten) when it has no usable waypoint pair."""
        points = clean_path(path)
        if points is None:
            self.reset()
            return None
        old = self.track
        if old is None or old.points.shape != points.shape \
                or not np.array_equal(old.points, points):
            self.track = Track(points)
            self.xy_reached = False
            self.progress_m = None      # a new path is searched whole once, then only forward
        return self.track

    def advance(self, xy: np.ndarray) -> float:
        """Progress to the robot at ``xy`` (m): only forward, within progress_window_m."""
        self.progress_m = self.track.progress(xy, self.progress_m, self.settings.progress_window_m)
        return self.progress_m

    def at_goal(self, d_goal_m: float, remaining_m: float) -> bool:
        """The goal latch: once the goal is within xy_goal_tolerance_m both in a straight line
        (``d_goal_m``) and along the path (``remaining_m``), until a new path."""
        tol = self.settings.xy_goal_tolerance_m
        self.xy_reached = self.xy_reached or (d_goal_m <= tol and remaining_m <= tol)
        return self.xy_reached

    def arrive(self, inp: ControlInput, pose: tuple, target: tuple,
               law: Optional[Callable[[float], float]] = None) -> ControlOutput:
        """At the goal: "arrived" when ``inp.goal_yaw`` is None (or not finite) or within
        yaw_goal_tolerance_rad of the heading, else the turn in place to it (``law``: the
        controller's turn rate for an error, default ``turn_rate``)."""
        goal_yaw = inp.goal_yaw
        if goal_yaw is None or not math.isfinite(goal_yaw):
            return ControlOutput(0.0, 0.0, ARRIVED, target)
        err = wrap_angle(float(goal_yaw) - pose[2])
        if abs(err) <= self.settings.yaw_goal_tolerance_rad:
            return ControlOutput(0.0, 0.0, ARRIVED, target)
        return self.turn(inp, pose, err, target, "the goal's heading",
                         None if law is None else law(err))

    def turn_rate(self, err: float) -> float:
        """w = gain x error, between the minimum and maximum turn rates, with the error's sign."""
        cfg = self.settings
        top = min(cfg.rotate_speed_max_radps, self.robot.max_angular_radps)
        mag = min(max(cfg.rotate_gain_per_s * abs(err), cfg.rotate_speed_min_radps), top)
        return math.copysign(mag, err)

    def turn(self, inp: ControlInput, pose: tuple, err: float, target: tuple, what: str,
             rate_radps: Optional[float] = None) -> ControlOutput:
        """Turn in place by ``err`` toward ``what`` (at ``rate_radps``, default ``turn_rate``)
        if the turn is clear, else "blocked"."""
        if self.body.turn_clear(inp, pose, err):
            w = self.turn_rate(err) if rate_radps is None else rate_radps
            return ControlOutput(0.0, w, ROTATING, target)
        return ControlOutput(0.0, 0.0, BLOCKED, target, (
            f"turning {err:.2f} rad in place to {what} would bring the body within "
            f"{self.body.margin_m} m of an obstacle; robot at ({pose[0]:.2f}, "
            f"{pose[1]:.2f}, {pose[2]:.2f} rad)"))
