"""The behaviour supervisor, driven by fake inputs over simulated time (no ROS).

Ticks are 0.1 s apart and times are computed as i / 10 (never accumulated), so boundaries
such as "exactly 10 s" are exact. Unless a test says otherwise the initial spin is off.
"""
import dataclasses
import math
from pathlib import Path

import pytest

from turtlebot_recon.behavior import (BUMPER_BACKOFF, CENTRE, DONE, DRIFT, EXPLORE, LEFT, NUDGE,
                                      RETURN_HOME, RIGHT, SPIN, Command, Inputs, StuckWatchdog,
                                      Supervisor, SupervisorSettings, choose_nudge,
                                      most_open_bearing, obstacle_side, ring_candidates,
                                      turn_away_rad)
from turtlebot_recon.behavior.recovery import bearings
from turtlebot_recon.config import ConfigError, from_dict

TOP = Path(__file__).resolve().parents[2]
DEFAULTS = SupervisorSettings()
NO_SPIN = SupervisorSettings(spin_angle_deg=0.0)


def all_free(x, y):
    return True


def uniform_scan(m):
    return lambda bearing: m


class Run:
    """A supervisor fed 10 Hz ticks. With ``drive=True`` twists move the fake robot (unicycle)."""

    def __init__(self, settings=NO_SPIN, start=(0.0, 0.0, 0.0), t0_s=0.0, drive=False, **inputs):
        self.sup = Supervisor(settings, start)
        self.pose = list(start)
        self.i, self.t0_s, self.drive = 0, t0_s, drive
        self.inputs = dict(nav="idle", goal_available=True, bumper=None, free_space=all_free,
                           scan_clearance=None, explore_goal=None, explorer_cycle=None)
        self.inputs.update(inputs)

    @property
    def now(self):
        return self.t0_s + self.i / 10

    @property
    def state(self):
        return self.sup.state

    def tick(self, **overrides) -> Command:
        args = {**self.inputs, **overrides}
        cmd = self.sup.tick(Inputs(now_s=self.now, pose=tuple(self.pose), **args))
        if self.drive and cmd.kind == "twist":
            x, y, yaw = self.pose
            self.pose = [x + cmd.linear_mps * 0.1 * math.cos(yaw),
                         y + cmd.linear_mps * 0.1 * math.sin(yaw), yaw + cmd.angular_radps * 0.1]
        self.i += 1
        return cmd

    def run_until(self, state, max_s=60.0, **overrides):
        """Tick until the machine is in ``state``; the commands of those ticks."""
        cmds = []
        while self.state != state:
            assert self.now < self.t0_s + max_s, f"never reached {state}: {self.sup.transitions}"
            cmds.append(self.tick(**overrides))
        return cmds

    def states(self):
        return [to for _, _, to, _ in self.sup.transitions]


# ------------------------------------------------------------------------ settings

def test_yaml_gives_every_setting_a_comment():
    # keys and defaults: test_config's table
    for line in (TOP / "config" / "supervisor.yaml").read_text().splitlines():
        if line and not line.startswith("#"):
            assert "#" in line, f"no comment/unit: {line}"


@pytest.mark.parametrize("bad, key", [
    ({"stuck_distance_m": 0.0}, "stuck_distance_m"),
    ({"nudge_radii_m": [0.6, 0.3]}, "nudge_radii_m"),
    ({"time_budget_s": -1.0}, "time_budget_s"),
    ({"drift_half_window": 18}, "drift_half_window"),
    ({"turn_centre_deg": 180.0}, "turn_side_deg"),
])
def test_invalid_settings_are_rejected(bad, key):
    with pytest.raises(ConfigError, match=f"src/{key}"):
        from_dict(SupervisorSettings, bad, "src")


def test_inputs_and_commands_reject_unknown_values():
    with pytest.raises(ValueError, match="nav"):
        Inputs(0.0, (0, 0, 0), "running", True, None, all_free, None)
    with pytest.raises(ValueError, match="bumper"):
        Inputs(0.0, (0, 0, 0), "idle", True, 3, all_free, None)
    with pytest.raises(ValueError, match="kind"):
        Command("fly")


