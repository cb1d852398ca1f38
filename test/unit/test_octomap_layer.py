"""The OctoMap layer (mapping/octomap_layer.py over _native.OctomapLayer) and the depth image to
points (perception/depth.py): what a depth camera adds to the lidar's map.

Scenes are axis-aligned boxes rendered exactly (test/benchmarks/octomap_figures.py); the
camera is the TurtleBot 2's (640 x 480, 0.287 m up, sampled at stride 4 to 160 x 120), whose
lidar (a depth scan) lies in the plane z = 0.287 m; the robot is 0.40 m tall.
"""
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import octomap_figures as scene  # noqa: E402

from turtlebot_recon import _native  # noqa: E402
from turtlebot_recon.config import ConfigError, from_dict  # noqa: E402
from turtlebot_recon.mapping import GridSettings, make_grid  # noqa: E402
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH  # noqa: E402
from turtlebot_recon.mapping.octomap_layer import (OBSTACLE, OctomapLayer, OctomapSettings,  # noqa: E402
                                                   merge_obstacles)
from turtlebot_recon.perception.depth import DepthCamera, depth_metres, stride_for  # noqa: E402
from turtlebot_recon.perception.image import ImageError  # noqa: E402
from turtlebot_recon.planning import (LETHAL, CostmapSettings, LatticeSettings, footprint_clear,  # noqa: E402
                                      make_costmap)
from turtlebot_recon.robot import load_robot  # noqa: E402

TB2 = load_robot("turtlebot2")
CAM = TB2.camera
K = scene.camera_matrix(CAM)
RES = 0.05
SETTINGS = OctomapSettings().with_robot(TB2)          # config/octomap.yaml, robot height 0.40 m
FLOOR = scene.box(-3.0, -3.0, -0.1, 5.0, 3.0, 0.0)    # its top face is the floor, z = 0
# 0.15 m tall, under the 0.287 m scan plane; its front face at x = 1.42 lies inside the voxels
# and cells of x in [1.40, 1.45) (not on an edge, where float rounding would pick the side)
LOW_BOX = scene.box(1.42, -0.22, 0.0, 1.82, 0.22, 0.15)


def new_layer(**overrides) -> OctomapLayer:
    return OctomapLayer(OctomapSettings(**overrides).with_robot(TB2))


def camera() -> DepthCamera:
    return DepthCamera(K, CAM.width_px, CAM.height_px, stride_for(CAM.width_px, SETTINGS.depth_columns))


def see(layer: OctomapLayer, boxes: list, x=0.0, y=0.0, yaw=0.0):
    """One depth frame of ``boxes`` from the TurtleBot 2 at (x, y, yaw), inserted."""
    pose = scene.optical_pose(x, y, yaw, (CAM.x_m, CAM.y_m, CAM.z_m))
    depth = scene.render_depth(K, CAM.width_px, CAM.height_px, pose, boxes)
    return layer.insert(camera().points(depth, pose), pose[:3, 3])


def lidar_grid(boxes: list, x=0.0, y=0.0, scans=3):
    """The 2-D map of the TurtleBot 2's lidar (its depth scan, in the plane z = 0.287 m) at
    (x, y, heading 0) after ``scans`` scans of ``boxes``: a default mapper grid."""
    lid = TB2.lidar
    grid = make_grid(GridSettings())
    angles = np.linspace(lid.angle_min_rad, lid.angle_max_rad, lid.beams)
    sx, sy = x + lid.x_m, y + lid.y_m
    beams = np.stack((np.cos(angles), np.sin(angles), np.zeros(angles.size)), 1)
    ranges = scene.ray_hits((sx, sy, lid.z_m), beams, boxes)
    ranges = np.where(ranges <= lid.range_max_m, ranges, np.inf).astype(np.float32)
    for _ in range(scans):
        grid.insert_scan(sx, sy, 0.0, ranges, lid.angle_min_rad, angles[1] - angles[0], lid.range_min_m,
                         lid.range_max_m, GridSettings.no_return_clear_m, GridSettings.range_cap_m)
    return grid


def cells_inside(b, grid_origin, shape, res=RES) -> tuple:
    """Rows and columns of the cells whose centres lie inside box ``b``'s footprint."""
    ys = grid_origin[1] + (np.arange(shape[0]) + 0.5) * res
    xs = grid_origin[0] + (np.arange(shape[1]) + 0.5) * res
    rows = np.flatnonzero((ys > b[0, 1]) & (ys < b[1, 1]))
    cols = np.flatnonzero((xs > b[0, 0]) & (xs < b[1, 0]))
    return np.ix_(rows, cols)


