"""The bad-input catalogue (issue 32, item 4): what a driver, a user or a file can send wrong,
each case through the ROS-free code that its node runs on it, in one table (``CASES``).

Every case checks two things:
(a) one line names the fault: the line the node logs, or the message of the error it refuses
    the input with ("" where the input is legitimate however extreme: then no line is due);
(b) the component keeps working and lost nothing: the map, the graph, the tags, the plan made
    before the bad input are still there, and the next good input is still taken.
docs/bad_input.md lists the same table for users (``test_the_docs_list_every_case``)."""
from __future__ import annotations

import dataclasses
import functools
import math
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import cv2
import numpy as np
import pytest
import rospy
import tf2_py
import yaml
from nav_msgs.msg import OccupancyGrid, Odometry
from sensor_msgs.msg import LaserScan

from conftest import room, walled_room, write_world
from turtlebot_recon.config import ConfigError, from_dict
from turtlebot_recon.mapping.map_io import load_map_as, save_map
from turtlebot_recon.mapping.mapper import Mapper, MapperSettings
from turtlebot_recon.perception.depth import DepthCamera, depth_metres
from turtlebot_recon.perception.detector import DetectorSettings, TagDetector
from turtlebot_recon.perception.families import dictionary
from turtlebot_recon.perception.image import ImageError, camera_model, compressed_to_gray, raw_to_gray
from turtlebot_recon.perception.tracker import TagTracker, TrackerSettings
from turtlebot_recon.planning.navigation import Navigation, NavigationSettings
from turtlebot_recon.planning.costmap import PlanningError
from turtlebot_recon.planning.sampling import plan_sampling
from turtlebot_recon.robot import load_robot
from turtlebot_recon.ros import convert, explore_msgs, navigator_msgs
from turtlebot_recon.ros.bags import BagReader, write_rosbag
from turtlebot_recon.sim.world import WorldError, load_world
from turtlebot_recon.slam.live import MAX_PENDING, LiveSlam
from turtlebot_recon.slam.logs import CarmenReader, LaserRecord, LogError, OdomRecord, write_carmen
from turtlebot_recon.slam.slam import Slam, SlamSettings

DOCS = Path(__file__).resolve().parents[2] / "docs" / "bad_input.md"


@dataclass(frozen=True)
class Case:
    name: str
    given: str                    # the bad input
    policy: str                   # the code its node runs on it
    expect: str                   # a fragment of the one line naming the fault ("": none is due)
    survives: str                 # what must still hold afterwards (``run`` asserts it)
    run: Callable[[Path], str]    # feeds the input (tmp_path), checks ``survives``; the line


def refused(call: Callable, error=ValueError) -> str:
    """The message of the ``error`` that ``call()`` raises."""
    with pytest.raises(error) as info:
        call()
    return str(info.value)


# ------------------------------------------------------------------ mapper: scans, clock
INC = 2 * math.pi / 360
ROOM_RANGES = [1.0] * 360               # a round room of radius 1 m around the scanner


def laser(ranges=ROOM_RANGES, beams=360, inc=INC, angle_min=0.0, range_min=0.12, range_max=3.5,
          stamp_s=1.0) -> LaserScan:
    """A sensor_msgs/LaserScan whose header says ``beams`` beams of ``inc`` from ``angle_min``."""
    m = LaserScan()
    m.header.stamp, m.header.frame_id = convert.stamp(stamp_s), "base_scan"
    m.angle_min, m.angle_increment = angle_min, inc
    m.angle_max = angle_min + inc * (beams - 1)
    m.range_min, m.range_max = range_min, range_max
    m.ranges = list(ranges)
    return m


def known(mapper: Mapper, x: float, y: float) -> int:
    g = mapper.grid
    return int(g.occupancy()[int((y - g.origin_y) / g.resolution), int((x - g.origin_x) / g.resolution)])


def mapper_scan(exact: bool, **bad) -> str:
    """A mapper that has seen the room three times takes ``laser(**bad)`` (through the node's
    conversion) and then a good scan. ``exact``: the bad scan leaves the map as it was (else
    every known cell stays known: a no-return beam rightly clears along its line)."""
    m = Mapper(MapperSettings(robot="turtlebot3_burger"), 0.105)
    for _ in range(3):
        m.insert(convert.scan_data(laser()), (0.0, 0.0, 0.0))
    before = m.grid.occupancy().copy()
    scan = convert.scan_data(laser(**bad))
    reason = m.check_scan(scan)
    if reason:
        line = m.skip_line(reason, scan)
    else:
        m.insert(scan, (0.0, 0.0, 0.0))
        line = m.diagnostics()
    after = m.grid.occupancy()
    if exact or reason:
        np.testing.assert_array_equal(after, before)
    assert ((after >= 0) | (before < 0)).all(), "a known cell became unknown"
    n = m.scans
    good = convert.scan_data(laser(stamp_s=2.0))
    assert m.check_scan(good) is None
    m.insert(good, (0.0, 0.0, 0.0))
    assert m.scans == n + 1 and 0 <= known(m, 0.5, 0.0) <= 25 and known(m, 1.01, 0.0) >= 65
    return line


def mapper_clock_back(_tmp) -> str:
    m = Mapper(MapperSettings(robot="turtlebot3_burger"), 0.105)
    assert not m.time_jumped_back(100.0)
    m.insert(convert.scan_data(laser()), (0.0, 0.0, 0.0))
    before = m.grid.occupancy().copy()
    assert m.time_jumped_back(3.0)                         # a restarted simulation or bag
    np.testing.assert_array_equal(m.grid.occupancy(), before)   # the map is kept
    m.insert(convert.scan_data(laser(stamp_s=3.0)), (0.0, 0.0, 0.0))
    assert m.scans == 2
    return m.diagnostics()


# ------------------------------------------------------------------ navigator: maps, goals, odometry
RES = 0.05


