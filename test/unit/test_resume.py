"""Resuming after a kill (docs/faults.md): the mapper's resume file and the tag tracker's
tags.yaml are written atomically, taken back only by a node of the same launch, and a mapper
or tracker built from them goes on where the dead one stood."""
import math
import os

import numpy as np
import pytest

from test_tag_tracker import WALL, camera, seen
from turtlebot_recon.files import write_atomic
from turtlebot_recon.mapping.mapper import Mapper, MapperSettings, Scan
from turtlebot_recon.mapping.resume import decided, known_cells, load_resume, resume_path, save_resume
from turtlebot_recon.perception.tracker import (CONFIRMED, TagTracker, TrackerSettings, load_tags_yaml,
                                                resumable_tracks, to_standalone_tags_yaml)


def wall_scan(distance_m=2.0, t=1.0):
    """360 beams of 1 degree, each hitting at ``distance_m``: a round room around the lidar."""
    inc = math.radians(1)
    return Scan(np.full(360, distance_m, np.float32), 0.0, inc * 359, inc, 0.12, 3.5, t)


def mapped():
    m = Mapper(MapperSettings(), robot_radius_m=0.177)
    m.insert(wall_scan(), (0.0, 0.0, 0.0))
    m.insert(wall_scan(1.5, t=2.0), (-6.0, -1.0, 0.5))   # beyond the initial 10 m: the grid grew
    return m


def test_a_resumed_mapper_has_the_dead_ones_grid_cell_for_cell(tmp_path):
    dead = mapped()
    logodds, res, origin = dead.resume_state()
    assert origin != (-5.0, -5.0)                          # the grid had grown: the origin travels too
    path = save_resume(resume_path(tmp_path / "map"), logodds, res, origin, key="run_1", stamp_s=42.0)
    assert path == tmp_path / "map.resume.npz"
    back = load_resume(path, "run_1")
    assert back[3] == 42.0
    new = Mapper(MapperSettings(), robot_radius_m=0.177, resume=back[:3])
    g, d = new.grid, dead.grid
    assert (g.origin_x, g.origin_y, g.rows, g.cols) == (d.origin_x, d.origin_y, d.rows, d.cols)
    np.testing.assert_array_equal(g.occupancy(), d.occupancy())
    assert (g.occupancy() >= 65).sum() > 100               # the walls are there, not an empty map
    new.insert(wall_scan(t=3.0), (0.0, 0.0, 0.0))          # and scans go on into it
    assert new.scans == 1


def test_a_resume_file_of_another_launch_or_none_is_not_taken(tmp_path):
    path = resume_path(tmp_path / "map")
    assert load_resume(path, "run_1") is None              # no file: a first start
    save_resume(path, *mapped().resume_state(), key="run_0", stamp_s=1.0)
    assert load_resume(path, "run_1") is None              # an earlier run in the same directory
    path.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a mapper resume file"):
        load_resume(path, "run_1")


def test_a_write_that_fails_leaves_the_previous_file_whole(tmp_path, monkeypatch):
    """A full disk (or a kill) in the middle of a save: the file a restarted node reads is the
    previous one, whole, and no temporary file is left."""
    path = resume_path(tmp_path / "map")
    save_resume(path, *mapped().resume_state(), key="run_1", stamp_s=10.0)
    before = path.read_bytes()

    def full_disk(_fd):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "fsync", full_disk)
    with pytest.raises(OSError, match="No space left"):
        save_resume(path, *Mapper(MapperSettings(), 0.177).resume_state(), key="run_1", stamp_s=20.0)
    with pytest.raises(OSError):
        write_atomic(tmp_path / "tags.yaml", "standalone_tags: []\n")
    assert path.read_bytes() == before
    assert load_resume(path, "run_1")[3] == 10.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.resume.npz"]


