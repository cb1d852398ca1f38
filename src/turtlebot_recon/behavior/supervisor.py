"""The behaviour supervisor: a small explicit state machine over plain data, ROS-free.

``Supervisor.tick(Inputs) -> Command`` is called at ~10 Hz; time comes in as ``now_s`` and
nothing blocks. A node (later) turns Inputs from topics and Commands into topics/actions.

    SPIN ──spin done──▶ EXPLORE ──no frontier for N cycles / time budget──▶ RETURN_HOME ──▶ DONE
                         │  ▲                                       (disabled or at home: DONE)
                   stuck │  │ rung succeeded / last rung: blacklist goal
                         ▼  │
          ladder:  NUDGE ─fail─▶ BUMPER_BACKOFF ──▶ DRIFT ─fail─▶ blacklist
          any state but DONE ──bumper──▶ BUMPER_BACKOFF

- SPIN (seed 001): turn in place by ``spin_angle_deg`` at +``spin_speed_radps`` (counter-
  clockwise), i.e. for angle / speed seconds, so the first map is all round.
- EXPLORE: the explorer picks goals, the navigator drives ("explore" command). Finish after
  ``finish_empty_cycles`` consecutive explorer cycles without a reachable frontier (seed 004:
  10), i.e. with nothing reachable left to see (a frontier is reachable while a cell the
  robot reaches sees some of it: ``frontiers.detect``), or when ``time_budget_s`` has passed
  since the first tick. A cycle that finds the robot pinned (it reaches no cell off its own
  footprint, ``Inputs.pinned``) says nothing about what is left to see: it does not count,
  and it climbs the ladder at once (the house's tag search ended at 74 % of its walls with
  the robot wedged beside a pillar, the lattice reaching 3 cells).
- Stuck watchdog (seed 004: moved < 0.3 m in 10 s) while the robot should move (EXPLORE or
  RETURN_HOME with the navigator active, NUDGE, DRIFT) escalates one rung of the ladder:
  NUDGE -> BUMPER_BACKOFF -> DRIFT -> blacklist. A rung that succeeds returns to the mission
  state (EXPLORE or RETURN_HOME) without resetting the ladder; a rung that fails goes straight
  to the next one. The ladder resets when the mission state makes progress (0.3 m from the
  watchdog's anchor), so a rung that did not really free the robot is followed by the next
  one when the watchdog fires again. After the last rung the explorer's goal is blacklisted
  (in RETURN_HOME: home is unreachable, DONE).
- NUDGE (seed 004): drive to the best free point on 3 rings around the robot (recovery.py).
  Succeeds on reaching it; fails with no usable point, a navigator failure, the watchdog
  or ``nudge_timeout_s``.
- BUMPER_BACKOFF (seed 001): reverse ``backoff_distance_m`` at ``backoff_speed_mps``, then
  turn 15 deg away from the hit side (45 deg on a centre hit, toward the more open side). A
  bumper press in any state but DONE starts it (and restarts it); as a ladder rung without a
  press, the scan's closer side plays the hit side. After a real press, seed 001 drops the
  current frontier (``blacklist_after_bump``).
- DRIFT (seed 001's escape from a local minimum): for ``drift_duration_s``, turn toward the
  most open direction of the latest scan and drive slowly along it when the way ahead is
  clear. Fails without a scan or without any open direction.
- RETURN_HOME: a navigator goal at the start pose; DONE when reached, when the navigator
  fails (unreachable) or after ``return_home_timeout_s``.

Navigator statuses are trusted only ``nav_settle_s`` after a goal was sent (until then the
status may still describe the previous goal); reaching a goal is also judged by distance.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, List, Optional, Tuple

from ..config import positive, require
from ..geometry import wrap_angle
from . import recovery
from .recovery import CENTRE, LEFT, RIGHT, StuckWatchdog

SPIN, EXPLORE, NUDGE, BUMPER_BACKOFF, DRIFT, RETURN_HOME, DONE = (
    "SPIN", "EXPLORE", "NUDGE", "BUMPER_BACKOFF", "DRIFT", "RETURN_HOME", "DONE")
STATES = (SPIN, EXPLORE, NUDGE, BUMPER_BACKOFF, DRIFT, RETURN_HOME, DONE)
LADDER = (NUDGE, BUMPER_BACKOFF, DRIFT)            # then: blacklist
NAV_STATUSES = ("idle", "active", "succeeded", "failed")
COMMAND_KINDS = ("twist", "goal", "explore", "cancel", "stop", "done")
SIDE_NAMES = {LEFT: "left", CENTRE: "centre", RIGHT: "right"}


@dataclass(frozen=True)
class SupervisorSettings:
    # SPIN (seed 001)
    spin_angle_deg: float = 360.0          # initial turn in place; 0 = no spin
    spin_speed_radps: float = 0.6          # counter-clockwise; 360 deg takes 10.5 s
    # stuck watchdog (seed 004)
    stuck_distance_m: float = 0.3          # stuck: moved less than this ...
    stuck_window_s: float = 10.0           # ... in this long while it should be moving
    nav_settle_s: float = 1.0              # navigator statuses ignored this long after a goal
    # NUDGE (seed 004)
    nudge_radii_m: Tuple[float, ...] = (0.3, 0.6, 0.9)   # candidate rings
    nudge_bearings: int = 16               # candidates per ring
    nudge_clearance_cap_m: float = 1.0     # scan clearance beyond this adds no preference
    nudge_back_bonus_m: float = 0.5        # score bonus for heading back along the path
    nudge_reached_m: float = 0.15          # this close to the nudge point counts as reached
    nudge_timeout_s: float = 15.0          # give the nudge up after this long (seed 004: 15 s
                                           # between recoveries)
    # BUMPER_BACKOFF (seed 001)
    backoff_distance_m: float = 0.15       # reverse this far ...
    backoff_speed_mps: float = 0.1         # ... at this speed
    turn_side_deg: float = 15.0            # then turn away from a side hit by this much
    turn_centre_deg: float = 45.0          # ... or by this much on a centre hit
    turn_speed_radps: float = 0.8          # in-place turn speed
    side_bearing_deg: float = 60.0         # where a side bumper faces (seed 001); the scan is
                                           # compared at +- this bearing to pick a side
    blacklist_after_bump: bool = True      # seed 001 drops the current frontier after a press
    # DRIFT (seed 001)
    drift_speed_mps: float = 0.2           # seed 001's drift speed
    drift_turn_radps: float = 0.6          # steering toward the open direction saturates here
    drift_duration_s: float = 4.0          # drift this long, then back to the mission state
    drift_min_clearance_m: float = 0.4     # a direction is open beyond this; drive only then
    drift_heading_tolerance_deg: float = 30.0   # drive forward only within this of the heading
    drift_bearings: int = 36               # scan directions compared
    drift_half_window: int = 1             # neighbours each side that must be open too
    # finish
    finish_empty_cycles: int = 10          # explorer cycles without a frontier (seed 004: 10)
    time_budget_s: float = 0.0             # exploration time from the first tick; 0 = none
    return_home: bool = True               # drive back to the start pose when done
    home_tolerance_m: float = 0.25         # this close to the start pose is home
    return_home_timeout_s: float = 120.0   # give the return up after this long
    status_period_s: float = 5.0           # status_due() is true this often

    def validate(self, src: str) -> None:
        positive(src, self, "spin_speed_radps", "stuck_distance_m", "stuck_window_s",
                 "nudge_bearings", "nudge_clearance_cap_m", "nudge_reached_m", "nudge_timeout_s",
                 "backoff_distance_m", "backoff_speed_mps", "turn_side_deg", "turn_centre_deg",
                 "turn_speed_radps", "side_bearing_deg", "drift_speed_mps", "drift_turn_radps",
                 "drift_duration_s", "drift_min_clearance_m", "drift_heading_tolerance_deg",
                 "drift_bearings", "finish_empty_cycles", "home_tolerance_m",
                 "return_home_timeout_s", "status_period_s")
        for key in ("spin_angle_deg", "nav_settle_s", "nudge_back_bonus_m", "time_budget_s"):
            v = getattr(self, key)
            require(math.isfinite(v) and v >= 0, src, key, f"must be >= 0, got {v!r}")
        for key in ("nudge_bearings", "drift_bearings", "finish_empty_cycles", "drift_half_window"):
            require(isinstance(getattr(self, key), int), src, key, "must be an integer")
        radii = self.nudge_radii_m
        require(len(radii) > 0 and all(r > 0 for r in radii)
                and all(a < b for a, b in zip(radii, radii[1:])), src, "nudge_radii_m",
                f"must be positive and increasing, got {radii!r}")
        require(self.turn_side_deg < 180 and self.turn_centre_deg < 180, src, "turn_side_deg",
                "turns must be < 180 deg")
        require(self.side_bearing_deg < 180, src, "side_bearing_deg", "must be < 180 deg")
        require(0 <= self.drift_half_window and 2 * self.drift_half_window + 1 <= self.drift_bearings,
                src, "drift_half_window", "must be >= 0 with 2 * half_window + 1 <= drift_bearings")


@dataclass(frozen=True)
class Inputs:
    """One tick's view of the world. Poses in the map frame (m, rad)."""
    now_s: float
    pose: tuple                            # (x, y, yaw)
    nav: str                               # navigator status: idle | active | succeeded | failed
    goal_available: bool                   # the explorer has a goal this cycle (a reachable
                                           # frontier its strategy takes)
    bumper: Optional[int]                  # pressed since the last tick: 0 left, 1 centre, 2 right
    free_space: Callable[[float, float], bool]     # (x, y) free and clear (cost < inscribed)
    scan_clearance: Optional[Callable[[float], float]]   # robot-frame bearing -> free m; None: no scan
    explore_goal: Optional[tuple] = None   # the explorer's current goal (x, y[, yaw]), if any
    explorer_cycle: Optional[int] = None   # the explorer cycle goal_available belongs to;
                                           # None: every tick is a cycle
    pinned: bool = False                   # that cycle found the robot reaching no cell off its
                                           # own footprint: nothing can be planned from here

    def __post_init__(self):
        if self.nav not in NAV_STATUSES:
            raise ValueError(f"nav must be one of {NAV_STATUSES}, got {self.nav!r}")
        if self.bumper not in (None, LEFT, CENTRE, RIGHT):
            raise ValueError(f"bumper must be None, 0, 1 or 2, got {self.bumper!r}")


