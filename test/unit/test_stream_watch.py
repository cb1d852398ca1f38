"""The mapper's watch over its streams (mapping/stream_watch.py): scans lost on the way and TF
lagging the scans are said once per episode, with the measured share and lag."""
import math

import pytest

from turtlebot_recon.mapping.stream_watch import (EPISODE_QUIET_S, LINE_MIN_GAP_S, SCAN_LOSS_WINDOW_S,
                                                  TF_LATE_SKIPS, StreamWatch)

SCAN_TIME_S = 0.2                 # a 5 Hz lidar


def feed(watch, t0_s, t1_s, drop_every=0):
    """Scans stamped every SCAN_TIME_S in [t0, t1), every ``drop_every``-th lost; the lines said."""
    lines, n = [], 0
    for k in range(round((t1_s - t0_s) / SCAN_TIME_S)):
        n += 1
        if drop_every and n % drop_every == 0:
            continue
        line = watch.scan(t0_s + k * SCAN_TIME_S, SCAN_TIME_S)
        if line:
            lines.append(line)
    return lines


def test_every_scan_there_is_never_said():
    assert feed(StreamWatch("/scan"), 0.0, 120.0) == []


def test_a_fifth_of_the_scans_lost_is_said_once_with_its_share():
    watch = StreamWatch("/scan")
    lines = feed(watch, 0.0, 120.0, drop_every=5)           # 20 % lost, the whole run
    assert len(lines) == 1, lines                           # one episode: one line
    # 10 s of stamps at 5 Hz: 50 scans due, 10 lost -> 20 %
    assert lines[0].startswith("mapper: 20 % of the scans on /scan missing over the last 10 s (40 of 50 at "
                               "the lidar's 5.0 Hz)"), lines[0]


def test_a_loss_that_dips_under_the_line_for_a_window_is_still_one_episode():
    watch = StreamWatch("/scan")
    assert len(feed(watch, 0.0, 20.0, drop_every=5)) == 1          # 20 %
    assert feed(watch, 20.0, 30.0, drop_every=12) == []            # 8 %: under 10 %, over 5 %
    assert feed(watch, 30.0, 120.0, drop_every=5) == []            # the same episode


def test_a_new_episode_after_a_quiet_spell_is_said_again():
    watch = StreamWatch("/scan")
    assert len(feed(watch, 0.0, 20.0, drop_every=5)) == 1
    assert feed(watch, 20.0, 20.0 + EPISODE_QUIET_S + LINE_MIN_GAP_S) == []       # scans whole again
    assert len(feed(watch, 60.0, 80.0, drop_every=4)) == 1


def test_an_unknown_scan_time_is_not_measured():
    watch = StreamWatch("/scan")
    assert all(watch.scan(t, 0.0) is None for t in (0.0, 5.0, 30.0))


def test_tf_late_is_said_with_its_lag_after_a_few_skips():
    watch = StreamWatch("/scan")
    said = []
    for k in range(20):                 # TF 0.3 s behind: every scan waits 0.2 s in vain
        now = 10.0 + 0.2 * k
        said.append(watch.tf_late(now, now - 0.2, now - 0.3, "odom -> base_scan", 0.2))
    lines = [s for s in said if s]
    assert said[:TF_LATE_SKIPS - 1] == [None] * (TF_LATE_SKIPS - 1) and said[TF_LATE_SKIPS - 1], said
    assert len(lines) == 1, said                                    # one episode: one line
    assert lines[0].startswith("mapper: TF odom -> base_scan lags the scans: its newest transform is 0.30 s "
                               "behind the clock, more than the 0.20 s a scan waits for it"), lines[0]


def test_a_few_late_transforms_on_a_loaded_machine_are_not_said():
    watch = StreamWatch("/scan")       # a fault-free run on 2 busy cores: 7 late in 240 s
    assert all(watch.tf_late(t, t - 0.2, t - 0.42, "odom -> base_scan", 0.2) is None
               for t in (10.0, 10.2, 10.4, 50.0, 90.0, 130.0, 170.0))


def test_a_scan_older_than_the_buffer_is_not_a_late_tf():
    watch = StreamWatch("/scan")
    assert all(watch.tf_late(100.0 + k, 50.0, 99.0 + k, "odom -> base_scan", 0.2) is None for k in range(10))


@pytest.mark.parametrize("stamp", [math.nan, math.inf])
def test_a_scan_with_a_broken_stamp_is_not_counted(stamp):
    watch = StreamWatch("/scan")
    assert watch.scan(stamp, SCAN_TIME_S) is None and watch.last_stamp_s is None


def test_after_a_clock_jump_the_stamps_start_again():
    watch = StreamWatch("/scan")
    feed(watch, 0.0, 5.0)
    watch.restart()
    # stamps from 0 again: not 5 s of scans "lost", not a jump of the stamps
    assert feed(watch, 0.0, SCAN_LOSS_WINDOW_S * 3) == []
