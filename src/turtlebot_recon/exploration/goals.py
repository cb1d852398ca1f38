"""Goal bookkeeping for every strategy: attempts, failures, blacklist, progress, re-evaluation.

Pure logic, no ROS, no clock of its own: every call that needs time takes ``now_s``. Goals
are remembered by position (metres, map frame), not by frontier id (ids change every
detection): a count "at" a point is the number of events within a radius of it.

- Attempts and failures: ``start`` counts an attempt, ``failed`` a failure; seed 003's
  attempt weight (1 - 0.2 per failure nearby, floor 0.01) is ``attempt_weight``.
- Blacklist: ``blacklist(xy, now_s)``; ``is_blacklisted(xy)`` within ``blacklist_radius_m``.
  ``failed`` blacklists by itself after ``blacklist_after_failures`` failures nearby.
- Expiry: a later success within ``expire_radius_m`` of an entry expires it (reaching a
  place nearby shows the map around it has changed); explore_lite's blacklist is permanent,
  a known complaint, so ``permanent_blacklist`` keeps that behaviour and
  ``is_blacklisted(..., include_expired=True)`` lets its strategy see every entry.
- Progress: ``ProgressWatchdog`` says when the distance to the goal has not shrunk for
  ``progress_timeout_s``.
- Unreachable: ``unreachable(xy, ctx)`` records a goal the navigator found no way to (or no
  place for) together with what the map looked like within ``unreachable_window_m`` of it;
  ``is_unreachable(xy, ctx)`` holds while that part of the map is unchanged (the same goal
  would fail the same way), and lets it go once the map there changed.
- Re-evaluation: ``reevaluate_reason`` says when the goal's frontier was explored on the way
  (seed 003's stated weakness: it drives on to a target that is no longer worth it), when
  an obstacle appeared at the goal (seed 000's goal reset), or when it has no path any more.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np
from scipy.spatial import cKDTree

from ..config import positive, require
from ..geometry import cells_to_points, inside
from ..mapping.map_io import OCCUPIED_THRESH
from .context import Context, Point
from .frontiers import Frontier
from .viewpoints import Tried


@dataclass(frozen=True)
class GoalBookSettings:
    attempt_radius_m: float = 0.4          # events this close count as the same goal (8 cells
                                           # at 0.05 m: seed 003's neighbourhood radius)
    blacklist_radius_m: float = 0.5        # a goal this close to an entry is blacklisted: about
                                           # a robot length, so a re-snapped goal still matches
    blacklist_after_failures: int = 1      # failures nearby that blacklist a goal (0: never);
                                           # a failure is declared after the supervisor's
                                           # recoveries, so one is enough
    expire_radius_m: float = 1.0           # a success this close expires blacklist entries
    permanent_blacklist: bool = False      # true: entries never expire (explore_lite)
    progress_timeout_s: float = 30.0       # no progress toward the goal this long: failure
                                           # (explore_lite's progress_timeout)
    progress_min_m: float = 0.05           # the distance must shrink by this to count
    reevaluate_radius_m: float = 0.15      # a frontier cell of the goal's cluster "remains" if
                                           # a current frontier cell is this close to it (3
                                           # cells: the jitter of a boundary between maps)
    reevaluate_min_fraction: float = 0.25  # re-evaluate when less than this fraction remains
    unreachable_window_m: float = 1.0      # a goal the navigator found no way to is not sent
                                           # again while the map this close to it is unchanged

    def validate(self, src: str) -> None:
        positive(src, self, "attempt_radius_m", "blacklist_radius_m", "expire_radius_m",
                 "progress_timeout_s", "reevaluate_radius_m", "unreachable_window_m")
        n = self.blacklist_after_failures
        require(isinstance(n, int) and n >= 0, src, "blacklist_after_failures",
                "must be an integer >= 0 (0: never)")
        require(self.progress_min_m >= 0, src, "progress_min_m", "must be >= 0")
        require(0.0 <= self.reevaluate_min_fraction <= 1.0, src, "reevaluate_min_fraction",
                "must be in [0, 1]")


@dataclass
class BlacklistEntry:
    xy: Point
    since_s: float
    expired_s: Optional[float] = None      # when a later success nearby expired it


@dataclass(frozen=True, eq=False)
class ActiveGoal:
    """The goal being pursued, in map-frame metres (grids may grow and shift between maps)."""
    goal: Point
    frontier_points: np.ndarray            # float (n, 2) x, y of its frontier's cell centres
    started_s: float


class ProgressWatchdog:
    """No progress toward the goal for ``timeout_s`` -> stalled.

    Progress is a new goal (farther than ``same_goal_m`` from the last one) or a distance
    ``min_progress_m`` below the best so far. explore_lite's rule, with min_progress_m = 0
    and its "distance" the robot's distance to the frontier's closest cell.
    """

    def __init__(self, timeout_s: float, min_progress_m: float = 0.0, same_goal_m: float = 1e-6):
        self.timeout_s = timeout_s
        self.min_progress_m = min_progress_m
        self.same_goal_m = same_goal_m
        self.reset()

    def reset(self) -> None:
        self._goal: Optional[Point] = None
        self._best_m = math.inf
        self._last_progress_s = -math.inf

    def update(self, goal: Point, distance_m: float, now_s: float) -> bool:
        """Record the distance to ``goal`` at ``now_s``; True once stalled."""
        new_goal = self._goal is None or math.dist(goal, self._goal) > self.same_goal_m
        if new_goal or distance_m < self._best_m - self.min_progress_m:
            self._goal, self._best_m, self._last_progress_s = tuple(goal), distance_m, now_s
        return now_s - self._last_progress_s > self.timeout_s


class GoalBook:
    """Attempts, failures, successes and the blacklist, by position (see module docstring)."""

    def __init__(self, settings: GoalBookSettings = GoalBookSettings()):
        self.settings = settings
        self._starts: List[Point] = []
        self._failures: List[Point] = []
        self._successes: List[Tuple[Point, float]] = []
        self._blacklist: List[BlacklistEntry] = []
        self._blocked: List[Point] = []            # goals dropped as "blocked" (obstructed)
        self._unreachable: List[Tuple[Point, bytes, Point]] = []   # (goal, the map near it then,
                                                                     # where the robot stood)
        self.active: Optional[ActiveGoal] = None
        self.watchdog = ProgressWatchdog(settings.progress_timeout_s, settings.progress_min_m)

    # -------------------------------------------------------------- attempts and outcomes

    def start(self, frontier: Frontier, ctx: Context) -> ActiveGoal:
        """Count an attempt at ``frontier.goal``; it becomes the active goal (watchdog reset)."""
        self._starts.append(_xy(frontier.goal))
        points = cells_to_points(np.reshape(frontier.cells, (-1, 2)), ctx.resolution, ctx.origin)
        self.active = ActiveGoal(goal=_xy(frontier.goal), frontier_points=points,
                                 started_s=ctx.now_s)
        self.watchdog.reset()
        return self.active

    def failed(self, xy: Point, now_s: float) -> bool:
        """Record a failure at ``xy``; True if that blacklisted it."""
        self._failures.append(_xy(xy))
        self._clear_active(xy)
        n = self.settings.blacklist_after_failures
        if n > 0 and self.failures(xy) >= n and not self.is_blacklisted(xy):
            self.blacklist(xy, now_s)
            return True
        return False

    def obstructed(self, xy: Point, now_s: float, cell_m: float) -> bool:
        """An obstacle appeared at the goal ``xy`` (``reevaluate_reason`` "blocked"). Usually
        the map growing: the wall band firms up and the frontier's next goal lies a cell or
        more further out (seed 000 chooses again). A goal blocked again on the same cell
        (within ``cell_m``, the map's resolution) is a wall face that reads free from afar and
        occupied from near (grazing beams), which would put a goal there again and again: a
        failure (``failed``). True if that blacklisted it."""
        xy = _xy(xy)
        again = _count_near(self._blocked, xy, cell_m) > 0
        self._blocked.append(xy)
        if again:
            return self.failed(xy, now_s)
        self._clear_active(xy)
        return False

    def succeeded(self, xy: Point, now_s: float) -> int:
        """Record a success at ``xy``; expire older blacklist entries within expire_radius_m
        (unless permanent_blacklist). Returns how many expired."""
        self._successes.append((_xy(xy), now_s))
        self._clear_active(xy)
        if self.settings.permanent_blacklist:
            return 0
        expired = 0
        for entry in self._blacklist:
            if (entry.expired_s is None and entry.since_s < now_s
                    and math.dist(entry.xy, xy) <= self.settings.expire_radius_m):
                entry.expired_s = now_s
                expired += 1
        return expired

    def attempts(self, xy: Point, radius_m: Optional[float] = None) -> int:
        return _count_near(self._starts, xy, radius_m or self.settings.attempt_radius_m)

    def failures(self, xy: Point, radius_m: Optional[float] = None) -> int:
        return _count_near(self._failures, xy, radius_m or self.settings.attempt_radius_m)

    def successes(self, xy: Point, radius_m: Optional[float] = None) -> int:
        return _count_near([p for p, _ in self._successes], xy,
                           radius_m or self.settings.attempt_radius_m)

    def failure_points(self) -> np.ndarray:
        """Every recorded failure as a float (n, 2) array of x, y."""
        return np.asarray(self._failures, dtype=float).reshape(-1, 2)

    def tried(self, now_s: float) -> Tried:
        """The goals ``frontiers.detect`` looks past at ``now_s``: every success before it (its
        view is spent, and no new viewpoint lies within attempt_radius_m of it). A success
        counts from the cycles after the one it triggers: that one runs on the map from before
        the arrival, which does not show yet what the robot sees there (the goal stands, and
        the robot looks)."""
        reached = [p for p, t in self._successes if t < now_s]
        return Tried(np.asarray(reached, dtype=float).reshape(-1, 2),
                     self.settings.attempt_radius_m)

    def attempt_weight(self, xy: Point, decrement: float = 0.2, floor: float = 0.01,
                       radius_m: Optional[float] = None) -> float:
        """Seed 003: 1, minus ``decrement`` per failure within the radius, at least ``floor``."""
        return max(floor, 1.0 - decrement * self.failures(xy, radius_m))

    def unreachable(self, xy: Point, ctx: Context, robot_xy: Point) -> None:
        """The navigator found no way from ``robot_xy`` to ``xy`` (or no place for the robot
        there) on the map ``ctx`` shows: not a goal again while the map near it is unchanged
        and the robot is still near where it was asked."""
        xy = _xy(xy)
        self._unreachable.append((xy, self._around(xy, ctx), _xy(robot_xy)))
        self._clear_active(xy)

    def is_unreachable(self, xy: Point, ctx: Context) -> bool:
        """Within attempt_radius_m of a goal found unreachable, with the map near it unchanged
        and the robot (``ctx.robot_xy``) within unreachable_window_m of where it stood then."""
        r, window = self.settings.attempt_radius_m, self.settings.unreachable_window_m
        return any(math.dist(p, xy) <= r + 1e-9 and math.dist(at, ctx.robot_xy) <= window
                   and self._around(p, ctx) == seen for p, seen, at in self._unreachable)

    def _around(self, xy: Point, ctx: Context) -> bytes:
        """What the map says (unknown, free, occupied) within unreachable_window_m of ``xy``,
        cells beyond the map's edge unknown: equal bytes, the same map there."""
        k = int(math.ceil(self.settings.unreachable_window_m / ctx.resolution))
        r, c = ctx.xy_to_cell(xy)
        occ = ctx.occupancy
        window = np.full((2 * k + 1, 2 * k + 1), -1, dtype=np.int8)
        r0, r1 = max(r - k, 0), min(r + k + 1, occ.shape[0])
        c0, c1 = max(c - k, 0), min(c + k + 1, occ.shape[1])
        if r0 < r1 and c0 < c1:
            window[r0 - (r - k):r1 - (r - k), c0 - (c - k):c1 - (c - k)] = occ[r0:r1, c0:c1]
        kind = np.where(window < 0, 0, np.where(window >= OCCUPIED_THRESH, 2, 1)).astype(np.uint8)
        return kind.tobytes()

    # -------------------------------------------------------------------------- blacklist

    def blacklist(self, xy: Point, now_s: float) -> None:
        self._blacklist.append(BlacklistEntry(_xy(xy), now_s))

    def is_blacklisted(self, xy: Point, radius_m: Optional[float] = None, *,
                       chebyshev: bool = False, include_expired: bool = False) -> bool:
        """An entry within ``radius_m`` (default blacklist_radius_m) of ``xy``; ``chebyshev``
        compares max(|dx|, |dy|) < radius_m instead (explore_lite's square tolerance)."""
        r = self.settings.blacklist_radius_m if radius_m is None else radius_m
        for entry in self.entries(include_expired):
            dx, dy = abs(entry.xy[0] - xy[0]), abs(entry.xy[1] - xy[1])
            if (max(dx, dy) < r) if chebyshev else (math.hypot(dx, dy) <= r):
                return True
        return False

    def entries(self, include_expired: bool = False) -> List[BlacklistEntry]:
        keep_all = include_expired or self.settings.permanent_blacklist
        return [e for e in self._blacklist if keep_all or e.expired_s is None]

    # ------------------------------------------------------------- progress, re-evaluation

    def stalled(self, distance_m: float, now_s: float) -> bool:
        """Progress watchdog on the active goal: True after progress_timeout_s without the
        distance to it shrinking by progress_min_m."""
        if self.active is None:
            return False
        return self.watchdog.update(self.active.goal, distance_m, now_s)

    def should_reevaluate(self, current: Optional[ActiveGoal], frontiers: Sequence[Frontier],
                          ctx: Context) -> bool:
        return self.reevaluate_reason(current, frontiers, ctx) is not None

    def reevaluate_reason(self, current: Optional[ActiveGoal], frontiers: Sequence[Frontier],
                          ctx: Context) -> Optional[str]:
        """Why the active goal should be dropped for a fresh choice, or None to keep it.

        "blocked": its cell is off the map or costs more than ctx.max_cost (an obstacle
        appeared there, seed 000's goal reset); "no path": its cost-to-come is infinite;
        "explored": fewer than reevaluate_min_fraction of its frontier's cells have a current
        frontier cell within reevaluate_radius_m (all gone: the cluster no longer exists).
        """
        if current is None:
            return None
        r, c = ctx.xy_to_cell(current.goal)
        if not inside(r, c, ctx.costmap.shape) or ctx.costmap[r, c] > ctx.max_cost:
            return "blocked"
        if not math.isfinite(float(ctx.cost_to_come[r, c])):
            return "no path"
        old = current.frontier_points
        if len(old) == 0:
            return None
        now = [f.cells for f in frontiers if len(f.cells)]
        if not now:
            return "explored"
        now_xy = cells_to_points(np.concatenate(now), ctx.resolution, ctx.origin)
        dist, _ = cKDTree(now_xy).query(old, k=1)
        remaining = float(np.mean(dist <= self.settings.reevaluate_radius_m + 1e-9))
        if remaining < max(self.settings.reevaluate_min_fraction, 1e-12):
            return "explored"
        return None

    def _clear_active(self, xy: Point) -> None:
        if (self.active is not None
                and math.dist(self.active.goal, xy) <= self.settings.attempt_radius_m):
            self.active = None
            self.watchdog.reset()


def stands_for(sent_xy: Point, choice_xy: Point, same_goal_m: float, ctx: Context) -> bool:
    """Whether the goal already sent to the navigator stands for the new choice: within
    ``same_goal_m`` of it and still a goal the robot can stand on and reach. A goal just
    dropped as blocked does not: kept, it is blocked again at the next cycle and counted twice."""
    return (math.dist(sent_xy, choice_xy) <= same_goal_m
            and ctx.goal_ok(ctx.xy_to_cell(sent_xy)))


def _xy(p: Sequence[float]) -> Point:
    return (float(p[0]), float(p[1]))


def _count_near(points: List[Point], xy: Point, radius_m: float) -> int:
    if not points:
        return 0
    arr = np.asarray(points)
    return int(np.count_nonzero(np.hypot(arr[:, 0] - xy[0], arr[:, 1] - xy[1]) <= radius_m + 1e-9))
