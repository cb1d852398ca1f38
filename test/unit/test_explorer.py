"""The exploration loop (exploration/explorer.py) driven with hand-made maps, no ROS.

Every test runs ``Explorer`` the way the node does: 10 Hz ticks (times i / 10, never
accumulated), each ``explore`` then ``supervise``, with navigator results fed back as
``NavEvent``s. The map is a 2 x 4 m strip at 5 cm, no walls (so the costmap is 0 on every
known cell and the numbers are easy to work by hand):

    cols  0..19  unknown   x in [0, 1.0)
    cols 20..59  free      x in [1.0, 3.0)
    cols 60..79  unknown   x in [3.0, 4.0)        rows 0..39: y in [0, 2.0)

Two frontiers: the unknown columns 19 and 60. The robot stands at the centre of cell
(20, 30), (1.525, 1.025), facing +x. The strategy is ``nearest``: the frontier cell nearest
the robot snapped to the nearest reachable cell, i.e. (20, 19) -> (20, 20), centre
(1.025, 1.025), 0.5 m away, beats (20, 60) -> (20, 59), centre (2.975, 1.025), 1.45 m away.
"""
import dataclasses
import logging
import math

import numpy as np
import pytest

from turtlebot_recon.behavior import CENTRE, SupervisorSettings
from turtlebot_recon.exploration import FrontierSettings, detect
from turtlebot_recon.exploration.explorer import (CancelGoal, ExploreInputs, Explorer, ExplorerSettings,
                                                  Grid, NavEvent, SendGoal, SuperviseInputs, Velocity)
from turtlebot_recon.exploration.frontiers import robot_cost_to_come
from turtlebot_recon.exploration.goals import GoalBook, GoalBookSettings
from turtlebot_recon.exploration.strategies import make_strategy
from turtlebot_recon.exploration.tag_search import TagSearch, TagSearchSettings
from turtlebot_recon.planning import INSCRIBED, CostmapSettings, dijkstra, make_costmap
from turtlebot_recon.perception.tracker import Glimpse
from turtlebot_recon.robot import load_robot
from turtlebot_recon.planning.navigation import GOAL_UNREACHABLE

import test_frontiers

RES = 0.05
FREE, UNKNOWN = 0, -1
ROBOT = (1.525, 1.025, 0.0)        # cell (20, 30)
LEFT_GOAL = (1.025, 1.025)         # cell (20, 20)
RIGHT_GOAL = (2.975, 1.025)        # cell (20, 59)
# no initial spin; the stuck watchdog only where a test asks for it
SUPERVISOR = SupervisorSettings(spin_angle_deg=0.0, stuck_window_s=1000.0)


def strip(left_unknown=True, right_unknown=True):
    occ = np.full((40, 80), FREE, np.int8)
    if left_unknown:
        occ[:, :20] = UNKNOWN
    if right_unknown:
        occ[:, 60:] = UNKNOWN
    return Grid(occ, RES, (0.0, 0.0))


class Run:
    """An Explorer fed 10 Hz ticks; ``log`` collects (level, line)."""

    def __init__(self, grid=None, supervisor=SUPERVISOR, strategy="nearest", pose=ROBOT, **settings):
        self.log = []
        self.ex = Explorer(ExplorerSettings(**settings), FrontierSettings(), make_strategy(strategy),
                           GoalBook(GoalBookSettings()), supervisor, load_robot("turtlebot3_burger"),
                           log=lambda level, msg, *args: self.log.append((level, msg % args)))
        self.grid = grid or strip()
        self.pose = pose
        self.i = 0
        self.ex.start(self.now, pose)

    @property
    def now(self):
        return self.i / 10

    def tick(self, events=(), bumper=None):
        """One tick; its (explore outputs, supervise outputs)."""
        a = self.ex.explore(ExploreInputs(self.now, self.pose, self.grid, None, tuple(events)))
        b = self.ex.supervise(SuperviseInputs(self.now, self.pose, bumper))
        self.i += 1
        return a, b

    def actions(self, *args, **kwargs):
        a, b = self.tick(*args, **kwargs)
        return a.actions + b.actions

    def until_goal(self, max_ticks=30, **kwargs):
        """Tick until a goal is sent; that goal."""
        for _ in range(max_ticks):
            sent = [x for x in self.actions(**kwargs) if isinstance(x, SendGoal)]
            if sent:
                return sent[-1]
        raise AssertionError(f"no goal sent in {max_ticks} ticks: {self.log}")

    def until_cycle(self, max_ticks=30, **kwargs):
        """Tick until an explorer cycle runs; that tick's actions."""
        for _ in range(max_ticks):
            a, b = self.tick(**kwargs)
            if a.cycled:
                return a.actions + b.actions
        raise AssertionError(f"no cycle in {max_ticks} ticks")

    def lines(self, text):
        return [line for _, line in self.log if text in line]