def navigation() -> Navigation:
    """The pure pursuit's navigator in a 4 x 3 m walled room, pursuing nothing yet."""
    nav = Navigation(NavigationSettings(controller="pure_pursuit"), load_robot("turtlebot3_burger"))
    nav.update_map(walled_room(), RES, (0.0, 0.0))
    return nav


def still_plans(nav: Navigation) -> None:
    """A goal across the room is planned on the map in use."""
    assert nav.set_goal(3.0, 2.0)
    v, w = nav.step(0.0, (1.0, 1.0, 0.0), (0.0, 0.0))
    assert nav.status == "active" and math.isfinite(v) and math.isfinite(w)
    assert len(nav.path_xy) >= 2 and math.dist(nav.path_xy[-1], (3.0, 2.0)) < 0.05


def grid_msg(width: int, height: int, resolution: float = RES, origin=(0.0, 0.0), cells=None) -> OccupancyGrid:
    m = OccupancyGrid()
    m.header.frame_id = "map"
    m.info.width, m.info.height, m.info.resolution = width, height, resolution
    m.info.origin.position.x, m.info.origin.position.y = origin
    m.data = bytes(width * height if cells is None else cells)
    return m


def map_message(msg: OccupancyGrid) -> Callable[[Path], str]:
    """The navigator's (and the explorer's) map callback on ``msg``: refused, the map in use kept."""
    def run(_tmp) -> str:
        nav = navigation()
        view = nav.map
        line = refused(lambda: nav.set_map(nav.map_view(*explore_msgs.grid(msg))))
        assert nav.map is view
        still_plans(nav)
        return line
    return run


def map_array(occupancy: np.ndarray, resolution: float = RES) -> Callable[[Path], str]:
    """The core's own check (a caller without the message layer)."""
    def run(_tmp) -> str:
        nav = navigation()
        view = nav.map
        line = refused(lambda: nav.update_map(occupancy, resolution, (0.0, 0.0)))
        assert nav.map is view
        still_plans(nav)
        return line
    return run


def bad_goal(x: float, y: float) -> Callable[[Path], str]:
    def run(_tmp) -> str:
        nav = navigation()
        assert not nav.set_goal(x, y)
        assert nav.status == "failed" and nav.map is not None
        line = nav.reason
        still_plans(nav)                                   # the next goal is taken
        return line
    return run


def ompl_goal_walled_off(_tmp) -> str:
    """An OMPL planner's navigator (planner:=ompl_rrtconnect), a goal behind a wall with no
    door: the goal fails naming the planner and its budget; the next goal is planned."""
    nav = Navigation(NavigationSettings(controller="pure_pursuit", planner="ompl_rrtconnect",
                                        sampling_budget_s=0.1), load_robot("turtlebot3_burger"))
    occ = walled_room()
    occ[:, 50:52] = 100                                     # a wall across the room, x 2.5 m
    nav.update_map(occ, RES, (0.0, 0.0))
    assert nav.set_goal(3.5, 1.5)
    nav.step(0.0, (1.0, 1.0, 0.0), (0.0, 0.0))
    assert nav.status == "failed"
    line = nav.reason
    assert nav.set_goal(2.0, 2.0)                            # on this side: planned, driven
    v, w = nav.step(0.1, (1.0, 1.0, 0.0), (0.0, 0.0))
    assert nav.status == "active" and math.isfinite(v) and math.isfinite(w)
    return line


def ompl_end_blocked(start, goal) -> Callable[[Path], str]:
    """plan_sampling (the OMPL planners' core) on a start or goal it cannot use: PlanningError
    in one line, no solve; the next request is planned."""
    def run(_tmp) -> str:
        robot = load_robot("turtlebot3_waffle_pi")
        line = refused(lambda: plan_sampling(walled_room(), RES, (0.0, 0.0), robot, start, goal,
                                             "bitstar", 0.1), error=PlanningError)
        path = plan_sampling(walled_room(), RES, (0.0, 0.0), robot, (1.0, 1.0, 0.0), (3.0, 2.0),
                             "rrtconnect", 0.2)
        assert math.dist(path.poses[-1, :2], (3.0, 2.0)) < 1e-9
        return line
    return run


def goal_1000_per_s(_tmp) -> str:
    """The same goal 100 times per 0.1 s tick: the plan and the controller's state are kept, and
    the robot arrives."""
    nav = navigation()
    assert nav.set_goal(3.0, 2.0)
    x, y, yaw, dt = 1.0, 1.0, 0.0, 0.1
    for k in range(400):
        path = nav.path_xy
        for _ in range(100):
            assert not nav.set_goal(3.0, 2.0)
        assert nav.path_xy is path and nav.status == "active"
        v, w = nav.step(k * dt, (x, y, yaw), (0.0, 0.0))
        x, y, yaw = x + v * dt * math.cos(yaw), y + v * dt * math.sin(yaw), yaw + w * dt
        if nav.status != "active":
            break
    assert nav.status == "succeeded", nav.reason
    assert math.hypot(x - 3.0, y - 2.0) <= 0.1 + 1e-9 and nav.repeated_goals == 100 * (k + 1)
    nav.status, nav.goal = "active", (3.0, 2.0, None)      # the line as the node logs it while active
    return nav.repeat_line()


def odom_twist_nan(_tmp) -> str:
    """The navigator's odometry callback: refused, the last velocity kept and driven on."""
    m = Odometry()
    m.twist.twist.linear.x, m.twist.twist.angular.z = 0.1, 0.0
    velocity = navigator_msgs.odom_velocity(m)
    m.twist.twist.linear.x = float("nan")
    line = refused(lambda: navigator_msgs.odom_velocity(m))
    nav = navigation()
    nav.set_goal(3.0, 2.0)
    v, w = nav.step(0.0, (1.0, 1.0, 0.0), velocity)
    assert math.isfinite(v) and math.isfinite(w) and nav.status == "active"
    return line