@dataclass(frozen=True)
class Command:
    """What the node does this tick.

    twist:   publish (linear_mps, angular_radps); the navigator must not drive (cancel it).
    goal:    make the navigator pursue ``goal`` (x, y, yaw); send it when it differs from the
             goal last sent or after a twist.
    explore: the explorer sends its goals and the navigator drives; if ``blacklist`` is set,
             the explorer blacklists that (x, y) first (emitted once).
    cancel / stop: cancel the navigator's goal / and hold still (part of the vocabulary; this
             machine expresses holding still as a zero twist).
    done:    exploration is over: cancel, hold still, write the run output.
    """
    kind: str
    linear_mps: float = 0.0
    angular_radps: float = 0.0
    goal: Optional[tuple] = None
    blacklist: Optional[tuple] = None
    reason: str = ""

    def __post_init__(self):
        if self.kind not in COMMAND_KINDS:
            raise ValueError(f"kind must be one of {COMMAND_KINDS}, got {self.kind!r}")


class Supervisor:
    """The state machine (module docstring). ``state`` is one of STATES; ``transitions`` lists
    (now_s, from, to, reason) in order; ``finished_reason`` says why exploration ended."""

    def __init__(self, settings: SupervisorSettings, start_pose: tuple):
        self.settings = settings
        self.start_pose = tuple(float(v) for v in start_pose)
        self.state = SPIN
        self.mission = EXPLORE                 # where recoveries return: EXPLORE or RETURN_HOME
        self.transitions: List[Tuple[float, str, str, str]] = []
        self.finished_reason: Optional[str] = None
        self.empty_cycles = 0
        self.rung = 0                          # index into LADDER of the next rung; 3: blacklist
        s = settings
        self._watchdog = StuckWatchdog(s.stuck_distance_m, s.stuck_window_s)
        self._t0: Optional[float] = None       # first tick: spin start, time budget start
        self._now = 0.0
        self._pose = self.start_pose
        self._entered_s = 0.0                  # when the current state was entered
        self._last_cycle: Optional[int] = None
        self._explore_goal: Optional[tuple] = None
        self._pending_blacklist: Optional[tuple] = None
        self._crumb: Optional[Tuple[float, float]] = None      # breadcrumbs for "back along
        self._came_from: Optional[Tuple[float, float]] = None  # the path" (NUDGE)
        self._goal: Optional[tuple] = None     # NUDGE / RETURN_HOME navigator goal
        self._goal_sent_s = 0.0
        self._home_started_s: Optional[float] = None
        self._backoff: Optional[dict] = None   # side, turn_rad, bumped, ladder, backoff_s, turn_s
        self._drift_heading = 0.0
        self._free_space: Callable[[float, float], bool] = lambda x, y: False
        self._clearance: Optional[Callable[[float], float]] = None
        self._next_status_s: Optional[float] = None

    # ------------------------------------------------------------------------- ticking

    def tick(self, inp: Inputs) -> Command:
        """Advance the machine by one tick and return what to do until the next one."""
        self._now, self._pose = inp.now_s, tuple(inp.pose)
        self._free_space, self._clearance = inp.free_space, inp.scan_clearance
        if self._t0 is None:
            self._t0 = self._entered_s = inp.now_s
            self._watchdog.reset(self._pose, inp.now_s)
        self._drop_crumb()
        if self.state == DONE:
            return Command("done", reason=self.finished_reason or "")
        if self.state == EXPLORE:
            self._explore_goal = inp.explore_goal
        if inp.bumper is not None:
            self._bumped(inp)
        elif self._budget_spent() and self.state in (SPIN, EXPLORE, NUDGE, DRIFT):
            self._finish(f"time budget {self.settings.time_budget_s:g} s spent")
        else:
            getattr(self, "_update_" + self.state.lower())(inp)
        return self._command(inp)

    def _go(self, to: str, reason: str) -> None:
        self.transitions.append((self._now, self.state, to, reason))
        self.state, self._entered_s = to, self._now
        self._watchdog.reset(self._pose, self._now)
        if to == RETURN_HOME:                  # (re)entered: send home (again)
            self._goal, self._goal_sent_s = self.start_pose, self._now

    def _elapsed(self) -> float:
        return self._now - self._entered_s

    def _budget_spent(self) -> bool:
        budget = self.settings.time_budget_s
        return budget > 0 and self._now - self._t0 >= budget

    def _drop_crumb(self) -> None:
        xy = self._pose[:2]
        if self._crumb is None:
            self._crumb = xy
        elif math.dist(xy, self._crumb) >= self.settings.stuck_distance_m:
            self._came_from, self._crumb = self._crumb, xy

    def _nav_final(self, nav: str) -> Optional[str]:
        """The navigator's terminal status for our goal, once it can be trusted."""
        settled = self._now - self._goal_sent_s >= self.settings.nav_settle_s
        return nav if settled and nav in ("succeeded", "failed") else None

    def _near(self, goal: tuple, tolerance_m: float) -> bool:
        return math.dist(self._pose[:2], goal[:2]) <= tolerance_m

    # ------------------------------------------------------------------- state updates

    def _update_spin(self, inp: Inputs) -> None:
        if self._elapsed() >= self._spin_duration_s():
            self._go(EXPLORE, "spin done")

    def _spin_duration_s(self) -> float:
        return math.radians(self.settings.spin_angle_deg) / self.settings.spin_speed_radps

    def _update_explore(self, inp: Inputs) -> None:
        if inp.explorer_cycle is None or inp.explorer_cycle != self._last_cycle:
            self._last_cycle = inp.explorer_cycle
            if inp.pinned:
                self._escalate("pinned: the robot reaches no cell off its footprint")
                return
            self.empty_cycles = 0 if inp.goal_available else self.empty_cycles + 1
        n = self.settings.finish_empty_cycles
        if self.empty_cycles >= n:
            self._finish(f"no reachable frontier for {n} explorer cycles")
            return
        self._watch(moving=inp.nav == "active")

    def _watch(self, moving: bool) -> None:
        """Run the stuck watchdog in a mission state: progress resets the ladder, stuck climbs it."""
        event = self._watchdog.update(self._pose, self._now, moving)
        if event == "progress":
            self.rung = 0
        elif event == "stuck":
            self._escalate(self._stuck_reason())

    def _stuck_reason(self) -> str:
        s = self.settings
        return f"stuck: moved < {s.stuck_distance_m:g} m in {s.stuck_window_s:g} s"

    def _update_nudge(self, inp: Inputs) -> None:
        final = self._nav_final(inp.nav)
        if self._near(self._goal, self.settings.nudge_reached_m) or final == "succeeded":
            self._go(self.mission, "nudge point reached")
        elif final == "failed":
            self._escalate("nudge: navigator failed")
        elif self._elapsed() >= self.settings.nudge_timeout_s:
            self._escalate("nudge: timeout")
        elif self._watchdog.update(self._pose, self._now, True) == "stuck":
            self._escalate("nudge: " + self._stuck_reason())

    def _update_bumper_backoff(self, inp: Inputs) -> None:
        b = self._backoff
        if self._elapsed() < b["backoff_s"] + b["turn_s"]:
            return
        if b["bumped"] and self.mission == EXPLORE and self.settings.blacklist_after_bump:
            self._pending_blacklist = self._goal_xy(self._explore_goal)
        self._go(self.mission, "backoff done")

    def _update_drift(self, inp: Inputs) -> None:
        if self._elapsed() >= self.settings.drift_duration_s:
            self._go(self.mission, "drift done")
        elif self._watchdog.update(self._pose, self._now, True) == "stuck":
            self._escalate("drift: " + self._stuck_reason())

    def _update_return_home(self, inp: Inputs) -> None:
        final = self._nav_final(inp.nav)
        if self._near(self.start_pose, self.settings.home_tolerance_m) or final == "succeeded":
            self._go(DONE, "home reached")
        elif final == "failed":
            self._go(DONE, "home unreachable: navigator failed")
        elif self._now - self._home_started_s >= self.settings.return_home_timeout_s:
            self._go(DONE, "home not reached in time")
        else:
            self._watch(moving=inp.nav == "active")

    # ------------------------------------------------------------- entering states

    def _escalate(self, reason: str) -> None:
        """Enter the next rung of the ladder; after the last one, give the goal up."""
        if self.rung >= len(LADDER):
            self.rung = 0
            if self.mission == RETURN_HOME:
                self._go(DONE, f"home unreachable: recoveries exhausted ({reason})")
                return
            goal = self._goal_xy(self._explore_goal)
            self._pending_blacklist = goal
            self._go(EXPLORE, f"recoveries exhausted ({reason}): blacklist goal {goal}")
            return
        rung = LADDER[self.rung]
        self.rung += 1
        if rung == NUDGE:
            self._enter_nudge(reason)
        elif rung == BUMPER_BACKOFF:
            side = recovery.obstacle_side(self._clearance, math.radians(self.settings.side_bearing_deg))
            self._enter_backoff(side, bumped=False, ladder=True, reason=reason)
        else:
            self._enter_drift(reason)

    def _enter_nudge(self, reason: str) -> None:
        s = self.settings
        back = None
        if self._came_from is not None:
            dx, dy = self._came_from[0] - self._pose[0], self._came_from[1] - self._pose[1]
            back = wrap_angle(math.atan2(dy, dx) - self._pose[2])
        best = recovery.choose_nudge(self._pose, s.nudge_radii_m, s.nudge_bearings, self._free_space,
                                     self._clearance, back, s.nudge_clearance_cap_m,
                                     s.nudge_back_bonus_m)
        if best is None:
            self._escalate(f"{reason}; nudge: no free candidate")
            return
        self._goal, self._goal_sent_s = best.goal(self._pose), self._now
        self._go(NUDGE, reason)

    def _enter_backoff(self, side: int, bumped: bool, ladder: bool, reason: str) -> None:
        s = self.settings
        sign = recovery.more_open_side(self._clearance, math.radians(s.side_bearing_deg))
        turn = recovery.turn_away_rad(side, math.radians(s.turn_side_deg),
                                      math.radians(s.turn_centre_deg), sign)
        self._backoff = dict(side=side, turn_rad=turn, bumped=bumped, ladder=ladder,
                             backoff_s=s.backoff_distance_m / s.backoff_speed_mps,
                             turn_s=abs(turn) / s.turn_speed_radps)
        self._go(BUMPER_BACKOFF, reason)

    def _enter_drift(self, reason: str) -> None:
        s = self.settings
        if self._clearance is None:
            self._escalate(f"{reason}; drift: no scan")
            return
        bearing, open_m = recovery.most_open_bearing(self._clearance, s.drift_bearings,
                                                     s.drift_half_window)
        if open_m < s.drift_min_clearance_m:
            self._escalate(f"{reason}; drift: no open direction")
            return
        self._drift_heading = wrap_angle(self._pose[2] + bearing)
        self._go(DRIFT, reason)

    def _bumped(self, inp: Inputs) -> None:
        in_ladder = self.state in (NUDGE, DRIFT) or (self.state == BUMPER_BACKOFF and self._backoff["ladder"])
        if in_ladder:                          # the press replaces the rung it interrupted
            self.rung = max(self.rung, LADDER.index(BUMPER_BACKOFF) + 1)
        self._enter_backoff(inp.bumper, bumped=True, ladder=in_ladder,
                            reason=f"bumper {SIDE_NAMES[inp.bumper]}")

    def _finish(self, reason: str) -> None:
        self.finished_reason, self.mission, self.rung = reason, RETURN_HOME, 0
        s = self.settings
        if not s.return_home:
            self._go(DONE, f"{reason}; return home disabled")
        elif self._near(self.start_pose, s.home_tolerance_m):
            self._go(DONE, f"{reason}; already home")
        else:
            self._home_started_s = self._now
            self._go(RETURN_HOME, reason)

    @staticmethod
    def _goal_xy(goal: Optional[tuple]) -> Optional[tuple]:
        return None if goal is None else (float(goal[0]), float(goal[1]))

    # ------------------------------------------------------------------------ output

    def _command(self, inp: Inputs) -> Command:
        s, state = self.settings, self.state
        reason = self.transitions[-1][3] if self.transitions else ""
        if state == SPIN:
            return Command("twist", angular_radps=s.spin_speed_radps, reason="initial spin")
        if state == EXPLORE:
            blacklist, self._pending_blacklist = self._pending_blacklist, None
            return Command("explore", blacklist=blacklist, reason=reason)
        if state == NUDGE:
            return Command("goal", goal=self._goal, reason=reason)
        if state == RETURN_HOME:
            return Command("goal", goal=self.start_pose, reason=reason)
        if state == BUMPER_BACKOFF:
            b = self._backoff
            if self._elapsed() < b["backoff_s"]:
                return Command("twist", linear_mps=-s.backoff_speed_mps, reason=reason)
            return Command("twist", angular_radps=math.copysign(s.turn_speed_radps, b["turn_rad"]),
                           reason=reason)
        if state == DRIFT:
            return self._drift_twist(inp, reason)
        return Command("done", reason=self.finished_reason or reason)

    def _drift_twist(self, inp: Inputs, reason: str) -> Command:
        s = self.settings
        err = wrap_angle(self._drift_heading - self._pose[2])
        tol = math.radians(s.drift_heading_tolerance_deg)
        angular = s.drift_turn_radps * max(-1.0, min(1.0, err / tol))
        ahead_open = inp.scan_clearance is not None and inp.scan_clearance(0.0) >= s.drift_min_clearance_m
        linear = s.drift_speed_mps if abs(err) < tol and ahead_open else 0.0
        return Command("twist", linear_mps=linear, angular_radps=angular, reason=reason)

    # ------------------------------------------------------------------------ report

    def status_due(self, now_s: float) -> bool:
        """True every ``status_period_s`` (the first call included): time to print a status line."""
        if self._next_status_s is None or now_s >= self._next_status_s:
            self._next_status_s = now_s + self.settings.status_period_s
            return True
        return False

    def status_line(self, coverage: Optional[float] = None) -> str:
        """One line for the terminal: state, coverage (a fraction, printed in %), sim time, goal."""
        t = self._now - (self._t0 if self._t0 is not None else self._now)
        parts = [f"[{self.state}]", f"t={t:.1f} s"]
        parts.append("coverage ?" if coverage is None else f"coverage {100.0 * coverage:.1f} %")
        goal = self._goal if self.state in (NUDGE, RETURN_HOME) else self._explore_goal
        parts.append("goal -" if goal is None else f"goal ({goal[0]:.2f}, {goal[1]:.2f})")
        parts.append(f"empty cycles {self.empty_cycles}/{self.settings.finish_empty_cycles}")
        if self.rung:
            parts.append(f"recovery rung {self.rung}/{len(LADDER)}")
        if self.finished_reason:
            parts.append(f"finished: {self.finished_reason}")
        return "  ".join(parts)