def approx_xy(xy):
    return pytest.approx(xy, abs=1e-9)


# ------------------------------------------------------------------------- first goal

def test_first_cycles_send_the_nearest_frontier_goal():
    run = Run()
    a, b = run.tick()
    # tick 0: the first cycle finds both frontiers but does not drive yet (the supervisor
    # starts in SPIN; with no spin it turns EXPLORE in this tick and asks for a cycle)
    assert a.cycled and a.actions == [] and len(a.frontiers.frontiers) == 2
    assert b.state == "EXPLORE" and run.ex.goal_available
    a, b = run.tick()
    # tick 1: that cycle sends the nearest goal, (1.025, 1.025), any final heading; the
    # explore/goal arrow points robot -> goal: atan2(0, 1.025 - 1.525) = pi
    assert a.cycled
    (goal,) = a.actions
    assert goal.kind == "explore" and goal.xy == approx_xy(LEFT_GOAL) and goal.yaw is None
    assert goal.seq == 1 and goal.retries == 0 and goal.heading == pytest.approx(math.pi)
    assert a.frontiers.goal == approx_xy(LEFT_GOAL)
    # (the centre 20.5 * 0.05 computes to 1.0250000000000001, which %.2f prints as 1.03)
    assert run.lines("explorer: goal (1.03, 1.03), 2 frontiers")
    # later cycles keep the goal being pursued: nothing is sent again
    for _ in range(25):
        assert not [x for x in run.actions() if isinstance(x, SendGoal)]
    assert run.ex.cycles >= 3


def test_no_frontier_means_no_goal_available():
    run = Run(grid=strip(left_unknown=False, right_unknown=False))
    a, _ = run.tick()
    assert a.cycled and a.frontiers.frontiers == [] and run.ex.goal_available is False
    # 40 x 80 = 3200 cells, all known
    assert run.lines("explorer: no frontier in the map (3200 known cells)")
    assert not [x for x in a.actions if isinstance(x, SendGoal)]


def test_a_cycle_runs_every_cycle_period_s():
    run = Run(cycle_period_s=0.5)
    cycled = [run.tick()[0].cycled for _ in range(12)]
    # t = 0.0 (first), 0.1 (asked for by the supervisor's first "explore"), then every 0.5 s
    # from 0.1: 0.6, 1.1
    assert [i for i, c in enumerate(cycled) if c] == [0, 1, 6, 11]


# -------------------------------------------------------------------- navigator results

@pytest.mark.parametrize("retries", [0, 2])
def test_aborted_goal_still_reachable_is_resent_up_to_abort_retries_then_fails(retries):
    run = Run(abort_retries=retries)
    goal = run.until_goal()
    for k in range(1, retries + 1):
        # still reachable in the last cycle's field: the same goal again, a new seq
        (again,) = [x for x in run.actions(events=[NavEvent(goal.seq, "failed", "blocked")])
                    if isinstance(x, SendGoal)]
        assert again.xy == goal.xy and again.kind == "explore" and again.retries == k
        assert again.seq == goal.seq + 1 and again.heading is None
        assert not run.ex.book.is_blacklisted(LEFT_GOAL)
        goal = again
    # abort_retries re-sends in a row made: this abort is a failure (one blacklists), and the
    # cycle it triggers at once goes to the other frontier
    a, b = run.tick(events=[NavEvent(goal.seq, "failed", "blocked")])
    assert a.cycled
    assert run.ex.book.failures(LEFT_GOAL) == 1 and run.ex.book.is_blacklisted(LEFT_GOAL)
    assert run.lines("failed (blocked); blacklisted")
    (nxt,) = [x for x in a.actions if isinstance(x, SendGoal)]
    assert nxt.xy == approx_xy(RIGHT_GOAL) and nxt.retries == 0
    # the retry line is throttled (5 s of sim time): one line for both re-sends
    assert len(run.lines("which is still reachable: sent again")) == min(retries, 1)