# ---------------------------------------------------------------------------- SPIN

def test_spin_turns_counter_clockwise_for_2pi_over_omega():
    run = Run(DEFAULTS, drive=True)
    cmds = run.run_until(EXPLORE)
    # 2 pi / 0.6 rad/s = 10.47 s; the ticks at 0.0 .. 10.4 s are < 10.47 s: 105 spin ticks,
    # then the switch at the first tick >= 10.47 s, t = 10.5 s, which already says "explore"
    assert len(cmds) == 106 and run.sup.transitions[0] == (10.5, SPIN, EXPLORE, "spin done")
    assert all(c.kind == "twist" and c.angular_radps == 0.6 and c.linear_mps == 0.0 for c in cmds[:-1])
    assert cmds[-1].kind == "explore"
    # 105 x 0.6 rad/s x 0.1 s = 6.30 rad >= 2 pi (one tick fewer, 6.24 rad, would not be)
    assert run.pose[2] == pytest.approx(6.3) and run.pose[2] >= 2 * math.pi


def test_spin_speed_sets_its_duration():
    run = Run(dataclasses.replace(DEFAULTS, spin_speed_radps=1.0))
    run.run_until(EXPLORE)
    assert run.sup.transitions[0][0] == 6.3     # 2 pi / 1.0 = 6.28 s -> first tick at 6.3 s


def test_no_spin_starts_exploring_at_once():
    run = Run(NO_SPIN)
    assert run.tick().kind == "explore" and run.sup.transitions == [(0.0, SPIN, EXPLORE, "spin done")]


# ------------------------------------------------------------------ stuck watchdog

def creep(run, speed_mps, until_s, **kw):
    """Drive the robot along +x at ``speed_mps`` with the navigator active; the commands."""
    cmds = []
    while run.now <= until_s + 1e-9:
        run.pose = [speed_mps * run.now, 0.0, 0.0]
        cmds.append(run.tick(nav="active", **kw))
    return cmds


def test_stuck_fires_at_exactly_10_s_below_0_3_m():
    run = Run()
    run.tick()                                  # t = 0: SPIN -> EXPLORE, watchdog anchored at x = 0
    # 0.025 m/s: 0.25 m after 10 s < 0.3 m. The window closes at the first tick >= 10 s
    creep(run, 0.025, 9.9)
    assert run.state == EXPLORE
    creep(run, 0.025, 10.0)
    assert run.state == NUDGE and run.sup.transitions[-1][0] == 10.0
    assert "stuck: moved < 0.3 m in 10 s" in run.sup.transitions[-1][3]


@pytest.mark.parametrize("x_at_10s, stuck", [(0.3, False), (0.2999, True)])
def test_stuck_boundary_is_0_3_m(x_at_10s, stuck):
    run = Run()
    run.tick()                                  # anchor at x = 0, t = 0
    while run.now < 10.0:
        run.tick(nav="active")                  # standing still for 9.9 s: not yet stuck
    assert run.state == EXPLORE
    run.pose = [x_at_10s, 0.0, 0.0]             # at t = 10 s: 0.3 m is progress (>=), less is not
    run.tick(nav="active")
    assert (run.state == NUDGE) == stuck


def test_average_speed_above_0_03_mps_is_never_stuck():
    run = Run()
    run.tick()
    # 0.035 m/s reaches 0.3 m from the anchor after 8.6 s < 10 s, re-anchoring each time
    creep(run, 0.035, 60.0)
    assert run.state == EXPLORE and run.sup.rung == 0


def test_idle_navigator_time_does_not_count_as_stuck():
    run = Run()
    for _ in range(200):                        # 20 s standing still with no goal: fine
        run.tick(nav="idle")
    assert run.state == EXPLORE
    last_idle = run.now - 0.1
    while run.state == EXPLORE:
        run.tick(nav="active")
    # the time from the last idle tick on counts (its next tick expects motion): stuck 10 s later
    assert run.now - 0.1 == pytest.approx(last_idle + 10.0)


