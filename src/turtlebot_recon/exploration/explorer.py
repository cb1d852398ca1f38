"""The exploration loop, ROS-free: frontier goals for the navigator, under the behaviour supervisor.

``Explorer`` is driven at the supervisor's rate (``supervisor_rate_hz``, sim time) by two
calls per tick, each returning ``Outputs`` (goals to send, cancels, twists, markers, state,
the end) for the node to carry out in order:

- ``explore(ExploreInputs)``: the navigator's results for our goals (GoalBook success on
  arrival, failure on abort; retries, below), then, every ``cycle_period_s`` and at once when
  a goal ended, the explorer cycle: costmap from the latest map, the robot's cell,
  ``frontiers.detect`` (past the goals tried so far: ``GoalBook.tried``, and the cells the
  lidar looked at from where the robot has been and did not reveal: ``Looks``), a ``Context``, the
  strategy's choice (none: the supervisor's finish rule counts an empty cycle) and the
  GoalBook's bookkeeping (attempt on send; failure when an obstacle appears at the goal
  twice; failure + blacklist when the progress watchdog fires; drop when the goal's frontier
  was explored on the way or it was cut off). A new choice replaces the navigator's goal.
- ``supervise(SuperviseInputs)``: ``Supervisor.tick`` (spin, explore, recoveries, finish,
  return home); its command becomes a twist, a navigator goal, the explorer's goals, or the
  end. The node calls it with the time and pose read after the cycle, which takes wall time,
  i.e. sim time at rtf > 1 (seconds in a large map); the navigator's status it hands the
  supervisor is the one from before the cycle, so that a goal that just ended shows as ended
  for one tick even when the cycle sent the next one (the stuck watchdog's window then starts
  with the new goal, not at the robot's last progress on the old one).

An arrival at a frontier goal does not wait for that cycle: the strategy chooses again at
once among the last cycle's frontiers, less those whose goal is where the robot stands, and
that goal goes out in the same tick; the cycle runs at the next tick and may replace it
(``_carry_on``). A cycle takes wall time, seconds of sim time at the benchmark's rtf of ~10,
which the robot stood through at every arrival (160 s of the depot's 880 s to 99 %).

``start`` builds the supervisor (SPIN, then EXPLORE) once the node has the first map, the
pose and the navigator.

Mission ``tags`` (``tag_search``, exploration/tag_search.py): once no frontier goal is left,
the cycle asks the tag search for a view (an unconfirmed tag, else the wall the camera has
seen least per metre of path) and sends it with its heading; the supervisor's finish rule
counts a cycle without frontier and view as empty. ``ExploreInputs.camera_poses`` (each
camera frame's pose since the last tick) feed the camera's coverage map.

Goals go out before the robot would stop for them: a goal whose frontier is seen on the way
is dropped at the next cycle, and one within stopping distance (``_hand_off``) counts as
reached and the next goal goes out at once. A navigator failure whose reason begins
``GOAL_UNREACHABLE`` is the goal's: one line, no retry, and the goal book keeps it out while
the map near it is unchanged (``GoalBook.unreachable``). In mission ``tags`` a tag seen but not
confirmed is looked at before the next frontier (``_priority_tag``).

An abort of a goal that the explorer's own field still reaches says, in practice, that the
robot is wedged (the navigator reports "blocked" wherever it stands), not that the goal is
bad: the goal is re-sent (up to ``abort_retries`` times in a row) instead of failed, so the
navigator stays active and the supervisor's stuck watchdog runs its recovery ladder, whose
last rung blacklists the goal. Without this, a wedged robot fails and blacklists every
frontier in turn and the run ends early. The home goal of RETURN_HOME is retried the same
way (the supervisor ends the return at the first navigator failure).

Navigator results come as the supervisor's status words (``ros/explore_msgs.nav_status`` of
the goal's terminal actionlib state): "succeeded", "failed" (aborted, rejected) or "idle"
(preempted, recalled, lost). Poses are (x, y, yaw) in the map frame (m, rad); times are sim
seconds. Log lines go to ``log(level, msg, *args)`` (Python logging levels; the node routes
them to rospy); the throttled ones are throttled on sim time, as rospy's are.
"""
from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..behavior import Inputs, Supervisor, SupervisorSettings
from ..behavior.supervisor import NAV_STATUSES
from ..config import positive, require
from ..control.footprint import BodyCheck
from ..geometry import inside, xy_to_cell
from ..planning import (INSCRIBED, LatticeSettings, escape_arcs, footprint_costmap,
                        lattice_cost_to_come)
from ..planning.navigation import GOAL_UNREACHABLE
from ..robot import RobotSpec
from .context import Context, Motion
from ..mapping.map_io import FREE_THRESH
from .frontiers import FrontierSettings, detect, find_frontier_cells
from .goals import GoalBook, stands_for
from .tag_search import TagSearch, View
from .viewpoints import Looks

Log = Callable[..., None]                          # log(level, msg, *args), logging.Logger.log's
DEBUG, INFO = logging.DEBUG, logging.INFO          # INFO: the start, the tag search, the end;
                                                   # DEBUG: each event (off the console)
