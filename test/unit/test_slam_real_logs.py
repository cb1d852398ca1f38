"""What real laser logs did to the SLAM core (issue 31), each on a few synthetic keyframes: stale
odometry catching up, a jump of the odometry, a turn in place seen by a laser off the turning
centre, stamps out of order, a scan with no return, a step iSAM2 refuses; and ``make slam-log``
on a cut or failing log."""
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from turtlebot_recon.geometry import compose, transform_points, wrap_angle
from turtlebot_recon.slam.logs import LaserRecord, flaser_geometry, write_carmen
from turtlebot_recon.slam.slam import Slam, SlamSettings, odometry_covariance

# A 10 x 6 m room with a 1 x 1 m pillar, a 2 m wall stub (every scan sees corners) and a 2 m
# door, through which beams see nothing.
SEGMENTS = [((0, 0), (10, 0)), ((10, 0), (10, 6)), ((10, 6), (6, 6)), ((4, 6), (0, 6)), ((0, 6), (0, 0)),
            ((4, 2), (5, 2)), ((5, 2), (5, 3)), ((5, 3), (4, 3)), ((4, 3), (4, 2)), ((7, 6), (7, 4))]
ANGLE_MIN, INC = flaser_geometry(180)
BEAMS = 180


def ranges_from(sensor) -> np.ndarray:
    """The 180-beam FLASER ranges (m) of a laser at ``sensor`` (x, y, yaw) in the room."""
    x, y, yaw = sensor
    out = np.full(BEAMS, np.inf)
    for i in range(BEAMS):
        a = yaw + ANGLE_MIN + i * INC
        d = np.array([math.cos(a), math.sin(a)])
        for (ax, ay), (bx, by) in SEGMENTS:
            e = np.array([bx - ax, by - ay])
            den = d[0] * -e[1] + d[1] * e[0]
            if abs(den) < 1e-12:
                continue
            w = np.array([ax - x, ay - y])
            t = (w[0] * -e[1] + w[1] * e[0]) / den          # along the beam
            u = (d[0] * w[1] - d[1] * w[0]) / den           # along the segment
            if t > 0 and 0 <= u <= 1:
                out[i] = min(out[i], t)
    return out


def scan_points_from(sensor) -> np.ndarray:
    r = ranges_from(sensor)
    a = ANGLE_MIN + INC * np.arange(BEAMS)
    keep = np.isfinite(r)
    return np.stack([r[keep] * np.cos(a[keep]), r[keep] * np.sin(a[keep])], axis=1)


def test_stale_odometry_catching_up_is_not_a_jump():
    """The MIT CSAIL log: odometry repeats one pose for 4 scans (0.8 s) while the robot drives on
    at 1 m/s, then catches up 0.8 m in one scan interval (0.2 s): 4 m/s over the interval, but
    1 m/s over the time since it last changed. Judged per scan interval it was a jump."""
    slam = Slam(SlamSettings(), 0.4)
    odom = np.array([1.0, 1.5, 0.0])
    for k in range(20):
        t = 0.2 * k
        if k % 5 == 0:
            odom = np.array([1.0 + 0.2 * k, 1.5, 0.0])   # the odometry updates every fifth scan
        slam.add_scan(t, scan_points_from((1.0 + 0.2 * k, 1.5, 0.0)), odom)
    assert slam.counts["odom_jumps"] == 0, slam.take_events()
    assert slam.counts["matched"] == slam.counts["keyframes"] - 1


def test_an_odometry_jump_is_bridged_by_the_step_before_it():
    """The odometry teleports 5 m while the robot drives on at 0.4 m per scan: the step before
    it stands in for the step across it, so the next keyframe lies one step ahead (and the scan
    match confirms it), not back at the last keyframe behind a loose (1 m, pi) tie."""
    slam = Slam(SlamSettings(), 0.4)
    for k in range(8):
        truth = (1.0 + 0.4 * k, 1.5, 0.0)
        odom = truth if k < 6 else (truth[0] + 5.0, truth[1] - 3.0, truth[2])
        slam.add_scan(0.25 * k, scan_points_from(truth), odom)
    assert slam.counts["odom_jumps"] == 1
    np.testing.assert_allclose(slam.estimates[-1][:2], (1.0 + 0.4 * 7, 1.5), atol=0.03)
    assert slam.counts["matched"] == slam.counts["keyframes"] - 1