def test_goals_reached_where_the_robot_stands_are_stuck_too():
    # the navigator active for one tick, then done, again and again (a goal the strategy picks
    # again though the robot stands on it): no 10 s of "active" in a row, but every interval
    # touches a tick that expects motion, so the watchdog fires 10 s after it started
    run = Run()
    run.tick()
    start = run.now
    k = 0
    while run.state == EXPLORE and run.now < start + 30.0:
        run.tick(nav="active" if k % 2 == 0 else "succeeded")
        k += 1
    assert run.state == NUDGE
    assert run.sup.transitions[-1][0] <= start + 10.0 + 0.1 + 1e-9


def test_watchdog_unit():
    w = StuckWatchdog(0.3, 10.0)
    w.reset((0, 0), 0.0)
    assert w.update((0.1, 0), 9.99, True) is None
    assert w.update((0.1, 0), 10.0, True) == "stuck"
    assert w.update((0.1, 0), 10.1, True) is None          # the window starts again
    assert w.update((0.4, 0), 10.2, True) == "progress"    # 0.3 m from the new anchor
    assert w.update((0.4, 0), 10.3, False) is None         # 0.1 s counted (the last tick moved)
    assert w.update((0.4, 0), 30.0, False) is None         # idle to idle: not counted
    assert w.update((0.4, 0), 39.8, True) is None          # 0.1 + 9.8 s
    assert w.update((0.4, 0), 39.9, True) == "stuck"       # 10 s; the anchor never moved
    assert w.update((0.4, 0), 45.0, False) is None         # not stuck while not expected to move
    assert w.update((0.75, 0), 60.0, False) == "progress"  # moving while idle still counts


# ---------------------------------------------------------------- recovery ladder

def _stand(run, **kw):
    """Stand still in EXPLORE with the navigator active until the watchdog acts (<= 10 s);
    the command of that tick."""
    start, n = run.now, len(run.sup.transitions)
    while len(run.sup.transitions) == n:
        assert run.now < start + 10.05, "the watchdog did not fire within 10 s"
        cmd = run.tick(nav="active", **kw)
    return cmd


def test_ladder_order_then_blacklist_of_the_explorer_goal():
    goal = (2.0, 1.0, 0.0)
    run = Run(scan_clearance=uniform_scan(2.0), explore_goal=goal)
    run.tick()
    _stand(run)
    assert run.state == NUDGE and run.sup.rung == 1
    # the navigator fails the nudge goal: the next rung at once
    run.tick(nav="active")
    run.run_until(BUMPER_BACKOFF, nav="failed")
    assert "nudge: navigator failed" in run.sup.transitions[-1][3]
    run.run_until(EXPLORE)                      # the backoff is a timed manoeuvre
    assert run.sup.rung == 2
    _stand(run)                                 # still stuck: next rung
    assert run.state == DRIFT
    run.run_until(EXPLORE)
    cmd = _stand(run)                           # still stuck after the last rung: blacklist
    assert run.state == EXPLORE and run.sup.rung == 0
    assert run.states()[1:] == [NUDGE, BUMPER_BACKOFF, EXPLORE, DRIFT, EXPLORE, EXPLORE]
    last = run.sup.transitions[-1]
    assert last[1:3] == (EXPLORE, EXPLORE) and "blacklist goal (2.0, 1.0)" in last[3]
    assert cmd.kind == "explore" and cmd.blacklist == (2.0, 1.0)
    assert run.tick(nav="active").blacklist is None          # emitted once