BODY_CHECK_STEP_S = 0.05                           # a recovery twist's poses checked this often
MISSIONS = ("map", "tags", "auto")
SEARCH_AFTER_CYCLES = 2      # mission tags: the tag search starts after this many cycles in a row
                             # without a frontier goal (one can be a map between two scans)


@dataclass(frozen=True)
class ExplorerSettings:
    """The node's own keys of config/explorer.yaml."""
    robot: str = ""                  # footprint -> costmap; no default: the launch
                                         # files set it (their top-level files hold its one default)
    map_frame: str = "odom"              # odom until SLAM provides map -> odom
    base_frame: str = "base_footprint"
    cycle_period_s: float = 1.0          # explorer cycle (sim time); also right after a goal ends
    supervisor_rate_hz: float = 10.0     # supervisor ticks (sim time)
    seed: int = 0                        # the strategies' RNG (sampled)
    same_goal_m: float = 0.3             # a choice this close to the goal being pursued keeps it
    field_turns_within_m: float = 5.0    # the field counts turns in place up to this cost (m);
                                         # beyond, not where the robot can turn (reach unchanged)
    use_visits: bool = True              # give the strategy /visit_map's counts (recon's term)
    abort_retries: int = 30              # an aborted goal that is still reachable is re-sent this
                                         # often in a row before it counts as a failure
    scan_margin_m: float = 0.03          # scan clearance: the body's half width plus this
    scan_max_age_s: float = 1.0          # older scans are not used for recoveries
    twist_check_s: float = 0.5           # a supervisor twist (recovery) is checked this far ahead
                                         # with the body against the map; unsafe: not driven
    status_period_wall_s: float = 5.0    # terminal progress line (wall time: readable at any rtf)
    shutdown_when_done: bool = False     # end the node once the supervisor says DONE
    mission: str = "auto"                # map: lidar coverage | tags: then the tag search |
                                         # auto: tags for a robot with a camera

    def validate(self, src: str) -> None:
        positive(src, self, "cycle_period_s", "supervisor_rate_hz", "same_goal_m", "scan_max_age_s",
                 "status_period_wall_s", "twist_check_s")
        require(self.field_turns_within_m >= 0, src, "field_turns_within_m", "must be >= 0 (.inf: everywhere)")
        require(isinstance(self.abort_retries, int) and self.abort_retries >= 0, src, "abort_retries",
                "must be an integer >= 0")
        require(self.scan_margin_m >= 0, src, "scan_margin_m", "must be >= 0")
        require(self.mission in MISSIONS, src, "mission", f"must be one of {MISSIONS}, got {self.mission!r}")


def resolve_mission(mission: str, robot: RobotSpec) -> str:
    """``auto``: ``tags`` for a robot with a camera, ``map`` without one."""
    if mission == "auto":
        return "tags" if robot.camera is not None else "map"
    return mission


# ------------------------------------------------------------------------------ inputs

@dataclass(frozen=True)
class Grid:
    """A map: int8 (rows, cols) (occupancy -1..100, or visit counts), row 0 at the smallest y."""
    data: np.ndarray
    resolution: float                     # m per cell
    origin: Tuple[float, float]           # (x, y) m of cell (0, 0)'s corner, map frame


@dataclass(frozen=True)
class NavEvent:
    """The navigator ended goal ``seq`` (as numbered by ``SendGoal``)."""
    seq: int
    status: str                           # "succeeded", "failed" or "idle" (a NAV_STATUSES word)
    text: str = ""                        # the navigator's reason

    def __post_init__(self):
        if self.status not in NAV_STATUSES:
            raise ValueError(f"status must be one of {NAV_STATUSES}, got {self.status!r}")


@dataclass(frozen=True)
class ExploreInputs:
    now_s: float
    pose: tuple                           # (x, y, yaw)
    grid: Optional[Grid]                  # the latest map; None: none usable (a cycle is skipped)
    visits: Optional[Grid] = None         # the latest visit counts (used with use_visits)
    nav_events: Tuple[NavEvent, ...] = () # navigator results since the last tick, in order
    camera_poses: Tuple[tuple, ...] = ()  # camera frames since the last tick: (x, y, yaw) of the
                                          # camera in the map frame (mission tags)
    unconfirmed: Tuple = ()               # markers seen, not confirmed (perception.tracker.Glimpse)


@dataclass(frozen=True)
class SuperviseInputs:
    now_s: float
    pose: tuple                           # (x, y, yaw)
    bumper: Optional[int] = None          # pressed since the last tick: 0 left, 1 centre, 2 right
    scan_clearance: Optional[Callable[[float], float]] = None   # robot-frame bearing -> free m


# ----------------------------------------------------------------------------- outputs

@dataclass(frozen=True)
class SendGoal:
    """Make the navigator pursue (x, y[, yaw]) (yaw None: any final heading); it replaces the
    goal pursued so far. Results for it come back as ``NavEvent(seq, ...)``."""
    kind: str                             # "explore" (a frontier goal) or "supervisor" (nudge, home)
    xy: Tuple[float, float]
    yaw: Optional[float]
    seq: int
    retries: int = 0                      # re-sends after aborts, in a row
    heading: Optional[float] = None       # a new frontier goal: the direction robot -> goal (rad)
                                          # to show on explore/goal; None otherwise