def test_a_turn_in_place_seen_from_off_the_turning_centre_is_matched():
    """The Intel Lab log: the laser pose is the odometry's, but the laser sits 0.15 m ahead of
    the turning centre, so a turn in place moves the scan's frame 4 cm (a chord). Odometry that
    claims 5 mm of translation gated every such match out (276 of 981 on that log)."""
    slam = Slam(SlamSettings(), 0.4)
    lever = (0.15, 0.0, 0.0)
    for k in range(12):
        base = (3.0, 3.5, 0.1 * k)
        slam.add_scan(0.2 * k, scan_points_from(compose(base, lever)), base, mount_known=False)  # odometry: the base
    assert slam.counts["keyframes"] >= 4
    assert slam.counts["match_inconsistent"] == 0 and slam.counts["matched"] == slam.counts["keyframes"] - 1


def test_the_lever_term_enters_only_where_the_laser_mounting_is_unknown():
    """A live robot's scans come in the base frame through TF (a bag's through the robot's
    YAML): a turn in place does not move them, and the lever term would only widen the gate
    for a wrong match (the house drive, 2026-12-07: a match 8.8 cm off odometry along a
    corridor passed, and the trajectory kept 6 cm of error to the end). A log whose laser pose
    is its odometry's gets it."""
    turn = np.array([0.0, 0.0, 0.8])
    chord = (SlamSettings().odom_turn_std_m_per_rad * 0.8) ** 2
    covs = {}
    for known in (True, False):
        slam = Slam(SlamSettings(odom_timing_std_s=0.0), 0.4)
        assert slam.add_scan(0.0, scan_points_from((1.0, 1.5, 0.0)), (1.0, 1.5, 0.0), mount_known=known)
        covs[known], _ = slam._odometry(0.2, turn)
    assert covs[False][0, 0] - covs[True][0, 0] == pytest.approx(chord)
    assert covs[False][1, 1] - covs[True][1, 1] == pytest.approx(chord)
    assert covs[True][0, 0] < 1e-4                      # the floor and the slip only: (1 cm)^2


def test_odometry_covariance_is_positive_definite_when_turning_while_travelling():
    """A step that turns far more than it travels: without the x-y term of the heading error the
    covariance had a negative eigenvalue (iSAM2's input check refused it on the MIT log)."""
    s = SlamSettings(odom_floor_std_m=0.0, odom_floor_std_rad=0.0, odom_turn_std_m_per_rad=0.0)
    for step in ((0.1, 0.0, 1.0), (0.05, 0.01, -0.5), (0.2, 0.01, 1.5), (0.945, 0.0, 0.132)):
        cov = odometry_covariance(step, 0.16, s)
        assert np.linalg.eigvalsh(cov).min() >= -1e-12 * np.abs(cov).max(), (step, np.linalg.eigvalsh(cov))


def test_a_step_of_no_duration_keeps_the_wheels_heading_variance():
    """The Intel Lab's stamps go back up to 0.9 s: a step of zero or negative duration had no gyro
    sample, yet counted as covered by the gyro, whose variance (proportional to the duration)
    was then ~0: a heading std of 3e-5 rad, and iSAM2 met an indeterminate system."""
    slam = Slam(SlamSettings(), 0.4)          # use_imu on, no IMU sample ever
    pts = scan_points_from((1.0, 1.5, 0.0))
    assert slam.add_scan(10.0, pts, (1.0, 1.5, 0.0))
    for stamp in (10.0, 9.5):                 # the same stamp, then one 0.5 s earlier
        delta = np.array([0.3, 0.0, 0.1])
        cov, gyro = slam._odometry(stamp, delta)
        _, predicted = slam._predict(delta, cov, gyro)
        assert gyro is None and predicted[2, 2] >= SlamSettings().odom_floor_std_rad ** 2


