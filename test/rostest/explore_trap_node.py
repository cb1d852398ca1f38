#!/usr/bin/env python3
"""rostest node for explore_trap.test: closes the door into room C once the explorer aims
there (while the robot is outside C, clear of the door), then waits for the exploration to
finish and checks it: finished by itself, not by the budget; the door was closed while a goal
in C was pending; the robot left its corner; no collision; rooms A and B mapped."""
import math
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Point32, PolygonStamped, PoseStamped
from nav_msgs.msg import Odometry
from std_msgs.msg import String

from explore_small_node import wait_for_report


class ExploreTrap(unittest.TestCase):
    def setUp(self):
        self.start = [float(v) for v in rospy.get_param("~start")]
        self.door = [float(v) for v in rospy.get_param("~door_box")]   # x0, y0, x1, y1 (world)
        self.lock = threading.Lock()
        self.truth = None
        self.farthest_m = 0.0
        self.closed_for = None           # the goal (world) pending when the door closed
        self.goal = None                 # the explorer's latest goal (world)
        self.done = None
        self.pub = rospy.Publisher("sim/add_obstacle", PolygonStamped, queue_size=1, latch=True)
        rospy.Subscriber("sim/ground_truth", Odometry, self.on_truth, queue_size=10)
        rospy.Subscriber("explore/goal", PoseStamped, self.on_goal, queue_size=10)
        rospy.Subscriber("explore/done", String, self.on_done, queue_size=1)

    def in_room_c(self, x, y):
        return x > 2.65 and y > self.door[3]

    def on_truth(self, msg):
        p = msg.pose.pose.position
        with self.lock:
            self.truth = (p.x, p.y)
            self.farthest_m = max(self.farthest_m, math.hypot(p.x - self.start[0], p.y - self.start[1]))
        self.maybe_close()

    def on_goal(self, msg):
        sx, sy, syaw = self.start         # explore/goal is in odom = the start pose
        gx, gy = msg.pose.position.x, msg.pose.position.y
        with self.lock:
            self.goal = (sx + math.cos(syaw) * gx - math.sin(syaw) * gy,
                         sy + math.sin(syaw) * gx + math.cos(syaw) * gy)
        self.maybe_close()

    def maybe_close(self):
        """Close the door while the goal pursued lies in C and the robot is outside C, clear of
        the doorway (the explorer keeps a goal until it is reached or seen: the robot may be
        near the door when it is sent, and clear of it a moment later)."""
        with self.lock:
            if self.closed_for is not None or self.truth is None or self.goal is None \
                    or not self.in_room_c(*self.goal):
                return
            x, y = self.truth
            cx, cy = 0.5 * (self.door[0] + self.door[2]), 0.5 * (self.door[1] + self.door[3])
            if self.in_room_c(x, y) or math.hypot(x - cx, y - cy) < 0.9:
                return                    # not while the robot is in C or in the doorway
            self.closed_for = wx, wy = self.goal
        box = PolygonStamped()
        box.header.frame_id, box.header.stamp = "world", rospy.Time.now()
        x0, y0, x1, y1 = self.door
        box.polygon.points = [Point32(x0, y0, 0.0), Point32(x1, y1, 0.0)]
        self.pub.publish(box)
        rospy.loginfo("explore_trap: goal (%.2f, %.2f) in room C: door closed", wx, wy)

    def on_done(self, msg):
        self.done = msg.data

    def test_trap(self):
        deadline = time.monotonic() + float(rospy.get_param("~wait_wall_s"))
        while self.done is None and time.monotonic() < deadline and not rospy.is_shutdown():
            time.sleep(0.2)
        self.assertIsNotNone(self.done, "the exploration did not finish in time")
        self.assertIsNotNone(self.closed_for, "the explorer never aimed at room C: the door stayed open")
        self.assertNotIn("budget", self.done)
        report = wait_for_report(rospy.get_param("~report"), 30.0)
        self.assertIsNotNone(report, "no report.json from this run")
        summary = {k: report.get(k) for k in ("coverage_final", "distance_m", "collisions",
                                              "collisions_at", "sim_time_s", "finished_reason")}
        rospy.loginfo("explore_trap: door closed for goal %s; %s", self.closed_for, summary)
        self.assertEqual(report["collisions"], 0, summary)
        self.assertGreater(self.farthest_m, 2.0, "the robot never left its corner")
        self.assertGreaterEqual(report["coverage_final"], float(rospy.get_param("~min_coverage")), summary)


if __name__ == "__main__":
    rospy.init_node("explore_trap_test")
    rostest.rosrun("turtlebot_recon", "explore_trap", ExploreTrap)
