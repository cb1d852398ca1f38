"""The dynamic window approach (seed 001; Fox, Burgard & Thrun 1997) behind the controller
contract; the sampling and scoring are C++ (include/turtlebot_recon/dwa.hpp, ``_native.Dwa``).

One control step, ``DwaController.compute(ControlInput) -> ControlOutput``:

1. progress  the path point closest to the robot, searched forward from the last one only
             (the shared ``tracking.PathTracker``: exact on the path's segments, a densified
             path in effect).
2. goal      within ``xy_goal_tolerance_m`` of the end (the tracker's latch): turn in place to
             ``goal_yaw`` if one is given, then "arrived".
3. target    the look-ahead point at arc length L_d beyond the closest point,
             L_d = lookahead_min_m + lookahead_time_s v_top, v_top the window's top speed
             (the measured |v| + one period's acceleration, at most the robot's maximum; seed
             001's "look-ahead proportional to the speed"): with lookahead_time_s = horizon_s the
             point lies lookahead_min_m beyond the farthest arc end, so the heading term (the
             bearing of the point from each arc's end pose) never looks back at it.
4. rotate    the target more than ``rotate_threshold_rad`` off the heading: turn in place toward
             it where the turn is clear (the tracker's law); a window of +-a_w T around w = 0
             would take many periods to turn round on arcs.
5. DWA       n_v x n_w arcs in the dynamic window (C++): body against the distance field of the
             occupancy, Fox's admissibility, score 0.75 heading + 0.18 clearance + 0.08 velocity.
6. exact     the chosen arc's first ``check_horizon_s`` checked with the exact footprint
             (BodyCheck, poses every half margin): the field's interpolation errs by up to half
             a cell; failing that, the next best admissible arc, up to ``exact_check_tries``.
7. none      no admissible arc, or the best one neither moves (v < 1 cm/s from standstill) nor
             turns (DWA always admits standing still): zero command, "blocked", one line saying
             why (seed 001's "drift" at 0.2 m/s is not used: the navigator replans, the
             supervisor recovers).

Tight corners (as the follower's, simplified): a corner of the path within L_d where the
turning disc does not clear obstacles by 0.1 m is the target and the arcs' end (the robot stops
on it, within 3 cm); standing on it, the robot turns in place to the next segment's heading
(to within 0.05 rad) where the turn is clear, then drives on.

Clearance is scored up to the plan's own clearance along the next L_d of the path (at most
``clearance_max_m``): entering a corridor the plan goes through then scores as well as standing
in the open before it (else the clearance term keeps the robot out of every narrow place).

Weights: seed 001's report gives 0.75 to obstacle avoidance and 0.18 to path tracking; issue 18
(and this module's defaults) read them as 0.75 heading + 0.18 clearance. With Fox's normalisation
(each term over its sum across the window) a dominant clearance term drives the robot to the
middle of every room instead of along the plan, so heading gets the 0.75.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .. import _native
from ..config import positive, require
from ..geometry import wrap_angle
from ..robot import RobotSpec, footprint_args
from .base import (BLOCKED, FOLLOWING, NO_PATH, ControlInput, ControlMarkers, ControlOutput,
                   PeriodClock)
from .footprint import BodyCheck
from .tracking import Grid, PathTracker, Track, TrackingSettings, finite

STALL_MPS = 0.01   # a best arc this slow, from standstill and not turning: no way on ("blocked")
CORNER_CLEARANCE_M = 0.1   # a corner where the turning disc clears obstacles by less is tight
                           # (the follower's corner_cut_clearance_m)
CORNER_TOLERANCE_M = 0.03  # on a tight corner within this (DWA's arcs end there)
ALIGN_RAD = 0.05           # leave a tight corner this close to the next segment's heading


@dataclass(frozen=True)
class DwaSettings:
    # the window and the rollouts (seed 001: 20 x 20 samples, a 2 s horizon)
    linear_samples: int = 20             # n_v, evenly spaced over the window's v (edges included)
    angular_samples: int = 20            # n_w, over its w
    horizon_s: float = 2.0               # each (v, w) held this long
    dt_s: float = 0.1                    # rollout step; the body is checked every grid cell it
                                         # moves, at most every step
    # score = heading_weight heading + clearance_weight clearance + velocity_weight velocity,
    # each normalised by its sum over the admissible arcs (Fox et al.)
    heading_weight: float = 0.75         # the bearing of the look-ahead point from the arc's end
    clearance_weight: float = 0.18       # the body's least clearance along the arc
    velocity_weight: float = 0.08        # v
    clearance_max_m: float = 0.3         # clearance scored up to this (m): farther is as good
    # the look-ahead point: L_d = lookahead_min_m + lookahead_time_s x the window's top speed
    lookahead_min_m: float = 0.3         # m beyond the farthest arc end (with the time = horizon)
    lookahead_time_s: float = 2.0        # s, = horizon_s: the point stays beyond every arc
    # collisions
    collision_margin_m: float = 0.005    # m, the body nearer an obstacle's edge than this collides
    unknown_is_collision: bool = True    # an arc whose centre enters unknown space is rejected
    outline_spacing_m: float = 0.05      # m, the box's outline points for the field lookups
    check_horizon_s: float = 0.5         # s of the chosen arc checked with the exact footprint
    exact_check_tries: int = 5           # best admissible arcs tried against the exact check

    def validate(self, src: str) -> None:
        positive(src, self, "linear_samples", "angular_samples", "horizon_s", "dt_s",
                 "clearance_max_m", "lookahead_min_m", "collision_margin_m", "outline_spacing_m", "check_horizon_s",
                 "exact_check_tries")
        for key in ("heading_weight", "clearance_weight", "velocity_weight", "lookahead_time_s"):
            require(getattr(self, key) >= 0, src, key, "must be >= 0")
        require(self.heading_weight + self.clearance_weight + self.velocity_weight > 0, src,
                "heading_weight", "the three weights must not all be 0")
        require(self.dt_s <= self.horizon_s, src, "dt_s", f"must be <= horizon_s ({self.horizon_s})")


class DwaController:
    """DWA (C++) on the path's look-ahead point, with the shared goal handling and in-place
    turns (tracking.PathTracker) and an exact footprint check of the command."""

    def __init__(self, settings: DwaSettings, robot: RobotSpec,
                 tracking: Optional[TrackingSettings] = None):
        self.settings = settings
        self.robot = robot
        self.body = BodyCheck(robot, settings.collision_margin_m)
        self.tracker = PathTracker(TrackingSettings() if tracking is None else tracking, robot,
                                   self.body)
        s = settings
        self.dwa = _native.Dwa(
            max_linear_mps=robot.max_linear_mps, max_angular_radps=robot.max_angular_radps,
            min_linear_mps=0.0,          # forward only, as every controller here but MPPI
            linear_accel_mps2=robot.max_linear_accel_mps2,
            angular_accel_radps2=robot.max_angular_accel_radps2, **footprint_args(robot),
            outline_spacing_m=s.outline_spacing_m, linear_samples=s.linear_samples,
            angular_samples=s.angular_samples, horizon_s=s.horizon_s, dt_s=s.dt_s,
            margin_m=s.collision_margin_m, clearance_max_m=s.clearance_max_m,
            unknown_is_obstacle=s.unknown_is_collision, occupied_threshold=self.body.occupied_threshold,
            heading_weight=s.heading_weight, clearance_weight=s.clearance_weight,
            velocity_weight=s.velocity_weight)
        self._clock = PeriodClock(0.1)   # the control period from the steps' times
        self.reset()

    def reset(self) -> None:
        self.tracker.reset()
        self._clock.reset()
        self.last_plan: Optional[dict] = None       # the last DWA result (for markers)
        self._last_pose: Optional[tuple] = None

    # ------------------------------------------------------------------ the step
    def compute(self, inp: ControlInput) -> ControlOutput:
        cfg, tracker = self.settings, self.tracker
        self.last_plan = None
        track = tracker.follow(inp.path)
        if track is None:
            self.reset()
            return ControlOutput(0.0, 0.0, NO_PATH, detail="fewer than two finite waypoints")
        grid = Grid.make(inp.occupancy, inp.costmap, inp.resolution, inp.origin)
        if grid is None:
            return ControlOutput(0.0, 0.0, BLOCKED, detail="no usable map")
        pose = finite(inp.pose, 3)
        if pose is None:
            return ControlOutput(0.0, 0.0, BLOCKED, detail="the pose is not finite")
        velocity = finite(inp.velocity, 2)
        if velocity is None:
            return ControlOutput(0.0, 0.0, BLOCKED, detail="the measured velocity is not finite")
        (x, y, yaw), (v_meas, w_meas) = pose, velocity
        period_s = self._clock(inp.now_s)
        xy = np.array([x, y])

        progress_m = tracker.advance(xy)
        remaining_m = track.length - progress_m
        d_goal_xy = float(np.hypot(*(track.goal - xy)))
        goal = (float(track.goal[0]), float(track.goal[1]))
        if grid.occupancy(np.array([x]), np.array([y]))[0] >= self.body.occupied_threshold:
            return ControlOutput(0.0, 0.0, BLOCKED, goal, "the robot's cell is an obstacle")

        # 2. goal
        if tracker.at_goal(d_goal_xy, remaining_m):
            return tracker.arrive(inp, pose, goal)
        tol = tracker.settings.xy_goal_tolerance_m

        # 3. the look-ahead point, 4. far behind: turn in place
        v_top = min(self.robot.max_linear_mps, abs(v_meas) + self.robot.max_linear_accel_mps2 * period_s)
        lookahead_m = cfg.lookahead_min_m + cfg.lookahead_time_s * v_top
        stop = goal
        corner, standing_on = self._tight_corner(inp, track, xy, lookahead_m)
        if standing_on is not None:          # on a tight corner: face the next segment first
            err = wrap_angle(math.atan2(standing_on[1], standing_on[0]) - yaw)
            if abs(err) > ALIGN_RAD and self.body.turn_clear(inp, pose, err):
                return tracker.turn(inp, pose, err, (x, y), "the next segment")
        if corner is not None:               # a tight corner ahead: aim at it, stop on it
            target, stop = corner, (float(corner[0]), float(corner[1]))
            tol = CORNER_TOLERANCE_M
            remaining_m = d_goal_xy = math.hypot(corner[0] - x, corner[1] - y)
        else:
            target = track.point_at(progress_m + lookahead_m)
        target_t = (float(target[0]), float(target[1]))
        alpha = wrap_angle(math.atan2(target[1] - y, target[0] - x) - yaw) \
            if math.hypot(target[0] - x, target[1] - y) > 1e-9 else 0.0
        if abs(alpha) > tracker.settings.rotate_threshold_rad and corner is None:
            return tracker.turn(inp, pose, alpha, target_t, "the look-ahead point")

        # 5. DWA, clearance scored up to the plan's own ahead
        ahead = self._path_poses(inp, track, progress_m, progress_m + lookahead_m)
        plan = self.dwa.plan(np.asarray(inp.occupancy, dtype=np.int8), float(inp.resolution),
                             (float(inp.origin[0]), float(inp.origin[1])), (x, y, yaw),
                             (v_meas, w_meas), period_s, target_t, stop,
                             goal_radius_m=tol, goal_distance_m=max(remaining_m, d_goal_xy),
                             path_ahead=ahead)
        self.last_plan, self._last_pose = plan, (x, y, yaw)
        admissible = np.flatnonzero(plan["admissible"])
        if admissible.size == 0:
            return self._none(plan, (x, y, yaw), target_t)

        # 6. the exact footprint on the first check_horizon_s of the best arcs
        order = admissible[np.argsort(-plan["score"][admissible], kind="stable")]
        for i in order[:cfg.exact_check_tries]:
            v, w = float(plan["v"][i]), float(plan["w"][i])
            if self.body.stays_clear(inp, self._arc(x, y, yaw, v, w)):
                if v < STALL_MPS and abs(v_meas) < STALL_MPS \
                        and abs(w) < tracker.settings.rotate_speed_min_radps:
                    return ControlOutput(0.0, 0.0, BLOCKED, target_t, (
                        f"no admissible arc moves the robot on: the best is v {v:.3f} m/s, w "
                        f"{w:.2f} rad/s; robot at ({x:.2f}, {y:.2f}, {yaw:.2f} rad)"))
                if i != plan["best"]:
                    self.last_plan = dict(plan, best=int(i), trajectory=self.dwa.rollout(
                        (x, y, yaw), v, w, int(plan["poses"][i])))
                return ControlOutput(*self._limit(v, w), FOLLOWING, target_t)
        return ControlOutput(0.0, 0.0, BLOCKED, target_t, (
            f"the {min(len(order), cfg.exact_check_tries)} best admissible arcs meet an obstacle "
            f"within {cfg.check_horizon_s} s by the exact footprint; robot at ({x:.2f}, {y:.2f}, "
            f"{yaw:.2f} rad)"))

    # ------------------------------------------------------------------ rviz
    def markers(self, max_rollouts: int = 50) -> Optional[ControlMarkers]:
        """The last step's chosen arc and an evenly spread sample of its arcs, scored in [0, 1]
        (NaN: inadmissible); None when the last step ran no DWA."""
        plan, pose = self.last_plan, self._last_pose
        if plan is None or pose is None:
            return None
        n = len(plan["v"])
        pick = np.unique(np.linspace(0, n - 1, min(max_rollouts, n)).round().astype(int))
        rollouts = [self.dwa.rollout(pose, float(plan["v"][i]), float(plan["w"][i]),
                                     self.dwa.steps + 1) for i in pick]
        score = plan["score"][pick].astype(float)
        ok = np.isfinite(score)
        if ok.any():
            lo, hi = score[ok].min(), score[ok].max()
            score[ok] = (score[ok] - lo) / (hi - lo) if hi > lo else 1.0
        score[~ok] = np.nan
        return ControlMarkers(trajectory=np.asarray(plan["trajectory"]), rollouts=rollouts,
                              scores=score)

    # ------------------------------------------------------------------ pieces
    def _arc(self, x: float, y: float, yaw: float, v: float, w: float) -> np.ndarray:
        """Poses every half margin along the first check_horizon_s of arc (v, w)."""
        cfg = self.settings
        reach = (abs(v) + abs(w) * self.robot.radius_m) * cfg.check_horizon_s
        n = int(min(max(math.ceil(reach / (0.5 * cfg.collision_margin_m)), 1), 1000))
        t = cfg.check_horizon_s * np.arange(n + 1) / n
        th = w * t
        chord = v * t * np.sinc(th / (2.0 * math.pi))      # 2 v / w sin(w t / 2), exact
        return np.column_stack([x + chord * np.cos(yaw + th / 2), y + chord * np.sin(yaw + th / 2),
                                yaw + th])

    def _tight_corner(self, inp: ControlInput, track: Track, xy: np.ndarray,
                      lookahead_m: float) -> tuple:
        """(the next corner within ``lookahead_m`` where the turning disc does not clear
        obstacles by CORNER_CLEARANCE_M, or None; the direction of the segment after the tight
        corner the robot stands on (within CORNER_TOLERANCE_M), or None). An arc cut across such
        a corner strays off the plan in a narrow place: the robot stops on it and turns there."""
        inner = np.arange(1, len(track.points) - 1)
        if inner.size == 0:
            return None, None
        s = track.s[inner]
        progress_m = self.tracker.progress_m
        near = inner[(s >= progress_m - CORNER_TOLERANCE_M) & (s <= progress_m + lookahead_m)]
        if near.size == 0:
            return None, None
        tight = ~self.body.disc_clear(inp, track.points[near], CORNER_CLEARANCE_M)
        for k, is_tight in zip(near, tight):
            if not is_tight:
                continue
            if math.dist(track.points[k], xy) <= CORNER_TOLERANCE_M:
                return None, track.seg[k]
            return track.points[k], None
        return None, None

    @staticmethod
    def _path_poses(inp: ControlInput, track: Track, s0: float, s1: float) -> np.ndarray:
        """Poses every cell along the path from arc length s0 to s1, each facing along its
        segment: DWA scores clearance up to the body's least clearance there."""
        s = np.arange(s0, min(s1, track.length) + 1e-9, float(inp.resolution))
        if s.size == 0 or len(track.seg_len) == 0:
            return np.zeros((0, 3))
        i = np.clip(np.searchsorted(track.s, s, side="right") - 1, 0, len(track.seg_len) - 1)
        xy = np.column_stack([np.interp(s, track.s, track.points[:, 0]),
                              np.interp(s, track.s, track.points[:, 1])])
        yaw = np.arctan2(track.seg[i, 1], track.seg[i, 0])
        return np.column_stack([xy, yaw])

    def _none(self, plan: dict, pose: tuple, target: tuple) -> ControlOutput:
        n = len(plan["v"])
        v_lo, v_hi, w_lo, w_hi = plan["window"]
        return ControlOutput(0.0, 0.0, BLOCKED, target, (
            f"no admissible arc: all {n} in the window v [{v_lo:.2f}, {v_hi:.2f}] m/s, w "
            f"[{w_lo:.2f}, {w_hi:.2f}] rad/s meet an obstacle, unknown space or cannot stop within "
            f"their clearance; robot at ({pose[0]:.2f}, {pose[1]:.2f}, {pose[2]:.2f} rad)"))

    def _limit(self, v: float, w: float) -> tuple:
        r = self.robot
        return (float(min(max(v, 0.0), r.max_linear_mps)),
                float(min(max(w, -r.max_angular_radps), r.max_angular_radps)))
