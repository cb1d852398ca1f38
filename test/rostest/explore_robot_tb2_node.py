#!/usr/bin/env python3
"""rostest node for explore_robot_tb2.test: explore_robot.launch's TurtleBot 2 wiring.

A real Kobuki publishes kobuki_msgs/BumperEvent; kobuki_msgs is not installed, so the base is
played by a class with kobuki's type name and md5sum (that of its definition, written out
here, so a change to msg/BumperEvent.msg that breaks compatibility fails this test)."""
import math
import threading
import time
import unittest

import rosgraph
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Twist
from nav_msgs.msg import OccupancyGrid, Path
from std_msgs.msg import String

from turtlebot_recon.msg import BumperEvent

VELOCITY = "/mobile_base/commands/velocity"
BUMPER = "/mobile_base/events/bumper"
RADIUS_M = 0.177                       # config/robots/turtlebot2.yaml
RIGHT_BUMPER_RAD = -math.pi / 3        # the mapper's right bumper direction


class KobukiBumperEvent(BumperEvent):
    """What kobuki_node publishes: same fields, kobuki's type name and md5sum."""
    _type = "kobuki_msgs/BumperEvent"
    _md5sum = "ffe360cd50f14f9251d9844083e72ac5"


def occupied_ring(m: OccupancyGrid, x: float, y: float, inner_m: float, outer_m: float) -> list:
    """Bearings (rad, map frame) from (x, y) of the cells of ``m`` marked occupied (>= 65) at a
    distance in [inner_m, outer_m]: the ring where a bumper press is marked."""
    info, bearings = m.info, []
    res, ox, oy = info.resolution, info.origin.position.x, info.origin.position.y
    reach = int(math.ceil(outer_m / res))
    col0, row0 = int((x - ox) / res), int((y - oy) / res)
    for row in range(row0 - reach, row0 + reach + 1):
        for col in range(col0 - reach, col0 + reach + 1):
            if 0 <= row < info.height and 0 <= col < info.width and m.data[row * info.width + col] >= 65:
                dx, dy = ox + (col + 0.5) * res - x, oy + (row + 0.5) * res - y
                if inner_m <= math.hypot(dx, dy) <= outer_m:
                    bearings.append(math.atan2(dy, dx))
    return bearings


