#!/usr/bin/env python3
"""rostest node for mapper_house.test."""
import unittest

import numpy as np
import rospy
import rostest
from nav_msgs.msg import OccupancyGrid
from std_srvs.srv import Trigger

from turtlebot_recon.evaluation import map_precision
from turtlebot_recon.mapping.map_io import load_map
from turtlebot_recon.sim import load_world


class MapperHouse(unittest.TestCase):
    def test_precision_and_saved_map(self):
        world = load_world(rospy.get_param("~world"))
        drive_s = rospy.get_param("~drive_s")
        while rospy.get_time() < drive_s and not rospy.is_shutdown():
            rospy.sleep(1.0)
        rospy.wait_for_service("/mapper/save_map", timeout=30)
        saved = rospy.ServiceProxy("/mapper/save_map", Trigger)()
        self.assertTrue(saved.success, saved.message)
        occ, res, origin = load_map(saved.message)
        # the odom frame (the map frame here) is the start pose: the evaluator's transform
        p = map_precision(occ, res, origin, world, world.start)
        rospy.loginfo("mapper_house: %s", p)
        self.assertGreater(p["cells_free"] * res * res, 20.0)       # it mapped > 20 m^2
        self.assertGreaterEqual(p["map_precision_occupied"], 0.98)
        self.assertGreaterEqual(p["map_precision_free"], 0.98)
        # the saved file is the published map, thresholded as map_saver does
        m = rospy.wait_for_message("/map", OccupancyGrid, timeout=10)
        data = np.array(m.data, np.int8).reshape(m.info.height, m.info.width)
        self.assertEqual(data.shape, occ.shape)
        self.assertEqual((m.info.origin.position.x, m.info.origin.position.y), origin)
        classes = np.where(data < 0, -1, np.where(data >= 65, 100, np.where(data <= 25, 0, -1)))
        agree = np.mean(classes == occ)
        self.assertGreater(agree, 0.99)   # /map may have gained a scan since the save


if __name__ == "__main__":
    rospy.init_node("mapper_house_test")
    rostest.rosrun("turtlebot_recon", "mapper_house", MapperHouse)
