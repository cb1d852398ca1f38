"""ros.frame_poses.lookup_at: a transform TF has not yet reached is waited for; one TF will never
give (a stamp older than it holds, a frame it does not have) is refused at once."""
import threading
import time

import pytest
import rospy
import rospy.rostime
import tf2_ros

from turtlebot_recon.ros import convert
from turtlebot_recon.ros.frame_poses import LOOKUP_ERRORS, lookup_at


@pytest.fixture
def tf(monkeypatch):
    """A TF buffer holding map <- laser at 10, 11 and 12 s (x = the stamp), on the wall clock."""
    monkeypatch.setattr(rospy.rostime, "_rostime_initialized", True)
    monkeypatch.setattr(rospy.rostime, "_rostime_current", None)   # the wall clock
    buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0), debug=False)
    for t in (10.0, 11.0, 12.0):
        buffer.set_transform(convert.transform("map", "laser", t, t, 0.0), "test")
    return buffer


def timed(fn):
    t0 = time.monotonic()
    try:
        return fn(), time.monotonic() - t0
    except tf2_ros.TransformException as exc:
        return exc, time.monotonic() - t0


def test_a_stamp_inside_what_tf_holds_is_answered_at_once(tf):
    out, wall = timed(lambda: lookup_at(tf, "map", "laser", rospy.Time(11.5), 5.0))
    assert out.transform.translation.x == pytest.approx(11.5) and wall < 0.5


def test_a_stamp_tf_has_not_reached_yet_is_waited_for(tf):
    later = threading.Timer(0.2, lambda: tf.set_transform(convert.transform("map", "laser", 13.0, 13.0, 0.0), "test"))
    later.start()
    out, wall = timed(lambda: lookup_at(tf, "map", "laser", rospy.Time(12.5), 5.0))
    later.join()
    assert out.transform.translation.x == pytest.approx(12.5) and 0.15 < wall < 2.0


def test_a_stamp_tf_never_reaches_is_refused_after_the_timeout(tf):
    out, wall = timed(lambda: lookup_at(tf, "map", "laser", rospy.Time(12.5), 0.3))
    assert isinstance(out, tf2_ros.ExtrapolationException) and 0.25 < wall < 2.0


@pytest.mark.parametrize("frame, stamp, error", [
    ("laser", 5.0, tf2_ros.ExtrapolationException),     # older than TF holds: no wait brings it
    ("nowhere", 11.0, tf2_ros.LookupException),         # a frame TF does not have
])
def test_what_no_wait_brings_is_refused_at_once(tf, frame, stamp, error):
    out, wall = timed(lambda: lookup_at(tf, "map", frame, rospy.Time(stamp), 5.0))
    assert isinstance(out, error) and wall < 0.5


def test_a_clock_jumping_back_during_the_wait_raises_one_of_lookup_errors(tf, monkeypatch):
    # sim time at 12 s; TF lags the stamp, so lookup_at waits; the clock jumps back to 5 s (a bag
    # looping): rospy's wait raises, and the nodes catch it as one of LOOKUP_ERRORS
    monkeypatch.setattr(rospy.rostime, "_rostime_current", rospy.Time(12.0))
    jump = threading.Timer(0.2, lambda: rospy.rostime._set_rostime(rospy.Time(5.0)))
    jump.start()
    with pytest.raises(LOOKUP_ERRORS) as err:
        lookup_at(tf, "map", "laser", rospy.Time(12.5), 5.0)
    jump.join()
    assert isinstance(err.value, rospy.exceptions.ROSTimeMovedBackwardsException)