def project_like(layer: OctomapLayer, grid) -> np.ndarray:
    return layer.project(grid.rows, grid.cols, grid.resolution, (grid.origin_x, grid.origin_y))


# ------------------------------------------------------------------------------ insertion

def test_a_ray_clears_the_voxels_it_crosses_and_marks_its_end():
    layer = new_layer()
    # sensor and end point at voxel centres on one row of voxels (0.05 m): x = 0.025 ... 1.025
    origin = (0.025, 0.025, 0.225)
    stats = layer.insert(np.array([[1.025, 0.025, 0.225]]), origin)
    assert (stats.inserted, stats.non_finite, stats.above_max_z) == (1, 0, 0)
    xs = 0.025 + RES * np.arange(22)                      # 0.025 ... 1.075
    p = layer.tree.probabilities(np.stack((xs, np.full(22, 0.025), np.full(22, 0.225)), 1))
    # one miss: OctoMap's prob_miss 0.4 in each of the 20 voxels from the sensor's to the one
    # before the end; one hit: prob_hit 0.7 at the end; beyond it nothing is known
    np.testing.assert_allclose(p[:20], 0.4, atol=1e-4)
    assert p[20] == pytest.approx(0.7, abs=1e-4)
    assert math.isnan(p[21])


def test_a_point_beyond_max_range_clears_up_to_it_and_marks_nothing():
    layer = new_layer(max_range_m=1.0)
    layer.insert(np.array([[2.025, 0.025, 0.225]]), (0.025, 0.025, 0.225))
    xs = np.array([0.525, 0.975, 1.125, 2.025])
    p = layer.tree.probabilities(np.stack((xs, np.full(4, 0.025), np.full(4, 0.225)), 1))
    np.testing.assert_allclose(p[:2], 0.4, atol=1e-4)      # within 1 m: one miss each
    assert np.isnan(p[2:]).all()                          # past 1 m: never reached
    assert layer.occupied_voxels()[0].shape == (0, 3)


def test_a_depth_frame_clears_the_space_before_a_box_and_marks_its_face():
    layer = new_layer()
    stats = see(layer, [FLOOR, LOW_BOX])
    # every sampled pixel: a point, no return (NaN: the sky past the floor's end) or too high
    assert stats.inserted + stats.non_finite + stats.above_max_z == 160 * 120
    assert stats.inserted > 0.4 * 160 * 120
    p = layer.tree.probabilities(np.array([[0.725, 0.025, 0.125],     # between camera and box
                                           [1.425, 0.025, 0.075],     # the box's front face
                                           [0.725, 0.025, 0.025]]))   # the floor before it
    assert p[0] < 0.5 and p[1] > 0.5 and p[2] > 0.5


# ------------------------------------------------------------------------------ projection

def test_projection_follows_the_grid_convention():
    layer = new_layer()
    layer.insert(np.array([[0.125, 0.325, 0.2]]), (0.125, 0.325, 0.3))   # straight down: one voxel
    grid = layer.project(10, 8, RES, (0.0, 0.0))
    # voxel [0.10, 0.15) x [0.30, 0.35): row 0 is the smallest y, so row 6, column 2
    assert list(zip(*np.nonzero(grid == OBSTACLE))) == [(6, 2)]
    assert (grid[grid != OBSTACLE] == -1).all()           # no free space: the layer knows none
    # on a 0.1 m grid shifted by (-0.1, 0) the voxel lies inside cell row 3, column 2
    coarse = layer.project(5, 4, 0.1, (-0.1, 0.0))
    assert list(zip(*np.nonzero(coarse == OBSTACLE))) == [(3, 2)]


