"""Messages of the explorer and the evaluator <-> core data (no algorithm here).

- ``grid``: nav_msgs/OccupancyGrid -> (int8 (rows, cols), resolution, (x, y) origin), checked.
- ``scan_clearance``: sensor_msgs/LaserScan -> the supervisor's ``scan_clearance`` callable
  (``behavior.ScanClearance``: robot-frame bearing -> free distance for the robot's body, m).
- ``nav_status``: an actionlib terminal state -> the supervisor's navigator status word.
- ``frontier_markers``: frontiers, the chosen goal and the tour -> visualization_msgs/MarkerArray.
- ``pose_stamped``: (x, y, yaw) -> geometry_msgs/PoseStamped.
- ``glimpses``: a TagDetectionArray of unconfirmed tags -> ``perception.tracker.Glimpse``s.
- ``tag_positions``: a TagDetectionArray (/tags) -> (family, id, x, y, z) per tag.
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import Point, PoseStamped, Quaternion
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import LaserScan
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..behavior.scan_clearance import ScanClearance
from ..geometry import cells_to_points
from ..mapping.map_io import check_grid
from ..perception.tracker import Glimpse
from .convert import stamp, yaw_to_quaternion, z_axis_yaw


def grid(m: OccupancyGrid) -> tuple:
    """(occupancy int8 (rows, cols), resolution m, (origin_x, origin_y) m) of a map message;
    row 0 at the origin (the origin's rotation is assumed to be zero, as the mapper writes).
    Subscribe with ``convert.OccupancyGridNumpy`` (data arrives as an array); a plain
    message's tuple works too, ~10 ms slower per 400k cells. A map that cannot be used (empty,
    too large, a resolution that is not positive, data of the wrong length: ``check_grid``)
    raises ValueError, one line, before its data is copied."""
    origin = (m.info.origin.position.x, m.info.origin.position.y)
    check_grid(m.info.height, m.info.width, m.info.resolution, origin, len(m.data))
    occ = np.array(m.data, dtype=np.int8).reshape(m.info.height, m.info.width)   # a writable copy
    return occ, float(m.info.resolution), origin


def scan_clearance(m: LaserScan, half_width_m: float,
                   lidar_xy: Sequence[float] = (0.0, 0.0)) -> ScanClearance:
    """The supervisor's ``scan_clearance`` callable for a scan (``behavior.ScanClearance``)."""
    return ScanClearance(m.ranges, m.angle_min, m.angle_increment, m.range_min, m.range_max,
                         half_width_m, lidar_xy, angle_max=m.angle_max)


def nav_status(state: Optional[int]) -> str:
    """The supervisor's navigator status for an actionlib GoalStatus value (None: no goal)."""
    if state is None:
        return "idle"
    if state in (GoalStatus.PENDING, GoalStatus.ACTIVE, GoalStatus.PREEMPTING,
                 GoalStatus.RECALLING):
        return "active"
    if state == GoalStatus.SUCCEEDED:
        return "succeeded"
    if state in (GoalStatus.ABORTED, GoalStatus.REJECTED):
        return "failed"
    return "idle"                            # PREEMPTED, RECALLED, LOST: nothing pursued


def pose_stamped(x: float, y: float, yaw: Optional[float], frame: str, t_s: float) -> PoseStamped:
    """A PoseStamped at (x, y) facing ``yaw``; ``yaw=None`` leaves the quaternion all zero,
    the navigator's "any final heading" (it skips the final turn)."""
    p = PoseStamped()
    p.header.stamp, p.header.frame_id = stamp(t_s), frame
    p.pose.position.x, p.pose.position.y = float(x), float(y)
    p.pose.orientation = Quaternion(0.0, 0.0, 0.0, 0.0) if yaw is None else yaw_to_quaternion(yaw)
    return p


def glimpses(m) -> tuple:
    """The tag tracker's tags/unconfirmed (pose: the side to look from) as Glimpses, stamped
    with the message's time."""
    t_s = m.header.stamp.to_sec()
    return tuple(Glimpse(d.family, d.id, d.pose.pose.position.x, d.pose.pose.position.y,
                         z_axis_yaw(d.pose.pose.orientation), t_s) for d in m.detections)


def tag_positions(m) -> list:
    """The tags of a TagDetectionArray as (family, id, x, y, z), m in its frame."""
    return [(d.family, d.id, d.pose.pose.position.x, d.pose.pose.position.y, d.pose.pose.position.z)
            for d in m.detections]


# Marker colours (r, g, b, a)
_CLUSTER = (0.1, 0.6, 1.0, 0.9)        # reachable frontier cells
_UNREACHABLE = (0.6, 0.6, 0.6, 0.6)    # frontier cells with no reachable goal
_GOAL = (1.0, 0.55, 0.0, 0.9)          # each cluster's goal
_CHOSEN = (1.0, 0.1, 0.1, 1.0)         # the goal being pursued
_TOUR = (0.2, 0.8, 0.2, 0.9)           # the tour from the robot through the goals


def frontier_markers(frontiers: Sequence, resolution: float, origin: Sequence[float],
                     chosen: Optional[Sequence[float]], tour_xy: Sequence[Sequence[float]],
                     robot_xy: Optional[Sequence[float]], frame: str, t_s: float) -> MarkerArray:
    """``explore/frontiers``: namespace "cells" (a POINTS marker of every frontier cell,
    unreachable clusters grey), "goals" (a SPHERE_LIST of the clusters' goals, the chosen one
    red and larger in "chosen") and "tour" (a LINE_STRIP robot -> tour goals). Every marker is
    re-sent each cycle with a fixed id, so an empty list clears the display."""
    header_stamp = stamp(t_s)

    def marker(ns: str, kind: int, scale: float, colour) -> Marker:
        m = Marker()
        m.header.stamp, m.header.frame_id = header_stamp, frame
        m.ns, m.id, m.type, m.action = ns, 0, kind, Marker.ADD
        m.pose.orientation.w = 1.0
        m.scale.x = m.scale.y = m.scale.z = scale
        m.color = ColorRGBA(*colour)
        return m

    cells = marker("cells", Marker.POINTS, resolution, _CLUSTER)
    goals = marker("goals", Marker.SPHERE_LIST, 0.12, _GOAL)
    for f in frontiers:
        xy = cells_to_points(f.cells, resolution, origin)
        colour = ColorRGBA(*(_CLUSTER if f.reachable else _UNREACHABLE))
        cells.points.extend(Point(float(x), float(y), 0.02) for x, y in xy)
        cells.colors.extend([colour] * len(xy))
        if f.reachable:
            goals.points.append(Point(f.goal[0], f.goal[1], 0.05))
    chosen_m = marker("chosen", Marker.SPHERE_LIST, 0.22, _CHOSEN)
    if chosen is not None:
        chosen_m.points.append(Point(float(chosen[0]), float(chosen[1]), 0.05))
    tour = marker("tour", Marker.LINE_STRIP, 0.03, _TOUR)
    if robot_xy is not None and len(tour_xy):
        tour.points = [Point(float(p[0]), float(p[1]), 0.04) for p in [robot_xy, *tour_xy]]
    out = MarkerArray()
    for m in (cells, goals, chosen_m, tour):
        if not m.points:                     # rviz rejects empty POINTS/LINE markers: delete
            m.action = Marker.DELETE
        out.markers.append(m)
    return out
