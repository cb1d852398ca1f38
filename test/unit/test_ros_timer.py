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
