"""sim_bridge's ROS-free policy (sim/bridge.py): pacing to the rtf, rtf 0's wait for the next
command, the wall-time tally, the footprint outline and the true path relative to the start."""
import math

import pytest

from turtlebot_recon.robot import load_robot
from turtlebot_recon.sim.bridge import (CommandSync, CycleSync, Pacer, StartupPace, WallShares, footprint_outline,
                                         relative_to_start)


def test_pacer_holds_sim_time_to_rtf_times_wall_time():
    p = Pacer(rtf=2.0, sim_s=10.0, wall_s=100.0)
    # 1 sim s at rtf 2 takes 0.5 wall s; 0.2 s have passed: sleep 0.3 s
    assert p.sleep_s(11.0, 100.2) == pytest.approx(0.3)
    assert p.sleep_s(11.0, 100.6) == 0.0          # behind: no sleep
    # 2.5 wall s behind (> 1 s): it starts afresh from here instead of sprinting
    assert p.sleep_s(12.0, 103.5) == 0.0
    assert p.sleep_s(12.5, 103.5) == pytest.approx(0.25)


def test_pacer_at_rtf_0_never_sleeps():
    p = Pacer(rtf=0.0, sim_s=0.0, wall_s=0.0)
    assert p.sleep_s(1000.0, 0.001) == 0.0


def test_command_sync_waits_only_at_rtf_0_while_moving_on_an_old_command():
    sync = CommandSync(rtf=0.0, age_s=0.11, wait_s=1.0)
    sync.applied(5.0)
    assert sync.wait_for_s(5.10, 0.2, 0.0) == 0.0     # the command is 0.10 s old: drive on
    assert sync.wait_for_s(5.11, 0.2, 0.0) == 1.0     # 0.11 s old: wait up to 1 wall s
    assert sync.wait_for_s(5.5, 0.0, 0.3) == 1.0      # turning in place counts as moving
    assert sync.wait_for_s(5.5, 0.0, 0.0) == 0.0      # standing still: nothing to wait for
    sync.gave_up()                                    # the wait ran out: the publisher stopped
    assert sync.wait_for_s(6.0, 0.2, 0.0) == 0.0
    sync.applied(6.0)                                 # a command came: waits again
    assert sync.wait_for_s(6.2, 0.2, 0.0) == 1.0
    assert CommandSync(rtf=1.0, age_s=0.11, wait_s=1.0).wait_for_s(9.0, 0.2, 0.0) == 0.0
    assert CommandSync(rtf=0.0, age_s=0.0, wait_s=1.0).wait_for_s(9.0, 0.2, 0.0) == 0.0


def test_cycle_sync_holds_the_step_past_a_due_cycle_until_its_node_speaks():
    sync = CycleSync(rtf=0.0, slack_s=0.1, wait_s=5.0)
    assert sync.blocking(100.0) is None               # nobody said anything: nothing to wait for
    sync.announced("/explorer", 12.0)                 # its next cycle is due at 12 s
    assert sync.blocking(12.1) is None                # within the slack: the cycle may start
    assert sync.blocking(12.15) == "/explorer"        # past it: wait for that cycle
    sync.announced("/explorer", 13.0)                 # it ran and says when the next is due
    assert sync.blocking(12.15) is None
    sync.announced("/other", 12.5)                    # every node that speaks is waited for
    assert sync.blocking(12.7) == "/other"
    sync.gave_up("/other")                            # its wait ran out: step on without it
    assert sync.blocking(12.7) is None
    sync.announced("/explorer", 0.0)                  # done: no cycle due any more
    assert sync.blocking(1e6) is None
    off = CycleSync(rtf=1.0, slack_s=0.1, wait_s=5.0)  # a real-time run pays its cycles
    off.announced("/explorer", 1.0)
    assert off.blocking(50.0) is None
    never = CycleSync(rtf=0.0, slack_s=0.1, wait_s=0.0)
    never.announced("/explorer", 1.0)
    assert never.blocking(50.0) is None


def test_wall_shares_per_sim_second_largest_first():
    shares = WallShares()
    assert shares.summary(10.0) == ""                 # nothing tallied yet
    shares.add("physics", 0.05)
    shares.add("wait", 0.3)
    shares.add("physics", 0.05)
    shares.add("publish", 0.1)
    assert shares.summary(0.0) == ""                  # no sim time: no rate
    # over 10 sim s: wait 0.3 s -> 30 ms per sim s, publish 10, physics 0.1 s -> 10;
    # 50 ms of wall per sim s = 20x real time
    line = shares.summary(10.0)
    assert line.startswith("wall ms per sim s: wait 30.0, ")
    assert "publish 10.0" in line and "physics 10.0" in line
    assert line.endswith("(total 50.0 = 20.0x real time)")