def test_the_layer_blocks_a_box_that_the_lidar_passes_over():
    room = [FLOOR, scene.box(-1.0, -2.1, 0.0, 3.1, -2.0, 0.5), scene.box(-1.0, 2.0, 0.0, 3.1, 2.1, 0.5),
            scene.box(3.0, -2.0, 0.0, 3.1, 2.0, 0.5)]
    grid = lidar_grid(room + [LOW_BOX])
    occupancy = grid.occupancy()
    layer = new_layer()
    see(layer, room + [LOW_BOX])
    merged = merge_obstacles(occupancy, project_like(layer, grid))
    under = cells_inside(LOW_BOX, (grid.origin_x, grid.origin_y), occupancy.shape)
    front = under[0], under[1][:, :1]                      # the cells of the face the camera sees
    # the lidar saw the box's cells free (its beams passed over); the layer blocks its face,
    # the whole width of it (the top face, seen at 4-5 deg, only where a sampled row lands)
    assert (occupancy[under] >= 0).all() and (occupancy[under] < OCCUPIED_THRESH).all()
    assert (merged[front] == OBSTACLE).all() and front[0].size == 8
    # elsewhere the lidar's values stay: its walls, its free and unknown cells
    layer_cells = project_like(layer, grid) == OBSTACLE
    assert (merged[~layer_cells] == occupancy[~layer_cells]).all()
    # the costmap and the lattice take it as a wall
    costmap = make_costmap(merged, RES, CostmapSettings.for_robot(TB2))
    assert (costmap[front] == LETHAL).all()
    assert (make_costmap(occupancy, RES, CostmapSettings.for_robot(TB2))[under] < LETHAL).all()
    on_box = np.array([[1.62, 0.0, 0.0]])
    args = (RES, (grid.origin_x, grid.origin_y), TB2, on_box, LatticeSettings())
    assert footprint_clear(occupancy, *args)[0] and not footprint_clear(merged, *args)[0]


def test_the_floor_is_no_obstacle():
    layer = new_layer()
    see(layer, [FLOOR])
    centres, sizes = layer.occupied_voxels()
    assert len(centres) > 1000 and np.abs(centres[:, 2]).max() < 0.03   # the floor's voxels, seen
    assert not (layer.project(120, 160, RES, (-3.0, -3.0)) == OBSTACLE).any()
    # the floor band is what keeps them out: without it the floor is one big obstacle
    flat = new_layer(floor_band_m=0.0)
    see(flat, [FLOOR])
    assert (flat.project(120, 160, RES, (-3.0, -3.0)) == OBSTACLE).sum() > 500


def test_an_overhang_below_the_robot_top_is_projected_and_one_above_it_is_not():
    low_shelf = scene.box(1.02, -0.6, 0.30, 1.52, -0.2, 0.36)  # between the scan plane and 0.40 m
    high_shelf = scene.box(1.02, 0.2, 0.41, 1.52, 0.6, 0.44)   # above the robot's top
    boxes = [FLOOR, low_shelf, high_shelf]
    grid = lidar_grid(boxes)
    layer = new_layer()
    see(layer, boxes)
    merged = merge_obstacles(grid.occupancy(), project_like(layer, grid))
    origin = (grid.origin_x, grid.origin_y)
    low, high = cells_inside(low_shelf, origin, merged.shape), cells_inside(high_shelf, origin, merged.shape)
    assert (grid.occupancy()[low] < OCCUPIED_THRESH).all()    # the scan passes under it
    # the camera sees the shelf's front face: its column of cells, x in [1.00, 1.05)
    assert (merged[low][:, 0] == OBSTACLE).all()
    assert not (merged[high] == OBSTACLE).any()
    centres, _ = layer.occupied_voxels()
    assert (centres[:, 2] > 0.40).any()                        # seen, and left out by the band only


