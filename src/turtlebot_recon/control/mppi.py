"""MPPI controller (seed 000's Algorithm 1 in Nav2's shape), behind the ``Controller`` contract.

The optimizer is C++ (include/turtlebot_recon/mppi/, bound as ``_native.MppiOptimizer``); this
module prepares its inputs (a densified local path, the map once per new occupancy array),
judges its answer (the exact body check of the first ``check_horizon_s``) and says what it did.

One control step, ``MppiController.compute(ControlInput) -> ControlOutput``:

1. input      fewer than two usable waypoints: "no_path"; no usable map, a non-finite pose or
              velocity, a map smaller than the rollouts' reach (2 x v_max x horizon), the
              robot's or the goal's cell an obstacle: "blocked"; each with a one-line detail
              and a zero command (the warm start is dropped).
2. progress   the path point nearest the robot, searched forward only (the shared
              ``tracking.PathTracker``).
3. goal       within ``xy_goal_tolerance_m`` (the tracker's latch): turn in place to
              ``goal_yaw`` where BodyCheck.turn_clear allows, then "arrived".
   heading    the path ``rotate_lookahead_m`` ahead lies more than ``rotate_threshold_rad`` off
              the heading: turn in place toward it first, where the turn is clear (Nav2's
              rotation shim: sampled rollouts rarely hold a turn long enough to face about,
              and would back up along the path instead).
4. MPPI       one iteration (optimizer.hpp) on the dense path from the progress point; the
              distance field covers a rolling window round the robot (Nav2's local costmap:
              the rollouts' reach + the body + the repulsion band + WINDOW_SLACK_M a side,
              exact for every clearance the critics look at), rebuilt for a new occupancy
              array or once the robot is WINDOW_SLACK_M from the window's centre (an office
              map's whole field took 20 ms, the window's well under 1 ms).
5. checks     every rollout collides; the chosen trajectory's first ``check_horizon_s``, every
              ``collision_margin_m``, fails the exact body check (BodyCheck.stays_clear); the
              robot has neither moved ``stall_distance_m`` nor turned ``stall_turn_rad`` in
              ``progress_timeout_s`` (across replans: each new path would restart a count
              along the path); or the
              chosen trajectory stands still (moves < ``stall_distance_m``, turns <
              ``stall_turn_rad``) for ``stall_time_s`` in a row farther than
              ``stall_distance_m`` from the goal's tolerance (one iteration from rest stands
              still where the path bends away; the warm start turns it in 2-3):
              "blocked", zero command (the navigator replans).
6. command    the sequence's first control, clamped to the robot's limits (it already keeps
              them: the model does): "rotating" when it turns nearly on the spot, else
              "following".

API (also for Tube MPPI, control/tube_mppi.py)
----------------------------------------------
``MppiSettings``   frozen dataclass, config/mppi.yaml; ``validate(src)``.
``MppiController(settings: MppiSettings, robot: RobotSpec,
               tracking: Optional[TrackingSettings] = None, seed: Optional[int] = None)``
    (tracking None: TrackingSettings' defaults; seed None: settings.seed)
    ``reset()``                           forget the path, the warm start and the RNG state
                                          (re-seeded: runs are repeatable)
    ``compute(inp: ControlInput) -> ControlOutput``   the Controller contract
    ``optimize(state, velocity, path, goal_yaw, occupancy, resolution, origin,
               period_s=None) -> MppiPlan``
        One MPPI iteration from an arbitrary (nominal) state, no safety checks and no
        statuses: Tube MPPI's nominal controller. ``state`` (x m, y m, yaw rad) map frame;
        ``velocity`` (v m/s, w rad/s) the state's current speeds (the acceleration limits
        start from them; for a nominal state: the nominal's last control); ``path`` float
        (n >= 2, 2) waypoints (its last point is the goal); ``goal_yaw`` rad or None;
        ``occupancy`` int8 grid (the distance field of a window round ``state`` is rebuilt
        when another array object is passed or ``state`` leaves the window's middle); ``resolution`` m/cell; ``origin`` (x, y) m; ``period_s``: time since the
        previous call (the warm start shifts by round(period_s / model_dt_s) steps; None: one
        control period, 1 / ``control_rate_hz``). Warm-started from the previous call.
    ``last_rollouts(n=50) -> np.ndarray``  float (n, T + 1, 3) poses of a sample of the last
                                          iteration's rollouts (rviz)
    ``trajectory``                        float (T + 1, 3) the last chosen trajectory (rviz)
``MppiPlan``       frozen dataclass:
    ``controls``   float (T, 2) the nominal control sequence (v m/s, w rad/s), within the
                   robot's velocity and acceleration limits; ``controls[0]`` is the command
    ``states``     float (T + 1, 3) poses (x, y, yaw) from ``state`` under ``controls``,
                   ``model_dt_s`` apart
    ``min_cost``   float, the best sampled rollout's total critic cost
    ``colliding``  int, how many rollouts hit an obstacle (or left the map)
    ``all_collide`` bool, every sampled rollout did
    ``collides``   bool, the chosen trajectory itself hits one (the distance field's test)
Hooks for a subclass (TubeMppiController): ``_iterate(pose, velocity, goal_yaw, occupancy,
resolution, origin, period_s) -> MppiPlan`` is the one MPPI iteration compute() and optimize()
call (override it to put the ancillary controller around it; compute() then checks and
commands the plan it returns); ``_rotation_shim(inp, pose, goal) -> ControlOutput | None`` turns
in place before any iteration when the path lies more than ``rotate_threshold_rad`` off the
heading: a subclass whose ``_iterate`` must run every step overrides it to return None (or
sets the tracking's ``rotate_threshold_rad`` to pi).
Settings for seed 000's experiments: ``dataclasses.replace(MppiSettings(), ...)``, e.g. their
noise on the sampling (``noise_std_v_mps``, ``noise_std_w_radps``), ``model_dt_s``,
``time_steps``; the robot's limits come from the RobotSpec (a RobotSpec with other limits
for their unicycle). The binding underneath: ``_native.MppiOptimizer`` (set_map, optimize,
rollouts, costs, reset, reach_m), ``_native.mppi_motion_model``, ``_native.mppi_config_keys``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Optional

import numpy as np

from .. import _native
from ..config import positive, require
from ..geometry import wrap_angle
from ..robot import RobotSpec, footprint_args
from .base import (BLOCKED, FOLLOWING, NO_PATH, ROTATING, ControlInput, ControlMarkers, ControlOutput,
                   PeriodClock)
from .footprint import BodyCheck
from .tracking import Grid, PathTracker, TrackingSettings, finite


WINDOW_SLACK_M = 0.5   # m: the robot may move this far from the distance field's window centre
                       # before the window is rebuilt round it


@dataclass(frozen=True)
class MppiSettings:
    # --- the optimizer (include/turtlebot_recon/mppi/optimizer.hpp); Nav2's defaults
    batch_size: int = 2000               # K rollouts per cycle
    time_steps: int = 56                 # T steps: a 2.8 s horizon at model_dt_s
    model_dt_s: float = 0.05             # s, the motion model's step
    temperature: float = 0.3             # lambda (cost units): w = exp(-(C - min C) / lambda)
    noise_std_v_mps: float = 0.2         # m/s, sampling noise on v (the robot's full range ~0.26)
    noise_std_w_radps: float = 0.4       # rad/s, sampling noise on w
    noise_knot_steps: int = 4            # noise drawn every this many steps, linear between:
                                         # whole swerves (1: white noise, Nav2's)
    goal_region_m: float = 1.0           # m, the goal critics drive within it, the path ones beyond
    smooth: bool = True                  # Savitzky-Golay (window 9) over the control sequence
    outline_spacing_m: float = 0.05      # m, the box's outline points in the obstacle critic (an
                                         # obstacle corner may poke in by half of it)
    path_resolution_m: float = 0.05      # m, the path critics' distance grid
    threads: int = 1                     # threads of the obstacle and path_align critics (the
                                         # result is the same for any count; 1: one core)
    min_linear_mps: float = -0.1         # m/s, slowest speed (<= 0): a slow back-off, priced by
                                         # prefer_forward; at 0 the clamp there leaves the mean
                                         # near 0 and a robot creeps the last cm to the goal
    clamp_velocity: bool = True          # the model clamps to the velocity limits (false: only the
                                         # accelerations; velocity_limits_weight prices the excess)
    seed: int = 0                        # the noise's seed: equal seeds, equal commands
    # --- critics (include/turtlebot_recon/mppi/critics/, one file each); 0 disables one
    goal_distance_weight: float = 5.0    # per m of mean distance to the goal (goal region)
    goal_heading_weight: float = 1.0     # per rad of mean heading error to goal_yaw (Nav2's 3
                                         # holds a robot that must approach sideways off the goal)
    goal_heading_threshold_m: float = 0.5    # m, the heading critic works this near the goal
    path_follow_weight: float = 5.0      # per m from a rollout's end to the path one reach ahead
    path_align_weight: float = 14.0      # per m of mean distance from the path (the planner
                                         # checked the body fits there)
    obstacle_weight: float = 2.0         # per unit (0..1) of mean intrusion into the band
    obstacle_band_m: float = 0.15        # m, repulsion within this clearance of the body
    collision_margin_m: float = 0.005    # m, the body nearer an obstacle's edge collides (the
                                         # follower's margin; also the exact check's)
    collision_cost: float = 1000.0       # added once to a colliding rollout (>> every other cost)
    velocity_limits_weight: float = 10.0     # per m/s (rad/s) of mean excess over the limits
    prefer_forward_weight: float = 5.0   # per m/s of mean reverse speed
    # --- the controller around it (this module)
    control_rate_hz: float = 10.0        # Hz, the period assumed until two calls give it
    path_spacing_m: float = 0.05         # m, the global path densified to this (its waypoints
                                         # are corners)
    rotate_lookahead_m: float = 0.3      # m, the path point the heading is measured to (turning
                                         # in place past the tracking's rotate_threshold_rad)
    check_horizon_s: float = 0.5         # s of the chosen trajectory checked with the exact body
                                         # check before a command goes out (5 periods at 10 Hz)
    stall_distance_m: float = 0.05       # m, a chosen trajectory that moves less than this and
    stall_turn_rad: float = 0.1          # rad, turns less than this, away from the goal, for
    stall_time_s: float = 1.0            # s in a row: blocked (the first iterations from rest,
                                         # before the warm start builds up, stand still too)
    progress_timeout_s: float = 4.0      # s in which the robot neither moved stall_distance_m nor
                                         # turned stall_turn_rad: blocked (hovering before a wall;
                                         # a turn in place toward the path takes < 2 s)
    rollout_markers: int = 50            # rollouts kept for rviz

    def validate(self, src: str) -> None:
        positive(src, self, "batch_size", "time_steps", "model_dt_s", "temperature",
                 "noise_knot_steps", "threads", "goal_region_m", "outline_spacing_m",
                 "path_resolution_m", "obstacle_band_m", "collision_margin_m", "collision_cost",
                 "control_rate_hz", "path_spacing_m", "rotate_lookahead_m", "check_horizon_s", "stall_distance_m", "stall_turn_rad", "stall_time_s",
                 "progress_timeout_s")
        require(self.batch_size >= 2 and self.time_steps >= 2, src, "batch_size",
                "batch_size and time_steps must be >= 2")
        for key in ("noise_std_v_mps", "noise_std_w_radps", "goal_distance_weight",
                    "goal_heading_weight", "goal_heading_threshold_m", "path_follow_weight",
                    "path_align_weight", "obstacle_weight", "velocity_limits_weight",
                    "prefer_forward_weight", "rollout_markers"):
            v = getattr(self, key)
            require(math.isfinite(v) and v >= 0, src, key, f"must be >= 0, got {v!r}")
        require(self.min_linear_mps <= 0, src, "min_linear_mps", "must be <= 0")
        require(self.obstacle_band_m >= self.collision_margin_m, src, "obstacle_band_m",
                "must be >= collision_margin_m")
        require(0 <= self.seed < 2 ** 32, src, "seed", "must be in [0, 2^32)")

    def native_config(self) -> dict:
        """The keys the C++ optimizer takes (``_native.mppi_config_keys()``), seed excluded."""
        keys = set(_native.mppi_config_keys())
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name in keys}


@dataclass(frozen=True, eq=False)
class MppiPlan:
    controls: np.ndarray      # float (T, 2) (v m/s, w rad/s), within the robot's limits
    states: np.ndarray        # float (T + 1, 3) (x, y, yaw) from the start, model_dt_s apart
    min_cost: float           # the best rollout's cost
    colliding: int            # rollouts that hit an obstacle (or left the map)
    all_collide: bool         # every rollout did
    collides: bool            # the chosen trajectory itself does (the distance field's test)



def _seconds(now_s) -> Optional[float]:
    """A control step's time as a finite float, or None."""
    try:
        now = float(now_s)
    except (TypeError, ValueError):
        return None
    return now if math.isfinite(now) else None