def test_blacklist_command_is_emitted_once_after_the_last_rung():
    run = Run(scan_clearance=uniform_scan(2.0), explore_goal=(2.0, 1.0, 0.0),
              settings=dataclasses.replace(NO_SPIN, nudge_timeout_s=1.0))
    run.tick()
    blacklists = []
    for _ in range(600):
        cmd = run.tick(nav="active")
        if cmd.blacklist is not None:
            blacklists.append((run.state, cmd.kind, cmd.blacklist))
            break
    assert blacklists == [(EXPLORE, "explore", (2.0, 1.0))]
    assert run.tick(nav="active").blacklist is None


def test_ladder_resets_on_progress_in_explore():
    run = Run(scan_clearance=uniform_scan(2.0))
    run.tick()
    _stand(run)
    assert run.state == NUDGE
    nudge = run.tick(nav="active").goal
    run.pose = [nudge[0], nudge[1], nudge[2]]   # the robot reaches the nudge point
    run.tick(nav="active")
    assert run.state == EXPLORE and run.sup.rung == 1
    run.pose[0] += 0.35                         # progress in EXPLORE: >= 0.3 m from the anchor
    run.tick(nav="active")
    assert run.sup.rung == 0
    _stand(run)
    assert run.state == NUDGE                   # first rung again, not BUMPER_BACKOFF


def test_without_progress_the_next_stuck_climbs_a_rung():
    run = Run(scan_clearance=uniform_scan(2.0))
    run.tick()
    _stand(run)
    nudge = run.tick(nav="active").goal
    run.pose = list(nudge)
    run.tick(nav="active")
    assert run.state == EXPLORE
    _stand(run)
    assert run.state == BUMPER_BACKOFF


def test_nudge_without_free_candidate_goes_straight_to_backoff():
    run = Run(free_space=lambda x, y: False)
    run.tick()
    _stand(run)
    assert run.state == BUMPER_BACKOFF and "nudge: no free candidate" in run.sup.transitions[-1][3]
    assert [t[2] for t in run.sup.transitions] == [EXPLORE, BUMPER_BACKOFF]


def test_nudge_ignores_a_stale_navigator_status_then_trusts_it():
    run = Run(scan_clearance=uniform_scan(2.0))
    run.tick()
    _stand(run)
    sent = run.now - 0.1                        # the nudge goal went out on that tick
    # "succeeded" still describes the explorer's old goal: ignored for nav_settle_s = 1 s
    while run.now < sent + 1.0:
        cmd = run.tick(nav="succeeded")
        assert run.state == NUDGE and cmd.kind == "goal"
    run.tick(nav="succeeded")
    assert run.state == EXPLORE and run.sup.transitions[-1][3] == "nudge point reached"


def test_nudge_times_out():
    # a long stuck window so only the 15 s nudge timeout can end the nudge
    run = Run(dataclasses.replace(NO_SPIN, stuck_window_s=10.0), scan_clearance=uniform_scan(2.0))
    run.tick()
    _stand(run)
    entered = run.now - 0.1
    run.sup._watchdog.window_s = 100.0
    while run.state == NUDGE:
        run.tick(nav="active")
    assert run.state == BUMPER_BACKOFF and "nudge: timeout" in run.sup.transitions[-1][3]
    assert run.now - 0.1 - entered == pytest.approx(15.0)


def test_nudge_goal_is_on_a_ring_in_free_space():
    run = Run(free_space=lambda x, y: x < -0.1, scan_clearance=uniform_scan(2.0), start=(0, 0, 0))
    run.tick()
    _stand(run)
    goal = run.tick(nav="active").goal
    assert goal[0] < -0.1 and math.hypot(goal[0], goal[1]) == pytest.approx(0.9)
    assert goal[2] == pytest.approx(math.atan2(goal[1], goal[0]))   # facing the way out


# --------------------------------------------------------------------- bumper