def confirmed_tracker():
    tracker = TagTracker(TrackerSettings())
    T = camera(1.0, 0.0, 0.0)
    for i in range(3):
        tracker.update(seen(T, (WALL[0] + 0.002 * i, WALL[1], WALL[2])), T, 10.0 + i)
    tracker.update(seen(T, WALL, tag_id=7), T, 13.0)        # seen once: tentative, not saved
    return tracker


def test_a_restarted_tracker_goes_on_from_its_tags_yaml():
    dead = confirmed_tracker()
    text = to_standalone_tags_yaml(dead.tags(), resume_key="run_1")
    assert load_tags_yaml(text) == dead.tags()              # still a plain tags.yaml to every reader
    assert resumable_tracks(text, "run_2") is None          # an earlier run's file
    assert resumable_tracks(to_standalone_tags_yaml(dead.tags()), "run_1") is None   # no key
    new = TagTracker(TrackerSettings())
    new.restore(resumable_tracks(text, "run_1"))
    assert new.tags() == dead.tags() and [t.state for t in new.tags()] == [CONFIRMED]
    (tag,) = new.tags()
    assert tag.sightings == 3
    T = camera(1.0, 0.0, 0.0)                               # a sighting fuses into the resumed track
    assert new.update(seen(T, WALL), T, 20.0) == "fused"
    assert new.tags()[0].sightings == 4


def test_known_cells_of_two_origins_meet_in_one_frame():
    # a 2 x 3 grid at origin (0, 0) and the same cells seen by a grid starting 1 cell left
    # (origin -0.05): its column 1 is the first grid's column 0
    a = np.array([[True, False, False], [False, False, True]])
    b = np.array([[False, True, False, False], [False, False, False, True]])
    assert known_cells(a, 0.05, (0.0, 0.0)) == {(0, 0), (2, 1)}
    assert known_cells(b, 0.05, (-0.05, 0.0)) == known_cells(a, 0.05, (0.0, 0.0))


def test_decided_cells_are_those_a_saved_map_keeps():
    # p = 0.2 (20 %: free), 0.5 (unknown in a PGM), 0.7 (70 %: occupied), NaN (unknown)
    logodds = np.log(np.array([[0.2 / 0.8, 1.0, 0.7 / 0.3, np.nan]], np.float32))
    assert decided(logodds).tolist() == [[True, False, True, False]]


def test_a_run_whose_mapper_died_for_good_keeps_its_last_autosave_as_the_map(tmp_path):
    """Issue 32 item 3: the run directory always has the map. A mapper that dies a fourth time
    (or with the run) writes no map.pgm: tools/launch writes its last autosave as the map, the
    mapper's own way (same thresholds), and leaves a newer map or an earlier run's file alone."""
    from test_launch_respawn import tools_launch
    from turtlebot_recon.mapping.map_io import load_map
    launch = tools_launch()
    dead = mapped()
    logodds, res, origin = dead.resume_state()
    resume = save_resume(resume_path(tmp_path / "map"), logodds, res, origin, key="run_1", stamp_s=42.0)
    assert launch.keep_the_map(str(tmp_path), since=os.path.getmtime(resume) + 10) == ""    # an earlier run's
    assert not (tmp_path / "map.yaml").exists()
    line = launch.keep_the_map(str(tmp_path), since=os.path.getmtime(resume) - 1)
    assert line.startswith("the map is the mapper's last autosave")
    occ, res2, origin2 = load_map(tmp_path / "map.yaml")
    assert res2 == res and np.allclose(origin2, origin)
    assert np.array_equal(occ >= 0, decided(logodds))             # every settled cell, no other
    assert (occ[decided(logodds) & (logodds > 0)] == 100).all()   # the walls are walls
    assert launch.keep_the_map(str(tmp_path), since=0.0) == ""     # the map is newer: left alone
    (tmp_path / "map.resume.npz").write_bytes(b"not a zip")
    os.utime(tmp_path / "map.yaml", (0, 0))
    assert "could not be written as the map" in launch.keep_the_map(str(tmp_path), since=0.0)
