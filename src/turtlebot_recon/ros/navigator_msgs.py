"""Messages of the navigator <-> core data (no algorithm here).

- ``path``: (n, 2) points -> nav_msgs/Path (/plan).
- ``path_poses``: nav_msgs/Path (SLAM's keyframes) -> their stamps and (x, y, yaw) poses.
- ``rollout_markers``: a controller's ``markers()`` (its trajectory and rollouts with their
  scores) -> visualization_msgs/MarkerArray (~controller_markers).
- ``odom_velocity``: nav_msgs/Odometry -> (v, w), refused when not finite.
- ``goal_yaw``: a goal pose's heading, None for an all-zero quaternion ("any final heading").
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np
import rospy
from geometry_msgs.msg import Point, PoseStamped
from nav_msgs.msg import Path
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from .convert import quaternion_to_yaw


def path(xy: np.ndarray, frame: str, stamp: rospy.Time) -> Path:
    """A Path through ``xy`` (m, ``frame``), every pose facing +x."""
    m = Path()
    m.header.stamp, m.header.frame_id = stamp, frame
    for x, y in xy:
        p = PoseStamped()
        p.header = m.header
        p.pose.position.x, p.pose.position.y = x, y
        p.pose.orientation.w = 1.0
        m.poses.append(p)
    return m


def path_poses(m: Path) -> tuple:
    """(stamps s, poses (x, y, yaw)) of a Path's poses: SLAM's keyframes on /slam/path, each
    stamped with its scan's stamp."""
    stamps = [p.header.stamp.to_sec() for p in m.poses]
    poses = [(p.pose.position.x, p.pose.position.y, quaternion_to_yaw(p.pose.orientation)) for p in m.poses]
    return stamps, poses


def odom_velocity(m) -> tuple:
    """(v m/s, w rad/s) of a nav_msgs/Odometry's twist; ValueError (one line) when not finite."""
    v, w = m.twist.twist.linear.x, m.twist.twist.angular.z
    if not (math.isfinite(v) and math.isfinite(w)):
        raise ValueError(f"odometry twist not finite (v {v}, w {w})")
    return v, w


def goal_yaw(q) -> Optional[float]:
    """The heading (rad) of a goal's orientation; None when the quaternion is all zero (or not
    finite): no final heading asked for."""
    yaw = quaternion_to_yaw(q)
    if not math.isfinite(yaw) or (q.w == 0 and q.z == 0):
        return None
    return yaw


def rollout_markers(shown, frame: str, stamp: rospy.Time) -> Optional[MarkerArray]:
    """The chosen trajectory (namespace "trajectory") and the rollouts (namespace "rollouts",
    rejected grey, else red (worst) .. green (best) by score) of a controller's ``markers()``;
    None when both are empty. Each lives 1 s: a step without rollouts (a turn in place) clears them."""
    def marker(ns, kind, scale, rgba):
        m = Marker()
        m.header.stamp, m.header.frame_id = stamp, frame
        m.ns, m.id, m.type, m.action = ns, 0, kind, Marker.ADD
        m.scale.x = scale
        m.pose.orientation.w = 1.0
        m.color = ColorRGBA(*rgba)
        m.lifetime = rospy.Duration(1.0)
        return m
    rollouts = marker("rollouts", Marker.LINE_LIST, 0.005, (1.0, 1.0, 1.0, 0.5))
    for poses, score in zip(shown.rollouts, shown.scores):
        c = ColorRGBA(0.5, 0.5, 0.5, 0.4) if not np.isfinite(score) else \
            ColorRGBA(float(1.0 - score), float(score), 0.2, 0.7)
        for (x0, y0, _), (x1, y1, _) in zip(poses[:-1], poses[1:]):
            rollouts.points += [Point(x0, y0, 0.01), Point(x1, y1, 0.01)]
            rollouts.colors += [c, c]
    chosen = marker("trajectory", Marker.LINE_STRIP, 0.02, (0.1, 0.4, 1.0, 0.9))
    chosen.points = [Point(x, y, 0.02) for x, y, _ in shown.trajectory]
    out = [m for m in (rollouts, chosen) if m.points]
    return MarkerArray(markers=out) if out else None
