#!/usr/bin/env python3
"""rostest node for tags_sim.test: the robot turns in place at its start until every tag of
the world is confirmed on /tags (odom = the start pose, odom_slip 0: odom is exact)."""
import math
import os
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import Twist
from rosgraph_msgs.msg import Clock
from scipy.spatial.transform import Rotation
from std_srvs.srv import Trigger

from turtlebot_recon.evaluation.coverage import world_to_map
from turtlebot_recon.geometry import wrap_angle
from turtlebot_recon.msg import TagDetectionArray
from turtlebot_recon.perception.families import canonical, marker_set
from turtlebot_recon.perception.tracker import CSV_HEADER, load_tags_yaml
from turtlebot_recon.sim.world import load_world

TURN_RADPS = 0.5              # a full turn in 12.6 sim s; a tag stays ~2 s (10 frames) in view
MAX_TURNS = 2.0               # the first turn must do; the second is slack
WALL_TIMEOUT_S = 75.0         # for the turning, on a slow machine
POSITION_TOL_M = 0.10
YAW_TOL_RAD = 0.25


def normal_yaw(q) -> float:
    """Heading (rad) of a marker pose's outward normal, its local z axis."""
    nx, ny, _ = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()[:, 2]
    return math.atan2(ny, nx)


def keys(msg: TagDetectionArray) -> set:
    return {(marker_set(d.family), d.id) for d in msg.detections}


class TagsSim(unittest.TestCase):
    def test_tags_confirmed_in_place_and_saved(self):
        world = load_world(rospy.get_param("~world"))
        base = rospy.get_param("~tags_file")
        for ext in (".yaml", ".csv"):                 # a file left by an earlier run must not count
            if os.path.exists(base + ext):
                os.remove(base + ext)
        start = world.start
        xy = world_to_map(np.array([[t.x, t.y] for t in world.tags]), start)
        truth = {(marker_set(t.family), t.id): (np.array([*p, t.z]), wrap_angle(t.yaw - start[2]))
                 for t, p in zip(world.tags, xy)}
        self.assertEqual(len(truth), 3)

        seen = []
        rospy.Subscriber("/tags", TagDetectionArray, seen.append, queue_size=100)
        rospy.wait_for_message("/clock", Clock, timeout=60)
        cmd_pub = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
        wall_deadline = time.monotonic() + WALL_TIMEOUT_S
        while not seen:                                # the tracker is up
            self.assertLess(time.monotonic(), wall_deadline, "no /tags message")
            rospy.sleep(0.1)

        turn = Twist()
        turn.angular.z = TURN_RADPS
        t0, rate = rospy.get_time(), rospy.Rate(10)    # sim time; the base stops 0.5 s after a /cmd_vel
        while not rospy.is_shutdown() and keys(seen[-1]) != set(truth):
            confirmed = keys(seen[-1])
            self.assertLessEqual(confirmed, set(truth), "a tag that is not in the world")
            if rospy.get_time() - t0 > MAX_TURNS * 2 * math.pi / TURN_RADPS or time.monotonic() > wall_deadline:
                self.fail(f"{rospy.get_time() - t0:.1f} sim s of turning and confirmed only "
                          f"{sorted(confirmed)} of {sorted(truth)}")
            cmd_pub.publish(turn)
            rate.sleep()
        cmd_pub.publish(Twist())
        rospy.loginfo("tags_sim: all %d tags confirmed after %.1f sim s of turning",
                      len(truth), rospy.get_time() - t0)

        for m in seen:
            self.assertEqual(m.header.frame_id, "odom")
            self.assertLessEqual(keys(m), set(truth), "a tag that is not in the world")
        final = seen[-1]
        self.assertEqual(len(final.detections), len(truth), "one entry per tag")
        for d in final.detections:
            where, yaw = truth[(marker_set(d.family), d.id)]
            self.assertEqual(d.family, canonical(d.family))
            p = d.pose.pose.position
            err = float(np.linalg.norm(np.array([p.x, p.y, p.z]) - where))
            self.assertLess(err, POSITION_TOL_M, f"{d.family} {d.id} at ({p.x:.3f}, {p.y:.3f}, {p.z:.3f}), "
                                                 f"true {np.round(where, 3).tolist()}")
            self.assertLess(abs(wrap_angle(normal_yaw(d.pose.pose.orientation) - yaw)), YAW_TOL_RAD,
                            f"{d.family} {d.id}")

        res = rospy.ServiceProxy("/tag_tracker/save", Trigger)()
        self.assertTrue(res.success, res.message)
        self.assertIn(f"{len(truth)} confirmed tag(s) saved", res.message)
        with open(base + ".yaml") as f:
            tracks = load_tags_yaml(f.read())
        self.assertEqual({(t.marker_set, t.id) for t in tracks}, set(truth))
        with open(base + ".csv") as f:
            lines = f.read().splitlines()
        self.assertEqual(lines[0], CSV_HEADER)
        self.assertEqual(sorted(int(line.split(",")[0]) for line in lines[1:]),
                         sorted(i for _, i in truth))


if __name__ == "__main__":
    rospy.init_node("tags_sim_test")
    rostest.rosrun("turtlebot_recon", "tags_sim", TagsSim)
