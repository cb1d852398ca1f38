"""Pure pursuit path follower with seed 003's look-ahead collision check (ROS-free).

One control step, ``PurePursuit.compute(ControlInput) -> ControlOutput``:

1. progress   the path point closest to the robot, searched only from the last progress point
              forward over ``progress_window_m`` of path: the robot never turns back to a part
              of the path it has passed, nor jumps ahead to a later leg that comes close (U-turn).
              A new path is searched whole once.
2. goal       within ``xy_goal_tolerance_m`` of the end (latched): turn in place to
              ``goal_yaw`` if one is given, then "arrived".
3. carrot     the path point at arc length L_d beyond the closest point,
              L_d = clamp(lookahead_time_s |v|, lookahead_min_m, lookahead_max_m), v measured;
              the goal when the path ends sooner.
4. heading    alpha = bearing of the carrot from the robot's heading; |alpha| >
              ``rotate_threshold_rad``: turn in place toward it ("rotating").
5. curvature  kappa = 2 sin(alpha) / D (Coulter 1992), D = distance to the carrot.
6. speed      v = min(v_max, w_max / |kappa|, sqrt(2 a d_goal)) * costmap slowdown, w = kappa v:
              slow in turns, stop at the goal with the robot's acceleration, slow near obstacles.
7. collision  seed 003's ``is_colliding``, on the arc: roll (v, w) forward for
              ``collision_horizon_s`` in half-cell steps; the first sample on a collision cell
              (inscribed or lethal, or unknown if ``unknown_is_collision``) caps v so that the
              horizon ends before it; if less than ``collision_stop_distance_m`` of the arc is
              free, steps 3-7 are tried again with L_d halved, down to one cell (a nearer
              carrot keeps to the collision-free plan where the arc to a far one cuts a corner
              into the inflation); if even that is blocked, a robot off inscribed cost turns in
              place toward that one-cell carrot (it stands at the band's edge facing into it),
              and one already facing it stops: zero command, "blocked" (the navigator
              replans). The robot standing on lethal cost is "blocked" too.

Only the footprint's centre is checked, against the inflated costmap, whose inscribed radius
is the footprint's circumscribed radius about base_footprint plus one cell diagonal
(``CostmapSettings.for_robot``, ``make_costmap``): turning in place sweeps that disc and does
not move the centre, so it is safe wherever the centre is. The follower never reverses.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..config import positive, require
from ..geometry import inside, points_to_cells, wrap_angle
from ..robot import RobotSpec
from . import ARRIVED, BLOCKED, FOLLOWING, NO_PATH, ROTATING, ControlInput, ControlOutput

# the costmap values of planning.costmap, repeated: control must not import planning, whose
# navigator imports control
INSCRIBED, LETHAL, NO_INFORMATION = 253, 254, 255
_COST_NAMES = {INSCRIBED: "inscribed", LETHAL: "lethal", NO_INFORMATION: "unknown"}
_TINY = 1e-9


@dataclass(frozen=True)
class FollowerSettings:
    # carrot (Nav2 regulated pure pursuit's defaults: 0.3 / 0.9 m, 1.5 s)
    lookahead_min_m: float = 0.3         # about one robot length: shorter chases the 5 cm
                                         # staircase of grid paths and odometry noise
    lookahead_max_m: float = 0.9         # TurtleBot3s never reach it (1.5 s x 0.26 m/s =
                                         # 0.39 m); caps a TurtleBot2's corner cutting
    lookahead_time_s: float = 1.5        # L_d = this x measured speed, between min and max
    progress_window_m: float = 1.0       # closest-point search this far past the last progress:
                                         # covers a cut corner, not the other leg of a U-turn
    # turning in place: a differential drive turns on the spot for free, a tight arc sweeps
    # a band beside the path
    rotate_threshold_rad: float = 1.047  # 60 deg: beyond it the arc's radius is < D / sqrt(3)
    rotate_speed_max_radps: float = 0.8  # a 5 Hz lidar sweep smears <= 0.16 rad at this rate
                                         # (the supervisor's spin: 0.6)
    rotate_speed_min_radps: float = 0.2  # beats wheel stiction; 0.02 rad per 10 Hz step, far
                                         # below 2 x yaw_goal_tolerance_rad: no chatter
    rotate_gain_per_s: float = 1.5       # w = gain x heading error; gain x 0.1 s << 1: no
                                         # overshoot at a 10 Hz control rate
    # goal
    xy_goal_tolerance_m: float = 0.1     # under the smallest robot radius (0.105 m); seed 003's
                                         # 0.05 m is one 5 cm cell, which odometry noise defeats
    yaw_goal_tolerance_rad: float = 0.1  # seed 003's angle_tolerance (5.7 deg)
    # speed near obstacles: v x (1 - (1 - f) c / 252) for cost c under the robot
    near_obstacle_speed_fraction: float = 0.5   # f: half speed when touching the inscribed
                                         # band, ~0.92 in the middle of a 1 m corridor
    # look-ahead collision check (seed 003)
    collision_horizon_s: float = 1.5     # 0.39 m at 0.26 m/s, about seed 003's 9-cell look-ahead
                                         # and about the carrot distance
    collision_stop_distance_m: float = 0.1   # less free arc than this: blocked; two 5 cm cells,
                                         # 4 control periods at full speed
    unknown_is_collision: bool = True    # unknown space may hide a wall; the planner keeps to
                                         # known space anyway

    def validate(self, src: str) -> None:
        positive(src, self, "lookahead_min_m", "lookahead_max_m", "lookahead_time_s",
                 "progress_window_m", "rotate_threshold_rad", "rotate_speed_max_radps",
                 "rotate_speed_min_radps", "rotate_gain_per_s", "xy_goal_tolerance_m",
                 "yaw_goal_tolerance_rad", "near_obstacle_speed_fraction", "collision_horizon_s",
                 "collision_stop_distance_m")
        require(self.lookahead_min_m <= self.lookahead_max_m, src, "lookahead_max_m",
                f"must be >= lookahead_min_m ({self.lookahead_min_m})")
        require(self.rotate_threshold_rad <= math.pi, src, "rotate_threshold_rad", "must be <= pi")
        require(self.rotate_speed_min_radps <= self.rotate_speed_max_radps, src,
                "rotate_speed_min_radps", f"must be <= rotate_speed_max_radps "
                f"({self.rotate_speed_max_radps})")
        require(self.yaw_goal_tolerance_rad < math.pi, src, "yaw_goal_tolerance_rad",
                "must be < pi")
        require(self.near_obstacle_speed_fraction <= 1.0, src, "near_obstacle_speed_fraction",
                "must be in (0, 1]")


class _Track:
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


class _Grid:
    """Costmap lookups in map coordinates; off the grid reads as unknown."""

    def __init__(self, costmap: np.ndarray, resolution: float, origin: tuple):
        self.cost, self.res = costmap, resolution
        self.ox, self.oy = float(origin[0]), float(origin[1])

    @staticmethod
    def make(costmap, resolution, origin) -> Optional["_Grid"]:
        try:
            grid = np.asarray(costmap)
            res, ox, oy = float(resolution), float(origin[0]), float(origin[1])
        except (TypeError, ValueError, IndexError):
            return None
        if grid.ndim != 2 or grid.size == 0 or not (math.isfinite(res) and res > 0) \
                or not (math.isfinite(ox) and math.isfinite(oy)):
            return None
        return _Grid(grid, res, (ox, oy))

    def lookup(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Costs at the finite points (xs, ys) m, map frame."""
        rows, cols = points_to_cells(np.stack([xs, ys], axis=-1), self.res, (self.ox, self.oy))
        on_grid = inside(rows, cols, self.cost.shape)
        out = np.full(rows.shape, NO_INFORMATION, dtype=np.int32)
        out[on_grid] = self.cost[rows[on_grid], cols[on_grid]]
        return out


