"""Poses of stamped sensor frames from TF, for frames that TF may place only a little later."""
from __future__ import annotations

from collections import deque

import rospy
import tf2_ros

from .convert import z_axis_yaw
from .log import StartGrace

TF_ERRORS = (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException)
# what lookup_at raises: TF's errors, and rospy's when its wait meets the clock jumping back
LOOKUP_ERRORS = (tf2_ros.TransformException, rospy.exceptions.ROSTimeMovedBackwardsException)


def lookup_at(tf: tf2_ros.Buffer, target: str, frame: str, stamp: rospy.Time, timeout_s: float):
    """target <- ``frame`` at ``stamp`` (a TransformStamped), waiting up to ``timeout_s`` only
    while TF has not yet reached the stamp (it lags the sensor data). A stamp older than what TF
    holds, or a frame TF does not have, raises at once: no wait brings those. Raises one of
    LOOKUP_ERRORS."""
    try:
        return tf.lookup_transform(target, frame, stamp)
    except tf2_ros.ExtrapolationException:
        if stamp < tf.lookup_transform(target, frame, rospy.Time(0)).header.stamp:
            raise
    return tf.lookup_transform(target, frame, stamp, rospy.Duration(timeout_s))


class FramePoses:
    """Frames (stamp, frame id) queued as they come (``add``, from a subscriber); ``poses``
    places them in a target frame at their stamps: (x, y, yaw of the frame's z axis: a camera's
    line of sight). A frame TF cannot place yet waits up to ``wait_s`` (sim) and is then skipped
    with a warning (throttled; debug while the node starts: TF's buffer is filling) that starts
    with ``label``."""

    def __init__(self, tf: tf2_ros.Buffer, target_frame: str, wait_s: float, label: str, maxlen: int = 100):
        self.tf, self.target, self.wait_s, self.label = tf, target_frame, wait_s, label
        self.frames = deque(maxlen=maxlen)
        self.grace = StartGrace()

    def add(self, stamp: rospy.Time, frame: str) -> None:
        self.frames.append((stamp, frame))

    def poses(self, now_s: float) -> tuple:
        poses, keep = [], []
        while self.frames:
            stamp, frame = self.frames.popleft()
            try:
                t = self.tf.lookup_transform(self.target, frame, stamp)
            except TF_ERRORS as exc:
                if now_s - stamp.to_sec() < self.wait_s:
                    keep.append((stamp, frame))
                else:
                    self.grace.warn_throttle(10.0, "%s: frame %s at %.2f s skipped: no pose in %s: %s",
                                             self.label, frame, stamp.to_sec(), self.target, exc)
                continue
            p = t.transform.translation
            poses.append((p.x, p.y, z_axis_yaw(t.transform.rotation)))
        self.frames.extendleft(reversed(keep))
        return tuple(poses)
