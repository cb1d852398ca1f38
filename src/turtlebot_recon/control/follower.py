"""Pure pursuit path follower with seed 003's look-ahead collision check (ROS-free).

One control step, ``PurePursuit.compute(ControlInput) -> ControlOutput``:

1. progress   the path point closest to the robot, searched forward only (the shared
              ``tracking.PathTracker``: never back to a part of the path it has passed, nor on
              to a later leg that comes close, a U-turn's).
2. goal       within ``xy_goal_tolerance_m`` of the end (the tracker's latch): turn in place to
              ``goal_yaw`` if one is given, then "arrived".
3. carrot     the path point at arc length L_d beyond the closest point,
              L_d = clamp(lookahead_time_s |v|, lookahead_min_m, lookahead_max_m), v measured;
              the goal when the path ends sooner.
4. heading    alpha = bearing of the carrot from the robot's heading; |alpha| >
              ``rotate_threshold_rad``: turn in place toward it ("rotating").
5. curvature  kappa = 2 sin(alpha) / D (Coulter 1992), D = distance to the carrot.
6. speed      v = min(v_max, w_max / |kappa|, sqrt(2 a d_goal)) * costmap slowdown, w = kappa v:
              slow in turns, stop at the goal with the robot's acceleration, slow near obstacles.
7. collision  seed 003's ``is_colliding``, on the arc, with the robot's body: roll (v, w)
              forward for ``collision_horizon_s``, a pose every half margin; the first pose
              whose body (the oriented box, control.footprint.BodyCheck) comes within
              ``collision_margin_m`` of an obstacle, or whose centre is on unknown space (if
              ``unknown_is_collision``), caps v so that the horizon ends before it; if less
              than ``collision_stop_distance_m`` of the arc is free, steps 3-7 are tried again
              with L_d halved, down to one cell (a nearer carrot keeps to the collision-free
              plan where the arc to a far one cuts a corner); if even that is blocked, the
              robot turns in place toward that one-cell carrot where the turn is clear, and
              one already facing it stops: zero command, "blocked" (the navigator replans).
              The robot's centre on an obstacle cell is "blocked" too. A robot already nearer
              than the margin may drive on through poses no nearer than it stands (escaping).

Tight corners. The path's corners are where the plan turns in place (a lattice plan's turns).
A corner where the turning disc clears every obstacle by ``corner_cut_clearance_m``, there and
along the next ``lookahead_max_m`` of the path, is cut with the pure-pursuit arc. At any other
(a narrow place) the robot follows the plan itself: it stops on the corner (within
``corner_tolerance_m``; v <= distance / control period, so one period does not overshoot it;
the carrot runs on along the line into the corner, extended, so the robot converges onto that
line, and the look-ahead check ends on the corner), turns in place to the next segment's heading
(to within ``align_tolerance_rad``) where that turn is clear (else it goes on with the checked
arc), and drives on. The start of the path is such a corner when the robot stands in a narrow
place.

Turning in place (steps 2, 4, 7, corners) follows the tracker's turn-in-place law, and only
where BodyCheck.turn_clear finds the turn safe: the turning disc fits, or the box is clear at
every yaw of the sweep. The parameters shared with the other controllers (progress window, goal
tolerances, turning in place) are ``TrackingSettings`` (navigator.yaml's ``tracking``). The
follower never reverses.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..config import positive, require
from ..geometry import wrap_angle
from ..robot import RobotSpec
from .base import BLOCKED, FOLLOWING, NO_PATH, ROTATING, ControlInput, ControlOutput, PeriodClock
from .footprint import BodyCheck
from .tracking import Grid, PathTracker, Track, TrackingSettings, finite

_TINY = 1e-9


@dataclass(frozen=True)
class FollowerSettings:
    # carrot (Nav2 regulated pure pursuit's defaults: 0.3 / 0.9 m, 1.5 s)
    lookahead_min_m: float = 0.3         # about one robot length: shorter chases the 5 cm
                                         # staircase of grid paths and odometry noise
    lookahead_max_m: float = 0.9         # TurtleBot3s never reach it (1.5 s x 0.26 m/s =
                                         # 0.39 m); caps a TurtleBot2's corner cutting
    lookahead_time_s: float = 1.5        # L_d = this x measured speed, between min and max
    # speed near obstacles: v x (1 - (1 - f) c / 252) for cost c under the robot
    near_obstacle_speed_fraction: float = 0.5   # f: half speed when touching the inscribed
                                         # band, ~0.92 in the middle of a 1 m corridor
    # look-ahead collision check (seed 003)
    collision_horizon_s: float = 1.5     # 0.39 m at 0.26 m/s, about seed 003's 9-cell look-ahead
                                         # and about the carrot distance
    collision_stop_distance_m: float = 0.1   # less free arc than this: blocked; two 5 cm cells,
                                         # 4 control periods at full speed
    unknown_is_collision: bool = True    # the centre on unknown space: collision (it may hide a
                                         # wall; the planner keeps to known space anyway)
    collision_margin_m: float = 0.005    # the body nearer an obstacle's edge than this collides
                                         # (look-ahead poses lie half of it apart); a quarter of
                                         # the planner's 0.02 m: the robot follows the plan to
                                         # within a centimetre or two
    # tight corners (see the module)
    corner_cut_clearance_m: float = 0.1  # cut a corner with an arc only where the turning disc
                                         # clears obstacles by this much (an arc strays a few cm)
    corner_tolerance_m: float = 0.01     # on a tight corner within this distance of it
    align_tolerance_rad: float = 0.03    # leave a tight corner this close to the next heading:
                                         # the box's back corner then sits 0.2 x 0.03 = 6 mm off

    def validate(self, src: str) -> None:
        positive(src, self, "lookahead_min_m", "lookahead_max_m", "lookahead_time_s",
                 "near_obstacle_speed_fraction", "collision_horizon_s",
                 "collision_stop_distance_m", "collision_margin_m", "corner_tolerance_m",
                 "align_tolerance_rad")
        require(self.corner_cut_clearance_m >= 0, src, "corner_cut_clearance_m", "must be >= 0")
        require(self.lookahead_min_m <= self.lookahead_max_m, src, "lookahead_max_m",
                f"must be >= lookahead_min_m ({self.lookahead_min_m})")
        require(self.near_obstacle_speed_fraction <= 1.0, src, "near_obstacle_speed_fraction",
                "must be in (0, 1]")


class PurePursuit:
    """Adaptive pure pursuit with goal deceleration, cost slowdown, an arc collision check with
    the robot's body and in-place turns on tight corners."""

    def __init__(self, settings: FollowerSettings, robot: RobotSpec,
                 tracking: Optional[TrackingSettings] = None):
        self.settings = settings
        self.robot = robot
        self.body = BodyCheck(robot, settings.collision_margin_m)
        self.tracker = PathTracker(TrackingSettings() if tracking is None else tracking, robot,
                                   self.body)
        self._clock = PeriodClock(0.1)   # the control period from the steps' times
        self.reset()

    def reset(self) -> None:
        self.tracker.reset()
        self._clock.reset()

    # ------------------------------------------------------------------ the step
    def compute(self, inp: ControlInput) -> ControlOutput:
        cfg, tracker = self.settings, self.tracker
        track = tracker.follow(inp.path)
        if track is None:
            self.reset()
            return ControlOutput(0.0, 0.0, NO_PATH)
        grid = Grid.make(inp.occupancy, inp.costmap, inp.resolution, inp.origin)
        if grid is None:                                 # cannot judge safety: do not move
            return ControlOutput(0.0, 0.0, BLOCKED, detail="no usable map")
        pose = finite(inp.pose, 3)
        if pose is None:
            return ControlOutput(0.0, 0.0, BLOCKED, detail="the pose is not finite")
        x, y, yaw = pose
        xy = np.array([x, y])
        period_s = self._clock(inp.now_s)

        progress_m = tracker.advance(xy)
        remaining_m = track.length - progress_m
        d_goal_xy = float(np.hypot(*(track.goal - xy)))
        goal_tuple = (float(track.goal[0]), float(track.goal[1]))

        if grid.occupancy(np.array([x]), np.array([y]))[0] >= self.body.occupied_threshold:
            return ControlOutput(0.0, 0.0, BLOCKED, goal_tuple, "the robot's cell is an obstacle")
        start_cost = int(grid.lookup(np.array([x]), np.array([y]))[0])

        # 2. goal: latched xy tolerance, then the heading
        if tracker.at_goal(d_goal_xy, remaining_m):
            return tracker.arrive(inp, pose, goal_tuple)

        # tight corners: stop on one, turn to the next segment there, drive on
        corner_s, next_dir = self._tight_corner(inp, track, xy)
        if next_dir is not None:
            err = wrap_angle(math.atan2(next_dir[1], next_dir[0]) - yaw)
            if abs(err) > cfg.align_tolerance_rad and self.body.turn_clear(inp, pose, err):
                return ControlOutput(0.0, tracker.turn_rate(err), ROTATING, (float(x), float(y)))
            # (a turn that is not clear: the arc below, checked as ever, or "blocked")

        # 3. carrot at L_d beyond the closest point; past a tight corner ahead, on the line of
        # the segment into it extended (the robot converges onto that line, and stops on the
        # corner: v <= the distance left / the control period)
        stop = None if corner_s is None else (corner_s, track.point_at(corner_s),
                                              track.seg[int(np.searchsorted(track.s, corner_s)) - 1])
        stop_m = corner_s - progress_m if corner_s is not None else math.inf
        v_meas = (finite(inp.velocity, 1) or (0.0,))[0]
        lookahead_m = min(max(cfg.lookahead_time_s * abs(v_meas), cfg.lookahead_min_m),
                          cfg.lookahead_max_m)
        d_goal_m = max(remaining_m, d_goal_xy)
        v_cap = stop_m / period_s if math.isfinite(stop_m) else math.inf

        # 3-7 with L_d, then (the arc blocked) with L_d halved down to one cell: a nearer carrot
        # hugs the collision-free plan where the arc to a far one cuts a corner.
        blocked = None
        while True:
            out, why = self._toward(inp, track, grid, x, y, yaw, lookahead_m, d_goal_m,
                                    start_cost, v_cap, stop)
            if out is not None:
                return out
            blocked = blocked or why
            if lookahead_m <= grid.res:
                # Every arc is blocked: the robot stands facing into an obstacle (a corner taken
                # tight). Face the nearest carrot first where the turn is clear; the next arc
                # then runs along the plan.
                near = why[0]
                alpha = wrap_angle(math.atan2(near[1] - y, near[0] - x) - yaw)
                if abs(alpha) > tracker.settings.yaw_goal_tolerance_rad \
                        and self.body.turn_clear(inp, pose, alpha):
                    return ControlOutput(0.0, tracker.turn_rate(alpha), ROTATING, near)
                return ControlOutput(0.0, 0.0, BLOCKED, blocked[0], blocked[1])
            lookahead_m = max(0.5 * lookahead_m, grid.res)

    def _toward(self, inp: ControlInput, track: Track, grid: Grid, x: float, y: float,
                yaw: float, lookahead_m: float, d_goal_m: float, start_cost: int,
                v_cap: float, stop: Optional[tuple]) -> tuple:
        """Steps 3-7 for one look-ahead distance: (the command, None), or (None, (carrot,
        why blocked)) when less than ``collision_stop_distance_m`` of its arc is free or the
        turn toward the carrot is not clear. ``stop``: (arc length, point, direction of the
        segment into it) of the tight corner ahead, or None."""
        cfg, tracker = self.settings, self.tracker
        s_carrot = tracker.progress_m + lookahead_m
        if stop is not None and s_carrot > stop[0]:     # on the line into the corner, extended
            along = stop[2] / max(float(np.hypot(*stop[2])), _TINY)
            carrot = stop[1] + (s_carrot - stop[0]) * along
        else:
            carrot = track.point_at(s_carrot)
        carrot_tuple = (float(carrot[0]), float(carrot[1]))
        dx, dy = carrot[0] - x, carrot[1] - y
        dist_m = math.hypot(dx, dy)
        alpha = wrap_angle(math.atan2(dy, dx) - yaw) if dist_m > _TINY else 0.0

        # 4. far off heading: turn in place first, where the turn is clear
        if abs(alpha) > tracker.settings.rotate_threshold_rad:
            if not self.body.turn_clear(inp, (x, y, yaw), alpha):
                return None, (carrot_tuple, f"turning {alpha:.2f} rad in place toward "
                              f"({carrot[0]:.2f}, {carrot[1]:.2f}) would bring the body within "
                              f"{cfg.collision_margin_m} m of an obstacle; robot at "
                              f"({x:.2f}, {y:.2f}, {yaw:.2f} rad)")
            return ControlOutput(0.0, tracker.turn_rate(alpha), ROTATING, carrot_tuple), None

        # 5. curvature of the arc through the carrot, 6. speed limits
        kappa = 2.0 * math.sin(alpha) / dist_m if dist_m > _TINY else 0.0
        v = min(self._speed(kappa, d_goal_m, start_cost), v_cap)

        # 7. look-ahead collision check along the arc
        horizon_m = max(v * cfg.collision_horizon_s, cfg.collision_stop_distance_m)
        if stop is not None:       # it stops on the corner: the poses past it are not checked
            horizon_m = min(horizon_m, stop[0] - tracker.progress_m + cfg.corner_tolerance_m)
        free_m, hit_xy, what = self._free_arc(inp, grid, x, y, yaw, kappa, horizon_m, track.goal)
        if free_m is not None:
            if free_m < cfg.collision_stop_distance_m:
                return None, (carrot_tuple, (
                    f"{what} {free_m:.2f} m ahead at ({hit_xy[0]:.2f}, {hit_xy[1]:.2f}) on the "
                    f"arc to the look-ahead point ({carrot[0]:.2f}, {carrot[1]:.2f}); robot at "
                    f"({x:.2f}, {y:.2f}, {yaw:.2f} rad) on cost {start_cost}"))
            v = min(v, free_m / cfg.collision_horizon_s)     # the horizon ends before the hit
        w_max = self.robot.max_angular_radps
        w = min(max(kappa * v, -w_max), w_max)
        return ControlOutput(float(v), float(w), FOLLOWING, carrot_tuple), None

    # ------------------------------------------------------------------ pieces
    def _tight_corner(self, inp: ControlInput, track: Track, xy: np.ndarray) -> tuple:
        """(arc length of the next tight corner ahead or None, the direction of the segment
        after the tight corner the robot stands on or None). Corners: the start and every
        interior point; tight: the turning disc does not clear obstacles by
        ``corner_cut_clearance_m`` at the corner (at the start: where the robot stands) or along
        the first ``lookahead_max_m`` of the path after it (an arc cut there would enter a
        narrow place off its line)."""
        cfg = self.settings
        if len(track.points) < 2:
            return None, None
        s = self.tracker.progress_m
        ahead = track.s[:-1] >= s - cfg.corner_tolerance_m
        ahead[0] = s <= cfg.corner_tolerance_m
        idx = np.flatnonzero(ahead)
        if idx.size == 0:
            return None, None
        # points every half cell along the first lookahead_max_m of the path after each corner
        step = 0.5 * float(inp.resolution)
        n = int(cfg.lookahead_max_m / step) + 1
        along = track.s[idx][:, None] + step * np.arange(n)[None, :]         # (corners, n)
        samples = np.stack([np.interp(along, track.s, track.points[:, 0]),
                            np.interp(along, track.s, track.points[:, 1])], axis=-1)
        if idx[0] == 0:                     # the start: from where the robot stands
            samples[0] += (xy - track.points[0]) * (1.0 - np.minimum(along[0] / max(
                track.seg_len[0], _TINY), 1.0))[:, None]
        owner = np.repeat(np.arange(idx.size), n)
        samples = samples.reshape(-1, 2)
        clear = self.body.disc_clear(inp, samples, cfg.corner_cut_clearance_m)
        tight = np.bincount(owner, weights=~clear, minlength=idx.size) > 0
        idx = idx[tight]
        if idx.size == 0:
            return None, None
        k = int(idx[0])
        if track.s[k] - s <= cfg.corner_tolerance_m:     # standing on it
            later = idx[1:]
            return (float(track.s[later[0]]) if later.size else None), track.seg[k]
        return float(track.s[k]), None

    def _speed(self, kappa: float, d_goal_m: float, cost: int) -> float:
        """v_max, then w_max / |kappa| (turns), sqrt(2 a d) (goal), the cost slowdown."""
        r = self.robot
        v = r.max_linear_mps
        if abs(kappa) > _TINY:
            v = min(v, r.max_angular_radps / abs(kappa))
        v = min(v, math.sqrt(2.0 * r.max_linear_accel_mps2 * max(d_goal_m, 0.0)))
        f = self.settings.near_obstacle_speed_fraction
        return v * (1.0 - (1.0 - f) * min(cost, 252) / 252.0)

    def _free_arc(self, inp: ControlInput, grid: Grid, x: float, y: float, yaw: float,
                  kappa: float, length_m: float, goal: np.ndarray) -> tuple:
        """(free arc length before the first colliding pose within ``length_m``, that pose's
        (x, y), what it hits), or (None, None, None) when the arc is free.

        Poses every half ``collision_margin_m`` along the arc of curvature ``kappa``; poses past the goal are
        not checked (the robot stops there). A pose collides when the body comes within
        ``collision_margin_m`` of an obstacle, or (``unknown_is_collision``) its centre is on
        unknown space. A robot already that near may drive on through poses no nearer than
        it stands, and one on unknown space through unknown cells, until it first leaves
        them, so it can get out.
        """
        cfg = self.settings
        ds = max(0.5 * cfg.collision_margin_m, length_m / 1000.0)   # at most 1000 poses
        s = ds * np.arange(0, int(math.ceil(length_m / ds)) + 1)
        half = 0.5 * kappa * s
        chord = s * np.sinc(half / math.pi)                # 2 sin(kappa s / 2) / kappa, exact arc
        xs, ys = x + chord * np.cos(yaw + half), y + chord * np.sin(yaw + half)
        at_goal = np.flatnonzero(np.hypot(xs - goal[0], ys - goal[1])
                                 <= self.tracker.settings.xy_goal_tolerance_m)
        if at_goal.size:
            n = at_goal[0] + 1
            s, xs, ys, half = s[:n], xs[:n], ys[:n], half[:n]
        margin = cfg.collision_margin_m
        clearance = self.body.clearance(inp, np.column_stack([xs, ys, yaw + 2.0 * half]), margin)
        near = clearance < margin
        if near[0]:          # escaping: the leading poses no nearer than the robot stands
            near &= ~np.cumprod(clearance >= clearance[0] - 1e-9).astype(bool)
        unknown = np.zeros_like(near)
        if cfg.unknown_is_collision:
            unknown = grid.occupancy(xs, ys) < 0
            if unknown[0]:
                unknown &= ~np.cumprod(unknown).astype(bool)
        bad = (near | unknown)[1:]                         # pose 0: where the robot stands
        hits = np.flatnonzero(bad)
        if hits.size == 0:
            return None, None, None
        k = hits[0] + 1
        what = "an obstacle within the body's margin" if near[k] else "unknown cell"
        return float(s[k] - ds), (float(xs[k]), float(ys[k])), what

