"""Localisation in a saved map (slam/localization.py): scans matched to the map's surface,
fused with drifting odometry; a wrong start corrected; bad input said, not fatal."""
import math

import numpy as np
import pytest

from test_slam import LOOP, drive, loop_world, rmse
from turtlebot_recon.geometry import compose
from turtlebot_recon.mapping.map_io import load_map
from turtlebot_recon.robot import load_robot
from turtlebot_recon.slam.localization import LocalizationSettings, Localizer, surface_points


class Feed:
    """drive()'s consumer: scans to the localiser, the map pose after each one kept."""

    def __init__(self, loc):
        self.loc, self.poses, self.updated = loc, [], []

    def add_imu(self, *_):
        pass

    def add_scan(self, stamp, points, odom):
        self.updated.append(self.loc.add_scan(stamp, points, odom))
        self.poses.append(compose(self.loc.map_to_odom(), odom))


def test_surface_points_lie_on_the_faces_between_wall_and_free_cells():
    occ = np.full((4, 5), -1, np.int8)
    occ[1:3, 1:4] = 0
    occ[1, 2] = 100                   # one wall cell with free cells left, right and above
    pts, normals = surface_points(occ, 0.1, (1.0, 2.0))
    found = {(round(x, 3), round(y, 3)): tuple(n) for (x, y), n in zip(pts, normals)}
    # x faces at 1.2 / 1.3 (normals -x / +x), the top face at y 2.2 (normal +y)
    assert found == {(1.2, 2.15): (-1.0, 0.0), (1.3, 2.15): (1.0, 0.0), (1.25, 2.2): (0.0, 1.0)}


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (0.2, -0.15, 0.12)])
def test_tracks_the_robot_in_the_saved_map_with_drifting_odometry(tmp_path, offset):
    """Two laps round the block with 3x the default drift: odometry alone ends far off, the
    localiser stays within a few centimetres, also from a start pose 25 cm / 7 degrees wrong."""
    from turtlebot_recon.sim import load_world
    from turtlebot_recon.sim.simulator import SimSettings, Simulator
    path = loop_world(tmp_path)
    occ, res, origin = load_map(path)
    world = load_world(path)
    robot = load_robot("turtlebot3_burger")
    sim = Simulator(world, robot, SimSettings(camera_rate_hz=0.0, odom_slip_std_sqrt_m=0.03, odom_heading="wheels",
                                              seed=7))
    start = np.array(sim.pose)
    loc = Localizer(LocalizationSettings(), occ, res, origin, robot.wheel_separation_m)
    loc.set_pose(compose(start, offset))
    feed = Feed(loc)
    _, truth_rel, odom = drive(sim, LOOP, laps=2, slam=feed)
    sim.close()
    truth = np.array([compose(start, t) for t in truth_rel])
    est = np.array(feed.poses)
    odom_map = np.array([compose(start, o) for o in odom])
    settle = len(est) // 10                                 # a wrong start takes a few updates
    ate = rmse(est[settle:], truth[settle:])
    # the heading where a scan was matched (between matches odometry's own step noise adds,
    # up to 0.2 rad per scan at this drift while turning at 1.5 rad/s)
    matched = np.array(feed.updated)[settle:]
    yaw_err = np.abs(np.angle(np.exp(1j * (est[settle:, 2] - truth[settle:, 2]))))[matched]
    st = loc.stats()
    assert rmse(odom_map, truth) > 0.15                     # the drift is real
    assert ate < 0.015, (ate, st)                           # occupied cells' centres: 0.066 m
    assert np.percentile(np.hypot(*(est[settle:, :2] - truth[settle:, :2]).T), 95) < 0.05
    assert yaw_err.max() < 0.05, st
    assert st["fused"] >= 0.8 * st["updates"], st


def test_a_lost_robot_searches_wider_and_is_found(tmp_path):
    """Put 0.6 m off: the narrow window cannot reach; after lost_after misses the wide one does."""
    from turtlebot_recon.sim import load_world
    from turtlebot_recon.sim.simulator import SimSettings, Simulator
    path = loop_world(tmp_path)
    occ, res, origin = load_map(path)
    robot = load_robot("turtlebot3_burger")
    sim = Simulator(load_world(path), robot, SimSettings(camera_rate_hz=0.0, seed=2))
    start = np.array(sim.pose)
    loc = Localizer(LocalizationSettings(), occ, res, origin, robot.wheel_separation_m)
    loc.set_pose(compose(start, (0.6, 0.0, 0.0)), std_m=0.05)
    feed = Feed(loc)
    _, truth_rel, _ = drive(sim, LOOP[:2], laps=1, slam=feed)
    sim.close()
    truth_end = compose(start, truth_rel[-1])
    assert loc.stats()["relocalised"] >= 1
    assert math.hypot(*(feed.poses[-1][:2] - truth_end[:2])) < 0.05
    assert any("searching" in e for e in loc.take_events())


def test_bad_input_is_said_and_loses_nothing(tmp_path):
    occ, res, origin = load_map(loop_world(tmp_path))
    loc = Localizer(LocalizationSettings(), occ, res, origin, 0.16)
    loc.set_pose((1.1, 1.1, 0.0))
    loc.set_pose((math.nan, 0.0, 0.0))                      # refused, the pose kept
    assert np.allclose(loc.pose, (1.1, 1.1, 0.0))
    assert not loc.add_scan(0.0, np.zeros((0, 2)), (math.inf, 0.0, 0.0))
    assert loc.add_scan(0.1, np.zeros((0, 2)), (0.0, 0.0, 0.0))       # every beam invalid
    assert loc.stats()["no_match"] == 1 and np.allclose(loc.pose, (1.1, 1.1, 0.0))
    events = loc.take_events()
    assert any("refused" in e for e in events) and any("not finite" in e for e in events)
    with pytest.raises(ValueError, match="wall faces"):
        Localizer(LocalizationSettings(), np.zeros((20, 20), np.int8), 0.05, (0.0, 0.0), 0.16)


def test_localize_log_tracks_a_recorded_drive_in_the_map(tmp_path):
    """The offline path (slam.offline.localize_log): a recorded CARMEN drive with 3x drift, tracked
    in the world's own map from the start pose, against the recorder's ground truth."""
    from turtlebot_recon.evaluation.trajectory_metrics import ate, read_tum
    from turtlebot_recon.sim import load_world
    from turtlebot_recon.sim.recorder import record_run
    from turtlebot_recon.slam.logs import CarmenReader
    from turtlebot_recon.slam.offline import localize_log
    path = loop_world(tmp_path)
    world = load_world(path)
    robot = load_robot("turtlebot3_burger")
    run = record_run(world, robot, 90.0, seed=3, odom_slip=0.03, out_dir=tmp_path / "rec",
                     odom_heading="wheels")
    res = localize_log(CarmenReader(run.carmen), path, tmp_path / "loc", wheel_separation_m=robot.wheel_separation_m,
                       initial_pose=world.start, log=lambda *a: None)
    gt = read_tum(run.ground_truth)                           # in the start frame
    gt_map = np.array([(t, *compose(world.start, p)) for t, *p in gt])
    a_loc = ate(read_tum(tmp_path / "loc" / "trajectory.tum"), gt_map, 0.02)
    odo = read_tum(run.odometry)
    a_odom = ate(odo, gt, 0.02)
    assert a_loc.matched > 100 and res.stats["fused"] >= 0.9 * res.stats["updates"], res.stats
    assert a_loc.rmse_m < 0.02, a_loc
    assert a_odom.max_m > 3 * a_loc.max_m                       # the drift is real