@dataclass(frozen=True)
class CancelGoal:
    """Forget goal ``seq``; cancel it at the navigator if ``active`` (it still pursues it)."""
    seq: int
    active: bool


@dataclass(frozen=True)
class Velocity:
    """Publish this twist (the navigator does not drive)."""
    linear_mps: float = 0.0
    angular_radps: float = 0.0


Action = Union[SendGoal, CancelGoal, Velocity]


@dataclass(frozen=True)
class FrontierView:
    """One cycle's frontiers, the goal pursued and the strategy's tour (explore/frontiers)."""
    frontiers: list
    resolution: float
    origin: Tuple[float, float]
    goal: Optional[Tuple[float, float]]
    tour: Sequence
    robot_xy: Tuple[float, float]
    now_s: float


@dataclass
class Outputs:
    actions: List[Action] = field(default_factory=list)   # carry out in this order
    cycled: bool = False                  # an explorer cycle ran (it took wall time)
    frontiers: Optional[FrontierView] = None
    state: Optional[str] = None           # the supervisor's new state, when it changed
    done: Optional[str] = None            # exploration ended this tick, with this reason
    phase: Optional[str] = None           # "map", then "tags" when the tag search begins
    camera_coverage: Optional[Grid] = None  # the camera's coverage map (a cycle of mission tags)


@dataclass
class SentGoal:
    """A goal the navigator pursues for us."""
    kind: str
    xy: Tuple[float, float]
    yaw: Optional[float]
    seq: int
    retries: int = 0


# -------------------------------------------------------------------------------- loop

