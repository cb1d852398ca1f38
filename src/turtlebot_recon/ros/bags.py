"""rosbag <-> the log records of ``slam.logs``: the bag reader and writer behind ``make
slam-log`` and the simulator's recorded runs (the ROS layer: rosbag, genpy and the message
classes stay out of the core).

A bag holds ``/scan`` (sensor_msgs/LaserScan), ``/odom`` (nav_msgs/Odometry), optionally
``/imu`` (sensor_msgs/Imu: yaw rate) and ``/tags/detections`` (turtlebot_recon/
TagDetectionArray, kept as the message in a ``TagRecord``).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Iterable, Iterator, Optional, Union

import genpy
import numpy as np
import rosbag
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu, LaserScan

from ..geometry import yaw_from_quaternion
from ..slam.logs import (CarmenReader, ImuRecord, LaserRecord, LogError, LogStats, OdomRecord, Record,
                         TagRecord, TimeJump, in_stamp_order)


class BagReader:
    """Records of a rosbag in header-stamp order, with TimeJump where time went back.

    Messages are read in the bag's (recording) order and merged by header stamp
    (``slam.logs.in_stamp_order``: every topic but the tags is continuous; ``max_lag_s``,
    ``jump_back_s`` as there). A zero header stamp takes the bag's time. ``imu_topic`` /
    ``tags_topic`` may be None or absent from the bag."""

    EXPECTED = {"scan": "sensor_msgs/LaserScan", "odom": "nav_msgs/Odometry",
                "imu": "sensor_msgs/Imu", "tags": "turtlebot_recon/TagDetectionArray"}

    def __init__(self, path: Union[str, Path], scan_topic: str = "/scan", odom_topic: str = "/odom",
                 imu_topic: Optional[str] = "/imu", tags_topic: Optional[str] = "/tags/detections",
                 max_lag_s: float = 5.0, jump_back_s: float = 1.0):
        self.path = Path(path)
        if not self.path.is_file():
            raise LogError(f"{self.path}: no such file")
        try:
            with rosbag.Bag(str(self.path)) as bag:
                types = {t: i.msg_type for t, i in bag.get_type_and_topic_info().topics.items()}
        except rosbag.ROSBagUnindexedException:
            raise LogError(f"{self.path}: not indexed, a recording cut short: `rosbag reindex {self.path}` "
                           "recovers its complete chunks") from None
        except Exception as e:   # ROSBagException, ROSBagFormatException, struct errors...
            raise LogError(f"{self.path}: not a readable rosbag ({type(e).__name__}: {e})") from None
        wanted = {"scan": scan_topic, "odom": odom_topic, "imu": imu_topic, "tags": tags_topic}
        if scan_topic not in types:
            raise LogError(f"{self.path}: no {scan_topic} in the bag (topics: {', '.join(sorted(types)) or 'none'})")
        self.topics = {}
        for kind, topic in wanted.items():
            if topic is None or topic not in types:
                continue
            if types[topic] != self.EXPECTED[kind]:
                raise LogError(f"{self.path}: {topic} is {types[topic]}, expected {self.EXPECTED[kind]}")
            self.topics[topic] = kind
        self.max_lag_s, self.jump_back_s = max_lag_s, jump_back_s
        self.stats = LogStats(self.path.name)

    def summary(self) -> str:
        return self.stats.summary()

    def __iter__(self) -> Iterator[Record]:
        self.stats = LogStats(self.path.name)
        continuous = [topic for topic, kind in self.topics.items() if kind != "tags"]
        with rosbag.Bag(str(self.path)) as bag:
            stamped = ((topic, self._convert(topic, msg, t.to_sec()))
                       for topic, msg, t in bag.read_messages(topics=list(self.topics)))
            for rec in in_stamp_order(((topic, r) for topic, r in stamped if r is not None), continuous,
                                      self.stats, self.max_lag_s, self.jump_back_s):
                self.stats.kept[type(rec).__name__] += 1
                yield rec

    def _convert(self, topic: str, msg, bag_s: float) -> Optional[Record]:
        kind = self.topics[topic]
        stamp = msg.header.stamp.to_sec()
        if stamp == 0.0:
            self.stats.ignored["zero stamps (bag time used)"] += 1
            stamp = bag_s
        if kind == "scan":
            values = (msg.angle_min, msg.angle_increment, msg.range_min, msg.range_max)
            if not all(math.isfinite(v) for v in values) or msg.angle_increment == 0.0:
                self.stats.skip("bad scan", f"{topic} at {stamp:.3f} s", f"geometry {values}")
                return None
            return LaserRecord(stamp, np.asarray(msg.ranges, dtype=np.float32), *values)
        if kind == "odom":
            p, tw = msg.pose.pose, msg.twist.twist
            q = p.orientation
            vals = (p.position.x, p.position.y, float(yaw_from_quaternion(q.x, q.y, q.z, q.w)), tw.linear.x,
                    tw.angular.z)
            if not all(math.isfinite(v) for v in vals):
                self.stats.skip("non-finite odometry", f"{topic} at {stamp:.3f} s", f"{vals}")
                return None
            return OdomRecord(stamp, *vals)
        if kind == "imu":
            w = msg.angular_velocity.z
            if not math.isfinite(w):
                self.stats.skip("non-finite imu", f"{topic} at {stamp:.3f} s", f"yaw rate {w}")
                return None
            return ImuRecord(stamp, w)
        return TagRecord(stamp, msg)


def _ros_time(stamp_s: float) -> genpy.Time:
    """genpy.Time to the nearest nanosecond (``from_sec`` truncates: 2.4 s would read 2.399999999)."""
    ns = int(round(stamp_s * 1e9))
    return genpy.Time(ns // 1_000_000_000, ns % 1_000_000_000)


def write_rosbag(path: Union[str, Path], records: Iterable[Record], scan_topic: str = "/scan",
                 odom_topic: str = "/odom", imu_topic: str = "/imu", tags_topic: str = "/tags/detections",
                 scan_frame: str = "base_scan", odom_frame: str = "odom",
                 base_frame: str = "base_footprint", imu_frame: str = "imu_link") -> int:
    """Write the records as ROS messages, header stamp = the record's stamp; returns the
    messages written. The bag's time is the stamp too, but a microsecond after the previous
    message's when the stamp is not later (a recorder's clock does not go back): the bag reads
    back in the written order, and a stream whose stamps go back with a TimeJump. TimeJump records
    are not written (the stamps show the jump)."""
    count, bag_t = 0, -math.inf
    with rosbag.Bag(str(path), "w") as bag:
        for rec in records:
            if isinstance(rec, TimeJump):
                continue
            stamp = _ros_time(rec.stamp_s)
            if isinstance(rec, LaserRecord):
                topic, msg = scan_topic, LaserScan()
                msg.header.frame_id = scan_frame
                n = len(rec.ranges)
                msg.angle_min, msg.angle_increment = rec.angle_min, rec.angle_increment
                msg.angle_max = rec.angle_min + (n - 1) * rec.angle_increment
                msg.range_min, msg.range_max = rec.range_min, rec.range_max
                msg.ranges = np.asarray(rec.ranges, dtype=np.float32).tolist()
            elif isinstance(rec, OdomRecord):
                topic, msg = odom_topic, Odometry()
                msg.header.frame_id, msg.child_frame_id = odom_frame, base_frame
                msg.pose.pose.position.x, msg.pose.pose.position.y = rec.x, rec.y
                o = msg.pose.pose.orientation
                o.z, o.w = math.sin(0.5 * rec.yaw), math.cos(0.5 * rec.yaw)
                msg.twist.twist.linear.x, msg.twist.twist.angular.z = rec.v, rec.w
            elif isinstance(rec, ImuRecord):
                topic, msg = imu_topic, Imu()
                msg.header.frame_id = imu_frame
                msg.orientation_covariance[0] = -1.0     # REP 145: no orientation estimate
                msg.angular_velocity.z = rec.yaw_rate
            elif isinstance(rec, TagRecord):
                topic, msg = tags_topic, rec.msg
            else:
                raise TypeError(f"write_rosbag: no message for {type(rec).__name__}")
            if not isinstance(rec, TagRecord):
                msg.header.stamp = stamp
            bag_t = rec.stamp_s if rec.stamp_s > bag_t else bag_t + 1e-6   # keeps the written order
            bag.write(topic, msg, t=_ros_time(bag_t))
            count += 1
    return count


def read_log(path: Union[str, Path], **topics) -> Union[CarmenReader, BagReader]:
    """A reader for ``path``: a rosbag by its ``.bag`` suffix (``topics``: BagReader's), else a
    CARMEN log."""
    return BagReader(path, **topics) if Path(path).suffix == ".bag" else CarmenReader(path)