def test_a_goal_the_navigator_cannot_reach_is_dropped_and_not_resent_while_the_map_is_unchanged():
    """"goal unreachable: ..." is the goal's fault, not the robot's: no retry, one line naming
    why, and the goal stays out while the map near it is unchanged (up to 31 re-sends before);
    once the map there changes it is a goal again."""
    run = Run()
    goal = run.until_goal()
    a, _ = run.tick(events=[NavEvent(goal.seq, "failed", GOAL_UNREACHABLE + "plan_lattice: goal "
                                     "(20, 20) is unreachable from start (30, 30)")])
    assert a.cycled
    (nxt,) = [x for x in a.actions if isinstance(x, SendGoal)]
    assert nxt.xy == approx_xy(RIGHT_GOAL) and nxt.retries == 0
    (line,) = run.lines("explorer: goal (1.03, 1.03) dropped: the navigator plan_lattice")
    assert "not sent again while the map within 1.0 m of it is unchanged" in line
    assert not run.ex.book.is_blacklisted(LEFT_GOAL) and run.ex.book.failures(LEFT_GOAL) == 0
    # the right goal fails as well: nothing usable is left on this map; the left one is not re-sent
    a, _ = run.tick(events=[NavEvent(nxt.seq, "failed", GOAL_UNREACHABLE + "goal (2.98, 1.03) is in "
                                     "an obstacle")])
    for _ in range(30):
        assert not [x for x in run.actions() if isinstance(x, SendGoal)]
    assert run.ex.goal_available is False
    # a wall mapped near the left goal: the map there changed, the goal is one again
    grid = strip()
    grid.data[5, 25:30] = 100
    run.grid = grid
    assert run.until_goal().xy == approx_xy(LEFT_GOAL)


def test_the_next_goal_goes_out_within_stopping_distance_before_the_arrival():
    """Driving at 0.2 m/s, the burger (2.5 m/s^2) needs 0.008 m to stop and covers 0.02 m per
    tick: within 0.028 m of the goal it counts as reached and the next goal goes out at once,
    before the navigator reports the arrival (the controller does not brake for it)."""
    run = Run()
    goal = run.until_goal()
    x = goal.xy[0] + 0.2                                  # 0.2 m east of it, driving west
    for _ in range(9):
        run.pose = (x, goal.xy[1], math.pi)
        assert not [s for s in run.actions() if isinstance(s, SendGoal)]
        x -= 0.02
    run.pose = (goal.xy[0] + 0.01, goal.xy[1], math.pi)
    (nxt,) = [s for s in run.actions() if isinstance(s, SendGoal)]
    assert nxt.xy == approx_xy(RIGHT_GOAL) and nxt.seq == goal.seq + 1
    assert run.ex.book.successes(LEFT_GOAL) == 1 and run.lines("within stopping distance")


def test_a_result_for_a_replaced_goal_is_ignored():
    run = Run()
    goal = run.until_goal()
    a, _ = run.tick(events=[NavEvent(goal.seq - 1, "succeeded"), NavEvent(goal.seq + 5, "failed")])
    assert run.ex.nav == "active" and run.ex.book.successes(LEFT_GOAL) == 0
    assert run.ex.book.failures(LEFT_GOAL) == 0 and not a.cycled


def test_an_arrival_sends_the_next_goal_at_once_and_the_cycle_follows():
    run = Run()
    goal = run.until_goal()
    a, _ = run.tick()
    assert not a.cycled                       # 0.1 s after a cycle: none due
    a, _ = run.tick(events=[NavEvent(goal.seq, "succeeded")])
    assert run.ex.book.successes(LEFT_GOAL) == 1
    assert run.lines("explorer: goal (1.03, 1.03) reached")
    # the arrival: the strategy's choice among the last cycle's other frontiers goes out in
    # the same tick, before any cycle (which takes wall time the robot would stand through)
    assert not a.cycled
    (nxt,) = [x for x in a.actions if isinstance(x, SendGoal)]
    assert nxt.xy == approx_xy(RIGHT_GOAL) and nxt.seq == goal.seq + 1 and nxt.retries == 0
    # the cycle runs at the next tick. The map did not change: (20, 20), reached, sees every
    # cell of the left frontier (column 19, at most 20 cells away) and did not reveal them;
    # with none left for another viewpoint to see, it is given up. The right goal stands:
    # nothing is sent again
    a, _ = run.tick()
    assert a.cycled and not [x for x in a.actions if isinstance(x, SendGoal)]
    left, right = run.ex.frontiers
    assert not left.reachable and right.reachable
    assert run.ex.book.active.goal == approx_xy(RIGHT_GOAL)


