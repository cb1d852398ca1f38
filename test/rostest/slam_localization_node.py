#!/usr/bin/env python3
"""rostest node for slam_localization.test: compares the localised pose (TF map -> base_footprint)
with /sim/ground_truth while the wander drives (see the .test file), and starts a second slam
node on a missing map to check its one-line error."""
import math
import os
import subprocess
import sys
import time
import unittest

import numpy as np
import rospkg
import rospy
import rostest
import tf2_ros
from nav_msgs.msg import OccupancyGrid, Odometry

from turtlebot_recon.ros import convert


class SlamLocalization(unittest.TestCase):
    def test_1_tracks_the_ground_truth(self):
        grid = rospy.wait_for_message("/map", OccupancyGrid, timeout=60.0)
        self.assertGreater(grid.info.width * grid.info.height, 1000)
        buf = tf2_ros.Buffer()
        tf2_ros.TransformListener(buf)
        errors, yaw_errors, odom_errors = [], [], []
        start = None
        # The wander starts once localisation publishes (its launch-prefix waits for /slam/path,
        # seconds of wall time on a busy machine, while the simulator runs on at rtf 0): the
        # window is the wander's own, from its first motion
        deadline = time.monotonic() + 120.0
        while not rospy.is_shutdown():
            twist = rospy.wait_for_message("/sim/ground_truth", Odometry, timeout=30.0).twist.twist
            if abs(twist.linear.x) > 0.01 or abs(twist.angular.z) > 0.01:
                break
            self.assertLess(time.monotonic(), deadline, "the wander never started")
        end = rospy.get_time() + float(rospy.get_param("~drive_s")) - 10.0   # sim s: it drives until then
        while not rospy.is_shutdown() and rospy.get_time() < end:
            truth = rospy.wait_for_message("/sim/ground_truth", Odometry, timeout=30.0)
            stamp = truth.header.stamp
            try:
                est = buf.lookup_transform("map", "base_footprint", stamp, rospy.Duration(1.0))
                odo = buf.lookup_transform("odom", "base_footprint", stamp, rospy.Duration(0.1))
            except tf2_ros.TransformException:
                continue
            x, y = truth.pose.pose.position.x, truth.pose.pose.position.y
            yaw = convert.quaternion_to_yaw(truth.pose.pose.orientation)
            ex, ey, eyaw = convert.pose2d(est)
            ox, oy, _ = convert.pose2d(odo)
            start = start or (x - ox, y - oy)       # odometry starts at the start pose, unrotated
            errors.append(math.hypot(ex - x, ey - y))
            yaw_errors.append(abs(math.remainder(eyaw - yaw, math.tau)))
            odom_errors.append(math.hypot(ox + start[0] - x, oy + start[1] - y))
            rospy.sleep(1.0)
        self.assertGreater(len(errors), 60)
        rospy.loginfo("slam_localization: error mean %.3f max %.3f m, odometry drift max %.3f m",
                      np.mean(errors), np.max(errors), np.max(odom_errors))
        self.assertLess(np.mean(errors), 0.05, (np.mean(errors), np.max(errors)))
        self.assertLess(np.mean(yaw_errors), 0.05)
        self.assertGreater(np.max(odom_errors), 0.05, np.max(odom_errors))  # the drift is real

    def test_2_a_missing_map_is_one_clear_error(self):
        env = dict(os.environ, ROS_NAMESPACE="/bad_map")
        script = os.path.join(rospkg.RosPack().get_path("turtlebot_recon"), "scripts", "slam")
        proc = subprocess.run([sys.executable, script, "__name:=slam_bad", "_mode:=localization",
                               "_robot:=turtlebot3_burger", "_map_file:=/nonexistent/map.yaml"],
                              env=env, timeout=60, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.assertNotEqual(proc.returncode, 0, proc.stdout)
        self.assertIn("cannot load map_file '/nonexistent/map.yaml'", proc.stdout)
        self.assertNotIn("Traceback", proc.stdout)


if __name__ == "__main__":
    rospy.init_node("slam_localization_test")
    rostest.rosrun("turtlebot_recon", "slam_localization", SlamLocalization)
