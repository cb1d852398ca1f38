"""World loading (DESIGN §4): map_server semantics, start selection, tags, clear errors."""
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from conftest import room, write_world
from turtlebot_recon.sim.world import WorldError, load_world

SHARED_WORLDS = Path(__file__).resolve().parents[3] / "shared" / "worlds"


def test_walls_where_the_image_is_dark_and_unknown_is_solid(tmp_path):
    free = room(2.0, 1.0)
    unknown = np.zeros_like(free)
    unknown[5:8, 10:13] = True   # an unknown blob inside the room
    w = load_world(write_world(tmp_path, "w", free, unknown=unknown))
    expected = free & ~unknown
    assert np.array_equal(w.free, expected)
    # cell (i, j) centre = origin + (j + .5, i + .5) * res: the wall cell at (0, 0) is solid
    assert not w.is_free(0.025, 0.025)
    assert w.is_free(0.5, 0.5)
    assert not w.is_free(0.55, 0.3)   # row 6, col 11: the unknown blob


def test_image_row_zero_is_the_top(tmp_path):
    free = room(2.0, 2.0)
    free[2:10, 2:10] = False   # obstacle near the ORIGIN corner (small x, small y)
    w = load_world(write_world(tmp_path, "w", free))
    assert not w.is_free(0.2, 0.2) and w.is_free(1.8, 1.8)


def test_negate_and_thresholds(tmp_path):
    free = room(1.0, 1.0, wall_m=1.0)   # walls 1 m thick around a 1 m room
    path = write_world(tmp_path, "w", free)
    meta = yaml.safe_load(path.read_text())
    meta["negate"] = 1           # now white (254) reads as occupied, black as free
    path.write_text(yaml.safe_dump(meta))
    assert np.array_equal(load_world(path).free, ~free)


def test_automatic_start_has_room_for_the_robot(tmp_path):
    free = room(3.0, 3.0)
    free[30:34, 30:34] = False   # a pillar at the centre of the map
    w = load_world(write_world(tmp_path, "w", free))
    clearance = w.clearance()
    r, c = w.cell(*w.start[:2])
    assert w.is_free(*w.start[:2]) and clearance[r, c] >= 0.35


@pytest.mark.parametrize("name", ["depot", "tb3_sandbox"])
def test_real_maps_load_unchanged(name):
    path = SHARED_WORLDS / f"{name}.yaml"
    w = load_world(path)
    # every tag listed on its walls loads (the loader rejects one off a wall or inside it)
    listed = yaml.safe_load(path.read_text()).get("tags") or []
    assert len(w.tags) == len(listed) and w.resolution == pytest.approx(0.05)
    r, c = w.cell(*w.start[:2])
    assert w.clearance()[r, c] >= 0.35
    if name == "tb3_sandbox":   # everything outside the hexagon is unknown, hence solid
        assert not w.free[0, 0] and w.free.mean() < 0.2


def test_tags_on_walls_facing_free_space(tmp_path):
    tags = [{"id": 1, "family": "tag36h11", "x": 2.0, "y": 0.1, "z": 0.25, "yaw": math.pi / 2, "size": 0.16}]
    w = load_world(write_world(tmp_path, "w", room(4.0, 2.0), tags=tags))
    t = w.tags[0]
    assert (t.id, t.family) == (1, "tag36h11")
    assert w.is_free(t.x + 0.05 * math.cos(t.yaw), t.y + 0.05 * math.sin(t.yaw))
    assert not w.is_free(t.x - 0.05 * math.cos(t.yaw), t.y - 0.05 * math.sin(t.yaw))


@pytest.mark.parametrize("change, key", [
    (lambda m: m.update(image="missing.pgm"), "'image'"),
    (lambda m: m.update(resolution=-0.05), "'resolution'"),
    (lambda m: m.update(resolution="fine"), "'resolution'"),
    (lambda m: m.update(mode="colour"), "'mode'"),               # mapping.map_io's reading
    (lambda m: m.update(free_thresh="low"), "'free_thresh'"),    # of the map_server keys
    (lambda m: m.update(start=[0.0, 0.0, 0.0]), "'start'"),
    (lambda m: m.update(tags=[{"id": 1, "x": 2.0, "y": 0.1, "yaw": -math.pi / 2}]), "'tags[0]'"),
])
def test_bad_world_files_name_the_file_and_key(tmp_path, change, key):
    path = write_world(tmp_path, "bad", room(4.0, 2.0))
    meta = yaml.safe_load(path.read_text())
    change(meta)
    path.write_text(yaml.safe_dump(meta))
    with pytest.raises(WorldError) as err:
        load_world(path)
    assert str(path) in str(err.value) and key in str(err.value)


def test_no_free_cell_is_a_clear_error(tmp_path):
    path = write_world(tmp_path, "solid", np.zeros((40, 40), bool))
    with pytest.raises(WorldError, match="no free cell"):
        load_world(path)


def test_missing_world_file_lists_shipped_worlds(tmp_path):
    with pytest.raises(WorldError, match="not found"):
        load_world(tmp_path / "nope.yaml")


def test_a_tag_at_an_angle_to_the_pixel_walls_is_moved_clear_of_them(tmp_path):
    """A real map's wall runs at an angle to the pixel grid the walls are drawn from: a marker
    placed along it would sink into the pixel boxes at one side (the camera then sees half of
    it). The loader moves it along its normal until all of it is in front; a marker on a
    straight face stays where it is."""
    from turtlebot_recon.sim import load_world
    from turtlebot_recon.sim.markers import full_scale
    tags = [{"id": 1, "family": "tag36h11", "x": 4.1, "y": 1.5, "z": 0.2, "yaw": math.pi, "size": 0.16},
            {"id": 2, "family": "tag36h11", "x": 4.1, "y": 2.5, "z": 0.2, "yaw": math.pi - 0.12, "size": 0.16}]
    w = load_world(write_world(tmp_path, "slant", room(4.0, 3.0), start=[1.0, 1.5, 0.0], tags=tags))
    straight, slanted = w.tags
    assert (straight.x, straight.y) == (4.1, 1.5)
    half = 0.5 * 0.16 * full_scale("tag36h11")
    moved = math.hypot(slanted.x - 4.1, slanted.y - 2.5)
    assert half * math.sin(0.12) - 0.003 <= moved <= half * math.sin(0.12) + 0.003
    assert slanted.x < 4.1                                   # out of the wall, along its normal
