#!/usr/bin/env python3
"""rostest node for sim_topics.test."""
import math
import statistics
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, Image, Imu, LaserScan
from std_msgs.msg import UInt32

# topic: (type, expected rate in sim Hz, expected header frame_id)
TOPICS = {
    "/scan": (LaserScan, 5.0, "base_scan"),
    "/odom": (Odometry, 100.0 / 3, "odom"),       # every 3rd 100 Hz physics step (~30 Hz)
    "/imu": (Imu, 50.0, "imu_link"),
    "/camera/image_raw": (Image, 5.0, "camera_optical"),
    "/camera/camera_info": (CameraInfo, 5.0, "camera_optical"),
    "/sim/ground_truth": (Odometry, 10.0, "world"),
    "/clock": (Clock, 20.0, None),                # config/sim_bridge.yaml clock_rate_hz
}


class SimTopics(unittest.TestCase):
    def setUp(self):
        rospy.wait_for_message("/clock", Clock, timeout=60)

    def test_1_topics_rates_frames(self):
        stamps = {t: [] for t in TOPICS}
        frames = {t: set() for t in TOPICS}
        subs = []
        for topic, (cls, _, _) in TOPICS.items():
            def cb(msg, topic=topic):
                if hasattr(msg, "header"):
                    stamps[topic].append(msg.header.stamp.to_sec())
                    frames[topic].add(msg.header.frame_id)
                else:
                    stamps[topic].append(msg.clock.to_sec())
            subs.append(rospy.Subscriber(topic, cls, cb, queue_size=1000))
        t0 = rospy.get_time()
        while rospy.get_time() < t0 + 6.0 and not rospy.is_shutdown():
            rospy.sleep(0.1)
        for s in subs:
            s.unregister()
        for topic, (_, hz, frame) in TOPICS.items():
            s = sorted(stamps[topic])
            self.assertGreater(len(s), 3, f"{topic}: too few messages")
            # the median interval between stamps: robust to a message dropped by a busy subscriber
            rate = 1.0 / statistics.median(b - a for a, b in zip(s, s[1:]))
            self.assertAlmostEqual(rate, hz, delta=0.1 * hz, msg=f"{topic}: {rate:.2f} Hz")
            if frame is not None:
                self.assertEqual(frames[topic], {frame}, topic)
        scan = rospy.wait_for_message("/scan", LaserScan, timeout=10)
        self.assertEqual(len(scan.ranges), 360)
        self.assertAlmostEqual(scan.range_max, 3.5)
        image = rospy.wait_for_message("/camera/image_raw", Image, timeout=10)
        self.assertEqual((image.width, image.height, image.encoding), (640, 480, "rgb8"))
        self.assertEqual(len(image.data), 640 * 480 * 3)
        odom = rospy.wait_for_message("/odom", Odometry, timeout=10)
        self.assertEqual(odom.child_frame_id, "base_footprint")

    def test_2_tf_tree(self):
        buf = tf2_ros.Buffer()
        tf2_ros.TransformListener(buf)
        for parent, child in [("odom", "base_footprint"), ("base_footprint", "base_scan"),
                              ("base_footprint", "camera_link"), ("camera_link", "camera_optical"),
                              ("odom", "camera_optical")]:
            t = buf.lookup_transform(parent, child, rospy.Time(0), rospy.Duration(10.0))
            self.assertEqual(t.child_frame_id, child)

    def test_3_cmd_vel_moves_and_bad_commands_are_ignored(self):
        pub = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
        start = rospy.wait_for_message("/sim/ground_truth", Odometry, timeout=10).pose.pose.position
        bad = Twist()
        bad.linear.x = float("nan")
        t0 = rospy.get_time()
        while rospy.get_time() < t0 + 1.0:      # NaN commands: the robot must not move
            pub.publish(bad)
            rospy.sleep(0.1)
        mid = rospy.wait_for_message("/sim/ground_truth", Odometry, timeout=10).pose.pose.position
        self.assertLess(math.hypot(mid.x - start.x, mid.y - start.y), 1e-6)
        cmd = Twist()
        cmd.linear.x = 0.2
        t0 = rospy.get_time()
        while rospy.get_time() < t0 + 3.0:
            pub.publish(cmd)
            rospy.sleep(0.1)
        end = rospy.wait_for_message("/sim/ground_truth", Odometry, timeout=10).pose.pose.position
        # ~3 s at 0.2 m/s after a short ramp: ~0.55-0.62 m forward along +x
        self.assertGreater(end.x - start.x, 0.45)
        self.assertLess(abs(end.y - start.y), 0.01)
        odom = rospy.wait_for_message("/odom", Odometry, timeout=10).pose.pose.position
        self.assertAlmostEqual(odom.x, end.x - 1.0, delta=0.05)   # odometry agrees (no slip)
        collisions = rospy.wait_for_message("/sim/collisions", UInt32, timeout=10)
        self.assertEqual(collisions.data, 0)


if __name__ == "__main__":
    rospy.init_node("sim_topics_test")
    rostest.rosrun("turtlebot_recon", "sim_topics", SimTopics)
