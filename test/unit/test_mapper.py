"""Mapper core: bad scans sorted and counted, map files as map_saver writes them, precision."""
import math
import re

import numpy as np
import pytest

from conftest import room, write_world
from turtlebot_recon.evaluation import map_precision
from turtlebot_recon.geometry import compose
from turtlebot_recon.mapping.map_io import MapError, load_map, save_map
from turtlebot_recon.mapping.mapper import Mapper, MapperSettings, Scan, body_disc
from turtlebot_recon.robot import load_robot
from turtlebot_recon.sim import load_world
from turtlebot_recon.sim.simulator import SimSettings, Simulator


def scan(ranges, angle_min=0.0, angle_max=None, inc=math.radians(1), rmin=0.12, rmax=3.5, t=1.0):
    ranges = np.asarray(ranges, np.float32)
    if angle_max is None:
        angle_max = angle_min + inc * (len(ranges) - 1)
    return Scan(ranges, angle_min, angle_max, inc, rmin, rmax, t)


@pytest.fixture
def mapper():
    return Mapper(MapperSettings(), robot_radius_m=0.177)


def test_bad_scans_are_skipped_with_a_reason(mapper):
    assert mapper.check_scan(scan([])) == "empty"
    assert mapper.check_scan(scan([1.0] * 10, angle_max=math.radians(100))) == "length_mismatch"
    assert mapper.check_scan(scan([1.0] * 360, inc=float("nan"))) == "bad_header"
    assert mapper.check_scan(scan([1.0] * 360, rmin=4.0)) == "bad_header"
    # one beam more or less than angle_max implies is what real drivers do: accepted
    assert mapper.check_scan(scan([1.0] * 360, angle_max=math.radians(360))) is None
    assert mapper.skipped == {"empty": 1, "length_mismatch": 1, "bad_header": 2}
    assert "skipped: bad_header 2, empty 1, length_mismatch 1" in mapper.diagnostics()


def test_bad_beams_are_counted_not_inserted(mapper):
    r = np.full(360, 2.0, np.float32)
    r[:10] = np.nan
    r[10:20] = np.inf          # no return
    r[20:30] = 0.0             # LDS-01 no return
    r[30:40] = 0.05            # too close
    r[40:50] = 7.0             # beyond range_max: no return
    mapper.insert(scan(r), (0.0, 0.0, 0.0))
    assert dict(mapper.beams) == {"valid": 310, "no_return": 30, "too_close": 10, "nan": 10}
    occ = mapper.grid.occupancy()
    assert (occ >= 65).any() and (occ == -1).any()


def test_time_jump_back_is_detected_once(mapper):
    assert not mapper.time_jumped_back(10.0)
    assert not mapper.time_jumped_back(9.5)        # less than a second back: not a restart
    assert mapper.time_jumped_back(2.0)
    assert not mapper.time_jumped_back(2.2)
    assert mapper.skipped["time_jump_back"] == 1


def test_save_and_reload_like_map_saver(tmp_path):
    occ = np.full((4, 6), -1, np.int8)
    occ[0, :] = 0
    occ[1, 2] = 100
    occ[2, 3] = 50             # uncertain: map_saver writes it as unknown
    occ[3, 5] = 20             # <= 25: free
    path = save_map(tmp_path / "m", occ, 0.05, (-1.0, 2.0))
    text = path.read_text()
    assert "image: m.pgm" in text and "origin: [-1.0, 2.0, 0.0]" in text
    back, res, origin = load_map(path)
    expected = np.full_like(occ, -1)
    expected[0, :] = 0
    expected[1, 2] = 100
    expected[3, 5] = 0
    assert res == 0.05 and origin == (-1.0, 2.0)
    assert np.array_equal(back, expected)
    # map_server's orientation: the PGM's last row is grid row 0 (all free here)
    import cv2
    assert (cv2.imread(str(tmp_path / "m.pgm"), cv2.IMREAD_UNCHANGED)[-1] == 254).all()