def test_footprint_outline_round_and_box():
    burger = load_robot("turtlebot3_burger")
    circle = footprint_outline(burger)
    assert len(circle) == 24
    assert all(math.hypot(x, y) == pytest.approx(burger.radius_m) for x, y in circle)
    waffle = load_robot("turtlebot3_waffle_pi")
    box = footprint_outline(waffle)
    # 0.281 x 0.306 m centred 0.064 m behind the axle: x in [-0.2045, 0.0765], y in [-0.153, 0.153]
    expected = [(0.0765, 0.153), (-0.2045, 0.153), (-0.2045, -0.153), (0.0765, -0.153)]
    assert [c for p in box for c in p] == pytest.approx([c for p in expected for c in p])


def test_relative_to_start():
    # start at (1, 2) facing +y: a pose 1 m further along +y is 1 m ahead, facing the same way
    assert relative_to_start((1.0, 2.0, math.pi / 2), (1.0, 3.0, math.pi / 2)) == pytest.approx((1.0, 0.0, 0.0))
    # a point at +x of the start is on the robot's right (-y), heading wrapped to (-pi, pi]
    x, y, yaw = relative_to_start((1.0, 2.0, math.pi / 2), (2.0, 2.0, -math.pi))
    assert (x, y) == pytest.approx((0.0, -1.0)) and yaw == pytest.approx(math.pi / 2)


def test_clock_stamps_land_on_the_timers_deadlines():
    from turtlebot_recon.ros import convert
    # 29 steps of 0.01 s are 0.28999999999999998 s: truncated (rospy's from_sec) the stamp read
    # 0.289999999, a 10 Hz timer due at 0.29 missed that /clock tick and the simulator, at
    # rtf 0 waiting for the navigator, sat out its wait; to the nearest ns every step is exact
    assert all(convert.stamp(k * 0.01).to_nsec() == k * 10_000_000 for k in range(100_000))
    assert convert.stamp(2.4).to_nsec() == 2_400_000_000


def test_every_sim_time_timer_period_is_whole_clock_periods():
    import yaml
    from turtlebot_recon.paths import SHARE_DIR
    cfg = {name: yaml.safe_load((SHARE_DIR / "config" / f"{name}.yaml").read_text())
           for name in ("sim_bridge", "navigator", "explorer", "mapper", "evaluator", "slam", "tag_tracker",
                        "trajectory")}
    clock_s = 1.0 / cfg["sim_bridge"]["clock_rate_hz"]
    # the periods the nodes give ros/timer.Timer; a sim-time timer fires only on a /clock tick,
    # so a period between ticks would fire late (a 0.05 s one at 0.04 and 0.06 s with 50 Hz)
    periods = {"navigator controller": 1.0 / cfg["navigator"]["controller_rate_hz"],
               "explorer supervisor": 1.0 / cfg["explorer"]["supervisor_rate_hz"],
               "explorer cycle": cfg["explorer"]["cycle_period_s"],
               "mapper": 1.0 / cfg["mapper"]["publish_rate_hz"],
               "evaluator sample": cfg["evaluator"]["sample_period_s"],
               "evaluator ate": cfg["evaluator"]["ate_period_s"],
               "slam tf": 1.0 / cfg["slam"]["tf_rate_hz"],
               "tag_tracker": 1.0 / cfg["tag_tracker"]["publish_rate_hz"],
               "trajectory": 1.0 / cfg["trajectory"]["sample_rate_hz"]}
    for name, period in periods.items():
        ticks = period / clock_s
        assert ticks == pytest.approx(round(ticks)) and round(ticks) >= 1, f"{name}: {period} s"


def test_rtf_0_runs_in_real_time_until_the_first_command_or_its_wall_limit():
    """Standing while the stack starts should cost the sim time it would on a robot: ~45 s of
    sim time at full speed drifted the odometry's heading, and SLAM anchored the map there."""
    pace = StartupPace(rtf=0.0, max_wall_s=20.0, sim_s=0.0, wall_s=100.0)
    assert pace.sleep_s(3.0, 101.0) == 2.0              # 3 s of sim time after 1 s of wall time
    pace.commanded()
    assert pace.sleep_s(40.0, 102.0) == 0.0             # the base was commanded: full speed
    idle = StartupPace(rtf=0.0, max_wall_s=20.0, sim_s=0.0, wall_s=100.0)
    assert idle.sleep_s(19.5, 119.0) == 0.5
    assert idle.sleep_s(30.0, 120.5) == 0.0 and not idle.on   # never commanded: full speed after 20 s
    assert idle.sleep_s(60.0, 121.0) == 0.0
    assert not StartupPace(rtf=2.0, max_wall_s=20.0, sim_s=0.0, wall_s=0.0).on   # rtf > 0 paces itself
    assert not StartupPace(rtf=0.0, max_wall_s=0.0, sim_s=0.0, wall_s=0.0).on
