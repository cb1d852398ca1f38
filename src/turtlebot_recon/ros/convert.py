"""Core data -> ROS messages (and back). The only core module besides scripts/ using rospy."""
from __future__ import annotations

import math

import numpy as np
import rospy
from geometry_msgs.msg import Quaternion, TransformStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from rospy.numpy_msg import numpy_msg
from sensor_msgs.msg import CameraInfo, Image, Imu, LaserScan, PointCloud2, PointField

from scipy.spatial.transform import Rotation

from ..geometry import yaw_from_quaternion
from ..robot import CameraSpec, DepthCameraSpec, LidarSpec


def stamp(t_s: float) -> rospy.Time:
    """rospy.Time to the nearest nanosecond. ``from_sec`` truncates, and 22 % of the simulator's
    0.1 s instants (29 steps of 0.01 s: 0.28999999999999998) came out 1 ns short: /clock then
    never reached a 10 Hz timer's deadline on that tick, the navigator answered one clock tick
    late, and at rtf 0 the simulator, waiting for that answer, sat out its 1 s wall timeout."""
    ns = int(round(t_s * 1e9))
    return rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)


def yaw_to_quaternion(yaw: float) -> Quaternion:
    return Quaternion(0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw))


def quaternion_to_yaw(q) -> float:
    return float(yaw_from_quaternion(q.x, q.y, q.z, q.w))


def transform_matrix(t: TransformStamped) -> np.ndarray:
    """The 4x4 homogeneous matrix of a transform (child frame's pose in the parent)."""
    q, v = t.transform.rotation, t.transform.translation
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    T[:3, 3] = (v.x, v.y, v.z)
    return T


def z_axis_yaw(q) -> float:
    """Heading (rad) of a frame's z axis in its parent, the frame given by quaternion ``q``: a
    camera optical frame's line of sight, a marker's outward normal (REP-103 optical / tag
    frames, whose z is not vertical)."""
    return math.atan2(2.0 * (q.y * q.z - q.w * q.x), 2.0 * (q.x * q.z + q.w * q.y))


def transform(parent: str, child: str, t_s: float, x: float, y: float, z: float = 0.0,
              yaw: float = 0.0, quat=None) -> TransformStamped:
    m = TransformStamped()
    m.header.stamp, m.header.frame_id, m.child_frame_id = stamp(t_s), parent, child
    m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = x, y, z
    m.transform.rotation = Quaternion(*quat) if quat is not None else yaw_to_quaternion(yaw)
    return m


def laser_scan(ranges: np.ndarray, spec: LidarSpec, t_s: float) -> LaserScan:
    m = LaserScan()
    m.header.stamp, m.header.frame_id = stamp(t_s), spec.frame_id
    m.angle_min, m.angle_max = spec.angle_min_rad, spec.angle_max_rad
    m.angle_increment = spec.angle_increment_rad
    m.scan_time = 1.0 / spec.rate_hz
    m.time_increment = m.scan_time / spec.beams
    m.range_min, m.range_max = spec.range_min_m, spec.range_max_m
    m.ranges = ranges.astype(np.float32).tolist()
    return m


def odometry(t_s: float, frame: str, child: str, x: float, y: float, yaw: float,
             v: float, w: float, pose_var=(1e-3, 1e-3, 1e-3), twist_var=(1e-3, 1e-3)) -> Odometry:
    m = Odometry()
    m.header.stamp, m.header.frame_id, m.child_frame_id = stamp(t_s), frame, child
    m.pose.pose.position.x, m.pose.pose.position.y = x, y
    m.pose.pose.orientation = yaw_to_quaternion(yaw)
    cov = [0.0] * 36
    cov[0], cov[7], cov[35] = pose_var
    cov[14] = cov[21] = cov[28] = 1e6          # z, roll, pitch are not estimated
    m.pose.covariance = cov
    tcov = [0.0] * 36
    tcov[0], tcov[35] = twist_var
    tcov[7] = tcov[14] = tcov[21] = tcov[28] = 1e6
    m.twist.covariance = tcov
    m.twist.twist.linear.x, m.twist.twist.angular.z = v, w
    return m


def imu(t_s: float, frame: str, yaw: float, yaw_rate: float, accel_x: float, accel_y: float,
        gyro_var: float) -> Imu:
    m = Imu()
    m.header.stamp, m.header.frame_id = stamp(t_s), frame
    m.orientation = yaw_to_quaternion(yaw)
    m.orientation_covariance = [1e6, 0, 0, 0, 1e6, 0, 0, 0, 1e-2]
    m.angular_velocity.z = yaw_rate
    m.angular_velocity_covariance = [gyro_var, 0, 0, 0, gyro_var, 0, 0, 0, gyro_var]
    m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z = accel_x, accel_y, 9.80665
    m.linear_acceleration_covariance = [1e-2, 0, 0, 0, 1e-2, 0, 0, 0, 1e-2]
    return m


def image_rgb8(rgb: np.ndarray, frame: str, t_s: float) -> Image:
    """sensor_msgs/Image from an (H, W, 3) uint8 array, without cv_bridge."""
    m = Image()
    m.header.stamp, m.header.frame_id = stamp(t_s), frame
    m.height, m.width = rgb.shape[:2]
    m.encoding, m.is_bigendian, m.step = "rgb8", 0, 3 * rgb.shape[1]
    m.data = np.ascontiguousarray(rgb, dtype=np.uint8).tobytes()
    return m


