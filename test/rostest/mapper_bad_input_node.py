#!/usr/bin/env python3
"""rostest node for mapper_bad_input.test (wall time, no simulator)."""
import math
import os
import subprocess
import sys
import unittest

import numpy as np
import rospkg
import rospy
import rostest
import tf2_ros
from nav_msgs.msg import OccupancyGrid
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Trigger

from turtlebot_recon.mapping.map_io import load_map
from turtlebot_recon.ros import convert


def make_scan(ranges, stamp, frame="base_scan", n_header=360):
    m = LaserScan()
    m.header.stamp, m.header.frame_id = stamp, frame
    m.angle_min, m.angle_increment = 0.0, 2 * math.pi / 360
    m.angle_max = m.angle_increment * (n_header - 1)
    m.range_min, m.range_max = 0.12, 3.5
    m.ranges = list(ranges)
    return m


class MapperBadInput(unittest.TestCase):
    def test_bad_scans(self):
        logs = []
        rospy.Subscriber("/rosout", Log, lambda m: logs.append(m.msg) if m.name == "/mapper" else None)
        tf = tf2_ros.TransformBroadcaster()
        pub = rospy.Publisher("/scan", LaserScan, queue_size=10)
        rospy.sleep(1.0)

        def send_tf(_=None):   # the scanner sits at the odom origin, facing +x
            tf.sendTransform(convert.transform("odom", "base_scan", rospy.get_time(), 0.0, 0.0))

        timer = rospy.Timer(rospy.Duration(0.05), send_tf)
        rospy.sleep(1.0)
        now = rospy.Time.now
        good = [1.0] * 360                                      # a round room of radius 1 m
        # one update per cell per scan: p_miss = 0.4 three times gives p = 0.23 <= 0.25, free
        for scan in [make_scan(good, now()),
                     make_scan(good, now()),
                     make_scan([], now()),                       # empty
                     make_scan([1.0] * 100, now()),              # 100 ranges, header says 360
                     make_scan([float("nan")] * 360, now()),     # all NaN: used, every beam skipped
                     make_scan(good, now() - rospy.Duration(100.0)),   # older than the TF buffer
                     make_scan(good, now(), frame="no_such_frame"),
                     make_scan(good, now())]:
            pub.publish(scan)
            rospy.sleep(0.5)
        timer.shutdown()
        saved = rospy.ServiceProxy("/mapper/save_map", Trigger)()
        self.assertTrue(saved.success, saved.message)
        occ, res, origin = load_map(saved.message)
        at = lambda x, y: occ[int(math.floor((y - origin[1]) / res)), int(math.floor((x - origin[0]) / res))]
        self.assertEqual(at(0.5, 0.0), 0)        # free inside the 1 m circle
        self.assertEqual(at(-0.3, 0.4), 0)
        self.assertEqual(at(1.01, 0.0), 100)     # the wall
        self.assertEqual(at(2.0, 0.0), -1)       # unknown beyond it
        rospy.sleep(1.0)
        line = [m for m in logs if "map saved (~save_map)" in m]
        self.assertTrue(line, logs)
        self.assertIn("4 scans inserted", line[-1])
        for reason in ("empty 1", "length_mismatch 1", "scan_tf_extrapolation 1", "scan_no_tf 1", "nan 360"):
            self.assertIn(reason, line[-1])
        m = rospy.wait_for_message("/map", OccupancyGrid, timeout=5)   # still publishing
        data = np.array(m.data)
        self.assertGreater(np.count_nonzero((data >= 0) & (data <= 25)), 1000)   # free: pi m^2 ~ 1250 cells

    def test_a_missing_initial_map_is_one_clear_error(self):
        env = dict(os.environ, ROS_NAMESPACE="/bad_initial_map")
        script = os.path.join(rospkg.RosPack().get_path("turtlebot_recon"), "scripts", "mapper")
        proc = subprocess.run([sys.executable, script, "__name:=mapper_bad", "_robot:=turtlebot3_burger",
                               "_initial_map:=/nonexistent/map.yaml"],
                              env=env, timeout=60, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.assertNotEqual(proc.returncode, 0, proc.stdout)
        self.assertIn("cannot load initial_map '/nonexistent/map.yaml'", proc.stdout)
        self.assertNotIn("Traceback", proc.stdout)


if __name__ == "__main__":
    rospy.init_node("mapper_bad_input_test")
    rostest.rosrun("turtlebot_recon", "mapper_bad_input", MapperBadInput)
