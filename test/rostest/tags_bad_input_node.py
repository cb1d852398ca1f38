#!/usr/bin/env python3
"""rostest node for tags_bad_input.test (wall time, no simulator, no TF to the map frame).

The test is the camera: /test_camera/image_raw (+ /compressed) and /test_camera/camera_info.
Each cause of a dropped frame must be named on /rosout by its node, at most once a second
(never three lines of one cause within 1 s while 10 frames a second of it come in), and no
detection array may carry a dropped frame's stamp. The synthetic marker is a real tag36h11,
fronto-parallel: its 8-bit black square spans 96 px, so with fx = 530 px and the 0.16 m of
config/tag_detector.yaml it is 530 * 0.16 / 96 = 0.883 m away."""
import re
import time
import unittest

import cv2
import numpy as np
import rosnode
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker, MarkerArray

from turtlebot_recon.msg import TagDetectionArray
from turtlebot_recon.perception.families import dictionary

W, H, FX, CX, CY = 640, 480, 530.0, 319.5, 239.5
FRAME = "test_camera_optical"            # no TF anywhere reaches it
CELL_PX = 12                             # one marker bit
TAG_SIZE_M = 0.16
GOOD_ID, CUT_ID = 7, 9
GOOD_AT = (100, 100)                     # (row, col) of the whole marker's quiet zone
DETECTOR, COMPRESSED, TRACKER = "/tag_detector", "/compressed/tag_detector", "/tag_tracker"
RATE_HZ = 10.0                           # bad frames per second in a burst
BURST_FRAMES = 10                        # at least this many per cause: 1 s at RATE_HZ
TIMEOUT_S = 20.0                         # wall; every wait is on a condition


def marker_patch(marker_id: int) -> np.ndarray:
    """A tag36h11 marker: the 8 x 8 bit black square and a 2-bit white quiet zone (uint8)."""
    m = cv2.aruco.generateImageMarker(dictionary("tag36h11"), marker_id, 8 * CELL_PX, borderBits=1)
    q = 2 * CELL_PX
    return cv2.copyMakeBorder(m, q, q, q, q, cv2.BORDER_CONSTANT, value=255)


def scene(cut: bool = False) -> np.ndarray:
    """Grey 640 x 480 with marker GOOD_ID whole and, with cut, CUT_ID half out of the right edge."""
    img = np.full((H, W), 128, np.uint8)
    m = marker_patch(GOOD_ID)
    r, c = GOOD_AT
    img[r:r + m.shape[0], c:c + m.shape[1]] = m
    if cut:
        m = marker_patch(CUT_ID)
        c = W - m.shape[1] // 2
        img[250:250 + m.shape[0], c:] = m[:, :W - c]
    return img


def raw(stamp, encoding="rgb8", gray=None) -> Image:
    """A sensor_msgs/Image of ``gray`` (H x W) in ``encoding``; gray None: an empty (0 x 0) image."""
    m = Image()
    m.header.stamp, m.header.frame_id = stamp, FRAME
    m.encoding = encoding
    if gray is None:
        return m
    if encoding == "16UC1":
        pixels = gray.astype(np.uint16) * 256
    elif encoding == "rgba8":
        pixels = np.dstack([gray, gray, gray, np.full_like(gray, 255)])
    else:
        pixels = np.dstack([gray, gray, gray])
    m.height, m.width = gray.shape
    m.step = pixels.strides[0]
    m.data = pixels.tobytes()
    return m


def compressed(stamp, data: bytes) -> CompressedImage:
    m = CompressedImage()
    m.header.stamp, m.header.frame_id = stamp, FRAME
    m.format, m.data = "jpeg", data
    return m


