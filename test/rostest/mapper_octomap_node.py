#!/usr/bin/env python3
"""rostest node for mapper_octomap.test (wall time, no simulator): a depth camera 0.30 m above
the floor looks along +x at a box 0.15 m high, 0.6 m wide, its front face at x = 1.52 m (mid-voxel); the
lidar at 0.287 m sees a round room of radius 3 m and nothing of the box."""
import math
import os
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from rosgraph_msgs.msg import Log
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import CameraInfo, Image, LaserScan
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from turtlebot_recon.mapping.map_io import load_map
from turtlebot_recon.mapping.octomap_layer import OctomapLayer, OctomapSettings
from turtlebot_recon.ros import convert

W, H, F = 160, 120, 100.0                       # px, px, focal length px (77 deg across)
CAM_Z = 0.30                                    # m, the optical centre above the floor
BOX = dict(x=1.52, depth=0.4, half_width=0.3, top=0.15)   # m
R_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])   # optical -> base (REP 103)
MAP_DIR = "/tmp/turtlebot_recon_test_maps/mapper_octomap"


def depth_image():
    """z-depth (m) of the scene per pixel, NaN where a ray meets nothing within 6 m."""
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    ray = np.stack(((u - (W - 1) / 2) / F, (v - (H - 1) / 2) / F, np.ones_like(u)), axis=-1) @ R_OPTICAL.T
    depth = np.full((H, W), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(ray[..., 2] < 0, -CAM_Z / ray[..., 2], np.inf)   # optical z = 1: t is depth
        t_face = BOX["x"] / ray[..., 0]
        y, z = t_face * ray[..., 1], CAM_Z + t_face * ray[..., 2]
        on_face = (ray[..., 0] > 0) & (np.abs(y) <= BOX["half_width"]) & (z >= 0) & (z <= BOX["top"])
        t_top = (BOX["top"] - CAM_Z) / ray[..., 2]
        x, y2 = t_top * ray[..., 0], t_top * ray[..., 1]
        on_top = (ray[..., 2] < 0) & (x >= BOX["x"]) & (x <= BOX["x"] + BOX["depth"]) & (np.abs(y2) <= BOX["half_width"])
    t = np.where(on_face, t_face, np.where(on_top, t_top, t_floor))
    depth[np.isfinite(t) & (t < 6.0)] = t[np.isfinite(t) & (t < 6.0)]
    depth[::7, ::5] = np.nan                      # drop-outs, as a real sensor has
    return depth.astype(np.float32)


def image_msg(depth, stamp, encoding="32FC1", frame="camera_depth_optical_frame"):
    m = Image()
    m.header.stamp, m.header.frame_id = stamp, frame
    m.height, m.width, m.encoding = H, W, encoding
    if encoding == "16UC1":
        m.data = np.nan_to_num(depth * 1000.0, nan=0.0).astype(np.uint16).tobytes()
        m.step = 2 * W
    else:
        m.data, m.step = depth.tobytes(), 4 * W
    return m


class MapperOctomap(unittest.TestCase):
    def test_a_low_box_becomes_an_obstacle(self):
        logs = []
        rospy.Subscriber("/rosout", Log, lambda m: logs.append(m.msg) if m.name == "/mapper" else None)
        voxels = []
        rospy.Subscriber("/octomap/occupied", MarkerArray, voxels.append)
        tf = tf2_ros.TransformBroadcaster()
        depth_pub = rospy.Publisher("/camera/depth/image_raw", Image, queue_size=10)
        info_pub = rospy.Publisher("/camera/depth/camera_info", CameraInfo, queue_size=10)
        scan_pub = rospy.Publisher("/scan", LaserScan, queue_size=10)
        rospy.sleep(1.0)
        q = Rotation.from_matrix(R_OPTICAL).as_quat()

        def send_tf(_=None):
            t = rospy.get_time()
            tf.sendTransform([convert.transform("odom", "base_footprint", t, 0.0, 0.0),
                              convert.transform("base_footprint", "camera_depth_optical_frame", t, 0.0, 0.0,
                                                CAM_Z, quat=q),
                              convert.transform("base_footprint", "camera_depth_frame", t, 0.0, 0.0, 0.287)])

        timer = rospy.Timer(rospy.Duration(0.05), send_tf)
        depth = depth_image()
        now = rospy.Time.now
        depth_pub.publish(image_msg(depth, now()))        # before any camera_info: skipped
        rospy.sleep(0.5)
        info = CameraInfo(width=W, height=H, K=[F, 0, (W - 1) / 2, 0, F, (H - 1) / 2, 0, 0, 1])
        info.header.frame_id = "camera_depth_optical_frame"
        info_pub.publish(info)
        rospy.sleep(0.5)
        scan = LaserScan(angle_min=-math.pi, angle_increment=2 * math.pi / 360, range_min=0.45, range_max=4.0)
        scan.angle_max = scan.angle_min + 359 * scan.angle_increment
        scan.ranges = [3.02] * 360                      # a round room, its wall mid-cell
        scan.header.frame_id = "camera_depth_frame"
        for i in range(4):
            scan.header.stamp = now()
            scan_pub.publish(scan)
            depth_pub.publish(image_msg(depth, now(), "16UC1" if i % 2 else "32FC1"))
            rospy.sleep(0.4)
        depth_pub.publish(image_msg(depth, now(), "rgb8"))                     # refused: its encoding
        rospy.sleep(0.3)
        depth_pub.publish(image_msg(depth, now(), frame="no_such_frame"))     # refused: no transform
        rospy.sleep(0.5)
        timer.shutdown()
        saved = rospy.ServiceProxy("/mapper/save_map", Trigger)()
        self.assertTrue(saved.success, saved.message)
        occ, res, origin = load_map(saved.message)
        at = lambda x, y: occ[int(math.floor((y - origin[1]) / res)), int(math.floor((x - origin[0]) / res))]
        for y in (-0.25, 0.0, 0.25):
            self.assertEqual(at(1.52, y), 100, f"the box's face at y={y}")   # the lidar passed over it
        self.assertEqual(at(1.0, 0.0), 0)               # the floor in front of it: free, not an obstacle
        self.assertEqual(at(1.5, 0.6), 0)               # beside the box
        self.assertEqual(max(at(3.02, y) for y in (-0.04, 0.0, 0.04)), 100)   # the lidar's wall (its
        # beam along y = 0 runs on a cell boundary: one of the two rows beside it has the hit)
        # the OcTree is saved beside the map and holds the box's voxels below its top
        bt = os.path.join(MAP_DIR, "octomap.bt")
        self.assertTrue(os.path.exists(bt))
        tree = OctomapLayer(OctomapSettings(robot_height_m=0.4))
        tree.load(bt)
        centres, _ = tree.occupied_voxels()
        face = centres[(np.abs(centres[:, 0] - 1.525) < 0.03) & (np.abs(centres[:, 1]) < 0.3)]
        self.assertGreater(len(face), 10)
        self.assertLessEqual(face[:, 2].max(), 0.2)
        # rviz's markers: cubes coloured by height, none at the floor
        deadline = rospy.get_time() + 5.0
        while not voxels and rospy.get_time() < deadline:
            rospy.sleep(0.1)
        self.assertTrue(voxels, "no /octomap/occupied")
        points = [p for m in voxels[-1].markers for p in m.points]
        self.assertGreater(len(points), 10)
        self.assertGreater(min(p.z for p in points), 0.03)
        colours = {(round(c.r, 2), round(c.b, 2)) for m in voxels[-1].markers for c in m.colors}
        self.assertGreater(len(colours), 1)           # several heights, several colours
        rospy.sleep(1.0)
        self.assertTrue(any("depth encoding 'rgb8' is not supported" in m for m in logs), logs)
        line = [m for m in logs if "map saved (~save_map)" in m]   # the skipped frames, counted
        self.assertTrue(line, logs)
        for reason in ("depth_no_camera_info 1", "depth_refused 1", "depth_no_tf 1"):
            self.assertIn(reason, line[-1])
        line = [m for m in logs if "OcTree saved" in m]
        self.assertTrue(line and "4 depth frames" in line[-1], logs)


if __name__ == "__main__":
    rospy.init_node("mapper_octomap_test")
    rostest.rosrun("turtlebot_recon", "mapper_octomap", MapperOctomap)