@pytest.mark.parametrize("side, scan, turn_deg", [
    (LEFT, None, -15.0),                         # left hit: turn right (clockwise, negative)
    (RIGHT, None, 15.0),                         # right hit: turn left
    (CENTRE, None, 45.0),                        # centre, no scan: left
    (CENTRE, lambda b: 3.0 if b < 0 else 1.0, -45.0),   # centre, more room on the right
])
def test_bumper_backs_off_then_turns_away(side, scan, turn_deg):
    run = Run(drive=True, scan_clearance=scan)
    for _ in range(10):
        run.tick(nav="active")                  # exploring until t = 1.0 s
    cmds = [run.tick(bumper=side)]
    assert run.state == BUMPER_BACKOFF and run.sup.transitions[-1][0] == 1.0
    cmds += run.run_until(EXPLORE)
    back, turn = [c for c in cmds if c.linear_mps], [c for c in cmds if c.angular_radps]
    # back-off: 0.15 m at 0.1 m/s = 1.5 s = 15 ticks, straight back
    assert len(back) == 15 and all(c.linear_mps == -0.1 and c.angular_radps == 0 for c in back)
    assert run.pose[0] == pytest.approx(-0.15 * math.cos(0.0), abs=0.02)
    # turn: |theta| / 0.8 rad/s (15 deg: 0.33 s, 45 deg: 0.98 s), all one sign
    expected_s = math.radians(abs(turn_deg)) / 0.8
    assert len(turn) == math.ceil(expected_s / 0.1)
    assert all(math.copysign(1, c.angular_radps) == math.copysign(1, turn_deg) for c in turn)
    assert all(c.linear_mps == 0 for c in turn)
    yaw = run.pose[2]
    assert math.copysign(1, yaw) == math.copysign(1, turn_deg)
    assert abs(yaw - math.radians(turn_deg)) <= 0.08    # within one tick of 0.8 rad/s
    # then back to EXPLORE at 1.0 + 1.5 + expected_s, rounded up to a tick
    assert run.sup.transitions[-1][0] == pytest.approx(1.0 + math.ceil((1.5 + expected_s) / 0.1) / 10)


def test_bumper_at_any_time_jumps_to_backoff():
    run = Run(DEFAULTS)
    run.tick()
    run.tick(bumper=CENTRE)
    assert run.sup.transitions[-1][1:] == (SPIN, BUMPER_BACKOFF, "bumper centre")
    run.run_until(EXPLORE)                      # a recovery from SPIN returns to exploring
    _stand(run, scan_clearance=uniform_scan(2.0))
    assert run.state == NUDGE
    run.tick(bumper=RIGHT)                      # during a rung: replaces it
    assert run.state == BUMPER_BACKOFF and run.sup.rung == 2
    run.tick(bumper=LEFT)                       # a new press restarts the manoeuvre
    assert run.sup.transitions[-1][1:] == (BUMPER_BACKOFF, BUMPER_BACKOFF, "bumper left")


def test_bumper_in_explore_blacklists_the_goal_after_backing_off():
    run = Run(explore_goal=(3.0, -1.0, 0.5))
    run.tick()
    run.tick(bumper=LEFT)
    # outside EXPLORE the goal input is not the explorer's any more (here: gone); the goal
    # blacklisted is the one being pursued when the bumper was hit
    cmds = run.run_until(EXPLORE, explore_goal=None)
    assert cmds[-1].kind == "explore" and cmds[-1].blacklist == (3.0, -1.0)
    assert run.sup.rung == 0                    # a press while exploring is not a ladder rung
    off = Run(dataclasses.replace(NO_SPIN, blacklist_after_bump=False), explore_goal=(3.0, -1.0, 0.5))
    off.tick()
    off.tick(bumper=LEFT)
    assert off.run_until(EXPLORE)[-1].blacklist is None


# ---------------------------------------------------------------------- DRIFT

