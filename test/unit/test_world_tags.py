"""The shipped worlds' tags are ones a tag-search mission must work for: each world has ArUco
markers (aruco_6x6_100, 0.10 m) and AprilTags (tag36h11, 0.16 m), a tag in a corner and, where
it has a corridor, one seen only at grazing angles from it; and the waffle_pi's camera reads
every tag from the free space in front of it."""
import logging
import math

import cv2
import numpy as np
import pytest
import yaml

from turtlebot_recon.perception.families import canonical, dictionary, marker_count, marker_set
from turtlebot_recon.sim import load_world
from turtlebot_recon.sim.world import WORLDS_DIR

WORLDS = ("arena", "doors", "garden", "house", "maze", "office")
ROBOT = "turtlebot3_waffle_pi"
# Tags on a corridor's side wall, seen from the corridor only at grazing angles (the issue's
# requirement; worldgen's hand-placed spots): (world, family, id).
GRAZING = [("house", "tag36h11", 10), ("doors", "aruco_6x6_100", 10),
           ("office", "tag36h11", 12), ("office", "aruco_6x6_100", 13)]
# Tags worldgen sampled before the hand-placed ones, with furniture, a rock or a bin 0.8-1.2 m in
# front of them (no free waffle_pi pose straight in front); read from up to 45 deg off their normal.
BLOCKED_IN_FRONT = {("house", 1), ("garden", 3), ("garden", 4), ("garden", 5), ("doors", 1)}


def _listed_tags():
    for name in WORLDS:
        for t in yaml.safe_load((WORLDS_DIR / f"{name}.yaml").read_text()).get("tags") or []:
            yield name, t["family"], t["id"]


ALL_TAGS = list(_listed_tags())


def _tag(world, family, tag_id):
    return next(t for t in world.tags if (marker_set(t.family), t.id) == (marker_set(family), tag_id))


# ---------------------------------------------------------------- world contents
@pytest.mark.parametrize("name", WORLDS)
def test_world_loads_cleanly_with_both_families(name, caplog):
    with caplog.at_level(logging.WARNING):
        w = load_world(name)
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING], caplog.text
    listed = yaml.safe_load((WORLDS_DIR / f"{name}.yaml").read_text())["tags"]
    assert len(w.tags) == len(listed)
    aruco = [t for t in w.tags if canonical(t.family) == "aruco_6x6_100"]
    april = [t for t in w.tags if canonical(t.family) == "tag36h11"]
    assert aruco and april
    assert all(t.size == pytest.approx(0.10) for t in aruco)
    assert all(t.size == pytest.approx(0.16) for t in april)
    keys = [(marker_set(t.family), t.id) for t in w.tags]
    assert len(set(keys)) == len(keys), "ids repeat within a marker set"
    for t in w.tags:
        assert 0 <= t.id < marker_count(t.family)
        assert t.z - t.size / 2 > 0 and t.z + t.size / 2 <= w.wall_height + 1e-9


def corners(free):
    """Free cells with a solid cell within two cells (0.1 m at 0.05 m) along x and along y:
    the inside of a corner of walls (or furniture)."""
    solid = np.pad(~free, 2, constant_values=True)
    h, w = free.shape
    near = {}
    for axis in (0, 1):
        hit = np.zeros_like(free)
        for k in (-2, -1, 1, 2):
            dr, dc = (k, 0) if axis == 0 else (0, k)
            hit |= solid[2 + dr:2 + dr + h, 2 + dc:2 + dc + w]
        near[axis] = hit
    return free & near[0] & near[1]


def near_corner(world, tag, within=0.3):
    """A corner cell on the tag's own wall (its centre < 0.1 m in front of the wall) lies within
    ``within`` m of the tag's centre."""
    rows, cols = np.nonzero(corners(world.free))
    res = world.resolution
    cx = world.origin[0] + (cols + 0.5) * res
    cy = world.origin[1] + (rows + 0.5) * res
    n = np.array([math.cos(tag.yaw), math.sin(tag.yaw)])
    dx, dy = cx - tag.x, cy - tag.y
    ahead = dx * n[0] + dy * n[1]
    return bool(np.any((ahead > 0) & (ahead < 0.1) & (np.hypot(dx, dy) <= within)))


@pytest.mark.parametrize("name", WORLDS)
def test_a_tag_in_a_corner(name):
    w = load_world(name)
    assert any(near_corner(w, t) for t in w.tags)


def test_corner_cells_found_in_a_room():
    free = np.zeros((20, 30), bool)
    free[2:18, 2:28] = True
    c = corners(free)
    assert c[2, 2] and c[3, 3] and c[17, 27] and not c[4, 4] and not c[2, 10] and c.sum() == 4 * 4


def free_depth(world, x, y, yaw, step=0.025, limit=5.0):
    """How far (m) the free space reaches from wall point (x, y) along direction ``yaw``."""
    d = step
    while d < limit and world.is_free(x + d * math.cos(yaw), y + d * math.sin(yaw)):
        d += step
    return d