def test_a_map_with_a_bad_threshold_names_the_file_and_key(tmp_path):
    path = save_map(tmp_path / "m", np.zeros((4, 6), np.int8), 0.05, (0.0, 0.0))
    path.write_text(path.read_text().replace("free_thresh: 0.196", "free_thresh: low"))
    with pytest.raises(MapError, match=re.escape(f"{path}: key 'free_thresh'")):
        load_map(path)


def test_precision_of_a_perfect_and_a_wrong_map(tmp_path):
    world = load_world(write_world(tmp_path, "w", room(3.0, 2.0), start=[1.0, 1.0, 0.5]))
    # A perfect map in the robot's frame (start pose = map origin): sample the world there.
    x0, y0, yaw = world.start
    res = 0.05
    rows, cols = np.mgrid[0:80, 0:100]
    mx, my = -2.5 + (cols + 0.5) * res, -2.0 + (rows + 0.5) * res
    wx = x0 + math.cos(yaw) * mx - math.sin(yaw) * my
    wy = y0 + math.sin(yaw) * mx + math.cos(yaw) * my
    truth = np.array([[world.is_free(a, b) for a, b in zip(ra, rb)] for ra, rb in zip(wx, wy)])
    occ = np.where(truth, 0, 100).astype(np.int8)
    p = map_precision(occ, res, (-2.5, -2.0), world, world.start)
    assert p["map_precision_free"] == 1.0 and p["map_precision_occupied"] == 1.0
    # Mark a free square in the middle of the room occupied: those cells are wrong.
    # The square spans +-0.25 m around the start, >= 0.5 m from every wall: 100 wrong cells,
    # so precision = correct / (correct + 100).
    bad = occ.copy()
    bad[35:45, 45:55] = 100
    p = map_precision(bad, res, (-2.5, -2.0), world, world.start)
    correct = int((occ == 100).sum())
    assert p["map_precision_occupied"] == pytest.approx(correct / (correct + 100))
    assert p["map_precision_free"] == 1.0


def test_mapping_a_simulated_room_is_precise(tmp_path, mapper):
    path = write_world(tmp_path, "r", room(3.0, 2.0), start=[1.0, 1.0, 0.0])
    world = load_world(path)
    sim = Simulator(world, load_robot("turtlebot3_burger"), SimSettings(camera_rate_hz=0.0, seed=2))
    lid = sim.robot.lidar
    for k in range(12):
        sim.set_pose(1.0 + 0.1 * k, 1.0, 0.5 * k)
        x, y, yaw = sim.sensor_pose(lid.x_m, lid.y_m)
        sx, sy, syaw = world.start
        # the map frame is the start pose
        c, s = math.cos(-syaw), math.sin(-syaw)
        pose = (c * (x - sx) - s * (y - sy), s * (x - sx) + c * (y - sy), yaw - syaw)
        r = sim.scan()
        mapper.insert(Scan(r, lid.angle_min_rad, lid.angle_max_rad, lid.angle_increment_rad,
                           lid.range_min_m, lid.range_max_m, float(k)), pose)
    sim.close()
    g = mapper.grid
    p = map_precision(g.occupancy(), g.resolution, (g.origin_x, g.origin_y), world, world.start)
    assert p["map_precision_occupied"] >= 0.98 and p["map_precision_free"] >= 0.98
    assert p["cells_free"] * g.resolution ** 2 > 4.0      # most of the 6 m^2 room seen