def test_an_arrival_with_no_other_frontier_waits_for_the_cycle():
    # Only the left frontier: nothing else to send, so the arrival's cycle runs at once, on
    # the map from before the arrival, which does not show yet what the robot sees there
    # (the arrival does not count): the goal is sent again, and the robot stays and looks
    run = Run(grid=strip(right_unknown=False))
    goal = run.until_goal()
    a, _ = run.tick(events=[NavEvent(goal.seq, "succeeded")])
    assert a.cycled
    (again,) = [x for x in a.actions if isinstance(x, SendGoal)]
    assert again.xy == approx_xy(LEFT_GOAL) and again.seq == goal.seq + 1


def test_goal_whose_frontier_disappears_is_dropped_for_the_next():
    run = Run()
    goal = run.until_goal()
    run.grid = strip(left_unknown=False)      # the left region is now mapped: its frontier is gone
    actions = run.until_cycle()
    assert run.lines("explorer: goal (1.03, 1.03) dropped: explored")
    # the right frontier replaces it; the navigator's goal is simply replaced (no cancel)
    (nxt,) = [x for x in actions if isinstance(x, SendGoal)]
    assert nxt.xy == approx_xy(RIGHT_GOAL) and nxt.seq == goal.seq + 1
    assert nxt.heading == pytest.approx(0.0)  # atan2(0, 2.975 - 1.525)
    assert not [x for x in actions if isinstance(x, CancelGoal)]
    # dropped, not failed
    assert run.ex.book.failures(LEFT_GOAL) == 0 and not run.ex.book.is_blacklisted(LEFT_GOAL)


def test_no_usable_frontier_cancels_the_goal():
    run = Run(grid=strip(right_unknown=False))
    goal = run.until_goal()
    run.grid = strip(left_unknown=False, right_unknown=False)
    actions = run.until_cycle()
    assert CancelGoal(goal.seq, active=True) in actions
    assert run.ex.sent is None and run.ex.goal_available is False


# ------------------------------------------------------------------------- viewpoints

def slab_room():
    """test_frontiers' slab_room: S (rows 1..29, the robot's), an unknown slab (rows 30..32,
    cols 10..45) between walls, a strip 3 cells wide north of it (rows 33..35, inscribed)
    open only to E (cols 47..68). The slab's south face (row 30) faces S; its north face
    (row 32) is seen only along the strip, from E. Both snap to (29, 27), from which the
    slab hides the north face."""
    return Grid(test_frontiers.slab_room(), RES, (0.0, 0.0))


def test_an_arrival_that_does_not_reveal_the_frontier_sends_the_next_viewpoint():
    run = Run(grid=slab_room(), strategy="recon", pose=(1.775, 0.525, 0.0))     # cell (10, 35)
    first = run.until_goal()
    assert first.xy == approx_xy((1.375, 1.475))                                  # (29, 27)
    run.pose = (1.375, 1.475, 0.0)
    a, _ = run.tick(events=[NavEvent(first.seq, "succeeded")])
    # the cycle of the arrival runs on the map from before it: the goal stands (sent again)
    (again,) = [x for x in a.actions if isinstance(x, SendGoal)]
    assert a.cycled and again.xy == first.xy
    run.tick()
    a, _ = run.tick(events=[NavEvent(again.seq, "succeeded")])
    # the map did not change: the south face, in view of (29, 27) and of the start 1 m off,
    # is no frontier any more (looked at from two places: Looks); the north face, which the
    # slab hid, gets its viewpoint in E (cols >= 47), looking along the strip
    # (test_frontiers: (36, 53) on the burger's costmap)
    assert a.cycled
    (nxt,) = [x for x in a.actions if isinstance(x, SendGoal)]
    (north,) = run.ex.frontiers
    assert (north.cells[:, 0] == 32).all() and north.reachable and run.ex.goal_available
    assert nxt.xy == approx_xy(north.goal) and nxt.seq == again.seq + 1
    assert north.goal_cell[1] >= 47 and test_frontiers.sees(run.grid.data, north.goal_cell,
                                                            north.cells)


