"""Behaviour: the supervisor state machine and its recovery geometry (ROS-free, never blocking)."""
from .recovery import (CENTRE, LEFT, RIGHT, Candidate, StuckWatchdog, choose_nudge,
                       most_open_bearing, obstacle_side, ring_candidates, turn_away_rad)
from .supervisor import (BUMPER_BACKOFF, DONE, DRIFT, EXPLORE, LADDER, NUDGE, RETURN_HOME, SPIN,
                         STATES, Command, Inputs, Supervisor, SupervisorSettings)

__all__ = [
    "CENTRE", "LEFT", "RIGHT", "Candidate", "StuckWatchdog", "choose_nudge", "most_open_bearing",
    "obstacle_side", "ring_candidates", "turn_away_rad",
    "BUMPER_BACKOFF", "DONE", "DRIFT", "EXPLORE", "LADDER", "NUDGE", "RETURN_HOME", "SPIN", "STATES",
    "Command", "Inputs", "Supervisor", "SupervisorSettings",
]
