"""ScanClearance: free distance along a bearing for the robot's body, from one scan.

Scans are built here from hand-placed returns; every expected distance is worked out in a
comment from the contract in behavior/scan_clearance.py: a return at (x, y) (base frame)
meets a body of half width w driving along bearing b when |l| <= w and f > 0, with
f = cos(b) x + sin(b) y and l = -sin(b) x + cos(b) y, after f - sqrt(w^2 - l^2) metres.
"""
import math

import numpy as np
import pytest

from turtlebot_recon.behavior import ScanClearance

RANGE_MIN, RANGE_MAX = 0.12, 3.5          # LDS-01
N = 360                                   # beams over the full circle, 1 deg apart
ANGLE_MIN, INC = -math.pi, 2.0 * math.pi / N


def beam(deg):
    """Index of the beam at ``deg`` (-180..179) in the 360-beam scan (beam k at -180 + k deg)."""
    return int(deg) + 180


def full_scan(returns=()):
    """A 360-beam scan that sees nothing (inf) but ``returns``: {bearing_deg: range_m}."""
    r = np.full(N, np.inf)
    for deg, rng in dict(returns).items():
        r[beam(deg)] = rng
    return r


def clearance(ranges, half_width_m, lidar_xy=(0.0, 0.0), **scan):
    args = dict(angle_min=ANGLE_MIN, angle_increment=INC, range_min=RANGE_MIN, range_max=RANGE_MAX)
    args.update(scan)
    return ScanClearance(ranges, half_width_m=half_width_m, lidar_xy=lidar_xy, **args)


def corridor_ranges(half_gap_m, end_x_m):
    """Ranges of a lidar at the origin in a corridor: walls y = +-half_gap_m, an end wall at
    x = end_x_m ahead, open behind (beyond range_max there nothing is seen: inf)."""
    a = ANGLE_MIN + INC * np.arange(N)
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore"):
        side = np.where(np.abs(s) > 1e-12, half_gap_m / np.abs(s), np.inf)
        end = np.where(c > 1e-12, end_x_m / c, np.inf)
    r = np.minimum(side, end)
    return np.where(r <= RANGE_MAX, r, np.inf)


# ------------------------------------------------------------------------------ geometry

def test_corridor_ahead_ends_at_the_end_wall_and_the_side_walls_are_near():
    cl = clearance(corridor_ranges(half_gap_m=0.3, end_x_m=2.0), half_width_m=0.2)
    # ahead: the side walls are 0.3 > w = 0.2 off the centre line, so only the end wall at
    # x = 2.0 counts; its nearest return is the one on the centre line (l = 0):
    # 2.0 - sqrt(0.2^2 - 0) = 1.8
    assert cl(0.0) == pytest.approx(1.8, abs=1e-9)
    # left (b = 90 deg): the wall y = 0.3 is ahead (f = y = 0.3); the return at x = 0 (the
    # 90 deg beam, r = 0.3) is on the centre line: 0.3 - 0.2 = 0.1; the same to the right
    assert cl(math.pi / 2) == pytest.approx(0.1, abs=1e-9)
    assert cl(-math.pi / 2) == pytest.approx(0.1, abs=1e-9)
    # behind: open (the side walls are 0.3 off the line, no end wall): range_max
    assert cl(math.pi) == RANGE_MAX


def test_a_return_off_to_the_side_blocks_only_a_body_wide_enough_to_meet_it():
    ranges = full_scan({30: 1.0})          # one return at (cos 30, sin 30) = (0.8660, 0.5)
    # w = 0.4: its lateral offset from the way ahead, 0.5, is beyond the body: open
    assert clearance(ranges, 0.4)(0.0) == RANGE_MAX
    # w = 0.6: 0.5 <= 0.6, so the body's front arc meets it after
    # 0.8660 - sqrt(0.36 - 0.25) = 0.8660 - 0.3317 = 0.5344
    assert clearance(ranges, 0.6)(0.0) == pytest.approx(math.cos(math.radians(30)) - math.sqrt(0.11),
                                                       abs=1e-9)
    assert clearance(ranges, 0.6)(0.0) == pytest.approx(0.5344, abs=1e-4)
    # driving straight at it (b = 30 deg): f = 1.0, l = 0: 1.0 - 0.4 = 0.6
    assert clearance(ranges, 0.4)(math.radians(30)) == pytest.approx(0.6, abs=1e-9)
    # behind the robot (b = -150 deg) it has f = -1 < 0: not in the way
    assert clearance(ranges, 0.6)(math.radians(-150)) == RANGE_MAX