class MppiController:
    """MPPI behind the Controller contract (module docstring)."""

    def __init__(self, settings: MppiSettings, robot: RobotSpec,
                 tracking: Optional[TrackingSettings] = None, seed: Optional[int] = None):
        self.settings = settings
        self.robot = robot
        self.body = BodyCheck(robot, settings.collision_margin_m)
        self.tracker = PathTracker(TrackingSettings() if tracking is None else tracking, robot,
                                   self.body)
        self._opt = _native.MppiOptimizer(
            settings.native_config(), max_linear_mps=robot.max_linear_mps,
            max_angular_radps=robot.max_angular_radps,
            max_linear_accel_mps2=robot.max_linear_accel_mps2,
            max_angular_accel_radps2=robot.max_angular_accel_radps2,
            seed=settings.seed if seed is None else int(seed), **footprint_args(robot))
        self._map_key = None            # (the occupancy array object, resolution, origin,
                                        # the window's centre (x, y))
        self.trajectory = np.zeros((0, 3))   # the last chosen trajectory (rviz)
        self._clock = PeriodClock(1.0 / settings.control_rate_hz)   # the period from the steps' times
        self.reset()

    # ------------------------------------------------------------------ contract
    def reset(self) -> None:
        self._opt.reset()
        self._carry = True                         # the next iteration starts at the speeds now
        self.tracker.reset()
        self._dense_of = None                      # the track _dense was made for
        self._dense: Optional[np.ndarray] = None   # the track every path_spacing_m (n, 2)
        self._dense_s: Optional[np.ndarray] = None
        self._clock.reset()
        self._mark: Optional[tuple] = None          # (time s, x, y, yaw) where the robot last moved
        self._still_since: Optional[float] = None   # time s the chosen trajectory began standing still
        self._start = (0.0, 0.0, 0.0)
        self.trajectory = np.zeros((0, 3))

    def compute(self, inp: ControlInput) -> ControlOutput:
        cfg = self.settings
        period_s = self._clock(inp.now_s)
        if not self._follow(inp.path):
            return self._stop(NO_PATH, "the path has fewer than two usable waypoints")
        tracker = self.tracker
        track = tracker.track
        goal = (float(track.goal[0]), float(track.goal[1]))
        grid = Grid.make(inp.occupancy, inp.costmap, inp.resolution, inp.origin)
        if grid is None:
            return self._stop(BLOCKED, "no usable map", goal)
        pose = finite(inp.pose, 3)
        if pose is None:
            return self._stop(BLOCKED, "the pose is not finite", goal)
        velocity = finite(inp.velocity, 2)
        if velocity is None:
            return self._stop(BLOCKED, "the measured velocity is not finite", goal)
        x, y, yaw = pose
        rows, cols = grid.occ.shape
        reach = self._opt.reach_m
        if min(rows, cols) * grid.res < 2.0 * reach:
            return self._stop(BLOCKED, f"the map ({cols * grid.res:.2f} x {rows * grid.res:.2f} m)"
                              f" is smaller than the rollouts' reach (2 x {reach:.2f} m)", goal)
        threshold = self.body.occupied_threshold
        if grid.occupancy(np.array([x]), np.array([y]))[0] >= threshold:
            return self._stop(BLOCKED, f"the robot's cell ({x:.2f}, {y:.2f}) is an obstacle", goal)
        if grid.occupancy(np.array([goal[0]]), np.array([goal[1]]))[0] >= threshold:
            return self._stop(BLOCKED, f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) is inside an "
                              "obstacle", goal)

        # the goal: latched xy tolerance, then the heading, turning in place
        remaining = track.length - tracker.advance(np.array([x, y]))
        d_goal = math.hypot(goal[0] - x, goal[1] - y)
        if tracker.at_goal(d_goal, remaining):
            return self._turn_to_goal(inp, pose, goal)
        turn = self._rotation_shim(inp, pose, goal)
        if turn is not None:
            return turn

        plan = self._iterate(pose, velocity, inp.goal_yaw, inp.occupancy, grid.res,
                             (grid.ox, grid.oy), period_s)
        v, w = self._clamp(plan.controls[0])
        k = self.settings.batch_size
        if plan.all_collide:
            return self._stop(BLOCKED, f"all {k} rollouts collide (or leave the map); robot at "
                              f"({x:.2f}, {y:.2f}, {yaw:.2f} rad)", goal)
        horizon = min(len(plan.states), int(round(cfg.check_horizon_s / cfg.model_dt_s)) + 1)
        ahead = _densify(plan.states[:horizon], cfg.collision_margin_m, self.robot.radius_m)
        if not self.body.stays_clear(inp, ahead):
            return self._stop(BLOCKED, f"the chosen trajectory's first {cfg.check_horizon_s} s "
                              f"bring the body within {cfg.collision_margin_m} m of an obstacle "
                              f"({plan.colliding} of {k} rollouts collide); robot at "
                              f"({x:.2f}, {y:.2f}, {yaw:.2f} rad)", goal)
        stuck = self._no_progress(inp.now_s, pose)
        if stuck:
            return self._stop(BLOCKED, f"{stuck}; {plan.colliding} of {k} rollouts collide; "
                              f"robot at ({x:.2f}, {y:.2f}, {yaw:.2f} rad)", goal)
        moved = np.hypot(*(plan.states[:, :2] - plan.states[0, :2]).T).max()
        turned = np.abs(plan.states[:, 2] - plan.states[0, 2]).max()
        near_goal = d_goal <= tracker.settings.xy_goal_tolerance_m + cfg.stall_distance_m  # a short way left
        still = moved < cfg.stall_distance_m and turned < cfg.stall_turn_rad and not near_goal
        if self._stood_still(still, inp.now_s):
            return self._stop(BLOCKED, f"the best of {k} rollouts has stood still for "
                              f"{cfg.stall_time_s} s ({plan.colliding} collide): the way along the "
                              f"path is blocked; robot at ({x:.2f}, {y:.2f}, {yaw:.2f} rad)", goal)
        status = ROTATING if abs(v) < 0.02 and abs(w) > 0.1 else FOLLOWING
        return ControlOutput(v, w, status, goal)

    # ------------------------------------------------------------------ Tube MPPI's entry
    def optimize(self, state, velocity, path, goal_yaw, occupancy, resolution, origin,
                 period_s: Optional[float] = None) -> MppiPlan:
        """One MPPI iteration from an arbitrary (nominal) state: see the module docstring.
        Raises ValueError on a path with fewer than two usable points or non-finite input."""
        if not self._follow(path):
            raise ValueError("MppiController.optimize: the path has fewer than two usable points")
        pose = finite(state, 3)
        speeds = finite(velocity, 2)
        if pose is None or speeds is None:
            raise ValueError("MppiController.optimize: state and velocity must be finite")
        self.tracker.advance(np.array(pose[:2]))
        if period_s is None:
            period_s = 1.0 / self.settings.control_rate_hz
        return self._iterate(pose, speeds, goal_yaw, occupancy, float(resolution),
                             (float(origin[0]), float(origin[1])), float(period_s))

    def last_rollouts(self, n: Optional[int] = None) -> np.ndarray:
        """float (n, T + 1, 3): a sample of the last iteration's rollouts, from its start pose."""
        n = self.settings.rollout_markers if n is None else int(n)
        r = self._opt.rollouts(n)
        start = np.broadcast_to(np.asarray(self._start, float), (len(r), 1, 3))
        return np.concatenate([start, r], axis=1)

    def markers(self, max_rollouts: int = 50) -> Optional[ControlMarkers]:
        """For rviz: the chosen trajectory and a sample of the last iteration's rollouts (the
        optimizer keeps their poses, not which sample each was: one shade, score 0.5); None
        before the first iteration."""
        if len(self.trajectory) == 0:
            return None
        rollouts = list(self.last_rollouts(max_rollouts))
        return ControlMarkers(np.asarray(self.trajectory, float), rollouts, np.full(len(rollouts), 0.5))

    # ------------------------------------------------------------------ pieces
    def _iterate(self, pose, velocity, goal_yaw, occupancy, resolution, origin,
                 period_s) -> MppiPlan:
        cfg = self.settings
        self._set_map(occupancy, resolution, origin, pose[:2])
        shift = max(0, int(round(period_s / cfg.model_dt_s)))
        gy = float(goal_yaw) if goal_yaw is not None and math.isfinite(goal_yaw) else None
        goal = self.tracker.track.goal
        # the speeds now, within the limits (a measured speed may overshoot them a little)
        v0 = min(max(velocity[0], cfg.min_linear_mps), self.robot.max_linear_mps)
        w0 = min(max(velocity[1], -self.robot.max_angular_radps), self.robot.max_angular_radps)
        if self._carry:
            # a new goal while driving: go on at the speed the robot has instead of easing off
            # from a warm start at rest (from rest the two are the same)
            self._opt.carry(v0, w0)
            self._carry = False
        out = self._opt.optimize(pose, (v0, w0), self._local_path(), (goal[0], goal[1]),
                                 goal_yaw=gy, shift_steps=shift)
        self._start = tuple(pose)
        self.trajectory = out["states"]
        return MppiPlan(out["controls"], out["states"], float(out["min_cost"]),
                        int(out["colliding"]), bool(out["all_collide"]), bool(out["collides"]))

    def _stood_still(self, still: bool, now_s) -> bool:
        """Whether the chosen trajectory has stood still for stall_time_s in a row."""
        now = _seconds(now_s)
        if not still or now is None:
            self._still_since = None
            return False
        if self._still_since is None or now < self._still_since:
            self._still_since = now
        return now - self._still_since >= self.settings.stall_time_s

    def _no_progress(self, now_s, pose) -> str:
        """Why the robot counts as stuck (neither stall_distance_m moved nor stall_turn_rad
        turned in progress_timeout_s), or "". Measured on the robot, not along the path: the
        navigator replans every few seconds, and progress along each new path started over
        (a robot hovering 0.85 m from its goal held there for minutes)."""
        cfg = self.settings
        now = _seconds(now_s)
        if now is None:
            return ""
        x, y, yaw = pose
        m = self._mark
        if m is None or now < m[0] or math.hypot(x - m[1], y - m[2]) >= cfg.stall_distance_m \
                or abs(wrap_angle(yaw - m[3])) >= cfg.stall_turn_rad:
            self._mark = (now, x, y, yaw)
            return ""
        if now - m[0] > cfg.progress_timeout_s:
            left_m = self.tracker.track.length - self.tracker.progress_m
            return (f"moved < {cfg.stall_distance_m} m and turned < {cfg.stall_turn_rad} rad in "
                    f"{now - m[0]:.1f} s, {left_m:.2f} m of path left")
        return ""

    def _set_map(self, occupancy, resolution: float, origin: tuple, centre) -> None:
        """The distance field of the window round ``centre`` (x, y), rebuilt for another
        occupancy array (or resolution, origin) or once ``centre`` is WINDOW_SLACK_M from the
        window's. Every pose a rollout from within WINDOW_SLACK_M of the centre reaches, with
        its body and the repulsion band round it, lies inside the window, so the clearances
        the critics use are the whole map's."""
        key = self._map_key
        if key is not None and key[0] is occupancy and key[1] == resolution and key[2] == origin \
                and math.hypot(centre[0] - key[3][0], centre[1] - key[3][1]) < WINDOW_SLACK_M:
            return
        occ = np.asarray(occupancy, dtype=np.int8)
        cfg = self.settings
        half = int(math.ceil((self._opt.reach_m + self.robot.radius_m
                              + max(cfg.obstacle_band_m, cfg.collision_margin_m) + WINDOW_SLACK_M)
                             / resolution)) + 1
        rows, cols = occ.shape
        r = min(max(int(math.floor((centre[1] - origin[1]) / resolution)), 0), rows - 1)
        c = min(max(int(math.floor((centre[0] - origin[0]) / resolution)), 0), cols - 1)
        r0, r1, c0, c1 = max(r - half, 0), min(r + half + 1, rows), max(c - half, 0), min(c + half + 1, cols)
        self._opt.set_map(np.ascontiguousarray(occ[r0:r1, c0:c1]), resolution,
                          (origin[0] + c0 * resolution, origin[1] + r0 * resolution),
                          occupied_threshold=self.body.occupied_threshold)
        self._map_key = (occupancy, resolution, origin, (float(centre[0]), float(centre[1])))

    def _follow(self, path) -> bool:
        """Track ``path`` (a new one restarts progress); False if it has < 2 usable points."""
        track = self.tracker.follow(path)
        if track is None or len(track.points) < 2:
            self.tracker.reset()
            return False
        if track is not self._dense_of:
            # densified: every path_spacing_m, and every corner exactly
            s = np.union1d(np.arange(0.0, track.length, self.settings.path_spacing_m), track.s)
            self._dense_of, self._dense_s = track, s
            self._dense = np.column_stack([np.interp(s, track.s, track.points[:, 0]),
                                           np.interp(s, track.s, track.points[:, 1])])
        return True

    def _local_path(self) -> np.ndarray:
        """The dense path from the progress point over two reaches and the goal region."""
        s0 = self.tracker.progress_m
        s1 = s0 + 2.0 * self._opt.reach_m + self.settings.goal_region_m
        inner = (self._dense_s > s0) & (self._dense_s <= s1)
        first = self.tracker.track.point_at(s0)
        return np.ascontiguousarray(np.vstack([first[None, :], self._dense[inner]]))

    def _rotation_shim(self, inp: ControlInput, pose: tuple,
                       goal: tuple) -> Optional[ControlOutput]:
        """Turn in place toward the path ``rotate_lookahead_m`` ahead when it lies more than
        the tracking's ``rotate_threshold_rad`` off the heading and the turn is clear, else None
        (MPPI drives). ``rotate_threshold_rad`` = pi disables it."""
        tracker = self.tracker
        x, y, yaw = pose
        ahead = tracker.track.point_at(tracker.progress_m + self.settings.rotate_lookahead_m)
        err = wrap_angle(math.atan2(ahead[1] - y, ahead[0] - x) - yaw)
        if abs(err) <= tracker.settings.rotate_threshold_rad \
                or not self.body.turn_clear(inp, pose, err):
            return None
        self._opt.reset()                     # the warm start was for the other heading
        self._mark = None
        self.trajectory = np.asarray([pose], float)
        return ControlOutput(0.0, tracker.turn_rate(err), ROTATING, goal)

    def _turn_to_goal(self, inp: ControlInput, pose: tuple, goal: tuple) -> ControlOutput:
        """The tracker's arrival (the goal's heading, turning in place); a stop drops the warm
        start as every stop does."""
        out = self.tracker.arrive(inp, pose, goal)
        if out.status != ROTATING:
            return self._stop(out.status, out.detail, goal)
        self.trajectory = np.asarray([pose], float)
        return out

    def _stop(self, status: str, detail: str, target=None) -> ControlOutput:
        """Zero command; the warm start is dropped (the next plan starts from rest)."""
        if status in (BLOCKED, NO_PATH):
            self._opt.reset()
            self._mark = self._still_since = None
        self.trajectory = np.zeros((0, 3))
        return ControlOutput(0.0, 0.0, status, target, detail)

    def _clamp(self, u) -> tuple:
        v, w = float(u[0]), float(u[1])
        if not (math.isfinite(v) and math.isfinite(w)):
            return 0.0, 0.0
        r = self.robot
        return (min(max(v, self.settings.min_linear_mps), r.max_linear_mps),
                min(max(w, -r.max_angular_radps), r.max_angular_radps))



def _densify(states: np.ndarray, step_m: float, radius_m: float) -> np.ndarray:
    """Poses between those of ``states`` so that no point of the body (within ``radius_m`` of
    base_footprint) moves more than ``step_m`` from one to the next."""
    out = [states[:1]]
    for a, b in zip(states[:-1], states[1:]):
        move = max(math.hypot(b[0] - a[0], b[1] - a[1]) + abs(b[2] - a[2]) * radius_m, 1e-12)
        n = max(1, int(math.ceil(move / step_m)))
        f = (np.arange(1, n + 1) / n)[:, None]
        out.append(a + f * (b - a))
    return np.vstack(out)
