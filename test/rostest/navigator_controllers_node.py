#!/usr/bin/env python3
"""rostest node for navigator_controllers.test. The house's start room: free x in [0.7, 5+],
y in [4.8, 6.2] (world); the robot starts at (1.45, 5.45) facing +x, so odom = world - start.
For each controller in turn a navigator is started (its parameters as navigator.launch loads
them), drives to GOALS through the move_base action, and is stopped again."""
import math
import unittest
from pathlib import Path

import actionlib
import roslaunch
import roslaunch.core
import roslaunch.scriptapi
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid, Odometry
from std_msgs.msg import UInt32

from turtlebot_recon.config import load_yaml
from turtlebot_recon.control import CONTROLLERS as ALL

CONTROLLERS = ["pure_pursuit", "dwa", "pd", "mppi", "tube_mppi"]   # one entry per controller under test
START = (1.45, 5.45)
GOALS = [(3.5, 5.5), (4.2, 5.05), (2.1, 5.2)]   # world frame, in the start room, in turn
CONFIG = Path(__file__).resolve().parents[2] / "config"
CONTROLLERS_WITH_FILES = [c for c in ALL if c != "pure_pursuit"]   # config/<name>.yaml -> ~<name>


def goal_pose(x, y):
    p = PoseStamped()
    p.header.frame_id, p.header.stamp = "odom", rospy.Time.now()
    p.pose.position.x, p.pose.position.y = x - START[0], y - START[1]
    p.pose.orientation.w = 1.0
    return p


def goal_cell_free(m, x, y):
    col = int((x - START[0] - m.info.origin.position.x) / m.info.resolution)
    row = int((y - START[1] - m.info.origin.position.y) / m.info.resolution)
    inside = 0 <= row < m.info.height and 0 <= col < m.info.width
    return inside and 0 <= m.data[row * m.info.width + col] < 20


def truth_xy():
    p = rospy.wait_for_message("/sim/ground_truth", Odometry, timeout=10).pose.pose.position
    return p.x, p.y


def start_navigator(launch, controller):
    """A navigator node named navigator_<controller> with navigator.launch's parameters."""
    name = f"navigator_{controller}"
    params = load_yaml(CONFIG / "navigator.yaml")
    params["lattice"] = load_yaml(CONFIG / "lattice.yaml")
    for own in CONTROLLERS_WITH_FILES:
        params[own] = load_yaml(CONFIG / f"{own}.yaml")
    params["robot"] = rospy.get_param("~robot")
    params["controller"] = controller
    params["takeover_m"] = 0.0           # each controller on its own: no pure pursuit takeover
    rospy.set_param(f"/{name}", params)
    node = roslaunch.core.Node("turtlebot_recon", "navigator", name=name, namespace="/",
                               remap_args=[("move_base", f"/{name}/move_base"),
                                           ("move_base_simple/goal", f"/{name}/simple_goal"),
                                           ("plan", f"/{name}/plan")],
                               output="screen")
    return launch.launch(node), name


class NavigatorControllers(unittest.TestCase):
    def test_each_controller_reaches_three_goals(self):
        deadline = rospy.get_time() + 60.0
        for gx, gy in GOALS:
            while not goal_cell_free(rospy.wait_for_message("/map", OccupancyGrid, timeout=30), gx, gy):
                self.assertLess(rospy.get_time(), deadline, f"the mapper never saw ({gx}, {gy}) free")
        launch = roslaunch.scriptapi.ROSLaunch()
        launch.start()
        try:
            for controller in CONTROLLERS:
                process, name = start_navigator(launch, controller)
                try:
                    client = actionlib.SimpleActionClient(f"/{name}/move_base", MoveBaseAction)
                    self.assertTrue(client.wait_for_server(rospy.Duration(60)), controller)
                    for gx, gy in GOALS:
                        t0 = rospy.get_time()
                        client.send_goal(MoveBaseGoal(target_pose=goal_pose(gx, gy)))
                        self.assertTrue(client.wait_for_result(rospy.Duration(90)),
                                        f"{controller}: no result for ({gx}, {gy})")
                        self.assertEqual(client.get_state(), GoalStatus.SUCCEEDED,
                                         f"{controller} to ({gx}, {gy}): {client.get_goal_status_text()}")
                        x, y = truth_xy()
                        rospy.loginfo("navigator_controllers: %s reached (%.2f, %.2f) in %.1f sim s, "
                                      "%.3f m off", controller, gx, gy, rospy.get_time() - t0,
                                      math.hypot(x - gx, y - gy))
                        self.assertLess(math.hypot(x - gx, y - gy), 0.15, controller)
                finally:
                    process.stop()
                    rospy.sleep(1.0)
        finally:
            launch.stop()
        self.assertEqual(rospy.wait_for_message("/sim/collisions", UInt32, timeout=5).data, 0)


if __name__ == "__main__":
    rospy.init_node("navigator_controllers_test")
    rostest.rosrun("turtlebot_recon", "navigator_controllers", NavigatorControllers)