def test_a_frontier_no_reachable_cell_sees_is_given_up_and_the_run_ends():
    # A sealed box (walls rows 5..15, cols 40..50) in the fully known strip holds free cells
    # (rows 6..9) and unknown ones (rows 10..14): a frontier on row 10 that the robot can
    # neither reach nor see from anywhere it reaches.
    grid = strip(left_unknown=False, right_unknown=False)
    occ = grid.data
    occ[5:16, 40:51] = 100
    occ[6:10, 41:50] = FREE
    occ[10:15, 41:50] = UNKNOWN
    run = Run(grid=grid, supervisor=SupervisorSettings(spin_angle_deg=0.0, finish_empty_cycles=2,
                                                       return_home=False))
    for _ in range(30):
        a, b = run.tick()
        assert not [x for x in a.actions + b.actions if isinstance(x, SendGoal)]
        if b.done is not None:
            break
    (f,) = run.ex.frontiers
    assert not f.reachable and run.ex.goal_available is False
    assert b.done == "no reachable frontier for 2 explorer cycles"
    assert run.lines("explorer: 1 frontiers, 0 seen from a reachable viewpoint, none usable")


def test_a_pocket_in_a_wall_face_the_robot_looked_at_while_passing_ends_the_run():
    # The fully known strip with a thick wall north (rows 30..39) whose face holds 3 unknown
    # cells (row 30, cols 36..38): a frontier no ray ever reveals (a wall face the map drew a
    # cell off). The robot passes below it, 0.5 m off, along row 20: two looks 0.25 m apart
    # and it is no frontier any more; nothing else is left, and the run ends.
    grid = strip(left_unknown=False, right_unknown=False)
    grid.data[30:, :] = 100
    grid.data[30, 36:39] = UNKNOWN
    run = Run(grid=grid, supervisor=SupervisorSettings(spin_angle_deg=0.0, finish_empty_cycles=2,
                                                       return_home=False))
    goal = run.until_goal()
    (f,) = run.ex.frontiers
    assert f.reachable and goal.kind == "explore" and run.ex.goal_available
    done, cycles = None, []
    for x in (1.525, 1.775, 2.025, 2.275, 2.525):              # 1.2 s at each: a cycle or two
        run.pose = (x, 1.025, 0.0)
        for _ in range(12):
            a, b = run.tick()
            done = done or b.done
            if a.cycled:
                cycles.append((x, len(run.ex.frontiers)))
    # a place is cast at the cycle after it: 1.525 at the first cycle there (one look; the
    # pocket stays), 1.775 at the first cycle at 2.025 (the second look: gone from then on)
    assert {x for x, n in cycles if n == 1} == {1.525, 1.775}
    assert min(x for x, n in cycles if n == 0) == 2.025       # (the run ends before 2.525)
    assert run.ex.frontiers == [] and run.ex.goal_available is False
    assert done == "no reachable frontier for 2 explorer cycles"


# ------------------------------------------------------------------- supervisor commands

def test_supervisor_twist_cancels_the_goal_and_drives():
    run = Run()
    goal = run.until_goal()
    a, b = run.tick(bumper=CENTRE)
    # a centre press: BUMPER_BACKOFF reverses at backoff_speed_mps (0.1): the goal is cancelled
    # at the navigator first, then the twist goes out
    assert b.actions == [CancelGoal(goal.seq, active=True), Velocity(-0.1, 0.0)]
    assert b.state == "BUMPER_BACKOFF" and run.ex.sent is None and run.ex.nav == "idle"
    assert run.lines("explorer: state BUMPER_BACKOFF (bumper centre)")