def camera_info(fx: float) -> CameraInfo:
    """640 x 480, no distortion; fx = 0 gives an all-zero K (an uncalibrated camera)."""
    m = CameraInfo()
    m.header.stamp, m.header.frame_id = rospy.Time.now(), FRAME
    m.width, m.height = W, H
    m.distortion_model, m.D = "plumb_bob", [0.0] * 5
    m.K = [fx, 0.0, CX, 0.0, fx, CY, 0.0, 0.0, 1.0] if fx > 0 else [0.0] * 9
    m.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    m.P = [fx, 0.0, CX, 0.0, 0.0, fx, CY, 0.0, 0.0, 0.0, 1.0, 0.0] if fx > 0 else [0.0] * 12
    return m


def wait_for(cond, what: str, timeout: float = TIMEOUT_S) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline or rospy.is_shutdown():
            raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(0.05)


def ns(stamp) -> int:
    return stamp.to_nsec()


class TagsBadInput(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.logs = []                                   # (node, level, stamp s, text)
        cls.arrays = {DETECTOR: [], COMPRESSED: []}     # TagDetectionArray each detector published
        cls.tags, cls.markers = [], []
        cls.bad = set()                                 # stamps (ns) of every frame that must be dropped
        rospy.Subscriber("/rosout", Log, lambda m: cls.logs.append(
            (m.name, m.level, m.header.stamp.to_sec(), m.msg)), queue_size=1000)
        rospy.Subscriber("/tags/detections", TagDetectionArray, cls.arrays[DETECTOR].append, queue_size=100)
        rospy.Subscriber("/compressed/tags/detections", TagDetectionArray, cls.arrays[COMPRESSED].append,
                         queue_size=100)
        rospy.Subscriber("/tags", TagDetectionArray, cls.tags.append, queue_size=100)
        rospy.Subscriber("/tags/markers", MarkerArray, cls.markers.append, queue_size=100)
        cls.image_pub = rospy.Publisher("/test_camera/image_raw", Image, queue_size=1)
        cls.jpeg_pub = rospy.Publisher("/test_camera/image_raw/compressed", CompressedImage, queue_size=1)
        cls.info_pub = rospy.Publisher("/test_camera/camera_info", CameraInfo, queue_size=1, latch=True)
        wait_for(lambda: cls.image_pub.get_num_connections() >= 1 and cls.jpeg_pub.get_num_connections() >= 1
                 and cls.info_pub.get_num_connections() >= 2, "both detectors to subscribe", 40.0)
        wait_for(lambda: cls.tags, "the tracker's first /tags", 40.0)
        _, jpg = cv2.imencode(".jpg", scene(), [cv2.IMWRITE_JPEG_QUALITY, 90])
        cls.good_jpeg = jpg.tobytes()
        noise = np.random.default_rng(16).integers(0, 256, 4000, dtype=np.uint8).tobytes()
        cls.corrupt_jpeg = cls.good_jpeg[:2] + noise     # a JPEG start-of-image marker, then noise

    # helpers -----------------------------------------------------------------------------

    def lines(self, node: str, text: str) -> list:
        """(level, stamp s, text) of every /rosout line of ``node`` that contains ``text``."""
        return [(level, t, m) for n, level, t, m in self.logs if n == node and text in m]

    def assert_throttled_warning(self, node: str, text: str) -> None:
        lines = self.lines(node, text)
        self.assertTrue(lines, f"no line '{text}' from {node}")
        self.assertTrue(all(level == Log.WARN for level, _, _ in lines), lines)
        t = sorted(t for _, t, _ in lines)
        for a, b in zip(t, t[2:]):
            self.assertGreaterEqual(b - a, 1.0, f"{node} logged '{text}' 3 times within 1 s (not "
                                                f"throttled); its first lines: {lines[:4]}")

    def assert_nothing_from_dropped_frames(self) -> None:
        published = {ns(a.header.stamp) for a in self.arrays[DETECTOR] + self.arrays[COMPRESSED]}
        self.assertFalse(published & self.bad, "a frame that should have been dropped was processed")

    def burst(self, publish, until, what: str, min_frames=BURST_FRAMES, rate_hz=RATE_HZ, bad=True) -> list:
        """publish(stamp) sends one frame; frames go out at rate_hz until until(stamps) holds
        (the stamps sent so far, ns; ``what`` names it) and min_frames are out. Returns the
        stamps, remembered as must-drop when bad."""
        stamps, deadline, rate = [], time.monotonic() + TIMEOUT_S, rospy.Rate(rate_hz)
        while len(stamps) < min_frames or not until(stamps):
            if time.monotonic() > deadline:
                self.fail(f"{len(stamps)} frames in {TIMEOUT_S:.0f} s and still no {what}")
            stamp = rospy.Time.now()
            publish(stamp)
            stamps.append(ns(stamp))
            if bad:
                self.bad.add(ns(stamp))
            rate.sleep()
        return stamps

    def arrays_for(self, node: str, stamps: list) -> list:
        s = set(stamps)
        return [a for a in self.arrays[node] if ns(a.header.stamp) in s]

    def processed(self, node: str, publish, n: int = 1) -> list:
        """Good frames until ``node`` has published n arrays with their stamps: those arrays
        (queue_size 1: a slow detector skips frames)."""
        sent = self.burst(publish, lambda sent: len(self.arrays_for(node, sent)) >= n,
                          f"{n} array(s) from {node} with the frames' stamps", min_frames=n, bad=False)
        return self.arrays_for(node, sent)

    def refused(self, node: str, text: str, publish) -> None:
        """A burst of bad frames: ``node`` names the cause (``text``) in a throttled warning and
        publishes no array for any of them."""
        self.burst(publish, lambda _: self.lines(node, text), f"line '{text}' from {node} on /rosout")
        time.sleep(0.5)                                 # a late line or array would show by now
        self.assert_throttled_warning(node, text)
        self.assert_nothing_from_dropped_frames()

    # the cases, in order -----------------------------------------------------------------

    def test_1_no_camera_info_yet(self):
        img = scene()
        self.refused(DETECTOR, "no camera_info yet on /test_camera/camera_info",
                     lambda stamp: self.image_pub.publish(raw(stamp, gray=img)))
        self.assertEqual(self.arrays[DETECTOR], [])

    def test_2_uncalibrated_camera_info(self):
        self.info_pub.publish(camera_info(0.0))
        img = scene()
        self.refused(DETECTOR, "camera_info K has no positive focal lengths",
                     lambda stamp: self.image_pub.publish(raw(stamp, gray=img)))
        self.assertEqual(self.arrays[DETECTOR], [])

    def test_3_marker_detected_with_its_stamp_and_frame(self):
        self.info_pub.publish(camera_info(FX))
        img = scene()
        out = self.processed(DETECTOR, lambda stamp: self.image_pub.publish(raw(stamp, gray=img)))[0]
        self.assertEqual(out.header.frame_id, FRAME)
        self.assertEqual([(d.family, d.id) for d in out.detections], [("tag36h11", GOOD_ID)])
        d = out.detections[0]
        self.assertAlmostEqual(d.size, TAG_SIZE_M)
        z = FX * TAG_SIZE_M / (8 * CELL_PX)                            # 0.883 m
        u = GOOD_AT[1] + 2 * CELL_PX + 4 * CELL_PX - 0.5                # centre column, 171.5 px
        v = GOOD_AT[0] + 2 * CELL_PX + 4 * CELL_PX - 0.5                # centre row, 171.5 px
        p = d.pose.pose.position
        self.assertAlmostEqual(p.z, z, delta=0.01)
        self.assertAlmostEqual(p.x, (u - CX) / FX * z, delta=0.01)     # -0.247 m
        self.assertAlmostEqual(p.y, (v - CY) / FX * z, delta=0.01)     # -0.113 m
        self.assertFalse(d.ambiguous)

    def test_4_refused_frames(self):
        img = scene()
        for enc in ("16UC1", "rgba8"):
            self.refused(DETECTOR, f"image encoding '{enc}' is not supported",
                         lambda stamp: self.image_pub.publish(raw(stamp, enc, img)))
        self.refused(DETECTOR, "image is empty (0 x 0)", lambda stamp: self.image_pub.publish(raw(stamp)))
        # the compressed detector reads a good JPEG and refuses a corrupt one
        out = self.processed(COMPRESSED, lambda stamp: self.jpeg_pub.publish(compressed(stamp, self.good_jpeg)))
        self.assertEqual([d.id for d in out[0].detections], [GOOD_ID])
        self.refused(COMPRESSED, "cannot be decoded",
                     lambda stamp: self.jpeg_pub.publish(compressed(stamp, self.corrupt_jpeg)))

    def test_5_marker_cut_by_the_edge_not_detected(self):
        img = scene(cut=True)
        for out in self.processed(DETECTOR, lambda stamp: self.image_pub.publish(raw(stamp, gray=img)), n=3):
            self.assertEqual([d.id for d in out.detections], [GOOD_ID])    # the whole one only

    def test_6_tracker_drops_arrays_without_tf(self):
        static = tf2_ros.StaticTransformBroadcaster()      # TF exists, but not for the camera
        t = TransformStamped()
        t.header.stamp, t.header.frame_id, t.child_frame_id = rospy.Time.now(), "odom", "elsewhere"
        t.transform.rotation.w = 1.0
        static.sendTransform(t)
        img = scene()
        text = f"tag_tracker: no transform odom -> {FRAME}"
        # 5 frames a second: the tracker waits tf_timeout_s (0.1 s) on each before dropping it
        sent = self.burst(lambda stamp: self.image_pub.publish(raw(stamp, gray=img)),
                          lambda _: self.lines(TRACKER, text), f"line '{text}'", min_frames=15, rate_hz=5.0,
                          bad=False)
        last = rospy.Time.now()
        wait_for(lambda: self.arrays_for(DETECTOR, sent[-1:]), "the detector's array for the last frame")
        expected = sum(1 for a in self.arrays[DETECTOR] if a.detections)   # each went to the tracker
        save = rospy.ServiceProxy("/tag_tracker/save", Trigger)
        dropped = lambda msg: int(re.search(r"(\d+) array\(s\) without TF", msg).group(1))
        wait_for(lambda: dropped(save().message) >= expected, f"the tracker to drop {expected} arrays")
        res = save()
        self.assertTrue(res.success, res.message)
        self.assertIn("0 confirmed tag(s) saved", res.message)
        self.assertIn("'sightings': 0,", res.message)             # none reached the fusion
        self.assertEqual(dropped(res.message), expected, res.message)
        self.assert_throttled_warning(TRACKER, text)
        self.assertFalse(self.lines(TRACKER, "tag_tracker: confirmed"), "the tracker confirmed a tag")
        wait_for(lambda: self.tags[-1].header.stamp > last, "a /tags message after the last frame")
        self.assertTrue(all(m.header.frame_id == "odom" and not m.detections for m in self.tags),
                        "a tag reached /tags without a transform")
        self.assertTrue(all(k.action == Marker.DELETEALL for m in self.markers for k in m.markers),
                        "the tracker keeps a track placed without a transform")

    def test_7_both_nodes_alive(self):
        for node in (DETECTOR, COMPRESSED, TRACKER):
            self.assertTrue(rosnode.rosnode_ping(node, max_count=1), f"{node} does not answer")
        img = scene()
        out = self.processed(DETECTOR, lambda stamp: self.image_pub.publish(raw(stamp, gray=img)))
        self.assertEqual([d.id for d in out[0].detections], [GOOD_ID])
        self.assert_nothing_from_dropped_frames()

if __name__ == "__main__":
    rospy.init_node("tags_bad_input_test")
    rostest.rosrun("turtlebot_recon", "tags_bad_input", TagsBadInput)