# ------------------------------------------------------------------ SLAM: odometry, IMU, clock
WALLS = np.array([[2.0, y] for y in np.linspace(-1, 1, 40)] + [[x, 1.5] for x in np.linspace(0, 2, 40)])


def odom_pose_nan(_tmp) -> str:
    slam = Slam(SlamSettings(), 0.16)
    assert slam.add_scan(0.0, WALLS, (0.0, 0.0, 0.0))
    assert not slam.add_scan(0.2, WALLS, (float("nan"), 0.0, 0.0))
    line = slam.take_events()[0]
    assert slam.add_scan(0.4, WALLS - [0.3, 0.0], (0.3, 0.0, 0.0))   # the next keyframe
    assert len(slam.keyframes) == 2 and np.isfinite(slam.estimates).all()
    return line


def c_stderr(call: Callable) -> str:
    """What ``call()`` writes on file descriptor 2 (tf2's C++ console)."""
    with tempfile.TemporaryFile(mode="w+") as f:
        sys.stderr.flush()
        saved_fd = os.dup(2)
        os.dup2(f.fileno(), 2)
        try:
            call()
        finally:
            os.dup2(saved_fd, 2)
            os.close(saved_fd)
        f.seek(0)
        return f.read()


def odom_tf(translation=(1.5, 0.0), quat=None) -> str:
    """odom -> base_footprint from the odometry into tf2's buffer (the nodes' TF): refused with
    tf2's own line, the transform before it still there."""
    buffer = tf2_py.BufferCore(rospy.Duration(10.0))
    buffer.set_transform(convert.transform("odom", "base_footprint", 1.0, 1.0, 0.0), "odometry")
    bad = convert.transform("odom", "base_footprint", 2.0, *translation, quat=quat)
    err = c_stderr(lambda: buffer.set_transform(bad, "odometry"))
    line = next(x for x in err.splitlines() if "Ignoring transform" in x)
    t = buffer.lookup_transform_core("odom", "base_footprint", rospy.Time(0))
    assert t.transform.translation.x == 1.0 and t.header.stamp.to_sec() == 1.0
    return line


def live_slam(imu_hz: float) -> str:
    """5 s of scans at 5 Hz, with the gyro at ``imu_hz`` (0: none): every scan goes to the core
    (none left waiting), the gyro's buffer stays bounded, keyframes are made; the node's line."""
    session = LiveSlam(Slam(SlamSettings(), 0.16))
    for k in range(25):
        t = 0.2 * k
        for i in range(int(imu_hz * 0.2)):
            session.add_imu(t - 0.2 + (i + 1) / imu_hz, 0.0)
        session.add_scan(t, WALLS - [0.02 * k, 0.0], (0.02 * k, 0.0, 0.0))
        assert len(session.queue.pending) <= MAX_PENDING
        since = t - session.core.keyframes[-1].stamp_s if session.core.keyframes else t
        assert len(session.core.gyro) <= imu_hz * (since + 0.2) + 2     # only since the last keyframe
    assert len(session.core.keyframes) >= 2 and session.map_to_odom is not None
    return session.queue.silence_line() if session.queue.silent else ""


def slam_clock_back(_tmp) -> str:
    session = LiveSlam(Slam(SlamSettings(), 0.16))
    assert not session.clock(10.0)
    session.add_scan(10.0, WALLS, (0.0, 0.0, 0.0))
    assert session.clock(2.0)                               # a looping bag, a restarted simulation
    line = session.take_events()[-1]
    session.add_scan(2.0, WALLS, (0.0, 0.0, 0.0))           # a new run: its first keyframe
    assert len(session.core.keyframes) == 1 and session.map_to_odom is not None
    return line


# ------------------------------------------------------------------ camera and tags
W, H, FX, CX, CY, CELL_PX = 640, 480, 530.0, 319.5, 239.5, 12
K_GOOD = [FX, 0.0, CX, 0.0, FX, CY, 0.0, 0.0, 1.0]


@functools.lru_cache(maxsize=None)
def scene() -> np.ndarray:
    """Grey 640 x 480 with tag36h11 #7 whole, fronto-parallel, its black square 96 px wide."""
    img = np.full((H, W), 128, np.uint8)
    m = cv2.aruco.generateImageMarker(dictionary("tag36h11"), 7, 8 * CELL_PX, borderBits=1)
    m = cv2.copyMakeBorder(m, 24, 24, 24, 24, cv2.BORDER_CONSTANT, value=255)
    img[100:100 + m.shape[0], 100:100 + m.shape[1]] = m
    return img


@functools.lru_cache(maxsize=None)
def detector() -> TagDetector:
    return TagDetector(from_dict(DetectorSettings, {"sizes": [{"family": "tag36h11", "size_m": 0.16}]}, "test"))


def still_detects() -> list:
    """The detector node's path on a good rgb8 frame: tag 7 found."""
    rgb = np.dstack([scene()] * 3)
    gray = raw_to_gray("rgb8", H, W, 3 * W, rgb.tobytes())
    K, D = camera_model(K_GOOD, [0.0] * 5, W, H, gray.shape)
    found = detector().detect(gray, K, D)
    assert [d.id for d in found] == [7]
    return found


def frame(call: Callable) -> Callable[[Path], str]:
    """A frame (or its camera_info) refused by the detector node's checks; the next good one detected."""
    def run(_tmp) -> str:
        line = refused(call, ImageError)
        still_detects()
        return line
    return run


# The optical frame looking along the map's +x from (0, 0, 0.2): optical z -> x, x -> -y, y -> -z
T_MAP_OPTICAL = np.array([[0.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.2], [0, 0, 0, 1.0]])