def test_a_table_seen_from_the_front_blocks_its_hidden_far_side_until_the_camera_looks():
    """Issue 33's 3-D check: a table top above the scan plane seen from the front shows the
    camera (0.287 m up, below the top) its front face only; the scan passes under and calls
    the cells beneath free. Its far side blocks while hidden (``obstacles``), and what lies
    behind it opens once the camera has looked from the other side."""
    walls = [scene.box(-1.0, -2.1, 0.0, 4.6, -2.0, 0.5), scene.box(-1.0, 2.0, 0.0, 4.6, 2.1, 0.5),
             scene.box(4.5, -2.0, 0.0, 4.6, 2.0, 0.5), scene.box(-1.1, -2.0, 0.0, -1.0, 2.0, 0.5)]
    table = scene.box(1.52, -0.32, 0.30, 2.22, 0.32, 0.45)
    boxes = [FLOOR, table] + walls
    grid = lidar_grid(boxes)
    occupancy, origin = grid.occupancy(), (grid.origin_x, grid.origin_y)
    layer = new_layer()
    see(layer, boxes)
    under = cells_inside(table, origin, occupancy.shape)
    behind = cells_inside(scene.box(2.27, -0.2, 0.0, 2.6, 0.2, 0.0), origin, occupancy.shape)
    for cells in (under, behind):                                         # the scan: free
        assert ((occupancy[cells] >= 0) & (occupancy[cells] < OCCUPIED_THRESH)).all()
    front_only = project_like(layer, grid)
    # the front face, and the underside where a sampled row grazes it: most of the top unseen
    assert (front_only[under][:, 0] == OBSTACLE).all() and (front_only[under] != OBSTACLE).mean() > 0.7
    seen = layer.obstacles(occupancy, RES, origin)
    # the far part of the top (beyond where a row grazed the underside) and what lies behind it
    # block; between the front face and that graze the cells are walled in on both sides
    far_side = under[0], under[1][:, -6:]
    assert (front_only[far_side] != OBSTACLE).mean() > 0.9
    assert (seen[far_side] == OBSTACLE).all() and (seen[behind] == OBSTACLE).all()
    # walls (the lidar's) cast nothing, unknown cells stay unknown, nothing beyond the extent
    added = (seen == OBSTACLE) & (front_only != OBSTACLE)
    assert ((occupancy[added] >= 0) & (occupancy[added] < OCCUPIED_THRESH)).all()
    in_front = cells_inside(scene.box(0.3, -1.5, 0.0, 1.4, 1.5, 0.0), origin, occupancy.shape)
    assert not (seen[in_front] == OBSTACLE).any()
    far = cells_inside(scene.box(3.3, -1.5, 0.0, 4.4, 1.5, 0.0), origin, occupancy.shape)
    assert not (seen[far] == OBSTACLE).any()
    off = OctomapLayer(replace(SETTINGS, hidden_extent_m=0.0))
    see(off, boxes)
    assert (off.obstacles(occupancy, RES, origin) == project_like(off, grid)).all()
    # from the far side (x = 4.0, facing back) the camera looks behind the table: that opens,
    # and the table's own far face blocks
    see(layer, boxes, x=4.0, yaw=math.pi)
    both = layer.obstacles(occupancy, RES, origin)
    assert not (both[behind] == OBSTACLE).any()
    far_face = cells_inside(scene.box(2.2, -0.3, 0.0, 2.25, 0.3, 0.0), origin, occupancy.shape)
    assert (both[far_face] == OBSTACLE).all() and (both[under][:, 0] == OBSTACLE).all()


def test_the_robots_own_column_is_free():
    layer = new_layer()
    layer.insert(np.array([[0.5, 0.0, 0.2]]), (0.5, 0.0, 0.3))     # a voxel seen occupied
    assert layer.tree.probabilities(np.array([[0.525, 0.025, 0.225]]))[0] > 0.5
    n = layer.free_body(0.5, 0.0, 0.15)
    # the disc's columns up to the robot's 0.40 m (8 voxels), each voxel one miss
    offsets = np.arange(-3, 4) * RES + 0.025                         # column centres from (0.5, 0.0)
    columns = int((np.hypot(*np.meshgrid(offsets, offsets)) <= 0.15).sum())
    assert columns == 32 and n == 8 * columns
    probe = np.array([[0.525, 0.125, 0.375], [0.475, -0.075, 0.025], [0.5, 0.4, 0.2]])
    p = layer.tree.probabilities(probe)
    assert p[0] < 0.5 and p[1] < 0.5 and np.isnan(p[2])             # inside: free; outside: unknown
    with pytest.raises(ValueError, match="free_body"):
        layer.free_body(math.nan, 0.0, 0.15)


# ------------------------------------------------------------------------------ bad points

def test_non_finite_points_are_skipped_and_counted():
    good = np.array([[1.0, 0.0, 0.2], [1.0, 0.5, 0.1], [0.8, -0.4, 0.3]])
    bad = np.array([[np.nan, 0, 0], [0, np.inf, 0], [0, 0, -np.inf], [np.nan, np.nan, np.nan]])
    high = np.array([[1.0, 0.0, 0.9]])                         # above max_point_z_m 0.45
    layer, reference = new_layer(), new_layer()
    stats = layer.insert(np.vstack((bad[:2], good[:2], high, bad[2:], good[2:])), (0, 0, 0.287))
    assert (stats.inserted, stats.non_finite, stats.above_max_z) == (3, 4, 1)
    reference.insert(good, (0, 0, 0.287))
    for a, b in zip(layer.occupied_voxels(), reference.occupied_voxels()):
        np.testing.assert_array_equal(a, b)
    assert layer.leaf_count == reference.leaf_count