def test_the_floor_under_the_robot_is_free_once_it_stands_there():
    # A waffle_pi-like box: disc 0.1 m ahead of base_footprint, radius 0.14 m. Standing at
    # (1.0, 1.0) facing +y, its cells that are unknown become free; a known occupied cell
    # inside the disc keeps its value; cells outside stay unknown.
    core = Mapper(MapperSettings(), robot_radius_m=0.257, body_disc=(0.1, 0.14))
    g = core.grid
    g.mark_bumper(1.0, 1.0, math.pi / 2, 0.0, 0.05, 1)    # an occupied cell at ~(1.0, 1.075)
    before = g.occupancy().copy()
    core.motion((1.0, 1.0, math.pi / 2), 0.0, 0.0)
    occ = g.occupancy()

    def at(x, y):
        return occ[int(math.floor((y - g.origin_y) / g.resolution)), int(math.floor((x - g.origin_x) / g.resolution))]

    assert 0 <= at(1.0, 1.2) <= 25 and 0 <= at(1.1, 1.1) <= 25     # inside the disc about (1.0, 1.1)
    assert at(1.0, 1.3) == -1 and at(1.0, 0.9) == -1               # beyond it (0.2 m from its centre)
    changed = (before != occ)
    assert (occ[changed] >= 0).all() and (occ[changed] <= 25).all()
    assert (occ >= 65).sum() == (before >= 65).sum() == 1            # the known cell kept
    # a second call changes nothing: those cells are known now
    assert g.free_unknown_disc(1.0, 1.1, 0.14) == 0


def test_redraw_from_corrected_keyframes_makes_a_drifted_map_precise(tmp_path):
    """Scans inserted at drifting poses smear the room; once SLAM's corrected keyframe poses
    arrive (every fourth scan a keyframe), every kept scan is drawn again at its keyframe's
    corrected pose composed with the odometry since: the redrawn map holds the same occupied
    cells as one drawn at the true poses, and the same poses again need no redraw."""
    world = load_world(write_world(tmp_path, "r", room(4.0, 3.0), start=[1.0, 1.0, 0.0]))
    sim = Simulator(world, load_robot("turtlebot3_burger"), SimSettings(camera_rate_hz=0.0, seed=2))
    lid = sim.robot.lidar
    offset = (lid.x_m, lid.y_m, 0.0)
    core = Mapper(MapperSettings(map_frame="map"), robot_radius_m=0.105)
    reference = Mapper(MapperSettings(), robot_radius_m=0.105)      # drawn at the true poses
    truth, odom, stamps = [], [], []
    for k in range(24):
        true = (0.1 * k, 0.05 * k, 0.2 * k)               # map frame = start pose
        sim.set_pose(1.0 + true[0], 1.0 + true[1], true[2])
        drifted = compose(true, (0.02 * k, -0.015 * k, 0.02 * k))   # odometry's error grows
        scan = Scan(sim.scan(), lid.angle_min_rad, lid.angle_max_rad, lid.angle_increment_rad,
                    lid.range_min_m, lid.range_max_m, 10.0 + k)
        core.insert(scan, tuple(compose(drifted, offset)), tuple(drifted), offset)
        reference.insert(scan, tuple(compose(true, offset)))
        truth.append(true)
        odom.append(drifted)
        stamps.append(10.0 + k)
    sim.close()

    def occupied(grid):   # the occupied cells, in cells of the map frame (extents may differ)
        rows, cols = np.nonzero(grid.occupancy() >= 65)
        return {(round(grid.origin_x / 0.05) + c, round(grid.origin_y / 0.05) + r) for r, c in zip(rows, cols)}

    expected = occupied(reference.grid)
    assert len(occupied(core.grid) ^ expected) > 0.5 * len(expected)     # the drift smeared the walls
    kf = list(range(0, 24, 4))
    # SLAM first reports the keyframes where odometry put them: drawn already, nothing to do
    assert not core.needs_redraw([stamps[k] for k in kf], [odom[k] for k in kf])
    # then corrects them; between keyframes the odometry's own drift remains (as in SLAM's
    # map -> odom), so the scans there move with their keyframe
    assert core.needs_redraw([stamps[k] for k in kf], [truth[k] for k in kf])
    grid, drawn = core.redraw([stamps[k] for k in kf], [truth[k] for k in kf])
    assert drawn == 24
    core.swap(grid, drawn)
    assert core.grid is grid and core.rerenders == 1
    p = map_precision(grid.occupancy(), grid.resolution, (grid.origin_x, grid.origin_y), world, world.start)
    assert p["map_precision_occupied"] >= 0.95 and p["map_precision_free"] >= 0.95
    assert not core.needs_redraw([stamps[k] for k in kf], [truth[k] for k in kf])
    assert "redrawn 1 times along 6 keyframes" in core.diagnostics()
    # every scan a keyframe at its true pose: exactly the reference's walls
    grid, _ = core.redraw(stamps, truth)
    assert occupied(grid) == expected


