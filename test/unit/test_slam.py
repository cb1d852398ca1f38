"""SLAM core (slam/slam.py) on simulated drives with drifting odometry: keyframes, odometry +
gyro + scan-match factors, loop closures, bad input."""
import math

import numpy as np
import pytest

from conftest import room, write_world
from turtlebot_recon.geometry import between, transform_points, wrap_angle
from turtlebot_recon.robot import load_robot
from turtlebot_recon.slam.scan_matching import scan_points
from turtlebot_recon.slam.slam import Slam, SlamSettings, odometry_covariance

LOOP = [(1.0, 1.0), (5.0, 1.0), (5.0, 4.0), (1.0, 4.0)]   # around the central block


def loop_world(tmp_path):
    """A 6 x 5 m room with a 2 x 1.4 m block in the middle and a few boxes along the walls,
    so that every scan has corners to match."""
    free = room(6.0, 5.0)
    res = 0.05

    def box(x0, y0, x1, y1):
        free[int(y0 / res) + 2:int(y1 / res) + 2, int(x0 / res) + 2:int(x1 / res) + 2] = False
    box(2.0, 1.8, 4.0, 3.2)
    for x0, y0, x1, y1 in ((0.0, 2.2, 0.3, 2.6), (2.8, 0.0, 3.1, 0.3), (5.7, 2.9, 6.0, 3.4), (1.8, 4.7, 2.2, 5.0),
                           (4.4, 4.6, 4.6, 5.0), (5.6, 0.6, 6.0, 0.8)):
        box(x0, y0, x1, y1)
    return write_world(tmp_path, "loop", free, start=[1.1, 1.1, 0.0])


def drive(sim, waypoints, laps, slam=None, speed=0.2):
    """Follow the waypoints (world frame) ``laps`` times with a simple pursuit; feed the SLAM
    core scans, odometry and gyro. Returns (stamps, true poses in the start frame, odometry
    poses) at every scan."""
    lid = sim.robot.lidar
    offset = (lid.x_m, lid.y_m, 0.0)
    start = np.array(sim.pose)
    out = ([], [], [])
    targets = [np.array(w, float) for w in waypoints] * laps + [np.array(waypoints[0], float)]
    i = 0
    for _ in range(200000):
        x, y, yaw = sim.pose
        if math.hypot(*(targets[i] - (x, y))) < 0.15:
            i += 1
            if i == len(targets):
                break
        err = wrap_angle(math.atan2(targets[i][1] - y, targets[i][0] - x) - yaw)
        v = speed * max(0.0, math.cos(err)) if abs(err) < 0.6 else 0.0
        if sim.time_s < 0.5:     # standing still for the first scans, as a robot does at start-up
            v, err = 0.0, 0.0
        sim.set_command(v, float(np.clip(2.0 * err, -1.5, 1.5)))
        due = sim.step()
        odom = (sim.odom.x, sim.odom.y, sim.odom.yaw)
        if slam is not None and "imu" in due:
            slam.add_imu(sim.time_s, sim.gyro_rate)
        if "scan" in due:
            r = sim.scan()
            pts = scan_points(r, lid.angle_min_rad, lid.angle_increment_rad, lid.range_min_m, lid.range_max_m)
            base = transform_points(offset, pts)
            if slam is not None:
                slam.add_scan(sim.time_s, base, odom)
            out[0].append(sim.time_s)
            out[1].append(between(start, sim.pose))
            out[2].append(odom)
    else:
        raise AssertionError("the drive did not finish")
    return np.array(out[0]), np.array(out[1]), np.array(out[2])


def rmse(a, b):
    return float(np.sqrt(np.mean(np.sum((np.asarray(a)[:, :2] - np.asarray(b)[:, :2]) ** 2, axis=1))))


@pytest.fixture(scope="module")
def two_laps(tmp_path_factory):
    """Two laps round the block (~28 m) with the burger's odometry drifting 3x the default."""
    from turtlebot_recon.sim import load_world
    from turtlebot_recon.sim.simulator import SimSettings, Simulator
    world = load_world(loop_world(tmp_path_factory.mktemp("slam")))
    robot = load_robot("turtlebot3_burger")
    # wheel-only heading (a base without the TurtleBots' gyro fusion): the harder case
    sim = Simulator(world, robot, SimSettings(camera_rate_hz=0.0, odom_slip_std_sqrt_m=0.03, odom_heading="wheels",
                                              seed=4))
    slam = Slam(SlamSettings(), robot.wheel_separation_m)
    stamps, truth, odom = drive(sim, LOOP, laps=2, slam=slam)
    sim.close()
    return slam, stamps, truth, odom


