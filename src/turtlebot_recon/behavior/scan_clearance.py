"""Free distance along a bearing for the robot's body, from one lidar scan (ROS-free).

``ScanClearance(ranges, angle_min, angle_increment, range_min, range_max, half_width_m,
lidar_xy)`` is the supervisor's ``scan_clearance`` callable: robot-frame bearing (rad, 0
ahead, + left) -> how far (m) the robot could drive straight along it before its body,
``half_width_m`` either side of its centre line, meets a scan return.

A return at (x, y) in the base frame meets the body on a straight drive along bearing b
when its lateral offset from the centre line, ``l = -sin(b) x + cos(b) y``, is within the
half width w and it lies ahead, ``f = cos(b) x + sin(b) y > 0``; the body's front edge (a
semicircle of radius w about the centre) touches it after ``f - sqrt(w^2 - l^2)``. The
clearance is the minimum over those returns, clamped to [0, range_max].
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np


class ScanClearance:
    """``clearance(bearing_rad) -> m`` for one scan (module docstring).

    ranges: (n,) m, beam k at ``angle_min + k * angle_increment`` (rad, lidar frame);
    range_min / range_max: m, the sensor's valid interval; angle_max: rad, the last beam's
    bearing (default angle_min + (n - 1) * angle_increment; a LaserScan carries it);
    half_width_m: m, half the body's width plus any margin; lidar_xy: (x, y) m of the lidar in
    the base frame (it is level and faces forward on every TurtleBot).

    A beam without a valid return (the driver's 0.0, inf, NaN, or out of [range_min,
    range_max]) shows nothing within range, so a corridor without returns is range_max
    long; a bearing outside the scan's field of view is 0 (unknown is not open).
    """

    def __init__(self, ranges: Sequence[float], angle_min: float, angle_increment: float,
                 range_min: float, range_max: float, half_width_m: float,
                 lidar_xy: Sequence[float] = (0.0, 0.0), angle_max: Optional[float] = None):
        r = np.asarray(ranges, dtype=float).reshape(-1)
        a = angle_min + angle_increment * np.arange(r.size)
        ok = np.isfinite(r) & (r >= range_min) & (r <= range_max)
        self.x = lidar_xy[0] + r[ok] * np.cos(a[ok])
        self.y = lidar_xy[1] + r[ok] * np.sin(a[ok])
        self.half_width_m, self.range_max = float(half_width_m), float(range_max)
        if angle_max is None:
            angle_max = angle_min + angle_increment * max(r.size - 1, 0)
        span = abs(angle_increment) * max(r.size, 1)
        self.full_circle = span >= 2.0 * math.pi - 1e-6
        self.angle_min, self.angle_max = min(angle_min, angle_max), max(angle_min, angle_max)

    def __call__(self, bearing_rad: float) -> float:
        if not self.full_circle:
            b = (bearing_rad - self.angle_min) % (2.0 * math.pi) + self.angle_min
            if b > self.angle_max:
                return 0.0
        c, s = math.cos(bearing_rad), math.sin(bearing_rad)
        forward = c * self.x + s * self.y
        lateral = -s * self.x + c * self.y
        w = self.half_width_m
        hit = (np.abs(lateral) <= w) & (forward > 0.0)
        if not hit.any():
            return self.range_max
        reach = forward[hit] - np.sqrt(w * w - lateral[hit] ** 2)
        return float(max(0.0, min(self.range_max, reach.min())))