def tracker_refuses(**change) -> Callable[[Path], str]:
    """The tracker, with tag 7 seen once, refuses a detection changed by ``change``; tag 7 is kept
    and the next good sighting confirms it."""
    def run(_tmp) -> str:
        good = still_detects()[0]
        tracker = TagTracker(TrackerSettings())
        assert tracker.update(good, T_MAP_OPTICAL, 1.0) == "tentative"
        line = refused(lambda: tracker.update(dataclasses.replace(good, **change), T_MAP_OPTICAL, 1.1))
        assert tracker.stats["sightings"] == 1
        assert tracker.update(good, T_MAP_OPTICAL, 1.2) == "confirmed"
        assert [(t.family, t.id) for t in tracker.tags()] == [("tag36h11", 7)]
        return line
    return run


# ------------------------------------------------------------------ worlds and saved maps
def world(change: Callable[[dict], None], error=WorldError) -> Callable[[Path], str]:
    """A world YAML changed by ``change`` (its dict) is refused naming the key; the world beside
    it, the same but unchanged, still loads (the simulator starts on it)."""
    def run(tmp: Path) -> str:
        good = write_world(tmp, "good", room(2.0, 2.0), tags=[
            {"id": 3, "family": "tag36h11", "x": 1.0, "y": 2.1, "z": 0.25, "yaw": -math.pi / 2, "size": 0.16}])
        meta = yaml.safe_load(good.read_text())
        change(meta)
        bad = tmp / "bad.yaml"
        bad.write_text(yaml.safe_dump(meta) if isinstance(meta, dict) else str(meta))
        line = refused(lambda: load_world(bad), error)
        w = load_world(good)
        assert w.free.any() and [t.id for t in w.tags] == [3]
        return line
    return run


def world_text(text: str) -> Callable[[Path], str]:
    def run(tmp: Path) -> str:
        write_world(tmp, "good", room(2.0, 2.0))
        (tmp / "bad.yaml").write_text(text)
        line = refused(lambda: load_world(tmp / "bad.yaml"), WorldError)
        assert load_world(tmp / "good.yaml").free.any()
        return line
    return run


def saved(tmp: Path, resolution: float = RES) -> Path:
    occ = np.full((40, 60), -1, np.int8)
    occ[5:35, 5:55] = 0
    occ[5, 5:55] = 100
    return save_map(tmp / f"saved_{round(resolution * 1000)}mm", occ, resolution, (-1.0, -1.0))


def initial_map(change: Callable[[Path], Path]) -> Callable[[Path], str]:
    """The mapper's (and the localiser's) initial_map: a saved map changed by ``change`` is
    refused at start in one line; the file is left as it was, and a good one still loads."""
    def run(tmp: Path) -> str:
        path = change(tmp)
        files = {p: p.read_bytes() for p in tmp.iterdir()}
        def start():
            Mapper(MapperSettings(robot="turtlebot3_burger"), 0.105, prior=load_map_as(path, "initial_map"))
        line = refused(start)
        assert {p: p.read_bytes() for p in tmp.iterdir()} == files
        mapper = Mapper(MapperSettings(robot="turtlebot3_burger"), 0.105, prior=load_map_as(saved(tmp), "initial_map"))
        assert 0 <= known(mapper, 0.0, 0.0) <= 25           # free, as saved
        return line
    return run


def not_yaml(tmp: Path) -> Path:
    (tmp / "broken.yaml").write_text("image: [a.pgm\nresolution: 0.05\n")
    return tmp / "broken.yaml"


def rewrite_yaml(tmp: Path, change: Callable[[dict], None]) -> Path:
    path = saved(tmp)
    meta = yaml.safe_load(path.read_text())
    change(meta)
    path.write_text(yaml.safe_dump(meta))
    return path


# ------------------------------------------------------------------ logs: CARMEN and bags
def drive_log(n: int = 20, t0: float = 1.0) -> list:
    """n odometry + laser pairs, 0.2 s apart, the robot driving along x; ranges that vary."""
    rng = np.random.default_rng(7)
    out = []
    for i in range(n):
        t, x = t0 + 0.2 * i, 0.05 * i
        out.append(OdomRecord(t, x, 0.0, 0.0, 0.25, 0.0))
        out.append(LaserRecord(t, rng.uniform(0.5, 3.0, 180).astype(np.float32), -math.pi / 2, math.pi / 180,
                               0.0, 81.9, (x, 0.0, 0.0), (x, 0.0, 0.0)))
    return out


def carmen(make: Callable[[str], str], kept: int) -> Callable[[Path], str]:
    """A CARMEN log made from a good one's text by ``make``: read to the end, ``kept`` records
    kept in time order; the reader's summary line."""
    def run(tmp: Path) -> str:
        write_carmen(tmp / "good.clf", drive_log())
        (tmp / "bad.clf").write_text(make((tmp / "good.clf").read_text()))
        reader = CarmenReader(tmp / "bad.clf")
        records = list(reader)
        stamps = [r.stamp_s for r in records]
        assert len(records) == kept and stamps == sorted(stamps)
        return reader.summary()
    return run


def backwards(text: str) -> str:
    """Two laser lines' places swapped: time goes back between them."""
    lines = text.splitlines(keepends=True)
    lasers = [i for i, x in enumerate(lines) if x.startswith(("ROBOTLASER1", "FLASER"))]
    a, b = lasers[3], lasers[6]
    lines[a], lines[b] = lines[b], lines[a]
    return "".join(lines)


def bag(make: Callable[[Path], None]) -> Callable[[Path], str]:
    """A bag made by ``make`` is refused in one line before anything is read."""
    def run(tmp: Path) -> str:
        make(tmp / "bad.bag")
        return refused(lambda: BagReader(tmp / "bad.bag"), LogError)
    return run


