"""Seed 003's PD path follower behind the controller contract (ROS-free).

Seed 003 drives "down a sequence of path segments" with two PD loops, one on the linear and one
on the angular velocity, "driving the robot forward when the angle is within a 0.1 rad tolerance
of the desired angle", and calls ``is_colliding`` (a hitbox ahead of the robot) every iteration,
stopping when it reports a collision. Our paths are exactly such segments: the lattice plan's
straight runs, joined by corners where it turns in place.

One control step, ``PdController.compute(ControlInput) -> ControlOutput``:

1. segment   the segment being driven (a new path starts at its first); its end is reached once
             the robot is within ``corner_tolerance_m`` of it along the segment (or past it):
             the next one starts, and both PD loops forget their last error (no derivative kick).
2. goal      within ``xy_goal_tolerance_m`` of the path's end on its last segment (the shared
             ``tracking.PathTracker``'s latch): turn in place to ``goal_yaw`` if one is given
             (w = kp_ang e, at least rotate_speed_min_radps), then "arrived".
3. errors    distance  d = how far the segment's end lies ahead along the segment;
             heading   e = bearing of the point ``lookahead_m`` ahead of the robot's projection
                           on the segment's line (extended past its end) from the robot's heading:
                           the robot steers back onto the line and the bearing stays defined at
                           the end.
4. PD        w = kp_ang e + kd_ang de/dt; |e| > heading_tolerance_rad (> heading_abort_rad once
             driving: hysteresis, so noise does not toggle it): turn in place (v = 0, |w| at
             least rotate_speed_min_radps, where the turn is clear), else drive with
             v = kp_lin d + kd_lin dd/dt. Both within the robot's limits, v also within one
             period's acceleration of the measured speed.
5. collision seed 003's ``is_colliding`` with the robot's body: the arc (v, w) rolled forward over
             ``collision_horizon_s`` (at least ``collision_min_distance_m``, never past the
             segment's end), a pose every half margin, checked with BodyCheck (the oriented box);
             a pose within ``collision_margin_m`` of an obstacle (a robot already nearer may move
             through poses no nearer than it stands), or whose centre enters unknown space:
             zero command, "blocked" (the navigator replans).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..config import positive, require
from ..geometry import wrap_angle
from ..robot import RobotSpec
from .base import BLOCKED, FOLLOWING, NO_PATH, ControlInput, ControlOutput, PeriodClock
from .footprint import BodyCheck
from .tracking import Grid, PathTracker, Track, TrackingSettings, finite


@dataclass(frozen=True)
class PdSettings:
    # the two PD loops (seed 003: Kp_lin 1, Kd_lin 0.3, Kp_ang 1, Kd_ang 0.2)
    linear_kp_per_s: float = 1.0         # v (m/s) per m of distance to the segment's end
    linear_kd: float = 0.3               # v (m/s) per m/s of that distance's rate
    angular_kp_per_s: float = 1.0        # w (rad/s) per rad of heading error
    angular_kd: float = 0.2              # w (rad/s) per rad/s of the error's rate
    # driving or turning in place
    heading_tolerance_rad: float = 0.1   # seed 003's angle_tolerance: drive once this close
    heading_abort_rad: float = 0.3       # while driving, turn in place again past this
    lookahead_m: float = 0.3             # m, the heading aims this far ahead along the segment
    corner_tolerance_m: float = 0.02     # m, a segment's end is reached this close along it
    # look-ahead collision check (seed 003's is_colliding, with the body)
    collision_horizon_s: float = 1.5     # s of the command's arc checked
    collision_min_distance_m: float = 0.1   # m, at least this much of it (slow or starting)
    collision_margin_m: float = 0.005    # m, the body nearer an obstacle's edge than this collides
    unknown_is_collision: bool = True    # the centre entering unknown space (or off the map)

    def validate(self, src: str) -> None:
        positive(src, self, "linear_kp_per_s", "angular_kp_per_s", "heading_tolerance_rad",
                 "heading_abort_rad", "lookahead_m", "corner_tolerance_m", "collision_horizon_s", "collision_min_distance_m", "collision_margin_m")
        require(self.linear_kd >= 0, src, "linear_kd", "must be >= 0")
        require(self.angular_kd >= 0, src, "angular_kd", "must be >= 0")
        require(self.heading_abort_rad >= self.heading_tolerance_rad, src, "heading_abort_rad",
                f"must be >= heading_tolerance_rad ({self.heading_tolerance_rad})")
        require(self.heading_abort_rad < math.pi, src, "heading_abort_rad", "must be < pi")


class PdController:
    """Segment by segment: turn in place to it, drive it with two PD loops, stop at its end.
    The path, the goal latch and the turn-in-place gate are the shared tracker's
    (tracking.PathTracker); its progress is the segment, and its turns the PD loop's rate."""

    def __init__(self, settings: PdSettings, robot: RobotSpec,
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
        self._restart()

    def _restart(self) -> None:
        """The first segment of a path, from rest."""
        self._track: Optional[Track] = None    # the tracker's track this segment count is on
        self._segment = 0                      # driving from points[i] to points[i + 1]
        self._driving = False                  # inside the hysteresis band
        self._clock.reset()
        self._last_d: Optional[float] = None   # the errors of the last step (derivatives)
        self._last_e: Optional[float] = None

    def compute(self, inp: ControlInput) -> ControlOutput:
        cfg, tracker = self.settings, self.tracker
        points = self._follow(inp.path)
        if points is None:
            return ControlOutput(0.0, 0.0, NO_PATH, detail="fewer than two finite waypoints")
        grid = Grid.make(inp.occupancy, inp.costmap, inp.resolution, inp.origin)
        if grid is None:
            return ControlOutput(0.0, 0.0, BLOCKED, detail="no usable map")
        pose = finite(inp.pose, 3)
        if pose is None:
            return ControlOutput(0.0, 0.0, BLOCKED, detail="the pose is not finite")
        x, y, yaw = pose
        v_meas = (finite(inp.velocity, 1) or (0.0,))[0]   # only the acceleration cap reads it
        period_s = self._clock(inp.now_s)
        xy = np.array([x, y])
        goal = (float(points[-1, 0]), float(points[-1, 1]))
        if grid.occupancy(np.array([x]), np.array([y]))[0] >= self.body.occupied_threshold:
            return ControlOutput(0.0, 0.0, BLOCKED, goal, "the robot's cell is an obstacle")

        # 2. goal (the tracker's latch): the path left counts as none on the last segment
        on_last = self._segment == len(points) - 2
        if tracker.at_goal(math.dist(xy, goal), 0.0 if on_last else math.inf):
            return tracker.arrive(inp, pose, goal,
                                  lambda err: self._turn_rate(err, cfg.angular_kp_per_s * err))

        # 1. the segment; 3. its errors
        while True:
            a, b = points[self._segment], points[self._segment + 1]
            seg = b - a
            length = float(np.hypot(*seg))
            direction = seg / length
            d = float(np.dot(b - xy, direction))          # the end, ahead along the segment
            if d > cfg.corner_tolerance_m or self._segment == len(points) - 2:
                break
            self._segment += 1                            # the corner is reached: next one
            self._driving, self._last_d, self._last_e = False, None, None
        along = float(np.dot(xy - a, direction))
        carrot = a + (along + cfg.lookahead_m) * direction
        carrot_t = (float(carrot[0]), float(carrot[1]))
        e = wrap_angle(math.atan2(carrot[1] - y, carrot[0] - x) - yaw)
        de = 0.0 if self._last_e is None else wrap_angle(e - self._last_e) / period_s
        dd = 0.0 if self._last_d is None else (d - self._last_d) / period_s
        self._last_e, self._last_d = e, d

        # 4. the PD loops
        w = self.settings.angular_kp_per_s * e + self.settings.angular_kd * de
        limit = cfg.heading_abort_rad if self._driving else cfg.heading_tolerance_rad
        if abs(e) > limit:
            self._driving = False
            return tracker.turn(inp, pose, e, carrot_t, "the segment", self._turn_rate(e, w))
        self._driving = True
        r = self.robot
        v = cfg.linear_kp_per_s * max(d, 0.0) + cfg.linear_kd * dd
        v = min(max(v, 0.0), r.max_linear_mps, max(v_meas, 0.0) + r.max_linear_accel_mps2 * period_s)
        w = min(max(w, -r.max_angular_radps), r.max_angular_radps)

        # 5. is_colliding, with the body along the command's arc
        hit = self._colliding(inp, grid, x, y, yaw, v, w, d + cfg.corner_tolerance_m)
        if hit is not None:
            return ControlOutput(0.0, 0.0, BLOCKED, carrot_t, (
                f"{hit[2]} {hit[0]:.2f} m ahead at ({hit[1][0]:.2f}, {hit[1][1]:.2f}) on the arc "
                f"v {v:.2f} m/s, w {w:.2f} rad/s; robot at ({x:.2f}, {y:.2f}, {yaw:.2f} rad)"))
        return ControlOutput(float(v), float(w), FOLLOWING, carrot_t)

    # ------------------------------------------------------------------ pieces
    def _turn_rate(self, err: float, w: float) -> float:
        """PD's turn in place by ``err``: the loop's rate ``w`` (none when it turns the other
        way), at least rotate_speed_min_radps, within the robot's limit (not the tracker's
        rotate_speed_max_radps: seed 003's loop turns as fast as the robot can)."""
        floor = self.tracker.settings.rotate_speed_min_radps
        mag = min(max(abs(w) if w * err > 0 else 0.0, floor), self.robot.max_angular_radps)
        return math.copysign(mag, err)

    def _colliding(self, inp: ControlInput, grid: Grid, x: float, y: float, yaw: float,
                   v: float, w: float, max_m: float) -> Optional[tuple]:
        """(distance along the arc, (x, y), what) of the first colliding pose of arc (v, w)
        within max(v collision_horizon_s, collision_min_distance_m) (at most ``max_m``), or
        None."""
        cfg = self.settings
        length = min(max(v * cfg.collision_horizon_s, cfg.collision_min_distance_m), max(max_m, 0.0))
        ds = 0.5 * cfg.collision_margin_m
        n = int(min(max(math.ceil(length / ds), 1), 1000))
        s = length * np.arange(n + 1) / n
        kappa = w / v if v > 1e-9 else 0.0
        half = 0.5 * kappa * s
        chord = s * np.sinc(half / math.pi)
        xs, ys = x + chord * np.cos(yaw + half), y + chord * np.sin(yaw + half)
        clearance = self.body.clearance(inp, np.column_stack([xs, ys, yaw + 2.0 * half]),
                                        cfg.collision_margin_m)
        near = clearance < cfg.collision_margin_m
        if near[0]:          # escaping: the leading poses no nearer than the robot stands
            near &= ~np.cumprod(clearance >= clearance[0] - 1e-9).astype(bool)
        unknown = np.zeros_like(near)
        if cfg.unknown_is_collision:
            unknown = grid.occupancy(xs, ys) < 0
            if unknown[0]:
                unknown &= ~np.cumprod(unknown).astype(bool)
        hits = np.flatnonzero((near | unknown)[1:])
        if hits.size == 0:
            return None
        k = hits[0] + 1
        what = "an obstacle within the body's margin" if near[k] else "unknown cell"
        return float(s[k]), (float(xs[k]), float(ys[k])), what

    def _follow(self, path) -> Optional[np.ndarray]:
        """The path's points (no repeats); a different path restarts at its first segment."""
        track = self.tracker.follow(path)
        if track is None or len(track.points) < 2:
            self.reset()
            return None
        if track is not self._track:
            self._restart()
            self._track = track
        return track.points

