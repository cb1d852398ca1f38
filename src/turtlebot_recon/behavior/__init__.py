"""Behaviour: the supervisor state machine, its recovery geometry and the scan clearance it reads
(ROS-free, never blocking)."""
from .recovery import (CENTRE, LEFT, RIGHT, Candidate, StuckWatchdog, choose_nudge,
                       most_open_bearing, obstacle_side, ring_candidates, turn_away_rad)
from .scan_clearance import ScanClearance
from .supervisor import (BUMPER_BACKOFF, DONE, DRIFT, EXPLORE, LADDER, NUDGE, RETURN_HOME, SPIN,
                         STATES, Command, Inputs, Supervisor, SupervisorSettings)

__all__ = [
    "CENTRE", "LEFT", "RIGHT", "Candidate", "StuckWatchdog", "choose_nudge", "most_open_bearing",
    "obstacle_side", "ring_candidates", "turn_away_rad", "ScanClearance",
    "BUMPER_BACKOFF", "DONE", "DRIFT", "EXPLORE", "LADDER", "NUDGE", "RETURN_HOME", "SPIN", "STATES",
    "Command", "Inputs", "Supervisor", "SupervisorSettings",
]
