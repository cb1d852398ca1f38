"""rospy.Timer for node loops that may be shut down at any moment.

A run ends when the evaluator says so (a budget, a coverage reached), while the other nodes are
still driving: a timer callback then meets a closed publisher or an interrupted sleep
(``rospy.ROSException``) on its own thread, and rospy prints the traceback and ends that thread.
``Timer`` ends quietly in that case only; any other exception, or one before shutdown, still
propagates (a bug must show).

Sim time that jumps back (a bag played with ``--loop``, a clock source restarted) raised
``ROSTimeMovedBackwardsException`` in rospy's timer thread, which then ended while the node lived
on: every node's loop stopped at once, the evaluator's with it, and the run hung without a line
(make bench-faults' clock_jump, docs/faults.md). ``Timer`` restarts its period from the new time
instead (rospy's ``reset``); the nodes that keep time-stamped state (the mapper's TF buffer, SLAM)
say so themselves.
"""
from __future__ import annotations

from typing import Callable

import rospy


def quiet_on_shutdown(callback: Callable) -> Callable:
    """``callback`` that returns instead of raising rospy.ROSException once ROS is shutting down,
    and skips the cycle in which sim time jumped back (a sleep inside it, e.g. a TF lookup's
    timeout, raises; rospy would end the timer's thread), with a warning."""
    def run(*args, **kwargs):
        try:
            return callback(*args, **kwargs)
        except rospy.exceptions.ROSTimeMovedBackwardsException as exc:
            rospy.logwarn("%s: sim time jumped back %.2f s during a cycle: that cycle skipped",
                          rospy.get_name().lstrip("/"), exc.time)
            return None
        except rospy.ROSException:
            # is_shutdown() turns true only after rospy's client hooks have closed the topics;
            # a publish in between meets a closed topic while is_shutdown() is still false
            if rospy.is_shutdown() or rospy.core.is_shutdown_requested():
                return None
            raise
    return run


def Timer(period_s: float, callback: Callable) -> rospy.Timer:
    """``rospy.Timer(rospy.Duration(period_s), callback)``, quiet on shutdown, and going on
    after sim time jumped back (module docstring)."""
    return rospy.Timer(rospy.Duration(period_s), quiet_on_shutdown(callback), reset=True)