def cut_bag(path: Path) -> None:
    write_rosbag(path, drive_log(200))
    path.write_bytes(path.read_bytes()[:path.stat().st_size // 2])


def bag_backwards(tmp: Path) -> str:
    """A looping bag: the second run's records come after the first's, time going back."""
    write_rosbag(tmp / "loop.bag", drive_log(10, t0=20.0) + drive_log(10, t0=1.0))
    reader = BagReader(tmp / "loop.bag")
    records = list(reader)
    assert sum(isinstance(r, LaserRecord) for r in records) == 20   # both runs, nothing lost
    return reader.summary()


def empty_carmen(tmp: Path) -> str:
    """An empty log: read (nothing in it), then refused by the offline SLAM in one line."""
    from turtlebot_recon.slam.offline import run_log
    (tmp / "empty.clf").write_text("")
    reader = CarmenReader(tmp / "empty.clf")
    assert list(reader) == [] and reader.summary() == "empty.clf: no records"
    return refused(lambda: run_log(reader, tmp / "out"))


# ------------------------------------------------------------------ the catalogue
NAN, INF = float("nan"), float("inf")
KEEPS_MAP = "the map as it was; the next good scan inserted"
KEEPS_PLAN = "the map in use kept; the next goal planned on it"
DETECTS = "the next good frame detected (tag 7)"
WORLD_OK = "the good world beside it loads"
SAVED_OK = "the file untouched; a good saved map loads"


# ------------------------------------------------------------------ mapper's OctoMap layer: depth frames
DW, DH = 160, 120                                       # px, a depth camera sampled at stride 1
K_DEPTH = [100.0, 0.0, 79.5, 0.0, 100.0, 59.5, 0.0, 0.0, 1.0]
OPTICAL = np.array([[0.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.2], [0, 0, 0, 1.0]])
# the optical frame 0.2 m up, looking along +x (REP 103: z forward, x right, y down)


def depth_wall(encoding="32FC1") -> bytes:
    """A wall 2 m ahead filling the frame, as the bytes of a 32FC1 (m) or 16UC1 (mm) image."""
    if encoding == "16UC1":
        return np.full((DH, DW), 2000, np.uint16).tobytes()
    return np.full((DH, DW), 2.0, np.float32).tobytes()


def depth_layer(bad: Callable) -> str:
    """The mapper's depth path (depth_metres, DepthCamera.points, OctomapLayer.insert) has
    inserted a good frame of a wall 2 m ahead; ``bad()`` (given the camera and the layer) feeds
    one bad frame and returns its line; the wall stays an obstacle, nothing else became one, and
    the next good frame goes in."""
    from turtlebot_recon.mapping.octomap_layer import OctomapLayer, OctomapSettings
    layer = OctomapLayer(OctomapSettings(robot_height_m=0.4))
    camera = DepthCamera(K_DEPTH, DW, DH, 1)

    def insert(encoding="32FC1", data=None):
        depth = depth_metres(encoding, DH, DW, DW * (2 if encoding == "16UC1" else 4),
                             depth_wall(encoding) if data is None else data)
        return layer.insert(camera.points(depth, OPTICAL), OPTICAL[:3, 3])

    insert()
    before = layer.project(100, 100, 0.05, (-2.5, -2.5))
    try:
        line = bad(camera, layer, insert)
    except ImageError as exc:
        line = str(exc)
    after = layer.project(100, 100, 0.05, (-2.5, -2.5))
    wall = after[50, 90]                                    # (2.0..2.05, 0): the wall's cell
    assert wall == 100 and ((after == 100) <= (before == 100) | (np.arange(100) >= 90)[None, :]).all()
    assert insert("16UC1").inserted > 0 and layer.project(100, 100, 0.05, (-2.5, -2.5))[50, 90] == 100
    return line


def depth_holes(_camera, _layer, insert) -> str:
    """NaN pixels (32FC1) and 0 pixels (16UC1) are "no return": skipped and counted, no line."""
    holes = np.full((DH, DW), 2.0, np.float32)
    holes[:, ::2] = np.nan
    stats = insert("32FC1", holes.tobytes())
    assert stats.non_finite == DH * DW // 2 and stats.inserted > 0
    zeros = np.full((DH, DW), 2000, np.uint16)
    zeros[::2, :] = 0
    stats = insert("16UC1", zeros.tobytes())
    assert stats.non_finite == DH * DW // 2 and stats.inserted > 0
    return ""

CASES = [
    # mapper: LaserScan -> convert.scan_data -> Mapper.check_scan / insert
    Case("scan_ranges_nan", "360 ranges NaN", "mapper: beams classified", "nan 360", KEEPS_MAP,
         lambda tmp: mapper_scan(True, ranges=[NAN] * 360)),
    Case("scan_ranges_inf", "360 ranges +inf (REP 117 no return)", "mapper: beams classified",
         "no_return 360", "every known cell still known; the next good scan inserted",
         lambda tmp: mapper_scan(False, ranges=[INF] * 360)),
    Case("scan_ranges_negative", "360 ranges -1 m", "mapper: beams classified", "too_close 360", KEEPS_MAP,
         lambda tmp: mapper_scan(True, ranges=[-1.0] * 360)),
    Case("scan_ranges_over_range", "360 ranges 10 m, range_max 3.5 m", "mapper: beams classified",
         "no_return 360", "every known cell still known; the next good scan inserted",
         lambda tmp: mapper_scan(False, ranges=[10.0] * 360)),
    Case("scan_zero_beams", "a scan of 0 ranges", "mapper: Mapper.check_scan", "scan skipped (empty", KEEPS_MAP,
         lambda tmp: mapper_scan(True, ranges=[])),
    Case("scan_angle_increment_zero", "angle_increment 0", "mapper: Mapper.check_scan",
         "scan skipped (bad_header", KEEPS_MAP, lambda tmp: mapper_scan(True, inc=0.0)),
    Case("scan_wrong_length", "100 ranges, the header says 360", "mapper: Mapper.check_scan",
         "scan skipped (length_mismatch", KEEPS_MAP, lambda tmp: mapper_scan(True, ranges=[1.0] * 100)),
    Case("scan_angle_nan", "angle_min NaN", "mapper: Mapper.check_scan", "scan skipped (bad_header", KEEPS_MAP,
         lambda tmp: mapper_scan(True, angle_min=NAN)),
    Case("scan_range_limits_swapped", "range_max 0.1 m < range_min 0.12 m", "mapper: Mapper.check_scan",
         "scan skipped (bad_header", KEEPS_MAP, lambda tmp: mapper_scan(True, range_max=0.1)),
    Case("mapper_time_backwards", "the clock 97 s back (a restarted simulation or bag)",
         "mapper: Mapper.time_jumped_back", "time_jump_back 1", "the map kept; the next scan inserted",
         mapper_clock_back),
    # navigator and explorer: OccupancyGrid -> explore_msgs.grid -> Navigation.map_view
    Case("map_0x0", "a map of 0 x 0 cells", "navigator/explorer: explore_msgs.grid",
         "map: empty (0 x 0 cells)", KEEPS_PLAN, map_message(grid_msg(0, 0))),
    Case("map_10000x10000", "a map of 10,000 x 10,000 cells", "navigator/explorer: explore_msgs.grid",
         "10000 x 10000 cells is more than 25,000,000", KEEPS_PLAN, map_message(grid_msg(10_000, 10_000, cells=0))),
    Case("map_resolution_negative", "resolution -0.05 m", "navigator/explorer: explore_msgs.grid",
         "resolution -0.05 m per cell is not positive", KEEPS_PLAN, map_message(grid_msg(80, 60, resolution=-0.05))),
    Case("map_resolution_nan", "resolution NaN", "navigator/explorer: explore_msgs.grid",
         "resolution nan m per cell is not positive", KEEPS_PLAN, map_message(grid_msg(80, 60, resolution=NAN))),
    Case("map_origin_nan", "origin (NaN, 0)", "navigator/explorer: explore_msgs.grid", "is not finite",
         KEEPS_PLAN, map_message(grid_msg(80, 60, origin=(NAN, 0.0)))),
    Case("map_data_wrong_length", "80 x 60 cells, 100 values", "navigator/explorer: explore_msgs.grid",
         "100 values for 80 x 60 cells", KEEPS_PLAN, map_message(grid_msg(80, 60, cells=100))),
    Case("map_array_0x0", "an empty array to the navigator's core", "Navigation.update_map",
         "map: empty (0 x 0 cells)", KEEPS_PLAN, map_array(np.zeros((0, 0), np.int8))),
    Case("goal_nan", "a goal at (NaN, 1)", "navigator: Navigation.set_goal", "goal (nan, 1.0, None) is not finite",
         "the goal fails with that reason; the next goal planned", bad_goal(NAN, 1.0)),
    Case("goal_inf", "a goal at (1, inf)", "navigator: Navigation.set_goal", "is not finite",
         "the goal fails with that reason; the next goal planned", bad_goal(1.0, INF)),
    Case("ompl_goal_walled_off", "a goal no path reaches, planner:=ompl_rrtconnect",
         "navigator: Navigation (planning.sampling)", "plan_sampling (rrtconnect): no path within 0.1",
         "the goal fails with that reason; the next goal planned", ompl_goal_walled_off),
    Case("ompl_start_in_wall", "an OMPL plan from a start on a wall", "planning.sampling.plan_sampling",
         "the start is off the map, on an unknown or obstacle cell",
         "no solve; the next request planned", ompl_end_blocked((0.02, 1.0, 0.0), (3.0, 2.0))),
    Case("ompl_goal_off_map", "an OMPL plan to a goal off the map", "planning.sampling.plan_sampling",
         "the goal is off the map", "no solve; the next request planned",
         ompl_end_blocked((1.0, 1.0, 0.0), (9.0, 2.0))),
    Case("goal_same_1000_per_s", "the goal being pursued sent 1,000 times a second",
         "navigator: Navigation.set_goal", "was sent again (", "its plan kept; the robot arrives",
         goal_1000_per_s),
    Case("odom_twist_nan", "odometry twist v NaN", "navigator: navigator_msgs.odom_velocity",
         "odometry twist not finite", "the last velocity kept; commands finite", odom_twist_nan),
    # SLAM: odometry pose (TF), IMU, clock
    Case("odom_pose_nan", "the odometry pose at a scan NaN", "slam: Slam.add_scan", "odometry pose not finite",
         "the graph kept; the next scan a keyframe", odom_pose_nan),
    Case("odom_tf_nan", "odom -> base_footprint with a NaN translation", "every node: tf2's buffer",
         "TF_NAN_INPUT: Ignoring transform", "the transform before it still looked up",
         lambda tmp: odom_tf(translation=(NAN, 0.0))),
    Case("odom_tf_quaternion_not_unit", "odom -> base_footprint with a quaternion of norm 1.7",
         "every node: tf2's buffer", "TF_DENORMALIZED_QUATERNION: Ignoring transform",
         "the transform before it still looked up", lambda tmp: odom_tf(quat=(0.0, 0.0, 0.6, 1.6))),
    Case("imu_0_hz", "no IMU sample at all", "slam: GyroQueue", "no IMU sample in the 0.5 s before each of the last",
         "no scan waits for the gyro; keyframes made from the wheels", lambda tmp: live_slam(0.0)),
    Case("imu_1_khz", "the IMU at 1 kHz", "slam: GyroQueue, Slam.add_imu", "",
         "every scan processed; the gyro buffer bounded", lambda tmp: live_slam(1000.0)),
    Case("slam_time_backwards", "the clock 8 s back", "slam: LiveSlam.clock", "state cleared: time jumped back to 2.00 s",
         "a new graph from the next scan", slam_clock_back),
    # tag detector: Image / CompressedImage / CameraInfo -> perception.image
    Case("camera_info_all_zeros", "camera_info K all zeros", "tag_detector: camera_model",
         "K has no positive focal lengths", DETECTS,
         frame(lambda: camera_model([0.0] * 9, [0.0] * 5, W, H, (H, W)))),
    Case("camera_info_distortion_nan", "camera_info D with a NaN", "tag_detector: camera_model",
         "camera_info D is not finite", DETECTS, frame(lambda: camera_model(K_GOOD, [NAN] + [0.0] * 4, W, H, (H, W)))),
    Case("image_size_not_camera_info", "a 320 x 240 image, camera_info for 640 x 480", "tag_detector: camera_model",
         "camera_info is for 640 x 480 but the image is 320 x 240", DETECTS,
         frame(lambda: camera_model(K_GOOD, [], W, H, (240, 320)))),
    Case("image_encoding_16UC1", "a depth image (16UC1)", "tag_detector: raw_to_gray",
         "image encoding '16UC1' is not supported", DETECTS,
         frame(lambda: raw_to_gray("16UC1", H, W, 2 * W, bytes(2 * W * H)))),
    Case("image_encoding_bayer", "a bayer_rggb8 image", "tag_detector: raw_to_gray",
         "image encoding 'bayer_rggb8' is not supported", DETECTS,
         frame(lambda: raw_to_gray("bayer_rggb8", H, W, W, bytes(W * H)))),
    Case("image_0x0", "an image of 0 x 0 pixels", "tag_detector: raw_to_gray", "image is empty (0 x 0)", DETECTS,
         frame(lambda: raw_to_gray("rgb8", 0, 0, 0, b""))),
    Case("image_data_short", "640 x 480 rgb8 with a 320 x 240 frame's bytes", "tag_detector: raw_to_gray",
         "image data too short", DETECTS, frame(lambda: raw_to_gray("rgb8", H, W, 3 * W, bytes(3 * 320 * 240)))),
    Case("compressed_corrupt", "a JPEG header, then noise", "tag_detector: compressed_to_gray", "cannot be decoded",
         DETECTS, frame(lambda: compressed_to_gray("jpeg", b"\xff\xd8" + bytes(range(256)) * 4))),
    Case("compressed_empty", "a CompressedImage with no data", "tag_detector: compressed_to_gray", "has no data",
         DETECTS, frame(lambda: compressed_to_gray("jpeg", b""))),
    # mapper's OctoMap layer: depth Image / CameraInfo -> perception.depth, OctomapLayer.insert
    Case("depth_nan_and_zero_pixels", "depth frames half NaN (32FC1) and half 0 (16UC1)",
         "mapper: depth_metres, OctomapLayer.insert", "",
         "the pixels that returned are inserted, the others skipped and counted; the wall stays",
         lambda _tmp: depth_layer(depth_holes)),
    Case("depth_encoding_rgb8", "a colour image on the depth topic", "mapper: depth_metres",
         "depth encoding 'rgb8' is not supported", "the OcTree unchanged; the next depth frame inserted",
         lambda _tmp: depth_layer(lambda c, layer, insert: insert("rgb8", bytes(3 * DW * DH)))),
    Case("depth_size_not_camera_info", "a 80 x 60 depth image, camera_info for 160 x 120",
         "mapper: DepthCamera.points", "camera_info is for 160 x 120 but the depth image is 80 x 60",
         "the OcTree unchanged; the next depth frame inserted",
         lambda _tmp: depth_layer(lambda camera, layer, insert: camera.points(
             depth_metres("32FC1", 60, 80, 320, bytes(4 * 80 * 60)), OPTICAL))),
    Case("depth_camera_info_zero", "depth camera_info with K all zeros", "mapper: DepthCamera",
         "K has no positive focal lengths", "the camera of the last good camera_info kept; frames inserted",
         lambda _tmp: depth_layer(lambda c, layer, insert: DepthCamera([0.0] * 9, DW, DH, 1))),
    Case("depth_pose_not_finite", "a depth frame whose transform has a NaN", "mapper: DepthCamera.points",
         "the camera pose must be a finite 4 x 4 transform", "the OcTree unchanged; the next depth frame inserted",
         lambda _tmp: depth_layer(lambda camera, layer, insert: camera.points(
             np.full((DH, DW), 2.0, np.float32), np.full((4, 4), NAN)))),
    # tag tracker: TagDetection -> TagTracker.update
    Case("detection_unknown_family", "a detection of family tag99h9", "tag_tracker: TagTracker.update",
         "unknown marker family 'tag99h9'", "the tag seen before kept; the next sighting confirms it",
         tracker_refuses(family="tag99h9")),
    Case("detection_position_nan", "a detection at (NaN, 0, 1)", "tag_tracker: TagTracker.update",
         "detection.position_m must be finite", "the tag seen before kept; the next sighting confirms it",
         tracker_refuses(position_m=np.array([NAN, 0.0, 1.0]))),
    Case("detector_unknown_family", "tag_detector families: [tag99h9]", "tag_detector: DetectorSettings",
         "unknown marker family 'tag99h9'", "refused at start (exit 1)",
         lambda tmp: refused(lambda: from_dict(DetectorSettings, {"families": ["tag99h9"]}, "tag_detector"),
                             ConfigError)),
    # simulator: world YAML -> sim.world.load_world
    Case("world_missing_image", "a world YAML without image", "sim_bridge: load_world", "key 'image': missing",
         WORLD_OK, world(lambda m: m.pop("image"))),
    Case("world_missing_resolution", "a world YAML without resolution", "sim_bridge: load_world",
         "key 'resolution': expected a number, got None", WORLD_OK, world(lambda m: m.pop("resolution"))),
    Case("world_resolution_negative", "resolution -0.05", "sim_bridge: load_world",
         "key 'resolution': -0.05 m per pixel is not a plausible map resolution", WORLD_OK,
         world(lambda m: m.update(resolution=-0.05))),
    Case("world_origin_nan", "origin [.nan, 0, 0]", "sim_bridge: load_world", "key 'origin': expected [x, y, yaw]",
         WORLD_OK, world(lambda m: m.update(origin=[NAN, 0.0, 0.0]))),
    Case("world_tag_unknown_family", "a tag of family tag99h9", "sim_bridge: load_world",
         "unknown marker family 'tag99h9'", WORLD_OK, world(lambda m: m["tags"][0].update(family="tag99h9"))),
    Case("world_tag_missing_keys", "a tag without x and y", "sim_bridge: load_world", "missing ['x', 'y']",
         WORLD_OK, world(lambda m: [m["tags"][0].pop(k) for k in ("x", "y")])),
    Case("world_not_a_mapping", "a world YAML that is a list", "sim_bridge: load_world",
         "expected a mapping at the top level", WORLD_OK, world_text("- image: good.pgm\n")),
    Case("world_not_yaml", "a world file that is not YAML", "sim_bridge: load_world", "not valid YAML", WORLD_OK,
         world_text("image: [good.pgm\nresolution: 0.05\n")),
    Case("world_obstacle_band_inverted", "an obstacle with z_min 0.5, z_max 0.3", "sim_bridge: load_world",
         "key 'obstacles[0]': z_min 0.5 m must be below z_max 0.3 m", WORLD_OK,
         world(lambda m: m.update(obstacles=[{"x0": 0.5, "y0": 0.5, "x1": 0.8, "y1": 0.8, "z_min": 0.5, "z_max": 0.3}]))),
    Case("world_obstacle_missing_key", "an obstacle without z_max", "sim_bridge: load_world",
         "key 'obstacles[0]': missing ['z_max']", WORLD_OK,
         world(lambda m: m.update(obstacles=[{"x0": 0.5, "y0": 0.5, "x1": 0.8, "y1": 0.8, "z_min": 0.0}]))),
    # saved maps: initial_map / saved_map -> map_io.load_map_as -> Mapper(prior)
    Case("saved_map_other_resolution", "a saved map at 0.1 m, the mapper at 0.05 m", "mapper: Mapper(prior)",
         "resolution 0.1 m differs from the mapper's grid.resolution 0.05 m", SAVED_OK,
         initial_map(lambda tmp: saved(tmp, 0.1))),
    Case("saved_map_resolution_negative", "a saved map's resolution -0.05", "mapper/slam: load_map_as",
         "key 'resolution': must be positive, got -0.05", SAVED_OK,
         initial_map(lambda tmp: rewrite_yaml(tmp, lambda m: m.update(resolution=-0.05)))),
    Case("saved_map_missing_image", "a saved map's YAML without image", "mapper/slam: load_map_as",
         "key 'image': missing", SAVED_OK, initial_map(lambda tmp: rewrite_yaml(tmp, lambda m: m.pop("image")))),
    Case("saved_map_not_yaml", "a saved map's YAML that is not YAML", "mapper/slam: load_map_as",
         "cannot load initial_map", SAVED_OK,
         initial_map(not_yaml)),
    # logs: CARMEN (slam.logs) and bags (ros.bags)
    Case("carmen_empty", "an empty CARMEN log", "slam-log: CarmenReader, run_log",
         "no scan with odometry in the log (empty.clf: no records)", "nothing to lose; refused in one line",
         empty_carmen),
    Case("carmen_truncated_mid_line", "a CARMEN log cut in the middle of a laser line", "slam-log: CarmenReader",
         "1 truncated (first line", "every complete line before the cut kept",
         carmen(lambda text: text[:text.rindex("ROBOTLASER1") + 300], kept=39)),
    Case("carmen_time_backwards", "two laser lines in the wrong order", "slam-log: CarmenReader",
         "out of time order (sorted)", "every record kept, in time order", carmen(backwards, kept=40)),
    Case("carmen_garbage_line", "a line of noise in a CARMEN log", "slam-log: CarmenReader", "1 malformed (first line",
         "every other record kept",
         carmen(lambda text: text + "ODOM 0.5 zz 0.0 0.0 0.0 0.0 9.0 host 9.0\n", kept=40)),
    Case("bag_empty", "a bag with no messages", "slam-log: BagReader", "no /scan in the bag (topics: none)",
         "nothing to lose; refused in one line", bag(lambda path: write_rosbag(path, []))),
    Case("bag_zero_bytes", "a bag file of 0 bytes", "slam-log: BagReader", "not a readable rosbag",
         "nothing to lose; refused in one line", bag(lambda path: path.write_bytes(b""))),
    Case("bag_truncated", "a bag cut in the middle of the recording", "slam-log: BagReader",
         "not indexed, a recording cut short: `rosbag reindex", "refused in one line naming the repair",
         bag(cut_bag)),
    Case("bag_time_backwards", "a bag whose time goes back (a looping recording)", "slam-log: BagReader",
         "time went back 1 time(s)", "both runs' scans kept, a TimeJump between them", bag_backwards),
]


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input(case, tmp_path):
    line = case.run(tmp_path)
    if not case.expect:
        assert line == "", f"no line is due, got {line!r}"
        return
    assert "\n" not in line.strip(), f"more than one line: {line!r}"
    assert case.expect in line, line


def test_the_catalogue_is_whole():
    names = [c.name for c in CASES]
    assert len(names) >= 40 and len(set(names)) == len(names)
    assert all(c.given and c.policy and c.survives for c in CASES)


def test_the_docs_list_every_case():
    text = DOCS.read_text()
    missing = [c.name for c in CASES if f"`{c.name}`" not in text]
    assert not missing, f"docs/bad_input.md does not list {missing}"