class Explorer:
    """The exploration loop (module docstring). ``nav`` is the navigator's status word for our
    goal ``sent``; ``cycles`` counts explorer cycles; ``done`` is final."""

    def __init__(self, settings: ExplorerSettings, frontier_settings: FrontierSettings, strategy,
                 book: GoalBook, supervisor_settings: SupervisorSettings, robot: RobotSpec,
                 log: Optional[Log] = None, lattice: Optional[LatticeSettings] = None,
                 tag_search: Optional[TagSearch] = None):
        self.s, self.fs, self.strategy, self.book = settings, frontier_settings, strategy, book
        self.sup_settings = supervisor_settings
        self.supervisor: Optional[Supervisor] = None        # built by start()
        # the navigator's lattice (config/lattice.yaml): goals count as reachable where it
        # reaches them, behind gaps narrower than the turning disc too
        self.robot, self.lattice = robot, (lattice or LatticeSettings()).with_robot(robot)
        self.body = BodyCheck(robot)
        half_width = robot.radius_m if robot.is_round else 0.5 * robot.footprint_width_m
        self.scan_half_width_m = half_width + settings.scan_margin_m   # for ScanClearance
        self.rng = np.random.default_rng(settings.seed)
        fs = frontier_settings
        self.looks = Looks(fs.look_range_m, fs.look_spacing_m, fs.looks_to_spend, fs.gain_beams,
                           FREE_THRESH)
        self.ctx: Optional[Context] = None                  # the last cycle's view
        self.frontiers, self.choice = [], None
        self.cycles, self.goal_available = 0, True          # no detection yet: nothing says "done"
        self.next_cycle_s, self.cycle_now = -math.inf, False
        self.sent: Optional[SentGoal] = None
        self.nav = "idle"                                   # idle | active | succeeded | failed
        self.seq = 0
        self.mode: Optional[str] = None                     # the last supervisor command's kind
        self.state: Optional[str] = None
        self.done = False
        self._nav_before_cycle = "idle"
        self._arrived: Optional[Tuple[float, float]] = None  # a frontier goal reached this tick
        self._out = Outputs()
        self._log = log or logging.getLogger(__name__).log
        self._throttled: Dict[str, float] = {}
        self.mission = resolve_mission(settings.mission, robot)
        if self.mission == "tags" and tag_search is None:
            raise ValueError("mission 'tags' needs a tag search (a robot with a camera)")
        self.search = tag_search if self.mission == "tags" else None
        self.phase = "map"
        self.view: Optional[View] = None                    # the tag search's view pursued
        self._no_frontier = 0                               # cycles in a row without a frontier goal
        self.pinned = False                                 # the last cycle's field: wedged
        self.speed_mps = 0.0                                # from the last two ticks' poses
        self._last_pose: Optional[Tuple[float, tuple]] = None   # (t, pose) of the last tick

    @property
    def started(self) -> bool:
        return self.supervisor is not None

    def start(self, now_s: float, pose: tuple) -> None:
        """Start the supervisor (SPIN first) at ``pose``, its home."""
        self.supervisor = Supervisor(self.sup_settings, pose)
        self._log(INFO, "explorer: started at t=%.1f s sim from (%.2f, %.2f, %.2f) in %s, mission %s",
                  now_s, *pose, self.s.map_frame, self.mission)
        self._out.phase = self.phase

    # ------------------------------------------------------------------------ ticking
    def explore(self, inp: ExploreInputs) -> Outputs:
        """The navigator's results, then the explorer cycle when one is due (``cycled``)."""
        if self.supervisor is None:
            raise RuntimeError("Explorer.explore before start()")
        out = self._out = Outputs()
        if self.done:
            return out                                    # DONE is final: nothing left to do
        self._measure_speed(inp.now_s, inp.pose)
        self._nav_results(inp.now_s, inp.pose, inp.nav_events)
        self._hand_off(inp.now_s, inp.pose)
        self._nav_before_cycle = self.nav
        if self.search is not None and inp.grid is not None:
            g = inp.grid
            for camera_pose in inp.camera_poses:
                self.search.saw(g.data, g.resolution, g.origin, camera_pose)
        arrived, self._arrived = self._arrived, None
        if arrived is not None and self._carry_on(arrived, inp.pose):
            return out                                    # the cycle follows at the next tick
        if self.cycle_now or inp.now_s >= self.next_cycle_s:
            self.cycle_now, self.next_cycle_s = False, inp.now_s + self.s.cycle_period_s
            out.cycled = True
            if inp.grid is not None:
                self._cycle(inp.now_s, inp.pose, inp.grid, inp.visits, inp.unconfirmed)
        return out

    def supervise(self, inp: SuperviseInputs) -> Outputs:
        """One supervisor tick and its command (after ``explore`` of the same tick)."""
        if self.supervisor is None:
            raise RuntimeError("Explorer.supervise before start()")
        out = self._out = Outputs()
        if self.done:
            return out
        active = self.book.active
        cmd = self.supervisor.tick(Inputs(
            now_s=inp.now_s, pose=inp.pose, nav=self._nav_before_cycle,
            goal_available=self.goal_available, bumper=inp.bumper, free_space=self.free_space,
            scan_clearance=inp.scan_clearance, explore_goal=active.goal if active else None,
            explorer_cycle=self.cycles, pinned=self.pinned))
        self._apply(cmd, inp.now_s, inp.pose)
        if self.supervisor.state != self.state:
            self.state = out.state = self.supervisor.state
            self._log(DEBUG, "explorer: state %s (%s)", self.state, cmd.reason)
        return out

    def free_space(self, x: float, y: float) -> bool:
        """(x, y) a place the robot fits and the navigator reaches, as of the last cycle (the
        lattice's field finite there): the supervisor's nudges and the way home."""
        ctx = self.ctx
        if ctx is None:
            return False
        r, c = ctx.xy_to_cell((x, y))
        return (bool(inside(r, c, ctx.costmap.shape)) and ctx.costmap[r, c] < INSCRIBED
                and bool(np.isfinite(ctx.cost_to_come[r, c])))

    # ------------------------------------------------------------- navigator results
    def _nav_results(self, now: float, pose: tuple, events: Sequence[NavEvent]) -> None:
        """The navigator's results for our goals: GoalBook success / failure, retries."""
        for event in events:
            sent = self.sent
            if sent is None or event.seq != sent.seq:
                continue                                   # a goal we already replaced
            self.nav = event.status
            failed = event.status == "failed"
            if failed and event.text.startswith(GOAL_UNREACHABLE) and sent.kind == "explore" \
                    and self.ctx is not None:
                # the goal, not the robot: no retry, and not again while the map near it stays
                self.book.unreachable(sent.xy, self.ctx, pose[:2])
                self._log(INFO, "explorer: goal (%.2f, %.2f) dropped: the navigator %s; not sent again "
                          "while the map within %.1f m of it is unchanged", *sent.xy,
                          event.text[len(GOAL_UNREACHABLE):], self.book.settings.unreachable_window_m)
                self.view = None if self.view is not None and self.view.xy == sent.xy else self.view
                self.cycle_now = True
                continue
            if failed and self._retry(sent, now, pose, event.text):
                continue
            if sent.kind != "explore" or self.mode != "explore":
                continue
            if event.status == "succeeded" and self.view is not None and sent.xy == self.view.xy:
                self.search.reached(self.view)
                self._log(DEBUG, "explorer: tag search: view (%.2f, %.2f) reached", *sent.xy)
                self.view = None
                self.cycle_now = True
                continue
            if event.status == "succeeded":
                expired = self.book.succeeded(sent.xy, now)
                self._arrived = sent.xy
                self._log(DEBUG, "explorer: goal (%.2f, %.2f) reached%s", *sent.xy,
                          f"; {expired} blacklist entries nearby expired" if expired else "")
                self.cycle_now = True
            elif failed:
                blacklisted = self.book.failed(sent.xy, now)
                self._log(DEBUG, "explorer: goal (%.2f, %.2f) failed (%s)%s", *sent.xy,
                          event.text or "no reason given", "; blacklisted" if blacklisted else "")
                self.cycle_now = True

    def _retry(self, sent: SentGoal, now: float, pose: tuple, text: str) -> bool:
        """Re-send an aborted frontier goal (in EXPLORE) or home goal (in RETURN_HOME) while
        it is still reachable (explore: the strategies' test; home: clear of the inscribed
        band) and fewer than abort_retries re-sends in a row were made."""
        if sent.retries >= self.s.abort_retries:
            return False
        if sent.kind == "explore":
            ctx = self.ctx
            ok = self.mode == "explore" and ctx is not None and ctx.goal_ok(ctx.xy_to_cell(sent.xy))
        else:
            ok = self.supervisor.state == "RETURN_HOME" and self.free_space(*sent.xy)
        if not ok:
            return False
        self._log_throttled(5.0, now, DEBUG, "explorer: the navigator gave up on (%.2f, %.2f) (%s), "
                            "which is still reachable: sent again (%d in a row)", *sent.xy, text,
                            sent.retries + 1)
        self._send(sent.kind, sent.xy, sent.yaw, pose, retries=sent.retries + 1)
        return True

    def _carry_on(self, arrived: tuple, pose: tuple) -> bool:
        """Right after an arrival at ``arrived``, the strategy's choice among the last cycle's
        frontiers less those whose goal is there, sent at once; True if one was. The cycle
        follows at the next tick and may replace it: it takes wall time, i.e. seconds of sim
        time at rtf > 1, which the robot would otherwise stand through (and its map does not
        yet show what the robot sees from the goal: that arrival counts from the cycles after
        it, ``GoalBook.tried``)."""
        ctx = self.ctx
        if ctx is None or self.mode != "explore":
            return False
        rest = [f for f in self.frontiers if math.dist(f.goal, arrived) > self.s.same_goal_m]
        choice = self._choose(rest, ctx)
        if choice is None or math.dist(choice.goal, arrived) <= self.s.same_goal_m:
            return False                                  # (a strategy may place its own goals)
        self.choice = choice
        self._pursue(ctx, pose)
        return True

    def _choose(self, frontiers: list, ctx: Context):
        """The strategy's choice, less goals the navigator found unreachable on the map as it is
        (``GoalBook.is_unreachable``; a strategy that places its own goals may pick one again)."""
        frontiers = list(frontiers)
        while True:
            choice = self.strategy.choose(frontiers, ctx, self.book)
            if choice is None or not self.book.is_unreachable(choice.goal, ctx):
                return choice
            rest = [f for f in frontiers if f.id != choice.id]
            if len(rest) == len(frontiers):
                return None                               # a goal of the strategy's own, again
            frontiers = rest

    def _measure_speed(self, now: float, pose: tuple) -> None:
        """The robot's speed from this tick's pose and the last one's (``Motion.speed_mps``), at
        most its top speed (a faster step is the pose jumping: a localisation correction)."""
        last, self._last_pose = self._last_pose, (now, tuple(pose))
        if last is not None and 0.0 < now - last[0] <= 1.0:
            self.speed_mps = min(math.dist(pose[:2], last[1][:2]) / (now - last[0]),
                                 self.robot.max_linear_mps)
        elif last is not None:
            self.speed_mps = 0.0                          # a clock jump: unknown, say standing

    def _hand_off(self, now: float, pose: tuple) -> None:
        """Within stopping distance of the frontier goal, plus the tick it takes the next goal to
        reach the navigator, the goal counts as reached: the next one goes out now (``_carry_on``)
        and the controller need not brake for the old one."""
        active, sent = self.book.active, self.sent
        if (active is None or sent is None or sent.kind != "explore" or self.nav != "active"
                or self.mode != "explore" or sent.xy != active.goal or self.view is not None):
            return
        motion = Motion.of(self.robot, self.lattice, self.speed_mps)
        reach_m = motion.stopping_distance_m + self.speed_mps / self.s.supervisor_rate_hz
        if self.speed_mps <= 0.0 or math.dist(pose[:2], sent.xy) > reach_m:
            return                                        # standing: the navigator's arrival ends it
        self.book.succeeded(sent.xy, now)
        self._arrived = sent.xy
        self.cycle_now = True
        self._log(DEBUG, "explorer: goal (%.2f, %.2f) within stopping distance (%.2f m at %.2f m/s): "
                  "the next goal goes out now", *sent.xy, reach_m, self.speed_mps)

    # ------------------------------------------------------------------ explorer cycle
    def _cycle(self, now: float, pose: tuple, grid: Grid, visits: Optional[Grid],
               unconfirmed: Sequence = ()) -> None:
        occ, res, origin = grid.data, grid.resolution, grid.origin
        # where the navigator can take the robot: its lattice, from the robot's pose (a cell
        # where some heading fits may still be out of reach: a slot the box cannot turn into)
        costmap = footprint_costmap(occ, res, self.robot, self.lattice)
        cell = xy_to_cell(pose[:2], res, origin)
        escapes = escape_arcs(occ, res, origin, self.robot, pose, self.lattice, self.body)
        field = lattice_cost_to_come(occ, res, origin, self.robot, pose, self.lattice,
                                     self.fs.snap_radius_m, escapes, self.s.field_turns_within_m)
        self.looks.look(occ, find_frontier_cells(occ, FREE_THRESH, self.fs.min_opening_cells), res, origin,
                        pose[:2])
        frontiers = detect(occ, res, origin, costmap, cell, self.fs, field, self.book.tried(now),
                           self.looks.spent(occ.shape, res, origin))
        ctx = Context(robot_xy=pose[:2], robot_yaw=pose[2], now_s=now, resolution=res, origin=origin,
                      occupancy=occ, costmap=costmap, cost_to_come=field,
                      visits=self._visits(occ.shape, origin, visits), rng=self.rng, max_cost=INSCRIBED - 1,
                      motion=Motion.of(self.robot, self.lattice, self.speed_mps),
                      priority_goals=tuple((float(t.x), float(t.y)) for t in unconfirmed))
        # a goal is valid on any cell the robot can pass (it turns in place safely there: the
        # inscribed radius is the circumscribed one); frontiers.max_cost only makes detect
        # prefer goals further from walls where there is room
        self.ctx, self.frontiers = ctx, frontiers
        field_cells = int(np.isfinite(field).sum())
        self.pinned = self._pinned(field_cells, res)
        if self.pinned:
            self._log_throttled(10.0, now, INFO, "explorer: the robot at (%.2f, %.2f) reaches no cell off its "
                                "footprint (%d cells): recovering, not finishing", pose[0], pose[1], field_cells)
        self._check_active_goal(ctx, frontiers, now)
        self.choice = self._choose(frontiers, ctx)
        self.cycles += 1
        self._no_frontier = 0 if self.choice is not None else self._no_frontier + 1
        view = None
        searching = self.search is not None and self.supervisor is not None and self.supervisor.state != "SPIN"
        if searching and self._no_frontier >= SEARCH_AFTER_CYCLES:
            view = self._tag_view(ctx, unconfirmed, now)
        elif searching and unconfirmed:
            view = self._priority_tag(ctx, unconfirmed)
        self.goal_available = self.choice is not None or view is not None  # the supervisor's finish rule
        if not frontiers:
            self._log_throttled(10.0, now, DEBUG, "explorer: no frontier in the map (%d known cells)",
                                int((occ >= 0).sum()))
        elif self.choice is None:
            self._log_throttled(10.0, now, DEBUG, "explorer: %d frontiers, %d seen from a reachable "
                                "viewpoint, none usable (blacklisted or too close to obstacles)",
                                len(frontiers), sum(f.reachable for f in frontiers))
        if self.mode == "explore":
            if view is not None:
                self._look(view, pose)
            else:
                self.view = None
                self._pursue(ctx, pose)
        active = self.book.active
        self._out.frontiers = FrontierView(frontiers, res, origin, active.goal if active else None,
                                           getattr(self.strategy, "last_tour", []), pose[:2], now)

    def _pinned(self, cells: int, resolution: float) -> bool:
        """The field from the robot's pose (finite in ``cells`` cells) reaches its own cell and no
        more cells than its footprint covers: it is wedged (a box beside a pillar, every lattice
        move and escape arc blocked), and no goal anywhere tells what is left to see (the supervisor recovers
        instead of finishing). An empty field is not that: the lattice could not place the
        robot on this map at all (the first map after the spin did that once)."""
        return 0 < cells and cells * resolution ** 2 <= math.pi * self.robot.radius_m ** 2

    def _tag_view(self, ctx: Context, unconfirmed: Sequence, now: float) -> Optional[View]:
        """The tag search's next view (mission tags, no frontier goal left); its coverage map
        goes out with this cycle."""
        if self.phase != "tags":
            self.phase = self._out.phase = "tags"
            self._log(INFO, "explorer: no frontier goal left at t=%.1f s: tag search begins", now)
        pursued = self.view if self.nav == "active" else None
        view = self.search.choose(ctx, unconfirmed, self.book.is_blacklisted, pursued)
        search = self.search
        if search.coverage.seen is not None and search.coverage.seen.shape == ctx.occupancy.shape:
            self._out.camera_coverage = Grid(search.coverage.to_occupancy_grid_data(search.region),
                                             ctx.resolution, ctx.origin)
        if view is None:
            self._log_throttled(10.0, now, DEBUG, "explorer: tag search: nothing left to look at (%.1f %% "
                                "of the walls seen, %d unconfirmed tags)", 100.0 * (search.seen_share or 0.0),
                                len(unconfirmed))
        return view

    def _priority_tag(self, ctx: Context, unconfirmed: Sequence) -> Optional[View]:
        """Seed 000's priority goal, for every strategy: a tag seen but not confirmed is looked
        at (from ``tag_view_m`` in front of it) before the next frontier, while the robot is
        near it, instead of after the last frontier (a trip back across the building)."""
        pursued = self.view if self.nav == "active" and self.view is not None else None
        if pursued is not None and pursued.kind == "tag" \
                and any((t.family, t.id) == pursued.targets for t in unconfirmed):
            return pursued
        return self.search.tag_view(ctx, unconfirmed, self.book.is_blacklisted)

    def _look(self, view: View, pose: tuple) -> None:
        """Drive to a tag search view unless it is the one pursued."""
        sent, old = self.sent, self.view
        if (old is not None and sent is not None and self.nav == "active" and sent.xy == old.xy
                and math.dist(view.xy, old.xy) <= self.s.same_goal_m):
            return
        self.book.active = None
        self.view = view
        self._log(DEBUG, "explorer: tag search: view (%.2f, %.2f) facing %.0f deg: %s (walls seen %.1f %%)",
                  *view.xy, math.degrees(view.yaw), view.label, 100.0 * (self.search.seen_share or 0.0))
        self._send("explore", view.xy, view.yaw, pose)

    def _visits(self, shape: tuple, origin: tuple, v: Optional[Grid]) -> Optional[np.ndarray]:
        if not self.s.use_visits or v is None:
            return None
        if v.data.shape != shape or not np.allclose(v.origin, origin):
            return None                                    # the grid grew between the two
        return v.data.astype(np.int32)

    def _check_active_goal(self, ctx: Context, frontiers: list, now: float) -> None:
        """Drop the goal being pursued when its frontier was explored, an obstacle appeared at
        it or it was cut off; fail and blacklist it when the distance to it has not shrunk for
        progress_timeout_s."""
        active = self.book.active
        if active is None:
            return
        # "blocked" as the navigator sees it (inscribed or worse: the context's max_cost), not
        # frontiers.max_cost, which only steers where goals are placed. The strategy then picks
        # again (seed 000's goal reset); the second time on one cell is a failure there
        # (GoalBook.obstructed: a wall face read free from afar would make the robot shuttle).
        reason = self.book.reevaluate_reason(active, frontiers, ctx)
        if reason is not None:
            blacklisted = reason == "blocked" and self.book.obstructed(active.goal, now, ctx.resolution)
            self._log(DEBUG, "explorer: goal (%.2f, %.2f) dropped: %s%s", *active.goal, reason,
                      "; blacklisted" if blacklisted else "")
            self.book.active = None
            return
        if self.mode != "explore" or self.nav != "active":
            return
        r, c = ctx.xy_to_cell(active.goal)
        if self.book.stalled(float(ctx.cost_to_come[r, c]), now):
            self.book.failed(active.goal, now)
            if not self.book.is_blacklisted(active.goal):
                self.book.blacklist(active.goal, now)
            self._log(DEBUG, "explorer: no progress toward (%.2f, %.2f) for %.0f s: blacklisted",
                      *active.goal, self.book.settings.progress_timeout_s)

    def _pursue(self, ctx: Context, pose: tuple) -> None:
        """Send the choice to the navigator (it replaces the goal) unless it is the goal being
        pursued; nothing to choose cancels our goal."""
        choice, active = self.choice, self.book.active
        if choice is None:
            self._cancel()
            self.book.active = None
            return
        sent = self.sent
        driving = sent is not None and sent.kind == "explore" and self.nav == "active"
        if active is not None and math.dist(choice.goal, active.goal) <= self.s.same_goal_m:
            if not (driving and sent.xy == active.goal):   # e.g. back from a recovery
                self._send("explore", active.goal, None, pose)
            return
        if active is not None:
            self._log(DEBUG, "explorer: goal (%.2f, %.2f) replaced by (%.2f, %.2f)", *active.goal,
                      *choice.goal)
        self.book.start(choice, ctx)
        if driving and stands_for(sent.xy, choice.goal, self.s.same_goal_m, ctx):
            self.book.active = dataclasses.replace(self.book.active, goal=sent.xy)  # already on its way
            return
        self._send("explore", self.book.active.goal, None, pose)

    # ------------------------------------------------------------------------ output
    def _apply(self, cmd, now: float, pose: tuple) -> None:
        """Carry out one supervisor command."""
        out = self._out
        if cmd.blacklist is not None:
            self.book.blacklist(cmd.blacklist, now)
            active, radius_m = self.book.active, self.book.settings.blacklist_radius_m
            if active is not None and math.dist(active.goal, cmd.blacklist) <= radius_m:
                self.book.active = None
            self._log(DEBUG, "explorer: supervisor blacklisted (%.2f, %.2f)", *cmd.blacklist)
            self.cycle_now = True
        if self.mode == "twist" and cmd.kind != "twist":
            # a recovery's last twist ends here: the base would drive on it until its command
            # timeout (0.5 s, blind) while the navigator plans the next goal
            out.actions.append(Velocity())
        if cmd.kind == "twist":
            self._cancel()
            out.actions.append(self._checked_twist(cmd.linear_mps, cmd.angular_radps, pose, now))
        elif cmd.kind == "goal":
            g, sent = cmd.goal, self.sent
            same = (sent is not None and sent.kind == "supervisor" and math.dist(sent.xy, g[:2]) <= 1e-3
                    and sent.yaw == g[2])
            if not same:
                self._send("supervisor", (g[0], g[1]), g[2], pose)
        elif cmd.kind == "explore":
            if self.mode != "explore":                    # back from SPIN or a recovery:
                if self.sent is not None and self.sent.kind == "supervisor":
                    self._cancel()                        # drop the nudge, and
                self.cycle_now = True                     # (re)send the frontier goal next tick
        elif cmd.kind in ("cancel", "stop"):
            self._cancel()
            if cmd.kind == "stop":
                out.actions.append(Velocity())
        elif cmd.kind == "done" and not self.done:
            self.done = True
            self._cancel()
            out.actions.append(Velocity())
            out.done = cmd.reason
            self._log(INFO, "explorer: DONE (%s) at t=%.1f s sim; %d goals blacklisted", cmd.reason, now,
                      len(self.book.entries()))
        self.mode = cmd.kind

    def _checked_twist(self, v: float, w: float, pose: tuple, now: float) -> Velocity:
        """The supervisor's twist if the body, driven by it for ``twist_check_s`` from ``pose``,
        keeps the follower's margin off every obstacle of the last map or at least gets no
        nearer to them (backing off a wall it touches); else its turn alone if that is safe,
        else a stop. The recoveries read the scan, which sees neither the box's corners nor
        what the lidar's plane misses; the map holds both."""
        ctx = self.ctx
        if ctx is None or (v == 0.0 and w == 0.0):
            return Velocity(v, w)
        turn_only = [(0.0, w)] if v != 0.0 and w != 0.0 else []
        for lin, ang in [(v, w)] + turn_only:
            if self._body_safe(ctx, pose, lin, ang):
                if (lin, ang) != (v, w):
                    self._log_throttled(5.0, now, DEBUG, "explorer: recovery twist (%.2f m/s, %.2f "
                                        "rad/s) would bring the body onto an obstacle: turning only", v, w)
                return Velocity(lin, ang)
        self._log_throttled(5.0, now, DEBUG, "explorer: recovery twist (%.2f m/s, %.2f rad/s) would "
                            "bring the body onto an obstacle: stopped", v, w)
        return Velocity()

    def _body_safe(self, ctx: Context, pose: tuple, v: float, w: float) -> bool:
        """Whether driving (v, w) for ``twist_check_s`` keeps the body clear (``_checked_twist``)."""
        steps = np.arange(0.0, self.s.twist_check_s + 1e-9, BODY_CHECK_STEP_S)
        yaw = pose[2] + w * steps
        if abs(w) > 1e-9:
            x = pose[0] + v / w * (np.sin(yaw) - math.sin(pose[2]))
            y = pose[1] - v / w * (np.cos(yaw) - math.cos(pose[2]))
        else:
            x, y = pose[0] + v * steps * math.cos(pose[2]), pose[1] + v * steps * math.sin(pose[2])
        return self.body.stays_clear(ctx, np.column_stack([x, y, yaw]))

    def _send(self, kind: str, xy: tuple, yaw: Optional[float], pose: tuple, retries: int = 0) -> None:
        """Make the navigator pursue (x, y[, yaw]) (yaw None: any final heading)."""
        self.seq += 1
        self.sent = SentGoal(kind, (float(xy[0]), float(xy[1])), yaw, self.seq, retries)
        self.nav = "active"
        heading = None
        if kind == "explore" and retries == 0:
            heading = math.atan2(xy[1] - pose[1], xy[0] - pose[0])
            self._log(DEBUG, "explorer: goal (%.2f, %.2f), %d frontiers", xy[0], xy[1], len(self.frontiers))
        self._out.actions.append(SendGoal(kind, self.sent.xy, yaw, self.seq, retries, heading))

    def _cancel(self) -> None:
        """Cancel our goal at the navigator, if it still pursues one."""
        if self.sent is not None:
            self._out.actions.append(CancelGoal(self.sent.seq, active=self.nav == "active"))
            self.sent, self.nav = None, "idle"

    def _log_throttled(self, period_s: float, now: float, level: int, msg: str, *args) -> None:
        """``log`` at most once per ``period_s`` of sim time per message (rospy's throttle)."""
        last = self._throttled.get(msg)
        if last is None or now - last > period_s or last > now:
            self._throttled[msg] = now
            self._log(level, msg, *args)

    # ------------------------------------------------------------------------ report
    def status_line(self, now_s: float, cycle_wall_ms: Sequence[float]) -> str:
        """The terminal's progress line; ``cycle_wall_ms``: the explorer cycles' wall durations
        since the last line."""
        sup, active, sent = self.supervisor, self.book.active, self.sent
        goal = "-" if active is None else f"({active.goal[0]:.2f}, {active.goal[1]:.2f})"
        if sent is not None and sent.kind == "supervisor":
            goal = f"({sent.xy[0]:.2f}, {sent.xy[1]:.2f}) [{sup.state.lower()}]"
        ms = cycle_wall_ms
        median = f"{np.median(ms):.0f}" if len(ms) else "-"
        rung = f"  recovery rung {sup.rung}" if sup.rung else ""
        reachable = sum(f.reachable for f in self.frontiers)
        return (f"explorer: [{sup.state}] t={now_s:.1f} s  goal {goal}  frontiers {len(self.frontiers)} "
                f"({reachable} reachable)  blacklist {len(self.book.entries())}  "
                f"empty cycles {sup.empty_cycles}/{self.sup_settings.finish_empty_cycles}  "
                f"cycle {median} ms (median of {len(ms)}, wall){rung}")