def test_drift_steers_toward_the_most_open_direction():
    left_open = lambda b: 3.0 if abs(b - math.pi / 2) < 0.3 else 0.3     # open only to the left
    run = Run(scan_clearance=left_open)
    run.tick()
    run.sup.rung = 2                            # next rung: DRIFT
    _stand(run)
    assert run.state == DRIFT
    cmd = run.tick(nav="active")
    # 90 deg off the open heading: full left turn (+0.6 rad/s), no forward motion
    assert cmd.kind == "twist" and cmd.angular_radps == 0.6 and cmd.linear_mps == 0.0
    run.pose[2] = math.pi / 2                   # now facing it: drive at 0.2 m/s
    cmd = run.tick(nav="active", scan_clearance=uniform_scan(3.0))
    assert cmd.linear_mps == 0.2 and cmd.angular_radps == pytest.approx(0.0, abs=1e-9)
    entered = run.sup.transitions[-1][0]
    run.run_until(EXPLORE)
    assert run.sup.transitions[-1][0] == pytest.approx(entered + 4.0)


def test_drift_without_scan_fails_straight_to_blacklist():
    run = Run(scan_clearance=None, explore_goal=(1.0, 1.0, 0.0))
    run.tick()
    run.sup.rung = 2
    _stand(run)
    assert run.state == EXPLORE and "drift: no scan" in run.sup.transitions[-1][3]
    assert run.sup.transitions[-1][1:3] == (EXPLORE, EXPLORE)


# --------------------------------------------------------------------- finish

def test_finish_after_10_empty_explorer_cycles_not_9():
    run = Run(start=(0.0, 0.0, 0.0))
    run.pose = [2.0, 0.0, 0.0]                  # away from home
    run.tick(goal_available=True, explorer_cycle=0)
    for k in range(1, 10):                      # cycles 1..9 empty, each seen for 3 ticks
        for _ in range(3):
            run.tick(goal_available=False, explorer_cycle=k)
    assert run.state == EXPLORE and run.sup.empty_cycles == 9
    run.tick(goal_available=False, explorer_cycle=10)
    assert run.state == RETURN_HOME
    assert run.sup.finished_reason == "no reachable frontier for 10 explorer cycles"


def test_a_pinned_cycle_does_not_count_toward_the_finish_and_climbs_the_ladder():
    """9 empty cycles, then the robot is found wedged (pinned): that cycle is no evidence that
    nothing is left to see. The supervisor recovers (NUDGE: no free point around a wedged
    robot -> BUMPER_BACKOFF) instead of finishing, and the count stands at 9."""
    run = Run(start=(0.0, 0.0, 0.0), free_space=lambda x, y: False, scan_clearance=uniform_scan(2.0))
    run.pose = [2.0, 0.0, 0.0]
    run.tick(goal_available=True, explorer_cycle=0)
    for k in range(1, 10):
        run.tick(goal_available=False, explorer_cycle=k)
    assert run.state == EXPLORE and run.sup.empty_cycles == 9
    run.tick(goal_available=False, explorer_cycle=10, pinned=True)
    assert run.state == BUMPER_BACKOFF and run.sup.empty_cycles == 9 and run.sup.finished_reason is None
    for _ in range(3):                       # the same cycle seen again: nothing more
        run.tick(goal_available=False, explorer_cycle=10, pinned=True)
    assert run.sup.rung == 2


def test_a_cycle_with_a_frontier_resets_the_count():
    run = Run()
    run.tick()
    for k in range(9):
        run.tick(goal_available=False)          # no cycle numbers: every tick is a cycle
    run.tick(goal_available=True)
    for k in range(9):
        run.tick(goal_available=False)
    assert run.state == EXPLORE
    run.tick(goal_available=False)
    assert run.state == DONE                    # at home already: straight to DONE


def test_time_budget_from_the_first_tick():
    run = Run(dataclasses.replace(NO_SPIN, time_budget_s=30.0), t0_s=100.0)
    run.pose = [1.0, 1.0, 0.0]
    while run.now < 129.95:
        run.tick()
    assert run.state == EXPLORE                 # t = 129.9 s
    cmd = run.tick()                            # t = 130.0 s: 30 s spent
    assert run.state == RETURN_HOME and cmd.kind == "goal" and cmd.goal == (0.0, 0.0, 0.0)
    assert run.sup.transitions[-1] == (130.0, EXPLORE, RETURN_HOME, "time budget 30 s spent")