def test_slam_beats_drifting_odometry_and_closes_the_loop(two_laps):
    slam, stamps, truth, odom = two_laps
    kf_t = np.array([k.stamp_s for k in slam.keyframes])
    idx = np.searchsorted(stamps, kf_t)
    ate_slam = rmse(slam.estimates, truth[idx])
    ate_odom = rmse(odom, truth)
    st = slam.stats()
    assert ate_odom > 0.15, ate_odom                      # the drift is real
    assert ate_slam < 0.05, (ate_slam, st)
    assert ate_odom / ate_slam > 5.0
    assert st["loop_accepted"] >= 1, st
    assert st["matched"] >= 0.9 * st["keyframes"] - 1
    # keyframes every 0.25 m or 15 degrees of odometry
    steps = [between(a.odom, b.odom) for a, b in zip(slam.keyframes, slam.keyframes[1:])]
    assert all(math.hypot(s[0], s[1]) >= 0.249 or abs(s[2]) >= 0.259 for s in steps)
    # map -> odom brings the last odometry pose onto the last estimate
    np.testing.assert_allclose(slam.pose(slam.keyframes[-1].odom), slam.estimates[-1], atol=1e-9)


def test_imu_fusion_improves_the_heading(tmp_path):
    from turtlebot_recon.sim import load_world
    from turtlebot_recon.sim.simulator import SimSettings, Simulator
    world = load_world(loop_world(tmp_path))
    robot = load_robot("turtlebot3_burger")
    errors = {}
    for use_imu in (False, True):
        sim = Simulator(world, robot, SimSettings(camera_rate_hz=0.0, odom_slip_std_sqrt_m=0.05, odom_heading="wheels",
                                                  seed=7))
        slam = Slam(SlamSettings(use_imu=use_imu, loop_every_keyframes=10 ** 6), robot.wheel_separation_m)
        slam.matcher.match = lambda *a, **k: None          # odometry (and gyro) alone
        stamps, truth, _ = drive(sim, LOOP[:2], laps=1, slam=slam)
        sim.close()
        idx = np.searchsorted(stamps, [k.stamp_s for k in slam.keyframes])
        errors[use_imu] = float(np.abs(wrap_angle(slam.estimates[:, 2] - truth[idx, 2])).max())
    assert slam.counts["imu_fused"] > 5
    assert errors[True] < 0.5 * errors[False], errors


def test_the_gyros_bias_is_estimated_in_the_graph(tmp_path):
    """A gyro with a bias of 2 mrad/s (40x the simulator's default, so that one lap of ~80 s
    shows it: 0.16 rad), odometry's heading from it as the TurtleBot3's firmware gives it, loop
    closures off (the front end alone, where the bias leaked into the heading). Each keyframe's
    matched turn differs from the gyro's by b dt + ~1.5 mrad: over 59 keyframes in 70 s the bias
    settles on it to ~2e-4 rad/s (1.5 mrad / sqrt(59)), and the heading keeps within a
    few mrad of the truth (4 mrad measured; 41 mrad with the bias left to each step's variance,
    as before the bias was in the graph). Without the yaw-rate factor no bias is estimated."""
    from turtlebot_recon.sim import load_world
    from turtlebot_recon.sim.simulator import SimSettings, Simulator
    world = load_world(loop_world(tmp_path))
    robot = load_robot("turtlebot3_burger")
    sim = Simulator(world, robot, SimSettings(camera_rate_hz=0.0, odom_slip_std_sqrt_m=0.01, gyro_bias_radps=0.002,
                                              seed=3))
    slam = Slam(SlamSettings(loop_every_keyframes=10 ** 6), robot.wheel_separation_m)
    stamps, truth, odom = drive(sim, LOOP, laps=1, slam=slam)
    sim.close()
    st = slam.stats()
    # a bias variable at the start and one gyro_bias_period_s (60 s) on, the steps between sharing it
    assert [k for k in range(len(slam.keyframes)) if slam.graph.has_bias(k)][0] == 0
    assert sum(slam.graph.has_bias(k) for k in range(len(slam.keyframes))) == 2
    assert abs(st["gyro_bias_radps"] - 0.002) < 4e-4, st          # 0.00198 measured
    assert st["gyro_bias_std_radps"] < 3e-4, st
    idx = np.searchsorted(stamps, [k.stamp_s for k in slam.keyframes])
    heading = np.abs(wrap_angle(slam.estimates[:, 2] - truth[idx, 2]))
    drift = np.abs(wrap_angle(np.asarray(odom)[:, 2] - truth[:, 2])).max()
    assert drift > 0.1, drift                                     # the bias is real in odometry's heading
    assert heading.max() < 0.01, (heading.max(), st)