def test_the_end_of_a_recovery_twist_stops_the_base():
    # The base drives on its last command until its timeout (0.5 s): where BUMPER_BACKOFF's
    # turn ends, a zero twist goes out, not a turn driven blind while the navigator plans.
    run = Run()
    run.until_goal()
    run.tick(bumper=CENTRE)
    twists = []
    for _ in range(300):
        a, b = run.tick()
        twists += [x for x in b.actions if isinstance(x, Velocity)]
        if b.state not in (None, "BUMPER_BACKOFF"):     # (set on a change of state only)
            break
    assert b.state == "EXPLORE"
    assert any(t.angular_radps != 0.0 for t in twists)          # it turned, then
    assert twists[-1] == Velocity(0.0, 0.0)                      # stopped as it left
    assert not [x for x in run.actions() if isinstance(x, Velocity)]   # once


def with_wall(column):
    grid = strip()
    occ = grid.data.copy()
    occ[:, column] = 100
    return Grid(occ, RES, grid.origin)


@pytest.mark.parametrize("wall_column, backs", [(27, False), (33, True), (None, True)])
def test_a_recovery_twist_that_would_hit_the_mapped_wall_is_not_driven(wall_column, backs):
    # The burger (0.105 m) at x = 1.525 m backs off a bump at 0.1 m/s; checked over 0.5 s it
    # moves 0.05 m. A wall behind it (column 27, x <= 1.40 m: 0.02 m from its back) would be
    # hit: it stops and says so. A wall in front (column 33, the one it bumped) or none: it backs.
    run = Run(grid=strip() if wall_column is None else with_wall(wall_column))
    run.until_goal()
    a, b = run.tick(bumper=CENTRE)
    assert b.state == "BUMPER_BACKOFF"
    velocity = [x for x in b.actions if isinstance(x, Velocity)]
    assert velocity == ([Velocity(-0.1, 0.0)] if backs else [Velocity(0.0, 0.0)])
    assert bool(run.lines("would bring the body onto an obstacle: stopped")) is not backs


def test_stuck_nudge_goal_then_back_to_the_frontier_goal():
    run = Run(supervisor=SupervisorSettings(spin_angle_deg=0.0))   # stuck after 10 s
    goal = run.until_goal()
    for _ in range(120):
        a, b = run.tick()
        if b.state == "NUDGE":
            break
    # the robot never moved while the navigator was active: the stuck watchdog's NUDGE goal
    # (with a heading) replaces the frontier goal
    (nudge,) = [x for x in b.actions if isinstance(x, SendGoal)]
    assert nudge.kind == "supervisor" and nudge.yaw is not None and nudge.seq == goal.seq + 1
    assert nudge.heading is None
    # the nudge point is reached (trusted after nav_settle_s = 1 s): back to EXPLORE, the
    # finished nudge is forgotten (not cancelled at the navigator: it ended) and the frontier
    # goal is sent again at the next tick
    for _ in range(10):
        run.tick()
    a, b = run.tick(events=[NavEvent(nudge.seq, "succeeded")])
    assert b.state == "EXPLORE" and CancelGoal(nudge.seq, active=False) in b.actions
    a, _ = run.tick()
    (back,) = [x for x in a.actions if isinstance(x, SendGoal)]
    assert back.kind == "explore" and back.xy == approx_xy(LEFT_GOAL)


def test_done_ends_with_the_reason_and_stays_done():
    run = Run(grid=strip(left_unknown=False, right_unknown=False),
              supervisor=SupervisorSettings(spin_angle_deg=0.0, finish_empty_cycles=2, return_home=False))
    for _ in range(30):
        a, b = run.tick()
        if b.done is not None:
            break
    # two cycles without a frontier (t = 0.0 and 0.1): the supervisor finishes, no return home
    assert b.done == "no reachable frontier for 2 explorer cycles"
    assert b.state == "DONE" and Velocity(0.0, 0.0) in b.actions and run.ex.done
    assert run.lines("explorer: DONE (no reachable frontier for 2 explorer cycles)")
    a, b = run.tick()
    assert a.actions == b.actions == [] and b.done is None and not a.cycled