def test_return_home_then_done():
    run = Run(start=(0.5, -0.5, 1.0))
    run.pose = [3.0, 2.0, 0.0]
    run.tick()                                  # SPIN -> EXPLORE (no cycle counted)
    for _ in range(10):
        run.tick(goal_available=False)
    assert run.state == RETURN_HOME
    # home was sent at t = 1.0 s; the navigator's stale "succeeded" is ignored at 1.1 .. 1.9 s
    # (less than nav_settle_s = 1 s after) and trusted at 2.0 s
    assert run.sup.transitions[-1][0] == 1.0
    for _ in range(9):
        cmd = run.tick(nav="succeeded")
        assert cmd.kind == "goal" and cmd.goal == (0.5, -0.5, 1.0)
    cmd = run.tick(nav="succeeded")
    assert run.state == DONE and cmd.kind == "done"
    assert cmd.reason == "no reachable frontier for 10 explorer cycles"
    assert run.tick(bumper=CENTRE).kind == "done" and run.state == DONE   # DONE is final


def test_return_home_ends_when_close_or_unreachable():
    near = Run(start=(0.0, 0.0, 0.0))
    near.pose = [3.0, 0.0, 0.0]
    near.tick()
    for _ in range(10):
        near.tick(goal_available=False)
    near.pose = [0.2, 0.0, 0.0]                 # within 0.25 m of home
    near.tick(nav="active")
    assert near.state == DONE and near.sup.transitions[-1][3] == "home reached"
    far = Run(start=(0.0, 0.0, 0.0))
    far.pose = [3.0, 0.0, 0.0]
    far.tick()
    for _ in range(10):
        far.tick(goal_available=False)
    far.run_until(DONE, nav="failed")
    assert far.sup.transitions[-1][3] == "home unreachable: navigator failed"


def test_return_home_disabled():
    run = Run(dataclasses.replace(NO_SPIN, return_home=False))
    run.pose = [3.0, 0.0, 0.0]
    run.tick()
    cmds = [run.tick(goal_available=False) for _ in range(10)]
    assert run.state == DONE and cmds[-1].kind == "done"
    assert RETURN_HOME not in run.states()
    assert run.sup.transitions[-1][3].endswith("return home disabled")


def test_stuck_on_the_way_home_climbs_the_ladder_then_gives_up():
    run = Run(dataclasses.replace(NO_SPIN, nudge_timeout_s=1.0), scan_clearance=uniform_scan(2.0))
    run.pose = [3.0, 0.0, 0.0]
    run.tick()
    for _ in range(10):
        run.tick(goal_available=False)
    run.run_until(DONE, max_s=120.0, nav="active")
    assert run.states()[1:] == [RETURN_HOME, NUDGE, BUMPER_BACKOFF, RETURN_HOME, DRIFT,
                                RETURN_HOME, DONE]
    assert run.sup.transitions[-1][3].startswith("home unreachable: recoveries exhausted")


# ------------------------------------------------------------ recovery geometry

def test_ring_candidates_cover_three_rings():
    c = ring_candidates((1.0, 2.0, math.pi / 2), (0.3, 0.6, 0.9), 16)
    assert len(c) == 48 and sorted({p.radius_m for p in c}) == [0.3, 0.6, 0.9]
    # bearing 0 is straight ahead: facing +y, the first point is 0.3 m above the robot
    assert (c[0].x, c[0].y, c[0].bearing_rad) == pytest.approx((1.0, 2.3, 0.0))
    assert all(math.hypot(p.x - 1.0, p.y - 2.0) == pytest.approx(p.radius_m) for p in c)