def test_a_scan_with_no_return_is_skipped_with_a_count():
    slam = Slam(SlamSettings(), 0.4)
    assert not slam.add_scan(0.0, np.zeros((0, 2)), (1.0, 1.5, 0.0))     # none before the first either
    assert slam.add_scan(0.2, scan_points_from((1.0, 1.5, 0.0)), (1.0, 1.5, 0.0))
    assert not slam.add_scan(0.4, np.zeros((0, 2)), (1.5, 1.5, 0.0))     # far enough, but nothing seen
    assert slam.counts["scans_no_return"] == 2 and len(slam.keyframes) == 1
    assert slam.add_scan(0.6, scan_points_from((1.6, 1.5, 0.0)), (1.6, 1.5, 0.0))


def test_a_step_isam2_refuses_leaves_the_keyframe_on_odometry_and_the_run_going():
    slam = Slam(SlamSettings(), 0.4)
    for k in range(3):
        slam.add_scan(0.2 * k, scan_points_from((1.0 + 0.3 * k, 1.5, 0.0)), (1.0 + 0.3 * k, 1.5, 0.0))
    real_update, calls = slam.graph.update, []

    def refuse_once():
        calls.append(1)
        if len(calls) == 1:
            slam.graph._new_factors.resize(0)      # as PoseGraph does: the step's factors dropped ...
            slam.graph._new_values.clear()
            slam.graph._n = slam.graph._n_done     # ... and the graph back as it was
            raise ValueError("iSAM2 refused the update (Indeterminate linear system ...)")
        return real_update()
    slam.graph.update = refuse_once
    assert slam.add_scan(0.6, scan_points_from((1.9, 1.5, 0.0)), (1.9, 1.5, 0.0))
    events = slam.take_events()
    assert slam.counts["refused"] == 1 and len(events) == 1 and "kept on its odometry alone" in events[0]
    assert len(slam.keyframes) == len(slam.estimates) == len(slam.graph) == 4
    assert slam.add_scan(0.8, scan_points_from((2.2, 1.5, 0.0)), (2.2, 1.5, 0.0))   # the run goes on
    np.testing.assert_allclose(slam.estimates[-1][:2], (2.2, 1.5), atol=0.03)


