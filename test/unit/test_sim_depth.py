"""The TurtleBot 2's depth camera: z-depth (REP 118) from PyBullet's depth buffer, registered to
the RGB camera, NaN outside 0.45-4 m, one render for both when both are due, and an image that
the depth pipeline (perception.depth) reads back to the right points in the world."""
import math

import numpy as np
import pytest

from conftest import room, write_world
from turtlebot_recon.perception.depth import DepthCamera, depth_metres

START = [1.0, 1.5, 0.0]
BOX = {"x0": 2.0, "y0": 1.0, "x1": 2.4, "y1": 2.0}
CAM_X = 1.0 - 0.087            # the camera's x in the world (x_m -0.087); it looks along +x, level
CAM_Z = 0.287
TO_BOX = 2.0 - CAM_X           # 1.087 m: z-depth of the box's face x = 2.0, whatever the pixel


def world(tmp_path, *bands):
    obstacles = [{**BOX, "z_min": lo, "z_max": hi} for lo, hi in bands]
    return write_world(tmp_path, "boxes", room(4.0, 3.0), start=START, obstacles=obstacles)


def row_at(sim, height_m):
    """The depth image's row (float) that sees the box's face x = 2.0 at ``height_m``."""
    k = sim.depth_matrix()
    return k[1, 2] + k[1, 1] * (CAM_Z - height_m) / TO_BOX   # y down in the optical frame