def test_choose_nudge_skips_occupied_points_and_prefers_open_ones():
    # a wall ahead (x >= 0.1 is not free); the scan: 2 m of room back-right (-135 deg), 0.5 m
    # elsewhere, and 3 m straight ahead (through the wall the costmap knows about)
    def scan(b):
        if abs(b) < 0.1:
            return 3.0
        return 2.0 if abs(b + 3 * math.pi / 4) < 0.1 else 0.5
    best = choose_nudge((0, 0, 0), (0.3, 0.6, 0.9), 16, lambda x, y: x < 0.1, scan)
    # back-right: reach 0.9 + min(2.0, 1.0) = 1.9; elsewhere at most 0.3 + 0.5 = 0.8
    assert best.bearing_rad == pytest.approx(-3 * math.pi / 4) and best.radius_m == 0.9
    assert best.score_m == pytest.approx(1.9)
    assert best.x < 0.1


def test_choose_nudge_needs_the_inner_rings_free_too():
    blocked = lambda x, y: math.hypot(x - 0.3, y) > 0.05     # only the 0.3 m point ahead is blocked
    best = choose_nudge((0, 0, 0), (0.3, 0.6, 0.9), 16, blocked)
    # every other bearing reaches 0.9 m with the same score; ties keep the first in order
    assert best.bearing_rad == pytest.approx(2 * math.pi / 16) and best.radius_m == 0.9
    assert choose_nudge((0, 0, 0), (0.3, 0.6, 0.9), 16, all_free).bearing_rad == 0.0


def test_choose_nudge_prefers_back_along_the_path_and_may_find_nothing():
    best = choose_nudge((0, 0, 0), (0.3, 0.6, 0.9), 16, all_free, back_bearing_rad=math.pi)
    assert abs(best.bearing_rad) == pytest.approx(math.pi)
    assert choose_nudge((0, 0, 0), (0.3, 0.6, 0.9), 16, lambda x, y: False) is None
    # the scan sees a return at 0.4 m everywhere: only the 0.3 m ring is usable
    assert choose_nudge((0, 0, 0), (0.3, 0.6, 0.9), 16, all_free, uniform_scan(0.4)).radius_m == 0.3


def test_turn_away_angles_follow_rep103():
    side, centre = math.radians(15), math.radians(45)
    assert turn_away_rad(LEFT, side, centre) == -side        # away from the left: clockwise
    assert turn_away_rad(RIGHT, side, centre) == side
    assert turn_away_rad(CENTRE, side, centre, 1) == centre
    assert turn_away_rad(CENTRE, side, centre, -1) == -centre
    with pytest.raises(ValueError):
        turn_away_rad(3, side, centre)


def test_obstacle_side_from_scan():
    s60 = math.radians(60)
    assert obstacle_side(lambda b: 0.2 if b > 0 else 1.0, s60) == LEFT
    assert obstacle_side(lambda b: 1.0 if b > 0 else 0.2, s60) == RIGHT
    assert obstacle_side(uniform_scan(1.0), s60) == CENTRE and obstacle_side(None, s60) == CENTRE


def test_most_open_bearing_ignores_one_ray_gaps():
    bs = bearings(36)
    gap, wide = bs[5], bs[21]

    def scan(b):
        if b == gap:
            return 3.0                          # one ray through a gap: not a way out
        if any(b == bs[k] for k in (20, 21, 22)):
            return 2.0
        return 1.0
    assert most_open_bearing(scan, 36, 1) == (wide, 2.0)
    assert most_open_bearing(scan, 36, 0) == (gap, 3.0)
    assert most_open_bearing(uniform_scan(1.0), 36, 1) == (0.0, 1.0)     # tie: straight ahead


# --------------------------------------------------------------------- status

def test_status_line_and_period():
    run = Run(explore_goal=(1.25, -2.5, 0.0))
    run.tick()
    run.i = 123
    run.tick()
    line = run.sup.status_line(0.873)
    assert "[EXPLORE]" in line and "t=12.3 s" in line and "coverage 87.3 %" in line
    assert "goal (1.25, -2.50)" in line and "empty cycles 0/10" in line
    assert "coverage ?" in run.sup.status_line()
    assert run.sup.status_due(0.0) and not run.sup.status_due(4.9) and run.sup.status_due(5.0)
