"""Camera: markers rendered with their real textures, decodable, at the right place (PnP)."""
import math

import cv2
import numpy as np
import pytest

from conftest import room, write_world
from turtlebot_recon.sim.markers import dictionary

TAGS = [
    # on the wall x = 4.1 (east), facing west (yaw = pi): straight ahead of a robot facing +x
    {"id": 7, "family": "tag36h11", "x": 4.1, "y": 1.5, "z": 0.2, "yaw": math.pi, "size": 0.16},
    # on the north wall y = 3.1, facing south
    {"id": 42, "family": "aruco_6x6_100", "x": 2.0, "y": 3.1, "z": 0.2, "yaw": -math.pi / 2, "size": 0.10},
]


@pytest.fixture
def tag_world(tmp_path):
    return write_world(tmp_path, "tags", room(4.0, 3.0), start=[3.0, 1.5, 0.0], tags=TAGS)


def detect(image, family, size, k):
    det = cv2.aruco.ArucoDetector(dictionary(family))
    corners, ids, _ = det.detectMarkers(cv2.cvtColor(image, cv2.COLOR_RGB2GRAY))
    if ids is None:
        return {}
    h = size / 2
    obj = np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], np.float32)
    out = {}
    for c, i in zip(corners, ids.ravel()):
        ok, rvec, tvec = cv2.solvePnP(obj, c.reshape(4, 2), k, None, flags=cv2.SOLVEPNP_IPPE_SQUARE)
        out[int(i)] = tvec.ravel()
    return out


@pytest.mark.parametrize("renderer", ["egl", "tiny"])
def test_tag_rendered_decodable_and_in_place(tag_world, make_sim, renderer):
    sim = make_sim(tag_world, "turtlebot3_waffle_pi", camera_rate_hz=5.0, camera_renderer=renderer)
    cam = sim.robot.camera
    img = sim.render_camera()
    assert img.shape == (cam.height_px, cam.width_px, 3) and img.dtype == np.uint8
    found = detect(img, "tag36h11", 0.16, sim.camera_matrix())
    assert list(found) == [7]
    # Camera at x = 3.0 + 0.073, y = 1.5 - 0.011, z = 0.104; tag centre at (4.1, 1.5, 0.2).
    # Optical frame: z forward = 4.1 - 3.073 = 1.027, x right = -(1.5 - 1.489) = -0.011,
    # y down = -(0.2 - 0.104) = -0.096.
    t = found[7]
    assert t == pytest.approx([-0.011, -0.096, 1.027], abs=0.02)


def test_aruco_family_and_camera_info(tag_world, make_sim):
    sim = make_sim(tag_world, "turtlebot3_waffle_pi", camera_rate_hz=5.0)
    sim.set_pose(2.0, 1.5, math.pi / 2)          # face north, 1.6 m from the ArUco marker
    found = detect(sim.render_camera(), "aruco_6x6_100", 0.10, sim.camera_matrix())
    # 1.527 m away a 0.10 m marker spans ~35 px; pixel quantisation of its edges allows ~3 %
    assert 42 in found and found[42][2] == pytest.approx(3.1 - 1.5 - 0.073, rel=0.03)
    k = sim.camera_matrix()
    # 62.2 deg horizontal FOV over 640 px: fx = 320 / tan(31.1 deg) = 530.4
    assert k[0, 0] == pytest.approx(320 / math.tan(math.radians(31.1)), rel=1e-3)
    assert math.degrees(sim.robot.camera.vfov_rad) == pytest.approx(48.8, abs=0.3)


def test_camera_due_only_at_its_rate(tag_world, make_sim):
    sim = make_sim(tag_world, "turtlebot3_waffle_pi", camera_rate_hz=5.0)
    due = [n for _ in range(100) for n in sim.step()]   # one sim second
    assert due.count("camera") == 5 and due.count("scan") == 5
    off = make_sim(tag_world, "turtlebot3_waffle_pi", camera_rate_hz=0.0)
    assert not off.camera_on and "camera" not in [n for _ in range(100) for n in off.step()]