def test_odometry_covariance_follows_the_wheel_model():
    s = SlamSettings(odom_floor_std_m=0.0, odom_floor_std_rad=0.0, odom_turn_std_m_per_rad=0.0)
    straight = odometry_covariance((1.0, 0.0, 0.0), 0.16, s)
    assert straight[0, 0] == pytest.approx(0.5 * 0.03 ** 2)           # (vl + vr) / 4
    assert straight[2, 2] == pytest.approx(2 * 0.03 ** 2 / 0.16 ** 2)  # (vl + vr) / B^2
    turn = odometry_covariance((0.0, 0.0, 1.0), 0.16, s)
    assert turn[0, 0] < straight[0, 0] and turn[2, 2] > 0
    assert np.all(np.linalg.eigvalsh(odometry_covariance((0.3, 0.02, 0.2), 0.287, SlamSettings())) > 0)
    # the scan's frame off the turning centre: a turn in place moves it by the lever's chord
    lever = odometry_covariance((0.0, 0.0, 1.0), 0.16, SlamSettings(odom_floor_std_m=0.0, odom_floor_std_rad=0.0))
    assert lever[1, 1] == pytest.approx(turn[1, 1] + 0.15 ** 2)


def test_bad_input_is_reported_not_fatal():
    slam = Slam(SlamSettings(), 0.16)
    pts = np.array([[1.0, y] for y in np.linspace(-1, 1, 50)] + [[x, 1.0] for x in np.linspace(0, 1, 30)])
    assert slam.add_scan(0.0, pts, (0.0, 0.0, 0.0))                   # the first keyframe
    assert not slam.add_scan(0.2, pts, (float("nan"), 0.0, 0.0))
    assert "not finite" in slam.take_events()[0]
    assert not slam.add_scan(0.4, np.zeros((0, 2)), (0.05, 0.0, 0.0))   # no points: skipped, counted
    assert not slam.add_scan(0.6, np.zeros((0, 2)), (0.3, 0.0, 0.0))    # far enough, still nothing seen
    assert slam.counts["scans_no_return"] == 2
    assert slam.add_scan(0.8, pts[:10], (0.35, 0.0, 0.0))               # too few points: odometry alone
    assert slam.counts["match_rejected"] == 1
    # a teleport of the odometry (a base restart resets it to zero somewhere else): the step
    # before it stands in for the step across it (0.05 m: no keyframe yet)
    assert not slam.add_scan(1.0, pts, (-7.0, 3.0, 1.0))
    assert slam.counts["odom_jumps"] == 1 and "jumped" in slam.take_events()[0]
    np.testing.assert_allclose(slam.pose((-7.0, 3.0, 1.0)), (0.4, 0.0, 0.0), atol=1e-9)
    assert np.isfinite(slam.estimates).all() and len(slam.estimates) == 2
    slam.reset("time jumped back to 0.00 s")
    assert not slam.keyframes and slam.graph is None and slam.counts["resets"] == 1
    assert slam.add_scan(0.0, pts, (0.0, 0.0, 0.0))


def test_a_gap_in_the_gyro_is_not_filled_by_the_next_sample():
    """The IMU stalls for 5 s while the robot turns 1.5 rad: the sample after the gap stands
    for its own period only, the step is not covered, and the heading comes from the wheels."""
    slam = Slam(SlamSettings(), 0.16)
    pts = np.array([[2.0, y] for y in np.linspace(-1, 1, 40)] + [[x, 1.5] for x in np.linspace(0, 2, 40)])
    for t in np.arange(0.0, 1.0, 0.02):
        slam.add_imu(t, 0.0)
    slam.add_scan(1.0, pts, (0.0, 0.0, 0.0))
    for t in np.arange(1.0, 2.01, 0.02):
        slam.add_imu(t, 0.0)
    slam.add_imu(7.0, 0.3)                                   # the first sample after the gap
    yaw, covered, samples = slam._integrate_gyro(1.0, 7.0)
    assert covered == pytest.approx(1.0 + 0.03, abs=1e-6) and yaw == pytest.approx(0.3 * 0.03, abs=1e-9)
    delta = np.array([0.0, 0.0, 1.5])
    cov, gyro = slam._odometry(7.0, delta)
    assert gyro is None                                      # no yaw-rate factor for the step
    step, _ = slam._predict(delta, cov, gyro)
    assert step[2] == pytest.approx(1.5)                     # wheel odometry's heading, not the gyro's 0


