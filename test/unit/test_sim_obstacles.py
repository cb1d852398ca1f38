"""Obstacles with a height band (DESIGN §4's extension): the world file's boxes, solid only
between z_min and z_max. The TurtleBot 2's depth scan (0.287 m) passes over a 0.15 m step and
under a 0.30-0.50 m bed frame, its body (0.01-0.41 m as the simulator places it) hits both, and
a shelf at 0.45-0.80 m is above it; the footprints are never free in the world's grid."""
import math

import numpy as np
import pytest
import yaml

from conftest import drive, room, write_world
from turtlebot_recon.sim.world import WorldError, load_world

START = [1.0, 1.5, 0.0]                    # facing +x, the box ahead across y 1.0-2.0
BOX = {"x0": 2.0, "y0": 1.0, "x1": 2.4, "y1": 2.0}
STEP, BED, SHELF, CABINET = (0.0, 0.15), (0.30, 0.50), (0.45, 0.80), (0.0, 0.45)
TB2_LIDAR_X = 1.0 - 0.087                  # the depth scan's origin: x_m -0.087 behind the centre
TO_BOX, TO_WALL = 2.0 - TB2_LIDAR_X, 4.1 - TB2_LIDAR_X   # 1.087 m, 3.187 m along the middle beam


def box_world(tmp_path, *bands):
    """The 4 x 3 m room (free x 0.1-4.1, y 0.1-3.1) with one box per band at BOX's footprint."""
    obstacles = [{**BOX, "z_min": lo, "z_max": hi} for lo, hi in bands]
    return write_world(tmp_path, "boxes", room(4.0, 3.0), start=START, obstacles=obstacles)


def test_footprints_are_not_free_and_not_walls(tmp_path):
    w = load_world(box_world(tmp_path, STEP))
    assert w.obstacles[0].z_max == 0.15 and len(w.obstacles) == 1
    # cells of 0.05 m: x 2.0-2.4 is columns 40-47, y 1.0-2.0 rows 20-39
    assert not w.free[20:40, 40:48].any()
    assert w.free[20:40, 39].all() and w.free[20:40, 48].all() and w.free[19, 40:48].all()
    assert not w.walls[20:40, 40:48].any()           # the simulator builds it at its own height
    assert np.array_equal(w.walls | ~w.free, ~w.free) and (~w.free).sum() - w.walls.sum() == 8 * 20
    # the clearance (and so F) sees it: column 39's centre x 1.975 is 0.025 m from the face at 2.0
    assert w.clearance()[30, 39] == pytest.approx(0.025)