def test_a_saved_map_is_the_start_and_scans_update_it(tmp_path):
    """``prior`` (a saved map, mapper.yaml's initial_map): the grid starts as that map (its
    cells, origin and size; unknown stays unknown) and later scans change it like any other
    cells; a redraw (SLAM) starts from it again. Another resolution is refused by name."""
    occ = np.full((40, 60), -1, np.int8)
    occ[5:35, 5:55] = 0
    occ[5, 5:55] = 100                                   # a wall along y = -1.0 + 5 cells
    origin = (-1.5, -1.25)
    core = Mapper(MapperSettings(map_frame="map"), robot_radius_m=0.105, prior=(occ, 0.05, origin))
    g = core.grid
    assert (g.rows, g.cols, g.origin_x, g.origin_y) == (40, 60, -1.5, -1.25)
    start = g.occupancy()
    assert (start[occ == -1] == -1).all()
    assert (start[occ == 0] == 12).all() and (start[occ == 100] == 97).all()   # p_min, p_max
    # a wall 1 m ahead of the sensor at (0, 0) that the saved map lacks: after a few scans it is in
    ranges = np.full(5, 1.0, np.float32)
    for k in range(4):
        core.insert(scan(ranges, angle_min=-math.radians(2), t=1.0 + k), (0.0, 0.0, 0.0))
    now = core.grid.occupancy()
    assert now[core.grid.cell(1.02, 0.0)] >= 65 and start[g.cell(1.02, 0.0)] == 12
    assert now[core.grid.cell(0.2, -0.98)] == 97        # the saved wall, untouched by these beams
    grid, drawn = core.redraw([], [])
    assert drawn == 0 and np.array_equal(grid.occupancy(), start)
    with pytest.raises(ValueError, match="resolution 0.1 m differs from the mapper's grid.resolution 0.05 m"):
        Mapper(MapperSettings(), robot_radius_m=0.105, prior=(occ, 0.1, origin))
    with pytest.raises(ValueError, match="set_logodds: a 3 x 3 array for a 40 x 60 grid"):
        g.set_logodds(np.zeros((3, 3), np.float32))


def test_a_press_before_the_pose_is_marked_at_the_next_motion_if_fresh():
    # the centre bumper (0 rad) of a 0.2 m body at (1.0, 1.0) facing +x marks x ~ 1.2
    core = Mapper(MapperSettings(), robot_radius_m=0.2)
    core.hold_bump(1, now_s=10.0)
    core.motion((1.0, 1.0, 0.0), 0.0, now_s=10.4)          # 0.4 s later: within BUMP_MAX_AGE_S
    g = core.grid
    occ = g.occupancy()
    r, c = int((1.0 - g.origin_y) / g.resolution), int((1.2 - g.origin_x) / g.resolution)
    assert occ[r - 1:r + 2, c - 1:c + 2].max() >= 65 and core.bumps[0][0] == 1
    core.hold_bump(1, now_s=20.0)
    core.motion((1.0, 1.0, 0.0), 0.0, now_s=20.6)          # too late: the base may have moved
    assert len(core.bumps) == 1 and core.skipped["bumper_no_tf"] == 1 and not core.held_bumps


def test_body_disc_of_a_round_and_a_box_robot():
    assert body_disc(load_robot("turtlebot3_burger")) == (0.0, load_robot("turtlebot3_burger").radius_m)
    waffle = load_robot("turtlebot3_waffle_pi")
    ahead, radius = body_disc(waffle)
    assert ahead == waffle.footprint_offset_x_m
    assert radius == 0.5 * min(waffle.footprint_length_m, waffle.footprint_width_m)