def test_an_empty_cloud_changes_nothing():
    layer = new_layer()
    for empty in (np.zeros((0, 3)), np.zeros(0), []):
        stats = layer.insert(empty, (0, 0, 0.3))
        assert (stats.inserted, stats.non_finite) == (0, 0)
    assert layer.leaf_count == 0


@pytest.mark.parametrize("points, origin, match", [
    (np.zeros((4, 2)), (0, 0, 0), r"points must be an \(n, 3\) array"),
    (np.zeros((4, 3)), (0, math.nan, 0), "sensor origin must be finite"),
])
def test_bad_clouds_are_refused_in_one_line(points, origin, match):
    with pytest.raises(ValueError, match=match) as err:
        new_layer().insert(points, origin)
    assert "\n" not in str(err.value)


def test_bad_settings_and_grids_are_refused():
    with pytest.raises(ConfigError, match="robot_height_m"):
        from_dict(OctomapSettings, {"floor_band_m": 0.3, "robot_height_m": 0.2}, "octomap.yaml")
    with pytest.raises(ConfigError, match="prob_hit"):
        from_dict(OctomapSettings, {"prob_hit": 0.4}, "octomap.yaml")
    with pytest.raises(ValueError, match="max_point_z_m"):
        new_layer(max_point_z_m=0.3)                           # below the TurtleBot 2's 0.40 m
    with pytest.raises(ValueError, match="robot_height_m"):
        OctomapLayer(OctomapSettings())                        # the robot's height unresolved
    with pytest.raises(ValueError, match="rows > 0"):
        new_layer().project(0, 10, RES, (0, 0))
    with pytest.raises(ValueError, match="resolution must be > 0 m"):    # the C++ core's own check
        _native.OctomapLayer(resolution=0.0, prob_hit=0.7, prob_miss=0.4, clamping_thres_min=0.12,
                             clamping_thres_max=0.97, occupancy_thres=0.5)
    with pytest.raises(ValueError, match="shape"):
        merge_obstacles(np.zeros((3, 3), np.int8), np.zeros((3, 4), np.int8))


# ------------------------------------------------------------------------------ depth images

def depth_scene() -> np.ndarray:
    """A 640 x 480 depth image in metres rounded to the millimetre, with no-return pixels."""
    pose = scene.optical_pose(0.0, 0.0, 0.3, (CAM.x_m, CAM.y_m, CAM.z_m))
    depth = scene.render_depth(K, CAM.width_px, CAM.height_px, pose,
                               [FLOOR, LOW_BOX], far_m=3.0)
    return np.round(depth * 1000.0) / 1000.0


def test_16uc1_and_32fc1_give_the_same_points():
    metres = depth_scene()
    assert np.isnan(metres).any() and np.isfinite(metres).any()
    mm = np.nan_to_num(metres * 1000.0, nan=0.0).round().astype(np.uint16)
    h, w = metres.shape
    as_float = depth_metres("32FC1", h, w, 4 * w, metres.astype("<f4").tobytes())
    as_mm = depth_metres("16UC1", h, w, 2 * w, mm.astype("<u2").tobytes())
    as_mm_big = depth_metres("16UC1", h, w, 2 * w + 6, np.pad(mm.astype(">u2"), ((0, 0), (0, 3))).tobytes(),
                             is_bigendian=True)                # rows padded: step > 2 width
    pose = scene.optical_pose(0.5, 0.2, 0.3, (CAM.x_m, CAM.y_m, CAM.z_m))
    points = [camera().points(d, pose) for d in (as_float, as_mm, as_mm_big)]
    assert points[0].shape == (160 * 120, 3)
    for other in points[1:]:
        np.testing.assert_array_equal(np.isnan(points[0]), np.isnan(other))
        np.testing.assert_allclose(points[0], other, atol=1e-5, equal_nan=True)