@pytest.mark.parametrize("box, key_hint", [
    ({**BOX, "z_min": 0.3, "z_max": 0.3}, "z_min 0.3 m must be below z_max"),
    ({**BOX, "z_min": 0.5, "z_max": 0.3}, "must be below z_max"),
    ({**BOX, "z_min": -0.1, "z_max": 0.3}, "below the floor"),
    ({"x0": 2.0, "y0": 1.0, "x1": 2.4, "z_min": 0.0, "z_max": 0.3}, "missing ['y1']"),
    ({**BOX, "z_min": 0.0}, "missing ['z_max']"),
    ({**BOX, "z_min": 0.0, "z_max": float("nan")}, "'z_max' must be a finite number"),
    ({**BOX, "x1": float("inf"), "z_min": 0.0, "z_max": 0.3}, "'x1' must be a finite number"),
    ({**BOX, "z_min": "low", "z_max": 0.3}, "'z_min' must be a finite number"),
    ({**BOX, "z_min": 0.0, "z_max": 0.3, "yaw": 0.5}, "unknown key(s) ['yaw']"),
    ({**BOX, "x0": 2.4, "x1": 2.0, "z_min": 0.0, "z_max": 0.3}, "x0 < x1"),
    ({"x0": 9.0, "y0": 9.0, "x1": 9.5, "y1": 9.5, "z_min": 0.0, "z_max": 0.3}, "outside the map"),
    ([2.0, 1.0, 2.4, 2.0, 0.0, 0.3], "expected a mapping"),
])
def test_bad_boxes_are_refused_in_one_line(tmp_path, box, key_hint):
    path = box_world(tmp_path)
    meta = yaml.safe_load(path.read_text())
    meta["obstacles"] = [box]
    path.write_text(yaml.safe_dump(meta))
    with pytest.raises(WorldError) as err:
        load_world(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: key 'obstacles[0]': ") and key_hint in msg and "\n" not in msg


def test_obstacles_must_be_a_list_and_may_not_cover_the_start(tmp_path):
    path = box_world(tmp_path)
    meta = yaml.safe_load(path.read_text())
    meta["obstacles"] = {"x0": 1.0}
    path.write_text(yaml.safe_dump(meta))
    with pytest.raises(WorldError, match=r"key 'obstacles': expected a list"):
        load_world(path)
    meta["obstacles"] = [{"x0": 0.8, "y0": 1.3, "x1": 1.2, "y1": 1.7, "z_min": 0.3, "z_max": 0.5}]
    path.write_text(yaml.safe_dump(meta))
    with pytest.raises(WorldError, match=r"key 'start'"):     # its footprint is not free space
        load_world(path)


@pytest.mark.parametrize("band, seen", [(STEP, False), (BED, False), (SHELF, False), (CABINET, True)])
def test_tb2_scan_sees_a_box_only_where_its_height_is_in_the_band(tmp_path, make_sim, band, seen):
    sim = make_sim(box_world(tmp_path, band), "turtlebot2")
    r = sim.true_ranges()
    middle = r[len(r) // 2 - 2:len(r) // 2 + 2]       # the beams straight ahead (y 1.5)
    assert middle == pytest.approx(TO_BOX if seen else TO_WALL, abs=0.005)


def test_burger_lidar_passes_over_the_step_but_sees_the_cabinet(tmp_path, make_sim):
    # the LDS-01 at 0.172 m: above a 0.15 m step, inside a 0-0.45 m cabinet
    for band, face_x in ((STEP, 4.1), (CABINET, 2.0)):
        sim = make_sim(box_world(tmp_path, band), "turtlebot3_burger")
        origin_x = 1.0 + sim.robot.lidar.x_m                                 # 0.032 m behind the centre
        assert sim.true_ranges()[0] == pytest.approx(face_x - origin_x, abs=0.005)   # beam 0: +x


@pytest.mark.parametrize("robot, band, blocked", [
    ("turtlebot2", STEP, True),          # the step is below the lidar, not below the body
    ("turtlebot2", BED, True),           # the bed frame is above the lidar, not above the 0.41 m top
    ("turtlebot2", SHELF, False),        # 0.45 m: 4 cm above the body's top
    ("turtlebot3_burger", BED, False),   # the burger (0.19 m tall) drives under the bed frame
    ("turtlebot3_burger", STEP, True),
])
def test_body_collides_with_a_box_only_where_their_heights_overlap(tmp_path, make_sim, robot, band, blocked):
    sim = make_sim(box_world(tmp_path, band), robot)
    drive(sim, 0.3, 0.0, 7.0)             # 0.3 m/s for 7 s: up to ~2 m, from x 1.0 to ~3.0
    if blocked:
        # stopped with its disc against the box's face x = 2.0
        assert sim.collisions == 1
        assert sim.pose[0] == pytest.approx(2.0 - sim.robot.radius_m, abs=0.01)
        if sim.robot.bumpers:             # the Kobuki's centre bumper pressed
            assert any(e.side == 1 and e.pressed for e in sim.bumper_events)
    else:
        assert sim.collisions == 0 and sim.pose[0] > 2.4 + sim.robot.radius_m


def test_add_box_with_a_band_above_the_robot_is_allowed(tmp_path, make_sim):
    sim = make_sim(box_world(tmp_path), "turtlebot2")
    with pytest.raises(ValueError, match="overlaps the robot"):
        sim.add_box(0.8, 1.3, 1.2, 1.7, *BED)
    sim.add_box(0.8, 1.3, 1.2, 1.7, *SHELF)             # a shelf over the robot
    assert not sim.world.is_free(1.0, 1.5) and sim.world.obstacles[-1].z_min == 0.45
    assert sim.world.walls[sim.world.cell(1.0, 1.5)] == False   # noqa: E712 (numpy bool)
    with pytest.raises(ValueError, match="0 <= z_min < z_max"):
        sim.add_box(3.0, 1.0, 3.5, 2.0, 0.5, 0.3)
    drive(sim, 0.3, 0.0, 1.0)
    assert sim.collisions == 0 and sim.pose[0] > 1.1


def test_a_wall_box_from_add_box_is_as_tall_as_the_walls(tmp_path, make_sim):
    sim = make_sim(box_world(tmp_path), "turtlebot2")
    sim.add_box(2.0, 1.0, 2.4, 2.0)
    assert sim.world.obstacles[-1].z_max == sim.world.wall_height
    assert sim.true_ranges()[320] == pytest.approx(TO_BOX, abs=0.005)
    assert math.isclose(sim.world.obstacles[-1].z_min, 0.0)
