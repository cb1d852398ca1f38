"""ros.timer: timer callbacks end quietly on shutdown, and only then."""
import pytest
import rospy

from turtlebot_recon.ros import timer


def closed_topic():
    raise rospy.ROSException("publish() to a closed topic")


def test_a_closed_topic_at_shutdown_ends_the_callback_quietly(monkeypatch):
    monkeypatch.setattr(rospy, "is_shutdown", lambda: True)
    assert timer.quiet_on_shutdown(closed_topic)() is None


def test_before_shutdown_it_propagates_and_other_errors_always_do(monkeypatch):
    monkeypatch.setattr(rospy, "is_shutdown", lambda: False)
    with pytest.raises(rospy.ROSException):
        timer.quiet_on_shutdown(closed_topic)()
    monkeypatch.setattr(rospy, "is_shutdown", lambda: True)
    with pytest.raises(ZeroDivisionError):
        timer.quiet_on_shutdown(lambda: 1 / 0)()
    assert timer.quiet_on_shutdown(lambda x: x + 1)(2) == 3
