"""std_srvs/Trigger calls between nodes: the saves at the end of a run."""
from __future__ import annotations

from typing import Optional

import rospy
from std_srvs.srv import Trigger


def trigger(name: str, timeout_s: float, caller: str, server: str) -> Optional[str]:
    """Call the Trigger service ``name``, waiting up to ``timeout_s`` for it: its message on
    success; else None after one warning line (``caller``: the node, ``server``: the node that
    serves it, named in the line)."""
    try:
        rospy.wait_for_service(name, timeout=timeout_s)
        answer = rospy.ServiceProxy(name, Trigger)()
    except (rospy.ROSException, rospy.ServiceException) as exc:
        rospy.logwarn("%s: no answer from %s (is the %s running?): %s", caller, rospy.resolve_name(name),
                      server, exc)
        return None
    if not answer.success:
        rospy.logwarn("%s: %s failed: %s", caller, rospy.resolve_name(name), answer.message)
        return None
    return answer.message