def _clean_path(path) -> Optional[np.ndarray]:
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


class PurePursuit:
    """Adaptive pure pursuit with goal deceleration, cost slowdown and an arc collision check."""

    def __init__(self, settings: FollowerSettings, robot: RobotSpec):
        self.settings = settings
        self.robot = robot
        self.reset()

    def reset(self) -> None:
        self._track: Optional[_Track] = None
        self._progress_m: Optional[float] = None   # arc length of the closest point so far
                                                   # (never decreases); None: not located yet
        self._xy_reached = False        # latched once within xy_goal_tolerance_m

    # ------------------------------------------------------------------ the step
    def compute(self, inp: ControlInput) -> ControlOutput:
        cfg = self.settings
        track = self._follow(inp.path)
        if track is None:
            return ControlOutput(0.0, 0.0, NO_PATH)
        try:
            x, y, yaw = (float(v) for v in inp.pose[:3])
        except (TypeError, ValueError):
            x = y = yaw = math.nan
        grid = _Grid.make(inp.costmap, inp.resolution, inp.origin)
        if grid is None:                                 # cannot judge safety: do not move
            return ControlOutput(0.0, 0.0, BLOCKED, detail="no usable costmap")
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
            return ControlOutput(0.0, 0.0, BLOCKED, detail="the pose is not finite")
        xy = np.array([x, y])

        # 1. progress: the closest point, forward from the last one only
        if self._progress_m is None:
            self._progress_m = track.closest(xy, 0.0, track.length)
        else:       # the window starts at the last progress: it never decreases
            self._progress_m = track.closest(xy, self._progress_m,
                                             self._progress_m + cfg.progress_window_m)
        remaining_m = track.length - self._progress_m
        d_goal_xy = float(np.hypot(*(track.goal - xy)))
        goal_tuple = (float(track.goal[0]), float(track.goal[1]))

        start_cost = int(grid.lookup(np.array([x]), np.array([y]))[0])
        if start_cost == LETHAL:
            return ControlOutput(0.0, 0.0, BLOCKED, goal_tuple, "the robot's cell is an obstacle")

        # 2. goal: latched xy tolerance, then the heading
        tol = cfg.xy_goal_tolerance_m
        if self._xy_reached or (d_goal_xy <= tol and remaining_m <= tol):
            self._xy_reached = True
            goal_yaw = inp.goal_yaw
            if goal_yaw is None or not math.isfinite(goal_yaw):
                return ControlOutput(0.0, 0.0, ARRIVED, goal_tuple)
            err = wrap_angle(float(goal_yaw) - yaw)
            if abs(err) <= cfg.yaw_goal_tolerance_rad:
                return ControlOutput(0.0, 0.0, ARRIVED, goal_tuple)
            return ControlOutput(0.0, self._turn_rate(err), ROTATING, goal_tuple)

        # 3. carrot at L_d beyond the closest point
        v_meas = float(inp.velocity[0]) if _finite_first(inp.velocity) else 0.0
        lookahead_m = min(max(cfg.lookahead_time_s * abs(v_meas), cfg.lookahead_min_m),
                          cfg.lookahead_max_m)
        d_goal_m = max(remaining_m, d_goal_xy)

        # 3-7 with L_d, then (the arc blocked) with L_d halved down to one cell: a nearer carrot
        # hugs the collision-free plan where the arc to a far one cuts a corner into inflation.
        blocked = None
        while True:
            out, why = self._toward(track, grid, x, y, yaw, lookahead_m, d_goal_m, start_cost)
            if out is not None:
                return out
            blocked = blocked or why
            if lookahead_m <= grid.res:
                # Every arc enters the band: the robot stands at its edge facing into it (a
                # corner taken tight). Turning in place is safe on any cell below inscribed, so
                # face the nearest carrot first; the next arc then runs along the plan.
                near = why[0]
                alpha = wrap_angle(math.atan2(near[1] - y, near[0] - x) - yaw)
                if start_cost < INSCRIBED and abs(alpha) > cfg.yaw_goal_tolerance_rad:
                    return ControlOutput(0.0, self._turn_rate(alpha), ROTATING, near)
                return ControlOutput(0.0, 0.0, BLOCKED, blocked[0], blocked[1])
            lookahead_m = max(0.5 * lookahead_m, grid.res)

    def _toward(self, track: "_Track", grid: "_Grid", x: float, y: float, yaw: float,
                lookahead_m: float, d_goal_m: float, start_cost: int) -> tuple:
        """Steps 3-7 for one look-ahead distance: (the command, None), or (None, (carrot,
        why blocked)) when less than ``collision_stop_distance_m`` of its arc is free."""
        cfg = self.settings
        carrot = track.point_at(self._progress_m + lookahead_m)
        carrot_tuple = (float(carrot[0]), float(carrot[1]))
        dx, dy = carrot[0] - x, carrot[1] - y
        dist_m = math.hypot(dx, dy)
        alpha = wrap_angle(math.atan2(dy, dx) - yaw) if dist_m > _TINY else 0.0

        # 4. far off heading: turn in place first
        if abs(alpha) > cfg.rotate_threshold_rad:
            return ControlOutput(0.0, self._turn_rate(alpha), ROTATING, carrot_tuple), None

        # 5. curvature of the arc through the carrot, 6. speed limits
        kappa = 2.0 * math.sin(alpha) / dist_m if dist_m > _TINY else 0.0
        v = self._speed(kappa, d_goal_m, start_cost)

        # 7. look-ahead collision check along the arc
        horizon_m = max(v * cfg.collision_horizon_s, cfg.collision_stop_distance_m)
        free_m, hit_xy, hit_cost = self._free_arc(grid, x, y, yaw, kappa, horizon_m, start_cost, track.goal)
        if free_m is not None:
            if free_m < cfg.collision_stop_distance_m:
                return None, (carrot_tuple, (
                    f"{_COST_NAMES.get(hit_cost, 'cost %d' % hit_cost)} cell {free_m:.2f} m ahead at "
                    f"({hit_xy[0]:.2f}, {hit_xy[1]:.2f}) on the arc to the look-ahead point "
                    f"({carrot[0]:.2f}, {carrot[1]:.2f}); robot at ({x:.2f}, {y:.2f}, {yaw:.2f} rad) "
                    f"on cost {start_cost}"))
            v = min(v, free_m / cfg.collision_horizon_s)     # the horizon ends before the hit
        w_max = self.robot.max_angular_radps
        w = min(max(kappa * v, -w_max), w_max)
        return ControlOutput(float(v), float(w), FOLLOWING, carrot_tuple), None

    # ------------------------------------------------------------------ pieces
    def _follow(self, path) -> Optional[_Track]:
        """The track for ``path``; a different path than last time restarts progress."""
        points = _clean_path(path)
        if points is None:
            self.reset()
            return None
        old = self._track
        if old is None or old.points.shape != points.shape \
                or not np.array_equal(old.points, points):
            self._track = _Track(points)
            self._xy_reached = False
            self._progress_m = None     # a new path is searched whole once, then only forward
        return self._track

    def _speed(self, kappa: float, d_goal_m: float, cost: int) -> float:
        """v_max, then w_max / |kappa| (turns), sqrt(2 a d) (goal), the cost slowdown."""
        r = self.robot
        v = r.max_linear_mps
        if abs(kappa) > _TINY:
            v = min(v, r.max_angular_radps / abs(kappa))
        v = min(v, math.sqrt(2.0 * r.max_linear_accel_mps2 * max(d_goal_m, 0.0)))
        f = self.settings.near_obstacle_speed_fraction
        return v * (1.0 - (1.0 - f) * min(cost, 252) / 252.0)

    def _turn_rate(self, err: float) -> float:
        """w = gain x error, between the minimum and maximum turn rates, with the error's sign."""
        cfg = self.settings
        top = min(cfg.rotate_speed_max_radps, self.robot.max_angular_radps)
        mag = min(max(cfg.rotate_gain_per_s * abs(err), cfg.rotate_speed_min_radps), top)
        return math.copysign(mag, err)

    def _colliding(self, cost: np.ndarray) -> np.ndarray:
        hit = (cost >= INSCRIBED) & (cost != NO_INFORMATION)
        return hit | (cost == NO_INFORMATION) if self.settings.unknown_is_collision else hit

    def _free_arc(self, grid: _Grid, x: float, y: float, yaw: float, kappa: float,
                  length_m: float, start_cost: int, goal: np.ndarray) -> tuple:
        """(free arc length before the first collision sample within ``length_m``, that
        sample's (x, y), its cost), or (None, None, None) when the arc is free.

        Samples every half cell along the arc of curvature ``kappa`` from the pose; samples past
        the goal are not checked (the robot stops there). A robot that already stands on a
        collision cell (inscribed, or unknown) may drive on through cells of that same cost
        until it first leaves them, so it can get out; lethal cells always collide.
        """
        ds = max(0.5 * grid.res, length_m / 1000.0)       # at most 1000 samples
        s = ds * np.arange(1, int(math.ceil(length_m / ds)) + 1)
        half = 0.5 * kappa * s
        chord = s * np.sinc(half / math.pi)                # 2 sin(kappa s / 2) / kappa, exact arc
        xs, ys = x + chord * np.cos(yaw + half), y + chord * np.sin(yaw + half)
        at_goal = np.flatnonzero(np.hypot(xs - goal[0], ys - goal[1])
                                 <= self.settings.xy_goal_tolerance_m)
        if at_goal.size:
            n = at_goal[0] + 1
            s, xs, ys = s[:n], xs[:n], ys[:n]
        cost = grid.lookup(xs, ys)
        bad = self._colliding(cost)
        if self._colliding(np.array([start_cost]))[0]:
            bad &= ~np.cumprod(cost == start_cost).astype(bool)   # the leading run: escaping
        hits = np.flatnonzero(bad)
        if hits.size == 0:
            return None, None, None
        k = hits[0]
        return float(s[k] - ds), (float(xs[k]), float(ys[k])), int(cost[k])


def _finite_first(values) -> bool:
    try:
        return math.isfinite(float(values[0]))
    except (TypeError, ValueError, IndexError):
        return False