WALLS = np.array([[2.0, y] for y in np.linspace(-1, 1, 40)] + [[x, 1.5] for x in np.linspace(0, 2, 40)])


def test_tags_enter_the_graph_after_two_sightings_at_their_place():
    """A tag seen from near a keyframe (base frame, through the odometry since it) becomes a
    landmark only at its second sighting, where the two sightings put it."""
    slam = Slam(SlamSettings(), 0.16)
    slam.add_scan(0.0, WALLS, (0.0, 0.0, 0.0))
    slam.add_scan(0.2, WALLS - [0.3, 0.0], (0.3, 0.0, 0.0))          # a keyframe 0.3 m on
    assert slam.add_tag(0.2, "tag36h11:3", (1.5, 0.5), np.diag([1e-4, 1e-4]), (0.3, 0.0, 0.0)) is None
    assert "tag36h11:3" not in slam.graph.landmarks()                  # one sighting: buffered
    slam.add_scan(0.4, WALLS - [0.35, 0.0], (0.35, 0.0, 0.0))        # moved 5 cm: no keyframe
    assert slam.add_tag(0.4, "tag36h11:3", (1.45, 0.5), np.diag([1e-4, 1e-4]), (0.35, 0.0, 0.0)) is None
    slam.add_scan(0.6, WALLS - [0.6, 0.0], (0.6, 0.0, 0.0))          # the next keyframe updates
    xy = slam.graph.landmarks()["tag36h11:3"]
    np.testing.assert_allclose(xy, (1.8, 0.5), atol=0.02)             # 0.3 + 1.5, in the map
    # an absurd sighting is refused with a reason, the graph untouched
    assert "finite" in slam.add_tag(0.65, "tag36h11:3", (float("nan"), 0.5), np.eye(2), (0.6, 0.0, 0.0))
    assert "finite" in slam.add_tag(0.65, "tag36h11:3", (1.2, 0.5), np.eye(2), (0.6, float("nan"), 0.0))
    assert "inconsistent" in slam.add_tag(0.65, "tag36h11:3", (4.0, -3.0), np.diag([1e-4, 1e-4]), (0.6, 0.0, 0.0))
    assert "before the first keyframe" in slam.add_tag(-0.5, "tag36h11:3", (1.2, 0.5), np.eye(2), (0.6, 0.0, 0.0))
    np.testing.assert_allclose(slam.graph.landmarks()["tag36h11:3"], (1.8, 0.5), atol=0.02)
    assert slam.stats()["landmarks"] == 1 and slam.stats()["landmark_rejected"] == 1


def test_a_tag_is_placed_by_the_pose_at_its_images_stamp_not_the_newest_scans():
    """The robot turns in place at 1 rad/s; the image of a tag at (1.8, 0.5) is taken at 0.25 s
    and its detection comes in after the scans of 0.4 and 0.6 s (the detector's latency), the
    0.6 s one a keyframe. The newest scan's pose (yaw 0.4) would put the tag 0.35 rad round:
    0.55 m off at 1.57 m. Through the odometry at the image's stamp, from the keyframe nearest
    in time (0.2 s), it lands on the tag."""
    slam = Slam(SlamSettings(), 0.16)
    tag = (1.8, 0.5, 0.0)
    slam.add_scan(0.0, WALLS, (0.0, 0.0, 0.0))
    slam.add_scan(0.2, WALLS - [0.3, 0.0], (0.3, 0.0, 0.0))          # keyframe 1
    pose_at = {t: (0.3, 0.0, t - 0.2) for t in (0.25, 0.3, 0.4, 0.6)}  # turning in place
    for t in (0.4, 0.6):
        slam.add_scan(t, transform_points(between(pose_at[t], (0, 0, 0)), WALLS), pose_at[t])
    assert len(slam.keyframes) == 3                                    # 0.4 rad at 0.6 s: keyframe 2
    for t in (0.25, 0.3):                                              # late detections
        xy = between(pose_at[t], tag)[:2]
        assert slam.add_tag(t, "tag36h11:7", xy, np.diag([1e-4, 1e-4]), pose_at[t]) is None
    slam.graph.update()
    np.testing.assert_allclose(slam.graph.landmarks()["tag36h11:7"], tag[:2], atol=0.01)