@pytest.mark.parametrize("name, family, tag_id", GRAZING)
def test_grazing_tag_on_a_corridor_side_wall(name, family, tag_id):
    w = load_world(name)
    t = _tag(w, family, tag_id)
    width = free_depth(w, t.x, t.y, t.yaw)
    assert 1.0 <= width <= 2.0, "the corridor is %.2f m wide" % width
    # a corridor: its wall goes on 0.4 m either side of the tag, and the wall across (no door
    # or room opposite) 1.0 m either side
    n = np.array([math.cos(t.yaw), math.sin(t.yaw)])
    along = np.array([-n[1], n[0]])
    for s in np.arange(-1.0, 1.01, 0.1):
        p = np.array([t.x, t.y]) + s * along
        if abs(s) <= 0.4:
            assert not w.is_free(*(p - 0.05 * n)), "no wall %.1f m along" % s
            assert free_depth(w, *p, t.yaw) == pytest.approx(width, abs=0.1)
        else:
            assert not w.is_free(*(p + (width + 0.05) * n)), "no wall across %.1f m along" % s


# ---------------------------------------------------------------- the camera reads them
@pytest.fixture(scope="module")
def sims():
    """sims(name): a simulator (waffle_pi, camera on) of that world, kept while the tests ask
    for the same world. One at a time: with several EGL-rendering simulators open in one
    process, a render now and then shows a mix of their scenes."""
    from turtlebot_recon.robot import load_robot
    from turtlebot_recon.sim.simulator import SimSettings, Simulator
    held = {}

    def get(name):
        if name not in held:
            for sim in held.values():
                sim.close()
            held.clear()
            held[name] = Simulator(load_world(name), load_robot(ROBOT), SimSettings(camera_rate_hz=5.0))
        return held[name]

    yield get
    for sim in held.values():
        sim.close()


def teleport(sim, x, y, yaw):
    """set_pose, False where the footprint overlaps a wall."""
    try:
        sim.set_pose(x, y, yaw)
    except ValueError:
        return False
    return True


def reads(sim, tag):
    img = sim.render_camera()
    det = cv2.aruco.ArucoDetector(dictionary(tag.family))
    _, ids, _ = det.detectMarkers(cv2.cvtColor(img, cv2.COLOR_RGB2GRAY))
    return ids is not None and tag.id in ids.ravel().tolist()


def poses_facing(tag, off_deg, distances=(1.0, 0.9, 1.1, 0.8, 1.2)):
    """Robot poses ``distances`` m from the tag, ``off_deg`` off its normal, facing it."""
    for d in distances:
        a = tag.yaw + math.radians(off_deg)
        yield tag.x + d * math.cos(a), tag.y + d * math.sin(a), a + math.pi


@pytest.mark.parametrize("name, family, tag_id", ALL_TAGS)
def test_tag_read_from_in_front(sims, name, family, tag_id):
    sim = sims(name)
    t = _tag(sim.world, family, tag_id)
    offsets = (0, 15, -15, 30, -30, 45, -45) if (name, tag_id) in BLOCKED_IN_FRONT else (0,)
    tried = 0
    for off in offsets:
        for pose in poses_facing(t, off):
            if not teleport(sim, *pose):
                continue
            tried += 1
            if reads(sim, t):
                return
    pytest.fail("%s %s %d not read from %d free pose(s) 0.8-1.2 m in front" % (name, family, tag_id, tried))


@pytest.mark.parametrize("name, family, tag_id", GRAZING)
def test_grazing_tag_read_while_driving_the_corridor(sims, name, family, tag_id):
    """From the corridor's centre line, heading along it (either way), the camera reads the tag
    at 65 deg off its normal (at 60 deg it is still outside the 62.2 deg field of view); turned
    to face it, at 50 and 60 deg. (At 70 deg reading is hit and miss: a 0.10 m ArUco is then
    ~11 px wide.)"""
    sim = sims(name)
    t = _tag(sim.world, family, tag_id)
    lateral = free_depth(sim.world, t.x, t.y, t.yaw) / 2
    n = np.array([math.cos(t.yaw), math.sin(t.yaw)])
    for sign in (1, -1):
        along = sign * np.array([-n[1], n[0]])          # the way the robot drives
        for off_deg, heading in ((65, math.atan2(along[1], along[0])), (50, None), (60, None)):
            p = np.array([t.x, t.y]) + lateral * n - lateral * math.tan(math.radians(off_deg)) * along
            yaw = heading if heading is not None else math.atan2(t.y - p[1], t.x - p[0])
            assert teleport(sim, p[0], p[1], yaw), (off_deg, sign)
            assert reads(sim, t), "not read %d deg off its normal (%s)" % (
                off_deg, "driving" if heading is not None else "facing it")
