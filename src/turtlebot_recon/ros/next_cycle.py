"""Tell the simulator when this node decides next (sim_bridge's CycleSync, rtf 0 only)."""
from __future__ import annotations

import math
from typing import Optional

import rospy
from std_msgs.msg import Time

from . import convert


class NextCycle:
    """``say(due_s)`` after each cycle: the sim time the next one is due, on ``sim/next_cycle``,
    so that the simulator at rtf 0 steps no further than its slack past it until that cycle has
    run (the cycle then costs no sim time, as a control step costs none); ``say(None)`` when
    no cycle is due any more (the run is done). Nothing is sent without a subscriber: on a real
    robot, or at rtf > 0 with nobody listening, this costs nothing."""

    def __init__(self):
        self.pub = rospy.Publisher("sim/next_cycle", Time, queue_size=1)

    def say(self, due_s: Optional[float]) -> None:
        if self.pub.get_num_connections():
            due = 0.0 if due_s is None or not math.isfinite(due_s) else max(due_s, 0.0)
            self.pub.publish(Time(convert.stamp(due)))
