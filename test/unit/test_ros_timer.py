"""ros.timer: timer callbacks end quietly on shutdown, and only then."""
import pytest
import rospy
import rospy.core

from turtlebot_recon.ros import timer


def closed_topic():
    raise rospy.ROSException("publish() to a closed topic")


def test_a_closed_topic_at_shutdown_ends_the_callback_quietly(monkeypatch):
    monkeypatch.setattr(rospy.core, "_shutdown_flag", True)
    assert timer.quiet_on_shutdown(closed_topic)() is None


def test_topics_closed_before_is_shutdown_turns_true_end_it_quietly_too(monkeypatch):
    # rospy's signal_shutdown closes the topics (client hooks) with only _in_shutdown set;
    # is_shutdown() is still false then (a navigator traceback at the end of a run, once)
    monkeypatch.setattr(rospy.core, "_in_shutdown", True)
    assert not rospy.is_shutdown()
    assert timer.quiet_on_shutdown(closed_topic)() is None


def test_before_shutdown_it_propagates_and_other_errors_always_do(monkeypatch):
    with pytest.raises(rospy.ROSException):
        timer.quiet_on_shutdown(closed_topic)()
    monkeypatch.setattr(rospy.core, "_shutdown_flag", True)
    with pytest.raises(ZeroDivisionError):
        timer.quiet_on_shutdown(lambda: 1 / 0)()
    assert timer.quiet_on_shutdown(lambda x: x + 1)(2) == 3


def set_sim_time(t: float) -> None:
    """What rospy's /clock subscriber does with each message."""
    rospy.rostime._set_rostime(rospy.Time.from_sec(t))
    cond = rospy.rostime.get_rostime_cond()
    with cond:
        cond.notify_all()


def test_sim_time_jumping_back_does_not_end_the_timer(monkeypatch):
    """docs/faults.md, clock_jump: rospy's own timer thread raised ROSTimeMovedBackwardsException
    and ended (the node lived on, its loop dead: the run hung). Ours restarts its period."""
    import time
    monkeypatch.setattr(rospy.rostime, "_rostime_current", None)
    monkeypatch.setattr(rospy.rostime, "_rostime_initialized", True)
    set_sim_time(100.0)
    calls = []
    t = timer.Timer(0.1, lambda event: calls.append(rospy.get_time()))
    try:
        for now in [100.0 + 0.05 * i for i in range(1, 21)] + [95.0] + [95.0 + 0.05 * i for i in range(1, 21)]:
            set_sim_time(now)
            time.sleep(0.01)
        after_jump = [c for c in calls if c < 99.0]
        assert t.is_alive(), "the timer's thread ended at the jump"
        assert len(after_jump) >= 5, calls        # 1 s of sim time at 10 Hz after the jump back
    finally:
        t.shutdown()
        set_sim_time(200.0)                       # wake its thread, which then ends
        t.join(timeout=2.0)


def test_a_cycle_in_which_sim_time_jumped_back_is_skipped_not_fatal():
    """A sleep inside the callback (tf2's lookup with a timeout) raises when sim time goes back;
    raised out of the callback it ended rospy's timer thread (the evaluator's ATE samples, once)."""
    def lookup_across_the_jump():
        raise rospy.exceptions.ROSTimeMovedBackwardsException(5.0)
    assert timer.quiet_on_shutdown(lookup_across_the_jump)() is None
