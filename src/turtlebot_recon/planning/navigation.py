"""Goal-to-velocity navigation core (ROS-free): a lattice plan for the robot's footprint (or
an OMPL planner's, ``planner``: planning.sampling), replanning, a path controller.

The navigator node feeds it maps, poses and time. It plans with the state lattice
(``planning.lattice``: forward and backward moves whose swept box is clear, turns in place
where the turning disc or the box's sweep fits; for a round robot the box is its disc, so one
code path serves every robot), replans when the map changes under the planned poses, when the
controller reports the way blocked, and every ``replan_period_s`` (the map grows while
exploring), and hands the path to a controller with the ``control.Controller`` contract: the
robot's position, then the end of every straight run of the lattice path (the corners where it
turns in place), the goal last. A plan that drives backward somewhere is followed forward to
that cusp; one that starts backward is a manoeuvre the navigator drives itself (turn in place
to the run's heading, back straight along it), then it plans again. A robot the lattice finds
no way on from (parallel to a wall, no room to turn anywhere along it) drives an escape arc
(``lattice.escape_arcs``) to a lattice pose the plan goes on from. Nothing here blocks.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from .. import _native, geometry
from ..config import positive, require
from ..control import (BLOCKED, CONTROLLERS, DEFAULT_CONTROLLER, NO_PATH, BodyCheck, ControlInput,
                       DwaSettings, FollowerSettings, MppiSettings, PdSettings, TrackingSettings,
                       TubeMppiSettings, make_controller)
from ..control.tracking import PathTracker
from ..mapping.map_io import check_grid
from ..robot import RobotSpec
from .costmap import INSCRIBED, PlanningError
from .lattice import (ESCAPE_RADIUS_M, EscapeArc, LatticePath, LatticeSettings, escape_arcs,
                      footprint_clear, footprint_costmap, plan_lattice)
from .sampling import GLOBAL_PLANNERS, as_lattice_path, plan_sampling


@dataclass(frozen=True)
class NavigationSettings:
    """navigator parameters (config/navigator.yaml)."""
    robot: str = ""                  # footprint, limits (config/robots/); no default: the launch
                                         # files set it (their top-level files hold its one default)
    base_frame: str = "base_footprint"
    controller_rate_hz: float = 10.0     # control loop (sim time)
    replan_period_s: float = 2.0         # replan at least this often while following
    max_blocked_replans: int = 3         # the controller reports blocked on more tries than this in
                                         # a row (one per new map, or per replan_period_s on a map
                                         # that never changes): fail
    snap_radius_m: float = 0.5           # a start/goal where the footprint does not fit moves to
                                         # the nearest cell within this where it does
    planner: str = "lattice"             # the global planner: lattice, or one of OMPL's
                                         # (planning.sampling.GLOBAL_PLANNERS)
    sampling_budget_s: float = 0.2       # an OMPL planner's solve time per plan (wall s)
    controller: str = DEFAULT_CONTROLLER  # which drives: a name of control.CONTROLLERS
    takeover_m: float = 0.5              # where the controller finds no free way (blocked), the
                                         # pure pursuit drives the plan this far (m), then hands
                                         # back; 0: never (the blocked report stands)
    lattice: LatticeSettings = field(default_factory=LatticeSettings)
    # What every controller shares (progress along the path, the goal tolerances, turning in
    # place); the navigator's own manoeuvres use its goal tolerance and turn rates too.
    tracking: TrackingSettings = field(default_factory=TrackingSettings)
    # One block per controller (the launch files load config/<name>.yaml into ~<name>); the
    # pure pursuit's is ``follower``, whose collision_margin_m the navigator's own manoeuvres
    # use whichever controller drives.
    follower: FollowerSettings = field(default_factory=FollowerSettings)
    dwa: DwaSettings = field(default_factory=DwaSettings)
    pd: PdSettings = field(default_factory=PdSettings)
    mppi: MppiSettings = field(default_factory=MppiSettings)
    tube_mppi: TubeMppiSettings = field(default_factory=TubeMppiSettings)

    def validate(self, src: str) -> None:
        positive(src, self, "controller_rate_hz", "replan_period_s", "snap_radius_m",
                 "sampling_budget_s")
        require(self.planner in GLOBAL_PLANNERS, src, "planner",
                f"unknown planner '{self.planner}'; choose one of {', '.join(GLOBAL_PLANNERS)}")
        require(self.takeover_m >= 0.0, src, "takeover_m", "must be >= 0")
        require(self.max_blocked_replans >= 1, src, "max_blocked_replans", "must be >= 1")
        require(self.controller in CONTROLLERS, src, "controller",
                f"unknown controller '{self.controller}'; choose one of {', '.join(CONTROLLERS)}")

    def controller_settings(self):
        """The settings block of the selected controller (``follower`` for the pure pursuit)."""
        return getattr(self, SETTINGS_FIELD.get(self.controller, self.controller))


# A failure that the goal causes, not the robot's situation (the goal has no cell where the
# footprint fits, or the lattice has no way to it): its reason begins with this, so a caller
# can tell "this goal, on this map" from "the robot is stuck" (explorer: not sent again while
# the map near it is unchanged, instead of retried).
GOAL_UNREACHABLE = "goal unreachable: "

SETTINGS_FIELD = {"pure_pursuit": "follower"}   # controller -> its NavigationSettings field,
                                                # where the two names differ


@dataclass
class MapView:
    occupancy: np.ndarray      # int8, -1 unknown, 0..100
    costmap: np.ndarray        # uint8, the lattice's graded costmap (footprint_costmap)
    resolution: float
    origin: tuple

    def cell(self, x: float, y: float) -> tuple:
        return geometry.xy_to_cell((x, y), self.resolution, self.origin)

    def inside(self, cell: tuple) -> bool:
        return geometry.inside(cell[0], cell[1], self.costmap.shape)

    def centre(self, cells: np.ndarray) -> np.ndarray:
        """(x, y) of cell centres for an int (n, 2) array of (row, col)."""
        return geometry.cells_to_points(cells, self.resolution, self.origin)


def run_ends(path: LatticePath) -> np.ndarray:
    """Indices of the poses that end a straight run (reached forward, followed by a turn in place,
    a backward move or by nothing): the corners of the path, and its last pose."""
    n = len(path.turned)
    forward = np.zeros(n, bool)
    forward[1:] = ~path.turned[1:] & ~path.reversed[1:]
    followed = np.append(path.turned[1:] | path.reversed[1:], True)
    return np.flatnonzero(forward & followed)


BACK_ALIGN_RAD = 0.05  # a backward run starts once the heading is this close to the run's (and
                       # is steered onto its end from there)
ANCHOR_AHEAD_M = 0.25   # a replan continues the plan from this far ahead of the robot (about
                        # the follower's shortest look-ahead): a first leg that long points
                        # along the plan to within a few degrees


class Navigation:
    """State: idle -> active -> succeeded | failed (with a reason), or idle again on cancel."""

    def __init__(self, settings: NavigationSettings, robot: RobotSpec):
        self.s = settings
        self.robot = robot
        self.lattice = settings.lattice.with_robot(robot)
        self.lattice.validate("lattice")
        self._yaws = np.array([yaw for _, _, yaw in _native.lattice_headings(self.lattice.headings)])
        # the turning disc as a round robot, with the lattice's turning margin
        self._disc = replace(robot, footprint_length_m=0.0, footprint_width_m=0.0,
                             footprint_offset_x_m=0.0)
        self._disc_settings = replace(self.lattice, margin_m=max(self.lattice.turn_margin_m, 1e-6))
        self.controller = make_controller(settings.controller, settings.controller_settings(), robot,
                                          settings.tracking)
        # The lattice plan's own follower, for where a sampling controller finds no free way:
        # the plan's poses fit the body by construction, and the pure pursuit follows them
        # exactly (stopping on tight corners to turn in place), where the weighted mean of
        # samples drawn round a wall's end may not (Nav2 answers the same with recoveries).
        self.takeover = None if settings.controller == "pure_pursuit" or settings.takeover_m <= 0 \
            else make_controller("pure_pursuit", settings.follower, robot, settings.tracking)
        self._taken_at: Optional[np.ndarray] = None   # (x, y) where the takeover began
        self.takeovers = 0                             # how many this navigator has had
        self.takeover_detail = ""                      # why the last one (the blocked detail)
        self.body = BodyCheck(robot, settings.follower.collision_margin_m)
        self._turn = PathTracker(settings.tracking, robot, self.body)   # its turn-in-place law
        self.backing: Optional[np.ndarray] = None     # (x, y, yaw): turn to yaw, back to (x, y)
        self.approach: Optional[np.ndarray] = None    # (x, y): drive straight on to it first
        self.arc: Optional[EscapeArc] = None          # an escape arc being driven
        self._cusp = False                            # path_xy ends where the plan reverses
        self._reversing = False                       # this manoeuvre has started backing
        self.map: Optional[MapView] = None
        self.status, self.reason = "idle", ""
        self.goal: Optional[tuple] = None            # (x, y, yaw or None)
        self.goal_yaw: Optional[float] = None        # the yaw pursued: None where it does not fit
        self.path_xy = np.zeros((0, 2))               # the plan being followed (waypoints)
        self.path_poses = np.zeros((0, 3))            # its lattice poses, for map-change checks
        self.plan: Optional[LatticePath] = None
        self._planned_at = -math.inf
        self._need_plan = False
        self._blocked = 0
        self._blocked_map: Optional[MapView] = None   # the map the last blocked report counted on
        self._blocked_at = -math.inf                  # ... and when (s)
        self.last_output = None
        self.repeated_goals = 0                       # the active goal sent again (set_goal)
        self._new_goal = False                        # set_goal kept the old plan for the anchor

    # ------------------------------------------------------------------ inputs
    def set_goal(self, x: float, y: float, yaw: Optional[float] = None) -> bool:
        """Pursue (x, y) m (map frame), ending facing ``yaw`` (None: any heading). Returns False
        for a goal refused (not finite: the goal fails, its reason says why) and for the goal
        being pursued sent again (a client repeating itself, up to 1,000 times a second): its
        plan and the controller's state are kept, counted in ``repeated_goals``."""
        if not (math.isfinite(x) and math.isfinite(y)) or (yaw is not None and not math.isfinite(yaw)):
            self._finish("failed", f"goal ({x}, {y}, {yaw}) is not finite")
            return False
        if self.status == "active" and self.goal == (x, y, yaw):
            self.repeated_goals += 1
            return False
        self.goal = (x, y, yaw)
        # A goal that replaces one being driven to keeps the old plan until the new one is made,
        # which starts from its anchor (``_anchor``: a pose of it just ahead, on the line the
        # robot is driving), as a replan does: the robot drives on into the new plan rather than
        # stopping to turn in place where it stands. The old plan is never followed again.
        following = self.status == "active" and len(self.path_poses) and self.backing is None \
            and self.arc is None
        if not following:
            self._clear_path()
        self._new_goal = True
        self.status, self.reason = "active", ""
        self._need_plan, self._blocked, self._blocked_map, self._blocked_at = True, 0, None, -math.inf
        self.controller.reset()
        self._taken_at = None
        return True

    def repeat_line(self) -> str:
        """The node's line for ``repeated_goals``."""
        x, y, _ = self.goal
        return (f"navigator: the goal being pursued ({x:.2f}, {y:.2f}) was sent again "
                f"({self.repeated_goals} times so far): its plan kept")

    def fail(self, reason: str) -> None:
        self._finish("failed", reason)

    def cancel(self) -> None:
        self.goal = None
        self.status, self.reason = "idle", "cancelled"
        self._clear_path()

    def update_map(self, occupancy: np.ndarray, resolution: float, origin: tuple) -> None:
        self.set_map(self.map_view(occupancy, resolution, origin))

    def map_view(self, occupancy: np.ndarray, resolution: float, origin: tuple) -> MapView:
        """The map with its footprint costmap (~20 ms for the waffle_pi, in C++ without the GIL).
        Reads no state: a node builds it outside its lock, then hands it to ``set_map``, so the
        control loop is not held up meanwhile. A map that cannot be used (``check_grid``: empty,
        too large, resolution not positive) raises ValueError, one line; the map in use stays."""
        occupancy = np.asarray(occupancy, dtype=np.int8)
        if occupancy.ndim != 2:
            raise ValueError(f"map: expected a 2-D grid, got shape {occupancy.shape}")
        check_grid(*occupancy.shape, resolution, origin, occupancy.size)
        costmap = footprint_costmap(occupancy, resolution, self.robot, self.lattice)
        return MapView(occupancy, costmap, resolution, (float(origin[0]), float(origin[1])))

    def set_map(self, view: MapView) -> None:
        self.map = view
        if self.status != "active":
            return
        if len(self.path_poses):
            if not self._poses_clear(self.path_poses).all():
                self._need_plan = True  # the map changed under the path
        elif self._blocked_map is not None:
            self._need_plan = True      # waiting for a map that covers the robot

    # ------------------------------------------------------------------ loop
    def step(self, now_s: float, pose: tuple, velocity: tuple) -> tuple:
        """(v m/s, w rad/s) for this control period; updates status/reason."""
        if self.status != "active" or self.map is None:
            return 0.0, 0.0
        if self.backing is not None:
            return self._back(pose)
        if self.arc is not None:
            return self._escape(pose)
        if self._need_plan or now_s - self._planned_at >= self.s.replan_period_s:
            if not self._plan(pose, now_s):
                return 0.0, 0.0
            if self.backing is not None:
                return self._back(pose)
            if self.arc is not None:
                return self._escape(pose)
        m = self.map
        inp = ControlInput(
            now_s=now_s, pose=pose, velocity=velocity, path=self.path_xy, goal_yaw=self.goal_yaw,
            occupancy=m.occupancy, costmap=m.costmap, resolution=m.resolution, origin=m.origin)
        out = self._drive(inp)
        self.last_output = out
        if out.status == "arrived":
            if self._cusp:                       # near where the plan backs: its manoeuvre
                plan = self.plan
                first = int(np.flatnonzero(plan.reversed)[0])
                self._manoeuvre(plan, first)
                self.approach = plan.poses[first - 1, :2].copy()   # the follower stops 0.1 m short
                return self._back(pose)
            self._finish("succeeded", "arrived")
            return 0.0, 0.0
        if out.status in ("blocked", "no_path"):
            # A replan on the same map meets the same obstacle: the map may be stale (it comes
            # at ~1 Hz, the controller runs at 10 Hz; the cell ahead may be unknown only
            # because the last map predates the robot's arrival). Hold; count and replan once
            # per map (the robot stands still, so a replan on the same map gives the same path).
            self._hold(now_s, "blocked", f"near ({pose[0]:.2f}, {pose[1]:.2f})", out.detail)
            return 0.0, 0.0
        self._blocked, self._blocked_map = 0, None
        return out.linear_mps, out.angular_radps

    def _drive(self, inp: ControlInput):
        """The selected controller's output, or the takeover's: the pure pursuit drives from
        where the controller reported blocked until the robot is takeover_m from there; where
        one of the two is blocked the other, reset, is asked (the blocked report stands when
        both are)."""
        if self._taken_at is not None and math.hypot(
                inp.pose[0] - self._taken_at[0], inp.pose[1] - self._taken_at[1]) >= self.s.takeover_m:
            self._taken_at = None
            self.controller.reset()
        first, other = (self.takeover, self.controller) if self._taken_at is not None \
            else (self.controller, self.takeover)
        out = first.compute(inp)
        if out.status != BLOCKED or other is None:
            return out
        other.reset()
        alt = other.compute(inp)
        if alt.status in (BLOCKED, NO_PATH):
            return out
        if other is self.takeover:
            self._taken_at = np.array(inp.pose[:2], dtype=float)
            self.takeovers += 1
            self.takeover_detail = out.detail
        else:
            self._taken_at = None
        return alt

    def _hold(self, now_s: float, what: str, where: str, detail: str = "") -> None:
        """Stand still and plan again: a try counts once per new map (a replan on the same
        map meets the same obstacle), or once per replan_period_s on a map that never changes
        (map_server's, mode:=localization's); the goal fails when ``what`` happens on more
        than max_blocked_replans tries in a row."""
        if self._blocked_map is self.map and now_s - self._blocked_at < self.s.replan_period_s:
            return
        self._blocked_map, self._blocked_at = self.map, now_s
        self._blocked += 1
        if self._blocked > self.s.max_blocked_replans:
            self._finish("failed", f"{what} {self._blocked} times in a row {where}"
                                   + (f": {detail}" if detail else ""))
        else:
            self._need_plan = True

    # ------------------------------------------------------------------ planning
    def _poses_clear(self, poses: np.ndarray) -> np.ndarray:
        """bool (n,): the footprint fits at each pose (margin_m) and its centre is on known space."""
        m = self.map
        rows, cols = geometry.points_to_cells(poses[:, :2], m.resolution, m.origin)
        known = geometry.inside(rows, cols, m.occupancy.shape)
        known[known] = m.occupancy[rows[known], cols[known]] >= 0
        return known & footprint_clear(m.occupancy, m.resolution, m.origin, self.robot, poses,
                                       self.lattice)

    def _fit(self, cell: tuple, yaw: Optional[float], headings: int,
             turnable: bool = False) -> Optional[tuple]:
        """The pose (x, y, yaw) at ``cell`` where the footprint fits at one of the ``headings``
        lattice headings nearest ``yaw`` (every heading when ``yaw`` is None); failing that, at
        the nearest cell within ``snap_radius_m`` where it fits at some heading (the one nearest
        ``yaw``). ``turnable``: only cells where the turning disc fits too. None if there is
        none."""
        m = self.map
        order = np.arange(len(self._yaws)) if yaw is None else \
            np.argsort(np.abs(np.remainder(self._yaws - yaw + math.pi, 2 * math.pi) - math.pi),
                       kind="stable")
        reach = int(self.s.snap_radius_m / m.resolution)
        dr, dc = np.mgrid[-reach:reach + 1, -reach:reach + 1]
        dist = np.hypot(dr, dc).ravel()
        near = np.argsort(dist, kind="stable")
        near = near[dist[near] <= reach]
        cells = np.column_stack([cell[0] + dr.ravel()[near], cell[1] + dc.ravel()[near]])
        on = geometry.inside(cells[:, 0], cells[:, 1], m.costmap.shape)
        cells = cells[on]
        cells = cells[m.costmap[cells[:, 0], cells[:, 1]] < INSCRIBED]   # some heading may fit
        if turnable and len(cells):
            disc = np.column_stack([m.centre(cells), np.zeros(len(cells))])
            cells = cells[footprint_clear(m.occupancy, m.resolution, m.origin, self._disc, disc,
                                          self._disc_settings)]
        for chunk in range(0, len(cells), 64):
            block = cells[chunk:chunk + 64]
            own = chunk == 0 and len(block) and tuple(block[0]) == tuple(cell)
            xy = m.centre(block)
            yaws = self._yaws[order]
            poses = np.column_stack([np.repeat(xy, len(yaws), axis=0), np.tile(yaws, len(xy))])
            fits = footprint_clear(m.occupancy, m.resolution, m.origin, self.robot, poses,
                                   self.lattice).reshape(len(xy), len(yaws))
            if own:
                fits[0, headings:] = False        # the robot's own cell: only the nearest headings
            hit = np.flatnonzero(fits.any(axis=1))
            if hit.size:
                i = int(hit[0])
                return float(xy[i, 0]), float(xy[i, 1]), float(yaws[int(np.argmax(fits[i]))])
        return None

    def _anchor(self, pose: tuple) -> Optional[tuple]:
        """Where a replan starts while the robot follows a plan: the pose of that plan the robot
        is driving to, ANCHOR_AHEAD_M ahead along it or the end of the current straight run,
        whichever comes first; the new plan then continues the line the robot is on. (From the
        robot's own cell a new lattice line would start at that cell's centre, up to half a
        cell beside the robot, and a gap passed with a 2 cm margin would be blocked to it.)
        None when there is no plan, the robot is off it, or it no longer fits the map."""
        P = self.path_poses
        if not len(P):
            return None
        res = self.map.resolution
        xy = np.array(pose[:2], dtype=float)
        i = int(np.argmin(np.hypot(P[:, 0] - xy[0], P[:, 1] - xy[1])))
        if math.hypot(*(P[i, :2] - xy)) > 2.0 * res:
            return None
        ahead = ((P[:, 0] - xy[0]) * np.cos(P[:, 2]) + (P[:, 1] - xy[1]) * np.sin(P[:, 2]))
        ends = np.zeros(len(P), bool)
        stops = run_ends(self.plan)
        ends[stops[stops < len(P)]] = True            # P ends at the cusp, if the plan backs
        ends[-1] = True
        ok = (np.arange(len(P)) >= i) & (ahead > 0.5 * res) & ((ahead >= ANCHOR_AHEAD_M) | ends)
        j = np.flatnonzero(ok)
        if j.size == 0 or not self._poses_clear(P[i:j[0] + 1]).all():
            return None
        return tuple(float(v) for v in P[j[0]])

    def _start(self, pose: tuple) -> Optional[tuple]:
        """The lattice start for the robot at ``pose``: its own cell at the heading nearest its
        yaw, or the next nearest; else the first cell straight ahead (within snap_radius_m)
        where one of those fits, which it reaches without turning; else the nearest cell where
        the footprint fits at all (``_fit``)."""
        m = self.map
        x, y, yaw = (float(v) for v in pose[:3])
        ahead = np.arange(0.0, self.s.snap_radius_m + 1e-9, m.resolution)
        for d in ahead:
            cell = m.cell(x + d * math.cos(yaw), y + d * math.sin(yaw))
            if not m.inside(cell) or m.costmap[cell] >= INSCRIBED:
                if d > 0.0:
                    break                     # no further through an obstacle
                continue
            order = np.argsort(np.abs(np.remainder(self._yaws - yaw + math.pi, 2 * math.pi)
                                      - math.pi), kind="stable")[:2]
            xy = m.centre(np.array([cell]))
            poses = np.column_stack([np.repeat(xy, 2, axis=0), self._yaws[order]])
            fits = footprint_clear(m.occupancy, m.resolution, m.origin, self.robot, poses,
                                   self.lattice)
            if fits.any():
                return float(xy[0, 0]), float(xy[0, 1]), float(poses[int(np.argmax(fits)), 2])
        return self._fit(m.cell(x, y), yaw, headings=0)

    def _plan(self, pose: tuple, now_s: float, anchored: bool = True) -> bool:
        m = self.map
        self._planned_at, self._need_plan = now_s, False
        anchor = self._anchor(pose) if anchored else None
        if self._new_goal:                    # the old goal's plan served as the anchor only
            self._new_goal = False
            self._clear_path()
        start = anchor or self._start(pose)
        if start is None:
            where = f"({pose[0]:.2f}, {pose[1]:.2f})"
            cell = m.cell(pose[0], pose[1])
            if not m.inside(cell) or m.occupancy[cell] < 0:
                # a goal sent before the mapper has inserted a scan (startup): the map does not
                # cover the robot yet; wait for the next maps rather than fail on the first
                self._hold(now_s, "no known cell under the robot", f"at {where}")
                return False
            return self._finish("failed", f"no cell within {self.s.snap_radius_m} m of the robot at "
                                          f"{where} where its footprint fits")
        gx, gy, gyaw = self.goal
        if math.hypot(gx - pose[0], gy - pose[1]) <= self.s.tracking.xy_goal_tolerance_m:
            # there already (a manoeuvre may end at the goal, a lattice line beside its cell):
            # the follower only turns to the goal's yaw
            self._clear_path()
            self.goal_yaw = gyaw
            self.path_xy = np.array([[pose[0], pose[1]], [gx, gy]])
            return True
        goal_cell = m.cell(gx, gy)
        # A cell where the robot can turn round first (a goal in a narrow dead end, a maze's or a
        # door's, would leave it only the way out backwards). That cell may lie beyond a thin
        # wall, out of reach: then the goal's own cell (or the nearest that fits).
        goals = [g for g in (self._fit(goal_cell, gyaw, headings=len(self._yaws), turnable=True),
                             self._fit(goal_cell, gyaw, headings=len(self._yaws))) if g is not None]
        if not goals:
            return self._finish("failed", f"{GOAL_UNREACHABLE}goal ({gx:.2f}, {gy:.2f}) is in an obstacle, unknown "
                                          f"space or off the map, with no cell within "
                                          f"{self.s.snap_radius_m} m where the footprint fits")
        # the goal's yaw is pursued where its nearest heading fits on the goal's own cell
        nearest = None if gyaw is None else self._yaws[int(np.argmin(
            np.abs(np.remainder(self._yaws - gyaw + math.pi, 2 * math.pi) - math.pi)))]
        try:
            for i, goal in enumerate(goals):
                self.goal_yaw = gyaw if nearest is not None and goal[2] == nearest \
                    and m.cell(goal[0], goal[1]) == goal_cell else None
                try:
                    path = self._lattice(start, goal)
                    break
                except PlanningError:
                    if i == len(goals) - 1 or goals[i + 1] == goal:
                        raise
        except PlanningError as exc:
            # The robot follows a lattice line only to within a centimetre or so; its own cell
            # may lie just off that line, where the lattice finds no way on (no room to turn
            # there). While the plan it follows is still clear, keep to it: the next replan
            # starts from a lattice pose of it again.
            if len(self.path_poses) and self._poses_clear(self.path_poses).all():
                return True
            # Parallel to a wall with no room to turn anywhere along it, the lattice has no
            # way off the robot's line: an escape arc may have (planning.lattice.escape_arcs).
            for arc in escape_arcs(m.occupancy, m.resolution, m.origin, self.robot, pose,
                                   self.lattice, self.body):
                if not any(self._reaches(arc.end, goal) for goal in dict.fromkeys(goals)):
                    continue
                self._clear_path()
                self.arc = arc
                return True
            return self._finish("failed", f"{GOAL_UNREACHABLE}{exc}")
        moving = np.flatnonzero(~path.turned[1:]) + 1           # poses reached by driving
        backward = np.flatnonzero(path.reversed)
        if moving.size and path.reversed[moving[0]]:
            if anchor is not None:            # a manoeuvre starts where the robot is
                return self._plan(pose, now_s, anchored=False)
            return self._manoeuvre(path, int(moving[0]))
        # forward to the end, or to the cusp where it starts backing (turns there included)
        last = len(path.poses) - 1
        if backward.size:
            last = int(moving[moving < backward[0]][-1])
        self._cusp = last < len(path.poses) - 1
        self.plan = path
        robot_xy = np.array([[pose[0], pose[1]]])
        snapped = m.cell(pose[0], pose[1]) != m.cell(start[0], start[1])
        points = [robot_xy, path.poses[:1, :2]] if snapped else [robot_xy]
        ends = run_ends(path)
        ends = ends[ends <= last]
        if ends.size == 0 or ends[-1] != last:
            ends = np.append(ends, last)
        points.append(path.poses[ends, :2])
        self.path_xy = np.vstack(points)
        self.path_poses = path.poses[:last + 1]
        if self._cusp:
            self.goal_yaw = None
        return True

    def _manoeuvre(self, path: LatticePath, first: int) -> bool:
        """The plan starts backward at pose ``first`` (after turns in place): turn to that run's
        heading, back straight to its end (``backing``), then plan again."""
        run = first
        while run + 1 < len(path.poses) and path.reversed[run + 1]:
            run += 1
        self._clear_path()
        self.backing = np.array([path.poses[run, 0], path.poses[run, 1], path.poses[first, 2]])
        return True

    def _back(self, pose: tuple) -> tuple:
        """One period of the backward manoeuvre: drive straight on to its cusp (``approach``,
        when the follower stopped short of it), turn in place to its heading (the box's sweep
        checked, at the tracking block's turning rate), then back straight (heading kept), both at
        the lattice's reverse_speed_mps while the body stays clear, until level with its end;
        then plan again."""
        m = self.map
        x, y, yaw = (float(v) for v in pose[:3])
        bx, by, byaw = (float(v) for v in self.backing)
        inp = ControlInput(now_s=0.0, pose=pose, velocity=(0.0, 0.0), path=np.zeros((0, 2)),
                           goal_yaw=None, occupancy=m.occupancy, costmap=m.costmap,
                           resolution=m.resolution, origin=m.origin)
        if self.approach is not None:
            ahead = (self.approach[0] - x) * math.cos(yaw) + (self.approach[1] - y) * math.sin(yaw)
            if ahead > 0.01:
                return self._straight(inp, pose, ahead, +1)
            self.approach = None
        to_go = math.hypot(bx - x, by - y)
        # facing away from the run's end, so backing straight ends on it (the robot starts up
        # to half a cell off the lattice line; the next turn in place is planned at its end)
        want = math.atan2(y - by, x - bx) if to_go > 0.02 else byaw
        err = geometry.wrap_angle(want - yaw)
        if abs(err) > BACK_ALIGN_RAD and not self._reversing:
            if not self.body.turn_clear(inp, pose, err):
                self._finish("failed", f"trapped at ({x:.2f}, {y:.2f}): turning to back out "
                                       f"would hit an obstacle")
                return 0.0, 0.0
            return 0.0, self._turn.turn_rate(err)
        to_go = -((bx - x) * math.cos(yaw) + (by - y) * math.sin(yaw))
        if to_go <= 0.01:
            self.backing, self._need_plan, self._reversing = None, True, False
            return 0.0, 0.0
        self._reversing = True
        v, _ = self._straight(inp, pose, to_go, -1)
        # steered onto the run's end as a pure pursuit of it, seen from the rear (err is the
        # angle between the robot's back and the end): a run of a metre or more, an OMPL
        # plan's, would otherwise drift BACK_ALIGN_RAD x its length sideways
        d = math.hypot(bx - x, by - y)
        return v, (abs(v) * 2.0 * math.sin(err) / d if d > 0.05 else 0.0)

    def _escape(self, pose: tuple) -> tuple:
        """One period of an escape arc: (v, w) along it at reverse_speed_mps while the body keeps
        the follower's margin (or gets no nearer) over the next 0.1 m of it, until the robot
        faces the arc's end heading; then plan again. Else the goal fails: trapped."""
        arc, m = self.arc, self.map
        left = geometry.wrap_angle(arc.end[2] - float(pose[2]))
        if abs(left) <= BACK_ALIGN_RAD or left * arc.turn_rad < 0:
            self.arc, self._need_plan = None, True
            return 0.0, 0.0
        turn = math.copysign(min(abs(left), 0.1 / ESCAPE_RADIUS_M), left)
        ahead = replace(arc, turn_rad=turn, length_m=ESCAPE_RADIUS_M * abs(turn))
        inp = ControlInput(now_s=0.0, pose=pose, velocity=(0.0, 0.0), path=np.zeros((0, 2)),
                           goal_yaw=None, occupancy=m.occupancy, costmap=m.costmap,
                           resolution=m.resolution, origin=m.origin)
        if not self.body.stays_clear(inp, ahead.poses(pose, 0.5 * self.body.margin_m)):
            self._finish("failed", f"trapped at ({pose[0]:.2f}, {pose[1]:.2f}): the escape arc "
                                   f"would hit an obstacle")
            return 0.0, 0.0
        v = arc.direction * self.lattice.reverse_speed_mps
        return v, abs(v) * arc.turn_rad / arc.length_m

    def _straight(self, inp: ControlInput, pose: tuple, to_go: float, sign: int) -> tuple:
        """(v, 0) driving straight forward (sign +1) or back (-1) at reverse_speed_mps, at most
        ``to_go`` m, while the body keeps the follower's margin (or gets no nearer) over the
        next 0.1 m; else the goal fails: trapped."""
        x, y, yaw = (float(v) for v in pose[:3])
        margin = self.s.follower.collision_margin_m
        d = sign * np.arange(0.0, min(to_go, 0.1) + 1e-9, 0.5 * margin)
        poses = np.column_stack([x + d * math.cos(yaw), y + d * math.sin(yaw), np.full(len(d), yaw)])
        if not self.body.stays_clear(inp, poses):
            way = "backing" if sign < 0 else "driving on to where it backs"
            self._finish("failed", f"trapped at ({x:.2f}, {y:.2f}): {way} would hit an obstacle")
            return 0.0, 0.0
        speed = self.lattice.reverse_speed_mps
        return sign * min(speed, to_go / max(1.0 / self.s.controller_rate_hz, 1e-3)), 0.0

    def _lattice(self, start: tuple, goal: tuple) -> LatticePath:
        """The global plan start -> goal (the lattice's, or an OMPL planner's in the lattice's
        form), at the goal's yaw if it is pursued and reachable."""
        m = self.map
        if self.s.planner != "lattice":
            def plan(goal_yaw=None):
                path = plan_sampling(m.occupancy, m.resolution, m.origin, self.robot, start,
                                     (goal[0], goal[1], goal_yaw), self.s.planner[len("ompl_"):],
                                     self.s.sampling_budget_s, self.lattice)
                return as_lattice_path(path, m.resolution, m.origin)
        else:
            def plan(goal_yaw=None):
                return plan_lattice(m.occupancy, m.resolution, m.origin, self.robot, start,
                                    goal[:2], self.lattice, goal_yaw=goal_yaw)
        if self.goal_yaw is not None:
            try:
                return plan(self.goal_yaw)
            except PlanningError:
                self.goal_yaw = None       # not at that heading: at any
        return plan()

    def _reaches(self, start: tuple, goal: tuple) -> bool:
        try:
            self._lattice(start, goal)
        except PlanningError:
            return False
        return True

    def _clear_path(self) -> None:
        self.backing = self.approach = self.arc = None
        self._cusp = False
        self._reversing = False
        self.path_xy = np.zeros((0, 2))
        self.path_poses = np.zeros((0, 3))
        self.plan = None

    def _finish(self, status: str, reason: str) -> bool:
        self.status, self.reason = status, reason
        self._taken_at = None
        self._clear_path()
        return False


def loop_summary(times_s: np.ndarray, step_ms: np.ndarray) -> Optional[str]:
    """One line on a control loop from its steps while driving (sim time s of each, wall ms it
    took): the rate it held in sim time (one over the mean period between steps: a sim-time
    timer wakes on /clock's ticks, so a 0.05 s period comes as 0.04 and 0.06 s, and the median
    alone would read 16.7 Hz), the period's median and p95, and a step's wall time. None
    without two steps less than 1 s apart (the pauses between goals do not count)."""
    if len(times_s) < 2:
        return None
    period = np.diff(times_s)
    period = period[(period > 0) & (period < 1.0)]
    if not len(period):
        return None
    return (f"control loop over {len(times_s)} steps: {1.0 / np.mean(period):.1f} Hz in sim time (period median "
            f"{np.median(period):.3f} s, p95 {np.percentile(period, 95):.3f} s); step wall time median "
            f"{np.median(step_ms):.1f} ms, p95 {np.percentile(step_ms, 95):.1f} ms, max {np.max(step_ms):.1f} ms")