def test_a_wedged_robot_recovers_instead_of_finishing():
    """The burger boxed in by a ring of wall 3 cells from its centre (every neighbour within
    its radius of a wall): the field holds its own cell only. Two empty cycles would finish
    the run; pinned cycles do not count: the supervisor climbs its ladder, one line says why."""
    grid = strip(left_unknown=False, right_unknown=False)
    occ = grid.data.copy()
    occ[17:24, 27:34] = 100
    occ[18:23, 28:33] = FREE
    run = Run(grid=Grid(occ, RES, (0.0, 0.0)),
              supervisor=SupervisorSettings(spin_angle_deg=0.0, finish_empty_cycles=2, return_home=False))
    states = set()
    for _ in range(40):
        a, b = run.tick()
        states.add(run.ex.supervisor.state)
        assert b.done is None
    assert run.ex.pinned and not run.ex.done
    assert states & {"NUDGE", "BUMPER_BACKOFF", "DRIFT"}
    assert run.lines("explorer: the robot at (1.52, 1.02) reaches no cell off its footprint")


def test_a_robot_the_lattice_cannot_place_is_not_wedged():
    """The pose off the map: the field is empty (not the robot's own cell alone): that is no
    sign of a wedged robot, and the empty cycles finish the run as before."""
    run = Run(grid=strip(left_unknown=False, right_unknown=False), pose=(10.0, 10.0, 0.0),
              supervisor=SupervisorSettings(spin_angle_deg=0.0, finish_empty_cycles=2, return_home=False))
    for _ in range(30):
        a, b = run.tick()
        if b.done is not None:
            break
    assert b.done == "no reachable frontier for 2 explorer cycles" and not run.ex.pinned
    assert not run.lines("reaches no cell off its footprint")


# ------------------------------------------------------------------------------ helpers

def test_free_space_is_the_last_cycles_passable_known_space():
    run = Run()
    assert not run.ex.free_space(*ROBOT[:2])          # no cycle yet: nothing is known
    run.tick()
    assert run.ex.free_space(*ROBOT[:2])
    assert not run.ex.free_space(0.5, 1.0)            # unknown
    assert not run.ex.free_space(5.0, 1.0)            # off the map


def test_free_space_is_where_the_navigator_reaches():
    # A wall across the strip at column 40 (x = 2.0 m) with no gap: the far side is known free
    # and the burger fits there, but the navigator cannot get there; the supervisor must not
    # nudge or go home there.
    run = Run(grid=with_wall(40))
    run.tick()
    assert run.ex.free_space(1.8, 1.0) and not run.ex.free_space(2.3, 1.0)
    assert run.ex.ctx.costmap[run.ex.ctx.xy_to_cell((2.3, 1.0))] < INSCRIBED


def test_status_line_names_state_goal_and_cycle_times():
    run = Run()
    run.until_goal()
    line = run.ex.status_line(1.25, [10.0, 30.0, 20.0])
    assert line.startswith("explorer: [EXPLORE] t=1.2 s  goal (1.03, 1.03)")
    assert "frontiers 2 (2 reachable)" in line and "cycle 20 ms (median of 3, wall)" in line


def test_explore_before_start_is_an_error():
    ex = Explorer(ExplorerSettings(), FrontierSettings(), make_strategy("nearest"), GoalBook(),
                  SUPERVISOR, load_robot("turtlebot3_burger"))
    with pytest.raises(RuntimeError):
        ex.explore(ExploreInputs(0.0, ROBOT, strip()))


def test_nav_event_takes_status_words_only():
    with pytest.raises(ValueError):
        NavEvent(1, "ABORTED")


def test_log_defaults_to_python_logging(caplog):
    ex = Explorer(ExplorerSettings(), FrontierSettings(), make_strategy("nearest"), GoalBook(),
                  SUPERVISOR, load_robot("turtlebot3_burger"))
    with caplog.at_level(logging.INFO, logger="turtlebot_recon.exploration.explorer"):
        ex.start(0.0, ROBOT)
    assert "explorer: started at t=0.0 s sim from (1.52, 1.02, 0.00) in odom" in caplog.text


# ------------------------------------------------------------------- the cost-to-come field

def test_robot_cost_to_come_is_detects_default_field():
    grid = strip()
    costmap = make_costmap(grid.data, RES, CostmapSettings.for_robot(load_robot("turtlebot3_burger")))
    field = robot_cost_to_come(costmap, (20, 30), RES, 1.0)
    # no obstacle: 10 cells straight to (20, 20) at 0 cost = 0.5 m
    assert field[20, 20] == pytest.approx(0.5, abs=1e-6) and math.isinf(field[20, 10])
    given = detect(grid.data, RES, grid.origin, costmap, (20, 30), FrontierSettings(), field)
    default = detect(grid.data, RES, grid.origin, costmap, (20, 30), FrontierSettings())
    assert [(f.goal, f.path_cost_m) for f in given] == [(f.goal, f.path_cost_m) for f in default]