def image_32fc1(depth_m: np.ndarray, frame: str, t_s: float) -> Image:
    """sensor_msgs/Image 32FC1 (REP 118: metres, NaN where nothing returns) from an (H, W) array."""
    m = Image()
    m.header.stamp, m.header.frame_id = stamp(t_s), frame
    m.height, m.width = depth_m.shape
    m.encoding, m.is_bigendian, m.step = "32FC1", 0, 4 * depth_m.shape[1]
    m.data = np.ascontiguousarray(depth_m, dtype="<f4").tobytes()
    return m


def point_cloud_xyz(points: np.ndarray, rows: int, cols: int, frame: str, t_s: float) -> PointCloud2:
    """An organised sensor_msgs/PointCloud2 (``rows`` x ``cols``, fields x, y, z float32) from
    (rows * cols, 3) points in image order; NaN points (no return) stay, so is_dense is false."""
    m = PointCloud2()
    m.header.stamp, m.header.frame_id = stamp(t_s), frame
    m.height, m.width = rows, cols
    m.fields = [PointField(name, 4 * i, PointField.FLOAT32, 1) for i, name in enumerate("xyz")]
    m.is_bigendian, m.point_step, m.row_step, m.is_dense = False, 12, 12 * cols, False
    m.data = np.ascontiguousarray(points, dtype="<f4").reshape(rows * cols, 3).tobytes()
    return m


def camera_info(spec: CameraSpec | DepthCameraSpec, k: np.ndarray, t_s: float) -> CameraInfo:
    """CameraInfo of an undistorted pinhole camera (K, its size and optical frame from ``spec``)."""
    m = CameraInfo()
    m.header.stamp, m.header.frame_id = stamp(t_s), spec.optical_frame_id
    m.width, m.height = spec.width_px, spec.height_px
    m.distortion_model, m.D = "plumb_bob", [0.0] * 5
    m.K = k.reshape(-1).tolist()
    m.R = [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0]
    m.P = [k[0, 0], 0.0, k[0, 2], 0.0, 0.0, k[1, 1], k[1, 2], 0.0, 0.0, 0.0, 1.0, 0.0]
    return m


def become_clock_source() -> None:
    """Make this node the source of sim time instead of a subscriber to /clock.

    With /use_sim_time set, rospy subscribes every node to /clock; the node that publishes
    /clock would then receive each of its own ticks over TCP (100 per sim second), which costs
    more than the physics. The simulator instead sets rospy's time directly with ``set_now``.
    """
    from rospy.impl import simtime
    sub = getattr(simtime, "_clock_sub", None)
    if sub is not None:
        sub.unregister()
        simtime._clock_sub = None


def set_now(t_s: float) -> None:
    """rospy's notion of 'now' for a node that is the clock source (see become_clock_source)."""
    from rospy.rostime import _set_rostime
    _set_rostime(stamp(t_s))


# nav_msgs/OccupancyGrid whose data (de)serialises straight from / into a numpy int8 array
# (rospy.numpy_msg; the same bytes on the wire). With the plain class a 774 x 537 map costs
# ~20 ms of Python list handling per publish and per subscriber, and the mapper publishes
# every sim second (ten times a wall second at 10x real time); this way ~0.1 ms. Publish
# and subscribe /map and /visit_map with it.
# Debian's generated serialize_numpy calls ndarray.tostring(), which NumPy 2.3 removes:
# tools/requirements.txt pins numpy 2.2 (test/unit/test_ros_grid.py would fail first).
OccupancyGridNumpy = numpy_msg(OccupancyGrid)


def occupancy_grid(values: np.ndarray, resolution: float, origin_xy: tuple, frame: str,
                   t_s: float) -> OccupancyGrid:
    """nav_msgs/OccupancyGrid (an ``OccupancyGridNumpy``) from an int8 (rows, cols) grid,
    row 0 at the origin."""
    m = OccupancyGridNumpy()
    m.header.stamp, m.header.frame_id = stamp(t_s), frame
    m.info.map_load_time = m.header.stamp
    m.info.resolution = resolution
    m.info.height, m.info.width = values.shape
    m.info.origin.position.x, m.info.origin.position.y = origin_xy
    m.info.origin.orientation.w = 1.0
    m.data = np.ascontiguousarray(values, dtype=np.int8).ravel()
    return m


def scan_data(m: LaserScan):
    """The core's Scan from a sensor_msgs/LaserScan."""
    from ..mapping.mapper import Scan
    return Scan(ranges=np.asarray(m.ranges, dtype=np.float32), angle_min=m.angle_min,
                angle_max=m.angle_max, angle_increment=m.angle_increment, range_min=m.range_min,
                range_max=m.range_max, stamp_s=m.header.stamp.to_sec())


def pose2d(t: TransformStamped) -> tuple:
    """(x, y, yaw) of a transform, dropping z, roll and pitch."""
    tr = t.transform.translation
    return tr.x, tr.y, quaternion_to_yaw(t.transform.rotation)
