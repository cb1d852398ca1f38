"""Goal-to-velocity navigation core (ROS-free): global A* plan, replanning, a path controller.

The navigator node feeds it maps, poses and time; it plans with the core's A* on an
inflated costmap, replans when the map changes along the path, when the controller reports
the way blocked, and every ``replan_period_s`` (the map grows while exploring), and hands the
path to a controller with the ``control.Controller`` contract. Nothing here blocks.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from .. import _native, geometry
from ..config import positive, require
from ..control import ControlInput, FollowerSettings, PurePursuit
from ..robot import RobotSpec
from .costmap import INSCRIBED, CostmapSettings, PlannerSettings, PlanningError, make_costmap, plan


@dataclass(frozen=True)
class NavigationSettings:
    """navigator parameters (config/navigator.yaml)."""
    robot: str = "turtlebot3_waffle_pi"  # footprint, limits (config/robots/)
    base_frame: str = "base_footprint"
    controller_rate_hz: float = 10.0     # control loop (sim time)
    replan_period_s: float = 2.0         # replan at least this often while following
    max_blocked_replans: int = 3         # the controller reports blocked on this many maps in a row
                                         # (one report per map counts): fail
    snap_radius_m: float = 0.5           # a start/goal in inscribed cost moves to the nearest free cell within this
    # the navigator drives to a given goal: no visit penalty (the explorer weighs visits)
    planner: PlannerSettings = field(default_factory=lambda: PlannerSettings(visit_sensitivity=0.0))
    follower: FollowerSettings = field(default_factory=FollowerSettings)

    def validate(self, src: str) -> None:
        positive(src, self, "controller_rate_hz", "replan_period_s", "snap_radius_m")
        require(self.max_blocked_replans >= 1, src, "max_blocked_replans", "must be >= 1")


@dataclass
class MapView:
    occupancy: np.ndarray
    costmap: np.ndarray
    resolution: float
    origin: tuple
    visits: Optional[np.ndarray] = None

    def cell(self, x: float, y: float) -> tuple:
        return geometry.xy_to_cell((x, y), self.resolution, self.origin)

    def inside(self, cell: tuple) -> bool:
        return geometry.inside(cell[0], cell[1], self.costmap.shape)

    def centre(self, cells: np.ndarray) -> np.ndarray:
        """(x, y) of cell centres for an int (n, 2) array of (row, col)."""
        return geometry.cells_to_points(cells, self.resolution, self.origin)


class Navigation:
    """State: idle -> active -> succeeded | failed (with a reason), or idle again on cancel."""

    def __init__(self, settings: NavigationSettings, robot: RobotSpec,
                 costmap_settings: Optional[CostmapSettings] = None):
        self.s = settings
        self.costmap_settings = costmap_settings or CostmapSettings.for_robot(robot)
        self.controller = PurePursuit(settings.follower, robot)
        self.map: Optional[MapView] = None
        self.status, self.reason = "idle", ""
        self.goal: Optional[tuple] = None            # (x, y, yaw or None)
        self.path_xy = np.zeros((0, 2))               # the plan being followed (waypoints)
        self.dense_xy = np.zeros((0, 2))              # every cell of it, for map-change checks
        self._planned_at = -math.inf
        self._need_plan = False
        self._blocked = 0
        self._blocked_map: Optional[MapView] = None   # the map the last blocked report counted on
        self.last_output = None

    # ------------------------------------------------------------------ inputs
    def set_goal(self, x: float, y: float, yaw: Optional[float] = None) -> None:
        if not (math.isfinite(x) and math.isfinite(y)) or (yaw is not None and not math.isfinite(yaw)):
            self._finish("failed", f"goal ({x}, {y}, {yaw}) is not finite")
            return
        self.goal = (x, y, yaw)
        self.status, self.reason = "active", ""
        self._need_plan, self._blocked, self._blocked_map = True, 0, None
        self.controller.reset()

    def fail(self, reason: str) -> None:
        self._finish("failed", reason)

    def cancel(self) -> None:
        self.goal = None
        self.status, self.reason = "idle", "cancelled"
        self.path_xy = self.dense_xy = np.zeros((0, 2))

    def update_map(self, occupancy: np.ndarray, resolution: float, origin: tuple,
                   visits: Optional[np.ndarray] = None) -> None:
        costmap = make_costmap(occupancy, resolution, self.costmap_settings)
        self.map = MapView(occupancy, costmap, resolution, tuple(origin), visits)
        if self.status == "active" and len(self.dense_xy):
            rows, cols = geometry.points_to_cells(self.dense_xy, resolution, origin)
            if not geometry.inside(rows, cols, costmap.shape).all() \
                    or (costmap[rows, cols] >= INSCRIBED).any():
                self._need_plan = True      # the map changed along the path

    # ------------------------------------------------------------------ loop
    def step(self, now_s: float, pose: tuple, velocity: tuple) -> tuple:
        """(v m/s, w rad/s) for this control period; updates status/reason."""
        if self.status != "active" or self.map is None:
            return 0.0, 0.0
        if self._need_plan or now_s - self._planned_at >= self.s.replan_period_s:
            if not self._plan(pose, now_s):
                return 0.0, 0.0
        out = self.controller.compute(ControlInput(
            now_s=now_s, pose=pose, velocity=velocity, path=self.path_xy, goal_yaw=self.goal[2],
            costmap=self.map.costmap, resolution=self.map.resolution, origin=self.map.origin))
        self.last_output = out
        if out.status == "arrived":
            self._finish("succeeded", "arrived")
            return 0.0, 0.0
        if out.status in ("blocked", "no_path"):
            # A replan on the same map meets the same obstacle: the map may be stale (it comes
            # at ~1 Hz, the controller runs at 10 Hz; the cell ahead may be unknown only
            # because the last map predates the robot's arrival). Hold; count and replan once
            # per map (the robot stands still, so a replan on the same map gives the same path).
            if self._blocked_map is self.map:
                return 0.0, 0.0
            self._blocked_map = self.map
            self._blocked += 1
            if self._blocked > self.s.max_blocked_replans:
                self._finish("failed", f"blocked on {self._blocked} maps in a row near "
                                       f"({pose[0]:.2f}, {pose[1]:.2f})"
                                       + (f": {out.detail}" if out.detail else ""))
            else:
                self._need_plan = True
            return 0.0, 0.0
        self._blocked, self._blocked_map = 0, None
        return out.linear_mps, out.angular_radps

    def _snap(self, cell: tuple) -> Optional[tuple]:
        m = self.map
        if m.inside(cell) and m.costmap[cell] < INSCRIBED:
            return cell
        found = _native.nearest_accessible(m.costmap, cell, max_cost=INSCRIBED - 1,
                                           max_radius_m=self.s.snap_radius_m, resolution=m.resolution)
        return None if found is None else tuple(found)

    def _plan(self, pose: tuple, now_s: float) -> bool:
        m = self.map
        start = self._snap(m.cell(pose[0], pose[1]))
        goal = self._snap(m.cell(self.goal[0], self.goal[1]))
        self._planned_at, self._need_plan = now_s, False
        if start is None:
            return self._finish("failed", f"no free cell within {self.s.snap_radius_m} m of the robot "
                                          f"at ({pose[0]:.2f}, {pose[1]:.2f})")
        if goal is None:
            return self._finish("failed", f"goal ({self.goal[0]:.2f}, {self.goal[1]:.2f}) is in an obstacle, "
                                          f"unknown space or off the map, with no free cell within "
                                          f"{self.s.snap_radius_m} m")
        try:
            dense = plan(m.costmap, start, goal, replace(self.s.planner, shortcut=False),
                         visits=m.visits, resolution=m.resolution)
        except PlanningError as exc:
            return self._finish("failed", str(exc))
        # The path starts at the robot's exact position, anywhere in its cell, so its first leg
        # goes to the next cell of the dense plan, whose straight line stays in the 2 x 2 block
        # the plan crossed (no corner cutting); line-of-sight shortcuts start there. A shortcut
        # from the start cell's centre was checked from that centre only: from the robot's
        # actual position its line could clip an inscribed cell of a pillar's band, and every
        # look-ahead point along it was "blocked", plan after plan.
        rest = dense[1:]
        waypoints = _native.shortcut(rest, m.costmap) if self.s.planner.shortcut and len(rest) > 1 else rest
        self.dense_xy = m.centre(dense)
        self.path_xy = np.vstack([[pose[0], pose[1]], m.centre(waypoints).reshape(-1, 2)])
        return True

    def _finish(self, status: str, reason: str) -> bool:
        self.status, self.reason = status, reason
        self.path_xy = self.dense_xy = np.zeros((0, 2))
        return False
