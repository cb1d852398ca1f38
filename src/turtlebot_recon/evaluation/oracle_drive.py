"""The oracle's run, ROS-free: the route loop that ``scripts/oracle_driver`` ticks.

``OracleDrive.tick(OracleInputs)`` is called every ``TICK_S`` of sim time and returns
``OracleOutputs`` (navigator goals, cancels and twists to carry out in order; the route point
to show on explore/goal; the clock's start; the state; the end). The run:

1. plan     the first route (``Oracle.route``) from the robot's true position. The tick ends
            there: planning takes seconds of wall time, i.e. of sim time at rtf > 1, so the
            next tick reads the clock again;
2. spin     the clock starts (``started_s``, the evaluator's zero) and, in state SPIN, the
            supervisor's initial spin (``spin_angle_deg`` at ``spin_speed_radps``, as every
            strategy makes): a turn twist every tick until it is done, then a stop; EXPLORE;
3. points   each route point in turn (world frame; goals go out in the map frame, whose
            origin is the start pose). A point the map shows free is driven to directly,
            until the navigator ends the goal. Else, every ``resend_period_s``, the robot is
            sent to the end of the stretch of the point's true path that the map shows free
            (``farthest_known_free``), again once that end moved ``advance_m`` or the navigator
            ended the goal. A point not reached within ``point_timeout_s`` is cancelled and
            skipped (a warning). After each point, coverage >= ``finish_coverage`` ends the route;
4. re-plan  after a route: done after ``max_routes`` routes, at coverage >= ``finish_coverage``,
            or when the last route added less than ``min_route_gain`` of F; else a route from
            here for what is still unseen (the tick ends, as in 1.; an empty one: done).

A route that cannot be planned (the robot off the costmap) ends the run with an error line and
"no route: ..." as the reason. Coverage is the evaluator's (``CoverageTracker`` on the
oracle's F). Log lines go to ``log(level, msg, *args)`` (Python logging levels).
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Tuple, Union

import numpy as np

from ..behavior.supervisor import SupervisorSettings
from .coverage import CoverageTracker, world_to_map
from .oracle import Oracle, OracleDriverSettings, Route, farthest_known_free

TICK_S = 0.1          # s (sim), the node ticks the run this often: the spin's twist rate and how
                      # soon the end of a goal is noticed
Log = Callable[..., None]


@dataclass(frozen=True)
class OracleInputs:
    now_s: float                          # sim time
    truth_xy: Tuple[float, float]         # the robot's true position, world frame (m)
    occupancy: np.ndarray                 # the robot's map: int8 ROS values, row 0 at origin
    resolution: float                     # m per cell
    origin: Tuple[float, float]           # (x, y) m of cell (0, 0)'s corner, map frame
    goal_active: bool                     # the navigator still pursues the last goal sent


@dataclass(frozen=True)
class DriveTo:
    """Make the navigator pursue (x, y) (map frame), any final heading; it replaces the last goal."""
    xy: Tuple[float, float]


@dataclass(frozen=True)
class Cancel:
    """Cancel the goal the navigator pursues."""


@dataclass(frozen=True)
class Turn:
    """Publish a twist turning in place at this rate (0: stop)."""
    angular_radps: float


Action = Union[DriveTo, Cancel, Turn]


@dataclass
class OracleOutputs:
    actions: List[Action] = field(default_factory=list)   # carry out in this order
    started_s: Optional[float] = None     # the run's clock starts at this sim time
    state: Optional[str] = None           # SPIN, EXPLORE, DONE: when it changed
    goal: Optional[Tuple[float, float]] = None   # a new route point, map frame
    done: Optional[str] = None            # the run ended this tick, with this reason


class OracleDrive:
    """The oracle's run (module docstring); ``done`` is final."""

    def __init__(self, settings: OracleDriverSettings, oracle: Oracle, spin: SupervisorSettings,
                 log: Optional[Log] = None):
        self.s, self.oracle, self.world = settings, oracle, oracle.world
        self.spin_s = math.radians(spin.spin_angle_deg) / spin.spin_speed_radps
        self.spin_speed_radps = spin.spin_speed_radps
        self.spin_end_s = math.inf
        self.tracker = CoverageTracker(self.world, oracle.F.reshape(self.world.free.shape))
        self._log = log or logging.getLogger(__name__).log
        self.phase = "plan"                # plan | start | spin | point | route (re-planned: its
                                           # first point at the next tick) | done
        self.route: Optional[Route] = None
        self.routes = 0                    # routes planned so far
        self.last_coverage: Optional[float] = None   # at the last re-plan
        self.index = -1                    # the route point pursued
        self.goal_map = None               # ... in the map frame
        self.deadline_s = math.inf
        self.direct = False                # the point itself was sent: wait for the navigator
        self.sent = None                   # the nearer point driven to, map frame
        self.next_check_s = -math.inf
        self._unknown_logged = False       # "no cell toward it is known free", once per point
        self._active = False
        self._inp: Optional[OracleInputs] = None
        self._out = OracleOutputs()

    @property
    def done(self) -> bool:
        return self.phase == "done"

    def tick(self, inp: OracleInputs) -> OracleOutputs:
        out = self._out = OracleOutputs()
        if self.done:
            return out
        self._inp, self._active = inp, inp.goal_active
        try:
            if self.phase == "plan":
                self._plan_first()
            elif self.phase in ("start", "spin"):
                self._spin()
            elif self.phase == "route":
                self._next_point()
            else:
                self._point()
        except ValueError as exc:          # a route from where the robot cannot be (a start in a wall)
            self._log(logging.ERROR, "oracle_driver: %s", exc)
            self._finish(f"no route: {exc}")
        return out

    def covered(self) -> np.ndarray:
        """bool (|F|,): the F cells the robot's map covers (the evaluator's rule)."""
        inp = self._inp
        return self.tracker.covered(inp.occupancy, inp.resolution, inp.origin)

    # ------------------------------------------------------------------ the steps
    def _plan_first(self) -> None:
        t = time.monotonic()
        self.route = self.oracle.route(self._inp.truth_xy)
        self.routes = 1
        self._log(logging.INFO, "oracle_driver: %d route points, model distance %.1f m to %.1f %% of F "
                  "(planned in %.1f s wall, before the start)", len(self.route.points), self.route.distance_m,
                  100 * self.oracle.s.target, time.monotonic() - t)
        self.phase = "start"

    def _spin(self) -> None:
        now = self._inp.now_s
        if self.phase == "start":
            self._out.started_s, self._out.state = now, "SPIN"
            self.spin_end_s, self.phase = now + self.spin_s, "spin"
        if now < self.spin_end_s:
            self._out.actions.append(Turn(self.spin_speed_radps))
            return
        self._out.actions.append(Turn(0.0))
        self._out.state = "EXPLORE"
        self._next_point()

    def _next_point(self) -> None:
        """The route's next point, or the next route after its last."""
        self.phase = "point"
        self.index += 1
        if self.index >= len(self.route.points):
            self._next_route()
            return
        xy_world = self.route.points[self.index]
        self.goal_map = world_to_map(np.array([xy_world]), self.world.start)[0]
        self._out.goal = (float(self.goal_map[0]), float(self.goal_map[1]))
        self.deadline_s = self._inp.now_s + self.s.point_timeout_s
        self.direct, self.sent, self.next_check_s = False, None, self._inp.now_s
        self._unknown_logged = False
        self._point()

    def _point(self) -> None:
        """Drive to the route point, through known-free points of its true path."""
        inp = self._inp
        if self.direct:
            if not self._active:
                self._point_done()
            elif inp.now_s >= self.deadline_s:
                self._skip()
            return
        if inp.now_s < self.next_check_s:
            return
        if inp.now_s >= self.deadline_s:
            self._skip()
            return
        self.next_check_s = inp.now_s + self.s.resend_period_s
        if farthest_known_free(self.goal_map[None], inp.occupancy, inp.resolution, inp.origin) == 0:
            self.direct = True
            self._send(self.goal_map)
            return
        xy_world = self.route.points[self.index]
        path = world_to_map(self.oracle.path(inp.truth_xy, xy_world), self.world.start)
        k = farthest_known_free(path, inp.occupancy, inp.resolution, inp.origin)
        if k is None:
            if not self._unknown_logged:
                self._unknown_logged = True
                self._log(logging.DEBUG, "oracle_driver: no cell toward (%.2f, %.2f) is known free yet",
                          *self.goal_map)
        elif self.sent is None or not self._active or np.hypot(*(path[k] - self.sent)) >= self.s.advance_m:
            self.sent = path[k]
            self._send(self.sent)

    def _skip(self) -> None:
        if self._active:
            self._out.actions.append(Cancel())
            self._active = False
        self._log(logging.WARNING, "oracle_driver: route point (%.2f, %.2f) not reached in %.0f s: skipped",
                  *self.goal_map, self.s.point_timeout_s)
        self._point_done()

    def _point_done(self) -> None:
        if self.covered().mean() >= self.s.finish_coverage:
            self._next_route()
        else:
            self._next_point()

    def _next_route(self) -> None:
        """After a route: done, or a re-plan for what is still unseen (the tick ends)."""
        if self.routes >= self.s.max_routes:
            self._finish(f"{self.s.max_routes} routes driven")
            return
        cov = self.covered()
        share = cov.mean()
        if share >= self.s.finish_coverage:
            self._finish(f"coverage {100 * share:.2f} % of F")
            return
        if self.last_coverage is not None and share - self.last_coverage < self.s.min_route_gain:
            self._finish(f"the last route added {100 * (share - self.last_coverage):.2f} % of F")
            return
        self.last_coverage = share
        self.route = self.oracle.route(self._inp.truth_xy, cov, restarts=self.s.replan_restarts,
                                       target=self.s.finish_coverage)
        self._log(logging.DEBUG, "oracle_driver: re-plan %d at %.1f %%: %d points", self.routes, 100 * share,
                  len(self.route.points))
        self.routes += 1
        if not len(self.route.points):
            self._finish(f"nothing more to see at {100 * share:.2f} % of F")
            return
        self.index, self.phase = -1, "route"

    def _send(self, xy_map) -> None:
        self._out.actions.append(DriveTo((float(xy_map[0]), float(xy_map[1]))))
        self._active = True

    def _finish(self, why: str) -> None:
        self.phase = "done"
        self._out.state, self._out.done = "DONE", why
        self._log(logging.INFO, "oracle_driver: done: %s", why)
