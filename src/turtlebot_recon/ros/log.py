"""Log levels for the nodes: the core's lines to rosout, and quiet start-up waits.

Core objects log through ``log(level, msg, *args)`` (``logging.Logger.log``'s signature, Python
levels) so that they stay ROS-free; a node passes ``ros_log``, which keeps each line's level:
per-event lines at DEBUG stay off the console unless the node's logger is set to debug.

A node's inputs (TF, the first map, camera_info, the navigator) arrive a few seconds after it
starts, so a line saying one is still missing is news only when it stays missing: ``StartGrace``
gives such lines DEBUG for ``START_GRACE_WALL_S`` after the node starts and WARN afterwards.
"""
from __future__ import annotations

import logging
import time

import rospy

START_GRACE_WALL_S = 10.0    # s (wall): a whole stack (the simulator's world included) is up by then


def ros_log(level: int, msg: str, *args) -> None:
    """``msg % args`` to rosout at the rospy level matching the Python ``level``."""
    if level >= logging.CRITICAL:
        rospy.logfatal(msg, *args)
    elif level >= logging.ERROR:
        rospy.logerr(msg, *args)
    elif level >= logging.WARNING:
        rospy.logwarn(msg, *args)
    elif level >= logging.INFO:
        rospy.loginfo(msg, *args)
    else:
        rospy.logdebug(msg, *args)


class StartGrace:
    """``warn_throttle`` is ``rospy.logdebug_throttle`` until START_GRACE_WALL_S after this
    object was made, then ``rospy.logwarn_throttle``. Call it on the line that logs
    (``grace.warn_throttle(10.0, msg, *args)``): rospy throttles per calling line."""

    def __init__(self):
        self.until_wall = time.monotonic() + START_GRACE_WALL_S

    @property
    def warn_throttle(self):
        return rospy.logdebug_throttle if time.monotonic() < self.until_wall else rospy.logwarn_throttle
