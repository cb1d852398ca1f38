#!/usr/bin/env python3
"""rostest node for navigator_room.test. small_room: free x in [0.1, 3.1], y in [0.1, 2.1]
(world frame); the robot starts at (1.0, 1.1) facing +x, so the odom/map frame is shifted by
(-1.0, -1.1) from the world."""
import math
import unittest

import actionlib
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid, Odometry, Path
from std_msgs.msg import UInt32

START = (1.0, 1.1)


def goal_pose(x, y):
    p = PoseStamped()
    p.header.frame_id, p.header.stamp = "odom", rospy.Time.now()
    p.pose.position.x, p.pose.position.y = x, y
    p.pose.orientation.w = 1.0
    return p


def goal_cell_free(m, x, y):
    col = int((x - m.info.origin.position.x) / m.info.resolution)
    row = int((y - m.info.origin.position.y) / m.info.resolution)
    inside = 0 <= row < m.info.height and 0 <= col < m.info.width
    return inside and 0 <= m.data[row * m.info.width + col] < 20    # below map_server's free_thresh


def truth_xy():
    p = rospy.wait_for_message("/sim/ground_truth", Odometry, timeout=10).pose.pose.position
    return p.x, p.y


class NavigatorRoom(unittest.TestCase):
    def test_1_action_goal_reached(self):
        client = actionlib.SimpleActionClient("/move_base", MoveBaseAction)
        self.assertTrue(client.wait_for_server(rospy.Duration(60)))
        # Let the mapper see the goal. Known cells alone are not enough: the robot's own body
        # is marked free from odometry before a slow machine's first scan is in (a CI run sent
        # the goal then, into unknown space, and it was rightly refused).
        deadline = rospy.get_time() + 30.0
        while not goal_cell_free(rospy.wait_for_message("/map", OccupancyGrid, timeout=30), 1.5, 0.5):
            self.assertLess(rospy.get_time(), deadline, "the mapper never saw the goal's cell free")
        client.send_goal(MoveBaseGoal(target_pose=goal_pose(1.5, 0.5)))   # world (2.5, 1.6)
        self.assertTrue(client.wait_for_result(rospy.Duration(60)))
        self.assertEqual(client.get_state(), GoalStatus.SUCCEEDED, client.get_goal_status_text())
        x, y = truth_xy()
        self.assertLess(math.hypot(x - 2.5, y - 1.6), 0.15)
        plan = rospy.wait_for_message("/plan", Path, timeout=5)
        self.assertEqual(plan.header.frame_id, "odom")

    def test_2_simple_goal_reached(self):
        pub = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
        rospy.sleep(1.0)
        pub.publish(goal_pose(-0.4, -0.6))                  # world (0.6, 0.5)
        t0 = rospy.get_time()
        while rospy.get_time() < t0 + 60:
            x, y = truth_xy()
            if math.hypot(x - 0.6, y - 0.5) < 0.15:
                break
            rospy.sleep(0.5)
        self.assertLess(math.hypot(x - 0.6, y - 0.5), 0.15)

    def test_3_goal_in_a_wall_is_refused(self):
        client = actionlib.SimpleActionClient("/move_base", MoveBaseAction)
        client.wait_for_server(rospy.Duration(10))
        client.send_goal(MoveBaseGoal(target_pose=goal_pose(5.0, 0.0)))   # world x = 6: outside
        self.assertTrue(client.wait_for_result(rospy.Duration(30)))
        self.assertEqual(client.get_state(), GoalStatus.ABORTED)
        self.assertIn("goal", client.get_goal_status_text())
        self.assertEqual(rospy.wait_for_message("/sim/collisions", UInt32, timeout=5).data, 0)

    def test_4_a_new_goal_while_driving_does_not_stop_the_robot(self):
        """A goal replaced by another while driving: the navigator drives on (before, the
        preempt published a zero command: a stop at every new goal of the explorer)."""
        client = actionlib.SimpleActionClient("/move_base", MoveBaseAction)
        client.wait_for_server(rospy.Duration(10))
        client.send_goal(MoveBaseGoal(target_pose=goal_pose(1.6, -0.6)))   # world (2.6, 0.5)
        deadline = rospy.get_time() + 30.0
        while rospy.wait_for_message("/sim/ground_truth", Odometry, timeout=10).twist.twist.linear.x < 0.15:
            self.assertLess(rospy.get_time(), deadline, "the robot never got going")
        commands = []
        sub = rospy.Subscriber("/cmd_vel", Twist, lambda m: commands.append(m.linear.x))
        rospy.sleep(0.3)
        client.send_goal(MoveBaseGoal(target_pose=goal_pose(1.9, -0.5)))   # further on, nearly ahead
        rospy.sleep(1.5)
        sub.unregister()
        self.assertGreater(len(commands), 5)
        self.assertGreater(min(commands), 0.05, f"the robot braked for the new goal: {commands}")
        self.assertTrue(client.wait_for_result(rospy.Duration(60)))
        self.assertEqual(client.get_state(), GoalStatus.SUCCEEDED, client.get_goal_status_text())


if __name__ == "__main__":
    rospy.init_node("navigator_room_test")
    rostest.rosrun("turtlebot_recon", "navigator_room", NavigatorRoom)
