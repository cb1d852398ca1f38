#!/usr/bin/env python3
"""rostest node for sim_depth.test: the camera (x -0.087, z 0.287 on the robot at x 1.0) looks
along +x at the bed frame's face x = 2.0 (1.087 m away, 0.30-0.50 m high) and, under it, at the
wall x = 3.1 (2.187 m)."""
import math
import statistics
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from sensor_msgs.msg import CameraInfo, Image, LaserScan, PointCloud2, PointField

from turtlebot_recon.perception.depth import depth_metres

FRAME = "camera_depth_optical"
TO_BED, TO_WALL, CAM_Z = 2.0 - 0.913, 3.1 - 0.913, 0.287
RATE_HZ = 2.5                                   # config/sim_bridge.yaml depth_rate_hz


class SimDepth(unittest.TestCase):
    def test_1_image_info_points(self):
        got = {"image": [], "info": [], "points": []}
        subs = [rospy.Subscriber("/camera/depth/image_raw", Image, got["image"].append, queue_size=100),
                rospy.Subscriber("/camera/depth/camera_info", CameraInfo, got["info"].append, queue_size=100),
                rospy.Subscriber("/camera/depth/points", PointCloud2, got["points"].append, queue_size=100)]
        rospy.wait_for_message("/camera/depth/image_raw", Image, timeout=60)
        t0 = rospy.get_time()
        while rospy.get_time() < t0 + 3.0 and not rospy.is_shutdown():
            rospy.sleep(0.1)
        for s in subs:
            s.unregister()
        for name, msgs in got.items():
            self.assertGreater(len(msgs), 3, name)
            self.assertEqual({m.header.frame_id for m in msgs}, {FRAME}, name)
            stamps = sorted(m.header.stamp.to_sec() for m in msgs)
            rate = 1.0 / statistics.median(b - a for a, b in zip(stamps, stamps[1:]))
            self.assertAlmostEqual(rate, RATE_HZ, delta=0.1 * RATE_HZ, msg=f"{name}: {rate:.2f} Hz")
        image, info, cloud = got["image"][-1], got["info"][-1], got["points"][-1]
        self.assertEqual((image.width, image.height, image.encoding, image.step), (160, 120, "32FC1", 640))
        depth = depth_metres(image.encoding, image.height, image.width, image.step, image.data, image.is_bigendian)
        self.assertTrue(np.isnan(depth[0]).all())                      # over the 0.5 m walls: no return
        valid = depth[~np.isnan(depth)]
        self.assertTrue(((valid >= 0.45) & (valid <= 4.0)).all())
        self.assertEqual((info.width, info.height), (160, 120))
        fx, cx, fy, cy = info.K[0], info.K[2], info.K[4], info.K[5]
        self.assertAlmostEqual(fx, 80.0 / math.tan(math.radians(31.0)), delta=0.1)
        self.assertEqual((cx, cy, fx), (79.5, 59.5, fy))
        row = int(round(cy - fy * (0.40 - CAM_Z) / TO_BED))     # sees 0.40 m up the bed's face
        self.assertAlmostEqual(float(np.nanmedian(depth[row, 70:90])), TO_BED, delta=0.03)
        self.assertAlmostEqual(float(np.nanmedian(depth[int(cy), 70:90])), TO_WALL, delta=0.06)   # under it
        # the organised cloud: every 2nd pixel, x y z float32, the bed's face at z 1.087 above the axis
        self.assertEqual((cloud.height, cloud.width, cloud.point_step, cloud.is_dense), (60, 80, 12, False))
        self.assertEqual([(f.name, f.offset, f.datatype) for f in cloud.fields],
                         [("x", 0, PointField.FLOAT32), ("y", 4, PointField.FLOAT32), ("z", 8, PointField.FLOAT32)])
        xyz = np.frombuffer(cloud.data, "<f4").reshape(60, 80, 3)
        bed = xyz[row // 2, 35:45]
        self.assertAlmostEqual(float(np.nanmedian(bed[:, 2])), TO_BED, delta=0.03)
        self.assertAlmostEqual(float(np.nanmedian(bed[:, 1])), -(0.40 - CAM_Z), delta=0.03)   # y down

    def test_2_scan_passes_under_the_bed(self):
        scan = rospy.wait_for_message("/scan", LaserScan, timeout=30)
        middle = [r for r in scan.ranges[315:325] if math.isfinite(r)]
        self.assertTrue(middle)
        self.assertAlmostEqual(statistics.median(middle), TO_WALL, delta=0.06)

    def test_3_depth_frame_in_tf(self):
        buf = tf2_ros.Buffer()
        tf2_ros.TransformListener(buf)
        t = buf.lookup_transform("base_footprint", FRAME, rospy.Time(0), rospy.Duration(10.0)).transform
        self.assertAlmostEqual(t.translation.x, -0.087, delta=1e-6)
        self.assertAlmostEqual(t.translation.z, 0.287, delta=1e-6)
        q = t.rotation         # REP-103 optical frame: its z axis along the robot's x
        z_axis_x = 2 * (q.x * q.z + q.w * q.y)
        self.assertAlmostEqual(z_axis_x, 1.0, delta=1e-6)


if __name__ == "__main__":
    rospy.init_node("sim_depth_test")
    rostest.rosrun("turtlebot_recon", "sim_depth", SimDepth)