def test_depth_back_projects_through_k():
    # the pixel at the principal point sees straight ahead: (0, 0, z) in the optical frame;
    # (u, v) = (cx + fx, cy) at depth 2 m lies at x = (u - cx) / fx * 2 = 2 m to the right
    cam = DepthCamera([100.0, 0, 10.0, 0, 100.0, 5.0, 0, 0, 1], 21, 11, 1)
    depth = np.full((11, 21), 2.0, np.float32)
    depth[0, 0] = np.nan
    p = cam.optical_points(depth).reshape(11, 21, 3)
    np.testing.assert_allclose(p[5, 10], (0.0, 0.0, 2.0))
    np.testing.assert_allclose(p[5, 20], (0.2, 0.0, 2.0))
    assert np.isnan(p[0, 0]).all()
    # a camera 1 m up looking along map x (optical z = map x, optical y = -map z)
    pose = scene.optical_pose(0.0, 0.0, 0.0, (0.0, 0.0, 1.0))
    np.testing.assert_allclose(cam.points(depth, pose).reshape(11, 21, 3)[5, 20], (2.0, -0.2, 1.0), atol=1e-6)


@pytest.mark.parametrize("make, match", [
    (lambda: depth_metres("rgb8", 2, 2, 6, bytes(12)), "depth encoding 'rgb8' is not supported"),
    (lambda: depth_metres("16UC1", 2, 2, 4, bytes(6)), "data too short"),
    (lambda: DepthCamera([0.0] * 9, 640, 480, 4), "no positive focal lengths"),
    (lambda: DepthCamera(K, 640, 480, 4).points(np.zeros((240, 320), np.float32), np.eye(4)),
     "camera_info is for 640 x 480 but the depth image is 320 x 240"),
    (lambda: DepthCamera(K, 640, 480, 4).points(np.zeros((480, 640), np.float32), np.eye(3)),
     "4 x 4 transform"),
])
def test_bad_depth_input_is_refused_in_one_line(make, match):
    with pytest.raises(ImageError, match=match) as err:
        make()
    assert isinstance(err.value, ValueError) and "\n" not in str(err.value)


# ------------------------------------------------------------------------------ files, size

def test_bt_round_trip_keeps_the_occupied_voxels(tmp_path):
    layer = new_layer()
    see(layer, [FLOOR, LOW_BOX])
    path = tmp_path / "octomap.bt"
    before = layer.occupied_voxels()
    layer.save(path)
    assert path.read_bytes().startswith(b"# Octomap OcTree binary file")
    np.testing.assert_array_equal(layer.occupied_voxels()[0], before[0])   # saving changes nothing
    loaded = new_layer(resolution_m=0.1)
    loaded.load(path)
    assert loaded.tree.resolution == pytest.approx(RES)                    # the file's
    for a, b in zip(loaded.occupied_voxels(), before):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(RuntimeError, match="cannot read"):
        loaded.load(tmp_path / "missing.bt")
    assert len(loaded.occupied_voxels()[1]) == len(before[1])             # kept after a failure


def test_memory_and_leaves_grow_with_what_is_seen():
    layer = new_layer()
    empty_bytes = layer.memory_bytes
    see(layer, [FLOOR])
    assert layer.leaf_count > 1000 and layer.memory_bytes > empty_bytes
    assert "OctomapLayer(resolution=0.05" in repr(layer.tree)


def test_a_scan_becomes_its_returns_at_the_lidars_height():
    from turtlebot_recon.mapping.octomap_layer import scan_cloud
    sensor = np.eye(4)
    sensor[:3, 3] = (1.0, 2.0, 0.287)                    # the lidar at (1, 2), 0.287 m up, facing +y
    sensor[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    ranges = np.array([2.0, np.inf, np.nan, 0.1, 5.0, 1.0], np.float32)   # one return, junk, one return
    pts = scan_cloud(ranges, -np.pi / 2, np.pi / 5, 0.2, 4.0, sensor)
    assert pts.dtype == np.float32 and pts.shape == (2, 3)
    # beam 0 at -90 deg in the laser frame points along the map's +x; beam 5 at +90 deg along -x
    assert np.allclose(pts, [[3.0, 2.0, 0.287], [0.0, 2.0, 0.287]], atol=1e-5)


def test_height_colours_run_from_blue_at_the_floor_to_red_at_the_top():
    from turtlebot_recon.mapping.octomap_layer import height_colours
    rgb = height_colours(np.array([0.0, 0.03, 0.215, 0.4, 2.0]), 0.03, 0.4)
    assert np.allclose(rgb[0], (0, 0, 1)) and np.allclose(rgb[1], (0, 0, 1))   # at or below the band
    assert np.allclose(rgb[2], (0, 1, 0), atol=1e-6)                           # half way: green
    assert np.allclose(rgb[3], (1, 0, 0)) and np.allclose(rgb[4], (1, 0, 0))   # the top and above
