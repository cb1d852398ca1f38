"""Messages of the slam node <-> core data (no algorithm here).

- ``path``: a ``slam.live.PathUpdate`` -> nav_msgs/Path (/slam/path, each pose at its scan's stamp).
- ``graph_markers``: keyframes, odometry edges and loop closures -> visualization_msgs/MarkerArray.
- ``landmark_array``: the graph's tags -> TagDetectionArray (/slam/landmarks).
- ``landmark_markers``: the graph's tags -> MarkerArray (cylinders and their names).
"""
from __future__ import annotations

import numpy as np
import rospy
from geometry_msgs.msg import Point, PoseStamped
from nav_msgs.msg import Path
from visualization_msgs.msg import Marker, MarkerArray

from ..msg import TagDetection, TagDetectionArray
from .convert import yaw_to_quaternion


def path(update, frame: str, stamp: rospy.Time) -> Path:
    """/slam/path: the update's poses, each stamped with its scan's stamp; the header at ``stamp``."""
    out = Path()
    out.header.stamp, out.header.frame_id = stamp, frame
    for t, (x, y, yaw) in zip(update.stamps, update.poses):
        p = PoseStamped()
        p.header.stamp, p.header.frame_id = rospy.Time.from_sec(t), frame
        p.pose.position.x, p.pose.position.y = x, y
        p.pose.orientation = yaw_to_quaternion(yaw)
        out.poses.append(p)
    return out


def graph_markers(header, poses, loops) -> MarkerArray:
    """Keyframes (spheres), the odometry edges between them and the loop closures (lines)."""
    def marker(ns, kind, rgba, scale):
        m = Marker()
        m.header, m.ns, m.id, m.type, m.action = header, ns, 0, kind, Marker.ADD
        m.scale.x = m.scale.y = m.scale.z = scale
        m.color.r, m.color.g, m.color.b, m.color.a = rgba
        m.pose.orientation.w = 1.0
        return m
    keys = marker("keyframes", Marker.SPHERE_LIST, (0.1, 0.4, 1.0, 0.9), 0.06)
    keys.points = [Point(x, y, 0.02) for x, y, _ in poses]
    odom = marker("odometry edges", Marker.LINE_STRIP, (0.1, 0.4, 1.0, 0.6), 0.015)
    odom.points = keys.points
    closures = marker("loop closures", Marker.LINE_LIST, (1.0, 0.3, 0.1, 0.9), 0.025)
    for i, j in loops:
        closures.points += [Point(poses[i][0], poses[i][1], 0.03), Point(poses[j][0], poses[j][1], 0.03)]
    return MarkerArray(markers=[keys, odom, closures] if closures.points else [keys, odom])


def landmark_array(header, landmarks) -> TagDetectionArray:
    """The tags in the graph (named family:id) at their estimates, with the marginal
    covariance of x, y (z unknown to a 2-D graph: 0, its variance left 0)."""
    out = TagDetectionArray()
    out.header = header
    for name, ((x, y), cov) in sorted(landmarks.items()):
        family, _, tag_id = name.rpartition(":")
        d = TagDetection()
        d.family, d.id = family, int(tag_id)
        d.pose.pose.position.x, d.pose.pose.position.y = float(x), float(y)
        d.pose.pose.orientation.w = 1.0
        c = np.zeros((6, 6))
        c[:2, :2] = np.asarray(cov, float)[:2, :2]
        d.pose.covariance = c.ravel().tolist()
        out.detections.append(d)
    return out


def landmark_markers(header, landmarks) -> MarkerArray:
    """A cylinder and the name of every tag in the graph."""
    out = MarkerArray()
    for i, (name, ((x, y), _)) in enumerate(sorted(landmarks.items())):
        for kind, z, text in ((Marker.CYLINDER, 0.1, ""), (Marker.TEXT_VIEW_FACING, 0.45, name)):
            m = Marker()
            m.header, m.ns, m.id, m.type = header, "slam landmarks", 2 * i + (kind == Marker.TEXT_VIEW_FACING), kind
            m.pose.position.x, m.pose.position.y, m.pose.position.z = x, y, z
            m.pose.orientation.w = 1.0
            m.scale.x = m.scale.y = 0.12
            m.scale.z = 0.2 if kind == Marker.CYLINDER else 0.15
            m.color.r, m.color.g, m.color.b, m.color.a = 0.6, 0.2, 0.9, 0.9
            m.text = text
            out.markers.append(m)
    return out