def test_robot_cost_to_come_starts_beside_a_wall_the_robot_brushes():
    # a 1-cell wall at column 7 of a free 11 x 15 grid. Its inscribed band reaches the burger's
    # radius plus one cell diagonal, 0.105 + 0.0707 = 0.176 m: the cells whose centres are
    # 0.05, 0.10 and 0.15 m from the wall's (columns 4..6 on its left) are inscribed, column 3
    # (0.20 m) is not
    occ = np.zeros((11, 15), np.int8)
    occ[:, 7] = 100
    costmap = make_costmap(occ, RES, CostmapSettings.for_robot(load_robot("turtlebot3_burger")))
    assert (costmap[5, 4:7] >= INSCRIBED).all() and costmap[5, 3] < INSCRIBED
    field = robot_cost_to_come(costmap, (5, 6), RES, 1.0)
    # the robot's cell (5, 6) is in the band: the field starts at the nearest passable cell,
    # (5, 3), 0.15 m away
    assert field[5, 3] == 0.0
    np.testing.assert_array_equal(field, dijkstra(costmap, (5, 3), resolution=RES))
    # no passable cell within 0.1 m: nothing is reachable
    assert np.isinf(robot_cost_to_come(costmap, (5, 6), RES, 0.1)).all()


def test_an_unconfirmed_tag_is_looked_at_before_the_next_frontier():
    """Mission tags (seed 000's priority goal, every strategy): a tag seen but not confirmed is
    looked at from in front of it while frontiers remain, not after the last one; confirmed,
    the frontiers come back."""
    waffle = load_robot("turtlebot3_waffle_pi")
    log = []
    ex = Explorer(ExplorerSettings(mission="tags"), FrontierSettings(), make_strategy("recon"),
                  GoalBook(GoalBookSettings()), SUPERVISOR, waffle,
                  log=lambda level, msg, *args: log.append(msg % args),
                  tag_search=TagSearch(TagSearchSettings(), waffle.camera))
    grid = strip()
    occ = grid.data
    occ[0, :] = occ[-1, :] = 100                               # walls along the strip
    tag = Glimpse("tag36h11", 7, 2.0, 0.0, math.pi / 2, 0.0)   # on the south wall, facing north
    ex.start(0.0, ROBOT)

    def sent(t, unconfirmed):
        a = ex.explore(ExploreInputs(t, ROBOT, grid, None, (), unconfirmed=unconfirmed))
        b = ex.supervise(SuperviseInputs(t, ROBOT))
        return [x for x in a.actions + b.actions if isinstance(x, SendGoal)]

    goals = [g for i in range(5) for g in sent(i / 10, (tag,))]
    assert goals and ex.frontiers, log
    view = goals[-1]
    assert math.dist(view.xy, (2.0, 1.0)) <= 0.6 + 1e-9      # tag_view_m in front, snapped
    assert view.yaw == pytest.approx(math.atan2(0.0 - view.xy[1], 2.0 - view.xy[0]))
    assert ex.book.active is None and ex.phase == "map"      # not the end-of-map tag search
    later = [g for i in range(5, 30) for g in sent(i / 10, ())]  # confirmed: back to the frontiers
    assert later and later[-1].yaw is None and ex.book.active is not None
    assert later[-1].xy in [approx_xy(f.goal) for f in ex.frontiers]


def test_a_strategys_own_goal_found_unreachable_is_not_chosen_again():
    """A goal of the strategy's own (not one of the frontiers' goals: sampled's tags, density's
    cells) found unreachable leaves nothing to choose instead of choosing it for ever."""
    class Own:
        name = "own"

        def choose(self, frontiers, ctx, book):
            f = frontiers[0]
            return dataclasses.replace(f, id=-1, goal=LEFT_GOAL)
    run = Run()
    run.ex.strategy = Own()
    goal = run.until_goal()
    run.tick(events=[NavEvent(goal.seq, "failed", GOAL_UNREACHABLE + "no way")])
    for _ in range(20):
        assert not [x for x in run.actions() if isinstance(x, SendGoal)]
    assert run.ex.choice is None