# ------------------------------------------------------------------------------------ make slam-log
def slam_log_main():
    path = Path(__file__).resolve().parents[2] / "tools" / "slam_log.py"
    spec = importlib.util.spec_from_file_location("slam_log", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.main


def drive_log(path, n=40):
    """A FLASER log of a drive along the room at 0.1 m per scan, 81.83 m for no return."""
    records = []
    for k in range(n):
        pose = (1.0 + 0.1 * k, 1.5 + 0.02 * k, 0.05)
        r = ranges_from(pose)
        records.append(LaserRecord(100.0 + 0.2 * k, np.where(np.isfinite(r), r, 81.83).astype(np.float32),
                                   ANGLE_MIN, INC, 0.0, 81.9, odom_pose=pose, laser_pose=pose))
    write_carmen(path, records, flaser=True)


def test_slam_log_writes_a_pose_for_every_scan(tmp_path):
    """The relations metric compares poses at scan stamps: with the keyframes alone (every
    0.25 m) interpolated linearly in time, a robot that stands between two keyframes is put
    part-way along the step (the Intel Lab log: 4.2 cm mean, 10.6 cm p90 off). trajectory.tum
    holds every scan's pose: the keyframe's where there is one, the odometry carried from the
    keyframes around it elsewhere."""
    from turtlebot_recon.evaluation.trajectory_metrics import read_tum
    records, truth = [], []
    x = 1.0
    for k in range(45):
        x += 0.0 if 10 <= k < 25 else 0.1            # drives, stands for 3 s, drives on
        pose = (x, 1.5, 0.05)
        r = ranges_from(pose)
        records.append(LaserRecord(100.0 + 0.2 * k, np.where(np.isfinite(r), r, 81.83).astype(np.float32),
                                   ANGLE_MIN, INC, 0.0, 81.9, odom_pose=pose, laser_pose=pose))
        truth.append(pose)
    write_carmen(tmp_path / "stop.clf", records, flaser=True)
    assert slam_log_main()(["--log", str(tmp_path / "stop.clf"), "--output", str(tmp_path / "out")]) == 0
    traj = read_tum(tmp_path / "out" / "trajectory.tum")
    keyframes = read_tum(tmp_path / "out" / "keyframes.tum")
    assert len(traj) == 45 and len(keyframes) < 20
    assert np.abs(traj[:, 1:3] - np.array(truth)[:, :2]).max() < 0.02
    # the keyframes' own poses are in it unchanged
    idx = np.searchsorted(traj[:, 0], keyframes[:, 0])
    np.testing.assert_allclose(traj[idx, 1:4], keyframes[:, 1:4], atol=1e-6)


def test_scan_trajectory_spreads_the_odometry_drift_and_survives_a_jump():
    from turtlebot_recon.slam.offline import scan_trajectory
    odo = np.array([[0.1 * i, 0.1 * i, 0.0, 0.0] for i in range(11)])
    odo[6:, 1] += 5.0                                 # the odometry jumps 5 m between scans 5 and 6
    est = np.array([[0.0, 0.0, 0.0], [1.02, 0.0, 0.0]])   # keyframes at scans 0 and 10; 2 cm of drift
    out = scan_trajectory([0, 10], est, odo)
    assert np.allclose(out[[0, 10], 1:4], est)
    assert np.allclose(out[1:6, 1], 0.1 * np.arange(1, 6))          # before the jump: from keyframe 0
    assert np.allclose(out[6:10, 1], 1.02 - 0.1 * np.arange(4, 0, -1))   # after it: from keyframe 10
    odo[6:, 1] -= 5.0
    out = scan_trajectory([0, 10], est, odo)
    assert np.isclose(out[5, 1], 0.51)                # the 2 cm spread along the step


def test_slam_log_on_a_cut_log_writes_its_results(tmp_path, capsys):
    log = tmp_path / "cut.clf"
    drive_log(log)
    text = log.read_text()
    log.write_text(text[:len(text) - 700] + "\nGARBAGE line\n")           # cut inside the last line
    assert slam_log_main()(["--log", str(log), "--output", str(tmp_path / "out")]) == 0
    out = capsys.readouterr()
    for name in ("trajectory.tum", "odometry.tum", "map.pgm", "map.yaml", "graph.g2o"):
        assert (tmp_path / "out" / name).stat().st_size > 0
    line = out.out.strip().splitlines()
    assert len(line) == 1 and "1 truncated" in line[0] and "no return at 81.83 m" in line[0], line


def test_slam_log_stopped_by_an_error_writes_what_it_has(tmp_path, capsys, monkeypatch):
    from turtlebot_recon.slam import slam as slam_module
    log = tmp_path / "drive.clf"
    drive_log(log)
    real = slam_module.Slam._keyframe
    def failing(self, *a):
        if len(self.keyframes) == 5:
            raise RuntimeError("corrupted")
        return real(self, *a)
    monkeypatch.setattr(slam_module.Slam, "_keyframe", failing)
    assert slam_log_main()(["--log", str(log), "--output", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "stopped at scan" in err[0] and "keyframe 5" in err[0] and "corrupted" in err[0], err
    assert len(np.loadtxt(tmp_path / "out" / "keyframes.tum", ndmin=2)) == 5
    assert len(np.loadtxt(tmp_path / "out" / "trajectory.tum", ndmin=2)) == \
        len(np.loadtxt(tmp_path / "out" / "odometry.tum", ndmin=2))
    for name in ("odometry.tum", "map.pgm", "graph.g2o"):
        assert (tmp_path / "out" / name).stat().st_size > 0


def drive_with_late_odometry(settings, lag_std_s=0.06, seed=3):
    """A robot driving 0.9 m/s along the room while turning 0.8 rad/s one way and back (the MIT
    CSAIL log's pace), scans at 5 Hz, each given the odometry pose of an instant off by
    N(0, lag_std_s) from the scan's own (exact odometry otherwise)."""
    rng = np.random.default_rng(seed)

    def pose(t):
        return np.array([1.5 + 0.9 * t * math.cos(0.3), 1.0 + 0.9 * t * math.sin(0.3) * 0.5, 0.3 + 0.5 * math.sin(1.6 * t)])

    slam = Slam(settings, 0.4)
    for k in range(30):
        t = 0.2 * k
        slam.add_scan(t, scan_points_from(pose(t)), pose(t + rng.normal(0.0, lag_std_s)), mount_known=False)
    return slam


def test_odometry_late_against_the_scan_is_not_trusted_over_the_match():
    """The MIT CSAIL log: the odometry pose given with a scan is off in time (per 0.21 s, its
    turn errs by 1 deg standing, 4-6 deg above 30 deg/s, its travel by 5 cm at 1 m/s). Without
    the timing term of the odometry noise (odom_timing_std_s 0) the gate refused the right
    matches (108 of 1,149 on that log) and the keyframes stayed on the late odometry."""
    with_term = drive_with_late_odometry(SlamSettings())
    without = drive_with_late_odometry(SlamSettings(odom_timing_std_s=0.0))
    assert without.counts["match_inconsistent"] >= 3, without.counts
    assert with_term.counts["match_inconsistent"] == 0, with_term.counts
    assert with_term.counts["matched"] == with_term.counts["keyframes"] - 1


def test_timing_covariance_follows_the_velocity_at_both_ends():
    from turtlebot_recon.slam.slam import timing_covariance
    cov = timing_covariance((0.3, 0.0, math.pi / 2), (1.0, 0.0, 0.0), (1.0, 0.0, 2.0), 0.1)
    # the start moves along x, the end (turned 90 deg) along y of the step's frame, and turns
    assert np.allclose(np.diag(cov), [0.01, 0.01, 0.04])
    assert np.isclose(cov[1, 2], 0.02) and np.isclose(cov[0, 2], 0.0)
    assert np.allclose(timing_covariance((0.3, 0.0, 0.0), (1.0, 0.0, 0.5), (1.0, 0.0, 0.5), 0.0), 0.0)


def corridor_points(sensor, half_width=1.0, x_min=-30.0, x_max=60.0):
    """The 180-beam FLASER points (sensor frame) of a laser at ``sensor`` in a featureless
    corridor along x, its ends beyond the matcher's max_range_m: every match in it is
    degenerate along the corridor."""
    x, y, yaw = sensor
    a = yaw + ANGLE_MIN + INC * np.arange(BEAMS)
    s = np.sin(a)
    with np.errstate(divide="ignore"):
        t = np.where(s > 1e-9, (half_width - y) / s, np.where(s < -1e-9, (-half_width - y) / s, np.inf))
    hx = x + t * np.cos(a)
    keep = np.isfinite(t) & (hx > x_min) & (hx < x_max)
    rel = a[keep] - yaw
    return np.stack([t[keep] * np.cos(rel), t[keep] * np.sin(rel)], axis=1)


def test_a_corridor_revisited_closes_the_loop_across_it():
    """The MIT CSAIL log's long corridors: 169 of 505 loop-closure matches were degenerate and
    all refused, so a corridor driven twice kept both passes apart (doubled walls). A
    degenerate closure still fixes the heading and the position across the corridor; its
    covariance leaves the position along it to the rest of the graph."""
    slam = Slam(SlamSettings(), 0.4)
    truth, odom = [], np.array([0.0, 0.0, 0.0])
    poses = [(0.1 * k, 0.0, 0.0) for k in range(100)]                               # 10 m out
    poses += [(9.9, 0.0, 0.1 * k) for k in range(1, 32)]                            # turn round
    poses += [(9.9 - 0.1 * k, 0.0, 3.1) for k in range(1, 100)]                     # and back
    previous = np.array(poses[0], float)
    for k, p in enumerate(poses):
        p = np.array(p, float)
        step = np.array([*(np.array([[math.cos(previous[2]), math.sin(previous[2])],
                                     [-math.sin(previous[2]), math.cos(previous[2])]]) @ (p[:2] - previous[:2])),
                         wrap_angle(p[2] - previous[2])])
        odom = compose(odom, step + np.array([0.0, 0.0, 0.004 * math.hypot(step[0], step[1]) / 0.1]))  # heading drift
        previous = p
        slam.add_scan(0.2 * k, corridor_points(p), odom)
        truth.append(p)
    assert slam.counts["loop_accepted"] >= 3, slam.stats()
    # the return pass lies on the outbound one across the corridor (odometry ends 3.6 m off)
    assert abs(slam.estimates[-1][1] - truth[-1][1]) < 0.1, slam.estimates[-1]
