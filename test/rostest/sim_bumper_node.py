#!/usr/bin/env python3
"""rostest node for sim_bumper.test: the east wall of small_room is at x = 3.1 m."""
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt32

from turtlebot_recon.msg import BumperEvent

WALL_X, RADIUS = 3.1, 0.177


class SimBumper(unittest.TestCase):
    def test_drive_into_wall(self):
        events, max_x = [], [0.0]
        rospy.Subscriber("/mobile_base/events/bumper", BumperEvent, events.append)
        rospy.Subscriber("/sim/ground_truth", Odometry,
                         lambda m: max_x.__setitem__(0, max(max_x[0], m.pose.pose.position.x)))
        pub = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
        rospy.wait_for_message("/sim/ground_truth", Odometry, timeout=60)
        cmd = Twist()
        cmd.linear.x = 0.5
        t0 = rospy.get_time()
        while rospy.get_time() < t0 + 8.0:     # 2 m to the wall at up to 0.5 m/s, then push
            pub.publish(cmd)
            rospy.sleep(0.1)
        self.assertTrue(events, "no bumper event")
        self.assertEqual((events[0].bumper, events[0].state), (BumperEvent.CENTER, BumperEvent.PRESSED))
        self.assertLessEqual(max_x[0] + RADIUS, WALL_X + 1e-3)     # never inside the wall
        self.assertGreater(max_x[0] + RADIUS, WALL_X - 0.02)       # but it reached it
        self.assertGreaterEqual(rospy.wait_for_message("/sim/collisions", UInt32, timeout=10).data, 1)
        cmd.linear.x = -0.2
        t0 = rospy.get_time()
        while rospy.get_time() < t0 + 1.0:     # back off: the bumper releases
            pub.publish(cmd)
            rospy.sleep(0.1)
        self.assertEqual((events[-1].bumper, events[-1].state), (BumperEvent.CENTER, BumperEvent.RELEASED))


if __name__ == "__main__":
    rospy.init_node("sim_bumper_test")
    rostest.rosrun("turtlebot_recon", "sim_bumper", SimBumper)
