"""The scripted wander of `make wander` (node ``scripted_drive``): a reactive drive on the scan
that maps a world without exploration logic, for the simulator and the mapper on their own.

It drives forward, steers toward the more open side and turns in place while the front is
blocked. Parameters: config/scripted_drive.yaml.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

import numpy as np

from ..config import positive, require
from ..geometry import wrap_angle

FRONT_RAD = (-0.6, 0.6)       # bearings (robot frame, + left) of the front sector
LEFT_RAD = (0.3, 1.3)
RIGHT_RAD = (-1.3, -0.3)
SLOW_FROM_M = 0.2             # forward speed is 0 with the nearest front return this near ...
SLOW_SPAN_M = 0.8             # ... and full this much further out
STEER_SHARE = 0.6             # of angular_radps, steering while driving (tanh of left - right)


@dataclass(frozen=True)
class WanderSettings:
    """config/scripted_drive.yaml."""
    linear_mps: float = 0.2       # cruise speed
    angular_radps: float = 1.0    # turn rate in place
    clearance_m: float = 0.55     # front sector closer than this: turn in place
    duration_s: float = 0.0       # s (sim) from the first tick, then stop and report; 0 = run until stopped
    output_dir: str = ""          # run directory for map.pgm/map.yaml and report.json ('' = none)

    def validate(self, src: str) -> None:
        positive(src, self, "linear_mps", "angular_radps", "clearance_m")
        require(math.isfinite(self.duration_s) and self.duration_s >= 0, src, "duration_s", "must be >= 0 (0: no end)")


def sectors(ranges: np.ndarray, angle_min: float, angle_increment: float, range_min: float,
            range_max: float) -> Tuple[float, float, float]:
    """Nearest return (m) in the front, left and right sectors; a beam without a valid return
    (0.0, inf, NaN, out of range) shows nothing within range_max, as does an empty sector."""
    r = np.asarray(ranges, dtype=float)
    a = wrap_angle(angle_min + angle_increment * np.arange(r.size))   # works on arrays too
    ok = np.isfinite(r) & (r >= range_min) & (r <= range_max)
    r = np.where(ok, r, range_max)

    def nearest(lo: float, hi: float) -> float:
        sel = (a >= lo) & (a <= hi)
        return float(r[sel].min()) if sel.any() else float(range_max)

    return nearest(*FRONT_RAD), nearest(*LEFT_RAD), nearest(*RIGHT_RAD)


def command(front_m: float, left_m: float, right_m: float, turn_dir: float,
            s: WanderSettings) -> Tuple[float, float, float]:
    """(linear m/s, angular rad/s, turn direction to keep) for the nearest returns of the three
    sectors. Blocked ahead: turn in place the way it last steered (+1 left, -1 right)."""
    if front_m < s.clearance_m:
        return 0.0, s.angular_radps * turn_dir, turn_dir
    turn_dir = 1.0 if left_m >= right_m else -1.0
    linear = s.linear_mps * min(1.0, (front_m - SLOW_FROM_M) / SLOW_SPAN_M)
    return linear, STEER_SHARE * s.angular_radps * math.tanh(left_m - right_m), turn_dir