def at(depth, row):
    """Depth in the middle column (the box spans y 1.0-2.0 around the camera's y 1.4875)."""
    return depth[int(round(row)), depth.shape[1] // 2]


@pytest.mark.parametrize("band, height", [
    ((0.0, 0.15), 0.075),      # a step under the depth scan's 0.287 m: the image sees its face
    ((0.30, 0.50), 0.40),      # a bed frame over it
    ((0.45, 0.80), 0.60),      # a shelf above the robot
])
def test_depth_sees_the_box_faces_the_scan_misses(tmp_path, make_sim, band, height):
    sim = make_sim(world(tmp_path, band), "turtlebot2", depth_rate_hz=2.5)
    depth = sim.true_depth()
    assert depth.shape == (120, 160) and depth.dtype == np.float32
    assert at(depth, row_at(sim, height)) == pytest.approx(TO_BOX, abs=0.01)
    # without the box: the floor (below the camera: z = 0.287 / tan of the pixel's angle down),
    # or above it the wall x = 4.1 or, over its 0.5 m, nothing (NaN)
    bare = make_sim(world(tmp_path), "turtlebot2", depth_rate_hz=2.5).true_depth()
    r = int(round(row_at(sim, height)))
    k = sim.depth_matrix()
    if height < CAM_Z:
        assert at(bare, r) == pytest.approx(CAM_Z / ((r - k[1, 2]) / k[1, 1]), rel=0.03)
    else:
        assert not at(bare, r) < 3.0


def test_out_of_range_is_nan_and_z_is_along_the_optical_axis(tmp_path, make_sim):
    sim = make_sim(world(tmp_path), "turtlebot2", depth_rate_hz=2.5)
    depth = sim.true_depth()
    # the middle row looks level at the wall x = 4.1: every pixel's z-depth is 3.187 m, the
    # outer pixels' ray is longer (1 / cos 23 deg) but z is not. Beyond +-23 deg (1.4 m to the
    # side walls over 3.187 m; fx 133 px: 57 px off the centre) the side walls are nearer.
    middle = depth[60, 80 - 55:80 + 55]
    assert np.nanmax(np.abs(middle - (4.1 - CAM_X))) < 0.01 and not np.isnan(middle).any()
    sim.set_pose(3.787, 1.5, 0.0)        # the camera 0.40 m from the wall x = 4.1: below 0.45 m, NaN
    assert np.isnan(sim.true_depth()[60, 80])
    sim.set_pose(3.787, 1.5, math.pi)    # facing the wall x = 0.1: 3.874 - 0.1 m away, in range
    assert sim.true_depth()[60, 80] == pytest.approx(3.774, abs=0.01)
    far = make_sim(write_world(tmp_path, "long", room(6.0, 3.0), start=START), "turtlebot2", depth_rate_hz=2.5)
    assert np.isnan(far.true_depth()[60, 80])    # the wall x = 6.1 is 5.187 m away: beyond 4 m


def test_one_render_serves_both_and_agrees_with_the_depth_render(tmp_path, make_sim):
    sim = make_sim(world(tmp_path, (0.30, 0.50)), "turtlebot2", camera_rate_hz=2.5, depth_rate_hz=2.5)
    due = [d for _ in range(40) for d in sim.step()]
    assert due.count("camera") == 1 and due.count("depth") == 1      # the same step: 2.5 Hz at 100 Hz
    rgb, shared = sim.render_views(rgb=True, depth=True)
    assert rgb.shape == (480, 640, 3) and shared.shape == (120, 160)
    own = sim.true_depth()
    both = ~np.isnan(shared) & ~np.isnan(own)
    assert np.mean(np.isnan(shared) == np.isnan(own)) > 0.97 and both.mean() > 0.5   # above the walls: none
    # the same surfaces: noise (sigma <= 1.2 mm + 1.9 mm * 3.2^2 = 21 mm at the far wall) and
    # the shared frame's 1/8-pixel offset, except at depth edges
    diff = np.abs(shared[both] - own[both])
    assert np.median(diff) < 0.01 and np.mean(diff < 0.08) > 0.97
    assert at(shared, row_at(sim, 0.40)) == pytest.approx(TO_BOX, abs=0.02)
    _, alone = sim.render_views(rgb=False, depth=True)                # the depth render alone
    assert np.median(np.abs(alone[both] - own[both])) < 0.01


def test_noise_is_seeded_and_sized_like_the_sensor(tmp_path, make_sim):
    path = world(tmp_path)
    a = make_sim(path, "turtlebot2", depth_rate_hz=2.5, seed=3)
    b = make_sim(path, "turtlebot2", depth_rate_hz=2.5, seed=3)
    da, db = a.render_views(False, True)[1], b.render_views(False, True)[1]
    assert np.array_equal(da, db, equal_nan=True)
    err = (da - a.true_depth())[58:62, 20:140]          # the wall x = 4.1 at z 3.187 m
    sigma = 0.0012 + 0.0019 * 3.187 ** 2                # 0.0205 m
    assert np.nanstd(err) == pytest.approx(sigma, rel=0.2)


def test_depth_image_reads_back_through_the_depth_pipeline(tmp_path, make_sim):
    """The bridge's 32FC1 message, read by depth_metres and DepthCamera with the published K,
    gives the box's face at x = 2.0 in the world (the optical frame's pose: the RGB camera's)."""
    from turtlebot_recon.ros import convert
    sim = make_sim(world(tmp_path, (0.0, 0.15)), "turtlebot2", depth_rate_hz=2.5)
    depth = sim.true_depth()
    msg = convert.image_32fc1(depth, "camera_depth_optical", 0.0)
    assert (msg.encoding, msg.step, msg.header.frame_id) == ("32FC1", 640, "camera_depth_optical")
    back = depth_metres(msg.encoding, msg.height, msg.width, msg.step, msg.data, bool(msg.is_bigendian))
    assert np.array_equal(back, depth, equal_nan=True)
    info = convert.camera_info(sim.robot.depth_camera, sim.depth_matrix(), 0.0)
    cam = DepthCamera(np.array(info.K).reshape(3, 3), info.width, info.height, 1)
    points = cam.points(back, sim.optical_pose()).reshape(120, 160, 3)
    face = points[int(round(row_at(sim, 0.075))), 60:100]
    assert face[:, 0] == pytest.approx(2.0, abs=0.01) and face[:, 2] == pytest.approx(0.075, abs=0.02)
    floor = points[-1, 80]                                      # the floor: z = 0
    assert floor[2] == pytest.approx(0.0, abs=0.01)
    # the organised cloud the bridge publishes (every 2nd pixel): x, y, z float32 in order
    sub = DepthCamera(sim.depth_matrix(), 160, 120, 2)
    cloud = convert.point_cloud_xyz(sub.optical_points(back), *sub.shape, "camera_depth_optical", 0.0)
    assert (cloud.height, cloud.width, cloud.point_step, cloud.is_dense) == (60, 80, 12, False)
    xyz = np.frombuffer(cloud.data, "<f4").reshape(60, 80, 3)
    assert np.array_equal(xyz[:, :, 2], back[::2, ::2], equal_nan=True)


def test_turtlebot3s_have_no_depth_camera(tmp_path, make_sim):
    sim = make_sim(world(tmp_path), "turtlebot3_waffle_pi", camera_rate_hz=5.0, depth_rate_hz=2.5)
    assert sim.camera_on and not sim.depth_on
    assert "depth" not in [d for _ in range(40) for d in sim.step()]


def test_a_depth_camera_needs_the_rgb_camera(tmp_path):
    import yaml
    from turtlebot_recon.config import ConfigError
    from turtlebot_recon.robot import CONFIG_DIR, load_robot
    spec = yaml.safe_load((CONFIG_DIR / "turtlebot2.yaml").read_text())
    del spec["camera"]
    path = tmp_path / "blind.yaml"
    path.write_text(yaml.safe_dump(spec))
    with pytest.raises(ConfigError, match="depth_camera: is registered to the RGB camera"):
        load_robot(str(path))
    spec = yaml.safe_load((CONFIG_DIR / "turtlebot2.yaml").read_text())
    spec["depth_camera"]["range_min_m"] = 5.0
    path.write_text(yaml.safe_dump(spec))
    with pytest.raises(ConfigError, match="range_min_m: must be < range_max_m"):
        load_robot(str(path))