class ExploreRobotTB2(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.cmds, self.states, self.maps, self.path = [], [], [], None
        rospy.Subscriber(VELOCITY, Twist, lambda m: self.add(self.cmds, (time.monotonic(), m)))
        rospy.Subscriber("/explore/state", String, lambda m: self.add(self.states, (time.monotonic(), m.data)))
        rospy.Subscriber("/map", OccupancyGrid, lambda m: self.add(self.maps, m))
        rospy.Subscriber("/trajectory", Path, lambda m: setattr(self, "path", m))
        self.tf = tf2_ros.Buffer()
        tf2_ros.TransformListener(self.tf)

    def add(self, items, item):
        with self.lock:
            items.append(item)

    def wait(self, cond, timeout_s: float, what: str):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                if cond():
                    return
            time.sleep(0.05)
        self.fail(f"timed out after {timeout_s:.0f} s (wall) waiting for {what}")

    def test_turtlebot2_wiring(self):
        # 1. The explorer starts (first map, navigator up) and its spin reaches the base.
        self.wait(lambda: self.states, float(rospy.get_param("~start_wait_wall_s")), "/explore/state")
        self.wait(lambda: any(abs(c.angular.z) > 0.1 for _, c in self.cmds), 10.0, f"a turn on {VELOCITY}")
        pubs, _, _ = rosgraph.Master("/explore_robot_tb2_test").getSystemState()
        publishers = dict((topic, set(nodes)) for topic, nodes in pubs)
        self.assertLessEqual({"/explorer", "/navigator"}, publishers.get(VELOCITY, set()))
        self.assertEqual(publishers.get("/cmd_vel", set()), set(), "nothing may command /cmd_vel on a TurtleBot 2")
        # SLAM runs by default on a robot: the map, and everything placed in it, is in "map"
        self.assertTrue(self.maps and self.maps[-1].header.frame_id == "map", "no /map in map")
        # the mapper has the base's transform once scans land in the map
        self.wait(lambda: sum(v >= 0 for v in self.maps[-1].data) > 500, 10.0, "scans in /map")

        # 2. A kobuki-typed right bumper press reaches the explorer and the mapper.
        pub = rospy.Publisher(BUMPER, KobukiBumperEvent, queue_size=5)
        self.wait(lambda: pub.get_num_connections() >= 2, 10.0, f"the mapper and the explorer on {BUMPER}")
        t = self.tf.lookup_transform("map", "base_footprint", rospy.Time(0), rospy.Duration(2.0))
        x, y = t.transform.translation.x, t.transform.translation.y
        q = t.transform.rotation
        yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        # The press is marked as 5 cells along the body's tangent at the right bumper, ~0.20-0.26 m
        # from the centre. The robot may still be turning while the press travels to the mapper,
        # so the whole ring around the base is counted, and the marks' mean bearing checked.
        ring = (RADIUS_M - 0.04, RADIUS_M + 0.12)
        with self.lock:
            before = occupied_ring(self.maps[-1], x, y, *ring)
        pressed_wall, pressed_sim = time.monotonic(), rospy.Time.now()
        pub.publish(KobukiBumperEvent(bumper=KobukiBumperEvent.RIGHT, state=KobukiBumperEvent.PRESSED))
        types = dict(rosgraph.Master("/explore_robot_tb2_test").getTopicTypes())
        self.assertEqual(types.get(BUMPER), "kobuki_msgs/BumperEvent")

        self.wait(lambda: any(s == "BUMPER_BACKOFF" and w >= pressed_wall for w, s in self.states), 10.0,
                  "the explorer's BUMPER_BACKOFF")
        self.wait(lambda: any(w >= pressed_wall and c.linear.x < -0.01 for w, c in self.cmds), 10.0,
                  f"reversing on {VELOCITY}")
        pub.publish(KobukiBumperEvent(bumper=KobukiBumperEvent.RIGHT, state=KobukiBumperEvent.RELEASED))

        self.wait(lambda: any(m.header.stamp > pressed_sim for m in self.maps), 10.0, "a /map after the press")
        with self.lock:
            after_map = next(m for m in self.maps if m.header.stamp > pressed_sim)
        after = occupied_ring(after_map, x, y, *ring)
        bearing = math.atan2(sum(map(math.sin, after)), sum(map(math.cos, after))) - yaw if after else math.nan
        off_rad = abs(math.remainder(bearing - RIGHT_BUMPER_RAD, math.tau))
        rospy.loginfo("explore_robot_tb2: occupied cells around the base (%.2f, %.2f): %d before, %d after, "
                      "at %.0f deg from the right bumper", x, y, len(before), len(after), math.degrees(off_rad))
        self.assertEqual(before, [], "the robot stood clear of walls")
        self.assertGreaterEqual(len(after), 4, "the mapper marks 5 cells along the pressed bumper")
        self.assertLess(off_rad, math.radians(45), "the marks lie at the right bumper")
        # The lidar's beams pass over the marks (what the bumper felt is below its plane): they
        # are still there seconds of scans later.
        later_sim = pressed_sim + rospy.Duration(4.0)
        self.wait(lambda: any(m.header.stamp > later_sim for m in self.maps), 20.0, "a /map 4 s after the press")
        with self.lock:
            later = occupied_ring(next(m for m in self.maps if m.header.stamp > later_sim), x, y, *ring)
        self.assertGreaterEqual(len(later), 4, "the bumper marks outlive the lidar's scans")

        # 3. The driven path: the reverse moved the base, in the map frame.
        self.wait(lambda: self.path is not None and len(self.path.poses) >= 2, 15.0, "/trajectory with 2 poses")
        self.assertEqual(self.path.header.frame_id, "map")


if __name__ == "__main__":
    rospy.init_node("explore_robot_tb2_test")
    rostest.rosrun("turtlebot_recon", "explore_robot_tb2", ExploreRobotTB2)