def test_a_return_inside_the_body_clamps_to_zero():
    # a return 0.15 m ahead with w = 0.2: 0.15 - 0.2 < 0 -> 0.0 (already touching)
    assert clearance(full_scan({0: 0.15}), 0.2)(0.0) == 0.0


def test_lidar_offset_places_returns_in_the_base_frame():
    ranges = full_scan({0: 1.0})           # 1.0 m straight ahead of the lidar
    # lidar at the centre: 1.0 - 0.2 = 0.8
    assert clearance(ranges, 0.2)(0.0) == pytest.approx(0.8, abs=1e-9)
    # lidar 0.1 m behind and 0.05 m left of the centre: the return is at (0.9, 0.05) in the
    # base frame: 0.9 - sqrt(0.04 - 0.0025) = 0.9 - 0.19365 = 0.70635
    assert clearance(ranges, 0.2, lidar_xy=(-0.1, 0.05))(0.0) == pytest.approx(
        0.9 - math.sqrt(0.0375), abs=1e-9)
    assert clearance(ranges, 0.2, lidar_xy=(-0.1, 0.05))(0.0) == pytest.approx(0.70635, abs=1e-5)


# ------------------------------------------------------------------ invalid returns, view

@pytest.mark.parametrize("value", [0.0, math.inf, math.nan, 0.05, 5.0],
                         ids=["zero", "inf", "nan", "below_range_min", "above_range_max"])
def test_invalid_returns_show_nothing_within_range(value):
    # a driver's "no return" (0.0, inf, NaN) or a range outside [0.12, 3.5] straight ahead is
    # not an obstacle: the way ahead is range_max long
    ranges = full_scan({0: value})
    assert clearance(ranges, 0.2)(0.0) == RANGE_MAX
    # ... while a valid return in its place would block it: 1.0 - 0.2 = 0.8
    assert clearance(full_scan({0: 1.0}), 0.2)(0.0) == pytest.approx(0.8, abs=1e-9)


def test_valid_returns_at_the_range_limits_count():
    # range_min and range_max themselves are valid: 0.12 - 0.2 < 0 -> 0.0; 3.5 - 0.2 = 3.3
    assert clearance(full_scan({0: RANGE_MIN}), 0.2)(0.0) == 0.0
    assert clearance(full_scan({0: RANGE_MAX}), 0.2)(0.0) == pytest.approx(3.3, abs=1e-9)


def test_limited_field_of_view_is_closed_outside_it():
    # 5 beams at -0.5, -0.25, 0, 0.25, 0.5 rad (a depth camera's narrow scan), none hit
    fov = dict(angle_min=-0.5, angle_increment=0.25, range_max=4.0)
    cl = clearance(np.full(5, np.inf), 0.2, **fov)
    assert cl(0.0) == 4.0 and cl(0.5) == 4.0 and cl(-0.5) == 4.0    # inside: open to range_max
    assert cl(math.pi / 2) == 0.0 and cl(-0.6) == 0.0 and cl(math.pi) == 0.0   # unknown: 0
    assert cl(2.0 * math.pi + 0.2) == 4.0   # 2 pi + 0.2 wraps to 0.2: inside
    # the same view scanned right to left (negative increment) covers the same bearings
    cl = clearance(np.full(5, np.inf), 0.2, **{**fov, "angle_min": 0.5, "angle_increment": -0.25})
    assert cl(0.0) == 4.0 and cl(math.pi / 2) == 0.0
    # a scan's own angle_max, when given, bounds the view: [-0.5, 0.3]
    cl = clearance(np.full(5, np.inf), 0.2, angle_max=0.3, **fov)
    assert cl(0.25) == 4.0 and cl(0.4) == 0.0


def test_full_circle_scan_has_no_closed_bearing():
    cl = clearance(full_scan(), 0.2)
    assert all(cl(b) == RANGE_MAX for b in np.linspace(-math.pi, math.pi, 13))


def test_message_conversion_reads_every_field():
    from sensor_msgs.msg import LaserScan      # ROS messages are part of the build (as test_ros_grid's)
    from turtlebot_recon.ros import explore_msgs
    m = LaserScan(angle_min=-0.5, angle_max=0.5, angle_increment=0.25, range_min=0.12,
                  range_max=4.0, ranges=[math.inf, math.inf, 1.0, math.inf, math.inf])
    cl = explore_msgs.scan_clearance(m, 0.2, (-0.1, 0.0))
    # the return 1.0 ahead of a lidar 0.1 m behind the centre: 0.9 - 0.2 = 0.7; outside the
    # message's view (|b| > 0.5): 0
    assert cl(0.0) == pytest.approx(0.7, abs=1e-6)
    assert cl(1.0) == 0.0