def test_a_tags_step_from_the_last_keyframe_takes_the_gyros_heading():
    """Between the last keyframe and the image the wheels say the robot turned 0.06 rad; it did
    not (a slipping wheel), and the gyro says so. The sighting's step takes the gyro's heading
    (fused by inverse variance: the gyro's is ~2e-8 rad², the wheels' ~4e-4): the tag at
    1.5 m lands within 1 cm, where the wheels' heading would put it 9 cm off."""
    slam = Slam(SlamSettings(), 0.16)
    for t in np.arange(0.0, 0.61, 0.02):
        slam.add_imu(t, 0.0)
    slam.add_scan(0.0, WALLS, (0.0, 0.0, 0.0))
    slam.add_scan(0.2, WALLS - [0.3, 0.0], (0.3, 0.0, 0.0))          # keyframe 1
    tag = np.array([1.8, 0.5])
    for t in (0.3, 0.5):
        wheels = (0.3, 0.0, 0.06)                                      # the true base: (0.3, 0, 0)
        assert slam.add_tag(t, "tag36h11:9", tag - (0.3, 0.0), np.diag([1e-4, 1e-4]), wheels) is None
    slam.graph.update()
    np.testing.assert_allclose(slam.graph.landmarks()["tag36h11:9"], tag, atol=0.01)


def test_a_loop_closure_that_jumps_beyond_the_poses_uncertainty_is_refused(two_laps):
    """A maze repeats every metre: the loop window also holds the match one corridor over, which
    scores as well. The closure's correction must lie within the marginals of both poses (plus
    the match's covariance): 2 cm passes, 1 m (the next corridor) does not."""
    from types import SimpleNamespace
    slam = two_laps[0]
    key, j = len(slam.keyframes) - 1, 10
    here = slam.estimates[key]
    cov = np.diag([0.02, 0.02, 0.01]) ** 2
    near = SimpleNamespace(pose=np.array([here[0] + 0.02, here[1], here[2]]), covariance=cov)
    far = SimpleNamespace(pose=np.array([here[0] + 1.0, here[1], here[2]]), covariance=cov)
    assert slam._loop_consistent(j, key, near)
    assert not slam._loop_consistent(j, key, far)
    assert slam.stats()["loop_accepted"] >= 1          # the true closures of the two laps passed it


def test_the_gyros_scale_error_is_estimated_in_the_graph(two_laps):
    """The simulator's gyro over-reads every turn by its scale error (1.5 %, SimSettings'
    default); two laps round the block (4 pi of turning) pin the graph's scale variable down to
    a few tenths of a %."""
    from turtlebot_recon.sim.simulator import SimSettings
    slam = two_laps[0]
    truth = SimSettings().gyro_scale_error
    assert truth == 0.015
    st = slam.stats()
    assert abs(st["gyro_scale"] - truth) < 0.004, st
    assert st["gyro_scale_std"] < 0.004, st


def test_a_partition_seen_from_both_rooms_does_not_shrink_the_map(tmp_path):
    """Two rooms on either side of a partition one cell (5 cm) thick, a door at its east end;
    exact odometry. The robot drives along the partition in the south room, through the door
    and back west along it in the north room: for a few keyframes the submap holds both faces.
    A line fitted across both pulled every north-room scan 2.5 cm south, towards where the
    robot had come from (a maze's or a house's map shrank by 0.5-1 % so); with the keyframes'
    viewpoints each scan pairs with the face it sees, and SLAM keeps exact odometry's track."""
    from turtlebot_recon.sim import load_world
    from turtlebot_recon.sim.simulator import SimSettings, Simulator
    res = 0.05
    free = room(6.0, 4.0)
    row = int(round(2.0 / res)) + 2                       # the partition at y = 2.0 .. 2.05 m
    free[row, :int(round(5.0 / res)) + 2] = False         # the door: x 5.0 .. 6.0 m
    world = load_world(write_world(tmp_path, "partition", free, start=[0.8, 1.2, 0.0]))
    robot = load_robot("turtlebot3_burger")
    sim = Simulator(world, robot, SimSettings(camera_rate_hz=0.0, odom_slip_std_sqrt_m=0.0, seed=2))
    slam = Slam(SlamSettings(), robot.wheel_separation_m)
    stamps, truth, _ = drive(sim, [(5.5, 1.2), (5.5, 2.9), (0.8, 2.9), (5.5, 2.9)], laps=1, slam=slam)
    sim.close()
    at_keyframes = truth[np.searchsorted(stamps, [k.stamp_s for k in slam.keyframes])]
    north = at_keyframes[:, 1] > 1.0             # keyframes in the north room (start frame)
    errors = slam.estimates - at_keyframes
    assert north.sum() >= 10
    assert abs(np.mean(errors[north, 1])) < 0.008, errors[north, 1]    # without viewpoints: -0.015
    assert rmse(slam.estimates, at_keyframes) < 0.015                   # without: 0.019
